//! `Import`: another graph file's output, built into this graph.
//!
//! The imported file is read relative to the importing one, checked as its own file (its `set`
//! values given to it exactly as `--set` gives them) and its nodes that the output needs are
//! rebuilt here through the builder, with `Position` replaced by the `input` node. Rebuilding
//! through the builder is what makes imports cheap: one file imported twice with the same
//! arguments becomes the same nodes (hash-consing across files), constants fold through the
//! import, and the compiler then sees one graph.
//!
//! A problem inside the imported file is reported in that file (its line and column) with the
//! import chain (`imported from floor.ron:12:9`). Import cycles, missing files, unknown outputs
//! and unknown `set` params are errors at the `Import` that causes them. Imports nest at most
//! [`MAX_IMPORT_DEPTH`] deep, and the imported nodes count towards the node limit.

use super::*;
use std::path::{Path, PathBuf};

/// How deep imports may nest below the file being checked.
pub const MAX_IMPORT_DEPTH: usize = 32;

/// The stack of the thread each imported file is checked on (as a file at the top level
/// would be on the main thread's).
const IMPORT_STACK_BYTES: usize = 16 << 20;

/// An Import's checked arguments.
pub(super) struct ImportArgs<'a> {
    pub file: &'a (String, Span),
    pub output: &'a (String, Span),
    pub input: NodeId,
    pub set: &'a [(String, Span, f64)],
}

