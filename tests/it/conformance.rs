//! Conformance: every math node, through the whole pipeline (parse → check → compile → tape →
//! interpreter), against a plain scalar reference on "spicy" inputs (0, -0, ±1, fractions,
//! tiny, huge, ±inf, NaN), per point and per batch, in f32 and f64, on scalar and vec3 operands,
//! and folded to a constant. Written once, stamped out for every operation (fidget style).

use texgraph::nodes::Lowering;
use texgraph::{check, compile, CheckOptions, CompileOptions, SourceFile, Tape};

const SPICY: [f64; 17] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    -0.5,
    2.5,
    -2.5,
    3.0,
    std::f64::consts::PI,
    1e-30,
    -1e-30,
    1e30,
    -1e30,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NAN,
];

fn tape(source: &str) -> Tape {
    let graph = check(
        SourceFile::new("conformance.ron", source),
        &CheckOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{}\n{source}", e.render_plain()));
    compile(&graph, &CompileOptions::default()).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

fn same<T: PartialEq + Copy + std::fmt::Debug>(a: T, b: T, a_nan: bool, b_nan: bool) -> bool {
    (a_nan && b_nan) || a == b
}

/// Plain references, written independently of `texgraph::ops`, for f64 and f32 alike.
macro_rules! unary_reference {
    ($t:ty, $name:expr, $x:expr) => {{
        let x: $t = $x;
        match $name {
            "Abs" => x.abs(),
            "Neg" => -x,
            "Sin" => x.sin(),
            "Cos" => x.cos(),
            "Sqrt" => x.sqrt(),
            "Floor" => x.floor(),
            "Exp" => x.exp(),
            "Log" => x.ln(),
            "Log2" => x.log2(),
            "Tan" => x.tan(),
            "Asin" => x.asin(),
            "Acos" => x.acos(),
            // GLSL sign, the zero and NaN passed through.
            "Sign" => {
                if x > 0.0 {
                    1.0
                } else if x < 0.0 {
                    -1.0
                } else {
                    x
                }
            }
            // Halves away from zero, from the truncation and the exact remainder.
            "Round" => {
                let t = if x >= 0.0 { x.floor() } else { x.ceil() };
                if (x - t).abs() >= 0.5 {
                    t + if x > 0.0 { 1.0 } else { -1.0 }
                } else {
                    t
                }
            }
            "Trunc" => {
                if x >= 0.0 {
                    x.floor()
                } else {
                    x.ceil()
                }
            }
            "Fract" => {
                let r = x - x.floor();
                if r >= 1.0 {
                    1.0 - <$t>::EPSILON / 2.0
                } else {
                    r
                }
            }
            other => panic!("no unary reference for {other}: add one here"),
        }
    }};
}

fn reference_unary(name: &str, x: f64) -> f64 {
    unary_reference!(f64, name, x)
}

fn reference_unary32(name: &str, x: f32) -> f32 {
    unary_reference!(f32, name, x)
}

macro_rules! binary_reference {
    ($name:expr, $a:expr, $b:expr) => {{
        let (a, b) = ($a, $b);
        match $name {
            "Add" => a + b,
            "Sub" => a - b,
            "Mul" => a * b,
            "Div" => a / b,
            "Min" => {
                if a.is_nan() || b.is_nan() {
                    a + b
                } else if b < a {
                    b
                } else {
                    a
                }
            }
            "Max" => {
                if a.is_nan() || b.is_nan() {
                    a + b
                } else if b > a {
                    b
                } else {
                    a
                }
            }
            "Pow" => a.powf(b),
            "Atan2" => a.atan2(b),
            "Mod" => {
                // Floored: the sign of b, the result strictly inside [0, b) (or (b, 0]).
                let r = a % b;
                if r != 0.0 && ((r < 0.0) != (b < 0.0)) {
                    if r + b == b {
                        // The largest magnitude below |b|: b scaled by 1 - epsilon/2.
                        b * (1.0 - 0.5 * epsilon_of(b))
                    } else {
                        r + b
                    }
                } else {
                    r
                }
            }
            // GLSL step(edge = a, x = b), NaN propagated.
            "Step" => {
                if a.is_nan() || b.is_nan() {
                    a + b
                } else if b < a {
                    0.0
                } else {
                    1.0
                }
            }
            other => panic!("no binary reference for {other}: add one here"),
        }
    }};
}

macro_rules! ternary_reference {
    ($name:expr, $a:expr, $b:expr, $c:expr) => {{
        let (a, b, c) = ($a, $b, $c);
        let nan = a + b + c;
        let clamp = |x, lo, hi| {
            if x != x || lo != lo || hi != hi {
                nan
            } else {
                let y = if x < lo { lo } else { x };
                if y > hi {
                    hi
                } else {
                    y
                }
            }
        };
        match $name {
            "Clamp" => clamp(a, b, c),
            "Mix" => a + c * (b - a),
            "Smoothstep" => {
                if a == b {
                    if c != c {
                        c
                    } else if c < a {
                        0.0
                    } else {
                        1.0
                    }
                } else {
                    let t = (c - a) / (b - a);
                    let t = if t != t {
                        t
                    } else if t < 0.0 {
                        0.0
                    } else if t > 1.0 {
                        1.0
                    } else {
                        t
                    };
                    t * t * (3.0 - 2.0 * t)
                }
            }
            // a > 0 chooses b; a NaN condition is not > 0.
            "Select" => {
                if a > 0.0 {
                    b
                } else {
                    c
                }
            }
            other => panic!("no ternary reference for {other}: add one here"),
        }
    }};
}

/// Machine epsilon of the operand's type (f32 or f64), for the references.
trait Epsilon {
    fn epsilon() -> Self;
}
impl Epsilon for f32 {
    fn epsilon() -> f32 {
        f32::EPSILON
    }
}
impl Epsilon for f64 {
    fn epsilon() -> f64 {
        f64::EPSILON
    }
}
fn epsilon_of<T: Epsilon>(_: T) -> T {
    T::epsilon()
}

/// The catalogue's math kinds, read from the table: a new one is tested here at once, and fails
/// until the references above know it.
use texgraph::nodes::names_where as math_kinds;

fn unary_kinds() -> Vec<&'static str> {
    math_kinds(|l| matches!(l, Lowering::Unary(_)))
}

fn binary_kinds() -> Vec<&'static str> {
    math_kinds(|l| matches!(l, Lowering::Binary(_)))
}

