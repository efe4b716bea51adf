//! The noise rule of filtered evaluation: a noise sample (and each octave of a fractal sum) over
//! a footprint.
//!
//! The mean of a noise over a region is estimated as its value at the centre faded towards the
//! basis' global mean, `α n(m) + (1 − α) μ`, and the variance it loses, `(1 − α²) σ²`, less
//! what the linear part explains on average, becomes residual variance (so a downstream `Sin`,
//! `Step` or ramp greys out). `α` is the regression
//! coefficient of the region's mean on the centre value: for a box of length `L` along a unit
//! direction, `1 − L² G / (24 σ²)` to second order (`G` the mean squared directional derivative,
//! by a Taylor expansion of the box mean and `E[n ∂²n] = −E[(∂n)²]` for a stationary noise),
//! taken as `(1 + κ² L² / 12)^(−1/2)` with `κ² = G / σ²` (the same second-order term, and the
//! `1/L` decay of a regression on one of about `L` independent cells); per edge of the
//! footprint in noise space, times `e^(−κ² Σ v_i / 2)` for a Gaussian residual of variance
//! `v_i` per axis (the same expansion). `μ`, `σ²` and `G` are measured once per table from
//! 1024 seeded points (`G` by differences at a quarter cell, so white and cellular noise, whose
//! gradient is zero or kinked, get their correlation length too). The linear part is the exact
//! gradient faded by `α`, through the input's linear part (the chain rule: a `Warp`'s
//! Jacobian). Octaves of a fractal sum are independent: their means, linear parts and variances
//! add; turbulence, billow and ridged shape each faded octave by the exact rules of `abs` and
//! the ramp, so a faded octave's non-zero mean `E|n|` is in the sum.

use super::rules::{dot, Dist, Footprint, Rules, Shapes};
use crate::noise::{NoiseTable, Octaves, Style};
use crate::ops::{BinaryOp, UnaryOp};

/// A table's statistics over space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    pub mean: f64,
    pub var: f64,
    /// κ² = G / σ² (per unit length squared).
    pub kappa2: f64,
    /// Mean square of one gradient component (`NoiseGradient`'s variance).
    pub grad_sq: f64,
    /// Whether small boxes take the six face centres (`FACES_FROM`): a basis smooth across its
    /// cells (Perlin, gradient, simplex, smooth value noise). Trilinear value noise, whose kinks
    /// on the lattice planes the faces straddle, keeps the eight sub-boxes
    /// (examples/band_rules.rs: 0.0098 against 0.0084 σ at a quarter of a cell), and so do
    /// white and cellular noise where their own rules fall back to the octave rule.
    pub faces: bool,
}

/// Measures a table's statistics at 1024 seeded points (a fixed sequence: the same numbers on
/// every run and machine).
pub fn stats(table: &NoiseTable) -> Stats {
    const N: usize = 1024;
    const H: f64 = 0.25;
    let mut rng = crate::noise::SplitMix64::new(0x9e37_79b9_7f4a_7c15);
    let mut next = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * 128.0 - 64.0;
    let (mut sum, mut sum2, mut diff2, mut grad2) = (0.0, 0.0, 0.0, 0.0);
    let mut count = 0.0;
    for i in 0..N {
        let p = [next(), next(), next()];
        let v: f64 = table.sample(p);
        let g: [f64; 3] = table.sample_grad(p);
        if !v.is_finite() {
            continue;
        }
        let mut q = p;
        q[i % 3] += H;
        let w: f64 = table.sample(q);
        sum += v;
        sum2 += v * v;
        diff2 += (w - v) * (w - v);
        grad2 += g.iter().map(|c| c * c).sum::<f64>() / 3.0;
        count += 1.0;
    }
    // Gradient bases are odd under a sign flip of their gradients: their mean is 0 exactly
    // (the sample mean would be off by about σ/32).
    let zero_mean = matches!(
        table.basis(),
        crate::noise::Basis::Perlin | crate::noise::Basis::Gradient | crate::noise::Basis::Simplex
    );
    let mean = if zero_mean { 0.0 } else { sum / count };
    let var = (sum2 / count - mean * mean).max(0.0);
    let g = diff2 / count / (H * H);
    Stats {
        mean,
        var,
        kappa2: if var > 0.0 { g / var } else { 0.0 },
        faces: {
            use crate::noise::{Basis, Interpolation};
            matches!(
                table.basis(),
                Basis::Perlin
                    | Basis::Gradient
                    | Basis::Simplex
                    | Basis::Value(Interpolation::Smooth)
            )
        },
        grad_sq: if grad2.is_finite() {
            grad2 / count
        } else {
            0.0
        },
    }
}

/// [`stats`] of the table `key` names, measured once per process (a table is a function of its
/// key: basis, seed, period), so each bake, render frame or mip level does not measure again.
pub fn cached_stats(key: crate::graph::TableKey, table: &NoiseTable) -> Stats {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    static CACHE: OnceLock<Mutex<HashMap<crate::graph::TableKey, Stats>>> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    if let Some(s) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return *s;
    }
    let s = stats(table);
    cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(key, s);
    s
}

/// A table to sample one octave with: the instruction's own, or a periodic copy at the
/// octave's period.
pub struct Sampler<'a> {
    pub table: &'a NoiseTable,
    pub stats: Stats,
    /// The value-only sub-box samples in f32 (an f32 result, and the precision analysis
    /// bounds what that adds: `Tape::narrow_samples`).
    pub narrow: bool,
}

/// The fade `α` of a noise whose input is `p` (noise space) over the footprint, and the
/// factor `β_k` on the slope along each footprint edge `k`.
///
/// `β_k = (1 + κ² L_k² / 12)^(−1)` (`L_k` the edge's length in noise space) is the regression
/// slope of the noise along an edge over its exact slope at the centre: 1 − κ² L² / 12 to second
/// order (the box's linear fit, by the same Taylor expansion as `α`), and decaying as `L⁻²` past
/// a cell, where a linear part extrapolated across many cells would stand for a uniform
/// spread of the noise's whole variance (7 % too bright turbulence toward a horizon).
fn fade(rules: &Rules, stats: &Stats, p: &[Dist; 3]) -> (f64, [f64; 3]) {
    if stats.kappa2 == 0.0 {
        return (1.0, [1.0; 3]);
    }
    // The footprint's edges in noise space, J e_k: their squared lengths from each component's
    // widths along the edges.
    let widths = p.map(|c| rules.footprint.widths(c.grad));
    let l2: [f64; 3] = std::array::from_fn(|k| widths.iter().map(|w| w[k] * w[k]).sum());
    let v: f64 = p.iter().map(|c| c.var).sum();
    fade_of(stats, l2, v)
}

