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

use multiversion::multiversion;
use multiversion::target::target_cfg_f;

use super::kernel::{
    octaves_grad, reference_batch, reference_fractal, reference_grad_batch, LatticeKernel,
    NoiseKernel,
};
use super::lanes::{canonical_grad, canonical_nan, CHUNK, SMALL};
use super::lattice::TWO52;
use super::octaves::{LaneOctaves, OctavePeriods};
use super::period::Period;
use crate::real::Real;

/// Most octaves [`fractal_octave_lanes`] takes as lanes (the octave limit of graph files).
const OCTAVE_LANES: usize = 32;

/// `out[i] = k.eval(p_i)` bit for bit.
#[inline]
pub(super) fn sample<S: Real, K: LatticeKernel>(
    k: &K,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    if out.len() < SMALL {
        reference_batch(|p| k.eval(p), x, y, z, out);
    } else {
        sample_lanes(k, x, y, z, out);
    }
}

/// `out[i] = Σ_o amp_o · k.eval(p_i · freq_o)` (|·| when `TURB`), summed as
/// [`fractal`](super::fractal) does, bit for bit.
#[inline]
pub(super) fn fractal<S: Real, K: LatticeKernel, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    if out.len() < SMALL {
        // Too few points to vectorise across: vectorise across each point's octaves instead.
        for (((o, &x), &y), &z) in out.iter_mut().zip(x).zip(y).zip(z) {
            *o = fractal_octave_lanes::<S, K, TURB>(k, freqs, amps, [x, y, z]);
        }
    } else {
        fractal_lanes::<S, K, TURB>(k, freqs, amps, x, y, z, out);
    }
}

/// The working arrays of one chunk of `N` lanes: the lattice step's output (cell indices mod 256
/// and fractions, per axis) and, on the byte-shuffle path, the corner hashes. Batches use
/// chunks of [`CHUNK`] points; [`fractal_octave_lanes`] a few lanes, one per octave.
pub(super) struct Lattice<S, const N: usize = CHUNK> {
    pub(super) cell: [[u8; N]; 3],
    pub(super) frac: [[S; N]; 3],
    pub(super) hashes: [[u8; N]; 8],
}

impl<S: Real, const N: usize> Lattice<S, N> {
    #[inline(always)]
    pub(super) fn new() -> Self {
        Lattice {
            cell: [[0; N]; 3],
            frac: [[S::ZERO; N]; 3],
            hashes: [[0; N]; 8],
        }
    }

    /// Step 1 for the lanes of `p` (at most [`CHUNK`]), scaled by `f` when `SCALE`; `fast`
    /// picks [`lattice_lane_fast`], which the caller has checked with [`fits`].
    #[inline(always)]
    pub(super) fn fill<const SCALE: bool>(&mut self, fast: bool, f: f64, p: [&[f64]; 3]) {
        if fast {
            self.fill_with::<SCALE>(f, p, lattice_lane_fast);
        } else {
            self.fill_with::<SCALE>(f, p, lattice_lane_exact);
        }
    }

    #[inline(always)]
    fn fill_with<const SCALE: bool>(&mut self, f: f64, p: [&[f64]; 3], lane: fn(f64) -> (u8, S)) {
        for (a, src) in p.into_iter().enumerate() {
            self.fill_axis_with::<SCALE>(a, f, src, lane);
        }
    }

    /// Step 1 for axis `a` alone: `lane(x · f)` (`lane(x)` without `SCALE`) for each lane.
    #[inline(always)]
    fn fill_axis_with<const SCALE: bool>(
        &mut self,
        a: usize,
        f: f64,
        src: &[f64],
        lane: fn(f64) -> (u8, S),
    ) {
        let (cell, frac) = (&mut self.cell[a], &mut self.frac[a]);
        for ((&x, c), t) in src.iter().zip(cell.iter_mut()).zip(frac.iter_mut()) {
            let x = if SCALE { x * f } else { x };
            (*c, *t) = lane(x);
        }
    }

    /// Step 1 for one axis, scaled by `f`, on the fast path (every `|x · f| < 2^51`).
    #[inline(always)]
    pub(super) fn fill_axis(&mut self, a: usize, f: f64, src: &[f64]) {
        self.fill_axis_with::<true>(a, f, src, lattice_lane_fast::<S>);
    }

    /// Step 1 for one axis, unscaled; `fast` as for [`Lattice::fill`].
    #[inline(always)]
    pub(super) fn fill_axis_exact(&mut self, a: usize, fast: bool, src: &[f64]) {
        if fast {
            self.fill_axis_with::<false>(a, 1.0, src, lattice_lane_fast::<S>);
        } else {
            self.fill_axis_with::<false>(a, 1.0, src, lattice_lane_exact::<S>);
        }
    }

    /// Steps 2 and 3 in one loop, the hashes gathered from the paired table: `out[i] = k(lane i)`
    /// (`ACC == false`) or `out[i] = out[i] + amp · k(lane i)` (|k| when `TURB`), for the first
    /// `out.len()` lanes.
    #[inline(always)]
    pub(super) fn noise<K: LatticeKernel, const ACC: bool, const TURB: bool, const WIDE: bool>(
        &self,
        k: &K,
        amp: S,
        out: &mut [S],
    ) {
        // With n <= CHUNK known, no index below needs a bounds check (one would cost a scalar
        // epilogue of 16 lanes per chunk: LLVM then vectorises only the lanes proved in bounds).
        let n = out.len().min(N);
        let (cell, frac) = (&self.cell, &self.frac);
        for i in 0..n {
            let c = |a: usize| i32::from(cell[a][i]);
            let h = k.hashes([c(0), c(1), c(2)]);
            let v: S = k.interior::<S, WIDE>(h, [frac[0][i], frac[1][i], frac[2][i]]);
            out[i] = accumulate::<S, ACC, TURB>(out[i], amp, v);
        }
    }

    /// Step 3 with the hashes of step 2 already in `self.hashes` (see
    /// [`Lattice::shuffle_hashes`]); otherwise as [`Lattice::noise`].
    #[inline(always)]
    pub(super) fn noise_hashed<
        K: LatticeKernel,
        const ACC: bool,
        const TURB: bool,
        const WIDE: bool,
    >(
        &self,
        k: &K,
        amp: S,
        out: &mut [S],
    ) {
        let n = out.len().min(N); // see `noise`
        let (hashes, frac) = (&self.hashes, &self.frac);
        for i in 0..n {
            let h = |c: usize| hashes[c][i];
            let h = [h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7)];
            let v: S = k.interior::<S, WIDE>(h, [frac[0][i], frac[1][i], frac[2][i]]);
            out[i] = accumulate::<S, ACC, TURB>(out[i], amp, v);
        }
    }
}

impl<S: Real, const N: usize> Lattice<S, N> {
    /// Step 3 of a gradient: per lane `interior_grad` (the value too when `VALUE`, into `n`;
    /// else `n` is left alone), the hashes from `self.hashes` when `HASHED` (see
    /// [`Lattice::noise_hashed`]), else gathered in the loop (see [`Lattice::noise`]); for the
    /// first `n.len()` lanes.
    #[inline(always)]
    pub(super) fn noise_grad<
        K: LatticeKernel,
        const HASHED: bool,
        const VALUE: bool,
        const WIDE: bool,
    >(
        &self,
        k: &K,
        n: &mut [S],
        g: [&mut [S]; 3],
    ) {
        let m = n.len().min(N); // see `noise`
        let [gx, gy, gz] = g;
        let (n, gx, gy, gz) = (&mut n[..m], &mut gx[..m], &mut gy[..m], &mut gz[..m]);
        for i in 0..m {
            let h = self.lane_hashes::<K, HASHED>(k, i);
            let (v, d) = k.interior_grad::<S, WIDE, VALUE>(h, self.lane_frac(i));
            if VALUE {
                n[i] = v;
            }
            let d = canonical_grad(d);
            (gx[i], gy[i], gz[i]) = (d[0], d[1], d[2]);
        }
    }

    /// Step 3 of an fbm's gradient, accumulated in place: `sum[c][i] = sum[c][i] + c · g_c`
    /// with `g` lane i's gradient (`interior_grad`, no value), for the first `m` lanes; the
    /// hashes as for [`Lattice::noise_grad`].
    #[inline(always)]
    pub(super) fn fbm_grad<K: LatticeKernel, const HASHED: bool, const WIDE: bool>(
        &self,
        k: &K,
        c: S,
        sum: &mut [[S; N]; 3],
        m: usize,
    ) {
        let m = m.min(N); // see `noise`
        for i in 0..m {
            // NaN stays NaN through the sum, made canonical once at the end.
            let h = self.lane_hashes::<K, HASHED>(k, i);
            let (_, d) = k.interior_grad::<S, WIDE, false>(h, self.lane_frac(i));
            for (plane, d) in sum.iter_mut().zip(d) {
                plane[i] = plane[i] + c * d;
            }
        }
    }

