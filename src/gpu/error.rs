//! Why the GPU path cannot run.

/// Why the GPU path cannot run (the caller falls back to the CPU or reports it).
#[derive(Clone, Debug, thiserror::Error)]
pub enum GpuError {
    /// No usable adapter (or a build without the `gpu` feature).
    #[error("no usable GPU: {0}")]
    NoAdapter(String),
    /// The generated shader did not validate or compile (a texgraph bug: please report it).
    #[error("the GPU shader does not compile: {0}")]
    Shader(String),
    /// Something the GPU path does not run.
    #[error("the GPU path does not run {0}")]
    Unsupported(String),
    /// The device failed during an evaluation.
    #[error("GPU error: {0}")]
    Device(String),
}