fn ternary_kinds() -> Vec<&'static str> {
    math_kinds(|l| matches!(l, Lowering::Ternary(_)))
}
const SHAPING: [&str; 3] = ["Hermite", "Curve", "ColorRamp"];
const NOISE: [&str; 3] = ["Noise", "Fbm", "Turbulence"];
const NOISE_FAMILIES: [&str; 7] = [
    "Ridged",
    "Billow",
    "Cellular",
    "WhiteNoise",
    "VecNoise",
    "VecFbm",
    "Warp",
];
const VECTOR: [&str; 7] = [
    "Position",
    "Combine",
    "Scale",
    "Translate",
    "Rotate",
    "Length",
    "Dot",
];

const COMPOSITION: [&str; 2] = ["Gradient", "Import"];
const COLOUR_AND_GEOMETRY: [&str; 8] = [
    "MapRange",
    "Cross",
    "Normalize",
    "Distance",
    "Luminance",
    "HsvToRgb",
    "RgbToHsv",
    "Blend",
];

use crate::common;

/// A test's graph uses every kind it claims to check.
#[track_caller]
fn assert_covers(source: &str, kinds: &[&str]) {
    let used = common::kinds_used(source);
    for kind in kinds {
        assert!(used.contains(kind), "{kind} is not in the test's graph");
    }
}

/// Every kind of the catalogue has a conformance reference in one of the tests below: a kind
/// added without one fails here.
#[test]
fn every_node_kind_has_a_conformance_reference() {
    let covered: Vec<&str> = [
        &unary_kinds()[..],
        &binary_kinds(),
        &ternary_kinds(),
        &SHAPING,
        &NOISE,
        &NOISE_FAMILIES,
        &VECTOR,
        &COLOUR_AND_GEOMETRY,
        &COMPOSITION,
    ]
    .concat();
    let missing: Vec<&str> = texgraph::nodes::CATALOGUE
        .iter()
        .map(|d| d.name)
        .filter(|name| !covered.contains(name))
        .collect();
    assert!(
        missing.is_empty(),
        "no conformance reference for {missing:?}"
    );
}

/// Vectors and domain transforms against plain formulas: Combine, Scale, Translate, Length and
/// Dot exactly (the same arithmetic in the same order), Rotate against the vector form of
/// Rodrigues' rotation, `v cos a + (k × v) sin a + k (k · v)(1 − cos a)`, within rounding.
#[test]
fn vector_and_domain_nodes_match_their_definitions() {
    let source = r#"Graph(nodes: { "p": Position }, outputs: {
            "combine": Combine("p.z", "p.x", "p.y"),
            "scale": Scale(input: "p", by: (2.0, -3.0, 0.5)),
            "translate": Translate(input: "p", by: (1.0, -2.0, 3.5)),
            "rotate": Rotate(input: "p", axis: (1.0, 2.0, -2.0), degrees: 30.0),
            "twist": Rotate(input: "p", degrees: Mul(90.0, "p.z")),
            "length": Length("p"),
            "dot": Dot("p", (1.0, -2.0, 0.25)),
        })"#;
    assert_covers(source, &VECTOR);
    let t = tape(source);
    let mut points: Vec<[f64; 3]> = Vec::new();
    for &a in &[0.0, -0.0, 1.0, -2.5, 0.125, 1e-30, 1e30, 1e200, -3.0e8] {
        for &b in &[0.5, -1.0, 7.25] {
            points.push([a, b, -a * 0.5 + b]);
        }
    }
    points.push([f64::INFINITY, 1.0, 0.0]);
    points.push([f64::NAN, 1.0, 0.0]);
    let (_, r64) = run(&t, &points);
    let n = points.len();
    let get = |channel: usize, i: usize| r64[channel * n + i];
    // Channels: combine 0..3, scale 3..6, translate 6..9, rotate 9..12, twist 12..15, length 15,
    // dot 16.
    let rodrigues = |v: [f64; 3], axis: [f64; 3], degrees: f64| -> [f64; 3] {
        let norm = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let k = axis.map(|c| c / norm);
        let (s, c) = degrees.to_radians().sin_cos();
        let cross = [
            k[1] * v[2] - k[2] * v[1],
            k[2] * v[0] - k[0] * v[2],
            k[0] * v[1] - k[1] * v[0],
        ];
        let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
        [0, 1, 2].map(|a| v[a] * c + cross[a] * s + k[a] * kv * (1.0 - c))
    };
    let close = |got: f64, want: f64, scale: f64| {
        (got.is_nan() && want.is_nan()) || got == want || (got - want).abs() <= 1e-12 * scale
    };
    for (i, p) in points.iter().enumerate() {
        let [x, y, z] = *p;
        let exact = [
            (0, z),
            (1, x),
            (2, y),
            (3, x * 2.0),
            (4, y * -3.0),
            (5, z * 0.5),
            (6, x + 1.0),
            (7, y - 2.0),
            (8, z + 3.5),
            (15, (x * x + y * y + z * z).sqrt()),
            (16, x * 1.0 + y * -2.0 + z * 0.25),
        ];
        for (channel, want) in exact {
            let got = get(channel, i);
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "channel {channel} at {p:?}: {got} vs {want}"
            );
        }
        if !p.iter().all(|c| c.is_finite()) {
            continue; // a rotated infinity is inf or NaN component by component, as IEEE says
        }
        let scale = x.abs().max(y.abs()).max(z.abs()).max(1.0);
        let rotated = rodrigues(*p, [1.0, 2.0, -2.0], 30.0);
        let twisted = rodrigues(*p, [0.0, 0.0, 1.0], 90.0 * z);
        for a in 0..3 {
            assert!(
                close(get(9 + a, i), rotated[a], scale),
                "Rotate axis (1, 2, -2) by 30 of {p:?}[{a}]: {} vs {}",
                get(9 + a, i),
                rotated[a]
            );
            // The twist angle grows with z: compare where the angle itself is exact enough.
            if (90.0 * z).abs() < 1e6 {
                assert!(
                    close(get(12 + a, i), twisted[a], scale),
                    "twist of {p:?}[{a}]: {} vs {}",
                    get(12 + a, i),
                    twisted[a]
                );
            }
        }
    }
}