    /// Lane i's eight corner hashes: from `self.hashes` when `HASHED`, else gathered from its
    /// cell bytes.
    #[inline(always)]
    fn lane_hashes<K: LatticeKernel, const HASHED: bool>(&self, k: &K, i: usize) -> [u8; 8] {
        if HASHED {
            // Written out, as in `noise_hashed`: built with `array::from_fn` the eight bytes
            // were packed into a 64-bit integer, and LLVM then kept a scalar epilogue of a
            // whole vector of lanes (16 of the chunk's 256, a third of the run time).
            let h = |c: usize| self.hashes[c][i];
            [h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7)]
        } else {
            let c = |a: usize| i32::from(self.cell[a][i]);
            k.hashes([c(0), c(1), c(2)])
        }
    }

    /// Lane i's fractions.
    #[inline(always)]
    fn lane_frac(&self, i: usize) -> [S; 3] {
        [self.frac[0][i], self.frac[1][i], self.frac[2][i]]
    }
}

impl<S: Real> Lattice<S, CHUNK> {
    /// Step 2 on CPUs with AVX-512 VBMI: the corner hashes of the first `n` lanes by byte
    /// shuffles (`vbmi.rs`), into `self.hashes`.
    ///
    /// # Safety
    /// The CPU must support avx512f, avx512bw and avx512vbmi.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn shuffle_hashes<K: LatticeKernel>(&mut self, k: &K, n: usize) {
        // SAFETY: the caller guarantees the target features.
        unsafe {
            if K::PERLIN_HASH {
                super::vbmi::corner_hashes::<true>(k.perm(), &self.cell, n, &mut self.hashes);
            } else {
                super::vbmi::corner_hashes::<false>(k.perm(), &self.cell, n, &mut self.hashes);
            }
        }
    }

    /// Never called: no CPU of this architecture has AVX-512 VBMI.
    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    unsafe fn shuffle_hashes<K: LatticeKernel>(&mut self, _: &K, _: usize) {
        unreachable!("AVX-512 VBMI on a non-x86-64 target")
    }

    /// [`Lattice::shuffle_hashes`] with each axis's upper corner index given (`hi`), for
    /// tiling (`vbmi::corner_hashes_wrapped`).
    ///
    /// # Safety
    /// The CPU must support avx512f, avx512bw and avx512vbmi.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn shuffle_hashes_wrapped<K: LatticeKernel>(
        &mut self,
        k: &K,
        hi: &[[u8; CHUNK]; 3],
        n: usize,
    ) {
        use super::vbmi::corner_hashes_wrapped;
        let (perm, cell, out) = (k.perm(), &self.cell, &mut self.hashes);
        // SAFETY: the caller guarantees the target features.
        unsafe {
            if K::PERLIN_HASH {
                corner_hashes_wrapped::<true>(perm, cell, hi, n, out);
            } else {
                corner_hashes_wrapped::<false>(perm, cell, hi, n, out);
            }
        }
    }

    /// Never called: no CPU of this architecture has AVX-512 VBMI.
    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    unsafe fn shuffle_hashes_wrapped<K: LatticeKernel>(
        &mut self,
        _: &K,
        _: &[[u8; CHUNK]; 3],
        _: usize,
    ) {
        unreachable!("AVX-512 VBMI on a non-x86-64 target")
    }

    /// The corner hashes of the first `n` lanes without byte shuffles, for tiling: gathered as
    /// for plain noise, then, when `any`, redone with the upper corner wrapped to cell 0
    /// (`lattice::corner_hashes_wrapped`) for the lanes in a period's last cell (`wraps`, per
    /// axis).
    #[inline(always)]
    fn wrapped_hashes<K: LatticeKernel>(
        &mut self,
        k: &K,
        wraps: &[[u8; CHUNK]; 3],
        any: bool,
        n: usize,
    ) {
        let n = n.min(CHUNK);
        for i in 0..n {
            let c = |a: usize| i32::from(self.cell[a][i]);
            let h = k.hashes([c(0), c(1), c(2)]);
            for (plane, h) in self.hashes.iter_mut().zip(h) {
                plane[i] = h;
            }
        }
        if !any {
            return;
        }
        for i in 0..n {
            let wrap: [bool; 3] = std::array::from_fn(|a| wraps[a][i] != 0);
            if wrap == [false; 3] {
                continue;
            }
            let lo: [usize; 3] = std::array::from_fn(|a| self.cell[a][i] as usize);
            let hi: [usize; 3] =
                std::array::from_fn(|a| if wrap[a] { 0 } else { (lo[a] + 1) & 255 });
            let h = super::lattice::corner_hashes_wrapped(k.perm(), K::PERLIN_HASH, lo, hi);
            for (plane, h) in self.hashes.iter_mut().zip(h) {
                plane[i] = h;
            }
        }
    }
}

/// One lane of step 3's output: `v` (`ACC == false`) or `sum + amp · v` (|v| when `TURB`).
#[inline(always)]
fn accumulate<S: Real, const ACC: bool, const TURB: bool>(sum: S, amp: S, v: S) -> S {
    if ACC {
        let v = if TURB { v.abs() } else { v };
        sum + amp * v
    } else {
        v
    }
}

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

/// The dispatch targets, best first; the first one the CPU supports runs. AVX-512 with VBMI
/// (16 f32 lanes, hashing by byte shuffles), AVX-512 (hashing by gathers), AVX2 (8 lanes; LLVM
/// loads the table entries one by one, as it deems AVX2 gathers slow on generic x86-64), SSE4.1
/// (`roundpd`), and the baseline (per-point loop).
macro_rules! simd_targets {
    ($item:item) => {
        #[multiversion(targets(
            "x86_64+avx512f+avx512bw+avx512vl+avx512vbmi+avx2+fma",
            "x86_64+avx512f+avx512bw+avx512vl+avx2+fma",
            "x86_64+avx2+fma",
            "x86_64+sse4.1",
        ))]
        $item
    };
}

simd_targets! {
/// [`sample`] for batches of [`SMALL`] lanes or more.
fn sample_lanes<S: Real, K: LatticeKernel>(k: &K, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
    if !target_cfg_f!(target_feature = "sse4.1") {
        return reference_batch(|p| k.eval(p), x, y, z, out);
    }
    let shuffle = target_cfg_f!(target_feature = "avx512vbmi") && !table_reads_forced();
    // Hash bits tested in bytes where AVX-512BW compares bytes into masks (see `LatticeKernel::interior`).
    const WIDE: bool = !target_cfg_f!(target_feature = "avx512bw");
    let mut lattice = Lattice::<S>::new();
    let chunks = out.chunks_mut(CHUNK).zip(x.chunks(CHUNK).zip(y.chunks(CHUNK)).zip(z.chunks(CHUNK)));
    for (out, ((x, y), z)) in chunks {
        let fast = fits([x, y, z], 1.0);
        lattice.fill::<false>(fast, 1.0, [x, y, z]);
        if shuffle {
            // SAFETY: `shuffle` is true only in the clone compiled for avx512vbmi (which implies
            // avx512f and avx512bw), which the dispatcher runs only on CPUs that have it.
            unsafe { lattice.shuffle_hashes(k, out.len()) };
            lattice.noise_hashed::<K, false, false, WIDE>(k, S::ONE, out);
        } else {
            lattice.noise::<K, false, false, WIDE>(k, S::ONE, out);
        }
    }
}
}

simd_targets! {
/// [`fractal`] for batches of [`SMALL`] lanes or more.
fn fractal_lanes<S: Real, K: LatticeKernel, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    if !target_cfg_f!(target_feature = "sse4.1") {
        return reference_fractal::<S, TURB>(|p| k.eval(p), freqs, amps, x, y, z, out);
    }
    let shuffle = target_cfg_f!(target_feature = "avx512vbmi") && !table_reads_forced();
    const WIDE: bool = !target_cfg_f!(target_feature = "avx512bw"); // see `sample_lanes`
    let f_max = max_abs(freqs);
    let mut lattice = Lattice::<S>::new();
    let chunks = out.chunks_mut(CHUNK).zip(x.chunks(CHUNK).zip(y.chunks(CHUNK)).zip(z.chunks(CHUNK)));
    for (out, ((x, y), z)) in chunks {
        let fast = fits([x, y, z], f_max);
        out.fill(S::ZERO);
        for (&f, &a) in freqs.iter().zip(amps) {
            lattice.fill::<true>(fast, f, [x, y, z]);
            if shuffle {
                // SAFETY: as in `sample_lanes`.
                unsafe { lattice.shuffle_hashes(k, out.len()) };
                lattice.noise_hashed::<K, true, TURB, WIDE>(k, S::from_f64(a), out);
            } else {
                lattice.noise::<K, true, TURB, WIDE>(k, S::from_f64(a), out);
            }
        }
        for o in out.iter_mut() {
            *o = canonical_nan(*o);
        }
    }
}
}

