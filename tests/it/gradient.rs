//! `Gradient`: the tape's exact derivatives against central differences of the f64 evaluation
//! (an independent reference: it only evaluates values), for every node kind and on random
//! graphs, away from the documented non-differentiable sets (a point is compared only where the
//! two one-sided differences agree, so kinks and jumps within the step are skipped); point =
//! batch bit for bit; f32 near f64.

use proptest::prelude::*;
use texgraph::nodes::{Lowering, CATALOGUE};
use texgraph::{check, compile, CheckOptions, CompileOptions, SourceFile, Tape, Workspace};

use crate::common;

/// Relative tolerance of the comparison, against `max(1, |reference|)`, beyond the reference's
/// own error estimate. The reference is Richardson's extrapolation of central differences with
/// steps `h = 1e-4` and `h / 2` (truncation error O(h⁴)); `|D(h) − D(h/2)|` estimates how far
/// the plain central difference is off (high octaves have large third derivatives), and is
/// allowed on top. A wrong derivative rule is off by O(1), far outside this.
const TOLERANCE: f64 = 1e-5;
const STEP: f64 = 1e-4;

/// A smooth scalar of the point, mapped into (−0.9, 0.9), and a positive one in (0.6, 2.4):
/// operands that keep every kind inside its domain.
const X: &str = r#"Mul(0.9, Sin(Add("q.x", Mul(0.5, "q.y"))))"#;
const Y: &str = r#"Mul(0.8, Cos(Sub("q.z", Mul(0.3, "q.x"))))"#;
const POSITIVE: &str = r#"Add(1.5, Mul(0.9, Sin(Add("q.y", "q.z"))))"#;

/// The graph: `p` the point, `q` a rotated and stretched copy (so every Jacobian is a full
/// matrix), the expression as output `v` and its gradient as output `g`.
fn graph(expression: &str) -> String {
    format!(
        r#"Graph(
            nodes: {{ "p": Position, "q": Scale(input: Rotate(input: "p", axis: (1.0, 2.0, 3.0), degrees: 30.0), by: (1.3, 0.7, 2.1)) }},
            outputs: {{ "v": {expression}, "g": Gradient(of: {expression}) }},
        )"#
    )
}

