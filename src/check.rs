//! Stage 2, check: RON value tree → [`CheckedGraph`].
//!
//! Checking is the gate. It collects every problem in the file at once (unknown kinds and
//! references, wrong components, types, cycles, bad parameters, limits), each with the node id
//! and span, and only a graph without problems goes on. Named nodes are lowered in dependency
//! order found by an iterative depth-first search, so a chain of 10 000 nodes cannot overflow the
//! stack; inline nesting is bounded by the parser's depth limit.

use crate::diagnostic::{
    Diagnostic, DiagnosticClass as Class, Diagnostics, SourceFile, Span, Spanned,
};
use crate::graph::{
    Args, CheckedGraph, FractalParams, GraphBuilder, NodeId, Op, Origin, Output, TableKey, Type,
};
use crate::limits;
use crate::nodes::{
    self, ArgDef, ArgKind, DefaultValue, InputType, Kind, Lowering, NodeDef, OutputType,
};
use crate::noise::{Basis, Interpolation};
use crate::ops::{self, BinaryOp, Curve, Hermite, Ramp, SplineInterpolation};
use crate::syntax::{self, Text, Value, ValueKind};
use rustc_hash::FxHashMap as HashMap;
use smallvec::{smallvec, SmallVec};
use std::sync::Arc;

/// Options for checking one graph.
#[derive(Clone, Debug, Default)]
pub struct CheckOptions {
    /// `--set NAME=VALUE`: param values that replace the file's.
    pub overrides: Vec<(String, f64)>,
}

/// Parses and checks a graph file. On failure every problem found is returned.
pub fn check(file: Arc<SourceFile>, options: &CheckOptions) -> Result<CheckedGraph, Diagnostics> {
    let root = match syntax::parse(&file.text) {
        Ok(root) => root,
        Err(diagnostic) => {
            return Err(Diagnostics {
                file,
                list: vec![diagnostic],
            })
        }
    };
    let mut checker = Checker {
        file: file.clone(),
        poisoned: Vec::new(),
        // About one node per 16 bytes of graph text (measured on the seed graphs: 12 to 30).
        builder: GraphBuilder::with_capacity(file.text.len() / 16),
        diagnostics: Vec::new(),
        params: Vec::new(),
        node_index: HashMap::default(),
        lowered: Vec::new(),
        written: 0,
    };
    let result = checker.graph(&root, options);
    if checker.diagnostics.is_empty() {
        if let Some((outputs, named, declared)) = result {
            let mut stats = checker.builder.stats;
            stats.declared = declared;
            stats.written = checker.written;
            return Ok(CheckedGraph {
                file,
                nodes: checker.builder.nodes,
                outputs,
                named,
                params: checker.params,
                stats,
            });
        }
    }
    // In file order, the way an author reads them (stable: same-place problems keep their order).
    checker
        .diagnostics
        .sort_by_key(|d| d.span.map_or(usize::MAX, |s| s.start));
    Err(Diagnostics {
        file,
        list: checker.diagnostics,
    })
}

/// One argument after reading it through its [`ArgDef`].
enum Arg {
    Input(NodeId),
    Const(f64),
    Axis([f64; 3]),
    Basis(Basis, bool),
    Interpolation(&'static str, bool),
    Stops(Vec<(f64, [f64; 3])>),
    Points(Vec<(f64, f64)>),
}

struct Checker {
    file: Arc<SourceFile>,
    /// Params that failed their own check: references to them fail silently (no cascade).
    poisoned: Vec<Text>,
    builder: GraphBuilder,
    diagnostics: Vec<Diagnostic>,
    params: Vec<(String, f64)>,
    /// Node id → index in the file's `nodes` map.
    node_index: HashMap<Text, usize>,
    /// What each named node became; `None` until lowered or when it failed.
    lowered: Vec<Option<NodeId>>,
    written: usize,
}

type CheckedParts = (Vec<Output>, Vec<(Text, NodeId)>, usize);

impl Checker {
    fn error(&mut self, diagnostic: Diagnostic) {
        self.diagnostics.push(diagnostic);
    }

