//! The fuzz harness, shared by the cargo-fuzz targets (`fuzz/fuzz_targets/`) and by the corpus
//! replay test (`tests/it/main.rs` compiles this very file with `#[path]` for
//! `tests/it/fuzz_corpus.rs`, so CI replays the committed corpus on stable Rust without
//! libFuzzer).
//!
//! A panic is a finding. The invariants:
//! - [`graph_bytes`]: any bytes give either a checked graph or diagnostics that render with the
//!   file name and without Rust internals; a checked graph compiles with and without footprint
//!   level of detail; point and batch evaluation agree bit for bit, in f32 and in f64, at
//!   ordinary, lattice, huge, negative and non-finite points.
//! - [`structured_graph`]: a graph built valid by construction from the bytes (every node kind,
//!   nested, stiff constants) checks; point and batch agree bit for bit in f32 and f64 at points
//!   drawn from the bytes; noise of a scaled, rotated, translated position stays within the
//!   accuracy issue's bound of f64 in f32 (|p| ≤ 1e4); filtered at a footprint drawn from the
//!   bytes, finite wherever the point value is (refused footprints with a message), batch =
//!   point bit for bit.
//! - [`scene_bytes`]: any bytes as a render input (a scene file, or a graph previewed on the
//!   default stage) next to the seed graphs: it loads, or fails with messages that name a file
//!   and show no Rust internals; what loads renders (8×6 pixels, one sample) without a panic.

use arbitrary::{Result, Unstructured};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use texgraph::nodes::Lowering;
use texgraph::{check, compile, CheckOptions, CompileOptions, Real, SourceFile, Tape, Workspace};

const FILE: &str = "fuzz.ron";

/// The project's `graphs/` folder, for `Import` (this file is compiled in the fuzz crate and,
/// by path, in the main crate's tests: its manifest folder differs).
fn graphs_dir() -> String {
    let manifest = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = [manifest.join("graphs"), manifest.join("../graphs")]
        .into_iter()
        .find(|d| d.join("cells.ron").is_file())
        .unwrap_or_else(|| manifest.join("graphs"));
    dir.display().to_string()
}

/// Points every checked graph of [`graph_bytes`] is evaluated at.
const FIXED_POINTS: [[f64; 3]; 12] = [
    [0.0, 0.0, 0.0],
    [0.25, 0.5, 0.75],
    [-1.5, 2.25, -3.125],
    [3.0, -4.0, 5.0],
    [-0.0, 1.0, -1.0],
    [1e6 + 0.37, -1e6 - 0.61, 2.0e6],
    [2_147_483_648.5, -2_147_483_647.25, 0.5],
    [1e300, -1e300, 1e-300],
    [f64::NAN, 0.5, 0.5],
    [f64::INFINITY, 0.0, 1.0],
    [0.5, f64::NEG_INFINITY, 0.5],
    [f64::MIN_POSITIVE, -f64::MIN_POSITIVE, 1e-320],
];

/// Parse → check → compile → evaluate arbitrary bytes (read as UTF-8, invalid sequences
/// replaced, as a text editor would show them).
pub fn graph_bytes(data: &[u8]) {
    let text = String::from_utf8_lossy(data).into_owned();
    match check(
        SourceFile::new(FILE, text.clone()),
        &CheckOptions::default(),
    ) {
        Err(diagnostics) => {
            assert!(
                !diagnostics.list.is_empty(),
                "rejected without a diagnostic"
            );
            let rendered = diagnostics.render_plain();
            assert!(
                rendered.contains(FILE),
                "a diagnostic without the file name:\n{rendered}"
            );
            no_internals(&rendered, &text);
        }
        Ok(graph) => {
            let mut batch: Vec<[f64; 3]> = FIXED_POINTS.to_vec();
            // A batch longer than one chunk of lanes, so chunk boundaries are crossed too.
            batch.extend((0..300).map(|i| {
                let t = i as f64;
                [t * 0.37 - 50.0, (t * 0.11).sin() * 7.0, -t * 0.029]
            }));
            for spacing in [None, Some(1.0 / 64.0)] {
                // The level-of-detail run also chooses precision for every coordinate.
                let options = CompileOptions {
                    outputs: Vec::new(),
                    spacing,
                    extent: spacing.map(|_| texgraph::Extent::unbounded()),
                    max_error: None,
                };
                let tape = compile(&graph, &options).expect("a checked graph compiles");
                point_and_batch_agree::<f32>(&tape, &batch);
                point_and_batch_agree::<f64>(&tape, &batch);
            }
        }
    }
}

