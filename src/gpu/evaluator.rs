//! [`GpuEvaluator`]: a tape's generated shader (`codegen.rs`) compiled once on the process's
//! GPU device, evaluating position buffers (`eval_batch`) or a bake's windows straight from the
//! grid (`bake_window`: positions made on the GPU, no upload).

use super::codegen::{self, TABLE_WORDS};
use super::error::GpuError;
use crate::tape::Tape;
use std::sync::{Arc, Mutex, OnceLock};
use wgpu::util::DeviceExt;

/// The process's GPU device: the first adapter with 64-bit floats, preferring a discrete GPU,
/// then an integrated, a virtual one, then a software driver (lavapipe).
pub(super) struct Context {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pub(super) info: wgpu::AdapterInfo,
    /// The largest storage buffer one binding may hold.
    max_binding: u64,
    /// The most workgroups one dispatch dimension may have.
    max_groups: u32,
}

static CONTEXT: OnceLock<Result<Arc<Context>, String>> = OnceLock::new();

pub(super) fn context() -> Result<Arc<Context>, GpuError> {
    CONTEXT
        .get_or_init(|| open().map(Arc::new))
        .clone()
        .map_err(GpuError::NoAdapter)
}

/// wgpu's instance flags in every build: its release defaults. wgpu's own default follows
/// *its* build, and in debug and test builds turns on `DEBUG`, which has naga write every
/// statement's source line into the SPIR-V (`Span::location` scans the source from its start
/// each time: quadratic in a shader's length) and the driver read them: 2.4 s of the
/// covering graphs' GPU contract test's 13.3 s on lavapipe with a warm Mesa cache (issue 46;
/// docs/gpu.md). `WGPU_DEBUG=1`,
/// `WGPU_VALIDATION=1` (`with_env`) turn them on where wanted.
fn instance_flags() -> wgpu::InstanceFlags {
    wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL
}

/// Every adapter of the Vulkan, Metal and DX12 backends (the environment's `WGPU_*` settings
/// applied), with the [`instance_flags`]: what `open` picks from and `gpu::adapters` lists.
pub(super) fn enumerate_adapters() -> Vec<wgpu::Adapter> {
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
    descriptor.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
    descriptor.flags = instance_flags();
    let descriptor = descriptor.with_env();
    let backends = descriptor.backends;
    let instance = wgpu::Instance::new(descriptor);
    pollster::block_on(instance.enumerate_adapters(backends))
}

fn open() -> Result<Context, String> {
    let adapters = enumerate_adapters();
    if adapters.is_empty() {
        return Err(
            "no graphics adapter found (no Vulkan, Metal or DX12 driver; on Debian, \
                    `apt-get install mesa-vulkan-drivers` gives the software one)"
                .into(),
        );
    }
    let rank = |info: &wgpu::AdapterInfo| match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    };
    let mut usable: Vec<_> = adapters
        .into_iter()
        .filter(|a| a.features().contains(wgpu::Features::SHADER_F64))
        .collect();
    usable.sort_by_key(|a| rank(&a.get_info()));
    let Some(adapter) = usable.into_iter().next() else {
        return Err(
            "no adapter has 64-bit floats in shaders (SHADER_F64), which the GPU path \
                    uses for positions and lattice cells"
                .into(),
        );
    };
    let info = adapter.get_info();
    let limits = adapter.limits();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("texgraph"),
        required_features: wgpu::Features::SHADER_F64,
        required_limits: limits.clone(),
        ..Default::default()
    }))
    .map_err(|e| format!("{}: cannot open the device: {e}", info.name))?;
    // Errors are caught per operation by error scopes; an uncaught one is reported, not fatal.
    device.on_uncaptured_error(Arc::new(|e| eprintln!("texgraph: GPU error: {e}")));
    let max_binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    Ok(Context {
        device,
        queue,
        info,
        max_binding,
        max_groups: limits.max_compute_workgroups_per_dimension,
    })
}

/// Threads per workgroup (`GROUP` in `wgsl/entry.wgsl`).
const GROUP: u64 = 64;

