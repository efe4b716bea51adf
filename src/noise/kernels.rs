//! Each basis' kernel over its tables ([`NoiseKernel`]): the lattice bases through
//! [`LatticeKernel`] and the SIMD kernels of `batch/` (the blanket implementation below),
//! simplex, cellular and white noise with their own. `with_kernel!` runs code with the kernel of
//! a [`NoiseTable`](super::table::NoiseTable)'s basis: one dispatch per call, monomorphic code
//! inside.

use super::batch;
use super::cellular::{self, Cellular};
use super::gradient;
use super::kernel::{
    octaves_grad, reference_batch, reference_grad_batch, LatticeKernel, NoiseKernel,
};
use super::lanes::{canonical_grad, canonical_nan, SMALL};
use super::lattice;
use super::octaves::{LaneOctaves, OctavePeriods, Style};
use super::period::{self, Period};
use super::perlin;
use super::simplex;
use super::value;
use crate::real::Real;

impl<K: LatticeKernel> NoiseKernel for K {
    #[inline(always)]
    fn sample<S: Real>(&self, p: [f64; 3]) -> S {
        self.eval(p)
    }

    /// The point reduced into its period; in a period's last cell the upper corner takes cell
    /// 0's hash (the general corner hashes, then the same `interior` as the batch kernels).
    #[inline]
    fn sample_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> S {
        let (q, wrap) = period::reduce3(p, period);
        if wrap == [false; 3] {
            return self.eval(q);
        }
        let cells = q.map(lattice::lattice);
        let lo = cells.map(|c| c.0);
        let hi: [usize; 3] = std::array::from_fn(|a| if wrap[a] { 0 } else { (lo[a] + 1) & 255 });
        let h = lattice::corner_hashes_wrapped(self.perm(), K::PERLIN_HASH, lo, hi);
        self.interior::<S, false>(h, cells.map(|c| S::from_f64(c.1)))
    }

    #[inline]
    fn sample_batch<S: Real>(&self, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
        batch::lattice::sample(self, x, y, z, out);
    }

    /// The tiled SIMD kernels (`batch::tiled::periodic`).
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
        batch::tiled::periodic_fractal::<S, K, TURB>(self, freqs, amps, periods, x, y, z, out);
    }

    /// Reduced points through the SIMD kernels, then the lanes in a period's last cell again
    /// through [`NoiseKernel::sample_periodic`] (see `batch::tiled::periodic`).
    fn sample_batch_periodic<S: Real>(
        &self,
        period: Period,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        batch::tiled::periodic(self, period, x, y, z, out);
    }

    #[inline]
    fn fractal_batch<S: Real, const TURB: bool>(
        &self,
        freqs: &[f64],
        amps: &[f64],
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        batch::lattice::fractal::<S, K, TURB>(self, freqs, amps, x, y, z, out);
    }

    /// The SIMD lane kernel (`batch::lattice::fractal_lod`).
    #[inline]
    fn fractal_batch_lanes<S: Real, const TURB: bool>(
        &self,
        freqs: &[f64],
        lanes: LaneOctaves,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        batch::lattice::fractal_lod::<S, K, TURB>(self, freqs, lanes, [x, y, z], out);
    }

    /// The lattice step and hashes as `sample`, then [`LatticeKernel::interior_grad`].
    #[inline]
    fn sample_grad<S: Real>(&self, p: [f64; 3]) -> (S, [S; 3]) {
        let cells = p.map(lattice::lattice);
        let h = self.hashes(cells.map(|c| c.0 as i32));
        let (v, g) = self.interior_grad::<S, false, true>(h, cells.map(|c| S::from_f64(c.1)));
        (v, canonical_grad(g))
    }

    /// As [`NoiseKernel::sample_periodic`]: the reduced point, the upper corner wrapped in a
    /// period's last cell.
    #[inline]
    fn sample_grad_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> (S, [S; 3]) {
        let (q, wrap) = period::reduce3(p, period);
        let cells = q.map(lattice::lattice);
        let lo = cells.map(|c| c.0);
        let h = if wrap == [false; 3] {
            self.hashes(lo.map(|c| c as i32))
        } else {
            let hi: [usize; 3] =
                std::array::from_fn(|a| if wrap[a] { 0 } else { (lo[a] + 1) & 255 });
            lattice::corner_hashes_wrapped(self.perm(), K::PERLIN_HASH, lo, hi)
        };
        let (v, g) = self.interior_grad::<S, false, true>(h, cells.map(|c| S::from_f64(c.1)));
        (v, canonical_grad(g))
    }

    /// The SIMD lane kernel (`batch::lattice::grad`) for untiled batches of [`SMALL`] lanes or
    /// more; the per-point loop otherwise.
    fn sample_grad_batch<S: Real, const VALUE: bool>(
        &self,
        period: Option<Period>,
        p: [&[f64]; 3],
        n: &mut [S],
        g: [&mut [S]; 3],
    ) {
        match period {
            None if n.len() >= SMALL => batch::lattice::grad::<S, K, VALUE>(self, p, n, g),
            _ => reference_grad_batch(self, period, p, n, g),
        }
    }

    /// The fused SIMD lane kernel (`batch::lattice::fbm_grad`).
    fn fbm_grad_batch<S: Real>(
        &self,
        freqs: &[f64],
        amps: &[f64],
        p: [&[f64]; 3],
        out: [&mut [f64]; 3],
    ) {
        if out[0].len() < SMALL {
            return octaves_grad::<S, Self>(
                self,
                freqs,
                amps,
                OctavePeriods::None,
                Style::Fbm,
                p,
                out,
            );
        }
        batch::lattice::fbm_grad::<S, K>(self, freqs, amps, p, out);
    }
}

