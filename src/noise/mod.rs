//! Lattice noise bases (Perlin's improved noise, Ebert's gradient noise, value noise) and their
//! fractal sums, evaluated one point at a time or over a batch of lanes.
//!
//! Precision contract: positions are always `f64`, so the integer lattice cell of a point stays
//! exact far beyond f32's 24-bit mantissa; the cell index mod 256 and the fraction within the cell
//! are computed in f64, and only the fraction enters the interior arithmetic in `S` (f32 or f64).
//! The tables are built by a frozen generator (`rng.rs`) so a graph's output never changes, and
//! stored in f32 precision so the f32 and f64 paths read identical numbers.
//!
//! The batch functions (`batch/`) run a SIMD formulation of the same arithmetic: per octave, a
//! lattice loop in f64, the corner hashes (gathers, or byte shuffles on AVX-512 VBMI in
//! `vbmi.rs`) and an interior loop in S, compiled per instruction set and picked at run time.
//! They return the point functions' bits (Rust never contracts or reassociates float arithmetic;
//! NaN results are made canonical on both paths); the tests hold them to it.
//!
//! Gradients (`derivative.rs`, for the `Gradient` node): the exact analytic gradient with
//! respect to the point of every basis and fractal sum ([`NoiseTable::sample_grad`],
//! [`fractal_styled_grad`] and their batch forms), under the same precision contract and the
//! same bit-for-bit rule; the lattice bases through `LatticeKernel::interior_grad` and the lane
//! kernels of `batch/` (an 8-octave Perlin fbm's gradient costs about twice its value).
//!
//! The files, by layer (nothing refers to a file above it, and nothing in `noise/` to this
//! one, which only declares and re-exports): `lanes.rs` (chunk sizes, the canonical NaN) and
//! `rng.rs`, `lattice.rs` (the lattice step, hashes, blends), `period.rs`; the bases' point
//! functions `perlin.rs`, `gradient.rs`, `value.rs`, `simplex.rs`, `cellular.rs`; `basis.rs`
//! (names, ranges, bounds); `octaves.rs` (schedules, styles, the octave loop); `kernel.rs` (the
//! kernel traits and their per-point references); `vbmi.rs` and `batch/` (the SIMD kernels);
//! `kernels.rs` (each basis' kernel, `with_kernel!`); `table.rs` ([`NoiseTable`]); `fractal.rs`
//! and `derivative.rs` (the fractal sums and gradients callers use).

mod basis;
// The SIMD modules are the only places `unsafe` is allowed (the crate root denies it): runtime
// feature dispatch and the AVX-512 VBMI intrinsics. Every block states its invariant in a
// `// SAFETY:` comment (clippy's `undocumented_unsafe_blocks` is on).
#[allow(unsafe_code)]
mod batch;
mod cellular;
mod derivative;
#[cfg(test)]
mod derivative_tests;
mod fractal;
mod gradient;
mod hash;
mod kernel;
mod kernels;
mod lanes;
mod lattice;
mod octaves;
mod period;
mod perlin;
mod rng;
mod simplex;
mod table;
#[cfg(test)]
#[allow(unsafe_code)] // calls the VBMI kernel directly, after detecting the features
mod tests;
mod value;
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod vbmi;

pub use basis::{Basis, Interpolation};
pub use cellular::{Cellular, CellularValue, Metric};
pub use derivative::{
    fractal_styled_grad, fractal_styled_grad_batch, fractal_styled_grad_batch_lanes,
};
pub use fractal::{
    fractal, fractal_batch, fractal_styled, fractal_styled_batch, fractal_styled_batch_lanes,
};
pub use octaves::{LaneOctaves, Octaves, Style};
pub use period::Period;
/// The crate's one fixed generator, also used for sample sets (report, level of detail).
pub(crate) use rng::SplitMix64;
pub use table::NoiseTable;
