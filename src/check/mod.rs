//! Stage 2, check: RON value tree → [`CheckedGraph`].
//!
//! Checking is the gate. It collects every problem in the file at once (unknown kinds and
//! references, wrong components, types, cycles, bad parameters, limits), each with the node id
//! and span, and only a graph without problems goes on. Named nodes are lowered in dependency
//! order found by an iterative depth-first search, so a chain of 10 000 nodes cannot overflow the
//! stack; inline nesting is bounded by the parser's depth limit.

mod arguments;
mod composite;
mod expressions;
mod imports;
mod lowering;
mod references;
mod sections;

use crate::diagnostic::{
    Diagnostic, DiagnosticClass as Class, Diagnostics, SourceFile, Span, Spanned,
};
use crate::graph::{
    Args, CheckedGraph, FractalParams, GraphBuilder, NodeId, Op, Origin, Output, TableKey, Type,
};
use crate::limits;
use crate::nodes::{
    self, ArgDef, ArgKind, DefaultValue, FractalKind, InputType, Lowering, NodeDef, OutputType,
};
use crate::noise::{Basis, Cellular, CellularValue, Interpolation, Metric, Period, Style};
use crate::ops::{self, BinaryOp, Curve, Hermite, Ramp, SplineInterpolation};
use crate::syntax::{self, Text, Value, ValueKind};
use rustc_hash::FxHashMap as HashMap;
use smallvec::{smallvec, SmallVec};
use std::path::PathBuf;
use std::sync::Arc;

/// Options for checking one graph.
#[derive(Clone, Debug, Default)]
pub struct CheckOptions {
    /// `--set NAME=VALUE`: param values that replace the file's.
    pub overrides: Vec<(String, f64)>,
}

/// Parses and checks a graph file. On failure every problem found is returned.
pub fn check(file: Arc<SourceFile>, options: &CheckOptions) -> Result<CheckedGraph, Diagnostics> {
    let context = ImportContext::for_root(&file);
    check_with(file, options, context).0
}

/// [`check`] with the import context of the files being checked around this one (moved in and
/// handed back, so nested checks need no shared mutable state).
fn check_with(
    file: Arc<SourceFile>,
    options: &CheckOptions,
    imports: ImportContext,
) -> (Result<CheckedGraph, Diagnostics>, ImportContext) {
    let root = match syntax::parse(&file.text) {
        Ok(root) => root,
        Err(diagnostic) => {
            let error = Diagnostics {
                file,
                list: vec![diagnostic],
            };
            return (Err(error), imports);
        }
    };
    let mut checker = Checker {
        file: file.clone(),
        poisoned: Vec::new(),
        // About one node per 16 bytes of graph text (measured on the seed graphs: 12 to 30).
        builder: GraphBuilder::with_capacity(file.text.len() / 16),
        diagnostics: Vec::new(),
        params: Vec::new(),
        ranges: Vec::new(),
        node_index: HashMap::default(),
        lowered: Vec::new(),
        written: 0,
        imports,
        overridden: Vec::new(),
        node_spans: HashMap::default(),
    };
    let result = checker.graph(&root, options);
    if checker.diagnostics.is_empty() {
        if let Some((outputs, named, declared)) = result {
            let mut stats = checker.builder.stats;
            stats.declared = declared;
            stats.written = checker.written;
            let graph = CheckedGraph {
                file,
                nodes: checker.builder.nodes,
                outputs,
                named,
                params: checker.params,
                ranges: checker.ranges,
                stats,
                imports: checker.imports.files.clone(),
            };
            return (Ok(graph), checker.imports);
        }
    }
    // In file order, the way an author reads them (stable: same-place problems keep their order).
    checker
        .diagnostics
        .sort_by_key(|d| d.span.map_or(usize::MAX, |s| s.start));
    let error = Diagnostics {
        file,
        list: checker.diagnostics,
    };
    (Err(error), checker.imports)
}

