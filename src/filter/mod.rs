//! Filtered evaluation (issue 33): the mean of each output over a footprint, not its value at a
//! point.
//!
//! From the bottom up: `moments` (the one-variable mathematics: exact box means, variances and
//! slopes of piecewise polynomials, `fract` and truncated powers of a value spread over a
//! footprint), `trig` (sine and cosine, one reduction for both) → `periodic` (`g(fract x)` for
//! a piecewise-cubic `g`, exactly), `rules` (a value's distribution, [`Dist`], through each
//! operation; the [`Footprint`]), `operands` (an operand saved for a fused instruction),
//! `abs_sine` (`|sin X|`: one-sided, or its Fourier series summed for a chunk's lanes) →
//! `noise` (noise and fractal sums over a footprint, white and cellular noise), `integers`
//! (which values are integer-valued), `ranges` (the interval a value cannot leave), `chains`
//! (periodic chains) → `fusions` (which instructions are computed from an earlier argument) →
//! `tape` ([`Filtered`]: a compiled tape run on distributions, chunk by chunk of lanes).
//! docs/filtering.md has every rule's
//! derivation.

mod abs_sine;
mod chains;
pub mod fusions;
pub mod integers;
mod lanes;
pub mod moments;
pub mod noise;
pub mod operands;
pub mod periodic;
pub mod ranges;
pub mod rules;
pub mod tape;
mod trig;

pub use rules::{Dist, Footprint, FootprintError};
pub use tape::{FilterWorkspace, Filtered};

/// What a bake's or render's sample stands for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    /// The graph's value at the voxel centre or pixel hit.
    #[default]
    Point,
    /// The estimate of the graph's mean over the voxel (its side the voxel size) or the
    /// pixel's footprint.
    Box,
}
