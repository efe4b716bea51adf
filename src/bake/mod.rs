//! Stage 5, bake: a tape evaluated over a voxel grid, streamed window by window into a sink (an
//! EXR, PNG, raw or KTX2 file writer, or an in-memory [`Volume`]).
//!
//! The voxels, in file order (x fastest, then y, then z), are cut into *segments*: runs of at
//! most [`SEGMENT_VOXELS`] voxels inside one row (a row longer than that is split). A window is
//! a run of consecutive segments: whole z slices when a slice is small, part of a slice when it
//! is large. The segments of a window are evaluated in parallel (rayon, one task per segment,
//! each with its own workspace) while a writer thread hands the previous window to the sink: a
//! pipeline two windows deep, over two buffers that swap (the sink runs inside the same pool, so
//! a sink that encodes in parallel, PNG slices or raw, shares the workers with the evaluation;
//! the writer thread itself only waits on the pool, so `threads` workers do all the work, and one
//! thread evaluates and writes in turn). A sink's error stops the bake at the next hand-over, a
//! cancellation before the next window; either way the writer is joined before the bake returns.
//! So the bake itself holds at most two windows, 2 × [`WINDOW_BYTES`] of samples, plus one
//! segment's buffers per thread, whatever the grid's shape (a 4 294 967 296 × 1 × 1 row and a
//! 65 536 × 65 536 slice stream like a cube). What a sink keeps is its own bound, checked before
//! the bake starts (`files.rs`): a raw writer a batch of at most 256 Ki voxels (7 MiB at most),
//! a PNG slice writer a row or two, a KTX2 writer a buffered block (and with Zstandard its
//! encoder's window and tables), a PNG atlas one row of tiles, an EXR file (whose writer needs
//! the whole image) and a `Volume` everything.
//!
//! Every voxel is evaluated on its own by the same code, segments do not depend on the thread
//! count, and statistics are reduced in segment order, so results are bit-identical whatever
//! the thread count.
//!
//! The files, by layer (ARCHITECTURE.md has the whole crate's): `crate::grid` (the voxel grid and
//! its layout) below everything; `device.rs` (which device evaluates a bake, one decision for
//! every sink); `window.rs` (the `Window` sinks receive: 32-bit floats, or from a GPU bake each channel in its file's sample type; the `Sink` trait); `engine.rs` (options, errors, statistics, the window engine and what produces its windows); `settings.rs` (what the file writers share: `BakeFileOptions`, reports,
//! mip grids); the writers `sinks.rs` (EXR, PNG, raw), `ktx2.rs`, `zarr.rs` (with `part.rs`) and
//! `vdb_bake.rs` (with `vdb.rs`); `files.rs`, the dispatch, on top. This file only declares and
//! re-exports; nothing in `bake/` refers to it.

mod device;
mod engine;
mod error;
mod files;
mod ktx2;
pub mod part;
mod settings;
mod sinks;
pub mod vdb;
mod vdb_bake;
mod window;
#[cfg(feature = "zarr")]
pub mod zarr;

pub use crate::encoding::{encode_u16, encode_u8, srgb_encode, Encoding, Packing};
pub use crate::grid::{Grid, Layout, Region, Segment, SEGMENT_BYTES, SEGMENT_VOXELS, WINDOW_BYTES};
pub use device::{choose as choose_device, Choice, Evaluator};
pub(crate) use engine::collect_stats;
pub use engine::{
    bake_into, bake_volume, bake_volume_with_progress, capped_threads, BakeOptions, ChannelStats,
    OutputStats, Precision, Volume, VolumeOutput, MAX_THREADS_PER_CORE,
};
pub use error::BakeError;
pub use files::commit_files;
pub use files::{bake_files, bake_mipmapped, planned_outputs, validate_grid};
pub use settings::{
    human_bytes, mip_grid, mip_level_count, mip_spacing, mips_note, BakeFileOptions, BakeReport,
    BakedFile, ExrCompression, Format, Ktx2SampleType, RawSampleType, Transfer, ZarrCompression,
    ZarrSettings, DEFAULT_CHUNK, DEFAULT_MAX_BAKE_BYTES, DEFAULT_MAX_HELD_BYTES, DEFAULT_SHARD,
    DEFAULT_ZSTD_LEVEL, ZSTD_LEVELS,
};
pub use sinks::{png_bytes, write_exr_image};
pub use window::{Sink, Window, WindowOutput};
