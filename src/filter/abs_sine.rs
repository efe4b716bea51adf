//! `|sin X|` and `|cos X|` over a footprint (the fused `Abs(Sin(x))`, `fusions.rs`): where `X`'s
//! support keeps to one side of the sine's zeros, `±sin X` by the `Sin` rule; else the Fourier
//! series of `|sin|` over `X`'s characteristic function, summed for a chunk's lanes at once
//! ([`SeriesLanes`], a loop over blocks of lanes compiled per CPU with `lanes.rs`' targets);
//! where the series cannot converge, `tape.rs` takes the plain rules.

use super::lanes::lane_targets;
use super::rules::{Dist, Rules};
use super::trig;

/// The most terms the `|sin|` series takes ([`Rules::abs_sin_plan`]).
pub(crate) const SERIES_TERMS: usize = 64;

/// [`Rules::abs_sin_plan`]: the answer, or the series to sum.
pub(crate) enum AbsSinPlan {
    Done(Option<Dist>),
    Series(SeriesLane),
}

/// The inputs of one lane's `|sin|` series: `sin 2μ`, `cos 2μ`, the footprint's widths of
/// the argument and their sines and cosines, `e^(−2σ²)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SeriesLane {
    pub s1: f64,
    pub c1: f64,
    pub widths: [f64; 3],
    pub steps: [(f64, f64); 3],
    pub q: f64,
}

impl SeriesLane {
    /// The series' inputs for `X = μ + Σ a_k U_k + σZ` (`widths` the `a_k`, `var` σ²).
    fn new(mean: f64, widths: [f64; 3], var: f64) -> SeriesLane {
        let (s1, c1) = trig::sin_cos(2.0 * mean);
        SeriesLane {
            s1,
            c1,
            widths,
            steps: widths.map(trig::sin_cos),
            q: (-2.0 * var).exp(),
        }
    }
}

impl Rules<'_> {
    /// `|sin X|` (or `|cos X|` with `cos`) over the footprint from `X` itself. Where `X`'s
    /// support keeps to one side of the sine's zeros ([`one_sided`]), `±sin X` by the `Sin`
    /// rule. Else by the Fourier series `|sin x| = 2/π − (4/π) Σ_m cos(2 m x) / (4 m² − 1)`
    /// and `X`'s characteristic function (the `Sin` rule's: exact for the linear part, Gaussian
    /// residual): exact where `X` is affine, where the composition of the two rules treats the
    /// sine's arcsine-shaped spread as unimodal (`E|sin X|` of a wide phase is 2/π, not
    /// `0.82 σ`). Here the answer where there is no series to sum (`Done`: a constant,
    /// one-sided, a line, or `None` where the spread is too small for the series to converge
    /// in [`SERIES_TERMS`] terms, the plain rules then being accurate), else the series'
    /// inputs, which [`SeriesLanes`] sums for a chunk's lanes at once and
    /// [`Rules::abs_sin_finish`] completes.
    pub(crate) fn abs_sin_plan(&self, x: &Dist, cos: bool) -> AbsSinPlan {
        if x.is_constant() || !x.mean.is_finite() {
            return AbsSinPlan::Done(None);
        }
        let widths = self.footprint.widths(x.grad);
        // A support on one side of the sine's zeros: `|sin X| = ±sin X` there, whose rule is
        // exact for the same model (linear part, Gaussian residual), without a series.
        // The sign is the mean's: `sin X` keeps it over such a support (each sinc of its
        // attenuation is positive there, its half-widths below π/2).
        if one_sided(x.mean, &widths, x.var, cos) {
            let s = self.sin_cos_over(x, widths, cos);
            return AbsSinPlan::Done(Some(if s.mean < 0.0 { s.scale(-1.0) } else { s }));
        }
        // Where even the last term's damping bound (|sinc| ≤ 1/|m a|) is not below the
        // tolerance, the series cannot converge: leave at once.
        // (min(1/|m a|, 1) is 1/max(|m a|, 1): one division for the three; no `exp` without a
        // residual.)
        let last = SERIES_TERMS as f64;
        let residual = if x.var == 0.0 {
            1.0
        } else {
            (-2.0 * last * last * x.var).exp()
        };
        let bound = residual
            / widths
                .iter()
                .map(|&a| (last * a).abs().max(1.0))
                .product::<f64>();
        if bound.is_nan() || bound >= 1e-7 {
            // One linear width (a line through the footprint, the residual too small for the
            // series): the exact box mean by the antiderivative instead.
            let mut live = widths.iter().copied().filter(|&a| a > 0.0);
            return AbsSinPlan::Done(match (live.next(), live.next()) {
                (Some(a), None) if a.is_finite() => Some(self.abs_sin_line(x, a, cos)),
                _ => None,
            });
        }
        // cos(2mμ), sin(2mμ) and each sin(m a_k) by angle addition from m = 1 (one sin_cos per
        // angle, not per term); e^(−2m²σ²) as a running product.
        AbsSinPlan::Series(SeriesLane::new(x.mean, widths, x.var))
    }

    /// [`Rules::abs_sin_plan`]'s answer from its series' sums (`series`, `slope`, `Re φ(2)`),
    /// `None` where the series did not converge.
    pub(crate) fn abs_sin_finish(
        &self,
        x: &Dist,
        cos: bool,
        sums: Option<(f64, f64, f64)>,
    ) -> Option<Dist> {
        let (series, slope, re2) = sums?;
        let pi = std::f64::consts::PI;
        let mean = 2.0 / pi - 4.0 / pi * series;
        Some(self.abs_sin_out(x, mean, 4.0 / pi * slope, re2, cos))
    }
}

