//! The integer hash of the per-cell bases (white noise, the cellular feature points and cell
//! values): a full-width hash of a cell's exact integer coordinates and the seed, so the
//! pattern has no period (the lattice bases' 256-entry tables repeat every 256 cells) and no
//! two cells share a value except by chance.
//!
//! The mixing step is `pcg2d` (Mark Jarzynski and Marc Olano, "Hash Functions for GPU
//! Rendering", JCGT 9(3), 2020, §3 and its code listing): an LCG step on two 32-bit words, two
//! rounds of each word plus the other times the LCG multiplier, an xor-shift after each round.
//! It is a bijection of the 64-bit state, passes the paper's TestU01 batteries, and needs only
//! 32-bit multiplies, which every SIMD instruction set and WGSL have (64-bit multiplies are
//! AVX-512-only on x86 and an extension on GPUs).
//!
//! A cell's state absorbs the coordinates one at a time, z then y then x (as the lattice bases'
//! `perm[x + perm[y + perm[z]]]`, so neighbouring cells share the inner steps):
//!
//! ```text
//! state_0 = pcg2d(seed as two words)            // the table's key
//! state   = pcg2d(state ^ (c as u32, (c >> 32) as u32))   for c = z, y, x
//! ```
//!
//! with each coordinate `c` the exact cell index as a 64-bit two's-complement integer (exact for
//! every |c| <= 2^53, where f64 floors are exact; beyond 2^63 it saturates, as Rust's `as`).
//! For a fixed state each step is injective in `c`, and for a fixed `c` a bijection of the
//! state, so two cells that differ in one coordinate never share a state, and two cells that
//! differ in several do with probability 2^-64. Values in [0, 1) are read from the state's top
//! bits: 24 for f32, 53 for f64 ([`Real::from_unit_bits`]), the f32 value being the f64 value
//! with its low bits dropped.

use crate::real::Real;

/// The LCG multiplier and increment of `pcg2d` (Numerical Recipes' 32-bit LCG).
const MUL: u32 = 1_664_525;
const ADD: u32 = 1_013_904_223;

/// `pcg2d` of Jarzynski and Olano (see the module docs).
#[inline(always)]
pub(super) fn pcg2d([x, y]: [u32; 2]) -> [u32; 2] {
    let mut x = x.wrapping_mul(MUL).wrapping_add(ADD);
    let mut y = y.wrapping_mul(MUL).wrapping_add(ADD);
    x = x.wrapping_add(y.wrapping_mul(MUL));
    y = y.wrapping_add(x.wrapping_mul(MUL));
    x ^= x >> 16;
    y ^= y >> 16;
    x = x.wrapping_add(y.wrapping_mul(MUL));
    y = y.wrapping_add(x.wrapping_mul(MUL));
    x ^= x >> 16;
    y ^= y >> 16;
    [x, y]
}

/// The starting state of a seed (a table's key).
pub(super) fn key(seed: u64) -> [u32; 2] {
    pcg2d([seed as u32, (seed >> 32) as u32])
}

/// One coordinate absorbed into the state.
#[inline(always)]
pub(super) fn absorb([a, b]: [u32; 2], c: i64) -> [u32; 2] {
    pcg2d([a ^ c as u32, b ^ (c >> 32) as u32])
}

/// The state of integer cell `c` under `key`.
#[inline(always)]
pub(super) fn cell(key: [u32; 2], c: [i64; 3]) -> [u32; 2] {
    absorb(absorb(absorb(key, c[2]), c[1]), c[0])
}

/// The cell index of a coordinate: `floor(x)` as a 64-bit integer (exact for |x| < 2^63,
/// saturating beyond; NaN gives 0, and callers return NaN for non-finite input anyway).
#[inline(always)]
pub(super) fn cell_index(x: f64) -> i64 {
    x.floor() as i64
}

/// 2^-16: a 16-bit fraction's unit.
const UNIT16: f32 = 1.0 / 65_536.0;

/// The jittered feature point of a cell with state `s`, as an offset from the cell's corner:
/// per axis `0.5 + jitter (u - 0.5)` with u the top 16 bits of a word (x: the state's first,
/// y: its second, z: the first of `pcg2d(state)`) and the jitter a multiple of 1/256
/// ([`Cellular::new`](super::cellular::Cellular::new) rounds it): the product has at most 24
/// significant bits and the sum is a multiple of 2^-24 in [0, 1), so every step is exact in
/// f32. The f32 and f64 paths and the GPU (whatever its rounding or fused multiply-adds) place
/// the point identically, and jitter 0 puts it exactly at the centre.
#[inline(always)]
pub(super) fn feature(s: [u32; 2], jitter: f32) -> [f32; 3] {
    let z = pcg2d(s)[0];
    [s[0], s[1], z].map(|w| 0.5 + jitter * ((w >> 16) as f32 * UNIT16 - 0.5))
}

/// The words a cell's random value is read from: a further `pcg2d` of its state with the
/// salt's words mixed in, so the value is independent of the feature point.
#[inline(always)]
pub(super) fn value_words(s: [u32; 2]) -> [u32; 2] {
    pcg2d([s[0] ^ 0x5BD1_E995, s[1] ^ 0xCC9E_2D51])
}

/// A cell's random value in [0, 1) (see [`Real::from_unit_bits`]).
#[inline(always)]
pub(super) fn value<S: Real>(s: [u32; 2]) -> S {
    S::from_unit_bits(value_words(s))
}
