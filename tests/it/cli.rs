//! The `texgraph` command line, run as a user runs it: the built binary, real files, real exit
//! codes (0 success; 1 invalid graph or input; 2 usage or I/O error; never 101, a panic).

use crate::common;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};

const BIN: &str = env!("CARGO_BIN_EXE_texgraph");
const MARBLE: &str = "graphs/seed003_marble.ron";
const CHECKER: &str = "graphs/seed004_checker2d.ron";
const PERLIN: &str =
    r#"Graph(nodes: { "n": Noise(input: Position, basis: Perlin) }, outputs: { "n": "n" })"#;

/// Every node kind `texgraph nodes` must list: the catalogue's (the table drives the command).
fn kinds() -> Vec<&'static str> {
    texgraph::nodes::CATALOGUE.iter().map(|d| d.name).collect()
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn command(args: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.args(args).current_dir(root()).env("NO_COLOR", "1");
    c
}

/// Runs the binary in the crate root.
fn run(args: &[&str]) -> Output {
    command(args)
        .stdin(Stdio::null())
        .output()
        .expect("run texgraph")
}

/// Runs the binary with `input` on standard input.
fn run_stdin(args: &[&str], input: &[u8]) -> Output {
    let mut child = command(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn texgraph");
    let mut stdin = child.stdin.take().expect("stdin");
    let input = input.to_vec();
    // Write from a thread so a large input cannot deadlock against a full stdout pipe.
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&input);
    });
    let output = child.wait_with_output().expect("wait texgraph");
    writer.join().expect("stdin writer");
    output
}

fn code(output: &Output) -> i32 {
    output.status.code().unwrap_or(-1)
}

fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Everything a failing assertion needs to explain itself.
fn show(args: &[&str], output: &Output) -> String {
    format!(
        "texgraph {}\nexit: {:?}\n--- stdout ---\n{}\n--- stderr ---\n{}",
        args.join(" "),
        output.status.code(),
        truncate(&stdout(output)),
        truncate(&stderr(output))
    )
}

fn truncate(s: &str) -> String {
    if s.len() <= 4000 {
        s.to_string()
    } else {
        let mut end = 4000;
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        format!("{}... ({} bytes)", &s[..end], s.len())
    }
}

#[track_caller]
fn expect_code(args: &[&str], expected: i32) -> Output {
    let output = run(args);
    assert_eq!(code(&output), expected, "{}", show(args, &output));
    output
}

/// A fresh scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!(
        "cli-{}-{}-{name}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create scratch dir");
    dir
}

fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> String {
    let path = dir.join(name);
    std::fs::write(&path, contents).expect("write scratch file");
    path.to_str().expect("UTF-8 scratch path").to_string()
}

// ---------------------------------------------------------------------------------------------
// help

#[test]
fn help_explains_every_command() {
    let out = expect_code(&["--help"], 0);
    let text = stdout(&out);
    for word in ["check", "eval", "nodes", "Exit codes"] {
        assert!(
            text.contains(word),
            "`texgraph --help` does not mention {word}:\n{text}"
        );
    }
    for (args, words) in [
        (
            &["help", "check"][..],
            &["--tape", "--output", "--set", "FILE"][..],
        ),
        (
            &["help", "eval"][..],
            &["--points", "--f64", "--output", "--set", "X Y Z"][..],
        ),
        (&["help", "nodes"][..], &["--markdown"][..]),
        (
            &["check", "--help"][..],
            &["--tape", "--output", "--set"][..],
        ),
        (&["eval", "--help"][..], &["--points", "--f64"][..]),
    ] {
        let out = expect_code(args, 0);
        let text = stdout(&out);
        for word in words {
            assert!(
                text.contains(word),
                "`texgraph {}` does not mention {word}:\n{text}",
                args.join(" ")
            );
        }
    }
}

#[test]
fn no_command_is_a_usage_error() {
    expect_code(&[], 2);
    expect_code(&["frobnicate"], 2);
    expect_code(&["check"], 2);
}

// ---------------------------------------------------------------------------------------------
// check

/// One file's summary block from `check`'s output.
struct Summary {
    instructions: usize,
    pruned: usize,
    outputs: String,
}

fn summary(text: &str, file: &str) -> Summary {
    let start = text
        .find(&format!("{file}: ok\n"))
        .unwrap_or_else(|| panic!("no `{file}: ok` in:\n{text}"));
    let block: Vec<&str> = text[start..]
        .lines()
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .collect();
    let line = |prefix: &str| -> &str {
        block
            .iter()
            .find_map(|l| l.trim_start().strip_prefix(prefix))
            .unwrap_or_else(|| panic!("no `{prefix}` line for {file} in:\n{text}"))
    };
    let nodes = line("nodes: ");
    let pruned =
        number_before(nodes, " pruned").unwrap_or_else(|| panic!("no pruned count: {nodes}"));
    let tape = line("tape: ");
    let instructions = number_before(tape, " instructions")
        .unwrap_or_else(|| panic!("no instruction count: {tape}"));
    assert!(tape.contains("slots:"), "no slot count for {file}: {tape}");
    Summary {
        instructions,
        pruned,
        outputs: line("outputs: ").to_string(),
    }
}

/// The number written just before `word` in `text`.
fn number_before(text: &str, word: &str) -> Option<usize> {
    let end = text.find(word)?;
    let digits: String = text[..end]
        .chars()
        .rev()
        .take_while(|c| c.is_ascii_digit())
        .collect();
    digits.chars().rev().collect::<String>().parse().ok()
}

#[test]
fn check_summarises_each_file() {
    let files = [
        MARBLE,
        CHECKER,
        "graphs/seed000_marble_cracks.ron",
        "graphs/seed004_wood_grain.ron",
    ];
    let mut args = vec!["check"];
    args.extend(files);
    let out = expect_code(&args, 0);
    let text = stdout(&out);
    for file in files {
        let s = summary(&text, file);
        assert!(s.instructions > 0, "{file}: empty tape\n{text}");
        assert_eq!(
            s.pruned, 0,
            "{file}: all outputs compiled, nothing should be pruned\n{text}"
        );
    }
    assert_eq!(summary(&text, MARBLE).outputs, "colour vec3, vein scalar");
    assert_eq!(summary(&text, CHECKER).outputs, "colour vec3, jump scalar");
    assert!(
        text.contains("fractal \"fractal\": 12 octaves"),
        "the marble's fractal octaves are reported:\n{text}"
    );
    assert!(stderr(&out).is_empty(), "{}", show(&args, &out));
}

#[test]
fn check_accepts_the_whole_seed_library() {
    let mut files: Vec<String> = std::fs::read_dir(root().join("graphs"))
        .expect("graphs/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .map(|p| {
            format!(
                "graphs/{}",
                p.file_name().and_then(|n| n.to_str()).expect("name")
            )
        })
        .collect();
    files.sort();
    assert!(files.len() >= 20, "{files:?}");
    let mut args = vec!["check"];
    args.extend(files.iter().map(|s| s.as_str()));
    let out = expect_code(&args, 0);
    let text = stdout(&out);
    for file in &files {
        let s = summary(&text, file);
        assert!(s.outputs.contains("colour vec3"), "{file}: {}", s.outputs);
    }
}

