// interpreter.wgsl: the tape interpreter (`gpu/interpreter.rs`), the alternative measured
// against the generated shaders; after the library, `CHANNELS`/`Channels` and the slot sizes.
// ---- The tape interpreter (gpu/interpreter.rs: the program layout) ---------------------------
@group(0) @binding(4) var<storage, read> program: array<u32>;
@group(0) @binding(5) var<storage, read> constants: array<f64>;

const I_HEADER: u32 = 4u;
const I_STRIDE: u32 = 8u;

const I_CONST_S: u32 = 0u;
const I_CONST_V: u32 = 1u;
const I_CONST_D: u32 = 2u;
const I_POSITION: u32 = 3u;
const I_SPLAT: u32 = 4u;
const I_COMBINE: u32 = 5u;
const I_COMPONENT: u32 = 6u;
const I_UNARY_S: u32 = 7u;
const I_UNARY_V: u32 = 8u;
const I_BINARY_S: u32 = 9u;
const I_BINARY_V: u32 = 10u;
const I_TERNARY_S: u32 = 11u;
const I_TERNARY_V: u32 = 12u;
const I_DOT: u32 = 13u;
const I_LENGTH: u32 = 14u;
const I_CROSS: u32 = 15u;
const I_NORMALIZE: u32 = 16u;
const I_ROTATE_CONST: u32 = 17u;
const I_ROTATE_VARYING: u32 = 18u;
const I_NOISE: u32 = 19u;
const I_FRACTAL: u32 = 20u;
const I_NOISE_GRADIENT: u32 = 21u;
const I_FRACTAL_GRADIENT: u32 = 22u;
const I_HERMITE: u32 = 23u;
const I_RAMP: u32 = 24u;
const I_CURVE: u32 = 25u;
const I_WIDE_COMPONENT: u32 = 26u;
const I_WIDE_UNARY: u32 = 27u;
const I_WIDE_BINARY: u32 = 28u;
const I_WIDE_TERNARY: u32 = 29u;
const I_WIDE_DOT: u32 = 30u;
const I_WIDE_LENGTH: u32 = 31u;
const I_WIDE_SPLAT: u32 = 32u;
const I_WIDE_COMBINE: u32 = 33u;
const I_WIDE_ROTATE: u32 = 34u;
const I_WIDEN: u32 = 35u;
const I_NARROW: u32 = 36u;
const I_OUT_S: u32 = 37u;
const I_OUT_V: u32 = 38u;

const I_FLAG_TILED: u32 = 1u;
const I_FLAG_BIAS: u32 = 2u;
const I_FLAG_SLOPE: u32 = 4u;

fn i_const3(k: u32) -> vec3<f64> {
    return vec3<f64>(constants[k], constants[k + 1u], constants[k + 2u]);
}

// codegen's unary_f32.
fn i_unary_s(op: u32, x: f32) -> f32 {
    var r: f32;
    switch op {
        case 0u: { r = abs(x); }
        case 1u: { r = -(x); }
        case 2u: { r = s_sin(x); }
        case 3u: { r = s_cos(x); }
        case 4u: { r = s_sqrt(x); }
        case 5u: { r = floor(x); }
        case 6u: { r = s_fract(x); }
        case 7u: { r = s_exp(x); }
        case 8u: { r = s_log(x); }
        case 9u: { r = s_log2(x); }
        case 10u: { r = s_tan(x); }
        case 11u: { r = s_asin(x); }
        case 12u: { r = s_acos(x); }
        case 13u: { r = s_sign(x); }
        case 14u: { r = s_round(x); }
        default: { r = trunc(x); }
    }
    return r;
}

// codegen's unary_f64.
fn i_unary_d(op: u32, x: f64) -> f64 {
    var r: f64;
    switch op {
        case 0u: { r = abs(x); }
        case 1u: { r = -(x); }
        case 2u: { r = d_sin(x); }
        case 3u: { r = d_cos(x); }
        case 4u: { r = d_sqrt(x); }
        case 5u: { r = floor(x); }
        case 6u: { r = d_fract(x); }
        case 7u: { r = d_exp(x); }
        case 8u: { r = d_log(x); }
        case 9u: { r = d_log2(x); }
        case 10u: { r = d_tan(x); }
        case 11u: { r = d_asin(x); }
        case 12u: { r = d_acos(x); }
        case 13u: { r = d_sign(x); }
        case 14u: { r = d_round(x); }
        default: { r = d_trunc(x); }
    }
    return r;
}

