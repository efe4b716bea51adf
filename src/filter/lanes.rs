//! Structure-of-arrays kernels of the noise octave rules (`noise.rs`): a run of a chunk's lanes
//! that share one fade (the same footprint and input spread: every lane of a bake's chunk) is
//! one loop per rule, each quantity one array, without branches so that the compiler
//! vectorises it, compiled per CPU like the noise kernels (`multiversion`). A lane where a rule's
//! special case applies (a non-finite slope, which takes the footprint's edge-by-edge
//! covariance; a non-finite sub-box mean) is marked and left to the caller's scalar rule. The
//! per-lane arithmetic does not depend on how the lanes are grouped, so one lane of a batch and
//! [`super::tape::Filtered::eval_point`] get the same bits.

use super::rules::{dot, residual, Dist};

/// The targets of this file's kernels (and `abs_sine.rs`'): every clone in release builds, the building machine's
/// alone in debug and test builds (`simd_clones!`, the crate root).
macro_rules! lane_targets {
    ($item:item) => {
        simd_clones! {
            all: ["x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma", "x86_64+sse4.1"],
            vbmi: "x86_64+avx512f+avx512vl+avx2+fma",
            avx2: "x86_64+avx2+fma",
            $item
        }
    };
}
/// For the filtered form's other lane kernels (`abs_sine.rs`).
pub(super) use lane_targets;

/// [`Octave::planes`]: mean, slope, variance and whether the estimate holds, one plane each.
type Planes<'a> = (
    &'a mut [f64],
    [&'a mut [f64]; 3],
    &'a mut [f64],
    &'a mut [bool],
);

/// One octave at each lane of a run: mean, linear part and residual variance, and whether the
/// kernel's estimate holds (else the caller's scalar rule).
#[derive(Default)]
pub(super) struct Octave {
    mean: Vec<f64>,
    grad: [Vec<f64>; 3],
    var: Vec<f64>,
    ok: Vec<bool>,
}

impl Octave {
    fn resize(&mut self, n: usize) {
        self.mean.resize(n, 0.0);
        self.grad.iter_mut().for_each(|g| g.resize(n, 0.0));
        self.var.resize(n, 0.0);
        self.ok.resize(n, false);
    }

    /// The `n` lanes' planes to write (mean, slope, variance, whether the estimate holds).
    fn planes(&mut self, n: usize) -> Planes<'_> {
        self.resize(n);
        let [g0, g1, g2] = &mut self.grad;
        (
            &mut self.mean[..n],
            [&mut g0[..n], &mut g1[..n], &mut g2[..n]],
            &mut self.var[..n],
            &mut self.ok[..n],
        )
    }

    /// `n` lanes, each left to the caller's scalar rule.
    pub(super) fn none(&mut self, n: usize) {
        self.resize(n);
        self.ok.fill(false);
    }

    /// Lane `i`'s octave, `None` where the caller's scalar rule takes it.
    #[inline]
    pub(super) fn get(&self, i: usize) -> Option<Dist> {
        self.ok[i].then(|| self.dist(i))
    }

    /// Whether the kernel's estimate holds at lane `i`.
    pub(super) fn holds(&self, i: usize) -> bool {
        self.ok[i]
    }

    /// Lane `i` as a distribution.
    #[inline]
    pub(super) fn dist(&self, i: usize) -> Dist {
        Dist {
            mean: self.mean[i],
            grad: [self.grad[0][i], self.grad[1][i], self.grad[2][i]],
            var: self.var[i],
        }
    }

    /// `n` lanes of the constant 0, a sum to add octaves to.
    pub(super) fn zero(&mut self, n: usize) {
        self.resize(n);
        self.mean.fill(0.0);
        self.grad.iter_mut().for_each(|g| g.fill(0.0));
        self.var.fill(0.0);
        self.ok.fill(true);
    }

    /// Lane `i` plus `amp · d`: `Rules::add` of `d.scale(amp)`, the same operations.
    #[inline]
    pub(super) fn add(&mut self, i: usize, amp: f64, d: &Dist) {
        self.mean[i] += amp * d.mean;
        for (g, dg) in self.grad.iter_mut().zip(d.grad) {
            g[i] += amp * dg;
        }
        self.var[i] += amp * amp * d.var;
    }

    /// [`Octave::add`] of every lane of `other` whose estimate holds; whether all did.
    pub(super) fn add_scaled(&mut self, amp: f64, other: &Octave) -> bool {
        add_scaled(self, amp, other)
    }
}

