//! Level of detail per lane (issue 18): `Tape::eval_batch_lod` / `eval_point_lod` give each
//! point the octaves its own sample spacing resolves, in one batch of one tape. Held to the
//! per-compile level of detail (`CompileOptions::spacing`) bit for bit, lane by lane, and to
//! point = batch with mixed spacings, promoted precision and hostile inputs.

use texgraph::{
    compile, CheckOptions, CheckedGraph, CompileOptions, Extent, Real, Tape, Workspace,
};

use crate::common;
use common::graph_files;

/// Every graph file, and beside each graph with a scalar output the same graph with that
/// output's gradient added (a bump's height: the `FractalGradient` instructions).
fn graphs() -> Vec<(String, CheckedGraph)> {
    let mut graphs = Vec::new();
    for path in graph_files() {
        let graph = texgraph::load_graph(&path, &CheckOptions::default()).expect("valid graph");
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let scalar = graph
            .outputs()
            .iter()
            .map(|o| o.name.clone())
            .find(|o| graph.with_gradient_output(o, "∇").is_ok());
        if let Some(of) = scalar {
            let with = graph.with_gradient_output(&of, "∇").expect("scalar output");
            graphs.push((format!("{name} with ∇{of}"), with));
        }
        graphs.push((name, graph));
    }
    graphs
}

fn compiled(graph: &CheckedGraph, spacing: Option<f64>) -> Tape {
    let options = CompileOptions {
        spacing,
        ..Default::default()
    };
    compile(graph, &options).expect("compiles")
}

/// A fixed scatter of points over [-3, 9)³ (SplitMix64): negative, fractional, several cells.
fn points(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) as f64 / u64::MAX as f64
    };
    (0..n)
        .map(|_| [0; 3].map(|_| next() * 12.0 - 3.0))
        .collect()
}

fn planes(points: &[[f64; 3]]) -> [Vec<f64>; 3] {
    [0, 1, 2].map(|a| points.iter().map(|p| p[a]).collect())
}

fn same_bits<S: Real>(a: S, b: S) -> bool {
    a.to_f64().to_bits() == b.to_f64().to_bits()
}

/// Spacings from far finer than any octave to coarser than the first.
const SPACINGS: [f64; 6] = [1e-5, 1.0 / 256.0, 1.0 / 37.0, 0.11, 0.6, 40.0];

/// Each lane of one batch with mixed spacings equals, bit for bit, the tape compiled for its
/// own spacing, and its per-point evaluation: per-lane LOD is per-compile LOD, lane by lane.
fn mixed_spacings_equal_their_compiled_tapes<S: Real>() {
    let pts = points(700, 18);
    let [x, y, z] = planes(&pts);
    // Runs of equal spacings and single odd lanes, so chunks are both uniform and mixed.
    let spacing: Vec<f64> = (0..pts.len())
        .map(|i| {
            SPACINGS[if i < 300 {
                i / 50
            } else {
                i * 7 % SPACINGS.len()
            }]
        })
        .collect();
    let mut checked = 0;
    for (name, graph) in graphs() {
        let plain = compiled(&graph, None);
        let channels = plain.channels();
        let mut lanes = vec![S::ZERO; channels * pts.len()];
        plain.eval_batch_lod(&mut Workspace::new(), [&x, &y, &z], &spacing, &mut lanes);
        let per_compile: Vec<Tape> = SPACINGS
            .iter()
            .map(|&h| compiled(&graph, Some(h)))
            .collect();
        let mut ws = Workspace::<S>::new();
        let mut ws_lod = Workspace::<S>::new();
        let (mut want, mut one) = (vec![S::ZERO; channels], vec![S::ZERO; channels]);
        for (i, p) in pts.iter().enumerate() {
            let tape = &per_compile[SPACINGS.iter().position(|&h| h == spacing[i]).unwrap()];
            tape.eval_point(&mut ws, *p, &mut want);
            plain.eval_point_lod(&mut ws_lod, *p, spacing[i], &mut one);
            for c in 0..channels {
                let got = lanes[c * pts.len() + i];
                assert!(
                    same_bits(got, want[c]) && same_bits(one[c], want[c]),
                    "{name}: lane {i} (spacing {}) channel {c}: batch {} point {} compiled {}",
                    spacing[i],
                    got.to_f64(),
                    one[c].to_f64(),
                    want[c].to_f64()
                );
            }
        }
        checked += 1;
    }
    assert!(checked > 40, "{checked} graphs");
}

#[test]
fn mixed_spacings_equal_their_compiled_tapes_f32() {
    mixed_spacings_equal_their_compiled_tapes::<f32>();
}

#[test]
fn mixed_spacings_equal_their_compiled_tapes_f64() {
    mixed_spacings_equal_their_compiled_tapes::<f64>();
}

/// A tape compiled for a spacing (a bake's) keeps its own octaves: per-lane spacings can only
/// drop more, never bring back what the tape left out.
#[test]
fn lanes_never_keep_more_than_their_tape() {
    let graph = texgraph::load_graph(
        &common::crate_root().join("graphs/seed003_marble.ron"),
        &CheckOptions::default(),
    )
    .expect("valid");
    let coarse = compiled(&graph, Some(0.1));
    let pts = points(300, 3);
    let [x, y, z] = planes(&pts);
    let n = pts.len();
    let mut fine = vec![0.0f32; coarse.channels() * n];
    coarse.eval_batch_lod(
        &mut Workspace::new(),
        [&x, &y, &z],
        &vec![1e-6; n],
        &mut fine,
    );
    let mut plain = vec![0.0f32; coarse.channels() * n];
    coarse.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut plain);
    assert_eq!(fine, plain);
    // Coarser than the tape: the per-compile tape of the coarser spacing.
    let coarser = compiled(&graph, Some(0.5));
    let mut lod = vec![0.0f32; coarse.channels() * n];
    coarse.eval_batch_lod(&mut Workspace::new(), [&x, &y, &z], &vec![0.5; n], &mut lod);
    let mut want = vec![0.0f32; coarse.channels() * n];
    coarser.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut want);
    assert_eq!(lod, want);
}

