//! Error goldens: every `tests/errors/NAME.ron` is an invalid graph, and `tests/errors/NAME.txt`
//! holds its rendered diagnostics (`Diagnostics::render_plain`), compared exactly (only line
//! endings are normalised).
//!
//! Re-bless after an intended change of wording with
//!
//! ```text
//! TEXGRAPH_BLESS=1 cargo test --test it errors::
//! ```
//!
//! and read the diff of `tests/errors/*.txt` before committing it.
//!
//! Besides the golden text, every case is held to the rules every diagnostic must follow: it
//! names `tests/errors/NAME.ron:LINE:COL`, it names the node when the problem belongs to one, and
//! it shows no Rust internals (`Some(`, `None`, `Value {`, ...). A case file may also carry
//! directives in its leading comments:
//!
//! - `// expect: TEXT` — TEXT must occur in the rendering; several `expect` lines must occur in
//!   the order written (this is how "all errors, in order" is tested).
//! - `// expect-errors: N` — exactly N diagnostics.
//! - `// set: NAME=VALUE` — checked with that param override, as `--set NAME=VALUE` gives it.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use texgraph::{check, compile, CheckOptions, CompileOptions, Diagnostics, SourceFile};

const DIR: &str = "tests/errors";

/// Substrings that betray Rust internals leaking into a message meant for a texture author.
const NOISE: &[&str] = &[
    "Some(",
    "None",
    "Value {",
    "ValueKind",
    "unwrap",
    "panicked",
    "Spanned",
    "Span {",
];

use crate::common;
use common::blessing;

fn cases() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(DIR);
    let mut cases: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .map(|entry| entry.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    cases.sort();
    cases
}

fn name_of(path: &Path) -> String {
    path.file_stem()
        .and_then(|s| s.to_str())
        .expect("case names are UTF-8")
        .to_string()
}

/// Checks (and, if that passes, compiles) a case; the diagnostics it must fail with.
fn diagnose(name: &str, text: &str) -> Result<Diagnostics, String> {
    let file = SourceFile::new(format!("{DIR}/{name}.ron"), text);
    let options = CheckOptions {
        overrides: directives(text).set,
    };
    match check(file, &options) {
        Err(diagnostics) => Ok(diagnostics),
        Ok(graph) => match compile(&graph, &CompileOptions::default()) {
            Err(diagnostics) => Ok(diagnostics),
            Ok(_) => Err(format!(
                "{name}.ron: expected an error, but the graph checks and compiles"
            )),
        },
    }
}

struct Directives {
    expect: Vec<String>,
    errors: Option<usize>,
    set: Vec<(String, f64)>,
}

fn directives(text: &str) -> Directives {
    let mut d = Directives {
        expect: Vec::new(),
        errors: None,
        set: Vec::new(),
    };
    for line in text.lines() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("// expect:") {
            d.expect.push(rest.trim().to_string());
        } else if let Some(rest) = line.strip_prefix("// expect-errors:") {
            d.errors = Some(rest.trim().parse().expect("expect-errors takes a number"));
        } else if let Some(rest) = line.strip_prefix("// set:") {
            let (name, value) = rest.trim().split_once('=').expect("set: NAME=VALUE");
            let value = value.trim().parse().expect("set: a number");
            d.set.push((name.trim().to_string(), value));
        }
    }
    d
}

/// `file:LINE:COL` with LINE and COL positive integers, somewhere in `text`.
fn has_location(text: &str, file: &str) -> bool {
    let needle = format!("{file}:");
    text.match_indices(&needle).any(|(i, _)| {
        let rest = &text[i + needle.len()..];
        let mut parts = rest.splitn(3, ':');
        let line = parts.next().unwrap_or("");
        let col = parts.next().unwrap_or("");
        let col: String = col.chars().take_while(|c| c.is_ascii_digit()).collect();
        let positive = |s: &str| {
            !s.is_empty()
                && s.chars().all(|c| c.is_ascii_digit())
                && s.parse::<usize>().is_ok_and(|n| n > 0)
        };
        positive(line)
            && positive(&col)
            && rest.len() > line.len() + 1 + col.len()
            && rest[line.len() + 1 + col.len()..].starts_with(':')
    })
}

