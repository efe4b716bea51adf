//! Keeps docs/format.md, the reference of the graph format, true to the code:
//!
//! - the node table between `<!-- catalogue:begin -->` and `<!-- catalogue:end -->` is exactly
//!   `texgraph nodes --markdown`;
//! - every node kind has its own `###` heading or is named in backticks in "Node semantics";
//! - every ```ron block that is a graph (its first line that is not blank or a `//` comment starts
//!   with `Graph(`) checks and compiles; a ```ron invalid block must fail to check, and the
//!   ```text block after it must be its rendered diagnostics (the file named `broken.ron`);
//! - a ```text block starting `$ texgraph eval FILE X Y Z [--f64]` shows what evaluating the
//!   graph block before it prints (within the golden tests' tolerances, for libm differences);
//! - the limits table matches `texgraph::limits`, and every diagnostic class is documented.

use texgraph::diagnostic::DiagnosticClass;
use texgraph::{
    check, compile, limits, nodes, CheckOptions, CompileOptions, Real, SourceFile, Tape, Workspace,
};

const DOC: &str = "docs/format.md";
const BEGIN: &str = "<!-- catalogue:begin -->";
const END: &str = "<!-- catalogue:end -->";
/// The file name an invalid example's diagnostics are rendered with.
const BROKEN: &str = "broken.ron";

fn doc() -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(DOC);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

use crate::common;
use common::{code_blocks as blocks_of, Block};

fn code_blocks(doc: &str) -> Vec<Block> {
    blocks_of(DOC, doc)
}

/// A graph example: its first line that is not blank or a `//` comment starts with `Graph(`.
fn is_graph(block: &Block) -> bool {
    block
        .text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with("//"))
        .is_some_and(|l| l.starts_with("Graph("))
}

fn is_ron(block: &Block) -> bool {
    block.info.split_whitespace().next() == Some("ron")
}

fn is_invalid(block: &Block) -> bool {
    is_ron(block) && block.info.split_whitespace().any(|w| w == "invalid")
}

fn check_block(block: &Block) -> Result<Tape, String> {
    let file = SourceFile::new(DOC, block.text.clone());
    let graph = check(file, &CheckOptions::default()).map_err(|d| d.render_plain())?;
    compile(&graph, &CompileOptions::default()).map_err(|d| d.render_plain())
}

#[test]
fn catalogue_table_is_the_generated_one() {
    let doc = doc();
    let lines: Vec<&str> = doc.lines().collect();
    let begin = lines.iter().position(|l| l.trim() == BEGIN);
    let end = lines.iter().position(|l| l.trim() == END);
    let (Some(begin), Some(end)) = (begin, end) else {
        panic!("{DOC} must contain the lines `{BEGIN}` and `{END}`, each on its own line, around the node table");
    };
    assert!(begin < end, "{DOC}: `{BEGIN}` must come before `{END}`");
    let written = lines[begin + 1..end].join("\n");
    let written = written.trim_matches('\n');
    let generated = nodes::catalogue_markdown();
    let generated = generated.trim_matches('\n');
    if written != generated {
        let first_difference = written
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| written.lines().count().min(generated.lines().count()));
        panic!(
            "{DOC}: the node catalogue is out of date. Paste the output of `texgraph nodes --markdown` \
             (`cargo run -q -- nodes --markdown`) between `{BEGIN}` and `{END}`.\n\
             First difference at table line {}:\n  written:   {}\n  generated: {}",
            first_difference + 1,
            written.lines().nth(first_difference).unwrap_or("(nothing)"),
            generated.lines().nth(first_difference).unwrap_or("(nothing)"),
        );
    }
}

#[test]
fn every_node_kind_is_described() {
    let doc = doc();
    // The semantics: from the end of the catalogue to the next `## ` section.
    let start = doc
        .find(END)
        .unwrap_or_else(|| panic!("{DOC}: no `{END}` marker"));
    let rest = &doc[start + END.len()..];
    let mut semantics = String::new();
    let mut seen_heading = false;
    for line in rest.lines() {
        if line.starts_with("## ") {
            if seen_heading {
                break;
            }
            seen_heading = true;
        }
        semantics.push_str(line);
        semantics.push('\n');
    }
    let headings: Vec<&str> = doc
        .lines()
        .filter_map(|l| l.strip_prefix("### "))
        .map(str::trim)
        .collect();
    let mut missing = Vec::new();
    for def in nodes::CATALOGUE {
        let name = def.name;
        let heading = headings
            .iter()
            .any(|h| *h == name || *h == format!("`{name}`"));
        let mentioned =
            semantics.contains(&format!("`{name}`")) || semantics.contains(&format!("`{name}("));
        if !heading && !mentioned {
            missing.push(name);
        }
    }
    assert!(
        missing.is_empty(),
        "{DOC}: these node kinds have no `### Name` heading and are not named in backticks in the node semantics section: {}",
        missing.join(", ")
    );
}

