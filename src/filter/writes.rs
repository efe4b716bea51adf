//! Which slot an instruction writes, per slot file, which scalar slots it reads, and where a
//! saved operand is read from: shared by the walks over the tape (`integers.rs`, `chains.rs`,
//! `fusions.rs`) and the filtered evaluation (`tape.rs`).

use crate::tape::{Instr, Slot, Wide};

/// An operand saved before its instruction runs: a scalar slot, a vec3 slot's component, or a
/// wide slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Source {
    Scalar(Slot),
    Vec3(Slot, u8),
    Wide(Slot),
}

/// The scalar slot an instruction writes, if it writes one.
pub fn scalar_dst(instr: &Instr) -> Option<Slot> {
    match *instr {
        Instr::Component { dst, .. }
        | Instr::UnaryScalar { dst, .. }
        | Instr::BinaryScalar { dst, .. }
        | Instr::TernaryScalar { dst, .. }
        | Instr::Dot { dst, .. }
        | Instr::Length { dst, .. }
        | Instr::Noise { dst, .. }
        | Instr::Fractal { dst, .. }
        | Instr::Hermite { dst, .. }
        | Instr::Curve { dst, .. }
        | Instr::Wide(Wide::Narrow { dst, .. }) => Some(dst),
        _ => None,
    }
}

/// The wide (promoted f64) scalar slot an instruction writes, if it writes one.
pub fn wide_dst(instr: &Instr) -> Option<Slot> {
    match *instr {
        Instr::Wide(
            Wide::Component { dst, .. }
            | Wide::Unary { dst, .. }
            | Wide::Binary { dst, .. }
            | Wide::Ternary { dst, .. }
            | Wide::Dot { dst, .. }
            | Wide::Length { dst, .. }
            | Wide::Noise { dst, .. }
            | Wide::Fractal { dst, .. }
            | Wide::Widen { dst, .. },
        ) => Some(dst),
        _ => None,
    }
}

/// The vec3 slot an instruction writes, if it writes one.
pub fn vec3_dst(instr: &Instr) -> Option<Slot> {
    match *instr {
        Instr::Position { dst }
        | Instr::Splat { dst, .. }
        | Instr::Combine { dst, .. }
        | Instr::UnaryVec3 { dst, .. }
        | Instr::BinaryVec3 { dst, .. }
        | Instr::TernaryVec3 { dst, .. }
        | Instr::Cross { dst, .. }
        | Instr::Normalize { dst, .. }
        | Instr::RotateConst { dst, .. }
        | Instr::RotateVarying { dst, .. }
        | Instr::NoiseGradient { dst, .. }
        | Instr::FractalGradient { dst, .. }
        | Instr::Ramp { dst, .. }
        | Instr::Wide(Wide::Splat { dst, .. })
        | Instr::Wide(Wide::Combine { dst, .. })
        | Instr::Wide(Wide::Rotate { dst, .. })
        | Instr::Wide(Wide::NoiseGradient { dst, .. })
        | Instr::Wide(Wide::FractalGradient { dst, .. }) => Some(dst),
        _ => None,
    }
}

/// Whether an instruction reads scalar slot `slot`.
pub(super) fn reads_scalar(instr: &Instr, slot: Slot) -> bool {
    match *instr {
        Instr::Splat { src, .. }
        | Instr::UnaryScalar { src, .. }
        | Instr::Hermite { src, .. }
        | Instr::Ramp { src, .. }
        | Instr::Curve { src, .. }
        | Instr::Wide(Wide::Widen { src, .. }) => src == slot,
        Instr::RotateVarying { degrees, .. } => degrees == slot,
        Instr::Combine { x, y, z, .. } => [x, y, z].contains(&slot),
        Instr::BinaryScalar { a, b, .. } => a == slot || b == slot,
        Instr::TernaryScalar { a, b, c, .. } => [a, b, c].contains(&slot),
        _ => false,
    }
}
