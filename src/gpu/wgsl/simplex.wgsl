// simplex.wgsl: the Simplex basis (noise/simplex.rs; `SimplexKernel` in noise/kernels.rs).
//
// Simplex noise on the body-centred cubic lattice (the integer and the half-integer points;
// Gustavson & McEwan's psrdnoise grid): the tetrahedron of the skewed coordinates
// (y + z, x + z, x + y) by the order of their fractions, its four vertices, each with one of the
// 12 cube-edge gradients picked by `hash % 12` of its skewed coordinates mod 256, the kernel
// (0.5 - r²)⁴ (g · d) scaled by 76.
//
// As on the CPU: each coordinate's cell mod 256 and fraction are exact in f64 (scaling by 2^-8
// is exact, so the residue is, at any magnitude), the skewed carries and the order come from
// f64 sums of fractions, each vertex's offset `frac - half / 2` is formed in f32 from the
// fraction rounded to f32 (`simplex::offset`), and the kernel sums run in f32 in the CPU's
// operation order. Non-finite input
// gives NaN (value and every gradient component).
//
// Needs common.wgsl (`perm_at`, `reduce3`).

const SIMPLEX_MAX_F64: f64 = 1.7976931348623157e308lf;
const SIMPLEX_RADIUS2: f32 = 0.5;
const SIMPLEX_SCALE: f32 = 76.0;

fn simplex_nan() -> f32 {
    return bitcast<f32>(0x7fc00000u);
}

// Finite (not NaN, not ±inf). With ordered comparisons NaN compares false.
fn simplex_finite3(p: vec3<f64>) -> bool {
    let a = abs(p);
    return a.x <= SIMPLEX_MAX_F64 && a.y <= SIMPLEX_MAX_F64 && a.z <= SIMPLEX_MAX_F64;
}

// Rust `lattice` per axis: the cell mod 256 and the fraction, both exact.
struct SimplexSplit {
    cell: vec3<i32>,
    frac: vec3<f64>,
}

fn simplex_split(p: vec3<f64>) -> SimplexSplit {
    let c = floor(p);
    let m = c - 256.0lf * floor(c * 0.00390625lf);
    var s: SimplexSplit;
    s.cell = vec3<i32>(i32(m.x), i32(m.y), i32(m.z));
    s.frac = p - c;
    return s;
}

// Rust `order`: the skewed axes of the largest and second largest fraction, ties to the lower.
fn simplex_order(s: vec3<f64>) -> vec2<u32> {
    let uv = s.x >= s.y;
    let vw = s.y >= s.z;
    let uw = s.x >= s.z;
    var first = 2u;
    if (uv && uw) {
        first = 0u;
    } else if (!uv && vw) {
        first = 1u;
    }
    var second = select(1u, 0u, uv);
    if (first == 0u) {
        second = select(2u, 1u, vw);
    } else if (first == 1u) {
        second = select(2u, 0u, uw);
    }
    return vec2<u32>(first, second);
}

// Rust `skewed_offset` plus the carries: vertex k's skewed coordinates relative to the cell's.
fn simplex_skewed(carry: vec3<i32>, order: vec2<u32>, k: u32) -> vec3<i32> {
    var o = vec3<i32>(0);
    if (k >= 1u) {
        o[order.x] = 1;
    }
    if (k >= 2u) {
        o[order.y] = 1;
    }
    if (k == 3u) {
        o = vec3<i32>(1);
    }
    return carry + o;
}

// Rust `half_offset`: twice the vertex's offset from the cell corner.
fn simplex_half(s: vec3<i32>) -> vec3<i32> {
    return vec3<i32>(-s.x + s.y + s.z, s.x - s.y + s.z, s.x + s.y - s.z);
}

// Rust `vertex_hash`: the skewed coordinates mod 256 from the doubled coordinates (all even or
// all odd, so each sum is even), then perm[i + perm[j + perm[k]]].
fn simplex_hash(t: u32, twice: vec3<i32>) -> u32 {
    let i = (bitcast<u32>(twice.y + twice.z) & 511u) >> 1u;
    let j = (bitcast<u32>(twice.x + twice.z) & 511u) >> 1u;
    let k = (bitcast<u32>(twice.x + twice.y) & 511u) >> 1u;
    return perm_at(t, i + perm_at(t, j + perm_at(t, k)));
}

