//! Periodic chains (`periodic.rs`): which values are `g(fract X)` of a `Fract`'s (or a `Mod` by
//! a constant's) argument `X`, with `g` piecewise cubic, so that the filtered form computes
//! them from `X` exactly instead of rule after rule.
//!
//! One forward walk over the tape beside `fusions.rs`'s: each scalar slot and each component of
//! a vec3 slot remembers the chain it holds (its root's instruction and operand, and `g`), and
//! which slots hold constants. A `Fract` or `Mod` starts a chain (its own rule is exact); an
//! `Abs`, `Neg`, an affine map, `Min`/`Max`/`Clamp`/`Step`/`Mix` with constants, a linear or
//! constant `Curve` or `ColorRamp` of a chained value extends it and is fused, and so does one
//! piecewise-cubic shape (a `Smoothstep` with constant edges, a smooth ramp or curve, a
//! `Hermite`) after which only affine maps may follow; copies
//! (`Splat`, `Combine`, `Component`) carry it. Anything else ends it.

use super::moments::Piecewise;
use super::operands::Source;
use super::periodic::{Periodic, Shape};
use super::rules::{hermite_shape, spline_shape};
use crate::ops::{BinaryOp, TernaryOp, UnaryOp};
use crate::tape::{Instr, Prec, Slot, SlotMap, Tape};

/// A value `g(fract(scale · X))`, `X` the operand `source` of instruction `at`.
#[derive(Clone, Debug)]
struct Chain {
    at: usize,
    source: Source,
    scale: f64,
    g: Periodic,
}

/// One component of a fused chain's result: `shape(fract(scale · X))`, `X` the operand
/// `source` of instruction `at` (saved before it runs).
pub(super) struct ChainPart {
    pub at: usize,
    pub source: Source,
    pub scale: f64,
    pub shape: Periodic,
}

/// An operand of an instruction, one component.
#[derive(Clone, Copy)]
enum Operand<'c> {
    Chained(&'c Chain),
    Constant(f64),
    Other,
}

/// The walk's state: per slot of every file, the chain it holds and its constant.
pub(super) struct Chains {
    chain: SlotMap<Option<Chain>>,
    constant: SlotMap<Option<f64>>,
}

impl Chains {
    pub(super) fn new(tape: &Tape) -> Chains {
        let mut c = Chains {
            chain: SlotMap::new(tape, None),
            constant: SlotMap::new(tape, None),
        };
        for &(slot, v) in &tape.scalar_constants {
            *c.constant.s_mut(Prec::Lane, slot) = Some(v);
        }
        for &(slot, v) in &tape.wide_constants {
            *c.constant.s_mut(Prec::Wide, slot) = Some(v);
        }
        for &(slot, v) in &tape.vec3_constants {
            *c.constant.v_mut(slot) = v.map(Some);
        }
        c
    }