/// Evaluates a tape at points, per point and per batch, in both precisions; asserts point ==
/// batch bit for bit (NaN included) and returns the f32 and f64 results.
fn run(tape: &Tape, points: &[[f64; 3]]) -> (Vec<f32>, Vec<f64>) {
    let f32s = common::point_and_batch::<f32>(tape, points, common::Agree::Bits);
    let f64s = common::point_and_batch::<f64>(tape, points, common::Agree::Bits);
    (
        f32s.unwrap_or_else(|e| panic!("{e}")),
        f64s.unwrap_or_else(|e| panic!("{e}")),
    )
}

#[test]
fn unary_nodes_match_the_scalar_reference() {
    for name in unary_kinds() {
        // Scalar operand: the x component (rounded to f32 on the fast path); vec3 operand: the
        // point itself (always f64).
        let t = tape(&format!(
            r#"Graph(nodes: {{ "p": Position }}, outputs: {{ "s": {name}("p.x"), "v": {name}("p") }})"#
        ));
        let points: Vec<[f64; 3]> = SPICY.iter().map(|&a| [a, a, -a]).collect();
        let (r32, r64) = run(&t, &points);
        let n = points.len();
        for (i, p) in points.iter().enumerate() {
            let e64 = reference_unary(name, p[0]);
            let e32 = reference_unary32(name, p[0] as f32);
            assert!(
                same(r64[i], e64, r64[i].is_nan(), e64.is_nan())
                    && (r64[i].is_nan() || r64[i].to_bits() == e64.to_bits()),
                "{name}({}) f64: {} vs {e64}",
                p[0],
                r64[i]
            );
            assert!(
                same(r32[i], e32, r32[i].is_nan(), e32.is_nan())
                    && (r32[i].is_nan() || r32[i].to_bits() == e32.to_bits()),
                "{name}({}) f32: {} vs {e32}",
                p[0],
                r32[i]
            );
            for c in 0..3 {
                let e = reference_unary(name, p[c]);
                let got = r64[(1 + c) * n + i];
                assert!(
                    same(got, e, got.is_nan(), e.is_nan()),
                    "{name} vec3[{c}]({}) f64: {got} vs {e}",
                    p[c]
                );
                let got = r32[(1 + c) * n + i];
                assert!(
                    same(got, e as f32, got.is_nan(), e.is_nan()),
                    "{name} vec3[{c}]({}) f32: {got} vs {e}",
                    p[c]
                );
            }
        }
    }
}

#[test]
fn binary_nodes_match_the_scalar_reference() {
    let mut points = Vec::new();
    for &a in &SPICY {
        for &b in &SPICY {
            points.push([a, b, 0.0]);
        }
    }
    for name in binary_kinds() {
        let t = tape(&format!(
            r#"Graph(nodes: {{ "p": Position, "q": Combine("p.y", "p.x", "p.y") }}, outputs: {{ "s": {name}("p.x", "p.y"), "v": {name}("p", "q") }})"#
        ));
        let (r32, r64) = run(&t, &points);
        let n = points.len();
        for (i, p) in points.iter().enumerate() {
            let (a, b) = (p[0], p[1]);
            let e64: f64 = binary_reference!(name, a, b);
            let e32: f32 = binary_reference!(name, a as f32, b as f32);
            assert!(
                same(r64[i], e64, r64[i].is_nan(), e64.is_nan()),
                "{name}({a}, {b}) f64: {} vs {e64}",
                r64[i]
            );
            assert!(
                same(r32[i], e32, r32[i].is_nan(), e32.is_nan()),
                "{name}({a}, {b}) f32: {} vs {e32}",
                r32[i]
            );
            // Vec3 path: component 0 is op(a, b) in f64, component 1 is op(b, a).
            let v0: f64 = binary_reference!(name, a, b);
            let v1: f64 = binary_reference!(name, b, a);
            let (g0, g1) = (r64[n + i], r64[2 * n + i]);
            assert!(
                same(g0, v0, g0.is_nan(), v0.is_nan()) && same(g1, v1, g1.is_nan(), v1.is_nan()),
                "{name} vec3 ({a}, {b})"
            );
            // On the f32 path "q" is built from f32 components, so b arrives rounded to f32.
            let v0: f64 = binary_reference!(name, a, b as f32 as f64);
            let g0 = r32[n + i];
            assert!(
                same(g0, v0 as f32, g0.is_nan(), v0.is_nan()),
                "{name} vec3 f32 ({a}, {b}): {g0} vs {v0}"
            );
        }
    }
}

