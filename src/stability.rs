//! The stability survey: every named node of a graph evaluated at huge and negative coordinates,
//! on lattice points and cell boundaries, in f32 and f64; the f32 error and continuity (seams)
//! at each magnitude.

use crate::compile::{compile, CompileOptions};
use crate::diagnostic::Diagnostics;
use crate::eval::Workspace;
use crate::graph::CheckedGraph;

/// Coordinate magnitudes probed, each with both signs along each axis.
pub const MAGNITUDES: [f64; 6] = [1.0, 1e3, 1e4, 1e6, 1e8, 2147483648.0];

/// The step between neighbouring samples of the continuity check.
pub const STEP: f64 = 1e-4;

/// One node at one magnitude (both signs, all axes, every point kind pooled).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StabilityRow {
    pub node: String,
    pub magnitude: f64,
    /// Largest |f32 − f64| where both are finite.
    pub max_f32_error: f64,
    /// Largest |value| seen (f64): f32 resolves a value v to about |v|·6e-8.
    pub max_abs_value: f64,
    /// max |f(p + δ) − f(p)| / (L·δ) over neighbouring pairs, f32 and f64 paths: at most 1
    /// means no seam. `None` where the node has no known Lipschitz bound L.
    pub continuity: Option<f64>,
    pub non_finite_f64: u64,
    pub non_finite_f32: u64,
    /// Whether the node is one of the graph's outputs (the others are named intermediate nodes,
    /// probed as if they were outputs).
    pub output: bool,
    /// Largest |f32 − f64| of the tape compiled for this magnitude's extent (precision chosen
    /// per instruction, `precision.rs`).
    pub max_promoted_error: f64,
    /// The compiler's bound on that error, and why it may exceed the target where it does.
    pub promoted_bound: f64,
    pub shortfall: Option<String>,
    /// Largest |GPU − f64| of that same tape on the GPU (`gpu::GpuEvaluator`, where one is
    /// usable), measured as the promoted error is.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_gpu_error: Option<f64>,
}

/// Half the side of the box every probe point at magnitude `m` lies in.
fn extent_at(magnitude: f64) -> crate::precision::Extent {
    let h = magnitude + 16.0;
    crate::precision::Extent::new([-h; 3], [h; 3])
}

/// The probe points at one magnitude: along each axis and sign, a scatter, lattice points and
/// both sides of cell boundaries, each with its neighbour `STEP` further along the axis.
fn probe_pairs(magnitude: f64) -> Vec<([f64; 3], [f64; 3])> {
    let mut pairs = Vec::new();
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let base = sign * magnitude;
            let mut at = |offset: f64, others: [f64; 2]| {
                let mut p = [0.0; 3];
                p[axis] = base + offset;
                p[(axis + 1) % 3] = others[0];
                p[(axis + 2) % 3] = others[1];
                let mut q = p;
                q[axis] += STEP;
                pairs.push((p, q));
            };
            for k in 0..24 {
                at(k as f64 * 0.0371, [0.31, 0.77]);
            }
            for k in 0..4 {
                at(k as f64, [2.0, 5.0]);
            }
            for k in 0..4 {
                let c = base.round() + k as f64;
                let below = c.next_down();
                at(below - base, [0.5, 0.25]);
                at(c - base, [0.5, 0.25]);
            }
        }
    }
    pairs
}

/// Surveys every output and named node of `graph`: the plain f32 tape, and the tape compiled
/// for each magnitude's extent with precision chosen for `max_error`.
pub fn stability_report(
    graph: &CheckedGraph,
    max_error: f64,
) -> Result<Vec<StabilityRow>, Diagnostics> {
    survey(graph, max_error, false)
}

/// [`stability_report`] with the GPU as well: each magnitude's tape also on the GPU
/// (`max_gpu_error`), where one is usable (`texgraph report --stability`).
pub fn stability_report_with_gpu(
    graph: &CheckedGraph,
    max_error: f64,
) -> Result<Vec<StabilityRow>, Diagnostics> {
    survey(graph, max_error, true)
}

