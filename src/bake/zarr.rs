//! `bake --format zarr`: a Zarr v3 store per graph, written with the `zarrs` crate (metadata,
//! chunk grid, sharding codec with a crc32c index, zstd / blosc, chunk keys); texgraph adds only
//! how a bake is cut into shards, which process bakes which (`--part`), and how a re-run knows
//! what is already done.
//!
//! Layout of `STORE` (`--out X.zarr`, or `--out DIR` → `DIR/STEM.zarr`):
//! - `zarr.json`: the root group, attributes `texgraph` (graph, params, region, size, version).
//! - `OUTPUT/zarr.json`: one array per output, shape (nz, ny, nx) or (nz, ny, nx, 3), dimension
//!   names z, y, x(, c); chunk grid = shards of `--shard` voxels a side (clipped to the array,
//!   whole chunks), each holding inner chunks of `--chunk` voxels a side (and all 3 channels).
//! - `OUTPUT/c/KZ/KY/KX`: a shard (zarr's default chunk key encoding), and beside it
//!   `OUTPUT/c/KZ/KY/KX.texgraph.json`: its manifest (byte length, crc32c of the shard's bytes,
//!   the fingerprints of the tape and of the array metadata it was baked for).
//!
//! Every write goes to a hidden temporary in the destination's folder and is renamed into place
//! ([`AtomicStore`]), the shard first, its manifest after: a shard with a matching manifest is
//! complete. Metadata is a pure function of the graph and the options, so every part writes the
//! same bytes (idempotent). A part evaluates its shards one at a time, whole shards only, so no
//! two parts write the same key, and every voxel is evaluated by the same code from its global
//! index: the store is bit-identical whatever the parts and the order they run or re-run in.

pub use super::settings::{ZarrCompression, ZarrSettings, DEFAULT_CHUNK, DEFAULT_SHARD};

use super::engine::collect_stats;
use super::engine::{BakeError, ChannelStats, Precision};
use super::settings::Transfer;
use super::settings::{BakeFileOptions, BakeReport, BakedFile};
use super::sinks::encode_u8;
use crate::eval::Workspace;
use crate::graph::Type;
use crate::grid::Grid;
use crate::output;
use crate::real::Real;
use crate::tape::Tape;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use zarrs::array::codec::api::ArrayToBytesCodecTraits;
use zarrs::array::codec::{
    BloscCodec, ShardingCodecBuilder, ShardingCodecOptions, SubchunkWriteOrder, ZstdCodec,
};
use zarrs::array::{Array, ArrayBuilder, ArrayBytes, ArrayMetadataOptions, CodecOptions};
use zarrs::storage::{
    Bytes, OffsetBytesIterator, StorageError, StoreKey, StorePrefix, WritableStorageTraits,
};

/// Suffix of a shard's manifest key.
pub const MANIFEST_SUFFIX: &str = ".texgraph.json";

/// The store a graph's bake writes: `--out` itself when it ends in `.zarr`, else `DIR/STEM.zarr`.
pub fn store_path(options: &BakeFileOptions) -> Result<PathBuf, BakeError> {
    let out = &options.out_dir;
    if out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("zarr"))
    {
        Ok(out.clone())
    } else {
        Ok(output::join_inside(out, &format!("{}.zarr", options.stem))?)
    }
}

/// A filesystem store whose every `set` is atomic: the value goes to a hidden temporary in the
/// key's folder, is synced and renamed over the key ([`output::write_atomic`]). Only what a bake
/// needs: whole values, erase.
pub struct AtomicStore {
    root: PathBuf,
}

impl AtomicStore {
    pub fn new(root: impl Into<PathBuf>) -> AtomicStore {
        AtomicStore { root: root.into() }
    }

    fn path(&self, key: &StoreKey) -> PathBuf {
        self.root.join(key.as_str())
    }

    fn write(&self, key: &str, value: &[u8]) -> Result<(), StorageError> {
        let path = self.root.join(key);
        std::fs::create_dir_all(output::parent_dir(&path))?;
        output::write_atomic(&path, |w| w.write_all(value))
            .map_err(|e| StorageError::Other(e.to_string()))
    }
}

impl WritableStorageTraits for AtomicStore {
    fn set(&self, key: &StoreKey, value: Bytes) -> Result<(), StorageError> {
        self.write(key.as_str(), &value)
    }

    fn set_partial_many(
        &self,
        key: &StoreKey,
        _offset_values: OffsetBytesIterator,
    ) -> Result<(), StorageError> {
        Err(StorageError::Other(format!(
            "{}: texgraph writes whole values only",
            key.as_str()
        )))
    }

