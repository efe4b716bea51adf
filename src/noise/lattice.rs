//! Lattice helpers shared by the bases: cell index and fraction, interpolation weights, and the
//! corner hashes of the seeded (Ebert-style) bases.

use crate::real::Real;

/// 2^52: every f64 at least this large in magnitude is an integer.
pub(super) const TWO52: f64 = 4_503_599_627_370_496.0;

/// Splits one coordinate into its lattice cell index mod 256 and its fraction within the cell.
///
/// The contract: `c = floor(x)`, `m = c - 256 * floor(c / 256)` (exact in f64 for every finite
/// c), index `m as usize`, fraction `x - c`. This computes exactly the same index and fraction
/// (bit for bit; the tests compare it with the formula) without the six `floor` calls per
/// sample, which are libm calls on baseline x86-64 (no SSE4.1 `roundsd`): with them the Value
/// basis took twice as long, the others 40% longer.
///
/// - |x| < 2^52 (the hot path): the i64 truncation `t` is exact and cannot saturate, so
///   `i = t - (t > x)` is floor(x) as an integer with no possibility of overflow, and `i & 255`
///   is its residue mod 256 (two's complement). The copysign keeps `floor(-0.0) = -0.0`, so the
///   fraction is `+0.0` as with `f64::floor`.
/// - Otherwise x is already an integer (so the fraction is `x - x = 0`), or NaN / ±inf (so the
///   fraction is NaN): the contract's formula, which never converts a huge float to an integer
///   type before reducing it. For |x| >= 2^61, x / 256 is an integer and m = 0. For non-finite
///   x, m is NaN and `as usize` gives 0, so the table is indexed harmlessly and the NaN fraction
///   carries into the result.
///
/// The fraction is in [0, 1] (1 only by rounding, for tiny negative x). The `& 255`s let the
/// compiler drop bounds checks.
#[inline(always)]
pub(super) fn lattice(x: f64) -> (usize, f64) {
    if x.abs() < TWO52 {
        let t = x as i64;
        let i = t - ((t as f64) > x) as i64;
        let c = (i as f64).copysign(x);
        ((i & 255) as usize, x - c)
    } else {
        lattice_cold(x)
    }
}

/// [`lattice`] for |x| >= 2^52 and non-finite x, out of line to keep the hot loop small.
#[cold]
#[inline(never)]
fn lattice_cold(x: f64) -> (usize, f64) {
    let c = x.floor(); // x itself (or NaN for NaN)
    let m = c - 256.0 * (c / 256.0).floor();
    ((m as usize) & 255, x - c)
}

/// Linear interpolation in the form both the Perlin reference and Ebert's `LERP` use:
/// `a + t * (b - a)` (exactly `a` at t = 0, which lattice-point tests rely on).
#[inline(always)]
pub(super) fn lerp<S: Real>(t: S, a: S, b: S) -> S {
    a + t * (b - a)
}

/// Ebert's `SMOOTHSTEP(t) = t * t * (3 - 2 * t)` (weight of the Gradient and smooth Value bases).
#[inline(always)]
pub(super) fn smoothstep<S: Real>(t: S) -> S {
    let two = S::from_f64(2.0);
    let three = S::from_f64(3.0);
    t * t * (three - two * t)
}

/// The slope of [`smoothstep`], `6 t (1 - t)`.
#[inline(always)]
pub(super) fn smoothstep_slope<S: Real>(t: S) -> S {
    S::from_f64(6.0) * t * (S::ONE - t)
}

/// Ebert's lattice hashes of the 8 corners of the cell (ix, iy, iz), all already mod 256:
/// `INDEX(ix, iy, iz) = PERM(ix + PERM(iy + PERM(iz)))` with `PERM(i) = perm[i & 255]`.
/// `perm` is the 256-entry permutation doubled to 512, so a sum of two values <= 255 indexes it
/// directly; the `& 511` is a no-op for the optimizer. Element `[dx + 2 dy + 4 dz]` is the hash
/// of corner (ix + dx, iy + dy, iz + dz).
#[inline(always)]
pub(super) fn corner_hashes(perm: &[u8; 512], ix: usize, iy: usize, iz: usize) -> [usize; 8] {
    let ix1 = (ix + 1) & 255;
    let iy1 = (iy + 1) & 255;
    let iz1 = (iz + 1) & 255;
    let pz0 = perm[iz] as usize;
    let pz1 = perm[iz1] as usize;
    let p00 = perm[(iy + pz0) & 511] as usize;
    let p10 = perm[(iy1 + pz0) & 511] as usize;
    let p01 = perm[(iy + pz1) & 511] as usize;
    let p11 = perm[(iy1 + pz1) & 511] as usize;
    [
        perm[(ix + p00) & 511] as usize,
        perm[(ix1 + p00) & 511] as usize,
        perm[(ix + p10) & 511] as usize,
        perm[(ix1 + p10) & 511] as usize,
        perm[(ix + p01) & 511] as usize,
        perm[(ix1 + p01) & 511] as usize,
        perm[(ix + p11) & 511] as usize,
        perm[(ix1 + p11) & 511] as usize,
    ]
}