/// One argument after reading it through its [`ArgDef`].
enum Arg {
    Input(NodeId),
    Const(f64),
    Axis([f64; 3]),
    Basis(Basis, bool),
    Choice(&'static str, bool),
    Period(Option<[u64; 3]>),
    Stops(Vec<(f64, [f64; 3])>),
    Points(Vec<(f64, f64)>),
    Flag(bool),
    /// A string argument and where it was written.
    Text(String, Span),
    /// An Import's `set`: each param name (and where), its constant value.
    Overrides(Vec<(String, Span, f64)>),
}

struct Checker {
    file: Arc<SourceFile>,
    /// Params that failed their own check: references to them fail silently (no cascade).
    poisoned: Vec<Text>,
    builder: GraphBuilder,
    diagnostics: Vec<Diagnostic>,
    params: Vec<(String, f64)>,
    /// The `ranges` section: (param, min, max).
    ranges: Vec<(String, f64, f64)>,
    /// Node id → index in the file's `nodes` map.
    node_index: HashMap<Text, usize>,
    /// What each named node became; `None` until lowered or when it failed.
    lowered: Vec<Option<NodeId>>,
    written: usize,
    /// The files being checked around this one, and the imports met so far.
    imports: ImportContext,
    /// The params whose values came from `--set` (or an Import's `set`), with those values.
    overridden: Vec<(String, f64)>,
    /// Each named node's definition, for tracing a bad value back to an override.
    node_spans: HashMap<Text, Span>,
}

/// An imported file and the `set` values it was checked with (sorted, as bits).
type ImportKey = (PathBuf, Vec<(String, u64)>);
/// A checked import: its graph, or its diagnostics.
type Checked = Result<Arc<CheckedGraph>, Arc<Diagnostics>>;

/// What one check shares with the checks of the files it imports (`imports.rs` reads and
/// checks them; the state is the checker's, kept here with it).
#[derive(Default)]
pub(crate) struct ImportContext {
    /// The files being checked, outermost first (canonical paths): an import of one of them is a
    /// cycle.
    stack: Vec<PathBuf>,
    /// Each (file, `set` values) checked once.
    cache: HashMap<ImportKey, Checked>,
    /// Every file imported, directly or not, in the order first met (as written, for display
    /// and for watching).
    pub(crate) files: Vec<PathBuf>,
}

impl ImportContext {
    pub(crate) fn for_root(file: &SourceFile) -> ImportContext {
        let mut context = ImportContext::default();
        context
            .stack
            .push(std::fs::canonicalize(&file.name).unwrap_or_else(|_| PathBuf::from(&file.name)));
        context
    }
}

type CheckedParts = (Vec<Output>, Vec<(Text, NodeId)>, usize);

impl Checker {
    fn error(&mut self, mut diagnostic: Diagnostic) {
        // A bad value that a `--set` (or an Import's `set`) put there says so: the file alone
        // would not explain it.
        if diagnostic.class == Class::BadParameter && diagnostic.file.is_none() {
            if let Some(span) = diagnostic.span {
                let given = self.overrides_behind(span);
                if !given.is_empty() {
                    let from = if self.imports.stack.len() > 1 {
                        "the Import's `set`"
                    } else {
                        "--set"
                    };
                    let given: Vec<String> = given
                        .iter()
                        .map(|(n, v)| format!("{n}={}", crate::diagnostic::number(*v)))
                        .collect();
                    diagnostic.message = format!(
                        "{} (the value comes from {from} {})",
                        diagnostic.message,
                        given.join(", ")
                    );
                }
            }
        }
        self.diagnostics.push(diagnostic);
    }