fn i_unary_v(op: u32, x: vec3<f64>) -> vec3<f64> {
    return vec3<f64>(i_unary_d(op, x.x), i_unary_d(op, x.y), i_unary_d(op, x.z));
}

// codegen's binary("s_", ...).
fn i_binary_s(op: u32, a: f32, b: f32) -> f32 {
    var r: f32;
    switch op {
        case 0u: { r = (a + b); }
        case 1u: { r = (a - b); }
        case 2u: { r = (a * b); }
        case 3u: { r = (a / b); }
        case 4u: { r = s_min(a, b); }
        case 5u: { r = s_max(a, b); }
        case 6u: { r = s_pow(a, b); }
        case 7u: { r = s_atan2(a, b); }
        case 8u: { r = s_mod(a, b); }
        default: { r = s_step(a, b); }
    }
    return r;
}

// codegen's binary("d_", ...).
fn i_binary_d(op: u32, a: f64, b: f64) -> f64 {
    var r: f64;
    switch op {
        case 0u: { r = (a + b); }
        case 1u: { r = (a - b); }
        case 2u: { r = (a * b); }
        case 3u: { r = (a / b); }
        case 4u: { r = d_min(a, b); }
        case 5u: { r = d_max(a, b); }
        case 6u: { r = d_pow(a, b); }
        case 7u: { r = d_atan2(a, b); }
        case 8u: { r = d_mod(a, b); }
        default: { r = d_step(a, b); }
    }
    return r;
}

fn i_binary_v(op: u32, a: vec3<f64>, b: vec3<f64>) -> vec3<f64> {
    return vec3<f64>(i_binary_d(op, a.x, b.x), i_binary_d(op, a.y, b.y), i_binary_d(op, a.z, b.z));
}

fn i_ternary_s(op: u32, a: f32, b: f32, c: f32) -> f32 {
    var r: f32;
    switch op {
        case 0u: { r = s_clamp(a, b, c); }
        case 1u: { r = s_mix(a, b, c); }
        case 2u: { r = s_smoothstep(a, b, c); }
        default: { r = s_select(a, b, c); }
    }
    return r;
}

fn i_ternary_d(op: u32, a: f64, b: f64, c: f64) -> f64 {
    var r: f64;
    switch op {
        case 0u: { r = d_clamp(a, b, c); }
        case 1u: { r = d_mix(a, b, c); }
        case 2u: { r = d_smoothstep(a, b, c); }
        default: { r = d_select(a, b, c); }
    }
    return r;
}

fn i_ternary_v(op: u32, a: vec3<f64>, b: vec3<f64>, c: vec3<f64>) -> vec3<f64> {
    return vec3<f64>(i_ternary_d(op, a.x, b.x, c.x), i_ternary_d(op, a.y, b.y, c.y),
                     i_ternary_d(op, a.z, b.z, c.z));
}

// codegen's sample_call (a sample): the basis' `*_sample`, `*_sample_periodic` when tiled.
fn i_sample(basis: u32, t: u32, q: vec3<f64>, tiled: bool, period: vec3<f64>, cell: u32, jitter: f32) -> f32 {
    let metric = cell & 0xffu;
    let value = cell >> 8u;
    var r: f32;
    if (tiled) {
        switch basis {
            case 0u: { r = perlin_sample_periodic(t, q, period); }
            case 1u: { r = gradient_sample_periodic(t, q, period); }
            case 2u: { r = value_linear_sample_periodic(t, q, period); }
            case 3u: { r = value_smooth_sample_periodic(t, q, period); }
            case 4u: { r = simplex_sample_periodic(t, q, period); }
            case 5u: { r = white_sample_periodic(t, q, period); }
            default: { r = cellular_sample_periodic(t, q, period, metric, value, jitter); }
        }
    } else {
        switch basis {
            case 0u: { r = perlin_sample(t, q); }
            case 1u: { r = gradient_sample(t, q); }
            case 2u: { r = value_linear_sample(t, q); }
            case 3u: { r = value_smooth_sample(t, q); }
            case 4u: { r = simplex_sample(t, q); }
            case 5u: { r = white_sample(t, q); }
            default: { r = cellular_sample(t, q, metric, value, jitter); }
        }
    }
    return r;
}

