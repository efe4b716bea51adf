//! Footprint level of detail: leave out the fbm/turbulence octaves a sampling cannot resolve.
//!
//! Given the sample spacing `h` (a bake's voxel size, a render's pixel footprint), an octave
//! whose wavelength falls below `2h` (the Nyquist limit, seed 004's "sample too sparsely") only
//! aliases. The frequency an octave has in world space depends on the domain transforms before
//! the noise (Scale, Rotate, Translate, any math), so for every node we bound how fast its value
//! can change per unit of world distance — its Lipschitz constant, the "stretch" — with one
//! forward pass over the graph (arguments come before their users; no recursion). An fbm whose
//! input stretches space by `s` sees octave `i` at world frequency `s · lacunarity^i`.
//!
//! Octaves are cut at a *continuous* index, so the last kept octave fades in and out as the
//! spacing changes (no popping), exactly like a fractional `octaves`. What the dropped octaves
//! contributed on average is added back as a constant (`amplitude × E[noise]` for fbm,
//! `amplitude × E[|noise|]` for turbulence), so the filtered texture keeps its mean brightness.

use crate::graph::{CheckedGraph, FractalParams, Op, TableKey};
use crate::nodes::{self, FractalKind, Lowering, Slope};
use crate::noise::NoiseTable;
use crate::noise::Style;
use crate::ops;
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// Upper bounds of each node's rate of change per unit of world distance; `None` where no
/// useful bound is known (discontinuous or unbounded operations), which disables LOD for noise
/// downstream of it. Each node follows its kind's catalogue rule (`nodes::Slope`).
pub fn stretches(graph: &CheckedGraph) -> Vec<Option<f64>> {
    let mut s: Vec<Option<f64>> = Vec::with_capacity(graph.nodes.len());
    for node in &graph.nodes {
        let bounds: Vec<Option<f64>> = node.args.iter().map(|&a| s[a as usize]).collect();
        let constants: Vec<Option<[f64; 3]>> = node
            .args
            .iter()
            .map(|&a| match graph.nodes[a as usize].op {
                Op::ConstScalar(v) => Some([v; 3]),
                Op::ConstVec3(v) => Some(v),
                _ => None,
            })
            .collect();
        let value = match &node.op {
            Op::ConstScalar(_) | Op::ConstVec3(_) => Some(0.0),
            // The checker's own plumbing (no catalogue kind): a copy of one input.
            Op::Splat | Op::Component(_) => bounds[0],
            op => slope(op, rule(op), &bounds, &constants),
        };
        s.push(value.filter(|v| v.is_finite()));
    }
    s
}

/// The catalogue's slope rule for an operation a kind lowers to (Scale shares Mul's rule,
/// Translate Add's: a test pins that the shared rules agree).
fn rule(op: &Op) -> Slope {
    let lowering = match op {
        Op::Position => Lowering::Position,
        Op::Combine => Lowering::Combine,
        Op::Unary(u) => Lowering::Unary(*u),
        Op::Binary(b) => Lowering::Binary(*b),
        Op::Ternary(t) => Lowering::Ternary(*t),
        Op::Dot => Lowering::Dot,
        Op::Length => Lowering::Length,
        Op::Cross => Lowering::Cross,
        Op::Normalize => Lowering::Normalize,
        Op::Rotate { .. } => Lowering::Rotate,
        Op::Noise(_) => Lowering::Noise,
        Op::Fractal(_, p) => Lowering::Fractal(match p.style {
            Style::Fbm => FractalKind::Fbm,
            Style::Turbulence => FractalKind::Turbulence,
            Style::Billow => FractalKind::Billow,
            Style::Ridged { .. } => FractalKind::Ridged,
        }),
        Op::Hermite(_) => Lowering::Hermite,
        Op::Ramp(_) => Lowering::Ramp,
        Op::Curve(_) => Lowering::Curve,
        Op::ConstScalar(_) | Op::ConstVec3(_) | Op::Splat | Op::Component(_) => {
            return Slope::Identity
        }
        Op::NoiseGradient(_) | Op::FractalGradient(..) => {
            return Slope::Unbounded("a gradient changes with the noise's second derivative")
        }
    };
    nodes::CATALOGUE
        .iter()
        .find(|d| d.lowering == lowering)
        .map_or(Slope::Unbounded("no catalogue kind"), |d| d.slope)
}

