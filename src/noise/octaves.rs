//! The octave machinery of the fractal sums, below the tables and the kernels: octave schedules
//! ([`Octaves`]), the styles and their per-lane shaping (values and gradients), per-lane level
//! of detail ([`LaneOctaves`]), and the octave loop outside the lanes that every batch form
//! without a fused kernel runs.

use super::lanes::{canonical_nan, sign, CHUNK};
use super::period::Period;
use crate::real::Real;

/// Octave schedule of Fbm / Turbulence, precomputed at compile time.
#[derive(Clone, Debug, PartialEq)]
pub struct Octaves {
    /// Frequency of each octave: the sample point is scaled by it (in f64) before sampling.
    pub frequencies: Vec<f64>,
    /// Weight of each octave in the sum.
    pub amplitudes: Vec<f64>,
    /// Tiled sums: each octave's period, the base period times its frequency (a whole number:
    /// the checker allows a period only with an integer lacunarity).
    pub periods: Option<Vec<Period>>,
}

/// `base^exp` by binary exponentiation, in exactly the steps of compiler-rt's `__powidf2` (what
/// `f64::powi` calls at run time). Why not `f64::powi` itself: its precision is documented as
/// unspecified, and LLVM may constant-fold or expand it differently from the run-time routine,
/// so the schedule (and every golden image) could change with the compiler. This is frozen.
fn powi(base: f64, exp: u32) -> f64 {
    let (mut a, mut b, mut r) = (base, exp, 1.0f64);
    loop {
        if b & 1 == 1 {
            r *= a;
        }
        b /= 2;
        if b == 0 {
            return r;
        }
        a *= a;
    }
}

impl Octaves {
    /// Octave indices i = first_octave, first_octave+1, ... over `octaves` octaves:
    /// frequency lacunarity^i, amplitude gain^i (`f64::powi`'s algorithm, frozen in a local
    /// copy so the schedule can never change with the compiler). A fractional
    /// `octaves` (e.g. 2.5) adds a last, partial octave whose amplitude is multiplied by the
    /// fraction (0.5): smooth level of detail as `octaves` varies continuously.
    /// `octaves == 0` gives an empty schedule (sum 0). Callers validate octaves >= 0 and finite
    /// (and reasonably small: the schedule allocates one entry per octave).
    pub fn new(octaves: f64, lacunarity: f64, gain: f64, first_octave: u32) -> Octaves {
        let whole = octaves.floor();
        let fraction = octaves - whole;
        let full = whole as usize; // saturating; NaN gives 0
        let total = full + usize::from(fraction > 0.0);
        let mut frequencies = Vec::with_capacity(total);
        let mut amplitudes = Vec::with_capacity(total);
        for k in 0..total {
            // Saturate instead of overflowing: such octaves are far below f64 resolution anyway.
            let i = first_octave.saturating_add(u32::try_from(k).unwrap_or(u32::MAX));
            frequencies.push(powi(lacunarity, i));
            let amplitude = powi(gain, i);
            amplitudes.push(if k < full {
                amplitude
            } else {
                amplitude * fraction
            });
        }
        Octaves {
            frequencies,
            amplitudes,
            periods: None,
        }
    }

    /// The schedule tiled with `base`: octave i repeats every `base · frequency_i` (rounded to
    /// a whole number of cells, saturating).
    pub fn with_period(mut self, base: Option<Period>) -> Octaves {
        self.periods = base.map(|base| {
            self.frequencies
                .iter()
                .map(|&f| base.map(|p| (p as f64 * f.round()).min(u64::MAX as f64) as u64))
                .collect()
        });
        self
    }

    /// Number of octaves (a partial last octave counts as one).
    pub fn len(&self) -> usize {
        self.frequencies.len()
    }

    /// True for the empty schedule (`octaves == 0`), whose sum is 0.
    pub fn is_empty(&self) -> bool {
        self.frequencies.is_empty()
    }
}

