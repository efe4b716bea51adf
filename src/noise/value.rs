//! Value noise: a seeded table of values in [0, 1] at the lattice points (hashed exactly like the
//! Gradient basis), interpolated trilinearly, with linear or smoothstep weights.

use super::lattice::{corner_hashes, lattice, lerp, smoothstep, smoothstep_slope};
use super::rng::SplitMix64;
use crate::real::Real;

/// 256 values uniform in [0, 1), from SplitMix64 seeded with `seed`, stored rounded to f32 so the
/// f32 and f64 paths share one table exactly (rounding may give 1.0, hence "in [0, 1]").
pub(super) fn values(seed: u64) -> [f32; 256] {
    let mut rng = SplitMix64::new(seed);
    let mut table = [0.0f32; 256];
    for v in table.iter_mut() {
        *v = rng.next_f64() as f32;
    }
    table
}

/// One sample; `SMOOTH` picks the weights t (Linear) or t²(3 - 2t) (Smooth). The lerps are
/// `d0 + t (d1 - d0)`, x first, then y, then z.
#[inline(always)]
pub(super) fn sample<S: Real, const SMOOTH: bool>(
    perm: &[u8; 512],
    values: &[f32; 256],
    p: [f64; 3],
) -> S {
    let (ix, fx) = lattice(p[0]);
    let (iy, fy) = lattice(p[1]);
    let (iz, fz) = lattice(p[2]);
    let h = corner_hashes(perm, ix, iy, iz);
    let weight = |f: f64| {
        let t = S::from_f64(f);
        if SMOOTH {
            smoothstep(t)
        } else {
            t
        }
    };
    let (wx, wy, wz) = (weight(fx), weight(fy), weight(fz));
    // f32 -> f64 -> S is exact and, for S = f32, folds to nothing. `& 255`: see gradient.rs.
    let v = |i: usize| S::from_f64(values[h[i] & 255] as f64);
    let vy0 = lerp(wx, v(0), v(1));
    let vy1 = lerp(wx, v(2), v(3));
    let vz0 = lerp(wy, vy0, vy1);
    let vy0 = lerp(wx, v(4), v(5));
    let vy1 = lerp(wx, v(6), v(7));
    let vz1 = lerp(wy, vy0, vy1);
    lerp(wz, vz0, vz1)
}

/// [`sample`]'s arithmetic for the batch kernels, from the corner hashes (as from
/// [`corner_hashes`], e.g. by `corner_hashes_paired`) and the fractions (already in S): the same
/// operations in the same order.
#[inline(always)]
pub(super) fn interior<S: Real, const SMOOTH: bool>(
    values: &[f32; 256],
    h: [u8; 8],
    frac: [S; 3],
) -> S {
    let weight = |t: S| if SMOOTH { smoothstep(t) } else { t };
    let [wx, wy, wz] = frac.map(weight);
    let v = |i: usize| S::from_f64(values[h[i] as usize] as f64);
    let vy0 = lerp(wx, v(0), v(1));
    let vy1 = lerp(wx, v(2), v(3));
    let vz0 = lerp(wy, vy0, vy1);
    let vy0 = lerp(wx, v(4), v(5));
    let vy1 = lerp(wx, v(6), v(7));
    let vz1 = lerp(wy, vy0, vy1);
    lerp(wz, vz0, vz1)
}

/// White noise: a per-cell random value in [0, 1) from the full-width hash of the point's
/// integer cell (`hash.rs`: no period, 24 bits in f32 and 53 in f64), NaN for non-finite input.
#[inline(always)]
pub(super) fn white<S: Real>(key: [u32; 2], p: [f64; 3]) -> S {
    if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) {
        return S::NAN;
    }
    super::hash::value(super::hash::cell(key, p.map(super::hash::cell_index)))
}

/// [`interior`]'s value (its bits, when `VALUE`; else 0) and its gradient with respect to the
/// fractions (NaN not made canonical): the corner values are constants, so only the weights'
/// slopes remain (`lattice::blend_slopes`): 1 for Linear (inside the cell; on a
/// face, this cell's side), `6t(1 - t)` for Smooth.
#[inline(always)]
pub(super) fn interior_grad<S: Real, const SMOOTH: bool, const VALUE: bool>(
    values: &[f32; 256],
    h: [u8; 8],
    frac: [S; 3],
) -> (S, [S; 3]) {
    let value = if VALUE {
        interior::<S, SMOOTH>(values, h, frac)
    } else {
        S::ZERO
    };
    let weight = |t: S| if SMOOTH { smoothstep(t) } else { t };
    let slope = |t: S| if SMOOTH { smoothstep_slope(t) } else { S::ONE };
    let corners: [S; 8] = std::array::from_fn(|i| S::from_f64(values[h[i] as usize] as f64));
    let g = super::lattice::blend_slopes(corners, frac.map(weight), frac.map(slope));
    // Linear weights' slopes are the constant 1, so a NaN fraction would not reach its own
    // axis' component: make it NaN (as every other basis' components are then).
    let bad = frac[0].is_nan() | frac[1].is_nan() | frac[2].is_nan();
    (value, g.map(|c| if !SMOOTH && bad { S::NAN } else { c }))
}
