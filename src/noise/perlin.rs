//! Ken Perlin's improved noise (SIGGRAPH 2002; the Java reference `ImprovedNoise.java`).
//!
//! The operation order below is the reference's, expression for expression, so that with the
//! published permutation and `S = f64` the result equals the Java output bit for bit (pinned by
//! tests). Only the cell index differs in form: the reference's `(int)Math.floor(x) & 255` is
//! replaced by the exact, overflow-free [`lattice`], which agrees with it wherever the Java cast
//! does not overflow.

use super::lattice::{lattice, lerp};
use crate::real::Real;

/// The published permutation (`ImprovedNoise.java`, `permutation[]`), used for seed 0.
pub(super) const REFERENCE_PERMUTATION: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

/// The reference's `fade(t) = t^3 (t (6t - 15) + 10)`, in its association order.
#[inline(always)]
fn fade<S: Real>(t: S) -> S {
    t * t * t * (t * (t * S::from_f64(6.0) - S::from_f64(15.0)) + S::from_f64(10.0))
}

/// For each `hash & 15`: which of (x, y, z) is the reference's `u` (h < 8 ? x : y) and `v`
/// (h < 4 ? y : h == 12 || h == 14 ? x : z).
const GRAD_U: [u8; 16] = [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1];
const GRAD_V: [u8; 16] = [1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 0, 2, 0, 2];

/// The reference's `grad`: the low 4 hash bits pick one of 12 edge directions (4 repeated) and
/// the result is `±u ± v`, the same single addition as the reference, so that even the sign of
/// a zero matches. The choices are table lookups into small arrays rather than `if`s: on x86
/// a float select on an integer condition becomes a branch, and these branches are random.
#[inline(always)]
fn grad<S: Real>(hash: u8, x: S, y: S, z: S) -> S {
    let h = (hash & 15) as usize;
    let d = [x, y, z, z];
    let u = d[GRAD_U[h] as usize & 3];
    let v = d[GRAD_V[h] as usize & 3];
    let u = [u, -u][h & 1];
    let v = [v, -v][(h >> 1) & 1];
    u + v
}

/// One sample of improved noise; `p` is the permutation doubled to 512 entries.
#[inline(always)]
pub(super) fn sample<S: Real>(p: &[u8; 512], pos: [f64; 3]) -> S {
    let (xi, xf) = lattice(pos[0]);
    let (yi, yf) = lattice(pos[1]);
    let (zi, zf) = lattice(pos[2]);
    let x = S::from_f64(xf);
    let y = S::from_f64(yf);
    let z = S::from_f64(zf);
    let u = fade(x);
    let v = fade(y);
    let w = fade(z);
    // Every index below is at most 255 + 255 + 1 = 511 (the reason the table is doubled); the
    // masks only tell the optimizer so.
    let a = p[xi] as usize + yi;
    let aa = p[a & 511] as usize + zi;
    let ab = p[(a + 1) & 511] as usize + zi;
    let b = p[(xi + 1) & 511] as usize + yi;
    let ba = p[b & 511] as usize + zi;
    let bb = p[(b + 1) & 511] as usize + zi;
    let one = S::ONE;
    let (x1, y1, z1) = (x - one, y - one, z - one);
    lerp(
        w,
        lerp(
            v,
            lerp(u, grad(p[aa & 511], x, y, z), grad(p[ba & 511], x1, y, z)),
            lerp(u, grad(p[ab & 511], x, y1, z), grad(p[bb & 511], x1, y1, z)),
        ),
        lerp(
            v,
            lerp(
                u,
                grad(p[(aa + 1) & 511], x, y, z1),
                grad(p[(ba + 1) & 511], x1, y, z1),
            ),
            lerp(
                u,
                grad(p[(ab + 1) & 511], x, y1, z1),
                grad(p[(bb + 1) & 511], x1, y1, z1),
            ),
        ),
    )
}

