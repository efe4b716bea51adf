//! Footprint level of detail: leave out the fbm/turbulence octaves a sampling cannot resolve.
//!
//! Given the sample spacing `h` (a bake's voxel size, a render's pixel footprint), an octave
//! whose wavelength falls below `2h` (the Nyquist limit, seed 004's "sample too sparsely") only
//! aliases. The frequency an octave has in world space depends on the domain transforms before
//! the noise (Scale, Rotate, Translate, any math), so for every node we bound how fast its value
//! can change per unit of world distance — its Lipschitz constant, the "stretch" — with one
//! forward pass over the graph (arguments come before their users; no recursion). An fbm whose
//! input stretches space by `s` sees octave `i` at world frequency `s · lacunarity^i`.
//!
//! Octaves are cut at a *continuous* index, so the last kept octave fades in and out as the
//! spacing changes (no popping), exactly like a fractional `octaves`. What the dropped octaves
//! contributed on average is added back as a constant (`amplitude × E[noise]` for fbm,
//! `amplitude × E[|noise|]` for turbulence), so the filtered texture keeps its mean brightness.

use crate::graph::{CheckedGraph, FractalParams, Op, TableKey};
use crate::noise::NoiseTable;
use crate::ops::{BinaryOp, TernaryOp, UnaryOp};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// Upper bounds of each node's rate of change per unit of world distance; `None` where no
/// useful bound is known (discontinuous or unbounded operations), which disables LOD for noise
/// downstream of it.
pub fn stretches(graph: &CheckedGraph) -> Vec<Option<f64>> {
    let mut s: Vec<Option<f64>> = Vec::with_capacity(graph.nodes.len());
    for node in &graph.nodes {
        let arg = |i: usize| -> Option<f64> { node.args.get(i).and_then(|&a| s[a as usize]) };
        let constant = |i: usize| -> Option<[f64; 3]> {
            node.args
                .get(i)
                .and_then(|&a| match graph.nodes[a as usize].op {
                    Op::ConstScalar(v) => Some([v; 3]),
                    Op::ConstVec3(v) => Some(v),
                    _ => None,
                })
        };
        let largest = |v: [f64; 3]| v.iter().fold(0.0f64, |m, c| m.max(c.abs()));
        let smallest = |v: [f64; 3]| v.iter().fold(f64::INFINITY, |m, c| m.min(c.abs()));
        // A closure, so `?` can give up on an unknown argument.
        let value: Option<f64> = (|| match &node.op {
            Op::Position => Some(1.0),
            Op::ConstScalar(_) | Op::ConstVec3(_) => Some(0.0),
            Op::Splat | Op::Component(_) => arg(0),
            Op::Combine => Some((arg(0)?.powi(2) + arg(1)?.powi(2) + arg(2)?.powi(2)).sqrt()),
            Op::Unary(UnaryOp::Neg | UnaryOp::Abs | UnaryOp::Sin | UnaryOp::Cos) => arg(0),
            // Unbounded slope (Sqrt at 0, Exp) or discontinuous (Floor, Fract): no bound. Listed, not
            // defaulted, so a new operation must say what its bound is.
            Op::Unary(UnaryOp::Sqrt | UnaryOp::Floor | UnaryOp::Fract | UnaryOp::Exp) => None,
            Op::Binary(BinaryOp::Add | BinaryOp::Sub) => Some(arg(0)? + arg(1)?),
            Op::Binary(BinaryOp::Min | BinaryOp::Max) => Some(arg(0)?.max(arg(1)?)),
            Op::Binary(BinaryOp::Mul) => match (constant(0), constant(1)) {
                (Some(c), _) => Some(largest(c) * arg(1)?),
                (_, Some(c)) => Some(largest(c) * arg(0)?),
                _ => None,
            },
            Op::Binary(BinaryOp::Div) => constant(1)
                .filter(|c| smallest(*c) > 0.0)
                .and_then(|c| Some(arg(0)? / smallest(c))),
            // Pow and Atan2 have unbounded slopes; Mod is discontinuous.
            Op::Binary(BinaryOp::Pow | BinaryOp::Atan2 | BinaryOp::Mod) => None,
            Op::Ternary(TernaryOp::Clamp) => constant(1).and(constant(2)).and_then(|_| arg(0)),
            Op::Ternary(TernaryOp::Mix) => constant(2)
                .and_then(|t| Some(largest(t.map(|v| 1.0 - v)) * arg(0)? + largest(t) * arg(1)?)),
            Op::Ternary(TernaryOp::Smoothstep) => match (constant(0), constant(1)) {
                (Some(e0), Some(e1)) => {
                    let width = smallest([e1[0] - e0[0], e1[1] - e0[1], e1[2] - e0[2]]);
                    (width > 0.0)
                        .then(|| 1.5 / width)
                        .and_then(|slope| Some(slope * arg(2)?))
                }
                _ => None,
            },
            Op::Dot => match (constant(0), constant(1)) {
                (Some(c), _) => Some(c.iter().map(|v| v * v).sum::<f64>().sqrt() * arg(1)?),
                (_, Some(c)) => Some(c.iter().map(|v| v * v).sum::<f64>().sqrt() * arg(0)?),
                _ => None,
            },
            Op::Length => arg(0),
            Op::Rotate { .. } => match graph.nodes.get(node.args[1] as usize).map(|n| &n.op) {
                Some(Op::ConstScalar(_)) => arg(0),
                _ => None,
            },
            Op::Noise(key) => Some(table_lipschitz(*key) * arg(0)?),
            Op::Fractal(key, params) => {
                let schedule = params.schedule();
                let sum: f64 = schedule
                    .frequencies
                    .iter()
                    .zip(&schedule.amplitudes)
                    .map(|(f, a)| (f * a).abs())
                    .sum();
                Some(table_lipschitz(*key) * sum * arg(0)?)
            }
            Op::Hermite(_) => None,
            Op::Ramp(r) => {
                spline_slope(r.knots(), r.values()).and_then(|slope| Some(slope * arg(0)?))
            }
            Op::Curve(c) => {
                spline_slope(c.knots(), c.values()).and_then(|slope| Some(slope * arg(0)?))
            }
        })();
        s.push(value.filter(|v| v.is_finite()));
    }
    s
}