/// A problem inside an imported file is located there; the case file then appears in its
/// import chain: a line `imported from FILE:LINE:COL`.
fn imported_from(text: &str, file: &str) -> bool {
    text.lines().any(|l| {
        l.trim()
            .strip_prefix(&format!("imported from {file}:"))
            .is_some_and(|rest| {
                let mut parts = rest.split(':');
                let number = |p: Option<&str>| {
                    p.is_some_and(|s| !s.is_empty() && s.chars().all(|c| c.is_ascii_digit()))
                };
                number(parts.next()) && number(parts.next()) && parts.next().is_none()
            })
    })
}

/// The rules every rendered case must follow; returns the problems found.
fn rules(name: &str, text: &str, diagnostics: &Diagnostics, rendered: &str) -> Vec<String> {
    let mut problems = Vec::new();
    let file = format!("{DIR}/{name}.ron");
    if diagnostics.list.is_empty() {
        problems.push("no diagnostics at all".to_string());
    }
    if !has_location(rendered, &file) && !imported_from(rendered, &file) {
        problems.push(format!("does not name `{file}:LINE:COL`"));
    }
    let headers = rendered.lines().filter(|l| l.starts_with("error[")).count();
    if headers != diagnostics.list.len() {
        problems.push(format!(
            "{} diagnostics but {headers} `error[` headlines",
            diagnostics.list.len()
        ));
    }
    for (i, diagnostic) in diagnostics.list.iter().enumerate() {
        if diagnostic.span.is_none() {
            problems.push(format!(
                "diagnostic {} ({:?}) has no span, so no line and column",
                i + 1,
                diagnostic.message
            ));
        }
        if let Some(node) = &diagnostic.node {
            if !rendered.contains(&format!("node \"{node}\"")) {
                problems.push(format!(
                    "diagnostic {} belongs to node \"{node}\", but the rendering does not name it",
                    i + 1
                ));
            }
        }
    }
    for noise in NOISE {
        if rendered.contains(noise) {
            problems.push(format!("shows Rust internals: contains `{noise}`"));
        }
    }
    let d = directives(text);
    let mut from = 0;
    for expected in &d.expect {
        match rendered[from..].find(expected.as_str()) {
            Some(i) => from += i + expected.len(),
            None if rendered.contains(expected.as_str()) => problems.push(format!(
                "`{expected}` occurs, but not after the previous `expect`"
            )),
            None => problems.push(format!("does not contain `{expected}`")),
        }
    }
    if let Some(n) = d.errors {
        if diagnostics.list.len() != n {
            problems.push(format!(
                "expected {n} diagnostics, found {}",
                diagnostics.list.len()
            ));
        }
    }
    problems
}

#[test]
fn error_goldens() {
    let cases = cases();
    assert!(
        cases.len() >= 30,
        "expected at least 30 error cases in {DIR}, found {}",
        cases.len()
    );
    let bless = blessing();
    let mut failures = String::new();
    let mut blessed = Vec::new();
    for path in &cases {
        let name = name_of(path);
        let text =
            std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let diagnostics = match diagnose(&name, &text) {
            Ok(d) => d,
            Err(message) => {
                let _ = writeln!(failures, "{message}\n");
                continue;
            }
        };
        // Line endings are the only thing normalised (a CRLF checkout must not fail).
        let rendered = diagnostics.render_plain().replace("\r\n", "\n");
        for problem in rules(&name, &text, &diagnostics, &rendered) {
            let _ = writeln!(
                failures,
                "{name}.ron: {problem}\n--- rendered ---\n{rendered}"
            );
        }
        let golden = path.with_extension("txt");
        if bless {
            let current = std::fs::read_to_string(&golden)
                .ok()
                .map(|s| s.replace("\r\n", "\n"));
            if current.as_deref() != Some(rendered.as_str()) {
                std::fs::write(&golden, &rendered)
                    .unwrap_or_else(|e| panic!("{}: {e}", golden.display()));
                blessed.push(format!("{DIR}/{name}.txt"));
            }
            continue;
        }
        match std::fs::read_to_string(&golden) {
            Err(_) => {
                let _ = writeln!(
                    failures,
                    "{name}.ron: no golden {DIR}/{name}.txt; create it with `TEXGRAPH_BLESS=1 cargo test --test it errors::`\n--- rendered ---\n{rendered}"
                );
            }
            Ok(expected) => {
                let expected = expected.replace("\r\n", "\n");
                if expected != rendered {
                    let _ = writeln!(
                        failures,
                        "{name}.ron: rendering differs from {DIR}/{name}.txt (re-bless with `TEXGRAPH_BLESS=1 cargo test --test it errors::` if intended)\n{}",
                        diff(&expected, &rendered)
                    );
                }
            }
        }
    }
    if bless {
        // Straight to the process's stderr, past the test harness's capture, so the list shows
        // without `--nocapture`.
        let mut report = if blessed.is_empty() {
            format!(
                "TEXGRAPH_BLESS: all {} error goldens already up to date\n",
                cases.len()
            )
        } else {
            format!("TEXGRAPH_BLESS: wrote {} error golden(s):\n", blessed.len())
        };
        for b in &blessed {
            let _ = writeln!(report, "  {b}");
        }
        let _ = std::io::Write::write_all(&mut std::io::stderr(), report.as_bytes());
    }
    // Goldens without a case are stale leftovers of a renamed or deleted case.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(DIR);
    for entry in std::fs::read_dir(&dir)
        .expect("read tests/errors")
        .flatten()
    {
        let p = entry.path();
        if p.extension().is_some_and(|e| e == "txt") && !p.with_extension("ron").exists() {
            let _ = writeln!(
                failures,
                "{}: golden without a case (delete it)\n",
                p.display()
            );
        }
    }
    assert!(failures.is_empty(), "error goldens failed:\n\n{failures}");
}

