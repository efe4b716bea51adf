//! Golden tests for every graph in `graphs/` and `graphs/library/`.
//!
//! Each graph is evaluated on a fixed sample set — a 32×32 slice of the unit cube at z = 0.5
//! (voxel centres) plus scattered points (negative, large, on lattice points and cell
//! boundaries) — in f64 (the reference path) and in f32 (the fast path), and compared with the
//! committed `tests/golden/NAME.txt`:
//! - f64 values within 1e-9 absolute (room for last-bit differences of the platform's libm
//!   sin/cos/pow/atan2; the noise itself is exactly reproducible),
//! - f32 values within 1e-5 absolute (the same, for f32's libm).
//!
//! A 64×64 PNG of the same slice, `tests/golden/NAME.png`, shows a reviewer the texture (first
//! vec3 output, else the first output as grey clamped to [0, 1]); it is compared pixel by pixel,
//! within 1 of 255.
//!
//! `tests/golden/NAME.tape` is the graph's tape disassembly (`texgraph check --tape`), compared
//! exactly.
//!
//! Re-bless after an intended change: `TEXGRAPH_BLESS=1 cargo test --test it golden::`, then review
//! the diff (`git diff tests/golden`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use texgraph::output::RgbImage;
use texgraph::{check, compile, CheckOptions, CompileOptions, SourceFile, Tape, Type, Workspace};

const F64_TOLERANCE: f64 = 1e-9;
const F32_TOLERANCE: f64 = 1e-5;
const SLICE: usize = 32;
const PICTURE: usize = 64;

use crate::common;
use common::blessing as bless;

/// The folders of graphs with goldens: the seed and noise-family graphs and the material
/// library (`tests/golden/library/` holds the library's).
const GRAPH_FOLDERS: [&str; 2] = ["graphs", "graphs/library"];

