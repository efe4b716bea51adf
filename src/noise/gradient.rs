//! Ebert's gradient noise (`gnoise`, Texturing & Modeling, ch. "Building procedural textures"):
//! a seeded table of unit vectors on the sphere, hashed per lattice point through a seeded
//! permutation, and smoothed trilinear interpolation of the eight corner dot products.

use super::lattice::{corner_hashes, lattice, lerp, smoothstep, smoothstep_slope};
use super::rng::SplitMix64;
use crate::real::Real;

/// 256 unit vectors uniformly distributed on the sphere, from SplitMix64 seeded with `seed`.
///
/// Per vector: z = 1 - 2u is uniform in (-1, 1]; the direction in the xy-plane is a uniform point
/// (a, b) of the unit disk by rejection (rejecting a² + b² > 1, and < 1e-12 so the normalisation
/// is well conditioned), scaled to radius r = sqrt(1 - z²). Archimedes' hat-box theorem makes
/// (uniform z, uniform angle) uniform on the sphere. Only IEEE-exact operations (+ - * / sqrt)
/// are used, unlike Ebert's `cos`/`sin` of a random angle, because libm's trigonometry may differ
/// between platforms and the tables must never change. Stored rounded to f32, so the f32 and f64
/// paths share one table exactly (see `NoiseTable`).
pub(super) fn unit_vectors(seed: u64) -> [[f32; 3]; 256] {
    let mut rng = SplitMix64::new(seed);
    let mut table = [[0.0f32; 3]; 256];
    for g in table.iter_mut() {
        let z = 1.0 - 2.0 * rng.next_f64();
        let (a, b, s) = loop {
            let a = rng.next_signed();
            let b = rng.next_signed();
            let s = a * a + b * b;
            if (1e-12..=1.0).contains(&s) {
                break (a, b, s);
            }
        };
        let len = s.sqrt();
        let r = (1.0 - z * z).sqrt();
        *g = [(r * a / len) as f32, (r * b / len) as f32, z as f32];
    }
    table
}

/// Ebert's `glattice`: the corner's gradient dotted with the offset from the corner.
#[inline(always)]
fn dot<S: Real>(g: &[f32; 3], fx: S, fy: S, fz: S) -> S {
    // f32 -> f64 -> S is exact and, for S = f32, folds to nothing.
    let [gx, gy, gz] = g.map(|c| S::from_f64(c as f64));
    gx * fx + gy * fy + gz * fz
}

/// One sample of Ebert's `gnoise`, in its order: x pairs first, then y, then z.
#[inline(always)]
pub(super) fn sample<S: Real>(perm: &[u8; 512], grads: &[[f32; 3]; 256], p: [f64; 3]) -> S {
    let (ix, fx) = lattice(p[0]);
    let (iy, fy) = lattice(p[1]);
    let (iz, fz) = lattice(p[2]);
    let h = corner_hashes(perm, ix, iy, iz);
    let (fx0, fy0, fz0) = (S::from_f64(fx), S::from_f64(fy), S::from_f64(fz));
    let (fx1, fy1, fz1) = (fx0 - S::ONE, fy0 - S::ONE, fz0 - S::ONE);
    let (wx, wy, wz) = (smoothstep(fx0), smoothstep(fy0), smoothstep(fz0));
    // Hash values are u8 widened, so `& 255` is a no-op the optimizer uses to drop bounds checks.
    let g = |i: usize| &grads[h[i] & 255];
    let vy0 = lerp(wx, dot(g(0), fx0, fy0, fz0), dot(g(1), fx1, fy0, fz0));
    let vy1 = lerp(wx, dot(g(2), fx0, fy1, fz0), dot(g(3), fx1, fy1, fz0));
    let vz0 = lerp(wy, vy0, vy1);
    let vy0 = lerp(wx, dot(g(4), fx0, fy0, fz1), dot(g(5), fx1, fy0, fz1));
    let vy1 = lerp(wx, dot(g(6), fx0, fy1, fz1), dot(g(7), fx1, fy1, fz1));
    let vz1 = lerp(wy, vy0, vy1);
    lerp(wz, vz0, vz1)
}

/// [`sample`]'s arithmetic for the batch kernels, from the corner hashes (as from
/// [`corner_hashes`], e.g. by `corner_hashes_paired`) and the fractions (already in S): the same
/// operations in the same order.
#[inline(always)]
pub(super) fn interior<S: Real>(grads: &[[f32; 3]; 256], h: [u8; 8], frac: [S; 3]) -> S {
    let [fx0, fy0, fz0] = frac;
    let (fx1, fy1, fz1) = (fx0 - S::ONE, fy0 - S::ONE, fz0 - S::ONE);
    let (wx, wy, wz) = (smoothstep(fx0), smoothstep(fy0), smoothstep(fz0));
    let g = |i: usize| &grads[h[i] as usize];
    let vy0 = lerp(wx, dot(g(0), fx0, fy0, fz0), dot(g(1), fx1, fy0, fz0));
    let vy1 = lerp(wx, dot(g(2), fx0, fy1, fz0), dot(g(3), fx1, fy1, fz0));
    let vz0 = lerp(wy, vy0, vy1);
    let vy0 = lerp(wx, dot(g(4), fx0, fy0, fz1), dot(g(5), fx1, fy0, fz1));
    let vy1 = lerp(wx, dot(g(6), fx0, fy1, fz1), dot(g(7), fx1, fy1, fz1));
    let vz1 = lerp(wy, vy0, vy1);
    lerp(wz, vz0, vz1)
}

/// [`interior`]'s value (its bits, when `VALUE`; else 0) and its gradient with respect to the
/// fractions (NaN not made canonical): the product rule on the trilinear blend (see
/// `lattice::blend_slopes`), each corner's dot product having the corner's unit vector as
/// its gradient (blended per component), the weights smoothstep's.
#[inline(always)]
pub(super) fn interior_grad<S: Real, const VALUE: bool>(
    grads: &[[f32; 3]; 256],
    h: [u8; 8],
    frac: [S; 3],
) -> (S, [S; 3]) {
    let value = if VALUE {
        interior(grads, h, frac)
    } else {
        S::ZERO
    };
    let [fx0, fy0, fz0] = frac;
    let (fx1, fy1, fz1) = (fx0 - S::ONE, fy0 - S::ONE, fz0 - S::ONE);
    let g = |i: usize| &grads[h[i] as usize];
    let offsets = [
        [fx0, fy0, fz0],
        [fx1, fy0, fz0],
        [fx0, fy1, fz0],
        [fx1, fy1, fz0],
        [fx0, fy0, fz1],
        [fx1, fy0, fz1],
        [fx0, fy1, fz1],
        [fx1, fy1, fz1],
    ];
    let corners: [S; 8] = std::array::from_fn(|c| {
        let [a, b, d] = offsets[c];
        dot(g(c), a, b, d)
    });
    let s = frac.map(smoothstep);
    let ds = frac.map(smoothstep_slope);
    let slopes = super::lattice::blend_slopes(corners, s, ds);
    let grad = std::array::from_fn(|a| {
        let component = std::array::from_fn(|c| S::from_f64(g(c)[a] as f64));
        super::lattice::trilerp(s, component) + slopes[a]
    });
    (value, grad)
}
