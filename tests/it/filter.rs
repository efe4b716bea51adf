//! Filtered evaluation (issue 33): each output's mean over a footprint. Exactness of the rules
//! for linear arguments against numerical quadrature, continuity at a zero footprint, the global
//! mean at huge footprints, point = batch, and every graph of `graphs/` finite at any footprint.

use crate::common::graph_files;
use texgraph::filter::{Filtered, Footprint};
use texgraph::{check, compile, CheckOptions, CompileOptions, SourceFile, Tape, Workspace};

pub fn tape(source: &str) -> Tape {
    let graph = check(
        SourceFile::new("filter.ron", source),
        &CheckOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{}", e.render_plain()));
    compile(&graph, &CompileOptions::default()).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

fn filtered(tape: &Tape, p: [f64; 3], footprint: &Footprint) -> Vec<f64> {
    let mut out = vec![0.0; tape.channels()];
    Filtered::new(tape).eval_point(p, footprint, &mut out);
    out
}

fn point(tape: &Tape, p: [f64; 3]) -> Vec<f64> {
    let mut out = vec![0.0; tape.channels()];
    tape.eval_point(&mut Workspace::new(), p, &mut out);
    out
}

/// SplitMix64 in [0, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// The mean of the tape's first channel along x over `[x − w/2, x + w/2]` (y, z fixed):
/// composite Gauss–Legendre (4 points) on `panels` panels — the independent reference. The
/// nodes run in f64 batches of 4096 (the batch path is the point path bit for bit:
/// `properties::point_and_batch_agree`), a few times faster than point by point.
fn line_mean(tape: &Tape, p: [f64; 3], w: f64, panels: usize) -> f64 {
    const NODES: [f64; 4] = [
        -0.861_136_311_594_052_6,
        -0.339_981_043_584_856_3,
        0.339_981_043_584_856_3,
        0.861_136_311_594_052_6,
    ];
    const WEIGHTS: [f64; 4] = [
        0.347_854_845_137_453_9,
        0.652_145_154_862_546_1,
        0.652_145_154_862_546_1,
        0.347_854_845_137_453_9,
    ];
    const CHUNK: usize = 1024; // panels per batch: 4096 points
    let h = w / panels as f64;
    let mut ws = Workspace::<f64>::new();
    let (mut x, mut out) = (Vec::new(), Vec::new());
    let (y, z) = (vec![p[1]; 4 * CHUNK], vec![p[2]; 4 * CHUNK]);
    let mut sum = 0.0;
    for first in (0..panels).step_by(CHUNK) {
        let count = CHUNK.min(panels - first);
        x.clear();
        for k in first..first + count {
            let centre = p[0] - w / 2.0 + (k as f64 + 0.5) * h;
            x.extend(NODES.iter().map(|node| centre + node * h / 2.0));
        }
        let n = x.len();
        out.resize(tape.channels() * n, 0.0);
        tape.eval_batch(&mut ws, &x, &y[..n], &z[..n], &mut out);
        for (i, v) in out[..n].iter().enumerate() {
            sum += WEIGHTS[i % 4] / 2.0 * v;
        }
    }
    sum / panels as f64
}

/// The mean over a box by stratified sampling (`n³` jittered samples).
fn box_mean(tape: &Tape, p: [f64; 3], sides: [f64; 3], n: usize, rng: &mut Rng) -> Vec<f64> {
    let mut ws = Workspace::new();
    let mut out = vec![0.0; tape.channels()];
    let mut sum = vec![0.0; tape.channels()];
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let q: [f64; 3] = std::array::from_fn(|a| {
                    let cell = [i, j, k][a] as f64;
                    p[a] + sides[a] * ((cell + rng.next()) / n as f64 - 0.5)
                });
                tape.eval_point(&mut ws, q, &mut out);
                for (s, v) in sum.iter_mut().zip(&out) {
                    *s += v;
                }
            }
        }
    }
    sum.iter().map(|s| s / (n * n * n) as f64).collect()
}