/// [`fade`] from the squared lengths of the footprint's edges in noise space and the input's
/// total residual variance.
fn fade_of(stats: &Stats, l2: [f64; 3], v: f64) -> (f64, [f64; 3]) {
    if stats.kappa2 == 0.0 {
        return (1.0, [1.0; 3]);
    }
    let t = l2.map(|l2| 1.0 + stats.kappa2 * l2 / 12.0);
    let beta = t.map(|t| if t.is_finite() { 1.0 / t } else { 0.0 });
    // One square root of the product (an overflow to ∞ is a fade of 0, as it should be).
    let alpha = 1.0 / (t[0] * t[1] * t[2]).sqrt();
    let alpha = if v == 0.0 {
        alpha
    } else {
        alpha * (-stats.kappa2 * v / 2.0).exp()
    };
    (if alpha.is_nan() { 0.0 } else { alpha }, beta)
}

/// Octaves faded by at least `SUB_BAND.0` and at most `SUB_BAND.1` (their cells about the
/// footprint's size) are sampled at the centres of the footprint's eight half-size sub-boxes
/// ([`subsampled`]): there the centre value is a poor estimate of the box mean, and beyond
/// the band either the box is well inside a cell (the centre value and slope suffice) or it
/// spans many (the fade is the mean).
const SUB_BAND: (f64, f64) = (0.01, 0.99);

/// The footprint's edges in noise space, `J e_k` (`J`'s rows the input's linear parts).
fn noise_edges(rules: &Rules, p: &[Dist; 3]) -> [[f64; 3]; 3] {
    let edges = rules.footprint.edges();
    std::array::from_fn(|k| std::array::from_fn(|i| dot(&p[i].grad, &edges[k])))
}

/// The eight sub-box centres in noise space: `m + Σ_k s_k E_k / 4`, `s ∈ {±1}³`, sub-box `j`
/// with `s_k = +1` where bit `k` of `j` is set.
fn sub_centres(p: &[Dist; 3], e: &[[f64; 3]; 3]) -> [[f64; 3]; 8] {
    let offsets = sub_offsets(e);
    std::array::from_fn(|j| std::array::from_fn(|i| p[i].mean + offsets[j][i]))
}

/// [`sub_centres`]' offsets from the centre, `Σ_k s_k E_k / 4`.
fn sub_offsets(e: &[[f64; 3]; 3]) -> [[f64; 3]; 8] {
    std::array::from_fn(|j| {
        std::array::from_fn(|i| {
            let s = |k: usize| if j >> k & 1 == 1 { 0.25 } else { -0.25 };
            (0..3).map(|k| s(k) * e[k][i]).sum::<f64>()
        })
    })
}

/// Fades from which a sub-sampled octave of an input without residual variance takes the six
/// face centres `m ± E_k / 2` instead of the eight sub-box centres (`lanes::faces`): a rule
/// of degree 3 (the mean of any cubic exact, and the spread of a linear function's values its
/// variance over the box, where the sub-box centres' spread is 3/4 of it). examples/band_rules.rs
/// measures them better than the eight in the mean up to half a cell (0.0017 against 0.0078 σ
/// at a quarter), in the variance up to a quarter of a cell (0.0051 against 0.0147 σ²), worse
/// past it (0.057 against 0.038 σ² at half a cell). In the filtering table fades of at least
/// 0.9 (0.38 of a cell for Perlin) did best: 0.95 made 3 rows worse, 0.85 and 0.8 7 and 8 worse.
const FACES_FROM: f64 = 0.9;

/// The six face centres' offsets from the centre, `+E_k / 2` then `−E_k / 2` (the last two
/// entries unused).
fn face_offsets(e: &[[f64; 3]; 3]) -> [[f64; 3]; 8] {
    std::array::from_fn(|j| {
        let sign = if j < 3 { 0.5 } else { -0.5 };
        std::array::from_fn(|i| if j < 6 { sign * e[j % 3][i] } else { 0.0 })
    })
}

/// One octave over the footprint from its eight sub-boxes (the value at each centre, and the
/// gradient where the input carries residual variance: `None` where it carries none): each sub-box faded by its own (half-size) fade; the mean of the eight; the linear
/// part the least-squares slope of the eight along each edge (`grad · e_k = 2 (mean of the
/// s_k = +1 half − mean of the other)`, the smallest such `grad`); the variance the eight's
/// spread plus what each sub-box's fade takes, less the linear part's. `None` where the edges
/// are degenerate (the centre rule then).
fn subsampled(
    rules: &Rules,
    stats: &Stats,
    p: &[Dist; 3],
    sub: &Sub,
    values: &[f64],
    grads: Option<[&[f64]; 3]>,
) -> Option<Dist> {
    let alpha = sub.alpha;
    let finite = |c: f64| if c.is_finite() { c } else { 0.0 };
    let means: [f64; 8] =
        std::array::from_fn(|j| alpha * finite(values[j]) + (1.0 - alpha) * stats.mean);
    let mean = means.iter().sum::<f64>() / 8.0;
    let du: [f64; 3] = std::array::from_fn(|k| {
        let (mut plus, mut minus) = (0.0, 0.0);
        for (j, m) in means.iter().enumerate() {
            if j >> k & 1 == 1 {
                plus += m / 4.0;
            } else {
                minus += m / 4.0;
            }
        }
        2.0 * (plus - minus)
    });
    let grad = rules.footprint.slope_with(du)?;
    let between = means.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / 8.0;
    let carried = grads.map_or(0.0, |grads| {
        (0..8)
            .map(|j| {
                (0..3)
                    .map(|i| finite(grads[i][j]).powi(2) * p[i].var)
                    .sum::<f64>()
            })
            .sum::<f64>()
            / 8.0
    });
    let within = (1.0 - alpha * alpha) * stats.var + alpha * alpha * carried;
    let var = super::rules::residual(between + within, rules.footprint.linear_var(grad));
    mean.is_finite().then_some(Dist {
        mean,
        grad,
        var: if var.is_finite() { var } else { 0.0 },
    })
}

/// A fade below which an octave is not sampled and counts as fully faded (the global mean and
/// variance): what level of detail's octave drop becomes here. The centre value's correlation
/// with the mean of a box that many cells wide is about `√α` (the box mean's variance is about
/// `α σ²`, its covariance with the centre `α σ²`), so sampling it would lower the octave's RMS
/// error by a factor of about `1 − α/2`: nothing worth a sample (docs/filtering.md's table moves
/// in no fourth digit between 10⁻⁶ and this). The GPU's `filter_octave.wgsl` uses the same.
const FADED: f64 = 1e-3;

/// A noise sample of `p` over the footprint (one lane of [`noise_lanes`]).
pub fn noise(rules: &Rules, s: &Sampler, p: &[Dist; 3], scratch: &mut LaneScratch) -> Dist {
    let mut out = [Dist::constant(0.0)];
    noise_lanes(
        Lanes::new(std::slice::from_ref(rules.footprint), 1),
        s,
        std::slice::from_ref(p),
        &mut out,
        scratch,
    );
    out[0]
}

/// The value of one octave (or noise sample) at a lane whose fade left it unsampled: fully
/// faded (the basis' global statistics), or a constant input (the plain sample).
fn unsampled(s: &Sampler, p: &[Dist; 3], alpha: f64) -> Option<Dist> {
    if alpha < FADED {
        return Some(Dist {
            mean: s.stats.mean,
            grad: [0.0; 3],
            var: s.stats.var,
        });
    }
    if alpha == 1.0 && p.iter().all(|c| c.var == 0.0 && c.grad == [0.0; 3]) {
        return Some(Dist::constant(s.table.sample(p.map(|c| c.mean))));
    }
    None
}