/// [`fractal`] with level of detail per lane: lane i sums the octaves `lanes` keeps for it,
/// bit for bit the per-point fractal of the schedule `Octaves::new(lanes.kept[i], ...)`.
#[inline]
pub(super) fn fractal_lod<S: Real, K: LatticeKernel, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    lanes: LaneOctaves,
    p: [&[f64]; 3],
    out: &mut [S],
) {
    if out.len() < SMALL || !fractal_lod_lanes::<S, K, TURB>(k, freqs, lanes, p, out) {
        let [x, y, z] = p;
        for (i, o) in out.iter_mut().enumerate() {
            let mut sum = S::ZERO;
            for (octave, &f) in freqs.iter().enumerate() {
                let Some(a) = lanes.amplitude(octave, i) else {
                    break;
                };
                let n: S = k.eval([x[i] * f, y[i] * f, z[i] * f]);
                sum = accumulate::<S, true, TURB>(sum, S::from_f64(a), n);
            }
            *o = canonical_nan(sum);
        }
    }
}

simd_targets! {
/// [`fractal_lod`]'s chunk loop, as [`fractal_lanes`] but each octave's noise lands in a
/// chunk array and is added per lane with the lane's own amplitude (a lane that dropped the
/// octave is left alone); a chunk runs the octaves up to the most one of its lanes keeps.
/// False (nothing written) on a CPU without SSE4.1.
fn fractal_lod_lanes<S: Real, K: LatticeKernel, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    lanes: LaneOctaves,
    [x, y, z]: [&[f64]; 3],
    out: &mut [S],
) -> bool {
    if !target_cfg_f!(target_feature = "sse4.1") {
        return false;
    }
    let shuffle = target_cfg_f!(target_feature = "avx512vbmi") && !table_reads_forced();
    const WIDE: bool = !target_cfg_f!(target_feature = "avx512bw"); // see `sample_lanes`
    let mut lattice = Lattice::<S>::new();
    let (mut n, mut partial) = ([S::ZERO; CHUNK], [S::ZERO; CHUNK]);
    let (mut whole, mut ends) = ([0u32; CHUNK], [0u32; CHUNK]);
    let mut start = 0;
    while start < out.len() {
        let m = CHUNK.min(out.len() - start);
        let (px, py, pz) = (&x[start..start + m], &y[start..start + m], &z[start..start + m]);
        let octaves = lanes.most(start..start + m, freqs.len());
        let fast = fits([px, py, pz], max_abs(&freqs[..octaves]));
        let sum = &mut out[start..start + m];
        sum.fill(S::ZERO);
        // Per lane once: its whole octaves, the amplitude of its faded one, and the octave it
        // stops before (as 32-bit lanes, so the loop below vectorises beside f32 sums).
        for i in 0..m {
            let lane = lanes.lane(start + i);
            (whole[i], ends[i]) = (lane.whole as u32, lane.ends as u32);
            partial[i] = S::from_f64(lane.partial);
        }
        for (octave, &f) in freqs[..octaves].iter().enumerate() {
            lattice.fill::<true>(fast, f, [px, py, pz]);
            if shuffle {
                // SAFETY: as in `sample_lanes`.
                unsafe { lattice.shuffle_hashes(k, m) };
                lattice.noise_hashed::<K, false, false, WIDE>(k, S::ONE, &mut n[..m]);
            } else {
                lattice.noise::<K, false, false, WIDE>(k, S::ONE, &mut n[..m]);
            }
            // Branch-free, so it vectorises: the octave's own amplitude below a lane's whole
            // octaves, its partial one at the faded octave, and a select keeps the sum of a lane
            // that dropped the octave as it is.
            let (a, k) = (S::from_f64(lanes.powers[octave]), octave as u32);
            for (i, o) in sum.iter_mut().enumerate() {
                let amp = if k < whole[i] { a } else { partial[i] };
                let added = accumulate::<S, true, TURB>(*o, amp, n[i]);
                *o = if k < ends[i] { added } else { *o };
            }
        }
        for o in sum.iter_mut() {
            *o = canonical_nan(*o);
        }
        start += m;
    }
    true
}
}

/// `(n[i], g[c][i]) = k.sample_grad(p_i)` (the values only when `VALUE`) bit for bit, for
/// batches of [`SMALL`] lanes or more: the lattice step and corner hashes as [`sample`], then
/// [`Lattice::noise_grad`].
#[inline]
pub(super) fn grad<S: Real, K: LatticeKernel, const VALUE: bool>(
    k: &K,
    p: [&[f64]; 3],
    n: &mut [S],
    g: [&mut [S]; 3],
) {
    let [gx, gy, gz] = g;
    grad_lanes::<S, K, VALUE>(k, p[0], p[1], p[2], n, gx, gy, gz);
}

simd_targets! {
/// [`grad`]'s chunk loop.
#[allow(clippy::too_many_arguments)]
fn grad_lanes<S: Real, K: LatticeKernel, const VALUE: bool>(
    k: &K,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    n: &mut [S],
    gx: &mut [S],
    gy: &mut [S],
    gz: &mut [S],
) {
    if !target_cfg_f!(target_feature = "sse4.1") {
        return reference_grad_batch(k, None, [x, y, z], n, [gx, gy, gz]);
    }
    let shuffle = target_cfg_f!(target_feature = "avx512vbmi") && !table_reads_forced();
    const WIDE: bool = !target_cfg_f!(target_feature = "avx512bw"); // see `sample_lanes`
    let mut lattice = Lattice::<S>::new();
    let mut start = 0;
    while start < n.len() {
        let r = start..(start + CHUNK).min(n.len());
        let m = r.len();
        let p = [&x[r.clone()], &y[r.clone()], &z[r.clone()]];
        lattice.fill::<false>(fits(p, 1.0), 1.0, p);
        let g = [&mut gx[r.clone()], &mut gy[r.clone()], &mut gz[r.clone()]];
        if shuffle {
            // SAFETY: as in `sample_lanes`.
            unsafe { lattice.shuffle_hashes(k, m) };
            lattice.noise_grad::<K, true, VALUE, WIDE>(k, &mut n[r], g);
        } else {
            lattice.noise_grad::<K, false, VALUE, WIDE>(k, &mut n[r], g);
        }
        start += m;
    }
}
}

/// The gradient of an untiled fbm over a batch of [`SMALL`] lanes or more, `out[c][i]` the
/// point function's (`derivative::fractal_styled_grad`) bits widened to f64: per chunk, the
/// octaves outside the lanes as in [`fractal`], each octave's gradient times
/// `S(amp · freq)` accumulated in place from zero (`GradShaper::add`'s Fbm arithmetic).
#[inline]
pub(super) fn fbm_grad<S: Real, K: LatticeKernel>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    p: [&[f64]; 3],
    out: [&mut [f64]; 3],
) {
    let [ox, oy, oz] = out;
    fbm_grad_lanes::<S, K>(k, freqs, amps, p[0], p[1], p[2], ox, oy, oz);
}

simd_targets! {
/// [`fbm_grad`]'s chunk loop.
#[allow(clippy::too_many_arguments)]
fn fbm_grad_lanes<S: Real, K: LatticeKernel>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    ox: &mut [f64],
    oy: &mut [f64],
    oz: &mut [f64],
) {
    use super::octaves::Style;
    if !target_cfg_f!(target_feature = "sse4.1") {
        let out = [ox, oy, oz];
        let periods = OctavePeriods::None;
        return octaves_grad::<S, K>(k, freqs, amps, periods, Style::Fbm, [x, y, z], out);
    }
    let shuffle = target_cfg_f!(target_feature = "avx512vbmi") && !table_reads_forced();
    const WIDE: bool = !target_cfg_f!(target_feature = "avx512bw"); // see `sample_lanes`
    let f_max = max_abs(freqs);
    let mut lattice = Lattice::<S>::new();
    let mut sum = [[S::ZERO; CHUNK]; 3];
    let mut start = 0;
    while start < x.len() {
        let r = start..(start + CHUNK).min(x.len());
        let m = r.len();
        let p = [&x[r.clone()], &y[r.clone()], &z[r.clone()]];
        let fast = fits(p, f_max);
        for plane in sum.iter_mut() {
            plane.fill(S::ZERO);
        }
        for (&f, &a) in freqs.iter().zip(amps) {
            lattice.fill::<true>(fast, f, p);
            let c = S::from_f64(a * f);
            if shuffle {
                // SAFETY: as in `sample_lanes`.
                unsafe { lattice.shuffle_hashes(k, m) };
                lattice.fbm_grad::<K, true, WIDE>(k, c, &mut sum, m);
            } else {
                lattice.fbm_grad::<K, false, WIDE>(k, c, &mut sum, m);
            }
        }
        for (o, plane) in [&mut *ox, &mut *oy, &mut *oz].into_iter().zip(&sum) {
            for (o, &v) in o[r.clone()].iter_mut().zip(&plane[..m]) {
                *o = canonical_nan(v).to_f64();
            }
        }
        start += m;
    }
}
}

