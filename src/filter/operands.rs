//! An operand the filtered form saves before its instruction runs, for a later instruction
//! fused with it (`fusions.rs`, `chains.rs`): shared by the walks over the tape and the
//! filtered evaluation (`tape.rs`, and the GPU's `gpu/filtered.rs`). Which slots an
//! instruction reads and writes is the tape's own ([`crate::tape::Instr::reads`],
//! [`crate::tape::Instr::writes`]).

use crate::tape::{Prec, Slot};

/// A scalar slot of either precision, or one component of a vec3 slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Source {
    Scalar(Prec, Slot),
    Vec3(Slot, u8),
}
