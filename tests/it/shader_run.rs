//! Runs exported shader functions on a Vulkan adapter (lavapipe in CI) through wgpu: a compute
//! shader around the exported source evaluates every function at a batch of points (and the
//! `_lod` form at the points' spacings), written channel-planar as `Tape::eval_batch` writes.
//! WGSL goes in as WGSL; GLSL 4.50 is compiled by glslang to SPIR-V first.

use std::sync::OnceLock;
use texgraph::shader::ExportedFunction;

pub struct Runner {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pub name: String,
}

/// The adapter (any: the exported shaders need no f64), or why there is none.
pub fn runner() -> Result<&'static Runner, String> {
    static RUNNER: OnceLock<Result<Runner, String>> = OnceLock::new();
    RUNNER.get_or_init(open).as_ref().map_err(Clone::clone)
}

fn open() -> Result<Runner, String> {
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
    descriptor.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
    let instance = wgpu::Instance::new(descriptor.with_env());
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
    .map_err(|e| format!("no graphics adapter: {e}"))?;
    let name = adapter.get_info().name;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("texgraph shader tests"),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| format!("{name}: {e}"))?;
    Ok(Runner {
        device,
        queue,
        name,
    })
}

/// A shader source and how it reaches the device.
pub enum Source {
    /// The exported WGSL with the test's entry point appended.
    Wgsl(String),
    /// SPIR-V words (GLSL compiled by glslang).
    SpirV(Vec<u32>),
}

/// Which form of the exported functions an entry point calls, and what each point's input is.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Call {
    /// `texgraph_NAME(p)`: x, y, z and an unread fourth float per point.
    Point,
    /// `texgraph_NAME_lod(p, spacing)`: x, y, z, spacing per point.
    Lod,
    /// `texgraph_NAME_filtered(p, footprint)`: x, y, z, then the footprint's three edges
    /// (nine floats) per point.
    Filtered,
}

impl Call {
    /// Floats per point in the input buffer.
    pub fn stride(self) -> usize {
        match self {
            Call::Point | Call::Lod => 4,
            Call::Filtered => 12,
        }
    }

    /// The call of `f`'s form (`p`, `h` and `f` are the entry points' locals).
    fn of(self, f: &ExportedFunction) -> String {
        match self {
            Call::Point => format!("{}(p)", f.name),
            Call::Lod => format!("{}(p, h)", f.lod),
            Call::Filtered => format!(
                "{}(p, fp)",
                f.filtered
                    .as_ref()
                    .expect("a function with a filtered form")
            ),
        }
    }
}

/// The WGSL compute entry point `main` over exported functions: input per point at binding 1
/// ([`Call::stride`] floats each), output at binding 2, channel-planar.
pub fn wgsl_entry(functions: &[ExportedFunction], n: usize, call: Call) -> String {
    let body = stores(functions, call, "let", "u");
    let s = call.stride();
    format!(
        "\n@group(0) @binding(1) var<storage, read> tg_test_in: array<f32>;\n\
         @group(0) @binding(2) var<storage, read_write> tg_test_out: array<f32>;\n\
         const N: u32 = {n}u;\n\
         fn tg_test_v(at: u32) -> vec3<f32> {{\n    \
         return vec3<f32>(tg_test_in[at], tg_test_in[at + 1u], tg_test_in[at + 2u]);\n}}\n\
         @compute @workgroup_size(64)\n\
         fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
         \x20   let i = id.x;\n    if (i >= N) {{ return; }}\n\
         \x20   let p = tg_test_v({s}u * i);\n\
         \x20   let h = tg_test_in[{s}u * i + 3u];\n    _ = h;\n\
         \x20   let fp = mat3x3<f32>(tg_test_v({s}u * i + 3u), tg_test_v({s}u * i + 6u), tg_test_v({s}u * i + 9u));\n    _ = fp;\n\
         {body}}}\n"
    )
}

