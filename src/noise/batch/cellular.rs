//! Cellular noise's lane kernel: the 27 nearest cells of every lane at once, coherent groups
//! of lanes visiting the union of their neighbourhoods.

use multiversion::target::target_cfg_f;

use super::*;
use crate::noise::kernel::reference_batch;
use crate::noise::lanes::canonical_nan;
use crate::real::Real;

/// Cellular noise over a batch, `out[i]` = `cellular::sample(p_i)` bit for bit: the 27 nearest
/// cells of every lane at once (the cell hash over lanes, distances, branch-free minimum updates
/// in the point function's scan order and with its comparisons), then per lane the ring test; a
/// lane that needs a further ring (rare), or whose point is not finite, runs the point function
/// instead.
pub(crate) fn cellular<S: Real>(
    key: [u32; 2],
    params: crate::noise::cellular::Cellular,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    use crate::noise::cellular::Metric;
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
    params: crate::noise::cellular::Cellular,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    use crate::noise::cellular::{self, CellularValue, Metric, Nearest};
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
                self.index[a][i] = crate::noise::hash::cell_index(src[i]);
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
        metric: crate::noise::cellular::Metric,
        lo: usize,
    ) -> bool {
        use crate::noise::hash;
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
                        let dist = crate::noise::cellular::distance(metric, d);
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
        metric: crate::noise::cellular::Metric,
        lo: usize,
        hi: usize,
    ) {
        use crate::noise::hash;
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
                        let dist = crate::noise::cellular::distance(metric, d);
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
