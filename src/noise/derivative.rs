//! Exact analytic gradients (∂/∂x, ∂/∂y, ∂/∂z with respect to the sample point) of every noise
//! basis and of every fractal sum, for the `Gradient` node's forward-mode differentiation.
//!
//! The precision contract is the value functions' (see the `noise` module docs): positions and
//! the lattice cell in f64, only the fraction enters the interior arithmetic in `S`; the
//! gradient is computed from the same corner hashes, fractions, nearest points and octave
//! values as the value, so it is the derivative of the function the value path evaluates. A
//! non-finite coordinate gives NaN on every component (the canonical `S::NAN`); a NaN that arises
//! otherwise is made canonical too, so the point and batch forms agree bit for bit.
//!
//! Each basis is differentiable almost everywhere; on the null set where it is not, the value
//! returned is one side's derivative, as listed:
//!
//! - **Perlin** (quintic fade `6t⁵ - 15t⁴ + 10t³`, `fade' = 30 t² (t - 1)²`): the product rule
//!   on the trilinear blend of the eight corner dot products, `∂N/∂x = Σ_c W_c g_c,x +
//!   fade'(x) Σ_yz w_yz (h_1yz - h_0yz)` (and likewise per axis). C² everywhere: no exceptions.
//! - **Gradient** (Ebert, smoothstep `t²(3 - 2t)`, slope `6t(1 - t)`): the same product rule
//!   with the table's unit gradients. C¹ everywhere: no exceptions.
//! - **Value, Smooth**: the corner values are constants, so only the weight slopes remain
//!   (`6t(1 - t)`). C¹ everywhere.
//! - **Value, Linear**: continuous with a crease on every cell face (the weight t has slope 1
//!   inside a cell, and the neighbour cell blends other corners). On a face the value kernel
//!   interpolates in the cell the point lies in (fraction 0 along that axis), so the gradient
//!   returned there is that cell's: the right-hand (upper-side) derivative.
//! - **Simplex**: `32 Σ_v [(0.6 - r²)⁴ g·d]'` = `32 Σ_v [(0.6 - r²)⁴ g - 8 (0.6 - r²)³ (g·d) d]`
//!   over the eight vertices the value sums, only where `r² < 0.6` (beyond it the term is 0 with
//!   all its derivatives up to the third, so the sum is C³). No exceptions.
//! - **Cellular**: the gradient of the distance from the point p to the feature point(s) the value
//!   function picks (its scan order and strict comparisons, so ties go to the first found):
//!   Euclidean `(p - f) / |p - f|`, Manhattan `sign(p - f)` per component, Chebyshev
//!   `sign(p_k - f_k) e_k` with k the axis of the largest |component| (ties: the first axis).
//!   F2MinusF1 is `∇F2 - ∇F1`, Edge half that, CellValue 0 (piecewise constant). Not
//!   differentiable where the chosen point changes (F1: the cell borders, where two points are
//!   equidistant; F2: also where the second and third tie): there the first point found's
//!   gradient. At a feature point itself Euclidean returns 0 (the cone's tip), Manhattan's and
//!   Chebyshev's `sign(0)` is 0 (every plane through a feature point along an axis is a crease
//!   for Manhattan, every plane where two components tie in magnitude one for Chebyshev).
//!   CellValue's jumps (the cell borders) have no derivative; 0 there too.
//! - **White noise**: 0 (piecewise constant per cell; its jumps on the cell faces have no
//!   derivative).
//!
//! Fractal sums, with `q_i = p · f_i` (f64) and the octave's amplitude `a_i` exactly as the
//! value sum weights it (the fractional last octave included), `n_i = N(q_i)`, and
//! `∇n_i` the basis gradient at `q_i` times the chain factor `f_i` (tiled schedules: octave i
//! samples at its own period; the reduction into the period is a translation per cell, so it is
//! the gradient of the reduced point):
//!
//! - **Fbm** `Σ a_i f_i ∇N(q_i)`.
//! - **Turbulence** `Σ a_i f_i sign(n_i) ∇N(q_i)`: on `n_i = 0` (a crease of `|n|`) sign(0) = 0,
//!   the average of the two sides.
//! - **Billow** `Σ 2 a_i f_i sign(n_i) ∇N(q_i)`, sign(0) = 0 likewise.
//! - **Ridged**: the recurrence differentiated: `ridge = max(offset - |n|, 0)` has gradient
//!   `-sign(n) ∇n` where `ridge > 0` and 0 where it is clamped (also on `ridge = 0` itself, the
//!   side where it stays 0); `s_i = ridge^sharpness · w_i` has gradient
//!   `sharpness · ridge^(sharpness - 1) ∇ridge · w_i + ridge^sharpness ∇w_i` (the power's slope
//!   taken as `sharpness · ridge^sharpness / ridge`, which needs `ridge > 0`: it is 0 where the
//!   ridge is clamped); `w_{i+1} = clamp(2 s_i, 0, 1)` has gradient `2 ∇s_i` where
//!   `0 < 2 s_i < 1` and 0 where it is clamped, on the clamp's edges included (the clamped
//!   side's). `∇w` is carried along the octaves from `∇w_0 = 0`.
//!
//! The point functions are the reference; the batch forms run the same per-lane arithmetic
//! (for the lattice bases `batch/`'s lane kernels, see `LatticeKernel::interior_grad`) and
//! are held to the same bits by the tests (`derivative_tests.rs`), which also hold the f64
//! gradients to central differences of the f64 value functions.