    fn graph(&mut self, root: &Value, options: &CheckOptions) -> Option<CheckedParts> {
        let no_fields = Vec::new();
        let fields = match &root.kind {
            ValueKind::Struct { name, fields }
                if name.as_ref().is_none_or(|n| n.value == "Graph") =>
            {
                fields
            }
            // `Graph()`: a graph with no fields (reported below as having no outputs).
            ValueKind::Tuple { name, items }
                if items.is_empty() && name.as_ref().is_none_or(|n| n.value == "Graph") =>
            {
                &no_fields
            }
            _ => {
                self.error(
                    Diagnostic::new(Class::Syntax, format!("expected `Graph(params: {{...}}, nodes: {{...}}, outputs: {{...}})`, found {}", root.kind.describe()))
                        .at(root.span)
                        .label("not a graph"),
                );
                return None;
            }
        };
        let mut params = None;
        let mut nodes = None;
        let mut outputs = None;
        for (field, value) in fields {
            let known = match field.value.as_str() {
                "params" | "nodes" | "outputs" => field.value.as_str(),
                other => {
                    let hint =
                        nodes::suggest_from(other, ["params", "nodes", "outputs"].into_iter());
                    let mut d = Diagnostic::new(
                        Class::UnknownArgument,
                        format!("unknown field `{other}` in Graph"),
                    )
                    .at(field.span)
                    .label("not a Graph field");
                    d = d.help(match hint {
                        Some(h) => format!(
                            "did you mean `{h}`? A graph has `params`, `nodes` and `outputs`"
                        ),
                        None => "a graph has `params`, `nodes` and `outputs`".into(),
                    });
                    self.error(d);
                    // Read a near miss (`node:`) as what it was meant to be, so its contents are
                    // still checked and its references do not cascade into more errors.
                    match hint {
                        Some(h) => h,
                        None => continue,
                    }
                }
            };
            let slot = match known {
                "params" => &mut params,
                "nodes" => &mut nodes,
                _ => &mut outputs,
            };
            if slot.is_some() {
                self.error(
                    Diagnostic::new(
                        Class::DuplicateName,
                        format!("field `{}` is given twice", field.value),
                    )
                    .at(field.span)
                    .label("second time"),
                );
            }
            *slot = Some(value);
        }

        let empty = Value {
            kind: ValueKind::Map(Vec::new()),
            span: root.span,
        };
        self.params(params.unwrap_or(&empty), options);
        let node_entries = self.map_entries(nodes.unwrap_or(&empty), "nodes");
        let declared = node_entries.len();
        if declared > limits::MAX_NODES {
            self.error(
                Diagnostic::new(
                    Class::Limit,
                    format!(
                        "the graph has {declared} nodes; at most {} are allowed",
                        limits::MAX_NODES
                    ),
                )
                .at(nodes.map_or(root.span, |n| n.span)),
            );
            return None;
        }
        // Register node ids first: nodes may refer to nodes declared later in the file.
        for (i, (id, _)) in node_entries.iter().enumerate() {
            if id.value.is_empty() || id.value.contains('.') {
                self.error(
                    Diagnostic::new(
                        Class::BadParameter,
                        format!("node id \"{}\" is not allowed", id.value),
                    )
                    .at(id.span)
                    .label("bad id")
                    .help("ids are non-empty and contain no `.` (it selects components: \"id.x\")"),
                );
            }
            if self.params.iter().any(|(p, _)| *p == id.value) {
                self.error(
                    Diagnostic::new(
                        Class::DuplicateName,
                        format!("\"{}\" is both a param and a node", id.value),
                    )
                    .in_node(id.value.as_str())
                    .at(id.span)
                    .label("also a param"),
                );
            }
            if let Some(first) = self.node_index.insert(id.value.clone(), i) {
                let (line, column) = self.file.line_col(node_entries[first].0.span.start);
                self.error(
                    Diagnostic::new(
                        Class::DuplicateName,
                        format!("node \"{}\" is defined twice", id.value),
                    )
                    .in_node(id.value.as_str())
                    .at(id.span)
                    .label("second definition")
                    .help(format!(
                        "first defined at line {line}, column {column}; rename one of them"
                    )),
                );
                self.node_index.insert(id.value.clone(), first);
            }
        }
        self.lowered = vec![None; declared];
        let order = self.dependency_order(&node_entries);
        for i in order {
            let (id, value) = &node_entries[i];
            let origin = Origin {
                node: Arc::from(id.value.as_str()),
                span: value.span,
            };
            self.lowered[i] = self.expression(value, &origin);
        }

        let output_entries = self.map_entries(outputs.unwrap_or(&empty), "outputs");
        if outputs.is_none() || output_entries.is_empty() {
            self.error(
                Diagnostic::new(Class::UnknownOutput, "the graph has no outputs")
                    .at(outputs.map_or(root.span, |o| o.span))
                    .help("add `outputs: { \"colour\": \"some_node\" }`"),
            );
        }
        let mut result_outputs = Vec::new();
        for (name, value) in &output_entries {
            if result_outputs.iter().any(|o: &Output| o.name == name.value) {
                self.error(
                    Diagnostic::new(
                        Class::DuplicateName,
                        format!("output \"{}\" is defined twice", name.value),
                    )
                    .at(name.span)
                    .label("second definition"),
                );
                continue;
            }
            if let Err(message) = crate::output::valid_output_name(&name.value) {
                self.error(
                    Diagnostic::new(Class::BadName, message)
                        .in_node(format!("outputs.{}", name.value).as_str())
                        .at(name.span)
                        .label("not a valid output name")
                        .help(crate::output::OUTPUT_NAME_HELP),
                );
            }
            let origin = Origin {
                node: Arc::from(format!("outputs.{}", name.value).as_str()),
                span: value.span,
            };
            if let Some(node) = self.expression(value, &origin) {
                result_outputs.push(Output {
                    name: name.value.to_string(),
                    node,
                    span: value.span,
                });
            }
        }
        let named = node_entries
            .iter()
            .enumerate()
            .filter_map(|(i, (id, _))| self.lowered[i].map(|n| (id.value.clone(), n)))
            .collect();
        Some((result_outputs, named, declared))
    }

    /// Reads a `{ "key": value, ... }` map with string keys.
    fn map_entries<'v>(&mut self, value: &'v Value, what: &str) -> Vec<(Spanned<Text>, &'v Value)> {
        let ValueKind::Map(entries) = &value.kind else {
            self.error(
                Diagnostic::new(
                    Class::Syntax,
                    format!(
                        "`{what}` must be a map `{{ \"name\": ..., }}`, found {}",
                        value.kind.describe()
                    ),
                )
                .at(value.span)
                .label("expected a map"),
            );
            return Vec::new();
        };
        let mut out = Vec::with_capacity(entries.len());
        for (key, v) in entries {
            match &key.kind {
                ValueKind::Str(s) => out.push((
                    Spanned {
                        value: s.clone(),
                        span: key.span,
                    },
                    v,
                )),
                other => self.error(
                    Diagnostic::new(
                        Class::Syntax,
                        format!("keys of `{what}` are strings, found {}", other.describe()),
                    )
                    .at(key.span)
                    .label("expected a \"quoted name\""),
                ),
            }
        }
        out
    }