#[test]
fn ternary_nodes_match_the_scalar_reference() {
    let values = [
        0.0,
        -1.0,
        0.25,
        1.0,
        2.0,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
    ];
    let mut points = Vec::new();
    for &a in &values {
        for &b in &values {
            for &c in &values {
                points.push([a, b, c]);
            }
        }
    }
    for name in ternary_kinds() {
        let t = tape(&format!(
            r#"Graph(nodes: {{ "p": Position }}, outputs: {{ "s": {name}("p.x", "p.y", "p.z"), "v": {name}("p.y", "p", "p.z") }})"#
        ));
        let (r32, r64) = run(&t, &points);
        let n = points.len();
        for (i, p) in points.iter().enumerate() {
            let e64: f64 = ternary_reference!(name, p[0], p[1], p[2]);
            let e32: f32 = ternary_reference!(name, p[0] as f32, p[1] as f32, p[2] as f32);
            assert!(
                same(r64[i], e64, r64[i].is_nan(), e64.is_nan()),
                "{name}{p:?} f64: {} vs {e64}",
                r64[i]
            );
            assert!(
                same(r32[i], e32, r32[i].is_nan(), e32.is_nan()),
                "{name}{p:?} f32: {} vs {e32}",
                r32[i]
            );
            // Vec3 path, component 1: op(p.y, p.y, p.z).
            let e: f64 = ternary_reference!(name, p[1], p[1], p[2]);
            let g = r64[2 * n + i];
            assert!(
                same(g, e, g.is_nan(), e.is_nan()),
                "{name} vec3 f64 at {p:?}: {g} vs {e}"
            );
        }
    }
}

/// A constant expression is folded at compile time (in f64); the folded value equals the f64
/// reference, and the f32 path returns it rounded once.
#[test]
fn folded_constants_equal_the_reference() {
    let literal = |v: f64| -> String {
        if v == f64::INFINITY {
            "inf".into()
        } else if v == f64::NEG_INFINITY {
            "-inf".into()
        } else {
            format!("{v:?}")
        }
    };
    let finite: Vec<f64> = SPICY.iter().copied().filter(|v| !v.is_nan()).collect();
    for name in binary_kinds() {
        for &a in &finite {
            for &b in &finite {
                let t = tape(&format!(
                    r#"Graph(outputs: {{ "s": {name}({}, {}) }})"#,
                    literal(a),
                    literal(b)
                ));
                assert!(
                    t.instructions().is_empty(),
                    "{name}({a}, {b}) was not folded"
                );
                let (r32, r64) = run(&t, &[[0.0; 3]]);
                let e: f64 = binary_reference!(name, a, b);
                assert!(
                    same(r64[0], e, r64[0].is_nan(), e.is_nan()),
                    "folded {name}({a}, {b}): {} vs {e}",
                    r64[0]
                );
                assert!(
                    same(r32[0], e as f32, r32[0].is_nan(), e.is_nan()),
                    "folded f32 {name}({a}, {b})"
                );
            }
        }
    }
    for name in unary_kinds() {
        for &a in &finite {
            let t = tape(&format!(
                r#"Graph(outputs: {{ "s": {name}({}) }})"#,
                literal(a)
            ));
            assert!(t.instructions().is_empty());
            let (_, r64) = run(&t, &[[0.0; 3]]);
            let e = reference_unary(name, a);
            assert!(
                same(r64[0], e, r64[0].is_nan(), e.is_nan()),
                "folded {name}({a})"
            );
        }
    }
}

#[test]
fn shaping_nodes_match_their_definitions() {
    let source = r#"Graph(nodes: { "p": Position }, outputs: {
            "h": Hermite(input: "p.x", p0: 0.0, p1: 1.0, m0: 1e6, m1: -1e6),
            "c": Curve(input: "p.x", points: [(0.0, 0.0), (0.5, 2.0), (0.5, -2.0), (1.0, 0.0)]),
            "r": ColorRamp(input: "p.x", stops: [(0.0, (0.0, 0.0, 0.0)), (1.0, (1.0, 0.5, 0.25))], interpolation: Smooth),
        })"#;
    assert_covers(source, &SHAPING);
    let t = tape(source);
    let xs = [
        -1.0,
        0.0,
        0.1,
        0.25,
        0.5,
        0.75,
        0.9,
        1.0,
        2.0,
        f64::NAN,
        f64::INFINITY,
    ];
    let points: Vec<[f64; 3]> = xs.iter().map(|&x| [x, 0.0, 0.0]).collect();
    let (_, r64) = run(&t, &points);
    let n = points.len();
    let hermite = texgraph::ops::Hermite {
        p0: 0.0,
        p1: 1.0,
        m0: 1e6,
        m1: -1e6,
    };
    for (i, &x) in xs.iter().enumerate() {
        let e = hermite.apply(x);
        assert!(same(r64[i], e, r64[i].is_nan(), e.is_nan()), "hermite({x})");
        // Plain Hermite basis.
        if x.is_finite() {
            let t = x.clamp(0.0, 1.0);
            let plain = (t * t * t - 2.0 * t * t + t) * 1e6
                + (-2.0 * t * t * t + 3.0 * t * t)
                + (t * t * t - t * t) * -1e6;
            assert!(
                (r64[i] - plain).abs() <= 1e-9 * plain.abs().max(1.0),
                "hermite({x}) = {} vs {plain}",
                r64[i]
            );
        }
    }
    // Curve: linear, clamped, later point wins at a coinciding knot.
    let curve: Vec<f64> = (0..n).map(|i| r64[n + i]).collect();
    for (got, want) in curve[..9]
        .iter()
        .zip([0.0, 0.0, 0.4, 1.0, -2.0, -1.0, -0.4, 0.0, 0.0])
    {
        assert!((got - want).abs() < 1e-12, "curve: {curve:?}");
    }
    assert!(curve[9].is_nan());
    assert_eq!(curve[10], 0.0);
    // Ramp, smooth: u = 0.25 → 0.15625.
    let red_at_quarter = r64[2 * n + 3];
    assert_eq!(red_at_quarter, 0.15625);
}

