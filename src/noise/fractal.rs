//! Fractal sums of one basis over an octave schedule: fBm and turbulence.

use super::{
    Basis, GradientKernel, Interpolation, NoiseKernel, NoiseTable, PerlinKernel, ValueKernel,
};
use crate::real::Real;

/// Octave schedule of Fbm / Turbulence, precomputed at compile time.
#[derive(Clone, Debug, PartialEq)]
pub struct Octaves {
    /// Frequency of each octave: the sample point is scaled by it (in f64) before sampling.
    pub frequencies: Vec<f64>,
    /// Weight of each octave in the sum.
    pub amplitudes: Vec<f64>,
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
        }
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