/// The `NNNN  ...` instruction lines of a disassembly.
fn instruction_lines(text: &str) -> Vec<&str> {
    text.lines()
        .filter(|l| {
            l.len() > 5 && l[..4].bytes().all(|b| b.is_ascii_digit()) && l[4..].starts_with("  ")
        })
        .collect()
}

#[test]
fn check_tape_prints_a_numbered_disassembly() {
    let args = ["check", "--tape", CHECKER];
    let out = expect_code(&args, 0);
    let text = stdout(&out);
    let s = summary(&text, CHECKER);
    let lines = instruction_lines(&text);
    assert_eq!(
        lines.len(),
        s.instructions,
        "one numbered line per instruction:\n{text}"
    );
    for (i, line) in lines.iter().enumerate() {
        assert!(
            line.starts_with(&format!("{i:04}  ")),
            "instructions are numbered from 0000 in order: {line}\n{text}"
        );
    }
    assert!(text.contains("output \"colour\""), "{text}");
    assert!(text.contains("output \"jump\""), "{text}");
    // Stable: the same file disassembles to the same text.
    assert_eq!(stdout(&expect_code(&args, 0)), text);
    // Without --tape, no disassembly.
    assert!(instruction_lines(&stdout(&expect_code(&["check", CHECKER], 0))).is_empty());
}

#[test]
fn check_output_selects_and_prunes() {
    for (file, output, ty) in [
        (CHECKER, "jump", "scalar"),
        (MARBLE, "vein", "scalar"),
        (MARBLE, "colour", "vec3"),
    ] {
        let all = summary(&stdout(&expect_code(&["check", file], 0)), file);
        let args = ["check", "--tape", "--output", output, file];
        let out = expect_code(&args, 0);
        let text = stdout(&out);
        let one = summary(&text, file);
        assert_eq!(
            one.outputs,
            format!("{output} {ty}"),
            "{}",
            show(&args, &out)
        );
        assert!(
            one.instructions <= all.instructions,
            "{file} --output {output}: {} > {} instructions",
            one.instructions,
            all.instructions
        );
        assert_eq!(instruction_lines(&text).len(), one.instructions, "{text}");
        assert!(
            !text.contains("output \"colour\"") || output == "colour",
            "{text}"
        );
        if output != "colour" {
            assert!(
                one.pruned > 0,
                "{file} --output {output}: the colour nodes should be pruned\n{text}"
            );
            assert!(
                one.instructions < all.instructions,
                "{file} --output {output}: the colour instructions should be gone\n{text}"
            );
        }
    }
}

#[test]
fn check_reports_bad_files_and_still_summarises_good_ones() {
    let bad = "tests/errors/cycle_two.ron";
    let args = ["check", MARBLE, bad, CHECKER];
    let out = expect_code(&args, 1);
    let text = stdout(&out);
    summary(&text, MARBLE);
    summary(&text, CHECKER);
    assert!(
        !text.contains(&format!("{bad}: ok")),
        "{}",
        show(&args, &out)
    );
    let err = stderr(&out);
    assert!(
        err.contains(&format!("error[cycle]: {bad}:6:17")),
        "{}",
        show(&args, &out)
    );
}

#[test]
fn check_missing_file_is_an_io_error() {
    let args = ["check", "graphs/no_such_graph.ron"];
    let out = expect_code(&args, 2);
    assert!(
        stderr(&out).contains("graphs/no_such_graph.ron"),
        "{}",
        show(&args, &out)
    );
    // I/O beats invalid: a missing file among bad and good ones still exits 2, and the good one
    // is still summarised.
    let args = [
        "check",
        MARBLE,
        "tests/errors/cycle_self.ron",
        "graphs/no_such_graph.ron",
    ];
    let out = expect_code(&args, 2);
    summary(&stdout(&out), MARBLE);
}

#[test]
fn a_directory_is_an_io_error_and_a_non_utf8_file_is_invalid() {
    let dir = scratch("io");
    expect_code(&["check", dir.to_str().expect("path")], 2);
    let file = write(
        &dir,
        "latin1.ron",
        b"Graph(nodes: { \"caf\xe9\": Position }, outputs: { \"c\": \"caf\xe9\" })",
    );
    // Not UTF-8 is invalid input (exit 1), located at the first bad byte.
    let out = expect_code(&["check", &file], 1);
    let err = stderr(&out);
    assert!(
        err.contains("latin1.ron:1:20: the file is not UTF-8 text: invalid byte 0xE9"),
        "{err}"
    );
}

// ---------------------------------------------------------------------------------------------
// eval

/// `NAME v` or `NAME r g b` lines parsed as (name, values).
fn parse_lines<T: std::str::FromStr + std::fmt::Display>(text: &str) -> Vec<(String, Vec<T>)> {
    text.lines()
        .map(|line| {
            let mut words = line.split(' ');
            let name = words.next().expect("a name").to_string();
            let values: Vec<T> = words
                .map(|w| {
                    let v: T = w
                        .parse()
                        .unwrap_or_else(|_| panic!("`{w}` in `{line}` is not a number"));
                    // Printed with `{}`, so printing the parsed value gives the same text.
                    assert_eq!(v.to_string(), w, "`{w}` in `{line}` does not round-trip");
                    v
                })
                .collect();
            assert!(
                values.len() == 1 || values.len() == 3,
                "`{line}`: one value or r g b"
            );
            (name, values)
        })
        .collect()
}

#[test]
fn eval_prints_one_line_per_output() {
    for point in [
        ["0.3", "0.5", "0.7"],
        ["-4.2", "10", "6"],
        ["0", "-0", "-0.001"],
        ["-100.25", "-3", "-7.5"],
    ] {
        let mut args = vec!["eval", MARBLE];
        args.extend(point);
        let out = expect_code(&args, 0);
        let lines = parse_lines::<f32>(&stdout(&out));
        assert_eq!(lines.len(), 2, "{}", show(&args, &out));
        assert_eq!(lines[0].0, "colour");
        assert_eq!(lines[0].1.len(), 3);
        assert_eq!(lines[1].0, "vein");
        assert_eq!(lines[1].1.len(), 1);
        let vein = lines[1].1[0];
        assert!(
            (0.0..=1.0).contains(&vein),
            "|sin| is in [0, 1]: {}",
            show(&args, &out)
        );

        args.push("--f64");
        let out = expect_code(&args, 0);
        let wide = parse_lines::<f64>(&stdout(&out));
        assert_eq!(wide.len(), 2, "{}", show(&args, &out));
        assert!(
            (wide[1].1[0] - f64::from(vein)).abs() < 1e-3,
            "f32 {vein} vs f64 {}",
            wide[1].1[0]
        );
    }
}

#[test]
fn eval_perlin_reference_values() {
    let dir = scratch("perlin");
    let file = write(&dir, "perlin.ron", PERLIN);
    let out = expect_code(&["eval", &file, "3.14", "42", "7", "--f64"], 0);
    assert_eq!(stdout(&out), "n 0.13691995878400012\n");
    let out = expect_code(&["eval", &file, "-4.2", "10", "6", "--f64"], 0);
    assert_eq!(stdout(&out), "n 0.14208000000000043\n");
    // The f32 path is close to the reference.
    let out = expect_code(&["eval", &file, "3.14", "42", "7"], 0);
    let v = parse_lines::<f32>(&stdout(&out))[0].1[0];
    assert!(
        (f64::from(v) - 0.13691995878400012).abs() < 1e-5,
        "f32 Perlin {v}"
    );
    // Options may come before the file and the point.
    let out = expect_code(&["eval", "--f64", &file, "3.14", "42", "7"], 0);
    assert_eq!(stdout(&out), "n 0.13691995878400012\n");
}

