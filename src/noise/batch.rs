//! The batch kernels: [`NoiseTable::sample_batch`](super::NoiseTable::sample_batch) and
//! [`fractal_batch`](super::fractal_batch) over many lanes, written for the auto-vectoriser and
//! compiled once per instruction set, picked at run time (the `multiversion` crate; a portable
//! build runs AVX-512 or AVX2 code where the CPU has it).
//!
//! Each chunk of up to [`CHUNK`] lanes goes through two loops per octave:
//!
//! 1. the lattice step, in f64 (positions are always f64, see the module docs of `noise`): the
//!    scaled position `p * f`, its cell index mod 256 (as i32) and its fraction within the cell
//!    (converted to S), into stack arrays. Branch-free: `floor` is one instruction from SSE4.1 on
//!    (`roundpd`), so the exact contract formula `c = floor(x)`, `m = c - 256 floor(c / 256)` is
//!    used as it stands, for every input (huge, negative, non-finite) alike.
//! 2. the interior, in S and i32 only: the corner hashes as gathers from the paired permutation
//!    table, the gradients or values as gathers, Perlin's `grad` as selects, the fades and lerps.
//!    With AVX-512 that is 16 f32 lanes per instruction.
//!
//! A fractal sum runs the octaves outside the lanes, and each lane sees
//! `sum = sum + amp · n` in octave order starting from zero: exactly [`fractal`](super::fractal)'s
//! additions. With the `Kernel::eval_lane` formulations (same arithmetic as the point functions,
//! expression for expression), the results are the point functions' bit for bit; the tests
//! check it on random, huge, negative, lattice, boundary and non-finite points, for every basis,
//! batch length and precision. (Rust never contracts `a * b + c` into an FMA nor reassociates, so
//! compiling for FMA-capable targets changes no result.)
//!
//! Batches of fewer than [`SMALL`] lanes (the interpreter's per-point path) and CPUs without
//! SSE4.1 run the per-point kernels in a loop instead: no dispatch, no stack arrays, no libm
//! `floor` calls.

use multiversion::multiversion;
use multiversion::target::target_cfg_f;

use super::{canonical_nan, Kernel};
use crate::real::Real;

/// Lanes per chunk: the stack arrays of the lattice step hold this many (3 × 1 KB of indices,
/// 3 × 1 or 2 KB of fractions: L1-resident). The interpreter's chunks are this size too.
pub(super) const CHUNK: usize = 256;

/// Below this many lanes a batch runs the per-point kernels: the SIMD path's setup (dispatch,
/// zeroing the stack arrays) costs more than it saves on one lane.
pub(super) const SMALL: usize = 8;

/// `out[i] = k.eval(p_i)` bit for bit.
#[inline]
pub(super) fn sample<S: Real, K: Kernel>(k: &K, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
    if out.len() < SMALL {
        point_loop(k, x, y, z, out);
    } else {
        sample_lanes(k, x, y, z, out);
    }
}

/// `out[i] = Σ_o amp_o · k.eval(p_i · freq_o)` (|·| when `TURB`), summed as
/// [`fractal`](super::fractal) does, bit for bit.
#[inline]
pub(super) fn fractal<S: Real, K: Kernel, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    if out.len() < SMALL {
        fractal_point_loop::<S, K, TURB>(k, freqs, amps, x, y, z, out);
    } else {
        fractal_lanes::<S, K, TURB>(k, freqs, amps, x, y, z, out);
    }
}

/// The per-point reference over a batch.
#[inline(always)]
fn point_loop<S: Real, K: Kernel>(k: &K, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
    for (((o, &x), &y), &z) in out.iter_mut().zip(x).zip(y).zip(z) {
        *o = k.eval([x, y, z]);
    }
}

/// The per-point reference of a fractal sum over a batch (octaves inside, per lane).
#[inline(always)]
fn fractal_point_loop<S: Real, K: Kernel, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    for (((o, &x), &y), &z) in out.iter_mut().zip(x).zip(y).zip(z) {
        let mut sum = S::ZERO;
        for (&f, &a) in freqs.iter().zip(amps) {
            let n: S = k.eval([x * f, y * f, z * f]);
            let n = if TURB { n.abs() } else { n };
            sum = sum + S::from_f64(a) * n;
        }
        *o = canonical_nan(sum);
    }
}

/// The lattice step's output for one chunk: cell indices mod 256 and fractions, per axis.
struct Lattice<S> {
    cell: [[i32; CHUNK]; 3],
    frac: [[S; CHUNK]; 3],
}

impl<S: Real> Lattice<S> {
    #[inline(always)]
    fn new() -> Self {
        Lattice {
            cell: [[0; CHUNK]; 3],
            frac: [[S::ZERO; CHUNK]; 3],
        }
    }

