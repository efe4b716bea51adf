//! The code's own layering (issue 31, ARCHITECTURE.md "Layers"): no file of `src/` refers to
//! another file that refers back to it, directly or through others, and every reference from
//! one top-level module to another goes to the same layer or a lower one of ARCHITECTURE.md's
//! table.
//!
//! A reference is what the source writes, read from the text (comments, strings and character
//! literals removed): a `use` of `crate::…`, `super::…`, `self::…`, a child module or an
//! imported module, and any such path written in code (`crate::noise::batch::CHUNK`,
//! `super::engine::bake_into(…)`, `batch::sample(…)` after `mod batch;`). It names the file
//! of the longest module prefix of the path, without following re-exports: a `pub use` is a
//! reference of the re-exporting file, so a child that names an item through its folder's
//! `mod.rs` refers to that `mod.rs`. `mod x;` declarations and method calls are not references.
//! `src/main.rs` is the binary's own crate and is not read.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// One reference: the file it names and how it was written (for the failure message).
type Edge = (String, String);

/// The files of a crate (`src/`-relative paths → their text) and each one's references.
struct Analysis {
    /// Module path (`["bake", "engine"]`) → the file that defines it.
    modules: BTreeMap<Vec<String>, String>,
    edges: BTreeMap<String, BTreeSet<Edge>>,
}

/// `bake/engine.rs` → `["bake", "engine"]`, `bake/mod.rs` → `["bake"]`, `lib.rs` → `[]`.
fn module_of(rel: &str) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .trim_end_matches(".rs")
        .split('/')
        .map(String::from)
        .collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib")) {
        parts.pop();
    }
    parts
}

