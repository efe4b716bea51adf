//! Structured random graphs, valid by construction, and their invariants (see src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| texgraph_fuzz::structured_graph(data));
