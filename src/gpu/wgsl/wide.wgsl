// wide.wgsl: the f64 (`_d`) forms `widen.rs` cannot derive from the f32 modules, because the
// f32 ones work on bit patterns: table entries (stored as f32 bits: the CPU's tables are f32
// too, so widening is exact), the hash value with all 53 bits, NaN tests and quiet NaNs.

fn grad_at_d(t: u32, h: u32) -> vec3<f64> {
    return vec3<f64>(grad_at(t, h));
}

fn value_at_d(t: u32, h: u32) -> f64 {
    return f64(value_at(t, h));
}

// Rust `Real::from_unit_bits` for f64 (`hash::value`): the value words' top 53 bits,
// w.x 2^-32 + (w.y >> 11) 2^-53, exact.
fn hash_value_d(s: vec2<u32>) -> f64 {
    let w = pcg2d(vec2<u32>(s.x ^ 0x5bd1e995u, s.y ^ 0xcc9e2d51u));
    return f64(w.x) * 2.3283064365386963e-10lf + f64(w.y >> 11u) * 1.1102230246251565e-16lf;
}

fn is_nan3_d(v: vec3<f64>) -> bool {
    return is_nan_d(v.x) || is_nan_d(v.y) || is_nan_d(v.z);
}

fn simplex_nan_d() -> f64 {
    return nan_d();
}

fn cellular_nan_d(zero: f64) -> f64 {
    return nan_d() + zero * 0.0lf;
}

fn cellular_is_nan3_d(v: vec3<f64>) -> bool {
    return is_nan3_d(v);
}

fn lg_is_nan_d(v: f64) -> bool {
    return is_nan_d(v);
}

fn lg_nan_d() -> f64 {
    return nan_d();
}

// `f64::powf` for the ridge: math.wgsl's `d_pow` (IEEE special values, negative bases).
fn lg_powf_d(x: f64, e: f64) -> f64 {
    return d_pow(x, e);
}
