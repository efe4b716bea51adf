//! The layout and metadata of a bake's store: sample types, the shard layout ([`Sharding`]),
//! the checks before a bake (`preflight`, `held_bytes`), each output's array with its codecs and
//! `texgraph` attributes, and the OME-Zarr multiscale groups of a mip chain. Builds documents;
//! writes nothing.

use super::store::AtomicStore;
use crate::bake::engine::Precision;
use crate::bake::error::BakeError;
use crate::bake::settings::{BakeFileOptions, Transfer, ZarrCompression};
use crate::encoding::Encoding;
use crate::graph::Type;
use crate::grid::Grid;
use crate::tape::Tape;
use std::path::Path;
use std::sync::Arc;
use zarrs::array::codec::{
    BloscCodec, ShardingCodecBuilder, ShardingCodecOptions, SubchunkWriteOrder, ZstdCodec,
};
use zarrs::array::{Array, ArrayBuilder, ArrayMetadataOptions};

/// Sample type of the arrays: 8-bit (colours through `--transfer`), half or single floats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZarrSample {
    U8,
    F16,
    F32,
}

impl ZarrSample {
    pub fn bytes(self) -> u64 {
        match self {
            ZarrSample::U8 => 1,
            ZarrSample::F16 => 2,
            ZarrSample::F32 => 4,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            ZarrSample::U8 => "uint8",
            ZarrSample::F16 => "float16",
            ZarrSample::F32 => "float32",
        }
    }

    fn data_type(self) -> zarrs::array::DataType {
        use zarrs::array::data_type;
        match self {
            ZarrSample::U8 => data_type::uint8(),
            ZarrSample::F16 => data_type::float16(),
            ZarrSample::F32 => data_type::float32(),
        }
    }

    /// How values are stored in this type (`srgb`: the array's colours are sRGB-encoded).
    pub(super) fn encoding(self, srgb: bool) -> Encoding {
        match self {
            ZarrSample::U8 => Encoding::U8 { srgb },
            ZarrSample::F16 => Encoding::F16,
            ZarrSample::F32 => Encoding::F32,
        }
    }

    /// Writes `values` in this type's little-endian bytes (the `bytes` codec's input, little
    /// endian as zarrs' default) into `out`.
    pub(super) fn encode(self, values: &[f32], srgb: bool, out: &mut [u8]) {
        let encoding = self.encoding(srgb);
        encoding.encode_run(values, out, encoding.bytes());
    }
}

/// The shape of a bake's store: array shape, shard and chunk sides (per axis, z y x order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sharding {
    /// Voxels per axis, z, y, x.
    pub shape: [u64; 3],
    /// Shard side per axis (z, y, x): `--shard` clipped to the array rounded up to whole chunks.
    pub shard: [u64; 3],
    /// Inner chunk side per axis: `--chunk` clipped to the array.
    pub chunk: [u64; 3],
}

impl Sharding {
    /// Checks `--chunk` and `--shard` and clips them to the grid.
    pub fn new(grid: &Grid, chunk: u64, shard: u64) -> Result<Sharding, BakeError> {
        if chunk == 0 || shard == 0 {
            return Err(BakeError::Refused(
                "--chunk and --shard must be at least 1 voxel".into(),
            ));
        }
        if !shard.is_multiple_of(chunk) {
            return Err(BakeError::Refused(format!(
                "--shard {shard} is not a multiple of --chunk {chunk}: a shard holds whole chunks"
            )));
        }
        let [nx, ny, nz] = grid.size.map(|n| n as u64);
        let shape = [nz, ny, nx];
        let chunk = shape.map(|n| chunk.min(n));
        let mut clipped = [0; 3];
        for a in 0..3 {
            clipped[a] = shard.min(shape[a].div_ceil(chunk[a]) * chunk[a]);
        }
        Ok(Sharding {
            shape,
            shard: clipped,
            chunk,
        })
    }

    /// Shards per axis (z, y, x).
    pub fn shards(&self) -> [u64; 3] {
        [0, 1, 2].map(|a| self.shape[a].div_ceil(self.shard[a]))
    }

    pub fn shard_count(&self) -> u64 {
        self.shards().iter().product()
    }

    /// Shard number `s` (C order, z slowest) as (kz, ky, kx).
    pub fn shard_index(&self, s: u64) -> [u64; 3] {
        let [_, sy, sx] = self.shards();
        [s / (sy * sx), (s / sx) % sy, s % sx]
    }

    /// Voxels per shard (the full shard shape, edges included).
    pub fn shard_voxels(&self) -> u64 {
        self.shard.iter().product()
    }

