//! Simplex noise: Perlin's 2001 simplex gradient noise in Stefan Gustavson's formulation
//! ("Simplex noise demystified", 2005): the space is cut into tetrahedra by skewing the cubic
//! grid along its main diagonal (F = 1/3, G = 1/6), each vertex carries one of the 12 cube-edge
//! gradients picked by a hash, and each vertex contributes `(0.6 - r²)⁴ (g · d)` within radius
//! √0.6, the sum scaled by 32.
//!
//! One departure, for continuity: Gustavson (and most libraries) sum only the four vertices of
//! the tetrahedron containing the point, but at radius √0.6 the kernel also reaches the vertex
//! beyond each of its four faces (the reflection of a vertex in the opposite face; 26% of points
//! have such a contribution), so the four-vertex sum jumps across every face. We sum those four
//! vertices too: eight vertices in all, the kernel's whole support (`simplex_reach_is_complete`
//! checks that no other vertex is ever within reach), so the noise is continuous and C³, at about
//! twice the arithmetic. It is zero on every vertex (a vertex's own term is `g · 0`, and every
//! other vertex is at least √0.75 away).
//!
//! Range: ±1, proved in `simplex_range_and_lipschitz_bounds_are_proved` (the bound with every
//! gradient chosen adversarially is 32 × 0.030585 = 0.9787; random samples reach ±0.975).
//! Lipschitz bound: see [`LIPSCHITZ`].
//!
//! Precision: the skewed cell is computed exactly at any magnitude. With `X = floor(x)` (and so
//! on) as integers and `f = x - X` exact, the skew `(x + y + z) / 3` splits into the integer
//! part of `(X + Y + Z) / 3` (`q`, with remainder `r`) and `(r + fx + fy + fz) / 3`, so the cell
//! is `X + q + L` with a small `L` and the offset inside it involves small numbers only. Only
//! residues of the indices are needed (mod 768 = 3 × 256, so that `q mod 256` and `r` are right).

use super::lattice::TWO52;
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

/// The output scale (Gustavson's 32).
pub(super) const SCALE: f64 = 32.0;

/// The squared kernel radius (Gustavson's 0.6).
pub(super) const RADIUS2: f64 = 0.6;

/// Half-width of the range; see the module docs.
pub(super) const RANGE: f64 = 1.0;

/// An upper bound on |∇N|: per vertex, |∇((0.6 - r²)⁴ g·d)| <= √2 (0.6 - r²)³ (0.6 + 7 r²)
/// (|g| = √2, |g·d| <= √2 r), at most √2 × 0.16331 = 0.23095 (at r² = 0.6/7); the test
/// `simplex_range_and_lipschitz_bounds_are_proved` bounds the sum of these over the vertices in
/// reach by 12.5 / 32 = 0.3906 everywhere (the sum's maximum is about 0.3797), so
/// |∇N| <= 12.5; measured slopes reach about 6.
pub(super) const LIPSCHITZ: f64 = 12.5;

/// One coordinate as its integer cell residue mod 768 and its fraction in [0, 1] (the
/// fraction as [`super::lattice::lattice`] computes it; NaN for non-finite input).
#[inline(always)]
pub(super) fn cell768(x: f64) -> (i64, f64) {
    if x.abs() < TWO52 {
        let t = x as i64;
        let i = t - ((t as f64) > x) as i64;
        let c = (i as f64).copysign(x);
        (i.rem_euclid(768), x - c)
    } else {
        // Already an integer (fraction 0) or not finite (fraction NaN). `%` (fmod) is exact.
        let c = x.floor();
        let m = c % 768.0;
        let m = if m < 0.0 { m + 768.0 } else { m };
        (m as i64, x - c)
    }
}

/// The hash of a vertex (cell indices mod 256), Ebert-style as the lattice bases hash.
#[inline(always)]
pub(super) fn hash(perm: &[u8; 512], i: i64, j: i64, k: i64) -> usize {
    let pk = perm[(k & 255) as usize] as usize;
    let pj = perm[((j & 255) as usize + pk) & 511] as usize;
    perm[((i & 255) as usize + pj) & 511] as usize
}

/// Where a point lies: the skewed cell's base vertex (mod 256), the offset from it (unskewed),
/// and the order of the offset's components (largest first), which picks the tetrahedron.
pub(super) struct Located {
    pub cell: [i64; 3],
    pub offset: [f64; 3],
    pub order: [usize; 3],
}

