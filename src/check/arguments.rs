//! A node's arguments, read through its catalogue entry: names and positions, defaults, ranges,
//! `basis`, `stops` and `points`.

use super::*;

impl Checker {
    /// A node expression `Kind`, `Kind(a, b)` or `Kind(name: a, ...)`.
    pub(super) fn node(
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

    pub(super) fn default_argument(
        &mut self,
        default: DefaultValue,
        arg: &ArgDef,
        here: &Origin,
    ) -> Arg {
        match (default, arg.kind) {
            (DefaultValue::Number(v), ArgKind::Input(_)) => {
                Arg::Input(self.builder.add(Op::ConstScalar(v), Args::new(), here))
            }
            (DefaultValue::Number(v), _) => Arg::Const(v),
            (DefaultValue::Vec3(v), _) => Arg::Axis(v),
            (DefaultValue::Name(n), _) => Arg::Choice(n, false),
            (DefaultValue::Nothing, _) => Arg::Period(None),
            (DefaultValue::Flag(b), _) => Arg::Flag(b),
            (DefaultValue::Position, _) => {
                Arg::Input(self.builder.add(Op::Position, Args::new(), here))
            }
            (DefaultValue::Empty, _) => Arg::Overrides(Vec::new()),
        }
    }

    pub(super) fn argument(
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
            ArgKind::ConstAxis => self.axis_argument(value, arg, def, origin),
            ArgKind::Period => self.period_argument(value, arg, def, origin),
            ArgKind::Basis => self
                .basis(value, origin)
                .map(|(b, explicit)| Arg::Basis(b, explicit)),
            ArgKind::Choice(allowed) => self.choice_argument(value, arg, def, allowed, origin),
            ArgKind::Stops => {
                let knots = self.knots(value, def, "stops", "(t, (r, g, b))", origin)?;
                let mut stops = Vec::with_capacity(knots.len());
                for (t, v) in knots {
                    stops.push((t, self.constant_vec3(v, &"a stop's colour", origin)?));
                }
                Some(Arg::Stops(stops))
            }
            ArgKind::Text => self.text_argument(value, arg, def, origin),
            ArgKind::Overrides => self.overrides(value, origin).map(Arg::Overrides),
            ArgKind::Flag => self.flag_argument(value, arg, def, origin),
            ArgKind::Points => self.points_argument(value, def, origin),
        }
    }

    /// A rotation axis: a constant vec3 that is not zero, normalised.
    fn axis_argument(
        &mut self,
        value: &Value,
        arg: &ArgDef,
        def: &NodeDef,
        origin: &Origin,
    ) -> Option<Arg> {
        let v = self.constant_vec3(value, &ArgName(arg.name, def.name), origin)?;
        if let Some(axis) = ops::normalise_axis(v) {
            return Some(Arg::Axis(axis));
        }
        self.error(
            bad_parameter(
                origin,
                value.span,
                format!("the rotation axis is zero: {}", triple(v)),
                "zero axis",
            )
            .help("give the axis a direction, e.g. (0, 1, 0)"),
        );
        None
    }

    /// A tiling period: whole numbers of cells from 1 to `limits::MAX_PERIOD` per axis.
    fn period_argument(
        &mut self,
        value: &Value,
        arg: &ArgDef,
        def: &NodeDef,
        origin: &Origin,
    ) -> Option<Arg> {
        let v = self.constant_vec3(value, &ArgName(arg.name, def.name), origin)?;
        let limit = limits::MAX_PERIOD;
        if v.iter()
            .all(|c| c.fract() == 0.0 && (1.0..=limit).contains(c))
        {
            return Some(Arg::Period(Some(v.map(|c| c as u64))));
        }
        self.error(
            bad_parameter(
                origin,
                value.span,
                format!(
                    "a period is a whole number of cells from 1 to {limit} per axis, got {}",
                    triple(v)
                ),
                "not a period",
            )
            .help("write e.g. `period: 4` or `period: (4, 4, 1)`"),
        );
        None
    }

