//! The batch kernels: [`NoiseTable::sample_batch`](super::NoiseTable::sample_batch) and
//! [`fractal_batch`](super::fractal_batch) over many lanes, written for the auto-vectoriser and
//! compiled once per instruction set, picked at run time by the `multiversion` crate: a portable
//! build (no `-C target-cpu`) runs AVX-512 or AVX2 code where the CPU has it.
//!
//! Each chunk of up to [`CHUNK`] lanes goes through these loops per octave, over stack arrays:
//!
//! 1. The lattice step, in f64 (positions are always f64, see the `noise` module docs): the
//!    scaled position `p · f`, its cell index mod 256 (a byte) and its fraction within the cell
//!    (converted to S). Branch-free: `floor` is one instruction from SSE4.1 on (`roundpd`). A
//!    chunk whose scaled coordinates all stay below 2^51 in magnitude (checked once per chunk,
//!    [`fits`]) takes the residue from the bits of `c + 1.5 · 2^52`; any other (huge or
//!    non-finite coordinates) uses the contract formula `m = c - 256 floor(c / 256)` itself.
//! 2. The corner hashes: on CPUs with AVX-512 VBMI by byte shuffles, 64 lanes per instruction
//!    (`vbmi.rs`, the one place with intrinsics); otherwise inside loop 3 as seven gathers per
//!    lane vector from the paired permutation (`LatticeKernel::hashes`).
//! 3. The interior, in S with the hashes as bytes: Perlin's `grad` as selects, the gradients or
//!    values as gathers, the fades and lerps (`LatticeKernel::interior`). With AVX-512 that is 16 f32
//!    lanes per instruction.
//!
//! A fractal sum runs the octaves outside the lanes, and each lane sees `sum = sum + amp · n` in
//! octave order starting from zero: exactly [`fractal`](super::fractal)'s additions. The lane
//! formulations are the point functions' arithmetic expression for expression (only the table
//! reads differ in form), and NaN results are made canonical on both paths (`canonical_nan`),
//! so batch and point results are the same bits; the tests check it on random, huge, negative,
//! lattice, boundary and non-finite points, for every basis, batch length and precision. Rust
//! never contracts `a * b + c` into an FMA nor reassociates, so compiling for FMA-capable
//! targets changes no result.
//!
//! Simplex noise ([`simplex`]) follows the same plan with its own loops: the cell and
//! tetrahedron of the body-centred cubic lattice per lane in f64 (the tetrahedron kept as axis
//! masks, so the four vertex offsets are arithmetic, not table reads), each vertex's gradient
//! by byte shuffles straight from the hash (`NoiseTable::signs`), then one pass summing the four
//! terms in S; tiled, the points are reduced into the period first and each vertex's hash bytes
//! come from its doubled coordinates mod twice the period. Those loops run over the whole chunk
//! (a constant count; see `SimplexLanes::sum`). Measured on the benches' 65 536-point slab
//! (`cargo bench --bench eval -- eval/simplex`, AVX-512 VBMI): 0.24 ms, 1.44× simdnoise's time.
//!
//! Batches of fewer than [`SMALL`] lanes (the interpreter's per-point path) and CPUs without
//! SSE4.1 run the per-point kernels in a loop instead: no dispatch, no stack arrays, no libm
//! `floor` calls; except fractal sums, whose octaves of one point become the lanes
//! ([`fractal_octave_lanes`]), so `eval_point` of an 8-octave fbm is one SIMD pass too.
//!
//! Measured on a Sapphire Rapids class VM, one thread, 8-octave Perlin fbm in f32 over 16 384
//! random points in [0, 8)³ (`cargo bench --bench noise -- noise/fbm8_perlin_f32`): 198 ns per
//! point with the per-lane kernels this module replaced; now 18–22 ns with AVX-512 VBMI, about
//! 27 ns with AVX-512 gathers, 42 ns on the AVX2 path (LLVM reads the tables lane by lane there,
//! as it deems AVX2 gathers slow on a generic x86-64 CPU) and 51 ns on the SSE4.1 one.
//!
//! The files: this one holds what the kernels share (the instruction sets they are compiled
//! for, `simd_targets!`; the lattice step's lane forms and the chunk checks `fits`,
//! `lane_bounds`; the tests' switches); `lattice.rs` the lattice bases' kernels (values,
//! fractal sums with and without level of detail per lane, gradients, the octave-lane form);
//! `tiled.rs` their tiled forms; `simplex.rs` and `cellular.rs` those bases' own lane kernels.

use crate::noise::lattice::TWO52;
use crate::real::Real;

/// The dispatch targets, best first; the first one the CPU supports runs. AVX-512 with VBMI
/// (16 f32 lanes, hashing by byte shuffles), AVX-512 (hashing by gathers), AVX2 (8 lanes; LLVM
/// loads the table entries one by one, as it deems AVX2 gathers slow on generic x86-64), SSE4.1
/// (`roundpd`), and the baseline (per-point loop).
///
/// Every clone in release builds, the building machine's alone in debug and test builds
/// (`simd_clones!`, the crate root).
macro_rules! simd_targets {
    ($item:item) => {
        simd_clones! {
            all: [
                "x86_64+avx512f+avx512bw+avx512vl+avx512vbmi+avx2+fma",
                "x86_64+avx512f+avx512bw+avx512vl+avx2+fma",
                "x86_64+avx2+fma",
                "x86_64+sse4.1",
            ],
            vbmi: "x86_64+avx512f+avx512bw+avx512vl+avx512vbmi+avx2+fma",
            avx2: "x86_64+avx2+fma",
            $item
        }
    };
}

pub(crate) mod cellular;
pub(crate) mod lattice;
pub(crate) mod simplex;
pub(crate) mod tiled;

