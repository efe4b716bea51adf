//! [`GpuBake`]: a bake's windows on the GPU at the speed of the bus (issue 49). Each window is
//! one submission: the tape's `bake` kernel, then `wgsl/pack.wgsl`, which packs every channel
//! into the sample type its file stores (8-bit, 16-bit, half or 32-bit floats,
//! [`crate::encoding`]) and reduces its statistics per workgroup, then a copy of the packed
//! bytes and the statistics into one of two staging buffers. So a bake reads back what it
//! writes (a quarter of the floats for 8-bit files), and while the caller copies window i out
//! of one staging buffer, the device already runs window i + 1 into the other.

use super::error::GpuError;
use super::evaluator::{binding as entry, GpuEvaluator};
use super::window_stats::{WindowStats, STATS_BYTES};
use crate::encoding::Packing;
use crate::grid::{Grid, Layout};
use std::collections::VecDeque;
use std::sync::{mpsc, Arc, OnceLock};
use wgpu::util::DeviceExt;

/// Words one `pack` workgroup packs per channel (`WORDS` in `pack.wgsl`).
const WORDS: u64 = 512;

/// The `pack` pipeline, made once per process on the GPU path's device.
struct Packer {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

fn packer(device: &wgpu::Device) -> Result<&'static Packer, GpuError> {
    static PACKER: OnceLock<Result<Packer, String>> = OnceLock::new();
    PACKER
        .get_or_init(|| make_packer(device))
        .as_ref()
        .map_err(|e| GpuError::Shader(e.clone()))
}

fn make_packer(device: &wgpu::Device) -> Result<Packer, String> {
    let source = include_str!("wgsl/pack.wgsl");
    super::codegen::validate(source)?;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("pack"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let entry = super::evaluator::layout_entry;
    let read = wgpu::BufferBindingType::Storage { read_only: true };
    let write = wgpu::BufferBindingType::Storage { read_only: false };
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("pack"),
        entries: &[
            entry(0, read),
            entry(1, wgpu::BufferBindingType::Uniform),
            entry(2, read),
            entry(3, write),
            entry(4, write),
        ],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("pack"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("pack"),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("pack"),
        compilation_options: Default::default(),
        cache: None,
    });
    if let Some(error) = pollster::block_on(scope.pop()) {
        return Err(error.to_string());
    }
    Ok(Packer { layout, pipeline })
}