/// Evaluates one slope rule over a node's argument bounds (`bounds`) and constant arguments.
fn slope(
    op: &Op,
    rule: Slope,
    bounds: &[Option<f64>],
    constants: &[Option<[f64; 3]>],
) -> Option<f64> {
    let arg = |i: usize| bounds.get(i).copied().flatten();
    let constant = |i: usize| constants.get(i).copied().flatten();
    let largest = |v: [f64; 3]| v.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    let smallest = |v: [f64; 3]| v.iter().fold(f64::INFINITY, |m, c| m.min(c.abs()));
    match rule {
        Slope::Identity => Some(1.0),
        Slope::NoSteeper => arg(0),
        Slope::Steepest => Some(arg(0)?.max(arg(1)?)),
        Slope::Sum => Some(arg(0)? + arg(1)?),
        Slope::Euclidean => Some((arg(0)?.powi(2) + arg(1)?.powi(2) + arg(2)?.powi(2)).sqrt()),
        Slope::ConstantFactor => match (constant(0), constant(1)) {
            (Some(c), _) => Some(largest(c) * arg(1)?),
            (_, Some(c)) => Some(largest(c) * arg(0)?),
            _ => None,
        },
        Slope::ConstantProjection => match (constant(0), constant(1)) {
            (Some(c), _) => Some(ops::length(c) * arg(1)?),
            (_, Some(c)) => Some(ops::length(c) * arg(0)?),
            _ => None,
        },
        Slope::ConstantDivisor => constant(1)
            .filter(|c| smallest(*c) > 0.0)
            .and_then(|c| Some(arg(0)? / smallest(c))),
        Slope::ConstantBounds => constant(1).and(constant(2)).and_then(|_| arg(0)),
        Slope::ConstantBlend => constant(2)
            .and_then(|t| Some(largest(t.map(|v| 1.0 - v)) * arg(0)? + largest(t) * arg(1)?)),
        Slope::ConstantEdges => {
            let (e0, e1) = (constant(0)?, constant(1)?);
            let width = smallest([e1[0] - e0[0], e1[1] - e0[1], e1[2] - e0[2]]);
            (width > 0.0).then_some(1.5 / width * arg(2)?)
        }
        // The angle is argument 1; a varying angle (a twist) has no bound here.
        Slope::RigidMotion => constant(1).and_then(|_| arg(0)),
        Slope::Basis => match op {
            Op::Noise(key) => Some(table_lipschitz(*key) * arg(0)?),
            _ => None,
        },
        Slope::FractalSum => match op {
            Op::Fractal(key, params) => {
                let schedule = params.schedule();
                let sum: f64 = schedule
                    .frequencies
                    .iter()
                    .zip(&schedule.amplitudes)
                    .map(|(f, a)| (f * a).abs())
                    .sum();
                // Billow's 2|n| doubles each octave's slope.
                let shaping = if params.style == Style::Billow {
                    2.0
                } else {
                    1.0
                };
                Some(shaping * table_lipschitz(*key) * sum * arg(0)?)
            }
            _ => None,
        },
        Slope::SteepestSegment => match op {
            Op::Ramp(r) => spline_slope(r.knots(), r.values()).and_then(|m| Some(m * arg(0)?)),
            Op::Curve(c) => spline_slope(c.knots(), c.values()).and_then(|m| Some(m * arg(0)?)),
            _ => None,
        },
        Slope::Unbounded(_) | Slope::Composite => None,
    }
}

/// The steepest segment of a spline (largest change of any channel per unit of input); `None`
/// for a jump (coinciding knots with different values).
fn spline_slope<const N: usize>(knots: &[f64], values: &[[f64; N]]) -> Option<f64> {
    let mut steepest = 0.0f64;
    for (k, v) in knots.windows(2).zip(values.windows(2)) {
        let change = (0..N).fold(0.0f64, |m, c| m.max((v[1][c] - v[0][c]).abs()));
        let width = k[1] - k[0];
        if width > 0.0 {
            steepest = steepest.max(change / width);
        } else if change > 0.0 {
            return None;
        }
    }
    Some(steepest)
}

fn table_lipschitz(key: TableKey) -> f64 {
    key.basis.lipschitz()
}

/// What level of detail did to one fbm/turbulence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FractalLod {
    /// Octaves kept (fractional: the last one faded).
    pub octaves: f64,
    /// Constant standing in for the dropped octaves' average.
    pub bias: f64,
}

/// The octaves an fbm with input stretch `stretch` keeps at sample spacing `spacing`, and the
/// bias for what it drops. Unchanged when nothing needs dropping or nothing is known.
pub fn fractal_lod(
    key: TableKey,
    params: &FractalParams,
    stretch: Option<f64>,
    spacing: f64,
) -> FractalLod {
    let unchanged = FractalLod {
        octaves: params.octaves,
        bias: 0.0,
    };
    let Some(stretch) = stretch.filter(|&s| resolvable(params, s)) else {
        return unchanged;
    };
    let kept = kept_octaves(params, params.lacunarity.ln(), stretch, spacing);
    if kept >= params.octaves {
        return unchanged;
    }
    FractalLod {
        octaves: kept,
        bias: dropped_bias(
            params,
            expected_signal(key, params.style),
            kept,
            &gain_powers(params),
        ),
    }
}