#[test]
fn graph_examples_check() {
    let doc = doc();
    let blocks = code_blocks(&doc);
    let mut checked = 0;
    let mut failures = String::new();
    for block in blocks
        .iter()
        .filter(|b| is_ron(b) && !is_invalid(b) && is_graph(b))
    {
        checked += 1;
        if let Err(diagnostics) = check_block(block) {
            failures.push_str(&format!(
                "the ```ron block at {DOC}:{} does not check:\n{diagnostics}\n",
                block.line
            ));
        }
    }
    assert!(failures.is_empty(), "{failures}");
    // Guards the block reader itself: the document has several complete examples.
    assert!(
        checked >= 3,
        "{DOC}: found only {checked} graph examples; is the code block reader broken?"
    );
}

#[test]
fn invalid_examples_fail_with_the_documented_diagnostics() {
    let doc = doc();
    let blocks = code_blocks(&doc);
    let mut found = 0;
    for (i, block) in blocks.iter().enumerate().filter(|(_, b)| is_invalid(b)) {
        found += 1;
        let file = SourceFile::new(BROKEN, block.text.clone());
        let diagnostics = match check(file, &CheckOptions::default()) {
            Ok(_) => panic!(
                "the ```ron invalid block at {DOC}:{} checks without errors",
                block.line
            ),
            Err(d) => d.render_plain(),
        };
        let shown = blocks
            .get(i + 1)
            .filter(|b| b.info == "text")
            .unwrap_or_else(|| panic!("the ```ron invalid block at {DOC}:{} must be followed by a ```text block with its diagnostics", block.line));
        assert_eq!(
            shown.text.trim_end(),
            diagnostics.trim_end(),
            "the diagnostics shown at {DOC}:{} are out of date: save the block before it as {BROKEN} and paste \
             the output of `texgraph check {BROKEN}`",
            shown.line
        );
    }
    assert!(
        found >= 1,
        "{DOC}: expected an invalid example (```ron invalid) with its rendered diagnostics"
    );
}

/// Evaluates `tape` at `point` and formats the lines `texgraph eval` prints, as (name, values).
fn eval_lines<S: Real>(tape: &Tape, point: [f64; 3]) -> Vec<(String, Vec<f64>)> {
    let mut workspace = Workspace::<S>::new();
    let mut out = vec![S::ZERO; tape.channels()];
    tape.eval_point(&mut workspace, point, &mut out);
    tape.outputs()
        .iter()
        .map(|o| {
            (
                o.name.clone(),
                out[o.first_channel..o.first_channel + o.ty.channels()]
                    .iter()
                    .map(|v| v.to_f64())
                    .collect(),
            )
        })
        .collect()
}

