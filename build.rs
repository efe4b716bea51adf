//! Debug and test builds compile the SIMD kernels' clone for the best instruction set of the
//! machine that builds them, not every clone (`simd_clones!`, the crate root): the
//! clones were 55 % of the crate's machine code in the test binary, and a test run executes one
//! of them. This script tells the crate whether that machine has AVX-512 VBMI
//! (`cfg(texgraph_host_vbmi)`), the one clone the tests must then compile instead of AVX2's.
//! Release builds compile every clone whatever this says.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(texgraph_host_vbmi)");
    println!("cargo::rustc-check-cfg=cfg(texgraph_simd_all)");
    println!("cargo::rerun-if-changed=build.rs");
    // Only when the build runs where it builds for (no cross-compiling): the host's CPU.
    let native = std::env::var("TARGET").ok() == std::env::var("HOST").ok();
    if native && host_has_vbmi() {
        println!("cargo::rustc-cfg=texgraph_host_vbmi");
    }
}

#[cfg(target_arch = "x86_64")]
fn host_has_vbmi() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx512vbmi")
}

#[cfg(not(target_arch = "x86_64"))]
fn host_has_vbmi() -> bool {
    false
}
