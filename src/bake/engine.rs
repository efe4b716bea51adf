//! The bake engine: a tape evaluated over a [`Grid`] window by window, on the CPU or the GPU,
//! streamed into a [`Sink`] (module documentation of [`crate::bake`] has the design).

use super::error::BakeError;
use super::window::{Sink, Window, WindowData, WindowOutput};
use crate::encoding::{Encoding, Packing};
use crate::eval::Workspace;
use crate::graph::Type;
use crate::grid::{Grid, Layout};
use crate::real::Real;
use crate::tape::Tape;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};

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
    /// Where the voxels are evaluated, decided by [`super::choose_device`] for every sink:
    /// `Device::Gpu` makes and reads them back on the GPU (the tape's point or filtered
    /// evaluator, f32 precision only) or refuses the bake, saying why; `Auto` the GPU where it
    /// can run the bake, else the CPU (the command line asks `choose_device` first and says
    /// which). The sinks, statistics and streaming are the same either way.
    pub device: crate::gpu::Device,
    /// `Box`: each voxel the estimate of the graph's mean over its cell (filtered evaluation,
    /// `crate::filter`); `Point`: the value at its centre.
    pub filter: crate::filter::Filter,
    /// Write these voxels instead of evaluating the tape: a volume baked before over the same
    /// grid, with the tape's outputs. The files' writing alone, from memory (what benches
    /// compare a bake's time with: `benches/gpu.rs`'s `bake_vs_write`).
    pub replay: Option<Arc<Volume>>,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions {
            grid: Grid::cube(64),
            threads: 0,
            precision: Precision::F32,
            cancel: None,
            device: crate::gpu::Device::Cpu,
            filter: crate::filter::Filter::Point,
            replay: None,
        }
    }
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
    /// Values below 0 and above 1 (infinities included): what an 8/16-bit file clamps.
    pub below_zero: u64,
    pub above_one: u64,
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
            below_zero: 0,
            above_one: 0,
            sum: 0.0,
            finite: 0,
        }
    }
}