/// Exactness for linear arguments (issue 33's first goal): `Sin`, `Cos`, `Fract`, `Floor`,
/// `Step`, `Smoothstep`, `Abs`, `Clamp` of `a x + c` over boxes of every size, within 1e-4 of
/// the exact mean along x (quadrature split finely enough that its own error is below 1e-5).
#[test]
fn linear_arguments_are_exact() {
    let shapes = [
        "Sin(ARG)",
        "Cos(ARG)",
        "Fract(ARG)",
        "Floor(ARG)",
        "Step(0.25, ARG)",
        "Smoothstep(-0.3, 0.45, ARG)",
        "Abs(ARG)",
        "Clamp(input: ARG, min: -0.2, max: 0.7)",
        // Composed exactly from the argument: |sin|, |cos| (a Fourier series) and a step or
        // smoothstep of |x| (one piecewise function of x).
        "Abs(Sin(ARG))",
        "Abs(Cos(ARG))",
        "Smoothstep(0.1, 0.4, Abs(ARG))",
        "Smoothstep(0.0, 0.3, Abs(ARG))",
        "Step(0.35, Abs(ARG))",
        // Periodic chains: a piecewise-linear function of a `Fract` or `Mod`, from its
        // argument (a tent, a clamped fold, stripes, a sawtooth of another period, a constant
        // ramp, a vec3 chain).
        "Sub(1.0, Abs(Sub(Mul(2.0, Fract(ARG)), 1.0)))",
        "Clamp(input: Mul(3.0, Abs(Sub(Fract(ARG), 0.5))), min: 0.2, max: 0.9)",
        "Step(0.65, Fract(ARG))",
        "Max(Neg(Div(Mod(ARG, 0.7), 0.7)), -0.6)",
        "Dot(ColorRamp(input: Fract(ARG), stops: [(0.0, (0.1, 0.2, 0.3)), (0.4, (0.9, 0.5, 0.1)), \
         (0.7, (0.3, 0.3, 0.8))], interpolation: Constant), (1.0, 0.5, 0.25))",
        "Dot(ColorRamp(input: Fract(ARG), stops: [(0.0, (0.1, 0.2, 0.3)), (0.6, (0.9, 0.5, 0.1)), \
         (1.0, (0.1, 0.2, 0.3))], interpolation: Linear), (1.0, 0.5, 0.25))",
        "Dot(Sub(1.0, Abs(Sub(Mul(2.0, Fract((ARG, ARG, ARG))), 1.0))), (0.2, 0.3, 0.5))",
        // ... and through one piecewise cubic (a smoothstep, a smooth ramp).
        "Smoothstep(0.1, 0.4, Fract(ARG))",
        "Sub(1.0, Smoothstep(0.0, 0.2, Abs(Sub(Fract(ARG), 0.5))))",
        "Dot(ColorRamp(input: Fract(ARG), stops: [(0.0, (0.1, 0.2, 0.3)), (0.6, (0.9, 0.5, 0.1)), \
         (1.0, (0.1, 0.2, 0.3))], interpolation: Smooth), (1.0, 0.5, 0.25))",
    ];
    let mut rng = Rng(7);
    for shape in shapes {
        for case in 0..6 {
            let (a, c) = (rng.range(-3.0, 3.0), rng.range(-2.0, 2.0));
            let arg = format!("Add(Mul({a:.6}, \"p.x\"), {c:.6})");
            let source = format!(
                "Graph(nodes: {{ \"p\": Position }}, outputs: {{ \"f\": {} }})",
                shape.replace("ARG", &arg)
            );
            let t = tape(&source);
            let w = [1e-3, 0.05, 0.5, 2.0, 7.0, 30.0][case];
            let p = [rng.range(-2.0, 2.0), 0.3, 0.7];
            let footprint = Footprint::from_sides([w, 0.25, 0.5]).unwrap();
            let got = filtered(&t, p, &footprint)[0];
            let panels = (20_000.0 * (w * a.abs()).max(1.0)).min(400_000.0) as usize;
            let want = line_mean(&t, p, w, panels);
            assert!(
                (got - want).abs() <= 1e-4 * want.abs().max(1.0),
                "{shape} with a = {a}, c = {c}, side {w} at {p:?}: filtered {got}, exact {want}"
            );
        }
    }
}

