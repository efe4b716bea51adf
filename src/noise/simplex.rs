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
//! vertices too: eight vertices in all, the kernel's whole support (the test
//! `simplex_matches_a_brute_force_sum_over_every_vertex` checks against a sum over every
//! vertex), so the noise is continuous and C³, at about twice the arithmetic. It is zero on every vertex (a vertex's own term is `g · 0`, and every
//! other vertex is at least √0.75 away).
//!
//! Range: ±1, proved in `simplex_range_and_lipschitz_bounds_are_proved` (the bound with every
//! gradient chosen adversarially is 32 × 0.030585 = 0.9787; random samples reach ±0.975).
//! Lipschitz bound: see [`LIPSCHITZ`].
//!
//! Precision: the skewed cell is computed exactly at any magnitude (small-integer arithmetic,
//! carried in f64 so that the batch kernel runs it over lanes). With `X = floor(x)` (and so
//! on) as integers and `f = x - X` exact, the skew `(x + y + z) / 3` splits into the integer
//! part of `(X + Y + Z) / 3` (`q`, with remainder `r`) and `(r + fx + fy + fz) / 3`, so the cell
//! is `X + q + L` with a small `L` and the offset inside it involves small numbers only. Only
//! residues of the indices are needed (mod 768 = 3 × 256, so that `q mod 256` and `r` are right).

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

/// 2^51: below it, [`cell768_fast`] applies.
pub(super) const FAST: f64 = 2_251_799_813_685_248.0;

/// One coordinate as its integer cell residue mod 768 (an exact small integer, as f64) and its
/// fraction in [0, 1] (as [`super::lattice::lattice`] computes it; NaN for non-finite input).
#[inline(always)]
pub(super) fn cell768(x: f64) -> (f64, f64) {
    if x.abs() < FAST {
        cell768_fast(x)
    } else {
        cell768_cold(x)
    }
}

/// [`cell768`] for |x| < 2^51, branch-free (the batch kernel runs it over lanes): with
/// `c = floor(x)`, `c · (1/768)` is within 2^-52 |c / 768| < 1/2 of `c / 768`, so its floor is
/// `floor(c / 768)` or one off, and `c - 768 k` (exact: integers below 2^52) is `c mod 768`
/// after at most one correction by 768 either way.
#[inline(always)]
pub(super) fn cell768_fast(x: f64) -> (f64, f64) {
    let c = x.floor();
    let m = c - 768.0 * (c * (1.0 / 768.0)).floor();
    let m = if m < 0.0 { m + 768.0 } else { m };
    let m = if m >= 768.0 { m - 768.0 } else { m };
    (m, x - c)
}

/// [`cell768`] for |x| >= 2^51 and non-finite x.
#[cold]
#[inline(never)]
fn cell768_cold(x: f64) -> (f64, f64) {
    // Already an integer beyond 2^52 (fraction 0), or not finite (fraction NaN, cell 0).
    // `%` (fmod) is exact.
    let c = x.floor();
    let m = c % 768.0;
    let m = if m < 0.0 { m + 768.0 } else { m };
    (if m.is_finite() { m } else { 0.0 }, x - c)
}

/// The hash of a vertex (cell indices mod 256), Ebert-style as the lattice bases hash.
#[inline(always)]
pub(super) fn hash(perm: &[u8; 512], i: i64, j: i64, k: i64) -> usize {
    let pk = perm[(k & 255) as usize] as usize;
    let pj = perm[((j & 255) as usize + pk) & 511] as usize;
    perm[((i & 255) as usize + pj) & 511] as usize
}

/// Where a point lies: the skewed cell's base vertex (an exact small integer per axis, as
/// f64, equal to the true index mod 256), the offset from it (unskewed), and which of the six
/// tetrahedra (a number into [`ORDERS`]), also as the comparisons that picked it.
pub(super) struct Located {
    pub cell: [f64; 3],
    pub offset: [f64; 3],
    pub order: usize,
    /// `4 (a >= b) + 2 (b >= c) + (a >= c)` for the offset `(a, b, c)`; `order` is
    /// `ORDER_OF_COMPARISONS[comparisons]` (the batch kernel derives the axes from these bits).
    pub comparisons: usize,
}

/// Finds the skewed cell and tetrahedron of `p` (see the module docs for the exact split).
#[inline(always)]
pub(super) fn locate(p: [f64; 3]) -> Located {
    let (cx, fx) = cell768(p[0]);
    let (cy, fy) = cell768(p[1]);
    let (cz, fz) = cell768(p[2]);
    locate_parts([cx, cy, cz], [fx, fy, fz])
}

