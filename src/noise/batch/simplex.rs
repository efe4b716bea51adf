//! Simplex noise's lane kernel (the body-centred cubic lattice), plain and tiled.

use multiversion::target::target_cfg_f;

use super::*;
use crate::noise::kernel::reference_batch;
use crate::noise::lanes::{canonical_nan, CHUNK};
use crate::noise::period::Period;
use crate::real::Real;

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
                    let (c, f) = crate::noise::lattice::lattice(x);
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
        use crate::noise::period;
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
        crate::noise::simplex::term(d, g)
    }

    /// The noise of the first `out.len()` lanes: the four terms summed in the point function's
    /// order, in one pass over the lanes.
    #[inline(always)]
    fn sum<S: Real>(&self, out: &mut [S]) {
        use crate::noise::simplex as sx;
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
        unsafe {
            crate::noise::vbmi::simplex_gradients(perm, signs, &self.vertex, n, &mut self.grad[K])
        }
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
pub(crate) fn simplex<S: Real>(
    perm: &[u8; 512],
    signs: &[[u8; 256]; 3],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    use crate::noise::simplex as sx;
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
pub(crate) fn simplex_periodic<S: Real>(
    perm: &[u8; 512],
    signs: &[[u8; 256]; 3],
    period: Period,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    use crate::noise::simplex as sx;
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