    /// The voxel ranges of shard `k` inside the array, per axis (z, y, x).
    pub fn shard_ranges(&self, k: [u64; 3]) -> [std::ops::Range<u64>; 3] {
        [0, 1, 2].map(|a| {
            let start = k[a] * self.shard[a];
            start..(start + self.shard[a]).min(self.shape[a])
        })
    }
}

/// One output's array while a bake runs.
pub(super) struct OutputArray {
    pub(super) name: String,
    pub(super) ty: Type,
    pub(super) first_channel: usize,
    pub(super) srgb: bool,
    pub(super) array: Array<AtomicStore>,
    /// Fingerprint (crc32c) of the array's metadata document.
    pub(super) metadata_crc: u32,
}

/// The sample type `options` asks for.
pub fn sample_type(options: &BakeFileOptions) -> ZarrSample {
    match options.ktx2_type {
        crate::bake::settings::Ktx2SampleType::U8 => ZarrSample::U8,
        crate::bake::settings::Ktx2SampleType::F16 => ZarrSample::F16,
        crate::bake::settings::Ktx2SampleType::F32 => ZarrSample::F32,
    }
}

/// Bytes a zarr bake holds beyond evaluation: three shards' worth per output (the shard being
/// evaluated, the one being written, and that one's encoding; evaluation and writing overlap).
pub fn held_bytes(tape: &Tape, options: &BakeFileOptions) -> Result<u64, BakeError> {
    let sharding = Sharding::new(&options.bake.grid, options.zarr.chunk, options.zarr.shard)?;
    let sample = sample_type(options).bytes();
    Ok(tape
        .outputs
        .iter()
        .map(|o| {
            sharding
                .shard_voxels()
                .saturating_mul(o.ty.channels() as u64 * sample)
                .saturating_mul(3)
        })
        .fold(0, u64::saturating_add))
}

/// What is checked before a zarr bake starts: `--chunk` / `--shard`, the bytes this part writes
/// (uncompressed) against the size limit, and what it holds in memory against the memory bound.
pub fn preflight(tape: &Tape, options: &BakeFileOptions) -> Result<(), BakeError> {
    let sharding = Sharding::new(&options.bake.grid, options.zarr.chunk, options.zarr.shard)?;
    let part = options.zarr.part;
    let owned: u64 = (0..sharding.shard_count())
        .filter(|&s| part.owns(s))
        .map(|s| {
            sharding
                .shard_ranges(sharding.shard_index(s))
                .iter()
                .map(|r| r.end - r.start)
                .product::<u64>()
        })
        .sum();
    let sample = sample_type(options).bytes();
    let estimate = tape
        .outputs
        .iter()
        .map(|o| owned.saturating_mul(o.ty.channels() as u64 * sample))
        .fold(0u64, u64::saturating_add);
    if estimate > options.max_bytes {
        return Err(BakeError::Refused(format!(
            "this bake{} would write about {} uncompressed ({owned} voxels × {} output(s)), more than the limit of {}; split it with --part I/N, or raise the limit (--allow-large)",
            if part.is_whole() { String::new() } else { format!(" (part {part})") },
            crate::bake::settings::human_bytes(estimate),
            tape.outputs.len(),
            crate::bake::settings::human_bytes(options.max_bytes)
        )));
    }
    let held = held_bytes(tape, options)?;
    if held > options.max_held_bytes {
        return Err(BakeError::Refused(format!(
            "a zarr bake holds each output's shard in memory while it encodes it: shards of {:?} voxels (z, y, x) hold about {}, more than the limit of {}; use a smaller --shard, or pass --allow-large",
            sharding.shard,
            crate::bake::settings::human_bytes(held),
            crate::bake::settings::human_bytes(options.max_held_bytes)
        )));
    }
    Ok(())
}

