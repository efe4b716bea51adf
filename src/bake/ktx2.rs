//! KTX 2.0 files: one 3D texture per output, written exactly as the Khronos KTX File Format
//! Specification, version 2.0 ("the spec"; section names in quotes below are its) lays them out.
//!
//! A file is the 80-byte header and index, the level index (24 bytes a level), the Data Format
//! Descriptor, the key/value data, no supercompression global data, then the levels from the
//! smallest to the largest (spec "File Structure"). Everything before the levels is known before
//! the bake starts and is written first, the level index with zeros; each level is streamed as it
//! is produced (never held whole), and the level index is patched in place once every level is
//! written: without supercompression the offsets and lengths are known up front, with Zstandard
//! a level's length only when its frame is finished. [`Ktx2Writer`] writes any number of levels
//! (a mip chain); a bake writes one, the voxels themselves.
//!
//! The texel order is the spec's (`levelImages`): x fastest, then y, then z, which is the order
//! the bake engine produces voxels in. The first texel is voxel (0, 0, 0), the region's minimum
//! corner; texgraph's axes are right-handed with y up, so `KTXorientation` is `ruo` (s to the
//! right, t up, r out of the screen).

use super::error::BakeError;
use super::settings::Ktx2SampleType;
use super::settings::ZSTD_LEVELS;
use super::window::{Sink, Window};
use crate::encoding::Encoding;
use crate::graph::Type;
use crate::grid::Grid;
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// The file identifier, `«KTX 20»\r\n\x1A\n` (spec "identifier").
pub const IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];
/// Bytes of the header and index, before the level index.
const HEADER_BYTES: u64 = 80;
/// Bytes of one level index entry: byteOffset, byteLength, uncompressedByteLength (UInt64 each).
const LEVEL_INDEX_BYTES: u64 = 24;

/// `supercompressionScheme` values (spec "supercompressionScheme").
const SUPERCOMPRESSION_NONE: u32 = 0;
const SUPERCOMPRESSION_ZSTD: u32 = 2;

/// `KTXorientation` for texgraph's axes: x to the right, y up, z out of the screen (right-handed).
pub const ORIENTATION: &str = "ruo";

/// `VkFormat` values (Vulkan specification, "Formats").
mod vk {
    pub const R8_UNORM: u32 = 9;
    pub const R8G8B8A8_UNORM: u32 = 37;
    pub const R8G8B8A8_SRGB: u32 = 43;
    pub const R16_SFLOAT: u32 = 76;
    pub const R16G16B16A16_SFLOAT: u32 = 97;
    pub const R32_SFLOAT: u32 = 100;
    pub const R32G32B32A32_SFLOAT: u32 = 109;
}

/// Khronos Data Format Specification 1.3 constants (`khr_df.h`).
mod df {
    /// `KHR_DF_VENDORID_KHRONOS` and `KHR_DF_KHR_DESCRIPTORTYPE_BASICFORMAT`.
    pub const VENDOR_KHRONOS: u32 = 0;
    pub const DESCRIPTOR_BASIC: u32 = 0;
    /// `KHR_DF_VERSIONNUMBER_1_3`, the latest.
    pub const VERSION: u32 = 2;
    pub const MODEL_RGBSDA: u32 = 1;
    pub const PRIMARIES_BT709: u32 = 1;
    pub const TRANSFER_LINEAR: u32 = 1;
    pub const TRANSFER_SRGB: u32 = 2;
    /// `KHR_DF_FLAG_ALPHA_STRAIGHT`.
    pub const FLAGS_ALPHA_STRAIGHT: u32 = 0;
    /// Channel ids of the RGBSDA model: red, green, blue, alpha.
    pub const CHANNELS: [u32; 4] = [0, 1, 2, 15];
    /// Sample qualifiers, in the channel-type byte: `KHR_DF_SAMPLE_DATATYPE_{LINEAR,SIGNED,FLOAT}`.
    pub const QUALIFIER_LINEAR: u32 = 0x10;
    pub const QUALIFIER_SIGNED: u32 = 0x40;
    pub const QUALIFIER_FLOAT: u32 = 0x80;
    /// Words of the basic descriptor block before its samples, and per sample.
    pub const BLOCK_WORDS: u32 = 6;
    pub const SAMPLE_WORDS: u32 = 4;
}

