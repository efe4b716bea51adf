//! The noise kernels' traits and their per-point references: [`NoiseKernel`], a basis as
//! everything outside `noise/` sees it (a per-point `sample`, and batch, tiled, fractal and
//! gradient forms whose defaults are loops over it), and [`LatticeKernel`], the form of the
//! lattice bases that `batch/`'s SIMD kernels take. The kernels themselves are in
//! `kernels.rs`, above the SIMD kernels.

use super::lanes::{canonical_nan, CHUNK, SMALL};
use super::lattice;
use super::octaves::{
    octaves_outside, shape_grad_lanes, turbulence_style, Amps, GradShaper, LaneOctaves,
    OctavePeriods, Style,
};
use super::period::{self, Period};
use super::perlin;
use crate::real::Real;

/// A noise basis as everything outside this module sees it (the interpreter, fractal sums,
/// constant folding, level of detail, the stability survey): a per-point reference and its
/// batch forms. A basis on the integer lattice implements [`LatticeKernel`] and gets the SIMD
/// batch kernels of `batch/` (points as lanes, or one point's octaves as lanes) through the
/// blanket implementation below. A basis on another grid — cellular noise's neighbour cells,
/// simplex noise's tetrahedra — implements this trait itself: `sample` alone is complete and
/// correct (the batch forms default to per-point loops, bit-identical by construction), and its
/// own batch kernels override them, held to `sample`'s bits by the same tests. Its range and
/// Lipschitz bound go on [`Basis`], whose matches are exhaustive.
pub(crate) trait NoiseKernel {
    /// One sample at `p` (positions in f64, interior arithmetic in `S`; NaN canonical).
    fn sample<S: Real>(&self, p: [f64; 3]) -> S;

    /// `out[i] = sample(p_i)` bit for bit.
    fn sample_batch<S: Real>(&self, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
        reference_batch(|p| self.sample(p), x, y, z, out);
    }

    /// One sample of the noise tiled with `period` (see `period.rs`). The default reduces the
    /// point into its period, which is all a basis without neighbours (white noise) needs.
    fn sample_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> S {
        self.sample(period::reduce3(p, period).0)
    }

    /// `out[i] = sample_periodic(p_i, period)` bit for bit.
    fn sample_batch_periodic<S: Real>(
        &self,
        period: Period,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        reference_batch(|p| self.sample_periodic(p, period), x, y, z, out);
    }

    /// A tiled fractal sum: `out[i] = Σ_o amp_o · sample_periodic(p_i · freq_o, period_o)`
    /// (|·| when `TURB`) in octave order from `S::ZERO`, NaN canonical, bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn fractal_batch_periodic<S: Real, const TURB: bool>(
        &self,
        freqs: &[f64],
        amps: &[f64],
        periods: &[Period],
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        octaves_outside(
            freqs,
            Amps::Shared(amps),
            turbulence_style(TURB),
            [x, y, z],
            out,
            |k, [sx, sy, sz], n| self.sample_batch_periodic(periods[k], sx, sy, sz, n),
        );
    }

    /// `out[i] = Σ_o amp_o · sample(p_i · freq_o)` (|·| when `TURB`), summed in octave order
    /// from `S::ZERO` as [`fractal`] does, bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn fractal_batch<S: Real, const TURB: bool>(
        &self,
        freqs: &[f64],
        amps: &[f64],
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        // Octaves outside, lanes inside: each octave is one `sample_batch` (the basis' own
        // batch kernel); a handful of lanes runs the reference loop.
        if out.len() < SMALL {
            return reference_fractal::<S, TURB>(|p| self.sample(p), freqs, amps, x, y, z, out);
        }
        let style = turbulence_style(TURB);
        octaves_outside(
            freqs,
            Amps::Shared(amps),
            style,
            [x, y, z],
            out,
            |_, [sx, sy, sz], n| self.sample_batch(sx, sy, sz, n),
        );
    }

    /// [`NoiseKernel::fractal_batch`] with level of detail per lane: lane i sums the octaves
    /// `lanes` keeps for it (see [`fractal_styled_batch_lanes`]), bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn fractal_batch_lanes<S: Real, const TURB: bool>(
        &self,
        freqs: &[f64],
        lanes: LaneOctaves,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        let style = turbulence_style(TURB);
        let amps = Amps::Lanes(lanes);
        octaves_outside(freqs, amps, style, [x, y, z], out, |_, [sx, sy, sz], n| {
            self.sample_batch(sx, sy, sz, n)
        });
    }

    /// The value (`sample`'s bits) and the exact gradient at `p` (see `derivative.rs`).
    fn sample_grad<S: Real>(&self, p: [f64; 3]) -> (S, [S; 3]);

    /// The value (`sample_periodic`'s bits) and the gradient of the noise tiled with `period`.
    /// The default reduces the point into its period (a translation per cell, so the gradient
    /// of the reduced point), which is all a basis without neighbours (white noise) needs.
    fn sample_grad_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> (S, [S; 3]) {
        self.sample_grad(period::reduce3(p, period).0)
    }

    /// Per lane, `(n[i], g[c][i])` = [`NoiseKernel::sample_grad`] of `p_i` (tiled when
    /// `period`) bit for bit; the values only when `VALUE` (else `n` is left unspecified).
    fn sample_grad_batch<S: Real, const VALUE: bool>(
        &self,
        period: Option<Period>,
        p: [&[f64]; 3],
        n: &mut [S],
        g: [&mut [S]; 3],
    ) where
        Self: Sized,
    {
        reference_grad_batch(self, period, p, n, g);
    }

    /// The gradient of an untiled fbm over a batch, `out[c][i]` =
    /// `fractal_styled_grad(.., Fbm, p_i)[c]` widened to f64, bit for bit.
    fn fbm_grad_batch<S: Real>(
        &self,
        freqs: &[f64],
        amps: &[f64],
        p: [&[f64]; 3],
        out: [&mut [f64]; 3],
    ) where
        Self: Sized,
    {
        octaves_grad::<S, Self>(self, freqs, amps, OctavePeriods::None, Style::Fbm, p, out);
    }
}