/// The text with comments, string literals (raw ones too) and character literals blanked out,
/// so that only code is left to read paths from. Lifetimes (`'a`) are kept.
fn code_only(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    let word_before = |i: usize| i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
    while i < b.len() {
        let rest = &src[i..];
        if rest.starts_with("//") {
            i += rest.find('\n').unwrap_or(rest.len());
        } else if rest.starts_with("/*") {
            let mut depth = 0;
            while i < b.len() {
                if src[i..].starts_with("/*") {
                    depth += 1;
                    i += 2;
                } else if src[i..].starts_with("*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else if !word_before(i)
            && (rest.starts_with("r#")
                || rest.starts_with("r\"")
                || rest.starts_with("br#")
                || rest.starts_with("br\""))
        {
            let start = if rest.starts_with('b') { 1 } else { 0 };
            let hashes = rest[start + 1..].bytes().take_while(|&c| c == b'#').count();
            if rest.as_bytes().get(start + 1 + hashes) == Some(&b'"') {
                let close = format!("\"{}", "#".repeat(hashes));
                let body = i + start + 2 + hashes;
                i = src[body..]
                    .find(&close)
                    .map_or(b.len(), |k| body + k + close.len());
                out.push_str("\"\"");
            } else {
                out.push('r');
                i += 1;
            }
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' {
            // A character literal ('x', '\n', '\u{..}', '\'') or a lifetime ('a).
            let lit = rest[1..].chars().next().map(|c| {
                if c == '\\' {
                    rest.get(3..)?.find('\'').map(|k| k + 4)
                } else if rest[1 + c.len_utf8()..].starts_with('\'') {
                    Some(2 + c.len_utf8())
                } else {
                    None
                }
            });
            match lit.flatten() {
                Some(len) => {
                    out.push_str("' '");
                    i += len;
                }
                None => {
                    out.push('\'');
                    i += 1;
                }
            }
        } else {
            let c = rest.chars().next().expect("not at the end");
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

/// A `use` tree's leaves: `a::{b, c::{d as e}, f::*}` → `a::b`, `a::c::d` (alias `e`), `a::f::*`.
fn expand_use(tree: &str) -> Vec<(Vec<String>, Option<String>)> {
    fn walk(prefix: &[String], tree: &str, out: &mut Vec<(Vec<String>, Option<String>)>) {
        let tree = tree.trim();
        if tree.is_empty() {
            return;
        }
        if let (Some(open), true) = (tree.find('{'), tree.ends_with('}')) {
            let mut head = prefix.to_vec();
            head.extend(
                tree[..open]
                    .split("::")
                    .map(str::trim)
                    .filter(|s| !s.is_empty())
                    .map(String::from),
            );
            let (mut depth, mut start) = (0, open + 1);
            for (k, c) in tree.char_indices().skip(open + 1) {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => walk(&head, &tree[start..k], out),
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        walk(&head, &tree[start..k], out);
                        start = k + 1;
                    }
                    _ => {}
                }
            }
            return;
        }
        let (path, alias) = match tree.split_once(" as ") {
            Some((p, a)) => (p, Some(a.trim().to_string())),
            None => (tree, None),
        };
        let mut segments = prefix.to_vec();
        segments.extend(
            path.split("::")
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(String::from),
        );
        out.push((segments, alias));
    }
    let mut out = Vec::new();
    walk(&[], tree, &mut out);
    out
}

/// The inline modules of a file (`mod tests { … }`): their byte ranges and names.
fn inline_modules(code: &str) -> Vec<(usize, usize, String)> {
    let mut found = Vec::new();
    let b = code.as_bytes();
    let mut from = 0;
    while let Some(k) = code[from..].find("mod ") {
        let at = from + k;
        from = at + 4;
        if at > 0 && (b[at - 1].is_ascii_alphanumeric() || b[at - 1] == b'_') {
            continue;
        }
        let name: String = code[at + 4..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let after = code[at + 4 + name.len()..].trim_start();
        if name.is_empty() || !after.starts_with('{') {
            continue;
        }
        let open = code.len() - after.len();
        let mut depth = 0;
        let mut end = code.len();
        for (k, c) in code[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = open + k;
                        break;
                    }
                }
                _ => {}
            }
        }
        found.push((at, end, name));
    }
    found
}

/// Every `a::b::c` path in the code (not preceded by `::` or a word character), with its
/// position.
fn paths(code: &str) -> Vec<(usize, Vec<String>)> {
    let b = code.as_bytes();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut found = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if !ident(b[i]) || (i > 0 && (ident(b[i - 1]) || b[i - 1] == b':')) {
            i += 1;
            continue;
        }
        let start = i;
        let mut segments = Vec::new();
        loop {
            let s = i;
            while i < b.len() && ident(b[i]) {
                i += 1;
            }
            segments.push(code[s..i].to_string());
            if code[i..].starts_with("::") && i + 2 < b.len() && ident(b[i + 2]) {
                i += 2;
            } else {
                break;
            }
        }
        if segments.len() > 1 {
            found.push((start, segments));
        }
    }
    found
}

impl Analysis {
    /// Reads `files` (`src/`-relative path, text).
    fn new(files: &[(String, String)]) -> Analysis {
        let modules: BTreeMap<Vec<String>, String> = files
            .iter()
            .map(|(rel, _)| (module_of(rel), rel.clone()))
            .collect();
        let mut analysis = Analysis {
            modules,
            edges: BTreeMap::new(),
        };
        for (rel, text) in files {
            let edges = analysis.references(rel, text);
            analysis.edges.insert(rel.clone(), edges);
        }
        analysis
    }

    /// The file defining the longest module prefix of `path`.
    fn file_of(&self, path: &[String]) -> Option<&String> {
        (0..=path.len())
            .rev()
            .find_map(|k| self.modules.get(&path[..k]))
    }

    fn references(&self, rel: &str, text: &str) -> BTreeSet<Edge> {
        let code = code_only(text);
        let module = module_of(rel);
        let inline = inline_modules(&code);
        let module_at = |pos: usize| {
            let mut m = module.clone();
            m.extend(
                inline
                    .iter()
                    .filter(|(a, b, _)| *a <= pos && pos <= *b)
                    .map(|(_, _, n)| n.clone()),
            );
            m
        };
        let children: BTreeSet<String> = self
            .modules
            .keys()
            .filter(|k| k.len() == module.len() + 1 && k[..module.len()] == module[..])
            .map(|k| k[module.len()].clone())
            .collect();
        let mut aliases: BTreeMap<String, Vec<String>> = BTreeMap::new();
        let resolve = |segments: &[String],
                       here: &[String],
                       aliases: &BTreeMap<String, Vec<String>>|
         -> Option<Vec<String>> {
            let first = segments.first()?.as_str();
            let mut path: Vec<String> = match first {
                "crate" => segments[1..].to_vec(),
                "super" => {
                    let ups = segments.iter().take_while(|s| *s == "super").count();
                    let mut p = here[..here.len().saturating_sub(ups)].to_vec();
                    p.extend_from_slice(&segments[ups..]);
                    p
                }
                "self" => here.iter().chain(&segments[1..]).cloned().collect(),
                _ if children.contains(first) && here == module.as_slice() => {
                    module.iter().chain(segments).cloned().collect()
                }
                _ => {
                    let target = aliases.get(first)?;
                    target.iter().chain(&segments[1..]).cloned().collect()
                }
            };
            path.retain(|s| s != "self" && s != "*");
            Some(path)
        };
        let mut edges = BTreeSet::new();
        let mut add = |path: &[String], how: String| {
            if let Some(file) = self.file_of(path) {
                if file != rel {
                    edges.insert((file.clone(), how));
                }
            }
        };
        // `use` declarations first (they bring module aliases into scope), then paths in code.
        let mut from = 0;
        let mut use_spans = Vec::new();
        while let Some(k) = code[from..].find("use ") {
            let at = from + k;
            from = at + 4;
            let b = code.as_bytes();
            if at > 0 && (b[at - 1].is_ascii_alphanumeric() || b[at - 1] == b'_') {
                continue;
            }
            let Some(end) = code[at..].find(';') else {
                break;
            };
            let tree = &code[at + 4..at + end];
            use_spans.push((at, at + end));
            for (segments, alias) in expand_use(tree) {
                let here = module_at(at);
                let Some(path) = resolve(&segments, &here, &aliases) else {
                    continue;
                };
                let last = segments.last().map(String::as_str);
                let name = alias.or_else(|| match last {
                    Some("self") => segments.iter().rev().nth(1).cloned(),
                    Some("*") | None => None,
                    Some(l) => Some(l.to_string()),
                });
                if let Some(name) = name {
                    if self.modules.contains_key(&path) {
                        aliases.insert(name, path.clone());
                    }
                }
                add(&path, format!("use {}", segments.join("::")));
            }
        }
        for (at, segments) in paths(&code) {
            if use_spans.iter().any(|&(a, b)| a <= at && at < b) {
                continue;
            }
            if let Some(path) = resolve(&segments, &module_at(at), &aliases) {
                add(&path, segments.join("::"));
            }
        }
        edges
    }

    /// Groups of files that refer to each other, directly or through others (Tarjan's strongly
    /// connected components of more than one file), each as one concrete circle of references.
    fn circles(&self) -> Vec<Vec<(String, String, String)>> {
        let names: Vec<&String> = self.edges.keys().collect();
        let index_of: BTreeMap<&String, usize> =
            names.iter().enumerate().map(|(i, n)| (*n, i)).collect();
        let next: Vec<Vec<usize>> = names
            .iter()
            .map(|n| {
                self.edges[*n]
                    .iter()
                    .filter_map(|(f, _)| index_of.get(f).copied())
                    .collect::<BTreeSet<_>>()
                    .into_iter()
                    .collect()
            })
            .collect();
        let components = strongly_connected(&next);
        components
            .into_iter()
            .filter(|c| c.len() > 1)
            .map(|c| {
                let inside: BTreeSet<usize> = c.iter().copied().collect();
                let cycle = cycle_within(&next, &inside, c[0]);
                cycle
                    .windows(2)
                    .map(|w| {
                        let (from, to) = (names[w[0]], names[w[1]]);
                        let how = self.edges[from]
                            .iter()
                            .find(|(f, _)| f == to)
                            .map(|(_, h)| h.clone())
                            .unwrap_or_default();
                        (from.clone(), to.clone(), how)
                    })
                    .collect()
            })
            .collect()
    }
}

/// Tarjan's algorithm, iterative (no recursion on the file count).
fn strongly_connected(next: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let n = next.len();
    let (mut index, mut low) = (vec![usize::MAX; n], vec![0; n]);
    let (mut on_stack, mut stack, mut out) = (vec![false; n], Vec::new(), Vec::new());
    let mut counter = 0;
    for root in 0..n {
        if index[root] != usize::MAX {
            continue;
        }
        let mut work = vec![(root, 0usize)];
        while let Some(&mut (v, ref mut child)) = work.last_mut() {
            if *child == 0 && index[v] == usize::MAX {
                index[v] = counter;
                low[v] = counter;
                counter += 1;
                stack.push(v);
                on_stack[v] = true;
            }
            if let Some(&w) = next[v].get(*child) {
                *child += 1;
                if index[w] == usize::MAX {
                    work.push((w, 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            work.pop();
            if let Some(&(parent, _)) = work.last() {
                low[parent] = low[parent].min(low[v]);
            }
            if low[v] == index[v] {
                let mut component = Vec::new();
                while let Some(w) = stack.pop() {
                    on_stack[w] = false;
                    component.push(w);
                    if w == v {
                        break;
                    }
                }
                out.push(component);
            }
        }
    }
    out
}

/// A circle through `start` inside one strongly connected group: `start, …, start`.
fn cycle_within(next: &[Vec<usize>], inside: &BTreeSet<usize>, start: usize) -> Vec<usize> {
    // Breadth-first from start's successors back to start: the shortest circle through it.
    let mut before = BTreeMap::new();
    let mut queue = std::collections::VecDeque::from([start]);
    while let Some(v) = queue.pop_front() {
        for &w in next[v].iter().filter(|w| inside.contains(w)) {
            if w == start {
                let mut cycle = vec![start, v];
                let mut at = v;
                while at != start {
                    at = before[&at];
                    cycle.push(at);
                }
                cycle.reverse();
                return cycle;
            }
            if let std::collections::btree_map::Entry::Vacant(e) = before.entry(w) {
                e.insert(v);
                queue.push_back(w);
            }
        }
    }
    vec![start, start]
}

/// The crate's files, `src/`-relative, without the binary's `main.rs`.
fn crate_files() -> Vec<(String, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    let mut dirs = vec![src.clone()];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).expect("src/ is readable") {
            let path = entry.expect("a directory entry").path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path
                    .strip_prefix(&src)
                    .expect("under src/")
                    .to_string_lossy()
                    .replace('\\', "/");
                if rel != "main.rs" {
                    let text = std::fs::read_to_string(&path).expect("UTF-8 source");
                    files.push((rel, text));
                }
            }
        }
    }
    files.sort();
    files
}

fn circles_text(circles: &[Vec<(String, String, String)>]) -> String {
    circles
        .iter()
        .map(|c| {
            c.iter()
                .map(|(a, b, how)| format!("    {a} -> {b}   ({how})"))
                .collect::<Vec<_>>()
                .join("\n")
        })
        .collect::<Vec<_>>()
        .join("\n  and\n")
}

#[test]
fn no_file_of_src_refers_back_to_a_file_that_refers_to_it() {
    let analysis = Analysis::new(&crate_files());
    assert!(analysis.edges.len() > 50, "src/ was not read");
    let circles = analysis.circles();
    assert!(
        circles.is_empty(),
        "{} import circle(s) among the files of src/ (put the shared thing in a module below \
         both; ARCHITECTURE.md, \"Layers\"):\n{}",
        circles.len(),
        circles_text(&circles)
    );
}

/// ARCHITECTURE.md's layer table: each row `| N name | `module`, … | … |`, lowest first.
fn layer_table() -> BTreeMap<String, (usize, String)> {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("ARCHITECTURE.md"))
            .expect("ARCHITECTURE.md");
    let section = text
        .split("\n## Layers")
        .nth(1)
        .expect("ARCHITECTURE.md has a \"## Layers\" section");
    let section = section.split("\n## ").next().unwrap_or(section);
    let mut layers = BTreeMap::new();
    for row in section.lines().filter(|l| l.starts_with('|')) {
        let cells: Vec<&str> = row.trim_matches('|').split('|').map(str::trim).collect();
        let Some(level) = cells
            .first()
            .and_then(|c| c.split_whitespace().next())
            .and_then(|n| n.parse::<usize>().ok())
        else {
            continue;
        };
        for module in cells[1].split(',').map(|m| m.trim().trim_matches('`')) {
            let previous = layers.insert(module.to_string(), (level, cells[0].to_string()));
            assert!(
                previous.is_none(),
                "`{module}` is in two rows of the layer table"
            );
        }
    }
    assert!(layers.len() > 10, "no layer table found: {layers:?}");
    layers
}

#[test]
fn every_module_uses_only_its_own_layer_and_those_below() {
    let layers = layer_table();
    let analysis = Analysis::new(&crate_files());
    let top = |file: &str| {
        let m = module_of(file);
        m.first().cloned().unwrap_or_else(|| "lib".to_string())
    };
    let mut problems = Vec::new();
    let tops: BTreeSet<String> = analysis.edges.keys().map(|f| top(f)).collect();
    for t in &tops {
        if !layers.contains_key(t) {
            problems.push(format!("`{t}` is not in ARCHITECTURE.md's layer table"));
        }
    }
    for t in layers.keys().filter(|t| !tops.contains(*t)) {
        problems.push(format!(
            "the layer table names `{t}`, which src/ does not have"
        ));
    }
    for (file, edges) in &analysis.edges {
        let Some((from, from_name)) = layers.get(&top(file)) else {
            continue;
        };
        for (target, how) in edges {
            if let Some((to, to_name)) = layers.get(&top(target)) {
                if to > from {
                    problems.push(format!(
                        "{file} ({from_name}) uses {target} ({to_name}), a higher layer: `{how}`"
                    ));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The analysis itself, on small crates written here: it must find what it is there to find.
#[test]
fn the_reference_reader_finds_circles_and_ignores_what_is_not_code() {
    let crate_of = |files: &[(&str, &str)]| {
        Analysis::new(
            &files
                .iter()
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .collect::<Vec<_>>(),
        )
    };
    // Through `use super::`, a full path in code, and a facade's `pub use`.
    let circled = crate_of(&[
        ("lib.rs", "pub mod a;\npub mod b;\n"),
        (
            "a/mod.rs",
            "mod inner;\npub use inner::Thing;\npub struct Root;\n",
        ),
        ("a/inner.rs", "use super::Root;\npub struct Thing(Root);\n"),
        ("b.rs", "pub fn f() -> usize { crate::a::inner::LEN }\n"),
    ]);
    let circles = circled.circles();
    assert_eq!(circles.len(), 1, "{}", circles_text(&circles));
    let files: BTreeSet<&str> = circles[0].iter().map(|(a, _, _)| a.as_str()).collect();
    assert_eq!(files, BTreeSet::from(["a/mod.rs", "a/inner.rs"]));
    // A circle through a third file, by code paths and an imported module's alias.
    let three = crate_of(&[
        ("lib.rs", "pub mod x;\npub mod y;\npub mod z;\n"),
        ("x.rs", "pub fn f() { crate::y::g() }\n"),
        ("y.rs", "use crate::z;\npub fn g() { z::h() }\n"),
        ("z.rs", "pub fn h() { super::x::f() }\n"),
    ]);
    assert_eq!(three.circles().len(), 1);
    assert_eq!(
        three.circles()[0].len(),
        3,
        "{}",
        circles_text(&three.circles())
    );
    // Comments, strings, doc links, `mod` declarations and inline test modules that use their
    // own file are not references; a lifetime does not open a character literal.
    let clean = crate_of(&[
        ("lib.rs", "pub mod p;\npub mod q;\n"),
        (
            "p.rs",
            "//! See [`crate::q::Q`].\npub struct P<'a>(&'a str);\n\
             /* crate::q::Q */ pub const S: &str = \"crate::q::Q\";\n\
             pub const R: &str = r#\"super::q::Q\"#;\npub const C: char = '\\'';\n\
             #[cfg(test)]\nmod tests {\n    use super::*;\n}\n",
        ),
        ("q.rs", "use crate::p::P;\npub struct Q<'a>(P<'a>);\n"),
    ]);
    assert!(
        clean.circles().is_empty(),
        "{}",
        circles_text(&clean.circles())
    );
    assert_eq!(clean.edges["p.rs"], BTreeSet::new());
    assert_eq!(clean.edges["q.rs"].len(), 1);
}

/// The longest a function may be (ARCHITECTURE.md, "Size"), in lines from its `fn` to its
/// closing brace.
const MAX_FUNCTION_LINES: usize = 150;
/// The longest a source file may be, without its test module.
const MAX_FILE_LINES: usize = 1500;

/// Every `.rs` file under `root` (relative to the repository), with its text.
fn rust_files(root: &str) -> Vec<(String, String)> {
    let base = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    let mut dirs = vec![base.join(root)];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).expect("a readable folder") {
            let path = entry.expect("a directory entry").path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(base).expect("under the repository");
                let text = std::fs::read_to_string(&path).expect("UTF-8 source");
                files.push((rel.to_string_lossy().replace('\\', "/"), text));
            }
        }
    }
    files.sort();
    files
}

/// Each function of `code` (comments and strings already blanked, `code_only`): its name, its
/// first line (from 1) and its length in lines, `fn` to closing brace. Functions nested in
/// others count on their own and inside their parent; a declaration without a body (a
/// trait's) is none.
fn functions(code: &str) -> Vec<(String, usize, usize)> {
    let mut found = Vec::new();
    // Open functions: (name, first line, brace depth of their body).
    let mut open: Vec<(String, usize, usize)> = Vec::new();
    // A `fn` read whose body has not begun, and the bracket depth it was read at.
    let mut pending: Option<(String, usize, usize)> = None;
    let (mut depth, mut brackets, mut line) = (0usize, 0usize, 1usize);
    let bytes = code.as_bytes();
    for (i, &b) in bytes.iter().enumerate() {
        let word_start = i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_');
        if word_start && code[i..].starts_with("fn ") {
            let name: String = code[i + 3..]
                .trim_start()
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                pending = Some((name, line, brackets));
            }
        }
        match b {
            b'\n' => line += 1,
            b'(' | b'[' => brackets += 1,
            b')' | b']' => brackets = brackets.saturating_sub(1),
            b'{' => {
                depth += 1;
                if let Some((name, first, _)) = pending.take() {
                    open.push((name, first, depth));
                }
            }
            b'}' => {
                if open.last().is_some_and(|f| f.2 == depth) {
                    let (name, first, _) = open.pop().expect("an open function");
                    found.push((name, first, line - first + 1));
                }
                depth = depth.saturating_sub(1);
            }
            b';' if pending.as_ref().is_some_and(|p| p.2 == brackets) => pending = None,
            _ => {}
        }
    }
    found
}

/// The code of a file without its inline test module (`#[cfg(test)] mod tests { ... }`,
/// which by this project's habit comes last), and nothing of a file that is a test module
/// itself (`tests.rs`, `*_tests.rs`).
fn without_tests(rel: &str, text: &str) -> String {
    let name = rel.rsplit('/').next().unwrap_or(rel);
    if name == "tests.rs" || name.ends_with("_tests.rs") {
        return String::new();
    }
    match text.find("#[cfg(test)]\nmod ") {
        Some(at) => text[..at].to_string(),
        None => text.to_string(),
    }
}

/// No function of the library or the Python binding is longer than [`MAX_FUNCTION_LINES`],
/// and no file, without its tests, longer than [`MAX_FILE_LINES`] (ARCHITECTURE.md, "Size").
#[test]
fn no_function_or_file_is_too_long() {
    let mut problems = Vec::new();
    for (rel, text) in rust_files("src")
        .into_iter()
        .chain(rust_files("python/src"))
    {
        let code = code_only(&without_tests(&rel, &text));
        let lines = code.lines().count();
        if lines > MAX_FILE_LINES {
            problems.push(format!(
                "{rel}: {lines} lines without its tests (at most {MAX_FILE_LINES})"
            ));
        }
        for (name, first, length) in functions(&code) {
            if length > MAX_FUNCTION_LINES {
                problems.push(format!(
                    "{rel}:{first}: fn {name} is {length} lines (at most {MAX_FUNCTION_LINES})"
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The function reader counts what it should: nested functions, bodiless declarations,
/// braces in strings and comments (blanked by `code_only`).
#[test]
fn the_function_reader_measures_functions() {
    let code = code_only(
        "trait T {\n    fn f(&self);\n}\nfn a() {\n    let s = \"{\";\n    // }\n    fn b() {\n    }\n}\n\
         impl X {\n    fn c(x: [u8; 3]) -> u8 {\n        x[0]\n    }\n}\n",
    );
    assert_eq!(
        functions(&code),
        [
            ("b".to_string(), 7, 2),
            ("a".to_string(), 4, 6),
            ("c".to_string(), 11, 3)
        ]
    );
    assert_eq!(without_tests("x/tests.rs", "fn a() {}"), "");
    assert_eq!(
        without_tests("x/y.rs", "fn a() {}\n#[cfg(test)]\nmod tests {\n}\n"),
        "fn a() {}\n"
    );
}
