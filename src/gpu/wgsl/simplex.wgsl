// simplex.wgsl: the Simplex basis (noise/simplex.rs; `SimplexKernel` in noise/mod.rs).
//
// Gustavson's simplex noise (F = 1/3, G = 1/6, the 12 cube-edge gradients picked by
// `hash % 12`, kernel (0.6 - r²)⁴ (g · d), scaled by 32), summed over the eight vertices in
// reach: the tetrahedron's own four and the vertex beyond each of its faces.
//
// As on the CPU: the skewed cell is found exactly in f64 (small-integer arithmetic on the
// coordinates' cell residues mod 768, `cell768` / `locate_from`), the offset inside the cell is
// computed in f64 and rounded to f32 once, and the kernel sums run in f32 in the CPU's
// operation order. Non-finite input gives NaN (value and every gradient component).
//
// Needs common.wgsl (`perm_at`, `reduce3`).

const SIMPLEX_FAST: f64 = 2251799813685248.0lf;       // 2^51: below it, the fast cell768
const SIMPLEX_MAX_F64: f64 = 1.7976931348623157e308lf;
const SIMPLEX_THIRD: f64 = 0.3333333333333333lf;      // 1.0 / 3.0 (rounded, as in Rust)
const SIMPLEX_SIXTH: f64 = 0.16666666666666666lf;     // 1.0 / 6.0
const SIMPLEX_INV768: f64 = 0.0013020833333333333lf;  // 1.0 / 768.0
const SIMPLEX_TWO48: f64 = 281474976710656.0lf;       // 2^48
const SIMPLEX_INV_TWO48: f64 = 3.552713678800501e-15lf; // 2^-48 (exact)
const SIMPLEX_INV256: f64 = 0.00390625lf;             // 2^-8 (exact)

const SIMPLEX_RADIUS2: f32 = 0x1.333334p-1f; // S::from_f64(0.6)
const SIMPLEX_SCALE: f32 = 32.0;

// `vertex_unskew`: S::from_f64(n / 6.0) for the vertex coordinate sums n = -1..=4 (index n + 1).
const SIMPLEX_UNSKEW: array<f32, 6> = array<f32, 6>(
    -0x1.555556p-3f, // -1/6
    0.0,
    0x1.555556p-3f,  // 1/6
    0x1.555556p-2f,  // 2/6
    0.5,             // 3/6
    0x1.555556p-1f,  // 4/6
);

// `ORDERS[ORDER_OF_COMPARISONS[comparisons]]`'s first (largest offset) and last axis, two bits
// per comparison outcome `4 (a >= b) + 2 (b >= c) + (a >= c)`:
// first = [2, 2, 1, 1, 2, 0, 0, 0], last = [0, 0, 0, 2, 1, 1, 2, 2].
const SIMPLEX_FIRST_AXIS: u32 = 602u;
const SIMPLEX_LAST_AXIS: u32 = 42368u;

fn simplex_nan() -> f32 {
    return bitcast<f32>(0x7fc00000u);
}

// Finite (not NaN, not ±inf). With ordered comparisons NaN compares false.
fn simplex_finite3(p: vec3<f64>) -> bool {
    let a = abs(p);
    return a.x <= SIMPLEX_MAX_F64 && a.y <= SIMPLEX_MAX_F64 && a.z <= SIMPLEX_MAX_F64;
}

// x mod m for an integer 0 <= x < 2^51 (as f64), m small, inv = 1/m rounded: exact (the floor
// is at most one off, corrected either way).
fn simplex_mod_small(x: f64, m: f64, inv: f64) -> f64 {
    var r = x - m * floor(x * inv);
    if (r < 0.0lf) {
        r = r + m;
    }
    if (r >= m) {
        r = r - m;
    }
    return r;
}

