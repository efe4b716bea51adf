// lattice_grad.wgsl: analytic gradients of the lattice noise bases (Perlin, Gradient, Value
// linear / smooth, White) and the fractal-sum gradient accumulator: the GPU form of
// noise/derivative.rs, noise/perlin.rs `interior_grad`, noise/gradient.rs `interior_grad`,
// noise/value.rs `interior_grad` and the `LatticeKernel` blanket `sample_grad(_periodic)` of
// noise/mod.rs. Concatenated after common.wgsl (tables, `lattice3`, `reduce3`, `upper_index`).
//
// Every `*_grad` returns vec4<f32>: xyz = the gradient `NoiseKernel::sample_grad` returns (with
// respect to the point), w = the value (`sample`'s bits), both NaN canonical. The f32 arithmetic
// mirrors the Rust f32 path operation for operation (the same association, the same `±0`
// additions); f64 only in the cell split (common.wgsl) and where the Rust works in f64 (the
// fractal accumulator's `amplitude · freq`).
//
// Private helpers are prefixed `lg_`.

// ---- NaN and small helpers ----------------------------------------------------------------------

// NaN test on the bits (independent of how a driver treats float compares of NaN).
fn lg_is_nan(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7fffffffu) > 0x7f800000u;
}

// Rust's `f32::NAN` (0x7fc00000), the one canonical NaN. Through a `var` so that it is never a
// constant expression (a const-expression evaluating to NaN is a WGSL shader-creation error).
fn lg_nan() -> f32 {
    var bits = 0x7fc00000u;
    return bitcast<f32>(bits);
}

// `canonical_nan` (noise/mod.rs).
fn lg_canon(v: f32) -> f32 {
    return select(v, lg_nan(), lg_is_nan(v));
}

// `canonical_grad` (derivative.rs).
fn lg_canon3(g: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(lg_canon(g.x), lg_canon(g.y), lg_canon(g.z));
}

// `lerp` (lattice.rs): a + t (b - a).
fn lg_lerp(t: f32, a: f32, b: f32) -> f32 {
    return a + t * (b - a);
}

// `lerp` on vec3 corners with one scalar weight (per component the same operations).
fn lg_lerp3(t: f32, a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return a + t * (b - a);
}

// `Real::max_nan(v, 0)` / `Real::min_nan(v, 1)` as used by the accumulator.
fn lg_max_nan(a: f32, b: f32) -> f32 {
    if (lg_is_nan(a) || lg_is_nan(b)) {
        return lg_nan();
    }
    return select(a, b, b > a);
}

fn lg_min_nan(a: f32, b: f32) -> f32 {
    if (lg_is_nan(a) || lg_is_nan(b)) {
        return lg_nan();
    }
    return select(a, b, b < a);
}

// `sign` (derivative.rs): 1, -1, 0 for ±0, NaN for NaN.
fn lg_sign(v: f32) -> f32 {
    if (lg_is_nan(v)) {
        return lg_nan();
    }
    if (v > 0.0) {
        return 1.0;
    }
    if (v < 0.0) {
        return -1.0;
    }
    return 0.0;
}

// a / b correctly rounded: the quotient in f64 rounded once to f32. (53 >= 2 * 24 + 2, so the
// double rounding is innocuous and this is exactly the IEEE f32 division the CPU does; a plain
// f32 `/` in WGSL/Vulkan is only required to be within 2.5 ulp.)
fn lg_div(a: f32, b: f32) -> f32 {
    return f32(f64(a) / f64(b));
}

