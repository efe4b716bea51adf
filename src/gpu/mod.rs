//! The GPU path (issue 19): the graphics adapters texgraph can run on, found through `wgpu`
//! (Vulkan, Metal, DX12). `texgraph devices` lists them. Built without the `gpu` cargo feature,
//! or on a machine without a driver, the list is empty — a software Vulkan driver such as
//! Mesa's lavapipe (Debian `mesa-vulkan-drivers`) counts as an adapter of kind "CPU".
//!
//! A tape runs on the GPU as WGSL generated from it (`codegen.rs`, over the library in
//! `wgsl/`), compiled once per tape by [`GpuEvaluator::new`]; `eval_batch` evaluates position
//! buffers, `bake_window` a bake's windows with the positions made on the GPU.

#[cfg(feature = "gpu")]
mod bake;
pub mod codegen;
mod window_stats;
pub use window_stats::WindowStats;
mod error;
#[cfg(feature = "gpu")]
mod evaluator;
pub mod filtered;
mod filtered_periodic;
#[cfg(feature = "gpu")]
pub use bake::GpuBake;
#[cfg(feature = "gpu")]
pub use evaluator::GpuEvaluator;
#[cfg(not(feature = "gpu"))]
mod stub;
#[cfg(not(feature = "gpu"))]
pub use stub::GpuBake;
#[cfg(any(feature = "gpu", feature = "shader"))]
pub(crate) mod ir;
#[cfg(any(feature = "gpu", feature = "shader"))]
pub(crate) mod widen;
/// Without naga nothing parses WGSL, so no shader is ever made: no twins to declare.
#[cfg(not(any(feature = "gpu", feature = "shader")))]
pub(crate) mod widen {
    pub(crate) fn declarations() -> &'static str {
        ""
    }
}
#[cfg(not(feature = "gpu"))]
pub use stub::GpuEvaluator;

#[cfg(feature = "gpu")]
pub use codegen::validate;
pub use error::GpuError;

/// The GPU evaluator of `tape`, compiled once per tape fingerprint in this process (a bake of
/// many windows, mip levels and repeated bakes of one graph share it).
pub fn evaluator_for(tape: &crate::tape::Tape) -> Result<std::sync::Arc<GpuEvaluator>, GpuError> {
    cached(tape, false)
}

/// The filtered form's GPU evaluator of `tape` (`filtered.rs`; each voxel or point the
/// estimate of its footprint's mean), compiled once per tape fingerprint in this process.
/// Refused, with the instruction it cannot run, for a tape the filtered form does not cover.
pub fn filtered_evaluator_for(
    tape: &crate::tape::Tape,
) -> Result<std::sync::Arc<GpuEvaluator>, GpuError> {
    cached(tape, true)
}

/// One cache for both forms, keyed by the tape's fingerprint and the form.
fn cached(
    tape: &crate::tape::Tape,
    filtered: bool,
) -> Result<std::sync::Arc<GpuEvaluator>, GpuError> {
    use std::collections::HashMap;
    use std::sync::{Arc, Mutex, OnceLock};
    type Cache = Mutex<HashMap<(u64, bool), Arc<GpuEvaluator>>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    let key = (tape.fingerprint(), filtered);
    if let Some(found) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return Ok(found.clone());
    }
    let made = Arc::new(if filtered {
        GpuEvaluator::new_filtered(tape)?
    } else {
        GpuEvaluator::new(tape)?
    });
    let mut cache = cache.lock().unwrap_or_else(|e| e.into_inner());
    // A few tapes at most live in one process; keep the cache from growing without bound
    // (`serve` recompiles on every edit).
    if cache.len() >= 32 {
        cache.clear();
    }
    cache.insert(key, made.clone());
    Ok(made)
}

/// The adapter the GPU path runs on (its name), or why there is none usable.
pub fn usable() -> Result<String, GpuError> {
    #[cfg(feature = "gpu")]
    {
        evaluator::context().map(|c| c.info.name.trim().to_string())
    }
    #[cfg(not(feature = "gpu"))]
    {
        GpuEvaluator::new_unavailable()
    }
}

/// Where an evaluation runs (`--device`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Device {
    /// The CPU (the default).
    #[default]
    Cpu,
    /// The GPU; an error when none is usable.
    Gpu,
    /// The GPU when one is usable, else the CPU (which one is said on stderr). The commands
    /// resolve it to `Cpu` or `Gpu` before evaluating, but for box-filtered bakes, where it
    /// reaches the bake engine as `Auto`: each graph on the GPU's filtered form where that
    /// covers it (`filtered::unsupported`), else on the CPU.
    Auto,
}

/// One adapter as `texgraph devices` prints it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Adapter {
    /// The device's name (`NVIDIA H100 80GB HBM3`, `llvmpipe (LLVM 15.0.7, 256 bits)`).
    pub name: String,
    /// The graphics API wgpu reaches it through (`Vulkan`, `Metal`, `Dx12`).
    pub backend: String,
    /// Discrete GPU, integrated GPU, virtual GPU, CPU (a software driver) or other.
    pub kind: String,
    /// The driver's name and version, where the driver reports them.
    pub driver: String,
}

impl std::fmt::Display for Adapter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}, {}", self.name, self.backend, self.kind)?;
        if !self.driver.is_empty() {
            write!(f, ", driver {}", self.driver)?;
        }
        write!(f, ")")
    }
}

/// Whether this build has the GPU path (the `gpu` cargo feature, on by default).
pub const BUILT_WITH_GPU: bool = cfg!(feature = "gpu");

/// The adapters found, in wgpu's order (the `WGPU_BACKEND` environment variable narrows the
/// APIs asked, as in every wgpu program). Empty without the `gpu` feature or a driver; never
/// fails.
pub fn adapters() -> Vec<Adapter> {
    #[cfg(feature = "gpu")]
    {
        evaluator::enumerate_adapters()
            .iter()
            .map(|adapter| describe(&adapter.get_info()))
            .collect()
    }
    #[cfg(not(feature = "gpu"))]
    {
        Vec::new()
    }
}

#[cfg(feature = "gpu")]
fn describe(info: &wgpu::AdapterInfo) -> Adapter {
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => "discrete GPU",
        wgpu::DeviceType::IntegratedGpu => "integrated GPU",
        wgpu::DeviceType::VirtualGpu => "virtual GPU",
        wgpu::DeviceType::Cpu => "CPU (software driver)",
        wgpu::DeviceType::Other => "other",
    };
    let driver = [info.driver.trim(), info.driver_info.trim()]
        .iter()
        .filter(|s| !s.is_empty())
        .copied()
        .collect::<Vec<_>>()
        .join(" ");
    Adapter {
        name: info.name.trim().to_string(),
        backend: format!("{:?}", info.backend),
        kind: kind.to_string(),
        driver,
    }
}