/// A message shows no Rust internals (a type path, a Debug-printed value, a panic) unless the
/// input itself contains the text (messages quote and show the input). The markers are ones
/// that quoting the input cannot produce: `Some   (` in a file is quoted as `Some(...)`.
fn no_internals(rendered: &str, input: &str) {
    let markers = [
        "texgraph::",
        "panicked at",
        "called `Option::unwrap()`",
        "called `Result::unwrap()`",
        "Diagnostic {",
        "Span {",
        "Error {",
    ];
    for internal in markers {
        assert!(
            input.contains(internal) || !rendered.contains(internal),
            "a message shows `{internal}`:\n{rendered}"
        );
    }
}

/// Any bytes as `texgraph render`'s input file, in a copy of `graphs/` (so scenes can refer to
/// the seed graphs as `"../seed003_marble.ron"`, as the committed scenes do).
pub fn scene_bytes(data: &[u8]) {
    use texgraph::render::{load_input, render, PreviewDefaults, RenderOptions};
    let path = scene_path();
    std::fs::write(path, data).expect("the fuzz scene file can be written");
    match load_input(path, &PreviewDefaults::default()) {
        Err(e) => {
            let rendered = e.render(false);
            assert!(
                rendered.contains(".ron") || rendered.contains(".obj"),
                "a render error without a file name:\n{rendered}"
            );
            no_internals(&rendered, &String::from_utf8_lossy(data));
        }
        Ok(scene) => {
            let options = RenderOptions {
                size: Some((8, 6)),
                samples: Some(1),
                threads: Some(1),
                // Level of detail per pixel (the default) sees every hostile scene too.
                ..Default::default()
            };
            // Errors (a mesh that cannot be read, say) are fine; panics are not.
            let _ = render(&scene, &options);
        }
    }
}

/// `<temp>/graphs/scenes/fuzz.ron`, with the repository's graph files copied to `<temp>/graphs/`
/// once per process.
fn scene_path() -> &'static Path {
    static PATH: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    let (_, path) = PATH.get_or_init(|| {
        // This file is compiled by the fuzz crate (manifest in fuzz/) and by the replay test
        // (manifest at the root).
        let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
        let root = if manifest.ends_with("fuzz") {
            manifest.parent().expect("fuzz/ has a parent")
        } else {
            manifest
        };
        let dir = tempfile::tempdir().expect("a temporary folder");
        let graphs = dir.path().join("graphs");
        std::fs::create_dir_all(graphs.join("scenes")).expect("folders");
        for entry in std::fs::read_dir(root.join("graphs")).expect("graphs/") {
            let entry = entry.expect("a graphs/ entry");
            if entry.path().extension().is_some_and(|e| e == "ron") {
                std::fs::copy(entry.path(), graphs.join(entry.file_name())).expect("a copy");
            }
        }
        let path = graphs.join("scenes").join("fuzz.ron");
        (dir, path)
    });
    path
}

/// A graph valid by construction, drawn from the bytes, and its invariants.
pub fn structured_graph(data: &[u8]) {
    let mut u = Unstructured::new(data);
    // The bytes that run out early just make the rest of the draws zero: still a valid graph.
    let Ok(mode) = u.int_in_range(0u8..=3) else {
        return;
    };
    if mode == 0 {
        transformed_noise_stays_near_f64(&mut u);
    } else {
        random_graph_agrees(&mut u);
    }
}