/// White noise (one value per unit cell) over a line is the mixture of the cells it crosses,
/// exactly; of an integer-valued input (a `Floor`), the lattice's two-point law across one face.
#[test]
fn white_noise_is_a_mixture_of_its_cells() {
    let mut rng = Rng(13);
    for (shape, integer) in [
        ("WhiteNoise(input: (ARG, 0.5, 0.5), seed: 3)", false),
        ("WhiteNoise(input: (Floor(ARG), 0.5, 0.5), seed: 3)", true),
    ] {
        for case in 0..12 {
            let (a, c) = (rng.range(-3.0, 3.0), rng.range(-2.0, 2.0));
            let arg = format!("Add(Mul({a:.6}, \"p.x\"), {c:.6})");
            let t = tape(&format!(
                "Graph(nodes: {{ \"p\": Position }}, outputs: {{ \"f\": {} }})",
                shape.replace("ARG", &arg)
            ));
            // Across at most one face of the lattice for the integer-valued input.
            let w = if integer {
                rng.range(0.01, 0.95) / a.abs()
            } else {
                [1e-3, 0.05, 0.5, 2.0, 7.0, 12.0][case % 6]
            };
            let p = [rng.range(-2.0, 2.0), 0.3, 0.7];
            let footprint = Footprint::from_sides([w, 0.25, 0.5]).unwrap();
            let got = filtered(&t, p, &footprint)[0];
            let panels = (20_000.0 * (w * a.abs()).max(1.0)) as usize;
            let want = line_mean(&t, p, w, panels);
            assert!(
                (got - want).abs() <= 1e-4,
                "{shape}, a = {a}, c = {c}, side {w}: filtered {got}, exact {want}"
            );
        }
    }
}

/// Cellular noise over boxes within a cell (sub-footprint evaluation): a cell's value over a box
/// inside it is that value exactly, and across cell borders the filtered estimates are far
/// closer to the box means than the centre values.
#[test]
fn cellular_boxes_see_their_cells() {
    let t = tape(
        "Graph(nodes: { \"p\": Position }, outputs: { \"v\": Cellular(input: \"p\", seed: 4, \
         value: CellValue), \"f\": Cellular(input: \"p\", seed: 4, value: F2MinusF1) })",
    );
    let mut rng = Rng(17);
    let (mut inside, mut filtered_err, mut point_err) = (0, 0.0, 0.0);
    for _ in 0..60 {
        let p = [
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        ];
        let tiny = filtered(&t, p, &Footprint::cube(1e-4).unwrap());
        if (tiny[0] - point(&t, p)[0]).abs() < 1e-12 {
            inside += 1;
        }
        let side = 0.3;
        let want = box_mean(&t, p, [side; 3], 8, &mut rng);
        let got = filtered(&t, p, &Footprint::cube(side).unwrap());
        let centre = point(&t, p);
        for c in 0..2 {
            filtered_err += (got[c] - want[c]).powi(2);
            point_err += (centre[c] - want[c]).powi(2);
        }
    }
    assert!(
        inside >= 58,
        "a tiny box keeps its cell's value: {inside} of 60"
    );
    assert!(
        filtered_err < point_err / 2.0,
        "filtered squared error {filtered_err}, point {point_err}"
    );
}

/// The rules compose: a linear argument in all three axes (a box, not a line), and products
/// and sums of such values, within a stratified 3-D reference's own error.
#[test]
fn three_dimensional_boxes_agree_with_supersampling() {
    let sources = [
        "Fract(Add(Add(Mul(1.3, \"p.x\"), Mul(-0.7, \"p.y\")), Mul(2.1, \"p.z\")))",
        "Sin(Add(Mul(5.0, \"p.x\"), Mul(3.0, \"p.z\")))",
        "Mul(\"p.x\", \"p.y\")",
        "Smoothstep(0.0, 0.5, Add(\"p.x\", \"p.y\"))",
    ];
    let mut rng = Rng(11);
    for s in sources {
        let t = tape(&format!(
            "Graph(nodes: {{ \"p\": Position }}, outputs: {{ \"f\": {s} }})"
        ));
        for _ in 0..3 {
            let p = [
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
            ];
            let sides = [
                rng.range(0.1, 1.5),
                rng.range(0.1, 1.5),
                rng.range(0.1, 1.5),
            ];
            let got = filtered(&t, p, &Footprint::from_sides(sides).unwrap())[0];
            let want = box_mean(&t, p, sides, 40, &mut rng)[0];
            assert!(
                (got - want).abs() <= 5e-3,
                "{s} at {p:?}, sides {sides:?}: filtered {got}, supersampled {want}"
            );
        }
    }
}