    /// Step 1 for the lanes of `p` (at most [`CHUNK`]), scaled by `f` when `SCALE`.
    #[inline(always)]
    fn fill<const SCALE: bool>(&mut self, f: f64, p: [&[f64]; 3]) {
        for ((src, cell), frac) in p.into_iter().zip(&mut self.cell).zip(&mut self.frac) {
            for ((&x, c), t) in src.iter().zip(cell.iter_mut()).zip(frac.iter_mut()) {
                let x = if SCALE { x * f } else { x };
                (*c, *t) = lattice_lane(x);
            }
        }
    }

    /// Step 2: `out[i] = k(lane i)` (`ACC == false`) or `out[i] = out[i] + amp · k(lane i)`
    /// (|k| when `TURB`), for the first `out.len()` lanes.
    #[inline(always)]
    fn noise<K: Kernel, const ACC: bool, const TURB: bool>(&self, k: &K, amp: S, out: &mut [S]) {
        let n = out.len();
        let [cx, cy, cz] = &self.cell;
        let [fx, fy, fz] = &self.frac;
        let (cx, cy, cz) = (&cx[..n], &cy[..n], &cz[..n]);
        let (fx, fy, fz) = (&fx[..n], &fy[..n], &fz[..n]);
        for i in 0..n {
            let v: S = k.eval_lane([cx[i], cy[i], cz[i]], [fx[i], fy[i], fz[i]]);
            out[i] = if ACC {
                let v = if TURB { v.abs() } else { v };
                out[i] + amp * v
            } else {
                v
            };
        }
    }
}

/// `lattice::lattice` without branches, for the vectorised step 1: the cell index mod 256 and
/// the fraction, by the contract formula itself. The same numbers as `lattice` for every finite
/// x: `c = floor(x)` (which `lattice`'s integer form reproduces exactly, `-0.0` included);
/// `m = c - 256 floor(c / 256)`, exact in f64 for every finite c, an integer in [0, 255]; the
/// fraction `x - c`. `c / 256` is exact (a power of two, no underflow for an integer), so LLVM's
/// multiplication by 1/256 is the same number.
///
/// m goes to i32 through the bits of `m + 2^52` (exact: its low mantissa bits are m), not
/// `as i32`: Rust's saturating conversion does not vectorise on x86 (it became a scalar
/// min / compare / convert per lane, the hottest code of the kernel). For ±inf or NaN, m is NaN
/// and the `& 255` turns its bits into some index in [0, 255] (so every later index sum stays
/// in the tables and far from i32 overflow); the fraction is NaN, so the result is NaN whatever
/// the index (every basis weights its x, y and z lerps by the fraction), and `canonical_nan`
/// makes it the same NaN as the point path's.
#[inline(always)]
fn lattice_lane<S: Real>(x: f64) -> (i32, S) {
    const TWO52: f64 = 4_503_599_627_370_496.0;
    let c = x.floor();
    let m = c - 256.0 * (c / 256.0).floor();
    ((m + TWO52).to_bits() as i32 & 255, S::from_f64(x - c))
}

/// The dispatch targets, best first; the first one the CPU supports runs. AVX-512 (16 f32 lanes,
/// gathers), AVX2 (8 lanes), SSE4.1 (`roundpd`), and the baseline (per-point loop).
macro_rules! simd_targets {
    ($item:item) => {
        #[multiversion(targets(
            "x86_64+avx512f+avx512bw+avx512vl+avx2+fma",
            "x86_64+avx2+fma",
            "x86_64+sse4.1",
        ))]
        $item
    };
}

simd_targets! {
/// [`sample`] for batches of [`SMALL`] lanes or more.
fn sample_lanes<S: Real, K: Kernel>(k: &K, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
    if !target_cfg_f!(target_feature = "sse4.1") {
        return point_loop(k, x, y, z, out);
    }
    let mut lattice = Lattice::<S>::new();
    let chunks = out.chunks_mut(CHUNK).zip(x.chunks(CHUNK).zip(y.chunks(CHUNK)).zip(z.chunks(CHUNK)));
    for (out, ((x, y), z)) in chunks {
        lattice.fill::<false>(1.0, [x, y, z]);
        lattice.noise::<K, false, false>(k, S::ONE, out);
    }
}
}

simd_targets! {
/// [`fractal`] for batches of [`SMALL`] lanes or more.
fn fractal_lanes<S: Real, K: Kernel, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    if !target_cfg_f!(target_feature = "sse4.1") {
        return fractal_point_loop::<S, K, TURB>(k, freqs, amps, x, y, z, out);
    }
    let mut lattice = Lattice::<S>::new();
    let chunks = out.chunks_mut(CHUNK).zip(x.chunks(CHUNK).zip(y.chunks(CHUNK)).zip(z.chunks(CHUNK)));
    for (out, ((x, y), z)) in chunks {
        out.fill(S::ZERO);
        for (&f, &a) in freqs.iter().zip(amps) {
            lattice.fill::<true>(f, [x, y, z]);
            lattice.noise::<K, true, TURB>(k, S::from_f64(a), out);
        }
        for o in out.iter_mut() {
            *o = canonical_nan(*o);
        }
    }
}
}