/// The `vkFormat` of one output's file and how its texels are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Ktx2Format {
    pub vk_format: u32,
    /// The Vulkan name without `VK_FORMAT_`, for the report.
    pub name: &'static str,
    /// 1 (scalars) or 4 (colours, with an opaque alpha: GPUs support three-channel formats
    /// poorly, and three.js and Bevy expect RGBA).
    pub channels: u32,
    pub sample: Ktx2SampleType,
    /// Colours sRGB-encoded (an `_SRGB` format).
    pub srgb: bool,
}

impl Ktx2Format {
    /// The format of an output of type `ty`; `srgb` asks for sRGB-encoded 8-bit colours (it does
    /// not apply to scalars, which are data, nor to float formats, which are linear).
    pub fn new(ty: Type, sample: Ktx2SampleType, srgb: bool) -> Ktx2Format {
        let colour = ty == Type::Vec3;
        let srgb = srgb && colour && sample == Ktx2SampleType::U8;
        let (vk_format, name) = match (sample, colour, srgb) {
            (Ktx2SampleType::U8, false, _) => (vk::R8_UNORM, "R8_UNORM"),
            (Ktx2SampleType::U8, true, true) => (vk::R8G8B8A8_SRGB, "R8G8B8A8_SRGB"),
            (Ktx2SampleType::U8, true, false) => (vk::R8G8B8A8_UNORM, "R8G8B8A8_UNORM"),
            (Ktx2SampleType::F16, false, _) => (vk::R16_SFLOAT, "R16_SFLOAT"),
            (Ktx2SampleType::F16, true, _) => (vk::R16G16B16A16_SFLOAT, "R16G16B16A16_SFLOAT"),
            (Ktx2SampleType::F32, false, _) => (vk::R32_SFLOAT, "R32_SFLOAT"),
            (Ktx2SampleType::F32, true, _) => (vk::R32G32B32A32_SFLOAT, "R32G32B32A32_SFLOAT"),
        };
        Ktx2Format {
            vk_format,
            name,
            channels: if colour { 4 } else { 1 },
            sample,
            srgb,
        }
    }

    /// `typeSize`: the bytes of one component (spec "typeSize").
    pub fn type_size(&self) -> u32 {
        match self.sample {
            Ktx2SampleType::U8 => 1,
            Ktx2SampleType::F16 => 2,
            Ktx2SampleType::F32 => 4,
        }
    }

    /// Bytes of one texel (the texel block size of an uncompressed format).
    pub fn texel_bytes(&self) -> u32 {
        self.channels * self.type_size()
    }

    /// Where each level starts: `lcm(texel block size, 4)` without supercompression, 1 with
    /// (spec "mipPadding", "levels[p].byteLength").
    pub fn level_alignment(&self, supercompressed: bool) -> u64 {
        if supercompressed {
            1
        } else {
            let texel = u64::from(self.texel_bytes());
            texel / gcd(texel, 4) * 4
        }
    }