/// The uniform block of `wgsl/entry.wgsl` (`Dispatch`).
#[derive(Clone, Copy, Default)]
struct Dispatch {
    first_segment: u32,
    segments: u32,
    segment_len: u32,
    per_row: u32,
    nx: u32,
    ny: u32,
    count: u32,
    spacing: u32,
}

impl Dispatch {
    /// The block of a `bake` dispatch over `count` segments from `first` of `grid`; refused
    /// past 32-bit segment indices or rows.
    fn bake(
        grid: &crate::grid::Grid,
        layout: &crate::grid::Layout,
        first: u64,
        count: usize,
    ) -> Result<Dispatch, GpuError> {
        let too_big = |v: u64| u32::try_from(v).is_err();
        if too_big(first + count as u64) || too_big(grid.size[0] as u64) {
            return Err(GpuError::Unsupported(
                "a grid of more than 2^32 rows of segments".into(),
            ));
        }
        Ok(Dispatch {
            first_segment: first as u32,
            segments: count as u32,
            segment_len: layout.segment_len as u32,
            per_row: layout.per_row as u32,
            nx: grid.size[0] as u32,
            ny: grid.size[1] as u32,
            count: 0,
            spacing: 0,
        })
    }

    /// The block's bytes: the fields, then `one` (1.0 as f32 bits, see `entry.wgsl`) and
    /// padding to a multiple of 16 bytes.
    fn bytes(&self) -> Vec<u8> {
        [
            self.first_segment,
            self.segments,
            self.segment_len,
            self.per_row,
            self.nx,
            self.ny,
            self.count,
            self.spacing,
            1.0f32.to_bits(),
            0,
            0,
            0,
        ]
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .collect()
    }
}

/// A tape compiled for the GPU: its pipelines (`bake` and `points` entry points) and its noise
/// tables uploaded once. `Send + Sync`; calls are serialised on the device's queue.
pub struct GpuEvaluator {
    context: Arc<Context>,
    layout: wgpu::BindGroupLayout,
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    /// The `bake` and `points` pipelines, each made on its first use: a driver compiles each
    /// entry point with the whole tape inlined (lavapipe takes seconds for a large filtered
    /// tape), and most evaluators use one of the two.
    bake: OnceLock<wgpu::ComputePipeline>,
    points: OnceLock<wgpu::ComputePipeline>,
    tables: wgpu::Buffer,
    /// The filtered form's data (`Shader::data`, binding 4); `None` for the point form.
    data: Option<wgpu::Buffer>,
    channels: usize,
    /// One evaluation at a time per evaluator, holding the results and read-back buffers of
    /// the last call for the next one. Made per call, a buffer of a window's size (up to the
    /// binding limit, 2 GiB and more on a discrete GPU) was cleared each time by wgpu's
    /// zero-initialisation: on an H200 that, not the kernel, took most of a 512³ marble
    /// (docs/performance.md).
    buffers: Mutex<Buffers>,
}

/// Buffers kept between calls; each grows to the largest call's size and is bound or copied
/// only over the bytes a call uses.
#[derive(Default)]
struct Buffers {
    results: Option<wgpu::Buffer>,
    readback: Option<wgpu::Buffer>,
}

impl Buffers {
    /// `slot`'s buffer when it holds `size` bytes, else a new one of `size` bytes in its place.
    fn take<'a>(
        slot: &'a mut Option<wgpu::Buffer>,
        device: &wgpu::Device,
        label: &'static str,
        size: u64,
        usage: wgpu::BufferUsages,
    ) -> &'a wgpu::Buffer {
        if slot.as_ref().is_none_or(|b| b.size() < size) {
            *slot = None;
            *slot = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            }));
        }
        slot.as_ref().expect("made above")
    }
}

impl std::fmt::Debug for GpuEvaluator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuEvaluator")
            .field("adapter", &self.context.info.name)
            .field("channels", &self.channels)
            .finish_non_exhaustive()
    }
}

impl GpuEvaluator {
    /// Generates and compiles `tape`'s shader on the process's GPU device. Fails when no
    /// adapter is usable or the shader does not compile (never panics).
    pub fn new(tape: &Tape) -> Result<GpuEvaluator, GpuError> {
        GpuEvaluator::build(tape, codegen::generate(tape)?)
    }