lane_targets! {
/// [`Octave::add_scaled`]'s loop, lanes whose estimate does not hold left as they are.
fn add_scaled(sum: &mut Octave, amp: f64, other: &Octave) -> bool {
    let n = other.mean.len();
    let a2 = amp * amp;
    let ok = &other.ok[..n];
    let pick = |ok: bool, add: f64, keep: f64| if ok { add } else { keep };
    let (mean, var) = (&mut sum.mean[..n], &mut sum.var[..n]);
    for i in 0..n {
        mean[i] = pick(ok[i], mean[i] + amp * other.mean[i], mean[i]);
        var[i] = pick(ok[i], var[i] + a2 * other.var[i], var[i]);
    }
    for (g, o) in sum.grad.iter_mut().zip(&other.grad) {
        let (g, o) = (&mut g[..n], &o[..n]);
        for i in 0..n {
            g[i] = pick(ok[i], g[i] + amp * o[i], g[i]);
        }
    }
    ok.iter().all(|&o| o)
}
}

/// What the lanes of a sub-sampled run share (`noise.rs`'s `Sub` and the table's statistics).
pub(super) struct SubRun<'a> {
    /// The half-size sub-box's fade.
    pub alpha: f64,
    /// `(1 − α) μ`: each sub-box mean is `α v + (1 − α) μ`.
    pub base: f64,
    /// `(1 − α²) σ²`: what each sub-box's fade takes (its input carries no residual).
    pub within: f64,
    /// The footprint's slope fit `E M⁻¹` and its covariance `Σ_k e_k e_kᵀ / 12`.
    pub fit: &'a [[f64; 3]; 3],
    pub quad: &'a [[f64; 3]; 3],
}

/// A sub-sampled lane's slope and residual variance from its samples' differences along the
/// edges (`du`, through the footprint's fit) and their total variance, less the slope's
/// (`subsampled`, `faces`).
#[inline(always)]
fn fitted(run: &SubRun, du: [f64; 3], total_var: f64) -> ([f64; 3], f64) {
    let g: [f64; 3] = std::array::from_fn(|r| dot(&run.fit[r], &du));
    let linear = quadratic(run.quad, &g).max(0.0);
    (g, residual(total_var, linear))
}

lane_targets! {
/// The sub-sampled octave (`noise.rs`, "the octave over the footprint from its eight
/// sub-boxes") at `n` lanes from the noise's values at their sub-box centres, sub-box `j` of
/// lane `i` at `values[j * n + i]`, for an input without residual variance: the mean of the
/// eight faded values; the least-squares slope along each edge
/// (`grad · e_k = (Σ_{s_k = +1} − Σ_{s_k = −1}) / 2` over the eight, through the fit); the
/// variance the eight's spread plus the sub-boxes' fades, less the slope's.
pub(super) fn subsampled(run: &SubRun, values: &[f64], n: usize, out: &mut Octave) {
    let values = &values[..8 * n];
    let (means, [g0, g1, g2], vars, ok) = out.planes(n);
    for i in 0..n {
        let mut m = [0.0; 8];
        let mut total = 0.0;
        for (j, m) in m.iter_mut().enumerate() {
            let v = values[j * n + i];
            *m = run.alpha * if v.is_finite() { v } else { 0.0 } + run.base;
            total += *m;
        }
        let mean = total / 8.0;
        let du: [f64; 3] = std::array::from_fn(|k| {
            let mut d = 0.0;
            for (j, m) in m.iter().enumerate() {
                d += if j >> k & 1 == 1 { *m } else { -*m };
            }
            d * 0.5
        });
        let mut between = 0.0;
        for m in &m {
            between += (m - mean) * (m - mean);
        }
        let (g, var) = fitted(run, du, between / 8.0 + run.within);
        means[i] = mean;
        (g0[i], g1[i], g2[i]) = (g[0], g[1], g[2]);
        vars[i] = var;
        ok[i] = g.iter().all(|c| c.is_finite()) & mean.is_finite();
    }
}
}

