//! `Import`: an imported output is the imported graph with `Position` replaced by `input` and
//! its params set — checked against the same expression written inline (bit for bit, f32 and
//! f64, on random graphs); one file imported twice with the same arguments is built once;
//! imports nest 32 deep and no deeper; `check` lists the imported files. The error cases
//! (cycles, missing files, unknown outputs and params, a problem inside an imported file) are
//! error goldens in tests/errors/import_*.ron.

use proptest::prelude::*;
use std::path::Path;
use texgraph::{check, compile, CheckOptions, CompileOptions, SourceFile, Tape};

use crate::common;

fn write(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).expect("write a test graph");
}

fn tape_of(path: &Path) -> Result<Tape, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    let graph = check(
        SourceFile::new(path.display().to_string(), text),
        &CheckOptions::default(),
    )
    .map_err(|e| e.render_plain())?;
    compile(&graph, &CompileOptions::default()).map_err(|e| e.render_plain())
}

fn points() -> Vec<[f64; 3]> {
    let mut pts = Vec::new();
    for i in 0..40 {
        let t = i as f64 * 0.731 - 9.0;
        pts.push([
            t,
            (t * 1.7).sin() * 5.0,
            t * -0.3 + 1e3 * ((i % 7) as f64 - 3.0),
        ]);
    }
    pts
}

/// Both tapes give the same bits at every point, in f32 and f64 (point and batch agreeing).
fn same_bits(a: &Tape, b: &Tape) -> Result<(), String> {
    let pts = points();
    let a64 = common::point_and_batch::<f64>(a, &pts, common::Agree::Bits)?;
    let b64 = common::point_and_batch::<f64>(b, &pts, common::Agree::Bits)?;
    let a32 = common::point_and_batch::<f32>(a, &pts, common::Agree::Bits)?;
    let b32 = common::point_and_batch::<f32>(b, &pts, common::Agree::Bits)?;
    let same64 = a64
        .iter()
        .zip(&b64)
        .all(|(x, y)| x.to_bits() == y.to_bits());
    let same32 = a32
        .iter()
        .zip(&b32)
        .all(|(x, y)| x.to_bits() == y.to_bits());
    if same64 && same32 && a64.len() == b64.len() {
        Ok(())
    } else {
        Err("the imported output differs from the inline expression".into())
    }
}

#[test]
fn an_import_is_its_graph_at_the_input_with_its_params_set() {
    let dir = tempfile::tempdir().expect("temp dir");
    write(
        dir.path(),
        "wood.ron",
        r#"Graph(
            params: { "rings": 12.0, "wobble": 0.2 },
            nodes: { "p": Position, "r": Add(Length(Combine("p.x", "p.y", 0.0)), Mul("wobble", Noise(input: "p", basis: Perlin))) },
            outputs: { "grain": Fract(Mul("r", "rings")), "colour": Mix((0.4, 0.25, 0.1), (0.8, 0.6, 0.35), Fract(Mul("r", "rings"))) },
        )"#,
    );
    std::fs::create_dir(dir.path().join("floors")).expect("subfolder");
    write(
        &dir.path().join("floors"),
        "floor.ron",
        r#"Graph(
            params: { "base": 10.0 },
            nodes: { "w": Warp(input: Scale(input: Position, by: 2.0), amount: 0.3, basis: Simplex, octaves: 2) },
            outputs: { "c": Import(file: "../wood.ron", output: "colour", input: "w", set: { "rings": Mul("base", 3.0) }) },
        )"#,
    );
    write(
        dir.path(),
        "inline.ron",
        r#"Graph(
            params: { "rings": 30.0, "wobble": 0.2 },
            nodes: { "p": Warp(input: Scale(input: Position, by: 2.0), amount: 0.3, basis: Simplex, octaves: 2), "r": Add(Length(Combine("p.x", "p.y", 0.0)), Mul("wobble", Noise(input: "p", basis: Perlin))) },
            outputs: { "c": Mix((0.4, 0.25, 0.1), (0.8, 0.6, 0.35), Fract(Mul("r", "rings"))) },
        )"#,
    );
    let imported = tape_of(&dir.path().join("floors/floor.ron")).unwrap_or_else(|e| panic!("{e}"));
    let inline = tape_of(&dir.path().join("inline.ron")).unwrap_or_else(|e| panic!("{e}"));
    same_bits(&imported, &inline).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(imported.instructions().len(), inline.instructions().len());
}