/// `gain^i` of each octave written (`i` from the first octave), by `f64::powi` at run time: the
/// factors [`dropped_bias`] weighs each dropped share by.
fn gain_powers(params: &FractalParams) -> Vec<f64> {
    let count = params.octaves.ceil() as u32;
    (0..count)
        .map(|n| params.gain.powi(params.first_octave as i32 + n as i32))
        .collect()
}

/// Whether level of detail can drop octaves of a fractal whose input has stretch `stretch`:
/// a positive, finite stretch and octaves that grow in frequency.
fn resolvable(params: &FractalParams, stretch: f64) -> bool {
    stretch > 0.0 && stretch.is_finite() && params.lacunarity > 1.0
}

/// The octaves (continuous: the last one faded) whose world frequency stays at or below the
/// Nyquist limit of `spacing`; all of them for a spacing that is not positive and finite.
/// The one formula of per-compile and per-lane level of detail (so the two agree bit for bit).
/// `ln_lacunarity` is `params.lacunarity.ln()` (a per-lane caller computes it once).
#[inline]
fn kept_octaves(params: &FractalParams, ln_lacunarity: f64, stretch: f64, spacing: f64) -> f64 {
    if !(spacing > 0.0 && spacing.is_finite()) {
        return params.octaves;
    }
    // Highest (continuous) octave index whose world frequency stays at or below Nyquist.
    let nyquist = 0.5 / spacing;
    let highest = (nyquist / stretch).ln() / ln_lacunarity;
    (highest - params.first_octave as f64 + 1.0).clamp(0.0, params.octaves)
}

/// A spacing below which [`kept_octaves`] is at least `kept` by a wide margin (1 / log2 of the
/// lacunarity octaves, far beyond any rounding of its logarithm): half the spacing at which
/// octave `kept` (counted from the first) reaches the Nyquist limit; 0 where none is
/// meaningful.
fn fine_spacing(params: &FractalParams, stretch: f64, kept: f64) -> f64 {
    let exponent = kept + params.first_octave as f64 - 1.0;
    let spacing = 0.25 / (stretch * params.lacunarity.powf(exponent));
    if spacing.is_finite() && spacing > 0.0 {
        spacing
    } else {
        0.0
    }
}

/// What a fractal's octaves contribute on average, per unit of amplitude: the basis' mean for
/// fbm, its mean magnitude for turbulence, and the shaped signal at the mean magnitude for
/// billow and ridged.
fn expected_signal(key: TableKey, style: Style) -> f64 {
    let (mean, mean_abs) = expectations(key);
    match style {
        Style::Fbm => mean,
        Style::Turbulence => mean_abs,
        Style::Billow => 2.0 * mean_abs - 1.0,
        // Ridged: the dropped octaves' signal (offset - |n|)^sharpness at the mean |n|, an
        // estimate (the weights w <= 1 of those octaves are left out).
        Style::Ridged { offset, sharpness } => (offset - mean_abs).max(0.0).powf(sharpness),
    }
}

/// The constant standing in for the octaves beyond `kept`: each dropped share of an octave's
/// amplitude times `expected` (`gains`: [`gain_powers`]).
fn dropped_bias(params: &FractalParams, expected: f64, kept: f64, gains: &[f64]) -> f64 {
    let mut bias = 0.0;
    for (n, &gain) in gains.iter().enumerate() {
        bias += dropped_share(params, n, kept, gain, expected);
    }
    bias
}

/// Octave `n`'s term of [`dropped_bias`]: the share of its written weight that `kept` drops,
/// times its gain and `expected`.
#[inline(always)]
fn dropped_share(params: &FractalParams, n: usize, kept: f64, gain: f64, expected: f64) -> f64 {
    let weight_written = (params.octaves - n as f64).clamp(0.0, 1.0);
    let weight_kept = (kept - n as f64).clamp(0.0, 1.0);
    (weight_written - weight_kept) * gain * expected
}