/// How many standard deviations of a Gaussian residual [`one_sided`] keeps clear of a
/// zero: past 5.5σ, `E[(σZ − 5.5σ)⁺] < 4·10⁻⁹ σ`, what `±sin X` then errs from `|sin X|`.
const ONE_SIDED_SIGMAS: f64 = 5.5;

/// Whether `X = μ + Σ a_k U_k + σZ` keeps to one side of the zeros of `sin X` (`cos X` with
/// `cos`): the uniform part's half-support `Σ |a_k| / 2` and [`ONE_SIDED_SIGMAS`] residual
/// deviations short of the nearest multiple of π from `μ` (`μ + π/2` for the cosine).
fn one_sided(mean: f64, widths: &[f64; 3], var: f64, cos: bool) -> bool {
    let pi = std::f64::consts::PI;
    let x = if cos { mean + pi / 2.0 } else { mean };
    let reach = widths.iter().map(|a| a.abs()).sum::<f64>() / 2.0 + ONE_SIDED_SIGMAS * var.sqrt();
    // The distance from x to the nearest zero kπ, to within |x| · 2⁻⁵² (the rounding of kπ):
    // a phase past 10⁶ is left to the series, where that error could reach a useful margin.
    // k = x/π rounded (ties to even) by adding and taking away 1.5 · 2⁵², as `trig` does: no
    // division, no libm `round`; exact where it matters, |x| < 10⁶.
    let k = (x * std::f64::consts::FRAC_1_PI + trig::ROUNDER) - trig::ROUNDER;
    let distance = (x - k * pi).abs();
    reach.is_finite() && x.abs() < 1e6 && reach < distance
}

/// The `|sin|` series of [`Rules::abs_sin_plan`] at many lanes (a chunk's lanes of
/// one fused `|sin|`): each lane's inputs pushed, then summed [`SERIES_BLOCK`] lanes at a time,
/// term by term until all of a block's have converged, a lane that has kept as it is. The same
/// operations per lane as one lane alone, so a batch and `eval_point` get the same bits.
#[derive(Default)]
pub(crate) struct SeriesLanes {
    /// The chunk lane each series lane stands for.
    pub lane: Vec<u32>,
    inputs: Vec<SeriesLane>,
    /// Per lane its sum, slope sum and `Re φ(2)`, `None` where the series did not converge.
    sums: Vec<Option<(f64, f64, f64)>>,
}

/// How many lanes [`SeriesLanes`] sums together: one AVX-512 register of f64.
const SERIES_BLOCK: usize = 8;

impl SeriesLanes {
    /// No lanes (allocations kept).
    pub(crate) fn clear(&mut self) {
        self.lane.clear();
        self.inputs.clear();
    }