use super::kernel::{octaves_grad, octaves_grad_amps, NoiseKernel};
use super::kernels::with_kernel;
use super::lanes::{check_lengths, CHUNK};
use super::octaves::{Amps, GradShaper, LaneOctaves, OctavePeriods, Octaves, Style};
use super::period::Period;
use super::table::NoiseTable;
use crate::real::Real;

impl NoiseTable {
    /// The analytic gradient of [`NoiseTable::sample`] at `p` (with the table's own period when
    /// it has one: tiling is a translation per cell, so it is the gradient of the reduced
    /// point); see the module docs of `derivative.rs` for each basis' rule and its value where
    /// the basis is not differentiable. Non-finite input gives NaN components.
    #[inline]
    pub fn sample_grad<S: Real>(&self, p: [f64; 3]) -> [S; 3] {
        match self.period {
            None => with_kernel!(self, k => k.sample_grad::<S>(p).1),
            Some(period) => with_kernel!(self, k => k.sample_grad_periodic::<S>(p, period).1),
        }
    }

    /// [`NoiseTable::sample`] and [`NoiseTable::sample_grad`] at `p` from one walk of the
    /// lattice (the value as the gradient kernel computes it: equal to `sample`'s up to
    /// rounding, not bit for bit).
    #[inline]
    pub fn sample_value_grad<S: Real>(&self, p: [f64; 3]) -> (S, [S; 3]) {
        match self.period {
            None => with_kernel!(self, k => k.sample_grad::<S>(p)),
            Some(period) => with_kernel!(self, k => k.sample_grad_periodic::<S>(p, period)),
        }
    }

    /// Batch form of [`NoiseTable::sample_grad`]: `out[c][i] = sample_grad::<S>(p_i)[c]`
    /// widened to f64, bit for bit.
    ///
    /// Panics only if the slices' lengths differ (a caller bug).
    pub fn sample_grad_batch<S: Real>(
        &self,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: [&mut [f64]; 3],
    ) {
        check_grad_lengths(x, y, z, &out);
        let period = self.period;
        with_kernel!(self, k => grad_chunks::<S, _>(&k, period, [x, y, z], out));
    }
}

impl NoiseTable {
    /// Batch form of [`NoiseTable::sample_value_grad`] in f64: `value[i]` and `grad[c][i]` are
    /// `sample_value_grad::<f64>(p_i)`'s, bit for bit (the kernels' batch gradient with its
    /// values; the filtered form samples each octave this way, `filter/noise.rs`).
    ///
    /// Panics only if the slices' lengths differ (a caller bug).
    pub fn sample_value_grad_batch(
        &self,
        [x, y, z]: [&[f64]; 3],
        value: &mut [f64],
        grad: [&mut [f64]; 3],
    ) {
        check_grad_lengths(x, y, z, &grad);
        assert_eq!(value.len(), x.len(), "noise gradient batch: value length");
        let period = self.period;
        let [gx, gy, gz] = grad;
        let mut start = 0;
        while start < x.len() {
            let m = CHUNK.min(x.len() - start);
            let r = start..start + m;
            with_kernel!(self, k => k.sample_grad_batch::<f64, true>(
                period,
                [&x[r.clone()], &y[r.clone()], &z[r.clone()]],
                &mut value[r.clone()],
                [&mut gx[r.clone()], &mut gy[r.clone()], &mut gz[r.clone()]],
            ));
            start += m;
        }
    }
}

/// The length check of the gradient batch entry points (see `check_lengths`).
fn check_grad_lengths(x: &[f64], y: &[f64], z: &[f64], out: &[&mut [f64]; 3]) {
    let n = out[0].len();
    check_lengths(x, y, z, n);
    assert!(
        out[1].len() == n && out[2].len() == n,
        "noise gradient batch: output planes' lengths differ ({}, {}, {})",
        n,
        out[1].len(),
        out[2].len()
    );
}