simd_targets! {
/// [`fractal`] of one point, with the point's octaves as the SIMD lanes: they are independent
/// samples (the point scaled by each frequency), so one point's fbm vectorises as a batch of
/// points does. This makes per-point evaluation (`eval_point`) of an fbm faster than a
/// hand-written scalar octave loop (benches/eval.rs). The terms are then summed in octave
/// order, starting from zero, exactly as [`super::reference_fractal`] sums them; each term is the
/// batch kernels' (bit-identical to the per-point kernel), so the result is the same bits.
fn fractal_octave_lanes<S: Real, K: LatticeKernel, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    p: [f64; 3],
) -> S {
    let n = freqs.len().min(amps.len());
    if !target_cfg_f!(target_feature = "sse4.1") || n > OCTAVE_LANES {
        let mut out = [S::ZERO];
        reference_fractal::<S, TURB>(|p| k.eval(p), freqs, amps, &[p[0]], &[p[1]], &[p[2]], &mut out);
        return out[0];
    }
    const WIDE: bool = !target_cfg_f!(target_feature = "avx512bw"); // see `sample_lanes`
    let (freqs, amps) = (&freqs[..n], &amps[..n]);
    let fast = fits([&[p[0]], &[p[1]], &[p[2]]], max_abs(freqs));
    // The lanes padded with frequency 0 (the lattice origin; their terms are never summed) to
    // a constant count, 8, 16 or 32: with a constant trip count the loops vectorise whole (a
    // loop of n lanes left n < the vector width to scalar code).
    let mut f = [0.0f64; OCTAVE_LANES];
    f[..n].copy_from_slice(freqs);
    let mut terms = [S::ZERO; OCTAVE_LANES];
    match n {
        0..=8 => octave_terms::<S, K, WIDE, 8>(k, p, &f, fast, &mut terms),
        9..=16 => octave_terms::<S, K, WIDE, 16>(k, p, &f, fast, &mut terms),
        _ => octave_terms::<S, K, WIDE, 32>(k, p, &f, fast, &mut terms),
    }
    let mut sum = S::ZERO;
    for (&term, &a) in terms[..n].iter().zip(amps) {
        let term = if TURB { term.abs() } else { term };
        sum = sum + S::from_f64(a) * term;
    }
    canonical_nan(sum)
}
}

/// The first `L` lanes of [`fractal_octave_lanes`]: `terms[i] = k(p · f[i])`, through the
/// batch kernels' own lattice and noise steps.
#[inline(always)]
fn octave_terms<S: Real, K: LatticeKernel, const WIDE: bool, const L: usize>(
    k: &K,
    p: [f64; 3],
    f: &[f64; OCTAVE_LANES],
    fast: bool,
    terms: &mut [S; OCTAVE_LANES],
) {
    let lanes: [[f64; L]; 3] = std::array::from_fn(|axis| std::array::from_fn(|i| p[axis] * f[i]));
    let mut lattice = Lattice::<S, L>::new();
    lattice.fill::<false>(fast, 1.0, [&lanes[0], &lanes[1], &lanes[2]]);
    lattice.noise::<K, false, false, WIDE>(k, S::ONE, &mut terms[..L]);
}

/// Cellular noise over a batch, `out[i]` = `cellular::sample(p_i)` bit for bit: the 27 nearest
/// cells of every lane at once (the cell hash over lanes, distances, branch-free minimum updates
/// in the point function's scan order and with its comparisons), then per lane the ring test; a
/// lane that needs a further ring (rare), or whose point is not finite, runs the point function
/// instead.
pub(super) fn cellular<S: Real>(
    key: [u32; 2],
    params: super::cellular::Cellular,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    use super::cellular::Metric;
    match params.metric {
        Metric::Euclidean => cellular_lanes::<S, 0>(key, params, x, y, z, out),
        Metric::Manhattan => cellular_lanes::<S, 1>(key, params, x, y, z, out),
        Metric::Chebyshev => cellular_lanes::<S, 2>(key, params, x, y, z, out),
    }
}

simd_targets! {
/// [`cellular`] for one metric (`METRIC`: 0 Euclidean, 1 Manhattan, 2 Chebyshev).
#[allow(clippy::needless_range_loop)] // lanes indexed across parallel arrays, by design
fn cellular_lanes<S: Real, const METRIC: u8>(
    key: [u32; 2],
    params: super::cellular::Cellular,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    use super::cellular::{self, CellularValue, Metric, Nearest};
    const N: usize = CELL_CHUNK;
    let metric = match METRIC {
        0 => Metric::Euclidean,
        1 => Metric::Manhattan,
        _ => Metric::Chebyshev,
    };
    let point = |p: [f64; 3]| canonical_nan(cellular::sample::<S>(key, params, None, p));
    if !target_cfg_f!(target_feature = "sse4.1") {
        return reference_batch(point, x, y, z, out);
    }
    let uses_f2 = !matches!(params.value, CellularValue::F1 | CellularValue::CellValue);
    let jitter = params.jitter();
    let mut lanes = CellLanes::<S>::new();
    let chunks = out.chunks_mut(N).zip(x.chunks(N).zip(y.chunks(N)).zip(z.chunks(N)));
    for (out, ((x, y), z)) in chunks {
        // `min(N)`: with m <= N known, no lane index needs a bounds check (see `Lattice::noise`).
        let m = out.len().min(N);
        lanes.locate([x, y, z], m);
        for lo in (0..m).step_by(CELL_GROUP) {
            if !lanes.coherent(key, params.jitter_f32(), metric, lo) {
                lanes.gathered(key, params.jitter_f32(), metric, lo, (lo + CELL_GROUP).min(m));
            }
        }
        // Every lane's value, then the point function for the lanes the 27 cells may not
        // settle (a further ring could hold a nearer point) or whose point is not finite.
        let mut far = [false; N];
        for i in 0..m {
            let f = [x[i] - lanes.floor[0][i], y[i] - lanes.floor[1][i], z[i] - lanes.floor[2][i]];
            let needed = if uses_f2 { lanes.f2[i] } else { lanes.f1[i] };
            let gap = cellular::ring_gap::<S>(2, jitter, f);
            let gap = if metric == Metric::Euclidean { gap * gap } else { gap };
            far[i] = f[0].is_nan() | f[1].is_nan() | f[2].is_nan() | (gap < needed);
            let best = Nearest {
                f1: lanes.f1[i],
                f2: lanes.f2[i],
                cell: [lanes.nearest[0][i], lanes.nearest[1][i]],
            };
            out[i] = canonical_nan(cellular::finish(metric, params.value, best));
        }
        for i in 0..m {
            if far[i] {
                out[i] = point([x[i], y[i], z[i]]);
            }
        }
    }
}
}

/// One lane's running search step, branch-free: a distance `dist` to the point of the cell with
/// hash state `(a, b)` becomes the nearest (the old nearest second) or the second nearest, with
/// the point function's strict comparisons (so ties keep the earlier cell, and infinite
/// distances change nothing). Values in, values out (references into the lane arrays kept LLVM
/// from vectorising the loops).
#[inline(always)]
fn nearer<S: Real>(
    (f1, f2, a, b): (S, S, u32, u32),
    dist: S,
    (ha, hb): (u32, u32),
) -> (S, S, u32, u32) {
    let closer = dist < f1;
    let second = dist < f2;
    let f2 = if closer {
        f1
    } else if second {
        dist
    } else {
        f2
    };
    if closer {
        (dist, f2, ha, hb)
    } else {
        (f1, f2, a, b)
    }
}

/// Lanes per chunk of a cellular batch.
const CELL_CHUNK: usize = 64;
/// Lanes per group of [`CellLanes::coherent`]: one AVX-512 register of f32.
const CELL_GROUP: usize = 16;
/// The most cells a group's lanes may span along one axis for [`CellLanes::coherent`], and the
/// most cells it may visit (the union of the lanes' 27-cell neighbourhoods). A visited cell costs
/// each lane about a dozen vector operations whether or not it is one of the lane's 27, and its
/// hash once for the group; a gathered cell costs each lane its hash. Measured on
/// `eval/cellular_fbm4` (octaves spanning 1, 2, 4 and 8 cells per group of 16 voxels) with the
/// table hash this replaced: allowing the 8-cell octave its 90 visits took the bench from 13.1
/// to 7.1 ms, so the union pays up to about 100 cells.
const CELL_SPAN: usize = 8;
const CELL_VISITS: usize = 100;