#[test]
fn noise_nodes_match_the_noise_library() {
    let source = r#"Graph(nodes: { "p": Position }, outputs: {
            "perlin": Noise(input: "p", basis: Perlin),
            "gradient": Noise(input: "p", basis: Gradient, seed: 7),
            "value": Noise(input: "p", basis: Value(interpolation: Smooth), seed: 3),
            "fbm": Fbm(input: "p", basis: Perlin, octaves: 4.5, lacunarity: 1.9, gain: 0.6, first_octave: 1),
            "turbulence": Turbulence(input: "p", basis: Gradient, octaves: 3.0),
        })"#;
    assert_covers(source, &NOISE);
    let t = tape(source);
    use texgraph::noise::{fractal, Basis, Interpolation, NoiseTable, Octaves};
    let perlin = NoiseTable::new(Basis::Perlin, 0);
    let gradient7 = NoiseTable::new(Basis::Gradient, 7);
    let gradient0 = NoiseTable::new(Basis::Gradient, 0);
    let value = NoiseTable::new(Basis::Value(Interpolation::Smooth), 3);
    let points: Vec<[f64; 3]> = (0..300)
        .map(|i| {
            [
                i as f64 * 0.173 - 20.0,
                (i as f64 * 0.37).sin() * 9.0,
                -(i as f64) * 0.041,
            ]
        })
        .collect();
    let (r32, r64) = run(&t, &points);
    let n = points.len();
    for (i, p) in points.iter().enumerate() {
        let expected = [
            perlin.sample::<f64>(*p),
            gradient7.sample::<f64>(*p),
            value.sample::<f64>(*p),
            fractal::<f64>(&perlin, &Octaves::new(4.5, 1.9, 0.6, 1), false, *p),
            fractal::<f64>(&gradient0, &Octaves::new(3.0, 2.0, 0.5, 0), true, *p),
        ];
        for (c, e) in expected.iter().enumerate() {
            assert_eq!(r64[c * n + i], *e, "output {c} at {p:?}");
            assert!(
                (r32[c * n + i] as f64 - e).abs() < 1e-5,
                "f32 output {c} at {p:?}"
            );
        }
    }
}

/// Cellular noise against a brute-force search in plain f64 over the 7³ cells around the point
/// (its feature points read through `NoiseTable::feature_point`): exactness of the pruned search
/// for every value and metric.
fn cellular_reference(
    table: &texgraph::noise::NoiseTable,
    metric: &str,
    value: &str,
    p: [f64; 3],
) -> f64 {
    let base = p.map(|c| c.floor() as i64);
    let mut found: Vec<(f64, [i64; 3])> = Vec::new();
    for dz in -3..=3 {
        for dy in -3..=3 {
            for dx in -3..=3 {
                let cell = [base[0] + dx, base[1] + dy, base[2] + dz];
                let q = table.feature_point(cell).unwrap();
                let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]].map(f64::abs);
                let dist = match metric {
                    "Euclidean" => (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt(),
                    "Manhattan" => d[0] + d[1] + d[2],
                    _ => d[0].max(d[1]).max(d[2]),
                };
                found.push((dist, cell));
            }
        }
    }
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (f1, f2) = (found[0].0, found[1].0);
    match value {
        "F1" => f1,
        "F2" => f2,
        "F2MinusF1" => f2 - f1,
        "Edge" => (f2 - f1) / 2.0,
        _ => table.cell_value(found[0].1).unwrap(),
    }
}