/// Point = batch bit for bit with both features on (precision promoted for a far extent, level
/// of detail per lane) over hostile spacings (zero, negative, NaN, infinite, subnormal, huge)
/// and hostile points (huge, negative, non-finite), in f32 and f64; a footprint coarser than
/// every octave leaves a fractal at its mean, a non-positive or non-finite one drops nothing.
#[test]
fn point_equals_batch_with_promotion_and_hostile_spacings() {
    let far = Extent::new([1e6; 3], [1e6 + 64.0; 3]);
    let spacings = [
        0.0,
        -1.0,
        f64::NAN,
        f64::INFINITY,
        f64::MIN_POSITIVE / 4.0,
        f64::MAX,
        1e-3,
        0.05,
        3.0,
    ];
    let mut pts = points(280, 7)
        .into_iter()
        .map(|p| p.map(|c| c * 5.0 + 1e6))
        .collect::<Vec<_>>();
    pts.extend([
        [f64::NAN, 0.0, 0.0],
        [f64::INFINITY, 1.0, 2.0],
        [-1e300, 3.0, 1e300],
        [2f64.powi(31), -2f64.powi(31), 0.5],
        [-0.0, 0.0, 1e-310],
    ]);
    let [x, y, z] = planes(&pts);
    let spacing: Vec<f64> = (0..pts.len())
        .map(|i| spacings[i * 5 % spacings.len()])
        .collect();
    let mut promoted_any = false;
    for (name, graph) in graphs() {
        let tape = compile(
            &graph,
            &CompileOptions {
                extent: Some(far),
                ..Default::default()
            },
        )
        .expect("compiles");
        promoted_any |= tape.wide_instructions() > 0;
        check_point_batch::<f32>(&name, &tape, &pts, [&x, &y, &z], &spacing);
        check_point_batch::<f64>(&name, &tape, &pts, [&x, &y, &z], &spacing);
    }
    assert!(
        promoted_any,
        "the far extent promotes some graph's instructions"
    );
}

fn check_point_batch<S: Real>(
    name: &str,
    tape: &Tape,
    pts: &[[f64; 3]],
    xyz: [&[f64]; 3],
    spacing: &[f64],
) {
    let n = pts.len();
    let channels = tape.channels();
    let mut batch = vec![S::ZERO; channels * n];
    tape.eval_batch_lod(&mut Workspace::new(), xyz, spacing, &mut batch);
    let mut plain = vec![S::ZERO; channels * n];
    tape.eval_batch(&mut Workspace::new(), xyz[0], xyz[1], xyz[2], &mut plain);
    let mut ws = Workspace::<S>::new();
    let mut one = vec![S::ZERO; channels];
    for (i, p) in pts.iter().enumerate() {
        tape.eval_point_lod(&mut ws, *p, spacing[i], &mut one);
        for (c, &u) in one.iter().enumerate() {
            let v = batch[c * n + i];
            assert!(
                same_bits(u, v),
                "{name}: point {} vs batch {} at {p:?} spacing {} channel {c}",
                u.to_f64(),
                v.to_f64(),
                spacing[i]
            );
            // A spacing that is not positive and finite drops nothing.
            if !(spacing[i] > 0.0 && spacing[i].is_finite()) {
                let w = plain[c * n + i];
                assert!(
                    same_bits(v, w),
                    "{name}: spacing {} changed lane {i}",
                    spacing[i]
                );
            }
        }
    }
}

/// A footprint coarser than every octave leaves an fbm at its mean (0 for Perlin), turbulence
/// at its mean magnitude (positive), while the finest spacing keeps every octave.
#[test]
fn a_footprint_coarser_than_every_octave_leaves_the_mean() {
    let text = r#"Graph(nodes: {
        "f": Fbm(input: Position, basis: Perlin, octaves: 8.0),
        "t": Turbulence(input: Position, basis: Perlin, octaves: 8.0),
    }, outputs: { "f": "f", "t": "t" })"#;
    let graph = texgraph::check(
        texgraph::SourceFile::new("t.ron", text.to_string()),
        &CheckOptions::default(),
    )
    .expect("valid");
    let tape = compiled(&graph, None);
    let pts = points(64, 5);
    let [x, y, z] = planes(&pts);
    let mut coarse = vec![0.0f64; 2 * 64];
    tape.eval_batch_lod(&mut Workspace::new(), [&x, &y, &z], &[1e3; 64], &mut coarse);
    let (f, t) = coarse.split_at(64);
    assert!(f.iter().all(|&v| v == 0.0), "{f:?}");
    assert!(
        t.windows(2).all(|w| w[0] == w[1]) && t[0] > 0.1 && t[0] < 1.0,
        "{t:?}"
    );
    let mut fine = vec![0.0f64; 2 * 64];
    tape.eval_batch_lod(&mut Workspace::new(), [&x, &y, &z], &[1e-9; 64], &mut fine);
    let mut plain = vec![0.0f64; 2 * 64];
    tape.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut plain);
    assert_eq!(fine, plain);
}