/// [`locate`] from each coordinate's cell residue mod 768 and fraction: branch-free, exact
/// small-integer arithmetic in f64 (every intermediate is an integer below 2^12, or a fraction).
#[inline(always)]
pub(super) fn locate_parts(c: [f64; 3], f: [f64; 3]) -> Located {
    locate_from::<true>(c, f)
}

/// [`locate_parts`]; without `REDUCE`, from full cell indices (below 2^50 in magnitude), giving
/// the full index of the skewed cell (tiling needs it).
#[inline(always)]
fn locate_from<const REDUCE: bool>(c: [f64; 3], f: [f64; 3]) -> Located {
    const THIRD: f64 = 1.0 / 3.0;
    let sum = c[0] + c[1] + c[2];
    // Multiplications by rounded reciprocals, their floors exact: `(n + 1/2) / d` is at least
    // 1/(2d) from an integer, far more than the product's rounding error for the integers n
    // here (below 2^12; below 2^50 without `REDUCE`).
    let sum = if REDUCE {
        sum - 768.0 * ((sum + 0.5) * (1.0 / 768.0)).floor()
    } else {
        sum
    };
    let q = ((sum + 0.5) * THIRD).floor();
    let r = sum - 3.0 * q;
    let skew = (r + f[0] + f[1] + f[2]) * THIRD;
    let l = [
        (f[0] + skew).floor(),
        (f[1] + skew).floor(),
        (f[2] + skew).floor(),
    ];
    let unskew = (r + l[0] + l[1] + l[2]) * (1.0 / 6.0);
    let offset = [
        f[0] - l[0] + unskew,
        f[1] - l[1] + unskew,
        f[2] - l[2] + unskew,
    ];
    let [a, b, cc] = offset;
    // Gustavson's comparisons (ties go to the lower axis) as an index: a >= b, b >= c, a >= c.
    let index = 4 * usize::from(a >= b) + 2 * usize::from(b >= cc) + usize::from(a >= cc);
    // Non-finite input: NaN everywhere; keep the cell harmless (0); the result is NaN anyway.
    let cell: [f64; 3] = std::array::from_fn(|k| {
        let v = c[k] + q + l[k];
        if v.is_finite() {
            v
        } else {
            0.0
        }
    });
    Located {
        cell,
        offset,
        order: ORDER_OF_COMPARISONS[index],
        comparisons: index,
    }
}

/// The tetrahedron (its number in [`ORDERS`]) for each outcome of the comparisons
/// `4 (a >= b) + 2 (b >= c) + (a >= c)` of the offset's components; the two impossible
/// outcomes (1 and 6) map to a neighbour.
pub(super) const ORDER_OF_COMPARISONS: [usize; 8] = [3, 3, 4, 5, 2, 1, 0, 0];

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

/// The batch kernel's form of `ORDERS[ORDER_OF_COMPARISONS[comparisons]]`, branch-free: which
/// axis comes first (largest offset) and which last, as 0/1 per axis. Exact for the six
/// outcomes that occur (the other two would need `a >= b >= c > a`; NaN offsets compare false
/// everywhere, outcome 0); `axis_masks_match_the_orders` checks them.
#[inline(always)]
pub(super) fn axis_masks(comparisons: u8) -> ([u8; 3], [u8; 3]) {
    let ab = (comparisons >> 2) & 1;
    let bc = (comparisons >> 1) & 1;
    let ac = comparisons & 1;
    let first_x = ab & ac;
    let first_y = (1 - ab) & bc;
    let last_x = (1 - ab) & (1 - ac);
    let last_y = ab & (1 - bc);
    (
        [first_x, first_y, 1 - first_x - first_y],
        [last_x, last_y, 1 - last_x - last_y],
    )
}

/// Vertex `K`'s offset along one axis (as [`vertices`] lists them) from that axis's masks:
/// `first` (1 on the tetrahedron's first axis) and `last`; the middle axis is `1 - first - last`.
/// Every value is a small integer; `0 - last` keeps vertex 7's zero positive, as the table's is.
#[inline(always)]
pub(super) fn vertex_offset<S: Real, const K: usize>(first: S, last: S) -> S {
    let one = S::ONE;
    match K {
        0 => S::ZERO,
        1 => first,
        2 => one - last,
        3 => one,
        4 => first + one,
        5 => one - first - last,
        6 => first + last,
        _ => S::ZERO - last,
    }
}

