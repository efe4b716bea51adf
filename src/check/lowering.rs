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
            Lowering::Noise | Lowering::Fractal { .. } => {
                self.noise(def, &args, given, whole, here)?
            }
            Lowering::Binary(op) => (Op::Binary(op), self.broadcast_all(&operands, here)),
            Lowering::Unary(op) => (unary(op), operands),
            Lowering::Length => (Op::Length, smallvec![input("v")]),
            Lowering::Dot => (Op::Dot, smallvec![input("a"), input("b")]),
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
                    Some(Arg::Interpolation("Smooth", _)) => SplineInterpolation::Smooth,
                    Some(Arg::Interpolation("Constant", _)) => SplineInterpolation::Constant,
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

    /// `Noise`, `Fbm` and `Turbulence`: the basis (with its interpolation, given once), the
    /// seed, and for the fractals an octave schedule whose scales stay finite.
    fn noise(
        &mut self,
        def: &NodeDef,
        args: &[Arg],
        given: &[Option<&Value>],
        whole: &Value,
        here: &Origin,
    ) -> Option<(Op, Args)> {
        let named = Named { def, args };
        let input = |name: &str| named.input(name);
        let constant = |name: &str| named.constant(name);
        let Some(&Arg::Basis(basis, explicit)) = named.get("basis") else {
            return None;
        };
        let interpolation_index = named.index("interpolation")?;
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
                    Diagnostic::new(
                        Class::BadParameter,
                        format!("`interpolation` applies to the Value basis only, not {other:?}"),
                    )
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
            seed: constant("seed") as u64,
        };
        Some(if def.lowering == Lowering::Noise {
            (Op::Noise(key), smallvec![input("input")])
        } else {
            let params = FractalParams {
                octaves: constant("octaves"),
                lacunarity: constant("lacunarity"),
                gain: constant("gain"),
                first_octave: constant("first_octave") as u32,
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
            (Op::Fractal(key, params), smallvec![input("input")])
        })
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