/// [`grad`] for the batch kernels: the same choice of `u`, `v` and signs, as selects (blends
/// under SIMD) instead of table lookups, and the same single addition (`u + (-v)` written
/// `u - v`, which IEEE 754 defines to be the same), so the bits, down to the sign of a zero,
/// are the same.
///
/// With h = hash & 15, the reference's conditions are bit tests on the hash itself (one SIMD
/// test each): h < 8 is bit 3 clear, h < 4 is bits 2 and 3 clear, and h == 12 || h == 14 is
/// bits 3, 2, 0 equal to 1, 1, 0.
///
/// `H` is the integer type the bits are tested in (see `LatticeKernel::interior`'s `WIDE`).
#[inline(always)]
fn grad_select<S: Real, H>(hash: H, x: S, y: S, z: S) -> S
where
    H: Copy + From<u8> + PartialEq + std::ops::BitAnd<Output = H>,
{
    let bits = |mask: u8| hash & H::from(mask);
    let is = |mask: u8, value: u8| bits(mask) == H::from(value);
    let u = if is(8, 0) { x } else { y };
    let v = if is(12, 0) {
        y
    } else if is(13, 12) {
        x
    } else {
        z
    };
    let u = if is(1, 1) { -u } else { u };
    if is(2, 2) {
        u - v
    } else {
        u + v
    }
}

/// [`sample`]'s eight gradient hashes for the batch kernels, from the lattice step's cell indices
/// (mod 256), in corner order `[dx + 2 dy + 4 dz]`: p[AA], p[BA], p[AB], p[BB], then the same
/// plus one. They come from the paired table (`pairs[i] = p[i] | p[i + 1] << 8`): the reference
/// reads p at A and A + 1, B and B + 1, AA and AA + 1, and so on, always neighbours, so seven
/// 32-bit reads (SIMD gathers) give all fourteen (every index is at most 510, so the neighbour
/// is in the doubled table).
#[inline(always)]
pub(super) fn hashes_paired(pairs: &[i32; 512], cell: [i32; 3]) -> [u8; 8] {
    let [xi, yi, zi] = cell;
    let at = |i: i32| pairs[(i & 511) as usize];
    let px = at(xi); // p[xi], p[xi + 1]
    let a = (px & 255) + yi;
    let b = (px >> 8) + yi;
    let pa = at(a); // p[A], p[A + 1]
    let pb = at(b); // p[B], p[B + 1]
    let aa = at((pa & 255) + zi); // p[AA], p[AA + 1]
    let ab = at((pa >> 8) + zi); // p[AB], p[AB + 1]
    let ba = at((pb & 255) + zi); // p[BA], p[BA + 1]
    let bb = at((pb >> 8) + zi); // p[BB], p[BB + 1]
    [
        aa as u8,
        ba as u8,
        ab as u8,
        bb as u8,
        (aa >> 8) as u8,
        (ba >> 8) as u8,
        (ab >> 8) as u8,
        (bb >> 8) as u8,
    ]
}

/// [`sample`]'s arithmetic for the batch kernels, from the corner hashes (as from
/// [`hashes_paired`]) and the fractions (already in S): the reference's, expression for
/// expression.
#[inline(always)]
pub(super) fn interior<S: Real, const WIDE: bool>(h: [u8; 8], frac: [S; 3]) -> S {
    let grad_select = |hash: u8, x: S, y: S, z: S| {
        if WIDE {
            grad_select(i32::from(hash), x, y, z)
        } else {
            grad_select(hash, x, y, z)
        }
    };
    let [x, y, z] = frac;
    let u = fade(x);
    let v = fade(y);
    let w = fade(z);
    let one = S::ONE;
    let (x1, y1, z1) = (x - one, y - one, z - one);
    lerp(
        w,
        lerp(
            v,
            lerp(u, grad_select(h[0], x, y, z), grad_select(h[1], x1, y, z)),
            lerp(u, grad_select(h[2], x, y1, z), grad_select(h[3], x1, y1, z)),
        ),
        lerp(
            v,
            lerp(u, grad_select(h[4], x, y, z1), grad_select(h[5], x1, y, z1)),
            lerp(
                u,
                grad_select(h[6], x, y1, z1),
                grad_select(h[7], x1, y1, z1),
            ),
        ),
    )
}