/// Runs `$body` with `$k` bound to the [`NoiseKernel`] of `$table`'s basis.
macro_rules! with_kernel {
    ($table:expr, $k:ident => $body:expr) => {{
        let t = $table;
        match t.basis {
            $crate::noise::basis::Basis::Perlin => {
                let $k = $crate::noise::kernels::PerlinKernel {
                    perm: &t.perm,
                    pairs: &t.pairs,
                };
                $body
            }
            $crate::noise::basis::Basis::Gradient => {
                let $k = $crate::noise::kernels::GradientKernel {
                    perm: &t.perm,
                    pairs: &t.pairs,
                    grads: &t.grads,
                };
                $body
            }
            $crate::noise::basis::Basis::Value($crate::noise::basis::Interpolation::Linear) => {
                let $k = $crate::noise::kernels::ValueKernel::<false> {
                    perm: &t.perm,
                    pairs: &t.pairs,
                    values: &t.values,
                };
                $body
            }
            $crate::noise::basis::Basis::Value($crate::noise::basis::Interpolation::Smooth) => {
                let $k = $crate::noise::kernels::ValueKernel::<true> {
                    perm: &t.perm,
                    pairs: &t.pairs,
                    values: &t.values,
                };
                $body
            }
            $crate::noise::basis::Basis::Simplex => {
                let $k = $crate::noise::kernels::SimplexKernel {
                    perm: &t.perm,
                    signs: &t.signs,
                };
                $body
            }
            $crate::noise::basis::Basis::Cellular(params) => {
                let $k = $crate::noise::kernels::CellularKernel { key: t.key, params };
                $body
            }
            $crate::noise::basis::Basis::White => {
                let $k = $crate::noise::kernels::WhiteKernel { key: t.key };
                $body
            }
        }
    }};
}

/// [`Basis::Perlin`]'s kernel.
pub(super) struct PerlinKernel<'a> {
    pub(super) perm: &'a [u8; 512],
    pub(super) pairs: &'a [i32; 512],
}

