//! A shard's evaluation and writing: every voxel from its global index (so a store is the same
//! bytes whatever the parts and their order), on the device `choose_device` picked for the bake,
//! then encoded with each array's codecs and written with its manifest.

use super::layout::{sample_type, OutputArray, Sharding};
use super::resume::{Manifest, MANIFEST_SUFFIX};
use super::store::{storage, AtomicStore};
use crate::bake::device::Evaluator;
use crate::bake::engine::{ChannelStats, Precision};
use crate::bake::error::BakeError;
use crate::bake::settings::BakeFileOptions;
use crate::bake::window::{Window, WindowData, WindowOutput};
use crate::eval::Workspace;
use crate::graph::Type;
use crate::real::Real;
use crate::tape::Tape;
use rayon::prelude::*;
use zarrs::array::codec::api::ArrayToBytesCodecTraits;
use zarrs::array::{ArrayBytes, CodecOptions};

/// One mip level of a zarr bake: its tape, options (its grid), shard layout and arrays.
pub(super) struct Level<'t> {
    pub(super) tape: &'t Tape,
    pub(super) options: BakeFileOptions,
    pub(super) sharding: Sharding,
    pub(super) arrays: Vec<OutputArray>,
    pub(super) tape_hash: String,
    /// What evaluates its voxels (`choose_device`, once per level).
    pub(super) evaluator: Evaluator,
}

/// The chunk-grid indices of shard `k` in an array of type `ty`.
pub(super) fn shard_indices(k: [u64; 3], ty: Type) -> Vec<u64> {
    let mut v = k.to_vec();
    if ty == Type::Vec3 {
        v.push(0);
    }
    v
}

/// An evaluated shard on its way to the writer: its level, index, keys and every output's
/// decoded shard.
pub(super) struct ShardJob {
    pub(super) level: usize,
    pub(super) k: [u64; 3],
    pub(super) keys: Vec<String>,
    pub(super) buffers: Vec<Vec<u8>>,
}

/// Evaluates shard `k` of `level` for every output. Returns the decoded shards and the
/// statistics of its voxels.
pub(super) fn eval_shard_buffers(
    level: &Level<'_>,
    pool: &rayon::ThreadPool,
    k: [u64; 3],
) -> Result<(Vec<Vec<u8>>, Vec<ChannelStats>), BakeError> {
    let (options, sharding) = (&level.options, &level.sharding);
    let sample = sample_type(options);
    let mut buffers: Vec<Vec<u8>> = level
        .arrays
        .iter()
        .map(|a| {
            let len = sharding.shard_voxels() * a.ty.channels() as u64 * sample.bytes();
            vec![0u8; len as usize]
        })
        .collect();
    let stats = match (&level.evaluator, options.bake.precision) {
        (Evaluator::Gpu(gpu) | Evaluator::GpuFiltered(gpu), _) => {
            eval_shard_gpu(level, gpu, k, &mut buffers)?
        }
        (Evaluator::Cpu, Precision::F32) => eval_shard::<f32>(level, pool, k, &mut buffers)?,
        (Evaluator::Cpu, Precision::F64) => eval_shard::<f64>(level, pool, k, &mut buffers)?,
    };
    Ok((buffers, stats))
}

/// Encodes an evaluated shard with each array's codecs and writes it, then its manifest.
pub(super) fn write_shard(
    level: &Level<'_>,
    job: ShardJob,
    store: &AtomicStore,
) -> Result<(), BakeError> {
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

/// What every z slice of one shard shares: the shard's voxel ranges and its x coordinates.
struct ShardSlices<'l> {
    level: &'l Level<'l>,
    rows: std::ops::Range<u64>,
    first_z: u64,
    xs: Vec<f64>,
    /// The shard's row length in the buffers (the full shard side, edges included).
    row_stride: usize,
    /// The footprint of a voxel (`--filter box`: each voxel its cell's mean).
    footprint: crate::filter::Footprint,
    /// The CPU's filtered form, where the CPU filters.
    filtered: Option<crate::filter::Filtered<'l>>,
}

