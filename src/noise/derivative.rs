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
//! (for the lattice bases `batch.rs`'s lane kernels, see `LatticeKernel::interior_grad`) and
//! are held to the same bits by the tests (`derivative_tests.rs`), which also hold the f64
//! gradients to central differences of the f64 value functions.

use super::fractal::{Amps, LaneOctaves, Octaves, Style};
use super::{
    canonical_nan, check_lengths, Basis, CellularKernel, GradientKernel, Interpolation,
    NoiseKernel, NoiseTable, Period, PerlinKernel, SimplexKernel, ValueKernel, WhiteKernel,
};
use crate::real::Real;

/// Lanes per chunk of the batch forms (the lattice lane kernels' chunk).
const CHUNK: usize = super::batch::CHUNK;

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
    let periods = OctavePeriods::of(table, octaves, style);
    with_kernel!(table, k => fractal_grad_point::<S, _>(&k, octaves, periods, style, p))
}

/// The period each octave of a fractal sum samples at, as [`fractal_styled`](super::fractal_styled)
/// picks it: the schedule's own per octave when it has them; otherwise none for Fbm and
/// Turbulence (`fractal` samples the basis' kernel directly) and the table's own for Billow and
/// Ridged (which sample through `NoiseTable::sample`).
#[derive(Clone, Copy)]
pub(super) enum OctavePeriods<'a> {
    None,
    Fixed(Period),
    PerOctave(&'a [Period]),
}

impl<'a> OctavePeriods<'a> {
    fn of(table: &NoiseTable, octaves: &'a Octaves, style: Style) -> Self {
        match (&octaves.periods, style, table.period) {
            (Some(periods), _, _) => OctavePeriods::PerOctave(periods),
            (None, Style::Fbm | Style::Turbulence, _) | (None, _, None) => OctavePeriods::None,
            (None, _, Some(period)) => OctavePeriods::Fixed(period),
        }
    }

    /// Octave `i`'s period.
    #[inline(always)]
    fn at(self, i: usize) -> Option<Period> {
        match self {
            OctavePeriods::None => None,
            OctavePeriods::Fixed(period) => Some(period),
            OctavePeriods::PerOctave(periods) => Some(periods[i]),
        }
    }
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
/// of `batch.rs` (octaves accumulated in place); every other sum runs the octaves outside the
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
    match (style, OctavePeriods::of(table, octaves, style)) {
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
        OctavePeriods::of(table, octaves, style),
    );
    let amps = Amps::Lanes(lanes);
    with_kernel!(table, k => octaves_grad_amps::<S, _>(&k, f, amps, periods, style, [x, y, z], out))
}

/// The octave loop of the batch gradient sums without a fused kernel: per chunk of lanes and
/// octave, the points scaled by the frequency in f64, one batch gradient of the basis (plain or
/// at the octave's period; values too unless the style is Fbm), then [`GradShaper::add`] per
/// lane: each lane sees the point function's operations in its order.
pub(super) fn octaves_grad<S: Real, K: NoiseKernel>(
    k: &K,
    freqs: &[f64],
    amps: &[f64],
    periods: OctavePeriods,
    style: Style,
    p: [&[f64]; 3],
    out: [&mut [f64]; 3],
) {
    octaves_grad_amps::<S, K>(k, freqs, Amps::Shared(amps), periods, style, p, out);
}

/// [`octaves_grad`] with the amplitudes shared or per lane (a lane's dropped octaves leave its
/// sum alone; a chunk runs only the octaves one of its lanes keeps).
fn octaves_grad_amps<S: Real, K: NoiseKernel>(
    k: &K,
    freqs: &[f64],
    amps: Amps,
    periods: OctavePeriods,
    style: Style,
    p: [&[f64]; 3],
    out: [&mut [f64]; 3],
) {
    if style == Style::Fbm {
        octaves_grad_with::<S, K, false>(k, freqs, amps, periods, style, p, out);
    } else {
        octaves_grad_with::<S, K, true>(k, freqs, amps, periods, style, p, out);
    }
}

