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
//!
//! The files, from the bottom up: `store.rs` (the store's path, [`AtomicStore`]) → `layout.rs`
//! (sample types, [`Sharding`], the arrays' metadata and the OME-Zarr groups) → `resume.rs`
//! (what is in the store already, the shard manifests) → `shards.rs` (a shard evaluated and
//! written), `verify.rs` (`texgraph verify`) → this file: the metadata checked and written,
//! then the shards of this part, evaluation overlapping writing.

mod layout;
mod resume;
mod shards;
mod store;
mod verify;

pub use crate::bake::settings::{ZarrCompression, ZarrSettings, DEFAULT_CHUNK, DEFAULT_SHARD};
pub use layout::{held_bytes, preflight, sample_type, Sharding, ZarrSample};
pub use resume::{shard_state, Manifest, ShardState, MANIFEST_SUFFIX};
pub use store::{store_path, AtomicStore};
pub use verify::{verify_store, ArrayCheck};

use crate::bake::device::Evaluator;
use crate::bake::engine::{collect_stats, ChannelStats};
use crate::bake::error::BakeError;
use crate::bake::settings::{BakeFileOptions, BakeReport, BakedFile, Transfer};
use crate::graph::Type;
use crate::tape::Tape;
use layout::{
    array_path, build_array, group_json, metadata_json, output_groups, texgraph_attributes,
    OutputArray,
};
use resume::{check_metadata, check_store, remove_stale_temporaries, Existing};
use shards::{eval_shard_buffers, shard_indices, write_shard, Level, ShardJob};
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use store::write_node;

/// Bakes the shards of `options.zarr.part` into the store; skips shards already complete
/// (unless `--force`).
pub fn bake_zarr(
    tape: &Tape,
    options: &BakeFileOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<BakeReport, BakeError> {
    bake_zarr_levels(&[tape], options, progress)
}

/// Checks every node the bake writes against what is in the store, then writes the metadata
/// (a refused bake writes nothing) and returns the levels ready for their shards.
fn open_levels<'t>(
    store: &Arc<AtomicStore>,
    store_dir: &Path,
    tapes: &[&'t Tape],
    evaluators: Vec<Evaluator>,
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
        level_options.bake.grid = crate::bake::settings::mip_grid(&options.bake.grid, level as u32);
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
    for ((tape, level_options, sharding, arrays), evaluator) in planned.into_iter().zip(evaluators)
    {
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
            evaluator,
        });
    }
    Ok(levels)
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
        let grid = crate::bake::settings::mip_grid(&options.bake.grid, level as u32);
        Sharding::new(&grid, options.zarr.chunk, options.zarr.shard)?;
    }
    // The device of every level, decided as every sink decides it, before anything is written.
    let double = options.bake.precision == crate::bake::engine::Precision::F64;
    let evaluators = tapes
        .iter()
        .map(|tape| {
            let (device, filter) = (options.bake.device, options.bake.filter);
            crate::bake::device::choose(tape, device, filter, double)
                .map(|choice| choice.evaluator)
                .map_err(BakeError::Refused)
        })
        .collect::<Result<Vec<_>, _>>()?;
    check_store(&store_dir)?;
    std::fs::create_dir_all(&store_dir).map_err(|e| BakeError::Io {
        path: store_dir.display().to_string(),
        source: e,
    })?;
    let store = Arc::new(AtomicStore::new(&store_dir));
    let levels = open_levels(&store, &store_dir, tapes, evaluators, options)?;
    let (threads, _) = crate::bake::engine::capped_threads(options.bake.threads);
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
                        eval_one_shard(levels, l, s, pool, store, options, &mut count)?
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
) -> Result<Option<(ShardJob, Vec<ChannelStats>)>, BakeError> {
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
        return Ok(None);
    }
    for key in &keys {
        remove_stale_temporaries(store_dir, key);
    }
    let (buffers, stats) = eval_shard_buffers(level, pool, k)?;
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
    Ok(Some((job, stats)))
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
                options
                    .zstd
                    .unwrap_or(crate::bake::settings::DEFAULT_ZSTD_LEVEL)
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