/// A zero footprint is point evaluation (f64), and a vanishing one tends to it.
#[test]
fn zero_footprint_is_the_point_value() {
    let mut rng = Rng(3);
    for path in graph_files() {
        let (t, _) = crate::common::load_graph_file(path.to_str().unwrap(), &[]);
        let f = Filtered::new(&t);
        for _ in 0..4 {
            let p = [
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
            ];
            let want = point(&t, p);
            let mut got = vec![0.0f64; t.channels()];
            f.eval_point(p, &Footprint::POINT, &mut got);
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    g == w
                        || (g.is_nan() && w.is_nan())
                        || (g - w).abs() <= 1e-12 * w.abs().max(1.0),
                    "{}: {p:?}: zero footprint {g}, point {w}",
                    path.display()
                );
            }
            let tiny = Footprint::cube(1e-9).unwrap();
            f.eval_point(p, &tiny, &mut got);
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    (g - w).abs() <= 1e-5 * w.abs().max(1.0) || !w.is_finite(),
                    "{}: {p:?}: footprint 1e-9 gives {g}, point {w}",
                    path.display()
                );
            }
        }
    }
}

/// Far larger footprints than any feature give the output's global mean.
#[test]
fn huge_footprints_give_the_global_mean() {
    let t = tape(
        r#"Graph(nodes: { "p": Position }, outputs: { "f": Fract(Mul(3.0, "p.x")), "s": Sin("p.y"), "n": Noise(input: Position, basis: Perlin) })"#,
    );
    let got = filtered(&t, [0.3, 0.2, 0.1], &Footprint::cube(1e6).unwrap());
    assert!((got[0] - 0.5).abs() < 1e-5, "fract mean {}", got[0]);
    assert!(got[1].abs() < 1e-5, "sin mean {}", got[1]);
    assert!(got[2].abs() < 0.02, "noise mean {}", got[2]);
    let wide = Footprint::from_sides([1e300, 1.0, 1.0]).unwrap();
    let got = filtered(&t, [0.3, 0.2, 0.1], &wide);
    assert!(
        (got[0] - 0.5).abs() < 1e-9,
        "fract over a side of 1e300: {}",
        got[0]
    );
}

