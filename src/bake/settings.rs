//! What the file writers of a bake share, below all of them: the options of a file bake
//! ([`BakeFileOptions`] and the format choices it holds, each writer's among them), what a bake
//! reports ([`BakeReport`]), mip chains' grids, the atlas shape and the params as JSON. The
//! writers (`sinks.rs`, `ktx2.rs`, `zarr.rs`, `vdb_bake.rs`) stand on it and on the engine;
//! `files.rs`, the dispatch, stands above them.

use super::engine::{BakeOptions, OutputStats};
use super::part::Part;
use crate::grid::Grid;
use std::ops::RangeInclusive;
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// One OpenEXR file per output: 32-bit float (or half), slices stacked vertically.
    Exr,
    /// PNG slices in a folder per output (or one atlas image with --atlas).
    #[default]
    Png,
    /// Packed voxels (x fastest, then y, then z) with a JSON sidecar.
    Raw,
    /// One KTX 2.0 file per output holding a 3D texture: 8-bit (R8 / RGBA8 sRGB), or half or
    /// single floats with --half / --float; --zstd supercompresses it.
    Ktx2,
    /// A Zarr v3 store per graph (an array per output, chunked and sharded): 8-bit, or half or
    /// single floats with --half / --float; --part splits it over processes.
    Zarr,
    /// One OpenVDB file per graph: a float grid per scalar output, a vec3s grid per colour
    /// output (values as evaluated), transform from the region.
    Vdb,
}

impl Format {
    /// The name on the command line (`--format NAME`).
    pub fn name(self) -> &'static str {
        match self {
            Format::Exr => "exr",
            Format::Png => "png",
            Format::Raw => "raw",
            Format::Ktx2 => "ktx2",
            Format::Zarr => "zarr",
            Format::Vdb => "vdb",
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Transfer {
    /// Colour outputs are linear and get the sRGB transfer function in 8/16-bit files.
    #[default]
    Srgb,
    /// Colour values are written as they are (clamped and scaled).
    Linear,
}

/// Lossless compression of EXR files (all of OpenEXR's lossless methods that the `exr` crate
/// writes). docs/baking.md has the measured sizes and times behind the default.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum ExrCompression {
    /// ZIP (deflate) over blocks of 16 scan lines.
    #[default]
    Zip,
    /// PIZ (wavelet + Huffman) over tiles of 256×256.
    Piz,
    /// Run-length encoding over tiles of 64×64.
    Rle,
    /// No compression.
    None,
}

impl ExrCompression {
    pub fn name(self) -> &'static str {
        match self {
            ExrCompression::Zip => "ZIP (16 scan lines per block)",
            ExrCompression::Piz => "PIZ (256×256 tiles)",
            ExrCompression::Rle => "RLE (64×64 tiles)",
            ExrCompression::None => "none",
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum RawSampleType {
    /// One byte per channel, 0..=255 (colours through --transfer).
    #[default]
    U8,
    /// Little-endian 32-bit floats, values as evaluated.
    F32,
}

/// What a KTX2 file stores per channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Ktx2SampleType {
    /// 8-bit unsigned normalised: scalars `R8_UNORM`, colours `R8G8B8A8_SRGB` (or `_UNORM` with
    /// the linear transfer), encoded as the PNG writer encodes them.
    #[default]
    U8,
    /// 16-bit floats (`--half`): `R16_SFLOAT`, `R16G16B16A16_SFLOAT`.
    F16,
    /// 32-bit floats (`--float`): `R32_SFLOAT`, `R32G32B32A32_SFLOAT`.
    F32,
}

/// Zstandard levels `--zstd` accepts (those of the zstd library).
pub const ZSTD_LEVELS: RangeInclusive<i32> = 1..=22;
/// The level of a bare `--zstd`: the zstd library's own default, and KTX-Software's (`toktx
/// --zcmp`). docs/baking.md has the measurements behind it.
pub const DEFAULT_ZSTD_LEVEL: i32 = 3;

/// Default voxels per inner chunk side (`--chunk`).
pub const DEFAULT_CHUNK: u64 = 64;
/// Default voxels per shard side (`--shard`).
pub const DEFAULT_SHARD: u64 = 512;
/// How chunks are compressed inside a shard.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum ZarrCompression {
    /// Zstandard at the `--zstd=LEVEL` level (default 3).
    #[default]
    Zstd,
    /// Blosc: LZ4 at level 5 with byte shuffle (bit shuffle for 8-bit samples).
    Blosc,
    /// No compression.
    None,
}

/// The zarr-specific options of a bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ZarrSettings {
    pub chunk: u64,
    pub shard: u64,
    pub compression: ZarrCompression,
    /// Which shards this process bakes.
    pub part: Part,
}

