//! Resource limits, enforced while parsing and checking so that a hostile or broken graph file is
//! rejected before it costs memory or time. Documented in docs/format.md ("Limits").

/// Largest graph file accepted, in bytes.
pub const MAX_FILE_BYTES: usize = 16 << 20;
/// Deepest nesting of RON values (inline nodes inside inline nodes, lists, tuples).
pub const MAX_NESTING: usize = 128;
/// Most nodes in one graph, counting inline nodes.
pub const MAX_NODES: usize = 200_000;
/// Most params in one graph.
pub const MAX_PARAMS: usize = 10_000;
/// Most octaves one Fbm or Turbulence may sum.
pub const MAX_OCTAVES: f64 = 32.0;
/// Highest first octave of Fbm or Turbulence.
pub const MAX_FIRST_OCTAVE: f64 = 32.0;
/// Largest octave frequency (lacunarity^i) or amplitude (gain^i) of an Fbm or Turbulence: beyond
/// it positions or sums overflow to infinity.
pub const MAX_OCTAVE_SCALE: f64 = 1e30;
/// Most stops in a ColorRamp, points in a Curve.
pub const MAX_RAMP_STOPS: usize = 4096;
/// Largest noise seed (seeds are integers, exactly representable in f64).
pub const MAX_SEED: f64 = 9_007_199_254_740_991.0; // 2^53 - 1

/// The largest tiling period per axis, in cells (2^20): far beyond any texture's repeat, and
/// small enough that an octave's period (times lacunarity^i) stays an exact integer.
pub const MAX_PERIOD: f64 = 1_048_576.0;