#[test]
fn one_file_imported_twice_with_the_same_arguments_is_built_once() {
    let dir = tempfile::tempdir().expect("temp dir");
    write(
        dir.path(),
        "marble.ron",
        r#"Graph(params: { "k": 3.0 }, outputs: { "vein": Abs(Sin(Mul("k", Fbm(input: Position, basis: Perlin, octaves: 6)))) })"#,
    );
    write(
        dir.path(),
        "one.ron",
        r#"Graph(outputs: { "v": Import(file: "marble.ron", output: "vein") })"#,
    );
    // The same import twice (once through a param equal to the default), and a third with
    // another `set`: two marbles are built, not three.
    write(
        dir.path(),
        "three.ron",
        r#"Graph(params: { "three": 3.0 }, outputs: {
            "a": Import(file: "marble.ron", output: "vein"),
            "b": Import(file: "./marble.ron", output: "vein", input: Position, set: { "k": "three" }),
            "c": Import(file: "marble.ron", output: "vein", set: { "k": 5.0 }),
        })"#,
    );
    let one = tape_of(&dir.path().join("one.ron")).unwrap_or_else(|e| panic!("{e}"));
    let three = tape_of(&dir.path().join("three.ron")).unwrap_or_else(|e| panic!("{e}"));
    let fractals = |t: &Tape| t.to_string().matches(" fbm ").count();
    assert_eq!(fractals(&one), 1);
    // k only scales the shared fbm: one fbm serves all three outputs.
    assert_eq!(fractals(&three), 1, "{three}");
    assert!(three.instructions().len() < 3 * one.instructions().len());
}

#[test]
fn imports_nest_thirty_two_deep_and_no_deeper() {
    let dir = tempfile::tempdir().expect("temp dir");
    let chain = |depth: usize| {
        // level0.ron imports level1.ron ... level{depth}.ron, which is a plain graph.
        for i in 0..depth {
            write(
                dir.path(),
                &format!("level{i}.ron"),
                &format!(
                    r#"Graph(outputs: {{ "v": Add(1.0, Import(file: "level{}.ron", output: "v")) }})"#,
                    i + 1
                ),
            );
        }
        write(
            dir.path(),
            &format!("level{depth}.ron"),
            r#"Graph(outputs: { "v": Position.x })"#.replace("Position.x", "Length(Position)").as_str(),
        );
        tape_of(&dir.path().join("level0.ron"))
    };
    let ok = chain(32).unwrap_or_else(|e| panic!("32 levels must import: {e}"));
    let mut out = [0.0f64];
    ok.eval_point(&mut texgraph::Workspace::new(), [3.0, 4.0, 0.0], &mut out);
    assert_eq!(out[0], 5.0 + 32.0);
    let too_deep = chain(33).expect_err("33 levels are one too many");
    assert!(
        too_deep.contains("error[limit]") && too_deep.contains("more than 32 deep"),
        "{too_deep}"
    );
}

#[test]
fn check_lists_the_imported_files() {
    let dir = tempfile::tempdir().expect("temp dir");
    write(
        dir.path(),
        "leaf.ron",
        r#"Graph(outputs: { "v": Length(Position) })"#,
    );
    write(
        dir.path(),
        "mid.ron",
        r#"Graph(outputs: { "v": Import(file: "leaf.ron", output: "v") })"#,
    );
    write(
        dir.path(),
        "top.ron",
        r#"Graph(outputs: { "v": Import(file: "mid.ron", output: "v") })"#,
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_texgraph"))
        .arg("check")
        .arg(dir.path().join("top.ron"))
        .output()
        .expect("run texgraph");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("imports:"))
        .unwrap_or_else(|| panic!("{text}"));
    assert!(
        line.contains("mid.ron") && line.contains("leaf.ron"),
        "{line}"
    );
}