/// A graph valid by construction, as text, drawn from the bytes (`None` when they run out).
pub fn random_graph_text(u: &mut Unstructured) -> Option<String> {
    let mut gen = Generator { depth_left: 4 };
    let (Ok(a), Ok(b), Ok(k)) = (gen.scalar(u), gen.vec3(u), finite(u)) else {
        return None;
    };
    Some(format!(
        r#"Graph(
    params: {{ "k": {k:?} }},
    nodes: {{
        "p": Position,
        "q": Scale(input: Position, by: (1.0, -2.0, 0.5)),
        "a": {a},
    }},
    outputs: {{ "a": "a", "b": {b} }},
)"#
    ))
}

fn random_graph_agrees(u: &mut Unstructured) {
    let Some(text) = random_graph_text(u) else {
        return;
    };
    let graph = match check(
        SourceFile::new(FILE, text.clone()),
        &CheckOptions::default(),
    ) {
        Ok(graph) => graph,
        // The generator cannot know whether a Gradient reaches a noise gradient.
        Err(e) if e.render_plain().contains("not-differentiable") => return,
        Err(e) => panic!(
            "a graph valid by construction was rejected:\n{text}\n{}",
            e.render_plain()
        ),
    };
    let points = points(u);
    for spacing in [None, Some(1.0 / 128.0)] {
        let options = CompileOptions {
            outputs: Vec::new(),
            spacing,
            extent: spacing.map(|_| texgraph::Extent::unbounded()),
            max_error: None,
        };
        let tape = compile(&graph, &options).expect("a checked graph compiles");
        point_and_batch_agree::<f32>(&tape, &points);
        point_and_batch_agree::<f64>(&tape, &points);
        if spacing.is_none() {
            filtered_is_finite(u, &tape, &points, &text);
        }
    }
}

/// The filtered form (issue 33) at a footprint drawn from the bytes (a point, tiny, ordinary,
/// huge or anisotropic; NaN, infinite and negative sides must be refused with a message):
/// finite wherever the point value is, and the batch equal to the point evaluation bit for bit.
fn filtered_is_finite(u: &mut Unstructured, tape: &Tape, points: &[[f64; 3]], text: &str) {
    use texgraph::filter::{Filtered, Footprint};
    let Ok(kind) = u.int_in_range(0u8..=5) else {
        return;
    };
    let side = |u: &mut Unstructured| -> Result<f64> {
        Ok(match u.int_in_range(0u8..=3)? {
            0 => 0.0,
            1 => in_range(u, 1e-12, 1e-6)?,
            2 => in_range(u, 1e-3, 4.0)?,
            _ => in_range(u, 1e3, 1e9)?,
        })
    };
    let footprint = match kind {
        0 => {
            let bad = [f64::NAN, f64::INFINITY, -1.0][u.choose_index(3).unwrap_or(0)];
            let e = Footprint::from_sides([bad, 0.5, 0.5]).expect_err("a refused side");
            assert!(e.to_string().contains("side x"), "{e}");
            return;
        }
        1 | 2 => {
            let edge = |u: &mut Unstructured| -> Result<[f64; 3]> {
                Ok([
                    in_range(u, -2.0, 2.0)?,
                    in_range(u, -2.0, 2.0)?,
                    in_range(u, -2.0, 2.0)?,
                ])
            };
            let (Ok(a), Ok(b)) = (edge(u), edge(u)) else {
                return;
            };
            Footprint::from_edges([a, b, [0.0; 3]]).expect("finite edges")
        }
        _ => {
            let (Ok(x), Ok(y), Ok(z)) = (side(u), side(u), side(u)) else {
                return;
            };
            Footprint::from_sides([x, y, z]).expect("valid sides")
        }
    };
    let filtered = Filtered::new(tape);
    let channels = tape.channels();
    let finite: Vec<[f64; 3]> = points
        .iter()
        .copied()
        .filter(|p| p.iter().all(|c| c.is_finite()))
        .collect();
    let n = finite.len();
    let [x, y, z] = [0, 1, 2].map(|c| finite.iter().map(|p| p[c]).collect::<Vec<f64>>());
    let mut batch = vec![0f64; channels * n];
    filtered.eval_batch([&x, &y, &z], &[footprint], &mut batch);
    for (i, p) in finite.iter().enumerate() {
        let mut exact = vec![0f64; channels];
        tape.eval_point(&mut Workspace::new(), *p, &mut exact);
        let mut value = vec![0f64; channels];
        filtered.eval_point(*p, &footprint, &mut value);
        for c in 0..channels {
            let (v, b) = (value[c], batch[c * n + i]);
            assert!(
                v.to_bits() == b.to_bits() || (v.is_nan() && b.is_nan()),
                "filtered batch {b} vs point {v} at {p:?}\n{text}"
            );
            assert!(
                !exact[c].is_finite() || v.is_finite(),
                "filtered {v} where the point value is {} at {p:?} over {footprint:?}\n{text}",
                exact[c]
            );
        }
    }
}