lane_targets! {
/// The octave from its values at the six face centres (`noise.rs`' `FACES_FROM`) at `n`
/// lanes, face `j` of lane `i` at `values[j * n + i]` (`+E_k / 2` for `j = k`, `−E_k / 2` for
/// `j = k + 3`), for an input without residual variance: their mean (a rule of degree 3); the
/// slope along each edge the difference across it (`grad · e_k = v_k − v_{k+3}`, through the
/// fit); as variance their spread (a linear function's variance over the box exactly), less
/// the slope's. No fade: at the fades that take it the box is within 0.4 of a cell.
pub(super) fn faces(run: &SubRun, values: &[f64], n: usize, out: &mut Octave) {
    let values = &values[..6 * n];
    let (means, [g0, g1, g2], vars, ok) = out.planes(n);
    for i in 0..n {
        let mut v = [0.0; 6];
        let mut total = 0.0;
        for (j, v) in v.iter_mut().enumerate() {
            let x = values[j * n + i];
            *v = if x.is_finite() { x } else { 0.0 };
            total += *v;
        }
        let mean = total / 6.0;
        let du: [f64; 3] = std::array::from_fn(|k| v[k] - v[k + 3]);
        let mut spread = 0.0;
        for x in &v {
            spread += (x - mean) * (x - mean);
        }
        let (g, var) = fitted(run, du, spread / 6.0);
        means[i] = mean;
        (g0[i], g1[i], g2[i]) = (g[0], g[1], g[2]);
        vars[i] = var;
        ok[i] = g.iter().all(|c| c.is_finite()) & mean.is_finite();
    }
}
}

/// What the lanes of a centre-sampled run share (the fade, the input's spread, the table's
/// statistics).
pub(super) struct CentreRun<'a> {
    pub alpha: f64,
    /// `(1 − α) μ`.
    pub base: f64,
    /// The residual variance (`noise.rs`' `Fade::rest`).
    pub rest: f64,
    /// The input's linear parts: `jac[i]` component `i`'s slope in the position.
    pub jac: [[f64; 3]; 3],
    /// The input's residual variance per component.
    pub spread: [f64; 3],
    /// The slope's damping (`Footprint::damp_matrix`), if any.
    pub damp: Option<&'a [[f64; 3]; 3]>,
}

lane_targets! {
/// The centre-sampled octave (`noise.rs`'s `sampled`) at `n` lanes from the noise's value and
/// gradient at their centres: the faded value; the gradient through the input's linear part,
/// faded and damped; as residual what the fade takes beyond the linear part's expectation
/// (`run.rest`, one number per run), plus the input's residual carried through the gradient.
pub(super) fn sampled(run: &CentreRun, value: &[f64], grad: [&[f64]; 3], out: &mut Octave) {
    let n = value.len();
    let (gx, gy, gz) = (&grad[0][..n], &grad[1][..n], &grad[2][..n]);
    let (means, [g0, g1, g2], vars, ok) = out.planes(n);
    let a2 = run.alpha * run.alpha;
    for i in 0..n {
        let finite = |c: f64| if c.is_finite() { c } else { 0.0 };
        let g = [finite(gx[i]), finite(gy[i]), finite(gz[i])];
        let slope: [f64; 3] = std::array::from_fn(|j| {
            run.alpha * (g[0] * run.jac[0][j] + g[1] * run.jac[1][j] + g[2] * run.jac[2][j])
        });
        let slope = match run.damp {
            Some(d) => {
                let damped: [f64; 3] = std::array::from_fn(|r| dot(&d[r], &slope));
                if damped.iter().all(|c| c.is_finite()) {
                    damped
                } else {
                    slope
                }
            }
            None => slope,
        };
        let carried =
            g[0] * g[0] * run.spread[0] + g[1] * g[1] * run.spread[1] + g[2] * g[2] * run.spread[2];
        let var = run.rest + a2 * carried;
        means[i] = run.alpha * value[i] + run.base;
        (g0[i], g1[i], g2[i]) = (slope[0], slope[1], slope[2]);
        vars[i] = if var.is_finite() { var.max(0.0) } else { 0.0 };
        ok[i] = slope.iter().all(|c| c.is_finite());
    }
}
}

/// `gᵀ Q g`.
#[inline(always)]
fn quadratic(q: &[[f64; 3]; 3], g: &[f64; 3]) -> f64 {
    g[0] * dot(&q[0], g) + g[1] * dot(&q[1], g) + g[2] * dot(&q[2], g)
}