impl ChannelStats {
    #[inline]
    pub(crate) fn add(&mut self, v: f32) {
        self.below_zero += u64::from(v < 0.0);
        self.above_one += u64::from(v > 1.0);
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

    pub(crate) fn merge(&mut self, other: &ChannelStats) {
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
        self.sum += other.sum;
        self.finite += other.finite;
        self.nan += other.nan;
        self.pos_inf += other.pos_inf;
        self.neg_inf += other.neg_inf;
        self.below_zero += other.below_zero;
        self.above_one += other.above_one;
        self.mean = if self.finite > 0 {
            self.sum / self.finite as f64
        } else {
            f64::NAN
        };
    }

    pub fn non_finite(&self) -> u64 {
        self.nan + self.pos_inf + self.neg_inf
    }

    /// A GPU window's statistics of one channel (reduced on the device by `pack.wgsl`).
    pub(crate) fn from_window(w: &crate::gpu::WindowStats) -> ChannelStats {
        let mut stats = ChannelStats {
            nan: w.nan,
            pos_inf: w.pos_inf,
            neg_inf: w.neg_inf,
            below_zero: w.below,
            above_one: w.above,
            sum: w.sum,
            finite: w.finite,
            ..ChannelStats::default()
        };
        if w.finite > 0 {
            stats.min = f64::from(w.min);
            stats.max = f64::from(w.max);
        }
        stats
    }

    /// How many values were finite (min, max and mean are over these).
    pub fn finite(&self) -> u64 {
        self.finite
    }

    /// Values outside [0, 1]: what an 8/16-bit encoding clamps (NaN, written as 0, is counted
    /// in [`ChannelStats::nan`] instead).
    pub fn clamped(&self) -> u64 {
        self.below_zero + self.above_one
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

    /// Values below 0 and above 1 over all channels.
    pub fn clamped(&self) -> (u64, u64) {
        self.channels
            .iter()
            .fold((0, 0), |(b, a), c| (b + c.below_zero, a + c.above_one))
    }
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
}

impl Sink for VolumeSink {
    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        for (o, output) in self.outputs.iter_mut().enumerate() {
            for (s, segment) in window.segments() {
                window.push_interleaved(o, s, &segment, &mut output.data);
            }
        }
        Ok(())
    }
}

/// Bakes into memory. Needs `voxels × channels × 4` bytes, reserved up front: a volume whose
/// size overflows or cannot be allocated is refused with an error, before any evaluation.
pub fn bake_volume(tape: &Tape, options: &BakeOptions) -> Result<Volume, BakeError> {
    bake_volume_with_progress(tape, options, &mut |_| {})
}

/// [`bake_volume`], calling `progress` with the voxels done after each window (the VDB writer
/// bakes this way).
pub fn bake_volume_with_progress(
    tape: &Tape,
    options: &BakeOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<Volume, BakeError> {
    let voxels = options.grid.voxels().and_then(|v| usize::try_from(v).ok());
    let mut outputs = Vec::with_capacity(tape.outputs.len());
    for o in &tape.outputs {
        let mut data = Vec::new();
        let len = voxels.and_then(|v| v.checked_mul(o.ty.channels()));
        len.and_then(|len| data.try_reserve_exact(len).ok())
            .ok_or_else(|| {
                BakeError::Refused(format!(
                    "a volume of {:?} voxels for output \"{}\" does not fit in memory",
                    options.grid.size, o.name
                ))
            })?;
        outputs.push(VolumeOutput {
            name: o.name.clone(),
            ty: o.ty,
            data,
        });
    }
    let mut sink = VolumeSink { outputs };
    let stats = bake_into(tape, options, &mut sink, progress)?;
    Ok(Volume {
        grid: options.grid,
        outputs: sink.outputs,
        stats,
    })
}

/// The thread count a GPU bake's windows are sized for ([`Layout::new`]): windows of up to
/// 2 × 32 × 64 Ki = 4 Mi voxels, where the CPU's are two segments per worker. A card runs such
/// a window in about a millisecond (the seed 003 marble at 10 Gvoxels/s on an H200), so the
/// cost of making and submitting it stays small beside it; lavapipe takes seconds.
const GPU_WINDOW_THREADS: usize = 32;

/// Most worker threads per available core (`--threads` above it is capped, with a warning from
/// the command line).
pub const MAX_THREADS_PER_CORE: usize = 4;

/// The thread count a bake or render uses for a request (`0`: one per core): at most
/// [`MAX_THREADS_PER_CORE`] × the available parallelism. Returns it and whether it was capped.
pub fn capped_threads(requested: usize) -> (usize, bool) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let cap = cores * MAX_THREADS_PER_CORE;
    match requested {
        0 => (cores, false),
        n if n > cap => (cap, true),
        n => (n, false),
    }
}

/// Bakes `tape` over the grid into `sink`, window by window in file order; calls `progress`
/// with the voxels done so far after each window. Returns per-output statistics.
pub fn bake_into(
    tape: &Tape,
    options: &BakeOptions,
    sink: &mut dyn Sink,
    progress: &mut dyn FnMut(u64),
) -> Result<Vec<OutputStats>, BakeError> {
    let (threads, _) = capped_threads(options.threads);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| BakeError::Refused(format!("cannot start {threads} worker threads: {e}")))?;
    match options.precision {
        Precision::F32 => bake_with::<f32>(tape, options, &pool, sink, progress),
        Precision::F64 => bake_with::<f64>(tape, options, &pool, sink, progress),
    }
}

/// What the coordinating thread, the workers and the writer thread share about a bake.
struct Plan<'a> {
    grid: &'a Grid,
    layout: Layout,
    channels: usize,
    outputs: Vec<WindowOutput>,
    /// How a GPU bake's windows hold their channels (each in the type its sink stores);
    /// `None` on the CPU (32-bit floats).
    packing: Option<Packing>,
}