    fn erase(&self, key: &StoreKey) -> Result<(), StorageError> {
        match std::fs::remove_file(self.path(key)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e.into()),
            _ => Ok(()),
        }
    }

    fn erase_prefix(&self, prefix: &StorePrefix) -> Result<(), StorageError> {
        match std::fs::remove_dir_all(self.root.join(prefix.as_str())) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e.into()),
            _ => Ok(()),
        }
    }

    fn supports_set_partial(&self) -> bool {
        false
    }
}

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

    /// Appends `values` in this type's native-endian bytes (the `bytes` codec's input).
    fn encode(self, values: &[f32], srgb: bool, out: &mut [u8]) {
        match self {
            ZarrSample::U8 => {
                for (o, &v) in out.iter_mut().zip(values) {
                    *o = encode_u8(v, srgb);
                }
            }
            ZarrSample::F16 => {
                for (o, &v) in out.chunks_exact_mut(2).zip(values) {
                    o.copy_from_slice(&half::f16::from_f32(v).to_ne_bytes());
                }
            }
            ZarrSample::F32 => {
                for (o, &v) in out.chunks_exact_mut(4).zip(values) {
                    o.copy_from_slice(&v.to_ne_bytes());
                }
            }
        }
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
struct OutputArray {
    name: String,
    ty: Type,
    first_channel: usize,
    srgb: bool,
    array: Array<AtomicStore>,
    /// Fingerprint (crc32c) of the array's metadata document.
    metadata_crc: u32,
}

/// The sample type `options` asks for.
pub fn sample_type(options: &BakeFileOptions) -> ZarrSample {
    match options.ktx2_type {
        super::settings::Ktx2SampleType::U8 => ZarrSample::U8,
        super::settings::Ktx2SampleType::F16 => ZarrSample::F16,
        super::settings::Ktx2SampleType::F32 => ZarrSample::F32,
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
            super::settings::human_bytes(estimate),
            tape.outputs.len(),
            super::settings::human_bytes(options.max_bytes)
        )));
    }
    let held = held_bytes(tape, options)?;
    if held > options.max_held_bytes {
        return Err(BakeError::Refused(format!(
            "a zarr bake holds each output's shard in memory while it encodes it: shards of {:?} voxels (z, y, x) hold about {}, more than the limit of {}; use a smaller --shard, or pass --allow-large",
            sharding.shard,
            super::settings::human_bytes(held),
            super::settings::human_bytes(options.max_held_bytes)
        )));
    }
    Ok(())
}

/// The `texgraph` attributes shared by the group and every array.
fn texgraph_attributes(
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
        serde_json::Value::Object(super::settings::params_map(&options.params)),
    );
    t.insert(
        "overrides".into(),
        serde_json::Value::Object(super::settings::params_map(&options.overrides)),
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

fn storage(path: &str) -> impl Fn(StorageError) -> BakeError + '_ {
    move |e| BakeError::Encode {
        path: path.to_string(),
        message: e.to_string(),
    }
}

/// Builds (does not write) the array of one output.
fn build_array(
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
                options.zstd.unwrap_or(super::settings::DEFAULT_ZSTD_LEVEL),
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
fn metadata_json(array: &Array<AtomicStore>) -> Result<Vec<u8>, BakeError> {
    serde_json::to_vec_pretty(&array.metadata_opt(&metadata_options()))
        .map_err(|e| BakeError::Refused(format!("array metadata: {e}")))
}

/// What is at the store path must be absent, an empty folder, or a Zarr v3 group.
fn check_store(store: &Path) -> Result<(), BakeError> {
    output::check_out_folder(store)?;
    if !store.exists() {
        return Ok(());
    }
    let root = store.join("zarr.json");
    match std::fs::read(&root) {
        Ok(bytes) => {
            let doc: serde_json::Value = serde_json::from_slice(&bytes).map_err(|e| {
                BakeError::Refused(format!(
                    "{}: not a Zarr v3 metadata document: {e}",
                    root.display()
                ))
            })?;
            if doc["zarr_format"] != 3 || doc["node_type"] != "group" {
                return Err(BakeError::Refused(format!(
                    "{}: is not a Zarr v3 group (zarr_format {}, node_type {}); refusing to write into it",
                    root.display(),
                    doc["zarr_format"],
                    doc["node_type"]
                )));
            }
            Ok(())
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // Another part may have written the document between the two looks.
            if only_metadata_temporaries(store)? || root.exists() {
                Ok(())
            } else {
                Err(BakeError::Refused(format!(
                    "{}: exists and is not a Zarr store (no zarr.json); refusing to write into it: give --out a new path",
                    store.display()
                )))
            }
        }
        Err(e) => Err(BakeError::Io {
            path: root.display().to_string(),
            source: e,
        }),
    }
}

/// Whether `dir` is empty or holds only the temporary of a `zarr.json` another part is writing
/// right now (parts start together; a node's document is written before anything inside it).
fn only_metadata_temporaries(dir: &Path) -> Result<bool, BakeError> {
    Ok(std::fs::read_dir(dir)
        .map_err(|e| BakeError::Io {
            path: dir.display().to_string(),
            source: e,
        })?
        .flatten()
        .all(|entry| {
            entry
                .file_name()
                .to_str()
                .is_some_and(|n| n.starts_with(".zarr.json.") && n.ends_with(".partial"))
        }))
}

/// What to do with an array's folder before writing its metadata.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Existing {
    /// Absent, or baked with the same metadata: write (the same bytes) and resume.
    Resume,
    /// Baked with other settings, and `--force` on a whole bake: remove it first.
    Replace,
}