/// [`vertex_offset`] as a byte added (mod 256) to a cell index byte.
#[inline(always)]
pub(super) fn vertex_byte<const K: usize>(first: u8, last: u8) -> u8 {
    match K {
        0 => 0,
        1 => first,
        2 => 1 - last,
        3 => 1,
        4 => first + 1,
        5 => 1 - first - last,
        6 => first + last,
        _ => 0u8.wrapping_sub(last),
    }
}

/// Vertex `K`'s unskew `G (v0 + v1 + v2)`, the same for every tetrahedron (the coordinate sums
/// of the eight vertices are 0, 1, 2, 3, 4, 1, 2, -1).
#[inline(always)]
pub(super) fn vertex_unskew<S: Real, const K: usize>() -> S {
    const SUMS: [i64; 8] = [0, 1, 2, 3, 4, 1, 2, -1];
    S::from_f64(SUMS[K] as f64 / 6.0)
}

/// The six tetrahedra of a skewed cell, by the order of the offset's components (largest
/// first), numbered as [`locate`] reports them.
pub(super) const ORDERS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [2, 0, 1],
    [2, 1, 0],
    [1, 2, 0],
    [1, 0, 2],
];

/// One vertex's term `(max(0.6 - r², 0))⁴ (g · d)` at offset `x0` from the cell's base vertex,
/// for vertex `v` (an offset from the base) whose hash is `h`.
#[inline(always)]
pub(super) fn term<S: Real>(x0: [S; 3], v: [i64; 3], h: usize) -> S {
    let (offset, g) = vertex_constants::<S>(v);
    term_with(x0, offset, g, gradient::<S>(h))
}

/// A vertex offset as `S`, and its unskew `G (v0 + v1 + v2)` (G times a small integer).
#[inline(always)]
pub(super) fn vertex_constants<S: Real>(v: [i64; 3]) -> ([S; 3], S) {
    (
        v.map(|c| S::from_f64(c as f64)),
        S::from_f64((v[0] + v[1] + v[2]) as f64 / 6.0),
    )
}

/// The gradient a hash picks, as `S`.
#[inline(always)]
pub(super) fn gradient<S: Real>(h: usize) -> [S; 3] {
    GRADIENTS[h % 12].map(|c| S::from_f64(c as f64))
}

/// [`term`]'s arithmetic from its constants: the point function's and the batch kernel's
/// (which reads the constants from tables), in one place.
#[inline(always)]
pub(super) fn term_with<S: Real>(x0: [S; 3], v: [S; 3], g: S, grad: [S; 3]) -> S {
    let d = [x0[0] - v[0] + g, x0[1] - v[1] + g, x0[2] - v[2] + g];
    let t = S::from_f64(RADIUS2) - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    let t = if t > S::ZERO { t } else { S::ZERO };
    let dot = grad[0] * d[0] + grad[1] * d[1] + grad[2] * d[2];
    let t2 = t * t;
    t2 * t2 * dot
}

/// The vertices a point reaches: its offset from its skewed cell's base vertex (in S) and the
/// eight vertices in reach, each as its offset from the base vertex and its hash, in the
/// order the sums add them.
pub(super) type Reach<S> = ([S; 3], [([i64; 3], usize); 8]);

/// The vertices `p` reaches (see [`Reach`]).
#[inline(always)]
fn reach<S: Real>(perm: &[u8; 512], p: [f64; 3]) -> Reach<S> {
    let at = locate(p);
    let x0 = at.offset.map(S::from_f64);
    let cell = at.cell.map(|c| c as i64);
    let vertices = vertices(ORDERS[at.order]).map(|v| {
        let h = hash(perm, cell[0] + v[0], cell[1] + v[1], cell[2] + v[2]);
        (v, h)
    });
    (x0, vertices)
}

/// The noise from the vertices in reach: the terms summed in order, scaled.
#[inline(always)]
fn sum<S: Real>((x0, vertices): Reach<S>) -> S {
    let mut sum = S::ZERO;
    for (v, h) in vertices {
        sum = sum + term(x0, v, h);
    }
    S::from_f64(SCALE) * sum
}

/// One sample. Positions in f64, the kernel arithmetic in `S` (the offsets are small numbers,
/// computed in f64 and rounded once).
#[inline(always)]
pub(super) fn sample<S: Real>(perm: &[u8; 512], p: [f64; 3]) -> S {
    sum(reach(perm, p))
}

/// [`sample`]'s value (its bits) and its gradient with respect to the point: the offset from
/// each vertex moves with the point (the cell is piecewise constant), so per vertex
/// `∇((0.6 - r²)⁴ g·d) = (0.6 - r²)⁴ g - 8 (0.6 - r²)³ (g·d) d` where `r² < 0.6` (0 beyond),
/// summed in the value's order and scaled alike. NaN on every component for non-finite input.
#[inline(always)]
pub(super) fn sample_grad<S: Real>(perm: &[u8; 512], p: [f64; 3]) -> (S, [S; 3]) {
    sum_grad(reach(perm, p))
}