/// One sampled octave over the footprint from the noise's value and gradient at the centre.
fn sampled(stats: &Stats, p: &[Dist; 3], fade: &Fade, value: f64, g: [f64; 3]) -> Dist {
    let alpha = fade.alpha;
    let g = g.map(|c| if c.is_finite() { c } else { 0.0 });
    let grad = std::array::from_fn(|j| alpha * (0..3).map(|i| g[i] * p[i].grad[j]).sum::<f64>());
    let grad = super::rules::apply(&fade.damp, grad);
    let carried: f64 = (0..3).map(|i| g[i] * g[i] * p[i].var).sum();
    // The residual is what the fade takes beyond the linear part's expectation (`Fade::rest`),
    // not beyond this lane's linear part.
    let var = fade.rest + alpha * alpha * carried;
    Dist {
        mean: alpha * value + (1.0 - alpha) * stats.mean,
        grad,
        var: if var.is_finite() { var.max(0.0) } else { 0.0 },
    }
}

/// The footprints of a chunk of lanes: one per lane, or one for all.
#[derive(Clone, Copy)]
pub struct Lanes<'a> {
    footprints: &'a [Footprint],
    pub width: usize,
}

impl<'a> Lanes<'a> {
    /// # Panics
    /// If `footprints` is neither one long nor `width` long (a caller bug).
    pub fn new(footprints: &'a [Footprint], width: usize) -> Lanes<'a> {
        assert!(footprints.len() == 1 || footprints.len() == width);
        Lanes { footprints, width }
    }

    pub fn rules(&self, lane: usize) -> Rules<'a> {
        let i = if self.footprints.len() == 1 { 0 } else { lane };
        Rules {
            footprint: &self.footprints[i],
        }
    }
}

/// Working arrays of the lane rules, kept from chunk to chunk.
#[derive(Default)]
pub struct LaneScratch {
    q: Vec<[Dist; 3]>,
    fades: Vec<Fade>,
    which: Vec<u32>,
    sampled: Vec<usize>,
    weight: Vec<Dist>,
    octave: Vec<Dist>,
    same: Vec<bool>,
    samples: Samples,
    /// The runs of lanes sharing a fade, and a run's octave (`lanes.rs`).
    runs: Vec<Run>,
    kernel: super::lanes::Octave,
    /// A shared-fade Fbm's sum over its octaves, and its input's means.
    sum: super::lanes::Octave,
    centres: [Vec<f64>; 3],
}

/// An octave's two batches of samples: the value and gradient at `coords` (centres, and the
/// sub-box centres of inputs with residual variance), the value alone at `value_coords`.
#[derive(Default)]
struct Samples {
    coords: [Vec<f64>; 3],
    value: Vec<f64>,
    grad: [Vec<f64>; 3],
    value_coords: [Vec<f64>; 3],
    values: Vec<f64>,
    narrow: Vec<f32>,
}

impl Samples {
    fn clear(&mut self) {
        self.coords.iter_mut().for_each(Vec::clear);
        self.value_coords.iter_mut().for_each(Vec::clear);
    }

    /// Both batches, each one call of the SIMD kernels: the value and gradient in f64, the
    /// values alone in f32 where the sampler is narrow (its f32 error bounded by the precision
    /// analysis; sampling every noise in f32 moved lava's f32 filtered value by 1.6e-5 and a
    /// steep random graph's by 15 %, docs/filtering.md), else in f64.
    fn sample(&mut self, s: &Sampler) {
        let [x, y, z] = &self.coords;
        self.value.resize(x.len(), 0.0);
        self.grad.iter_mut().for_each(|g| g.resize(x.len(), 0.0));
        let [gx, gy, gz] = &mut self.grad;
        s.table
            .sample_value_grad_batch([x, y, z], &mut self.value, [gx, gy, gz]);
        let [x, y, z] = &self.value_coords;
        self.values.resize(x.len(), 0.0);
        if s.narrow {
            self.narrow.resize(x.len(), 0.0);
            s.table.sample_batch(x, y, z, &mut self.narrow);
            for (v, &n) in self.values.iter_mut().zip(&self.narrow) {
                *v = f64::from(n);
            }
        } else {
            s.table.sample_batch(x, y, z, &mut self.values);
        }
    }
}

/// A lane's fade: `α`, the damping of its slope (`Footprint::damp_matrix` of the `β`s), the
/// centre rule's residual variance, and in the sub-sampled band what [`subsampled`] needs.
#[derive(Clone, Copy)]
struct Fade {
    alpha: f64,
    damp: Option<[[f64; 3]; 3]>,
    /// The centre rule's residual: the noise's variance within the footprint is what the fade
    /// takes from the box mean, `(1 − α²) σ²` (the law of total variance, the box mean's
    /// variance being `α² σ²`); the linear part explains some of it, on average its
    /// expectation over the noise's gradients, `α² E|g|² Σ_i linear_var(D J_i)` (`D` the
    /// damping, `J_i` the input's linear parts, the gradient's components independent with
    /// the table's `grad_sq` each); the rest, the curvature's share, is residual. Taking out
    /// the lane's own linear part instead (as before) left a lane near the noise's extremum, its
    /// gradient small, the whole `(1 − α²) σ²`: examples/band_rules.rs measures the error of
    /// the total variance over a cube of 1/4 cell at 0.0098 σ² against 0.0317 σ² before (the
    /// variance's own spread 0.064 σ²), 0.0585 against 0.116 σ² at 1/2 cell.
    rest: f64,
    sub: Option<Sub>,
}

/// A sub-sampled lane's sub-box centres' offsets (from the footprint's edges in noise space)
/// and the fade of a half-size sub-box (functions of the footprint and the input's spread, so
/// shared like the fade).
#[derive(Clone, Copy)]
struct Sub {
    /// The sample points' offsets: the eight sub-box centres, or the six face centres first.
    offsets: [[f64; 3]; 8],
    alpha: f64,
    /// The six face centres instead of the eight sub-box centres ([`FACES_FROM`]).
    faces: bool,
}

impl Fade {
    /// The fade of `q` over the lane's footprint, its slope damping and, in the sub-sampled
    /// band, its sub-boxes.
    fn new(rules: &Rules, stats: &Stats, q: &[Dist; 3]) -> Fade {
        let (alpha, beta) = fade(rules, stats, q);
        let band = (SUB_BAND.0..=SUB_BAND.1).contains(&alpha);
        let damp = rules.footprint.damp_matrix(beta);
        let expected: f64 = q
            .iter()
            .map(|c| {
                let d = super::rules::apply(&damp, c.grad);
                rules.footprint.linear_var(d)
            })
            .sum::<f64>()
            * alpha
            * alpha
            * stats.grad_sq;
        Fade {
            alpha,
            damp,
            rest: super::rules::residual((1.0 - alpha * alpha) * stats.var, expected),
            sub: band.then(|| Sub::new(rules, stats, q, alpha)),
        }
    }
}