#[test]
fn noise_family_nodes_match_their_definitions() {
    let source = r#"Graph(nodes: { "p": Position }, outputs: {
            "f1": Cellular(input: "p", seed: 3),
            "f2": Cellular(input: "p", metric: Manhattan, value: F2, jitter: 0.7),
            "diff": Cellular(input: "p", metric: Chebyshev, value: F2MinusF1),
            "edge": Cellular(input: "p", value: Edge, jitter: 0.25),
            "cells": Cellular(input: "p", value: CellValue, seed: 9),
            "white": WhiteNoise(input: "p", seed: 5),
            "ridged": Ridged(input: "p", basis: Perlin, octaves: 4.5, offset: 0.9, sharpness: 3.0),
            "billow": Billow(input: "p", basis: Simplex, octaves: 3.0, gain: 0.6),
            "vecnoise": VecNoise(input: "p", basis: Gradient, seed: 4),
            "vecfbm": VecFbm(input: "p", basis: Perlin, octaves: 3.0),
            "warp": Warp(input: "p", amount: 0.75, basis: Value, octaves: 2.0),
        })"#;
    assert_covers(source, &NOISE_FAMILIES);
    let t = tape(source);
    use texgraph::noise::{
        Basis, Cellular, CellularValue, Interpolation, Metric, NoiseTable, Octaves,
    };
    let cellular = |seed, jitter, metric, value| {
        NoiseTable::new(Basis::Cellular(Cellular::new(jitter, metric, value)), seed)
    };
    let f1 = cellular(3, 1.0, Metric::Euclidean, CellularValue::F1);
    let f2 = cellular(0, 0.7, Metric::Manhattan, CellularValue::F2);
    let diff = cellular(0, 1.0, Metric::Chebyshev, CellularValue::F2MinusF1);
    let edge = cellular(0, 0.25, Metric::Euclidean, CellularValue::Edge);
    let cells = cellular(9, 1.0, Metric::Euclidean, CellularValue::CellValue);
    // White noise is the hash value of the point's integer cell (`NoiseTable::cell_value`).
    let white5 = NoiseTable::new(Basis::White, 5);
    let perlin = NoiseTable::new(Basis::Perlin, 0);
    let simplex = NoiseTable::new(Basis::Simplex, 0);
    // The vector kinds: components from seeds seed, seed + 2^53, seed + 2^54.
    let three = |basis, seed: u64| [0u64, 1, 2].map(|k| NoiseTable::new(basis, seed + (k << 53)));
    let gradient4 = three(Basis::Gradient, 4);
    let perlin0 = three(Basis::Perlin, 0);
    let value0 = three(Basis::Value(Interpolation::Linear), 0);
    let points: Vec<[f64; 3]> = (0..250)
        .map(|i| {
            [
                i as f64 * 0.173 - 20.0,
                (i as f64 * 0.37).sin() * 9.0,
                -(i as f64) * 0.041 + 0.5,
            ]
        })
        .collect();
    let (r32, r64) = run(&t, &points);
    let n = points.len();
    // Plain octave loops (not the library's fractal code).
    let octave_sum = |p: [f64; 3],
                      octaves: f64,
                      gain: f64,
                      table: &NoiseTable,
                      shape: &dyn Fn(f64, &mut f64) -> f64| {
        let schedule = Octaves::new(octaves, 2.0, gain, 0);
        let mut state = 1.0;
        let mut sum = 0.0;
        for (f, a) in schedule.frequencies.iter().zip(&schedule.amplitudes) {
            let v = table.sample::<f64>([p[0] * f, p[1] * f, p[2] * f]);
            sum += a * shape(v, &mut state);
        }
        sum
    };
    let fbm = |p: [f64; 3], octaves: f64, table: &NoiseTable| {
        octave_sum(p, octaves, 0.5, table, &|v, _| v)
    };
    for (i, &p) in points.iter().enumerate() {
        let ridged = octave_sum(p, 4.5, 0.5, &perlin, &|v, weight| {
            let signal = (0.9 - v.abs()).max(0.0).powf(3.0) * *weight;
            *weight = (2.0 * signal).clamp(0.0, 1.0);
            signal
        });
        let billow = octave_sum(p, 3.0, 0.6, &simplex, &|v, _| 2.0 * v.abs() - 1.0);
        let vf: Vec<f64> = perlin0.iter().map(|t| fbm(p, 3.0, t)).collect();
        let warp: Vec<f64> = (0..3)
            .map(|a| p[a] + 0.75 * fbm(p, 2.0, &value0[a]))
            .collect();
        let mut expected = vec![
            (cellular_reference(&f1, "Euclidean", "F1", p), 1e-12),
            (cellular_reference(&f2, "Manhattan", "F2", p), 1e-12),
            (
                cellular_reference(&diff, "Chebyshev", "F2MinusF1", p),
                1e-12,
            ),
            (cellular_reference(&edge, "Euclidean", "Edge", p), 1e-12),
            (cellular_reference(&cells, "Euclidean", "CellValue", p), 0.0),
            (white5.cell_value(p.map(|c| c.floor() as i64)).unwrap(), 0.0),
            (ridged, 1e-12),
            (billow, 1e-12),
        ];
        expected.extend(gradient4.iter().map(|t| (t.sample::<f64>(p), 0.0)));
        expected.extend(vf.iter().map(|&v| (v, 1e-12)));
        expected.extend(warp.iter().map(|&v| (v, 1e-12)));
        for (c, (e, tolerance)) in expected.iter().enumerate() {
            let got = r64[c * n + i];
            assert!(
                (got - e).abs() <= *tolerance,
                "output channel {c} at {p:?}: {got} vs {e}"
            );
            // f32 within 1e-5 of f64 (|p| <= 1e4), the cell value exactly where no tie is near.
            let got32 = r32[c * n + i] as f64;
            assert!(
                (got32 - got).abs() < 1e-5 || c == 4,
                "f32 channel {c} at {p:?}: {got32} vs {got}"
            );
        }
    }
}