impl Plan<'_> {
    /// Samples per segment (every channel, `segment_len` voxels each).
    fn block(&self) -> usize {
        self.channels * self.layout.segment_len
    }

    /// The window of `job`'s segments over its buffer.
    fn window<'a>(&'a self, job: &'a Job) -> Window<'a> {
        Window {
            grid: self.grid,
            layout: &self.layout,
            first_segment: job.first,
            segments: job.count,
            channels: self.channels,
            outputs: &self.outputs,
            data: match &self.packing {
                None => WindowData::F32(&job.buffer[..job.count * self.block()]),
                Some(packing) => WindowData::Packed {
                    bytes: &job.bytes[..packing.bytes(job.count)],
                    packing,
                },
            },
        }
    }
}

/// An evaluated window on its way to the writer thread (and its buffers on their way back):
/// 32-bit floats from the CPU, packed bytes from the GPU.
#[derive(Default)]
struct Job {
    first: u64,
    count: usize,
    buffer: Vec<f32>,
    bytes: Vec<u8>,
}

/// What evaluates a bake's windows. (Without the `gpu` feature `GpuBake` is an empty stand-in,
/// and the CPU variant the large one; one producer lives per bake.)
#[cfg_attr(not(feature = "gpu"), allow(clippy::large_enum_variant))]
enum Producer<'a, S: Real> {
    Cpu {
        tape: &'a Tape,
        filtered: Option<crate::filter::Filtered<'a>>,
        _lane: std::marker::PhantomData<S>,
    },
    /// Double-buffered: window i + 1 is queued on the device before window i is collected.
    Gpu(crate::gpu::GpuBake),
    /// Copies of a volume's voxels ([`BakeOptions::replay`]).
    Replay(&'a Volume, std::marker::PhantomData<S>),
}

impl<S: Real> Producer<'_, S> {
    /// Evaluates the window of `job.count` segments from `job.first` into `job`'s buffers
    /// (`next`: the window after it, which the GPU starts before this one is copied out);
    /// returns its channel statistics, in segment order.
    fn produce(
        &mut self,
        plan: &Plan<'_>,
        pool: &rayon::ThreadPool,
        job: &mut Job,
        next: Option<(u64, usize)>,
    ) -> Result<Vec<Vec<ChannelStats>>, BakeError> {
        let (first, count) = (job.first, job.count);
        match self {
            Producer::Cpu { tape, filtered, .. } => {
                job.buffer
                    .resize(plan.layout.per_window * plan.block(), 0.0);
                let data = &mut job.buffer[..count * plan.block()];
                Ok(evaluate_window::<S>(
                    tape,
                    filtered.as_ref(),
                    plan,
                    pool,
                    first,
                    data,
                ))
            }
            Producer::Gpu(gpu) => {
                let refused = |e: crate::gpu::GpuError| BakeError::Refused(e.to_string());
                if gpu.queued() == 0 {
                    gpu.submit(first, count).map_err(refused)?;
                }
                if let Some((next, count)) = next {
                    gpu.submit(next, count).map_err(refused)?;
                }
                let stats = gpu.collect(&mut job.bytes).map_err(refused)?;
                Ok(vec![stats.iter().map(ChannelStats::from_window).collect()])
            }
            Producer::Replay(volume, _) => {
                job.buffer
                    .resize(plan.layout.per_window * plan.block(), 0.0);
                let data = &mut job.buffer[..count * plan.block()];
                Ok(replay_window(volume, plan, pool, first, data))
            }
        }
    }
}