impl Fade {
    /// What a centre-sampled run of input `q`'s lanes shares (`lanes::sampled`).
    fn centre_run<'a>(&'a self, stats: &Stats, q: &[Dist; 3]) -> super::lanes::CentreRun<'a> {
        super::lanes::CentreRun {
            alpha: self.alpha,
            base: (1.0 - self.alpha) * stats.mean,
            rest: self.rest,
            jac: q.map(|c| c.grad),
            spread: q.map(|c| c.var),
            damp: self.damp.as_ref(),
        }
    }
}

impl Sub {
    /// What a value-only sub-sampled run's lanes share (`lanes::subsampled`).
    fn run<'a>(
        &self,
        stats: &Stats,
        fit: &'a [[f64; 3]; 3],
        quad: &'a [[f64; 3]; 3],
    ) -> super::lanes::SubRun<'a> {
        super::lanes::SubRun {
            alpha: self.alpha,
            base: (1.0 - self.alpha) * stats.mean,
            within: (1.0 - self.alpha * self.alpha) * stats.var,
            fit,
            quad,
        }
    }

    /// The sub-sampling of input `p` whose footprint's fade is `alpha`.
    fn new(rules: &Rules, stats: &Stats, p: &[Dist; 3], alpha: f64) -> Sub {
        let edges = noise_edges(rules, p);
        let l2 = edges.map(|e| dot(&e, &e) / 4.0);
        let v: f64 = p.iter().map(|c| c.var).sum();
        let faces = stats.faces && alpha >= FACES_FROM && v == 0.0;
        Sub {
            offsets: if faces {
                face_offsets(&edges)
            } else {
                sub_offsets(&edges)
            },
            alpha: fade_of(stats, l2, v).0,
            faces,
        }
    }

    /// The sample points' offsets from the centre.
    fn points(&self) -> &[[f64; 3]] {
        if self.faces {
            &self.offsets[..6]
        } else {
            &self.offsets
        }
    }
}

/// Per lane, whether its footprint and input spread (linear part, residual) equal the previous
/// lane's, as along any affine chain: its fade is then the previous lane's.
fn same_spread(lanes: Lanes, p: &[[Dist; 3]], same: &mut Vec<bool>) {
    same.clear();
    same.push(false);
    let one_footprint = lanes.footprints.len() == 1;
    same.extend(p.windows(2).enumerate().map(|(i, w)| {
        let spread = |q: &[Dist; 3]| (q.map(|c| c.grad), q.map(|c| c.var));
        spread(&w[0]) == spread(&w[1])
            && (one_footprint || lanes.footprints[i] == lanes.footprints[i + 1])
    }));
}

/// Each lane's fade of `p` (computed again only where `same` says the spread changed).
/// `fades` holds the distinct fades, `which[lane]` the index of the lane's (a fade is about
/// 20 numbers: along an affine chain one is made per chunk, not copied per lane).
fn lane_fades(
    lanes: Lanes,
    stats: &Stats,
    p: &[[Dist; 3]],
    same: &[bool],
    fades: &mut Vec<Fade>,
    which: &mut Vec<u32>,
) {
    fades.clear();
    which.clear();
    for (lane, q) in p.iter().enumerate() {
        if fades.is_empty() || !same[lane] {
            fades.push(Fade::new(&lanes.rules(lane), stats, q));
        }
        which.push(fades.len() as u32 - 1);
    }
}

/// [`noise`] at every lane of a chunk: each lane's fade, then one batch sample (the noise
/// kernels' SIMD value and gradient) of the lanes the fade leaves sampled.
pub fn noise_lanes(
    lanes: Lanes,
    s: &Sampler,
    p: &[[Dist; 3]],
    out: &mut [Dist],
    scratch: &mut LaneScratch,
) {
    let mut same = std::mem::take(&mut scratch.same);
    same_spread(lanes, p, &mut same);
    octave_lanes(lanes, s, p, &same, out, scratch);
    scratch.same = same;
}

/// How a run of lanes sharing a fade is sampled.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// The value and gradient at the centre (outside the sub-sampled band).
    Centre,
    /// The value alone at the eight sub-box centres (an input without residual variance).
    SubValues,
    /// The value and gradient at the eight sub-box centres (the gradient carries the input's
    /// residual).
    SubGrads,
}

/// Consecutive lanes (`todo[lanes]`) of one fade and [`Kind`], their samples from `at` in
/// their batch.
struct Run {
    fade: u32,
    kind: Kind,
    lanes: std::ops::Range<usize>,
    at: usize,
}

/// [`noise_lanes`] with each lane's [`same_spread`] given.
///
/// Lanes sharing a fade (any affine chain under one footprint: every lane of a bake's chunk)
/// form runs, each run's rule one structure-of-arrays kernel (`lanes.rs`). Two batches: the
/// noise's value and gradient at the centres (the slope needs the gradient) and at the sub-box
/// centres of lanes whose input carries residual variance (it goes through the gradient), the
/// value alone at the sub-box centres of the others (about half the cost).
fn octave_lanes(
    lanes: Lanes,
    s: &Sampler,
    p: &[[Dist; 3]],
    same: &[bool],
    out: &mut [Dist],
    scratch: &mut LaneScratch,
) {
    let LaneScratch {
        fades,
        which,
        sampled: todo,
        runs,
        samples,
        kernel: octave,
        ..
    } = scratch;
    lane_fades(lanes, &s.stats, p, same, fades, which);
    let fade_of_lane = |lane: usize| &fades[which[lane] as usize];
    todo.clear();
    for (lane, (o, q)) in out.iter_mut().zip(p).enumerate() {
        match unsampled(s, q, fade_of_lane(lane).alpha) {
            Some(d) => *o = d,
            None => todo.push(lane),
        }
    }
    if todo.is_empty() {
        return;
    }
    runs.clear();
    for (t, &lane) in todo.iter().enumerate() {
        let kind = match fade_of_lane(lane).sub {
            None => Kind::Centre,
            Some(_) if p[lane].iter().all(|c| c.var == 0.0) => Kind::SubValues,
            Some(_) => Kind::SubGrads,
        };
        match runs.last_mut() {
            Some(r) if r.fade == which[lane] && r.kind == kind => r.lanes.end += 1,
            _ => runs.push(Run {
                fade: which[lane],
                kind,
                lanes: t..t + 1,
                at: 0,
            }),
        }
    }
    samples.clear();
    let Samples {
        coords,
        value_coords,
        ..
    } = samples;
    for run in runs.iter_mut() {
        let run_lanes = &todo[run.lanes.clone()];
        let sub = fades[run.fade as usize].sub;
        match (run.kind, sub) {
            (Kind::Centre, _) => {
                run.at = coords[0].len();
                for (i, c) in coords.iter_mut().enumerate() {
                    c.extend(run_lanes.iter().map(|&l| p[l][i].mean));
                }
            }
            // Sub-box j of the run's lane k at `at + j * len + k`.
            (Kind::SubValues, Some(sub)) => {
                run.at = value_coords[0].len();
                for (i, c) in value_coords.iter_mut().enumerate() {
                    for o in sub.points() {
                        c.extend(run_lanes.iter().map(|&l| p[l][i].mean + o[i]));
                    }
                }
            }
            // Lane k's eight at `at + 8 k ..`.
            (_, sub) => {
                run.at = coords[0].len();
                let offsets = sub.expect("a sub-sampled run has its sub-boxes").offsets;
                for (i, c) in coords.iter_mut().enumerate() {
                    for &l in run_lanes {
                        c.extend(offsets.iter().map(|o| p[l][i].mean + o[i]));
                    }
                }
            }
        }
    }
    samples.sample(s);
    let samples = &*samples;
    for run in runs.iter() {
        let fade = &fades[run.fade as usize];
        let run_lanes = &todo[run.lanes.clone()];
        let first = run_lanes[0];
        let (rules, q) = (lanes.rules(first), &p[first]);
        if run.kind == Kind::SubGrads {
            let sub = fade
                .sub
                .as_ref()
                .expect("a sub-sampled run has its sub-boxes");
            for (k, &lane) in run_lanes.iter().enumerate() {
                let r = run.at + 8 * k..run.at + 8 * k + 8;
                let grads = [0, 1, 2].map(|i| &samples.grad[i][r.clone()]);
                out[lane] = subsampled(
                    &rules,
                    &s.stats,
                    &p[lane],
                    sub,
                    &samples.value[r.clone()],
                    Some(grads),
                )
                .unwrap_or_else(|| degenerate(s, &p[lane], fade, samples, Kind::SubGrads, r.start));
            }
            continue;
        }
        run_kernel(&rules, s, q, fade, run, run_lanes.len(), samples, octave);
        for (k, &lane) in run_lanes.iter().enumerate() {
            out[lane] = octave
                .get(k)
                .unwrap_or_else(|| fallback(s, &p[lane], fade, samples, run, k));
        }
    }
}