#[test]
fn eval_transcripts_are_current() {
    let doc = doc();
    let blocks = code_blocks(&doc);
    let mut found = 0;
    for (i, block) in blocks.iter().enumerate() {
        let Some(command) = block
            .text
            .lines()
            .next()
            .and_then(|l| l.strip_prefix("$ texgraph eval "))
        else {
            continue;
        };
        found += 1;
        let words: Vec<&str> = command.split_whitespace().collect();
        let double = words.contains(&"--f64");
        let numbers: Vec<f64> = words.iter().filter_map(|w| w.parse().ok()).collect();
        assert_eq!(
            numbers.len(),
            3,
            "{DOC}:{}: expected `$ texgraph eval FILE X Y Z [--f64]`",
            block.line
        );
        let graph = blocks[..i]
            .iter()
            .rev()
            .find(|b| is_ron(b) && !is_invalid(b) && is_graph(b))
            .unwrap_or_else(|| {
                panic!(
                    "{DOC}:{}: no graph example before this eval transcript",
                    block.line
                )
            });
        let tape = check_block(graph).unwrap_or_else(|d| panic!("{d}"));
        let point = [numbers[0], numbers[1], numbers[2]];
        let (actual, tolerance) = if double {
            (eval_lines::<f64>(&tape, point), 1e-9)
        } else {
            (eval_lines::<f32>(&tape, point), 1e-5)
        };
        let shown: Vec<(String, Vec<f64>)> = block
            .text
            .lines()
            .skip(1)
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                let mut parts = l.split_whitespace();
                let name = parts.next().unwrap_or_default().to_string();
                let values = parts.map(|v| v.parse().unwrap_or(f64::NAN)).collect();
                (name, values)
            })
            .collect();
        let matches = shown.len() == actual.len()
            && shown.iter().zip(&actual).all(|((sn, sv), (an, av))| {
                sn == an
                    && sv.len() == av.len()
                    && sv
                        .iter()
                        .zip(av)
                        .all(|(s, a)| (s - a).abs() <= tolerance || (s.is_nan() && a.is_nan()))
            });
        let printed: Vec<String> = actual
            .iter()
            .map(|(n, v)| {
                let values: Vec<String> = if double {
                    v.iter().map(|x| x.to_string()).collect()
                } else {
                    v.iter().map(|x| (*x as f32).to_string()).collect()
                };
                format!("{n} {}", values.join(" "))
            })
            .collect();
        assert!(
            matches,
            "the eval transcript at {DOC}:{} is out of date; `texgraph eval` now prints:\n{}",
            block.line,
            printed.join("\n")
        );
    }
    assert!(
        found >= 1,
        "{DOC}: expected an eval transcript (```text starting with `$ texgraph eval`)"
    );
}

#[test]
fn limits_table_matches_the_code() {
    let doc = doc();
    let limits: [(&str, String); 9] = [
        ("MAX_FILE_BYTES", limits::MAX_FILE_BYTES.to_string()),
        ("MAX_NESTING", limits::MAX_NESTING.to_string()),
        ("MAX_NODES", limits::MAX_NODES.to_string()),
        ("MAX_PARAMS", limits::MAX_PARAMS.to_string()),
        ("MAX_OCTAVES", limits::MAX_OCTAVES.to_string()),
        ("MAX_FIRST_OCTAVE", limits::MAX_FIRST_OCTAVE.to_string()),
        ("MAX_RAMP_STOPS", limits::MAX_RAMP_STOPS.to_string()),
        ("MAX_SEED", limits::MAX_SEED.to_string()),
        (
            "MAX_OCTAVE_SCALE",
            format!("{:e}", limits::MAX_OCTAVE_SCALE),
        ),
    ];
    for (name, value) in limits {
        let row = doc
            .lines()
            .find(|l| l.starts_with(&format!("| `{name}` |")))
            .unwrap_or_else(|| {
                panic!("{DOC}: the limits table has no row for `{name}` (src/limits.rs)")
            });
        let cell = row.split('|').nth(2).unwrap_or_default();
        assert!(
            cell.contains(&value),
            "{DOC}: the limits table says `{name}` is {}, src/limits.rs says {value}",
            cell.trim()
        );
    }
}

/// Every diagnostic class. The `match` has no wildcard, so a new class does not compile here
/// until it is listed (and documented).
fn all_classes() -> Vec<DiagnosticClass> {
    use DiagnosticClass::*;
    let all = vec![
        Syntax,
        UnknownKind,
        UnknownReference,
        WrongComponent,
        Type,
        Cycle,
        BadParameter,
        MissingArgument,
        UnknownArgument,
        DuplicateName,
        Limit,
        NotConstant,
        UnknownOutput,
        UnknownParam,
        BadName,
        NotDifferentiable,
        MissingFile,
    ];
    for class in &all {
        match class {
            Syntax | UnknownKind | UnknownReference | WrongComponent | Type | Cycle
            | BadParameter | MissingArgument | UnknownArgument | DuplicateName | Limit
            | NotConstant | UnknownOutput | UnknownParam | BadName | NotDifferentiable
            | MissingFile => {}
        }
    }
    all
}

#[test]
fn every_diagnostic_class_is_documented() {
    let doc = doc();
    let missing: Vec<&str> = all_classes()
        .into_iter()
        .map(|c| c.code())
        .filter(|code| !doc.lines().any(|l| l.starts_with(&format!("| `{code}` |"))))
        .collect();
    assert!(
        missing.is_empty(),
        "{DOC}: the diagnostics table has no row for: {}",
        missing.join(", ")
    );
}