/// A window submitted and not yet collected.
struct Queued {
    staging: usize,
    count: usize,
    groups: u64,
    index: wgpu::SubmissionIndex,
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

/// A bake's windows on the GPU: [`GpuBake::submit`] queues a window (at most two at a time),
/// [`GpuBake::collect`] waits for the oldest and copies its packed samples out. Its buffers
/// are made once per bake for its largest window.
pub struct GpuBake {
    evaluator: Arc<GpuEvaluator>,
    grid: Grid,
    layout: Layout,
    packing: Packing,
    inputs: wgpu::Buffer,
    results: wgpu::Buffer,
    table: wgpu::Buffer,
    packed: wgpu::Buffer,
    stats: wgpu::Buffer,
    staging: [wgpu::Buffer; 2],
    /// Where a staging buffer's statistics start (after the largest window's samples).
    stats_at: u64,
    queued: VecDeque<Queued>,
    turn: usize,
}

impl GpuBake {
    /// A bake of `grid` (laid out by `layout`, windows of at most `layout.per_window`
    /// segments) on `evaluator`, each channel packed as `packing` says.
    pub fn new(
        evaluator: Arc<GpuEvaluator>,
        grid: &Grid,
        layout: &Layout,
        packing: Packing,
    ) -> Result<GpuBake, GpuError> {
        let (device, _, max_binding, _) = evaluator.device();
        let channels = evaluator.channels();
        assert_eq!(
            packing.encodings.len(),
            channels,
            "one encoding per channel"
        );
        assert_eq!(packing.segment_len, layout.segment_len);
        let per = layout.per_window;
        let results_size = (per * channels * layout.segment_len * 4) as u64;
        let packed_size = packing.bytes(per) as u64;
        if results_size > max_binding {
            return Err(GpuError::Unsupported(format!(
                "a bake window of {results_size} bytes, over the device's binding limit of \
                 {max_binding}"
            )));
        }
        let stats_size = channels as u64 * max_groups(&packing, per) * STATS_BYTES;
        let buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(4),
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let table: Vec<u8> = packing
            .encodings
            .iter()
            .zip(&packing.offsets)
            .enumerate()
            .flat_map(|(c, (e, &offset))| {
                let end = packing.offsets.get(c + 1).copied();
                let words = end.unwrap_or(packing.stride_words) - offset;
                let (code, srgb) = e.gpu_code();
                [code, srgb, offset as u32, words as u32]
            })
            .flat_map(u32::to_le_bytes)
            .collect();
        let staging_size = packed_size + stats_size;
        Ok(GpuBake {
            inputs: evaluator.grid_inputs(grid),
            results: buffer("results", results_size, U::STORAGE),
            table: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("pack channels"),
                contents: &table,
                usage: U::STORAGE,
            }),
            packed: buffer("packed", packed_size, U::STORAGE | U::COPY_SRC),
            stats: buffer("stats", stats_size, U::STORAGE | U::COPY_SRC),
            staging: [0, 1].map(|_| buffer("staging", staging_size, U::MAP_READ | U::COPY_DST)),
            stats_at: packed_size,
            evaluator,
            grid: *grid,
            layout: *layout,
            packing,
            queued: VecDeque::new(),
            turn: 0,
        })
    }

    /// Windows submitted and not yet collected (0, 1 or 2).
    pub fn queued(&self) -> usize {
        self.queued.len()
    }

    /// Queues the window of `count` segments from `first`: kernel, packing, copy into a free
    /// staging buffer. Refused (a caller bug) while two windows are queued.
    pub fn submit(&mut self, first: u64, count: usize) -> Result<(), GpuError> {
        assert!(self.queued.len() < 2, "two windows are queued already");
        assert!(count <= self.layout.per_window);
        let (device, queue, _, max) = self.evaluator.device();
        let packer = packer(device)?;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut encoder = device.create_command_encoder(&Default::default());
        self.evaluator.record_bake(
            &mut encoder,
            (&self.inputs, &self.results),
            (&self.grid, &self.layout),
            first,
            count,
        )?;
        let groups = max_groups(&self.packing, count);
        let params: Vec<u8> = [
            first as u32,
            count as u32,
            self.layout.segment_len as u32,
            self.layout.per_row as u32,
            self.grid.size[0] as u32,
            self.packing.stride_words as u32,
            groups as u32,
            self.packing.encodings.len() as u32,
        ]
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .collect();
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("pack params"),
            contents: &params,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pack"),
            layout: &packer.layout,
            entries: &[
                entry(0, &self.results),
                entry(1, &params),
                entry(2, &self.table),
                entry(3, &self.packed),
                entry(4, &self.stats),
            ],
        });
        {
            let gx = groups.min(u64::from(max));
            let gy = groups.div_ceil(gx.max(1));
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&packer.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            let channels = self.packing.encodings.len() as u32;
            pass.dispatch_workgroups(gx as u32, gy as u32, channels);
        }
        let staging = self.turn;
        self.turn = 1 - self.turn;
        let target = &self.staging[staging];
        let bytes = self.packing.bytes(count) as u64;
        let stats = self.packing.encodings.len() as u64 * groups * STATS_BYTES;
        encoder.copy_buffer_to_buffer(&self.packed, 0, target, 0, bytes);
        encoder.copy_buffer_to_buffer(&self.stats, 0, target, self.stats_at, stats);
        let index = queue.submit([encoder.finish()]);
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Device(error.to_string()));
        }
        let (tx, mapped) = mpsc::channel();
        target.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.queued.push_back(Queued {
            staging,
            count,
            groups,
            index,
            mapped,
        });
        Ok(())
    }

    /// Waits for the oldest queued window, copies its packed samples into `out` (resized to
    /// [`Packing::bytes`] of its segments) and returns each channel's statistics. Refused (a
    /// caller bug) when none is queued.
    pub fn collect(&mut self, out: &mut Vec<u8>) -> Result<Vec<WindowStats>, GpuError> {
        let q = self.queued.pop_front().expect("a window is queued");
        let (device, ..) = self.evaluator.device();
        device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(q.index),
                timeout: None,
            })
            .map_err(|e| GpuError::Device(e.to_string()))?;
        q.mapped
            .recv()
            .map_err(|e| GpuError::Device(e.to_string()))?
            .map_err(|e| GpuError::Device(e.to_string()))?;
        let buffer = &self.staging[q.staging];
        let channels = self.packing.encodings.len();
        let mut stats = vec![WindowStats::default(); channels];
        {
            let view = buffer
                .slice(..)
                .get_mapped_range()
                .map_err(|e| GpuError::Device(e.to_string()))?;
            let bytes = self.packing.bytes(q.count);
            out.clear();
            out.extend_from_slice(&view[..bytes]);
            let records = &view[self.stats_at as usize..];
            for (c, stat) in stats.iter_mut().enumerate() {
                let at = c * q.groups as usize * STATS_BYTES as usize;
                let channel = &records[at..at + q.groups as usize * STATS_BYTES as usize];
                for record in channel.chunks_exact(STATS_BYTES as usize) {
                    stat.add(record);
                }
            }
        }
        buffer.unmap();
        Ok(stats)
    }
}

impl GpuBake {
    /// Every window of the grid, in order, each handed to `each` (its first segment, segment
    /// count, packed bytes and channel statistics) while the next one runs on the device.
    pub fn for_each_window(
        &mut self,
        mut each: impl FnMut(u64, usize, &[u8], Vec<WindowStats>),
    ) -> Result<(), GpuError> {
        let (total, per) = (self.layout.total, self.layout.per_window as u64);
        let window = |first: u64| (total - first).min(per) as usize;
        let mut bytes = Vec::new();
        if self.queued.is_empty() && total > 0 {
            self.submit(0, window(0))?;
        }
        let mut first = 0;
        while first < total {
            let next = first + window(first) as u64;
            if next < total {
                self.submit(next, window(next))?;
            }
            let stats = self.collect(&mut bytes)?;
            each(first, window(first), &bytes, stats);
            first = next;
        }
        Ok(())
    }
}

impl Drop for GpuBake {
    /// Waits for windows still queued (an error stopped the bake), so that no mapping outlives
    /// its buffers.
    fn drop(&mut self) {
        if !self.queued.is_empty() {
            let (device, ..) = self.evaluator.device();
            let _ = device.poll(wgpu::PollType::wait_indefinitely());
        }
    }
}

/// `pack` workgroups per channel for a window of `segments` segments: enough for the channel
/// with the most words.
fn max_groups(packing: &Packing, segments: usize) -> u64 {
    let widest = packing
        .offsets
        .iter()
        .zip(
            packing
                .offsets
                .iter()
                .skip(1)
                .chain([&packing.stride_words]),
        )
        .map(|(a, b)| b - a)
        .max()
        .unwrap_or(0);
    ((segments * widest) as u64).div_ceil(WORDS).max(1)
}