    fn scalar_operand(&self, prec: Prec, slot: Slot) -> Operand<'_> {
        match (self.chain.s(prec, slot), *self.constant.s(prec, slot)) {
            (Some(chain), _) => Operand::Chained(chain),
            (None, Some(v)) => Operand::Constant(v),
            _ => Operand::Other,
        }
    }

    fn vec3_operand(&self, slot: Slot, k: usize) -> Operand<'_> {
        match (&self.chain.v(slot)[k], self.constant.v(slot)[k]) {
            (Some(chain), _) => Operand::Chained(chain),
            (None, Some(v)) => Operand::Constant(v),
            _ => Operand::Other,
        }
    }

    /// Instruction `i`: records what its result holds, and returns its parts (one per
    /// component of its result) where it extends chains: a fused instruction.
    pub(super) fn visit(
        &mut self,
        tape: &Tape,
        i: usize,
        instr: &Instr,
        integer: [bool; 3],
    ) -> Option<Vec<ChainPart>> {
        let (scalar, vector, extends) = self.made(tape, i, instr, integer);
        let mut fused = None;
        if extends {
            let chains: Vec<&Chain> = match (&scalar, &vector) {
                (Some(c), _) => vec![c],
                (None, Some(v)) => v.iter().flatten().collect(),
                _ => Vec::new(),
            };
            let complete = chains.len() == if scalar.is_some() { 1 } else { 3 };
            if complete {
                let parts = chains.into_iter().map(|c| ChainPart {
                    at: c.at,
                    source: c.source,
                    scale: c.scale,
                    shape: c.g.clone(),
                });
                fused = Some(parts.collect());
            }
        }
        let dst = instr.writes();
        match dst.file.prec() {
            None => {
                *self.constant.v_mut(dst.slot) = self.made_constant(instr);
                *self.chain.v_mut(dst.slot) = vector.unwrap_or([None, None, None]);
            }
            Some(prec) => {
                *self.constant.s_mut(prec, dst.slot) = None;
                *self.chain.s_mut(prec, dst.slot) = scalar;
            }
        }
        fused
    }

    /// A vec3 result that is constant, per component: a splat or combination of constants
    /// (the pinned constant slots are never written).
    fn made_constant(&self, instr: &Instr) -> [Option<f64>; 3] {
        match *instr {
            Instr::Splat { prec, src, .. } => [*self.constant.s(prec, src); 3],
            Instr::Combine { prec, x, y, z, .. } => {
                let c = [x, y, z].map(|c| *self.constant.s(prec, c));
                // All three or none, as a constant vec3 slot.
                if c.iter().all(Option::is_some) {
                    c
                } else {
                    [None; 3]
                }
            }
            _ => [None; 3],
        }
    }

    /// The chains an instruction's result holds (scalar, or per component), and whether it
    /// extends a chain (a fused instruction) rather than starting or copying one.
    #[allow(clippy::type_complexity)]
    fn made(
        &self,
        tape: &Tape,
        i: usize,
        instr: &Instr,
        integer: [bool; 3],
    ) -> (Option<Chain>, Option<[Option<Chain>; 3]>, bool) {
        let each = |f: &dyn Fn(usize) -> Option<Chain>| Some(std::array::from_fn(f));
        match *instr {
            Instr::UnaryScalar { prec, op, src, .. } => {
                let root = Source::Scalar(prec, src);
                match (op, self.scalar_operand(prec, src)) {
                    (UnaryOp::Fract, _) => (Some(start(i, root, 1.0)), None, false),
                    (_, Operand::Chained(c)) => (unary(op, c), None, true),
                    _ => (None, None, false),
                }
            }
            Instr::UnaryVec3 { op, src, .. } => {
                let made = each(&|k| match (op, self.vec3_operand(src, k)) {
                    (UnaryOp::Fract, _) => Some(start(i, Source::Vec3(src, k as u8), 1.0)),
                    (_, Operand::Chained(c)) => unary(op, c),
                    _ => None,
                });
                (None, made, op != UnaryOp::Fract)
            }
            Instr::BinaryScalar { prec, op, a, b, .. } => {
                let (x, y) = (self.scalar_operand(prec, a), self.scalar_operand(prec, b));
                match modulo(i, op, Source::Scalar(prec, a), x, y, integer[0]) {
                    Some(root) => (Some(root), None, false),
                    None => (binary(op, x, y), None, true),
                }
            }
            Instr::BinaryVec3 { op, a, b, .. } => {
                let made = each(&|k| {
                    let (x, y) = (self.vec3_operand(a, k), self.vec3_operand(b, k));
                    let root = Source::Vec3(a, k as u8);
                    modulo(i, op, root, x, y, integer[k]).or_else(|| binary(op, x, y))
                });
                (None, made, op != BinaryOp::Mod)
            }
            Instr::TernaryScalar {
                prec, op, a, b, c, ..
            } => {
                let [x, y, z] = [a, b, c].map(|s| self.scalar_operand(prec, s));
                (ternary(op, x, y, z), None, true)
            }
            Instr::TernaryVec3 { op, a, b, c, .. } => {
                let made = each(&|k| {
                    let [x, y, z] = [a, b, c].map(|s| self.vec3_operand(s, k));
                    ternary(op, x, y, z)
                });
                (None, made, true)
            }
            Instr::Curve { src, curve, .. } => {
                let h = spline_shape(tape.curves[curve as usize].as_ref(), 0);
                let made = chained(self.scalar_operand(Prec::Lane, src)).and_then(|c| then(c, &h));
                (made, None, true)
            }
            Instr::Hermite { src, spline, .. } => {
                let h = hermite_shape(&tape.hermites[spline as usize]);
                let made = chained(self.scalar_operand(Prec::Lane, src)).and_then(|c| then(c, &h));
                (made, None, true)
            }
            Instr::Ramp { src, ramp, .. } => {
                let r = tape.ramps[ramp as usize].as_ref();
                let operand = self.scalar_operand(Prec::Lane, src);
                let made = each(&|k| then(chained(operand)?, &spline_shape(r, k)));
                (None, made, true)
            }
            Instr::Splat { prec, src, .. } => {
                let c = self.chain.s(prec, src).clone();
                (None, Some([c.clone(), c.clone(), c]), false)
            }
            Instr::Combine { prec, x, y, z, .. } => {
                let made = [x, y, z].map(|s| self.chain.s(prec, s).clone());
                (None, Some(made), false)
            }
            Instr::Component { src, axis, .. } => {
                let c = self.chain.v(src)[axis as usize % 3].clone();
                (c, None, false)
            }
            Instr::Widen { src, .. } => (self.chain.s(Prec::Lane, src).clone(), None, false),
            Instr::Narrow { src, .. } => (self.chain.s(Prec::Wide, src).clone(), None, false),
            _ => (None, None, false),
        }
    }
}