impl LatticeKernel for PerlinKernel<'_> {
    const PERLIN_HASH: bool = true;
    #[inline(always)]
    fn eval<S: Real>(&self, p: [f64; 3]) -> S {
        canonical_nan(perlin::sample(self.perm, p))
    }
    #[inline(always)]
    fn perm(&self) -> &[u8; 512] {
        self.perm
    }
    #[inline(always)]
    fn pairs(&self) -> &[i32; 512] {
        self.pairs
    }
    #[inline(always)]
    fn interior<S: Real, const WIDE: bool>(&self, h: [u8; 8], frac: [S; 3]) -> S {
        canonical_nan(perlin::interior::<S, WIDE>(h, frac))
    }
    #[inline(always)]
    fn interior_grad<S: Real, const WIDE: bool, const VALUE: bool>(
        &self,
        h: [u8; 8],
        frac: [S; 3],
    ) -> (S, [S; 3]) {
        let (v, g) = perlin::interior_grad::<S, WIDE, VALUE>(h, frac);
        (canonical_nan(v), g)
    }
}

/// [`Basis::Gradient`]'s kernel.
pub(super) struct GradientKernel<'a> {
    pub(super) perm: &'a [u8; 512],
    pub(super) pairs: &'a [i32; 512],
    pub(super) grads: &'a [[f32; 3]; 256],
}

impl LatticeKernel for GradientKernel<'_> {
    const PERLIN_HASH: bool = false;
    #[inline(always)]
    fn eval<S: Real>(&self, p: [f64; 3]) -> S {
        canonical_nan(gradient::sample(self.perm, self.grads, p))
    }
    #[inline(always)]
    fn perm(&self) -> &[u8; 512] {
        self.perm
    }
    #[inline(always)]
    fn pairs(&self) -> &[i32; 512] {
        self.pairs
    }
    #[inline(always)]
    fn interior<S: Real, const WIDE: bool>(&self, h: [u8; 8], frac: [S; 3]) -> S {
        canonical_nan(gradient::interior(self.grads, h, frac))
    }
    #[inline(always)]
    fn interior_grad<S: Real, const WIDE: bool, const VALUE: bool>(
        &self,
        h: [u8; 8],
        frac: [S; 3],
    ) -> (S, [S; 3]) {
        let (v, g) = gradient::interior_grad::<S, VALUE>(self.grads, h, frac);
        (canonical_nan(v), g)
    }
}

/// [`Basis::Value`]'s kernel; `SMOOTH` selects [`Interpolation::Smooth`].
pub(super) struct ValueKernel<'a, const SMOOTH: bool> {
    pub(super) perm: &'a [u8; 512],
    pub(super) pairs: &'a [i32; 512],
    pub(super) values: &'a [f32; 256],
}

impl<const SMOOTH: bool> LatticeKernel for ValueKernel<'_, SMOOTH> {
    const PERLIN_HASH: bool = false;
    #[inline(always)]
    fn eval<S: Real>(&self, p: [f64; 3]) -> S {
        canonical_nan(value::sample::<S, SMOOTH>(self.perm, self.values, p))
    }
    #[inline(always)]
    fn perm(&self) -> &[u8; 512] {
        self.perm
    }
    #[inline(always)]
    fn pairs(&self) -> &[i32; 512] {
        self.pairs
    }
    #[inline(always)]
    fn interior<S: Real, const WIDE: bool>(&self, h: [u8; 8], frac: [S; 3]) -> S {
        canonical_nan(value::interior::<S, SMOOTH>(self.values, h, frac))
    }
    #[inline(always)]
    fn interior_grad<S: Real, const WIDE: bool, const VALUE: bool>(
        &self,
        h: [u8; 8],
        frac: [S; 3],
    ) -> (S, [S; 3]) {
        let (v, g) = value::interior_grad::<S, SMOOTH, VALUE>(self.values, h, frac);
        (canonical_nan(v), g)
    }
}

/// [`Basis::Simplex`]'s kernel.
pub(super) struct SimplexKernel<'a> {
    pub(super) perm: &'a [u8; 512],
    pub(super) signs: &'a [[u8; 256]; 3],
}