/// How each octave's noise enters a fractal sum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Style {
    /// `Σ a_i n_i` (fractional Brownian motion).
    Fbm,
    /// `Σ a_i |n_i|` (Perlin's turbulence).
    Turbulence,
    /// `Σ a_i (2 |n_i| - 1)` (libnoise's billow: puffy, rounded crests).
    Billow,
    /// Musgrave's ridged multifractal (*Texturing and Modeling*, 3rd ed., ch. 16,
    /// `RidgedMultifractal`): per octave `s_i = max(offset - |n_i|, 0)^sharpness · w_i`,
    /// summed as `Σ a_i s_i`, with `w_0 = 1` and `w_{i+1} = clamp(2 s_i, 0, 1)` (Musgrave's
    /// weighting gain 2): octaves grow ridges only where the coarser octave has one. Musgrave's
    /// amplitudes `lacunarity^(-iH)` are the schedule's `gain^i`; `max(·, 0)` keeps a basis
    /// value just beyond ±offset from raising a negative number to a fractional power.
    Ridged { offset: f64, sharpness: f64 },
}

/// The style of a plain (`TURB == false`) or turbulent sum.
pub(super) const fn turbulence_style(turb: bool) -> Style {
    if turb {
        Style::Turbulence
    } else {
        Style::Fbm
    }
}

/// Per-lane state of a shaped (Billow, Ridged) sum: the same arithmetic on the point and the
/// batch paths, so both give the same bits.
#[derive(Clone, Copy)]
pub(super) struct Shaper<S> {
    pub(super) sum: S,
    weight: S,
}

impl<S: Real> Shaper<S> {
    pub(super) const START: Shaper<S> = Shaper {
        sum: S::ZERO,
        weight: S::ONE,
    };

    #[inline(always)]
    pub(super) fn add(&mut self, style: Style, n: S, amplitude: f64) {
        let a = S::from_f64(amplitude);
        match style {
            Style::Fbm => self.sum = self.sum + a * n,
            Style::Turbulence => self.sum = self.sum + a * n.abs(),
            Style::Billow => {
                self.sum = self.sum + a * (S::from_f64(2.0) * n.abs() - S::ONE);
            }
            Style::Ridged { offset, sharpness } => {
                let ridge = (S::from_f64(offset) - n.abs()).max_nan(S::ZERO);
                let signal = ridge.powf(S::from_f64(sharpness)) * self.weight;
                self.sum = self.sum + a * signal;
                self.weight = (S::from_f64(2.0) * signal).max_nan(S::ZERO).min_nan(S::ONE);
            }
        }
    }
}

/// Per-lane level of detail of a fractal sum: lane i keeps `kept[i]` octaves (continuous, the
/// last one faded), octave k weighted `powers[k]` unfaded — for each lane, exactly the
/// amplitudes of [`Octaves::new`]`(kept[i], ...)`. `kept` is as long as the batch.
#[derive(Clone, Copy, Debug)]
pub struct LaneOctaves<'a> {
    pub powers: &'a [f64],
    pub kept: &'a [f64],
}

impl LaneOctaves<'_> {
    /// Lane `i`'s octaves: the arithmetic of [`Octaves::new`] (`gain^k` below its whole
    /// octaves, times the fraction for the last, partial one), once per lane.
    #[inline(always)]
    pub(super) fn lane(&self, i: usize) -> LaneWeights {
        let kept = self.kept[i];
        let whole = kept.floor();
        let full = whole as usize;
        let fades = kept > whole;
        LaneWeights {
            whole: full,
            ends: full + usize::from(fades),
            partial: if fades {
                self.powers[full] * (kept - whole)
            } else {
                0.0
            },
        }
    }

    /// Octave `k`'s amplitude at lane `i`, `None` once the lane has dropped it.
    #[inline(always)]
    pub(super) fn amplitude(&self, k: usize, i: usize) -> Option<f64> {
        let lane = self.lane(i);
        if k < lane.whole {
            Some(self.powers[k])
        } else if k < lane.ends {
            Some(lane.partial)
        } else {
            None
        }
    }

    /// The octaves any of lanes `range` keeps (at most `limit`).
    #[inline]
    pub(super) fn most(&self, range: std::ops::Range<usize>, limit: usize) -> usize {
        let most = self.kept[range]
            .iter()
            .fold(0.0f64, |m, &k| m.max(k.ceil()));
        (most as usize).min(limit).min(self.powers.len())
    }
}

/// One lane's octaves ([`LaneOctaves::lane`]): octaves below `whole` at full amplitude, octave
/// `whole` at `partial` when `ends` is one more, none from `ends` on.
#[derive(Clone, Copy, Debug)]
pub(super) struct LaneWeights {
    pub(super) whole: usize,
    pub(super) ends: usize,
    pub(super) partial: f64,
}

