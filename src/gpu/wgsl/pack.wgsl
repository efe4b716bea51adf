// pack.wgsl: a GPU bake window's results (32-bit floats, segment-planar as `entry.wgsl`'s
// `bake` writes them) packed into the sample type each channel's file stores, with each
// channel's statistics, so that a bake reads back what it writes (issue 49). The encodings are
// `crate::encoding`'s, rule for rule: clamp to [0, 1] with NaN → 0, the sRGB transfer,
// scale and round half away from zero; half floats rounded to nearest even, overflow to
// infinity, as the `half` crate. Values are classified by their bits, not by float compares,
// so that no driver's assumption about NaN or infinity changes a count or a sample.
//
// Dispatch: (groups, rows, channels) workgroups; group g of channel c packs words
// [g·WORDS, (g+1)·WORDS) of the channel's words in the window (segment by segment) and writes
// its statistics at `stats[c · params.groups + g]`.

const GROUP: u32 = 64u;
const PER_THREAD: u32 = 8u;
const WORDS: u32 = 512u; // GROUP × PER_THREAD

const ENC_F32: u32 = 0u;
const ENC_U8: u32 = 1u;
const ENC_U16: u32 = 2u;
const ENC_F16: u32 = 3u;

struct Params {
    first_segment: u32,
    segments: u32,
    segment_len: u32,
    per_row: u32,
    nx: u32,
    stride_words: u32,
    groups: u32,
    channels: u32,
}

// Per channel: encoding code, sRGB flag, first word in a segment's block, words per segment.
struct Channel {
    code: u32,
    srgb: u32,
    offset: u32,
    words: u32,
}

struct Stats {
    sum: f64,
    min: f32,
    max: f32,
    finite: u32,
    nan: u32,
    pos_inf: u32,
    neg_inf: u32,
    below: u32,
    above: u32,
}

@group(0) @binding(0) var<storage, read> results: array<f32>;
@group(0) @binding(1) var<uniform> params: Params;
@group(0) @binding(2) var<storage, read> channels: array<Channel>;
@group(0) @binding(3) var<storage, read_write> packed: array<u32>;
@group(0) @binding(4) var<storage, read_write> stats: array<Stats>;

var<workgroup> w_sum: array<f64, 64>;
var<workgroup> w_min: array<f32, 64>;
var<workgroup> w_max: array<f32, 64>;
var<workgroup> w_counts: array<atomic<u32>, 6>;

// The largest finite f32: min and max start from it (a group without finite values leaves
// them there; its `finite` count of 0 says so).
const MAX_F32: u32 = 0x7f7fffffu;

// `v` clamped to [0, 1] (NaN → 0), sRGB-encoded when `srgb`: `crate::encoding::encode_u8`'s
// first steps.
fn unit(v: f32, srgb: bool) -> f32 {
    let b = bitcast<u32>(v);
    var c = 0.0;
    if ((b & 0x7fffffffu) <= 0x7f800000u && (b >> 31u) == 0u) {
        c = select(v, 1.0, b >= 0x3f800000u);
    }
    if (srgb) {
        if (c <= 0.0031308) {
            c = 12.92 * c;
        } else {
            // 1 / 2.4 as Rust's f32 division gives it.
            c = 1.055 * pow(c, bitcast<f32>(0x3ed55555u)) - 0.055;
        }
    }
    return c;
}

// `x.round()` for x in [0, 2^24), clamped to `top`.
fn round_to(x: f32, top: u32) -> u32 {
    let t = u32(x);
    return min(t + select(0u, 1u, x - f32(t) >= 0.5), top);
}

// f32 → IEEE half bits, rounded to nearest even (the `half` crate's conversion).
fn half_bits(v: f32) -> u32 {
    let x = bitcast<u32>(v);
    let sign = (x >> 16u) & 0x8000u;
    let exp = x & 0x7f800000u;
    let man = x & 0x007fffffu;
    if (exp == 0x7f800000u) {
        return sign | 0x7c00u | select(0x0200u, 0u, man == 0u) | (man >> 13u);
    }
    let half_exp = i32(exp >> 23u) - 127 + 15;
    if (half_exp >= 0x1f) {
        return sign | 0x7c00u;
    }
    if (half_exp <= 0) {
        if (14 - half_exp > 24) {
            return sign;
        }
        let m = man | 0x00800000u;
        var half_man = m >> u32(14 - half_exp);
        let round_bit = 1u << u32(13 - half_exp);
        if ((m & round_bit) != 0u && (m & (3u * round_bit - 1u)) != 0u) {
            half_man = half_man + 1u;
        }
        return sign | half_man;
    }
    var h = sign | (u32(half_exp) << 10u) | (man >> 13u);
    if ((x & 0x1000u) != 0u && (x & 0x2fffu) != 0u) {
        h = h + 1u;
    }
    return h;
}

