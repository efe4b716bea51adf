//! Stage 5, bake: a tape evaluated over a voxel grid, streamed slab by slab into a sink (an EXR,
//! PNG or raw file writer, or an in-memory [`Volume`]).
//!
//! The grid is cut into windows of whole z slices. The voxels of a window are evaluated in
//! parallel (rayon, one task per row of voxels, each with its own workspace), then the window is
//! handed to the sink in z order; the next window reuses the same buffer. Peak memory is one
//! window (about `2 × threads × 64 Ki` voxels, at least one slice) plus what the sink keeps: a
//! PNG slice writer and a raw writer keep nothing, a PNG atlas keeps one row of tiles, an EXR
//! file (whose writer needs the whole image) and a `Volume` keep everything.
//!
//! Every voxel is evaluated on its own by the same code, and statistics are reduced in row
//! order, so results are bit-identical whatever the thread count.

mod files;
mod sinks;

pub use files::{
    bake_files, human_bytes, planned_outputs, BakeFileOptions, BakeReport, BakedFile, Format,
    RawSampleType, Transfer, DEFAULT_MAX_BAKE_BYTES,
};
pub use sinks::{encode_u16, encode_u8, srgb_encode};

use crate::graph::Type;
use crate::real::Real;
use crate::tape::Tape;
use crate::Workspace;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// The box the grid covers. Default: the unit cube [0, 1]³.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Region {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl Default for Region {
    fn default() -> Self {
        Region {
            min: [0.0; 3],
            max: [1.0; 3],
        }
    }
}

/// A voxel grid: `size` voxels along x, y, z over `region`. Voxel (i, j, k) samples the centre of
/// its cell: `region.min + (index + 0.5) · (region.max − region.min) / size`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub size: [usize; 3],
    pub region: Region,
}

impl Grid {
    pub fn cube(n: usize) -> Grid {
        Grid {
            size: [n; 3],
            region: Region::default(),
        }
    }

    /// Total voxels; `None` if the count overflows u64.
    pub fn voxels(&self) -> Option<u64> {
        self.size
            .iter()
            .try_fold(1u64, |acc, &n| acc.checked_mul(n as u64))
    }

    /// The centre coordinate of voxel `index` along `axis`.
    #[inline]
    pub fn centre(&self, axis: usize, index: usize) -> f64 {
        let (lo, hi) = (self.region.min[axis], self.region.max[axis]);
        lo + (index as f64 + 0.5) * (hi - lo) / self.size[axis] as f64
    }

    /// The spacing between voxel centres along each axis.
    pub fn spacing(&self) -> [f64; 3] {
        [0, 1, 2].map(|a| (self.region.max[a] - self.region.min[a]) / self.size[a] as f64)
    }
}

/// Which evaluation path bakes: the f32 fast path or the f64 reference (stored as f32).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    #[default]
    F32,
    F64,
}

/// How to bake.
#[derive(Clone, Debug)]
pub struct BakeOptions {
    pub grid: Grid,
    /// Worker threads; 0 means one per core.
    pub threads: usize,
    pub precision: Precision,
    /// Set from another thread (Ctrl-C) to stop between windows with [`BakeError::Cancelled`].
    pub cancel: Option<Arc<AtomicBool>>,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions {
            grid: Grid::cube(64),
            threads: 0,
            precision: Precision::F32,
            cancel: None,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Encode { path: String, message: String },
    #[error("{0}")]
    Refused(String),
    #[error("the bake was interrupted")]
    Cancelled,
}

/// Statistics of one channel over the whole grid. NaN and infinities are counted, not mixed in.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ChannelStats {
    /// Over the finite values; +inf / -inf when there are none (`null` in JSON sidecars).
    pub min: f64,
    pub max: f64,
    /// Mean of the finite values; NaN when there are none.
    pub mean: f64,
    pub nan: u64,
    pub pos_inf: u64,
    pub neg_inf: u64,
    #[serde(skip)]
    sum: f64,
    #[serde(skip)]
    finite: u64,
}

impl Default for ChannelStats {
    fn default() -> Self {
        ChannelStats {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            mean: f64::NAN,
            nan: 0,
            pos_inf: 0,
            neg_inf: 0,
            sum: 0.0,
            finite: 0,
        }
    }
}

impl ChannelStats {
    #[inline]
    fn add(&mut self, v: f32) {
        if v.is_finite() {
            let v = v as f64;
            self.min = self.min.min(v);
            self.max = self.max.max(v);
            self.sum += v;
            self.finite += 1;
        } else if v.is_nan() {
            self.nan += 1;
        } else if v > 0.0 {
            self.pos_inf += 1;
        } else {
            self.neg_inf += 1;
        }
    }