/// [`sum`] and its gradient (see [`sample_grad`]).
#[inline(always)]
fn sum_grad<S: Real>(reach: Reach<S>) -> (S, [S; 3]) {
    let (x0, vertices) = reach;
    let mut g = [S::ZERO; 3];
    for (v, h) in vertices {
        let (offset, unskew) = vertex_constants::<S>(v);
        let dt = term_grad_with(x0, offset, unskew, gradient::<S>(h));
        g = std::array::from_fn(|a| g[a] + dt[a]);
    }
    let scale = S::from_f64(SCALE);
    let bad = x0.iter().any(|c| c.is_nan());
    let g = g.map(|c| if bad { S::NAN } else { scale * c });
    (sum((x0, vertices)), g)
}

/// The gradient of [`term_with`] with respect to the point (which moves `d` one for one).
#[inline(always)]
pub(super) fn term_grad_with<S: Real>(x0: [S; 3], v: [S; 3], g: S, grad: [S; 3]) -> [S; 3] {
    let d = [x0[0] - v[0] + g, x0[1] - v[1] + g, x0[2] - v[2] + g];
    let t = S::from_f64(RADIUS2) - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    let t = if t > S::ZERO { t } else { S::ZERO };
    let dot = grad[0] * d[0] + grad[1] * d[1] + grad[2] * d[2];
    let t2 = t * t;
    let t4 = t2 * t2;
    let k = S::from_f64(-8.0) * (t2 * t) * dot;
    std::array::from_fn(|a| t4 * grad[a] + k * d[a])
}

/// One sample tiled with `period` (each a multiple of 3, which the checker ensures: the skewed
/// grid is invariant under a translation by `(P, 0, 0)` exactly when 3 divides P, the vertex
/// index moving by `(4P/3, P/3, P/3)`). The point is reduced into its period (so the full cell
/// index is small and exact), and each vertex is hashed as its translate into the period box:
/// its unskewed position times 6, `U = 6 V - (V0 + V1 + V2)`, is reduced mod `6 P` per axis and
/// turned back into a vertex index (`V = (U + ΣU / 3) / 6`, exact integers). A vertex and its
/// translates by whole periods get one hash, so the noise repeats; it is the same kernel sum,
/// so it stays continuous.
pub(super) fn sample_periodic<S: Real>(perm: &[u8; 512], p: [f64; 3], period: [u64; 3]) -> S {
    sum(reach_periodic(perm, p, period))
}

/// [`sample_periodic`]'s value (its bits) and gradient, as [`sample_grad`]: the reduction into
/// the period is a translation per cell, so this is the gradient at the reduced point.
pub(super) fn sample_grad_periodic<S: Real>(
    perm: &[u8; 512],
    p: [f64; 3],
    period: [u64; 3],
) -> (S, [S; 3]) {
    sum_grad(reach_periodic(perm, p, period))
}

/// The vertices `p` reaches in the noise tiled with `period` (see [`sample_periodic`]).
#[inline(always)]
fn reach_periodic<S: Real>(perm: &[u8; 512], p: [f64; 3], period: [u64; 3]) -> Reach<S> {
    let q = super::period::reduce3(p, period).0;
    if q.iter().any(|v| !v.is_finite()) || period.iter().any(|&p| p == 0 || p % 3 != 0) {
        return reach(perm, q);
    }
    // Full cell indices: the reduced coordinates are below 2^21.
    let c = q.map(f64::floor);
    let at = locate_from::<false>(c, [q[0] - c[0], q[1] - c[1], q[2] - c[2]]);
    let x0 = at.offset.map(S::from_f64);
    let cell = at.cell.map(|v| v as i64);
    let vertices = vertices(ORDERS[at.order]).map(|v| {
        let vertex = [cell[0] + v[0], cell[1] + v[1], cell[2] + v[2]];
        let s = vertex[0] + vertex[1] + vertex[2];
        let u: [i64; 3] =
            std::array::from_fn(|a| (6 * vertex[a] - s).rem_euclid(6 * period[a] as i64));
        let s = (u[0] + u[1] + u[2]) / 3;
        let wrapped: [i64; 3] = std::array::from_fn(|a| (u[a] + s) / 6);
        (v, hash(perm, wrapped[0], wrapped[1], wrapped[2]))
    });
    (x0, vertices)
}