// `f32::powf` for the ridge (>= 0, -0, or NaN) with IEEE 754 `pow`'s special values, so that
// the cases the CPU gets exactly (e = 0, x = 1, x = ±0, e = 1, e = 2) come out the same. WGSL
// `pow` is only `exp2(e · log2(x))` in accuracy (not libm's powf), and undefined for x <= 0.
// e = 2 (the Ridged node's default sharpness) is computed as x · x, the correctly rounded square;
// glibc's powf(x, 2) is within 0.82 ulp, so the two agree but for rare last-bit ties.
fn lg_powf(x: f32, e: f32) -> f32 {
    if (e == 0.0 || x == 1.0) {
        return 1.0;
    }
    if (lg_is_nan(x) || lg_is_nan(e)) {
        return lg_nan();
    }
    if (e == 1.0) {
        return x;
    }
    if (e == 2.0) {
        return x * x;
    }
    let integral = floor(e) == e;
    let odd = integral && (e - 2.0 * floor(e * 0.5)) == 1.0;
    if (x == 0.0) {
        // ±0: e > 0 gives ±0 for odd integers (the sign kept), else +0; e < 0 gives ±inf.
        if (e > 0.0) {
            return select(0.0, x, odd);
        }
        // 1 / ±0 built from the bits (a GPU division by 0 need not give inf).
        var inf_bits = 0x7f800000u;
        let sign_bit = select(0u, bitcast<u32>(x) & 0x80000000u, odd);
        return bitcast<f32>(inf_bits | sign_bit);
    }
    if (x < 0.0) {
        // Not reached by the ridge (max(·, 0)); IEEE pow of a negative base.
        if (!integral) {
            return lg_nan();
        }
        let m = pow(-x, e);
        return select(m, -m, odd);
    }
    return pow(x, e);
}

// ---- Lattice blend pieces (derivative.rs) --------------------------------------------------------

// `blend_slopes`: the weight-slope part of the gradient of the trilinear blend of `h`
// (corner [dx + 2 dy + 4 dz]) with weights `s` of slopes `ds`.
fn lg_blend_slopes(h: array<f32, 8>, s: vec3<f32>, ds: vec3<f32>) -> vec3<f32> {
    let u = s.x;
    let v = s.y;
    let w = s.z;
    let x01 = lg_lerp(u, h[0], h[1]);
    let x23 = lg_lerp(u, h[2], h[3]);
    let x45 = lg_lerp(u, h[4], h[5]);
    let x67 = lg_lerp(u, h[6], h[7]);
    let y0 = lg_lerp(v, x01, x23);
    let y1 = lg_lerp(v, x45, x67);
    let dx = lg_lerp(
        w,
        lg_lerp(v, h[1] - h[0], h[3] - h[2]),
        lg_lerp(v, h[5] - h[4], h[7] - h[6]),
    );
    return vec3<f32>(
        ds.x * dx,
        ds.y * lg_lerp(w, x23 - x01, x67 - x45),
        ds.z * (y1 - y0),
    );
}

// `trilerp`: the blend in the lattice bases' lerp order (x, then y, then z). It is also each
// basis' `interior` value: Perlin's, Gradient's and Value's lerp chains are exactly this.
fn lg_trilerp(s: vec3<f32>, h: array<f32, 8>) -> f32 {
    return lg_lerp(
        s.z,
        lg_lerp(s.y, lg_lerp(s.x, h[0], h[1]), lg_lerp(s.x, h[2], h[3])),
        lg_lerp(s.y, lg_lerp(s.x, h[4], h[5]), lg_lerp(s.x, h[6], h[7])),
    );
}

// `trilerp` of vec3 corners (per component the scalar one).
fn lg_trilerp3(s: vec3<f32>, g: array<vec3<f32>, 8>) -> vec3<f32> {
    return lg_lerp3(
        s.z,
        lg_lerp3(s.y, lg_lerp3(s.x, g[0], g[1]), lg_lerp3(s.x, g[2], g[3])),
        lg_lerp3(s.y, lg_lerp3(s.x, g[4], g[5]), lg_lerp3(s.x, g[6], g[7])),
    );
}

// `corner_weights`: W_c = (u or 1 - u) · yz[c >> 1], yz = [v0 w0, v w0, v0 w, v w].
fn lg_corner_weights(s: vec3<f32>) -> array<f32, 8> {
    let u = s.x;
    let v = s.y;
    let w = s.z;
    let u0 = 1.0 - u;
    let v0 = 1.0 - v;
    let w0 = 1.0 - w;
    let yz0 = v0 * w0;
    let yz1 = v * w0;
    let yz2 = v0 * w;
    let yz3 = v * w;
    return array<f32, 8>(
        u0 * yz0, u * yz0,
        u0 * yz1, u * yz1,
        u0 * yz2, u * yz2,
        u0 * yz3, u * yz3,
    );
}