    fn merge(&mut self, other: &ChannelStats) {
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
        self.sum += other.sum;
        self.finite += other.finite;
        self.nan += other.nan;
        self.pos_inf += other.pos_inf;
        self.neg_inf += other.neg_inf;
        self.mean = if self.finite > 0 {
            self.sum / self.finite as f64
        } else {
            f64::NAN
        };
    }

    pub fn non_finite(&self) -> u64 {
        self.nan + self.pos_inf + self.neg_inf
    }
}

/// Statistics of one output (one entry per channel).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OutputStats {
    pub name: String,
    pub channels: Vec<ChannelStats>,
}

impl OutputStats {
    pub fn non_finite(&self) -> u64 {
        self.channels.iter().map(|c| c.non_finite()).sum()
    }
}

/// One window of evaluated slices, handed to a sink in z order.
///
/// Layout: row-planar. Row (k, j) of the window holds every channel of every output for the `nx`
/// voxels of that row: channel `c` (numbered across outputs) of voxel `i` at
/// `(row * channels + c) * nx + i`, rows in order k, then j.
pub struct Window<'a> {
    pub grid: &'a Grid,
    /// First z slice of the window and how many slices it holds.
    pub z_start: usize,
    pub depth: usize,
    /// Channels per row across all outputs, and the first channel of each output.
    pub channels: usize,
    pub outputs: &'a [WindowOutput],
    data: &'a [f32],
}

/// Where an output's channels are in a window.
#[derive(Clone, Debug)]
pub struct WindowOutput {
    pub name: String,
    pub ty: Type,
    pub first_channel: usize,
}

impl Window<'_> {
    /// Writes slice `k_local` of output `output` as interleaved channels, x fastest then y
    /// (`nx · ny · channels` values) into `out`.
    pub fn slice_interleaved(&self, output: usize, k_local: usize, out: &mut Vec<f32>) {
        let [nx, ny, _] = self.grid.size;
        let o = &self.outputs[output];
        let width = o.ty.channels();
        out.clear();
        out.reserve(nx * ny * width);
        for j in 0..ny {
            let row = k_local * ny + j;
            let base = row * self.channels * nx;
            for i in 0..nx {
                for c in 0..width {
                    out.push(self.data[base + (o.first_channel + c) * nx + i]);
                }
            }
        }
    }
}

/// Receives the windows of a bake, in z order.
pub trait Sink: Send {
    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError>;
}

/// A whole baked grid in memory.
#[derive(Clone, Debug)]
pub struct Volume {
    pub grid: Grid,
    pub outputs: Vec<VolumeOutput>,
    pub stats: Vec<OutputStats>,
}

/// One output of a [`Volume`]: interleaved channels, x fastest, then y, then z (the layout
/// `glTexImage3D` takes).
#[derive(Clone, Debug)]
pub struct VolumeOutput {
    pub name: String,
    pub ty: Type,
    pub data: Vec<f32>,
}

impl VolumeOutput {
    /// Channel `c` of voxel (i, j, k).
    pub fn get(&self, grid: &Grid, i: usize, j: usize, k: usize, c: usize) -> f32 {
        let [nx, ny, _] = grid.size;
        self.data[((k * ny + j) * nx + i) * self.ty.channels() + c]
    }
}

struct VolumeSink {
    outputs: Vec<VolumeOutput>,
    scratch: Vec<f32>,
}

impl Sink for VolumeSink {
    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        for (o, output) in self.outputs.iter_mut().enumerate() {
            for k in 0..window.depth {
                window.slice_interleaved(o, k, &mut self.scratch);
                output.data.extend_from_slice(&self.scratch);
            }
        }
        Ok(())
    }
}

/// Bakes into memory. Needs `voxels × channels × 4` bytes.
pub fn bake_volume(tape: &Tape, options: &BakeOptions) -> Result<Volume, BakeError> {
    let mut sink = VolumeSink {
        outputs: tape
            .outputs
            .iter()
            .map(|o| VolumeOutput {
                name: o.name.clone(),
                ty: o.ty,
                data: Vec::new(),
            })
            .collect(),
        scratch: Vec::new(),
    };
    let stats = bake_into(tape, options, &mut sink, &mut |_| {})?;
    Ok(Volume {
        grid: options.grid,
        outputs: sink.outputs,
        stats,
    })
}

