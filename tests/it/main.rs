//! texgraph's integration tests: one test binary (as rust-analyzer and cargo keep theirs), so
//! the test build links the library once, with a module per area. `cargo test` runs them all;
//! `cargo test --test it golden::` one area (`TEXGRAPH_BLESS=1` re-blesses goldens).

mod common;
// The fuzz harness (`fuzz/src/lib.rs`, its own crate for cargo-fuzz), compiled here by path so
// `fuzz_corpus` replays the corpus through it on stable Rust.
#[allow(dead_code)]
#[path = "../../fuzz/src/lib.rs"]
mod harness;

mod accuracy;
mod architecture;
mod bake;
mod bake_ktx2;
mod bake_mips;
mod bake_vdb_reader;
mod bake_zarr;
mod cli;
mod conformance;
mod docs;
mod errors;
mod far_points;
mod filter;
mod fuzz_corpus;
mod gltf_clients;
mod golden;
#[cfg(feature = "gpu")]
mod gpu;
#[cfg(feature = "gpu")]
mod gpu_filtered;
mod gradient;
mod imports;
mod lod_lanes;
mod mesh;
mod precision;
mod properties;
mod random_graphs;
mod render;
mod safety;
mod serve;
mod serve_browser;
#[cfg(all(feature = "gpu", feature = "shader"))]
mod shader;
#[cfg(all(feature = "gpu", feature = "shader"))]
mod shader_run;
#[cfg(all(feature = "gpu", feature = "shader"))]
mod shader_webgl;