/// A chunk of a cellular batch: each lane's cell (its index and its floor in f64), its fraction
/// (in S), and the two nearest distances found and the hash state of the nearest point's cell.
struct CellLanes<S> {
    index: [[i64; CELL_CHUNK]; 3],
    floor: [[f64; CELL_CHUNK]; 3],
    frac: [[S; CELL_CHUNK]; 3],
    f1: [S; CELL_CHUNK],
    f2: [S; CELL_CHUNK],
    nearest: [[u32; CELL_CHUNK]; 2],
}

#[allow(clippy::needless_range_loop)] // lanes indexed across parallel arrays, by design
impl<S: Real> CellLanes<S> {
    #[inline(always)]
    fn new() -> Self {
        CellLanes {
            index: [[0; CELL_CHUNK]; 3],
            floor: [[0.0; CELL_CHUNK]; 3],
            frac: [[S::ZERO; CELL_CHUNK]; 3],
            f1: [S::ZERO; CELL_CHUNK],
            f2: [S::ZERO; CELL_CHUNK],
            nearest: [[0; CELL_CHUNK]; 2],
        }
    }

    /// The first `m` lanes' cells and fractions, as the point function finds them, and no
    /// nearest point yet.
    #[inline(always)]
    fn locate(&mut self, p: [&[f64]; 3], m: usize) {
        let m = m.min(CELL_CHUNK);
        for (a, src) in p.into_iter().enumerate() {
            let src = &src[..m];
            for i in 0..m {
                self.frac[a][i] = lattice_lane_exact::<S>(src[i]).1;
                self.floor[a][i] = src[i].floor();
                self.index[a][i] = super::hash::cell_index(src[i]);
            }
        }
        // The lanes past `m` copy lane m - 1, so that every group has CELL_GROUP real lanes.
        if m > 0 {
            for a in 0..3 {
                let (index, floor, frac) = (
                    self.index[a][m - 1],
                    self.floor[a][m - 1],
                    self.frac[a][m - 1],
                );
                self.index[a][m..].fill(index);
                self.floor[a][m..].fill(floor);
                self.frac[a][m..].fill(frac);
            }
        }
        let infinity = S::from_f64(f64::INFINITY);
        self.f1 = [infinity; CELL_CHUNK];
        self.f2 = [infinity; CELL_CHUNK];
    }

    /// The 27-cell search of the group of lanes from `lo` when their cells lie close together
    /// (as they do in a bake, where neighbouring voxels share cells): the union of their
    /// neighbourhoods is visited once, each cell hashed once and its feature point broadcast to
    /// every lane, and a lane skips the cells outside its own 27 by an infinite offset (so an
    /// infinite distance, which no strict comparison takes). Each lane thus sees exactly its own
    /// 27 cells in the point function's order (the union's z, y, x order restricted to them)
    /// with its arithmetic, bit for bit. False, touching nothing, when a lane is not finite or
    /// the lanes lie too far apart (see [`CELL_SPAN`]). The lanes past a chunk's end copy its
    /// last lane (see [`CellLanes::locate`]), so the group is always full.
    #[inline(always)]
    fn coherent(
        &mut self,
        key: [u32; 2],
        jitter: f32,
        metric: super::cellular::Metric,
        lo: usize,
    ) -> bool {
        use super::hash;
        const G: usize = CELL_GROUP;
        const { assert!(CELL_CHUNK.is_multiple_of(G)) }; // so `lo + G <= CELL_CHUNK`
                                                         // Per axis: the union's first cell index and length, and each lane's offset to every
                                                         // union cell (infinite outside its neighbourhood).
        let mut base = [0i64; 3];
        let mut len = [0usize; 3];
        let mut offsets = [[[S::ZERO; G]; CELL_SPAN + 2]; 3];
        for a in 0..3 {
            let floor: &[f64; G] = self.floor[a][lo..lo + G].try_into().expect("G lanes");
            let Some((min, max)) = lane_bounds::<G>(floor) else {
                return false;
            };
            if !(min.is_finite() && max.is_finite()) {
                return false;
            }
            // Integers: the difference is exact when it is small.
            let span = max - min + 1.0;
            if span > CELL_SPAN as f64 {
                return false;
            }
            len[a] = span as usize + 2;
            // The union's first cell, min - 1, as the point function indexes it: a lane's own
            // index plus its offset (wrapping, as `floor as i64` saturates beyond 2^63).
            base[a] = self.index[a][lo]
                .wrapping_sub((floor[0] - min) as i64)
                .wrapping_sub(1);
            for u in 0..len[a] {
                for j in 0..G {
                    // The lane's offset to union cell u: u - 1 - (floor - min), exact.
                    let o = (u as f64 - 1.0) - (floor[j] - min);
                    offsets[a][u][j] = if o.abs() <= 1.0 {
                        S::from_f64(o)
                    } else {
                        S::from_f64(f64::INFINITY)
                    };
                }
            }
        }
        if len[0] * len[1] * len[2] > CELL_VISITS {
            return false;
        }
        let frac: [&[S; G]; 3] =
            std::array::from_fn(|a| self.frac[a][lo..lo + G].try_into().expect("G lanes"));
        let f1: &mut [S; G] = (&mut self.f1[lo..lo + G]).try_into().expect("G lanes");
        let f2: &mut [S; G] = (&mut self.f2[lo..lo + G]).try_into().expect("G lanes");
        let [na, nb] = &mut self.nearest;
        let na: &mut [u32; G] = (&mut na[lo..lo + G]).try_into().expect("G lanes");
        let nb: &mut [u32; G] = (&mut nb[lo..lo + G]).try_into().expect("G lanes");
        let at = |a: usize, u: usize| base[a].wrapping_add(u as i64);
        for uz in 0..len[2] {
            let sz = hash::absorb(key, at(2, uz));
            for uy in 0..len[1] {
                let syz = hash::absorb(sz, at(1, uy));
                for ux in 0..len[0] {
                    let [ha, hb] = hash::absorb(syz, at(0, ux));
                    let q = hash::feature([ha, hb], jitter).map(|v| S::from_f64(f64::from(v)));
                    let o = [&offsets[0][ux], &offsets[1][uy], &offsets[2][uz]];
                    for j in 0..G {
                        let d: [S; 3] = std::array::from_fn(|a| o[a][j] + q[a] - frac[a][j]);
                        let dist = super::cellular::distance(metric, d);
                        let best = (f1[j], f2[j], na[j], nb[j]);
                        (f1[j], f2[j], na[j], nb[j]) = nearer(best, dist, (ha, hb));
                    }
                }
            }
        }
        #[cfg(test)]
        COHERENT_GROUPS.with(|n| n.set(n.get() + 1));
        true
    }

    /// Lanes `lo..hi`'s 27-cell search, each lane's cells hashed over the lanes: the hash of the
    /// 27 cells with its inner steps shared (3 z steps, 9 (y, z), 27 cells), the feature
    /// points, distances and branch-free minimum updates in the point function's scan order and
    /// with its comparisons.
    #[inline(always)]
    fn gathered(
        &mut self,
        key: [u32; 2],
        jitter: f32,
        metric: super::cellular::Metric,
        lo: usize,
        hi: usize,
    ) {
        use super::hash;
        const N: usize = CELL_CHUNK;
        let hi = hi.min(N);
        let index = &self.index;
        for dz in -1..=1i64 {
            let mut sz = [[0u32; 2]; N];
            for i in lo..hi {
                sz[i] = hash::absorb(key, index[2][i].wrapping_add(dz));
            }
            for dy in -1..=1i64 {
                let mut syz = [[0u32; 2]; N];
                for i in lo..hi {
                    syz[i] = hash::absorb(sz[i], index[1][i].wrapping_add(dy));
                }
                for dx in -1..=1i64 {
                    let offset = [dx, dy, dz].map(|v| S::from_f64(v as f64));
                    for i in lo..hi {
                        let h = hash::absorb(syz[i], index[0][i].wrapping_add(dx));
                        let q = hash::feature(h, jitter).map(|v| S::from_f64(f64::from(v)));
                        let d: [S; 3] = std::array::from_fn(|a| offset[a] + q[a] - self.frac[a][i]);
                        let dist = super::cellular::distance(metric, d);
                        let best = (
                            self.f1[i],
                            self.f2[i],
                            self.nearest[0][i],
                            self.nearest[1][i],
                        );
                        (
                            self.f1[i],
                            self.f2[i],
                            self.nearest[0][i],
                            self.nearest[1][i],
                        ) = nearer(best, dist, (h[0], h[1]));
                    }
                }
            }
        }
    }
}