// The four vertices in reach: each one's offset (point minus vertex, f32) and hash.
struct SimplexReach {
    d: array<vec3<f32>, 4>,
    h: vec4<u32>,
}

// Rust `reach` (untiled, `period` 0 on every axis) and `reach_periodic`: a tiled axis hashes
// the vertex's doubled coordinate mod twice the period, from the reduced point's exact cell.
fn simplex_reach(t: u32, q: vec3<f64>, period: vec3<f64>) -> SimplexReach {
    let s = simplex_split(q);
    let f = s.frac;
    let sums = vec3<f64>(f.y + f.z, f.x + f.z, f.x + f.y);
    let carry_f = floor(sums);
    let skewed = sums - carry_f;
    // 0, 1 or 2 (a fraction is 1.0 where a tiny negative coordinate's p - floor(p) rounds
    // up); 0 for NaN, as Rust's `locate_parts`.
    // (Booleans converted, not `select`: GLSL ES 3.00 has no integer `mix`.)
    let carry = vec3<i32>(carry_f >= vec3<f64>(1.0lf)) + vec3<i32>(carry_f >= vec3<f64>(2.0lf));
    let order = simplex_order(skewed);
    let base = floor(q);
    var re: SimplexReach;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let half = simplex_half(simplex_skewed(carry, order, k));
        var twice = 2 * s.cell + half;
        for (var a = 0u; a < 3u; a = a + 1u) {
            if (period[a] > 0.0lf) {
                let w = 2.0lf * base[a] + f64(half[a]);
                let m = 2.0lf * period[a];
                var r = w - m * floor(w / m);
                if (r < 0.0lf) {
                    r = r + m;
                }
                if (r >= m) {
                    r = r - m;
                }
                twice[a] = i32(r);
            }
        }
        re.d[k] = vec3<f32>(f) - vec3<f32>(half) * 0.5;
        re.h[k] = simplex_hash(t, twice);
    }
    return re;
}

// `gradient(h)`: GRADIENTS[h % 12], the 12 cube-edge vectors.
fn simplex_gradient(h: u32) -> vec3<f32> {
    let i = h % 12u;
    let a = select(f32(1.0), f32(-1.0), (i & 1u) != 0u);
    let b = select(f32(1.0), f32(-1.0), (i & 2u) != 0u);
    if (i < 4u) {
        return vec3<f32>(a, b, 0.0);
    }
    if (i < 8u) {
        return vec3<f32>(a, 0.0, b);
    }
    return vec3<f32>(0.0, a, b);
}

// `sum`: the terms `(max(0.5 - r², 0))⁴ (g · d)` summed in vertex order, scaled.
fn simplex_sum(re: SimplexReach) -> f32 {
    var sum: f32 = 0.0;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let d = re.d[k];
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
    var sum: f32 = 0.0;
    var g = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k = k + 1u) {
        let d = re.d[k];
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
    return simplex_sum(simplex_reach(t, p, vec3<f64>(0.0lf)));
}

// period: whole cells per axis (0 = none on that axis); every integer period tiles.
fn simplex_sample_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> f32 {
    if (!simplex_finite3(p)) {
        return simplex_nan();
    }
    return simplex_sum(simplex_reach(t, reduce3(p, period).p, period));
}

// xyz: d noise / d p, w: the value.
fn simplex_grad(t: u32, p: vec3<f64>) -> vec4<f32> {
    if (!simplex_finite3(p)) {
        return vec4<f32>(simplex_nan());
    }
    return simplex_sum_grad(simplex_reach(t, p, vec3<f64>(0.0lf)));
}

fn simplex_grad_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> vec4<f32> {
    if (!simplex_finite3(p)) {
        return vec4<f32>(simplex_nan());
    }
    return simplex_sum_grad(simplex_reach(t, reduce3(p, period).p, period));
}