fn graph_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = GRAPH_FOLDERS
        .iter()
        .filter_map(|folder| std::fs::read_dir(folder).ok())
        .flatten()
        .map(|e| e.expect("readable entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    files.sort();
    files
}

/// A graph's golden name: its path under `graphs/` without the extension (`cells`,
/// `library/granite`).
fn stem_of(path: &Path) -> String {
    let relative = path.strip_prefix("graphs").unwrap_or(path);
    relative
        .with_extension("")
        .to_str()
        .expect("utf-8 file name")
        .replace('\\', "/")
}

fn load(path: &Path) -> Tape {
    let text = std::fs::read_to_string(path).expect("readable graph");
    let file = SourceFile::new(path.display().to_string(), text);
    let graph =
        check(file, &CheckOptions::default()).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    compile(&graph, &CompileOptions::default()).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

/// The fixed sample set: slice points, then scattered points (3.14 is Perlin's reference point,
/// not π).
#[allow(clippy::approx_constant)]
fn sample_points() -> Vec<[f64; 3]> {
    let mut points = Vec::new();
    for j in 0..SLICE {
        for i in 0..SLICE {
            points.push([
                (i as f64 + 0.5) / SLICE as f64,
                (j as f64 + 0.5) / SLICE as f64,
                0.5,
            ]);
        }
    }
    points.extend([
        [0.0, 0.0, 0.0],
        [1.0, 2.0, 3.0],
        [-1.0, -2.0, -3.0],
        [0.5, -0.25, 0.125],
        [-0.3, 0.7, -1.9],
        [3.0, 3.0, 3.0],
        [-4.2, 10.0, 6.0],
        [3.14, 42.0, 7.0],
        [12.75, -7.5, 0.001],
        [100.5, 200.25, -300.125],
        [-1234.567, 890.123, 4567.891],
        [1.0e4 + 0.3, -1.0e4 - 0.7, 0.5],
    ]);
    // A deterministic scatter (SplitMix64) over [-8, 8)³.
    let mut state: u64 = 0x5EED;
    let mut next = || {
        state = state.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 16.0 - 8.0
    };
    for _ in 0..20 {
        points.push([next(), next(), next()]);
    }
    points
}

fn evaluate<S: texgraph::Real>(tape: &Tape, points: &[[f64; 3]]) -> Vec<S> {
    // Per point and per batch, bit for bit: a golden is only as good as both paths agreeing.
    common::point_and_batch(tape, points, common::Agree::Bits).unwrap_or_else(|e| panic!("{e}"))
}

/// The golden text: one line per point and precision, channels in output order.
fn golden_text(path: &Path, tape: &Tape, points: &[[f64; 3]]) -> String {
    let f64s = evaluate::<f64>(tape, points);
    let f32s = evaluate::<f32>(tape, points);
    let n = points.len();
    let mut text = String::new();
    let outputs: Vec<String> = tape
        .outputs()
        .iter()
        .map(|o| format!("{} ({})", o.name, o.ty))
        .collect();
    let _ = writeln!(
        text,
        "# golden values of {}; outputs: {}",
        path.display(),
        outputs.join(", ")
    );
    let _ = writeln!(
        text,
        "# each point: `p x y z`, then `f64` and `f32` lines with every output channel in order"
    );
    let _ = writeln!(
        text,
        "# re-bless: TEXGRAPH_BLESS=1 cargo test --test it golden::"
    );
    for (i, p) in points.iter().enumerate() {
        let _ = writeln!(text, "p {} {} {}", p[0], p[1], p[2]);
        let channels = tape.channels();
        let line64: Vec<String> = (0..channels).map(|c| f64s[c * n + i].to_string()).collect();
        let line32: Vec<String> = (0..channels).map(|c| f32s[c * n + i].to_string()).collect();
        let _ = writeln!(text, "f64 {}", line64.join(" "));
        let _ = writeln!(text, "f32 {}", line32.join(" "));
    }
    text
}

fn numbers(line: &str) -> Vec<f64> {
    line.split_whitespace()
        .skip(1)
        .map(|s| s.parse::<f64>().unwrap_or(f64::NAN))
        .collect()
}

fn same(a: f64, b: f64, tolerance: f64) -> bool {
    (a.is_nan() && b.is_nan()) || a == b || (a - b).abs() <= tolerance
}

/// Compares actual and expected golden text; returns the first mismatches.
fn compare(expected: &str, actual: &str) -> Vec<String> {
    let mut problems = Vec::new();
    let (e, a): (Vec<&str>, Vec<&str>) = (expected.lines().collect(), actual.lines().collect());
    if e.len() != a.len() {
        problems.push(format!("{} lines expected, {} produced", e.len(), a.len()));
        return problems;
    }
    let mut point = "";
    for (le, la) in e.iter().zip(&a) {
        if le.starts_with('#') {
            continue;
        }
        if le.starts_with("p ") {
            point = le;
            if le != la {
                problems.push(format!("sample point changed: `{le}` vs `{la}`"));
            }
            continue;
        }
        let tolerance = if le.starts_with("f64") {
            F64_TOLERANCE
        } else {
            F32_TOLERANCE
        };
        let (ve, va) = (numbers(le), numbers(la));
        if ve.len() != va.len() || ve.iter().zip(&va).any(|(x, y)| !same(*x, *y, tolerance)) {
            problems.push(format!("at {point}: expected `{le}`, got `{la}`"));
        }
        if problems.len() >= 5 {
            break;
        }
    }
    problems
}

/// 8-bit RGB picture of the slice: the first vec3 output, or the first output as grey.
fn picture(tape: &Tape) -> RgbImage {
    let mut points = Vec::with_capacity(PICTURE * PICTURE);
    for j in 0..PICTURE {
        for i in 0..PICTURE {
            // Row 0 at the top shows y = 1 (y up).
            points.push([
                (i as f64 + 0.5) / PICTURE as f64,
                1.0 - (j as f64 + 0.5) / PICTURE as f64,
                0.5,
            ]);
        }
    }
    let values = evaluate::<f32>(tape, &points);
    let n = points.len();
    let output = tape
        .outputs()
        .iter()
        .find(|o| o.ty == Type::Vec3)
        .unwrap_or(&tape.outputs()[0]);
    let to_byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8; // NaN clamps to NaN → 0
    let channel = |c: usize, k: usize| {
        to_byte(values[(output.first_channel + c.min(output.ty.channels() - 1)) * n + k])
    };
    let bytes = (0..n).flat_map(|k| (0..3).map(move |c| (c, k)));
    let bytes = bytes.map(|(c, k)| channel(c, k)).collect();
    RgbImage::from_raw(PICTURE as u32, PICTURE as u32, bytes).expect("PICTURE² pixels")
}

#[test]
fn every_seed_graph_matches_its_golden_values_and_picture() {
    let files = graph_files();
    assert!(
        files.len() >= 20,
        "expected the seed library in graphs/, found {} files",
        files.len()
    );
    let points = sample_points();
    let mut failures = Vec::new();
    std::fs::create_dir_all("tests/golden/library").expect("tests/golden is writable");
    for path in &files {
        let stem = stem_of(path);
        let tape = load(path);
        let text = golden_text(path, &tape, &points);
        let values_path = PathBuf::from(format!("tests/golden/{stem}.txt"));
        let picture_path = PathBuf::from(format!("tests/golden/{stem}.png"));
        let image = picture(&tape);
        if bless() {
            std::fs::write(&values_path, &text).expect("write golden");
            std::fs::write(&picture_path, image.encode_png()).expect("write golden picture");
            eprintln!(
                "blessed {} and {}",
                values_path.display(),
                picture_path.display()
            );
            continue;
        }
        match std::fs::read_to_string(&values_path) {
            Ok(expected) => {
                for problem in compare(&expected, &text) {
                    failures.push(format!("{}: {problem}", values_path.display()));
                }
            }
            Err(_) => failures.push(format!(
                "{} is missing: run TEXGRAPH_BLESS=1 cargo test --test it golden::",
                values_path.display()
            )),
        }
        match common::Png::open(&picture_path) {
            Ok(expected) => {
                let differs = expected.dimensions() != image.dimensions()
                    || expected
                        .rgb8()
                        .iter()
                        .zip(image.as_raw())
                        .any(|(x, y)| x.abs_diff(*y) > 1);
                if differs {
                    failures.push(format!("{}: picture differs", picture_path.display()));
                }
            }
            Err(_) => failures.push(format!(
                "{} is missing: run TEXGRAPH_BLESS=1 cargo test --test it golden::",
                picture_path.display()
            )),
        }
    }
    assert!(
        failures.is_empty(),
        "golden mismatches:\n{}",
        failures.join("\n")
    );
}

/// The tape disassembly of every graph, `tests/golden/NAME.tape`, compared exactly: the
/// disassembly is a golden format, so a change to checking, folding, deduplication, pruning,
/// instruction selection or slot allocation shows up as a reviewable diff.
#[test]
fn every_seed_graph_compiles_to_its_golden_tape() {
    let mut failures = Vec::new();
    for path in &graph_files() {
        let stem = stem_of(path);
        let text = load(path).to_string();
        let tape_path = PathBuf::from(format!("tests/golden/{stem}.tape"));
        if bless() {
            std::fs::write(&tape_path, &text).expect("write golden tape");
            continue;
        }
        match std::fs::read_to_string(&tape_path) {
            Ok(expected) if expected == text => {}
            Ok(expected) => {
                let line = expected
                    .lines()
                    .zip(text.lines())
                    .position(|(a, b)| a != b)
                    .unwrap_or(expected.lines().count().min(text.lines().count()));
                failures.push(format!(
                    "{}: differs from line {}:\n  golden: {}\n  now:    {}",
                    tape_path.display(),
                    line + 1,
                    expected.lines().nth(line).unwrap_or("(end)"),
                    text.lines().nth(line).unwrap_or("(end)")
                ));
            }
            Err(_) => failures.push(format!(
                "{} is missing: run TEXGRAPH_BLESS=1 cargo test --test it golden::",
                tape_path.display()
            )),
        }
    }
    assert!(
        failures.is_empty(),
        "tape mismatches:\n{}",
        failures.join("\n")
    );
}

#[test]
fn no_golden_file_is_orphaned() {
    let stems: Vec<String> = graph_files().iter().map(|p| stem_of(p)).collect();
    for folder in ["tests/golden", "tests/golden/library"] {
        let Ok(entries) = std::fs::read_dir(folder) else {
            continue;
        };
        for entry in entries {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                continue;
            }
            let relative = path
                .strip_prefix("tests/golden")
                .expect("under tests/golden");
            let stem = relative
                .with_extension("")
                .to_str()
                .unwrap_or_default()
                .replace('\\', "/");
            assert!(
                stems.contains(&stem),
                "{} has no graph in graphs/; delete it",
                path.display()
            );
        }
    }
}

#[test]
fn point_and_batch_evaluation_agree_bit_for_bit_on_every_graph() {
    let points = sample_points();
    for path in graph_files() {
        let tape = load(&path);
        let batch32 = evaluate::<f32>(&tape, &points);
        let batch64 = evaluate::<f64>(&tape, &points);
        let (mut ws32, mut ws64) = (Workspace::<f32>::new(), Workspace::<f64>::new());
        let n = points.len();
        for (i, p) in points.iter().enumerate() {
            let mut out32 = vec![0f32; tape.channels()];
            let mut out64 = vec![0f64; tape.channels()];
            tape.eval_point(&mut ws32, *p, &mut out32);
            tape.eval_point(&mut ws64, *p, &mut out64);
            for c in 0..tape.channels() {
                assert_eq!(
                    out32[c].to_bits(),
                    batch32[c * n + i].to_bits(),
                    "{} f32 at {p:?} channel {c}",
                    path.display()
                );
                assert_eq!(
                    out64[c].to_bits(),
                    batch64[c * n + i].to_bits(),
                    "{} f64 at {p:?} channel {c}",
                    path.display()
                );
            }
        }
    }
}

#[test]
fn every_seed_graph_is_valid_ron_for_the_ron_crate_too() {
    // Our reader keeps spans; the files must still be plain RON for other tools.
    for path in graph_files() {
        let text = std::fs::read_to_string(&path).expect("readable");
        let parsed: Result<ron::Value, _> = ron::from_str(&text);
        assert!(parsed.is_ok(), "{}: {:?}", path.display(), parsed.err());
    }
}

/// The slots a disassembly line names: the one left of `=` (written) and those right of it
/// (read), each as (file prefix, slot), in order; words that are no slot (operations, bases,
/// numbers, side-table text) are skipped.
fn line_slots(line: &str) -> ((char, u32), Vec<(char, u32)>) {
    let slot = |word: &str| -> Option<(char, u32)> {
        // `degrees=s3` names a slot; `v2.x` is one; `s3,` ends a list item.
        let word = word.rsplit('=').next()?.trim_end_matches(',');
        let word = word.split('.').next()?;
        let file = word
            .chars()
            .next()
            .filter(|c| matches!(c, 's' | 'd' | 'v'))?;
        let digits = &word[1..];
        let all_digits = !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit());
        all_digits.then(|| (file, digits.parse().expect("a slot number")))
    };
    let (left, right) = line.split_once(" = ").expect("an assignment");
    let written = slot(left.trim()).expect("a written slot");
    let read = right.split([' ', '(', '[']).filter_map(slot).collect();
    (written, read)
}

