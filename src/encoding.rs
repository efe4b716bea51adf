//! The sample types files store ([`Encoding`]), one definition of how a value becomes one (the
//! sRGB transfer, 8/16-bit rounding, half floats), and the byte layout of a bake window whose
//! channels are stored encoded ([`Packing`]): a GPU bake packs its samples on the device into
//! the type the file stores (`gpu/wgsl/pack.wgsl`, the same rules) and reads back that, not
//! 32-bit floats (issue 49).

/// The sRGB transfer function (IEC 61966-2-1): linear [0, 1] → encoded [0, 1].
#[inline]
pub fn srgb_encode(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// `x.round()` for `x` in [0, 2^24): half away from zero, without libm's `roundf` call (a
/// truncating conversion and one compare; ~8 % of an 8-bit bake's time went to `roundf`).
/// Exact: `x − trunc(x)` is computed without rounding for such `x` (Sterbenz), so the compare
/// with 0.5 decides exactly as `round` does.
#[inline]
fn round_non_negative(x: f32) -> u32 {
    let t = x as u32;
    t + u32::from(x - t as f32 >= 0.5)
}

/// Clamp to [0, 1] (NaN → 0), apply the transfer if asked, scale to 0..=255 and round.
#[inline]
pub fn encode_u8(v: f32, srgb: bool) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let v = if srgb { srgb_encode(v) } else { v };
    round_non_negative(v * 255.0).min(255) as u8
}

/// As [`encode_u8`], to 0..=65535.
#[inline]
pub fn encode_u16(v: f32, srgb: bool) -> u16 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let v = if srgb { srgb_encode(v) } else { v };
    round_non_negative(v * 65535.0).min(65535) as u16
}

/// How a file stores one channel's samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// 32-bit floats, as evaluated.
    F32,
    /// 0..=255: clamped to [0, 1] (NaN → 0), sRGB-encoded when `srgb`, rounded.
    U8 { srgb: bool },
    /// 0..=65535, as `U8`.
    U16 { srgb: bool },
    /// IEEE half floats, rounded to nearest even (overflow → infinity), as the `half` crate.
    F16,
}

impl Encoding {
    /// Bytes per sample.
    pub fn bytes(self) -> usize {
        match self {
            Encoding::F32 => 4,
            Encoding::U8 { .. } => 1,
            Encoding::U16 { .. } | Encoding::F16 => 2,
        }
    }

    /// `v` in this encoding, little-endian, into `out` (exactly [`Encoding::bytes`] long).
    #[inline]
    pub fn encode(self, v: f32, out: &mut [u8]) {
        match self {
            Encoding::F32 => out.copy_from_slice(&v.to_le_bytes()),
            Encoding::U8 { srgb } => out[0] = encode_u8(v, srgb),
            Encoding::U16 { srgb } => out.copy_from_slice(&encode_u16(v, srgb).to_le_bytes()),
            Encoding::F16 => out.copy_from_slice(&half::f16::from_f32(v).to_le_bytes()),
        }
    }

    /// `values` encoded into `out`, value `i` at byte `i × stride` (`stride` ≥
    /// [`Encoding::bytes`]; bytes between are left as they are): the encoding chosen once per
    /// run, not per sample (a bake's hot path: every voxel of every 8-bit file goes through it).
    pub fn encode_run(self, values: &[f32], out: &mut [u8], stride: usize) {
        fn run<const N: usize>(
            values: &[f32],
            out: &mut [u8],
            stride: usize,
            f: impl Fn(f32) -> [u8; N],
        ) {
            if stride == N {
                for (t, &v) in out.chunks_exact_mut(N).zip(values) {
                    t.copy_from_slice(&f(v));
                }
            } else {
                for (t, &v) in out.chunks_mut(stride).zip(values) {
                    t[..N].copy_from_slice(&f(v));
                }
            }
        }
        match self {
            Encoding::F32 => run(values, out, stride, f32::to_le_bytes),
            Encoding::U8 { srgb } => run(values, out, stride, |v| [encode_u8(v, srgb)]),
            Encoding::U16 { srgb } => {
                run(values, out, stride, |v| encode_u16(v, srgb).to_le_bytes())
            }
            Encoding::F16 => run(values, out, stride, |v| {
                half::f16::from_f32(v).to_le_bytes()
            }),
        }
    }

    /// The code `pack.wgsl` knows this encoding by (`ENC_*` there), and its sRGB flag.
    #[cfg_attr(not(feature = "gpu"), allow(dead_code))]
    pub(crate) fn gpu_code(self) -> (u32, u32) {
        match self {
            Encoding::F32 => (0, 0),
            Encoding::U8 { srgb } => (1, u32::from(srgb)),
            Encoding::U16 { srgb } => (2, u32::from(srgb)),
            Encoding::F16 => (3, 0),
        }
    }
}

/// Where each channel's samples lie in a window stored encoded: segment `s`'s block starts at
/// word `s × stride_words`, channel `c`'s `segment_len` samples at word `offsets[c]` inside it
/// (each channel's run padded to whole 32-bit words, which the GPU writes).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Packing {
    pub encodings: Vec<Encoding>,
    pub offsets: Vec<usize>,
    pub stride_words: usize,
    pub segment_len: usize,
}