#[test]
fn eval_output_selects_lines() {
    let out = expect_code(
        &["eval", MARBLE, "0.3", "0.5", "0.7", "--output", "vein"],
        0,
    );
    let lines = parse_lines::<f32>(&stdout(&out));
    assert_eq!(lines.len(), 1);
    assert_eq!(lines[0].0, "vein");
    let all = parse_lines::<f32>(&stdout(&expect_code(
        &["eval", MARBLE, "0.3", "0.5", "0.7"],
        0,
    )));
    assert_eq!(lines[0].1, all[1].1, "pruning does not change a value");
    // Order follows the --output flags.
    let out = expect_code(
        &[
            "eval", MARBLE, "0.3", "0.5", "0.7", "--output", "vein", "--output", "colour",
        ],
        0,
    );
    let names: Vec<String> = parse_lines::<f32>(&stdout(&out))
        .into_iter()
        .map(|l| l.0)
        .collect();
    assert_eq!(names, ["vein", "colour"]);
}

const POINTS: &[[&str; 3]] = &[
    ["0.3", "0.5", "0.7"],
    ["-4.2", "10", "6"],
    ["0", "0", "0"],
    ["12.5", "-0.125", "3"],
    ["1e-7", "2", "-9"],
];

/// The single-point evaluation of each of POINTS, concatenated.
fn single_point_lines(file: &str, extra: &[&str]) -> String {
    let mut expected = String::new();
    for p in POINTS {
        let mut args = vec!["eval", file, p[0], p[1], p[2]];
        args.extend(extra);
        expected.push_str(&stdout(&expect_code(&args, 0)));
    }
    expected
}

#[test]
fn eval_points_file_and_stdin_match_single_points() {
    let dir = scratch("points");
    let mut text = String::from("# x y z\n\n");
    for (i, p) in POINTS.iter().enumerate() {
        // Whitespace, tabs and commas all separate numbers; comment and blank lines are skipped.
        match i % 3 {
            0 => text.push_str(&format!("{} {} {}\n", p[0], p[1], p[2])),
            1 => text.push_str(&format!("  {}\t{}  {}  \n   \n", p[0], p[1], p[2])),
            _ => text.push_str(&format!("{}, {}, {}\n# between\n", p[0], p[1], p[2])),
        }
    }
    let points = write(&dir, "points.txt", &text);
    for extra in [&[][..], &["--f64"][..], &["--output", "vein"][..]] {
        let expected = single_point_lines(MARBLE, extra);
        let mut args = vec!["eval", MARBLE, "--points", &points];
        args.extend(extra);
        let from_file = expect_code(&args, 0);
        assert_eq!(
            stdout(&from_file),
            expected,
            "--points FILE vs single points ({extra:?})"
        );
        let mut args = vec!["eval", MARBLE, "--points", "-"];
        args.extend(extra);
        let from_stdin = run_stdin(&args, text.as_bytes());
        assert_eq!(code(&from_stdin), 0, "{}", show(&args, &from_stdin));
        assert_eq!(
            stdout(&from_stdin),
            expected,
            "--points - vs single points ({extra:?})"
        );
    }
}

#[test]
fn eval_points_across_batch_boundaries_match_single_points() {
    // More points than one batch chunk (4096), so several batches and a partial last one.
    let n = 9000;
    let point = |i: usize| {
        [
            format!("{}", i as f64 * 0.0137 - 40.0),
            format!("{}", (i % 97) as f64 * 0.31),
            format!("{}", -(i as f64) * 0.002),
        ]
    };
    let text: String = (0..n).map(|i| point(i).join(" ") + "\n").collect();
    for extra in [&[][..], &["--f64"][..]] {
        let mut args = vec!["eval", MARBLE, "--points", "-"];
        args.extend(extra);
        let out = run_stdin(&args, text.as_bytes());
        assert_eq!(code(&out), 0, "{}", show(&args, &out));
        let lines: Vec<String> = stdout(&out).lines().map(str::to_string).collect();
        assert_eq!(lines.len(), 2 * n, "two outputs per point");
        for i in [0, 1, 4095, 4096, 4097, 8191, 8192, 8999] {
            let p = point(i);
            let mut single = vec!["eval", MARBLE, &p[0], &p[1], &p[2]];
            single.extend(extra);
            let expected = stdout(&expect_code(&single, 0));
            let got = format!("{}\n{}\n", lines[2 * i], lines[2 * i + 1]);
            assert_eq!(
                got, expected,
                "point {i} ({p:?}, {extra:?}): batch and single-point results differ"
            );
        }
    }
}

#[test]
fn eval_points_malformed_line_names_its_number() {
    let dir = scratch("malformed");
    let text = "0 0 0\n# comment\n\n1 2\n3 3 3\n";
    let points = write(&dir, "bad.txt", text);
    let args = ["eval", MARBLE, "--points", &points];
    let out = expect_code(&args, 1);
    let err = stderr(&out);
    assert!(
        err.contains(&format!("{points}:4")),
        "the message names the file and line 4: {}",
        show(&args, &out)
    );
    let out = run_stdin(&["eval", MARBLE, "--points", "-"], text.as_bytes());
    assert_eq!(code(&out), 1, "{}", show(&args, &out));
    assert!(stderr(&out).contains(":4"), "{}", show(&args, &out));
    for bad in ["1 2 3 4\n", "x y z\n", "1 2 three\n", "1,,2\n"] {
        let out = run_stdin(&["eval", MARBLE, "--points", "-"], bad.as_bytes());
        assert_eq!(code(&out), 1, "points {bad:?}: {}", show(&args, &out));
        assert!(
            stderr(&out).contains(":1"),
            "points {bad:?}: {}",
            stderr(&out)
        );
    }
}

#[test]
fn eval_points_missing_file_is_an_io_error() {
    expect_code(&["eval", MARBLE, "--points", "no/such/points.txt"], 2);
}

#[test]
fn eval_points_empty_input_prints_nothing() {
    let out = run_stdin(&["eval", MARBLE, "--points", "-"], b"# nothing\n\n");
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    assert!(stdout(&out).is_empty(), "{}", stdout(&out));
}

#[test]
fn eval_points_non_finite_positions_do_not_crash() {
    let text = "nan 0 0\ninf 1 2\n-inf -inf -inf\nNaN inf -inf\n1e308 -1e308 1e308\n0.5 0.5 0.5\n";
    for graph in [
        MARBLE,
        CHECKER,
        "graphs/seed004_wood_grain.ron",
        "graphs/seed002_woodgrain.ron",
        "graphs/seed000_wood.ron",
    ] {
        for extra in [&[][..], &["--f64"][..]] {
            let mut args = vec!["eval", graph, "--points", "-"];
            args.extend(extra);
            let out = run_stdin(&args, text.as_bytes());
            assert_eq!(code(&out), 0, "{}", show(&args, &out));
            let lines = stdout(&out);
            assert_eq!(lines.lines().count(), 12, "{}", show(&args, &out));
            assert!(
                lines.contains("NaN"),
                "a NaN position gives NaN: {}",
                show(&args, &out)
            );
        }
    }
}

