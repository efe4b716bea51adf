//! texgraph: procedural solid textures from RON node graphs.
//!
//! The pipeline, one module per stage (ARCHITECTURE.md has the map):
//! parse (`syntax`) → check ([`check()`], producing a [`graph::CheckedGraph`]) → compile
//! ([`compile()`], producing a [`tape::Tape`]) → evaluate ([`eval`], per point or per batch, in
//! f32 or f64).
//!
//! ```
//! use texgraph::{check, compile, CheckOptions, CompileOptions, SourceFile, Workspace};
//! let file = SourceFile::new("doc.ron", r#"Graph(nodes: { "n": Noise(input: Position, basis: Perlin) }, outputs: { "v": "n" })"#);
//! let graph = check(file, &CheckOptions::default()).unwrap();
//! let tape = compile(&graph, &CompileOptions::default()).unwrap();
//! let mut workspace = Workspace::<f64>::new();
//! let mut out = [0.0];
//! tape.eval_point(&mut workspace, [3.14, 42.0, 7.0], &mut out);
//! assert_eq!(out[0], 0.13691995878400012); // Ken Perlin's reference implementation
//! ```

//! The public API, by stage: [`load_graph`] / [`load_tape`] (read a file, check, compile),
//! [`check()`] → [`CheckedGraph`], [`compile()`] → [`Tape`], [`Tape::eval_point`] /
//! [`Tape::eval_batch`] with a [`Workspace`] (f32 or f64 through [`Real`]); [`bake`] (volumes
//! and files), [`render`] (previews), [`report`] and [`stability`] (error against run time);
//! [`diagnostic`] (located messages), [`nodes`] (the catalogue), [`noise`] (the bases and their
//! tables), [`ops`] (the per-lane semantics), [`output`] (where and how texgraph writes),
//! [`limits`]. The parser, level of detail, the check summary and the points reader are
//! crate-private; `cli` is the binary's. A `CheckedGraph` and a `Tape` can only be made by
//! checking and compiling, so evaluation never meets a malformed tape.

// `unsafe` lives only in the SIMD modules (`noise/batch/`, `noise/vbmi.rs`), allowed there by
// name, each block with a `// SAFETY:` comment.
#![deny(unsafe_code)]
#![warn(clippy::undocumented_unsafe_blocks)]

/// `$item` compiled per CPU with `multiversion`: for every target of `all` in release builds
/// (and with `RUSTFLAGS="--cfg texgraph_simd_all"`); in debug and test builds for the one the
/// building machine runs (`build.rs`), `vbmi` where it has AVX-512 VBMI, else `avx2` — a test
/// run executes one clone, and the clones were 55 % of the crate's machine code in the test
/// binary (issue 46: the test build's time). The noise kernels (`noise/batch/`,
/// `simd_targets!`) and the filtered form's lane kernels (`filter/lanes.rs`) use it.
macro_rules! simd_clones {
    (all: [$($all:literal),+ $(,)?], vbmi: $vbmi:literal, avx2: $avx2:literal, $item:item) => {
        #[cfg_attr(
            any(not(debug_assertions), texgraph_simd_all),
            multiversion::multiversion(targets($($all),+))
        )]
        #[cfg_attr(
            all(debug_assertions, not(texgraph_simd_all), texgraph_host_vbmi),
            multiversion::multiversion(targets($vbmi))
        )]
        #[cfg_attr(
            all(debug_assertions, not(texgraph_simd_all), not(texgraph_host_vbmi)),
            multiversion::multiversion(targets($avx2))
        )]
        $item
    };
}

pub mod bake;
pub mod check;
/// The commands of the `texgraph` binary (its implementation, not a library API).
#[doc(hidden)]
pub mod cli;
pub mod compile;
pub(crate) mod derive;
pub mod diagnostic;
pub mod encoding;
pub mod eval;
pub mod filter;
pub mod filter_report;
pub mod gpu;
pub mod graph;
pub mod grid;
pub mod limits;
pub mod load;
pub(crate) mod lod;
pub mod mesh;
pub mod mip_report;
pub mod nodes;
pub mod noise;
pub mod ops;
pub mod output;
pub(crate) mod points;
pub mod precision;
pub mod real;
pub mod report;
#[cfg(feature = "serve")]
pub mod serve;
pub mod shader;
pub mod source;
pub mod stability;
pub(crate) mod summary;
pub(crate) mod syntax;
pub mod tape;

pub use check::{check, CheckOptions};
pub use compile::{compile, CompileOptions};
pub use diagnostic::{Diagnostic, Diagnostics, SourceFile};
pub use eval::{Workspace, LANES};
pub use graph::{CheckedGraph, Type};
pub use load::{load_graph, load_tape};
pub use precision::Extent;
pub use real::Real;
pub use source::{read_source, LoadError};
pub use tape::Tape;
pub mod render;
