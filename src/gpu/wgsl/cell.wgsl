// cell.wgsl: what a basis reads of its cell in the real type of its kernel: the tables' float
// entries, the cell hash's values and feature points, the lattice split (index and fraction)
// and the wrapped upper corner. Written in f32 (the kernels' type); `widen.rs` derives the f64
// forms of this module and of the bases for noise the precision plan promoted (`_d` names).
//
// Needs common.wgsl (`tables`, `perm_at`, `pcg2d`).

// ---- Table entries -----------------------------------------------------------------------------

fn grad_at(t: u32, h: u32) -> vec3<f32> {
    let b = t + T_GRADS + 3u * (h & 255u);
    return vec3<f32>(bitcast<f32>(tables[b]), bitcast<f32>(tables[b + 1u]), bitcast<f32>(tables[b + 2u]));
}

fn value_at(t: u32, h: u32) -> f32 {
    return bitcast<f32>(tables[t + T_VALUES + (h & 255u)]);
}

// ---- Hash values (noise/hash.rs) ---------------------------------------------------------------

// Rust `Real::from_unit_bits` for f32 (`hash::value`): the value words' top 24 bits.
fn hash_value(s: vec2<u32>) -> f32 {
    let w = pcg2d(vec2<u32>(s.x ^ 0x5bd1e995u, s.y ^ 0xcc9e2d51u));
    return f32(w.x >> 8u) * 5.9604644775390625e-8f;
}

// Rust `hash::feature`: per axis 0.5 + jitter (u - 0.5), u the top 16 bits of a word and the
// jitter a multiple of 1/256, so every step is exact in f32 (fused or not).
fn hash_feature(s: vec2<u32>, jitter: f32) -> vec3<f32> {
    let z = pcg2d(s).x;
    let u = vec3<f32>(f32(s.x >> 16u), f32(s.y >> 16u), f32(z >> 16u)) * 1.52587890625e-5f;
    return vec3<f32>(0.5) + jitter * (u - vec3<f32>(0.5));
}

// ---- The lattice split (noise/lattice.rs `lattice`) --------------------------------------------
// c = floor(x), index = c mod 256, fraction = x - c (exact in f64), rounded to f32 once.
struct Split {
    index: u32,
    frac: f32,
}

fn lattice(x: f64) -> Split {
    let c = floor(x);
    let m = c - 256.0lf * floor(c / 256.0lf);
    var s: Split;
    s.index = u32(i32(m)) & 255u;
    s.frac = f32(x - c);
    return s;
}

// The split of each axis.
struct Split3 {
    index: vec3<u32>,
    frac: vec3<f32>,
}

fn lattice3(p: vec3<f64>) -> Split3 {
    let x = lattice(p.x);
    let y = lattice(p.y);
    let z = lattice(p.z);
    var s: Split3;
    s.index = vec3<u32>(x.index, y.index, z.index);
    s.frac = vec3<f32>(x.frac, y.frac, z.frac);
    return s;
}

// The upper corner's index per axis: index + 1 (mod 256), or 0 where the axis wraps.
fn upper_index(s: Split3, wrap: vec3<bool>) -> vec3<u32> {
    // A product with the mask, not `select` (GLSL ES 3.00 has no integer `mix`, which naga
    // writes `select` of vectors as in the exported shaders).
    return ((s.index + vec3<u32>(1u)) & vec3<u32>(255u)) * vec3<u32>(!wrap);
}