/// Voxels per window per thread: large enough that a task switch is noise, small enough that a
/// window stays a few MiB.
const VOXELS_PER_THREAD: usize = 64 * 1024;

/// Bakes `tape` over the grid into `sink`, window by window in z order; calls `progress` with
/// the voxels done so far after each window. Returns per-output statistics.
pub fn bake_into(
    tape: &Tape,
    options: &BakeOptions,
    sink: &mut dyn Sink,
    progress: &mut dyn FnMut(u64),
) -> Result<Vec<OutputStats>, BakeError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads)
        .build()
        .map_err(|e| {
            BakeError::Refused(format!(
                "cannot start {} worker threads: {e}",
                options.threads
            ))
        })?;
    match options.precision {
        Precision::F32 => bake_with::<f32>(tape, options, &pool, sink, progress),
        Precision::F64 => bake_with::<f64>(tape, options, &pool, sink, progress),
    }
}

fn bake_with<S: Real>(
    tape: &Tape,
    options: &BakeOptions,
    pool: &rayon::ThreadPool,
    sink: &mut dyn Sink,
    progress: &mut dyn FnMut(u64),
) -> Result<Vec<OutputStats>, BakeError> {
    let threads = pool.current_num_threads();
    let grid = &options.grid;
    let [nx, ny, nz] = grid.size;
    let channels = tape.channels();
    let outputs: Vec<WindowOutput> = tape
        .outputs
        .iter()
        .map(|o| WindowOutput {
            name: o.name.clone(),
            ty: o.ty,
            first_channel: o.first_channel,
        })
        .collect();
    let mut stats: Vec<ChannelStats> = vec![ChannelStats::default(); channels];
    if nx == 0 || ny == 0 || nz == 0 || channels == 0 {
        return Ok(collect_stats(tape, &stats));
    }
    let slice_voxels = nx * ny;
    let depth = (2 * threads * VOXELS_PER_THREAD)
        .div_ceil(slice_voxels)
        .clamp(1, nz);
    let xs: Vec<f64> = (0..nx).map(|i| grid.centre(0, i)).collect();
    let row_len = channels * nx;
    let mut buffer = vec![0f32; depth * ny * row_len];
    let mut done = 0u64;
    let mut z_start = 0;
    while z_start < nz {
        if options
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(Ordering::Relaxed))
        {
            return Err(BakeError::Cancelled);
        }
        let window_depth = depth.min(nz - z_start);
        let data = &mut buffer[..window_depth * ny * row_len];
        // One task per row; each returns its channel statistics, merged below in row order.
        let row_stats: Vec<Vec<ChannelStats>> = pool.install(|| {
            data.par_chunks_mut(row_len)
                .enumerate()
                .map_init(
                    || {
                        (
                            Workspace::<S>::new(),
                            vec![0f64; nx],
                            vec![0f64; nx],
                            vec![S::ZERO; row_len],
                        )
                    },
                    |(workspace, ys, zs, out), (row, target)| {
                        let (k, j) = (z_start + row / ny, row % ny);
                        ys.fill(grid.centre(1, j));
                        zs.fill(grid.centre(2, k));
                        tape.eval_batch(workspace, &xs, ys, zs, out);
                        let mut row_stats = vec![ChannelStats::default(); channels];
                        for (c, stat) in row_stats.iter_mut().enumerate() {
                            for (t, v) in target[c * nx..(c + 1) * nx]
                                .iter_mut()
                                .zip(&out[c * nx..(c + 1) * nx])
                            {
                                *t = v.to_f64() as f32;
                                stat.add(*t);
                            }
                        }
                        row_stats
                    },
                )
                .collect()
        });
        for row in &row_stats {
            for (total, part) in stats.iter_mut().zip(row) {
                total.merge(part);
            }
        }
        let window = Window {
            grid,
            z_start,
            depth: window_depth,
            channels,
            outputs: &outputs,
            data,
        };
        // Inside the pool, so a sink that encodes in parallel (PNG slices) uses its threads.
        pool.install(|| sink.window(&window))?;
        done += (window_depth * slice_voxels) as u64;
        progress(done);
        z_start += window_depth;
    }
    Ok(collect_stats(tape, &stats))
}

fn collect_stats(tape: &Tape, stats: &[ChannelStats]) -> Vec<OutputStats> {
    tape.outputs
        .iter()
        .map(|o| OutputStats {
            name: o.name.clone(),
            channels: stats[o.first_channel..o.first_channel + o.ty.channels()].to_vec(),
        })
        .collect()
}