/// [`octaves_grad_amps`]; `VALUE`: whether the style reads the octave values.
fn octaves_grad_with<S: Real, K: NoiseKernel, const VALUE: bool>(
    k: &K,
    freqs: &[f64],
    amps: Amps,
    periods: OctavePeriods,
    style: Style,
    [x, y, z]: [&[f64]; 3],
    out: [&mut [f64]; 3],
) {
    let [ox, oy, oz] = out;
    let mut shapers = [GradShaper::<S>::START; CHUNK];
    let mut scaled = [[0.0f64; CHUNK]; 3];
    let mut n = [S::ZERO; CHUNK];
    let mut g = [[S::ZERO; CHUNK]; 3];
    let mut start = 0;
    while start < x.len() {
        let m = CHUNK.min(x.len() - start);
        shapers[..m].fill(GradShaper::START);
        for (octave, &f) in freqs[..amps.octaves(start, m, freqs.len())]
            .iter()
            .enumerate()
        {
            for (plane, src) in scaled.iter_mut().zip([x, y, z]) {
                for (s, &v) in plane[..m].iter_mut().zip(&src[start..start + m]) {
                    *s = v * f;
                }
            }
            let [sx, sy, sz] = &scaled;
            let [gx, gy, gz] = &mut g;
            k.sample_grad_batch::<S, VALUE>(
                periods.at(octave),
                [&sx[..m], &sy[..m], &sz[..m]],
                &mut n[..m],
                [&mut gx[..m], &mut gy[..m], &mut gz[..m]],
            );
            let (shapers, n) = (&mut shapers[..m], &n[..m]);
            match amps {
                Amps::Shared(a) => shape_grad_lanes(style, shapers, n, &g, f, |_| Some(a[octave])),
                Amps::Lanes(l) => {
                    shape_grad_lanes(style, shapers, n, &g, f, |i| l.amplitude(octave, start + i))
                }
            }
        }
        for (c, o) in [&mut *ox, &mut *oy, &mut *oz].into_iter().enumerate() {
            for (o, s) in o[start..start + m].iter_mut().zip(&shapers[..m]) {
                *o = canonical_nan(s.sum[c]).to_f64();
            }
        }
        start += m;
    }
}

/// Per lane of a chunk, [`GradShaper::add`] of octave value `n[i]` and gradient `g[·][i]` at
/// frequency `f` with the lane's amplitude `amp(i)` (`None`: dropped, the lane is left alone).
/// One loop per style, each with its style a constant (straight-line lane code).
#[inline(always)]
fn shape_grad_lanes<S: Real>(
    style: Style,
    shapers: &mut [GradShaper<S>],
    n: &[S],
    g: &[[S; CHUNK]; 3],
    f: f64,
    amp: impl Fn(usize) -> Option<f64>,
) {
    let lanes = shapers.iter_mut().zip(n).enumerate();
    let add = |style: Style| {
        move |(i, (s, &v)): (usize, (&mut GradShaper<S>, &S))| {
            if let Some(a) = amp(i) {
                s.add(style, v, [g[0][i], g[1][i], g[2][i]], a, f)
            }
        }
    };
    match style {
        Style::Fbm => lanes.for_each(add(Style::Fbm)),
        Style::Turbulence => lanes.for_each(add(Style::Turbulence)),
        Style::Billow => lanes.for_each(add(Style::Billow)),
        ridged @ Style::Ridged { .. } => lanes.for_each(add(ridged)),
    }
}

/// Per-lane state of a fractal gradient: the gradient of the sum so far and, for Ridged, the
/// weight of the next octave and its gradient. The same arithmetic on the point and batch paths.
#[derive(Clone, Copy)]
pub(super) struct GradShaper<S> {
    pub(super) sum: [S; 3],
    weight: S,
    weight_grad: [S; 3],
}

impl<S: Real> GradShaper<S> {
    pub(super) const START: GradShaper<S> = GradShaper {
        sum: [S::ZERO; 3],
        weight: S::ONE,
        weight_grad: [S::ZERO; 3],
    };