/// A line-by-line difference, enough to see what changed.
fn diff(expected: &str, actual: &str) -> String {
    let e: Vec<&str> = expected.lines().collect();
    let a: Vec<&str> = actual.lines().collect();
    let mut out = String::new();
    for i in 0..e.len().max(a.len()) {
        match (e.get(i), a.get(i)) {
            (Some(x), Some(y)) if x == y => {
                let _ = writeln!(out, "   {x}");
            }
            (x, y) => {
                if let Some(x) = x {
                    let _ = writeln!(out, " - {x}");
                }
                if let Some(y) = y {
                    let _ = writeln!(out, " + {y}");
                }
            }
        }
    }
    out
}

/// The location rule itself must reject what it should.
#[test]
fn location_rule() {
    assert!(has_location(
        "error[x]: tests/errors/a.ron:3:14: node",
        "tests/errors/a.ron"
    ));
    assert!(!has_location(
        "error[x]: tests/errors/a.ron: node",
        "tests/errors/a.ron"
    ));
    assert!(!has_location(
        "error[x]: tests/errors/a.ron:3: node",
        "tests/errors/a.ron"
    ));
    assert!(!has_location(
        "error[x]: tests/errors/b.ron:3:4: node",
        "tests/errors/a.ron"
    ));
}

/// Each headline (`error[class]: file:line:col: message`) must be followed directly by the
/// snippet (`╭─[`), the help, or the next diagnostic. `Diagnostics::render` drops the first line
/// of miette's report, assuming it is the whole headline, but miette wraps headlines longer than
/// the 100-column width, and the wrapped remainder then leaks into the output as a stray
/// `  │ ...` line (see `interpolation_unknown.txt`, `type_list_as_input.txt`).
#[test]
fn long_headlines_do_not_leak_into_the_snippet() {
    let mut failures = String::new();
    for path in cases() {
        let name = name_of(&path);
        let text = std::fs::read_to_string(&path).expect("read case");
        let Ok(diagnostics) = diagnose(&name, &text) else {
            continue;
        };
        let rendered = diagnostics.render_plain();
        let lines: Vec<&str> = rendered.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            if !line.starts_with("error[") {
                continue;
            }
            if let Some(next) = lines.get(i + 1) {
                let ok = next.trim_start().starts_with('╭')
                    || next.trim_start().starts_with("help:")
                    || next.starts_with("error[");
                if !ok {
                    let _ = writeln!(failures, "{name}.ron: after the headline comes `{next}`");
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures}");
}

/// When the file ends inside `Graph(` (or any struct-like node), the message should say so.
/// Today it reads "expected a field name" at the end of the file, with no caret and no hint of the
/// unclosed parenthesis (see `syntax_unclosed_paren.txt`).
#[test]
fn end_of_file_inside_a_struct_says_end_of_file() {
    let text = "Graph(\n    nodes: { \"n\": Noise(input: Position, basis: Perlin) },\n    outputs: { \"n\": \"n\" },\n";
    let diagnostics = check(SourceFile::new("eof.ron", text), &CheckOptions::default())
        .expect_err("the file is cut short");
    let rendered = diagnostics.render_plain();
    assert!(rendered.contains("end of file"), "{rendered}");
    assert!(
        rendered.contains("`)`"),
        "the message says what would close it: {rendered}"
    );
}
