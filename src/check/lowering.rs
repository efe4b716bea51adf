//! Lowering: a node kind's checked arguments become graph operations, by the catalogue entry's
//! `Lowering`.

use super::*;

impl Checker {
    /// Turns a node's checked arguments into graph operations.
    pub(super) fn build(
        &mut self,
        def: &NodeDef,
        args: SmallVec<[Arg; 8]>,
        given: &[Option<&Value>],
        whole: &Value,
        here: &Origin,
    ) -> Option<NodeId> {
        let named = Named { def, args: &args };
        let input = |name: &str| named.input(name);
        let constant = |name: &str| named.constant(name);
        // The operands of a math node, in the catalogue's order (a, b; x; input, min, max; ...).
        let operands: Args = args
            .iter()
            .filter_map(|a| match a {
                Arg::Input(id) => Some(*id),
                _ => None,
            })
            .collect();
        let unary = |op| Op::Unary(op);
        let op_args: (Op, Args) = match def.lowering {
            Lowering::Position => (Op::Position, Args::new()),
            Lowering::Combine => (Op::Combine, smallvec![input("x"), input("y"), input("z")]),
            Lowering::Scale | Lowering::Translate => {
                let by = self.builder.broadcast(input("by"), Type::Vec3, here);
                let op = if def.lowering == Lowering::Scale {
                    BinaryOp::Mul
                } else {
                    BinaryOp::Add
                };
                (Op::Binary(op), smallvec![input("input"), by])
            }
            Lowering::Rotate => {
                let Some(Arg::Axis(axis)) = named.get("axis") else {
                    return None;
                };
                (
                    Op::Rotate { axis: *axis },
                    smallvec![input("input"), input("degrees")],
                )
            }
            Lowering::Noise
            | Lowering::Fractal(_)
            | Lowering::Cellular
            | Lowering::White
            | Lowering::VecNoise
            | Lowering::VecFractal
            | Lowering::Warp => self.noise(def, &args, given, whole, here)?,
            Lowering::Binary(op) => (Op::Binary(op), self.broadcast_all(&operands, here)),
            Lowering::Unary(op) => (unary(op), operands),
            Lowering::Length => (Op::Length, smallvec![input("v")]),
            Lowering::Dot => (Op::Dot, smallvec![input("a"), input("b")]),
            Lowering::Cross => (Op::Cross, smallvec![input("a"), input("b")]),
            Lowering::Gradient => return self.gradient(input("of"), here),
            Lowering::Import => {
                let (Some(Arg::Text(f, fs)), Some(Arg::Text(o, os)), Some(Arg::Overrides(set))) =
                    (named.get("file"), named.get("output"), named.get("set"))
                else {
                    return None;
                };
                let args = super::imports::ImportArgs {
                    file: &(f.clone(), *fs),
                    output: &(o.clone(), *os),
                    input: input("input"),
                    set,
                };
                return self.import(args, here);
            }
            Lowering::Normalize => (Op::Normalize, smallvec![input("v")]),
            Lowering::MapRange
            | Lowering::Distance
            | Lowering::Luminance
            | Lowering::HsvToRgb
            | Lowering::RgbToHsv
            | Lowering::Blend => self.composite(
                def.lowering,
                &operands,
                named.flag("clamp"),
                named.choice("mode"),
                here,
            )?,
            Lowering::Ternary(op) => (Op::Ternary(op), self.broadcast_all(&operands, here)),
            Lowering::Hermite => (
                Op::Hermite(Hermite {
                    p0: constant("p0"),
                    p1: constant("p1"),
                    m0: constant("m0"),
                    m1: constant("m1"),
                }),
                smallvec![input("input")],
            ),
            Lowering::Ramp | Lowering::Curve => {
                let interpolation = match named.get("interpolation") {
                    Some(Arg::Choice("Smooth", _)) => SplineInterpolation::Smooth,
                    Some(Arg::Choice("Constant", _)) => SplineInterpolation::Constant,
                    _ => SplineInterpolation::Linear,
                };
                let table = named.get("stops").or_else(|| named.get("points"));
                match table? {
                    Arg::Stops(stops) => {
                        let ramp = Ramp::new(
                            stops.iter().map(|s| s.0).collect(),
                            stops.iter().map(|s| s.1).collect(),
                            interpolation,
                        );
                        (Op::Ramp(Arc::new(ramp)), smallvec![input("input")])
                    }
                    Arg::Points(points) => {
                        let curve = Curve::new(
                            points.iter().map(|p| p.0).collect(),
                            points.iter().map(|p| [p.1]).collect(),
                            interpolation,
                        );
                        (Op::Curve(Arc::new(curve)), smallvec![input("input")])
                    }
                    _ => return None,
                }
            }
        };
        debug_assert!(def.output != OutputType::Broadcast || !op_args.1.is_empty());
        let (op, op_args) = op_args;
        Some(self.builder.add(op, op_args, here))
    }