/// [`NoiseTable::sample_grad_batch`] for one kernel: chunks through the kernel's batch
/// gradient, widened into the f64 planes.
fn grad_chunks<S: Real, K: NoiseKernel>(
    k: &K,
    period: Option<Period>,
    [x, y, z]: [&[f64]; 3],
    out: [&mut [f64]; 3],
) {
    let [ox, oy, oz] = out;
    let mut n = [S::ZERO; CHUNK];
    let mut g = [[S::ZERO; CHUNK]; 3];
    let mut start = 0;
    while start < x.len() {
        let m = CHUNK.min(x.len() - start);
        let r = start..start + m;
        let [gx, gy, gz] = &mut g;
        k.sample_grad_batch::<S, false>(
            period,
            [&x[r.clone()], &y[r.clone()], &z[r.clone()]],
            &mut n[..m],
            [&mut gx[..m], &mut gy[..m], &mut gz[..m]],
        );
        for (o, plane) in [&mut *ox, &mut *oy, &mut *oz].into_iter().zip(&g) {
            for (o, &v) in o[r.clone()].iter_mut().zip(&plane[..m]) {
                *o = v.to_f64();
            }
        }
        start += m;
    }
}

/// The gradient of [`fractal_styled`](super::fractal_styled)`::<S>(table, octaves, style, p)`
/// for every [`Style`] and tiled schedules too: per octave the basis gradient at `p · f_i`
/// times the chain factor `f_i`, shaped by the style (see the module docs of `derivative.rs`),
/// the amplitudes exactly as the value sum uses them. Summed in S in octave order from zero;
/// NaN components canonical.
pub fn fractal_styled_grad<S: Real>(
    table: &NoiseTable,
    octaves: &Octaves,
    style: Style,
    p: [f64; 3],
) -> [S; 3] {
    let periods = octave_periods(table, octaves, style);
    with_kernel!(table, k => fractal_grad_point::<S, _>(&k, octaves, periods, style, p))
}

/// [`fractal_styled_grad`] for one kernel.
#[inline]
fn fractal_grad_point<S: Real, K: NoiseKernel>(
    k: &K,
    octaves: &Octaves,
    periods: OctavePeriods,
    style: Style,
    p: [f64; 3],
) -> [S; 3] {
    let mut shaper = GradShaper::<S>::START;
    for (i, (&f, &a)) in octaves
        .frequencies
        .iter()
        .zip(&octaves.amplitudes)
        .enumerate()
    {
        let q = [p[0] * f, p[1] * f, p[2] * f];
        let (n, g) = match periods.at(i) {
            Some(period) => k.sample_grad_periodic::<S>(q, period),
            None => k.sample_grad::<S>(q),
        };
        shaper.add(style, n, g, a, f);
    }
    shaper.gradient()
}

/// Batch form of [`fractal_styled_grad`]: `out[c][i] = fractal_styled_grad::<S>(.., p_i)[c]`
/// widened to f64, bit for bit. An untiled Fbm of a lattice basis runs the fused lane kernel
/// of `batch/` (octaves accumulated in place); every other sum runs the octaves outside the
/// lanes, each octave one batch gradient of the basis, then the style's shaping per lane.
///
/// Panics only if the slices' lengths differ (a caller bug).
pub fn fractal_styled_grad_batch<S: Real>(
    table: &NoiseTable,
    octaves: &Octaves,
    style: Style,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: [&mut [f64]; 3],
) {
    check_grad_lengths(x, y, z, &out);
    let (f, a) = (&octaves.frequencies[..], &octaves.amplitudes[..]);
    match (style, octave_periods(table, octaves, style)) {
        (Style::Fbm, OctavePeriods::None) => {
            with_kernel!(table, k => k.fbm_grad_batch::<S>(f, a, [x, y, z], out))
        }
        (_, periods) => {
            with_kernel!(table, k => octaves_grad::<S, _>(&k, f, a, periods, style, [x, y, z], out))
        }
    }
}

/// [`fractal_styled_grad_batch`] with level of detail per lane (see
/// [`fractal_styled_batch_lanes`](super::fractal_styled_batch_lanes)): lane i's gradient is
/// that of the sum of the octaves `lanes` keeps for it, bit for bit
/// [`fractal_styled_grad`] with the schedule `Octaves::new(lanes.kept[i], ...)`.
#[allow(clippy::too_many_arguments)]
pub fn fractal_styled_grad_batch_lanes<S: Real>(
    table: &NoiseTable,
    octaves: &Octaves,
    lanes: LaneOctaves,
    style: Style,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: [&mut [f64]; 3],
) {
    check_grad_lengths(x, y, z, &out);
    assert_eq!(lanes.kept.len(), x.len(), "one kept count per lane");
    let (f, periods) = (
        &octaves.frequencies[..],
        octave_periods(table, octaves, style),
    );
    let amps = Amps::Lanes(lanes);
    with_kernel!(table, k => octaves_grad_amps::<S, _>(&k, f, amps, periods, style, [x, y, z], out))
}

/// The period each octave of a fractal sum of `table` samples at (see [`OctavePeriods`]).
fn octave_periods<'a>(table: &NoiseTable, octaves: &'a Octaves, style: Style) -> OctavePeriods<'a> {
    match (&octaves.periods, style, table.period) {
        (Some(periods), _, _) => OctavePeriods::PerOctave(periods),
        (None, Style::Fbm | Style::Turbulence, _) | (None, _, None) => OctavePeriods::None,
        (None, _, Some(period)) => OctavePeriods::Fixed(period),
    }
}
