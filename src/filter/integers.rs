//! Which values of a tape are integer-valued: the outputs of `Floor`, `Round`, `Trunc` and
//! `Step`, integer constants, and sums, differences, products, minima, maxima, clamps, selects
//! and remainders of such. A filtered `Mod` of an integer-valued value by an integer (a checker,
//! `Mod(Floor(x) + Floor(y), 2)`) takes the values' lattice into account
//! (`Rules::lattice_mod`): `mod 2` of a continuous value averages to 1 over a wide box, of an
//! integer to 1/2.
//!
//! One forward walk over the tape, tracking each slot's flag as instructions write it (slots
//! are reused, so the flag is the one of the value a slot holds at that instruction).

use crate::ops::{BinaryOp, TernaryOp, UnaryOp};
use crate::tape::{Instr, Prec, SlotMap, Tape};

/// For each instruction: whether its operand `a` is integer-valued (per component for vec3
/// instructions; scalar instructions use the first). A promoted instruction follows the plain
/// one's rules on the wide slots.
pub fn integer_operands(tape: &Tape) -> Vec<[bool; 3]> {
    let mut flags = SlotMap::new(tape, false);
    let whole = |v: f64| v.is_finite() && v.fract() == 0.0;
    for &(slot, v) in &tape.scalar_constants {
        *flags.s_mut(Prec::Lane, slot) = whole(v);
    }
    for &(slot, v) in &tape.wide_constants {
        *flags.s_mut(Prec::Wide, slot) = whole(v);
    }
    for &(slot, v) in &tape.vec3_constants {
        *flags.v_mut(slot) = v.map(whole);
    }
    tape.instrs.iter().map(|i| visit(i, &mut flags)).collect()
}

/// One instruction: the flags of what it writes, and its operand `a`'s.
fn visit(instr: &Instr, f: &mut SlotMap<bool>) -> [bool; 3] {
    let mut operand = [false; 3];
    match *instr {
        Instr::UnaryScalar { prec, op, dst, src } => {
            operand = [*f.s(prec, src); 3];
            *f.s_mut(prec, dst) = unary(op, *f.s(prec, src));
        }
        Instr::UnaryVec3 { op, dst, src } => {
            operand = *f.v(src);
            *f.v_mut(dst) = f.v(src).map(|x| unary(op, x));
        }
        Instr::BinaryScalar {
            prec,
            op,
            dst,
            a,
            b,
        } => {
            operand = [*f.s(prec, a); 3];
            *f.s_mut(prec, dst) = binary(op, *f.s(prec, a), *f.s(prec, b));
        }
        Instr::BinaryVec3 { op, dst, a, b } => {
            let (x, y) = (*f.v(a), *f.v(b));
            operand = x;
            *f.v_mut(dst) = std::array::from_fn(|i| binary(op, x[i], y[i]));
        }
        Instr::TernaryScalar {
            prec,
            op,
            dst,
            a,
            b,
            c,
        } => {
            let [x, y, z] = [a, b, c].map(|s| *f.s(prec, s));
            *f.s_mut(prec, dst) = ternary(op, x, y, z);
        }
        Instr::TernaryVec3 { op, dst, a, b, c } => {
            let [x, y, z] = [a, b, c].map(|s| *f.v(s));
            *f.v_mut(dst) = std::array::from_fn(|i| ternary(op, x[i], y[i], z[i]));
        }
        Instr::Splat { prec, dst, src } => *f.v_mut(dst) = [*f.s(prec, src); 3],
        Instr::Combine { prec, dst, x, y, z } => *f.v_mut(dst) = [x, y, z].map(|s| *f.s(prec, s)),
        Instr::Component {
            prec,
            dst,
            src,
            axis,
        } => *f.s_mut(prec, dst) = f.v(src)[axis as usize % 3],
        Instr::Widen { dst, src } => *f.s_mut(Prec::Wide, dst) = *f.s(Prec::Lane, src),
        Instr::Narrow { dst, src } => *f.s_mut(Prec::Lane, dst) = *f.s(Prec::Wide, src),
        ref other => {
            // A noise's operand is its input point (`noise::white` reads its lattice).
            if let Instr::Noise { src, .. } = *other {
                operand = *f.v(src);
            }
            // Every other instruction writes a value that is not integer-valued.
            f.clear(other, false);
        }
    }
    operand
}

fn unary(op: UnaryOp, x: bool) -> bool {
    match op {
        UnaryOp::Floor | UnaryOp::Round | UnaryOp::Trunc | UnaryOp::Sign => true,
        UnaryOp::Neg | UnaryOp::Abs => x,
        _ => false,
    }
}

fn binary(op: BinaryOp, a: bool, b: bool) -> bool {
    match op {
        BinaryOp::Step => true,
        BinaryOp::Add
        | BinaryOp::Sub
        | BinaryOp::Mul
        | BinaryOp::Min
        | BinaryOp::Max
        | BinaryOp::Mod => a && b,
        _ => false,
    }
}

fn ternary(op: TernaryOp, a: bool, b: bool, c: bool) -> bool {
    match op {
        TernaryOp::Clamp => a && b && c,
        TernaryOp::Select => b && c,
        TernaryOp::Mix | TernaryOp::Smoothstep => false,
    }
}