/// `Instr::reads` and `Instr::writes` — what the compiler's check, the filtered form's walks
/// and the shader export's per-output pruning rely on — name exactly the slots the
/// disassembly prints, for every instruction of every graph, plain and with promoted (f64)
/// instructions (compiled for ±1e6, where most of them promote).
#[test]
fn instruction_reads_and_writes_match_the_disassembly() {
    let mut checked = 0;
    let mut wide = 0;
    for path in &graph_files() {
        let text = std::fs::read_to_string(path).expect("readable graph");
        let file = SourceFile::new(path.display().to_string(), text);
        let graph = check(file, &CheckOptions::default())
            .unwrap_or_else(|e| panic!("{}", e.render_plain()));
        for extent in [None, Some(texgraph::Extent::new([-1e6; 3], [1e6; 3]))] {
            let options = CompileOptions {
                extent,
                ..Default::default()
            };
            let tape = compile(&graph, &options).unwrap_or_else(|e| panic!("{}", e.render_plain()));
            let lines = tape.instruction_lines().map(|(_, text)| text);
            for (instr, line) in tape.instructions().iter().zip(lines) {
                let (written, read) = line_slots(&line);
                let name = |o: texgraph::tape::Operand| (o.file.prefix(), o.slot);
                assert_eq!(name(instr.writes()), written, "{}: {line}", path.display());
                let reads: Vec<(char, u32)> = instr.reads().into_iter().map(name).collect();
                assert_eq!(reads, read, "{}: {line}", path.display());
                wide += usize::from(instr.prec() == texgraph::tape::Prec::Wide);
                checked += 1;
            }
        }
    }
    assert!(
        checked > 1000 && wide > 100,
        "{checked} instructions, {wide} in f64"
    );
}