/// HSV → RGB as the textbook hexcone (Smith 1978; Python's `colorsys.hsv_to_rgb`): six
/// sectors by `floor(h · 6)`, written with branches, independent of the branch-free lowering.
fn hsv_to_rgb_reference(h: f64, s: f64, v: f64) -> [f64; 3] {
    let h = h - h.floor();
    let i = (h * 6.0).floor();
    let f = h * 6.0 - i;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    match i as i32 % 6 {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

/// RGB → HSV as `colorsys.rgb_to_hsv` (hue in turns).
fn rgb_to_hsv_reference([r, g, b]: [f64; 3]) -> [f64; 3] {
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    if max == min {
        return [0.0, 0.0, max];
    }
    let c = max - min;
    let (rc, gc, bc) = ((max - r) / c, (max - g) / c, (max - b) / c);
    let h = if r == max {
        bc - gc
    } else if g == max {
        2.0 + rc - bc
    } else {
        4.0 + gc - rc
    };
    [(h / 6.0).rem_euclid(1.0), c / max, max]
}

/// The W3C Compositing and Blending Level 1 formulas (section 9.1.5), as written there, plus
/// the arithmetic modes; `cb` backdrop (base), `cs` source (layer).
fn blend_reference(mode: &str, cb: f64, cs: f64) -> f64 {
    let multiply = |cb: f64, cs: f64| cb * cs;
    let screen = |cb: f64, cs: f64| cb + cs - cb * cs;
    let hard_light = |cb: f64, cs: f64| {
        if cs <= 0.5 {
            multiply(cb, 2.0 * cs)
        } else {
            screen(cb, 2.0 * cs - 1.0)
        }
    };
    match mode {
        "Mix" => cs,
        "Multiply" => multiply(cb, cs),
        "Screen" => screen(cb, cs),
        "Overlay" => hard_light(cs, cb),
        "Add" => cb + cs,
        "Subtract" => cb - cs,
        "Difference" => (cb - cs).abs(),
        "Darken" => cb.min(cs),
        "Lighten" => cb.max(cs),
        other => panic!("no reference for blend mode {other}"),
    }
}

/// The geometry and colour kinds against independent formulas on a grid of colours and
/// vectors (channels in [0, 1] for the colour conversions, any sign for the geometry), f64 and
/// f32, point = batch bit for bit.
#[test]
fn colour_and_geometry_nodes_match_their_references() {
    let modes = texgraph::nodes::BLEND_MODES;
    let blends: Vec<String> = modes
        .iter()
        .map(|m| format!(r#""blend_{m}": Blend(base: "p", layer: "q", t: 0.75, mode: {m}),"#))
        .collect();
    let source = format!(
        r#"Graph(nodes: {{ "p": Position, "q": Combine("p.z", "p.x", "p.y") }}, outputs: {{
            "map": MapRange("p.x", -1.0, 3.0, 10.0, 20.0),
            "map_clamped": MapRange(input: "p.x", from_min: 0.25, from_max: 0.75, to_min: 1.0, to_max: -1.0, clamp: true),
            "cross": Cross("p", "q"),
            "normalize": Normalize("p"),
            "distance": Distance("p", "q"),
            "luminance": Luminance("p"),
            "hsv": HsvToRgb("p"),
            "rgb_hsv": RgbToHsv("p"),
            "round_trip": HsvToRgb(RgbToHsv("p")),
            {}
        }})"#,
        blends.join("\n")
    );
    assert_covers(&source, &COLOUR_AND_GEOMETRY);
    let t = tape(&source);
    let steps = [0.0, 0.1, 0.25, 0.5, 0.6, 0.75, 0.9, 1.0];
    let mut points: Vec<[f64; 3]> = Vec::new();
    for &a in &steps {
        for &b in &steps {
            for &c in &steps {
                points.push([a, b, c]);
            }
        }
    }
    points.extend([
        [-2.0, 3.0, 0.5],
        [1e-310, 0.0, 0.0],
        [1e200, -1e200, 0.0],
        [0.0; 3],
    ]);
    let (r32, r64) = run(&t, &points);
    let n = points.len();
    let channel = |name: &str| {
        let out = t.output(name).unwrap_or_else(|| panic!("no output {name}"));
        out.first_channel
    };
    let close = |got: f64, want: f64, tol: f64| {
        (got.is_nan() && want.is_nan())
            || got == want
            || (got - want).abs() <= tol * want.abs().max(1.0)
    };
    for (i, &[x, y, z]) in points.iter().enumerate() {
        let q = [z, x, y];
        let get = |r: &[f64], name: &str, c: usize| r[(channel(name) + c) * n + i];
        let expect = |name: &str, c: usize, want: f64, tol: f64| {
            let got = get(&r64, name, c);
            assert!(
                close(got, want, tol),
                "{name}[{c}] at {:?}: {got} vs {want}",
                [x, y, z]
            );
        };
        expect("map", 0, 10.0 + (x + 1.0) / 4.0 * 10.0, 1e-15);
        let t = ((x - 0.25) / 0.5).clamp(0.0, 1.0);
        expect("map_clamped", 0, 1.0 - 2.0 * t, 1e-15);
        let cross = [
            y * q[2] - z * q[1],
            z * q[0] - x * q[2],
            x * q[1] - y * q[0],
        ];
        let len = (x * x + y * y + z * z).sqrt();
        for (c, want) in cross.into_iter().enumerate() {
            expect("cross", c, want, 0.0);
        }
        let p = [x, y, z];
        let d = ((x - q[0]).powi(2) + (y - q[1]).powi(2) + (z - q[2]).powi(2)).sqrt();
        if x.abs() < 1e100 {
            expect("distance", 0, d, 1e-15);
        }
        if p == [0.0; 3] {
            for c in 0..3 {
                expect("normalize", c, 0.0, 0.0);
            }
        } else if len.is_finite() && len > 1e-300 {
            for (c, v) in p.into_iter().enumerate() {
                expect("normalize", c, v / len, 1e-15);
            }
        } else {
            // Beyond f64's range of |v|²: still a unit vector along the largest axis.
            let got: Vec<f64> = (0..3).map(|c| get(&r64, "normalize", c)).collect();
            let norm = got.iter().map(|g| g * g).sum::<f64>().sqrt();
            assert!((norm - 1.0).abs() < 1e-15, "normalize {p:?}: {got:?}");
        }
        expect("luminance", 0, 0.2126 * x + 0.7152 * y + 0.0722 * z, 1e-15);
        let in_unit = p.iter().all(|c| (0.0..=1.0).contains(c));
        if in_unit {
            let rgb = hsv_to_rgb_reference(x, y, z);
            let hsv = rgb_to_hsv_reference(p);
            for c in 0..3 {
                expect("hsv", c, rgb[c], 1e-12);
                expect("round_trip", c, p[c], 1e-12);
            }
            // Hue is a circle: 0.999… and 0 are neighbours.
            let h = get(&r64, "rgb_hsv", 0);
            let dh = (h - hsv[0]).abs();
            assert!(dh.min(1.0 - dh) < 1e-12, "hue of {p:?}: {h} vs {}", hsv[0]);
            expect("rgb_hsv", 1, hsv[1], 1e-12);
            expect("rgb_hsv", 2, hsv[2], 0.0);
            for m in modes {
                for c in 0..3 {
                    let want = p[c] + 0.75 * (blend_reference(m, p[c], q[c]) - p[c]);
                    expect(&format!("blend_{m}"), c, want, 1e-15);
                }
            }
            // f32: the scalar parts (RgbToHsv's components) are computed in f32.
            let got = r32[channel("round_trip") * n + i] as f64;
            assert!((got - x).abs() < 1e-5, "f32 round trip at {p:?}: {got}");
        }
    }
}

/// Select chooses whole branches and never leaks the other one; a constant condition is
/// removed by the compiler.
#[test]
fn select_chooses_branches_and_folds() {
    let t = tape(
        r#"Graph(nodes: { "p": Position }, outputs: {
            "v": Select("p.x", "p", Div(1.0, 0.0)),
            "guarded": Select("p.x", Div(1.0, "p.x"), 0.0),
        })"#,
    );
    let points = [
        [2.0, -1.0, 4.0],
        [0.0, 1.0, 1.0],
        [-0.0, 1.0, 1.0],
        [f64::NAN, 1.0, 1.0],
        [-3.0, 1.0, 1.0],
    ];
    let (_, r) = run(&t, &points);
    let n = points.len();
    assert_eq!([r[0], r[n], r[2 * n]], [2.0, -1.0, 4.0]);
    for i in 1..n {
        assert_eq!(r[i], f64::INFINITY, "point {i}");
        assert_eq!(r[3 * n + i], 0.0, "guarded at {:?}", points[i]);
    }
    assert_eq!(r[3 * n], 0.5);
    let folded = tape(
        r#"Graph(nodes: { "p": Position }, outputs: { "a": Select(1.0, "p.x", "p.y"), "b": Select(-1.0, "p.x", "p.y"), "c": Select("p.z", "p.y", "p.y") })"#,
    );
    assert!(
        folded.instructions().len() <= 3,
        "a constant condition and equal branches leave only the components:\n{folded}"
    );
}