/// The GLSL 4.50 compute shader around exported GLSL (the same bindings as [`wgsl_entry`]).
pub fn glsl_entry(exported: &str, functions: &[ExportedFunction], n: usize, call: Call) -> String {
    let body = stores(functions, call, "vec3", "");
    let s = call.stride();
    format!(
        "#version 450\n{exported}\n\
         layout(local_size_x = 64) in;\n\
         layout(std430, set = 0, binding = 1) readonly buffer TgIn {{ float tg_test_in[]; }};\n\
         layout(std430, set = 0, binding = 2) buffer TgOut {{ float tg_test_out[]; }};\n\
         const uint N = {n}u;\n\
         vec3 tg_test_v(uint at) {{ return vec3(tg_test_in[at], tg_test_in[at + 1u], tg_test_in[at + 2u]); }}\n\
         void main() {{\n    uint i = gl_GlobalInvocationID.x;\n    if (i >= N) {{ return; }}\n\
         \x20   vec3 p = tg_test_v({s}u * i);\n\
         \x20   float h = tg_test_in[{s}u * i + 3u];\n\
         \x20   mat3 fp = mat3(tg_test_v({s}u * i + 3u), tg_test_v({s}u * i + 6u), tg_test_v({s}u * i + 9u));\n\
         {body}}}\n"
    )
}

/// The entry points' statements: each function's `call` form at the point, its channels
/// stored channel-planar; `vec3` declares a vector local (`let` in WGSL, `vec3` in GLSL),
/// `unsigned` is the unsigned literal suffix (`u` in WGSL).
fn stores(functions: &[ExportedFunction], call: Call, vec3: &str, unsigned: &str) -> String {
    assignments(functions, call, vec3, |c| {
        format!("tg_test_out[{c}{unsigned} * N + i]")
    })
}

/// Statements that assign channel `c` of the functions' `call` forms, in output order, to
/// `target(c)`; `vec3` declares a vector local (`let` in WGSL, `vec3` in GLSL).
pub fn assignments(
    functions: &[ExportedFunction],
    call: Call,
    vec3: &str,
    target: impl Fn(usize) -> String,
) -> String {
    let mut body = String::new();
    let mut c = 0;
    for f in functions {
        let call = call.of(f);
        if f.channels == 1 {
            body.push_str(&format!("    {} = {call};\n", target(c)));
        } else {
            body.push_str(&format!("    {vec3} v{c} = {call};\n"));
            for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                body.push_str(&format!("    {} = v{c}.{axis};\n", target(c + k)));
            }
        }
        c += f.channels;
    }
    body
}

impl Runner {
    /// Runs `source`'s `main` over the points of `input` (`call.stride()` floats each),
    /// `channels` outputs each; `uniforms`: the `TexgraphParams` block at binding 0.
    pub fn run(
        &self,
        source: Source,
        (input, call): (&[f32], Call),
        channels: usize,
        uniforms: Option<&[f32]>,
    ) -> Result<Vec<f32>, String> {
        use wgpu::util::DeviceExt;
        let n = input.len() / call.stride();
        let device = &self.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("exported"),
            source: match source {
                Source::Wgsl(text) => wgpu::ShaderSource::Wgsl(text.into()),
                Source::SpirV(words) => wgpu::ShaderSource::SpirV(words.into()),
            },
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("exported"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let bytes = |v: &[f32]| v.iter().flat_map(|f| f.to_le_bytes()).collect::<Vec<u8>>();
        let inputs = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: &bytes(input),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let size = (channels.max(1) * n * 4) as u64;
        let outputs = device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut block = uniforms.map(|u| u.to_vec()).unwrap_or_default();
        block.resize(block.len().div_ceil(4).max(1) * 4, 0.0);
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: &bytes(&block),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let layout = pipeline.get_bind_group_layout(0);
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 1,
                resource: inputs.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: outputs.as_entire_binding(),
            },
        ];
        if uniforms.is_some() {
            entries.push(wgpu::BindGroupEntry {
                binding: 0,
                resource: params.as_entire_binding(),
            });
        }
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout,
            entries: &entries,
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(n.div_ceil(64) as u32, 1, 1);
        }
        encoder.copy_buffer_to_buffer(&outputs, 0, &readback, 0, size);
        self.queue.submit([encoder.finish()]);
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(error.to_string());
        }
        let slice = readback.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| e.to_string())?;
        let data = slice.get_mapped_range().map_err(|e| e.to_string())?;
        Ok(data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }
}