/// docs/accuracy.md: noise in f32 within 1e-5 of f64 (per unit of octave amplitude) below
/// |p| = 1e4, whatever scale, rotation and translation put the point there.
fn transformed_noise_stays_near_f64(u: &mut Unstructured) {
    let draw = |u: &mut Unstructured| -> Result<(f64, f64, f64, f64, usize, f64)> {
        Ok((
            in_range(u, 0.01, 50.0)?,
            in_range(u, -360.0, 360.0)?,
            in_range(u, -1000.0, 1000.0)?,
            in_range(u, 0.0, 10.0)?,
            u.choose_index(3)?,
            in_range(u, -1.0, 1.0)?,
        ))
    };
    let Ok((scale, degrees, shift, octaves, basis, gain)) = draw(u) else {
        return;
    };
    let basis = ["Perlin", "Gradient", "Value"][basis];
    let text = format!(
        r#"Graph(outputs: {{ "n": Fbm(input: Translate(input: Rotate(input: Scale(input: Position, by: {scale:?}), axis: (1, 1, 0), degrees: {degrees:?}), by: {shift:?}), basis: {basis}, octaves: {octaves:?}, gain: {gain:?}) }})"#
    );
    let graph = match check(
        SourceFile::new(FILE, text.clone()),
        &CheckOptions::default(),
    ) {
        Ok(graph) => graph,
        Err(e) => panic!("a valid graph was rejected:\n{text}\n{}", e.render_plain()),
    };
    let tape = compile(&graph, &CompileOptions::default()).expect("compiles");
    // Sum of the octave amplitudes: the error bound scales with it.
    let amplitude: f64 = (0..octaves.ceil() as i32).map(|i| gain.abs().powi(i)).sum();
    let bound = 1e-5 * amplitude.max(1.0);
    let (mut w32, mut w64) = (Workspace::<f32>::new(), Workspace::<f64>::new());
    for _ in 0..16 {
        let (Ok(x), Ok(y), Ok(z)) = (
            in_range(u, -1e4, 1e4),
            in_range(u, -1e4, 1e4),
            in_range(u, -1e4, 1e4),
        ) else {
            return;
        };
        let p = [x, y, z];
        let (mut a, mut b) = ([0f32], [0f64]);
        tape.eval_point(&mut w32, p, &mut a);
        tape.eval_point(&mut w64, p, &mut b);
        // Where the transformed point leaves |p| ≤ 1e4 the bound does not apply.
        if p.iter().any(|c| (c * scale).abs() + shift.abs() > 1e4) {
            continue;
        }
        let error = (a[0] as f64 - b[0]).abs();
        assert!(
            error <= bound,
            "f32 {} vs f64 {} (error {error:e} > {bound:e}) at {p:?}\n{text}",
            a[0],
            b[0]
        );
    }
}