fn survey(
    graph: &CheckedGraph,
    max_error: f64,
    gpu: bool,
) -> Result<Vec<StabilityRow>, Diagnostics> {
    let probe = graph.with_node_probes();
    let tape = compile(&probe, &CompileOptions::default())?;
    let stretches = crate::lod::stretches(&probe);
    let mut rows = Vec::new();
    for &magnitude in &MAGNITUDES {
        let promoted = compile(
            &probe,
            &CompileOptions {
                extent: Some(extent_at(magnitude)),
                max_error: Some(max_error),
                ..Default::default()
            },
        )?;
        let pairs = probe_pairs(magnitude);
        let points: Vec<[f64; 3]> = pairs.iter().flat_map(|(p, q)| [*p, *q]).collect();
        let [x, y, z] = [0, 1, 2].map(|c| points.iter().map(|p| p[c]).collect::<Vec<f64>>());
        let n = points.len();
        let mut v64 = vec![0f64; tape.channels() * n];
        let mut v32 = vec![0f32; tape.channels() * n];
        let mut p32 = vec![0f32; tape.channels() * n];
        tape.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut v64);
        tape.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut v32);
        promoted.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut p32);
        let on_gpu = gpu.then(|| gpu_values(&promoted, [&x, &y, &z])).flatten();
        let nearby = nearby_references(&tape, [&x, &y, &z]);
        let plan = promoted.precision();
        for (i, (output, graph_output)) in tape.outputs.iter().zip(&probe.outputs).enumerate() {
            let lipschitz = stretches[graph_output.node as usize];
            let bound = plan.and_then(|p| p.outputs.get(i));
            let mut row = StabilityRow {
                node: output.name.clone(),
                magnitude,
                max_f32_error: 0.0,
                max_abs_value: 0.0,
                continuity: lipschitz.map(|_| 0.0),
                non_finite_f64: 0,
                non_finite_f32: 0,
                output: i < graph.outputs.len(),
                max_promoted_error: 0.0,
                promoted_bound: bound.map_or(f64::INFINITY, |b| b.promoted),
                shortfall: bound.and_then(|b| b.shortfall.clone()),
                max_gpu_error: on_gpu.as_ref().map(|_| 0.0),
            };
            for c in output.first_channel..output.first_channel + output.ty.channels() {
                let channel = |v: &[f32]| v[c * n..(c + 1) * n].to_vec();
                let a = &v64[c * n..(c + 1) * n];
                let (b, promoted) = (channel(&v32), channel(&p32));
                let near: Vec<&[f64]> = nearby.iter().map(|v| &v[c * n..(c + 1) * n]).collect();
                survey_channel(&mut row, a, &b, &promoted, &near);
                if let (Some(values), Some(worst)) = (&on_gpu, row.max_gpu_error.as_mut()) {
                    *worst = worst.max(nearest_error(a, &values[c * n..(c + 1) * n], &near));
                }
                if let (Some(l), Some(ratio)) = (lipschitz, row.continuity.as_mut()) {
                    *ratio = ratio.max(continuity(l, pairs.len(), a, &b));
                }
            }
            rows.push(row);
        }
    }
    Ok(rows)
}

/// How far from a probe point the f64 reference is also consulted for the promoted error:
/// the edge rule (docs/accuracy.md) lets a discontinuity move by rounding-sized amounts.
pub const EDGE_TOLERANCE: f64 = 1e-6;

/// The f64 reference at every probe point moved by ±[`EDGE_TOLERANCE`] along each axis.
fn nearby_references(tape: &crate::tape::Tape, points: [&[f64]; 3]) -> Vec<Vec<f64>> {
    let n = points[0].len();
    let mut out = Vec::with_capacity(6);
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let moved: Vec<Vec<f64>> = (0..3)
                .map(|c| {
                    let shift = if c == axis {
                        sign * EDGE_TOLERANCE
                    } else {
                        0.0
                    };
                    points[c].iter().map(|v| v + shift).collect()
                })
                .collect();
            let mut v = vec![0f64; tape.channels() * n];
            tape.eval_batch(
                &mut Workspace::new(),
                &moved[0],
                &moved[1],
                &moved[2],
                &mut v,
            );
            out.push(v);
        }
    }
    out
}

