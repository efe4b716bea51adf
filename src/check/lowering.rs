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
                self.noise(def, &args, given, whole, here)?
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
        let input = |i: usize| match args[i] {
            Arg::Input(id) => id,
            _ => unreachable_arg(),
        };
        let constant = |i: usize| match args[i] {
            Arg::Const(v) => v,
            _ => 0.0,
        };
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
            seed: constant(2) as u64,
        };
        Some(if def.kind == Kind::Noise {
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