/// Level of detail per lane for one fractal instruction (a render's hits each have their own
/// footprint): the octaves a lane keeps at its own spacing and the bias for the rest, by the
/// same formulas as [`fractal_lod`], so a batch whose lanes share one spacing gives the bits of
/// a tape compiled for that spacing. Never more octaves than the tape's schedule already keeps.
#[derive(Debug)]
pub struct LaneLod {
    key: TableKey,
    params: FractalParams,
    stretch: f64,
    /// The octaves the tape's schedule keeps (its own level of detail) and its bias.
    kept: f64,
    bias: f64,
    /// `gain^i` of each octave of the schedule, unfaded.
    powers: Vec<f64>,
    /// [`gain_powers`] of the octaves written.
    gains: Vec<f64>,
    /// `params.lacunarity.ln()`.
    ln_lacunarity: f64,
    /// Below this spacing a lane keeps every octave of the schedule (see [`LaneLod::kept`]).
    fine: f64,
    /// [`expected_signal`], computed the first time a lane drops an octave.
    expected: OnceLock<f64>,
}

impl LaneLod {
    /// `None` where per-lane level of detail can drop nothing (the input's stretch is unknown,
    /// zero or infinite; the octaves do not grow in frequency).
    pub(crate) fn new(
        key: TableKey,
        params: &FractalParams,
        stretch: Option<f64>,
        compiled: FractalLod,
    ) -> Option<LaneLod> {
        let stretch = stretch.filter(|&s| resolvable(params, s))?;
        let powers = crate::noise::Octaves::new(
            compiled.octaves.ceil(),
            params.lacunarity,
            params.gain,
            params.first_octave,
        )
        .amplitudes;
        Some(LaneLod {
            key,
            params: *params,
            stretch,
            kept: compiled.octaves,
            bias: compiled.bias,
            powers,
            gains: gain_powers(params),
            ln_lacunarity: params.lacunarity.ln(),
            fine: fine_spacing(params, stretch, compiled.octaves),
            expected: OnceLock::new(),
        })
    }

    /// The octaves a lane at sample spacing `spacing` keeps (continuous).
    #[inline]
    pub(crate) fn kept(&self, spacing: f64) -> f64 {
        // A spacing well below the one at which the schedule's last octave starts to fade keeps
        // the whole schedule whatever the rounding of the logarithm: no logarithm needed.
        if spacing > 0.0 && spacing < self.fine {
            return self.kept;
        }
        kept_octaves(&self.params, self.ln_lacunarity, self.stretch, spacing).min(self.kept)
    }

    /// Whether a lane keeping `kept` octaves drops one the schedule has.
    #[inline]
    pub(crate) fn drops(&self, kept: f64) -> bool {
        kept < self.kept
    }

    /// Per lane, the bias of a lane keeping `kept[i]` octaves into `bias[i]` (the schedule's
    /// own where it drops none): [`dropped_bias`]'s sum, lanes inside the octave loop so it
    /// vectorises.
    pub(crate) fn biases(&self, kept: &[f64], bias: &mut [f64]) {
        let expected = *self
            .expected
            .get_or_init(|| expected_signal(self.key, self.params.style));
        let bias = &mut bias[..kept.len()];
        bias.fill(0.0);
        for (n, &gain) in self.gains.iter().enumerate() {
            for (b, &k) in bias.iter_mut().zip(kept) {
                *b += dropped_share(&self.params, n, k, gain, expected);
            }
        }
        for (b, &k) in bias.iter_mut().zip(kept) {
            *b = if self.drops(k) { *b } else { self.bias };
        }
    }

    /// `gain^i` of each octave of the schedule, unfaded.
    pub(crate) fn powers(&self) -> &[f64] {
        &self.powers
    }

    /// The numbers the GPU path writes into its shader to run [`LaneLod::kept`] and
    /// [`LaneLod::biases`] per thread (`gpu/codegen.rs`): the same formulas, in WGSL.
    pub(crate) fn terms(&self) -> LaneLodTerms<'_> {
        LaneLodTerms {
            octaves: self.params.octaves,
            first_octave: self.params.first_octave,
            stretch: self.stretch,
            ln_lacunarity: self.ln_lacunarity,
            kept: self.kept,
            fine: self.fine,
            powers: &self.powers,
            gains: &self.gains,
            expected: *self
                .expected
                .get_or_init(|| expected_signal(self.key, self.params.style)),
        }
    }
}

/// [`LaneLod`]'s numbers (see [`LaneLod::terms`]).
pub(crate) struct LaneLodTerms<'a> {
    pub octaves: f64,
    pub first_octave: u32,
    pub stretch: f64,
    pub ln_lacunarity: f64,
    pub kept: f64,
    pub fine: f64,
    pub powers: &'a [f64],
    pub gains: &'a [f64],
    pub expected: f64,
}