/// The slope of [`fade`], `30 t² (t - 1)²`, from t and `t - 1`.
#[inline(always)]
fn fade_slope<S: Real>(t: S, t1: S) -> S {
    let a = t * t1;
    S::from_f64(30.0) * (a * a)
}

/// [`interior`]'s value (its bits, when `VALUE`; else 0) and its gradient with respect to the
/// fractions (NaN not made canonical): the product rule on the trilinear blend (see
/// `lattice::blend_slopes`). Each corner's `grad` is `±u ± v` with u and v two of the
/// offset's components, so its gradient has ±1 on those two axes: the corner gradients' blend
/// is `Σ_c ±W_c` per axis, the trilinear weights signed and routed by the same hash bit tests as
/// [`grad_select`] (selects, no table reads, straight lane code).
#[inline(always)]
pub(super) fn interior_grad<S: Real, const WIDE: bool, const VALUE: bool>(
    h: [u8; 8],
    frac: [S; 3],
) -> (S, [S; 3]) {
    let value = if VALUE {
        interior::<S, WIDE>(h, frac)
    } else {
        S::ZERO
    };
    let grad_select = |hash: u8, x: S, y: S, z: S| {
        if WIDE {
            grad_select(i32::from(hash), x, y, z)
        } else {
            grad_select(hash, x, y, z)
        }
    };
    let [x, y, z] = frac;
    let one = S::ONE;
    let (x1, y1, z1) = (x - one, y - one, z - one);
    let offsets = [
        [x, y, z],
        [x1, y, z],
        [x, y1, z],
        [x1, y1, z],
        [x, y, z1],
        [x1, y, z1],
        [x, y1, z1],
        [x1, y1, z1],
    ];
    let corners: [S; 8] = std::array::from_fn(|c| {
        let [a, b, d] = offsets[c];
        grad_select(h[c], a, b, d)
    });
    let s = [fade(x), fade(y), fade(z)];
    let ds = [fade_slope(x, x1), fade_slope(y, y1), fade_slope(z, z1)];
    let slopes = super::lattice::blend_slopes(corners, s, ds);
    let weights = super::lattice::corner_weights(s);
    let mut g = [S::ZERO; 3];
    for (&hash, &weight) in h.iter().zip(&weights) {
        let corner = if WIDE {
            grad_vector(i32::from(hash), weight)
        } else {
            grad_vector(hash, weight)
        };
        g = std::array::from_fn(|a| g[a] + corner[a]);
    }
    (value, std::array::from_fn(|a| g[a] + slopes[a]))
}

/// `weight` times the gradient of [`grad_select`]'s `±u ± v`: `±weight` on u's axis (x when
/// bit 3 is clear, else y) and on v's (y when bits 2 and 3 are clear, x when bits 3, 2, 0 are
/// 1, 1, 0, else z), the signs from bits 0 and 1; u's and v's axes always differ.
#[inline(always)]
fn grad_vector<S: Real, H>(hash: H, weight: S) -> [S; 3]
where
    H: Copy + From<u8> + PartialEq + std::ops::BitAnd<Output = H>,
{
    let bits = |mask: u8| hash & H::from(mask);
    let is = |mask: u8, value: u8| bits(mask) == H::from(value);
    let wu = if is(1, 1) { -weight } else { weight };
    let wv = if is(2, 2) { -weight } else { weight };
    let (u_x, v_y, v_x) = (is(8, 0), is(12, 0), is(13, 12));
    let v_z = !v_y & !v_x;
    // Flat selects against zero (masked moves over lanes); nested `if`s or `||` became
    // branches, and the lane loop then stayed scalar.
    let pick = |on: bool, w: S| if on { w } else { S::ZERO };
    [
        pick(u_x, wu) + pick(v_x, wv),
        pick(!u_x, wu) + pick(v_y, wv),
        pick(v_z, wv),
    ]
}