impl Packing {
    /// The packing of `encodings` (one per channel) for segments of `segment_len` voxels.
    pub fn new(encodings: Vec<Encoding>, segment_len: usize) -> Packing {
        let mut offsets = Vec::with_capacity(encodings.len());
        let mut at = 0;
        for e in &encodings {
            offsets.push(at);
            at += (segment_len * e.bytes()).div_ceil(4);
        }
        Packing {
            encodings,
            offsets,
            stride_words: at,
            segment_len,
        }
    }

    /// Bytes of `segments` segments.
    pub fn bytes(&self, segments: usize) -> usize {
        4 * self.stride_words * segments
    }

    /// The encoded samples of channel `c` of segment `s` (its first `n` voxels) in `bytes`.
    pub fn channel<'a>(&self, bytes: &'a [u8], s: usize, c: usize, n: usize) -> &'a [u8] {
        let start = 4 * (s * self.stride_words + self.offsets[c]);
        &bytes[start..start + n * self.encodings[c].bytes()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every encoding against the encoders the sinks used before (`encode_u8`, `encode_u16`,
    /// the `half` crate), at the edges where they could differ.
    #[test]
    fn encodings_are_the_file_encoders() {
        let values = [
            0.0f32,
            -0.0,
            0.5,
            1.0,
            -1.0,
            2.0,
            0.001,
            0.7354,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            65504.0,
            65520.0,
            1e-7,
            -3.5e-6,
        ];
        for v in values {
            let mut b = [0u8; 4];
            Encoding::F32.encode(v, &mut b);
            assert_eq!(f32::from_le_bytes(b).to_bits(), v.to_bits());
            for srgb in [false, true] {
                Encoding::U8 { srgb }.encode(v, &mut b[..1]);
                assert_eq!(b[0], encode_u8(v, srgb));
                Encoding::U16 { srgb }.encode(v, &mut b[..2]);
                assert_eq!(u16::from_le_bytes([b[0], b[1]]), encode_u16(v, srgb));
            }
            Encoding::F16.encode(v, &mut b[..2]);
            let h = half::f16::from_le_bytes([b[0], b[1]]);
            assert!(h.to_bits() == half::f16::from_f32(v).to_bits());
        }
        let mut b = [0u8; 2];
        Encoding::F16.encode(65520.0, &mut b);
        assert!(half::f16::from_le_bytes(b).is_infinite());
    }

    /// A run encodes each value as `encode` does, at its stride, leaving the bytes between.
    #[test]
    fn runs_are_samples_at_a_stride() {
        let values = [0.25f32, -1.0, f32::NAN, 0.7354, 65520.0];
        for e in [
            Encoding::F32,
            Encoding::U8 { srgb: true },
            Encoding::U16 { srgb: false },
            Encoding::F16,
        ] {
            let size = e.bytes();
            for stride in [size, size + 1, 3 * size] {
                let mut out = vec![0xAAu8; values.len() * stride];
                e.encode_run(&values, &mut out, stride);
                for (i, &v) in values.iter().enumerate() {
                    let mut want = [0u8; 4];
                    e.encode(v, &mut want[..size]);
                    let at = i * stride;
                    assert_eq!(out[at..at + size], want[..size], "{e:?} {v}");
                    assert!(out[at + size..at + stride].iter().all(|&b| b == 0xAA));
                }
            }
        }
    }

    #[test]
    fn channels_are_padded_to_words() {
        let p = Packing::new(
            vec![
                Encoding::U8 { srgb: true },
                Encoding::F16,
                Encoding::F32,
                Encoding::U8 { srgb: false },
            ],
            5,
        );
        // 5 bytes → 2 words, 10 bytes → 3, 20 → 5, 5 → 2.
        assert_eq!(p.offsets, vec![0, 2, 5, 10]);
        assert_eq!(p.stride_words, 12);
        assert_eq!(p.bytes(3), 144);
        let bytes: Vec<u8> = (0..144).map(|b| b as u8).collect();
        assert_eq!(p.channel(&bytes, 1, 1, 5), &bytes[56..66]);
    }

    #[test]
    fn rounding_is_roundf_exactly() {
        // Every 31st float in [0, 1], scaled as both encodings scale, and every half-way point
        // and its neighbours.
        let mut bits = 0u32;
        while bits <= 1.0f32.to_bits() {
            let v = f32::from_bits(bits);
            for scale in [255.0f32, 65535.0] {
                let x = v * scale;
                assert_eq!(round_non_negative(x), x.round() as u32, "{x:?}");
            }
            bits += 31;
        }
        for k in 0..65536u32 {
            let half = k as f32 + 0.5;
            for x in [half, half.next_down(), half.next_up(), k as f32] {
                assert_eq!(round_non_negative(x), x.round() as u32, "{x:?}");
            }
        }
        assert_eq!(encode_u8(f32::NAN, true), 0);
        assert_eq!(encode_u8(2.0, true), 255);
        assert_eq!(encode_u16(1.0, false), 65535);
    }

    #[test]
    fn srgb_transfer_hits_its_anchor_points() {
        assert_eq!(encode_u8(0.0, true), 0);
        assert_eq!(encode_u8(1.0, true), 255);
        assert_eq!(encode_u8(0.5, false), 128);
        // Linear 0.5 is sRGB 188 (0.7354).
        assert_eq!(encode_u8(0.5, true), 188);
        assert_eq!(encode_u8(f32::NAN, true), 0);
        assert_eq!(encode_u8(7.0, false), 255);
        assert_eq!(encode_u16(1.0, false), 65535);
        assert!((srgb_encode(0.0031308) - 0.04045).abs() < 1e-4);
    }
}
