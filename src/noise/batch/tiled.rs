//! The lattice bases' tiled kernels: the points reduced into each octave's period, the
//! corner hashes of the lanes in a period's last cell wrapped to cell 0.

use multiversion::target::target_cfg_f;

use super::lattice::Lattice;
use super::*;
use crate::noise::kernel::{reference_batch, LatticeKernel, NoiseKernel};
use crate::noise::lanes::{canonical_nan, CHUNK, SMALL};
use crate::noise::period::Period;
use crate::real::Real;

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

/// `out[i] = k.sample_periodic(p_i, period)` bit for bit (see [`periodic_octaves`]).
pub(crate) fn periodic<S: Real, K: LatticeKernel>(
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
pub(crate) fn periodic_fractal<S: Real, K: LatticeKernel, const TURB: bool>(
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
    use crate::noise::period;
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