    /// The Data Format Descriptor: `dfdTotalSize` and one basic descriptor block, the one the
    /// Khronos Data Format Specification gives for the format (as KTX-Software's `vk2dfd`
    /// writes it): colour model RGBSDA, BT.709 primaries, the sRGB transfer for the `_SRGB`
    /// format and linear otherwise, straight alpha, 1×1×1×1 texel blocks, `bytesPlane0` the texel
    /// size (also with Zstandard: spec "DFD for Supercompressed Data"), and one sample per
    /// channel.
    pub fn dfd(&self) -> Vec<u8> {
        let samples = self.channels;
        let block_bytes = 4 * (df::BLOCK_WORDS + df::SAMPLE_WORDS * samples);
        let transfer = if self.srgb {
            df::TRANSFER_SRGB
        } else {
            df::TRANSFER_LINEAR
        };
        let mut words = vec![
            4 + block_bytes,                                   // dfdTotalSize
            df::VENDOR_KHRONOS | (df::DESCRIPTOR_BASIC << 17), // vendorId:17, descriptorType:15
            df::VERSION | (block_bytes << 16), // versionNumber:16, descriptorBlockSize:16
            df::MODEL_RGBSDA
                | (df::PRIMARIES_BT709 << 8)
                | (transfer << 16)
                | (df::FLAGS_ALPHA_STRAIGHT << 24),
            0,                  // texelBlockDimension0..3: 1×1×1×1, stored minus one
            self.texel_bytes(), // bytesPlane0 = texel size, bytesPlane1..3 = 0
            0,                  // bytesPlane4..7
        ];
        let bits = 8 * self.type_size();
        for c in 0..samples {
            let channel = df::CHANNELS[c as usize];
            let qualifiers = match self.sample {
                Ktx2SampleType::F16 | Ktx2SampleType::F32 => {
                    df::QUALIFIER_FLOAT | df::QUALIFIER_SIGNED
                }
                // The KTX spec ("Restrictions"): with a non-linear transfer, the alpha sample is
                // marked linear.
                Ktx2SampleType::U8 if self.srgb && channel == 15 => df::QUALIFIER_LINEAR,
                Ktx2SampleType::U8 => 0,
            };
            let (lower, upper) = match self.sample {
                Ktx2SampleType::U8 => (0, (1u32 << bits) - 1),
                // -1.0 and 1.0 as 32-bit floats, whatever the sample's width.
                Ktx2SampleType::F16 | Ktx2SampleType::F32 => {
                    ((-1.0f32).to_bits(), 1.0f32.to_bits())
                }
            };
            words.extend([
                (c * bits) | ((bits - 1) << 16) | ((channel | qualifiers) << 24),
                0, // samplePosition0..3
                lower,
                upper,
            ]);
        }
        words.iter().flat_map(|w| w.to_le_bytes()).collect()
    }
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

fn align(offset: u64, alignment: u64) -> u64 {
    offset.div_ceil(alignment) * alignment
}

/// The key/value data (spec "Key/Value Data"): the pairs sorted by key (byte order of UTF-8 is
/// code point order), each `keyAndValueByteLength`, the key, NUL, the value, and zero padding to
/// 4 bytes. Values are given without their terminating NUL, which is added.
pub(crate) fn key_value_data(pairs: &[(String, String)]) -> Vec<u8> {
    let mut sorted: Vec<&(String, String)> = pairs.iter().collect();
    sorted.sort_by(|a, b| a.0.as_bytes().cmp(b.0.as_bytes()));
    let mut out = Vec::new();
    for (key, value) in sorted {
        let length = key.len() + 1 + value.len() + 1;
        out.extend((length as u32).to_le_bytes());
        out.extend(key.as_bytes());
        out.push(0);
        out.extend(value.as_bytes());
        out.push(0);
        out.resize(align(out.len() as u64, 4) as usize, 0);
    }
    out
}

/// Width, height and depth of level `p` of a texture of `size` (spec "levelImages").
fn level_extent(size: [u32; 3], p: u32) -> [u64; 3] {
    size.map(|n| u64::from((n >> p.min(31)).max(1)))
}

/// Uncompressed bytes of level `p`, if they fit in a u64.
fn level_bytes(format: &Ktx2Format, size: [u32; 3], p: u32) -> Option<u64> {
    let [w, h, d] = level_extent(size, p);
    w.checked_mul(h)?
        .checked_mul(d)?
        .checked_mul(u64::from(format.texel_bytes()))
}

/// The levels a texture of `size` can have: ⌊log2(max side)⌋ + 1 (spec "levelCount").
fn max_levels(size: [u32; 3]) -> u32 {
    32 - size
        .iter()
        .max()
        .copied()
        .unwrap_or(1)
        .max(1)
        .leading_zeros()
}

/// What a file holds besides its texels.
#[derive(Clone, Debug)]
pub(crate) struct Ktx2Description {
    pub format: Ktx2Format,
    /// pixelWidth, pixelHeight, pixelDepth of level 0.
    pub size: [u32; 3],
    /// Levels, each half the size of the one before (1: the texture itself).
    pub levels: u32,
    /// Zstandard supercompression at this level.
    pub zstd: Option<i32>,
    /// Key/value pairs (values without their NUL).
    pub key_values: Vec<(String, String)>,
}

impl Ktx2Description {
    /// Checks what the spec and the writer need: positive sides, at most the levels a texture of
    /// that size can have, level sizes that fit in 64 bits, a Zstandard level in range.
    pub fn validate(&self) -> Result<(), String> {
        if self.size.contains(&0) {
            return Err(format!(
                "a KTX2 3D texture has at least one texel a side, not {:?}",
                self.size
            ));
        }
        if self.levels == 0 || self.levels > max_levels(self.size) {
            return Err(format!(
                "a texture of {:?} texels has 1 to {} levels, not {}",
                self.size,
                max_levels(self.size),
                self.levels
            ));
        }
        if let Some(level) = self.zstd {
            if !ZSTD_LEVELS.contains(&level) {
                return Err(format!(
                    "the Zstandard level is {} to {}, not {level}",
                    ZSTD_LEVELS.start(),
                    ZSTD_LEVELS.end()
                ));
            }
        }
        if (0..self.levels).any(|p| level_bytes(&self.format, self.size, p).is_none()) {
            return Err(format!(
                "a KTX2 level of {:?} texels of {} bytes does not fit in 64 bits",
                self.size,
                self.format.texel_bytes()
            ));
        }
        Ok(())
    }