    /// One octave: its value `n` and basis gradient `g` at `p · freq`, weighted `amplitude`.
    /// Fbm adds `S(amplitude · freq) · g` per component (the fused lane kernel of `batch.rs`
    /// does exactly this).
    #[inline(always)]
    pub(super) fn add(&mut self, style: Style, n: S, g: [S; 3], amplitude: f64, freq: f64) {
        match style {
            Style::Fbm => {
                let c = S::from_f64(amplitude * freq);
                self.sum = std::array::from_fn(|a| self.sum[a] + c * g[a]);
            }
            Style::Turbulence => {
                let c = S::from_f64(amplitude * freq) * sign(n);
                self.sum = std::array::from_fn(|a| self.sum[a] + c * g[a]);
            }
            Style::Billow => {
                // d(a (2|n| - 1)) = 2 a sign(n) dn; `2 · amplitude` is exact.
                let c = S::from_f64(2.0 * amplitude * freq) * sign(n);
                self.sum = std::array::from_fn(|a| self.sum[a] + c * g[a]);
            }
            Style::Ridged { offset, sharpness } => {
                self.add_ridged(offset, sharpness, n, g, amplitude, freq)
            }
        }
    }

    /// [`GradShaper::add`] for Ridged: the value recurrence exactly as `fractal::Shaper`
    /// computes it (ridge, power, signal, next weight), and its derivative beside it.
    #[inline(always)]
    fn add_ridged(&mut self, offset: f64, sharpness: f64, n: S, g: [S; 3], amp: f64, freq: f64) {
        let zero = S::ZERO;
        let ridge = (S::from_f64(offset) - n.abs()).max_nan(zero);
        let sharp = S::from_f64(sharpness);
        let power = ridge.powf(sharp);
        let signal = power * self.weight;
        // d power = sharpness · ridge^(sharpness - 1) · d ridge, d ridge = -sign(n) · f · dn
        // while the ridge is not clamped (ridge > 0); else 0. A NaN n gives a NaN g, so the
        // zero factor keeps the NaN.
        let slope = if ridge > zero {
            -(sharp * power / ridge) * sign(n) * S::from_f64(freq)
        } else {
            zero
        };
        let d_signal: [S; 3] =
            std::array::from_fn(|a| slope * g[a] * self.weight + power * self.weight_grad[a]);
        let amp = S::from_f64(amp);
        self.sum = std::array::from_fn(|a| self.sum[a] + amp * d_signal[a]);
        let two_signal = S::from_f64(2.0) * signal;
        let inside = two_signal > zero && two_signal < S::ONE;
        self.weight_grad = std::array::from_fn(|a| {
            if inside {
                S::from_f64(2.0) * d_signal[a]
            } else {
                zero
            }
        });
        self.weight = two_signal.max_nan(zero).min_nan(S::ONE);
    }

    /// The gradient of the sum, NaN canonical.
    #[inline(always)]
    pub(super) fn gradient(&self) -> [S; 3] {
        self.sum.map(canonical_nan)
    }
}

/// sign(v): 1, -1, 0 for ±0 (the average of the two sides of |v|'s crease), NaN for NaN.
#[inline(always)]
pub(super) fn sign<S: Real>(v: S) -> S {
    if v > S::ZERO {
        S::ONE
    } else if v < S::ZERO {
        -S::ONE
    } else if v.is_nan() {
        S::NAN
    } else {
        S::ZERO
    }
}