/// [`evaluate_window`] from a volume in memory: its voxels copied into the window's layout.
fn replay_window(
    volume: &Volume,
    plan: &Plan<'_>,
    pool: &rayon::ThreadPool,
    first: u64,
    data: &mut [f32],
) -> Vec<Vec<ChannelStats>> {
    let (grid, layout) = (plan.grid, &plan.layout);
    let [nx, ny, _] = grid.size;
    pool.install(|| {
        data.par_chunks_mut(plan.block())
            .enumerate()
            .map(|(s, target)| {
                let segment = layout.segment(grid, first + s as u64);
                let start = (segment.k * ny + segment.j) * nx + segment.i0;
                let mut stats = vec![ChannelStats::default(); plan.channels];
                for (o, output) in plan.outputs.iter().enumerate() {
                    let width = output.ty.channels();
                    let voxels = &volume.outputs[o].data[start * width..][..segment.len * width];
                    for c in 0..width {
                        let channel = output.first_channel + c;
                        let row = &mut target[channel * layout.segment_len..][..segment.len];
                        for (t, v) in row.iter_mut().zip(voxels[c..].iter().step_by(width)) {
                            *t = *v;
                            stats[channel].add(*v);
                        }
                    }
                }
                stats
            })
            .collect()
    })
}

/// Bakes window by window, two windows in flight: while the pool evaluates window i + 1 into
/// one buffer, a writer thread hands window i, in the other, to the sink; then they swap. So at
/// most two windows of samples exist. The statistics are merged here, in segment order, and
/// `progress` is called here once a window is written. A sink error (the writer stops at it) is
/// returned at the next hand-over, at most one window's evaluation later; a cancellation stops
/// before the next window; either way the writer finishes the window it holds and is joined
/// before this returns.
fn bake_with<S: Real>(
    tape: &Tape,
    options: &BakeOptions,
    pool: &rayon::ThreadPool,
    sink: &mut dyn Sink,
    progress: &mut dyn FnMut(u64),
) -> Result<Vec<OutputStats>, BakeError> {
    let grid = &options.grid;
    let channels = tape.channels();
    // The device, as every sink decides it (`device.rs`): `--device gpu` that cannot run
    // this bake is refused here too, never baked on the CPU in silence.
    let double = S::NAME == "f64";
    let choice = super::device::choose(tape, options.device, options.filter, double)
        .map_err(BakeError::Refused)?;
    let mut stats: Vec<ChannelStats> = vec![ChannelStats::default(); channels];
    // A card's window is one submission: windows as for [`GPU_WINDOW_THREADS`] threads (4 Mi
    // voxels, within the window bound), not the pool's few. A software adapter runs on the
    // pool's cores: its windows as the CPU's (progress and Ctrl-C as often).
    let on_card = choice.evaluator.gpu().is_some_and(|g| !g.is_software());
    let threads = if on_card && options.replay.is_none() {
        GPU_WINDOW_THREADS
    } else {
        pool.current_num_threads()
    };
    let Some(layout) = Layout::new(grid, channels, threads) else {
        return Ok(collect_stats(tape, &stats));
    };
    let outputs = tape
        .outputs
        .iter()
        .map(|o| WindowOutput {
            name: o.name.clone(),
            ty: o.ty,
            first_channel: o.first_channel,
        })
        .collect();
    let (mut producer, packing) = producer::<S>(tape, options, &choice, &*sink, &layout)?;
    let plan = &Plan {
        grid,
        layout,
        channels,
        outputs,
        packing,
    };
    let cancelled = || {
        options
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(Ordering::Relaxed))
    };
    std::thread::scope(|scope| {
        // One job at a time is in the writer's hands (the loop waits for it before sending the
        // next), so neither send below ever blocks for long; dropping `jobs` (any return from
        // this closure, a panic included) ends the writer's loop.
        let (jobs, to_write) = mpsc::sync_channel::<Job>(1);
        let (written, done) = mpsc::channel::<Result<Job, BakeError>>();
        scope.spawn(move || write_windows(plan, pool, sink, to_write, written));
        let mut spare: Option<Job> = None;
        // The segment after the window the writer holds.
        let mut in_flight: Option<u64> = None;
        let mut first = 0u64;
        while first < layout.total {
            if cancelled() {
                return Err(BakeError::Cancelled);
            }
            let count = (layout.total - first).min(layout.per_window as u64) as usize;
            let mut job = spare.take().unwrap_or_default();
            (job.first, job.count) = (first, count);
            let after = first + count as u64;
            let next = (after < layout.total).then(|| {
                (
                    after,
                    (layout.total - after).min(layout.per_window as u64) as usize,
                )
            });
            let segment_stats = producer.produce(plan, pool, &mut job, next)?;
            for part in &segment_stats {
                for (total, part) in stats.iter_mut().zip(part) {
                    total.merge(part);
                }
            }
            if let Some(end) = in_flight.take() {
                spare = Some(wait_written(&done)?);
                progress(layout.voxels_before(grid, end));
                if cancelled() {
                    return Err(BakeError::Cancelled);
                }
            }
            jobs.send(job).map_err(|_| writer_stopped())?;
            first += count as u64;
            in_flight = Some(first);
        }
        if let Some(end) = in_flight {
            wait_written(&done)?;
            progress(layout.voxels_before(grid, end));
        }
        Ok(collect_stats(tape, &stats))
    })
}