/// A random scalar expression over the point `p` and the param `k`.
fn expression(depth: u32) -> BoxedStrategy<String> {
    let leaf = prop_oneof![
        (-4.0f64..4.0).prop_map(|v| format!("{v:?}")),
        Just("\"p.x\"".to_string()),
        Just("\"p.y\"".to_string()),
        Just("\"p.z\"".to_string()),
        Just("\"k\"".to_string()),
        prop::sample::select(vec!["Perlin", "Simplex", "Value", "Cellular"])
            .prop_map(|b| format!("Noise(input: \"p\", basis: {b})")),
        (0.0f64..4.0).prop_map(|o| format!(
            "Fbm(input: Scale(input: \"p\", by: \"k\"), basis: Perlin, octaves: {o:?})"
        )),
    ];
    if depth == 0 {
        return leaf.boxed();
    }
    let inner = expression(depth - 1);
    prop_oneof![
        2 => leaf,
        3 => (prop::sample::select(texgraph::nodes::names_where(|l| matches!(l, texgraph::nodes::Lowering::Binary(_)))), inner.clone(), inner.clone())
            .prop_map(|(op, a, b)| format!("{op}({a}, {b})")),
        2 => (prop::sample::select(texgraph::nodes::names_where(|l| matches!(l, texgraph::nodes::Lowering::Unary(_)))), inner.clone())
            .prop_map(|(op, a)| format!("{op}({a})")),
        1 => (inner.clone(), inner.clone(), inner.clone()).prop_map(|(a, b, c)| format!("Select({a}, {b}, {c})")),
        1 => (inner.clone(), inner).prop_map(|(a, b)| format!("Dot(Gradient(of: {a}), Combine({b}, 1.0, -0.5))")),
    ]
    .boxed()
}

fn input() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("Position".to_string()),
        (-3.0f64..3.0).prop_map(|s| format!("Scale(input: Position, by: {s:?})")),
        Just("Warp(input: Position, amount: 0.4, basis: Perlin, octaves: 2)".to_string()),
        Just(
            "Rotate(input: Position, axis: (1.0, 1.0, 0.0), degrees: Mul(20.0, Position.z))"
                .replace("Position.z", "Noise(input: Position, basis: Simplex)")
        ),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Random graphs with imports (and gradients inside them): the import equals the inline
    /// expression with `p` the input and `k` the value set, bit for bit.
    #[test]
    fn random_imports_equal_their_inline_expressions(e in expression(3), w in input(), k in -3.0f64..3.0) {
        let dir = tempfile::tempdir().expect("temp dir");
        write(dir.path(), "inner.ron", &format!(
            r#"Graph(params: {{ "k": 1.0 }}, nodes: {{ "p": Position }}, outputs: {{ "v": {e} }})"#
        ));
        write(dir.path(), "outer.ron", &format!(
            r#"Graph(params: {{ "kk": {k:?} }}, outputs: {{ "v": Import(file: "inner.ron", output: "v", input: {w}, set: {{ "k": "kk" }}) }})"#
        ));
        write(dir.path(), "inline.ron", &format!(
            r#"Graph(params: {{ "k": {k:?} }}, nodes: {{ "p": {w} }}, outputs: {{ "v": {e} }})"#
        ));
        let inline = tape_of(&dir.path().join("inline.ron"));
        let outer = tape_of(&dir.path().join("outer.ron"));
        // A Gradient inside the imported graph is taken with respect to that graph's Position,
        // the input (the imported graph evaluated at the input), where the inline expression's
        // is with respect to the outer point: they agree only for the identity input.
        if e.contains("Gradient") && w != "Position" {
            if let Ok(t) = outer {
                let pts = points();
                prop_assert!(common::point_and_batch::<f64>(&t, &pts, common::Agree::Bits).is_ok());
            }
            return Ok(());
        }
        match (inline, outer) {
            (Ok(a), Ok(b)) => prop_assert!(same_bits(&a, &b).is_ok(), "{e} at {w}"),
            // Both refuse the same expression (a second derivative of noise, a limit).
            (Err(a), Err(b)) => {
                let class = |t: &str| t.split(']').next().unwrap_or("").to_string();
                prop_assert_eq!(class(&a), class(&b));
            }
            (a, b) => prop_assert!(false, "inline {:?} vs import {:?}", a.err(), b.err()),
        }
    }
}