/// The weight-slope part of the gradient of the trilinear blend every lattice basis evaluates,
/// `lerp(s_z, lerp(s_y, lerp(s_x, h0, h1), lerp(s_x, h2, h3)), lerp(s_y, lerp(s_x, h4, h5),
/// lerp(s_x, h6, h7)))` (corner `[dx + 2 dy + 4 dz]`), where the weight `s_a` depends on axis
/// a alone with slope `ds_a`. By the product rule through the lerps (`lerp(t, a, b) =
/// a + t (b - a)` has gradient `lerp(t, ∇a, ∇b) + (b - a) ∇t`), the blend's gradient is the
/// blend of the corners' gradients (`trilerp` of each component, or the same sum weighted
/// otherwise; 0 for value noise's constant corners) plus this:
///
/// - x: `ds_x · lerp(s_z, lerp(s_y, h1 - h0, h3 - h2), lerp(s_y, h5 - h4, h7 - h6))`;
/// - y: `ds_y · lerp(s_z, x23 - x01, x67 - x45)` with `x01` the x lerp of corners 0 and 1,
///   and so on;
/// - z: `ds_z · (y1 - y0)` with `y0`, `y1` the two y lerps.
#[inline(always)]
pub(super) fn blend_slopes<S: Real>(h: [S; 8], s: [S; 3], ds: [S; 3]) -> [S; 3] {
    use super::lattice::lerp;
    let [u, v, w] = s;
    let x01 = lerp(u, h[0], h[1]);
    let x23 = lerp(u, h[2], h[3]);
    let x45 = lerp(u, h[4], h[5]);
    let x67 = lerp(u, h[6], h[7]);
    let y0 = lerp(v, x01, x23);
    let y1 = lerp(v, x45, x67);
    let dx = lerp(
        w,
        lerp(v, h[1] - h[0], h[3] - h[2]),
        lerp(v, h[5] - h[4], h[7] - h[6]),
    );
    [
        ds[0] * dx,
        ds[1] * lerp(w, x23 - x01, x67 - x45),
        ds[2] * (y1 - y0),
    ]
}

/// The trilinear blend of eight corner values in the lattice bases' lerp order.
#[inline(always)]
pub(super) fn trilerp<S: Real>([u, v, w]: [S; 3], h: [S; 8]) -> S {
    use super::lattice::lerp;
    lerp(
        w,
        lerp(v, lerp(u, h[0], h[1]), lerp(u, h[2], h[3])),
        lerp(v, lerp(u, h[4], h[5]), lerp(u, h[6], h[7])),
    )
}

/// The eight trilinear weights `W_c` of the blend (`Σ_c W_c h_c` is [`trilerp`] in exact
/// arithmetic), corner `[dx + 2 dy + 4 dz]`.
#[inline(always)]
pub(super) fn corner_weights<S: Real>([u, v, w]: [S; 3]) -> [S; 8] {
    let one = S::ONE;
    let (u0, v0, w0) = (one - u, one - v, one - w);
    let yz = [v0 * w0, v * w0, v0 * w, v * w];
    std::array::from_fn(|c| {
        if c & 1 == 1 {
            u * yz[c >> 1]
        } else {
            u0 * yz[c >> 1]
        }
    })
}

/// A lattice gradient as returned by the point functions and the batch lanes: NaN canonical.
/// (A NaN fraction, from a non-finite coordinate, makes every component NaN: each component
/// multiplies or lerps by the weights of all three axes.)
#[inline(always)]
pub(super) fn canonical_grad<S: Real>(g: [S; 3]) -> [S; 3] {
    g.map(canonical_nan)
}

/// White noise's gradient: 0 (piecewise constant), NaN for non-finite input, with its value.
#[inline(always)]
pub(super) fn white_grad<S: Real>(value: S, p: [f64; 3]) -> (S, [S; 3]) {
    let finite = p.iter().all(|c| c.is_finite());
    (value, [if finite { S::ZERO } else { S::NAN }; 3])
}

/// `(n[i], g[c][i]) = k.sample_grad(p_i)` (tiled with `period` when given): the per-point
/// reference over a batch.
#[inline(always)]
pub(super) fn reference_grad_batch<S: Real, K: NoiseKernel>(
    k: &K,
    period: Option<Period>,
    [x, y, z]: [&[f64]; 3],
    n: &mut [S],
    [gx, gy, gz]: [&mut [S]; 3],
) {
    for i in 0..n.len() {
        let p = [x[i], y[i], z[i]];
        let (v, g) = match period {
            Some(period) => k.sample_grad_periodic(p, period),
            None => k.sample_grad(p),
        };
        n[i] = v;
        (gx[i], gy[i], gz[i]) = (g[0], g[1], g[2]);
    }
}