// ---- Corner hashes (lattice.rs `corner_hashes_wrapped`) ------------------------------------------
// The eight hashes, corner [dx + 2 dy + 4 dz], from the lower and upper corner index per axis
// (each mod 256). With hi = (lo + 1) & 255 these are exactly `perlin::hashes_paired` /
// `lattice::corner_hashes(_paired)` (the permutation is doubled, so p[i + 1 + v] and
// p[((i + 1) & 255) + v] agree), so the untiled and tiled paths share them.

// Perlin's order: p[p[p[x] + y] + z].
fn lg_hashes_perlin(t: u32, lo: vec3<u32>, hi: vec3<u32>) -> array<u32, 8> {
    let px0 = perm_at(t, lo.x);
    let px1 = perm_at(t, hi.x);
    let p00 = perm_at(t, px0 + lo.y); // p[A]
    let p01 = perm_at(t, px0 + hi.y); // p[A + 1]
    let p10 = perm_at(t, px1 + lo.y); // p[B]
    let p11 = perm_at(t, px1 + hi.y); // p[B + 1]
    return array<u32, 8>(
        perm_at(t, p00 + lo.z), // AA
        perm_at(t, p10 + lo.z), // BA
        perm_at(t, p01 + lo.z), // AB
        perm_at(t, p11 + lo.z), // BB
        perm_at(t, p00 + hi.z),
        perm_at(t, p10 + hi.z),
        perm_at(t, p01 + hi.z),
        perm_at(t, p11 + hi.z),
    );
}

// Ebert's order (Gradient, Value, White): perm[x + perm[y + perm[z]]].
fn lg_hashes_ebert(t: u32, lo: vec3<u32>, hi: vec3<u32>) -> array<u32, 8> {
    let pz0 = perm_at(t, lo.z);
    let pz1 = perm_at(t, hi.z);
    let p00 = perm_at(t, lo.y + pz0);
    let p10 = perm_at(t, hi.y + pz0);
    let p01 = perm_at(t, lo.y + pz1);
    let p11 = perm_at(t, hi.y + pz1);
    return array<u32, 8>(
        perm_at(t, lo.x + p00),
        perm_at(t, hi.x + p00),
        perm_at(t, lo.x + p10),
        perm_at(t, hi.x + p10),
        perm_at(t, lo.x + p01),
        perm_at(t, hi.x + p01),
        perm_at(t, lo.x + p11),
        perm_at(t, hi.x + p11),
    );
}

// The reduced point and the axes whose upper corner wraps. common.wgsl's `reduce3` reports an
// axis with period 0 ("no period") as wrapping (its `c mod P` is -1 and -1 + 1 == 0), which the
// Rust `reduce3` does not (`c != u64::MAX`): masked here.
fn lg_wrap(r: Reduced, period: vec3<f64>) -> vec3<bool> {
    return r.wrap & (period != vec3<f64>(0.0lf));
}

// ---- Perlin (perlin.rs) ----------------------------------------------------------------------------