// codegen's sample_call (a gradient): (gradient, value).
fn i_grad(basis: u32, t: u32, q: vec3<f64>, tiled: bool, period: vec3<f64>, cell: u32, jitter: f32) -> vec4<f32> {
    let metric = cell & 0xffu;
    let value = cell >> 8u;
    var r: vec4<f32>;
    if (tiled) {
        switch basis {
            case 0u: { r = perlin_grad_periodic(t, q, period); }
            case 1u: { r = gradient_grad_periodic(t, q, period); }
            case 2u: { r = value_linear_grad_periodic(t, q, period); }
            case 3u: { r = value_smooth_grad_periodic(t, q, period); }
            case 4u: { r = simplex_grad_periodic(t, q, period); }
            case 5u: { r = white_grad_periodic(t, q, period); }
            default: { r = cellular_grad_periodic(t, q, period, metric, value, jitter); }
        }
    } else {
        switch basis {
            case 0u: { r = perlin_grad(t, q); }
            case 1u: { r = gradient_grad(t, q); }
            case 2u: { r = value_linear_grad(t, q); }
            case 3u: { r = value_smooth_grad(t, q); }
            case 4u: { r = simplex_grad(t, q); }
            case 5u: { r = white_grad(t, q); }
            default: { r = cellular_grad(t, q, metric, value, jitter); }
        }
    }
    return r;
}

// Octave o's constants start (after the 4 header constants).
fn i_octave(k: u32, tiled: bool, o: u32) -> u32 {
    return k + 4u + o * select(2u, 5u, tiled);
}

// codegen's `fractal`, as a loop over the octaves.
fn i_fractal(w0: u32, t: u32, cell: u32, k: u32, n: u32, q: vec3<f64>) -> f32 {
    let style = (w0 >> 8u) & 0xffu;
    let basis = (w0 >> 16u) & 0xffu;
    let flags = w0 >> 24u;
    let tiled = (flags & I_FLAG_TILED) != 0u;
    let jitter = f32(constants[k]);
    let offset = f32(constants[k + 2u]);
    let sharpness = f32(constants[k + 3u]);
    var sum: f32 = 0.0;
    var weight: f32 = 1.0;
    for (var o = 0u; o < n; o = o + 1u) {
        let at = i_octave(k, tiled, o);
        var period = vec3<f64>(0.0lf);
        if (tiled) {
            period = i_const3(at + 2u);
        }
        let x = i_sample(basis, t, q * constants[at], tiled, period, cell, jitter);
        let a = f32(constants[at + 1u]);
        switch style {
            case 0u: { sum = sum + a * x; }
            case 1u: { sum = sum + a * abs(x); }
            case 2u: { sum = sum + a * (2.0 * abs(x) - 1.0); }
            default: {
                let r = s_pow(s_max(offset - abs(x), 0.0), sharpness) * weight;
                sum = sum + a * r;
                weight = s_min(s_max(2.0 * r, 0.0), 1.0);
            }
        }
    }
    if (is_nan(sum)) { sum = nan_f32(); }
    if ((flags & I_FLAG_BIAS) != 0u) {
        sum = sum + f32(constants[k + 1u]);
    }
    return sum;
}