    /// The noise kinds: the basis (with its interpolation or cellular parameters, each given
    /// once), the seed, for the fractals an octave schedule whose scales stay finite, and for
    /// the vector kinds three decorrelated samples (tables `seed`, `seed + 2^53`, `seed + 2^54`:
    /// seeds no node can write, as seeds stop at 2^53 - 1).
    fn noise(
        &mut self,
        def: &NodeDef,
        args: &[Arg],
        given: &[Option<&Value>],
        whole: &Value,
        here: &Origin,
    ) -> Option<(Op, Args)> {
        let named = Named { def, args };
        let input = named.input("input");
        let basis = match def.lowering {
            Lowering::White => Basis::White,
            Lowering::Cellular => Basis::Cellular(cellular_params(&named)),
            _ => self.resolve_basis(&named, given, whole, here)?,
        };
        let seed = named.constant("seed") as u64;
        let period = self.period(&named, given, whole, here)?;
        let fractal = matches!(
            def.lowering,
            Lowering::Fractal(_) | Lowering::VecFractal | Lowering::Warp
        );
        let key = |k: u64| TableKey {
            basis,
            seed: seed.wrapping_add(k << 53),
            period: if fractal { None } else { period },
        };
        let style = match def.lowering {
            Lowering::Fractal(FractalKind::Fbm) | Lowering::VecFractal | Lowering::Warp => {
                Some(Style::Fbm)
            }
            Lowering::Fractal(FractalKind::Turbulence) => Some(Style::Turbulence),
            Lowering::Fractal(FractalKind::Billow) => Some(Style::Billow),
            Lowering::Fractal(FractalKind::Ridged) => Some(Style::Ridged {
                offset: named.constant("offset"),
                sharpness: named.constant("sharpness"),
            }),
            _ => None,
        };
        let params = match style {
            Some(style) => Some(self.fractal_params(&named, style, period, whole, here)?),
            None => None,
        };
        let one = |k: u64| match params {
            Some(p) => Op::Fractal(key(k), p),
            None => Op::Noise(key(k)),
        };
        let vector = |checker: &mut Self| -> Args {
            (0..3)
                .map(|k| checker.builder.add(one(k), smallvec![input], here))
                .collect()
        };
        Some(match def.lowering {
            Lowering::VecNoise | Lowering::VecFractal => (Op::Combine, vector(self)),
            Lowering::Warp => {
                let components = vector(self);
                let offset = self.builder.add(Op::Combine, components, here);
                let amount = self
                    .builder
                    .broadcast(named.input("amount"), Type::Vec3, here);
                let moved =
                    self.builder
                        .add(Op::Binary(BinaryOp::Mul), smallvec![amount, offset], here);
                (Op::Binary(BinaryOp::Add), smallvec![input, moved])
            }
            _ => (one(0), smallvec![input]),
        })
    }

    /// The basis of a noise kind that takes one: `basis` with the node's `interpolation`
    /// (Value only) or `jitter`/`metric`/`value` (Cellular only), each said at most once.
    fn resolve_basis(
        &mut self,
        named: &Named,
        given: &[Option<&Value>],
        whole: &Value,
        here: &Origin,
    ) -> Option<Basis> {
        let Some(&Arg::Basis(basis, explicit)) = named.get("basis") else {
            return None;
        };
        let span_of = |name: &str| {
            named
                .index(name)
                .and_then(|i| given.get(i).copied().flatten())
                .map(|v| v.span)
        };
        let cellular_given = ["jitter", "metric", "value"]
            .into_iter()
            .find_map(|n| span_of(n).map(|s| (n, s)));
        let interpolation = match named.get("interpolation") {
            Some(Arg::Choice(field, true)) => Some(*field),
            _ => None,
        };
        let interpolation_span = span_of("interpolation").unwrap_or(whole.span);
        let twice = |what: &str| {
            Diagnostic::new(
                Class::BadParameter,
                format!("the {what} is given twice: in `basis` and as the node's own argument"),
            )
            .in_node(&*here.node)
            .label("also given in the basis")
            .help("give it once")
        };
        let basis = match (basis, interpolation, cellular_given) {
            (Basis::Value(written), Some(field), _)
                if explicit && written != interpolation_named(field) =>
            {
                self.error(twice("interpolation").at(interpolation_span));
                return None;
            }
            (Basis::Value(_), Some(field), _) => Basis::Value(interpolation_named(field)),
            (Basis::Cellular(_), _, Some((name, span))) if explicit => {
                self.error(twice(&format!("cellular `{name}`")).at(span));
                return None;
            }
            (Basis::Cellular(c), _, _) if explicit => Basis::Cellular(c),
            (Basis::Cellular(_), _, _) => Basis::Cellular(cellular_params(named)),
            (other, _, Some((name, span))) => {
                self.error(
                    Diagnostic::new(
                        Class::BadParameter,
                        format!("`{name}` applies to the Cellular basis only, not {other:?}"),
                    )
                    .in_node(&*here.node)
                    .at(span)
                    .label("not used by this basis"),
                );
                return None;
            }
            (Basis::Value(i), None, _) => Basis::Value(i),
            (other, Some(_), _) => {
                self.error(
                    Diagnostic::new(
                        Class::BadParameter,
                        format!("`interpolation` applies to the Value basis only, not {other:?}"),
                    )
                    .in_node(&*here.node)
                    .at(interpolation_span)
                    .label("not used by this basis"),
                );
                return None;
            }
            (other, None, None) => other,
        };
        Some(basis)
    }

