//! Lattice helpers shared by the bases: cell index and fraction, interpolation weights, and the
//! corner hashes of the seeded (Ebert-style) bases.

use crate::real::Real;

/// 2^52: every f64 at least this large in magnitude is an integer.
const TWO52: f64 = 4_503_599_627_370_496.0;

/// `f64::floor`, bit for bit (including `floor(-0.0) == -0.0`, NaN and ±inf), without the libm
/// call that `f64::floor` becomes on baseline x86-64 (no SSE4.1 `roundsd`): it runs six times per
/// sample on the hot path.
#[inline(always)]
pub(super) fn floor_f64(x: f64) -> f64 {
    if x.abs() < TWO52 {
        // |x| < 2^52: the i64 truncation is exact and cannot saturate; no integer arithmetic
        // follows it, so nothing can overflow.
        let t = (x as i64) as f64;
        let f = if t > x { t - 1.0 } else { t };
        // The only sign the truncation loses is that of -0.0 (and of (-1, 0), where f is -1).
        f.copysign(x)
    } else {
        // Already an integer, or NaN / ±inf, which floor returns unchanged.
        x
    }
}

/// Splits one coordinate into its lattice cell index mod 256 and its fraction within the cell.
///
/// `c = floor(x)`, then `m = c - 256 * floor(c / 256)`, which is exact in f64 for every finite
/// `c` (for |c| >= 2^61, c / 256 is an integer and m = 0; below that the subtraction is exact by
/// Sterbenz's lemma or because both operands are integers below 2^53), so coordinates up to
/// f64::MAX keep their true cell without ever converting a huge float to an integer type and
/// doing integer arithmetic on it. The fraction `x - c` is in [0, 1] (1 only by rounding, for
/// tiny negative x), NaN for non-finite x (inf - inf); then `m` is NaN and `as usize` gives 0,
/// so non-finite input indexes the table harmlessly and the NaN fraction carries into the
/// result. The `& 255` is a no-op that lets the compiler drop bounds checks.
#[inline(always)]
pub(super) fn lattice(x: f64) -> (usize, f64) {
    let c = floor_f64(x);
    let m = c - 256.0 * floor_f64(c * (1.0 / 256.0));
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