/// A chunk's lanes for [`simplex`]: where each lane lies (cell bytes, fractions in f64, the
/// skewed cell's carries, and its tetrahedron as masks of the skewed axes that come first and
/// second), one vertex's hash index bytes at a time, and each vertex's gradient bytes.
struct SimplexLanes<const N: usize = CHUNK> {
    cell: [[u8; N]; 3],
    /// Tiled: the whole cells of the reduced points (below the period) and twice each axis'
    /// period (0 for an untiled axis).
    whole: [[i32; N]; 3],
    twice_period: [i32; 3],
    frac: [[f64; N]; 3],
    /// The fractions rounded to f32, for the f32 terms (`simplex::offset`).
    frac32: [[f32; N]; 3],
    carry: [[u8; N]; 3],
    first: [[u8; N]; 3],
    second: [[u8; N]; 3],
    vertex: [[u8; N]; 3],
    grad: [[[u8; N]; 3]; 4],
}

#[allow(clippy::needless_range_loop)] // lanes indexed across parallel arrays, by design
impl SimplexLanes {
    #[inline(always)]
    fn new() -> Self {
        SimplexLanes {
            cell: [[0; CHUNK]; 3],
            whole: [[0; CHUNK]; 3],
            twice_period: [0; 3],
            frac: [[0.0; CHUNK]; 3],
            frac32: [[0.0; CHUNK]; 3],
            carry: [[0; CHUNK]; 3],
            first: [[0; CHUNK]; 3],
            second: [[0; CHUNK]; 3],
            vertex: [[0; CHUNK]; 3],
            grad: [[[0; CHUNK]; 3]; 4],
        }
    }

    /// Each lane's cell and tetrahedron, as the point function finds them (`FAST`: every
    /// coordinate below 2^51 in magnitude, the branch-free split of `lattice_lane_fast`). Two
    /// passes, so that LLVM vectorises them: the cells and fractions per axis, then the carries
    /// and the order of the skewed fractions.
    #[inline(always)]
    fn locate<const FAST: bool>(&mut self, p: [&[f64]; 3]) {
        const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52, see `lattice_lane_fast`
        for ((src, cell), frac) in p.into_iter().zip(&mut self.cell).zip(&mut self.frac) {
            for ((&x, cell), frac) in src.iter().zip(cell.iter_mut()).zip(frac.iter_mut()) {
                if FAST {
                    let c = x.floor();
                    (*cell, *frac) = ((c + MAGIC).to_bits() as u8, x - c);
                } else {
                    let (c, f) = super::lattice::lattice(x);
                    (*cell, *frac) = (c as u8, f);
                }
            }
        }
        for (f, f32s) in self.frac.iter().zip(&mut self.frac32) {
            for (&f, f32s) in f.iter().zip(f32s.iter_mut()) {
                *f32s = f as f32;
            }
        }
        let f = &self.frac;
        // Every lane of the chunk, a constant count (see `sum`).
        for i in 0..CHUNK {
            let sums = [f[1][i] + f[2][i], f[0][i] + f[2][i], f[0][i] + f[1][i]];
            let carry = sums.map(|s| s.floor());
            let skewed = [sums[0] - carry[0], sums[1] - carry[1], sums[2] - carry[2]];
            let (uv, vw, uw) = (
                skewed[0] >= skewed[1],
                skewed[1] >= skewed[2],
                skewed[0] >= skewed[2],
            );
            // `simplex::order` as masks: the first axis, then the second of the other two.
            let first = [uv & uw, !uv & vw, !(uv & uw) & !(!uv & vw)];
            let second = [
                !first[0] & ((first[1] & uw) | (first[2] & uv)),
                !first[1] & ((first[0] & vw) | (first[2] & !uv)),
                !first[2] & ((first[0] & !vw) | (first[1] & !uw)),
            ];
            for a in 0..3 {
                // A NaN sum (non-finite input) gives carry 0, as `locate_parts`. A fraction
                // is 1.0 where a tiny negative coordinate's `x - floor(x)` rounds up, so a
                // sum of two reaches 2.0: carry 2 (a carry of 1 there, found by the random-graph
                // test in CI, put the lane in the wrong tetrahedron).
                self.carry[a][i] = u8::from(carry[a] >= 1.0) + u8::from(carry[a] >= 2.0);
                self.first[a][i] = u8::from(first[a]);
                self.second[a][i] = u8::from(second[a]);
            }
        }
    }

    /// Tiled: each lane's point reduced into the period (`period::reduce3`'s numbers) into
    /// `reduced`, and on each tiled axis its whole cell (at most the period). Per axis over the
    /// lanes, branch-free (`reduce_fast`) where every coordinate is below 2^51.
    #[inline(always)]
    fn reduce(&mut self, reduced: &mut [[f64; CHUNK]; 3], p: [&[f64]; 3], period: Period) {
        use super::period;
        let n = p[0].len().min(CHUNK);
        let fast = fits(p, 1.0);
        for a in 0..3 {
            let (src, dst, whole) = (&p[a][..n], &mut reduced[a][..n], &mut self.whole[a][..n]);
            let pa = period[a];
            if pa == 0 || pa > 1 << 20 {
                dst.copy_from_slice(src);
            } else if fast {
                const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52: m's bits, as `locate`
                let (pf, inverse) = (pa as f64, 1.0 / pa as f64);
                for ((&x, q), w) in src.iter().zip(dst.iter_mut()).zip(whole.iter_mut()) {
                    let (r, _) = period::reduce_fast(x, pf, inverse);
                    // The reduced point's whole cell, `floor(r)` as the point function takes
                    // it: m, or m + 1 = P where a fraction rounded to 1.0 (see `locate`). An
                    // integer in [0, 2^20]: its low bits after adding 1.5 · 2^52 (no saturating
                    // conversion).
                    (*q, *w) = (r, (r.floor() + MAGIC).to_bits() as i32);
                }
            } else {
                for ((&x, q), w) in src.iter().zip(dst.iter_mut()).zip(whole.iter_mut()) {
                    // A non-finite x keeps its value (the lane is NaN); its cell is unused.
                    let (r, _) = period::reduce(x, pa);
                    (*q, *w) = (r, r.floor() as i32);
                }
            }
        }
        // An untiled axis is taken mod 512 (its whole cell is its cell byte, see
        // `untiled_cells`): the hash reads the doubled coordinates mod 512 anyway.
        self.twice_period = period.map(|p| if p == 0 { 512 } else { 2 * p as i32 });
    }

    /// Tiled: each untiled axis' whole cells are its cell bytes (after [`SimplexLanes::locate`]),
    /// so that [`SimplexLanes::tiled_vertices`] treats every axis alike.
    #[inline(always)]
    fn untiled_cells(&mut self, period: Period, n: usize) {
        for a in 0..3 {
            if period[a] == 0 {
                let (whole, cell) = (&mut self.whole[a][..n], &self.cell[a][..n]);
                for (w, &c) in whole.iter_mut().zip(cell) {
                    *w = i32::from(c);
                }
            }
        }
    }

    /// Vertex `K`'s skewed offset plus carry on skewed axis `a` of lane `i`, a small integer.
    #[inline(always)]
    fn skewed<const K: usize>(&self, a: usize, i: usize) -> u8 {
        let o = match K {
            0 => 0,
            1 => self.first[a][i],
            2 => self.first[a][i] + self.second[a][i],
            _ => 1,
        };
        self.carry[a][i] + o
    }

    /// Vertex `K`'s gradient bytes for the first `n` lanes: its hash index bytes (the skewed
    /// coordinates mod 256: `cell_y + cell_z + s_u`, `cell_x + cell_z + s_v`,
    /// `cell_x + cell_y + s_w`, `simplex::vertex_hash`'s), then its hash's gradient (by byte
    /// shuffles when `shuffle`, see [`SimplexLanes::shuffle_gradients`]; else by table reads).
    #[inline(always)]
    fn gradients<const K: usize>(
        &mut self,
        perm: &[u8; 512],
        signs: &[[u8; 256]; 3],
        n: usize,
        (shuffle, tiled): (bool, bool),
    ) {
        let n = n.min(CHUNK);
        if tiled {
            self.tiled_vertices::<K>();
        } else {
            // Every lane of the chunk, a constant count (see `sum`).
            for i in 0..CHUNK {
                let c = [self.cell[0][i], self.cell[1][i], self.cell[2][i]];
                let s = [
                    self.skewed::<K>(0, i),
                    self.skewed::<K>(1, i),
                    self.skewed::<K>(2, i),
                ];
                self.vertex[0][i] = c[1].wrapping_add(c[2]).wrapping_add(s[0]);
                self.vertex[1][i] = c[0].wrapping_add(c[2]).wrapping_add(s[1]);
                self.vertex[2][i] = c[0].wrapping_add(c[1]).wrapping_add(s[2]);
            }
        }
        if shuffle {
            // SAFETY: `shuffle` is true only in the clone compiled for avx512vbmi (see
            // `simplex`).
            unsafe { self.shuffle_gradients::<K>(perm, signs, n) };
        } else {
            let v = &self.vertex;
            for i in 0..n {
                let pz = perm[usize::from(v[2][i])];
                let py = perm[usize::from(v[1][i].wrapping_add(pz))];
                let j = usize::from(v[0][i].wrapping_add(py));
                for a in 0..3 {
                    self.grad[K][a][i] = signs[a][j];
                }
            }
        }
    }

