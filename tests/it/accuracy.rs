//! Accuracy and cost: the error report, footprint level of detail, and the stability suite —
//! stiff parameters, extreme coordinates and non-finite inputs, each with its documented
//! behaviour (docs/accuracy.md, "Defined behaviour").

use crate::common;
use texgraph::report::{accuracy_report, ReportOptions};
use texgraph::stability::{stability_report, MAGNITUDES};
use texgraph::{
    check, compile, CheckOptions, CheckedGraph, CompileOptions, SourceFile, Tape, Workspace,
};

fn graph(source: &str) -> CheckedGraph {
    check(
        SourceFile::new("accuracy.ron", source),
        &CheckOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

fn tape(source: &str) -> Tape {
    compile(&graph(source), &CompileOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

fn eval<S: texgraph::Real>(tape: &Tape, p: [f64; 3]) -> Vec<S> {
    let mut out = vec![S::ZERO; tape.channels()];
    tape.eval_point(&mut Workspace::new(), p, &mut out);
    out
}

fn marble() -> CheckedGraph {
    let text = std::fs::read_to_string("graphs/seed003_marble.ron").expect("seed 003 marble");
    check(
        SourceFile::new("graphs/seed003_marble.ron", text),
        &CheckOptions {
            overrides: vec![("octaves".into(), 8.0)],
        },
    )
    .expect("valid")
}

fn quick() -> ReportOptions {
    ReportOptions {
        points: 3000,
        runs: 1,
        bake_sizes: vec![16, 32],
        ..ReportOptions::default()
    }
}

// ---------------------------------------------------------------- the report

#[test]
fn the_report_measures_every_strategy_against_the_reference() {
    let rows = accuracy_report(&marble(), &["vein".to_string()], &quick()).expect("report");
    let names: Vec<&str> = rows.iter().map(|r| r.strategy.as_str()).collect();
    assert!(names[0].starts_with("f64 reference"), "{names:?}");
    for wanted in [
        "f64 per point",
        "f32 per point",
        "f32 batch",
        "LOD spacing 1/64",
        "LOD spacing 1/128",
        "LOD spacing 1/256",
        "baked 16³",
        "baked 32³",
    ] {
        assert!(
            names.iter().any(|n| n.contains(wanted)),
            "no `{wanted}` row in {names:?}"
        );
    }
    let reference = &rows[0];
    assert_eq!(
        (
            reference.max_abs_error,
            reference.rms_error,
            reference.speedup
        ),
        (0.0, 0.0, 1.0)
    );
    assert_eq!(reference.psnr_db, None, "zero error is infinite PSNR");
    let f32_batch = rows
        .iter()
        .find(|r| r.strategy == "f32 batch")
        .expect("f32 batch row");
    assert!(
        f32_batch.max_abs_error > 0.0 && f32_batch.max_abs_error < 1e-4,
        "{f32_batch:?}"
    );
    assert!(f32_batch.rms_error <= f32_batch.max_abs_error);
    assert!(f32_batch.psnr_db.is_some_and(|p| p > 80.0));
    // Coarser bakes are smaller and less accurate.
    let baked: Vec<_> = rows
        .iter()
        .filter(|r| r.strategy.starts_with("baked"))
        .collect();
    assert_eq!(baked[0].memory_bytes, Some(16 * 16 * 16 * 4));
    assert_eq!(baked[1].memory_bytes, Some(32 * 32 * 32 * 4));
    assert!(baked[0].rms_error > baked[1].rms_error);
    // Per-point and batch f32 agree exactly, so their errors are equal.
    let point = rows
        .iter()
        .find(|r| r.strategy == "f32 per point")
        .expect("row");
    assert_eq!(point.max_abs_error, f32_batch.max_abs_error);
}

#[test]
fn the_report_serialises_the_documented_fields() {
    let rows = accuracy_report(&marble(), &["colour".to_string()], &quick()).expect("report");
    let json = serde_json::to_value(&rows).expect("json");
    let first = &json[0];
    for field in [
        "strategy",
        "ns_per_point",
        "speedup",
        "max_abs_error",
        "rms_error",
        "psnr_db",
        "non_finite",
    ] {
        assert!(first.get(field).is_some(), "missing {field} in {first}");
    }
    assert!(json
        .as_array()
        .expect("array")
        .iter()
        .any(|r| r.get("memory_bytes").is_some()));
}

#[test]
fn the_plot_is_a_png() {
    let rows = accuracy_report(&marble(), &["vein".to_string()], &quick()).expect("report");
    let dir = tempfile::tempdir().expect("temp");
    let path = dir.path().join("plot.png");
    texgraph::report::plot(&rows, "marble", &path).expect("plot");
    let image = common::Png::open(&path).expect("a readable png");
    assert_eq!((image.width, image.height), (1000, 640));
    assert!(
        image.rgb8().chunks_exact(3).any(|p| p != [255, 255, 255]),
        "the plot is blank"
    );
}

// ---------------------------------------------------------------- level of detail

#[test]
fn level_of_detail_drops_octaves_above_nyquist_and_counts_domain_scaling() {
    let source = |scale: f64| {
        format!(
            r#"Graph(nodes: {{ "f": Fbm(input: Scale(input: Position, by: {scale:?}), basis: Perlin, octaves: 10.0) }}, outputs: {{ "f": "f" }})"#
        )
    };
    let kept = |scale: f64, spacing: f64| {
        let t = compile(
            &graph(&source(scale)),
            &CompileOptions {
                outputs: vec![],
                spacing: Some(spacing),
                ..Default::default()
            },
        )
        .expect("compiles");
        t.fractal_octaves()[0].2
    };
    // Nyquist of spacing 1/128 is 64 = 2^6: octaves 0..=6.
    assert!((kept(1.0, 1.0 / 128.0) - 7.0).abs() < 1e-9);
    assert!(
        (kept(4.0, 1.0 / 128.0) - 5.0).abs() < 1e-9,
        "Scale by 4 is two octaves higher"
    );
    assert_eq!(kept(1.0, 1e-9), 10.0);
    // Rotation does not change frequencies.
    let rotated = r#"Graph(nodes: { "f": Fbm(input: Rotate(input: Scale(input: Position, by: 4.0), axis: (1, 2, 3), degrees: 33.0), basis: Perlin, octaves: 10.0) }, outputs: { "f": "f" })"#;
    let t = compile(
        &graph(rotated),
        &CompileOptions {
            outputs: vec![],
            spacing: Some(1.0 / 128.0),
            ..Default::default()
        },
    )
    .expect("compiles");
    assert!((t.fractal_octaves()[0].2 - 5.0).abs() < 1e-9);
}

#[test]
fn level_of_detail_fades_instead_of_popping() {
    let g = graph(
        r#"Graph(nodes: { "f": Fbm(input: Position, basis: Perlin, octaves: 10.0) }, outputs: { "f": "f" })"#,
    );
    let at = |spacing: f64| {
        let t = compile(
            &g,
            &CompileOptions {
                outputs: vec![],
                spacing: Some(spacing),
                ..Default::default()
            },
        )
        .expect("compiles");
        eval::<f64>(&t, [0.3, 0.6, 0.9])[0]
    };
    // Across the spacing where octave 6 leaves, the value moves continuously.
    let mut previous = at(1.0 / 127.0);
    for step in 1..=40 {
        let spacing = 1.0 / (127.0 - step as f64 * 0.05);
        let value = at(spacing);
        assert!(
            (value - previous).abs() < 2e-3,
            "jump {previous} -> {value} at spacing {spacing}"
        );
        previous = value;
    }
}

#[test]
fn turbulence_lod_keeps_the_mean() {
    // Dropping |noise| octaves would darken turbulence; their average is added back.
    let g = graph(
        r#"Graph(outputs: { "t": Turbulence(input: Position, basis: Perlin, octaves: 8.0) })"#,
    );
    let full = compile(&g, &CompileOptions::default()).expect("compiles");
    let lod = compile(
        &g,
        &CompileOptions {
            outputs: vec![],
            spacing: Some(1.0 / 16.0),
            ..Default::default()
        },
    )
    .expect("compiles");
    let points: Vec<[f64; 3]> = (0..4000)
        .map(|i| {
            [
                i as f64 * 0.0731,
                (i % 97) as f64 * 0.113,
                (i % 13) as f64 * 0.37,
            ]
        })
        .collect();
    let mean =
        |t: &Tape| points.iter().map(|p| eval::<f64>(t, *p)[0]).sum::<f64>() / points.len() as f64;
    let (a, b) = (mean(&full), mean(&lod));
    assert!((a - b).abs() < 0.02 * a, "mean {a} without LOD, {b} with");
}

#[test]
fn lod_is_reported_by_check() {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_texgraph"))
        .args([
            "check",
            "graphs/seed003_marble.ron",
            "--spacing",
            "0.0078125",
        ])
        .output()
        .expect("runs");
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(text.contains("7.000 of 12 octaves kept"), "{text}");
}

// ---------------------------------------------------------------- extreme coordinates

#[test]
fn noise_outputs_meet_the_f32_targets_at_every_magnitude() {
    let g = graph(
        r#"Graph(nodes: {
            "perlin": Noise(input: Position, basis: Perlin),
            "gradient": Noise(input: Position, basis: Gradient, seed: 3),
            "value": Noise(input: Position, basis: Value(Smooth), seed: 4),
            "fbm": Fbm(input: Position, basis: Perlin, octaves: 8.0),
            "turbulence": Turbulence(input: Position, basis: Gradient, octaves: 6.0),
        }, outputs: { "perlin": "perlin" })"#,
    );
    let rows = stability_report(&g, 1e-4).expect("survey");
    assert_eq!(rows.len(), 5 * MAGNITUDES.len());
    for row in &rows {
        let target = if row.magnitude <= 1e4 { 1e-5 } else { 1e-4 };
        assert!(row.max_f32_error <= target, "{row:?}");
        assert_eq!((row.non_finite_f32, row.non_finite_f64), (0, 0), "{row:?}");
        let continuity = row.continuity.expect("noise has a Lipschitz bound");
        assert!(continuity <= 1.0, "a seam: {row:?}");
    }
}

#[test]
fn huge_and_negative_coordinates_need_no_offset() {
    // Value noise on lattice points equals the table wherever the lattice point is, so the same
    // cell mod 256 gives the same value: no seam at 0, no loss at 2^31 or 1e15.
    let t = tape(r#"Graph(outputs: { "v": Noise(input: Position, basis: Value, seed: 9) })"#);
    for base in [0.0, -256.0, 2147483648.0, -2147483648.0, 1e15, -1e15] {
        let a = eval::<f64>(&t, [base + 3.0, 5.0, 7.0])[0];
        let b = eval::<f64>(&t, [3.0, 5.0, 7.0])[0];
        assert_eq!(a, b, "the lattice repeats every 256 cells (base {base})");
        let f = eval::<f32>(&t, [base + 3.0, 5.0, 7.0])[0];
        assert_eq!(f as f64, (b as f32) as f64);
    }
}

// ---------------------------------------------------------------- stiff parameters

#[test]
fn octaves_at_the_maximum_and_gain_above_one_stay_finite_and_bounded() {
    for (octaves, lacunarity, gain) in [
        (32.0f64, 2.0f64, 0.5f64),
        (32.0, 1.0001, 0.9),
        (9.0, 1000.0, 0.5),
        (16.0, 2.0, 1.5),
    ] {
        let t = tape(&format!(
            r#"Graph(outputs: {{ "f": Fbm(input: Position, basis: Perlin, octaves: {octaves:?}, lacunarity: {lacunarity:?}, gain: {gain:?}) }})"#
        ));
        let bound: f64 = (0..octaves as i32).map(|i| gain.powi(i)).sum::<f64>() * 1.04;
        for p in [[0.1, 0.2, 0.3], [123.4, -56.7, 8.9], [1e6, 2e6, -3e6]] {
            let v = eval::<f64>(&t, p)[0];
            assert!(
                v.is_finite() && v.abs() <= bound,
                "octaves {octaves} lacunarity {lacunarity} gain {gain}: {v} at {p:?}"
            );
            assert!(eval::<f32>(&t, p)[0].is_finite());
        }
    }
}

#[test]
fn octave_scales_beyond_the_limit_are_rejected_at_check_time() {
    let e = check(
        SourceFile::new("big.ron", r#"Graph(outputs: { "f": Fbm(input: Position, basis: Perlin, octaves: 32.0, lacunarity: 1000.0) })"#),
        &CheckOptions::default(),
    )
    .expect_err("1000^31 overflows");
    assert!(
        e.render_plain().contains("above the limit"),
        "{}",
        e.render_plain()
    );
}

#[test]
fn steep_hermite_slopes_and_coinciding_ramp_stops() {
    let t = tape(
        r#"Graph(nodes: { "p": Position }, outputs: {
            "h": Hermite(input: "p.x", p0: 0.0, p1: 1.0, m0: 1e6, m1: -1e6),
            "r": Curve(input: "p.x", points: [(0.0, 0.0), (0.5, 0.0), (0.5, 1.0), (1.0, 1.0)]),
        })"#,
    );
    for x in [0.0, 1e-9, 0.25, 0.5, 0.75, 1.0 - 1e-9, 1.0] {
        let out = eval::<f64>(&t, [x, 0.0, 0.0]);
        assert!(out[0].is_finite(), "hermite at {x}");
        assert!(out[0].abs() <= 1e6, "hermite at {x}: {}", out[0]);
    }
    assert_eq!(eval::<f64>(&t, [0.0, 0.0, 0.0])[0], 0.0);
    assert_eq!(eval::<f64>(&t, [1.0, 0.0, 0.0])[0], 1.0);
    // Coinciding stops: a hard edge, the later stop from the knot on.
    assert_eq!(eval::<f64>(&t, [0.5f64.next_down(), 0.0, 0.0])[1], 0.0);
    assert_eq!(eval::<f64>(&t, [0.5, 0.0, 0.0])[1], 1.0);
}

#[test]
fn very_high_sine_frequencies_stay_in_range() {
    let t = tape(
        r#"Graph(nodes: { "p": Position }, outputs: { "s": Sin(Mul(1e8, "p.x")), "c": Cos(Mul(1e12, "p.x")) })"#,
    );
    for x in [0.1, 0.123456789, 3.3, -7.77] {
        for v in eval::<f64>(&t, [x, 0.0, 0.0])
            .into_iter()
            .chain(eval::<f32>(&t, [x, 0.0, 0.0]).into_iter().map(f64::from))
        {
            assert!(v.is_finite() && v.abs() <= 1.0, "{v} at {x}");
        }
    }
    // f64 is exact to its own argument: sin(1e8 · 0.1) = sin(1e7).
    assert_eq!(eval::<f64>(&t, [0.1, 0.0, 0.0])[0], (1e8f64 * 0.1).sin());
}

#[test]
fn division_by_tiny_values_pow_sqrt_atan2_and_mod_edge_cases() {
    let t = tape(
        r#"Graph(nodes: { "p": Position }, outputs: {
            "div": Div(1.0, Mul(1e-300, "p.x")),
            "pow": Pow("p.y", 0.5),
            "sqrt": Sqrt("p.y"),
            "atan2": Atan2("p.z", "p.z"),
            "mod": Mod("p.x", "p.z"),
        })"#,
    );
    let f64s = eval::<f64>(&t, [1.0, -4.0, 0.0]);
    assert_eq!(f64s[0], 1.0 / 1e-300, "f64: 1 / 1e-300, finite");
    let f32s = eval::<f32>(&t, [1.0, -4.0, 0.0]);
    assert_eq!(
        f32s[0],
        f32::INFINITY,
        "f32: 1e-300 underflows to 0, so 1/0 = +inf (counted as non-finite)"
    );
    assert!(
        f64s[1].is_nan() && f64s[2].is_nan(),
        "pow and sqrt of a negative are NaN"
    );
    assert_eq!(f64s[3], 0.0, "atan2(0, 0) = 0");
    assert!(f64s[4].is_nan(), "mod by 0 is NaN");
}