/// Checks one array's existing metadata: it must be identical to this bake's, else the store
/// was baked with other settings; `--force` on a whole (not split) bake replaces the array, a
/// split bake never does (other parts may be writing it). Writes nothing.
fn check_metadata(
    store_dir: &Path,
    name: &str,
    json: &[u8],
    options: &BakeFileOptions,
) -> Result<Existing, BakeError> {
    let dir = store_dir.join(name);
    let doc = dir.join("zarr.json");
    match std::fs::read(&doc) {
        Ok(existing) if existing == json => Ok(Existing::Resume),
        Ok(existing) => {
            let what = mismatch(&existing, json);
            if !(options.force && options.zarr.part.is_whole()) {
                let hint = if options.zarr.part.is_whole() {
                    "pass --force to rebake it with these settings, or bake into a new store"
                } else {
                    "every part of a split bake must use the same graph and settings; delete the store (or bake into a new one) to change them"
                };
                return Err(BakeError::Refused(format!(
                    "{}: was baked with other settings (stored: {what}); {hint}",
                    dir.display()
                )));
            }
            Ok(Existing::Replace)
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            if dir.exists() && !only_metadata_temporaries(&dir)? {
                // Another part may have written the document between the two looks.
                if doc.exists() {
                    return check_metadata(store_dir, name, json, options);
                }
                return Err(BakeError::Refused(format!(
                    "{}: exists and is not a Zarr array (no zarr.json); refusing to write into it",
                    dir.display()
                )));
            }
            Ok(Existing::Resume)
        }
        Err(e) => Err(BakeError::Io {
            path: doc.display().to_string(),
            source: e,
        }),
    }
}

/// Names the first fields where two metadata documents differ.
fn mismatch(existing: &[u8], wanted: &[u8]) -> String {
    let (Ok(a), Ok(b)) = (
        serde_json::from_slice::<serde_json::Value>(existing),
        serde_json::from_slice::<serde_json::Value>(wanted),
    ) else {
        return "its zarr.json is not valid JSON".into();
    };
    let mut diffs = Vec::new();
    let sharding = |v: &serde_json::Value| v["codecs"][0]["configuration"].clone();
    let (sa, sb) = (sharding(&a), sharding(&b));
    if sa["chunk_shape"] != sb["chunk_shape"] {
        diffs.push(format!(
            "chunks {} but this bake has {}",
            sa["chunk_shape"], sb["chunk_shape"]
        ));
    }
    if sa["codecs"] != sb["codecs"] {
        diffs.push(format!(
            "chunk codecs {} but this bake has {}",
            sa["codecs"], sb["codecs"]
        ));
    }
    for key in ["shape", "data_type", "chunk_grid", "fill_value"] {
        if a[key] != b[key] {
            diffs.push(format!("{key} {} but this bake has {}", a[key], b[key]));
        }
    }
    let (ta, tb) = (&a["attributes"]["texgraph"], &b["attributes"]["texgraph"]);
    for key in ["tape", "region", "size", "precision", "transfer"] {
        if ta[key] != tb[key] {
            diffs.push(format!("{key} {} but this bake has {}", ta[key], tb[key]));
        }
    }
    if diffs.is_empty() && a["codecs"] != b["codecs"] {
        diffs.push("the sharding codec's index differs".into());
    }
    if diffs.is_empty() {
        diffs.push("attributes differ".into());
    }
    diffs.join("; ")
}

/// A shard's manifest, as written beside it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Manifest {
    pub key: String,
    pub bytes: u64,
    /// crc32c of the shard's bytes, 8 hex digits.
    pub crc32c: String,
    /// crc32c of the array's zarr.json the shard belongs to.
    pub array_metadata_crc32c: String,
    /// The tape's fingerprint (attributes.texgraph.tape).
    pub tape: String,
}

/// Why a shard is not complete.
#[derive(Clone, Debug, PartialEq)]
pub enum ShardState {
    Complete,
    Missing,
    NoManifest,
    Corrupt(String),
    Stale(String),
}

/// Checks a shard against its manifest: present, the manifest readable and for this array and
/// tape, length and checksum as recorded.
pub fn shard_state(store_dir: &Path, key: &str, metadata_crc: u32, tape: &str) -> ShardState {
    let path = store_dir.join(key);
    let manifest_path = store_dir.join(format!("{key}{MANIFEST_SUFFIX}"));
    let Ok(bytes) = std::fs::read(&path) else {
        return ShardState::Missing;
    };
    let Ok(text) = std::fs::read(&manifest_path) else {
        return ShardState::NoManifest;
    };
    let manifest: Manifest = match serde_json::from_slice(&text) {
        Ok(m) => m,
        Err(e) => return ShardState::Corrupt(format!("its manifest is unreadable: {e}")),
    };
    if manifest.array_metadata_crc32c != format!("{metadata_crc:08x}") || manifest.tape != tape {
        return ShardState::Stale(format!(
            "baked for another array or tape (manifest: metadata {}, tape {}; array: metadata {metadata_crc:08x}, tape {tape})",
            manifest.array_metadata_crc32c, manifest.tape
        ));
    }
    let crc = format!("{:08x}", crc32c::crc32c(&bytes));
    if manifest.bytes != bytes.len() as u64 || manifest.crc32c != crc {
        return ShardState::Corrupt(format!(
            "{} bytes with crc32c {crc}; its manifest records {} bytes with crc32c {}",
            bytes.len(),
            manifest.bytes,
            manifest.crc32c
        ));
    }
    ShardState::Complete
}