    /// Tiled: vertex `K`'s hash index bytes from its doubled coordinates, each tiled axis' taken
    /// mod twice the period (`simplex::reach_periodic`: `2 cell + half` lies in
    /// [-3, 2P + 6], reduced by a fixed count of conditional steps, branch-free), an
    /// untiled axis' from its cell byte, mod 512 the same way (the same bytes: the hash reads
    /// the sums mod 512); then the skewed coordinates mod 256 as `simplex::vertex_hash` forms
    /// them.
    #[inline(always)]
    fn tiled_vertices<const K: usize>(&mut self) {
        let tp = self.twice_period;
        // Every lane of the chunk, a constant count (see `sum`).
        for i in 0..CHUNK {
            let s: [i32; 3] = std::array::from_fn(|a| i32::from(self.skewed::<K>(a, i)));
            let half = [-s[0] + s[1] + s[2], s[0] - s[1] + s[2], s[0] + s[1] - s[2]];
            let twice: [i32; 3] = std::array::from_fn(|a| {
                // In [-3, 2P + 6] (a whole cell in [0, P], carries up to 2, so half in
                // [-3, 6]), P >= 1: two additions and four subtractions of 2P at most,
                // branch-free.
                let mut t = 2 * self.whole[a][i] + half[a];
                for _ in 0..2 {
                    t += if t < 0 { tp[a] } else { 0 };
                }
                for _ in 0..4 {
                    t -= if t >= tp[a] { tp[a] } else { 0 };
                }
                t
            });
            self.vertex[0][i] = (((twice[1] + twice[2]) & 511) >> 1) as u8;
            self.vertex[1][i] = (((twice[0] + twice[2]) & 511) >> 1) as u8;
            self.vertex[2][i] = (((twice[0] + twice[1]) & 511) >> 1) as u8;
        }
    }

    /// Vertex `K`'s term at lane `i`, in S: its offset `frac - half / 2` in S from the fraction
    /// rounded to S (`simplex::offset`; in f32 from `frac32`, so the lane loop touches no f64
    /// and runs on 16 lanes with AVX-512) and its gradient.
    #[inline(always)]
    fn term<S: Real, const K: usize>(&self, i: usize) -> S {
        let s: [i32; 3] = std::array::from_fn(|a| i32::from(self.skewed::<K>(a, i)));
        let half = [-s[0] + s[1] + s[2], s[0] - s[1] + s[2], s[0] + s[1] - s[2]];
        let d: [S; 3] = std::array::from_fn(|a| {
            let f = if S::MANTISSA_BITS == 24 {
                S::from_f64(f64::from(self.frac32[a][i]))
            } else {
                S::from_f64(self.frac[a][i])
            };
            f - S::from_f64(f64::from(half[a]) * 0.5)
        });
        let grad = &self.grad[K];
        let g: [S; 3] = std::array::from_fn(|a| S::from_f64(f64::from(grad[a][i] as i8)));
        super::simplex::term(d, g)
    }

    /// The noise of the first `out.len()` lanes: the four terms summed in the point function's
    /// order, in one pass over the lanes.
    #[inline(always)]
    fn sum<S: Real>(&self, out: &mut [S]) {
        use super::simplex as sx;
        let n = out.len().min(CHUNK);
        // Summed into a stack array, then copied: writing `out` in the loop made LLVM check it
        // against the lane arrays at run time and take a scalar loop.
        let mut sums = [S::ZERO; CHUNK];
        // Over every lane of the chunk, a constant count (the lanes past n hold the last
        // chunk's or zeroed numbers, computed and dropped): over `0..n` LLVM kept a scalar
        // epilogue of a whole vector (16 of 256 lanes, 14% of the run time).
        for i in 0..CHUNK {
            let mut sum = S::ZERO;
            sum = sum + self.term::<S, 0>(i);
            sum = sum + self.term::<S, 1>(i);
            sum = sum + self.term::<S, 2>(i);
            sum = sum + self.term::<S, 3>(i);
            sums[i] = canonical_nan(S::from_f64(sx::SCALE) * sum);
        }
        out.copy_from_slice(&sums[..n]);
    }

    /// The gradient bytes of `self.vertex`'s first `n` lanes by byte shuffles (`vbmi.rs`).
    ///
    /// # Safety
    /// The CPU must support avx512f, avx512bw and avx512vbmi.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn shuffle_gradients<const K: usize>(
        &mut self,
        perm: &[u8; 512],
        signs: &[[u8; 256]; 3],
        n: usize,
    ) {
        // SAFETY: the caller guarantees the target features.
        unsafe { super::vbmi::simplex_gradients(perm, signs, &self.vertex, n, &mut self.grad[K]) }
    }

    /// Never called: no CPU of this architecture has AVX-512 VBMI.
    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    unsafe fn shuffle_gradients<const K: usize>(
        &mut self,
        _: &[u8; 512],
        _: &[[u8; 256]; 3],
        _: usize,
    ) {
        unreachable!("AVX-512 VBMI on a non-x86-64 target")
    }
}

simd_targets! {
/// Simplex noise over a batch, `out[i]` = the point function bit for bit, in loops over the
/// lanes of each chunk: locate (f64, per lane, the point function's arithmetic and comparisons;
/// the tetrahedron kept as masks, so the four vertex offsets are arithmetic, not table reads),
/// then per vertex in the point function's order its hash index bytes and its gradient (byte
/// shuffles with AVX-512 VBMI: the permutation's three steps and a last lookup straight into
/// the gradient components), and the four terms in S.
pub(super) fn simplex<S: Real>(
    perm: &[u8; 512],
    signs: &[[u8; 256]; 3],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    use super::simplex as sx;
    if !target_cfg_f!(target_feature = "sse4.1") {
        return reference_batch(|p| sx::sample(perm, p), x, y, z, out);
    }
    let shuffle = target_cfg_f!(target_feature = "avx512vbmi") && !table_reads_forced();
    simplex_chunks(perm, signs, [x, y, z], out, shuffle, None);
}
}

simd_targets! {
/// Tiled simplex noise over a batch, `out[i]` = `simplex::sample_periodic` bit for bit: the
/// points reduced into the period per lane, then [`simplex`]'s passes with each vertex's hash
/// bytes from its doubled coordinates mod twice the period (periods up to 2^20 on every axis,
/// 0 for an untiled one; beyond, the point function per lane).
pub(super) fn simplex_periodic<S: Real>(
    perm: &[u8; 512],
    signs: &[[u8; 256]; 3],
    period: Period,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    use super::simplex as sx;
    let supported = period.iter().all(|&p| p <= 1 << 20);
    if !target_cfg_f!(target_feature = "sse4.1") || !supported {
        return reference_batch(|p| sx::sample_periodic(perm, p, period), x, y, z, out);
    }
    let shuffle = target_cfg_f!(target_feature = "avx512vbmi") && !table_reads_forced();
    simplex_chunks(perm, signs, [x, y, z], out, shuffle, Some(period));
}
}

/// [`simplex_chunks`]'s lanes and reduced points, kept per thread: a fresh 20 kB of zeroed
/// arrays per call of 256 points cost as much as a fifth of the kernel.
struct SimplexScratch {
    lanes: SimplexLanes,
    reduced: [[f64; CHUNK]; 3],
}

thread_local! {
    /// Taken out for a call and put back after it (no closure around the kernel: a closure
    /// would not get the multiversioned function's target features).
    static SIMPLEX_SCRATCH: std::cell::Cell<Option<Box<SimplexScratch>>> =
        const { std::cell::Cell::new(None) };
}

/// [`simplex`]'s and [`simplex_periodic`]'s chunk loop; `shuffle` picks the byte-shuffle
/// gradients (true only in the AVX-512 VBMI clone).
#[inline(always)]
fn simplex_chunks<S: Real>(
    perm: &[u8; 512],
    signs: &[[u8; 256]; 3],
    [x, y, z]: [&[f64]; 3],
    out: &mut [S],
    shuffle: bool,
    period: Option<Period>,
) {
    let mut scratch = SIMPLEX_SCRATCH.take().unwrap_or_else(|| {
        Box::new(SimplexScratch {
            lanes: SimplexLanes::new(),
            reduced: [[0.0; CHUNK]; 3],
        })
    });
    let SimplexScratch { lanes, reduced } = &mut *scratch;
    let chunks = out
        .chunks_mut(CHUNK)
        .zip(x.chunks(CHUNK).zip(y.chunks(CHUNK)).zip(z.chunks(CHUNK)));
    let how = (shuffle, period.is_some());
    for (out, ((x, y), z)) in chunks {
        let n = out.len();
        let p = match period {
            Some(period) => {
                lanes.reduce(reduced, [x, y, z], period);
                [&reduced[0][..n], &reduced[1][..n], &reduced[2][..n]]
            }
            None => [x, y, z],
        };
        // `fits` with f = 1 is |x| < 2^51 for every coordinate.
        if fits(p, 1.0) {
            lanes.locate::<true>(p);
        } else {
            lanes.locate::<false>(p);
        }
        if let Some(period) = period {
            lanes.untiled_cells(period, n);
        }
        lanes.gradients::<0>(perm, signs, n, how);
        lanes.gradients::<1>(perm, signs, n, how);
        lanes.gradients::<2>(perm, signs, n, how);
        lanes.gradients::<3>(perm, signs, n, how);
        lanes.sum(out);
    }
    SIMPLEX_SCRATCH.set(Some(scratch));
}