    /// The node's tiling period, refused where it cannot tile: with a fractional lacunarity
    /// (octave i must repeat every `period · lacunarity^i` whole cells). Every basis tiles at
    /// every integer period (Simplex too: its lattice is invariant under integer translations).
    fn period(
        &mut self,
        named: &Named,
        given: &[Option<&Value>],
        whole: &Value,
        here: &Origin,
    ) -> Option<Option<Period>> {
        let Some(Arg::Period(Some(period))) = named.get("period") else {
            return Some(None);
        };
        let span = named
            .index("period")
            .and_then(|i| given.get(i).copied().flatten())
            .map_or(whole.span, |v| v.span);
        let refuse = |message: String, help: &str| {
            Diagnostic::new(Class::BadParameter, message)
                .in_node(&*here.node)
                .at(span)
                .label("cannot tile")
                .help(help.to_string())
        };
        if named.index("lacunarity").is_some() {
            let lacunarity = named.constant("lacunarity");
            if lacunarity.fract() != 0.0 {
                self.error(refuse(
                    format!(
                        "a tiled fractal needs a whole-number lacunarity (octave i repeats every period × lacunarity^i cells), got {}",
                        crate::diagnostic::number(lacunarity)
                    ),
                    "use lacunarity: 2 (or 3, ...), or drop the period",
                ));
                return None;
            }
        }
        Some(Some(*period))
    }

    /// The octave schedule of a fractal kind, refused when its scales overflow.
    fn fractal_params(
        &mut self,
        named: &Named,
        style: Style,
        period: Option<Period>,
        whole: &Value,
        here: &Origin,
    ) -> Option<FractalParams> {
        let params = FractalParams {
            octaves: named.constant("octaves"),
            lacunarity: named.constant("lacunarity"),
            gain: named.constant("gain"),
            first_octave: named.constant("first_octave") as u32,
            style,
            period,
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
        Some(params)
    }

    /// Splats scalar operands when any operand is a vec3 (component-wise math).
    pub(super) fn broadcast_all(&mut self, ids: &[NodeId], here: &Origin) -> Args {
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

/// A node's checked arguments read by name, through its catalogue entry: lowering never depends
/// on an argument's position, so reordering or adding arguments cannot silently misread one.
struct Named<'a> {
    def: &'a NodeDef,
    args: &'a [Arg],
}

impl Named<'_> {
    /// The position of argument `name` in the catalogue entry.
    fn index(&self, name: &str) -> Option<usize> {
        self.def.args.iter().position(|a| a.name == name)
    }

    /// The checked argument `name`.
    fn get(&self, name: &str) -> Option<&Arg> {
        self.index(name).and_then(|i| self.args.get(i))
    }

    /// The node an input argument reads. A name the entry lacks is a bug in this file: loud in
    /// debug builds (every kind goes through the conformance tests), node 0 in release.
    fn input(&self, name: &str) -> NodeId {
        debug_assert!(
            self.index(name).is_some(),
            "{} has no argument `{name}`",
            self.def.name
        );
        match self.get(name) {
            Some(Arg::Input(id)) => *id,
            _ => unreachable_arg(),
        }
    }

    /// A flag argument (a name the entry lacks: false).
    fn flag(&self, name: &str) -> bool {
        matches!(self.get(name), Some(Arg::Flag(true)))
    }

    /// A choice argument's name (a name the entry lacks: as for [`Named::input`]).
    fn choice(&self, name: &str) -> &'static str {
        match self.get(name) {
            Some(Arg::Choice(n, _)) => n,
            _ => "",
        }
    }

    /// A constant argument's value (a name the entry lacks: as for [`Named::input`]).
    fn constant(&self, name: &str) -> f64 {
        debug_assert!(
            self.index(name).is_some(),
            "{} has no argument `{name}`",
            self.def.name
        );
        match self.get(name) {
            Some(Arg::Const(v)) => *v,
            _ => 0.0,
        }
    }
}

/// The cellular parameters of a node's own `jitter`, `metric` and `value` arguments.
fn cellular_params(named: &Named) -> Cellular {
    Cellular::new(
        named.constant("jitter"),
        metric_named(named.choice("metric")),
        cellular_value_named(named.choice("value")),
    )
}

/// A metric by its name in the catalogue's list.
pub(super) fn metric_named(name: &str) -> Metric {
    match name {
        "Manhattan" => Metric::Manhattan,
        "Chebyshev" => Metric::Chebyshev,
        _ => Metric::Euclidean,
    }
}

/// A cellular value by its name in the catalogue's list.
pub(super) fn cellular_value_named(name: &str) -> CellularValue {
    match name {
        "F2" => CellularValue::F2,
        "F2MinusF1" => CellularValue::F2MinusF1,
        "CellValue" => CellularValue::CellValue,
        "Edge" => CellularValue::Edge,
        _ => CellularValue::F1,
    }
}