/// [`corner_hashes`] from the paired table (`pairs[i] = perm[i] | perm[i + 1] << 8`), for the
/// batch kernels: the same eight hashes in the same order, from seven 32-bit reads instead of
/// fourteen byte reads, with no branch, so a loop over lanes becomes seven SIMD gathers.
///
/// Why the pairs are the same numbers: `perm` is doubled, so for a value v <= 255 and an index
/// i <= 255, `perm[((i + 1) & 255) + v] == perm[i + 1 + v]` (the two indices differ by 0 or 256),
/// and i + 1 + v <= 511. So the x and y neighbours (`ix1`, `iy1`) of [`corner_hashes`] read the
/// entry after the one at `ix` / `iy`, i.e. the high byte of the same pair; likewise `iz1`. The
/// cell indices are <= 255 and every sum is <= 510, so the `& 511`s only tell the optimizer so.
#[inline(always)]
pub(super) fn corner_hashes_paired(pairs: &[i32; 512], cell: [i32; 3]) -> [u8; 8] {
    let [ix, iy, iz] = cell;
    let at = |i: i32| pairs[(i & 511) as usize];
    let pz = at(iz); // perm[iz], perm[iz1]
    let py0 = at(iy + (pz & 255)); // p00, p10
    let py1 = at(iy + (pz >> 8)); // p01, p11
    let h0 = at(ix + (py0 & 255)); // corners 0, 1
    let h2 = at(ix + (py0 >> 8)); // corners 2, 3
    let h4 = at(ix + (py1 & 255)); // corners 4, 5
    let h6 = at(ix + (py1 >> 8)); // corners 6, 7
    [
        h0 as u8,
        (h0 >> 8) as u8,
        h2 as u8,
        (h2 >> 8) as u8,
        h4 as u8,
        (h4 >> 8) as u8,
        h6 as u8,
        (h6 >> 8) as u8,
    ]
}

/// The eight corner hashes of a cell whose corner indices (each already mod 256) are given per
/// axis, `lo` and `hi`, in corner order `[dx + 2 dy + 4 dz]`: the general form of
/// [`corner_hashes`] (Ebert's order, z innermost) and of Perlin's (x innermost,
/// `p[p[p[x] + y] + z]`), for tiling, where the upper corner of a period's last cell wraps to
/// index 0 instead of following the lower one.
#[inline(always)]
pub(super) fn corner_hashes_wrapped(
    perm: &[u8; 512],
    perlin: bool,
    lo: [usize; 3],
    hi: [usize; 3],
) -> [u8; 8] {
    let at = |i: usize| perm[i & 511] as usize;
    std::array::from_fn(|corner| {
        let pick = |axis: usize| {
            if (corner >> axis) & 1 == 1 {
                hi[axis]
            } else {
                lo[axis]
            }
        };
        let (x, y, z) = (pick(0), pick(1), pick(2));
        if perlin {
            at(at(at(x) + y) + z) as u8
        } else {
            at(x + at(y + at(z))) as u8
        }
    })
}

/// The weight-slope part of the gradient of the trilinear blend every lattice basis evaluates,
/// `lerp(s_z, lerp(s_y, lerp(s_x, h0, h1), lerp(s_x, h2, h3)), lerp(s_y, lerp(s_x, h4, h5),
/// lerp(s_x, h6, h7)))` (corner `[dx + 2 dy + 4 dz]`), where the weight `s_a` depends on axis
/// a alone with slope `ds_a`. By the product rule through the lerps (`lerp(t, a, b) =
/// a + t (b - a)` has gradient `lerp(t, ∇a, ∇b) + (b - a) ∇t`), the blend's gradient is the
/// blend of the corners' gradients (`trilerp` of each component, or the same sum weighted
/// otherwise; 0 for value noise's constant corners) plus this:
///
/// - x: `ds_x · lerp(s_z, lerp(s_y, h1 - h0, h3 - h2), lerp(s_y, h5 - h4, h7 - h6))`;
/// - y: `ds_y · lerp(s_z, x23 - x01, x67 - x45)` with `x01` the x lerp of corners 0 and 1,
///   and so on;
/// - z: `ds_z · (y1 - y0)` with `y0`, `y1` the two y lerps.
#[inline(always)]
pub(super) fn blend_slopes<S: Real>(h: [S; 8], s: [S; 3], ds: [S; 3]) -> [S; 3] {
    let [u, v, w] = s;
    let x01 = lerp(u, h[0], h[1]);
    let x23 = lerp(u, h[2], h[3]);
    let x45 = lerp(u, h[4], h[5]);
    let x67 = lerp(u, h[6], h[7]);
    let y0 = lerp(v, x01, x23);
    let y1 = lerp(v, x45, x67);
    let dx = lerp(
        w,
        lerp(v, h[1] - h[0], h[3] - h[2]),
        lerp(v, h[5] - h[4], h[7] - h[6]),
    );
    [
        ds[0] * dx,
        ds[1] * lerp(w, x23 - x01, x67 - x45),
        ds[2] * (y1 - y0),
    ]
}

/// The trilinear blend of eight corner values in the lattice bases' lerp order.
#[inline(always)]
pub(super) fn trilerp<S: Real>([u, v, w]: [S; 3], h: [S; 8]) -> S {
    lerp(
        w,
        lerp(v, lerp(u, h[0], h[1]), lerp(u, h[2], h[3])),
        lerp(v, lerp(u, h[4], h[5]), lerp(u, h[6], h[7])),
    )
}

/// The eight trilinear weights `W_c` of the blend (`Σ_c W_c h_c` is [`trilerp`] in exact
/// arithmetic), corner `[dx + 2 dy + 4 dz]`.
#[inline(always)]
pub(super) fn corner_weights<S: Real>([u, v, w]: [S; 3]) -> [S; 8] {
    let one = S::ONE;
    let (u0, v0, w0) = (one - u, one - v, one - w);
    let yz = [v0 * w0, v * w0, v0 * w, v * w];
    std::array::from_fn(|c| {
        if c & 1 == 1 {
            u * yz[c >> 1]
        } else {
            u0 * yz[c >> 1]
        }
    })
}
