//! Simplex noise on the body-centred cubic (BCC) lattice: the lattice of OpenSimplex2 and of
//! Gustavson and McEwan's psrdnoise (Stefan Gustavson and Ian McEwan, "Tiling simplex noise and
//! flow noise in two and three dimensions", JCGT 11(1), 2022), which tiles at every integer
//! period where Gustavson's skewed grid tiles only at multiples of 3.
//!
//! The grid: the vertices are the points whose coordinates are all integers or all
//! half-integers, `V = M⁻¹ i` for integer `i`, with `M = [[0,1,1],[1,0,1],[1,1,0]]` (so
//! `i = M V = (Vy + Vz, Vx + Vz, Vx + Vy)`, the "skewed" coordinates u, v, w). Any integer
//! translation maps the grid onto itself, which is why every integer period works. The space is
//! cut into tetrahedra (the skewed unit cube of `M x` into six, by the order of the skewed
//! fractions), each with two vertices of the integer lattice and two of the half-integer one.
//!
//! Each vertex carries one of the 12 cube-edge gradients (Gustavson's `grad3`), picked by a
//! hash of its skewed coordinates mod 256, and contributes `(0.5 - r²)⁴ (g · d)` within radius
//! √0.5 (d the offset from the vertex, r = |d|); the sum is scaled by [`SCALE`]. Radius √0.5 is
//! the tetrahedra's smallest altitude (a vertex beyond a face is at least √0.5 from every point
//! of the face, and from every point of the tetrahedron: checked by the test
//! `simplex_matches_a_brute_force_sum_over_every_vertex`), so the four vertices of the point's
//! tetrahedron are every vertex in reach and the sum is continuous, in fact C³ (the kernel and
//! its first three derivatives vanish at r² = 0.5). It is exactly 0 on every vertex (a vertex's
//! own term is `g · 0`, and every other vertex is at least √0.75 away).
//!
//! Range ±1 and Lipschitz bound 12.5: proved by branch and bound in
//! `simplex_range_and_lipschitz_bounds_are_proved` (see [`SCALE`], [`LIPSCHITZ`]).
//!
//! Precision: the skewed cell is found from each coordinate's integer cell and fraction (exact
//! in f64 at any magnitude, as the lattice bases split them): `u = y + z` has the cell
//! `Y + Z + floor(fy + fz)` and the fraction `fy + fz - floor(fy + fz)`, so the offsets to the
//! vertices, `f - k/2` for small integers k, involve small numbers only, and the hash needs the
//! cells mod 256 only. The fractions are then rounded to the kernel's type once and the offsets
//! formed there ([`offset`]).
//!
//! Tiling: a vertex is hashed as its translate into the period box (each coordinate, in halves,
//! mod twice the period, which keeps it an integer or a half-integer), so a vertex and its
//! translates by whole periods share their gradient and `N(p + P eₐ) = N(p)` bit for bit for
//! every integer period P ≤ 2^20 (the point is reduced into its period first, as the other
//! bases do).

use super::lattice::lattice;
use super::period::{self, Period};
use crate::real::Real;

/// The 12 cube-edge gradients (Gustavson's `grad3`), picked by `hash % 12`.
pub(super) const GRADIENTS: [[f32; 3]; 12] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
];

/// The squared kernel radius: the tetrahedra's smallest altitude squared.
pub(super) const RADIUS2: f64 = 0.5;

/// The output scale. With every gradient chosen adversarially (each vertex's `|g · d|` at its
/// largest, the sum of d's two largest |components|), `Σ (0.5 - r²)⁴ |g · d|` is at most
/// 0.013008 (at about (0, 1/6, 1/6) and its images), so `76 ×` that, 0.98861, bounds |N|.
pub(super) const SCALE: f64 = 76.0;

/// Half-width of the range; see [`SCALE`].
pub(super) const RANGE: f64 = 1.0;

/// An upper bound on |∇N|: per vertex `|∇((0.5 - r²)⁴ g·d)| <= √2 (0.5 - r²)³ (0.5 + 7 r²)`
/// (|g| = √2, |g · d| <= √2 r); the test `simplex_range_and_lipschitz_bounds_are_proved` bounds
/// the sum of these over the vertices in reach by 12.5 / 76 everywhere (its maximum, at the
/// centre of the half-integer cube's corners, (1/4, 1/4, 1/4), is 0.15645), so |∇N| <= 12.5.
pub(super) const LIPSCHITZ: f64 = 12.5;

/// The vertices of a tetrahedron, by the order of the skewed fractions: `first` and `second`
/// are the axes (0 = u, 1 = v, 2 = w) of the largest and second largest, ties to the lower
/// axis. The vertices are, as offsets in skewed coordinates, `0`, `e_first`,
/// `e_first + e_second` and `(1, 1, 1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Order {
    pub first: usize,
    pub second: usize,
}