/// A centre-sampled or value-only sub-sampled run's kernel (`lanes.rs`) over its `n` lanes.
#[allow(clippy::too_many_arguments)]
fn run_kernel(
    rules: &Rules,
    s: &Sampler,
    q: &[Dist; 3],
    fade: &Fade,
    run: &Run,
    n: usize,
    samples: &Samples,
    octave: &mut super::lanes::Octave,
) {
    let stats = &s.stats;
    let quad = rules.footprint.quad();
    match (run.kind, &fade.sub, rules.footprint.fit()) {
        (Kind::SubValues, Some(sub), Some(fit)) => {
            let r = run.at..run.at + sub.points().len() * n;
            let shared = sub.run(stats, fit, quad);
            if sub.faces {
                super::lanes::faces(&shared, &samples.values[r], n, octave);
            } else {
                super::lanes::subsampled(&shared, &samples.values[r], n, octave);
            }
        }
        (Kind::SubValues, _, _) => octave.none(n),
        _ => {
            let shared = fade.centre_run(stats, q);
            let r = run.at..run.at + n;
            let grad = [0, 1, 2].map(|i| &samples.grad[i][r.clone()]);
            super::lanes::sampled(&shared, &samples.value[r.clone()], grad, octave);
        }
    }
}

/// Lane `k` of a run whose kernel left it to the scalar rules: the centre rule's edge-by-edge
/// covariance for a non-finite slope; for a degenerate footprint or a non-finite sub-box
/// mean, the centre rule at the first sub-box centre.
fn fallback(
    s: &Sampler,
    q: &[Dist; 3],
    fade: &Fade,
    samples: &Samples,
    run: &Run,
    k: usize,
) -> Dist {
    match run.kind {
        Kind::Centre => {
            let i = run.at + k;
            let g = [0, 1, 2].map(|c| samples.grad[c][i]);
            sampled(&s.stats, q, fade, samples.value[i], g)
        }
        kind => degenerate(s, q, fade, samples, kind, run.at + k),
    }
}

/// A sub-sampled lane whose sub-boxes give no estimate (degenerate edges, a non-finite
/// mean): the first sub-box centre stands for the centre (they agree along any zero edge; a
/// degenerate box has no volume to split). `first`: that centre's index in its batch.
fn degenerate(
    s: &Sampler,
    q: &[Dist; 3],
    fade: &Fade,
    samples: &Samples,
    kind: Kind,
    first: usize,
) -> Dist {
    let c = if kind == Kind::SubValues {
        &samples.value_coords
    } else {
        &samples.coords
    };
    let (value, g) = s
        .table
        .sample_value_grad::<f64>([c[0][first], c[1][first], c[2][first]]);
    sampled(&s.stats, q, fade, value, g)
}

/// At most this many cells per axis, and in all, for [`white`]'s mixture: a wider box takes
/// the fade (towards the global mean) instead.
const WHITE_CELLS: usize = 64;

/// White noise (one random value per unit cell) over the footprint, exactly as a mixture of
/// the cells the input reaches: per axis the probability of each cell index `n = floor(X_i)`
/// (`P(X_i ≥ n) − P(X_i ≥ n + 1)`, the exact step means; for an integer-valued component, as
/// `integers.rs` marks them, the lattice's two-point law where the spread allows it, else
/// `round(Y)` with Sheppard's correction, as `Rules::lattice_mod`), the axes taken as
/// independent (exact where each depends on its own box axis), and the mean, second moment and
/// slopes summed over the cells. `None` for wider boxes or a non-finite input: the fade rule
/// then (a white noise's fade is total at any width, so a box inside one cell would otherwise
/// lose its cell's value).
pub fn white(rules: &Rules, s: &Sampler, p: &[Dist; 3], integer: [bool; 3]) -> Option<Dist> {
    let axes: [Option<Cells>; 3] = std::array::from_fn(|i| cells(rules, &p[i], integer[i]));
    let [x, y, z] = axes;
    let (x, y, z) = (x?, y?, z?);
    if x.count * y.count * z.count > WHITE_CELLS {
        return None;
    }
    let (mut mean, mut square, mut slope) = (0.0, 0.0, [0.0; 3]);
    for i in 0..x.count {
        for j in 0..y.count {
            for k in 0..z.count {
                let centre = [x.first + i as f64, y.first + j as f64, z.first + k as f64];
                let w: f64 = s.table.sample(centre.map(|c| c + 0.5));
                let (px, py, pz) = (x.prob[i], y.prob[j], z.prob[k]);
                mean += px * py * pz * w;
                square += px * py * pz * w * w;
                slope[0] += x.slope[i] * py * pz * w;
                slope[1] += px * y.slope[j] * pz * w;
                slope[2] += px * py * z.slope[k] * w;
            }
        }
    }
    let grad: [f64; 3] = std::array::from_fn(|j| (0..3).map(|i| slope[i] * p[i].grad[j]).sum());
    let var = super::rules::residual(square - mean * mean, rules.footprint.linear_var(grad));
    mean.is_finite().then_some(Dist { mean, grad, var })
}