/// Which lanes of an axis whose scaled coordinates `x · f` all lie inside [0, P) sit in the
/// period's last cell (`wraps[i] = 1`), `cell` being their lattice cell bytes (the reduction is
/// the identity there, so the cell is the reduction's): by the bytes where P < 256, none where
/// P is a multiple of 256 (the hashes read cell indices mod 256, so the upper corner's index
/// P is cell 0's already), else by comparing the coordinates.
#[inline(always)]
fn inside_wraps(wraps: &mut [u8; CHUNK], cell: &[u8; CHUNK], src: &[f64], f: f64, p: u64) {
    if p < 256 {
        let top = (p - 1) as u8;
        for (w, &c) in wraps.iter_mut().zip(&cell[..src.len()]) {
            *w = u8::from(c == top);
        }
    } else if !p.is_multiple_of(256) {
        let top = p as f64 - 1.0;
        for (w, &x) in wraps.iter_mut().zip(src) {
            *w = u8::from(x * f >= top);
        }
    } else {
        wraps.fill(0);
    }
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

/// `out[i] = k.sample_periodic(p_i, period)` bit for bit (see [`periodic_octaves`]).
pub(super) fn periodic<S: Real, K: LatticeKernel>(
    k: &K,
    period: Period,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    if out.len() < SMALL || period.iter().any(|&p| p == 0 || p > 1 << 52) {
        return reference_batch(|p| k.sample_periodic(p, period), x, y, z, out);
    }
    periodic_octaves::<S, K, false, false>(k, &[1.0], &[1.0], &[period], x, y, z, out);
}

/// A tiled fractal sum, `out[i] = Σ_o amp_o · k.sample_periodic(p_i · freq_o, period_o)` (|·|
/// when `TURB`) in octave order from zero, bit for bit; `periods` holds each octave's period.
#[allow(clippy::too_many_arguments)]
pub(super) fn periodic_fractal<S: Real, K: LatticeKernel, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    periods: &[Period],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    let unusual = periods.iter().flatten().any(|&p| p == 0 || p > 1 << 52);
    if out.len() < SMALL || unusual {
        for (((o, &x), &y), &z) in out.iter_mut().zip(x).zip(y).zip(z) {
            let mut sum = S::ZERO;
            for ((&f, &a), &period) in freqs.iter().zip(amps).zip(periods) {
                let n: S = k.sample_periodic([x * f, y * f, z * f], period);
                sum = sum + S::from_f64(a) * if TURB { n.abs() } else { n };
            }
            *o = canonical_nan(sum);
        }
        return;
    }
    out.fill(S::ZERO);
    periodic_octaves::<S, K, true, TURB>(k, freqs, amps, periods, x, y, z, out);
    for o in out.iter_mut() {
        *o = canonical_nan(*o);
    }
}

simd_targets! {
/// The tiled lattice kernels, per chunk and octave: the scaled points reduced into the
/// octave's period (branch-free while every coordinate stays below 2^51, else per lane, both
/// exactly `period::reduce`), the lattice step on the reduced points, the corner hashes
/// gathered as for plain noise, then, for the lanes in a period's last cell, the general
/// corner hashes with the upper corner wrapped to cell 0, and the interior over all lanes
/// (stored, or accumulated as `out + amp · n` when `ACC`).
#[allow(clippy::too_many_arguments)]
fn periodic_octaves<S: Real, K: LatticeKernel, const ACC: bool, const TURB: bool>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    periods: &[Period],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    use super::period;
    const WIDE: bool = !target_cfg_f!(target_feature = "avx512bw"); // see `sample_lanes`
    let mut lattice = Lattice::<S>::new();
    let shuffle = target_cfg_f!(target_feature = "avx512vbmi") && !table_reads_forced();
    // Per axis, which lanes sit in the period's last cell (1), and each axis's upper corners.
    let mut wraps = [[0u8; CHUNK]; 3];
    let mut hi = [[0u8; CHUNK]; 3];
    let chunks = out.chunks_mut(CHUNK).zip(x.chunks(CHUNK).zip(y.chunks(CHUNK)).zip(z.chunks(CHUNK)));
    for (out, ((x, y), z)) in chunks {
        let m = out.len().min(CHUNK); // bounded: no lane index needs a check (see `Lattice::noise`)
        let bounds = [x, y, z].map(lane_bounds::<32>);
        // The largest |coordinate| of the chunk (NaN when one is NaN, failing every test).
        let magnitude = if bounds.iter().all(Option::is_some) {
            let ends = bounds.iter().flatten();
            ends.fold(0.0f64, |m, &(lo, hi)| m.max(lo.abs()).max(hi.abs()))
        } else {
            f64::NAN
        };
        for ((&f, &amp), &period) in freqs.iter().zip(amps).zip(periods) {
            // Every scaled coordinate, and so every reduced one, below 2^51 (the periods too):
            // `fits` on the chunk's largest magnitude (rounding is monotone).
            let fast = magnitude * f.abs() < TWO51 && period.iter().all(|&p| (p as f64) < TWO51);
            for (a, src) in [x, y, z].into_iter().enumerate() {
                let p = period[a];
                // Every scaled coordinate of the axis already inside [0, P) (baking one tile,
                // what tiling is for): the reduction is the identity there (`period::reduce`
                // gives `c + (x - c)`, exactly x), so only the lattice step runs.
                if fast && scaled_inside(bounds[a], f, p as f64) {
                    lattice.fill_axis(a, f, src);
                    inside_wraps(&mut wraps[a], &lattice.cell[a], src, f, p);
                } else {
                    // The reduction's cell index per lane (made here: zeroing it and `reduced`
                    // once per call cost the one-tile bench, which never needs them, 3 %).
                    let mut last = [0.0f64; CHUNK];
                    if fast {
                        // The fast reduction vectorises, and goes on to the lattice step in the
                        // same pass (a reduced coordinate is in [0, P), below 2^51 here, where
                        // `lattice_lane_fast` is exact).
                        let (pf, inverse) = (p as f64, 1.0 / p as f64);
                        for i in 0..m {
                            let (r, c) = period::reduce_fast(src[i] * f, pf, inverse);
                            last[i] = c;
                            (lattice.cell[a][i], lattice.frac[a][i]) = lattice_lane_fast::<S>(r);
                        }
                    } else {
                        let mut reduced = [0.0f64; CHUNK];
                        for i in 0..m {
                            let (r, c) = period::reduce(src[i] * f, p);
                            reduced[i] = r;
                            last[i] = if c == u64::MAX { -1.0 } else { c as f64 };
                        }
                        let r = &reduced[..m];
                        lattice.fill_axis_exact(a, fits([r, r, r], 1.0), r);
                    }
                    // The reduction's cell index, not the lattice step's: a reduced coordinate
                    // can round up into the next cell (the point function decides the same way).
                    let top = p as f64 - 1.0;
                    for (w, &l) in wraps[a].iter_mut().zip(&last[..m]) {
                        *w = u8::from(l == top);
                    }
                }
            }
            let any = wraps.iter().flat_map(|w| &w[..m]).fold(0u8, |acc, &w| acc | w);
            if shuffle && any == 0 {
                // SAFETY: `shuffle` is true only in the clone compiled for avx512vbmi (which
                // implies avx512f and avx512bw), which the dispatcher runs only on CPUs that
                // have it.
                unsafe { lattice.shuffle_hashes(k, m) };
            } else if shuffle {
                // Each axis's upper corner: cell 0 in a period's last cell, else the next one;
                // then every lane's hashes by byte shuffles.
                for a in 0..3 {
                    let (cell, wraps) = (&lattice.cell[a][..m], &wraps[a][..m]);
                    for ((h, &c), &w) in hi[a].iter_mut().zip(cell).zip(wraps) {
                        *h = if w != 0 { 0 } else { c.wrapping_add(1) };
                    }
                }
                // SAFETY: as above.
                unsafe { lattice.shuffle_hashes_wrapped(k, &hi, m) };
            } else {
                lattice.wrapped_hashes(k, &wraps, any != 0, m);
            }
            lattice.noise_hashed::<K, ACC, TURB, WIDE>(k, S::from_f64(amp), out);
        }
    }
}
}
