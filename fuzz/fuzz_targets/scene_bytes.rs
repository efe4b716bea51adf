//! Any bytes as a render input: a scene or a previewed graph (see src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| texgraph_fuzz::scene_bytes(data));