/// What evaluates `options`' windows for `tape` on the device `choice` says: the CPU, a
/// double-buffered GPU bake packing each output as `sink` stores it, or a replayed volume; and
/// how the windows hold their channels (`None`: 32-bit floats).
fn producer<'a, S: Real>(
    tape: &'a Tape,
    options: &'a BakeOptions,
    choice: &super::device::Choice,
    sink: &dyn Sink,
    layout: &Layout,
) -> Result<(Producer<'a, S>, Option<Packing>), BakeError> {
    let grid = &options.grid;
    Ok(match (&options.replay, choice.evaluator.gpu()) {
        (Some(volume), _) => {
            let fits =
                volume.grid == *grid
                    && volume.outputs.len() == tape.outputs.len()
                    && volume.outputs.iter().zip(&tape.outputs).all(|(v, o)| {
                        v.ty == o.ty && v.data.len() == voxels(grid) * o.ty.channels()
                    });
            if !fits {
                return Err(BakeError::Refused(
                    "internal: a replayed volume of another grid or other outputs".into(),
                ));
            }
            (Producer::Replay(volume, std::marker::PhantomData), None)
        }
        (None, Some(gpu)) => {
            // Each channel in the type its sink stores, packed on the device.
            let encodings = tape
                .outputs
                .iter()
                .enumerate()
                .flat_map(|(index, o)| {
                    let e = sink.stores(index).unwrap_or(Encoding::F32);
                    std::iter::repeat_n(e, o.ty.channels())
                })
                .collect();
            let packing = Packing::new(encodings, layout.segment_len);
            let bake = crate::gpu::GpuBake::new(gpu.clone(), grid, layout, packing.clone())
                .map_err(|e| BakeError::Refused(e.to_string()))?;
            (Producer::<S>::Gpu(bake), Some(packing))
        }
        (None, None) => (
            Producer::Cpu {
                tape,
                filtered: (options.filter == crate::filter::Filter::Box)
                    .then(|| crate::filter::Filtered::new(tape)),
                _lane: std::marker::PhantomData,
            },
            None,
        ),
    })
}

/// The writer thread: hands each job's window to the sink, inside the pool (so a sink that
/// encodes in parallel, PNG slices, uses its workers, alongside the evaluation of the next
/// window), and sends the job back with the result; stops at the first error.
fn write_windows(
    plan: &Plan<'_>,
    pool: &rayon::ThreadPool,
    sink: &mut dyn Sink,
    jobs: mpsc::Receiver<Job>,
    written: mpsc::Sender<Result<Job, BakeError>>,
) {
    for job in jobs {
        let result = pool.install(|| sink.window(&plan.window(&job)));
        let failed = result.is_err();
        if written.send(result.map(|()| job)).is_err() || failed {
            return;
        }
    }
}