    fn params(&mut self, value: &Value, options: &CheckOptions) {
        let entries = self.map_entries(value, "params");
        if entries.len() > limits::MAX_PARAMS {
            self.error(
                Diagnostic::new(
                    Class::Limit,
                    format!(
                        "the graph has {} params; at most {} are allowed",
                        entries.len(),
                        limits::MAX_PARAMS
                    ),
                )
                .at(value.span),
            );
            return;
        }
        for (name, v) in entries {
            let node = format!("params.{}", name.value);
            if self.params.iter().any(|(p, _)| *p == name.value) {
                self.error(
                    Diagnostic::new(
                        Class::DuplicateName,
                        format!("param \"{}\" is defined twice", name.value),
                    )
                    .in_node(node)
                    .at(name.span)
                    .label("second definition"),
                );
                continue;
            }
            if name.value.is_empty() || name.value.contains('.') {
                self.error(
                    Diagnostic::new(
                        Class::BadParameter,
                        format!("param name \"{}\" is not allowed", name.value),
                    )
                    .at(name.span)
                    .label("bad name")
                    .help(
                        "names are non-empty and contain no `.` (it selects components: \"id.x\")",
                    ),
                );
                self.poisoned.push(name.value.clone());
                continue;
            }
            let number = match v.kind {
                ValueKind::Number(n) if n.is_nan() => {
                    self.error(
                        Diagnostic::new(Class::BadParameter, "a param cannot be NaN")
                            .in_node(node)
                            .at(v.span)
                            .label("NaN"),
                    );
                    self.poisoned.push(name.value.clone());
                    continue;
                }
                ValueKind::Number(n) => n,
                ref other => {
                    self.error(
                        Diagnostic::new(
                            Class::Type,
                            format!("a param is a number, found {}", other.describe()),
                        )
                        .in_node(node)
                        .at(v.span)
                        .label("expected a number")
                        .help("params are named scalars; put expressions in `nodes`"),
                    );
                    self.poisoned.push(name.value.clone());
                    continue;
                }
            };
            self.params.push((name.value.to_string(), number));
        }
        for (name, value) in &options.overrides {
            if value.is_nan() {
                self.error(Diagnostic::new(
                    Class::BadParameter,
                    format!("--set {name}: a param cannot be NaN"),
                ));
            } else if let Some(slot) = self.params.iter_mut().find(|(p, _)| p == name) {
                slot.1 = *value;
            } else {
                let known: Vec<&str> = self.params.iter().map(|(p, _)| p.as_str()).collect();
                let mut d = Diagnostic::new(
                    Class::UnknownParam,
                    format!("--set {name}: the graph has no param \"{name}\""),
                );
                d = d.help(match nodes::suggest_from(name, known.iter().copied()) {
                    Some(s) => format!("did you mean \"{s}\"?"),
                    None if known.is_empty() => "the graph has no params".to_string(),
                    None => format!("its params are: {}", known.join(", ")),
                });
                self.error(d);
            }
        }
    }

    /// Orders named nodes so each comes after the nodes it refers to; reports cycles.
    fn dependency_order(&mut self, entries: &[(Spanned<Text>, &Value)]) -> Vec<usize> {
        // References of entry i: refs[starts[i]..starts[i + 1]] (flat, one allocation).
        let mut refs: Vec<usize> = Vec::with_capacity(entries.len() * 2);
        let mut starts: Vec<usize> = Vec::with_capacity(entries.len() + 1);
        let mut walk = Vec::new();
        for (_, value) in entries {
            let first = refs.len();
            starts.push(first);
            collect_references(value, &mut walk, &mut |name| {
                let base = name.split('.').next().unwrap_or(name);
                if let Some(&j) = self.node_index.get(base) {
                    if !refs[first..].contains(&j) {
                        refs.push(j);
                    }
                }
            });
        }
        starts.push(refs.len());
        let deps = |v: usize| &refs[starts[v]..starts[v + 1]];
        const WHITE: u8 = 0;
        const GREY: u8 = 1;
        const BLACK: u8 = 2;
        let mut state = vec![WHITE; entries.len()];
        let mut in_cycle = vec![false; entries.len()];
        let mut order = Vec::with_capacity(entries.len());
        for root in 0..entries.len() {
            if state[root] != WHITE {
                continue;
            }
            state[root] = GREY;
            let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
            while let Some(&mut (v, ref mut next)) = stack.last_mut() {
                if let Some(&w) = deps(v).get(*next) {
                    *next += 1;
                    match state[w] {
                        WHITE => {
                            state[w] = GREY;
                            stack.push((w, 0));
                        }
                        GREY => {
                            let start = stack.iter().position(|&(u, _)| u == w).unwrap_or(0);
                            let cycle: Vec<usize> =
                                stack[start..].iter().map(|&(u, _)| u).collect();
                            if cycle.iter().all(|&u| !in_cycle[u]) {
                                let mut names: Vec<String> = cycle
                                    .iter()
                                    .map(|&u| format!("\"{}\"", entries[u].0.value))
                                    .collect();
                                names.push(format!("\"{}\"", entries[w].0.value));
                                let (id, value) = &entries[w];
                                self.error(
                                    Diagnostic::new(
                                        Class::Cycle,
                                        format!("the graph has a cycle: {}", names.join(" -> ")),
                                    )
                                    .in_node(id.value.as_str())
                                    .at(value.span)
                                    .label("depends on itself through this expression")
                                    .help("a node cannot use its own value; break the loop"),
                                );
                            }
                            for u in cycle {
                                in_cycle[u] = true;
                            }
                        }
                        _ => {}
                    }
                } else {
                    state[v] = BLACK;
                    if !in_cycle[v] {
                        order.push(v);
                    }
                    stack.pop();
                }
            }
        }
        order
    }

