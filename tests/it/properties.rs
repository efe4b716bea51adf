//! Property tests: point and batch evaluation agree, f32 stays near f64, gradient noise vanishes
//! on the lattice, noise is continuous across cell faces, tapes are shared across threads, and
//! deep graphs compile without recursion.

use proptest::prelude::*;
use texgraph::{check, compile, CheckOptions, CompileOptions, SourceFile, Tape, Workspace};

fn tape(source: &str) -> Tape {
    let graph = check(
        SourceFile::new("property.ron", source),
        &CheckOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{}", e.render_plain()));
    compile(&graph, &CompileOptions::default()).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

fn marble() -> Tape {
    let text = std::fs::read_to_string("graphs/seed003_marble.ron").expect("seed 003 marble");
    tape(&text)
}

const NOISES: &str = r#"Graph(nodes: { "p": Position }, outputs: {
    "perlin": Noise(input: "p", basis: Perlin),
    "gradient": Noise(input: "p", basis: Gradient, seed: 5),
    "value": Noise(input: "p", basis: Value, seed: 9),
    "fbm": Fbm(input: "p", basis: Perlin, octaves: 8.0),
    "turbulence": Turbulence(input: "p", basis: Gradient, octaves: 6.0),
})"#;

use crate::common;

fn batch<S: texgraph::Real>(tape: &Tape, points: &[[f64; 3]]) -> Vec<S> {
    let x: Vec<f64> = points.iter().map(|p| p[0]).collect();
    let y: Vec<f64> = points.iter().map(|p| p[1]).collect();
    let z: Vec<f64> = points.iter().map(|p| p[2]).collect();
    let mut out = vec![S::ZERO; tape.channels() * points.len()];
    tape.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut out);
    out
}

fn coordinate(max: f64) -> impl Strategy<Value = f64> {
    prop_oneof![
        -max..max,
        (-1000i64..1000).prop_map(|i| i as f64),
        (-1000i64..1000).prop_map(|i| i as f64 * 0.5),
        Just(0.0),
        Just(-0.0),
    ]
}

fn points(max: f64, len: std::ops::Range<usize>) -> impl Strategy<Value = Vec<[f64; 3]>> {
    prop::collection::vec([coordinate(max), coordinate(max), coordinate(max)], len)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Batches of any length (across chunk boundaries) equal point evaluation bit for bit.
    #[test]
    fn point_and_batch_agree(points in points(1e9, 1..700)) {
        let tape = marble();
        for problem in [
            common::point_and_batch::<f32>(&tape, &points, common::Agree::Bits).err(),
            common::point_and_batch::<f64>(&tape, &points, common::Agree::Bits).err(),
        ]
        .into_iter()
        .flatten()
        {
            prop_assert!(false, "{}", problem);
        }
    }

    /// The accuracy targets for noise-valued outputs: within 1e-5 of the f64 reference for
    /// |p| <= 1e4, within 1e-4 up to |p| = 2^31.
    #[test]
    fn f32_stays_near_f64_for_noise(near in points(1e4, 1..64), far in points(2147483648.0, 1..64)) {
        let tape = tape(NOISES);
        for (pts, tolerance) in [(&near, 1e-5), (&far, 1e-4)] {
            let b32 = batch::<f32>(&tape, pts);
            let b64 = batch::<f64>(&tape, pts);
            for (a, b) in b32.iter().zip(&b64) {
                prop_assert!((*a as f64 - b).abs() <= tolerance, "f32 {} vs f64 {} (tolerance {})", a, b, tolerance);
            }
        }
    }

    /// Gradient and Perlin noise vanish on every lattice point, at any magnitude.
    #[test]
    fn gradient_noise_is_zero_on_lattice_points(cells in prop::collection::vec([-2_000_000_000i64..2_000_000_000, -5000i64..5000, -3i64..3], 1..32)) {
        let tape = tape(r#"Graph(outputs: { "g": Noise(input: Position, basis: Gradient, seed: 11), "p": Noise(input: Position, basis: Perlin) })"#);
        let pts: Vec<[f64; 3]> = cells.iter().map(|c| [c[0] as f64, c[1] as f64, c[2] as f64]).collect();
        for v in batch::<f32>(&tape, &pts) {
            prop_assert_eq!(v, 0.0);
        }
        for v in batch::<f64>(&tape, &pts) {
            prop_assert_eq!(v, 0.0);
        }
    }

    /// No seams: across a cell face, samples 2e-9 apart differ by less than the noise's
    /// Lipschitz bound allows.
    #[test]
    fn noise_is_continuous_across_cell_faces(k in -100_000i64..100_000, y in -50.0f64..50.0, z in -50.0f64..50.0) {
        let tape = tape(NOISES);
        let x = k as f64;
        let b = batch::<f64>(&tape, &[[x - 1e-9, y, z], [x + 1e-9, y, z]]);
        for pair in b.chunks(2) {
            // Lipschitz bound of any basis here times 2e-9, generously: fbm sums 8 octaves of
            // frequency up to 128.
            prop_assert!((pair[0] - pair[1]).abs() < 1e-5, "{:?}", pair);
        }
    }
}

#[test]
fn a_workspace_moves_between_tapes() {
    let a = marble();
    let b = tape(NOISES);
    let pts = [[0.1, 0.2, 0.3], [4.0, -5.0, 6.5]];
    let mut ws = Workspace::<f32>::new();
    let mut first = vec![0f32; a.channels()];
    a.eval_point(&mut ws, pts[0], &mut first);
    let mut other = vec![0f32; b.channels()];
    b.eval_point(&mut ws, pts[1], &mut other);
    let mut again = vec![0f32; a.channels()];
    a.eval_point(&mut ws, pts[0], &mut again);
    assert_eq!(first, again);
    let mut fresh = vec![0f32; b.channels()];
    b.eval_point(&mut Workspace::new(), pts[1], &mut fresh);
    assert_eq!(other, fresh);
}

#[test]
fn one_tape_is_shared_by_threads_without_locks() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Tape>();
    let tape = marble();
    let pts: Vec<[f64; 3]> = (0..5000)
        .map(|i| [i as f64 * 0.001, (i % 77) as f64 * 0.01, 0.5])
        .collect();
    let single = batch::<f32>(&tape, &pts);
    let n = pts.len();
    let parts: Vec<Vec<f32>> = std::thread::scope(|scope| {
        let handles: Vec<_> = pts
            .chunks(n / 8 + 1)
            .map(|chunk| scope.spawn(|| batch::<f32>(&tape, chunk)))
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("thread"))
            .collect()
    });
    // Reassemble the planar per-chunk outputs and compare bit for bit.
    let mut offset = 0;
    assert_eq!(parts.len(), 8, "eight threads");
    for (chunk, out) in pts.chunks(n / 8 + 1).zip(&parts) {
        let m = chunk.len();
        for c in 0..tape.channels() {
            for i in 0..m {
                assert_eq!(
                    out[c * m + i].to_bits(),
                    single[c * n + offset + i].to_bits()
                );
            }
        }
        offset += m;
    }
}

