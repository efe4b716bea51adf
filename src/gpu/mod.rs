//! The GPU path (issue 19): the graphics adapters texgraph can run on, found through `wgpu`
//! (Vulkan, Metal, DX12). `texgraph devices` lists them. Built without the `gpu` cargo feature,
//! or on a machine without a driver, the list is empty — a software Vulkan driver such as
//! Mesa's lavapipe (Debian `mesa-vulkan-drivers`) counts as an adapter of kind "CPU".

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
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
        descriptor.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
        let descriptor = descriptor.with_env();
        let backends = descriptor.backends;
        let instance = wgpu::Instance::new(descriptor);
        pollster::block_on(instance.enumerate_adapters(backends))
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
