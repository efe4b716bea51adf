// cellular.wgsl: Cellular (Worley) noise, the port of noise/cellular.rs (`search`, `finish`,
// `finish_grad`, `distance`, `distance_grad`, `ring_gap`) and of `CellularKernel`'s
// `sample`, `sample_periodic`, `sample_grad`, `sample_grad_periodic` (noise/mod.rs).
//
// Enum codes (the Rust enums' declaration order):
//   Metric::Euclidean          -> CELL_METRIC_EUCLIDEAN = 0
//   Metric::Manhattan          -> CELL_METRIC_MANHATTAN = 1
//   Metric::Chebyshev          -> CELL_METRIC_CHEBYSHEV = 2
//   CellularValue::F1          -> CELL_VALUE_F1 = 0
//   CellularValue::F2          -> CELL_VALUE_F2 = 1
//   CellularValue::F2MinusF1   -> CELL_VALUE_F2_MINUS_F1 = 2
//   CellularValue::CellValue   -> CELL_VALUE_CELL_VALUE = 3
//   CellularValue::Edge        -> CELL_VALUE_EDGE = 4
// (An out-of-range metric code acts as Chebyshev, an out-of-range value code as Edge.)
//
// The cell hash (common.wgsl, Rust's noise/hash.rs): a cell's state from the table's key and
// its exact integer coordinates, its feature point `hash_feature` (exact in f32: the jitter is
// a multiple of 1/256, so it arrives here exactly) and its value `hash_value`.
//
// Arithmetic: the cell (floor of the point) and its fraction are exact in f64; the fraction is
// rounded to f32 once (as the CPU's `S::from_f64(fx)`), and the offsets `d = (o + point) - f`
// and distances are f32 in the Rust order. The Euclidean distance is compared squared and
// rooted at the end; the root (and the Euclidean gradient's division) go through f64 so that
// the f32 result is the correctly rounded one, as on the CPU (WGSL's f32 sqrt and division
// are not correctly rounded).
//
// The search (exact for every jitter in [0, 1]): the 27 cells around the point's cell, in the
// Rust order (z outer, then y, x inner, each ascending: on equal distances the first visited
// stays the nearest), then the Chebyshev rings 2, 3, ... (in the same order, the cells of the
// ring only) while `ring_gap` says a ring could still hold a point nearer than the needed
// distance (F1, or F2 for F2 / F2-F1 / Edge). For finite input the Rust loop never visits a ring
// beyond 4: the gap of ring r is at least r - 1 (minus ~1e-6), and the needed distance is at
// most the F2 bound of `Cellular::range` (Euclidean sqrt(4.25), Manhattan 3.5, Chebyshev 1.5),
// so ring 5's check always stops it (Manhattan F2 may reach ring 4, Euclidean ring 3,
// Chebyshev ring 2). CELLULAR_MAX_RING = 4 is that cap.

const CELL_METRIC_EUCLIDEAN: u32 = 0u;
const CELL_METRIC_MANHATTAN: u32 = 1u;
const CELL_METRIC_CHEBYSHEV: u32 = 2u;

const CELL_VALUE_F1: u32 = 0u;
const CELL_VALUE_F2: u32 = 1u;
const CELL_VALUE_F2_MINUS_F1: u32 = 2u;
const CELL_VALUE_CELL_VALUE: u32 = 3u;
const CELL_VALUE_EDGE: u32 = 4u;

// The largest ring the Rust search can visit for finite input (see above).
const CELLULAR_MAX_RING: i32 = 4;

// The largest finite f32: the "no point yet" distance (Rust starts at +inf; every distance
// here is below 100, and 27 cells are always visited, so no result can differ).
const CELLULAR_FAR: f32 = 3.4028234663852886e38;

// The two nearest distances so far (in `cellular_distance`'s form: squared for Euclidean), the
// hash state of the nearest point's cell, and the offsets `feature - p` of the nearest (d1) and
// second nearest (d2) points (Rust's `Nearest` and the tracked `offsets`).
struct CellularBest {
    f1: f32,
    f2: f32,
    cell: vec2<u32>,
    d1: vec3<f32>,
    d2: vec3<f32>,
}

// The search's result: `nan` for non-finite input (Rust's `None`).
struct CellularSearch {
    best: CellularBest,
    nan: bool,
}