/// 10 000 chained nodes, declared last-first so the checker must order them itself.
#[test]
fn a_chain_of_ten_thousand_nodes_compiles_without_recursion() {
    let n = 10_000;
    let mut nodes = String::new();
    for i in (1..n).rev() {
        nodes.push_str(&format!(
            "\"n{i}\": Add(Mul(\"n{}\", 0.999), 0.001),\n",
            i - 1
        ));
    }
    nodes.push_str("\"n0\": Noise(input: Position, basis: Perlin),\n");
    let source = format!(
        "Graph(nodes: {{ {nodes} }}, outputs: {{ \"out\": \"n{}\" }})",
        n - 1
    );
    let tape = tape(&source);
    assert_eq!(tape.instructions().len(), 2 + 2 * (n - 1));
    // Slot reuse keeps the frame tiny however long the chain.
    assert!(
        tape.scalar_slots() <= 6,
        "{} scalar slots",
        tape.scalar_slots()
    );
    let mut out = [0f64];
    tape.eval_point(&mut Workspace::new(), [0.5, 0.25, 0.125], &mut out);
    assert!(out[0].is_finite());
}

#[test]
fn a_ten_thousand_node_cycle_is_reported_not_overflowed() {
    let n = 10_000;
    let mut nodes = String::new();
    for i in 0..n {
        nodes.push_str(&format!("\"n{i}\": Sin(\"n{}\"),\n", (i + 1) % n));
    }
    let source = format!("Graph(nodes: {{ {nodes} }}, outputs: {{ \"out\": \"n0\" }})");
    let error = check(
        SourceFile::new("cycle.ron", source),
        &CheckOptions::default(),
    )
    .expect_err("a cycle");
    assert_eq!(error.list.len(), 1);
    assert!(error.list[0].message.contains("cycle"));
}

#[test]
fn only_requested_outputs_are_compiled() {
    let text = std::fs::read_to_string("graphs/seed003_marble.ron").expect("seed 003 marble");
    let graph = check(SourceFile::new("m.ron", text), &CheckOptions::default()).expect("valid");
    let all = compile(&graph, &CompileOptions::default()).expect("compiles");
    let vein = compile(
        &graph,
        &CompileOptions {
            outputs: vec!["vein".into()],
            ..Default::default()
        },
    )
    .expect("compiles");
    assert!(vein.instructions().len() < all.instructions().len());
    assert_eq!(vein.outputs().len(), 1);
    assert!(vein.stats().pruned_nodes >= 1);
    // The shared part computes the same values.
    let p = [0.3, 0.6, 0.9];
    let mut a = vec![0f32; all.channels()];
    let mut v = vec![0f32; 1];
    all.eval_point(&mut Workspace::new(), p, &mut a);
    vein.eval_point(&mut Workspace::new(), p, &mut v);
    let vein_channel = all.output("vein").expect("vein").first_channel;
    assert_eq!(a[vein_channel], v[0]);
}

#[test]
fn identical_subgraphs_are_deduplicated_and_constants_folded() {
    let t = tape(
        r#"Graph(params: { "k": 2.0 }, nodes: {
            "a": Fbm(input: Position, basis: Perlin, octaves: 4.0),
            "b": Fbm(input: Position, basis: Perlin, octaves: Mul("k", 2.0)),
            "c": Add(Sin(Mul("k", 3.0)), Cos(0.5)),
        }, outputs: { "sum": Add("a", "b"), "c": "c" })"#,
    );
    let fractals = t
        .instructions()
        .iter()
        .filter(|i| matches!(i, texgraph::tape::Instr::Fractal { .. }))
        .count();
    assert_eq!(fractals, 1, "{t}");
    // "c" is a constant: no instruction computes it.
    assert_eq!(t.instructions().len(), 3, "{t}"); // position, fbm, add
    let mut out = [0f64; 2];
    t.eval_point(&mut Workspace::new(), [0.0; 3], &mut out);
    assert_eq!(out[1], 6.0f64.sin() + 0.5f64.cos());
}
