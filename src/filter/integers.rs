//! Which values of a tape are integer-valued: the outputs of `Floor`, `Round`, `Trunc` and
//! `Step`, integer constants, and sums, differences, products, minima, maxima, clamps, selects
//! and remainders of such. A filtered `Mod` of an integer-valued value by an integer (a checker,
//! `Mod(Floor(x) + Floor(y), 2)`) takes the values' lattice into account
//! (`Rules::lattice_mod`): `mod 2` of a continuous value averages to 1 over a wide box, of an
//! integer to 1/2.
//!
//! One forward walk over the tape, tracking each slot's flag as instructions write it (slots
//! are reused, so the flag is the one of the value a slot holds at that instruction).

use super::writes::{scalar_dst, vec3_dst};
use crate::ops::{BinaryOp, TernaryOp, UnaryOp};
use crate::tape::{Instr, Tape, Wide};

/// For each instruction: whether its operand `a` is integer-valued (per component for vec3
/// instructions; scalar instructions use the first).
pub fn integer_operands(tape: &Tape) -> Vec<[bool; 3]> {
    let mut scalars = vec![false; tape.scalar_slots];
    let mut wides = vec![false; tape.wide_slots];
    let mut vec3s = vec![[false; 3]; tape.vec3_slots];
    let whole = |v: f64| v.is_finite() && v.fract() == 0.0;
    for &(slot, v) in &tape.scalar_constants {
        scalars[slot as usize] = whole(v);
    }
    for &(slot, v) in &tape.wide_constants {
        wides[slot as usize] = whole(v);
    }
    for &(slot, v) in &tape.vec3_constants {
        vec3s[slot as usize] = v.map(whole);
    }
    let mut out = Vec::with_capacity(tape.instrs.len());
    for instr in &tape.instrs {
        let mut operand = [false; 3];
        match *instr {
            Instr::UnaryScalar { op, dst, src } => {
                operand = [scalars[src as usize]; 3];
                scalars[dst as usize] = unary(op, scalars[src as usize]);
            }
            Instr::UnaryVec3 { op, dst, src } => {
                operand = vec3s[src as usize];
                vec3s[dst as usize] = vec3s[src as usize].map(|f| unary(op, f));
            }
            Instr::BinaryScalar { op, dst, a, b } => {
                operand = [scalars[a as usize]; 3];
                scalars[dst as usize] = binary(op, scalars[a as usize], scalars[b as usize]);
            }
            Instr::BinaryVec3 { op, dst, a, b } => {
                let (x, y) = (vec3s[a as usize], vec3s[b as usize]);
                operand = x;
                vec3s[dst as usize] = std::array::from_fn(|i| binary(op, x[i], y[i]));
            }
            Instr::TernaryScalar { op, dst, a, b, c } => {
                let [x, y, z] = [a, b, c].map(|s| scalars[s as usize]);
                scalars[dst as usize] = ternary(op, x, y, z);
            }
            Instr::TernaryVec3 { op, dst, a, b, c } => {
                let [x, y, z] = [a, b, c].map(|s| vec3s[s as usize]);
                vec3s[dst as usize] = std::array::from_fn(|i| ternary(op, x[i], y[i], z[i]));
            }
            Instr::Splat { dst, src } => vec3s[dst as usize] = [scalars[src as usize]; 3],
            Instr::Combine { dst, x, y, z } => {
                vec3s[dst as usize] = [x, y, z].map(|s| scalars[s as usize]);
            }
            Instr::Component { dst, src, axis } => {
                scalars[dst as usize] = vec3s[src as usize][axis as usize % 3];
            }
            Instr::Wide(w) => operand = wide(w, &mut scalars, &mut wides, &mut vec3s),
            ref other => {
                // A noise's operand is its input point (`noise::white` reads its lattice).
                if let Instr::Noise { src, .. } = *other {
                    operand = vec3s[src as usize];
                }
                clear(other, &mut scalars, &mut vec3s)
            }
        }
        out.push(operand);
    }
    out
}

/// A promoted instruction's flags (the plain one's rules on the wide slots).
fn wide(w: Wide, scalars: &mut [bool], wides: &mut [bool], vec3s: &mut [[bool; 3]]) -> [bool; 3] {
    match w {
        Wide::Unary { op, dst, src } => {
            wides[dst as usize] = unary(op, wides[src as usize]);
            [wides[src as usize]; 3]
        }
        Wide::Binary { op, dst, a, b } => {
            wides[dst as usize] = binary(op, wides[a as usize], wides[b as usize]);
            [wides[a as usize]; 3]
        }
        Wide::Ternary { op, dst, a, b, c } => {
            let [x, y, z] = [a, b, c].map(|s| wides[s as usize]);
            wides[dst as usize] = ternary(op, x, y, z);
            [false; 3]
        }
        Wide::Component { dst, src, axis } => {
            wides[dst as usize] = vec3s[src as usize][axis as usize % 3];
            [false; 3]
        }
        Wide::Splat { dst, src } => {
            vec3s[dst as usize] = [wides[src as usize]; 3];
            [false; 3]
        }
        Wide::Combine { dst, x, y, z } => {
            vec3s[dst as usize] = [x, y, z].map(|s| wides[s as usize]);
            [false; 3]
        }
        Wide::Widen { dst, src } => {
            wides[dst as usize] = scalars[src as usize];
            [false; 3]
        }
        Wide::Narrow { dst, src } => {
            scalars[dst as usize] = wides[src as usize];
            [false; 3]
        }
        Wide::Noise { dst, src, .. } => {
            wides[dst as usize] = false;
            vec3s[src as usize]
        }
        Wide::Dot { dst, .. } | Wide::Length { dst, .. } | Wide::Fractal { dst, .. } => {
            wides[dst as usize] = false;
            [false; 3]
        }
        Wide::Rotate { dst, .. }
        | Wide::NoiseGradient { dst, .. }
        | Wide::FractalGradient { dst, .. } => {
            vec3s[dst as usize] = [false; 3];
            [false; 3]
        }
    }
}

/// Every other instruction writes a value that is not integer-valued (wide instructions are
/// `wide`'s).
fn clear(instr: &Instr, scalars: &mut [bool], vec3s: &mut [[bool; 3]]) {
    if let Some(dst) = scalar_dst(instr) {
        scalars[dst as usize] = false;
    }
    if let Some(dst) = vec3_dst(instr) {
        vec3s[dst as usize] = [false; 3];
    }
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