impl NoiseKernel for SimplexKernel<'_> {
    #[inline(always)]
    fn sample<S: Real>(&self, p: [f64; 3]) -> S {
        canonical_nan(simplex::sample(self.perm, p))
    }

    /// The lane kernel of `batch/`, bit for bit `sample`.
    fn sample_batch<S: Real>(&self, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
        if out.len() < SMALL {
            return reference_batch(|p| self.sample(p), x, y, z, out);
        }
        batch::simplex::simplex(self.perm, self.signs, x, y, z, out);
    }

    /// Vertices hashed as their translates into the period box (`simplex::sample_periodic`).
    fn sample_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> S {
        canonical_nan(simplex::sample_periodic(self.perm, p, period))
    }

    /// The tiled lane kernel of `batch/`, bit for bit `sample_periodic`.
    fn sample_batch_periodic<S: Real>(
        &self,
        period: Period,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        if out.len() < SMALL {
            return reference_batch(|p| self.sample_periodic(p, period), x, y, z, out);
        }
        batch::simplex::simplex_periodic(self.perm, self.signs, period, x, y, z, out);
    }

    fn sample_grad<S: Real>(&self, p: [f64; 3]) -> (S, [S; 3]) {
        let (v, g) = simplex::sample_grad(self.perm, p);
        (canonical_nan(v), g.map(canonical_nan))
    }

    fn sample_grad_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> (S, [S; 3]) {
        let (v, g) = simplex::sample_grad_periodic(self.perm, p, period);
        (canonical_nan(v), g.map(canonical_nan))
    }
}

/// [`Basis::Cellular`]'s kernel.
pub(super) struct CellularKernel {
    /// The cell hash's key (`hash.rs`).
    pub(super) key: [u32; 2],
    pub(super) params: Cellular,
}

impl NoiseKernel for CellularKernel {
    #[inline(always)]
    fn sample<S: Real>(&self, p: [f64; 3]) -> S {
        canonical_nan(cellular::sample(self.key, self.params, None, p))
    }

    /// The SIMD kernel of `batch/` (the 27 nearest cells over lanes), bit for bit `sample`.
    fn sample_batch<S: Real>(&self, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
        if out.len() < SMALL {
            return reference_batch(|p| self.sample(p), x, y, z, out);
        }
        batch::cellular::cellular(self.key, self.params, x, y, z, out);
    }

    /// The point reduced into its period, and the neighbour cells wrapped around it.
    fn sample_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> S {
        let q = period::reduce3(p, period).0;
        canonical_nan(cellular::sample(self.key, self.params, Some(period), q))
    }

    fn sample_grad<S: Real>(&self, p: [f64; 3]) -> (S, [S; 3]) {
        let (v, g) = cellular::sample_grad(self.key, self.params, None, p);
        (canonical_nan(v), g.map(canonical_nan))
    }

    fn sample_grad_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> (S, [S; 3]) {
        let q = period::reduce3(p, period).0;
        let (v, g) = cellular::sample_grad(self.key, self.params, Some(period), q);
        (canonical_nan(v), g.map(canonical_nan))
    }
}

/// [`Basis::White`]'s kernel.
pub(super) struct WhiteKernel {
    /// The cell hash's key (`hash.rs`).
    pub(super) key: [u32; 2],
}

impl NoiseKernel for WhiteKernel {
    #[inline(always)]
    fn sample<S: Real>(&self, p: [f64; 3]) -> S {
        canonical_nan(value::white(self.key, p))
    }

    fn sample_grad<S: Real>(&self, p: [f64; 3]) -> (S, [S; 3]) {
        white_grad(self.sample(p), p)
    }
}

/// White noise's gradient: 0 (piecewise constant), NaN for non-finite input, with its value.
#[inline(always)]
fn white_grad<S: Real>(value: S, p: [f64; 3]) -> (S, [S; 3]) {
    let finite = p.iter().all(|c| c.is_finite());
    (value, [if finite { S::ZERO } else { S::NAN }; 3])
}

pub(super) use with_kernel;