impl Default for ZarrSettings {
    fn default() -> Self {
        ZarrSettings {
            chunk: DEFAULT_CHUNK,
            shard: DEFAULT_SHARD,
            compression: ZarrCompression::Zstd,
            part: Part::WHOLE,
        }
    }
}

/// Everything a file bake needs besides the tape.
#[derive(Clone, Debug)]
pub struct BakeFileOptions {
    pub bake: BakeOptions,
    pub format: Format,
    pub out_dir: PathBuf,
    /// The name files are derived from (a graph file's stem).
    pub stem: String,
    /// Overwrite existing outputs.
    pub force: bool,
    /// EXR: 16-bit half floats instead of 32-bit.
    pub half: bool,
    /// PNG: 16-bit samples instead of 8-bit.
    pub depth16: bool,
    /// PNG: one tiled atlas image instead of a folder of slices.
    pub atlas: bool,
    pub raw_type: RawSampleType,
    /// Raw: add an opaque alpha channel (RGBA / grey+alpha).
    pub alpha: bool,
    /// KTX2: 8-bit (default), half or single floats.
    pub ktx2_type: Ktx2SampleType,
    /// KTX2: Zstandard supercompression at this level (1 to 22; `None`: none). Zarr: the zstd
    /// level (`None`: the default, 3).
    pub zstd: Option<i32>,
    /// Zarr: chunking, sharding, compression and which part of the shards to bake.
    pub zarr: ZarrSettings,
    /// Mip levels, level 0 (the grid) first; 1 without `--mips`. Set by [`bake_mipmapped`](crate::bake::bake_mipmapped).
    pub levels: u32,
    pub transfer: Transfer,
    /// Refuse a bake whose files would exceed this many bytes (uncompressed estimate).
    pub max_bytes: u64,
    /// Refuse a bake whose format would hold more than this many bytes in memory (EXR: the
    /// whole volume; PNG atlas: a row of tiles; PNG slices: two rows; KTX2 with Zstandard: the
    /// encoder's window and tables).
    pub max_held_bytes: u64,
    /// EXR compression.
    pub exr_compression: ExrCompression,
    /// Recorded in the raw sidecar, the EXR header and the KTX2 key/value data.
    pub graph_path: String,
    /// The params the graph was baked with (overrides applied), in file order.
    pub params: Vec<(String, f64)>,
    /// The `--set` overrides, as given.
    pub overrides: Vec<(String, f64)>,
}

/// Default for [`BakeFileOptions::max_bytes`]: 16 GiB.
pub const DEFAULT_MAX_BAKE_BYTES: u64 = 16 << 30;
/// Default for [`BakeFileOptions::max_held_bytes`]: 2 GiB.
pub const DEFAULT_MAX_HELD_BYTES: u64 = 2 << 30;