/// Point and batch forms agree bit for bit (the parallel batch, the tape's method and a worker's
/// kept workspace); f32 is the f64 result rounded.
#[test]
fn batch_equals_point_and_f32_rounds_f64() {
    let (t, _) = crate::common::load_graph_file("graphs/seed003_marble.ron", &[]);
    let f = Filtered::new(&t);
    let mut rng = Rng(5);
    let n = 97;
    let pts: Vec<[f64; 3]> = (0..n)
        .map(|_| {
            [
                rng.range(-4.0, 4.0),
                rng.range(-4.0, 4.0),
                rng.range(-4.0, 4.0),
            ]
        })
        .collect();
    let footprints: Vec<Footprint> = (0..n)
        .map(|i| Footprint::cube([0.0, 1e-3, 0.125, 0.5, 3.0][i % 5]).unwrap())
        .collect();
    let axis = |a: usize| pts.iter().map(|p| p[a]).collect::<Vec<_>>();
    let (x, y, z) = (axis(0), axis(1), axis(2));
    let c = t.channels();
    let mut batch = vec![0.0f64; c * n];
    f.eval_batch([&x, &y, &z], &footprints, &mut batch);
    let mut batch32 = vec![0.0f32; c * n];
    f.eval_batch([&x, &y, &z], &footprints, &mut batch32);
    // The tape's own methods are the same evaluation.
    let mut via_tape = vec![0.0f64; c * n];
    t.eval_batch_filtered([&x, &y, &z], &footprints, &mut via_tape);
    assert!(via_tape
        .iter()
        .zip(&batch)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    // A worker's kept workspace: used first on another tape (other slots, other constants),
    // then on this one, twice: the same bits as the parallel batch.
    let mut ws = texgraph::filter::FilterWorkspace::<f64>::default();
    let (other, _) = crate::common::load_graph_file("graphs/seed000_wood_rings.ron", &[]);
    let mut scrap = vec![0.0f64; other.channels() * n];
    Filtered::new(&other).eval_batch_with(&mut ws, [&x, &y, &z], &footprints, &mut scrap);
    for _ in 0..2 {
        let mut kept = vec![f64::NAN; c * n];
        f.eval_batch_with(&mut ws, [&x, &y, &z], &footprints, &mut kept);
        assert!(kept
            .iter()
            .zip(&batch)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }
    let mut one_via_tape = vec![0.0f32; c];
    t.eval_point_filtered(pts[0], &footprints[0], &mut one_via_tape);
    assert_eq!(
        one_via_tape,
        (0..c).map(|ch| batch32[ch * n]).collect::<Vec<_>>()
    );
    for i in 0..n {
        let mut one = vec![0.0f64; c];
        f.eval_point(pts[i], &footprints[i], &mut one);
        let mut one32 = vec![0.0f32; c];
        f.eval_point(pts[i], &footprints[i], &mut one32);
        for ch in 0..c {
            assert_eq!(
                one[ch].to_bits(),
                batch[ch * n + i].to_bits(),
                "point {i} channel {ch}"
            );
            // f32: the same bits point and batch (f32 samples where the tape allows them),
            // within the f32 contract of the f64 value.
            assert_eq!(batch32[ch * n + i].to_bits(), one32[ch].to_bits());
            let (a, b) = (f64::from(one32[ch]), one[ch]);
            assert!(
                (a - b).abs() <= 1e-5 * b.abs().max(1.0),
                "point {i} channel {ch}: f32 {a}, f64 {b}"
            );
        }
    }
}

/// Issue 47's f32 contract: the f32 filtered value (its noise's value-only samples in f32 where
/// the tape's precision analysis allows it) within 1e-5 of the f64 one, on every graph, at box
/// sides from 1/2 to 1/512 and an anisotropic footprint; and the f32 samples are taken (the
/// seed 003 marble's f32 values are not all its f64 values rounded).
#[test]
fn f32_filtered_is_within_1e5_of_f64_on_every_graph() {
    let mut footprints: Vec<Footprint> = [2.0, 8.0, 32.0, 128.0, 512.0]
        .iter()
        .map(|d| Footprint::cube(1.0 / d).unwrap())
        .collect();
    footprints.push(Footprint::from_sides([0.3, 0.01, 0.05]).unwrap());
    let mut rng = Rng(47);
    let n = 48;
    let mut marble_moved = 0;
    for path in graph_files() {
        let (t, _) = crate::common::load_graph_file(path.to_str().unwrap(), &[]);
        let f = Filtered::new(&t);
        let c = t.channels();
        for fp in &footprints {
            let [x, y, z] =
                [0, 1, 2].map(|_| (0..n).map(|_| rng.range(-5.0, 5.0)).collect::<Vec<f64>>());
            let mut wide = vec![0.0f64; c * n];
            let mut narrow = vec![0.0f32; c * n];
            f.eval_batch([&x, &y, &z], std::slice::from_ref(fp), &mut wide);
            f.eval_batch([&x, &y, &z], std::slice::from_ref(fp), &mut narrow);
            for (k, (&a, &b)) in narrow.iter().zip(&wide).enumerate() {
                if !b.is_finite() || !(b as f32).is_finite() {
                    continue;
                }
                let a = f64::from(a);
                assert!(
                    (a - b).abs() <= 1e-5 * b.abs().max(1.0),
                    "{}: channel {} at ({}, {}, {}) over {fp:?}: f32 {a}, f64 {b}",
                    path.display(),
                    k / n,
                    x[k % n],
                    y[k % n],
                    z[k % n]
                );
                if path.ends_with("seed003_marble.ron") && a != f64::from(b as f32) {
                    marble_moved += 1;
                }
            }
        }
    }
    assert!(
        marble_moved > 0,
        "the marble's f32 filtered values took no f32 samples"
    );
}

/// Every graph, at random footprints (zero, tiny, huge, anisotropic): a finite value wherever
/// the point value is finite, never a panic; bad footprints (NaN, negative, infinite) are refused
/// with a message.
#[test]
fn every_graph_is_finite_at_every_footprint() {
    let footprints = [
        Footprint::cube(0.0).unwrap(),
        Footprint::cube(1e-12).unwrap(),
        Footprint::from_sides([0.3, 0.0, 1e-3]).unwrap(),
        Footprint::cube(0.5).unwrap(),
        Footprint::cube(1e9).unwrap(),
        Footprint::from_sides([1e6, 0.1, 0.1]).unwrap(),
        Footprint::from_edges([[0.1, 0.05, 0.0], [0.0, 0.02, 0.3], [0.0; 3]]).unwrap(),
    ];
    let mut rng = Rng(9);
    for path in graph_files() {
        let (t, _) = crate::common::load_graph_file(path.to_str().unwrap(), &[]);
        let f = Filtered::new(&t);
        for fp in &footprints {
            let p = [
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
            ];
            let want = point(&t, p);
            let mut got = vec![0.0f64; t.channels()];
            f.eval_point(p, fp, &mut got);
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    g.is_finite() || !w.is_finite(),
                    "{}: {p:?} footprint {fp:?}: {g} where the point value is {w}",
                    path.display()
                );
            }
        }
    }
    for bad in [
        [f64::NAN, 1.0, 1.0],
        [-1.0, 1.0, 1.0],
        [1.0, f64::INFINITY, 1.0],
    ] {
        let e = Footprint::from_sides(bad).unwrap_err().to_string();
        assert!(e.contains("footprint side"), "{e}");
    }
    assert!(Footprint::from_edges([[f64::INFINITY, 0.0, 0.0], [0.0; 3], [0.0; 3]]).is_err());
}