/// The cells one input component reaches: indices `first..first + count`, each with its
/// probability and its derivative along the component's mean.
struct Cells {
    first: f64,
    count: usize,
    prob: [f64; WHITE_CELLS],
    slope: [f64; WHITE_CELLS],
}

fn cells(rules: &Rules, d: &Dist, integer: bool) -> Option<Cells> {
    use super::moments::{density, ramp_mean, Spread};
    let mu = d.mean;
    if !mu.is_finite() {
        return None;
    }
    let mut c = Cells {
        first: mu.floor(),
        count: 1,
        prob: [0.0; WHITE_CELLS],
        slope: [0.0; WHITE_CELLS],
    };
    c.prob[0] = 1.0;
    if d.is_constant() {
        return Some(c);
    }
    let widths = rules.footprint.widths(d.grad);
    // The cell edges relative to the value (an integer-valued K = round(Y): edges at n ± 1/2).
    let (spread, shift, residual) = if integer {
        let t = rules.total_var(d);
        let q = mu - c.first;
        if t <= q * (1.0 - q) + 1e-12 {
            c.count = 2;
            c.prob[..2].copy_from_slice(&[1.0 - q, q]);
            c.slope[..2].copy_from_slice(&[-1.0, 1.0]);
            return Some(c);
        }
        let r = (d.var - 1.0 / 12.0).max(0.0);
        (Spread::new(widths, r), 0.5, r)
    } else {
        (Spread::new(widths, d.var), 0.0, d.var)
    };
    let half = widths.iter().sum::<f64>() / 2.0 + (6.0 * residual).sqrt();
    let first = (mu + shift - half).floor();
    let last = (mu + shift + half).floor();
    // (NaN-safe: a NaN count is refused too.)
    if (last - first).partial_cmp(&(WHITE_CELLS as f64)) != Some(std::cmp::Ordering::Less) {
        return None;
    }
    c.first = first;
    c.count = (last - first) as usize + 1;
    // P(cell n) = P(X ≥ n − shift) − P(X ≥ n + 1 − shift), X = mu + S.
    let at_least = |e: f64| (ramp_mean(mu - e, &spread, 0), density(mu - e, &spread));
    let mut below = at_least(first - shift);
    for n in 0..c.count {
        let above = at_least(first + n as f64 + 1.0 - shift);
        c.prob[n] = below.0 - above.0;
        c.slope[n] = below.1 - above.1;
        below = above;
    }
    Some(c)
}

/// Cellular noise over a footprint within about one cell in noise space (its edges' lengths
/// there at most `SUB_SPAN`): the documented fallback of sub-footprint evaluation. A cellular
/// value has kinks and jumps at cell borders (`F1`'s ridges, `CellValue`'s steps) that the
/// fade, fitted to its average correlation, does not see: a box inside one cell would lose its
/// cell's value. The value and gradient are taken at the centres of the footprint's eight
/// half-size sub-boxes: the mean of the eight values, the mean gradient as the linear part (the
/// chain rule through the input's), and as variance the spread of the eight values plus each
/// sub-box's own linear variance (a quarter of the whole box's), plus the input's residual
/// carried through the gradient. `None` for a larger footprint or a non-finite input: the fade
/// then, which averages many cells.
pub fn cellular(rules: &Rules, s: &Sampler, p: &[Dist; 3]) -> Option<Dist> {
    const SUB_SPAN: f64 = 1.0;
    let noise_edges = noise_edges(rules, p);
    let longest = noise_edges.iter().map(|e| dot(e, e)).fold(0.0, f64::max);
    let centre = p.map(|c| c.mean);
    let small = longest <= SUB_SPAN * SUB_SPAN; // false for NaN
    if !small || centre.iter().any(|c| !c.is_finite()) {
        return None;
    }
    let centres = sub_centres(p, &noise_edges);
    let coords: [[f64; 8]; 3] = std::array::from_fn(|i| centres.map(|c| c[i]));
    let (mut value, mut grad) = ([0.0; 8], [[0.0; 8]; 3]);
    let [gx, gy, gz] = &mut grad;
    s.table.sample_value_grad_batch(
        [&coords[0], &coords[1], &coords[2]],
        &mut value,
        [gx.as_mut_slice(), gy.as_mut_slice(), gz.as_mut_slice()],
    );
    let mean = value.iter().sum::<f64>() / 8.0;
    let finite = |c: f64| if c.is_finite() { c } else { 0.0 };
    let mut g_mean = [0.0; 3];
    let (mut within, mut carried) = (0.0, 0.0);
    let [gx, gy, gz] = &grad;
    for ((&x, &y), &z) in gx.iter().zip(gy).zip(gz) {
        let g = [finite(x), finite(y), finite(z)];
        for (m, gi) in g_mean.iter_mut().zip(g) {
            *m += gi / 8.0;
        }
        let slope: [f64; 3] = std::array::from_fn(|a| (0..3).map(|i| g[i] * p[i].grad[a]).sum());
        within += rules.footprint.linear_var(slope) / 4.0 / 8.0;
        carried += (0..3).map(|i| g[i] * g[i] * p[i].var).sum::<f64>() / 8.0;
    }
    let between = value.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / 8.0;
    let slope: [f64; 3] = std::array::from_fn(|a| (0..3).map(|i| g_mean[i] * p[i].grad[a]).sum());
    let total = between + within;
    let var = super::rules::residual(total, rules.footprint.linear_var(slope)) + carried;
    mean.is_finite().then_some(Dist {
        mean,
        grad: slope,
        var: if var.is_finite() { var } else { 0.0 },
    })
}

/// The analytic gradient of the noise at `p` over the footprint: faded like the value, the
/// lost part as residual variance (its own linear part is left out: second derivatives).
pub fn noise_gradient(rules: &Rules, s: &Sampler, p: &[Dist; 3], scale: f64) -> [Dist; 3] {
    let m = p.map(|c| c.mean);
    let g: [f64; 3] = s.table.sample_grad(m);
    let (alpha, _) = fade(rules, &s.stats, p);
    let var = (1.0 - alpha * alpha) * s.stats.grad_sq * scale * scale;
    g.map(|c| Dist {
        mean: alpha * c * scale,
        grad: [0.0; 3],
        var: if var.is_finite() { var } else { 0.0 },
    })
}

/// The samplers of a fractal sum's octaves: the instruction's table, or for a tiled sum each
/// octave's periodic copy (the base table's statistics either way).
pub struct FractalSamplers<'a> {
    pub octaves: &'a Octaves,
    pub base: Sampler<'a>,
    pub periodic: Option<&'a [NoiseTable]>,
    /// The share of the summed amplitude whose value-only samples may be f32
    /// (`Tape::narrow_samples`).
    pub narrow: f64,
}