    /// Everything before the levels, with a level index of zeros.
    fn prefix(&self) -> Vec<u8> {
        let dfd = self.format.dfd();
        let kvd = key_value_data(&self.key_values);
        let dfd_offset = HEADER_BYTES + LEVEL_INDEX_BYTES * u64::from(self.levels);
        let kvd_offset = dfd_offset + dfd.len() as u64;
        let scheme = if self.zstd.is_some() {
            SUPERCOMPRESSION_ZSTD
        } else {
            SUPERCOMPRESSION_NONE
        };
        let mut out = Vec::with_capacity(kvd_offset as usize + kvd.len());
        out.extend(IDENTIFIER);
        for word in [
            self.format.vk_format,
            self.format.type_size(),
            self.size[0],
            self.size[1],
            self.size[2],
            0, // layerCount: not an array
            1, // faceCount: not a cubemap
            self.levels,
            scheme,
            dfd_offset as u32,
            dfd.len() as u32,
            if kvd.is_empty() { 0 } else { kvd_offset as u32 },
            kvd.len() as u32,
        ] {
            out.extend(word.to_le_bytes());
        }
        out.extend(0u64.to_le_bytes()); // sgdByteOffset: no supercompression global data
        out.extend(0u64.to_le_bytes()); // sgdByteLength
        out.resize(dfd_offset as usize, 0); // the level index, patched at the end
        out.extend(dfd);
        out.extend(kvd);
        out
    }
}

/// One entry of the level index.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct LevelIndex {
    byte_offset: u64,
    byte_length: u64,
    uncompressed_byte_length: u64,
}

/// A writer that counts what passes through it.
struct Counting<W> {
    inner: W,
    count: u64,
}

impl<W: Write> Write for Counting<W> {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(bytes)?;
        self.count += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

enum Stream<W: Write> {
    Plain(Counting<W>),
    Zstd(Box<zstd::stream::write::Encoder<'static, Counting<W>>>),
    /// Between two states, or after an error.
    Gone,
}

/// A level being written.
struct OpenLevel {
    p: u32,
    offset: u64,
    expected: u64,
    written: u64,
}

fn invalid(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, message)
}

/// Writes a KTX2 file: [`Ktx2Writer::new`] writes everything before the levels; then each level,
/// from the smallest (`levels - 1`) to the largest (0), is [`begin_level`](Ktx2Writer::begin_level),
/// [`write`](Ktx2Writer::write) its texels in order (any chunking), [`end_level`](Ktx2Writer::end_level);
/// [`finish`](Ktx2Writer::finish) fills in the level index.
pub(crate) struct Ktx2Writer<W: Write + Seek> {
    stream: Stream<W>,
    description: Ktx2Description,
    index: Vec<LevelIndex>,
    open: Option<OpenLevel>,
    /// The next level to begin; `None` once level 0 has begun.
    next: Option<u32>,
    /// Where the file started in `W`.
    base: u64,
}

impl<W: Write + Seek> Ktx2Writer<W> {
    pub fn new(mut out: W, description: Ktx2Description) -> io::Result<Self> {
        description.validate().map_err(invalid)?;
        let base = out.stream_position()?;
        let prefix = description.prefix();
        out.write_all(&prefix)?;
        let levels = description.levels;
        Ok(Ktx2Writer {
            stream: Stream::Plain(Counting {
                inner: out,
                count: prefix.len() as u64,
            }),
            index: vec![LevelIndex::default(); levels as usize],
            description,
            open: None,
            next: Some(levels - 1),
            base,
        })
    }

