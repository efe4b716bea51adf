//! The lattice bases' SIMD kernels (Perlin, Gradient, Value): the chunk's working arrays
//! ([`Lattice`]: steps 1 to 3 of the module plan), and per batch the value, the fractal sum with
//! and without level of detail per lane, the gradient, the fused fbm gradient, and a point's
//! octaves as lanes.

use multiversion::target::target_cfg_f;

use super::*;
use crate::noise::kernel::{
    octaves_grad, reference_batch, reference_fractal, reference_grad_batch, LatticeKernel,
};
use crate::noise::lanes::{canonical_grad, canonical_nan, CHUNK, SMALL};
use crate::noise::octaves::{LaneOctaves, OctavePeriods};
use crate::real::Real;

/// Most octaves [`fractal_octave_lanes`] takes as lanes (the octave limit of graph files).
const OCTAVE_LANES: usize = 32;

/// `out[i] = k.eval(p_i)` bit for bit.
#[inline]
pub(crate) fn sample<S: Real, K: LatticeKernel>(
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
/// [`fractal`](crate::noise::fractal) does, bit for bit.
#[inline]
pub(crate) fn fractal<S: Real, K: LatticeKernel, const TURB: bool>(
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
pub(crate) struct Lattice<S, const N: usize = CHUNK> {
    pub(crate) cell: [[u8; N]; 3],
    pub(crate) frac: [[S; N]; 3],
    pub(crate) hashes: [[u8; N]; 8],
}

impl<S: Real, const N: usize> Lattice<S, N> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Lattice {
            cell: [[0; N]; 3],
            frac: [[S::ZERO; N]; 3],
            hashes: [[0; N]; 8],
        }
    }

    /// Step 1 for the lanes of `p` (at most [`CHUNK`]), scaled by `f` when `SCALE`; `fast`
    /// picks [`lattice_lane_fast`], which the caller has checked with [`fits`].
    #[inline(always)]
    pub(crate) fn fill<const SCALE: bool>(&mut self, fast: bool, f: f64, p: [&[f64]; 3]) {
        if fast {
            self.fill_with::<SCALE>(f, p, lattice_lane_fast);
        } else {
            self.fill_with::<SCALE>(f, p, lattice_lane_exact);
        }
    }

    #[inline(always)]
    pub(super) fn fill_with<const SCALE: bool>(
        &mut self,
        f: f64,
        p: [&[f64]; 3],
        lane: fn(f64) -> (u8, S),
    ) {
        for (a, src) in p.into_iter().enumerate() {
            self.fill_axis_with::<SCALE>(a, f, src, lane);
        }
    }

    /// Step 1 for axis `a` alone: `lane(x · f)` (`lane(x)` without `SCALE`) for each lane.
    #[inline(always)]
    pub(super) fn fill_axis_with<const SCALE: bool>(
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
    pub(crate) fn fill_axis(&mut self, a: usize, f: f64, src: &[f64]) {
        self.fill_axis_with::<true>(a, f, src, lattice_lane_fast::<S>);
    }

    /// Step 1 for one axis, unscaled; `fast` as for [`Lattice::fill`].
    #[inline(always)]
    pub(crate) fn fill_axis_exact(&mut self, a: usize, fast: bool, src: &[f64]) {
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
    pub(crate) fn noise<K: LatticeKernel, const ACC: bool, const TURB: bool, const WIDE: bool>(
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
    pub(crate) fn noise_hashed<
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
    pub(crate) fn noise_grad<
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
    pub(crate) fn fbm_grad<K: LatticeKernel, const HASHED: bool, const WIDE: bool>(
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
    pub(super) fn lane_hashes<K: LatticeKernel, const HASHED: bool>(
        &self,
        k: &K,
        i: usize,
    ) -> [u8; 8] {
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
    pub(super) fn lane_frac(&self, i: usize) -> [S; 3] {
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
    pub(super) unsafe fn shuffle_hashes<K: LatticeKernel>(&mut self, k: &K, n: usize) {
        // SAFETY: the caller guarantees the target features.
        unsafe {
            if K::PERLIN_HASH {
                crate::noise::vbmi::corner_hashes::<true>(
                    k.perm(),
                    &self.cell,
                    n,
                    &mut self.hashes,
                );
            } else {
                crate::noise::vbmi::corner_hashes::<false>(
                    k.perm(),
                    &self.cell,
                    n,
                    &mut self.hashes,
                );
            }
        }
    }

    /// Never called: no CPU of this architecture has AVX-512 VBMI.
    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    pub(super) unsafe fn shuffle_hashes<K: LatticeKernel>(&mut self, _: &K, _: usize) {
        unreachable!("AVX-512 VBMI on a non-x86-64 target")
    }

    /// [`Lattice::shuffle_hashes`] with each axis's upper corner index given (`hi`), for
    /// tiling (`vbmi::corner_hashes_wrapped`).
    ///
    /// # Safety
    /// The CPU must support avx512f, avx512bw and avx512vbmi.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(super) unsafe fn shuffle_hashes_wrapped<K: LatticeKernel>(
        &mut self,
        k: &K,
        hi: &[[u8; CHUNK]; 3],
        n: usize,
    ) {
        use crate::noise::vbmi::corner_hashes_wrapped;
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
    pub(super) unsafe fn shuffle_hashes_wrapped<K: LatticeKernel>(
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
    pub(super) fn wrapped_hashes<K: LatticeKernel>(
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
            let h = crate::noise::lattice::corner_hashes_wrapped(k.perm(), K::PERLIN_HASH, lo, hi);
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
pub(crate) fn fractal_lod<S: Real, K: LatticeKernel, const TURB: bool>(
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
pub(crate) fn grad<S: Real, K: LatticeKernel, const VALUE: bool>(
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
pub(crate) fn fbm_grad<S: Real, K: LatticeKernel>(
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
    use crate::noise::octaves::Style;
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
/// order, starting from zero, exactly as [`crate::noise::reference_fractal`] sums them; each term is the
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
