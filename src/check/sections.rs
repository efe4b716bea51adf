//! The graph's sections: `params`, `nodes` and `outputs`, read as maps with string keys.

use super::*;

impl Checker {
    pub(super) fn graph(&mut self, root: &Value, options: &CheckOptions) -> Option<CheckedParts> {
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
        let [params, nodes, outputs, ranges] = self.graph_fields(fields);
        let empty = Value {
            kind: ValueKind::Map(Vec::new()),
            span: root.span,
        };
        self.params(params.unwrap_or(&empty), options);
        if let Some(ranges) = ranges {
            self.ranges(ranges);
        }
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
        self.register_nodes(&node_entries);
        self.lowered = vec![None; declared];
        self.node_spans = node_entries
            .iter()
            .map(|(id, value)| (id.value.clone(), value.span))
            .collect();
        let order = self.dependency_order(&node_entries);
        for i in order {
            let (id, value) = &node_entries[i];
            let origin = Origin {
                node: Arc::from(id.value.as_str()),
                span: value.span,
            };
            self.lowered[i] = self.expression(value, &origin);
        }

        let result_outputs = self.outputs(root, outputs);
        let named = node_entries
            .iter()
            .enumerate()
            .filter_map(|(i, (id, _))| self.lowered[i].map(|n| (id.value.clone(), n)))
            .collect();
        Some((result_outputs, named, declared))
    }

    /// The fields of `Graph(...)`: `params`, `nodes`, `outputs` and `ranges`, in that order,
    /// each at most once; an unknown field is an error (a near miss, `node:`, is read as what
    /// it was meant to be, so its contents are still checked and its references do not
    /// cascade into more errors).
    fn graph_fields<'v>(&mut self, fields: &'v [(Spanned<Text>, Value)]) -> [Option<&'v Value>; 4] {
        const FIELDS: [&str; 4] = ["params", "nodes", "outputs", "ranges"];
        let mut found = [None; 4];
        for (field, value) in fields {
            let known = match FIELDS.iter().position(|f| *f == field.value.as_str()) {
                Some(k) => k,
                None => {
                    let other = field.value.as_str();
                    let hint = nodes::suggest_from(other, FIELDS.into_iter());
                    let mut d = Diagnostic::new(
                        Class::UnknownArgument,
                        format!("unknown field `{other}` in Graph"),
                    )
                    .at(field.span)
                    .label("not a Graph field");
                    d = d.help(match hint {
                        Some(h) => format!(
                            "did you mean `{h}`? A graph has `params`, `nodes`, `outputs` and `ranges`"
                        ),
                        None => "a graph has `params`, `nodes`, `outputs` and `ranges`".into(),
                    });
                    self.error(d);
                    match hint.and_then(|h| FIELDS.iter().position(|f| *f == h)) {
                        Some(k) => k,
                        None => continue,
                    }
                }
            };
            if found[known].is_some() {
                self.error(
                    Diagnostic::new(
                        Class::DuplicateName,
                        format!("field `{}` is given twice", field.value),
                    )
                    .at(field.span)
                    .label("second time"),
                );
            }
            found[known] = Some(value);
        }
        found
    }

    /// Registers every node id before any node is read (nodes may refer to nodes declared
    /// later in the file): ids must be non-empty without `.`, not a param's name, and unique.
    fn register_nodes(&mut self, node_entries: &[(Spanned<Text>, &Value)]) {
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
    }

    /// The `outputs` map: at least one, no duplicates, names from the file-name character set
    /// (they become file names), each an input expression.
    fn outputs(&mut self, root: &Value, outputs: Option<&Value>) -> Vec<Output> {
        let empty = Value {
            kind: ValueKind::Map(Vec::new()),
            span: root.span,
        };
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
            let node = self.expression(value, &origin);
            // One namespace with the nodes: an output may bear a node's name only when it is
            // that node's value (`"vein": "vein"`); a param's name is free to take (params are
            // named by `--set` and `set:`, outputs by `--output` and `output:`).
            if let (Some(id), Some(&i)) = (node, self.node_index.get(&name.value)) {
                if self.lowered[i].is_some_and(|named| named != id) {
                    self.error(
                        Diagnostic::new(
                            Class::DuplicateName,
                            format!(
                                "output \"{0}\" has the name of node \"{0}\" but another value",
                                name.value
                            ),
                        )
                        .in_node(format!("outputs.{}", name.value).as_str())
                        .at(name.span)
                        .label("also a node")
                        .help(format!(
                            "nodes and outputs share one namespace: output node \"{0}\" as \"{0}\", or rename the output",
                            name.value
                        )),
                    );
                    continue;
                }
            }
            if let Some(node) = node {
                result_outputs.push(Output {
                    name: name.value.to_string(),
                    node,
                    span: value.span,
                });
            }
        }
        result_outputs
    }

    /// Reads a `{ "key": value, ... }` map with string keys.
    pub(super) fn map_entries<'v>(
        &mut self,
        value: &'v Value,
        what: &str,
    ) -> Vec<(Spanned<Text>, &'v Value)> {
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

    pub(super) fn params(&mut self, value: &Value, options: &CheckOptions) {
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
                self.overridden.push((name.clone(), *value));
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

    /// The optional `ranges` map: a slider range `(min, max)` per param, for `texgraph serve`
    /// (docs/serve.md). Each name must be a param; both numbers finite, `min < max`.
    fn ranges(&mut self, value: &Value) {
        for (name, v) in self.map_entries(value, "ranges") {
            let node = format!("ranges.{}", name.value);
            if !self.params.iter().any(|(p, _)| *p == name.value) {
                let known: Vec<&str> = self.params.iter().map(|(p, _)| p.as_str()).collect();
                let help = match nodes::suggest_from(&name.value, known.iter().copied()) {
                    Some(s) => format!("did you mean \"{s}\"? A range belongs to a param"),
                    None => "a range belongs to a param of the graph's `params`".to_string(),
                };
                self.error(
                    Diagnostic::new(
                        Class::UnknownParam,
                        format!("range for \"{}\", which is not a param", name.value),
                    )
                    .in_node(node)
                    .at(name.span)
                    .label("no such param")
                    .help(help),
                );
                continue;
            }
            let pair = match &v.kind {
                ValueKind::Tuple { name: None, items } if items.len() == 2 => {
                    match (&items[0].kind, &items[1].kind) {
                        (ValueKind::Number(a), ValueKind::Number(b)) => Some((*a, *b)),
                        _ => None,
                    }
                }
                _ => None,
            };
            match pair {
                Some((min, max)) if min.is_finite() && max.is_finite() && min < max => {
                    if self.ranges.iter().any(|(p, _, _)| *p == name.value.as_str()) {
                        self.error(
                            Diagnostic::new(
                                Class::DuplicateName,
                                format!("the range of \"{}\" is given twice", name.value),
                            )
                            .in_node(node)
                            .at(name.span)
                            .label("second range"),
                        );
                    } else {
                        self.ranges.push((name.value.to_string(), min, max));
                    }
                }
                _ => self.error(
                    Diagnostic::new(
                        Class::BadParameter,
                        format!(
                            "the range of \"{}\" must be `(min, max)`: two finite numbers, min < max",
                            name.value
                        ),
                    )
                    .in_node(node)
                    .at(v.span)
                    .label("expected (min, max)")
                    .help("for example `ranges: { \"period\": (0.1, 10.0) }`"),
                ),
            }
        }
    }
}