/// Bakes the shards of `options.zarr.part` into the store; skips shards already complete
/// (unless `--force`).
pub fn bake_zarr(
    tape: &Tape,
    options: &BakeFileOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<BakeReport, BakeError> {
    bake_zarr_levels(&[tape], options, progress)
}

/// One mip level of a zarr bake: its tape, options (its grid), shard layout and arrays.
struct Level<'t> {
    tape: &'t Tape,
    options: BakeFileOptions,
    sharding: Sharding,
    arrays: Vec<OutputArray>,
    tape_hash: String,
}

/// The store path (relative, `/`-separated) of output `name`'s array at `level`: `name`, or
/// `name/L` in a multiscale group.
fn array_path(name: &str, level: usize, multiscale: bool) -> String {
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
            let g = super::settings::mip_grid(grid, level as u32);
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
fn output_groups(
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
                super::settings::mips_note(options.bake.filter).into(),
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

fn group_json(group: &zarrs::group::Group<AtomicStore>) -> Result<Vec<u8>, BakeError> {
    match group.metadata_opt(&Default::default()) {
        zarrs::group::GroupMetadata::V3(m) => serde_json::to_vec_pretty(&m)
            .map_err(|e| BakeError::Refused(format!("group metadata: {e}"))),
        _ => Err(BakeError::Refused("internal: not a Zarr v3 group".into())),
    }
}

/// Checks every node the bake writes against what is in the store, then writes the metadata
/// (a refused bake writes nothing) and returns the levels ready for their shards.
fn open_levels<'t>(
    store: &Arc<AtomicStore>,
    store_dir: &Path,
    tapes: &[&'t Tape],
    options: &BakeFileOptions,
) -> Result<Vec<Level<'t>>, BakeError> {
    let multiscale = tapes.len() > 1;
    let mut replace = std::collections::BTreeSet::new();
    let groups = if multiscale {
        output_groups(store, tapes, options)?
    } else {
        Vec::new()
    };
    for (name, json) in &groups {
        if check_metadata(store_dir, name, json, options)? == Existing::Replace {
            replace.insert(name.clone());
        }
    }
    let mut planned = Vec::new();
    for (level, tape) in tapes.iter().enumerate() {
        let mut level_options = options.clone();
        level_options.bake.grid = super::settings::mip_grid(&options.bake.grid, level as u32);
        let sharding = Sharding::new(
            &level_options.bake.grid,
            options.zarr.chunk,
            options.zarr.shard,
        )?;
        let mut arrays = Vec::new();
        for output in &tape.outputs {
            let path = array_path(&output.name, level, multiscale);
            let array = build_array(store, &level_options, tape, &sharding, output, &path)?;
            let json = metadata_json(&array)?;
            if check_metadata(store_dir, &path, &json, options)? == Existing::Replace {
                replace.insert(output.name.clone());
            }
            arrays.push((output, path, array));
        }
        planned.push((tape, level_options, sharding, arrays));
    }
    let root = zarrs::group::GroupBuilder::new()
        .attributes(texgraph_attributes(options, tapes[0]))
        .build(store.clone(), "/")
        .map_err(|e| BakeError::Refused(format!("zarr group: {e}")))?;
    write_node(store_dir, "", &group_json(&root)?)?;
    for name in &replace {
        let dir = store_dir.join(name);
        std::fs::remove_dir_all(&dir).map_err(|e| BakeError::Io {
            path: dir.display().to_string(),
            source: e,
        })?;
    }
    for (name, json) in &groups {
        write_node(store_dir, name, json)?;
    }
    let mut levels = Vec::with_capacity(planned.len());
    for (tape, level_options, sharding, arrays) in planned {
        let mut opened = Vec::with_capacity(arrays.len());
        for (output, path, array) in arrays {
            let json = metadata_json(&array)?;
            write_node(store_dir, &path, &json)?;
            opened.push(OutputArray {
                name: output.name.clone(),
                ty: output.ty,
                first_channel: output.first_channel,
                srgb: output.ty == Type::Vec3
                    && sample_type(options) == ZarrSample::U8
                    && options.transfer == Transfer::Srgb,
                array,
                metadata_crc: crc32c::crc32c(&json),
            });
        }
        levels.push(Level {
            tape,
            options: level_options,
            sharding,
            arrays: opened,
            tape_hash: format!("{:016x}", tape.fingerprint()),
        });
    }
    Ok(levels)
}

/// Writes a node's `zarr.json` (the bytes zarrs serialises) atomically.
fn write_node(store_dir: &Path, path: &str, json: &[u8]) -> Result<(), BakeError> {
    let key = if path.is_empty() {
        "zarr.json".to_string()
    } else {
        format!("{path}/zarr.json")
    };
    AtomicStore::new(store_dir)
        .write(&key, json)
        .map_err(storage(&store_dir.join(&key).display().to_string()))
}

/// Bakes a zarr store with one array per output (one level) or, for a mip chain (`tapes[L]`
/// compiled for level L), an OME-Zarr multiscale group per output with an array per level.
/// Shards are numbered level by level (level 0's first) for `--part`.
pub fn bake_zarr_levels(
    tapes: &[&Tape],
    options: &BakeFileOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<BakeReport, BakeError> {
    let store_dir = store_path(options)?;
    for level in 0..tapes.len() {
        let grid = super::settings::mip_grid(&options.bake.grid, level as u32);
        Sharding::new(&grid, options.zarr.chunk, options.zarr.shard)?;
    }
    check_store(&store_dir)?;
    std::fs::create_dir_all(&store_dir).map_err(|e| BakeError::Io {
        path: store_dir.display().to_string(),
        source: e,
    })?;
    let store = Arc::new(AtomicStore::new(&store_dir));
    let levels = open_levels(&store, &store_dir, tapes, options)?;
    let (threads, _) = super::engine::capped_threads(options.bake.threads);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| BakeError::Refused(format!("cannot start {threads} worker threads: {e}")))?;
    let started = std::time::Instant::now();
    let mut stats = vec![ChannelStats::default(); tapes[0].channels()];
    let mut count = ShardCount::default();
    // Evaluation and writing overlap: while the writer encodes and writes shard i, the pool
    // evaluates shard i + 1 (at most two shards in flight, the bound `held_bytes` checks).
    let (send, receive) = std::sync::mpsc::sync_channel::<ShardJob>(0);
    std::thread::scope(|scope| -> Result<(), BakeError> {
        let levels = &levels;
        let store = &store;
        let pool = &pool;
        let writer = scope.spawn(move || -> Result<(), BakeError> {
            // Inside the bake's pool: zarrs encodes a shard's inner chunks in parallel on the
            // current pool, so `--threads` bounds encoding too.
            for job in receive {
                pool.install(|| write_shard(&levels[job.level], job, store))?;
            }
            Ok(())
        });
        let evaluated = (|| -> Result<(), BakeError> {
            let mut item = 0u64;
            for (l, level) in levels.iter().enumerate() {
                for s in 0..level.sharding.shard_count() {
                    let mine = options.zarr.part.owns(item);
                    item += 1;
                    if !mine {
                        continue;
                    }
                    let cancelled = options.bake.cancel.as_ref();
                    if cancelled.is_some_and(|c| c.load(Ordering::Relaxed)) {
                        return Err(BakeError::Cancelled);
                    }
                    let Some((job, shard_stats)) =
                        eval_one_shard(levels, l, s, pool, store, options, &mut count)
                    else {
                        continue;
                    };
                    if l == 0 {
                        for (total, part) in stats.iter_mut().zip(&shard_stats) {
                            total.merge(part);
                        }
                    }
                    // A closed channel means the writer failed: its error is reported below.
                    if send.send(job).is_err() {
                        return Ok(());
                    }
                    progress(count.voxels);
                }
            }
            Ok(())
        })();
        drop(send);
        let written = writer
            .join()
            .unwrap_or_else(|_| Err(BakeError::Refused("the zarr writer thread panicked".into())));
        written.and(evaluated)
    })?;
    Ok(BakeReport {
        files: zarr_files(&store_dir, &levels, options, &count),
        stats: collect_stats(tapes[0], &stats),
        voxels: count.voxels,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// Shards of this part: owned, baked, skipped (complete), voxels evaluated.
#[derive(Default)]
struct ShardCount {
    owned: u64,
    baked: u64,
    skipped: u64,
    voxels: u64,
}

/// Evaluates shard `s` of level `l` unless it is complete (and not `--force`). Returns the job
/// for the writer and its voxels' statistics (`None` when skipped).
fn eval_one_shard(
    levels: &[Level<'_>],
    l: usize,
    s: u64,
    pool: &rayon::ThreadPool,
    store: &AtomicStore,
    options: &BakeFileOptions,
    count: &mut ShardCount,
) -> Option<(ShardJob, Vec<ChannelStats>)> {
    let level = &levels[l];
    count.owned += 1;
    let store_dir = store.root.as_path();
    let k = level.sharding.shard_index(s);
    let keys: Vec<String> = level
        .arrays
        .iter()
        .map(|a| {
            a.array
                .chunk_key(&shard_indices(k, a.ty))
                .as_str()
                .trim_start_matches('/')
                .to_string()
        })
        .collect();
    let complete = !options.force
        && level.arrays.iter().zip(&keys).all(|(a, key)| {
            shard_state(store_dir, key, a.metadata_crc, &level.tape_hash) == ShardState::Complete
        });
    if complete {
        count.skipped += 1;
        return None;
    }
    for key in &keys {
        remove_stale_temporaries(store_dir, key);
    }
    let (buffers, stats) = eval_shard_buffers(level, pool, k);
    count.baked += 1;
    count.voxels += level
        .sharding
        .shard_ranges(k)
        .iter()
        .map(|r| r.end - r.start)
        .product::<u64>();
    let job = ShardJob {
        level: l,
        k,
        keys,
        buffers,
    };
    Some((job, stats))
}

/// The report's lines: one per output (its array, or its multiscale group).
fn zarr_files(
    store_dir: &Path,
    levels: &[Level<'_>],
    options: &BakeFileOptions,
    count: &ShardCount,
) -> Vec<BakedFile> {
    let sharding = &levels[0].sharding;
    let [nz, ny, nx] = sharding.shape;
    let compression = match options.zarr.compression {
        ZarrCompression::Zstd => {
            format!(
                "zstd {}",
                options.zstd.unwrap_or(super::settings::DEFAULT_ZSTD_LEVEL)
            )
        }
        ZarrCompression::Blosc => "blosc lz4".into(),
        ZarrCompression::None => "uncompressed".into(),
    };
    let part = options.zarr.part;
    let part_text = if part.is_whole() {
        String::new()
    } else {
        format!(", part {part}")
    };
    let total: u64 = levels.iter().map(|l| l.sharding.shard_count()).sum();
    let mips = if levels.len() > 1 {
        format!(
            "OME-Zarr multiscale group of {} levels baked from the graph, level 0 ",
            levels.len()
        )
    } else {
        String::new()
    };
    levels[0]
        .arrays
        .iter()
        .map(|a| BakedFile {
            output: a.name.clone(),
            path: store_dir.join(&a.name),
            description: format!(
                "{mips}Zarr array {nx}×{ny}×{nz} {}{} {}, chunks {:?} in shards {:?} (z, y, x), {compression}: {} shard(s) baked, {} already complete, of {}{part_text} ({total} in the store)",
                if a.ty == Type::Vec3 { "RGB " } else { "" },
                sample_type(options).name(),
                if a.srgb { "sRGB" } else { "linear" },
                sharding.chunk,
                sharding.shard,
                count.baked,
                count.skipped,
                count.owned,
            ),
        })
        .collect()
}

/// The chunk-grid indices of shard `k` in an array of type `ty`.
fn shard_indices(k: [u64; 3], ty: Type) -> Vec<u64> {
    let mut v = k.to_vec();
    if ty == Type::Vec3 {
        v.push(0);
    }
    v
}

/// Evaluates shard `k` for every output, encodes it with the array's codecs, writes it and its
/// manifest. Returns the statistics of its voxels.
/// An evaluated shard on its way to the writer: its level, index, keys and every output's
/// decoded shard.
struct ShardJob {
    level: usize,
    k: [u64; 3],
    keys: Vec<String>,
    buffers: Vec<Vec<u8>>,
}

/// Evaluates shard `k` of `level` for every output. Returns the decoded shards and the
/// statistics of its voxels.
fn eval_shard_buffers(
    level: &Level<'_>,
    pool: &rayon::ThreadPool,
    k: [u64; 3],
) -> (Vec<Vec<u8>>, Vec<ChannelStats>) {
    let (options, sharding, arrays) = (&level.options, &level.sharding, &level.arrays);
    let tape = level.tape;
    let sample = sample_type(options);
    let mut buffers: Vec<Vec<u8>> = arrays
        .iter()
        .map(|a| {
            let len = sharding.shard_voxels() * a.ty.channels() as u64 * sample.bytes();
            vec![0u8; len as usize]
        })
        .collect();
    let stats = match options.bake.precision {
        Precision::F32 => eval_shard::<f32>(tape, options, pool, sharding, k, arrays, &mut buffers),
        Precision::F64 => eval_shard::<f64>(tape, options, pool, sharding, k, arrays, &mut buffers),
    };
    (buffers, stats)
}

/// Encodes an evaluated shard with each array's codecs and writes it, then its manifest.
fn write_shard(level: &Level<'_>, job: ShardJob, store: &AtomicStore) -> Result<(), BakeError> {
    let (arrays, tape_hash, k) = (&level.arrays, level.tape_hash.as_str(), job.k);
    let store_dir = store.root.as_path();
    for ((a, key), buffer) in arrays.iter().zip(&job.keys).zip(job.buffers) {
        let indices = shard_indices(k, a.ty);
        let shape = a
            .array
            .chunk_shape(&indices)
            .map_err(|e| BakeError::Encode {
                path: key.clone(),
                message: e.to_string(),
            })?;
        let encoded = a
            .array
            .codecs()
            .encode(
                ArrayBytes::new_flen(buffer),
                &shape,
                a.array.data_type(),
                a.array.fill_value(),
                &CodecOptions::default(),
            )
            .map(std::borrow::Cow::into_owned)
            .map_err(|e| BakeError::Encode {
                path: store_dir.join(key).display().to_string(),
                message: e.to_string(),
            })?;
        let bytes: &[u8] = &encoded;
        store
            .write(key, bytes)
            .map_err(storage(&store_dir.join(key).display().to_string()))?;
        let manifest = Manifest {
            key: key.clone(),
            bytes: bytes.len() as u64,
            crc32c: format!("{:08x}", crc32c::crc32c(bytes)),
            array_metadata_crc32c: format!("{:08x}", a.metadata_crc),
            tape: tape_hash.to_string(),
        };
        let text = serde_json::to_vec_pretty(&manifest).expect("a manifest serialises");
        let manifest_key = format!("{key}{MANIFEST_SUFFIX}");
        store.write(&manifest_key, &text).map_err(storage(
            &store_dir.join(&manifest_key).display().to_string(),
        ))?;
    }
    Ok(())
}

/// Evaluates the in-bounds voxels of shard `k` into each output's shard buffer (its sample type,
/// C order z, y, x, channel; voxels past the array's edge keep the fill value 0), one z slice of
/// the shard per task. Statistics are merged in slice order.
fn eval_shard<S: Real>(
    tape: &Tape,
    options: &BakeFileOptions,
    pool: &rayon::ThreadPool,
    sharding: &Sharding,
    k: [u64; 3],
    arrays: &[OutputArray],
    buffers: &mut [Vec<u8>],
) -> Vec<ChannelStats> {
    let grid = &options.bake.grid;
    let sample = sample_type(options);
    let [rz, ry, rx] = sharding.shard_ranges(k);
    let [_, sy, sx] = sharding.shard.map(|n| n as usize);
    let channels = tape.channels();
    let width = (rx.end - rx.start) as usize;
    let xs: Vec<f64> = (rx.start..rx.end)
        .map(|i| grid.centre(0, i as usize))
        .collect();
    // Per z slice of the shard: a mutable view of each output's slice.
    let mut slices: Vec<Vec<&mut [u8]>> = (0..(rz.end - rz.start) as usize)
        .map(|_| Vec::new())
        .collect();
    for (a, buffer) in arrays.iter().zip(buffers.iter_mut()) {
        let slice_bytes = sy * sx * a.ty.channels() * sample.bytes() as usize;
        for (z, view) in buffer
            .chunks_mut(slice_bytes)
            .take(slices.len())
            .enumerate()
        {
            slices[z].push(view);
        }
    }
    // --device gpu: each slice's rows in one GPU batch (the tape's cached evaluator); where the
    // GPU fails, the slice is evaluated on the CPU (said on stderr).
    // `--filter box`: each voxel the filtered estimate of its cell's mean (the bake engine's
    // footprint), on the GPU's filtered form where asked and covered.
    let boxed = options.bake.filter == crate::filter::Filter::Box;
    let footprint = crate::filter::Footprint::from_sides(grid.spacing().map(f64::abs))
        .unwrap_or(crate::filter::Footprint::POINT);
    let filtered = boxed.then(|| crate::filter::Filtered::new(tape));
    let gpu = match options.bake.device {
        crate::gpu::Device::Gpu | crate::gpu::Device::Auto if S::NAME == "f32" && boxed => {
            crate::gpu::filtered_evaluator_for(tape).ok()
        }
        crate::gpu::Device::Gpu if S::NAME == "f32" => crate::gpu::evaluator_for(tape).ok(),
        _ => None,
    };
    let rows = (ry.end - ry.start) as usize;
    let gpu_slice = |kz: usize| -> Option<Vec<f32>> {
        let gpu = gpu.as_ref()?;
        let n = rows * width;
        let px: Vec<f64> = (0..rows).flat_map(|_| xs.iter().copied()).collect();
        let py: Vec<f64> = (ry.start..ry.end)
            .flat_map(|j| std::iter::repeat_n(grid.centre(1, j as usize), width))
            .collect();
        let pz = vec![grid.centre(2, kz); n];
        let mut out = vec![0f32; channels * n];
        let done = if boxed {
            gpu.eval_batch_filtered([&px, &py, &pz], std::slice::from_ref(&footprint), &mut out)
        } else {
            gpu.eval_batch(&px, &py, &pz, &mut out)
        };
        match done {
            Ok(()) => Some(out),
            Err(e) => {
                eprintln!("texgraph: {e}; slice {kz} evaluated on the CPU");
                None
            }
        }
    };
    let per_slice: Vec<Vec<ChannelStats>> = pool.install(|| {
        slices
            .into_par_iter()
            .enumerate()
            .map_init(
                || {
                    (
                        Workspace::<S>::new(),
                        vec![S::ZERO; channels * width],
                        Vec::new(),
                        (vec![0f64; width], vec![0f64; width]),
                    )
                },
                |(workspace, out, interleaved, (ys, zs)), (z, mut views)| {
                    let kz = rz.start as usize + z;
                    let mut stats = vec![ChannelStats::default(); channels];
                    zs.fill(grid.centre(2, kz));
                    let on_gpu = gpu_slice(kz);
                    for (jy, j) in (ry.start..ry.end).enumerate() {
                        ys.fill(grid.centre(1, j as usize));
                        match &on_gpu {
                            Some(values) => {
                                let n = rows * width;
                                for c in 0..channels {
                                    let row = &values[c * n + jy * width..][..width];
                                    for (o, &v) in
                                        out[c * width..(c + 1) * width].iter_mut().zip(row)
                                    {
                                        *o = S::from_f64(f64::from(v));
                                    }
                                }
                            }
                            None => match &filtered {
                                Some(f) => f.eval_batch(
                                    [&xs, ys, zs],
                                    std::slice::from_ref(&footprint),
                                    out,
                                ),
                                None => tape.eval_batch(workspace, &xs, ys, zs, out),
                            },
                        }
                        for (a, view) in arrays.iter().zip(views.iter_mut()) {
                            let c = a.ty.channels();
                            interleaved.clear();
                            for i in 0..width {
                                for ch in 0..c {
                                    let v = out[(a.first_channel + ch) * width + i].to_f64() as f32;
                                    stats[a.first_channel + ch].add(v);
                                    interleaved.push(v);
                                }
                            }
                            let b = sample.bytes() as usize;
                            let row = jy * sx * c * b;
                            sample.encode(interleaved, a.srgb, &mut view[row..row + width * c * b]);
                        }
                    }
                    stats
                },
            )
            .collect()
    });
    let mut stats = vec![ChannelStats::default(); channels];
    for part in &per_slice {
        for (total, p) in stats.iter_mut().zip(part) {
            total.merge(p);
        }
    }
    stats
}

/// Removes hidden temporaries a killed bake left for `key` (`.NAME.XXXXXX.partial`, of the
/// shard or of its manifest) in the key's folder. Only the part that owns a shard writes it, so
/// these are that part's own leftovers.
fn remove_stale_temporaries(store_dir: &Path, key: &str) {
    let path = store_dir.join(key);
    let (Some(dir), Some(name)) = (path.parent(), path.file_name().and_then(|n| n.to_str())) else {
        return;
    };
    let prefixes = [format!(".{name}."), format!(".{name}{MANIFEST_SUFFIX}.")];
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(file) = file.to_str() else { continue };
        let ours = prefixes.iter().any(|p| {
            file.strip_prefix(p.as_str())
                .and_then(|rest| rest.strip_suffix(".partial"))
                .is_some_and(|random| !random.is_empty() && !random.contains('.'))
        });
        if ours {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// What `texgraph verify` found in one array.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrayCheck {
    /// The array's path in the store (`colour`).
    pub name: String,
    pub shards: u64,
    /// Every shard that is not complete, with why.
    pub problems: Vec<(String, ShardState)>,
}

/// Checks every shard of every texgraph array in the store at `store_dir`: present, with a
/// manifest for this array's metadata and tape, length and crc32c as recorded.
pub fn verify_store(store_dir: &Path) -> Result<Vec<ArrayCheck>, BakeError> {
    let root = store_dir.join("zarr.json");
    let doc = read_json(&root)?;
    if doc["zarr_format"] != 3 || doc["node_type"] != "group" {
        return Err(BakeError::Refused(format!(
            "{}: is not a Zarr v3 group",
            root.display()
        )));
    }
    let mut arrays = Vec::new();
    find_arrays(store_dir, "", &mut arrays)?;
    if arrays.is_empty() {
        return Err(BakeError::Refused(format!(
            "{}: holds no array baked by texgraph",
            store_dir.display()
        )));
    }
    arrays
        .into_iter()
        .map(|name| check_array(store_dir, &name))
        .collect()
}

fn read_json(path: &Path) -> Result<serde_json::Value, BakeError> {
    let bytes = std::fs::read(path).map_err(|e| BakeError::Io {
        path: path.display().to_string(),
        source: e,
    })?;
    serde_json::from_slice(&bytes)
        .map_err(|e| BakeError::Refused(format!("{}: not a JSON document: {e}", path.display())))
}

/// The texgraph arrays under `dir` (a group), depth first, in name order.
fn find_arrays(store_dir: &Path, prefix: &str, out: &mut Vec<String>) -> Result<(), BakeError> {
    let dir = store_dir.join(prefix);
    let mut entries: Vec<_> = std::fs::read_dir(&dir)
        .map_err(|e| BakeError::Io {
            path: dir.display().to_string(),
            source: e,
        })?
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .filter(|n| !n.starts_with('.'))
        .collect();
    entries.sort();
    for name in entries {
        let path = if prefix.is_empty() {
            name
        } else {
            format!("{prefix}/{name}")
        };
        let doc_path = store_dir.join(&path).join("zarr.json");
        if !doc_path.exists() {
            continue;
        }
        let doc = read_json(&doc_path)?;
        match doc["node_type"].as_str() {
            Some("array") if doc["attributes"]["texgraph"]["tape"].is_string() => out.push(path),
            Some("group") => find_arrays(store_dir, &path, out)?,
            _ => {}
        }
    }
    Ok(())
}

fn check_array(store_dir: &Path, name: &str) -> Result<ArrayCheck, BakeError> {
    let doc_path = store_dir.join(name).join("zarr.json");
    let bytes = std::fs::read(&doc_path).map_err(|e| BakeError::Io {
        path: doc_path.display().to_string(),
        source: e,
    })?;
    let doc: serde_json::Value = serde_json::from_slice(&bytes)
        .map_err(|e| BakeError::Refused(format!("{}: {e}", doc_path.display())))?;
    let numbers = |v: &serde_json::Value| -> Option<Vec<u64>> {
        v.as_array()?.iter().map(|n| n.as_u64()).collect()
    };
    let shape = numbers(&doc["shape"]);
    let shard = numbers(&doc["chunk_grid"]["configuration"]["chunk_shape"]);
    let (Some(shape), Some(shard)) = (shape, shard) else {
        return Err(BakeError::Refused(format!(
            "{}: no regular chunk grid",
            doc_path.display()
        )));
    };
    if shape.len() != shard.len() || shard.contains(&0) {
        return Err(BakeError::Refused(format!(
            "{}: shape and chunk shape disagree",
            doc_path.display()
        )));
    }
    let tape = doc["attributes"]["texgraph"]["tape"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    let crc = crc32c::crc32c(&bytes);
    let counts: Vec<u64> = shape
        .iter()
        .zip(&shard)
        .map(|(n, s)| n.div_ceil(*s))
        .collect();
    let total: u64 = counts.iter().product();
    let mut problems = Vec::new();
    for s in 0..total {
        let mut rest = s;
        let mut index = vec![0; counts.len()];
        for a in (0..counts.len()).rev() {
            index[a] = rest % counts[a];
            rest /= counts[a];
        }
        let key = format!(
            "{name}/c/{}",
            index
                .iter()
                .map(u64::to_string)
                .collect::<Vec<_>>()
                .join("/")
        );
        let state = shard_state(store_dir, &key, crc, &tape);
        if state != ShardState::Complete {
            problems.push((key, state));
        }
    }
    Ok(ArrayCheck {
        name: name.to_string(),
        shards: total,
        problems,
    })
}