#[test]
fn eval_set_overrides_a_param() {
    let base = stdout(&expect_code(&["eval", MARBLE, "0.3", "0.5", "0.7"], 0));
    let set = stdout(&expect_code(
        &["eval", MARBLE, "0.3", "0.5", "0.7", "--set", "period=2"],
        0,
    ));
    assert_ne!(base, set, "--set period=2 changes the marble");
    // Setting a param to its own value changes nothing.
    let same = stdout(&expect_code(
        &["eval", MARBLE, "0.3", "0.5", "0.7", "--set", "period=1.3"],
        0,
    ));
    assert_eq!(base, same);
    // Several --set, and the check summary honours them too.
    let out = expect_code(
        &["check", MARBLE, "--set", "octaves=3", "--set", "scale=2"],
        0,
    );
    assert!(stdout(&out).contains("3 octaves"), "{}", stdout(&out));
}

#[test]
fn eval_usage_and_input_errors_have_their_exit_codes() {
    let out = expect_code(&["eval", MARBLE, "1", "2", "3", "--set", "nosuch=1"], 1);
    assert!(stderr(&out).contains("nosuch"), "{}", stderr(&out));
    expect_code(&["eval", MARBLE, "1", "2", "3", "--set", "bad"], 2);
    expect_code(&["eval", MARBLE, "1", "2", "3", "--set", "period=abc"], 2);
    let out = expect_code(&["eval", MARBLE, "1", "2", "3", "--output", "nosuch"], 1);
    assert!(stderr(&out).contains("nosuch"), "{}", stderr(&out));
    expect_code(&["check", MARBLE, "--output", "nosuch"], 1);
    expect_code(&["eval", MARBLE], 2);
    expect_code(&["eval", MARBLE, "1"], 2);
    expect_code(&["eval", MARBLE, "1", "2"], 2);
    expect_code(&["eval", MARBLE, "1", "2", "3", "4"], 2);
    expect_code(&["eval", MARBLE, "1", "two", "3"], 2);
    expect_code(&["eval", MARBLE, "1", "2", "3", "--points", "-"], 2);
    expect_code(&["eval", "graphs/no_such_graph.ron", "1", "2", "3"], 2);
    let out = expect_code(&["eval", "tests/errors/cycle_three.ron", "1", "2", "3"], 1);
    assert!(stderr(&out).contains("error[cycle]"), "{}", stderr(&out));
    assert!(stdout(&out).is_empty());
}

// ---------------------------------------------------------------------------------------------
// nodes

#[test]
fn nodes_lists_every_kind_with_defaults() {
    let out = expect_code(&["nodes"], 0);
    let text = stdout(&out);
    for kind in kinds() {
        assert!(
            text.lines().any(|l| l.starts_with(&format!("{kind}("))),
            "`texgraph nodes` does not list {kind}:\n{text}"
        );
    }
    let headings = text
        .lines()
        .filter(|l| !l.starts_with(' ') && l.contains(") -> "))
        .count();
    assert_eq!(headings, kinds().len(), "exactly the known kinds:\n{text}");
    for needle in [
        "default 2",
        "default 0.5",
        "default Linear",
        "default (0, 0, 1)",
        "required",
        "octaves",
        "lacunarity",
        "first_octave",
        "stops",
    ] {
        assert!(text.contains(needle), "`texgraph nodes` lacks `{needle}`");
    }
}

#[test]
fn nodes_markdown_is_a_table() {
    let out = expect_code(&["nodes", "--markdown"], 0);
    let text = stdout(&out);
    let rows: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    assert!(rows[0].starts_with("| node |"), "{text}");
    assert!(rows[1].starts_with("|---"), "{text}");
    let columns = rows[0].matches(" | ").count();
    for kind in kinds() {
        let row = rows
            .iter()
            .find(|r| r.starts_with(&format!("| `{kind}` |")))
            .unwrap_or_else(|| panic!("no row for {kind}:\n{text}"));
        // Escaped pipes (\|) inside cells do not count as column separators.
        assert_eq!(
            row.replace("\\|", "").matches(" | ").count(),
            columns,
            "row of {kind} has the header's columns: {row}"
        );
    }
    assert_eq!(rows.len(), kinds().len() + 2);
}

// ---------------------------------------------------------------------------------------------
// robustness