    /// Adds chunk lane `lane`'s series.
    pub(crate) fn push(&mut self, lane: usize, l: &SeriesLane) {
        self.lane.push(lane as u32);
        self.inputs.push(*l);
    }

    pub(crate) fn len(&self) -> usize {
        self.lane.len()
    }

    /// Sums every lane's series ([`SeriesLanes::sums`] after).
    pub(crate) fn run(&mut self, cos: bool) {
        self.sums.clear();
        for block in self.inputs.chunks(SERIES_BLOCK) {
            let mut sums = [None; SERIES_BLOCK];
            series(block, cos, &mut sums);
            self.sums.extend_from_slice(&sums[..block.len()]);
        }
    }

    /// Series lane `i`'s sum, slope sum and `Re φ(2) = E[cos 2X]`; `None` where it did not
    /// converge in [`SERIES_TERMS`] terms.
    pub(crate) fn sums(&self, i: usize) -> Option<(f64, f64, f64)> {
        self.sums[i]
    }
}

/// Lane `j` of a block: its inputs, or a lane that converges at the first term (`q = 0`).
fn block_lane(block: &[SeriesLane], j: usize) -> SeriesLane {
    block.get(j).copied().unwrap_or(SeriesLane {
        s1: 0.0,
        c1: 0.0,
        widths: [0.0; 3],
        steps: [(0.0, 1.0); 3],
        q: 0.0,
    })
}

