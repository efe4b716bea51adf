//! What every lane kernel and fractal loop of `noise/` shares, below all of them: the chunk
//! sizes, the canonical NaN, the length check of the batch entry points, `sign`.

use crate::real::Real;

/// Lanes per chunk: the stack arrays hold this many (cell bytes, fractions, hashes: 4.8 KB in
/// f32, 7.8 KB in f64, L1-resident). The interpreter's chunks are this size too.
pub(super) const CHUNK: usize = 256;

/// Below this many lanes a batch runs the per-point kernels: the SIMD path's setup (dispatch,
/// zeroing the stack arrays) costs more than it saves on one lane. (Fractal sums then take their
/// octaves as lanes: [`fractal_octave_lanes`].)
pub(super) const SMALL: usize = 8;

/// The length check of every batch entry point: mismatched slices are a caller bug, and a loud
/// panic beats silently evaluating only the shortest prefix.
#[inline]
pub(super) fn check_lengths(x: &[f64], y: &[f64], z: &[f64], n: usize) {
    assert!(
        x.len() == n && y.len() == n && z.len() == n,
        "noise batch: slice lengths differ (x {}, y {}, z {}, out {})",
        x.len(),
        y.len(),
        z.len(),
        n
    );
}

/// NaN as the one canonical NaN, `S::NAN` (positive, quiet, zero payload); other values as they
/// are. Every noise result and fractal sum passes through it, so that a non-finite input gives
/// the same bits on the point and the batch paths: IEEE 754 and Rust leave the sign and payload
/// of a NaN result unspecified, and LLVM may order an addition's operands differently in scalar
/// and in vectorised code (Perlin's `grad` adds `±x + ±y` of two NaNs of opposite signs, and x86
/// returns the first operand's NaN). One compare and one blend per lane in SIMD.
#[inline(always)]
pub(super) fn canonical_nan<S: Real>(v: S) -> S {
    if v.is_nan() {
        S::NAN
    } else {
        v
    }
}

/// A lattice gradient as returned by the point functions and the batch lanes: NaN canonical.
/// (A NaN fraction, from a non-finite coordinate, makes every component NaN: each component
/// multiplies or lerps by the weights of all three axes.)
#[inline(always)]
pub(super) fn canonical_grad<S: Real>(g: [S; 3]) -> [S; 3] {
    g.map(canonical_nan)
}

/// sign(v): 1, -1, 0 for ±0 (the average of the two sides of |v|'s crease), NaN for NaN.
#[inline(always)]
pub(super) fn sign<S: Real>(v: S) -> S {
    if v > S::ZERO {
        S::ONE
    } else if v < S::ZERO {
        -S::ONE
    } else if v.is_nan() {
        S::NAN
    } else {
        S::ZERO
    }
}
