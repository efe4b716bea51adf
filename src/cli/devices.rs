//! `texgraph devices`: the graphics adapters the GPU path can use.

use super::*;
use clap::Args;

#[derive(Args)]
pub struct DevicesArgs {}

/// Prints one line per adapter (`INDEX: NAME (API, KIND, driver DRIVER)`), or why there is
/// none. Exit code 0 either way: finding no adapter is an answer, not a failure.
pub fn devices(_args: DevicesArgs) -> Result<(), Failure> {
    let adapters = crate::gpu::adapters();
    let mut text = String::new();
    for (i, adapter) in adapters.iter().enumerate() {
        text.push_str(&format!("{i}: {adapter}\n"));
    }
    if adapters.is_empty() {
        text.push_str(if crate::gpu::BUILT_WITH_GPU {
            "no GPU adapter found: no Vulkan, Metal or DX12 driver answered (on Linux without a GPU, Mesa's software driver lavapipe provides one: apt-get install mesa-vulkan-drivers)\n"
        } else {
            "no GPU adapter: this texgraph was built without the `gpu` cargo feature\n"
        });
    }
    write_stdout(|out| out.write_all(text.as_bytes()))
}
