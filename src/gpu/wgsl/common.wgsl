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
const T_VALUES: u32 = 1280u;   // 256: Value lattice values / Cellular cell values / White values
const T_FEATURES: u32 = 1536u; // 3 planes of 256: Cellular feature points (axis a of h at 256a + h)
const T_WORDS: u32 = 2304u;

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

fn feature_at(t: u32, h: u32) -> vec3<f32> {
    let b = t + T_FEATURES + (h & 255u);
    return vec3<f32>(bitcast<f32>(tables[b]), bitcast<f32>(tables[b + 256u]), bitcast<f32>(tables[b + 512u]));
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