/// Finds the skewed cell and tetrahedron of `p` (see the module docs for the exact split).
#[inline(always)]
pub(super) fn locate(p: [f64; 3]) -> Located {
    let (cx, fx) = cell768(p[0]);
    let (cy, fy) = cell768(p[1]);
    let (cz, fz) = cell768(p[2]);
    let sum = (cx + cy + cz) % 768;
    let (q, r) = (sum / 3, (sum % 3) as f64);
    let skew = (r + fx + fy + fz) / 3.0;
    let l = [
        (fx + skew).floor(),
        (fy + skew).floor(),
        (fz + skew).floor(),
    ];
    // Non-finite input: the NaN fraction gives NaN `l`; keep the indices harmless (0).
    let li = l.map(|v| if v.is_finite() { v as i64 } else { 0 });
    let unskew = (r + l[0] + l[1] + l[2]) / 6.0;
    let offset = [fx - l[0] + unskew, fy - l[1] + unskew, fz - l[2] + unskew];
    let [a, b, c] = offset;
    // Ties go to the lower axis, as Gustavson's `>=` comparisons do.
    let order = if a >= b {
        if b >= c {
            [0, 1, 2]
        } else if a >= c {
            [0, 2, 1]
        } else {
            [2, 0, 1]
        }
    } else if b < c {
        [2, 1, 0]
    } else if a < c {
        [1, 2, 0]
    } else {
        [1, 0, 2]
    };
    Located {
        cell: [cx + q + li[0], cy + q + li[1], cz + q + li[2]],
        offset,
        order,
    }
}

/// The eight vertices in reach of a point in the tetrahedron with axis order `order`, as
/// offsets from the cell's base vertex: the tetrahedron's own four `v0 = 0, v1 = e_a,
/// v2 = e_a + e_b, v3 = 1` (a, b, c the axes by decreasing offset), then the vertex beyond the
/// face opposite each, `v1 + v3 - v0`, `v0 + v2 - v1`, `v1 + v3 - v2`, `v0 + v2 - v3`.
#[inline(always)]
pub(super) fn vertices(order: [usize; 3]) -> [[i64; 3]; 8] {
    let e = |axis: usize| {
        let mut v = [0i64; 3];
        v[axis] = 1;
        v
    };
    let add = |a: [i64; 3], b: [i64; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
    let sub = |a: [i64; 3], b: [i64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let v0 = [0; 3];
    let v1 = e(order[0]);
    let v2 = add(v1, e(order[1]));
    let v3 = [1; 3];
    [
        v0,
        v1,
        v2,
        v3,
        sub(add(v1, v3), v0),
        sub(add(v0, v2), v1),
        sub(add(v1, v3), v2),
        sub(add(v0, v2), v3),
    ]
}

/// The six axis orders [`locate`] can return, in a fixed numbering (for the batch kernel's
/// vertex table).
pub(super) const ORDERS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [2, 0, 1],
    [2, 1, 0],
    [1, 2, 0],
    [1, 0, 2],
];

/// The number of an axis order in [`ORDERS`].
#[inline(always)]
pub(super) fn order_number(order: [usize; 3]) -> usize {
    ORDERS.iter().position(|o| *o == order).unwrap_or(0)
}

/// One vertex's term `(max(0.6 - r², 0))⁴ (g · d)` at offset `x0` from the cell's base vertex,
/// for vertex `v` (an offset from the base) whose hash is `h`: the point function's and the
/// batch kernel's arithmetic, in one place.
#[inline(always)]
pub(super) fn term<S: Real>(x0: [S; 3], v: [i64; 3], h: usize) -> S {
    // The vertex's unskewed offset is v - G (v0 + v1 + v2); G times a small integer.
    let g = S::from_f64((v[0] + v[1] + v[2]) as f64 / 6.0);
    let d = [
        x0[0] - S::from_f64(v[0] as f64) + g,
        x0[1] - S::from_f64(v[1] as f64) + g,
        x0[2] - S::from_f64(v[2] as f64) + g,
    ];
    let t = S::from_f64(RADIUS2) - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    let t = if t > S::ZERO { t } else { S::ZERO };
    let grad = GRADIENTS[h % 12];
    let dot = S::from_f64(grad[0] as f64) * d[0]
        + S::from_f64(grad[1] as f64) * d[1]
        + S::from_f64(grad[2] as f64) * d[2];
    let t2 = t * t;
    t2 * t2 * dot
}

/// One sample. Positions in f64, the kernel arithmetic in `S` (the offsets are small numbers,
/// computed in f64 and rounded once).
#[inline(always)]
pub(super) fn sample<S: Real>(perm: &[u8; 512], p: [f64; 3]) -> S {
    let at = locate(p);
    let x0 = at.offset.map(S::from_f64);
    let mut sum = S::ZERO;
    for v in vertices(at.order) {
        let h = hash(
            perm,
            at.cell[0] + v[0],
            at.cell[1] + v[1],
            at.cell[2] + v[2],
        );
        sum = sum + term(x0, v, h);
    }
    S::from_f64(SCALE) * sum
}