    /// One of the names `allowed`, written as an identifier.
    fn choice_argument(
        &mut self,
        value: &Value,
        arg: &ArgDef,
        def: &NodeDef,
        allowed: &[&'static str],
        origin: &Origin,
    ) -> Option<Arg> {
        let name = match &value.kind {
            ValueKind::Ident(n) => allowed.iter().find(|a| **a == n.as_str()).copied(),
            _ => None,
        };
        if let Some(n) = name {
            return Some(Arg::Choice(n, true));
        }
        self.error(bad_parameter(
            origin,
            value.span,
            format!(
                "`{}` of {} must be one of {}, found {}",
                arg.name,
                def.name,
                allowed.join(", "),
                value.kind.describe()
            ),
            format!("not a known `{}`", arg.name),
        ));
        None
    }

    /// A string (an import's file name).
    fn text_argument(
        &mut self,
        value: &Value,
        arg: &ArgDef,
        def: &NodeDef,
        origin: &Origin,
    ) -> Option<Arg> {
        if let ValueKind::Str(s) = &value.kind {
            return Some(Arg::Text(s.to_string(), value.span));
        }
        self.error(
            Diagnostic::new(
                Class::Type,
                format!(
                    "`{}` of {} is a string, found {}",
                    arg.name,
                    def.name,
                    value.kind.describe()
                ),
            )
            .in_node(&*origin.node)
            .at(value.span)
            .label("expected a string"),
        );
        None
    }

    /// `true` or `false`.
    fn flag_argument(
        &mut self,
        value: &Value,
        arg: &ArgDef,
        def: &NodeDef,
        origin: &Origin,
    ) -> Option<Arg> {
        if let ValueKind::Bool(b) = value.kind {
            return Some(Arg::Flag(b));
        }
        self.error(bad_parameter(
            origin,
            value.span,
            format!(
                "`{}` of {} must be true or false, found {}",
                arg.name,
                def.name,
                value.kind.describe()
            ),
            "not true or false",
        ));
        None
    }

    /// A curve's points: `[(x, y), ...]`, sorted `x`, finite `y`.
    fn points_argument(&mut self, value: &Value, def: &NodeDef, origin: &Origin) -> Option<Arg> {
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

    /// Reads `[(key, value), ...]`: constant, finite, sorted keys; the values are returned raw.
    pub(super) fn knots<'v>(
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
            self.error(bad_parameter(
                origin,
                value.span,
                format!("`{what}` of {} is empty", def.name),
                "needs at least one entry",
            ));
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
                        bad_parameter(
                            origin,
                            pair[0].span,
                            format!(
                                "`{what}` of {} are not sorted: {key} comes after {previous}",
                                def.name
                            ),
                            "smaller than the one before",
                        )
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
    pub(super) fn basis(&mut self, value: &Value, origin: &Origin) -> Option<(Basis, bool)> {
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
                        self.error(bad_parameter(
                            origin,
                            items[0].span,
                            "value noise interpolation is Linear or Smooth",
                            "unknown interpolation",
                        ));
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
            "Simplex" if inner.is_none() => Basis::Simplex,
            "Cellular" => {
                let fields = inner.unwrap_or(&[]);
                return Some((self.cellular_basis(fields, origin)?, !fields.is_empty()));
            }
            "Perlin" | "Gradient" | "Simplex" => {
                self.error(
                    bad_parameter(
                        origin,
                        value.span,
                        format!("the {name} basis takes no arguments"),
                        "only Value and Cellular noise take arguments",
                    )
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
                                bad_parameter(origin, field.span.to(v.span), "Value noise takes `interpolation: Linear` or `interpolation: Smooth`", "not understood"),
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
                let mut d = bad_parameter(
                    origin,
                    span,
                    format!("unknown noise basis {}", value.kind.describe()),
                    "not a basis",
                );
                d = d.help(match nodes::suggest_from(name, BASES.into_iter()) {
                    Some(s) if !name.is_empty() => format!("did you mean `{s}`?"),
                    _ => "the bases are Perlin, Gradient, Value, Simplex and Cellular".into(),
                });
                self.error(d);
                return None;
            }
        };
        Some((basis, false))
    }

    /// `Cellular(jitter: J, metric: M, value: V)`'s fields (each optional, defaults as the
    /// node arguments of the same names: jitter 1, Euclidean, F1).
    fn cellular_basis(
        &mut self,
        fields: &[(Spanned<Text>, Value)],
        origin: &Origin,
    ) -> Option<Basis> {
        let (mut jitter, mut metric, mut value) = (1.0, "Euclidean", "F1");
        for (field, v) in fields {
            let ok = match (field.value.as_str(), &v.kind) {
                ("jitter", &ValueKind::Number(j)) if (0.0..=1.0).contains(&j) => {
                    jitter = j;
                    true
                }
                ("metric", ValueKind::Ident(m)) => nodes::METRICS
                    .iter()
                    .find(|n| **n == m.as_str())
                    .map(|n| metric = n)
                    .is_some(),
                ("value", ValueKind::Ident(m)) => nodes::CELLULAR_VALUES
                    .iter()
                    .find(|n| **n == m.as_str())
                    .map(|n| value = n)
                    .is_some(),
                _ => false,
            };
            if !ok {
                self.error(bad_parameter(
                    origin,
                    field.span.to(v.span),
                    format!(
                        "Cellular takes `jitter: 0..1`, `metric: {}` and `value: {}`",
                        nodes::METRICS.join(" | "),
                        nodes::CELLULAR_VALUES.join(" | ")
                    ),
                    "not understood",
                ));
                return None;
            }
        }
        Some(Basis::Cellular(Cellular::new(
            jitter,
            super::lowering::metric_named(metric),
            super::lowering::cellular_value_named(value),
        )))
    }
}

/// The basis names `basis:` accepts, for "did you mean" hints.
const BASES: [&str; 5] = ["Perlin", "Gradient", "Value", "Simplex", "Cellular"];

/// A bad parameter of `origin`'s node: `message`, with `span` labelled `label` (add a help with
/// [`Diagnostic::help`]).
fn bad_parameter(
    origin: &Origin,
    span: Span,
    message: impl Into<String>,
    label: impl Into<String>,
) -> Diagnostic {
    Diagnostic::new(Class::BadParameter, message)
        .in_node(&*origin.node)
        .at(span)
        .label(label)
}

/// `(x, y, z)`, each number as diagnostics write it.
fn triple(v: [f64; 3]) -> String {
    let [x, y, z] = v.map(crate::diagnostic::number);
    format!("({x}, {y}, {z})")
}