/// Filtering beats point sampling where point sampling aliases: the seed 003 marble's vein at
/// box side 1/2, against a 216-sample stratified reference, over random boxes in [−4, 4]³.
#[test]
fn marble_filtered_beats_point_sampling() {
    let (t, _) = crate::common::load_graph_file("graphs/seed003_marble.ron", &[]);
    let f = Filtered::new(&t);
    let vein = t.output("vein").unwrap().first_channel;
    let mut rng = Rng(21);
    let (mut point_se, mut filtered_se) = (0.0, 0.0);
    let n = 40;
    for _ in 0..n {
        let p = [
            rng.range(-4.0, 4.0),
            rng.range(-4.0, 4.0),
            rng.range(-4.0, 4.0),
        ];
        let reference = box_mean(&t, p, [0.5; 3], 6, &mut rng)[vein];
        let mut got = vec![0.0; t.channels()];
        f.eval_point(p, &Footprint::cube(0.5).unwrap(), &mut got);
        filtered_se += (got[vein] - reference).powi(2);
        point_se += (point(&t, p)[vein] - reference).powi(2);
    }
    let (point_rms, filtered_rms) = (
        (point_se / n as f64).sqrt(),
        (filtered_se / n as f64).sqrt(),
    );
    assert!(
        filtered_rms * 2.0 < point_rms,
        "marble vein at side 1/2: filtered RMS {filtered_rms}, point RMS {point_rms}"
    );
}