/// Evaluates the in-bounds voxels of shard `k` into each output's shard buffer (its sample type,
/// C order z, y, x, channel; voxels past the array's edge keep the fill value 0), one z slice of
/// the shard per task, on the level's evaluator. Statistics are merged in slice order.
fn eval_shard<S: Real>(
    level: &Level<'_>,
    pool: &rayon::ThreadPool,
    k: [u64; 3],
    buffers: &mut [Vec<u8>],
) -> Result<Vec<ChannelStats>, BakeError> {
    let (options, sharding) = (&level.options, &level.sharding);
    let grid = &options.bake.grid;
    let [rz, ry, rx] = sharding.shard_ranges(k);
    let [_, sy, sx] = sharding.shard.map(|n| n as usize);
    let on_cpu = matches!(level.evaluator, Evaluator::Cpu);
    let boxed = options.bake.filter == crate::filter::Filter::Box;
    let shared = ShardSlices {
        level,
        rows: ry,
        first_z: rz.start,
        xs: (rx.start..rx.end)
            .map(|i| grid.centre(0, i as usize))
            .collect(),
        row_stride: sx,
        footprint: crate::filter::Footprint::from_sides(grid.spacing().map(f64::abs))
            .unwrap_or(crate::filter::Footprint::POINT),
        filtered: (boxed && on_cpu).then(|| crate::filter::Filtered::new(level.tape)),
    };
    // Per z slice of the shard: a mutable view of each output's slice.
    let sample = sample_type(options);
    let mut slices: Vec<Vec<&mut [u8]>> = (rz.start..rz.end).map(|_| Vec::new()).collect();
    for (a, buffer) in level.arrays.iter().zip(buffers.iter_mut()) {
        let slice_bytes = sy * sx * a.ty.channels() * sample.bytes() as usize;
        let views = buffer.chunks_mut(slice_bytes).take(slices.len());
        for (z, view) in views.enumerate() {
            slices[z].push(view);
        }
    }
    let shared = &shared;
    let per_slice: Vec<Vec<ChannelStats>> = pool.install(|| {
        slices
            .into_par_iter()
            .enumerate()
            .map_init(SliceScratch::<S>::default, |scratch, (z, views)| {
                shared.slice(scratch, shared.first_z + z as u64, views)
            })
            .collect::<Result<_, BakeError>>()
    })?;
    let mut stats = vec![ChannelStats::default(); level.tape.channels()];
    for part in &per_slice {
        for (total, p) in stats.iter_mut().zip(part) {
            total.merge(p);
        }
    }
    Ok(stats)
}

/// A worker's buffers for the rows of a slice, kept from slice to slice.
struct SliceScratch<S: Real> {
    workspace: Workspace<S>,
    /// One row's values, planar (channel by channel).
    out: Vec<S>,
    /// One output's row, interleaved (voxel by voxel), before encoding.
    interleaved: Vec<f32>,
    ys: Vec<f64>,
    zs: Vec<f64>,
}

impl<S: Real> Default for SliceScratch<S> {
    fn default() -> Self {
        SliceScratch {
            workspace: Workspace::new(),
            out: Vec::new(),
            interleaved: Vec::new(),
            ys: Vec::new(),
            zs: Vec::new(),
        }
    }
}

impl ShardSlices<'_> {
    /// Slice `kz` of the shard into each output's view (`views`, one per output), row by row;
    /// the slice's statistics.
    fn slice<S: Real>(
        &self,
        scratch: &mut SliceScratch<S>,
        kz: u64,
        mut views: Vec<&mut [u8]>,
    ) -> Result<Vec<ChannelStats>, BakeError> {
        let (tape, grid) = (self.level.tape, &self.level.options.bake.grid);
        let channels = tape.channels();
        let width = self.xs.len();
        let mut stats = vec![ChannelStats::default(); channels];
        let SliceScratch {
            workspace,
            out,
            interleaved,
            ys,
            zs,
        } = scratch;
        out.resize(channels * width, S::ZERO);
        zs.clear();
        zs.resize(width, grid.centre(2, kz as usize));
        for (jy, j) in self.rows.clone().enumerate() {
            ys.clear();
            ys.resize(width, grid.centre(1, j as usize));
            match &self.filtered {
                Some(f) => {
                    let footprint = std::slice::from_ref(&self.footprint);
                    f.eval_batch([&self.xs, ys, zs], footprint, out)
                }
                None => tape.eval_batch(workspace, &self.xs, ys, zs, out),
            }
            self.encode_row(out, jy, interleaved, &mut stats, &mut views);
        }
        Ok(stats)
    }

    /// Row `jy` of the slice, its values planar in `out`, into each output's view in the
    /// array's sample type, interleaved; its statistics into `stats`.
    fn encode_row<S: Real>(
        &self,
        out: &[S],
        jy: usize,
        interleaved: &mut Vec<f32>,
        stats: &mut [ChannelStats],
        views: &mut [&mut [u8]],
    ) {
        let width = self.xs.len();
        let sample = sample_type(&self.level.options);
        for (a, view) in self.level.arrays.iter().zip(views.iter_mut()) {
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
            let row = jy * self.row_stride * c * b;
            sample.encode(interleaved, a.srgb, &mut view[row..row + width * c * b]);
        }
    }
}