    /// The uncompressed bytes level `p` holds.
    pub fn level_bytes(&self, p: u32) -> u64 {
        level_bytes(&self.description.format, self.description.size, p).unwrap_or(u64::MAX)
    }

    /// Starts level `p`, which must be the next one (the smallest first).
    pub fn begin_level(&mut self, p: u32) -> io::Result<()> {
        if self.open.is_some() || self.next != Some(p) {
            return Err(invalid(format!(
                "KTX2 level {p} begun out of order (levels go from the smallest to the largest)"
            )));
        }
        let Stream::Plain(mut plain) = std::mem::replace(&mut self.stream, Stream::Gone) else {
            return Err(invalid("KTX2 writer in a failed state".into()));
        };
        let expected = self.level_bytes(p);
        let supercompressed = self.description.zstd.is_some();
        // mipPadding: zeros up to the level's alignment (none with supercompression).
        let padded = align(
            plain.count,
            self.description.format.level_alignment(supercompressed),
        );
        let padding = (padded - plain.count) as usize;
        plain.write_all(&[0u8; 16][..padding])?;
        let offset = plain.count;
        self.stream = match self.description.zstd {
            None => Stream::Plain(plain),
            Some(level) => {
                let mut encoder = zstd::stream::write::Encoder::new(plain, level)?;
                // The frame records the level's size and a checksum of its content (spec
                // "Zstandard": checksums are optional; inflators should verify one).
                encoder.set_pledged_src_size(Some(expected))?;
                encoder.include_contentsize(true)?;
                encoder.include_checksum(true)?;
                Stream::Zstd(Box::new(encoder))
            }
        };
        self.open = Some(OpenLevel {
            p,
            offset,
            expected,
            written: 0,
        });
        self.next = p.checked_sub(1);
        Ok(())
    }

    /// Appends texel bytes to the open level.
    pub fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        let Some(open) = self.open.as_mut() else {
            return Err(invalid("KTX2 texels written outside a level".into()));
        };
        open.written += bytes.len() as u64;
        if open.written > open.expected {
            return Err(invalid(format!(
                "KTX2 level {} given more than its {} bytes",
                open.p, open.expected
            )));
        }
        match &mut self.stream {
            Stream::Plain(plain) => plain.write_all(bytes),
            Stream::Zstd(encoder) => encoder.write_all(bytes),
            Stream::Gone => Err(invalid("KTX2 writer in a failed state".into())),
        }
    }

    /// Ends the open level, which must have received all its bytes.
    pub fn end_level(&mut self) -> io::Result<()> {
        let Some(open) = self.open.take() else {
            return Err(invalid("no KTX2 level to end".into()));
        };
        if open.written != open.expected {
            return Err(invalid(format!(
                "KTX2 level {} got {} of its {} bytes",
                open.p, open.written, open.expected
            )));
        }
        let plain = match std::mem::replace(&mut self.stream, Stream::Gone) {
            Stream::Plain(plain) => plain,
            Stream::Zstd(encoder) => encoder.finish()?,
            Stream::Gone => return Err(invalid("KTX2 writer in a failed state".into())),
        };
        self.index[open.p as usize] = LevelIndex {
            byte_offset: open.offset,
            byte_length: plain.count - open.offset,
            uncompressed_byte_length: open.expected,
        };
        self.stream = Stream::Plain(plain);
        Ok(())
    }

    /// Writes the level index (every level must have been written) and returns the output,
    /// positioned at the end of the file.
    pub fn finish(mut self) -> io::Result<W> {
        if self.open.is_some() || self.next.is_some() {
            return Err(invalid("a KTX2 file finished before all its levels".into()));
        }
        let Stream::Plain(plain) = std::mem::replace(&mut self.stream, Stream::Gone) else {
            return Err(invalid("KTX2 writer in a failed state".into()));
        };
        let mut out = plain.inner;
        out.seek(SeekFrom::Start(self.base + HEADER_BYTES))?;
        for level in &self.index {
            for value in [
                level.byte_offset,
                level.byte_length,
                level.uncompressed_byte_length,
            ] {
                out.write_all(&value.to_le_bytes())?;
            }
        }
        out.seek(SeekFrom::Start(self.base + plain.count))?;
        Ok(out)
    }
}