// `cell768` for finite x: (cell residue mod 768 as an exact small integer, fraction x - floor(x)).
fn simplex_cell768(x: f64) -> vec2<f64> {
    let c = floor(x);
    if (abs(x) < SIMPLEX_FAST) {
        // cell768_fast
        var m = c - 768.0lf * floor(c * SIMPLEX_INV768);
        if (m < 0.0lf) {
            m = m + 768.0lf;
        }
        if (m >= 768.0lf) {
            m = m - 768.0lf;
        }
        return vec2<f64>(m, x - c);
    }
    // cell768_cold (|x| >= 2^51, finite): Rust's exact fmod, here through base-2^48 digits of
    // |c| (split exactly): 2^48 = 256 (mod 768) and 256^k = 256 (mod 768) for k >= 1, so
    // |c| = d0 + 256 (d1 + d2 + ... mod 3) (mod 768).
    let a = abs(c);
    var hi = floor(a * SIMPLEX_INV_TWO48);
    let d0 = a - hi * SIMPLEX_TWO48;
    var acc = 0.0lf;
    for (var i = 0; i < 24; i = i + 1) {
        if (hi == 0.0lf) {
            break;
        }
        let h2 = floor(hi * SIMPLEX_INV_TWO48);
        let d = hi - h2 * SIMPLEX_TWO48;
        acc = simplex_mod_small(acc + simplex_mod_small(d, 3.0lf, SIMPLEX_THIRD), 3.0lf, SIMPLEX_THIRD);
        hi = h2;
    }
    let r = simplex_mod_small(simplex_mod_small(d0, 768.0lf, SIMPLEX_INV768) + 256.0lf * acc, 768.0lf, SIMPLEX_INV768);
    // fmod keeps the sign of c; a negative remainder gets 768 added.
    var m = r;
    if (c < 0.0lf && r != 0.0lf) {
        m = 768.0lf - r;
    }
    return vec2<f64>(m, x - c);
}

struct SimplexLocated {
    cell: vec3<f64>,    // the skewed cell's base vertex (exact integers)
    offset: vec3<f64>,  // the offset from it, unskewed
    comparisons: u32,
}

// `locate_from`: reduce = REDUCE (cell residues mod 768) or not (full cell indices).
fn simplex_locate_from(c: vec3<f64>, f: vec3<f64>, reduce: bool) -> SimplexLocated {
    var sum = c.x + c.y + c.z;
    if (reduce) {
        sum = sum - 768.0lf * floor((sum + 0.5lf) * SIMPLEX_INV768);
    }
    let q = floor((sum + 0.5lf) * SIMPLEX_THIRD);
    let r = sum - 3.0lf * q;
    let skew = (r + f.x + f.y + f.z) * SIMPLEX_THIRD;
    let l = vec3<f64>(floor(f.x + skew), floor(f.y + skew), floor(f.z + skew));
    let unskew = (r + l.x + l.y + l.z) * SIMPLEX_SIXTH;
    let offset = vec3<f64>(f.x - l.x + unskew, f.y - l.y + unskew, f.z - l.z + unskew);
    var at: SimplexLocated;
    at.cell = vec3<f64>(c.x + q + l.x, c.y + q + l.y, c.z + q + l.z);
    at.offset = offset;
    at.comparisons = 4u * u32(offset.x >= offset.y) + 2u * u32(offset.y >= offset.z)
        + u32(offset.x >= offset.z);
    return at;
}

// `locate` for a finite point.
fn simplex_locate(p: vec3<f64>) -> SimplexLocated {
    let x = simplex_cell768(p.x);
    let y = simplex_cell768(p.y);
    let z = simplex_cell768(p.z);
    return simplex_locate_from(vec3<f64>(x.x, y.x, z.x), vec3<f64>(x.y, y.y, z.y), true);
}

// Vertex k (0..8) of `vertices(ORDERS[order])` as an offset from the cell's base vertex.
fn simplex_vertex(k: u32, comparisons: u32) -> vec3<i32> {
    let fa = (SIMPLEX_FIRST_AXIS >> (2u * comparisons)) & 3u;
    let la = (SIMPLEX_LAST_AXIS >> (2u * comparisons)) & 3u;
    let first = vec3<i32>(vec3<u32>(0u, 1u, 2u) == vec3<u32>(fa));
    let last = vec3<i32>(vec3<u32>(0u, 1u, 2u) == vec3<u32>(la));
    let one = vec3<i32>(1);
    switch k {
        case 0u: { return vec3<i32>(0); }
        case 1u: { return first; }              // v1 = e_a
        case 2u: { return one - last; }         // v2 = e_a + e_b
        case 3u: { return one; }                // v3
        case 4u: { return first + one; }        // v1 + v3 - v0
        case 5u: { return one - first - last; } // v0 + v2 - v1
        case 6u: { return first + last; }       // v1 + v3 - v2
        default: { return -last; }              // v0 + v2 - v3
    }
}