// A quiet NaN made at run time (0x7fc00000; `zero` is any f32, only to keep this out of
// constant evaluation).
fn cellular_nan(zero: f32) -> f32 {
    return bitcast<f32>((bitcast<u32>(zero) & 0u) | 0x7fc00000u);
}

fn cellular_is_nan3(v: vec3<f32>) -> bool {
    return any((bitcast<vec3<u32>>(v) & vec3<u32>(0x7fffffffu)) > vec3<u32>(0x7f800000u));
}

// sign(v) as `derivative::sign`: 1, -1, and +0 for ±0 (NaN cannot reach here).
fn cellular_sign(v: f32) -> f32 {
    if (v > 0.0) {
        return 1.0;
    }
    if (v < 0.0) {
        return -1.0;
    }
    return 0.0;
}

// sqrt(v) correctly rounded to f32 (the CPU's `f32::sqrt`): the f64 root rounded once (a double
// rounding that is innocuous for sqrt, 53 >= 2 * 24 + 2).
fn cellular_sqrt(v: f32) -> f32 {
    return f32(sqrt(f64(v)));
}

// A neighbour's cell, absorbed into the hash state `s`: untiled (`period` 0) the cell index
// `c` plus `o` as Rust's `i64::wrapping_add` (on the two words, with the carry, so it stays
// exact beyond 2^53); tiled, `(c + o) mod period` (c = floor of the reduced coordinate, exact
// in f64: all integers below 2^53; Rust `(c + o).rem_euclid(P)`).
fn cellular_absorb(s: vec2<u32>, c: f64, period: f64, o: i32) -> vec2<u32> {
    if (period == 0.0lf) {
        let w = cell_words(c);
        let lo = w.x + bitcast<u32>(o);
        let carry = select(0u, 1u, lo < w.x);
        let hi = w.y + select(0u, 0xffffffffu, o < 0) + carry;
        return pcg2d(s ^ vec2<u32>(lo, hi));
    }
    let x = c + f64(o);
    var m = x - period * floor(x / period);
    if (m < 0.0lf) {
        m = m + period;
    }
    if (m >= period) {
        m = m - period;
    }
    return hash_absorb(s, m);
}

// Rust `distance`: squared Euclidean, Manhattan, Chebyshev (the first of equal maxima).
fn cellular_distance(metric: u32, d: vec3<f32>) -> f32 {
    if (metric == CELL_METRIC_EUCLIDEAN) {
        return d.x * d.x + d.y * d.y + d.z * d.z;
    }
    if (metric == CELL_METRIC_MANHATTAN) {
        return abs(d.x) + abs(d.y) + abs(d.z);
    }
    return max(max(abs(d.x), abs(d.y)), abs(d.z));
}

// Rust's `visit` closure for the cell of hash state `h` at offset `o` from the point's cell
// (`fr` the point's f32 fractions).
fn cellular_visit(b: CellularBest, h: vec2<u32>, o: vec3<i32>, fr: vec3<f32>, metric: u32, jitter: f32) -> CellularBest {
    let point = hash_feature(h, jitter);
    let d = (vec3<f32>(o) + point) - fr;
    let dist = cellular_distance(metric, d);
    var r = b;
    if (dist < r.f1) {
        r.f2 = r.f1;
        r.f1 = dist;
        r.cell = h;
        r.d2 = r.d1;
        r.d1 = d;
    } else if (dist < r.f2) {
        r.f2 = dist;
        r.d2 = d;
    }
    return r;
}

// Rust `ring_gap` (in f64 from the f64 fractions `fd`, then rounded to f32 once), made a little
// smaller so that it is never above the CPU's: the jitter arrives rounded to f32 (off by at
// most 2^-25 from the CPU's f64 jitter), so the band [lo, hi] is widened by 2^-24 each side;
// and WGSL allows an f64 -> f32 conversion to round either way (the CPU rounds to nearest), so
// 2^-20 more comes off (> 1.5 ulp of f32 below 4). A gap never above the CPU's means every ring
// the CPU visits is visited here; a ring visited here beyond the CPU's last one cannot change
// the result (its gap already covers the needed distance, by the CPU's own bound). The extra
// margin (about 1e-6, as the CPU's own) keeps ring 5 out of reach (its gap stays above 3.99).
fn cellular_ring_gap(ring: i32, jitter: f32, fd: vec3<f64>) -> f32 {
    let j = clamp(f64(jitter), 0.0lf, 1.0lf);
    let eps = 5.9604644775390625e-8lf; // 2^-24
    let lo = 0.5lf - j / 2.0lf - eps;
    let hi = 0.5lf + j / 2.0lf + eps;
    let r = f64(ring);
    let g = min(min(min(r + lo - fd.x, fd.x + r - hi), min(r + lo - fd.y, fd.y + r - hi)),
                min(r + lo - fd.z, fd.z + r - hi));
    return f32(g * (1.0lf - 1e-6lf) - 1e-6lf - 9.5367431640625e-7lf); // 2^-20
}

