// common.wgsl: what every texgraph compute shader shares (noise tables, the lattice split, the
// tiling reduction). The generated shader of a tape is: common.wgsl, math.wgsl, the basis
// modules, then the tape's own `main`.
//
// Conventions: positions and every vec3 value are vec3<f64> (the CPU's vec3 slots are f64
// planes, and the lattice cell must be exact at |p| up to 2^31); a lattice fraction is computed
// in f64 and rounded to f32 once, as the CPU's f32 path does (`S::from_f64(x - c)`); everything
// after the split is f32.

// ---- Noise tables -------------------------------------------------------------------------
// All tables of a tape in one storage buffer of 32-bit words; table t starts at word t (a
// multiple of T_WORDS). Float entries are stored as their bits.
@group(0) @binding(0) var<storage, read> tables: array<u32>;

const T_PERM: u32 = 0u;        // 512 entries: the permutation of 0..=255, doubled
const T_GRADS: u32 = 512u;     // 256 x 3: Gradient basis unit vectors (x, y, z of hash h at 3h)
const T_VALUES: u32 = 1280u;   // 256: Value lattice values
const T_KEY: u32 = 1536u;      // 2: the cell hash's key (Cellular, White; noise/hash.rs)
const T_WORDS: u32 = 1544u;

fn perm_at(t: u32, i: u32) -> u32 {
    return tables[t + T_PERM + (i & 511u)];
}

fn grad_at(t: u32, h: u32) -> vec3<f32> {
    let b = t + T_GRADS + 3u * (h & 255u);
    return vec3<f32>(bitcast<f32>(tables[b]), bitcast<f32>(tables[b + 1u]), bitcast<f32>(tables[b + 2u]));
}

fn value_at(t: u32, h: u32) -> f32 {
    return bitcast<f32>(tables[t + T_VALUES + (h & 255u)]);
}

// ---- The cell hash (noise/hash.rs) ------------------------------------------------------------------
// pcg2d (Jarzynski & Olano, JCGT 2020) absorbing a cell's exact integer coordinates, z, y, x,
// each as its two 32-bit two's-complement words; values in [0, 1) from the top bits.

fn pcg2d(v: vec2<u32>) -> vec2<u32> {
    var x = v.x * 1664525u + 1013904223u;
    var y = v.y * 1664525u + 1013904223u;
    x = x + y * 1664525u;
    y = y + x * 1664525u;
    x = x ^ (x >> 16u);
    y = y ^ (y >> 16u);
    x = x + y * 1664525u;
    y = y + x * 1664525u;
    x = x ^ (x >> 16u);
    y = y ^ (y >> 16u);
    return vec2<u32>(x, y);
}

fn hash_key(t: u32) -> vec2<u32> {
    return vec2<u32>(tables[t + T_KEY], tables[t + T_KEY + 1u]);
}

// A cell index (an integer-valued f64, Rust's `floor as i64`) as its two words (low, high):
// exact for |c| < 2^63, saturating beyond as Rust's `as` does.
fn cell_words(c: f64) -> vec2<u32> {
    if (c >= 9223372036854775808.0lf) {
        return vec2<u32>(0xffffffffu, 0x7fffffffu);
    }
    if (c < -9223372036854775808.0lf) {
        return vec2<u32>(0u, 0x80000000u);
    }
    let hi = floor(c / 4294967296.0lf);
    let lo = c - hi * 4294967296.0lf;
    // hi is within [-2^31, 2^31): through i32 to its two's-complement bits.
    return vec2<u32>(u32(lo), bitcast<u32>(i32(hi)));
}

fn hash_absorb(s: vec2<u32>, c: f64) -> vec2<u32> {
    return pcg2d(s ^ cell_words(c));
}

fn hash_cell(key: vec2<u32>, c: vec3<f64>) -> vec2<u32> {
    return hash_absorb(hash_absorb(hash_absorb(key, c.z), c.y), c.x);
}

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

// ---- Tiling (noise/period.rs) ------------------------------------------------------------------
// A period per axis in whole cells (as f64; 0 means "no period on this axis", which the
// generator writes for periods beyond 2^52). `reduce3` gives the point reduced into [0, P) per
// axis and which axes sit in their period's last cell (where the upper corner wraps to cell 0).
struct Reduced {
    p: vec3<f64>,
    wrap: vec3<bool>,
}

fn reduce1(x: f64, period: f64) -> vec2<f64> {
    // (x', c mod P); P = 0: (x, -1).
    if (period == 0.0lf) {
        return vec2<f64>(x, -1.0lf);
    }
    let c = floor(x);
    var m = c - period * floor(c / period);
    if (m < 0.0lf) {
        m = m + period;
    }
    if (m >= period) {
        m = m - period;
    }
    return vec2<f64>(m + (x - c), m);
}

fn reduce3(p: vec3<f64>, period: vec3<f64>) -> Reduced {
    let x = reduce1(p.x, period.x);
    let y = reduce1(p.y, period.y);
    let z = reduce1(p.z, period.z);
    var r: Reduced;
    r.p = vec3<f64>(x.x, y.x, z.x);
    r.wrap = vec3<bool>(period.x != 0.0lf && x.y + 1.0lf == period.x,
                       period.y != 0.0lf && y.y + 1.0lf == period.y,
                       period.z != 0.0lf && z.y + 1.0lf == period.z);
    return r;
}

// The upper corner's index per axis: index + 1 (mod 256), or 0 where the axis wraps.
fn upper_index(s: Split3, wrap: vec3<bool>) -> vec3<u32> {
    return select((s.index + vec3<u32>(1u)) & vec3<u32>(255u), vec3<u32>(0u), wrap);
}

// ---- NaN ---------------------------------------------------------------------------------------
// Shader compilers may fold `x != x`; the bit pattern test cannot be folded away.
fn is_nan(x: f32) -> bool {
    let b = bitcast<u32>(x);
    return (b & 0x7f800000u) == 0x7f800000u && (b & 0x007fffffu) != 0u;
}

fn is_nan3(v: vec3<f32>) -> bool {
    return is_nan(v.x) || is_nan(v.y) || is_nan(v.z);
}

fn nan_f32() -> f32 {
    return bitcast<f32>(0x7fc00000u);
}