// codegen's `fractal_gradient`, as a loop over the octaves.
fn i_fractal_gradient(w0: u32, t: u32, cell: u32, k: u32, n: u32, q: vec3<f64>) -> vec3<f64> {
    let style = (w0 >> 8u) & 0xffu;
    let basis = (w0 >> 16u) & 0xffu;
    let tiled = ((w0 >> 24u) & I_FLAG_TILED) != 0u;
    let jitter = f32(constants[k]);
    let offset = f32(constants[k + 2u]);
    let sharpness = f32(constants[k + 3u]);
    var g = gshaper_start();
    for (var o = 0u; o < n; o = o + 1u) {
        let at = i_octave(k, tiled, o);
        var period = vec3<f64>(0.0lf);
        if (tiled) {
            period = i_const3(at + 2u);
        }
        let f = constants[at];
        let x = i_grad(basis, t, q * f, tiled, period, cell, jitter);
        g = gshaper_add_f64(g, style, x.w, x.xyz, constants[at + 1u], f, offset, sharpness);
    }
    return vec3<f64>(gshaper_gradient(g));
}

// Knot i's value of a spline with `channels` channels (a curve's in x, y and z alike).
fn i_knot_value(k: u32, channels: u32, i: u32) -> vec3<f64> {
    let b = k + i * (channels + 2u) + 1u;
    if (channels == 3u) {
        return i_const3(b);
    }
    return vec3<f64>(constants[b]);
}

// codegen's `spline_function`, as a loop over the knots (from the last down).
fn i_spline(w0: u32, k: u32, n: u32, channels: u32, t: f64) -> vec3<f64> {
    let interpolation = (w0 >> 8u) & 0xffu;
    let slope = ((w0 >> 24u) & I_FLAG_SLOPE) != 0u;
    let stride = channels + 2u;
    let zero = vec3<f64>(0.0lf);
    if (is_nan_d(t)) { return vec3<f64>(nan_d()); }
    if (n == 0u) { return vec3<f64>(nan_d()); }
    let first = constants[k];
    let last = constants[k + (n - 1u) * stride];
    if (slope) {
        if (!(t >= first && t < last)) { return zero; }
    }
    let c = min(max(t, first), last);
    if (c >= last) {
        if (slope) { return zero; }
        return i_knot_value(k, channels, n - 1u);
    }
    for (var j = n - 1u; j > 0u; j = j - 1u) {
        let i = j - 1u;
        let at = k + i * stride;
        let knot = constants[at];
        if (c >= knot) {
            let inv = constants[at + stride - 1u];
            var u = (c - knot) * inv;
            let a = i_knot_value(k, channels, i);
            let b = i_knot_value(k, channels, i + 1u);
            if (interpolation == 2u) {
                if (slope) { return zero; }
                return a;
            }
            if (slope) {
                if (interpolation == 0u) {
                    return (b - a) * inv;
                }
                return 6.0lf * u * (1.0lf - u) * (b - a) * inv;
            }
            if (interpolation == 1u) {
                u = u * u * (3.0lf - 2.0lf * u);
            }
            return a + u * (b - a);
        }
    }
    return i_knot_value(k, channels, 0u);
}