// `hash`: Ebert-style, from the vertex indices mod 256.
fn simplex_hash(t: u32, i: u32, j: u32, k: u32) -> u32 {
    let pk = perm_at(t, k & 255u);
    let pj = perm_at(t, (j & 255u) + pk);
    return perm_at(t, (i & 255u) + pj);
}

// The vertices a point reaches: its offset (f32) and the eight vertices with their hashes.
struct SimplexReach {
    x0: vec3<f32>,
    v: array<vec3<i32>, 8>,
    h: array<u32, 8>,
}

// `reach` for a finite point.
fn simplex_reach(t: u32, p: vec3<f64>) -> SimplexReach {
    let at = simplex_locate(p);
    var re: SimplexReach;
    re.x0 = vec3<f32>(f32(at.offset.x), f32(at.offset.y), f32(at.offset.z));
    // Small non-negative integers (below 2^11).
    let cell = vec3<i32>(i32(at.cell.x), i32(at.cell.y), i32(at.cell.z));
    for (var k = 0u; k < 8u; k = k + 1u) {
        let v = simplex_vertex(k, at.comparisons);
        let i = (cell + v) & vec3<i32>(255);
        re.v[k] = v;
        re.h[k] = simplex_hash(t, u32(i.x), u32(i.y), u32(i.z));
    }
    return re;
}

// x rem_euclid m for integers |x| < 2^52 (as f64) within a few m of [0, m).
fn simplex_rem_euclid(x: f64, m: f64) -> f64 {
    var r = x - m * floor(x / m);
    if (r < 0.0lf) {
        r = r + m;
    }
    if (r >= m) {
        r = r - m;
    }
    return r;
}

// Whether a period (whole cells as f64, 0 = none) takes the tiled path: non-zero and a
// multiple of 3.
fn simplex_period_ok(period: f64) -> bool {
    if (period == 0.0lf) {
        return false;
    }
    return simplex_mod_small(period, 3.0lf, SIMPLEX_THIRD) == 0.0lf;
}

// `reach_periodic` for a finite point.
fn simplex_reach_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> SimplexReach {
    let q = reduce3(p, period).p;
    if (!simplex_period_ok(period.x) || !simplex_period_ok(period.y) || !simplex_period_ok(period.z)) {
        return simplex_reach(t, q);
    }
    // Full cell indices: the reduced coordinates lie in [0, P).
    let c = floor(q);
    let at = simplex_locate_from(c, q - c, false);
    var re: SimplexReach;
    re.x0 = vec3<f32>(f32(at.offset.x), f32(at.offset.y), f32(at.offset.z));
    let m = 6.0lf * period;
    for (var k = 0u; k < 8u; k = k + 1u) {
        let v = simplex_vertex(k, at.comparisons);
        // The vertex's unskewed position times 6, reduced mod 6P, turned back into an index.
        let vertex = at.cell + vec3<f64>(v);
        let s = vertex.x + vertex.y + vertex.z;
        let u = vec3<f64>(
            simplex_rem_euclid(6.0lf * vertex.x - s, m.x),
            simplex_rem_euclid(6.0lf * vertex.y - s, m.y),
            simplex_rem_euclid(6.0lf * vertex.z - s, m.z),
        );
        // (u0 + u1 + u2) / 3 and (u + s) / 6: exact integer divisions of non-negative integers.
        let s3 = floor((u.x + u.y + u.z + 0.5lf) * SIMPLEX_THIRD);
        let w = floor((u + vec3<f64>(s3) + vec3<f64>(0.5lf)) * SIMPLEX_SIXTH);
        // w mod 256 (exact: w - 256 floor(w / 256)).
        let w256 = w - 256.0lf * floor(w * SIMPLEX_INV256);
        re.v[k] = v;
        re.h[k] = simplex_hash(t, u32(w256.x), u32(w256.y), u32(w256.z));
    }
    return re;
}