lane_targets! {
/// [`SeriesLanes::run`] on one block of up to [`SERIES_BLOCK`] lanes: term `m` at every lane
/// not yet converged (the scalar rule's operations in its order: cos(2mμ), sin(2mμ) and
/// sin(m a_k) by angle addition, e^(−2m²σ²) as a running product), until every lane has or
/// [`SERIES_TERMS`] terms are summed. Its state is the block's arrays, held in registers.
fn series(block: &[SeriesLane], cos: bool, out: &mut [Option<(f64, f64, f64)>; SERIES_BLOCK]) {
    const B: usize = SERIES_BLOCK;
    let lanes: [SeriesLane; B] = std::array::from_fn(|j| block_lane(block, j));
    let (s1, c1, q) = (lanes.map(|l| l.s1), lanes.map(|l| l.c1), lanes.map(|l| l.q));
    let widths: [[f64; B]; 3] = std::array::from_fn(|k| lanes.map(|l| l.widths[k]));
    let step_sin: [[f64; B]; 3] = std::array::from_fn(|k| lanes.map(|l| l.steps[k].0));
    let step_cos: [[f64; B]; 3] = std::array::from_fn(|k| lanes.map(|l| l.steps[k].1));
    let (mut sin, mut cosine) = (step_sin, step_cos);
    let (mut sm, mut cm) = (s1, c1);
    let mut gauss = q;
    let mut ratio = q.map(|q| q * q * q);
    let (mut sum, mut slope, mut re2) = ([0.0; B], [0.0; B], [0.0; B]);
    let mut done = [false; B];
    let pick = |keep: bool, old: f64, new: f64| if keep { old } else { new };
    for m in 1..=SERIES_TERMS {
        let mf = m as f64;
        // The term's weight ±1/(4m² − 1), the same for every lane: a product, not a division.
        let sign = if cos && m % 2 == 1 { -1.0 } else { 1.0 };
        let weight = sign / (4.0 * mf * mf - 1.0);
        for j in 0..B {
            // Π sinc(m a_k) e^(−2m²σ²) as one quotient (one division a term, not three):
            // each sinc's numerator sin(m a) over m a, or its series 1 − (m a)²/6 over 1 near
            // 0. Huge widths make the denominator overflow to ∞ and the damping 0, its limit.
            let (mut num, mut den) = (gauss[j], 1.0);
            for k in 0..3 {
                let ma = mf * widths[k][j];
                let small = ma.abs() < 1e-4;
                num *= pick(small, 1.0 - ma * ma / 6.0, sin[k][j]);
                den *= pick(small, 1.0, ma);
            }
            let d = num / den;
            if m == 1 {
                // Re φ(2) = cos(2μ) times the first term's damping, Π sinc(a_k) e^(−2σ²).
                re2[j] = c1[j] * d;
            }
            let w = weight * d;
            sum[j] = pick(done[j], sum[j], sum[j] + w * cm[j]);
            slope[j] = pick(done[j], slope[j], slope[j] + w * 2.0 * mf * sm[j]);
            done[j] = done[j] || d.abs() < 1e-7;
            // m → m + 1 (a lane that is done no longer reads these).
            (sm[j], cm[j]) = (sm[j] * c1[j] + cm[j] * s1[j], cm[j] * c1[j] - sm[j] * s1[j]);
            for k in 0..3 {
                let (s, c) = (sin[k][j], cosine[k][j]);
                sin[k][j] = s * step_cos[k][j] + c * step_sin[k][j];
                cosine[k][j] = c * step_cos[k][j] - s * step_sin[k][j];
            }
            gauss[j] *= ratio[j];
            ratio[j] *= q[j] * q[j];
        }
        if done.iter().all(|&d| d) {
            break;
        }
    }
    for j in 0..B {
        out[j] = done[j].then_some((sum[j], slope[j], re2[j]));
    }
}
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::rules::Footprint;

    /// `|sin X|` over a support on one side of the sine's zeros (`one_sided`) is `±sin X`:
    /// its mean against a quadrature of `|sin|` over the footprint's uniforms and the Gaussian
    /// residual, and against the Fourier series it replaces where that converges.
    #[test]
    fn one_sided_abs_sine_is_the_signed_sine() {
        let fp = Footprint::cube(0.05).expect("a cube");
        let rules = Rules { footprint: &fp };
        let mut checked = 0;
        for (mean, grad, var, cos) in [
            (1.3, [4.0, -2.0, 1.0], 0.0, false),
            (-1.7, [3.0, 5.0, -2.5], 2e-3, false),
            (4.4, [-6.0, 1.5, 2.0], 5e-3, false),
            (0.2, [2.0, 2.0, 2.0], 1e-3, true),
            (-3.3, [8.0, 0.5, -1.0], 4e-4, true),
        ] {
            let x = Dist { mean, grad, var };
            let widths = fp.widths(grad);
            assert!(one_sided(mean, &widths, var, cos), "{x:?}");
            let AbsSinPlan::Done(Some(fast)) = rules.abs_sin_plan(&x, cos) else {
                panic!("one-sided: {x:?}");
            };
            // Reference: midpoints over the three uniforms, the trapezoid rule over the residual.
            let shift = if cos {
                std::f64::consts::FRAC_PI_2
            } else {
                0.0
            };
            let (n, m) = (48, 41);
            let mut total = 0.0;
            for i in 0..n * n * n {
                let u = [i % n, i / n % n, i / (n * n)].map(|k| (k as f64 + 0.5) / n as f64 - 0.5);
                let y = mean + shift + (0..3).map(|k| widths[k] * u[k]).sum::<f64>();
                for j in 0..m {
                    let z = -8.0 + 16.0 * j as f64 / (m - 1) as f64;
                    let w = (-z * z / 2.0).exp() * 16.0 / (m - 1) as f64;
                    total += w * (y + var.sqrt() * z).sin().abs();
                }
            }
            let reference = total / (n * n * n) as f64 / (2.0 * std::f64::consts::PI).sqrt();
            assert!(
                (fast.mean - reference).abs() < 1e-5,
                "{x:?}: {} against {reference}",
                fast.mean
            );
            // The series, where it converges, agrees to its truncation.
            let lane = SeriesLane::new(mean, widths, var);
            let mut series = SeriesLanes::default();
            series.push(0, &lane);
            series.run(cos);
            if let Some(slow) = rules.abs_sin_finish(&x, cos, series.sums(0)) {
                assert!(
                    (slow.mean - fast.mean).abs() < 1e-7,
                    "{x:?}: {slow:?} against {fast:?}"
                );
                assert!(
                    (slow.var - fast.var).abs() < 1e-7,
                    "{x:?}: {slow:?} against {fast:?}"
                );
                checked += 1;
            }
        }
        assert!(checked >= 3, "the series converged in {checked} cases");
    }
}