impl Checker {
    /// `set: { "name": constant, ... }`.
    pub(super) fn overrides(
        &mut self,
        value: &Value,
        origin: &Origin,
    ) -> Option<Vec<(String, Span, f64)>> {
        let ValueKind::Map(entries) = &value.kind else {
            self.error(
                Diagnostic::new(
                    Class::Type,
                    format!(
                        "`set` of Import is a map of param values, found {}",
                        value.kind.describe()
                    ),
                )
                .in_node(&*origin.node)
                .at(value.span)
                .label("expected { \"param\": value, ... }"),
            );
            return None;
        };
        let mut out: Vec<(String, Span, f64)> = Vec::with_capacity(entries.len());
        let mut ok = true;
        for (key, v) in entries {
            let ValueKind::Str(name) = &key.kind else {
                self.error(
                    Diagnostic::new(Class::Type, "a `set` key is a param name in quotes")
                        .in_node(&*origin.node)
                        .at(key.span)
                        .label("expected a string"),
                );
                ok = false;
                continue;
            };
            if out.iter().any(|(n, _, _)| n == name.as_str()) {
                self.error(
                    Diagnostic::new(Class::DuplicateName, format!("`{name}` is set twice"))
                        .in_node(&*origin.node)
                        .at(key.span)
                        .label("second time"),
                );
                ok = false;
                continue;
            }
            let what = ArgName("set", "Import");
            let Some(id) = self.typed_input(v, InputType::Scalar, &what, origin) else {
                ok = false;
                continue;
            };
            match self.builder.const_scalar(id) {
                Some(c) if c.is_finite() => out.push((name.to_string(), key.span, c)),
                _ => {
                    self.error(
                        Diagnostic::new(
                            Class::NotConstant,
                            format!("the value set for `{name}` must be a finite constant"),
                        )
                        .in_node(&*origin.node)
                        .at(v.span)
                        .label("not a finite constant")
                        .help("use a number, a param of this graph, or an expression of those"),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(out)
    }

    /// Builds an imported output into this graph (or reports why it cannot be).
    pub(super) fn import(&mut self, args: ImportArgs, here: &Origin) -> Option<NodeId> {
        let graph = self.imported_graph(&args, here)?;
        let Some(output) = graph.output(&args.output.0) else {
            let names: Vec<&str> = graph.outputs().iter().map(|o| o.name.as_str()).collect();
            let mut d = Diagnostic::new(
                Class::UnknownOutput,
                format!("{} has no output `{}`", args.file.0, args.output.0),
            )
            .in_node(&*here.node)
            .at(args.output.1)
            .label("not an output of that file");
            d = d.help(
                match nodes::suggest_from(&args.output.0, names.iter().copied()) {
                    Some(s) => format!("did you mean `{s}`?"),
                    None => format!("its outputs are: {}", names.join(", ")),
                },
            );
            self.error(d);
            return None;
        };
        let needed = reachable(graph.nodes(), output.node);
        self.written += needed.len();
        if self.written > limits::MAX_NODES {
            self.error(
                Diagnostic::new(
                    Class::Limit,
                    format!(
                        "the graph has more than {} nodes (imported nodes included)",
                        limits::MAX_NODES
                    ),
                )
                .in_node(&*here.node)
                .at(here.span),
            );
            return None;
        }
        let mut map: HashMap<NodeId, NodeId> = HashMap::default();
        for &id in &needed {
            let node = &graph.nodes()[id as usize];
            let new = match node.op {
                Op::Position => args.input,
                _ => {
                    let mapped: Args = node.args.iter().map(|a| map[a]).collect();
                    self.builder.add(node.op.clone(), mapped, here)
                }
            };
            map.insert(id, new);
        }
        Some(map[&output.node])
    }

    /// The imported file, checked (once per file and `set` values), or `None` after reporting.
    fn imported_graph(&mut self, args: &ImportArgs, here: &Origin) -> Option<Arc<CheckedGraph>> {
        let (written, file_span) = (&args.file.0, args.file.1);
        let base = Path::new(&self.file.name).parent().unwrap_or(Path::new(""));
        let path = base.join(written);
        let fail = |class: Class, message: String, label: &str| {
            Diagnostic::new(class, message)
                .in_node(&*here.node)
                .at(file_span)
                .label(label.to_string())
        };
        let canonical = match std::fs::canonicalize(&path) {
            Ok(c) => c,
            Err(e) => {
                let d = fail(
                    Class::MissingFile,
                    format!("cannot import {}: {}", path.display(), io_reason(&e)),
                    "no such graph file",
                )
                .help("the path is relative to the importing file");
                self.error(d);
                return None;
            }
        };
        if let Some(start) = self.imports.stack.iter().position(|p| *p == canonical) {
            let mut cycle: Vec<String> = self.imports.stack[start..]
                .iter()
                .map(|p| file_name(p))
                .collect();
            cycle.push(file_name(&canonical));
            let d = fail(
                Class::Cycle,
                format!("import cycle: {}", cycle.join(" → ")),
                "imports a file that imports this one",
            );
            self.error(d);
            return None;
        }
        if self.imports.stack.len() > MAX_IMPORT_DEPTH {
            let d = fail(
                Class::Limit,
                format!("imports nest more than {MAX_IMPORT_DEPTH} deep"),
                "one import too many",
            );
            self.error(d);
            return None;
        }
        if !self.imports.files.contains(&path) {
            self.imports.files.push(path.clone());
        }
        let mut key_set: Vec<(String, u64)> = args
            .set
            .iter()
            .map(|(n, _, v)| (n.clone(), v.to_bits()))
            .collect();
        key_set.sort();
        let key = (canonical.clone(), key_set);
        let result = match self.imports.cache.get(&key) {
            Some(r) => r.clone(),
            None => {
                let r = self.check_import(&path, canonical, args.set, here)?;
                self.imports.cache.insert(key, r.clone());
                r
            }
        };
        match result {
            Ok(graph) => Some(graph),
            Err(diagnostics) => {
                self.report_inner(&diagnostics, args, here);
                None
            }
        }
    }

    /// Reads and checks one imported file with this check's import context (moved in and back).
    fn check_import(
        &mut self,
        path: &Path,
        canonical: PathBuf,
        set: &[(String, Span, f64)],
        here: &Origin,
    ) -> Option<Checked> {
        let file = match crate::source::read_source(path) {
            Ok(file) => file,
            // Too large, or not UTF-8: reported in that file, like its other problems.
            Err(crate::source::LoadError::Invalid(d)) => return Some(Err(Arc::new(d))),
            Err(crate::source::LoadError::Io { source, .. }) => {
                self.error(
                    Diagnostic::new(
                        Class::MissingFile,
                        format!("cannot import {}: {}", path.display(), io_reason(&source)),
                    )
                    .in_node(&*here.node)
                    .at(here.span),
                );
                return None;
            }
        };
        let options = CheckOptions {
            overrides: set.iter().map(|(n, _, v)| (n.clone(), *v)).collect(),
        };
        let mut context = std::mem::take(&mut self.imports);
        context.stack.push(canonical);
        // Each nested check runs on its own thread: a check's frames are deep (expressions
        // nest up to the parser's limit), and 32 levels of them on one stack could overflow it.
        let nested = std::thread::scope(|scope| {
            std::thread::Builder::new()
                .name("texgraph-import".into())
                .stack_size(IMPORT_STACK_BYTES)
                .spawn_scoped(scope, move || check_with(file, &options, context))
                .map(|handle| handle.join())
        });
        let (result, mut context) = match nested {
            Ok(Ok(done)) => done,
            // No thread could be started (or it panicked, which checking never does): report it
            // at the import rather than failing the whole process.
            _ => {
                self.error(
                    Diagnostic::new(Class::Limit, "cannot check the imported file: no thread")
                        .in_node(&*here.node)
                        .at(here.span),
                );
                return None;
            }
        };
        context.stack.pop();
        self.imports = context;
        Some(result.map(Arc::new).map_err(Arc::new))
    }

    /// An imported file's diagnostics, seen from here: a `set` of a param it lacks is this
    /// file's error (at the key); the rest stay located in their file, with the chain.
    fn report_inner(&mut self, inner: &Diagnostics, args: &ImportArgs, here: &Origin) {
        let (line, column) = self.file.line_col(here.span.start);
        let at = format!("{}:{line}:{column}", self.file.name);
        for d in &inner.list {
            let unknown_set =
                d.class == Class::UnknownParam && d.span.is_none() && d.file.is_none();
            if unknown_set {
                let name = args
                    .set
                    .iter()
                    .find(|(n, _, _)| d.message.starts_with(&format!("--set {n}:")));
                if let Some((name, span, _)) = name {
                    let mut e = Diagnostic::new(
                        Class::UnknownParam,
                        format!("{} has no param \"{name}\"", args.file.0),
                    )
                    .in_node(&*here.node)
                    .at(*span)
                    .label("not a param of that file");
                    if let Some(help) = &d.help {
                        e = e.help(help.clone());
                    }
                    self.error(e);
                    continue;
                }
            }
            self.error(d.clone().imported(&inner.file, at.clone()));
        }
    }
}

/// The nodes `of` needs, itself included, in ascending id order (arguments first).
fn reachable(nodes: &[crate::graph::Node], of: NodeId) -> Vec<NodeId> {
    let mut seen = vec![false; nodes.len()];
    let mut stack = vec![of];
    seen[of as usize] = true;
    while let Some(id) = stack.pop() {
        for &a in &nodes[id as usize].args {
            if !seen[a as usize] {
                seen[a as usize] = true;
                stack.push(a);
            }
        }
    }
    (0..nodes.len() as NodeId)
        .filter(|&i| seen[i as usize])
        .collect()
}

/// An I/O error as a sentence fragment, without Rust's `(os error 2)` suffix.
fn io_reason(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".into(),
        std::io::ErrorKind::PermissionDenied => "permission denied".into(),
        _ => {
            let text = e.to_string();
            text.split(" (os error").next().unwrap_or(&text).to_string()
        }
    }
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}