/// `tape` on the GPU at the points, where a GPU is usable (else `None`: no GPU column).
fn gpu_values(tape: &crate::tape::Tape, [x, y, z]: [&[f64]; 3]) -> Option<Vec<f32>> {
    let gpu = crate::gpu::evaluator_for(tape).ok()?;
    let mut out = vec![0f32; tape.channels() * x.len()];
    gpu.eval_batch(x, y, z, &mut out).ok()?;
    Some(out)
}

/// The largest difference of `values` from the reference `a` where both are finite, each
/// against the nearest of the reference at the point and at the `near`by points.
fn nearest_error(a: &[f64], values: &[f32], near: &[&[f64]]) -> f64 {
    let mut worst = 0f64;
    for (i, (r, v)) in a.iter().zip(values).enumerate() {
        let v = f64::from(*v);
        if r.is_finite() && v.is_finite() {
            let nearest = near
                .iter()
                .map(|n| (n[i] - v).abs())
                .fold((r - v).abs(), f64::min);
            worst = worst.max(nearest);
        }
    }
    worst
}

/// Folds one channel's reference (`a`), plain f32 (`b`) and promoted f32 values into a row;
/// the promoted error takes the nearest of the reference at the point and at `near`by points.
fn survey_channel(row: &mut StabilityRow, a: &[f64], b: &[f32], promoted: &[f32], near: &[&[f64]]) {
    for (i, ((r, s), p)) in a.iter().zip(b).zip(promoted).enumerate() {
        let (s, p) = (*s as f64, *p as f64);
        row.non_finite_f64 += u64::from(!r.is_finite());
        row.non_finite_f32 += u64::from(!s.is_finite());
        if r.is_finite() {
            row.max_abs_value = row.max_abs_value.max(r.abs());
        }
        if r.is_finite() && s.is_finite() {
            row.max_f32_error = row.max_f32_error.max((r - s).abs());
        }
        if r.is_finite() && p.is_finite() {
            let nearest = near
                .iter()
                .map(|v| (v[i] - p).abs())
                .fold((r - p).abs(), f64::min);
            row.max_promoted_error = row.max_promoted_error.max(nearest);
        }
    }
}

/// The continuity ratio of one channel over its neighbouring pairs (f64 and f32 paths).
fn continuity(lipschitz: f64, pairs: usize, a: &[f64], b: &[f32]) -> f64 {
    let allowed = (lipschitz * STEP).max(f64::MIN_POSITIVE);
    let mut ratio = 0.0f64;
    for pair in 0..pairs {
        let (i, j) = (2 * pair, 2 * pair + 1);
        for d in [(a[i] - a[j]).abs(), (b[i] as f64 - b[j] as f64).abs()] {
            if d.is_finite() {
                // f32 values carry rounding of their own size: allow it.
                let slack = 2.0 * f32::EPSILON as f64 * b[i].abs().max(b[j].abs()) as f64;
                ratio = ratio.max((d - slack).max(0.0) / allowed);
            }
        }
    }
    ratio
}

fn magnitude_label(m: f64) -> String {
    if m == 2147483648.0 {
        "2^31".into()
    } else if m == 1.0 {
        "1".into()
    } else {
        format!("{m:e}")
    }
}