/// E[noise] and E[|noise|] of a basis, once per table: the mean exactly, the mean magnitude
/// estimated on a fixed scatter of 8192 points over one lattice period (deterministic, so
/// tapes are reproducible).
fn expectations(key: TableKey) -> (f64, f64) {
    static CACHE: OnceLock<Mutex<HashMap<TableKey, (f64, f64)>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(found) = cache.lock().ok().and_then(|c| c.get(&key).copied()) {
        return found;
    }
    let table = NoiseTable::new(key.basis, key.seed);
    let mut rng = crate::noise::SplitMix64::new(0x10D);
    let mut next = || rng.next_f64() * 256.0;
    let n = 8192;
    let (mut sum, mut sum_abs) = (0.0, 0.0);
    for _ in 0..n {
        let v: f64 = table.sample([next(), next(), next()]);
        sum += v;
        sum_abs += v.abs();
    }
    // The mean is known exactly: gradient bases are zero-mean by construction (a sampled
    // estimate would only add noise), and value noise averages to its table's mean, which the
    // 256 lattice points of one row along x visit exactly once each (the hash is a permutation).
    let mean = match key.basis {
        crate::noise::Basis::Perlin
        | crate::noise::Basis::Gradient
        | crate::noise::Basis::Simplex => 0.0,
        // No closed form: the same scatter's estimate.
        crate::noise::Basis::Cellular(_) | crate::noise::Basis::White => sum / n as f64,
        crate::noise::Basis::Value(_) => {
            (0..256)
                .map(|x| table.sample::<f64>([x as f64, 0.0, 0.0]))
                .sum::<f64>()
                / 256.0
        }
    };
    let result = (mean, sum_abs / n as f64);
    if let Ok(mut c) = cache.lock() {
        c.insert(key, result);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::Basis;

    fn params(octaves: f64) -> FractalParams {
        FractalParams {
            octaves,
            lacunarity: 2.0,
            gain: 0.5,
            first_octave: 0,
            style: Style::Fbm,
            period: None,
        }
    }

    /// Kinds lowering to the same operation (Scale to Mul, Translate to Add) state the same
    /// rule, so the rule found for the operation is each kind's own.
    #[test]
    fn kinds_sharing_an_operation_share_their_rule() {
        let of = |k: nodes::Kind| nodes::def(k).slope;
        assert_eq!(of(nodes::Kind::Scale), of(nodes::Kind::Mul));
        assert_eq!(of(nodes::Kind::Translate), of(nodes::Kind::Add));
        for d in nodes::CATALOGUE {
            let shared: Vec<_> = nodes::CATALOGUE
                .iter()
                .filter(|o| o.lowering == d.lowering)
                .collect();
            assert_eq!(shared.len(), 1, "{} shares its lowering", d.name);
        }
    }

    #[test]
    fn octaves_above_nyquist_are_dropped_smoothly() {
        let key = TableKey {
            basis: Basis::Perlin,
            seed: 0,
            period: None,
        };
        // Spacing 1/128: Nyquist 64 = 2^6, so octaves 0..=6 stay: 7 octaves.
        let lod = fractal_lod(key, &params(8.0), Some(1.0), 1.0 / 128.0);
        assert!((lod.octaves - 7.0).abs() < 1e-9, "{lod:?}");
        // A scale of 2 before the noise doubles every frequency: one octave fewer.
        let scaled = fractal_lod(key, &params(8.0), Some(2.0), 1.0 / 128.0);
        assert!((scaled.octaves - 6.0).abs() < 1e-9, "{scaled:?}");
        // In between, the last octave fades.
        let between = fractal_lod(key, &params(8.0), Some(1.5), 1.0 / 128.0);
        assert!(between.octaves > 6.0 && between.octaves < 7.0);
        // Fine spacing keeps everything; unknown stretch keeps everything.
        assert_eq!(fractal_lod(key, &params(8.0), Some(1.0), 1e-6).octaves, 8.0);
        assert_eq!(fractal_lod(key, &params(8.0), None, 1.0).octaves, 8.0);
    }

    #[test]
    fn turbulence_keeps_its_mean_through_dropped_octaves() {
        let key = TableKey {
            basis: Basis::Perlin,
            seed: 0,
            period: None,
        };
        let mut p = params(8.0);
        p.style = Style::Turbulence;
        let lod = fractal_lod(key, &p, Some(1.0), 0.25);
        assert!((lod.octaves - 2.0).abs() < 1e-9, "{lod:?}");
        assert!(lod.bias > 0.0, "{lod:?}");
        let (_, mean_abs) = expectations(key);
        assert!(mean_abs > 0.1 && mean_abs < 0.4, "{mean_abs}");
    }
}