    /// Lowers one input expression. `None` means it failed (and a diagnostic was recorded, here
    /// or for the node it refers to).
    fn expression(&mut self, value: &Value, origin: &Origin) -> Option<NodeId> {
        let here = Origin {
            node: origin.node.clone(),
            span: value.span,
        };
        match &value.kind {
            ValueKind::Number(v) => {
                if v.is_nan() {
                    self.error(
                        Diagnostic::new(Class::BadParameter, "NaN is not allowed as a literal")
                            .in_node(&*origin.node)
                            .at(value.span)
                            .label("NaN")
                            .help("a NaN literal would make every result NaN"),
                    );
                    return None;
                }
                Some(self.builder.add(Op::ConstScalar(*v), Args::new(), &here))
            }
            ValueKind::Str(name) => self.reference(name, value.span, origin),
            ValueKind::Tuple { name: None, items } => {
                if items.len() != 3 {
                    self.error(
                        Diagnostic::new(
                            Class::Type,
                            format!(
                                "a vec3 literal has 3 components, this one has {}",
                                items.len()
                            ),
                        )
                        .in_node(&*origin.node)
                        .at(value.span)
                        .label("expected (x, y, z)"),
                    );
                    return None;
                }
                let mut components = Vec::with_capacity(3);
                for item in items {
                    components.push(self.typed_input(
                        item,
                        InputType::Scalar,
                        &"a vec3 component",
                        origin,
                    ));
                }
                let components: Option<Args> = components.into_iter().collect();
                Some(self.builder.add(Op::Combine, components?, &here))
            }
            ValueKind::Ident(kind_name) => {
                self.node(kind_name, value.span, &[], &[], value, origin)
            }
            ValueKind::Tuple {
                name: Some(kind_name),
                items,
            } => self.node(&kind_name.value, kind_name.span, items, &[], value, origin),
            ValueKind::Struct {
                name: Some(kind_name),
                fields,
            } => self.node(&kind_name.value, kind_name.span, &[], fields, value, origin),
            other => {
                self.error(
                    Diagnostic::new(Class::Type, format!("expected an input (a \"reference\", a number, a vec3 (x, y, z) or a node), found {}", other.describe()))
                        .in_node(&*origin.node)
                        .at(value.span)
                        .label("not an input"),
                );
                None
            }
        }
    }

    fn reference(&mut self, text: &str, span: Span, origin: &Origin) -> Option<NodeId> {
        let here = Origin {
            node: origin.node.clone(),
            span,
        };
        // A name that failed its own check (an id with a `.`, a bad param) resolves silently.
        if self.poisoned.iter().any(|p| p == text)
            || self
                .node_index
                .get(text)
                .is_some_and(|_| text.contains('.'))
        {
            return None;
        }
        let (base, component) = match text.split_once('.') {
            Some((b, c)) => (b, Some(c)),
            None => (text, None),
        };
        if self.poisoned.iter().any(|p| p == base) {
            return None;
        }
        let target = if let Some((_, v)) = self.params.iter().find(|(p, _)| p == base) {
            let v = *v;
            Some(self.builder.add(Op::ConstScalar(v), Args::new(), &here))
        } else if let Some(&i) = self.node_index.get(base) {
            // Lowered already (dependency order) or failed with its own diagnostic.
            self.lowered.get(i).copied().flatten()
        } else {
            let candidates: Vec<&str> = self
                .node_index
                .keys()
                .map(|s| s.as_str())
                .chain(self.params.iter().map(|(p, _)| p.as_str()))
                .collect();
            let mut d = Diagnostic::new(
                Class::UnknownReference,
                format!("unknown reference \"{base}\""),
            )
            .in_node(&*origin.node)
            .at(span)
            .label("no node or param has this name");
            if nodes::lookup(base).is_some() {
                d = d.help(format!("`{base}` is a node kind: write it without quotes"));
            } else if let Some(s) = nodes::suggest_from(base, candidates.iter().copied()) {
                d = d.help(format!("did you mean \"{s}\"?"));
            }
            self.error(d);
            return None;
        };
        let target = target?;
        let Some(component) = component else {
            return Some(target);
        };
        let axis = match component {
            "x" | "r" => 0,
            "y" | "g" => 1,
            "z" | "b" => 2,
            _ => {
                self.error(
                    Diagnostic::new(
                        Class::WrongComponent,
                        format!("\"{text}\": there is no component `{component}`"),
                    )
                    .in_node(&*origin.node)
                    .at(span)
                    .label("unknown component")
                    .help("components are .x .y .z (or .r .g .b)"),
                );
                return None;
            }
        };
        if self.builder.ty(target) != Type::Vec3 {
            self.error(
                Diagnostic::new(
                    Class::WrongComponent,
                    format!("\"{text}\": \"{base}\" is a scalar and has no components"),
                )
                .in_node(&*origin.node)
                .at(span)
                .label("scalar")
                .help(format!("use \"{base}\" itself")),
            );
            return None;
        }
        Some(
            self.builder
                .add(Op::Component(axis), smallvec![target], &here),
        )
    }

    /// Lowers an input and checks its type (a vec3 where a scalar is expected is an error; a
    /// scalar where a vec3 is expected is an error unless the type is `Any`).
    fn typed_input(
        &mut self,
        value: &Value,
        ty: InputType,
        what: &dyn std::fmt::Display,
        origin: &Origin,
    ) -> Option<NodeId> {
        let id = self.expression(value, origin)?;
        let actual = self.builder.ty(id);
        let ok = match ty {
            InputType::Any => true,
            InputType::Scalar => actual == Type::Scalar,
            InputType::Vec3 => actual == Type::Vec3,
        };
        if !ok {
            let expected = if ty == InputType::Scalar {
                "scalar"
            } else {
                "vec3"
            };
            let help = if ty == InputType::Scalar {
                "pick one component with \"id.x\", or reduce the vector with Length or Dot"
            } else {
                "build a point with Combine(x, y, z), or use Position"
            };
            self.error(
                Diagnostic::new(
                    Class::Type,
                    format!("{what} must be a {expected}, found a {actual}"),
                )
                .in_node(&*origin.node)
                .at(value.span)
                .label(format!("this is a {actual}"))
                .help(help),
            );
            return None;
        }
        Some(id)
    }

