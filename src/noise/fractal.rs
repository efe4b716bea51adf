//! Fractal sums of one basis over an octave schedule: fBm and turbulence.

use super::kernel::{reference_fractal, NoiseKernel};
use super::kernels::with_kernel;
use super::lanes::{canonical_nan, check_lengths};
use super::octaves::{octaves_outside, Amps, LaneOctaves, Octaves, Shaper, Style};
use super::table::NoiseTable;
use crate::real::Real;

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
            reference_fractal::<S, true>(sample, f, a, &[x], &[y], &[z], &mut out)
        } else {
            reference_fractal::<S, false>(sample, f, a, &[x], &[y], &[z], &mut out)
        }
    });
    out[0]
}

/// Per-lane bit-identical to [`fractal`]: the octave loop is outside the lane loop (so the basis
/// and turbulence dispatch happen once per batch, and the lanes of one octave vectorise; see
/// `batch/`), but each lane still sees the same additions in the same order, starting from
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
    check_lengths(x, y, z, out.len());
    let (f, a) = (&octaves.frequencies[..], &octaves.amplitudes[..]);
    with_kernel!(table, k => {
        if turbulence {
            k.fractal_batch::<S, true>(f, a, x, y, z, out)
        } else {
            k.fractal_batch::<S, false>(f, a, x, y, z, out)
        }
    });
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
            canonical_nan(shaper.sum)
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
    check_lengths(x, y, z, out.len());
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
    check_lengths(x, y, z, out.len());
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
