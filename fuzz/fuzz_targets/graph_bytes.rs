//! Arbitrary bytes through parse → check → compile → evaluate (see src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| texgraph_fuzz::graph_bytes(data));