    fn constant_scalar(
        &mut self,
        value: &Value,
        arg: &ArgDef,
        range: nodes::Range,
        def: &NodeDef,
        origin: &Origin,
    ) -> Option<f64> {
        let id = self.typed_input(
            value,
            InputType::Scalar,
            &ArgName(arg.name, def.name),
            origin,
        )?;
        let Some(v) = self.builder.const_scalar(id) else {
            self.error(
                Diagnostic::new(
                    Class::NotConstant,
                    format!("`{}` of {} must be a constant", arg.name, def.name),
                )
                .in_node(&*origin.node)
                .at(value.span)
                .label("varies per point")
                .help("use a number, a param, or an expression of those"),
            );
            return None;
        };
        if !v.is_finite() || !range.contains(v) {
            let label = if v.is_finite() && range.integer && v.fract() != 0.0 {
                "not an integer"
            } else {
                "out of range"
            };
            self.error(
                Diagnostic::new(
                    Class::BadParameter,
                    format!(
                        "`{}` of {} must be {}, got {}",
                        arg.name,
                        def.name,
                        range.describe(),
                        crate::diagnostic::number(v)
                    ),
                )
                .in_node(&*origin.node)
                .at(value.span)
                .label(label),
            );
            return None;
        }
        Some(v)
    }

    fn constant_vec3(
        &mut self,
        value: &Value,
        what: &dyn std::fmt::Display,
        origin: &Origin,
    ) -> Option<[f64; 3]> {
        let id = self.expression(value, origin)?;
        let v = self.builder.const_vec3(id);
        match v {
            Some(v) if v.iter().all(|c| c.is_finite()) => Some(v),
            Some(_) => {
                self.error(
                    Diagnostic::new(Class::BadParameter, format!("{what} must be finite"))
                        .in_node(&*origin.node)
                        .at(value.span)
                        .label("not finite"),
                );
                None
            }
            None => {
                self.error(
                    Diagnostic::new(Class::NotConstant, format!("{what} must be a constant"))
                        .in_node(&*origin.node)
                        .at(value.span)
                        .label("varies per point")
                        .help("use (r, g, b) numbers or params"),
                );
                None
            }
        }
    }

    /// A node expression `Kind`, `Kind(a, b)` or `Kind(name: a, ...)`.
    fn node(
        &mut self,
        kind_name: &str,
        kind_span: Span,
        positional: &[Value],
        named: &[(Spanned<Text>, Value)],
        whole: &Value,
        origin: &Origin,
    ) -> Option<NodeId> {
        self.written += 1;
        if self.written == limits::MAX_NODES + 1 {
            self.error(
                Diagnostic::new(
                    Class::Limit,
                    format!(
                        "the graph has more than {} nodes (inline nodes included)",
                        limits::MAX_NODES
                    ),
                )
                .in_node(&*origin.node)
                .at(whole.span),
            );
        }
        if self.written > limits::MAX_NODES {
            return None;
        }
        let Some(def) = nodes::lookup(kind_name) else {
            let mut d = Diagnostic::new(
                Class::UnknownKind,
                format!("unknown node kind `{kind_name}`"),
            )
            .in_node(&*origin.node)
            .at(kind_span)
            .label("not a node kind");
            if let Some(s) = nodes::suggest(kind_name) {
                d = d.help(format!("did you mean `{s}`?"));
            } else if self.node_index.contains_key(kind_name)
                || self.params.iter().any(|(p, _)| p == kind_name)
            {
                d = d.help(format!("references are strings: write \"{kind_name}\""));
            } else {
                d = d.help("`texgraph nodes` lists every kind");
            }
            self.error(d);
            return None;
        };
        let here = Origin {
            node: origin.node.clone(),
            span: whole.span,
        };

        // Match the written arguments to the definition's.
        // Inline vectors: every node expression passes through here (no kind has more than 8
        // arguments).
        let mut given: SmallVec<[Option<&Value>; 8]> = smallvec::smallvec![None; def.args.len()];
        if positional.len() > def.args.len() {
            self.error(
                Diagnostic::new(
                    Class::UnknownArgument,
                    format!(
                        "{} takes {} argument(s), found {}",
                        def.name,
                        def.args.len(),
                        positional.len()
                    ),
                )
                .in_node(&*origin.node)
                .at(positional[def.args.len()].span)
                .label("extra argument")
                .help(signature(def)),
            );
            return None;
        }
        for (slot, value) in given.iter_mut().zip(positional) {
            *slot = Some(value);
        }
        let mut ok = true;
        // Arguments a misspelt name probably meant: not also reported as missing.
        let mut meant: Vec<&str> = Vec::new();
        for (field, value) in named {
            match def.args.iter().position(|a| a.name == field.value) {
                Some(i) if given[i].is_some() => {
                    self.error(
                        Diagnostic::new(
                            Class::DuplicateName,
                            format!("`{}` is given twice", field.value),
                        )
                        .in_node(&*origin.node)
                        .at(field.span)
                        .label("second time"),
                    );
                    ok = false;
                }
                Some(i) => given[i] = Some(value),
                None => {
                    let mut d = Diagnostic::new(
                        Class::UnknownArgument,
                        format!("{} has no argument `{}`", def.name, field.value),
                    )
                    .in_node(&*origin.node)
                    .at(field.span)
                    .label("unknown argument");
                    let suggestion =
                        nodes::suggest_from(&field.value, def.args.iter().map(|a| a.name));
                    meant.extend(suggestion);
                    d = d.help(match suggestion {
                        Some(s) => format!("did you mean `{s}`? {}", signature(def)),
                        None => signature(def),
                    });
                    self.error(d);
                    ok = false;
                }
            }
        }
        let mut args: SmallVec<[Option<Arg>; 8]> = SmallVec::new();
        for (arg, value) in def.args.iter().zip(&given) {
            let read = match value {
                Some(value) => self.argument(value, arg, def, origin),
                None => match arg.default {
                    Some(default) => Some(self.default_argument(default, arg, &here)),
                    None if meant.contains(&arg.name) => None,
                    None => {
                        self.error(
                            Diagnostic::new(
                                Class::MissingArgument,
                                format!("{} needs `{}`", def.name, arg.name),
                            )
                            .in_node(&*origin.node)
                            .at(whole.span)
                            .label(format!("`{}` missing", arg.name))
                            .help(signature(def)),
                        );
                        None
                    }
                },
            };
            ok &= read.is_some();
            args.push(read);
        }
        if !ok {
            return None;
        }
        let args: SmallVec<[Arg; 8]> = args.into_iter().collect::<Option<_>>()?;
        self.build(def, args, &given, whole, &here)
    }