// Sample `v` as `code` encodes it, in the low bits.
fn encode(v: f32, code: u32, srgb: bool) -> u32 {
    switch code {
        case ENC_U8: {
            return round_to(unit(v, srgb) * 255.0, 255u);
        }
        case ENC_U16: {
            return round_to(unit(v, srgb) * 65535.0, 65535u);
        }
        case ENC_F16: {
            return half_bits(v);
        }
        default: {
            return bitcast<u32>(v);
        }
    }
}

@compute @workgroup_size(64)
fn pack(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
        @builtin(local_invocation_index) local: u32) {
    let c = wg.z;
    let g = wg.y * groups.x + wg.x;
    let ch = channels[c];
    let srgb = ch.srgb != 0u;
    var per_word = 2u;
    if (ch.code == ENC_U8) {
        per_word = 4u;
    } else if (ch.code == ENC_F32) {
        per_word = 1u;
    }
    let bits = 32u / per_word;
    let total = params.segments * ch.words;
    var sum = 0.0lf;
    var lo = bitcast<f32>(MAX_F32);
    var hi = -bitcast<f32>(MAX_F32);
    var counts = array<u32, 6>(0u, 0u, 0u, 0u, 0u, 0u);
    for (var j = 0u; j < PER_THREAD; j = j + 1u) {
        let w = g * WORDS + j * GROUP + local;
        if (g >= params.groups || w >= total) {
            break;
        }
        let s = w / ch.words;
        let q = w % ch.words;
        let segment = params.first_segment + s;
        let x0 = (segment % params.per_row) * params.segment_len;
        let len = min(params.segment_len, params.nx - x0);
        var word = 0u;
        for (var t = 0u; t < per_word; t = t + 1u) {
            let i = q * per_word + t;
            if (i >= len) {
                break;
            }
            let v = results[(s * params.channels + c) * params.segment_len + i];
            word = word | (encode(v, ch.code, srgb) << (t * bits));
            let b = bitcast<u32>(v);
            let mag = b & 0x7fffffffu;
            let negative = (b >> 31u) != 0u;
            if (mag > 0x7f800000u) {
                counts[0] = counts[0] + 1u;
                continue;
            }
            counts[4] = counts[4] + select(0u, 1u, negative && mag != 0u);
            counts[5] = counts[5] + select(0u, 1u, !negative && b > 0x3f800000u);
            if (mag == 0x7f800000u) {
                if (negative) {
                    counts[2] = counts[2] + 1u;
                } else {
                    counts[1] = counts[1] + 1u;
                }
                continue;
            }
            counts[3] = counts[3] + 1u;
            sum = sum + f64(v);
            lo = min(lo, v);
            hi = max(hi, v);
        }
        packed[s * params.stride_words + ch.offset + q] = word;
    }
    if (local < 6u) {
        atomicStore(&w_counts[local], 0u);
    }
    w_sum[local] = sum;
    w_min[local] = lo;
    w_max[local] = hi;
    workgroupBarrier();
    for (var k = 0u; k < 6u; k = k + 1u) {
        if (counts[k] != 0u) {
            atomicAdd(&w_counts[k], counts[k]);
        }
    }
    for (var step = GROUP / 2u; step > 0u; step = step / 2u) {
        if (local < step) {
            w_sum[local] = w_sum[local] + w_sum[local + step];
            w_min[local] = min(w_min[local], w_min[local + step]);
            w_max[local] = max(w_max[local], w_max[local + step]);
        }
        workgroupBarrier();
    }
    if (local == 0u && g < params.groups) {
        var out: Stats;
        out.sum = w_sum[0];
        out.min = w_min[0];
        out.max = w_max[0];
        out.nan = atomicLoad(&w_counts[0]);
        out.pos_inf = atomicLoad(&w_counts[1]);
        out.neg_inf = atomicLoad(&w_counts[2]);
        out.finite = atomicLoad(&w_counts[3]);
        out.below = atomicLoad(&w_counts[4]);
        out.above = atomicLoad(&w_counts[5]);
        stats[c * params.groups + g] = out;
    }
}