impl<'a> FractalSamplers<'a> {
    /// Each octave's sampler, frequency and amplitude. Octave `k` samples its values in f32
    /// where the octaves from `k` on hold at most the `narrow` share of the summed amplitude
    /// (the precision analysis' bound then holds whichever of them a footprint sub-samples).
    fn each(&self) -> impl Iterator<Item = (Sampler<'a>, f64, f64)> + '_ {
        let octaves = &self.octaves;
        let total: f64 = octaves.amplitudes.iter().map(|a| a.abs()).sum();
        let mut rest = total;
        (octaves.frequencies.iter().zip(&octaves.amplitudes))
            .enumerate()
            .map(move |(k, (&freq, &amp))| {
                let narrow = self.narrow > 0.0 && rest <= self.narrow * total;
                rest -= amp.abs();
                let table = self.periodic.map_or(self.base.table, |tables| &tables[k]);
                let sampler = Sampler {
                    table,
                    narrow,
                    ..self.base
                };
                (sampler, freq, amp)
            })
    }
}

/// A fractal sum over the footprint at every lane of a chunk: every octave by
/// [`noise_lanes`] on the scaled input, shaped by the style's rules, summed (independent
/// octaves: means, linear parts and variances add).
pub fn fractal_lanes(
    lanes: Lanes,
    shapes: &Shapes,
    f: &FractalSamplers,
    style: Style,
    p: &[[Dist; 3]],
    out: &mut [Dist],
    scratch: &mut LaneScratch,
) {
    out.fill(Dist::constant(0.0));
    let mut q = std::mem::take(&mut scratch.q);
    let mut weight = std::mem::take(&mut scratch.weight);
    let mut n = std::mem::take(&mut scratch.octave);
    n.clear();
    n.resize(p.len(), Dist::constant(0.0));
    weight.clear();
    weight.resize(p.len(), Dist::constant(1.0));
    let mut same = std::mem::take(&mut scratch.same);
    same_spread(lanes, p, &mut same);
    // Every lane's input has the same spread (one footprint, an affine chain): each octave's
    // fade is one for the chunk.
    let shared = style == Style::Fbm && same.iter().skip(1).all(|&s| s);
    let mut acc = std::mem::take(&mut scratch.sum);
    acc.zero(p.len());
    // The input's means as one array per component, read once for every octave.
    let mut centres = std::mem::take(&mut scratch.centres);
    for (i, c) in centres.iter_mut().enumerate() {
        c.clear();
        if shared {
            c.extend(p.iter().map(|q| q[i].mean));
        }
    }
    for (sampler, freq, amp) in f.each() {
        let octave = Scaled {
            p,
            centres: &centres,
            freq,
            amp,
        };
        if shared && shared_octave(lanes, &sampler, octave, &mut acc, scratch) {
            continue;
        }
        q.clear();
        q.extend(p.iter().map(|v| v.map(|c| c.scale(freq))));
        octave_lanes(lanes, &sampler, &q, &same, &mut n, scratch);
        if shared {
            // The sum's `add` of each octave `scale(amp)`, as everywhere below.
            n.iter()
                .enumerate()
                .for_each(|(lane, n)| acc.add(lane, amp, n));
            continue;
        }
        if style == Style::Fbm {
            for (lane, (sum, n)) in out.iter_mut().zip(&n).enumerate() {
                *sum = lanes.rules(lane).add(sum, &n.scale(amp));
            }
            continue;
        }
        for (lane, (sum, n)) in out.iter_mut().zip(&n).enumerate() {
            let rules = lanes.rules(lane);
            let shaped = shape(&rules, shapes, style, n, &mut weight[lane]);
            *sum = rules.add(sum, &shaped.scale(amp));
        }
    }
    if shared {
        out.iter_mut()
            .enumerate()
            .for_each(|(lane, o)| *o = acc.dist(lane));
    }
    scratch.q = q;
    scratch.weight = weight;
    scratch.octave = n;
    scratch.same = same;
    scratch.sum = acc;
    scratch.centres = centres;
}

/// A fractal's input at one octave: `freq · p`, the input's means one array per component
/// (`centres`), and the octave's amplitude.
#[derive(Clone, Copy)]
struct Scaled<'a> {
    p: &'a [[Dist; 3]],
    centres: &'a [Vec<f64>; 3],
    freq: f64,
    amp: f64,
}

/// One Fbm octave added to `sum` at every lane of a chunk whose lanes share one fade (the
/// same footprint and input spread), without per-lane fades or gathers: the same arithmetic as
/// [`octave_lanes`] then the sum's `add` (bit for bit), the sub-box values laid out sub-box by
/// sub-box, the sum kept as structure of arrays. `false` (nothing done) where the octave needs [`octave_lanes`]' other cases: an
/// input with residual variance in the sub-sampled band, a constant input at no fade.
fn shared_octave(
    lanes: Lanes,
    s: &Sampler,
    Scaled {
        p,
        centres,
        freq,
        amp,
    }: Scaled,
    sum: &mut super::lanes::Octave,
    scratch: &mut LaneScratch,
) -> bool {
    let rules = lanes.rules(0);
    let stats = &s.stats;
    let q0 = p[0].map(|c| c.scale(freq));
    let fade = Fade::new(&rules, stats, &q0);
    if fade.alpha < FADED {
        let faded = unsampled(s, &q0, fade.alpha).expect("faded");
        (0..p.len()).for_each(|lane| sum.add(lane, amp, &faded));
        return true;
    }
    let constant = q0.iter().all(|c| c.var == 0.0 && c.grad == [0.0; 3]);
    let value_only = q0.iter().all(|c| c.var == 0.0);
    if (fade.alpha == 1.0 && constant) || (fade.sub.is_some() && !value_only) {
        return false;
    }
    let n = p.len();
    let LaneScratch {
        samples,
        kernel: octave,
        ..
    } = scratch;
    samples.clear();
    let kind = match &fade.sub {
        None => {
            for (i, c) in samples.coords.iter_mut().enumerate() {
                c.extend(centres[i].iter().map(|m| freq * m));
            }
            Kind::Centre
        }
        // Sub-box j of lane i at `j * n + i`.
        Some(sub) => {
            for (i, c) in samples.value_coords.iter_mut().enumerate() {
                for offset in sub.points() {
                    c.extend(centres[i].iter().map(|m| freq * m + offset[i]));
                }
            }
            Kind::SubValues
        }
    };
    samples.sample(s);
    let samples = &*samples;
    let run = Run {
        fade: 0,
        kind,
        lanes: 0..n,
        at: 0,
    };
    run_kernel(&rules, s, &q0, &fade, &run, n, samples, octave);
    if !sum.add_scaled(amp, octave) {
        for lane in (0..n).filter(|&lane| !octave.holds(lane)) {
            let d = fallback(s, &q0, &fade, samples, &run, lane);
            sum.add(lane, amp, &d);
        }
    }
    true
}