/// The amplitudes of a fractal sum: one per octave for every lane (the schedule's), or per lane.
#[derive(Clone, Copy)]
pub(super) enum Amps<'a> {
    Shared(&'a [f64]),
    Lanes(LaneOctaves<'a>),
}

impl Amps<'_> {
    /// The octaves lanes `start..start + m` need.
    #[inline(always)]
    pub(super) fn octaves(&self, start: usize, m: usize, freqs: usize) -> usize {
        match self {
            Amps::Shared(a) => a.len().min(freqs),
            Amps::Lanes(l) => l.most(start..start + m, freqs),
        }
    }
}

/// Per lane of a chunk, [`Shaper::add`] of octave value `n[i]` with the lane's amplitude `amp(i)`
/// (`None`: the lane has dropped the octave, the sum is left alone). One loop per style, each
/// with its style a constant, so each is straight-line lane code that vectorises.
#[inline(always)]
fn shape_lanes<S: Real>(
    style: Style,
    shapers: &mut [Shaper<S>],
    n: &[S],
    amp: impl Fn(usize) -> Option<f64>,
) {
    let lanes = shapers.iter_mut().zip(n).enumerate();
    let add = |style: Style| {
        move |(i, (s, &v)): (usize, (&mut Shaper<S>, &S))| {
            if let Some(a) = amp(i) {
                s.add(style, v, a)
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

/// The octave loop of the batch fractal sums that have no fused kernel (and of per-lane level
/// of detail): per chunk of 64 lanes and octave k, the points scaled by `freqs[k]` in f64, one
/// `sample(k, scaled, n)` (a basis' batch kernel, plain or tiled), then [`Shaper::add`] per lane
/// with its amplitude: each lane sees the point function's operations in its order, so the
/// sums are its bits. With per-lane amplitudes a chunk runs only the octaves one of its lanes
/// keeps.
pub(super) fn octaves_outside<S: Real>(
    freqs: &[f64],
    amps: Amps,
    style: Style,
    [x, y, z]: [&[f64]; 3],
    out: &mut [S],
    mut sample: impl FnMut(usize, [&[f64]; 3], &mut [S]),
) {
    const CHUNK: usize = 64;
    let mut start = 0;
    while start < out.len() {
        let m = CHUNK.min(out.len() - start);
        let mut shapers = [Shaper::<S>::START; CHUNK];
        let mut scaled = [[0.0f64; CHUNK]; 3];
        let mut n = [S::ZERO; CHUNK];
        for (k, &f) in freqs[..amps.octaves(start, m, freqs.len())]
            .iter()
            .enumerate()
        {
            for (plane, src) in scaled.iter_mut().zip([x, y, z]) {
                for i in 0..m {
                    plane[i] = src[start + i] * f;
                }
            }
            let [sx, sy, sz] = &scaled;
            sample(k, [&sx[..m], &sy[..m], &sz[..m]], &mut n[..m]);
            let (shapers, n) = (&mut shapers[..m], &n[..m]);
            match amps {
                Amps::Shared(a) => shape_lanes(style, shapers, n, |_| Some(a[k])),
                Amps::Lanes(l) => shape_lanes(style, shapers, n, |i| l.amplitude(k, start + i)),
            }
        }
        for (o, shaper) in out[start..start + m].iter_mut().zip(&shapers[..m]) {
            *o = canonical_nan(shaper.sum);
        }
        start += m;
    }
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

/// Per lane of a chunk, [`GradShaper::add`] of octave value `n[i]` and gradient `g[·][i]` at
/// frequency `f` with the lane's amplitude `amp(i)` (`None`: dropped, the lane is left alone).
/// One loop per style, each with its style a constant (straight-line lane code).
#[inline(always)]
pub(super) fn shape_grad_lanes<S: Real>(
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
    /// Fbm adds `S(amplitude · freq) · g` per component (the fused lane kernel of `batch/`
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

impl OctavePeriods<'_> {
    /// Octave `i`'s period.
    #[inline(always)]
    pub(super) fn at(self, i: usize) -> Option<Period> {
        match self {
            OctavePeriods::None => None,
            OctavePeriods::Fixed(period) => Some(period),
            OctavePeriods::PerOctave(periods) => Some(periods[i]),
        }
    }
}