    fn default_argument(&mut self, default: DefaultValue, arg: &ArgDef, here: &Origin) -> Arg {
        match (default, arg.kind) {
            (DefaultValue::Number(v), ArgKind::Input(_)) => {
                Arg::Input(self.builder.add(Op::ConstScalar(v), Args::new(), here))
            }
            (DefaultValue::Number(v), _) => Arg::Const(v),
            (DefaultValue::Vec3(v), _) => Arg::Axis(v),
            (DefaultValue::Name(n), _) => Arg::Interpolation(n, false),
        }
    }

    fn argument(
        &mut self,
        value: &Value,
        arg: &ArgDef,
        def: &NodeDef,
        origin: &Origin,
    ) -> Option<Arg> {
        match arg.kind {
            ArgKind::Input(ty) => self
                .typed_input(value, ty, &ArgName(arg.name, def.name), origin)
                .map(Arg::Input),
            ArgKind::ConstScalar(range) => self
                .constant_scalar(value, arg, range, def, origin)
                .map(Arg::Const),
            ArgKind::ConstAxis => {
                let v = self.constant_vec3(value, &ArgName(arg.name, def.name), origin)?;
                match ops::normalise_axis(v) {
                    Some(axis) => Some(Arg::Axis(axis)),
                    None => {
                        self.error(
                            Diagnostic::new(
                                Class::BadParameter,
                                format!(
                                    "the rotation axis is zero: ({}, {}, {})",
                                    crate::diagnostic::number(v[0]),
                                    crate::diagnostic::number(v[1]),
                                    crate::diagnostic::number(v[2])
                                ),
                            )
                            .in_node(&*origin.node)
                            .at(value.span)
                            .label("zero axis")
                            .help("give the axis a direction, e.g. (0, 1, 0)"),
                        );
                        None
                    }
                }
            }
            ArgKind::Basis => self
                .basis(value, origin)
                .map(|(b, explicit)| Arg::Basis(b, explicit)),
            ArgKind::Interpolation(allowed) => {
                let name = match &value.kind {
                    ValueKind::Ident(n) => allowed.iter().find(|a| **a == n.as_str()).copied(),
                    _ => None,
                };
                match name {
                    Some(n) => Some(Arg::Interpolation(n, true)),
                    None => {
                        self.error(
                            Diagnostic::new(
                                Class::BadParameter,
                                format!(
                                    "`{}` of {} must be one of {}, found {}",
                                    arg.name,
                                    def.name,
                                    allowed.join(", "),
                                    value.kind.describe()
                                ),
                            )
                            .in_node(&*origin.node)
                            .at(value.span)
                            .label("unknown interpolation"),
                        );
                        None
                    }
                }
            }
            ArgKind::Stops => {
                let knots = self.knots(value, def, "stops", "(t, (r, g, b))", origin)?;
                let mut stops = Vec::with_capacity(knots.len());
                for (t, v) in knots {
                    stops.push((t, self.constant_vec3(v, &"a stop's colour", origin)?));
                }
                Some(Arg::Stops(stops))
            }
            ArgKind::Points => {
                let knots = self.knots(value, def, "points", "(x, y)", origin)?;
                let mut points = Vec::with_capacity(knots.len());
                let y_def = ArgDef {
                    name: "y",
                    kind: ArgKind::ConstScalar(nodes::Range::FINITE),
                    default: None,
                    doc: "",
                };
                for (x, v) in knots {
                    points.push((
                        x,
                        self.constant_scalar(v, &y_def, nodes::Range::FINITE, def, origin)?,
                    ));
                }
                Some(Arg::Points(points))
            }
        }
    }