fn start(at: usize, source: Source, scale: f64) -> Chain {
    Chain {
        at,
        source,
        scale,
        g: Periodic::sawtooth(),
    }
}

fn chained(o: Operand<'_>) -> Option<&Chain> {
    match o {
        Operand::Chained(c) => Some(c),
        _ => None,
    }
}

fn with(c: &Chain, g: Option<Periodic>) -> Option<Chain> {
    Some(Chain { g: g?, ..c.clone() })
}

fn then(c: &Chain, h: &Piecewise) -> Option<Chain> {
    with(c, c.g.then(h))
}

fn affine(c: &Chain, a: f64, b: f64) -> Option<Chain> {
    with(c, c.g.affine(a, b))
}

fn unary(op: UnaryOp, c: &Chain) -> Option<Chain> {
    match op {
        UnaryOp::Abs => then(c, &Shape::abs()),
        UnaryOp::Neg => affine(c, 0.0, -1.0),
        _ => None,
    }
}

/// `Mod(x, c)` by a constant `c > 0` of a value not integer-valued (the lattice rule takes
/// those) and not chained: `c · fract(x / c)`, a new chain.
fn modulo(
    at: usize,
    op: BinaryOp,
    source: Source,
    x: Operand,
    y: Operand,
    integer: bool,
) -> Option<Chain> {
    match (op, x, y) {
        (BinaryOp::Mod, Operand::Other, Operand::Constant(c))
            if c > 0.0 && c.is_finite() && !integer =>
        {
            let chain = start(at, source, 1.0 / c);
            affine(&chain, 0.0, c)
        }
        _ => None,
    }
}

fn binary(op: BinaryOp, x: Operand, y: Operand) -> Option<Chain> {
    use Operand::{Chained, Constant};
    match (op, x, y) {
        (BinaryOp::Add, Chained(c), Constant(v)) | (BinaryOp::Add, Constant(v), Chained(c)) => {
            affine(c, v, 1.0)
        }
        (BinaryOp::Sub, Chained(c), Constant(v)) => affine(c, -v, 1.0),
        (BinaryOp::Sub, Constant(v), Chained(c)) => affine(c, v, -1.0),
        (BinaryOp::Mul, Chained(c), Constant(v)) | (BinaryOp::Mul, Constant(v), Chained(c)) => {
            affine(c, 0.0, v)
        }
        (BinaryOp::Div, Chained(c), Constant(v)) if v != 0.0 => affine(c, 0.0, 1.0 / v),
        (BinaryOp::Min, Chained(c), Constant(v)) | (BinaryOp::Min, Constant(v), Chained(c)) => {
            then(c, &Shape::min_max(v, false)?)
        }
        (BinaryOp::Max, Chained(c), Constant(v)) | (BinaryOp::Max, Constant(v), Chained(c)) => {
            then(c, &Shape::min_max(v, true)?)
        }
        (BinaryOp::Step, Constant(edge), Chained(c)) => then(c, &Shape::step(edge)?),
        _ => None,
    }
}

fn ternary(op: TernaryOp, x: Operand, y: Operand, z: Operand) -> Option<Chain> {
    use Operand::{Chained, Constant};
    match (op, x, y, z) {
        (TernaryOp::Clamp, Chained(c), Constant(lo), Constant(hi)) => {
            then(c, &Shape::clamp(lo, hi)?)
        }
        // a + t (b − a).
        (TernaryOp::Mix, Constant(a), Constant(b), Chained(c)) => affine(c, a, b - a),
        (TernaryOp::Smoothstep, Constant(e0), Constant(e1), Chained(c)) => {
            then(c, &Shape::smoothstep(e0, e1)?)
        }
        _ => None,
    }
}