/// One octave shaped by the fractal's style (`weight`: ridged's running weight).
fn shape(rules: &Rules, shapes: &Shapes, style: Style, n: &Dist, weight: &mut Dist) -> Dist {
    match style {
        Style::Fbm => *n,
        Style::Turbulence => rules.unary(shapes, UnaryOp::Abs, n),
        Style::Billow => {
            let a = rules.unary(shapes, UnaryOp::Abs, n);
            rules.sub(&a.scale(2.0), &Dist::constant(1.0))
        }
        Style::Ridged { offset, sharpness } => {
            let a = rules.unary(shapes, UnaryOp::Abs, n);
            let ridge = rules.sub(&Dist::constant(offset), &a);
            let ridge = rules.binary(shapes, BinaryOp::Max, &ridge, &Dist::constant(0.0));
            let ridge = rules.binary(shapes, BinaryOp::Pow, &ridge, &Dist::constant(sharpness));
            let signal = rules.mul(&ridge, weight);
            let doubled = signal.scale(2.0);
            let w = rules.binary(shapes, BinaryOp::Max, &doubled, &Dist::constant(0.0));
            *weight = rules.binary(shapes, BinaryOp::Min, &w, &Dist::constant(1.0));
            signal
        }
    }
}

/// The gradient of a fractal sum over the footprint: Fbm as the sum of the octaves' faded
/// gradients; the shaped styles by their point gradient faded by the coarsest octave's fade
/// (documented approximation).
pub fn fractal_gradient(
    rules: &Rules,
    f: &FractalSamplers,
    style: Style,
    p: &[Dist; 3],
    point: [f64; 3],
) -> [Dist; 3] {
    if style == Style::Fbm {
        let mut out = [Dist::constant(0.0); 3];
        for (sampler, freq, amp) in f.each() {
            let q = p.map(|c| c.scale(freq));
            let g = noise_gradient(rules, &sampler, &q, amp * freq);
            for (o, g) in out.iter_mut().zip(&g) {
                *o = rules.add(o, g);
            }
        }
        return out;
    }
    let alpha = match f.octaves.frequencies.first() {
        Some(&freq) => fade(rules, &f.base.stats, &p.map(|c| c.scale(freq))).0,
        None => 1.0,
    };
    point.map(|c| Dist::constant(alpha * c))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::{Basis, NoiseTable};

    #[test]
    fn face_centres_are_exact_for_a_linear_function() {
        // The six faces' rule (`lanes::faces`) on `f(y) = 0.3 + c · y` in noise space, the
        // input `y = J x` affine in the position: the mean is f at the centre, the slope
        // `Jᵀ c`, no residual (their spread is the linear part's variance exactly).
        let table = NoiseTable::new(Basis::Perlin, 3);
        let stats = stats(&table);
        let fp = Footprint::from_sides([0.08, 0.05, 0.1]).unwrap();
        let rules = Rules { footprint: &fp };
        let jac = [[2.0, 0.1, 0.0], [-0.2, 3.0, 0.4], [0.0, 0.3, 1.5]];
        let q: [Dist; 3] = std::array::from_fn(|i| Dist {
            mean: [1.2, -3.4, 5.6][i],
            grad: jac[i],
            var: 0.0,
        });
        let fade = Fade::new(&rules, &stats, &q);
        let sub = fade.sub.expect("in the band");
        assert!(sub.faces && sub.points().len() == 6, "{}", fade.alpha);
        let c = [0.7, -1.1, 0.25];
        let f = |y: [f64; 3]| 0.3 + dot(&c, &y);
        let values: Vec<f64> = sub
            .points()
            .iter()
            .map(|o| f(std::array::from_fn(|i| q[i].mean + o[i])))
            .collect();
        let mut out = super::super::lanes::Octave::default();
        let run = sub.run(&stats, fp.fit().unwrap(), fp.quad());
        super::super::lanes::faces(&run, &values, 1, &mut out);
        let d = out.get(0).expect("finite");
        assert!((d.mean - f(q.map(|x| x.mean))).abs() < 1e-12, "{d:?}");
        for (j, g) in d.grad.iter().enumerate() {
            let want: f64 = (0..3).map(|i| c[i] * jac[i][j]).sum();
            assert!((g - want).abs() < 1e-9 * want.abs().max(1.0), "{d:?}");
        }
        assert!(d.var.abs() < 1e-12, "{d:?}");
    }

    /// The lane kernels (`lanes.rs`) against the scalar rules they replace for a run
    /// (`subsampled` without gradients, `sampled`): the same estimates to rounding, at random
    /// values, gradients and footprints of a run of 13 lanes.
    #[test]
    fn lane_kernels_agree_with_the_scalar_rules() {
        let table = NoiseTable::new(Basis::Perlin, 3);
        let stats = stats(&table);
        let mut rng = crate::noise::SplitMix64::new(47);
        let mut next =
            |lo: f64, hi: f64| lo + (hi - lo) * (rng.next_u64() >> 11) as f64 / 2f64.powi(53);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-3);
        let agree = |case: usize, got: Dist, want: Dist| {
            assert!(
                close(got.mean, want.mean) && close(got.var, want.var),
                "{case}: {got:?} vs {want:?}"
            );
            assert!(
                (0..3).all(|k| close(got.grad[k], want.grad[k])),
                "{case}: {got:?} vs {want:?}"
            );
        };
        for case in 0..40 {
            let side = [0.01, 0.3, 1.0, 4.0][case % 4] * next(0.5, 2.0);
            let fp = Footprint::from_sides([side, side * next(0.2, 1.0), side]).unwrap();
            let rules = Rules { footprint: &fp };
            let jac: [[f64; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    if i == j {
                        next(1.0, 8.0)
                    } else {
                        next(-0.5, 0.5)
                    }
                })
            });
            let spread = if case % 3 == 0 {
                [0.0; 3]
            } else {
                [next(0.0, 0.1), 0.0, next(0.0, 0.1)]
            };
            let q: [Dist; 3] = std::array::from_fn(|i| Dist {
                mean: next(-9.0, 9.0),
                grad: jac[i],
                var: spread[i],
            });
            let (alpha, beta) = fade(&rules, &stats, &q);
            let mut f = Fade::new(&rules, &stats, &q);
            assert_eq!((f.alpha, f.damp), (alpha, fp.damp_matrix(beta)));
            f.sub = Some(Sub::new(&rules, &stats, &q, 0.5));
            let n = 13;
            let value: Vec<f64> = (0..8 * n).map(|_| next(-1.0, 1.0)).collect();
            let grad: [Vec<f64>; 3] =
                std::array::from_fn(|_| (0..n).map(|_| next(-3.0, 3.0)).collect());
            let mut out = super::super::lanes::Octave::default();
            let centre = f.centre_run(&stats, &q);
            super::super::lanes::sampled(
                &centre,
                &value[..n],
                [&grad[0], &grad[1], &grad[2]],
                &mut out,
            );
            for i in 0..n {
                let want = sampled(
                    &stats,
                    &q,
                    &f,
                    value[i],
                    [grad[0][i], grad[1][i], grad[2][i]],
                );
                agree(case, out.get(i).expect("finite"), want);
            }
            let sub = f.sub.unwrap();
            let run = sub.run(&stats, fp.fit().unwrap(), fp.quad());
            super::super::lanes::subsampled(&run, &value, n, &mut out);
            for i in 0..n {
                let eight: [f64; 8] = std::array::from_fn(|j| value[j * n + i]);
                let want = subsampled(&rules, &stats, &q, &sub, &eight, None).expect("an estimate");
                agree(case, out.get(i).expect("finite"), want);
            }
        }
    }
}