/// `out[i] = eval(p_i)`: the per-point reference over a batch.
#[inline(always)]
pub(super) fn reference_batch<S: Real>(
    eval: impl Fn([f64; 3]) -> S,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    for (((o, &x), &y), &z) in out.iter_mut().zip(x).zip(y).zip(z) {
        *o = eval([x, y, z]);
    }
}

/// The per-point reference of a fractal sum over a batch: per lane, the octaves summed in order
/// from `S::ZERO` as [`fractal`] does, NaN made canonical.
#[inline(always)]
pub(super) fn reference_fractal<S: Real, const TURB: bool>(
    eval: impl Fn([f64; 3]) -> S,
    freqs: &[f64],
    amps: &[f64],
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: &mut [S],
) {
    for (((o, &x), &y), &z) in out.iter_mut().zip(x).zip(y).zip(z) {
        let mut sum = S::ZERO;
        for (&f, &a) in freqs.iter().zip(amps) {
            let n: S = eval([x * f, y * f, z * f]);
            let n = if TURB { n.abs() } else { n };
            sum = sum + S::from_f64(a) * n;
        }
        *o = canonical_nan(sum);
    }
}

/// The lattice noise function of one basis, as one monomorphic kernel per basis, so the batch
/// loops can dispatch on the basis once per batch instead of once per lane.
///
/// Two formulations of one function: `eval` is the readable per-point reference; `hashes` and
/// `interior` are the batch kernels' form of it after the lattice step (cell indices mod 256 and
/// fractions already computed, see `batch/`): the eight corner hashes, then the arithmetic,
/// written without branches or byte tables so that a loop over lanes vectorises (and so that the
/// hashes can come from elsewhere, see `vbmi.rs`). Both give the same bits for every input
/// (proved by the tests, not assumed).
pub(super) trait LatticeKernel {
    /// Whether the corner hashes are Perlin's (`perlin::hashes_paired`) or Ebert's
    /// (`lattice::corner_hashes`, as Gradient and Value hash).
    const PERLIN_HASH: bool;
    fn eval<S: Real>(&self, p: [f64; 3]) -> S;
    /// The permutation, doubled (the byte-shuffle hashing of `vbmi.rs` reads its first half).
    fn perm(&self) -> &[u8; 512];
    /// The paired permutation (see [`NoiseTable`]'s `pairs`).
    fn pairs(&self) -> &[i32; 512];
    /// The eight corner hashes of a cell, `[dx + 2 dy + 4 dz]`, from the paired table.
    #[inline(always)]
    fn hashes(&self, cell: [i32; 3]) -> [u8; 8] {
        if Self::PERLIN_HASH {
            perlin::hashes_paired(self.pairs(), cell)
        } else {
            lattice::corner_hashes_paired(self.pairs(), cell)
        }
    }
    /// The noise value from the corner hashes and the fractions, NaN made canonical. `WIDE`
    /// tests hash bits on 32-bit integers rather than bytes (the same results): better code for
    /// targets without AVX-512BW, whose byte compares must be widened before a float blend.
    fn interior<S: Real, const WIDE: bool>(&self, h: [u8; 8], frac: [S; 3]) -> S;
    /// `interior`'s value (its bits, when `VALUE`; else 0) and its exact gradient with respect
    /// to the fractions, which is the gradient with respect to the point (see `derivative.rs`),
    /// from the same hashes and fractions; NaN on every component for a NaN fraction, not made
    /// canonical (the callers do: per lane, or once on a fractal sum). Straight lane code as
    /// `interior` is.
    fn interior_grad<S: Real, const WIDE: bool, const VALUE: bool>(
        &self,
        h: [u8; 8],
        frac: [S; 3],
    ) -> (S, [S; 3]);
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
pub(super) fn octaves_grad_amps<S: Real, K: NoiseKernel>(
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