// `gradient(h)`: GRADIENTS[h % 12], the 12 cube-edge vectors.
fn simplex_gradient(h: u32) -> vec3<f32> {
    let i = h % 12u;
    let a = select(1.0, -1.0, (i & 1u) != 0u);
    let b = select(1.0, -1.0, (i & 2u) != 0u);
    if (i < 4u) {
        return vec3<f32>(a, b, 0.0);
    }
    if (i < 8u) {
        return vec3<f32>(a, 0.0, b);
    }
    return vec3<f32>(0.0, a, b);
}

// `d` of `term_with`: (x0 - v) + g per axis.
fn simplex_d(x0: vec3<f32>, v: vec3<i32>) -> vec3<f32> {
    let g = SIMPLEX_UNSKEW[v.x + v.y + v.z + 1];
    let vf = vec3<f32>(v);
    return vec3<f32>(x0.x - vf.x + g, x0.y - vf.y + g, x0.z - vf.z + g);
}

// `sum`: the terms `(max(0.6 - r², 0))⁴ (g · d)` summed in vertex order, scaled.
fn simplex_sum(re: SimplexReach) -> f32 {
    var sum = 0.0;
    for (var k = 0u; k < 8u; k = k + 1u) {
        let d = simplex_d(re.x0, re.v[k]);
        let grad = simplex_gradient(re.h[k]);
        var t = SIMPLEX_RADIUS2 - (d.x * d.x + d.y * d.y + d.z * d.z);
        t = select(0.0, t, t > 0.0);
        let dot = grad.x * d.x + grad.y * d.y + grad.z * d.z;
        let t2 = t * t;
        sum = sum + t2 * t2 * dot;
    }
    return SIMPLEX_SCALE * sum;
}

// `sum_grad`: (gradient, value) as xyz, w.
fn simplex_sum_grad(re: SimplexReach) -> vec4<f32> {
    var sum = 0.0;
    var g = vec3<f32>(0.0);
    for (var k = 0u; k < 8u; k = k + 1u) {
        let d = simplex_d(re.x0, re.v[k]);
        let grad = simplex_gradient(re.h[k]);
        var t = SIMPLEX_RADIUS2 - (d.x * d.x + d.y * d.y + d.z * d.z);
        t = select(0.0, t, t > 0.0);
        let dot = grad.x * d.x + grad.y * d.y + grad.z * d.z;
        let t2 = t * t;
        let t4 = t2 * t2;
        sum = sum + t4 * dot;
        let kk = -8.0 * (t2 * t) * dot;
        g = vec3<f32>(g.x + (t4 * grad.x + kk * d.x), g.y + (t4 * grad.y + kk * d.y),
            g.z + (t4 * grad.z + kk * d.z));
    }
    return vec4<f32>(SIMPLEX_SCALE * g.x, SIMPLEX_SCALE * g.y, SIMPLEX_SCALE * g.z, SIMPLEX_SCALE * sum);
}

// ---- The basis -------------------------------------------------------------------------------

fn simplex_sample(t: u32, p: vec3<f64>) -> f32 {
    if (!simplex_finite3(p)) {
        return simplex_nan();
    }
    return simplex_sum(simplex_reach(t, p));
}

// period: whole cells per axis (0 = none on that axis). Tiles only where every axis has a
// period that is a multiple of 3 (the checker ensures it); otherwise, as on the CPU, the noise
// at the reduced point.
fn simplex_sample_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> f32 {
    if (!simplex_finite3(p)) {
        return simplex_nan();
    }
    return simplex_sum(simplex_reach_periodic(t, p, period));
}

// xyz: d noise / d p, w: the value.
fn simplex_grad(t: u32, p: vec3<f64>) -> vec4<f32> {
    if (!simplex_finite3(p)) {
        return vec4<f32>(simplex_nan());
    }
    return simplex_sum_grad(simplex_reach(t, p));
}

fn simplex_grad_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> vec4<f32> {
    if (!simplex_finite3(p)) {
        return vec4<f32>(simplex_nan());
    }
    return simplex_sum_grad(simplex_reach_periodic(t, p, period));
}