/// Waits for the writer to finish the window it holds.
fn wait_written(done: &mpsc::Receiver<Result<Job, BakeError>>) -> Result<Job, BakeError> {
    done.recv().map_err(|_| writer_stopped())?
}

/// The writer thread is gone without a word: only a panic in the sink does that, and the scope
/// re-raises it when it joins the thread.
fn writer_stopped() -> BakeError {
    BakeError::Refused("internal: the bake's writer thread stopped".into())
}

/// Evaluates the `data.len() / block` segments from `first` into `data`, in parallel, one task
/// per segment; returns each segment's channel statistics, in segment order.
fn evaluate_window<S: Real>(
    tape: &Tape,
    filtered: Option<&crate::filter::Filtered>,
    plan: &Plan<'_>,
    pool: &rayon::ThreadPool,
    first: u64,
    data: &mut [f32],
) -> Vec<Vec<ChannelStats>> {
    let (grid, layout, channels) = (plan.grid, &plan.layout, plan.channels);
    // The voxel's cell: its sides the grid spacing (a degenerate axis is a point along it).
    let footprint = crate::filter::Footprint::from_sides(grid.spacing().map(f64::abs))
        .unwrap_or(crate::filter::Footprint::POINT);
    let seg_len = layout.segment_len;
    let block = plan.block();
    pool.install(|| {
        data.par_chunks_mut(block)
            .enumerate()
            .map_init(
                || {
                    (
                        (
                            Workspace::<S>::new(),
                            crate::filter::FilterWorkspace::<S>::default(),
                        ),
                        // The x coordinates of the last segment, and where it started: rows
                        // that fit in one segment reuse them for every row.
                        (Vec::with_capacity(seg_len), usize::MAX),
                        Vec::with_capacity(seg_len),
                        Vec::with_capacity(seg_len),
                        vec![S::ZERO; block],
                    )
                },
                |((workspace, filter_ws), (xs, xs_start), ys, zs, out), (s, target)| {
                    let segment = layout.segment(grid, first + s as u64);
                    let n = segment.len;
                    if *xs_start != segment.i0 || xs.len() != n {
                        xs.clear();
                        xs.extend((segment.i0..segment.i0 + n).map(|i| grid.centre(0, i)));
                        *xs_start = segment.i0;
                    }
                    ys.clear();
                    ys.resize(n, grid.centre(1, segment.j));
                    zs.clear();
                    zs.resize(n, grid.centre(2, segment.k));
                    let out = &mut out[..channels * n];
                    match filtered {
                        Some(f) => f.eval_batch_with(
                            filter_ws,
                            [xs, ys, zs],
                            std::slice::from_ref(&footprint),
                            out,
                        ),
                        None => tape.eval_batch(workspace, xs, ys, zs, out),
                    }
                    let mut seg_stats = vec![ChannelStats::default(); channels];
                    for (c, stat) in seg_stats.iter_mut().enumerate() {
                        for (t, v) in target[c * seg_len..c * seg_len + n]
                            .iter_mut()
                            .zip(&out[c * n..(c + 1) * n])
                        {
                            *t = v.to_f64() as f32;
                            stat.add(*t);
                        }
                    }
                    seg_stats
                },
            )
            .collect()
    })
}

/// The grid's voxel count as a length (0 when it does not fit one).
fn voxels(grid: &Grid) -> usize {
    grid.voxels()
        .and_then(|v| usize::try_from(v).ok())
        .unwrap_or(0)
}