    /// The overridden params (`--set`, an Import's `set`) that the text at `span` refers to,
    /// directly or through the nodes it names, in the order given.
    fn overrides_behind(&self, span: Span) -> Vec<(String, f64)> {
        if self.overridden.is_empty() {
            return Vec::new();
        }
        let mut names: Vec<&str> = Vec::new();
        let mut spans = vec![span];
        let mut seen: Vec<&str> = Vec::new();
        while let Some(span) = spans.pop() {
            let Some(text) = self.file.text.get(span.start..span.end) else {
                continue;
            };
            // Every string literal in the text is a reference (or a name): `"id"`, `"id.x"`.
            for (k, quoted) in text.split('"').enumerate() {
                if k % 2 == 0 {
                    continue;
                }
                let name = quoted.split('.').next().unwrap_or(quoted);
                if seen.contains(&name) {
                    continue;
                }
                if let Some((key, node_span)) = self.node_spans.get_key_value(name) {
                    seen.push(key);
                    spans.push(*node_span);
                } else if let Some((p, _)) = self.overridden.iter().find(|(p, _)| p == name) {
                    seen.push(p);
                    names.push(p);
                }
            }
        }
        self.overridden
            .iter()
            .filter(|(p, _)| names.contains(&p.as_str()))
            .cloned()
            .collect()
    }
}

/// The values of a map (an Import's `set`), or the value itself when it is not a map.
fn map_values(value: &Value) -> Vec<&Value> {
    match &value.kind {
        ValueKind::Map(entries) => entries.iter().map(|(_, v)| v).collect(),
        _ => vec![value],
    }
}

fn unreachable_arg() -> NodeId {
    // `build` only asks for inputs at positions the catalogue declares as inputs; the catalogue
    // test pins that. Returning node 0 keeps this path panic-free should it ever be reached.
    0
}

/// "`octaves` of Fbm", formatted only when a message needs it (checking builds none on the
/// happy path).
struct ArgName(&'static str, &'static str);

impl std::fmt::Display for ArgName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "`{}` of {}", self.0, self.1)
    }
}

fn interpolation_named(name: &str) -> Interpolation {
    if name == "Smooth" {
        Interpolation::Smooth
    } else {
        Interpolation::Linear
    }
}

fn signature(def: &NodeDef) -> String {
    let args: Vec<String> = def
        .args
        .iter()
        .map(|a| match a.default {
            None => a.name.to_string(),
            Some(_) => format!("{}?", a.name),
        })
        .collect();
    format!(
        "{}({}); `texgraph nodes` explains each argument",
        def.name,
        args.join(", ")
    )
}

/// Calls `f` with every string in a value tree (strings are references in graph files).
/// `stack` is scratch space, passed in so one allocation serves every node.
fn collect_references<'v>(value: &'v Value, stack: &mut Vec<&'v Value>, f: &mut impl FnMut(&str)) {
    // Explicit stack: the tree is bounded by the parser's nesting limit, but no recursion is
    // needed at all.
    stack.clear();
    stack.push(value);
    while let Some(v) = stack.pop() {
        match &v.kind {
            ValueKind::Str(s) => f(s),
            // An Import's file and output name strings of another file, and its `set` keys that
            // file's params: none is a reference here (positionally: file, output, input, set).
            ValueKind::Tuple {
                name: Some(n),
                items,
            } if n.value == "Import" => {
                stack.extend(items.iter().skip(2).take(1));
                if let Some(set) = items.get(3) {
                    stack.extend(map_values(set));
                }
            }
            ValueKind::Struct {
                name: Some(n),
                fields,
            } if n.value == "Import" => {
                for (field, v) in fields {
                    match field.value.as_str() {
                        "file" | "output" => {}
                        "set" => stack.extend(map_values(v)),
                        _ => stack.push(v),
                    }
                }
            }
            ValueKind::Tuple { items, .. } | ValueKind::List(items) => stack.extend(items.iter()),
            ValueKind::Struct { fields, .. } => stack.extend(fields.iter().map(|(_, v)| v)),
            ValueKind::Map(entries) => {
                for (k, v) in entries {
                    stack.push(k);
                    stack.push(v);
                }
            }
            _ => {}
        }
    }
}