/// The steepest segment of a spline (largest change of any channel per unit of input); `None`
/// for a jump (coinciding knots with different values).
fn spline_slope<const N: usize>(knots: &[f64], values: &[[f64; N]]) -> Option<f64> {
    let mut steepest = 0.0f64;
    for (k, v) in knots.windows(2).zip(values.windows(2)) {
        let change = (0..N).fold(0.0f64, |m, c| m.max((v[1][c] - v[0][c]).abs()));
        let width = k[1] - k[0];
        if width > 0.0 {
            steepest = steepest.max(change / width);
        } else if change > 0.0 {
            return None;
        }
    }
    Some(steepest)
}

fn table_lipschitz(key: TableKey) -> f64 {
    key.basis.lipschitz()
}

/// What level of detail did to one fbm/turbulence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FractalLod {
    /// Octaves kept (fractional: the last one faded).
    pub octaves: f64,
    /// Constant standing in for the dropped octaves' average.
    pub bias: f64,
}

/// The octaves an fbm with input stretch `stretch` keeps at sample spacing `spacing`, and the
/// bias for what it drops. Unchanged when nothing needs dropping or nothing is known.
pub fn fractal_lod(
    key: TableKey,
    params: &FractalParams,
    stretch: Option<f64>,
    spacing: f64,
) -> FractalLod {
    let unchanged = FractalLod {
        octaves: params.octaves,
        bias: 0.0,
    };
    let Some(stretch) = stretch else {
        return unchanged;
    };
    if !(spacing > 0.0 && spacing.is_finite()) || stretch <= 0.0 || params.lacunarity <= 1.0 {
        return unchanged;
    }
    // Highest (continuous) octave index whose world frequency stays at or below Nyquist.
    let nyquist = 0.5 / spacing;
    let highest = (nyquist / stretch).ln() / params.lacunarity.ln();
    let kept = (highest - params.first_octave as f64 + 1.0).clamp(0.0, params.octaves);
    if kept >= params.octaves {
        return unchanged;
    }
    // The dropped share of each octave's amplitude, times the basis' mean (or mean magnitude).
    let (mean, mean_abs) = expectations(key);
    let expected = if params.turbulence { mean_abs } else { mean };
    let mut bias = 0.0;
    let count = params.octaves.ceil() as u32;
    for n in 0..count {
        let weight_written = (params.octaves - n as f64).clamp(0.0, 1.0);
        let weight_kept = (kept - n as f64).clamp(0.0, 1.0);
        let i = params.first_octave as i32 + n as i32;
        bias += (weight_written - weight_kept) * params.gain.powi(i) * expected;
    }
    FractalLod {
        octaves: kept,
        bias,
    }
}