// `fade`: t^3 (t (6t - 15) + 10) in the reference's association.
fn lg_fade(t: f32) -> f32 {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

// `fade_slope`: 30 (t (t - 1))^2.
fn lg_fade_slope(t: f32, t1: f32) -> f32 {
    let a = t * t1;
    return 30.0 * (a * a);
}

// `grad_select`: ±u ± v as one addition (u - v for the negated v, which IEEE defines equal).
fn lg_perlin_corner(h: u32, x: f32, y: f32, z: f32) -> f32 {
    let u0 = select(y, x, (h & 8u) == 0u);
    let v = select(select(z, x, (h & 13u) == 12u), y, (h & 12u) == 0u);
    let u = select(u0, -u0, (h & 1u) == 1u);
    return select(u + v, u - v, (h & 2u) == 2u);
}

// `grad_vector`: weight times the gradient of `lg_perlin_corner`'s ±u ± v.
fn lg_perlin_vector(h: u32, weight: f32) -> vec3<f32> {
    let wu = select(weight, -weight, (h & 1u) == 1u);
    let wv = select(weight, -weight, (h & 2u) == 2u);
    let u_x = (h & 8u) == 0u;
    let v_y = (h & 12u) == 0u;
    let v_x = (h & 13u) == 12u;
    let v_z = !v_y && !v_x;
    return vec3<f32>(
        select(0.0, wu, u_x) + select(0.0, wv, v_x),
        select(0.0, wu, !u_x) + select(0.0, wv, v_y),
        select(0.0, wv, v_z),
    );
}

// `perlin::interior_grad` (VALUE) plus the kernel's canonical NaN.
fn lg_perlin_interior(h: array<u32, 8>, f: vec3<f32>) -> vec4<f32> {
    let x = f.x;
    let y = f.y;
    let z = f.z;
    let x1 = x - 1.0;
    let y1 = y - 1.0;
    let z1 = z - 1.0;
    let corners = array<f32, 8>(
        lg_perlin_corner(h[0], x, y, z),
        lg_perlin_corner(h[1], x1, y, z),
        lg_perlin_corner(h[2], x, y1, z),
        lg_perlin_corner(h[3], x1, y1, z),
        lg_perlin_corner(h[4], x, y, z1),
        lg_perlin_corner(h[5], x1, y, z1),
        lg_perlin_corner(h[6], x, y1, z1),
        lg_perlin_corner(h[7], x1, y1, z1),
    );
    let s = vec3<f32>(lg_fade(x), lg_fade(y), lg_fade(z));
    let ds = vec3<f32>(lg_fade_slope(x, x1), lg_fade_slope(y, y1), lg_fade_slope(z, z1));
    let value = lg_trilerp(s, corners);
    let slopes = lg_blend_slopes(corners, s, ds);
    let weights = lg_corner_weights(s);
    var g = vec3<f32>(0.0);
    for (var c = 0u; c < 8u; c = c + 1u) {
        g = g + lg_perlin_vector(h[c], weights[c]);
    }
    return vec4<f32>(lg_canon3(g + slopes), lg_canon(value));
}

fn lg_perlin_at(t: u32, q: vec3<f64>, wrap: vec3<bool>) -> vec4<f32> {
    let s = lattice3(q);
    let h = lg_hashes_perlin(t, s.index, upper_index(s, wrap));
    return lg_perlin_interior(h, s.frac);
}

fn perlin_grad(t: u32, p: vec3<f64>) -> vec4<f32> {
    return lg_perlin_at(t, p, vec3<bool>(false));
}

fn perlin_grad_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> vec4<f32> {
    let r = reduce3(p, period);
    return lg_perlin_at(t, r.p, lg_wrap(r, period));
}

// ---- Gradient (gradient.rs) --------------------------------------------------------------------------

// `smoothstep`: t t (3 - 2t), and its slope `6 t (1 - t)` (per component).
fn lg_smoothstep3(t: vec3<f32>) -> vec3<f32> {
    return t * t * (3.0 - 2.0 * t);
}

fn lg_smoothstep_slope3(t: vec3<f32>) -> vec3<f32> {
    return 6.0 * t * (1.0 - t);
}

// Ebert's `glattice` dot product, in its order (no `dot` builtin, which may reassociate).
fn lg_gdot(g: vec3<f32>, x: f32, y: f32, z: f32) -> f32 {
    return g.x * x + g.y * y + g.z * z;
}

// `gradient::interior_grad` (VALUE) plus the kernel's canonical NaN.
fn lg_gradient_interior(t: u32, h: array<u32, 8>, f: vec3<f32>) -> vec4<f32> {
    let f1 = f - vec3<f32>(1.0);
    let g = array<vec3<f32>, 8>(
        grad_at(t, h[0]), grad_at(t, h[1]), grad_at(t, h[2]), grad_at(t, h[3]),
        grad_at(t, h[4]), grad_at(t, h[5]), grad_at(t, h[6]), grad_at(t, h[7]),
    );
    let corners = array<f32, 8>(
        lg_gdot(g[0], f.x, f.y, f.z),
        lg_gdot(g[1], f1.x, f.y, f.z),
        lg_gdot(g[2], f.x, f1.y, f.z),
        lg_gdot(g[3], f1.x, f1.y, f.z),
        lg_gdot(g[4], f.x, f.y, f1.z),
        lg_gdot(g[5], f1.x, f.y, f1.z),
        lg_gdot(g[6], f.x, f1.y, f1.z),
        lg_gdot(g[7], f1.x, f1.y, f1.z),
    );
    let s = lg_smoothstep3(f);
    let ds = lg_smoothstep_slope3(f);
    let value = lg_trilerp(s, corners);
    let slopes = lg_blend_slopes(corners, s, ds);
    let grad = lg_trilerp3(s, g) + slopes;
    return vec4<f32>(lg_canon3(grad), lg_canon(value));
}

fn lg_gradient_at(t: u32, q: vec3<f64>, wrap: vec3<bool>) -> vec4<f32> {
    let s = lattice3(q);
    let h = lg_hashes_ebert(t, s.index, upper_index(s, wrap));
    return lg_gradient_interior(t, h, s.frac);
}

fn gradient_grad(t: u32, p: vec3<f64>) -> vec4<f32> {
    return lg_gradient_at(t, p, vec3<bool>(false));
}

fn gradient_grad_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> vec4<f32> {
    let r = reduce3(p, period);
    return lg_gradient_at(t, r.p, lg_wrap(r, period));
}

// ---- Value (value.rs) --------------------------------------------------------------------------------

// `value::interior_grad` (VALUE) plus the kernel's canonical NaN; `smooth` picks smoothstep
// weights (slope 6t(1 - t)), else linear weights (slope 1).
fn lg_value_interior(t: u32, h: array<u32, 8>, f: vec3<f32>, is_smooth: bool) -> vec4<f32> {
    let corners = array<f32, 8>(
        value_at(t, h[0]), value_at(t, h[1]), value_at(t, h[2]), value_at(t, h[3]),
        value_at(t, h[4]), value_at(t, h[5]), value_at(t, h[6]), value_at(t, h[7]),
    );
    var w = f;
    var ds = vec3<f32>(1.0);
    if (is_smooth) {
        w = lg_smoothstep3(f);
        ds = lg_smoothstep_slope3(f);
    }
    let value = lg_trilerp(w, corners);
    var g = lg_blend_slopes(corners, w, ds);
    // Linear: the slopes are the constant 1, so a NaN fraction would not reach its own axis'
    // component; the Rust makes every component NaN then.
    let bad = lg_is_nan(f.x) || lg_is_nan(f.y) || lg_is_nan(f.z);
    if (!is_smooth && bad) {
        g = vec3<f32>(lg_nan());
    }
    return vec4<f32>(lg_canon3(g), lg_canon(value));
}

fn lg_value_at(t: u32, q: vec3<f64>, wrap: vec3<bool>, is_smooth: bool) -> vec4<f32> {
    let s = lattice3(q);
    let h = lg_hashes_ebert(t, s.index, upper_index(s, wrap));
    return lg_value_interior(t, h, s.frac, is_smooth);
}

fn value_linear_grad(t: u32, p: vec3<f64>) -> vec4<f32> {
    return lg_value_at(t, p, vec3<bool>(false), false);
}

fn value_linear_grad_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> vec4<f32> {
    let r = reduce3(p, period);
    return lg_value_at(t, r.p, lg_wrap(r, period), false);
}

fn value_smooth_grad(t: u32, p: vec3<f64>) -> vec4<f32> {
    return lg_value_at(t, p, vec3<bool>(false), true);
}

fn value_smooth_grad_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> vec4<f32> {
    let r = reduce3(p, period);
    return lg_value_at(t, r.p, lg_wrap(r, period), true);
}

// ---- White (value.rs `white`, derivative.rs `white_grad`) ----------------------------------------------
// The hash value of the point's cell, gradient 0; NaN value and gradient for a non-finite
// coordinate (a coordinate is non-finite exactly when its fraction is NaN, x - floor(x)).
fn white_grad(t: u32, p: vec3<f64>) -> vec4<f32> {
    let s = lattice3(p);
    if (lg_is_nan(s.frac.x) || lg_is_nan(s.frac.y) || lg_is_nan(s.frac.z)) {
        return vec4<f32>(lg_nan());
    }
    return vec4<f32>(vec3<f32>(0.0), white_sample(t, p));
}

// The default `sample_grad_periodic`: the point reduced into its period (no neighbours).
fn white_grad_periodic(t: u32, p: vec3<f64>, period: vec3<f64>) -> vec4<f32> {
    return white_grad(t, reduce3(p, period).p);
}

// ---- The fractal gradient accumulator (derivative.rs `GradShaper`) ----------------------------------
// Per octave i: `n`, `g` = the basis value and gradient at q_i = p · f_i (the caller scales p in
// f64, as `fractal_grad_point` does), then `gshaper_add`. Style codes: 0 Fbm, 1 Turbulence,
// 2 Billow, 3 Ridged (offset, sharpness read only by Ridged).
//
// Precision of the octave constants, as in the Rust `GradShaper::add`: Fbm, Turbulence and
// Billow form the chain factor `amplitude · freq` (Billow `2 · amplitude · freq`) in F64 and
// round it to f32 once (`S::from_f64(amplitude * freq)`); Ridged rounds amplitude, freq,
// offset and sharpness to f32 separately (`S::from_f64` each) and works in f32 from there.
// `gshaper_add_f64` takes amplitude and freq as the f64 schedule values and is the exact
// mirror. `gshaper_add` (f32 amplitude and freq) widens them to f64 and forms the same product:
// bit-exact with the Rust only when the schedule's f64 amplitude and freq are representable in
// f32 (gain and lacunarity powers of two, e.g. the default lacunarity 2 with gain 0.5);
// otherwise the product is of the rounded factors (within about 1 ulp of the Rust factor).
// Ridged is exact with either form (given f32(offset), f32(sharpness) rounded from the f64
// parameters).

struct GradShaper {
    sum: vec3<f32>,
    weight: f32,
    weight_grad: vec3<f32>,
}

fn gshaper_start() -> GradShaper {
    var s: GradShaper;
    s.sum = vec3<f32>(0.0);
    s.weight = 1.0;
    s.weight_grad = vec3<f32>(0.0);
    return s;
}

fn gshaper_add_f64(
    s: GradShaper,
    style: u32,
    n: f32,
    g: vec3<f32>,
    amplitude: f64,
    freq: f64,
    offset: f32,
    sharpness: f32,
) -> GradShaper {
    var r = s;
    switch (style) {
        case 0u: {
            // Fbm: sum + S(a f) g.
            let c = f32(amplitude * freq);
            r.sum = s.sum + c * g;
        }
        case 1u: {
            // Turbulence: sum + S(a f) sign(n) g.
            let c = f32(amplitude * freq) * lg_sign(n);
            r.sum = s.sum + c * g;
        }
        case 2u: {
            // Billow: d(a (2|n| - 1)) = 2 a sign(n) dn; `2 · amplitude` is exact.
            let c = f32(2.0lf * amplitude * freq) * lg_sign(n);
            r.sum = s.sum + c * g;
        }
        default: {
            // Ridged (`add_ridged`): the value recurrence and its derivative beside it.
            let ridge = lg_max_nan(offset - abs(n), 0.0);
            let sharp = sharpness;
            let power = lg_powf(ridge, sharp);
            let signal = power * s.weight;
            // d power = sharpness · ridge^(sharpness - 1) · d ridge, d ridge = -sign(n) · f · dn
            // while ridge > 0; else 0 (a NaN n gives a NaN g, so the zero keeps the NaN).
            var slope: f32 = 0.0;
            if (!lg_is_nan(ridge) && ridge > 0.0) {
                slope = -lg_div(sharp * power, ridge) * lg_sign(n) * f32(freq);
            }
            let d_signal = slope * g * s.weight + power * s.weight_grad;
            let amp = f32(amplitude);
            r.sum = s.sum + amp * d_signal;
            let two_signal = 2.0 * signal;
            let inside = !lg_is_nan(two_signal) && two_signal > 0.0 && two_signal < 1.0;
            r.weight_grad = select(vec3<f32>(0.0), 2.0 * d_signal, inside);
            r.weight = lg_min_nan(lg_max_nan(two_signal, 0.0), 1.0);
        }
    }
    return r;
}

fn gshaper_add(
    s: GradShaper,
    style: u32,
    n: f32,
    g: vec3<f32>,
    amplitude: f32,
    freq: f32,
    offset: f32,
    sharpness: f32,
) -> GradShaper {
    return gshaper_add_f64(s, style, n, g, f64(amplitude), f64(freq), offset, sharpness);
}

// The gradient of the sum, NaN canonical.
fn gshaper_gradient(s: GradShaper) -> vec3<f32> {
    return lg_canon3(s.sum);
}