/// The order of skewed fractions `s` (ties to the lower axis; NaN compares false everywhere
/// and gives u, v).
#[inline(always)]
pub(super) fn order(s: [f64; 3]) -> Order {
    let (uv, vw, uw) = (s[0] >= s[1], s[1] >= s[2], s[0] >= s[2]);
    let first = if uv && uw {
        0
    } else if !uv && vw {
        1
    } else {
        2
    };
    let second = match first {
        0 => {
            if vw {
                1
            } else {
                2
            }
        }
        1 => {
            if uw {
                0
            } else {
                2
            }
        }
        _ => {
            if uv {
                0
            } else {
                1
            }
        }
    };
    Order { first, second }
}

/// Vertex `k`'s offset in skewed coordinates, 0 or 1 per skewed axis.
#[inline(always)]
pub(super) fn skewed_offset(order: Order, k: usize) -> [i64; 3] {
    let mut o = [0i64; 3];
    if k >= 1 {
        o[order.first] = 1;
    }
    if k >= 2 {
        o[order.second] = 1;
    }
    if k == 3 {
        o = [1; 3];
    }
    o
}

/// Where a point lies: its lattice cells mod 256 and fractions (as [`lattice`] splits them),
/// the carries `floor` of the skewed fraction sums `(fy + fz, fx + fz, fx + fy)`, and its
/// tetrahedron.
#[derive(Clone, Copy, Debug)]
pub(super) struct Located {
    pub cell: [usize; 3],
    pub frac: [f64; 3],
    pub carry: [i64; 3],
    pub order: Order,
}

/// Finds the skewed cell and tetrahedron of `p`.
#[inline(always)]
pub(super) fn locate(p: [f64; 3]) -> Located {
    let parts = p.map(lattice);
    locate_parts(parts.map(|c| c.0), parts.map(|c| c.1))
}

/// [`locate`] from each axis' cell residue and fraction.
#[inline(always)]
pub(super) fn locate_parts(cell: [usize; 3], f: [f64; 3]) -> Located {
    let sums = [f[1] + f[2], f[0] + f[2], f[0] + f[1]];
    let carry = sums.map(|s| s.floor());
    let skewed = [sums[0] - carry[0], sums[1] - carry[1], sums[2] - carry[2]];
    Located {
        cell,
        frac: f,
        // A NaN fraction (non-finite input) gives carry 0: the result is NaN anyway.
        carry: carry.map(|c| if c.is_nan() { 0 } else { c as i64 }),
        order: order(skewed),
    }
}

/// Twice vertex `k`'s offset from the point's lattice cell corner, per axis: the vertex is
/// `cell + half / 2` (`half` small integers, all even or all odd), from
/// `V = M⁻¹ (M cell + carry + o)` with `M⁻¹ = [[-1,1,1],[1,-1,1],[1,1,-1]] / 2`.
#[inline(always)]
pub(super) fn half_offset(carry: [i64; 3], o: [i64; 3]) -> [i64; 3] {
    let s = [carry[0] + o[0], carry[1] + o[1], carry[2] + o[2]];
    [-s[0] + s[1] + s[2], s[0] - s[1] + s[2], s[0] + s[1] - s[2]]
}

/// The hash of a vertex from its doubled coordinates mod 512 (`twice[a]` = `2 V_a` mod 512,
/// all even or all odd): its skewed coordinates `M V` mod 256, then the lattice bases' hash.
#[inline(always)]
pub(super) fn vertex_hash(perm: &[u8; 512], twice: [i64; 3]) -> usize {
    let i = (twice[1] + twice[2]).rem_euclid(512) / 2;
    let j = (twice[0] + twice[2]).rem_euclid(512) / 2;
    let k = (twice[0] + twice[1]).rem_euclid(512) / 2;
    hash(perm, i, j, k)
}

/// `perm[i + perm[j + perm[k]]]` (indices mod 256).
#[inline(always)]
pub(super) fn hash(perm: &[u8; 512], i: i64, j: i64, k: i64) -> usize {
    let pk = perm[(k & 255) as usize] as usize;
    let pj = perm[((j & 255) as usize + pk) & 511] as usize;
    perm[((i & 255) as usize + pj) & 511] as usize
}

/// The gradient a hash picks, as `S`.
#[inline(always)]
pub(super) fn gradient<S: Real>(h: usize) -> [S; 3] {
    GRADIENTS[h % 12].map(|c| S::from_f64(c as f64))
}

/// The offset from vertex `half / 2` (relative to the cell corner) to the point of fractions
/// `f`: `f - half / 2` in S, the fraction rounded to S first (exact in f64; in f32 two roundings,
/// within 2^-24 of the exact offset, and zero on the vertex itself). The fraction in S once per
/// point, not once per vertex in f64, is what lets the batch kernel run its terms on 16 f32
/// lanes (issue 32's speed goal).
#[inline(always)]
pub(super) fn offset<S: Real>(f: [f64; 3], half: [i64; 3]) -> [S; 3] {
    std::array::from_fn(|a| S::from_f64(f[a]) - S::from_f64(half[a] as f64 * 0.5))
}

/// One vertex's term `(max(0.5 - r², 0))⁴ (g · d)` at offset `d` from it.
#[inline(always)]
pub(super) fn term<S: Real>(d: [S; 3], g: [S; 3]) -> S {
    let t = S::from_f64(RADIUS2) - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    let t = if t > S::ZERO { t } else { S::ZERO };
    let dot = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
    let t2 = t * t;
    t2 * t2 * dot
}