#[test]
fn non_finite_positions_give_nan_not_panics() {
    let g = marble();
    let t = compile(&g, &CompileOptions::default()).expect("compiles");
    for p in [
        [f64::NAN, 0.0, 0.0],
        [f64::INFINITY, 1.0, 2.0],
        [0.0, f64::NEG_INFINITY, 0.0],
        [1e308, -1e308, 1e308],
    ] {
        let v = eval::<f32>(&t, p);
        let w = eval::<f64>(&t, p);
        if p.iter().any(|c| !c.is_finite()) {
            assert!(
                v.iter().all(|x| x.is_nan()) && w.iter().all(|x| x.is_nan()),
                "{p:?}: {v:?} {w:?}"
            );
        } else {
            assert_eq!(v.len(), 4);
        }
    }
}

#[test]
fn non_finite_parameters_are_defined() {
    // NaN params are rejected; infinite inputs flow through as infinities/NaN and are counted.
    assert!(check(
        SourceFile::new(
            "nan.ron",
            r#"Graph(params: { "k": NaN }, outputs: { "o": "k" })"#
        ),
        &CheckOptions::default()
    )
    .is_err());
    assert!(check(
        SourceFile::new("set.ron", r#"Graph(params: { "k": 1.0 }, outputs: { "o": Mul("k", Noise(input: Position, basis: Perlin)) })"#),
        &CheckOptions { overrides: vec![("k".into(), f64::NAN)] }
    )
    .is_err());
    let t = tape(
        r#"Graph(outputs: { "o": Noise(input: Scale(input: Position, by: inf), basis: Perlin) })"#,
    );
    assert!(
        eval::<f64>(&t, [0.5, 0.5, 0.5])[0].is_nan(),
        "an infinite point has no lattice cell"
    );
    let t = tape(r#"Graph(nodes: { "p": Position }, outputs: { "o": Mul(inf, "p.x") })"#);
    assert!(
        eval::<f64>(&t, [0.0, 0.0, 0.0])[0].is_nan(),
        "inf × 0 = NaN (IEEE)"
    );
    assert_eq!(eval::<f64>(&t, [2.0, 0.0, 0.0])[0], f64::INFINITY);
}