/// Memory a Zstandard stream encoder holds at `level` (1 to 22) for a level of `bytes`
/// uncompressed bytes: the least of `ZSTD_estimateCStreamSize(level)` of zstd 1.5.7 (the zstd-sys
/// crate's; any input size) and a bound from the input's size (zstd shrinks the window to the
/// pledged size, and the hash and chain tables to twice the window: window and input buffer
/// 2 · 2^w, tables 16 · 2^w, plus block buffers).
pub(crate) fn zstd_encoder_bytes(level: i32, bytes: u64) -> u64 {
    /// `ZSTD_estimateCStreamSize(level)`, levels 1 to 22, measured with zstd 1.5.7.
    const ESTIMATE: [u64; 22] = [
        1_369_633,
        2_090_529,
        3_663_393,
        4_974_113,
        6_022_689,
        6_022_689,
        9_168_417,
        9_168_417,
        17_557_025,
        30_139_937,
        30_139_937,
        55_305_761,
        55_305_761,
        55_305_761,
        72_082_977,
        72_082_977,
        72_082_977,
        72_082_977,
        93_848_223,
        202_900_127,
        404_226_719,
        874_070_687,
    ];
    let any_size = ESTIMATE[(level.clamp(1, 22) - 1) as usize];
    let window_log = (64 - bytes.saturating_sub(1).leading_zeros()).clamp(10, 40);
    let by_size = 18u64 << window_log;
    any_size.min(by_size.saturating_add(2 << 20))
}

/// The bake's sink for one output: its texels, encoded, streamed into the open level (the
/// smallest first: a mip chain is baked level by level, [`Ktx2Sink::next_level`] between them).
pub(crate) struct Ktx2Sink {
    pub path: PathBuf,
    writer: Ktx2Writer<io::BufWriter<std::fs::File>>,
    /// The level being written.
    level: u32,
    output: usize,
    format: Ktx2Format,
    bytes: Vec<u8>,
}

impl Ktx2Sink {
    /// Writes the header of output `output`'s file into `file` and opens its smallest level.
    pub fn create(
        path: &Path,
        file: std::fs::File,
        output: usize,
        description: Ktx2Description,
    ) -> Result<Ktx2Sink, BakeError> {
        let io = |source| BakeError::Io {
            path: path.display().to_string(),
            source,
        };
        let format = description.format;
        let level = description.levels.saturating_sub(1);
        let mut writer = Ktx2Writer::new(io::BufWriter::with_capacity(1 << 16, file), description)
            .map_err(io)?;
        writer.begin_level(level).map_err(io)?;
        Ok(Ktx2Sink {
            path: path.to_path_buf(),
            writer,
            level,
            output,
            format,
            bytes: Vec::new(),
        })
    }

    /// Ends the open level and opens the next larger one.
    pub fn next_level(&mut self) -> Result<(), BakeError> {
        let io = |source| BakeError::Io {
            path: self.path.display().to_string(),
            source,
        };
        self.writer.end_level().map_err(io)?;
        self.level = self.level.checked_sub(1).ok_or_else(|| BakeError::Encode {
            path: self.path.display().to_string(),
            message: "internal: no KTX2 level after level 0".into(),
        })?;
        self.writer.begin_level(self.level).map_err(io)
    }

    /// Ends the level, writes the level index, and syncs the file.
    pub fn finish(mut self) -> Result<(), BakeError> {
        let io = |source| BakeError::Io {
            path: self.path.display().to_string(),
            source,
        };
        self.writer.end_level().map_err(io)?;
        let buffered = self.writer.finish().map_err(io)?;
        let file = buffered.into_inner().map_err(|e| io(e.into_error()))?;
        file.sync_all().map_err(io)
    }
}

impl Ktx2Sink {
    /// The sample type of the texture's colour channels.
    fn encoding(&self) -> Encoding {
        match self.format.sample {
            Ktx2SampleType::U8 => Encoding::U8 {
                srgb: self.format.srgb,
            },
            Ktx2SampleType::F16 => Encoding::F16,
            Ktx2SampleType::F32 => Encoding::F32,
        }
    }
}