fn tape(source: &str) -> Tape {
    let graph = check(
        SourceFile::new("gradient.ron", source),
        &CheckOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{}\n{source}", e.render_plain()));
    compile(&graph, &CompileOptions::default()).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

fn value(tape: &Tape, ws: &mut Workspace<f64>, p: [f64; 3]) -> f64 {
    let mut out = [0.0; 4];
    tape.eval_point(ws, p, &mut out);
    out[0]
}

/// The worst relative error of the gradient against central differences over `points`, and
/// how many partial derivatives were compared (smooth points only).
fn compare(label: &str, tape: &Tape, points: &[[f64; 3]]) -> (f64, usize) {
    let mut ws = Workspace::<f64>::new();
    let mut out = [0.0; 4];
    let (mut worst, mut compared) = (0.0f64, 0);
    for p in points {
        tape.eval_point(&mut ws, *p, &mut out);
        let g = [out[1], out[2], out[3]];
        for (axis, &analytic) in g.iter().enumerate() {
            let mut f = |d: f64| {
                let mut q = *p;
                q[axis] += d;
                value(tape, &mut ws, q)
            };
            let (fm, fm2, f0, fp2, fp) = (f(-STEP), f(-STEP / 2.0), f(0.0), f(STEP / 2.0), f(STEP));
            let wide = (fp - fm) / (2.0 * STEP);
            let narrow = (fp2 - fm2) / STEP;
            let reference = (4.0 * narrow - wide) / 3.0;
            // The four half-step slopes change linearly where f is smooth (their second
            // differences are O(f''' h^2)); a kink or jump anywhere in [-h, h] breaks that.
            let s = [fm2 - fm, f0 - fm2, fp2 - f0, fp - fp2].map(|d| d / (STEP / 2.0));
            let scale = s.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            let bend = (s[0] - 2.0 * s[1] + s[2])
                .abs()
                .max((s[1] - 2.0 * s[2] + s[3]).abs());
            // Skipped: a kink or jump within the steps; a value too large to difference; a
            // slope so steep that a periodic function (Fract, Mod) could wrap within one half
            // step and alias into a smooth-looking difference.
            if !reference.is_finite()
                || bend.is_nan()
                || bend > 1e-4 * scale
                || f0.abs() > 1e6
                || analytic.abs().max(scale) * STEP > 0.25
            {
                continue;
            }
            let spread = (wide - narrow).abs();
            let error = (analytic - reference).abs() / reference.abs().max(1.0);
            assert!(
                error <= TOLERANCE + 4.0 * spread / reference.abs().max(1.0),
                "{label}: ∂/∂{} at {p:?}: tape {analytic} vs central differences {reference} (error {error:e}, spread {spread:e})",
                ["x", "y", "z"][axis]
            );
            worst = worst.max(error);
            compared += 1;
        }
    }
    (worst, compared)
}

/// Random points: mostly in [-4, 4]³, every fifth out to ±3e4 when `far`.
fn points(count: usize, seed: u64) -> Vec<[f64; 3]> {
    sample_points(count, seed, true)
}

fn sample_points(count: usize, seed: u64, far: bool) -> Vec<[f64; 3]> {
    let mut state = seed;
    let mut next = || {
        state = state.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..count)
        .map(|i| {
            // Mostly near the origin; some far out and negative (the lattice cell far from 0).
            let scale = if far && i % 5 == 4 { 3e4 } else { 4.0 };
            [0, 1, 2].map(|_| (next() * 2.0 - 1.0) * scale)
        })
        .collect()
}

/// A scalar expression exercising `kind` (its derivative rule) for every kind of the catalogue.
fn case(kind: &str, lowering: Lowering) -> String {
    let cellular = "Cellular(input: \"q\", jitter: 0.8, metric: Euclidean, value: F2MinusF1)";
    match lowering {
        Lowering::Unary(_) => match kind {
            "Sqrt" | "Log" | "Log2" => format!("{kind}({POSITIVE})"),
            _ => format!("{kind}({X})"),
        },
        Lowering::Binary(_) => match kind {
            "Pow" => format!("Pow({POSITIVE}, {Y})"),
            _ => format!("{kind}({X}, {Y})"),
        },
        Lowering::Ternary(_) => match kind {
            "Clamp" => format!("Clamp(input: {X}, min: {Y}, max: 0.5)"),
            "Select" => format!("Select({Y}, {X}, Mul({X}, {POSITIVE}))"),
            _ => format!("{kind}(Mul(0.2, {Y}), Add(1.0, {Y}), {X})"),
        },
        _ => match kind {
            "Position" => "Dot(Position, (0.3, -0.2, 0.7))".into(),
            "Combine" => format!("Dot(Combine({X}, {Y}, Mul({X}, {Y})), (1.0, 2.0, 3.0))"),
            "Scale" => format!("Length(Scale(input: \"q\", by: {X}))"),
            "Translate" => format!("Length(Translate(input: \"q\", by: {Y}))"),
            "Rotate" => format!(
                "Dot(Rotate(input: \"q\", axis: (0.0, 1.0, 1.0), degrees: Mul(40.0, {X})), (1.0, -1.0, 0.5))"
            ),
            "Noise" => "Noise(input: \"q\", basis: Perlin)".into(),
            "Fbm" => "Fbm(input: \"q\", basis: Simplex, octaves: 3.5)".into(),
            "Turbulence" => "Turbulence(input: \"q\", basis: Gradient, octaves: 3)".into(),
            "Ridged" => "Ridged(input: \"q\", basis: Perlin, octaves: 4)".into(),
            "Billow" => "Billow(input: \"q\", basis: Value(Smooth), octaves: 3)".into(),
            "Cellular" => cellular.into(),
            "WhiteNoise" => format!("Add(WhiteNoise(input: \"q\"), {X})"),
            "VecNoise" => "Dot(VecNoise(input: \"q\", basis: Perlin), (1.0, 0.5, -0.5))".into(),
            "VecFbm" => "Length(VecFbm(input: \"q\", basis: Perlin, octaves: 2))".into(),
            "Warp" => {
                "Noise(input: Warp(input: \"q\", amount: 0.3, basis: Simplex, octaves: 2), basis: Perlin)"
                    .into()
            }
            "MapRange" => format!("MapRange(input: {X}, from_min: -0.5, from_max: {POSITIVE}, to_min: 2.0, to_max: {Y})"),
            "Length" => "Length(\"q\")".into(),
            "Dot" => format!("Dot(\"q\", Combine({X}, {Y}, 1.0))"),
            "Cross" => format!("Dot(Cross(\"q\", Combine({X}, {Y}, 1.0)), (1.0, 2.0, 3.0))"),
            "Normalize" => "Dot(Normalize(\"q\"), (1.0, -2.0, 0.5))".into(),
            "Distance" => format!("Distance(\"q\", Combine({Y}, 1.0, {X}))"),
            "Gradient" => {
                // A second derivative of math (noise has none).
                format!("Dot(Gradient(of: Mul({X}, {Y})), (1.0, 0.5, 0.25))")
            }
            "Hermite" => format!("Hermite(input: Add(0.5, Mul(0.6, {X})), p0: 0.1, p1: 0.9, m0: 3.0, m1: -1.0)"),
            "ColorRamp" => format!(
                "Dot(ColorRamp(input: {X}, stops: [(-0.5, (0, 0, 1)), (0.2, (1, 0.5, 0)), (0.6, (0.2, 1, 0.3))], interpolation: Smooth), (1.0, 2.0, 3.0))"
            ),
            "Curve" => format!("Curve(input: {X}, points: [(-0.5, 1.0), (0.0, -1.0), (0.7, 2.0)])"),
            "Import" => format!(
                "Import(file: \"{}/graphs/stone.ron\", output: \"stone\", input: \"q\", set: {{ \"scale\": 1.5 }})",
                env!("CARGO_MANIFEST_DIR")
            ),
            "Luminance" => format!("Luminance(Combine({X}, {Y}, {POSITIVE}))"),
            "HsvToRgb" => format!("Luminance(HsvToRgb(Combine({X}, Add(0.5, Mul(0.4, {Y})), {POSITIVE})))"),
            "RgbToHsv" => format!(
                "Dot(RgbToHsv(Combine(Add(0.5, Mul(0.4, {X})), Add(0.5, Mul(0.3, {Y})), 0.45)), (1.0, 2.0, 3.0))"
            ),
            "Blend" => format!(
                "Luminance(Blend(base: Combine(Add(0.5, Mul(0.5, {X})), 0.3, 0.7), layer: Combine({Y}, 0.6, {X}), t: 0.8, mode: Overlay))"
            ),
            other => panic!("no gradient case for {other}: add one"),
        },
    }
}

/// Every kind of the catalogue, differentiated through the tape, against central differences.
#[test]
fn every_kind_differentiates_like_central_differences() {
    let pts = points(120, 1);
    let mut report = Vec::new();
    let mut worst_overall = 0.0f64;
    for def in CATALOGUE {
        let expression = case(def.name, def.lowering);
        let source = graph(&expression);
        assert!(
            common::kinds_used(&source).contains(def.name),
            "{}'s case does not use it",
            def.name
        );
        let t = tape(&source);
        let (worst, compared) = compare(def.name, &t, &pts);
        assert!(
            compared >= 120,
            "{}: only {compared} smooth partials compared",
            def.name
        );
        worst_overall = worst_overall.max(worst);
        report.push(format!(
            "{:<12} {compared:>4} partials, worst {worst:.1e}",
            def.name
        ));
    }
    println!(
        "{}\nworst relative error: {worst_overall:.2e}",
        report.join("\n")
    );
}

/// Every noise basis and fractal style, tiled too, and the cellular metrics and values.
#[test]
fn noise_gradients_match_central_differences() {
    let mut cases = Vec::new();
    for basis in ["Perlin", "Gradient", "Value", "Value(Smooth)", "Simplex"] {
        cases.push(format!("Noise(input: \"q\", basis: {basis}, seed: 5)"));
        for kind in ["Fbm", "Turbulence", "Ridged", "Billow"] {
            cases.push(format!(
                "{kind}(input: \"q\", basis: {basis}, octaves: 5.5)"
            ));
        }
        cases.push(format!(
            "Fbm(input: \"q\", basis: {basis}, octaves: 3, period: 6)"
        ));
    }
    for metric in ["Euclidean", "Manhattan", "Chebyshev"] {
        for value in ["F1", "F2", "F2MinusF1", "CellValue", "Edge"] {
            cases.push(format!(
                "Cellular(input: \"q\", jitter: 0.9, metric: {metric}, value: {value})"
            ));
        }
    }
    cases.push("Fbm(input: \"q\", basis: Cellular, octaves: 3)".into());
    let pts = points(80, 2);
    for expression in cases {
        let t = tape(&graph(&expression));
        let (worst, compared) = compare(&expression, &t, &pts);
        assert!(compared >= 60, "{expression}: only {compared} compared");
        println!("{expression}: worst {worst:.1e} over {compared}");
    }
}

/// Point = batch bit for bit on gradient graphs (f32 and f64), and f32 near f64.
#[test]
fn gradients_agree_point_batch_and_precision() {
    let pts = points(300, 3);
    for def in CATALOGUE {
        let t = tape(&graph(&case(def.name, def.lowering)));
        let r64 = common::point_and_batch::<f64>(&t, &pts, common::Agree::Bits)
            .unwrap_or_else(|e| panic!("{}: {e}", def.name));
        let r32 = common::point_and_batch::<f32>(&t, &pts, common::Agree::Bits)
            .unwrap_or_else(|e| panic!("{}: {e}", def.name));
        let n = pts.len();
        let mut far = 0;
        for c in 1..4 {
            // Near the origin: far out, f32 math (not noise, whose cell stays exact) loses the
            // point's fraction, values and derivatives alike.
            for i in (0..n).filter(|&i| pts[i].iter().all(|c| c.abs() <= 4.0)) {
                let (a, b) = (r32[c * n + i] as f64, r64[c * n + i]);
                if a.is_nan() && b.is_nan() {
                    continue;
                }
                // f32 interiors: about 1e-3 of the magnitude, more where a jump's side flips.
                if (a - b).abs() > 2e-3 * b.abs().max(1.0) {
                    far += 1;
                }
            }
        }
        assert!(
            far <= n / 20,
            "{}: {far} of {} f32 partials far from f64",
            def.name,
            3 * n
        );
    }
}

/// Only what feeds a Gradient is differentiated: the value outputs' instructions are unchanged.
#[test]
fn only_what_feeds_a_gradient_is_differentiated() {
    let plain = tape(
        r#"Graph(nodes: { "p": Position }, outputs: { "v": Fbm(input: "p", basis: Perlin, octaves: 8) })"#,
    );
    let with = tape(
        r#"Graph(nodes: { "p": Position, "f": Fbm(input: "p", basis: Perlin, octaves: 8) }, outputs: { "v": "f", "n": Noise(input: Scale(input: "p", by: 3.0), basis: Simplex), "g": Gradient(of: "f") })"#,
    );
    let text = with.to_string();
    assert_eq!(text.matches("gradient").count(), 1, "{text}");
    assert!(
        !text.contains("gradient noise"),
        "the Simplex noise was differentiated:\n{text}"
    );
    // Gradient of fbm(Position) is one instruction: its gradient planes are the output.
    let only = tape(
        r#"Graph(outputs: { "g": Gradient(of: Fbm(input: Position, basis: Perlin, octaves: 8)) })"#,
    );
    assert_eq!(only.instructions().len(), 2, "{only}");
    assert!(plain.instructions().len() < with.instructions().len());
}

/// A second derivative of noise is a located error.
#[test]
fn a_gradient_of_a_noise_gradient_is_an_error() {
    let source = r#"Graph(outputs: { "g": Gradient(of: Dot(Gradient(of: Noise(input: Position, basis: Perlin)), (1.0, 0.0, 0.0))) })"#;
    let errors = check(
        SourceFile::new("second.ron", source),
        &CheckOptions::default(),
    )
    .expect_err("a second derivative of noise must be refused");
    let text = errors.render_plain();
    assert!(
        text.contains("not-differentiable") && text.contains("second.ron:1:"),
        "{text}"
    );
}

/// Smooth random expressions over the math kinds and noise, with their gradients.
fn expression(depth: u32) -> BoxedStrategy<String> {
    let leaf = prop_oneof![
        (-3.0f64..3.0).prop_map(|v| format!("{v:?}")),
        Just("\"q.x\"".to_string()),
        Just("\"q.y\"".to_string()),
        Just("\"q.z\"".to_string()),
        prop::sample::select(vec!["Perlin", "Gradient", "Simplex", "Value(Smooth)"])
            .prop_map(|b| format!("Noise(input: \"q\", basis: {b})")),
        (1.0f64..5.0).prop_map(|o| format!("Fbm(input: \"q\", basis: Perlin, octaves: {o:?})")),
    ];
    if depth == 0 {
        return leaf.boxed();
    }
    let inner = expression(depth - 1);
    let safe_unary = vec!["Sin", "Cos", "Neg", "Abs", "Exp", "Fract", "Floor", "Sign"];
    prop_oneof![
        2 => leaf,
        3 => (prop::sample::select(vec!["Add", "Sub", "Mul", "Min", "Max", "Atan2", "Step"]), inner.clone(), inner.clone())
            .prop_map(|(op, a, b)| format!("{op}({a}, {b})")),
        2 => (prop::sample::select(safe_unary), inner.clone()).prop_map(|(op, a)| format!("{op}(Mul(0.3, {a}))")),
        1 => (inner.clone(), inner.clone(), inner.clone()).prop_map(|(a, b, c)| format!("Mix({a}, {b}, {c})")),
        1 => (inner.clone(), inner.clone(), inner.clone()).prop_map(|(a, b, c)| format!("Select({a}, {b}, {c})")),
        1 => (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("Smoothstep(-1.0, 1.5, Add({a}, {b}))")),
        1 => (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("Length(Combine({a}, {b}, 0.5))")),
        1 => (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("Noise(input: Warp(input: Combine({a}, {b}, \"q.z\"), amount: 0.2, basis: Perlin, octaves: 2), basis: Simplex)")),
        1 => (inner.clone(), inner).prop_map(|(a, b)| format!("Luminance(Blend(base: Combine({a}, 0.5, {b}), layer: 0.3, mode: Screen))")),
    ]
    .boxed()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn random_graphs_differentiate_like_central_differences(e in expression(3), seed in 0u64..1000) {
        let t = tape(&graph(&e));
        // Near the origin: arbitrary arithmetic far out (t = 3e4 in a Mix, then Fract) is
        // ill-conditioned for the differences themselves; the kinds' tests go far out.
        compare(&e, &t, &sample_points(12, seed, false));
        let pts = points(40, seed + 1);
        for result in [
            common::point_and_batch::<f64>(&t, &pts, common::Agree::Bits).map(|_| ()),
            common::point_and_batch::<f32>(&t, &pts, common::Agree::Bits).map(|_| ()),
        ] {
            prop_assert!(result.is_ok(), "{e}: {:?}", result);
        }
    }
}