/// [`eval_shard`] on the GPU: the shard's box as a grid of its own (the same voxel centres, to
/// the last bits of their f64 arithmetic) baked through [`crate::gpu::GpuBake`], each channel
/// packed on the device into the array's sample type and read back so, its statistics reduced
/// there; the windows' segments (rows of the box) scattered into the shard buffers.
fn eval_shard_gpu(
    level: &Level<'_>,
    gpu: &std::sync::Arc<crate::gpu::GpuEvaluator>,
    k: [u64; 3],
    buffers: &mut [Vec<u8>],
) -> Result<Vec<ChannelStats>, BakeError> {
    let (options, sharding) = (&level.options, &level.sharding);
    let grid = &options.bake.grid;
    let ranges = sharding.shard_ranges(k);
    let [_, sy, sx] = sharding.shard.map(|n| n as usize);
    // The box, x y z: its first voxel and its size.
    let start = [2, 1, 0].map(|a| ranges[a].start as usize);
    let size = [2, 1, 0].map(|a| (ranges[a].end - ranges[a].start) as usize);
    let spacing = grid.spacing();
    let region = crate::grid::Region {
        min: [0, 1, 2].map(|a| grid.region.min[a] + start[a] as f64 * spacing[a]),
        max: [0, 1, 2].map(|a| grid.region.min[a] + (start[a] + size[a]) as f64 * spacing[a]),
    };
    let shard = crate::grid::Grid { size, region };
    let channels = level.tape.channels();
    let mut stats = vec![ChannelStats::default(); channels];
    let Some(layout) = crate::grid::Layout::new(&shard, channels, 32) else {
        return Ok(stats);
    };
    let sample = sample_type(options);
    let mut encodings = vec![crate::encoding::Encoding::F32; channels];
    for a in &level.arrays {
        for ch in 0..a.ty.channels() {
            encodings[a.first_channel + ch] = sample.encoding(a.srgb);
        }
    }
    let packing = crate::encoding::Packing::new(encodings, layout.segment_len);
    let failed = |e: crate::gpu::GpuError| BakeError::Refused(format!("the GPU, shard {k:?}: {e}"));
    let mut bake =
        crate::gpu::GpuBake::new(gpu.clone(), &shard, &layout, packing.clone()).map_err(failed)?;
    let b = sample.bytes() as usize;
    let outputs: Vec<WindowOutput> = level
        .arrays
        .iter()
        .map(|a| WindowOutput {
            name: a.name.clone(),
            ty: a.ty,
            first_channel: a.first_channel,
        })
        .collect();
    bake.for_each_window(|first, count, bytes, window_stats| {
        for (total, part) in stats.iter_mut().zip(&window_stats) {
            total.merge(&ChannelStats::from_window(part));
        }
        let window = Window {
            grid: &shard,
            layout: &layout,
            first_segment: first,
            segments: count,
            channels,
            outputs: &outputs,
            data: WindowData::Packed {
                bytes,
                packing: &packing,
            },
        };
        for (s, segment) in window.segments() {
            let voxel = (segment.k * sy + segment.j) * sx + segment.i0;
            for (o, (a, buffer)) in level.arrays.iter().zip(buffers.iter_mut()).enumerate() {
                let c = a.ty.channels() * b;
                let row = &mut buffer[voxel * c..][..segment.len * c];
                window.copy_encoded(o, s, &segment, sample.encoding(a.srgb), row);
            }
        }
    })
    .map_err(failed)?;
    Ok(stats)
}