/// The `texgraph` attributes shared by the group and every array.
pub(super) fn texgraph_attributes(
    options: &BakeFileOptions,
    tape: &Tape,
) -> serde_json::Map<String, serde_json::Value> {
    let grid = options.bake.grid;
    let mut map = serde_json::Map::new();
    let mut t = serde_json::Map::new();
    t.insert("version".into(), env!("CARGO_PKG_VERSION").into());
    // The file name only: the parts of a split bake may name one file by different paths (a
    // relative path, another mount point), and every part must write the same metadata. What
    // the graph computes is in `tape`.
    let graph_name = Path::new(&options.graph_path)
        .file_name()
        .map_or(options.graph_path.clone(), |n| {
            n.to_string_lossy().into_owned()
        });
    t.insert("graph".into(), graph_name.into());
    t.insert(
        "params".into(),
        serde_json::Value::Object(crate::bake::settings::params_map(&options.params)),
    );
    t.insert(
        "overrides".into(),
        serde_json::Value::Object(crate::bake::settings::params_map(&options.overrides)),
    );
    t.insert(
        "region".into(),
        serde_json::json!({"min": grid.region.min, "max": grid.region.max}),
    );
    t.insert("size".into(), serde_json::json!(grid.size));
    t.insert(
        "voxel_centres".into(),
        "voxel (i, j, k) = array[k, j, i] samples region.min + (index + 0.5) * (region.max - region.min) / size, per axis"
            .into(),
    );
    t.insert(
        "precision".into(),
        match options.bake.precision {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
        .into(),
    );
    t.insert("tape".into(), format!("{:016x}", tape.fingerprint()).into());
    map.insert("texgraph".into(), serde_json::Value::Object(t));
    map
}

/// Builds (does not write) the array of one output.
pub(super) fn build_array(
    store: &Arc<AtomicStore>,
    options: &BakeFileOptions,
    tape: &Tape,
    sharding: &Sharding,
    output: &crate::tape::TapeOutput,
    path: &str,
) -> Result<Array<AtomicStore>, BakeError> {
    let sample = sample_type(options);
    let channels = output.ty.channels() as u64;
    let colour = output.ty == Type::Vec3;
    let mut shape = sharding.shape.to_vec();
    let mut shard = sharding.shard.to_vec();
    let mut chunk = sharding.chunk.to_vec();
    let mut dims = vec!["z", "y", "x"];
    if colour {
        shape.push(channels);
        shard.push(channels);
        chunk.push(channels);
        dims.push("c");
    }
    let data_type = sample.data_type();
    let mut sharding_codec = ShardingCodecBuilder::new(
        chunk
            .iter()
            .map(|&n| std::num::NonZeroU64::new(n).expect("sides are at least 1"))
            .collect(),
        &data_type,
    );
    let typesize = sample.bytes() as usize;
    let compressor: Vec<Arc<dyn zarrs::array::codec::api::BytesToBytesCodecTraits>> =
        match options.zarr.compression {
            ZarrCompression::Zstd => vec![Arc::new(ZstdCodec::new(
                options
                    .zstd
                    .unwrap_or(crate::bake::settings::DEFAULT_ZSTD_LEVEL),
                false,
            ))],
            ZarrCompression::Blosc => {
                use zarrs::metadata_ext::codec::blosc::{BloscCompressor, BloscShuffleMode};
                let shuffle = if typesize == 1 {
                    BloscShuffleMode::BitShuffle
                } else {
                    BloscShuffleMode::Shuffle
                };
                let codec = BloscCodec::new(
                    BloscCompressor::LZ4,
                    5u8.try_into().expect("5 is a blosc level"),
                    None,
                    shuffle,
                    Some(typesize),
                )
                .map_err(|e| BakeError::Refused(format!("blosc: {e}")))?;
                vec![Arc::new(codec)]
            }
            ZarrCompression::None => Vec::new(),
        };
    sharding_codec.bytes_to_bytes_codecs(compressor);
    let fill: zarrs::array::FillValue = match sample {
        ZarrSample::U8 => 0u8.into(),
        ZarrSample::F16 => half::f16::ZERO.into(),
        ZarrSample::F32 => 0f32.into(),
    };
    let mut attributes = texgraph_attributes(options, tape);
    if let Some(serde_json::Value::Object(t)) = attributes.get_mut("texgraph") {
        t.insert("output".into(), output.name.clone().into());
        t.insert(
            "type".into(),
            if colour { "colour" } else { "scalar" }.into(),
        );
        let transfer = if colour && sample == ZarrSample::U8 {
            match options.transfer {
                Transfer::Srgb => "srgb",
                Transfer::Linear => "linear",
            }
        } else {
            "linear"
        };
        t.insert("transfer".into(), transfer.into());
    }
    let path = format!("/{path}");
    ArrayBuilder::new(shape, shard, data_type, fill)
        // Inner chunks in C order, whatever order the threads finish them in: a shard's bytes
        // are a function of its values (zarrs' default appends them as they complete).
        .array_to_bytes_codec(Arc::new(sharding_codec.build().with_options(
            ShardingCodecOptions::default().with_subchunk_write_order(SubchunkWriteOrder::C),
        )))
        .dimension_names(Some(dims))
        .attributes(attributes)
        .build(store.clone(), &path)
        .map_err(|e| BakeError::Refused(format!("{path}: {e}")))
}

/// Options for metadata documents: no zarrs version stamp, so every texgraph build that makes
/// the same array writes the same bytes whatever zarrs version it links.
fn metadata_options() -> ArrayMetadataOptions {
    ArrayMetadataOptions::default().with_include_zarrs_metadata(false)
}

/// The JSON document of an array's metadata, as written.
pub(super) fn metadata_json(array: &Array<AtomicStore>) -> Result<Vec<u8>, BakeError> {
    serde_json::to_vec_pretty(&array.metadata_opt(&metadata_options()))
        .map_err(|e| BakeError::Refused(format!("array metadata: {e}")))
}

/// The store path (relative, `/`-separated) of output `name`'s array at `level`: `name`, or
/// `name/L` in a multiscale group.
pub(super) fn array_path(name: &str, level: usize, multiscale: bool) -> String {
    if multiscale {
        format!("{name}/{level}")
    } else {
        name.to_string()
    }
}

/// The OME-Zarr (NGFF 0.5) `multiscales` attributes of output `output`'s group: one dataset
/// per level with its voxel size and the offset of its first voxel centre.
fn ome_attributes(
    output: &crate::tape::TapeOutput,
    grid: &Grid,
    levels: usize,
    filter: crate::filter::Filter,
) -> serde_json::Value {
    let mut axes = vec![
        serde_json::json!({"name": "z", "type": "space"}),
        serde_json::json!({"name": "y", "type": "space"}),
        serde_json::json!({"name": "x", "type": "space"}),
    ];
    if output.ty == Type::Vec3 {
        axes.push(serde_json::json!({"name": "c", "type": "channel"}));
    }
    let datasets: Vec<serde_json::Value> = (0..levels)
        .map(|level| {
            let g = crate::bake::settings::mip_grid(grid, level as u32);
            let s = g.spacing();
            let mut scale = vec![s[2], s[1], s[0]];
            let mut translation = vec![g.centre(2, 0), g.centre(1, 0), g.centre(0, 0)];
            if output.ty == Type::Vec3 {
                scale.push(1.0);
                translation.push(0.0);
            }
            serde_json::json!({
                "path": level.to_string(),
                "coordinateTransformations": [
                    {"type": "scale", "scale": scale},
                    {"type": "translation", "translation": translation},
                ],
            })
        })
        .collect();
    serde_json::json!({
        "version": "0.5",
        "multiscales": [{
            "name": output.name,
            "axes": axes,
            "datasets": datasets,
            "type": match filter {
                crate::filter::Filter::Point => "graph-prefiltered: each level baked from the graph with footprint level of detail",
                crate::filter::Filter::Box => "box-filtered: each voxel the graph's filtered estimate of its mean over its cell",
            },
        }],
    })
}

/// Builds the multiscale group of every output (writes nothing).
pub(super) fn output_groups(
    store: &Arc<AtomicStore>,
    tapes: &[&Tape],
    options: &BakeFileOptions,
) -> Result<Vec<(String, Vec<u8>)>, BakeError> {
    let mut groups = Vec::new();
    for output in &tapes[0].outputs {
        let mut attributes = texgraph_attributes(options, tapes[0]);
        if let Some(serde_json::Value::Object(t)) = attributes.get_mut("texgraph") {
            t.insert(
                "mips".into(),
                crate::bake::settings::mips_note(options.bake.filter).into(),
            );
            t.insert("output".into(), output.name.clone().into());
        }
        attributes.insert(
            "ome".into(),
            ome_attributes(output, &options.bake.grid, tapes.len(), options.bake.filter),
        );
        let group = zarrs::group::GroupBuilder::new()
            .attributes(attributes)
            .build(store.clone(), &format!("/{}", output.name))
            .map_err(|e| BakeError::Refused(format!("zarr group {}: {e}", output.name)))?;
        let json = group_json(&group)?;
        groups.push((output.name.clone(), json));
    }
    Ok(groups)
}

pub(super) fn group_json(group: &zarrs::group::Group<AtomicStore>) -> Result<Vec<u8>, BakeError> {
    match group.metadata_opt(&Default::default()) {
        zarrs::group::GroupMetadata::V3(m) => serde_json::to_vec_pretty(&m)
            .map_err(|e| BakeError::Refused(format!("group metadata: {e}"))),
        _ => Err(BakeError::Refused("internal: not a Zarr v3 group".into())),
    }
}