/// Point and batch evaluation give the same bits (any NaN matches any NaN).
fn point_and_batch_agree<S: Real>(tape: &Tape, points: &[[f64; 3]]) {
    let n = points.len();
    let channels = tape.channels();
    let x: Vec<f64> = points.iter().map(|p| p[0]).collect();
    let y: Vec<f64> = points.iter().map(|p| p[1]).collect();
    let z: Vec<f64> = points.iter().map(|p| p[2]).collect();
    let mut batch = vec![S::ZERO; channels * n];
    let mut workspace = Workspace::<S>::new();
    tape.eval_batch(&mut workspace, &x, &y, &z, &mut batch);
    let mut single = vec![S::ZERO; channels];
    for (i, &p) in points.iter().enumerate() {
        tape.eval_point(&mut workspace, p, &mut single);
        for c in 0..channels {
            // Widening f32 to f64 is exact, so comparing the f64 bits compares the f32 bits.
            let (u, v) = (single[c].to_f64(), batch[c * n + i].to_f64());
            assert!(
                u.to_bits() == v.to_bits() || (u.is_nan() && v.is_nan()),
                "{}: point {u:e} vs batch {v:e}, channel {c}, at {p:?}",
                S::NAME
            );
        }
    }
}

/// 1 to 300 points: ordinary, lattice, huge, tiny and non-finite coordinates.
fn points(u: &mut Unstructured) -> Vec<[f64; 3]> {
    let n = match u.int_in_range(0u8..=9) {
        Ok(9) => 257 + u.int_in_range(0usize..=43).unwrap_or(0),
        _ => 1 + u.int_in_range(0usize..=31).unwrap_or(0),
    };
    (0..n)
        .map(|_| {
            [
                coordinate(u).unwrap_or(0.5),
                coordinate(u).unwrap_or(-0.5),
                coordinate(u).unwrap_or(0.25),
            ]
        })
        .collect()
}

fn coordinate(u: &mut Unstructured) -> Result<f64> {
    Ok(match u.int_in_range(0u8..=15)? {
        0..=7 => in_range(u, -10.0, 10.0)?,
        8 | 9 => in_range(u, -1e9, 1e9)?,
        10 => u.int_in_range(-100i32..=100)? as f64,
        11 => f64::NAN,
        12 => *u.choose(&[f64::INFINITY, f64::NEG_INFINITY])?,
        13 => -0.0,
        14 => *u.choose(&[1e300, -1e300, 2_147_483_648.0, 1e-310])?,
        _ => f64::from_bits(u.arbitrary()?),
    })
}

/// A number in [lo, hi] from 32 bits of input.
fn in_range(u: &mut Unstructured, lo: f64, hi: f64) -> Result<f64> {
    let t = u.arbitrary::<u32>()? as f64 / u32::MAX as f64;
    Ok(lo + (hi - lo) * t)
}

/// A finite literal: ordinary, stiff, or any finite bit pattern.
fn finite(u: &mut Unstructured) -> Result<f64> {
    Ok(match u.int_in_range(0u8..=7)? {
        0..=4 => in_range(u, -1000.0, 1000.0)?,
        5 => *u.choose(&[
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            1e-30,
            1e30,
            1e-300,
            f64::MAX,
            f64::MIN_POSITIVE,
        ])?,
        6 => u.int_in_range(-8i32..=8)? as f64,
        _ => {
            let v = f64::from_bits(u.arbitrary()?);
            if v.is_finite() {
                v
            } else {
                0.0
            }
        }
    })
}

/// Writes random expressions as graph text, every node kind reachable. Once `depth_left` is
/// used up, only leaves are drawn, so the text stays small.
struct Generator {
    depth_left: u32,
}

/// The catalogue's kinds that lower to a unary (binary) math operation, in catalogue order: the
/// generator iterates the table, so a new math kind is generated without touching this file.
fn unary_kinds() -> &'static [&'static str] {
    static KINDS: OnceLock<Vec<&'static str>> = OnceLock::new();
    KINDS.get_or_init(|| texgraph::nodes::names_where(|l| matches!(l, Lowering::Unary(_))))
}

fn binary_kinds() -> &'static [&'static str] {
    static KINDS: OnceLock<Vec<&'static str>> = OnceLock::new();
    KINDS.get_or_init(|| texgraph::nodes::names_where(|l| matches!(l, Lowering::Binary(_))))
}

impl Generator {
    fn nested<T>(&mut self, f: impl FnOnce(&mut Self) -> Result<T>) -> Result<T> {
        self.depth_left -= 1;
        let result = f(self);
        self.depth_left += 1;
        result
    }