    /// The filtered form's evaluator (`filtered.rs`): `bake_window` gives each voxel the
    /// estimate of its cell's mean, [`GpuEvaluator::eval_batch_filtered`] each point its
    /// footprint's. Refused for a tape the filtered form does not cover.
    pub fn new_filtered(tape: &Tape) -> Result<GpuEvaluator, GpuError> {
        GpuEvaluator::build(tape, super::filtered::generate(tape)?)
    }

    fn build(tape: &Tape, shader: codegen::Shader) -> Result<GpuEvaluator, GpuError> {
        let context = context()?;
        let naga_module = codegen::module(&shader.source).map_err(GpuError::Shader)?;
        let device = &context.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("texgraph tape"),
            source: wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(naga_module)),
        });
        let entry = layout_entry;
        let read = wgpu::BufferBindingType::Storage { read_only: true };
        let mut entries = vec![
            entry(0, read),
            entry(1, read),
            entry(2, wgpu::BufferBindingType::Uniform),
            entry(3, wgpu::BufferBindingType::Storage { read_only: false }),
        ];
        if !shader.data.is_empty() {
            entries.push(entry(4, read));
        }
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("texgraph"),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("texgraph"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let mut words: Vec<u32> = Vec::with_capacity(tape.tables.len().max(1) * TABLE_WORDS);
        for (_, table) in &tape.tables {
            words.extend(table.gpu_words());
        }
        words.resize(words.len().max(TABLE_WORDS), 0);
        let tables = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("noise tables"),
            contents: &words
                .iter()
                .flat_map(|w| w.to_le_bytes())
                .collect::<Vec<u8>>(),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let data = (!shader.data.is_empty()).then(|| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("filtered data"),
                contents: &(shader.data.iter())
                    .flat_map(|v| v.to_le_bytes())
                    .collect::<Vec<u8>>(),
                usage: wgpu::BufferUsages::STORAGE,
            })
        });
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader(error.to_string()));
        }
        Ok(GpuEvaluator {
            context,
            layout,
            module,
            pipeline_layout,
            bake: OnceLock::new(),
            points: OnceLock::new(),
            tables,
            data,
            channels: shader.channels,
            buffers: Mutex::new(Buffers::default()),
        })
    }

    /// The pipeline of entry point `bake` or `points`, made on its first use (a validation
    /// error is returned, not left to wgpu's uncaptured-error handler).
    fn pipeline(&self, bake: bool) -> Result<&wgpu::ComputePipeline, GpuError> {
        let (cell, name) = if bake {
            (&self.bake, "bake")
        } else {
            (&self.points, "points")
        };
        if let Some(made) = cell.get() {
            return Ok(made);
        }
        let device = &self.context.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let made = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: Some(&self.pipeline_layout),
            module: &self.module,
            entry_point: Some(name),
            compilation_options: Default::default(),
            cache: None,
        });
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader(error.to_string()));
        }
        Ok(cell.get_or_init(|| made))
    }

    /// The device and queue this evaluator runs on, and the largest storage binding.
    pub(super) fn device(&self) -> (&wgpu::Device, &wgpu::Queue, u64, u32) {
        let c = &self.context;
        (&c.device, &c.queue, c.max_binding, c.max_groups)
    }

    /// The bake window's inputs (the grid's region and size) as a storage buffer.
    pub(super) fn grid_inputs(&self, grid: &crate::grid::Grid) -> wgpu::Buffer {
        let bytes: Vec<u8> = grid_values(grid)
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        self.context
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("inputs"),
                contents: &bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
    }

    /// Records the `bake` entry point over `count` segments from `first` of `grid` (laid out
    /// by `layout`) into `encoder`, its results into `results` (segment-planar, as
    /// [`GpuEvaluator::bake_window`]). `inputs`: [`GpuEvaluator::grid_inputs`].
    pub(super) fn record_bake(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        (inputs, results): (&wgpu::Buffer, &wgpu::Buffer),
        (grid, layout): (&crate::grid::Grid, &crate::grid::Layout),
        first: u64,
        count: usize,
    ) -> Result<(), GpuError> {
        let dispatch = Dispatch::bake(grid, layout, first, count)?;
        let size = (count * self.channels * layout.segment_len * 4) as u64;
        let threads = (count * layout.segment_len) as u64;
        let pipeline = self.pipeline(true)?;
        self.record(
            encoder,
            pipeline,
            (inputs, results, size),
            dispatch,
            threads,
        );
        Ok(())
    }

    /// Records one dispatch of `threads` threads of `pipeline` into `encoder`, with the noise
    /// tables, `inputs`, `dispatch` as the uniform block and the first `size` bytes of
    /// `results` bound.
    fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pipeline: &wgpu::ComputePipeline,
        (inputs, results, size): (&wgpu::Buffer, &wgpu::Buffer, u64),
        dispatch: Dispatch,
        threads: u64,
    ) {
        let device = &self.context.device;
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("dispatch"),
            contents: &dispatch.bytes(),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let mut entries = vec![
            binding(0, &self.tables),
            binding(1, inputs),
            binding(2, &uniform),
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: results,
                    offset: 0,
                    size: std::num::NonZeroU64::new(size),
                }),
            },
        ];
        if let Some(data) = &self.data {
            entries.push(binding(4, data));
        }
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("texgraph"),
            layout: &self.layout,
            entries: &entries,
        });
        let (gx, gy) = groups(threads, self.context.max_groups);
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(gx, gy, 1);
    }

    /// The adapter it runs on (`NVIDIA H100 80GB HBM3`, `llvmpipe (LLVM 15.0.7, 256 bits)`).
    pub fn adapter(&self) -> String {
        self.context.info.name.trim().to_string()
    }

    /// Whether the adapter is a software driver (lavapipe): the "device" runs on the host's
    /// own cores.
    pub fn is_software(&self) -> bool {
        self.context.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Output channels per point (as `Tape::channels`).
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// The tape at the points (`x[i]`, `y[i]`, `z[i]`): channel `c` of point `i` into
    /// `out[c * n + i]`, as [`Tape::eval_batch`] lays it out. Panics if the slices' lengths
    /// differ (a caller bug).
    pub fn eval_batch(
        &self,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [f32],
    ) -> Result<(), GpuError> {
        self.eval_points([x, y, z], None, out)
    }

    /// [`GpuEvaluator::eval_batch`] with level of detail per point, as
    /// [`Tape::eval_batch_lod`]: each fractal keeps the octaves point `i`'s sample spacing
    /// `spacing[i]` resolves.
    pub fn eval_batch_lod(
        &self,
        points: [&[f64]; 3],
        spacing: &[f64],
        out: &mut [f32],
    ) -> Result<(), GpuError> {
        assert_eq!(spacing.len(), points[0].len());
        self.eval_points(points, Some(Extra::Spacing(spacing)), out)
    }

    /// A filtered evaluator's ([`GpuEvaluator::new_filtered`]) estimates at the points, each
    /// over its footprint (`footprints` as long as the points, or one for all), laid out as
    /// [`GpuEvaluator::eval_batch`]. Panics if the slices' lengths disagree (a caller bug).
    pub fn eval_batch_filtered(
        &self,
        points: [&[f64]; 3],
        footprints: &[crate::filter::Footprint],
        out: &mut [f32],
    ) -> Result<(), GpuError> {
        let n = points[0].len();
        assert!(footprints.len() == n || footprints.len() == 1);
        let edges: Vec<f64> = footprints
            .iter()
            .flat_map(|f| f.edges().into_iter().flatten())
            .collect();
        self.eval_points(points, Some(Extra::Footprints(&edges)), out)
    }

    fn eval_points(
        &self,
        [x, y, z]: [&[f64]; 3],
        extra: Option<Extra>,
        out: &mut [f32],
    ) -> Result<(), GpuError> {
        let n = x.len();
        assert!(y.len() == n && z.len() == n && out.len() == n * self.channels);
        if n == 0 || self.channels == 0 {
            return Ok(());
        }
        // Points per dispatch: the inputs (96 bytes each at most) and results fit one binding
        // each.
        let per = (self.context.max_binding / (96 + 4 * self.channels as u64)).clamp(1, 1 << 22);
        let mut part = vec![0f32; (per as usize).min(n) * self.channels];
        let mut start = 0;
        while start < n {
            let m = (n - start).min(per as usize);
            let mut inputs = Vec::with_capacity(12 * m);
            for plane in [x, y, z] {
                inputs.extend_from_slice(&plane[start..start + m]);
            }
            // `spacing`: 1 where the fourth plane (or the per-point footprints) follow.
            let spacing = match extra {
                None => 0,
                Some(Extra::Spacing(h)) => {
                    inputs.extend_from_slice(&h[start..start + m]);
                    1
                }
                Some(Extra::Footprints(e)) if e.len() == 9 => {
                    inputs.extend_from_slice(e);
                    0
                }
                Some(Extra::Footprints(e)) => {
                    inputs.extend_from_slice(&e[9 * start..9 * (start + m)]);
                    1
                }
            };
            let dispatch = Dispatch {
                count: m as u32,
                spacing,
                ..Dispatch::default()
            };
            let part = &mut part[..m * self.channels];
            self.run(
                self.pipeline(false)?,
                &inputs,
                dispatch,
                m as u64,
                part,
                true,
            )?;
            for c in 0..self.channels {
                out[c * n + start..c * n + start + m].copy_from_slice(&part[c * m..(c + 1) * m]);
            }
            start += m;
        }
        Ok(())
    }

    /// The bake window of `segments` segments from `first` (layout `bake::Window`): the
    /// voxel centres of `grid` made on the GPU, the results read back into `data`
    /// (`segments × channels × layout.segment_len` values).
    pub fn bake_window(
        &self,
        grid: &crate::grid::Grid,
        layout: &crate::grid::Layout,
        first: u64,
        data: &mut [f32],
    ) -> Result<(), GpuError> {
        self.window(grid, layout, first, data, true)
    }

    /// [`GpuEvaluator::bake_window`], reading the results back only with `read_back`.
    fn window(
        &self,
        grid: &crate::grid::Grid,
        layout: &crate::grid::Layout,
        first: u64,
        data: &mut [f32],
        read_back: bool,
    ) -> Result<(), GpuError> {
        let block = self.channels * layout.segment_len;
        let segments = data.len() / block.max(1);
        Dispatch::bake(grid, layout, first, segments)?;
        // Segments per dispatch: the results fit one binding.
        let per = (self.context.max_binding / (4 * block as u64)).max(1) as usize;
        let inputs = grid_values(grid);
        for (k, chunk) in data.chunks_mut(per * block).enumerate() {
            let count = chunk.len() / block;
            let dispatch = Dispatch::bake(grid, layout, first + (k * per) as u64, count)?;
            let threads = (count * layout.segment_len) as u64;
            self.run(
                self.pipeline(true)?,
                &inputs,
                dispatch,
                threads,
                chunk,
                read_back,
            )?;
        }
        Ok(())
    }

    /// The whole grid evaluated on the GPU in windows of `window` segments (the bake's layout
    /// for `threads` threads), each read back into one reused buffer, or with `keep` left on
    /// the GPU (the results buffer is written and nothing is copied back: the kernel's own
    /// speed, benches `gpu/marble_512`).
    pub fn eval_grid(&self, grid: &crate::grid::Grid, keep: bool) -> Result<(), GpuError> {
        let Some(layout) = crate::grid::Layout::new(grid, self.channels.max(1), 1) else {
            return Ok(());
        };
        let block = self.channels * layout.segment_len;
        let per = (self.context.max_binding / (4 * block as u64)).max(1);
        let mut buffer = vec![0f32; (per.min(layout.total) as usize) * block];
        let mut first = 0u64;
        while first < layout.total {
            let count = (layout.total - first).min(per) as usize;
            let data = &mut buffer[..count * block];
            self.window(grid, &layout, first, data, !keep)?;
            first += count as u64;
        }
        Ok(())
    }

    /// One dispatch of `threads` threads of `pipeline` over `inputs`, its results read back
    /// into `out` (whose length is the results buffer's) with `read_back`, else only waited for.
    fn run(
        &self,
        pipeline: &wgpu::ComputePipeline,
        inputs: &[f64],
        dispatch: Dispatch,
        threads: u64,
        out: &mut [f32],
        read_back: bool,
    ) -> Result<(), GpuError> {
        let mut buffers = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        let device = &self.context.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let bytes = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let inputs = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("inputs"),
            contents: &bytes(inputs),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let size = (out.len() * 4) as u64;
        let Buffers { results, readback } = &mut *buffers;
        let results = Buffers::take(
            results,
            device,
            "results",
            size,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let mut encoder = device.create_command_encoder(&Default::default());
        self.record(
            &mut encoder,
            pipeline,
            (&inputs, results, size),
            dispatch,
            threads,
        );
        let readback = read_back.then(|| {
            Buffers::take(
                readback,
                device,
                "read-back",
                size,
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            )
        });
        if let Some(readback) = readback {
            encoder.copy_buffer_to_buffer(results, 0, readback, 0, size);
        }
        self.context.queue.submit([encoder.finish()]);
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Device(error.to_string()));
        }
        let Some(readback) = readback else {
            return device
                .poll(wgpu::PollType::wait_indefinitely())
                .map(|_| ())
                .map_err(|e| GpuError::Device(e.to_string()));
        };
        copy_back(device, readback, size, out)
    }
}