/// 2^51: below it in magnitude, [`lattice_lane_fast`] applies.
pub(super) const TWO51: f64 = 2_251_799_813_685_248.0;

/// `lattice::lattice` without branches, for the vectorised step 1, for every x: the cell index
/// mod 256 and the fraction by the contract formula itself. The same numbers as `lattice` for
/// every finite x:
/// `c = floor(x)` (which `lattice`'s integer form reproduces exactly, `-0.0` included);
/// `m = c - 256 floor(c / 256)`, exact in f64 for every finite c, an integer in [0, 255]; the
/// fraction `x - c`. `c / 256` is exact (a power of two, no underflow for an integer), so LLVM's
/// multiplication by 1/256 is the same number.
///
/// m goes to u8 through the low byte of the bits of `m + 2^52` (exact: its low mantissa bits are
/// m), not `as u8`: Rust's saturating float-to-int conversion does not vectorise on x86 (it
/// became a scalar min / compare / convert per lane, the hottest code of the kernel). For ±inf
/// or NaN, m is NaN and its low byte some index in [0, 255]; the fraction is NaN, so the result
/// is NaN whatever the index (every basis weights its x, y and z lerps by the fraction), and
/// `canonical_nan` makes it the same NaN as the point path's.
#[inline(always)]
pub(super) fn lattice_lane_exact<S: Real>(x: f64) -> (u8, S) {
    let c = x.floor();
    let m = c - 256.0 * (c / 256.0).floor();
    ((m + TWO52).to_bits() as u8, S::from_f64(x - c))
}

/// [`lattice_lane_exact`] for |x| < 2^51, in three fewer operations: for an integer c with
/// |c| <= 2^51, `c + 1.5 · 2^52` is exact and lies in [2^52, 2^53), where the mantissa bits are
/// `c + 2^51`, whose low 8 bits are c mod 256 (2^51 is a multiple of 256, and the bits are
/// two's complement for negative c).
#[inline(always)]
pub(super) fn lattice_lane_fast<S: Real>(x: f64) -> (u8, S) {
    const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52
    let c = x.floor();
    ((c + MAGIC).to_bits() as u8, S::from_f64(x - c))
}

/// The largest |f| of `freqs` (NaN if one is NaN, 0 if there are none).
#[inline(always)]
fn max_abs(freqs: &[f64]) -> f64 {
    freqs.iter().fold(0.0, |m: f64, &f| {
        if f.abs() > m || f.is_nan() {
            f.abs()
        } else {
            m
        }
    })
}

/// Whether |x · f| < 2^51 for every lane x of `p` and every |f| <= `f_max`, so that step 1 may
/// use [`lattice_lane_fast`] for every octave of the chunk: rounding is monotone, so
/// |x · f| <= |x| · f_max (both rounded) < 2^51. NaN and ±inf fail the test (NaN compares
/// false), so they take the exact path. One compare per lane per chunk, against three
/// operations saved per lane, axis and octave.
#[inline(always)]
pub(super) fn fits(p: [&[f64]; 3], f_max: f64) -> bool {
    let mut ok = true;
    for src in p {
        for &x in src {
            ok &= x.abs() * f_max < TWO51;
        }
    }
    ok
}

#[cfg(test)]
thread_local! {
    /// Tests set this to run the table-read forms of the kernels (those of CPUs without AVX-512
    /// VBMI) on CPUs with it too, on this thread.
    pub(super) static TABLE_READS: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// How many lane groups [`CellLanes::coherent`] has searched on this thread (so that tests
    /// can show they reach it).
    pub(super) static COHERENT_GROUPS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Whether a test asked for the table-read forms ([`TABLE_READS`]); always false outside tests.
#[inline(always)]
fn table_reads_forced() -> bool {
    #[cfg(test)]
    return TABLE_READS.with(std::cell::Cell::get);
    #[cfg(not(test))]
    false
}

/// The least and greatest of `src`, `None` when one is NaN, in `W` running lanes and then a tree
/// of lane-wise steps (a fold's NaN-aware `min` would run lane by lane): the tiled kernels' chunk
/// bounds (see [`scaled_inside`]: rounding is monotone, so `lo · f <= x · f <= hi · f` for
/// f >= 0, reversed for f < 0) and a cellular group's cell span. `W` a power of two.
#[inline(always)]
fn lane_bounds<const W: usize>(src: &[f64]) -> Option<(f64, f64)> {
    let mut lo = [f64::INFINITY; W];
    let mut hi = [f64::NEG_INFINITY; W];
    let mut nan = [false; W];
    let (groups, rest) = src.as_chunks::<W>();
    for g in groups {
        for j in 0..W {
            lo[j] = lo[j].min(g[j]);
            hi[j] = hi[j].max(g[j]);
            nan[j] |= g[j].is_nan();
        }
    }
    for (j, &x) in rest.iter().enumerate() {
        lo[j] = lo[j].min(x);
        hi[j] = hi[j].max(x);
        nan[j] |= x.is_nan();
    }
    let mut width = W / 2;
    while width > 0 {
        for j in 0..width {
            lo[j] = lo[j].min(lo[j + width]);
            hi[j] = hi[j].max(hi[j + width]);
            nan[j] |= nan[j + width];
        }
        width /= 2;
    }
    (!nan[0]).then_some((lo[0], hi[0]))
}

/// Whether `x · f` lies in [0, `p`) for every x in `bounds` (see [`lane_bounds`]).
#[inline(always)]
fn scaled_inside(bounds: Option<(f64, f64)>, f: f64, p: f64) -> bool {
    bounds.is_some_and(|(lo, hi)| {
        let (a, b) = (lo * f, hi * f);
        let (min, max) = if a <= b { (a, b) } else { (b, a) };
        min >= 0.0 && max < p
    })
}
