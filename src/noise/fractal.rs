//! Fractal sums of one basis over an octave schedule: fBm and turbulence.

use super::{
    Basis, CellularKernel, GradientKernel, Interpolation, NoiseKernel, NoiseTable, Period,
    PerlinKernel, SimplexKernel, ValueKernel, WhiteKernel,
};
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

/// Σ amp_i · basis(p · freq_i) (or Σ amp_i · |basis(...)| when `turbulence`), summed in S in
/// octave order, starting from `S::ZERO`: `sum = sum + S::from_f64(amp) * n`; a NaN sum is
/// returned as the canonical NaN (see `canonical_nan` in `noise`). Scaling p · freq is
/// done in f64, so high octaves keep their lattice cell exact.
pub fn fractal<S: Real>(table: &NoiseTable, octaves: &Octaves, turbulence: bool, p: [f64; 3]) -> S {
    let (f, a) = (&octaves.frequencies[..], &octaves.amplitudes[..]);
    let mut out = [S::ZERO];
    let ([x], [y], [z]) = ([p[0]], [p[1]], [p[2]]);
    with_kernel!(table, k => {
        let sample = |q| NoiseKernel::sample(&k, q);
        if turbulence {
            super::reference_fractal::<S, true>(sample, f, a, &[x], &[y], &[z], &mut out)
        } else {
            super::reference_fractal::<S, false>(sample, f, a, &[x], &[y], &[z], &mut out)
        }
    });
    out[0]
}

/// Per-lane bit-identical to [`fractal`]: the octave loop is outside the lane loop (so the basis
/// and turbulence dispatch happen once per batch, and the lanes of one octave vectorise; see
/// `batch.rs`), but each lane still sees the same additions in the same order, starting from
/// `S::ZERO`.
///
/// Panics if the slices' lengths differ (a caller bug).
pub fn fractal_batch<S: Real>(
    table: &NoiseTable,
    octaves: &Octaves,
    turbulence: bool,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    super::check_lengths(x, y, z, out.len());
    let (f, a) = (&octaves.frequencies[..], &octaves.amplitudes[..]);
    with_kernel!(table, k => {
        if turbulence {
            k.fractal_batch::<S, true>(f, a, x, y, z, out)
        } else {
            k.fractal_batch::<S, false>(f, a, x, y, z, out)
        }
    });
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
struct Shaper<S> {
    sum: S,
    weight: S,
}

impl<S: Real> Shaper<S> {
    const START: Shaper<S> = Shaper {
        sum: S::ZERO,
        weight: S::ONE,
    };

    #[inline(always)]
    fn add(&mut self, style: Style, n: S, amplitude: f64) {
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

/// One fractal sum of any style at `p`: Fbm and Turbulence as [`fractal`], Billow and Ridged
/// by the same octave loop (`p · freq` in f64, the sum in S from `S::ZERO`, NaN canonical).
pub fn fractal_styled<S: Real>(
    table: &NoiseTable,
    octaves: &Octaves,
    style: Style,
    p: [f64; 3],
) -> S {
    match (style, &octaves.periods) {
        (Style::Fbm, None) => fractal(table, octaves, false, p),
        (Style::Turbulence, None) => fractal(table, octaves, true, p),
        (_, periods) => {
            let mut shaper = Shaper::<S>::START;
            for (k, (&f, &a)) in octaves
                .frequencies
                .iter()
                .zip(&octaves.amplitudes)
                .enumerate()
            {
                let q = [p[0] * f, p[1] * f, p[2] * f];
                let n: S = match periods {
                    Some(periods) => table.sample_at_period(q, periods[k]),
                    None => table.sample(q),
                };
                shaper.add(style, n, a);
            }
            super::canonical_nan(shaper.sum)
        }
    }
}

/// Per lane bit-identical to [`fractal_styled`]. Billow and Ridged run the octave loop outside
/// the lanes, in chunks of 64: each octave is one [`NoiseTable::sample_batch`] (the basis' own
/// batch kernel), then the shaping per lane.
pub fn fractal_styled_batch<S: Real>(
    table: &NoiseTable,
    octaves: &Octaves,
    style: Style,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    super::check_lengths(x, y, z, out.len());
    let (f, a) = (&octaves.frequencies[..], &octaves.amplitudes[..]);
    match (style, &octaves.periods) {
        (Style::Fbm, None) => return fractal_batch(table, octaves, false, x, y, z, out),
        (Style::Turbulence, None) => return fractal_batch(table, octaves, true, x, y, z, out),
        (Style::Fbm, Some(periods)) => {
            with_kernel!(table, k => k.fractal_batch_periodic::<S, false>(f, a, periods, x, y, z, out));
            return;
        }
        (Style::Turbulence, Some(periods)) => {
            with_kernel!(table, k => k.fractal_batch_periodic::<S, true>(f, a, periods, x, y, z, out));
            return;
        }
        _ => {}
    }
    octaves_outside(
        &octaves.frequencies,
        Amps::Shared(&octaves.amplitudes),
        style,
        [x, y, z],
        out,
        |k, [sx, sy, sz], n| match &octaves.periods {
            Some(periods) => table.sample_batch_at_period(periods[k], sx, sy, sz, n),
            None => table.sample_batch(sx, sy, sz, n),
        },
    );
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
            *o = super::canonical_nan(shaper.sum);
        }
        start += m;
    }
}

/// [`fractal_styled_batch`] with level of detail per lane: lane i sums the octaves of
/// `octaves`' schedule that `lanes` keeps for it. Per lane bit-identical to
/// [`fractal_styled`] with the schedule `Octaves::new(lanes.kept[i], ...)` (its frequencies and
/// periods are the schedule's: an octave's frequency does not depend on how many are kept).
#[allow(clippy::too_many_arguments)]
pub fn fractal_styled_batch_lanes<S: Real>(
    table: &NoiseTable,
    octaves: &Octaves,
    lanes: LaneOctaves,
    style: Style,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    super::check_lengths(x, y, z, out.len());
    assert_eq!(lanes.kept.len(), out.len(), "one kept count per lane");
    let f = &octaves.frequencies[..];
    // As `fractal_batch`: untiled Fbm and Turbulence sample the basis' kernel itself.
    match (style, &octaves.periods) {
        (Style::Fbm, None) => {
            return with_kernel!(table, k => k.fractal_batch_lanes::<S, false>(f, lanes, x, y, z, out))
        }
        (Style::Turbulence, None) => {
            return with_kernel!(table, k => k.fractal_batch_lanes::<S, true>(f, lanes, x, y, z, out))
        }
        _ => {}
    }
    octaves_outside(
        &octaves.frequencies,
        Amps::Lanes(lanes),
        style,
        [x, y, z],
        out,
        |k, [sx, sy, sz], n| match &octaves.periods {
            Some(periods) => table.sample_batch_at_period(periods[k], sx, sy, sz, n),
            None => table.sample_batch(sx, sy, sz, n),
        },
    );
}