impl Sink for Ktx2Sink {
    fn stores(&self, output: usize) -> Option<Encoding> {
        (output == self.output).then(|| self.encoding())
    }

    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        let encoding = self.encoding();
        for (s, segment) in window.segments() {
            // RGB colours are stored RGBA, alpha opaque.
            let texel = self.format.channels as usize * encoding.bytes();
            self.bytes.resize(segment.len * texel, 0);
            if self.format.channels == 4 {
                window.copy_encoded_opaque(self.output, s, &segment, encoding, &mut self.bytes);
            } else {
                window.copy_encoded(self.output, s, &segment, encoding, &mut self.bytes);
            }
            self.writer
                .write(&self.bytes)
                .map_err(|source| BakeError::Io {
                    path: self.path.display().to_string(),
                    source,
                })?;
        }
        Ok(())
    }
}

/// The size of a grid as KTX2's 32-bit `pixelWidth`, `pixelHeight`, `pixelDepth`.
pub(crate) fn texture_size(grid: &Grid) -> Option<[u32; 3]> {
    let [x, y, z] = grid.size.map(|n| u32::try_from(n).ok());
    Some([x?, y?, z?])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn description(
        format: Ktx2Format,
        size: [u32; 3],
        levels: u32,
        zstd: Option<i32>,
    ) -> Ktx2Description {
        Ktx2Description {
            format,
            size,
            levels,
            zstd,
            key_values: vec![
                ("KTXwriter".into(), "test".into()),
                ("KTXorientation".into(), ORIENTATION.into()),
            ],
        }
    }

    /// Level p's texels: byte i of level p is `(p * 64 + i) mod 251`.
    fn level_data(writer: &Ktx2Writer<io::Cursor<Vec<u8>>>, p: u32) -> Vec<u8> {
        (0..writer.level_bytes(p))
            .map(|i| ((u64::from(p) * 64 + i) % 251) as u8)
            .collect()
    }

    fn write_levels(description: Ktx2Description) -> (Vec<u8>, Vec<Vec<u8>>) {
        let levels = description.levels;
        let mut writer = Ktx2Writer::new(io::Cursor::new(Vec::new()), description).unwrap();
        let mut data = vec![Vec::new(); levels as usize];
        for p in (0..levels).rev() {
            writer.begin_level(p).unwrap();
            let bytes = level_data(&writer, p);
            // In uneven chunks, as a bake's windows come.
            for chunk in bytes.chunks(7) {
                writer.write(chunk).unwrap();
            }
            writer.end_level().unwrap();
            data[p as usize] = bytes;
        }
        (writer.finish().unwrap().into_inner(), data)
    }

    /// Several levels: stored from the smallest to the largest, each aligned as the spec says,
    /// the index pointing at each; read back by the `ktx2` crate.
    #[test]
    fn a_mip_chain_is_laid_out_smallest_first_and_aligned() {
        for sample in [Ktx2SampleType::U8, Ktx2SampleType::F16, Ktx2SampleType::F32] {
            for ty in [Type::Scalar, Type::Vec3] {
                for zstd in [None, Some(3)] {
                    let format = Ktx2Format::new(ty, sample, true);
                    let size = [5, 3, 4];
                    let (file, data) = write_levels(description(format, size, 3, zstd));
                    let reader = ktx2::Reader::new(&file[..]).unwrap();
                    let header = reader.header();
                    assert_eq!(header.level_count, 3);
                    let index: Vec<[u64; 3]> = (0..3)
                        .map(|p| {
                            let at = 80 + 24 * p;
                            [0, 8, 16].map(|o| {
                                u64::from_le_bytes(file[at + o..at + o + 8].try_into().unwrap())
                            })
                        })
                        .collect();
                    let alignment = format.level_alignment(zstd.is_some());
                    let kvd_end =
                        u64::from(header.index.kvd_byte_offset + header.index.kvd_byte_length);
                    // The smallest level first, right after the key/value data (and padding).
                    assert_eq!(index[2][0], align(kvd_end, alignment));
                    assert!(index[2][0] < index[1][0] && index[1][0] < index[0][0]);
                    for p in 0..3 {
                        let [offset, length, uncompressed] = index[p];
                        assert_eq!(offset % alignment, 0, "{format:?} level {p}");
                        assert_eq!(uncompressed, data[p].len() as u64);
                        let level = &file[offset as usize..(offset + length) as usize];
                        let bytes = match zstd {
                            None => level.to_vec(),
                            Some(_) => zstd::decode_all(level).unwrap(),
                        };
                        assert_eq!(bytes, data[p], "{format:?} level {p}");
                        if p > 0 {
                            // The next larger level follows after at most the padding.
                            let next = align(offset + length, alignment);
                            assert_eq!(index[p - 1][0], next);
                        }
                    }
                    assert_eq!(index[0][0] + index[0][1], file.len() as u64);
                    // Level sizes halve per axis, never below 1: 5×3×4, 2×1×2, 1×1×1.
                    let texel = u64::from(format.texel_bytes());
                    assert_eq!(index[1][2], 2 * 2 * texel);
                    assert_eq!(index[2][2], texel);
                }
            }
        }
    }

    #[test]
    fn levels_out_of_order_or_incomplete_are_refused() {
        let format = Ktx2Format::new(Type::Scalar, Ktx2SampleType::U8, false);
        let mut writer = Ktx2Writer::new(
            io::Cursor::new(Vec::new()),
            description(format, [4, 4, 4], 2, None),
        )
        .unwrap();
        assert!(writer.begin_level(0).is_err(), "level 1 comes first");
        writer.begin_level(1).unwrap();
        writer.write(&[0; 7]).unwrap();
        assert!(writer.write(&[0; 2]).is_err(), "more than the level holds");
        let mut writer = Ktx2Writer::new(
            io::Cursor::new(Vec::new()),
            description(format, [4, 4, 4], 1, None),
        )
        .unwrap();
        writer.begin_level(0).unwrap();
        writer.write(&[0; 63]).unwrap();
        assert!(writer.end_level().is_err(), "one byte short");
        assert!(description(format, [4, 4, 4], 4, None).validate().is_err());
        assert!(description(format, [4, 4, 4], 3, Some(23))
            .validate()
            .is_err());
        assert!(description(format, [4, 4, 4], 3, Some(0))
            .validate()
            .is_err());
    }

    #[test]
    fn alignment_is_the_lcm_of_the_texel_size_and_4() {
        let align_of = |ty, sample| Ktx2Format::new(ty, sample, true).level_alignment(false);
        assert_eq!(align_of(Type::Scalar, Ktx2SampleType::U8), 4);
        assert_eq!(align_of(Type::Vec3, Ktx2SampleType::U8), 4);
        assert_eq!(align_of(Type::Scalar, Ktx2SampleType::F16), 4);
        assert_eq!(align_of(Type::Vec3, Ktx2SampleType::F16), 8);
        assert_eq!(align_of(Type::Scalar, Ktx2SampleType::F32), 4);
        assert_eq!(align_of(Type::Vec3, Ktx2SampleType::F32), 16);
        assert_eq!(
            Ktx2Format::new(Type::Vec3, Ktx2SampleType::F32, true).level_alignment(true),
            1
        );
    }

    /// The DFD of every format is the one the `ktx2` crate derives from the vkFormat (an
    /// independent implementation of the Khronos Data Format tables).
    #[test]
    fn the_dfd_of_every_format_is_the_canonical_one() {
        for sample in [Ktx2SampleType::U8, Ktx2SampleType::F16, Ktx2SampleType::F32] {
            for ty in [Type::Scalar, Type::Vec3] {
                for srgb in [false, true] {
                    let format = Ktx2Format::new(ty, sample, srgb);
                    let vk = ktx2::Format::new(format.vk_format).unwrap();
                    let (basic, type_size) = ktx2::dfd::Basic::from_format(vk).unwrap();
                    let block = ktx2::dfd::Block::Basic(basic).to_vec();
                    let mut expected = ((block.len() + 4) as u32).to_le_bytes().to_vec();
                    expected.extend(block);
                    assert_eq!(format.dfd(), expected, "{}", format.name);
                    assert_eq!(format.type_size(), type_size, "{}", format.name);
                }
            }
        }
    }

    #[test]
    fn the_zstd_memory_bound_shrinks_with_the_input() {
        assert_eq!(zstd_encoder_bytes(22, u64::MAX), 874_070_687);
        assert_eq!(zstd_encoder_bytes(3, u64::MAX), 3_663_393);
        // A 64³ RGBA8 level (1 MiB): a 2^20 window.
        assert_eq!(zstd_encoder_bytes(22, 1 << 20), (18 << 20) + (2 << 20));
        assert!(zstd_encoder_bytes(1, 1) >= 18 << 10);
    }
}