    /// Reads `[(key, value), ...]`: constant, finite, sorted keys; the values are returned raw.
    fn knots<'v>(
        &mut self,
        value: &'v Value,
        def: &NodeDef,
        what: &str,
        form: &str,
        origin: &Origin,
    ) -> Option<Vec<(f64, &'v Value)>> {
        let ValueKind::List(items) = &value.kind else {
            self.error(
                Diagnostic::new(
                    Class::Type,
                    format!(
                        "`{what}` of {} is a list [{form}, ...], found {}",
                        def.name,
                        value.kind.describe()
                    ),
                )
                .in_node(&*origin.node)
                .at(value.span)
                .label("expected a list"),
            );
            return None;
        };
        if items.is_empty() {
            self.error(
                Diagnostic::new(
                    Class::BadParameter,
                    format!("`{what}` of {} is empty", def.name),
                )
                .in_node(&*origin.node)
                .at(value.span)
                .label("needs at least one entry"),
            );
            return None;
        }
        if items.len() > limits::MAX_RAMP_STOPS {
            self.error(
                Diagnostic::new(
                    Class::Limit,
                    format!(
                        "`{what}` of {} has {} entries; at most {} are allowed",
                        def.name,
                        items.len(),
                        limits::MAX_RAMP_STOPS
                    ),
                )
                .in_node(&*origin.node)
                .at(value.span),
            );
            return None;
        }
        let key_def = ArgDef {
            name: "t",
            kind: ArgKind::ConstScalar(nodes::Range::FINITE),
            default: None,
            doc: "",
        };
        let mut out: Vec<(f64, &Value)> = Vec::with_capacity(items.len());
        for item in items {
            let ValueKind::Tuple {
                name: None,
                items: pair,
            } = &item.kind
            else {
                self.error(
                    Diagnostic::new(
                        Class::Type,
                        format!(
                            "each entry of `{what}` is {form}, found {}",
                            item.kind.describe()
                        ),
                    )
                    .in_node(&*origin.node)
                    .at(item.span)
                    .label(format!("expected {form}")),
                );
                return None;
            };
            if pair.len() != 2 {
                self.error(
                    Diagnostic::new(
                        Class::Type,
                        format!(
                            "each entry of `{what}` is {form}, this one has {} items",
                            pair.len()
                        ),
                    )
                    .in_node(&*origin.node)
                    .at(item.span)
                    .label(format!("expected {form}")),
                );
                return None;
            }
            let key =
                self.constant_scalar(&pair[0], &key_def, nodes::Range::FINITE, def, origin)?;
            if let Some(&(previous, _)) = out.last() {
                if key < previous {
                    self.error(
                        Diagnostic::new(
                            Class::BadParameter,
                            format!(
                                "`{what}` of {} are not sorted: {key} comes after {previous}",
                                def.name
                            ),
                        )
                        .in_node(&*origin.node)
                        .at(pair[0].span)
                        .label("smaller than the one before")
                        .help("sort the entries by their first number"),
                    );
                    return None;
                }
            }
            out.push((key, &pair[1]));
        }
        Some(out)
    }

    /// Reads a basis; the flag says whether it spelled out an interpolation (`Value(Smooth)`).
    fn basis(&mut self, value: &Value, origin: &Origin) -> Option<(Basis, bool)> {
        let (name, span, inner) = match &value.kind {
            ValueKind::Ident(n) => (n.as_str(), value.span, None),
            ValueKind::Struct {
                name: Some(n),
                fields,
            } => (n.value.as_str(), n.span, Some(fields.as_slice())),
            ValueKind::Tuple {
                name: Some(n),
                items,
            } if items.len() == 1 => {
                // `Value(Smooth)`: positional interpolation.
                let interpolation = match &items[0].kind {
                    ValueKind::Ident(i) if i == "Linear" => Interpolation::Linear,
                    ValueKind::Ident(i) if i == "Smooth" => Interpolation::Smooth,
                    _ => {
                        self.error(
                            Diagnostic::new(
                                Class::BadParameter,
                                "value noise interpolation is Linear or Smooth",
                            )
                            .in_node(&*origin.node)
                            .at(items[0].span)
                            .label("unknown interpolation"),
                        );
                        return None;
                    }
                };
                if n.value == "Value" {
                    return Some((Basis::Value(interpolation), true));
                }
                (n.value.as_str(), n.span, Some([].as_slice()))
            }
            _ => ("", value.span, None),
        };
        let basis = match name {
            "Perlin" if inner.is_none() => Basis::Perlin,
            "Gradient" if inner.is_none() => Basis::Gradient,
            "Perlin" | "Gradient" => {
                self.error(
                    Diagnostic::new(
                        Class::BadParameter,
                        format!("the {name} basis takes no arguments"),
                    )
                    .in_node(&*origin.node)
                    .at(value.span)
                    .label("only Value noise has an interpolation")
                    .help(format!("write `basis: {name}`")),
                );
                return None;
            }
            "Value" => {
                let mut interpolation = Interpolation::Linear;
                for (field, v) in inner.unwrap_or(&[]) {
                    match (field.value.as_str(), &v.kind) {
                        ("interpolation", ValueKind::Ident(i)) if i == "Linear" => {
                            interpolation = Interpolation::Linear
                        }
                        ("interpolation", ValueKind::Ident(i)) if i == "Smooth" => {
                            interpolation = Interpolation::Smooth
                        }
                        _ => {
                            self.error(
                                Diagnostic::new(Class::BadParameter, "Value noise takes `interpolation: Linear` or `interpolation: Smooth`")
                                    .in_node(&*origin.node)
                                    .at(field.span.to(v.span))
                                    .label("not understood"),
                            );
                            return None;
                        }
                    }
                }
                return Some((
                    Basis::Value(interpolation),
                    inner.is_some_and(|f| !f.is_empty()),
                ));
            }
            _ => {
                let mut d = Diagnostic::new(
                    Class::BadParameter,
                    format!("unknown noise basis {}", value.kind.describe()),
                )
                .in_node(&*origin.node)
                .at(span)
                .label("not a basis");
                d = d.help(
                    match nodes::suggest_from(name, ["Perlin", "Gradient", "Value"].into_iter()) {
                        Some(s) if !name.is_empty() => format!("did you mean `{s}`?"),
                        _ => "the bases are Perlin, Gradient and Value".into(),
                    },
                );
                self.error(d);
                return None;
            }
        };
        Some((basis, false))
    }

    /// Turns a node's checked arguments into graph operations.
    fn build(
        &mut self,
        def: &NodeDef,
        args: SmallVec<[Arg; 8]>,
        given: &[Option<&Value>],
        whole: &Value,
        here: &Origin,
    ) -> Option<NodeId> {
        let input = |i: usize| match args[i] {
            Arg::Input(id) => id,
            _ => unreachable_arg(),
        };
        let constant = |i: usize| match args[i] {
            Arg::Const(v) => v,
            _ => 0.0,
        };
        let unary = |op| Op::Unary(op);
        let op_args: (Op, Args) = match def.lowering {
            Lowering::Position => (Op::Position, Args::new()),
            Lowering::Combine => (Op::Combine, smallvec![input(0), input(1), input(2)]),
            Lowering::Scale | Lowering::Translate => {
                let by = self.builder.broadcast(input(1), Type::Vec3, here);
                let op = if def.lowering == Lowering::Scale {
                    BinaryOp::Mul
                } else {
                    BinaryOp::Add
                };
                (Op::Binary(op), smallvec![input(0), by])
            }
            Lowering::Rotate => {
                let Arg::Axis(axis) = args[1] else {
                    return None;
                };
                (Op::Rotate { axis }, smallvec![input(0), input(2)])
            }
            Lowering::Noise | Lowering::Fractal { .. } => {
                let Arg::Basis(basis, explicit) = args[1] else {
                    return None;
                };
                let interpolation_index = if def.kind == Kind::Noise { 3 } else { 7 };
                let basis = match (basis, &args[interpolation_index]) {
                    (Basis::Value(written), Arg::Interpolation(field, true))
                        if explicit && written != interpolation_named(field) =>
                    {
                        let span = given[interpolation_index].map_or(whole.span, |v| v.span);
                        self.error(
                            Diagnostic::new(
                                Class::BadParameter,
                                "the interpolation is given twice, differently: in `basis` and in `interpolation`",
                            )
                            .in_node(&*here.node)
                            .at(span)
                            .label("contradicts the basis")
                            .help("give it once"),
                        );
                        return None;
                    }
                    (Basis::Value(_), Arg::Interpolation("Smooth", true)) => {
                        Basis::Value(Interpolation::Smooth)
                    }
                    (Basis::Value(_), Arg::Interpolation("Linear", true)) => {
                        Basis::Value(Interpolation::Linear)
                    }
                    (Basis::Value(i), _) => Basis::Value(i),
                    (other, Arg::Interpolation(_, true)) => {
                        let span = given[interpolation_index].map_or(whole.span, |v| v.span);
                        self.error(
                            Diagnostic::new(Class::BadParameter, format!("`interpolation` applies to the Value basis only, not {other:?}"))
                                .in_node(&*here.node)
                                .at(span)
                                .label("not used by this basis"),
                        );
                        return None;
                    }
                    (other, _) => other,
                };
                let key = TableKey {
                    basis,
                    seed: constant(2) as u64,
                };
                if def.kind == Kind::Noise {
                    (Op::Noise(key), smallvec![input(0)])
                } else {
                    let params = FractalParams {
                        octaves: constant(3),
                        lacunarity: constant(4),
                        gain: constant(5),
                        first_octave: constant(6) as u32,
                        turbulence: def.lowering == Lowering::Fractal { turbulence: true },
                    };
                    // Octave frequencies and amplitudes grow as powers: keep them finite.
                    let schedule = params.schedule();
                    let worst = schedule
                        .frequencies
                        .iter()
                        .chain(&schedule.amplitudes)
                        .fold(0.0f64, |m, v| m.max(v.abs()));
                    if worst > limits::MAX_OCTAVE_SCALE {
                        self.error(
                            Diagnostic::new(
                                Class::BadParameter,
                                format!(
                                    "octave frequencies or amplitudes reach {}, above the limit {}",
                                    crate::diagnostic::number(worst),
                                    crate::diagnostic::number(limits::MAX_OCTAVE_SCALE)
                                ),
                            )
                            .in_node(&*here.node)
                            .at(whole.span)
                            .label("lacunarity^i or gain^i too large")
                            .help("use fewer octaves, a smaller first_octave, lacunarity or gain"),
                        );
                        return None;
                    }
                    (Op::Fractal(key, params), smallvec![input(0)])
                }
            }
            Lowering::Binary(op) => (
                Op::Binary(op),
                self.broadcast_all(&[input(0), input(1)], here),
            ),
            Lowering::Unary(op) => (unary(op), smallvec![input(0)]),
            Lowering::Length => (Op::Length, smallvec![input(0)]),
            Lowering::Dot => (Op::Dot, smallvec![input(0), input(1)]),
            Lowering::Ternary(op) => (
                Op::Ternary(op),
                self.broadcast_all(&[input(0), input(1), input(2)], here),
            ),
            Lowering::Hermite => (
                Op::Hermite(Hermite {
                    p0: constant(1),
                    p1: constant(2),
                    m0: constant(3),
                    m1: constant(4),
                }),
                smallvec![input(0)],
            ),
            Lowering::Ramp | Lowering::Curve => {
                let interpolation = match args[2] {
                    Arg::Interpolation("Smooth", _) => SplineInterpolation::Smooth,
                    Arg::Interpolation("Constant", _) => SplineInterpolation::Constant,
                    _ => SplineInterpolation::Linear,
                };
                match &args[1] {
                    Arg::Stops(stops) => {
                        let ramp = Ramp::new(
                            stops.iter().map(|s| s.0).collect(),
                            stops.iter().map(|s| s.1).collect(),
                            interpolation,
                        );
                        (Op::Ramp(Arc::new(ramp)), smallvec![input(0)])
                    }
                    Arg::Points(points) => {
                        let curve = Curve::new(
                            points.iter().map(|p| p.0).collect(),
                            points.iter().map(|p| [p.1]).collect(),
                            interpolation,
                        );
                        (Op::Curve(Arc::new(curve)), smallvec![input(0)])
                    }
                    _ => return None,
                }
            }
        };
        debug_assert!(def.output != OutputType::Broadcast || !op_args.1.is_empty());
        let (op, op_args) = op_args;
        Some(self.builder.add(op, op_args, here))
    }

    /// Splats scalar operands when any operand is a vec3 (component-wise math).
    fn broadcast_all(&mut self, ids: &[NodeId], here: &Origin) -> Args {
        let ty = if ids.iter().any(|&id| self.builder.ty(id) == Type::Vec3) {
            Type::Vec3
        } else {
            Type::Scalar
        };
        ids.iter()
            .map(|&id| self.builder.broadcast(id, ty, here))
            .collect()
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