// Rust `search` (with `TRACK`): `q` the (already reduced, when tiled) point, `period` per axis
// in cells (0: untiled axis).
fn cellular_search(t: u32, q: vec3<f64>, period: vec3<f64>, metric: u32, value: u32, jitter: f32) -> CellularSearch {
    var out: CellularSearch;
    let s = lattice3(q);
    let c = floor(q);
    let fd = q - c;
    let fr = s.frac;
    out.nan = cellular_is_nan3(fr);
    out.best.f1 = CELLULAR_FAR;
    out.best.f2 = CELLULAR_FAR;
    out.best.cell = vec2<u32>(0u);
    out.best.d1 = vec3<f32>(0.0);
    out.best.d2 = vec3<f32>(0.0);
    if (out.nan) {
        return out;
    }
    var best = out.best;

    // The 27 cells, z outer, y, x inner (the hash's inner steps shared by a row).
    let key = hash_key(t);
    for (var dz = -1; dz <= 1; dz = dz + 1) {
        let sz = cellular_absorb(key, c.z, period.z, dz);
        for (var dy = -1; dy <= 1; dy = dy + 1) {
            let syz = cellular_absorb(sz, c.y, period.y, dy);
            for (var dx = -1; dx <= 1; dx = dx + 1) {
                let h = cellular_absorb(syz, c.x, period.x, dx);
                best = cellular_visit(best, h, vec3<i32>(dx, dy, dz), fr, metric, jitter);
            }
        }
    }

    // The rings, while one could hold a nearer point than the needed distance.
    let uses_f2 = !(value == CELL_VALUE_F1 || value == CELL_VALUE_CELL_VALUE);
    for (var ring = 2; ring <= CELLULAR_MAX_RING; ring = ring + 1) {
        let needed = select(best.f1, best.f2, uses_f2);
        var gap = cellular_ring_gap(ring, jitter, fd);
        if (metric == CELL_METRIC_EUCLIDEAN) {
            gap = gap * gap;
        }
        if (gap >= needed) {
            break;
        }
        // The cells at Chebyshev distance `ring`, in the order of the Rust filtered cube loop:
        // a row whose y or z offset is ±ring is all in the ring, any other only at x = ±ring.
        for (var dz = -ring; dz <= ring; dz = dz + 1) {
            let sz = cellular_absorb(key, c.z, period.z, dz);
            for (var dy = -ring; dy <= ring; dy = dy + 1) {
                let syz = cellular_absorb(sz, c.y, period.y, dy);
                let full = abs(dz) == ring || abs(dy) == ring;
                let step = select(2 * ring, 1, full);
                for (var dx = -ring; dx <= ring; dx = dx + step) {
                    let h = cellular_absorb(syz, c.x, period.x, dx);
                    best = cellular_visit(best, h, vec3<i32>(dx, dy, dz), fr, metric, jitter);
                }
            }
        }
    }
    out.best = best;
    return out;
}

// Rust `finish`: the requested value from the two nearest distances.
fn cellular_finish(t: u32, metric: u32, value: u32, b: CellularBest) -> f32 {
    if (value == CELL_VALUE_CELL_VALUE) {
        return hash_value(b.cell);
    }
    var r1 = b.f1;
    var r2 = b.f2;
    if (metric == CELL_METRIC_EUCLIDEAN) {
        r1 = cellular_sqrt(b.f1);
        r2 = cellular_sqrt(b.f2);
    }
    if (value == CELL_VALUE_F1) {
        return r1;
    }
    if (value == CELL_VALUE_F2) {
        return r2;
    }
    if (value == CELL_VALUE_F2_MINUS_F1) {
        return r2 - r1;
    }
    return (r2 - r1) * 0.5;
}

