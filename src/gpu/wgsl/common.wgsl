// common.wgsl: what every texgraph compute shader shares (noise tables, the cell hash, the
// tiling reduction). The generated shader of a tape is: common.wgsl, math.wgsl, cell.wgsl, the
// basis modules, for a tape with promoted noise their f64 forms (`widen.rs`), then the tape's
// own function and the entry points.
//
// Conventions: positions and every vec3 value are vec3<f64> (the CPU's vec3 slots are f64
// planes, and the lattice cell must be exact at |p| up to 2^31); a lattice fraction is computed
// in f64 and rounded to f32 once, as the CPU's f32 path does (`S::from_f64(x - c)`); everything
// after the split is f32 (f64 in the `_d` forms).

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