    fn scalar(&mut self, u: &mut Unstructured) -> Result<String> {
        let leaf_only = self.depth_left == 0;
        let choice = if leaf_only {
            0
        } else {
            u.int_in_range(0u8..=15)?
        };
        match choice {
            0..=3 => self.scalar_leaf(u),
            4 => self.nested(|g| {
                let op = u.choose(binary_kinds())?;
                Ok(format!("{op}({}, {})", g.scalar(u)?, g.scalar(u)?))
            }),
            5 => self.nested(|g| {
                let op = u.choose(unary_kinds())?;
                Ok(format!("{op}({})", g.scalar(u)?))
            }),
            6 => self.nested(|g| {
                let (a, b, c) = (g.scalar(u)?, g.scalar(u)?, g.scalar(u)?);
                Ok(match u.int_in_range(0u8..=5)? {
                    0 => format!("Clamp(input: {a}, min: {b}, max: {c})"),
                    1 => format!("Clamp({a})"),
                    2 => format!("Mix({a}, {b}, {c})"),
                    3 => format!("Select({a}, {b}, {c})"),
                    4 => {
                        let (d, e) = (g.scalar(u)?, g.scalar(u)?);
                        let clamp = u.arbitrary::<bool>()?;
                        format!("MapRange(input: {a}, from_min: {b}, from_max: {c}, to_min: {d}, to_max: {e}, clamp: {clamp})")
                    }
                    _ => format!("Smoothstep({a}, {b}, {c})"),
                })
            }),
            7 => self.nested(|g| {
                let x = g.scalar(u)?;
                let (p0, p1) = (finite(u)?, finite(u)?);
                let (m0, m1) = (in_range(u, -1e6, 1e6)?, in_range(u, -1e6, 1e6)?);
                Ok(format!("Hermite(input: {x}, p0: {p0:?}, p1: {p1:?}, m0: {m0:?}, m1: {m1:?})"))
            }),
            8 => self.nested(|g| {
                let x = g.scalar(u)?;
                let count = u.int_in_range(1usize..=6)?;
                let mut points = Vec::with_capacity(count);
                for _ in 0..count {
                    points.push((in_range(u, -2.0, 2.0)?, finite(u)?));
                }
                points.sort_by(|a, b| a.0.total_cmp(&b.0));
                let points: Vec<String> = points.iter().map(|(t, v)| format!("({t:?}, {v:?})")).collect();
                let interpolation = u.choose(&["Linear", "Smooth", "Constant"])?;
                Ok(format!("Curve(input: {x}, points: [{}], interpolation: {interpolation})", points.join(", ")))
            }),
            9 | 10 => self.nested(|g| {
                let v = g.vec3(u)?;
                let kind = u.choose(&["Fbm", "Turbulence", "Ridged", "Billow"])?;
                let (basis, interpolation) = basis(u)?;
                let seed = u.int_in_range(0u64..=(1 << 53) - 1)?;
                let octaves = in_range(u, 0.0, 12.0)?;
                let lacunarity = in_range(u, 1.0001, 6.0)?;
                let gain = in_range(u, -1.5, 1.5)?;
                let first = u.int_in_range(0u32..=3)?;
                Ok(format!("{kind}(input: {v}, basis: {basis}, seed: {seed}, octaves: {octaves:?}, lacunarity: {lacunarity:?}, gain: {gain:?}, first_octave: {first}{interpolation})"))
            }),
            11 => self.nested(|g| {
                let v = g.vec3(u)?;
                let (basis, interpolation) = basis(u)?;
                let seed = u.int_in_range(0u64..=1000)?;
                Ok(match u.int_in_range(0u8..=2)? {
                    0 => format!("Noise(input: {v}, basis: {basis}, seed: {seed}{interpolation})"),
                    1 => {
                        let jitter = in_range(u, 0.0, 1.0)?;
                        let metric = u.choose(&["Euclidean", "Manhattan", "Chebyshev"])?;
                        let value = u.choose(&["F1", "F2", "F2MinusF1", "CellValue", "Edge"])?;
                        format!("Cellular(input: {v}, seed: {seed}, jitter: {jitter:?}, metric: {metric}, value: {value})")
                    }
                    _ => format!("WhiteNoise(input: {v}, seed: {seed})"),
                })
            }),
            12 => self.nested(|g| {
                Ok(if u.ratio(1u8, 4u8)? {
                    format!("Dot(Gradient(of: {}), (0.25, -1.0, 0.5))", g.scalar(u)?)
                } else {
                    format!("Length({})", g.vec3(u)?)
                })
            }),
            13 => self.nested(|g| {
                let (a, b) = (g.vec3(u)?, g.vec3(u)?);
                Ok(match u.int_in_range(0u8..=3)? {
                    0 => format!("Dot({a}, {b})"),
                    1 => format!("Distance({a}, {b})"),
                    2 => {
                        let (file, output) =
                            *u.choose(&[("cells.ron", "cells"), ("stone.ron", "stone")])?;
                        let scale = in_range(u, 0.5, 8.0)?;
                        format!(
                            "Import(file: \"{}/{file}\", output: \"{output}\", input: {a}, set: {{ \"scale\": {scale:?} }})",
                            graphs_dir()
                        )
                    }
                    _ => format!("Luminance({a})"),
                })
            }),
            14 => self.nested(|g| {
                // A component of a vec3 expression, through a reference or a nested node.
                Ok(format!("Dot({}, (0.0, 1.0, 0.0))", g.vec3(u)?))
            }),
            _ => Ok(u.choose(&["\"q.y\"", "\"p.z\"", "\"k\""])?.to_string()),
        }
    }