// `h` (a point's sample spacing) is not read: the interpreter has no level of detail per
// point (it exists to measure the interpreter against the generated shader).
fn tape(p: vec3<f64>, h: f64) -> Channels {
    var s: array<f32, I_SCALARS>;
    var v: array<vec3<f64>, I_VEC3S>;
    var d: array<f64, I_WIDES>;
    var r: Channels;
    let count = program[0];
    for (var i = 0u; i < count; i = i + 1u) {
        let at = I_HEADER + i * I_STRIDE;
        let w0 = program[at];
        let dst = program[at + 1u];
        let a = program[at + 2u];
        let b = program[at + 3u];
        let c = program[at + 4u];
        let k = program[at + 5u];
        let sub = (w0 >> 8u) & 0xffu;
        switch (w0 & 0xffu) {
            case I_CONST_S: { s[dst] = f32(constants[k]); }
            case I_CONST_V: { v[dst] = i_const3(k); }
            case I_CONST_D: { d[dst] = constants[k]; }
            case I_POSITION: { v[dst] = p; }
            case I_SPLAT: { v[dst] = vec3<f64>(f64(s[a])); }
            case I_COMBINE: { v[dst] = vec3<f64>(f64(s[a]), f64(s[b]), f64(s[c])); }
            case I_COMPONENT: { s[dst] = f32(v[a][sub]); }
            case I_UNARY_S: { s[dst] = i_unary_s(sub, s[a]); }
            case I_UNARY_V: { v[dst] = i_unary_v(sub, v[a]); }
            case I_BINARY_S: { s[dst] = i_binary_s(sub, s[a], s[b]); }
            case I_BINARY_V: { v[dst] = i_binary_v(sub, v[a], v[b]); }
            case I_TERNARY_S: { s[dst] = i_ternary_s(sub, s[a], s[b], s[c]); }
            case I_TERNARY_V: { v[dst] = i_ternary_v(sub, v[a], v[b], v[c]); }
            case I_DOT: { s[dst] = f32(v_dot(v[a], v[b])); }
            case I_LENGTH: { s[dst] = f32(v_length(v[a])); }
            case I_CROSS: { v[dst] = v_cross(v[a], v[b]); }
            case I_NORMALIZE: { v[dst] = v_normalize(v[a]); }
            case I_ROTATE_CONST: {
                v[dst] = v_matrix(i_const3(k), i_const3(k + 3u), i_const3(k + 6u), v[a]);
            }
            case I_ROTATE_VARYING: { v[dst] = v_rotate(i_const3(k), f64(s[b]), v[a]); }
            case I_NOISE: {
                let basis = (w0 >> 16u) & 0xffu;
                let tiled = ((w0 >> 24u) & I_FLAG_TILED) != 0u;
                s[dst] = i_sample(basis, program[at + 7u], v[a], tiled, i_const3(k + 1u), c,
                                  f32(constants[k]));
            }
            case I_NOISE_GRADIENT: {
                let basis = (w0 >> 16u) & 0xffu;
                let tiled = ((w0 >> 24u) & I_FLAG_TILED) != 0u;
                let g = i_grad(basis, program[at + 7u], v[a], tiled, i_const3(k + 1u), c,
                               f32(constants[k]));
                v[dst] = vec3<f64>(g.xyz);
            }
            case I_FRACTAL: {
                s[dst] = i_fractal(w0, program[at + 7u], c, k, program[at + 6u], v[a]);
            }
            case I_FRACTAL_GRADIENT: {
                v[dst] = i_fractal_gradient(w0, program[at + 7u], c, k, program[at + 6u], v[a]);
            }
            case I_HERMITE: {
                s[dst] = s_hermite(s[a], f32(constants[k]), f32(constants[k + 1u]),
                                   f32(constants[k + 2u]), f32(constants[k + 3u]));
            }
            case I_RAMP: { v[dst] = i_spline(w0, k, program[at + 6u], 3u, f64(s[a])); }
            case I_CURVE: { s[dst] = f32(i_spline(w0, k, program[at + 6u], 1u, f64(s[a])).x); }
            case I_WIDE_COMPONENT: { d[dst] = v[a][sub]; }
            case I_WIDE_UNARY: { d[dst] = i_unary_d(sub, d[a]); }
            case I_WIDE_BINARY: { d[dst] = i_binary_d(sub, d[a], d[b]); }
            case I_WIDE_TERNARY: { d[dst] = i_ternary_d(sub, d[a], d[b], d[c]); }
            case I_WIDE_DOT: { d[dst] = v_dot(v[a], v[b]); }
            case I_WIDE_LENGTH: { d[dst] = v_length(v[a]); }
            case I_WIDE_SPLAT: { v[dst] = vec3<f64>(d[a]); }
            case I_WIDE_COMBINE: { v[dst] = vec3<f64>(d[a], d[b], d[c]); }
            case I_WIDE_ROTATE: { v[dst] = v_rotate(i_const3(k), d[b], v[a]); }
            case I_WIDEN: { d[dst] = f64(s[a]); }
            case I_NARROW: { s[dst] = f32(d[a]); }
            case I_OUT_S: { r.c[dst] = s[a]; }
            case I_OUT_V: {
                let x = v[a];
                r.c[dst] = f32(x.x);
                r.c[dst + 1u] = f32(x.y);
                r.c[dst + 2u] = f32(x.z);
            }
            default: {}
        }
    }
    return r;
}