impl BakeFileOptions {
    pub fn new(stem: impl Into<String>, out_dir: impl Into<PathBuf>) -> BakeFileOptions {
        BakeFileOptions {
            bake: BakeOptions::default(),
            format: Format::Png,
            out_dir: out_dir.into(),
            stem: stem.into(),
            force: false,
            half: false,
            depth16: false,
            atlas: false,
            raw_type: RawSampleType::U8,
            alpha: false,
            ktx2_type: Ktx2SampleType::U8,
            zstd: None,
            zarr: ZarrSettings::default(),
            levels: 1,
            transfer: Transfer::Srgb,
            max_bytes: DEFAULT_MAX_BAKE_BYTES,
            max_held_bytes: DEFAULT_MAX_HELD_BYTES,
            exr_compression: ExrCompression::default(),
            graph_path: String::new(),
            params: Vec::new(),
            overrides: Vec::new(),
        }
    }
}

/// A file (or folder of slices) a bake wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedFile {
    pub output: String,
    pub path: PathBuf,
    /// What it is, for the report: "EXR 64×64×64 RGB f32", "64 PNG slices", ...
    pub description: String,
}

/// What one file bake did.
#[derive(Clone, Debug)]
pub struct BakeReport {
    pub files: Vec<BakedFile>,
    pub stats: Vec<OutputStats>,
    pub voxels: u64,
    pub seconds: f64,
}

/// What every mip level of a texgraph bake is, in words (KTX2 key `texgraph.mips`, zarr
/// attributes, docs/baking.md), for the bake's filter.
pub fn mips_note(filter: crate::filter::Filter) -> &'static str {
    match filter {
        crate::filter::Filter::Point => "level L has max(1, n >> L) voxels per axis over the same region, each baked from the graph at its own voxel centres with footprint level of detail for its spacing (octaves finer than the voxel left out, faded, their mean added back), not box-filtered from level 0",
        crate::filter::Filter::Box => "level L has max(1, n >> L) voxels per axis over the same region, each voxel the graph's filtered estimate of its mean over its own cell (texgraph's filtered form, one evaluation per voxel), not box-filtered from level 0",
    }
}

/// Levels of a full mip chain of `grid`: down to 1 voxel on every axis (⌊log2(largest side)⌋ + 1).
pub fn mip_level_count(grid: &Grid) -> u32 {
    let largest = grid.size.iter().copied().max().unwrap_or(1).max(1) as u64;
    64 - largest.leading_zeros()
}

/// Level `level` of `grid`'s mip chain: max(1, n >> level) voxels per axis, the same region.
pub fn mip_grid(grid: &Grid, level: u32) -> Grid {
    Grid {
        size: grid
            .size
            .map(|n| (n.checked_shr(level).unwrap_or(0)).max(1)),
        region: grid.region,
    }
}

/// The footprint a level is baked with: its smallest voxel side (as `bake --lod` takes it).
/// `None` for a flat region (no footprint).
pub fn mip_spacing(grid: &Grid, level: u32) -> Option<f64> {
    let spacing = mip_grid(grid, level)
        .spacing()
        .into_iter()
        .fold(f64::INFINITY, f64::min);
    (spacing > 0.0 && spacing.is_finite()).then_some(spacing)
}

/// Columns and rows of tiles of an atlas of `nz` slices: ⌈√nz⌉ columns.
pub(crate) fn atlas_shape(nz: u64) -> (u64, u64) {
    let columns = ((nz as f64).sqrt().ceil() as u64).max(1);
    (columns, nz.div_ceil(columns))
}
/// `{"period":1.3,"octaves":2.0}`: params or overrides as a JSON object, in order.
pub(crate) fn params_json(params: &[(String, f64)]) -> String {
    serde_json::Value::Object(params_map(params)).to_string()
}

pub(crate) fn params_map(params: &[(String, f64)]) -> serde_json::Map<String, serde_json::Value> {
    params
        .iter()
        .map(|(k, v)| (k.clone(), serde_json::json!(v)))
        .collect()
}
/// "1.5 GiB", "640 KiB".
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit < UNITS.len() - 1 {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}