    fn scalar_leaf(&mut self, u: &mut Unstructured) -> Result<String> {
        Ok(match u.int_in_range(0u8..=5)? {
            0 | 1 => format!("{:?}", finite(u)?),
            2 => u
                .choose(&["\"p.x\"", "\"p.y\"", "\"p.z\"", "\"q.x\""])?
                .to_string(),
            3 => "\"k\"".to_string(),
            4 => {
                let (basis, interpolation) = basis(u)?;
                format!("Noise(input: \"p\", basis: {basis}{interpolation})")
            }
            _ => format!("Mul(\"k\", {:?})", finite(u)?),
        })
    }

    fn vec3(&mut self, u: &mut Unstructured) -> Result<String> {
        let leaf_only = self.depth_left == 0;
        let choice = if leaf_only {
            0
        } else {
            u.int_in_range(0u8..=14)?
        };
        match choice {
            0..=2 => Ok(u
                .choose(&["\"p\"", "Position", "\"q\"", "(0.5, -1.0, 2.0)"])?
                .to_string()),
            3 => self.nested(|g| {
                let v = g.vec3(u)?;
                Ok(match u.int_in_range(0u8..=2)? {
                    0 => format!("Scale(input: {v}, by: {:?})", in_range(u, -100.0, 100.0)?),
                    1 => format!(
                        "Scale(input: {v}, by: ({:?}, {:?}, {:?}))",
                        finite(u)?,
                        finite(u)?,
                        finite(u)?
                    ),
                    _ => format!("Scale(input: {v}, by: {})", g.scalar(u)?),
                })
            }),
            4 => self.nested(|g| {
                Ok(format!(
                    "Translate(input: {}, by: {})",
                    g.vec3(u)?,
                    g.scalar(u)?
                ))
            }),
            5 => self.nested(|g| {
                let (v, d) = (g.vec3(u)?, g.scalar(u)?);
                let axis = [
                    in_range(u, -1.0, 1.0)?,
                    in_range(u, -1.0, 1.0)?,
                    in_range(u, 0.1, 1.0)?,
                ];
                Ok(format!(
                    "Rotate(input: {v}, axis: ({:?}, {:?}, {:?}), degrees: {d})",
                    axis[0], axis[1], axis[2]
                ))
            }),
            6 => self.nested(|g| {
                Ok(format!(
                    "Combine({}, {}, {})",
                    g.scalar(u)?,
                    g.scalar(u)?,
                    g.scalar(u)?
                ))
            }),
            7 => self.nested(|g| {
                let op = u.choose(binary_kinds())?;
                // Mixed operands broadcast the scalar.
                let b = if u.arbitrary()? {
                    g.vec3(u)?
                } else {
                    g.scalar(u)?
                };
                Ok(format!("{op}({}, {b})", g.vec3(u)?))
            }),
            8 => self.nested(|g| {
                let op = u.choose(unary_kinds())?;
                Ok(format!("{op}({})", g.vec3(u)?))
            }),
            11 => self.nested(|g| {
                let v = g.vec3(u)?;
                let (basis, extra) = basis(u)?;
                let octaves = in_range(u, 0.0, 6.0)?;
                Ok(if u.arbitrary()? {
                    format!("VecNoise(input: {v}, basis: {basis}{extra})")
                } else {
                    format!("VecFbm(input: {v}, basis: {basis}, octaves: {octaves:?}{extra})")
                })
            }),
            12 => self.nested(|g| {
                let (v, amount) = (g.vec3(u)?, g.scalar(u)?);
                let (basis, extra) = basis(u)?;
                let octaves = in_range(u, 0.0, 6.0)?;
                Ok(format!(
                    "Warp(input: {v}, amount: {amount}, basis: {basis}, octaves: {octaves:?}{extra})"
                ))
            }),
            9 => self.nested(|g| {
                let (a, b, c) = (g.vec3(u)?, g.vec3(u)?, g.scalar(u)?);
                Ok(match u.int_in_range(0u8..=8)? {
                    0 => format!("Clamp(input: {a}, min: {c}, max: {b})"),
                    1 => format!("Mix({a}, {b}, {c})"),
                    2 => format!("Select({c}, {a}, {b})"),
                    3 => format!("Cross({a}, {b})"),
                    4 => format!("Normalize({a})"),
                    5 => format!("HsvToRgb({a})"),
                    6 => format!("RgbToHsv({a})"),
                    7 => {
                        let mode = u.choose(texgraph::nodes::BLEND_MODES)?;
                        format!("Blend(base: {a}, layer: {b}, t: {c}, mode: {mode})")
                    }
                    _ => format!("Smoothstep({c}, {b}, {a})"),
                })
            }),
            _ => self.nested(|g| {
                let x = g.scalar(u)?;
                let count = u.int_in_range(1usize..=8)?;
                let mut stops = Vec::with_capacity(count);
                for _ in 0..count {
                    let t = if u.ratio(1u8, 4u8)? {
                        stops.last().map_or(0.0, |s: &(f64, [f64; 3])| s.0) // coinciding stops: a hard edge
                    } else {
                        in_range(u, -1.0, 2.0)?
                    };
                    stops.push((
                        t,
                        [in_range(u, 0.0, 1.0)?, finite(u)?, in_range(u, -1.0, 2.0)?],
                    ));
                }
                stops.sort_by(|a, b| a.0.total_cmp(&b.0));
                let stops: Vec<String> = stops
                    .iter()
                    .map(|(t, c)| format!("({t:?}, ({:?}, {:?}, {:?}))", c[0], c[1], c[2]))
                    .collect();
                let interpolation = u.choose(&["Linear", "Smooth", "Constant"])?;
                Ok(format!(
                    "ColorRamp(input: {x}, stops: [{}], interpolation: {interpolation})",
                    stops.join(", ")
                ))
            }),
        }
    }
}

/// A noise basis and, for Value and Cellular, sometimes their own arguments (with a leading
/// comma).
fn basis(u: &mut Unstructured) -> Result<(&'static str, &'static str)> {
    Ok(match u.int_in_range(0u8..=7)? {
        0 => ("Perlin", ""),
        1 => ("Gradient", ""),
        2 => ("Value", ""),
        3 => ("Value", ", interpolation: Smooth"),
        4 => ("Simplex", ""),
        5 => ("Cellular", ""),
        6 => ("Cellular", ", jitter: 0.3, metric: Chebyshev, value: Edge"),
        _ => ("Cellular(metric: Manhattan, value: CellValue)", ""),
    })
}