// Rust `distance_grad`: the gradient with respect to p of the distance `dist` (squared for
// Euclidean) to the feature point at offset `d = feature - p`.
fn cellular_distance_grad(metric: u32, dist: f32, d: vec3<f32>) -> vec3<f32> {
    if (metric == CELL_METRIC_EUCLIDEAN) {
        let r = cellular_sqrt(dist);
        if (r > 0.0) {
            // (-c) / r per component, correctly rounded through f64 (53 >= 2 * 24 + 2).
            let rr = f64(r);
            return vec3<f32>(f32(f64(-d.x) / rr), f32(f64(-d.y) / rr), f32(f64(-d.z) / rr));
        }
        return vec3<f32>(0.0);
    }
    if (metric == CELL_METRIC_MANHATTAN) {
        return vec3<f32>(-cellular_sign(d.x), -cellular_sign(d.y), -cellular_sign(d.z));
    }
    // Chebyshev: -sign(d_k) e_k on the axis of the largest |component|, the first of equals.
    let m = abs(d);
    var k = 0u;
    if (m.y > m.x) {
        k = 1u;
    }
    if (m.z > m[k]) {
        k = 2u;
    }
    var g = vec3<f32>(0.0);
    g[k] = -cellular_sign(d[k]);
    return g;
}

// Rust `finish_grad`.
fn cellular_finish_grad(metric: u32, value: u32, b: CellularBest) -> vec3<f32> {
    if (value == CELL_VALUE_CELL_VALUE) {
        return vec3<f32>(0.0);
    }
    if (value == CELL_VALUE_F1) {
        return cellular_distance_grad(metric, b.f1, b.d1);
    }
    let g2 = cellular_distance_grad(metric, b.f2, b.d2);
    if (value == CELL_VALUE_F2) {
        return g2;
    }
    let g1 = cellular_distance_grad(metric, b.f1, b.d1);
    if (value == CELL_VALUE_F2_MINUS_F1) {
        return g2 - g1;
    }
    return (g2 - g1) * 0.5;
}

fn cellular_value_of(t: u32, s: CellularSearch, metric: u32, value: u32) -> f32 {
    if (s.nan) {
        return cellular_nan(s.best.f1);
    }
    return cellular_finish(t, metric, value, s.best);
}

fn cellular_grad_of(t: u32, s: CellularSearch, metric: u32, value: u32) -> vec4<f32> {
    if (s.nan) {
        return vec4<f32>(cellular_nan(s.best.f1));
    }
    let g = cellular_finish_grad(metric, value, s.best);
    return vec4<f32>(g, cellular_finish(t, metric, value, s.best));
}

// ---- The basis ---------------------------------------------------------------------------------

// `CellularKernel::sample`.
fn cellular_sample(t: u32, p: vec3<f64>, metric: u32, value: u32, jitter: f32) -> f32 {
    let s = cellular_search(t, p, vec3<f64>(0.0lf), metric, value, jitter);
    return cellular_value_of(t, s, metric, value);
}

// `CellularKernel::sample_periodic`: the point reduced into its period (reduce3), the
// neighbour cells wrapped mod the period on each tiled axis (period 0: untiled axis).
fn cellular_sample_periodic(t: u32, p: vec3<f64>, period: vec3<f64>, metric: u32, value: u32, jitter: f32) -> f32 {
    let q = reduce3(p, period).p;
    let s = cellular_search(t, q, period, metric, value, jitter);
    return cellular_value_of(t, s, metric, value);
}

// `CellularKernel::sample_grad`: xyz the analytic gradient, w the value (NaN everywhere for
// non-finite input).
fn cellular_grad(t: u32, p: vec3<f64>, metric: u32, value: u32, jitter: f32) -> vec4<f32> {
    let s = cellular_search(t, p, vec3<f64>(0.0lf), metric, value, jitter);
    return cellular_grad_of(t, s, metric, value);
}

// `CellularKernel::sample_grad_periodic` (tiling is a translation per cell: the gradient at the
// reduced point).
fn cellular_grad_periodic(t: u32, p: vec3<f64>, period: vec3<f64>, metric: u32, value: u32, jitter: f32) -> vec4<f32> {
    let q = reduce3(p, period).p;
    let s = cellular_search(t, q, period, metric, value, jitter);
    return cellular_grad_of(t, s, metric, value);
}