/// Gradient against hand-derived partials (`x² y + sin z`: `(2xy, x², cos z)`) and Import
/// against the formula of the imported graph at the input with its param set (a file written
/// to a temporary folder). tests/it/gradient.rs and tests/it/imports.rs test both in depth.
#[test]
fn gradient_and_import_match_their_definitions() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(
        dir.path().join("poly.ron"),
        r#"Graph(params: { "a": 1.0 }, nodes: { "p": Position }, outputs: { "f": Add(Mul("a", Mul(Mul("p.x", "p.x"), "p.y")), Sin("p.z")) })"#,
    )
    .expect("write");
    let main = dir.path().join("main.ron");
    let source = r#"Graph(nodes: { "p": Position }, outputs: {
            "g": Gradient(of: Add(Mul(Mul("p.x", "p.x"), "p.y"), Sin("p.z"))),
            "i": Import(file: "poly.ron", output: "f", input: Scale(input: "p", by: 2.0), set: { "a": 3.0 }),
        })"#;
    assert_covers(source, &COMPOSITION);
    let graph = check(
        SourceFile::new(main.display().to_string(), source),
        &CheckOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let t = compile(&graph, &CompileOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let points: Vec<[f64; 3]> = (0..30)
        .map(|i| {
            let v = i as f64 * 0.37 - 5.0;
            [v, 1.5 - v * 0.25, v * v * 0.1]
        })
        .collect();
    let (_, r) = run(&t, &points);
    let n = points.len();
    for (i, &[x, y, z]) in points.iter().enumerate() {
        let want = [2.0 * x * y, x * x, z.cos()];
        for (c, w) in want.into_iter().enumerate() {
            let got = r[c * n + i];
            assert!(
                (got - w).abs() <= 1e-12 * w.abs().max(1.0),
                "∂{c} at {:?}: {got} vs {w}",
                [x, y, z]
            );
        }
        let (u, v, w) = (2.0 * x, 2.0 * y, 2.0 * z);
        let want = 3.0 * (u * u * v) + w.sin();
        let got = r[3 * n + i];
        assert!(
            (got - want).abs() <= 1e-12 * want.abs().max(1.0),
            "import at {:?}: {got} vs {want}",
            [x, y, z]
        );
    }
}