/// A bake's inputs (`centre` in `bindings.wgsl`): the grid's corner, extent and size.
fn grid_values(grid: &crate::grid::Grid) -> Vec<f64> {
    let mut values = Vec::with_capacity(9);
    values.extend_from_slice(&grid.region.min);
    values.extend((0..3).map(|a| grid.region.max[a] - grid.region.min[a]));
    values.extend(grid.size.iter().map(|&n| n as f64));
    values
}

/// Workgroups of [`GROUP`] threads for `threads` threads, as (x, y) within `max` per
/// dimension (`thread_index` in `bindings.wgsl` numbers them back).
pub(super) fn groups(threads: u64, max: u32) -> (u32, u32) {
    let groups = threads.div_ceil(GROUP);
    let max = u64::from(max);
    (groups.min(max) as u32, groups.div_ceil(max) as u32)
}

/// What follows a points dispatch's x, y and z planes.
#[derive(Clone, Copy)]
enum Extra<'a> {
    /// Each point's sample spacing (level of detail).
    Spacing(&'a [f64]),
    /// The footprints' edges, nine values each: one footprint, or one per point.
    Footprints(&'a [f64]),
}

/// A compute shader's buffer binding `binding` of type `ty`, in a bind group layout.
pub(super) fn layout_entry(
    binding: u32,
    ty: wgpu::BufferBindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(super) fn binding(index: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding: index,
        resource: buffer.as_entire_binding(),
    }
}

/// Bytes [`copy_back`] copies out of a mapped range at a time.
const STAGING_BYTES: usize = 1 << 16;

/// Maps `buffer` (after the queue's work) and copies it into `out`.
fn copy_back(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
    size: u64,
    out: &mut [f32],
) -> Result<(), GpuError> {
    let slice = buffer.slice(..size);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GpuError::Device(e.to_string()))?;
    rx.recv()
        .map_err(|e| GpuError::Device(e.to_string()))?
        .map_err(|e| GpuError::Device(e.to_string()))?;
    {
        let view = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Device(e.to_string()))?;
        // Sequential copies out of the mapped range, 64 KiB at a time, into a buffer that
        // stays in cache: on a card the range may be host-visible memory that is not cached,
        // where reading four bytes at a time crawls. (A copy of the whole range first, as
        // before, allocated and faulted in as many bytes again: 2 GiB for a 512³ marble,
        // whose float read-back took 2.9 s on an H200 against a 13 ms kernel.)
        let mut staging = vec![0u8; STAGING_BYTES];
        for (o, b) in out
            .chunks_mut(STAGING_BYTES / 4)
            .zip(view.chunks(STAGING_BYTES))
        {
            let staging = &mut staging[..b.len()];
            staging.copy_from_slice(b);
            for (o, b) in o.iter_mut().zip(staging.chunks_exact(4)) {
                *o = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
        }
    }
    buffer.unmap();
    Ok(())
}