/// The survey as text: f32 error by node and magnitude, then continuity, then where the error
/// starts to grow and why.
pub fn stability_text(rows: &[StabilityRow]) -> String {
    let mut nodes: Vec<&str> = Vec::new();
    for row in rows {
        if !nodes.contains(&row.node.as_str()) {
            nodes.push(&row.node);
        }
    }
    let find = |node: &str, m: f64| rows.iter().find(|r| r.node == node && r.magnitude == m);
    let width = nodes.iter().map(|n| n.len()).max().unwrap_or(4).max(4);
    let mut out = String::new();
    let header: String = MAGNITUDES
        .iter()
        .map(|m| format!(" {:>10}", magnitude_label(*m)))
        .collect();
    out.push_str(&format!("max |f32 - f64| at |p| = (both signs, each axis; scattered, lattice and cell-boundary points)\n  {:<width$}{header}\n", "node"));
    for node in &nodes {
        let cells: String = MAGNITUDES
            .iter()
            .map(|m| match find(node, *m) {
                Some(r) if r.non_finite_f64 > 0 || r.non_finite_f32 > 0 => {
                    format!(" {:>10}", format!("{:.1e}*", r.max_f32_error))
                }
                Some(r) => format!(" {:>10.1e}", r.max_f32_error),
                None => format!(" {:>10}", "-"),
            })
            .collect();
        out.push_str(&format!("  {node:<width$}{cells}\n"));
    }
    out.push_str("the same, compiled for each magnitude's extent (precision chosen per instruction; * marks the graph's outputs)\n");
    for node in &nodes {
        let is_output = rows.iter().any(|r| r.node == *node && r.output);
        let cells: String = MAGNITUDES
            .iter()
            .map(|m| match find(node, *m) {
                Some(r) => format!(" {:>10.1e}", r.max_promoted_error),
                None => format!(" {:>10}", "-"),
            })
            .collect();
        let mark = if is_output { "*" } else { " " };
        out.push_str(&format!("{mark} {node:<width$}{cells}\n"));
    }
    if rows.iter().any(|r| r.max_gpu_error.is_some()) {
        out.push_str("the same tapes on the GPU (max |GPU - f64|)\n");
        for node in &nodes {
            let is_output = rows.iter().any(|r| r.node == *node && r.output);
            let cells: String = MAGNITUDES
                .iter()
                .map(|m| match find(node, *m).and_then(|r| r.max_gpu_error) {
                    Some(e) => format!(" {e:>10.1e}"),
                    None => format!(" {:>10}", "-"),
                })
                .collect();
            let mark = if is_output { "*" } else { " " };
            out.push_str(&format!("{mark} {node:<width$}{cells}\n"));
        }
    }
    out.push_str(&format!("continuity: max |f(p + δ) - f(p)| / (Lipschitz · δ), δ = {STEP}; ≤ 1 means no seam (- : no Lipschitz bound known)\n"));
    for node in &nodes {
        let cells: String = MAGNITUDES
            .iter()
            .map(|m| match find(node, *m).and_then(|r| r.continuity) {
                Some(c) => format!(" {c:>10.3}"),
                None => format!(" {:>10}", "-"),
            })
            .collect();
        out.push_str(&format!("  {node:<width$}{cells}\n"));
    }
    let mut notes = Vec::new();
    for node in &nodes {
        let short = MAGNITUDES
            .iter()
            .filter_map(|m| find(node, *m))
            .find(|r| r.output && r.max_promoted_error > 1e-4);
        if let Some(r) = short {
            notes.push(format!(
                "  {node}: output still off by {:.1e} at |p| = {} when compiled for it: {}",
                r.max_promoted_error,
                magnitude_label(r.magnitude),
                r.shortfall
                    .as_deref()
                    .unwrap_or("(no reason found: a bound is wrong)")
            ));
        }
        if let Some(first) = MAGNITUDES
            .iter()
            .filter_map(|m| find(node, *m))
            .find(|r| r.max_f32_error > 1e-4)
        {
            notes.push(format!(
                "  {node}: f32 error passes 1e-4 at |p| = {} (values up to {:.3e} there; f32 keeps 24 bits, about {:.1e} absolute at that size)",
                magnitude_label(first.magnitude),
                first.max_abs_value,
                first.max_abs_value * f32::EPSILON as f64 / 2.0
            ));
        }
        if MAGNITUDES
            .iter()
            .filter_map(|m| find(node, *m))
            .any(|r| r.non_finite_f64 > 0 || r.non_finite_f32 > 0)
        {
            notes.push(format!(
                "  {node}: * non-finite values appear (NaN or infinity), counted in --json"
            ));
        }
        if MAGNITUDES
            .iter()
            .filter_map(|m| find(node, *m))
            .any(|r| r.continuity.is_some_and(|c| c > 1.0))
        {
            notes.push(format!("  {node}: a neighbouring pair differs by more than the Lipschitz bound allows (a seam or a jump)"));
        }
    }
    if notes.is_empty() {
        out.push_str(
            "every node stays within 1e-4 of f64, finite and seam-free at every magnitude\n",
        );
    } else {
        out.push_str("where the error grows:\n");
        for note in notes {
            out.push_str(&note);
            out.push('\n');
        }
    }
    out
}