#[test]
fn nothing_panics_on_nasty_input() {
    let dir = scratch("nasty");
    let mut files = vec![
        write(&dir, "empty.ron", ""),
        write(&dir, "spaces.ron", "   \n\t\n"),
        write(&dir, "comment.ron", "// only a comment"),
        write(&dir, "parens.ron", "(".repeat(1 << 20)),
        write(&dir, "closers.ron", ")".repeat(1 << 16)),
        write(&dir, "brackets.ron", "[".repeat(1 << 16)),
        write(&dir, "nodes_deep.ron", format!("Graph(nodes: {{ \"a\": {}1{} }}, outputs: {{ \"a\": \"a\" }})", "Sin(".repeat(5000), ")".repeat(5000))),
        write(&dir, "non_utf8.ron", b"Graph(nodes: { \"\xff\xfe\": Position }, outputs: { \"o\": \"\xff\xfe\" })"),
        write(&dir, "nul.ron", b"Graph(\0)"),
        write(&dir, "bom.ron", "\u{feff}Graph(nodes: { \"n\": Position }, outputs: { \"n\": \"n\" })"),
        write(&dir, "unicode.ron", "Graph(nodes: { \"ä\": Sin(\"ö\") }, outputs: { \"ü\": \"ä\" }) ✓"),
        write(&dir, "crlf.ron", "Graph(\r\n  nodes: { \"n\": Sinn(1) },\r\n  outputs: { \"n\": \"n\" },\r\n)\r\n"),
        write(&dir, "eof_in_string.ron", "Graph(nodes: { \"n"),
        write(&dir, "eof_in_escape.ron", "Graph(nodes: { \"n\\"),
        write(&dir, "eof_in_raw.ron", "Graph(nodes: { r#\"n"),
        write(&dir, "attribute.ron", "#![enable(implicit_some"),
        write(&dir, "minus.ron", "Graph(nodes: { \"n\": Mul(-, 1) }, outputs: { \"n\": \"n\" })"),
        write(&dir, "huge_number.ron", format!("Graph(nodes: {{ \"n\": Mul(1{}, Length(Position)) }}, outputs: {{ \"n\": \"n\" }})", "0".repeat(400))),
        write(&dir, "inf_literals.ron", "Graph(nodes: { \"n\": Fbm(input: Scale(input: Position, by: inf), basis: Value, octaves: inf, seed: -inf) }, outputs: { \"n\": \"n\" })"),
        write(&dir, "huge_seed.ron", "Graph(nodes: { \"n\": Noise(input: Position, basis: Gradient, seed: 1e300) }, outputs: { \"n\": \"n\" })"),
        write(&dir, "max_seed.ron", "Graph(nodes: { \"n\": Noise(input: Position, basis: Gradient, seed: 9007199254740991) }, outputs: { \"n\": \"n\" })"),
        write(&dir, "max_octaves.ron", "Graph(nodes: { \"n\": Turbulence(input: Position, basis: Value, octaves: 32, first_octave: 32, lacunarity: 1000000) }, outputs: { \"n\": \"n\" })"),
        write(&dir, "ramp_one_stop.ron", "Graph(nodes: { \"c\": ColorRamp(input: Length(Position), stops: [(0.5, (1, 0, 0))]) }, outputs: { \"c\": \"c\" })"),
        write(&dir, "ramp_equal_stops.ron", "Graph(nodes: { \"c\": ColorRamp(input: Length(Position), stops: [(0.5, (1, 0, 0)), (0.5, (0, 1, 0))], interpolation: Smooth) }, outputs: { \"c\": \"c\" })"),
        write(&dir, "curve_equal_points.ron", "Graph(nodes: { \"c\": Curve(input: Length(Position), points: [(0.5, 0), (0.5, 1), (0.5, 2)], interpolation: Constant) }, outputs: { \"c\": \"c\" })"),
        write(&dir, "tiny_axis.ron", "Graph(nodes: { \"r\": Rotate(input: Position, axis: (1e-320, 0, 0), degrees: 1e308) }, outputs: { \"r\": \"r\" })"),
        write(&dir, "mod_zero.ron", "Graph(nodes: { \"m\": Mod(Floor(Position), 0), \"d\": Div(Position, 0), \"p\": Pow(-8, 0.5) }, outputs: { \"m\": \"m\", \"d\": \"d\", \"p\": \"p\" })"),
        write(&dir, "empty_graph.ron", "Graph()"),
        write(&dir, "nodes_not_map.ron", "Graph(nodes: [1, 2], outputs: 3, params: \"x\")"),
        write(&dir, "keys_not_strings.ron", "Graph(nodes: { 1: Position, Sin: 2 }, outputs: { (1, 2): \"n\" })"),
        write(&dir, "nested_positions.ron", "Graph(nodes: { \"n\": Position(Position(Position)) }, outputs: { \"n\": \"n\" })"),
        write(&dir, "basis_forms.ron", "Graph(nodes: { \"a\": Noise(input: Position, basis: Value(Cubic)), \"b\": Noise(input: Position, basis: Value(interpolation: 3)), \"c\": Noise(input: Position, basis: \"Perlin\"), \"d\": Noise(input: Position, basis: Perlin(1, 2)) }, outputs: { \"a\": \"a\" })"),
        write(&dir, "cycle_via_output.ron", "Graph(nodes: { \"a\": \"b\", \"b\": \"a.x\" }, outputs: { \"o\": \"a\" })"),
        write(&dir, "self_component.ron", "Graph(nodes: { \"a\": Combine(\"a.x\", \"a.y\", 1) }, outputs: { \"o\": \"a.z\" })"),
        write(&dir, "empty_id.ron", "Graph(nodes: { \"\": Position, \".\": Position }, outputs: { \"\": \"\", \"o\": \".x\" })"),
    ];
    std::fs::create_dir_all(dir.join("dir.ron")).expect("mkdir");
    files.push(dir.join("dir.ron").to_str().expect("path").to_string());
    files.push(dir.join("missing.ron").to_str().expect("path").to_string());
    let mut garbage = Vec::with_capacity(1 << 16);
    let mut state = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..(1 << 16) {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        garbage.push((state >> 32) as u8);
    }
    files.push(write(&dir, "garbage.ron", &garbage));
    const ALPHABET: &[u8] = b"(){}[]:,\"' abcXYZ019.-+_/*#\n";
    let ascii: Vec<u8> = garbage
        .iter()
        .map(|b| ALPHABET[*b as usize % ALPHABET.len()])
        .collect();
    files.push(write(&dir, "ascii_garbage.ron", &ascii));
    let points = write(
        &dir,
        "points.txt",
        "nan nan nan\n1e308 1e308 1e308\n-1e308 0 5\n\u{0}\n",
    );
    let perlin = write(&dir, "perlin.ron", PERLIN);
    files.push(perlin.clone());
    files.push(MARBLE.to_string());

    let mut failures = String::new();
    let mut check = |args: Vec<&str>, stdin: Option<&[u8]>| {
        let out = match stdin {
            Some(input) => run_stdin(&args, input),
            None => run(&args),
        };
        let c = code(&out);
        if !(0..=2).contains(&c) || stderr(&out).contains("panicked") {
            failures.push_str(&show(&args, &out));
            failures.push('\n');
        }
    };
    for file in &files {
        check(vec!["check", file], None);
        check(vec!["check", "--tape", file], None);
        check(vec!["eval", file, "1", "2", "3"], None);
        check(
            vec!["eval", file, "1e308", "-1e308", "1e308", "--f64"],
            None,
        );
        check(vec!["eval", file, "--", "-inf", "inf", "nan"], None);
        check(vec!["eval", file, "--points", &points, "--f64"], None);
        check(vec!["eval", file, "--points", "-"], Some(&garbage));
    }
    // Huge, tiny and non-finite coordinates through every graph of the library, both precisions.
    let mut graphs: Vec<String> = std::fs::read_dir(root().join("graphs"))
        .expect("graphs/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .map(|p| p.to_str().expect("path").to_string())
        .collect();
    graphs.sort();
    let nasty = "1e308 -1e308 1e308\n-inf inf nan\n3.4e38 -3.4e38 1e39\n1e-320 -1e-320 0\n-0 -0 -0\n9007199254740993 -9007199254740993 4294967296.5\n";
    for graph in &graphs {
        check(vec!["eval", graph, "--points", "-"], Some(nasty.as_bytes()));
        check(
            vec!["eval", graph, "--points", "-", "--f64"],
            Some(nasty.as_bytes()),
        );
        check(vec!["eval", graph, "-1e308", "1e308", "-1e308"], None);
    }
    assert!(
        failures.is_empty(),
        "exit codes outside 0..=2 or panics:\n{failures}"
    );
}

#[test]
fn huge_and_non_finite_coordinates_evaluate() {
    let dir = scratch("huge");
    let perlin = write(&dir, "perlin.ron", PERLIN);
    for args in [
        vec!["eval", perlin.as_str(), "1e308", "1e308", "1e308"],
        vec!["eval", perlin.as_str(), "1e308", "1e308", "1e308", "--f64"],
        vec!["eval", perlin.as_str(), "-1e308", "-5", "1e300", "--f64"],
        vec!["eval", perlin.as_str(), "--", "-inf", "inf", "nan"],
        vec!["eval", MARBLE, "--", "-inf", "1", "2"],
    ] {
        let out = expect_code(&args, 0);
        let lines = parse_lines::<f64>(&stdout(&out));
        assert!(!lines.is_empty(), "{}", show(&args, &out));
    }
}

/// `-.5`, `-1e-3`, `-inf` are numbers like `-4.2` (Rust parses them, and `--points` accepts
/// them), but as coordinates the argument parser takes them for options: `texgraph eval g.ron
/// 0 0 -1e-3` is a usage error (exit 2, "unexpected argument '-1' found") unless written after
/// `--`. clap's `allow_negative_numbers` only recognises `-DIGITS[.DIGITS][eDIGITS]`.
#[test]
fn eval_accepts_every_negative_float_as_a_coordinate() {
    let dir = scratch("neg-floats");
    let perlin = write(&dir, "perlin.ron", PERLIN);
    let mut failures = Vec::new();
    for coordinate in ["-.5", "-1e-3", "-1E-3", "-1.5e+3", "-inf", "-NaN"] {
        let out = run(&["eval", &perlin, "0.25", "0.5", coordinate]);
        if code(&out) != 0 {
            failures.push(format!(
                "{coordinate}: exit {:?}: {}",
                out.status.code(),
                stderr(&out).lines().next().unwrap_or("")
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// A diagnostic shows the offending line; for a 1 MB one-line file that is 1 MB of stderr.
#[test]
fn diagnostics_on_huge_lines_stay_short() {
    let dir = scratch("long-line");
    let file = write(&dir, "parens.ron", "(".repeat(1 << 20));
    let out = expect_code(&["check", &file], 1);
    assert!(
        out.stderr.len() < 16 << 10,
        "{} bytes of stderr",
        out.stderr.len()
    );
}

// ---------------------------------------------------------------------------------------------
// the error goldens through the binary

#[test]
fn check_every_error_case_through_the_binary() {
    let mut cases: Vec<String> = std::fs::read_dir(root().join("tests/errors"))
        .expect("tests/errors")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .map(|p| {
            format!(
                "tests/errors/{}",
                p.file_name().and_then(|n| n.to_str()).expect("name")
            )
        })
        .collect();
    cases.sort();
    assert!(cases.len() >= 30);
    // A case's `// set: NAME=VALUE` directives (tests/it/errors.rs) are its `--set` flags.
    let sets = |case: &str| -> Vec<String> {
        std::fs::read_to_string(root().join(case))
            .expect("a case")
            .lines()
            .filter_map(|l| l.trim().strip_prefix("// set:"))
            .flat_map(|set| ["--set".to_string(), set.trim().to_string()])
            .collect()
    };
    let mut args = vec!["check"];
    args.extend(
        cases
            .iter()
            .filter(|c| sets(c).is_empty())
            .map(|s| s.as_str()),
    );
    let out = expect_code(&args, 1);
    assert!(
        stdout(&out).is_empty(),
        "no error case checks fine:\n{}",
        stdout(&out)
    );
    let err = stderr(&out);
    assert!(
        !err.contains('\u{1b}'),
        "no colour when stderr is not a terminal"
    );
    for case in &cases {
        let set = sets(case);
        let err = if set.is_empty() {
            err.clone()
        } else {
            let mut args = vec!["check", case.as_str()];
            args.extend(set.iter().map(String::as_str));
            stderr(&expect_code(&args, 1))
        };
        // A problem inside an imported file is located there, the case in its import chain.
        let located = err.lines().any(|l| {
            (l.starts_with("error[") && l.contains(&format!("]: {case}:")))
                || l.trim_start()
                    .starts_with(&format!("imported from {case}:"))
        });
        assert!(
            located,
            "no `error[...]: {case}:LINE:COL` headline in:\n{}",
            truncate(&err)
        );
        // What the binary prints is what the golden holds.
        let golden = std::fs::read_to_string(root().join(case).with_extension("txt"))
            .unwrap_or_default()
            .replace("\r\n", "\n");
        if !golden.is_empty() {
            assert!(
                err.contains(&golden),
                "{case}: the binary's diagnostic differs from its golden"
            );
        }
    }
    // Each file on its own exits 1 too.
    for case in &cases {
        let set = sets(case);
        let mut args = vec!["check", case.as_str()];
        args.extend(set.iter().map(String::as_str));
        expect_code(&args, 1);
    }
}

// ---------------------------------------------------------------- render

#[test]
fn render_writes_a_png_of_the_requested_size() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("marble.png");
    let output = run(&[
        "render",
        "graphs/seed003_marble.ron",
        "-o",
        out.to_str().expect("utf-8"),
        "--size",
        "48,32",
        "--object",
        "teapot",
        "--samples",
        "1",
        "-q",
    ]);
    assert_eq!(code(&output), 0, "{}", stderr(&output));
    assert!(stdout(&output).contains("wrote"), "{}", stdout(&output));
    let image = common::Png::open(&out).expect("a png");
    assert_eq!((image.width, image.height), (48, 32));
    // A scene file renders too.
    let scene_out = dir.path().join("scene.png");
    let output = run(&[
        "render",
        "graphs/scenes/seed003_sphere.ron",
        "-o",
        scene_out.to_str().expect("utf-8"),
        "--size",
        "40,30",
        "-q",
    ]);
    assert_eq!(code(&output), 0, "{}", stderr(&output));
    assert!(scene_out.exists());
}

#[test]
fn render_reports_bad_input_with_the_documented_exit_codes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let broken = dir.path().join("broken.ron");
    std::fs::write(&broken, "Graph(outputs: { \"c\": Sinn(1.0) })").expect("write");
    let out = dir.path().join("x.png");
    let output = run(&[
        "render",
        broken.to_str().expect("utf-8"),
        "-o",
        out.to_str().expect("utf-8"),
        "-q",
    ]);
    assert_eq!(code(&output), 1, "{}", stderr(&output));
    assert!(
        stderr(&output).contains("broken.ron:1:"),
        "{}",
        stderr(&output)
    );
    assert!(!out.exists(), "no image for a broken graph");
    let output = run(&[
        "render",
        "no/such/file.ron",
        "-o",
        out.to_str().expect("utf-8"),
        "-q",
    ]);
    assert!(matches!(code(&output), 1 | 2), "{}", stderr(&output));
    let output = run(&["render", "graphs/seed003_marble.ron", "--size", "0,10"]);
    assert_eq!(code(&output), 2);
}

/// `--no-lod` and `--lod-bias B` (issue 18): both render; they do not go together, a bias is a
/// finite number of octaves within ±16, and neither applies to the timing table.
#[test]
fn render_level_of_detail_flags() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("x.png");
    let out = out.to_str().expect("utf-8");
    let base = [
        "render",
        "graphs/seed000_turbulence.ron",
        "-q",
        "--size",
        "24,16",
        "-o",
        out,
    ];
    for extra in [
        &["--no-lod"][..],
        &["--lod-bias", "1.5"],
        &["--lod-bias=-2"],
        &[],
    ] {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        let output = run(&args);
        assert_eq!(code(&output), 0, "{}", show(&args, &output));
    }
    for extra in [
        &["--no-lod", "--lod-bias", "1"][..],
        &["--lod-bias", "17"],
        &["--lod-bias", "nan"],
        &["--lod-bias", "soft"],
    ] {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        let output = run(&args);
        assert_eq!(code(&output), 2, "{}", show(&args, &output));
    }
    let output = run(&["render", "--timing-table", "--no-lod"]);
    assert_eq!(code(&output), 2, "{}", stderr(&output));
    assert!(stderr(&output).contains("--no-lod"), "{}", stderr(&output));
}

#[test]
fn render_prints_the_seed_003_timing_table() {
    let output = run(&["render", "--timing-table", "-q", "--threads", "2"]);
    assert_eq!(code(&output), 0, "{}", stderr(&output));
    let text = stdout(&output);
    assert!(text.contains("500×500"), "{text}");
    for octaves in ["1", "2", "4", "8"] {
        assert!(
            text.lines().any(|l| l.trim_start().starts_with(octaves)),
            "no row for {octaves} octaves:\n{text}"
        );
    }
}

/// `texgraph devices` (issue 19): one line per adapter, or a line saying why there is none;
/// exit code 0 either way. Where CI installed Mesa's lavapipe (`TEXGRAPH_REQUIRE_GPU_ADAPTER`),
/// an adapter must be found; elsewhere finding none prints a visible SKIPPED line.
#[test]
fn devices_lists_the_adapters_or_says_why_there_are_none() {
    let output = run(&["devices"]);
    assert_eq!(code(&output), 0, "{}", show(&["devices"], &output));
    let text = stdout(&output);
    let listed: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with(char::is_numeric))
        .collect();
    for (i, line) in listed.iter().enumerate() {
        assert!(line.starts_with(&format!("{i}: ")), "{text}");
        assert!(
            line.contains("Vulkan") || line.contains("Metal") || line.contains("Dx12"),
            "{text}"
        );
    }
    if listed.is_empty() {
        assert!(text.starts_with("no GPU adapter"), "{text}");
        assert!(
            std::env::var_os("TEXGRAPH_REQUIRE_GPU_ADAPTER").is_none(),
            "TEXGRAPH_REQUIRE_GPU_ADAPTER is set but no adapter was found:\n{text}"
        );
        eprintln!(
            "SKIPPED: no GPU adapter here (install mesa-vulkan-drivers for lavapipe): {text}"
        );
    }
}

#[test]
fn serve_refuses_a_missing_input_and_a_taken_port() {
    let output = run(&["serve", "no/such/graph.ron", "--port", "0"]);
    assert_eq!(code(&output), 2, "{}", show(&["serve"], &output));
    assert!(
        stderr(&output).contains("no/such/graph.ron"),
        "{}",
        stderr(&output)
    );
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let output = run(&["serve", "graphs/seed003_marble.ron", "--port", &port]);
    assert_eq!(code(&output), 2, "{}", show(&["serve"], &output));
    assert!(
        stderr(&output).contains("cannot listen"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn serve_prints_its_localhost_url() {
    use std::io::BufRead;
    let mut child = command(&["serve", "graphs/seed003_marble.ron", "--port", "0"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        line.starts_with("texgraph serve: http://127.0.0.1:"),
        "{line}"
    );
}

/// `--extent` and `--max-error`: the promoted tape is shown with its reasons, a far point is
/// evaluated within the target of f64, and bad values are usage errors.
#[test]
fn precision_flags() {
    let marble = "graphs/seed003_marble.ron";
    let out = expect_code(
        &[
            "check",
            "--tape",
            "--extent=-1e6,-1e6,-1e6:1e6,1e6,1e6",
            marble,
        ],
        0,
    );
    let text = stdout(&out);
    assert!(text.contains("d1 = v0.x"), "{text}");
    assert!(text.contains("f64: |value| <= 1.000e6"), "{text}");
    assert!(text.contains("precision: extent -1000000,"), "{text}");
    assert!(text.contains("output \"vein\": error bound"), "{text}");
    let plain = stdout(&expect_code(&["check", "--tape", marble], 0));
    assert!(
        !plain.contains("precision") && !plain.contains(" d0"),
        "{plain}"
    );
    // A loose target promotes nothing.
    let loose = stdout(&expect_code(
        &[
            "check",
            "--tape",
            "--extent=0,0,0:1e3,1,1",
            "--max-error",
            "1",
            marble,
        ],
        0,
    ));
    assert!(loose.contains("0 of 10 instructions in f64"), "{loose}");
    // One far point: its own extent, within 1e-4 of the f64 path.
    let value = |args: &[&str]| -> f64 {
        let s = stdout(&expect_code(args, 0));
        let line = s
            .lines()
            .find(|l| l.starts_with("vein "))
            .expect("vein line");
        line[5..].trim().parse().expect("number")
    };
    let far = [
        "eval",
        marble,
        "1000000.3",
        "-2000000.7",
        "5.1",
        "--output",
        "vein",
    ];
    let fast = value(&far);
    let mut reference = far.to_vec();
    reference.push("--f64");
    let exact = value(&reference);
    assert!((fast - exact).abs() <= 1e-4, "{fast} vs {exact}");
    for bad in [
        vec!["check", "--extent", "1,1,1:0,0,0", marble],
        vec!["check", "--extent", "0,0:1,1", marble],
        vec!["check", "--max-error", "0", marble],
        vec!["eval", "--max-error", "-1", marble, "0", "0", "0"],
    ] {
        expect_code(&bad, 2);
    }
}

// ---------------------------------------------------------------------------------------------
// Filtering (issue 33)

/// `eval --footprint`: the mean over a box, here of `Fract(3x + 0.2)` over x in [0, 1/2]
/// (exactly 0.5 + ... computed from fract's antiderivative), with one footprint for every
/// point of `--points`; a bad footprint is a usage error naming the flag.
#[test]
fn eval_footprint_prints_the_box_mean() {
    let dir = tempfile::tempdir().expect("tempdir");
    let graph = dir.path().join("f.ron");
    std::fs::write(
        &graph,
        r#"Graph(nodes: { "p": Position }, outputs: { "f": Fract(Add(Mul(3.0, "p.x"), 0.2)) })"#,
    )
    .unwrap();
    let g = graph.to_str().unwrap();
    let antiderivative = |x: f64| x.floor() / 2.0 + (x - x.floor()).powi(2) / 2.0;
    let exact = (antiderivative(1.7) - antiderivative(0.2)) / 1.5;
    let out = expect_code(
        &[
            "eval",
            g,
            "0.25",
            "0",
            "0",
            "--footprint",
            "0.5,1,1",
            "--f64",
        ],
        0,
    );
    let value: f64 = stdout(&out)
        .trim()
        .trim_start_matches("f ")
        .parse()
        .unwrap();
    assert!((value - exact).abs() < 1e-12, "{value} vs {exact}");
    let out = run_stdin(
        &["eval", g, "--points", "-", "--footprint", "0.5"],
        b"0.25 0 0\n0.25 5 -3\n",
    );
    assert_eq!(code(&out), 0, "{}", stderr(&out));
    for line in stdout(&out).lines() {
        let v: f64 = line.trim_start_matches("f ").parse().unwrap();
        assert!((v - exact).abs() < 1e-6, "{line} vs {exact}");
    }
    for bad in ["-1", "nan", "1,2", "inf"] {
        let out = expect_code(&["eval", g, "0", "0", "0", "--footprint", bad], 2);
        assert!(
            stderr(&out).contains("--footprint"),
            "{bad}: {}",
            stderr(&out)
        );
    }
}

/// `bake --filter box` on any device: `auto` bakes (on the GPU's filtered form where there is
/// a GPU and it covers the graph, else on the CPU; `gpu_filtered.rs` checks the values);
/// `--lod` does not apply.
#[test]
fn bake_filter_box_devices_and_conflicts() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_str().unwrap();
    let base = [
        "bake",
        "graphs/seed002_sine.ron",
        "--size",
        "4",
        "--format",
        "raw",
        "--quiet",
        "--filter",
        "box",
        "--out",
        out,
    ];
    expect_code(&[&base[..], &["--device", "auto"]].concat(), 0);
    let lod = expect_code(&[&base[..], &["--lod", "--force"]].concat(), 2);
    assert!(stderr(&lod).contains("--lod"), "{}", stderr(&lod));
}

/// `render --filter`: point samples with level of detail by default (issue 47: at equal time
/// they beat the box filter), box on request; `--no-lod` is point samples at every octave and
/// contradicts an explicit box; `auto` renders (box filtered on the GPU's filtered form where
/// there is a GPU: `gpu_filtered.rs`).
#[test]
fn render_filter_flags() {
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("r.png");
    let png = png.to_str().unwrap();
    let base = [
        "render",
        "graphs/seed002_sine.ron",
        "--size",
        "12,8",
        "--samples",
        "1",
        "--quiet",
        "-o",
        png,
    ];
    let image = |args: &[&str]| {
        expect_code(&[&base[..], args].concat(), 0);
        std::fs::read(png).expect("the PNG")
    };
    let default = image(&[]);
    assert_eq!(
        default,
        image(&["--filter", "point"]),
        "point is the default"
    );
    assert_ne!(default, image(&["--filter", "box"]), "box filtering shows");
    assert_eq!(
        image(&["--no-lod"]),
        image(&["--no-lod", "--filter", "point"])
    );
    let both = expect_code(&[&base[..], &["--no-lod", "--filter", "box"]].concat(), 2);
    assert!(stderr(&both).contains("--no-lod"), "{}", stderr(&both));
    expect_code(&[&base[..], &["--device", "auto"]].concat(), 0);
}

/// `report --filtering`: a row per box side with every strategy's RMS and time (equal-time
/// supersampling and its verdict among them), the filtered marble closer to the box mean than
/// point sampling at side 1/2; JSON rows and the plot; the flags it excludes are usage errors.
#[test]
fn report_filtering_table_json_and_plot() {
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("f.png");
    let base = [
        "report",
        "--filtering",
        "graphs/seed003_marble.ron",
        "--boxes",
        "12",
        "--region=-4,-4,-4:4,4,4",
        "--output",
        "vein",
    ];
    let table = stdout(&expect_code(&base, 0));
    assert!(
        table.contains("| side | point RMS | 4 samples RMS | 16 samples RMS | filtered RMS |"),
        "{table}"
    );
    assert!(
        table.contains("| equal-time samples | their RMS | at equal time |"),
        "{table}"
    );
    for side in ["| 1/2 |", "| 1/8 |", "| 1/32 |"] {
        assert!(table.contains(side), "{table}");
    }
    let json = stdout(&expect_code(
        &[&base[..], &["--json", "--plot", png.to_str().unwrap()]].concat(),
        0,
    ));
    let rows: serde_json::Value = serde_json::from_str(&json).expect("JSON");
    let rows = rows.as_array().expect("an array");
    assert_eq!(rows.len(), 3);
    let half = &rows[0]["row"];
    assert_eq!(half["side"], 0.5);
    let (point, filtered) = (
        half["point_rms"].as_f64().unwrap(),
        half["filtered_rms"].as_f64().unwrap(),
    );
    assert!(
        filtered < 0.5 * point,
        "filtered {filtered} vs point {point}"
    );
    assert!(half["filtered_us"].as_f64().unwrap() > 0.0);
    // Equal-time supersampling: as many samples as fit in the filtered time, scored on the
    // same boxes; the verdict is the comparison of the two RMS figures.
    for row in rows {
        let row = &row["row"];
        let samples = row["equal_samples"].as_u64().unwrap();
        assert!((1..=216).contains(&samples), "{row}");
        let (f, e) = (
            row["filtered_rms"].as_f64().unwrap(),
            row["equal_rms"].as_f64().unwrap(),
        );
        assert_eq!(
            row["filtered_wins"].as_bool().unwrap(),
            f <= e + 1e-6,
            "{row}"
        );
    }
    let image = common::Png::open(&png).expect("a PNG");
    assert_eq!((image.width, image.height), (1000, 640));
    for other in [["--mips"], ["--stability"]] {
        expect_code(&[&base[..], &other[..]].concat(), 2);
    }
}

/// `texgraph shader` (issue 35): stdout by default, `-o` writes the same text to a file (no
/// temporary left beside it), `--output` keeps one output's functions, `--uniforms` says which
/// params stay constants, GLSL gets `#version` only when asked, and the usage errors exit 2.
#[cfg(feature = "shader")]
#[test]
fn shader_writes_the_functions_and_refuses_bad_flags() {
    let out = run(&["shader", MARBLE]);
    assert_eq!(code(&out), 0, "{}", String::from_utf8_lossy(&out.stderr));
    let wgsl = String::from_utf8(out.stdout).unwrap();
    for f in [
        "fn texgraph_colour(p: vec3<f32>) -> vec3<f32>",
        "fn texgraph_vein_lod(p: vec3<f32>, spacing: f32) -> f32",
        "fn texgraph_vein_filtered(p: vec3<f32>, footprint: mat3x3<f32>) -> f32",
    ] {
        assert!(wgsl.contains(f), "no `{f}`");
    }
    // `--no-filtered`: the same point and `_lod` functions, no filtered form and its rules.
    let out = run(&["shader", MARBLE, "--no-filtered"]);
    let plain = String::from_utf8(out.stdout).unwrap();
    assert!(plain.contains("fn texgraph_vein_lod(") && !plain.contains("_filtered"));
    assert!(
        plain.len() * 2 < wgsl.len(),
        "{} of {}",
        plain.len(),
        wgsl.len()
    );
    assert!(
        !wgsl.contains("@fragment") && !wgsl.contains("@compute"),
        "an entry point is left"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("vein.glsl");
    let out = run(&[
        "shader",
        MARBLE,
        "--lang",
        "glsl",
        "--output",
        "vein",
        "-o",
        path.to_str().unwrap(),
    ]);
    assert_eq!(code(&out), 0, "{}", String::from_utf8_lossy(&out.stderr));
    let glsl = std::fs::read_to_string(&path).unwrap();
    assert!(glsl.contains("float texgraph_vein(vec3 p)") && !glsl.contains("texgraph_colour"));
    assert!(!glsl.contains("#version"));
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "a temporary file is left"
    );
    let out = run(&["shader", MARBLE, "--lang", "glsl-es", "--version", "310"]);
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("#version 310 es"));
    let out = run(&["shader", MARBLE, "--uniforms", "--lang", "hlsl"]);
    assert_eq!(code(&out), 0);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("param `octaves` stays the constant 12"),
        "{stderr}"
    );
    assert!(!stderr.contains("param `period`"), "{stderr}");
    // The filtered rules are built for the params' values: left out, and said.
    assert!(stderr.contains("no `_filtered` functions"), "{stderr}");
    assert!(!String::from_utf8_lossy(&out.stdout).contains("_filtered"));
    assert!(String::from_utf8_lossy(&out.stdout).contains("cbuffer texgraph_params : register(b0)"));
    for (args, says) in [
        (
            &["shader", MARBLE, "--lang", "glsl", "--version", "100"][..],
            "--version 100",
        ),
        (
            &["shader", MARBLE, "--lang", "hlsl", "--version", "450"][..],
            "glsl and glsl-es only",
        ),
        (&["shader", MARBLE, "--lang", "cobol"][..], "cobol"),
    ] {
        let out = run(args);
        assert_eq!(code(&out), 2, "{args:?}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(says),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let out = run(&["shader", "graphs/no_such_file.ron"]);
    assert_eq!(code(&out), 2);
}