/// E[noise] and E[|noise|] of a basis, once per table: the mean exactly, the mean magnitude
/// estimated on a fixed scatter of 8192 points over one lattice period (deterministic, so
/// tapes are reproducible).
fn expectations(key: TableKey) -> (f64, f64) {
    static CACHE: OnceLock<Mutex<HashMap<TableKey, (f64, f64)>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(found) = cache.lock().ok().and_then(|c| c.get(&key).copied()) {
        return found;
    }
    let table = NoiseTable::new(key.basis, key.seed);
    let mut rng = crate::noise::SplitMix64::new(0x10D);
    let mut next = || rng.next_f64() * 256.0;
    let n = 8192;
    let mut sum_abs = 0.0;
    for _ in 0..n {
        let v: f64 = table.sample([next(), next(), next()]);
        sum_abs += v.abs();
    }
    // The mean is known exactly: gradient bases are zero-mean by construction (a sampled
    // estimate would only add noise), and value noise averages to its table's mean, which the
    // 256 lattice points of one row along x visit exactly once each (the hash is a permutation).
    let mean = match key.basis {
        crate::noise::Basis::Perlin | crate::noise::Basis::Gradient => 0.0,
        crate::noise::Basis::Value(_) => {
            (0..256)
                .map(|x| table.sample::<f64>([x as f64, 0.0, 0.0]))
                .sum::<f64>()
                / 256.0
        }
    };
    let result = (mean, sum_abs / n as f64);
    if let Ok(mut c) = cache.lock() {
        c.insert(key, result);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::Basis;

    fn params(octaves: f64) -> FractalParams {
        FractalParams {
            octaves,
            lacunarity: 2.0,
            gain: 0.5,
            first_octave: 0,
            turbulence: false,
        }
    }

    #[test]
    fn octaves_above_nyquist_are_dropped_smoothly() {
        let key = TableKey {
            basis: Basis::Perlin,
            seed: 0,
        };
        // Spacing 1/128: Nyquist 64 = 2^6, so octaves 0..=6 stay: 7 octaves.
        let lod = fractal_lod(key, &params(8.0), Some(1.0), 1.0 / 128.0);
        assert!((lod.octaves - 7.0).abs() < 1e-9, "{lod:?}");
        // A scale of 2 before the noise doubles every frequency: one octave fewer.
        let scaled = fractal_lod(key, &params(8.0), Some(2.0), 1.0 / 128.0);
        assert!((scaled.octaves - 6.0).abs() < 1e-9, "{scaled:?}");
        // In between, the last octave fades.
        let between = fractal_lod(key, &params(8.0), Some(1.5), 1.0 / 128.0);
        assert!(between.octaves > 6.0 && between.octaves < 7.0);
        // Fine spacing keeps everything; unknown stretch keeps everything.
        assert_eq!(fractal_lod(key, &params(8.0), Some(1.0), 1e-6).octaves, 8.0);
        assert_eq!(fractal_lod(key, &params(8.0), None, 1.0).octaves, 8.0);
    }

    #[test]
    fn turbulence_keeps_its_mean_through_dropped_octaves() {
        let key = TableKey {
            basis: Basis::Perlin,
            seed: 0,
        };
        let mut p = params(8.0);
        p.turbulence = true;
        let lod = fractal_lod(key, &p, Some(1.0), 0.25);
        assert!((lod.octaves - 2.0).abs() < 1e-9, "{lod:?}");
        assert!(lod.bias > 0.0, "{lod:?}");
        let (_, mean_abs) = expectations(key);
        assert!(mean_abs > 0.1 && mean_abs < 0.4, "{mean_abs}");
    }
}