/// An integer-valued value through `Mod` (a checker: `Mod(Floor(x) + Floor(y), 2)`) is
/// filtered on its lattice: over boxes straddling one face, exactly the two cells' shares;
/// over wide boxes, 1/2 (a continuous model would give 1).
#[test]
fn checker_parity_is_filtered_on_the_lattice() {
    let t = tape(
        r#"Graph(nodes: { "p": Position }, outputs: { "c": Mod(Add(Floor("p.x"), Floor("p.y")), 2.0) })"#,
    );
    // x in [0.9, 1.3): 1/4 in cell 0 (parity 0 with y in cell 0), 3/4 in cell 1 (parity 1).
    let got = filtered(
        &t,
        [1.1, 0.5, 0.0],
        &Footprint::from_sides([0.4, 0.2, 0.0]).unwrap(),
    )[0];
    assert!((got - 0.75).abs() < 1e-12, "straddling one face: {got}");
    let wide = filtered(&t, [0.3, 0.7, 0.0], &Footprint::cube(40.0).unwrap())[0];
    assert!((wide - 0.5).abs() < 0.02, "a wide box: {wide}");
    let mut rng = Rng(17);
    for _ in 0..6 {
        let p = [rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), 0.0];
        let sides = [rng.range(0.1, 3.0), rng.range(0.1, 3.0), 0.0];
        let got = filtered(&t, p, &Footprint::from_sides(sides).unwrap())[0];
        let want = box_mean(&t, p, sides, 40, &mut rng)[0];
        assert!(
            (got - want).abs() < 0.12,
            "at {p:?}, sides {sides:?}: filtered {got}, supersampled {want}"
        );
    }
}

/// Two different values with equal distributions stay two values: the distances to a tile's
/// edge along x and along y over a box of whole tiles have the same mean, no linear part and the
/// same spread, and their minimum is the minimum of two independent values (1/6 for two
/// uniforms on [0, 1/2]), not either one (1/4: `floor_tiles`' grout was half its mean so).
/// A value and its copy through `max` are still one value (`max(r, g) − r` is 0 where `r` wins).
#[test]
fn equal_distributions_are_not_one_value() {
    let t = tape(
        r#"Graph(
            nodes: {
                "p": Position,
                "tx": Abs(Sub(Fract(Mul(4.0, "p.x")), 0.5)),
                "ty": Abs(Sub(Fract(Mul(4.0, "p.y")), 0.5)),
                "r": Mul(0.3, "p.x"),
            },
            outputs: { "m": Min("tx", "ty"), "copy": Sub(Max("r", -10.0), "r") },
        )"#,
    );
    let p = [3.648, -0.857, -1.957];
    let footprint = Footprint::cube(0.5).unwrap();
    let got = filtered(&t, p, &footprint);
    let want = box_mean(&t, p, [0.5; 3], 30, &mut Rng(5));
    assert!(
        (got[0] - 1.0 / 6.0).abs() < 0.01 && (got[0] - want[0]).abs() < 0.01,
        "min of the two axes' distances: filtered {}, supersampled {}, exact 1/6",
        got[0],
        want[0]
    );
    assert_eq!(got[1], 0.0, "max(r, -10) - r where r wins");
}