/// Per output of `tape`, its channels' statistics out of `stats` (one per channel).
pub(crate) fn collect_stats(tape: &Tape, stats: &[ChannelStats]) -> Vec<OutputStats> {
    tape.outputs
        .iter()
        .map(|o| OutputStats {
            name: o.name.clone(),
            channels: stats[o.first_channel..o.first_channel + o.ty.channels()].to_vec(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Region, SEGMENT_VOXELS, WINDOW_BYTES};

    fn grid(size: [usize; 3]) -> Grid {
        Grid {
            size,
            region: Region::default(),
        }
    }

    /// Segments cover every voxel once, in file order, whatever the shape.
    #[test]
    fn segments_tile_the_grid_in_file_order() {
        for (size, channels, threads) in [
            ([5, 3, 2], 1, 1),
            ([70_000, 2, 3], 4, 2),
            ([1, 1, 9], 2, 8),
            ([131_073, 1, 1], 1, 3),
        ] {
            let g = grid(size);
            let layout = Layout::new(&g, channels, threads).unwrap();
            let mut next = (0usize, 0usize, 0usize);
            for index in 0..layout.total {
                let s = layout.segment(&g, index);
                assert_eq!((s.i0, s.j, s.k), next, "{size:?} segment {index}");
                assert!(s.len >= 1 && s.len <= layout.segment_len);
                next = if s.i0 + s.len < size[0] {
                    (s.i0 + s.len, s.j, s.k)
                } else if s.j + 1 < size[1] {
                    (0, s.j + 1, s.k)
                } else {
                    (0, 0, s.k + 1)
                };
            }
            assert_eq!(next, (0, 0, size[2]));
            assert_eq!(layout.voxels_before(&g, layout.total), g.voxels().unwrap());
            let mut before = 0;
            for index in 0..layout.total {
                assert_eq!(layout.voxels_before(&g, index), before, "{size:?} {index}");
                before += layout.segment(&g, index).len as u64;
            }
        }
    }

    /// A window's samples stay within WINDOW_BYTES for any shape and channel count, and rows
    /// are split rather than held whole.
    #[test]
    fn windows_are_bounded_for_any_shape() {
        for size in [
            [4_294_967_296, 1, 1],
            [65_536, 65_536, 1],
            [1, 1, 1 << 40],
            [512, 512, 512],
        ] {
            for channels in [1, 4, 3_000, 600_000] {
                for threads in [1, 2, 64, 1024] {
                    let layout = Layout::new(&grid(size), channels, threads).unwrap();
                    let bytes = layout.per_window * layout.segment_len * channels * 4;
                    assert!(
                        bytes <= WINDOW_BYTES.max(channels * 4),
                        "{size:?} {channels} {threads}: {bytes}"
                    );
                    assert!(layout.segment_len <= SEGMENT_VOXELS);
                }
            }
        }
        // Small slices: whole slices per window.
        let layout = Layout::new(&grid([128, 128, 128]), 4, 2).unwrap();
        assert_eq!(layout.per_window % 128, 0);
    }

    /// A cheap one-output graph (x) for the pipeline tests.
    fn x_tape() -> Tape {
        let file = crate::diagnostic::SourceFile::new(
            "x.ron",
            r#"Graph(nodes: { "p": Position }, outputs: { "x": "p.x" })"#,
        );
        let graph =
            crate::check::check(file, &crate::check::CheckOptions::default()).expect("checks");
        crate::compile::compile(&graph, &crate::compile::CompileOptions::default())
            .expect("compiles")
    }

    /// 512 × 512 × 6 voxels of one channel: windows of half a slice on 1 thread, of a slice on 2
    /// or 3.
    fn pipeline_options(threads: usize) -> BakeOptions {
        BakeOptions {
            grid: grid([512, 512, 6]),
            threads,
            ..BakeOptions::default()
        }
    }

    /// Counts the windows it is handed (shared, so progress can look), checks they come in
    /// order, and fails on window `fail_at` (or panics, when `panic`).
    struct Counting {
        seen: Arc<std::sync::atomic::AtomicUsize>,
        next_segment: u64,
        fail_at: Option<usize>,
        panic: bool,
    }

    impl Counting {
        fn new(fail_at: Option<usize>) -> Counting {
            Counting {
                seen: Arc::default(),
                next_segment: 0,
                fail_at,
                panic: false,
            }
        }
    }

    impl Sink for Counting {
        fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
            assert_eq!(
                window.first_segment, self.next_segment,
                "windows in file order"
            );
            self.next_segment += window.segments as u64;
            let index = self.seen.fetch_add(1, Ordering::SeqCst);
            if Some(index) == self.fail_at {
                assert!(!self.panic, "the sink panics on window {index}");
                return Err(BakeError::Encode {
                    path: "sink".into(),
                    message: format!("window {index} failed"),
                });
            }
            Ok(())
        }
    }

    /// Progress is reported from the coordinating thread once each window is written, with
    /// the voxels done so far, and the bake ends with every window written.
    #[test]
    fn progress_follows_the_written_windows() {
        let tape = x_tape();
        for threads in [1, 2, 3] {
            let options = pipeline_options(threads);
            let mut sink = Counting::new(None);
            let seen = sink.seen.clone();
            let mut reported = Vec::new();
            let stats = bake_into(&tape, &options, &mut sink, &mut |voxels| {
                reported.push(voxels);
                assert!(
                    seen.load(Ordering::SeqCst) >= reported.len(),
                    "reported before written"
                );
            })
            .expect("bakes");
            let layout = Layout::new(&options.grid, 1, threads).unwrap();
            let ends: Vec<u64> = (1..=layout.total.div_ceil(layout.per_window as u64))
                .map(|w| (w * layout.per_window as u64).min(layout.total))
                .map(|end| layout.voxels_before(&options.grid, end))
                .collect();
            assert!(ends.len() >= 6, "{threads} threads: {} windows", ends.len());
            assert_eq!(seen.load(Ordering::SeqCst), ends.len(), "{threads} threads");
            assert_eq!(reported, ends, "{threads} threads");
            assert_eq!(stats[0].channels[0].finite(), 6 * 512 * 512);
        }
    }

    /// A sink that fails on the third window: its error comes back, no window after it is
    /// written or reported, and nothing hangs.
    #[test]
    fn a_failing_sink_stops_the_bake_with_its_error() {
        let tape = x_tape();
        for threads in [1, 2, 3] {
            let mut sink = Counting::new(Some(2));
            let seen = sink.seen.clone();
            let mut reported = 0;
            let result = bake_into(&tape, &pipeline_options(threads), &mut sink, &mut |_| {
                reported += 1;
            });
            match result {
                Err(BakeError::Encode { message, .. }) => assert_eq!(message, "window 2 failed"),
                other => panic!("{threads} threads: {other:?}"),
            }
            assert_eq!(
                seen.load(Ordering::SeqCst),
                3,
                "{threads} threads: windows written"
            );
            assert_eq!(reported, 2, "{threads} threads: windows reported");
        }
    }

    /// A flag raised after the first window stops the bake with `Cancelled`: the window then
    /// evaluated is not handed to the sink.
    #[test]
    fn a_cancelled_bake_stops_between_windows() {
        let tape = x_tape();
        for threads in [1, 2] {
            let cancel = Arc::new(AtomicBool::new(false));
            let options = BakeOptions {
                cancel: Some(cancel.clone()),
                ..pipeline_options(threads)
            };
            let mut sink = Counting::new(None);
            let seen = sink.seen.clone();
            let mut reported = 0;
            let result = bake_into(&tape, &options, &mut sink, &mut |_| {
                reported += 1;
                cancel.store(true, Ordering::Relaxed);
            });
            assert!(matches!(result, Err(BakeError::Cancelled)), "{result:?}");
            assert_eq!((seen.load(Ordering::SeqCst), reported), (1, 1));
        }
    }

    /// A sink that panics: the panic reaches the caller (the writer thread is joined), no hang.
    #[test]
    fn a_panicking_sink_panics_the_bake() {
        let tape = x_tape();
        let mut sink = Counting::new(Some(1));
        sink.panic = true;
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            bake_into(&tape, &pipeline_options(2), &mut sink, &mut |_| {})
        }));
        assert!(result.is_err());
    }
}