/// The gradient of [`term`] with respect to the point (which moves `d` one for one):
/// `t⁴ g - 8 t³ (g · d) d`.
#[inline(always)]
pub(super) fn term_grad<S: Real>(d: [S; 3], g: [S; 3]) -> [S; 3] {
    let t = S::from_f64(RADIUS2) - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    let t = if t > S::ZERO { t } else { S::ZERO };
    let dot = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
    let t2 = t * t;
    let t4 = t2 * t2;
    let k = S::from_f64(-8.0) * (t2 * t) * dot;
    std::array::from_fn(|a| t4 * g[a] + k * d[a])
}

/// The four vertices a point reaches: each one's offset `d` (point minus vertex, in S) and hash.
pub(super) type Reach<S> = [([S; 3], usize); 4];

/// The vertices `p` reaches (untiled).
#[inline(always)]
fn reach<S: Real>(perm: &[u8; 512], p: [f64; 3]) -> Reach<S> {
    let at = locate(p);
    std::array::from_fn(|k| {
        let half = half_offset(at.carry, skewed_offset(at.order, k));
        let twice: [i64; 3] = std::array::from_fn(|a| 2 * at.cell[a] as i64 + half[a]);
        (offset(at.frac, half), vertex_hash(perm, twice))
    })
}

/// The noise from the vertices in reach: the terms summed in order, scaled.
#[inline(always)]
fn sum<S: Real>(reach: Reach<S>) -> S {
    let mut sum = S::ZERO;
    for (d, h) in reach {
        sum = sum + term(d, gradient::<S>(h));
    }
    S::from_f64(SCALE) * sum
}

/// One sample. Positions in f64, the kernel arithmetic in `S` (the offsets are small numbers,
/// from the fractions rounded to S, see [`offset`]).
#[inline(always)]
pub(super) fn sample<S: Real>(perm: &[u8; 512], p: [f64; 3]) -> S {
    sum(reach(perm, p))
}

/// [`sample`]'s value (its bits) and its gradient with respect to the point: the offset from
/// each vertex moves with the point (the tetrahedron is piecewise constant), summed in the
/// value's order and scaled alike. NaN on every component for non-finite input.
#[inline(always)]
pub(super) fn sample_grad<S: Real>(perm: &[u8; 512], p: [f64; 3]) -> (S, [S; 3]) {
    sum_grad(reach(perm, p))
}

/// [`sum`] and its gradient (see [`sample_grad`]).
#[inline(always)]
fn sum_grad<S: Real>(reach: Reach<S>) -> (S, [S; 3]) {
    let mut g = [S::ZERO; 3];
    let mut bad = false;
    for (d, h) in reach {
        let dt = term_grad(d, gradient::<S>(h));
        g = std::array::from_fn(|a| g[a] + dt[a]);
        bad |= d.iter().any(|c| c.is_nan());
    }
    let scale = S::from_f64(SCALE);
    let g = g.map(|c| if bad { S::NAN } else { scale * c });
    (sum(reach), g)
}

/// One sample tiled with `period` (every integer period: see the module docs). The point is
/// reduced into its period, so each tiled axis' cell is an exact small integer, and each vertex
/// is hashed as its translate into the period box: `2 V` mod `2 P` per tiled axis.
pub(super) fn sample_periodic<S: Real>(perm: &[u8; 512], p: [f64; 3], period: Period) -> S {
    sum(reach_periodic(perm, p, period))
}

/// [`sample_periodic`]'s value (its bits) and gradient, as [`sample_grad`]: the reduction into
/// the period is a translation per cell, so this is the gradient at the reduced point.
pub(super) fn sample_grad_periodic<S: Real>(
    perm: &[u8; 512],
    p: [f64; 3],
    period: Period,
) -> (S, [S; 3]) {
    sum_grad(reach_periodic(perm, p, period))
}

/// The vertices `p` reaches in the noise tiled with `period` (see [`sample_periodic`]).
#[inline(always)]
fn reach_periodic<S: Real>(perm: &[u8; 512], p: [f64; 3], period: Period) -> Reach<S> {
    let q = period::reduce3(p, period).0;
    let at = locate(q);
    // Per axis: the tiled cell (exact, below the period) and twice the period, or none.
    let tiled: [Option<(i64, i64)>; 3] = std::array::from_fn(|a| {
        let ok = (1..=1u64 << 52).contains(&period[a]) && q[a].is_finite();
        ok.then(|| (q[a].floor() as i64, 2 * period[a] as i64))
    });
    std::array::from_fn(|k| {
        let half = half_offset(at.carry, skewed_offset(at.order, k));
        let twice: [i64; 3] = std::array::from_fn(|a| match tiled[a] {
            Some((cell, twice_period)) => (2 * cell + half[a]).rem_euclid(twice_period),
            None => 2 * at.cell[a] as i64 + half[a],
        });
        (offset(at.frac, half), vertex_hash(perm, twice))
    })
}