/// Promoted (wide) instructions take the same rules: the wood grain compiled for x = 1e6 (its
/// noise promoted to f64) filters to its point value at a zero footprint and to the plain
/// tape's filtered value at a small one.
#[test]
fn promoted_instructions_filter_like_plain_ones() {
    let text =
        std::fs::read_to_string(crate::common::crate_root().join("graphs/seed004_wood_grain.ron"))
            .unwrap();
    let graph = check(
        SourceFile::new("seed004_wood_grain.ron", text),
        &CheckOptions::default(),
    )
    .unwrap();
    let far = texgraph::Extent::new([1e6, 0.0, 0.0], [1e6 + 1.0, 1.0, 1.0]);
    let promoted = compile(
        &graph,
        &CompileOptions {
            extent: Some(far),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        promoted.to_string().contains(" noise "),
        "a noise instruction"
    );
    let plain = compile(&graph, &CompileOptions::default()).unwrap();
    let p = [1e6 + 0.25, 0.3, 0.7];
    let want = point(&promoted, p);
    let got = filtered(&promoted, p, &Footprint::POINT);
    assert_eq!(got, want);
    let fp = Footprint::cube(0.01).unwrap();
    let (a, b) = (filtered(&promoted, p, &fp), filtered(&plain, p, &fp));
    for (a, b) in a.iter().zip(&b) {
        assert!((a - b).abs() < 1e-9, "promoted {a}, plain {b}");
    }
}

/// A ramp that is one line over its input's interval is that line (`filter/ranges.rs`): seed
/// 003 marble's green is 0.875 × `vein` (`|sin|`, in [0, 1]) over the vein's range, so its
/// filtered mean is 0.875 × the vein's filtered mean (within the stops' 8 digits), where the
/// ramp's clamped ends at 0 and 1 priced the spread's leak past them.
#[test]
fn a_ramp_that_is_a_line_over_its_input_is_that_line() {
    use texgraph::filter::ranges::{piecewise_inputs, Interval};
    let path = crate::common::crate_root().join("graphs/seed003_marble.ron");
    let (_, t) =
        texgraph::load_tape(&path, &CheckOptions::default(), &CompileOptions::default()).unwrap();
    let inputs: Vec<Interval> = piecewise_inputs(&t).into_iter().flatten().collect();
    assert_eq!(inputs, [Interval { lo: 0.0, hi: 1.0 }]);
    let mut rng = Rng(11);
    for side in [1.0 / 32.0, 0.125, 0.5, 3.0] {
        for _ in 0..20 {
            let p = [0; 3].map(|_| rng.range(-3.0, 3.0));
            let got = filtered(&t, p, &Footprint::cube(side).unwrap());
            let (green, vein) = (got[1], got[3]);
            assert!(
                (green - 0.875 * vein).abs() < 1e-7,
                "side {side} at {p:?}: green {green}, vein {vein}"
            );
        }
    }
}

/// `Sqrt` near 0 (library/slate's pale edges, found by its exported shader): the length of a
/// gradient that is zero over all of a box or most of it, a threshold of that length, and the
/// root of a non-negative value whose box reaches 0. The delta method's second-order terms
/// diverge as the mean nears 0: it gave such a length a variance of 1e19 and a mean of 0, and
/// the threshold 0.43–0.47 where the box's mean is 0.17 or 0.08. With the Gamma model's
/// moments (errors against 20 000 samples, before → now): the threshold 0.254 → 0.212 where
/// the length is 0 over 7/8 of the box, 0.115 → 0.027 across a bevel, 0.395 → 0.038 over four
/// sheets; exactly 0 where the gradient vanishes over the whole box.
#[test]
fn a_length_that_vanishes_over_most_of_a_box_is_filtered() {
    let t = tape(
        r#"Graph(nodes: { "p": Position,
            "bevel": Smoothstep(0.0, 0.12, Fract(Mul("p.y", 9.0))),
            "slope": Length(Gradient(of: Mul(0.4, "bevel"))) },
          outputs: { "edge": Smoothstep(0.5, 4.0, Mul(0.11111111, "slope")), "slope": "slope",
                     "root": Sqrt(Abs(Sub("p.x", 0.3))) })"#,
    );
    let mut rng = Rng(17);
    // (sheet phase at the centre, box side, the threshold's allowed error): wholly flat;
    // reaching into the bevel over an eighth of the box; across it; over several sheets.
    let cases = [
        (0.9, 1.0 / 256.0, 0.0),
        (0.97, 1.0 / 64.0, 0.22),
        (0.05, 1.0 / 64.0, 0.05),
        (0.5, 0.5, 0.05),
    ];
    for (phase, side, edge_tol) in cases {
        let p = [0.31, (2.0 + phase) / 9.0, 0.47];
        let got = filtered(&t, p, &Footprint::from_sides([side; 3]).unwrap());
        let want = box_mean(&t, p, [side; 3], 24, &mut rng);
        let at =
            format!("sheet phase {phase}, side {side}: filtered {got:?}, supersampled {want:?}");
        if phase == 0.9 {
            assert!(
                got[0] == 0.0 && got[1] < 1e-9,
                "a box within one flat sheet: {at}"
            );
        } else {
            assert!((got[0] - want[0]).abs() <= edge_tol, "edge at {at}");
            assert!(got[1] > 0.3 * want[1], "slope at {at}");
        }
        assert!((got[2] - want[2]).abs() <= 0.02 * want[2], "root at {at}");
    }
}
