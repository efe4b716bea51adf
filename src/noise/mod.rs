//! Lattice noise bases (Perlin's improved noise, Ebert's gradient noise, value noise) and their
//! fractal sums, evaluated one point at a time or over a batch of lanes.
//!
//! Precision contract: positions are always `f64`, so the integer lattice cell of a point stays
//! exact far beyond f32's 24-bit mantissa; the cell index mod 256 and the fraction within the cell
//! are computed in f64, and only the fraction enters the interior arithmetic in `S` (f32 or f64).
//! The tables are built by a frozen generator (`rng.rs`) so a graph's output never changes, and
//! stored in f32 precision so the f32 and f64 paths read identical numbers.
//!
//! The batch functions (`batch.rs`) run a SIMD formulation of the same arithmetic: per octave, a
//! lattice loop in f64, the corner hashes (gathers, or byte shuffles on AVX-512 VBMI in
//! `vbmi.rs`) and an interior loop in S, compiled per instruction set and picked at run time.
//! They return the point functions' bits (Rust never contracts or reassociates float arithmetic;
//! NaN results are made canonical on both paths); the tests hold them to it.
//!
//! Gradients (`derivative.rs`, for the `Gradient` node): the exact analytic gradient with
//! respect to the point of every basis and fractal sum ([`NoiseTable::sample_grad`],
//! [`fractal_styled_grad`] and their batch forms), under the same precision contract and the
//! same bit-for-bit rule; the lattice bases through `LatticeKernel::interior_grad` and the lane
//! kernels of `batch.rs` (an 8-octave Perlin fbm's gradient costs about twice its value).

mod cellular;
mod lattice;
mod period;
mod rng;
mod simplex;

pub use period::Period;

pub use cellular::{Cellular, CellularValue, Metric};

/// The crate's one fixed generator, also used for sample sets (report, level of detail).
pub(crate) use rng::SplitMix64;

/// A noise basis as everything outside this module sees it (the interpreter, fractal sums,
/// constant folding, level of detail, the stability survey): a per-point reference and its
/// batch forms. A basis on the integer lattice implements [`LatticeKernel`] and gets the SIMD
/// batch kernels of `batch.rs` (points as lanes, or one point's octaves as lanes) through the
/// blanket implementation below. A basis on another grid — cellular noise's neighbour cells,
/// simplex noise's skewed grid — implements this trait itself: `sample` alone is complete and
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
        fractal::octaves_outside(
            freqs,
            fractal::Amps::Shared(amps),
            fractal::turbulence_style(TURB),
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
        if out.len() < batch::SMALL {
            return reference_fractal::<S, TURB>(|p| self.sample(p), freqs, amps, x, y, z, out);
        }
        let style = fractal::turbulence_style(TURB);
        fractal::octaves_outside(
            freqs,
            fractal::Amps::Shared(amps),
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
        let style = fractal::turbulence_style(TURB);
        let amps = fractal::Amps::Lanes(lanes);
        fractal::octaves_outside(freqs, amps, style, [x, y, z], out, |_, [sx, sy, sz], n| {
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
        derivative::reference_grad_batch(self, period, p, n, g);
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
        derivative::octaves_grad::<S, Self>(
            self,
            freqs,
            amps,
            derivative::OctavePeriods::None,
            Style::Fbm,
            p,
            out,
        );
    }
}

/// `out[i] = eval(p_i)`: the per-point reference over a batch.
#[inline(always)]
fn reference_batch<S: Real>(
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
fn reference_fractal<S: Real, const TURB: bool>(
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
        batch::sample(self, x, y, z, out);
    }

    /// The tiled SIMD kernels (`batch::periodic`).
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
        batch::periodic_fractal::<S, K, TURB>(self, freqs, amps, periods, x, y, z, out);
    }

    /// Reduced points through the SIMD kernels, then the lanes in a period's last cell again
    /// through [`NoiseKernel::sample_periodic`] (see `batch::periodic`).
    fn sample_batch_periodic<S: Real>(
        &self,
        period: Period,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        batch::periodic(self, period, x, y, z, out);
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
        batch::fractal::<S, K, TURB>(self, freqs, amps, x, y, z, out);
    }

    /// The SIMD lane kernel (`batch::fractal_lod`).
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
        batch::fractal_lod::<S, K, TURB>(self, freqs, lanes, [x, y, z], out);
    }

    /// The lattice step and hashes as `sample`, then [`LatticeKernel::interior_grad`].
    #[inline]
    fn sample_grad<S: Real>(&self, p: [f64; 3]) -> (S, [S; 3]) {
        let cells = p.map(lattice::lattice);
        let h = self.hashes(cells.map(|c| c.0 as i32));
        let (v, g) = self.interior_grad::<S, false, true>(h, cells.map(|c| S::from_f64(c.1)));
        (v, derivative::canonical_grad(g))
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
        (v, derivative::canonical_grad(g))
    }

    /// The SIMD lane kernel (`batch::grad`) for untiled batches of [`batch::SMALL`] lanes or
    /// more; the per-point loop otherwise.
    fn sample_grad_batch<S: Real, const VALUE: bool>(
        &self,
        period: Option<Period>,
        p: [&[f64]; 3],
        n: &mut [S],
        g: [&mut [S]; 3],
    ) {
        match period {
            None if n.len() >= batch::SMALL => batch::grad::<S, K, VALUE>(self, p, n, g),
            _ => derivative::reference_grad_batch(self, period, p, n, g),
        }
    }

    /// The fused SIMD lane kernel (`batch::fbm_grad`).
    fn fbm_grad_batch<S: Real>(
        &self,
        freqs: &[f64],
        amps: &[f64],
        p: [&[f64]; 3],
        out: [&mut [f64]; 3],
    ) {
        if out[0].len() < batch::SMALL {
            return derivative::octaves_grad::<S, Self>(
                self,
                freqs,
                amps,
                derivative::OctavePeriods::None,
                Style::Fbm,
                p,
                out,
            );
        }
        batch::fbm_grad::<S, K>(self, freqs, amps, p, out);
    }
}

/// The lattice noise function of one basis, as one monomorphic kernel per basis, so the batch
/// loops can dispatch on the basis once per batch instead of once per lane.
///
/// Two formulations of one function: `eval` is the readable per-point reference; `hashes` and
/// `interior` are the batch kernels' form of it after the lattice step (cell indices mod 256 and
/// fractions already computed, see `batch.rs`): the eight corner hashes, then the arithmetic,
/// written without branches or byte tables so that a loop over lanes vectorises (and so that the
/// hashes can come from elsewhere, see `vbmi.rs`). Both give the same bits for every input
/// (proved by the tests, not assumed).
trait LatticeKernel {
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

/// Runs `$body` with `$k` bound to the [`NoiseKernel`] of `$table`'s basis.
macro_rules! with_kernel {
    ($table:expr, $k:ident => $body:expr) => {{
        let t: &NoiseTable = $table;
        match t.basis {
            Basis::Perlin => {
                let $k = PerlinKernel {
                    perm: &t.perm,
                    pairs: &t.pairs,
                };
                $body
            }
            Basis::Gradient => {
                let $k = GradientKernel {
                    perm: &t.perm,
                    pairs: &t.pairs,
                    grads: &t.grads,
                };
                $body
            }
            Basis::Value(Interpolation::Linear) => {
                let $k = ValueKernel::<false> {
                    perm: &t.perm,
                    pairs: &t.pairs,
                    values: &t.values,
                };
                $body
            }
            Basis::Value(Interpolation::Smooth) => {
                let $k = ValueKernel::<true> {
                    perm: &t.perm,
                    pairs: &t.pairs,
                    values: &t.values,
                };
                $body
            }
            Basis::Simplex => {
                let $k = SimplexKernel {
                    perm: &t.perm,
                    signs: &t.signs,
                };
                $body
            }
            Basis::Cellular(params) => {
                let $k = CellularKernel {
                    perm: &t.perm,
                    features: &t.features,
                    values: &t.values,
                    params,
                };
                $body
            }
            Basis::White => {
                let $k = WhiteKernel {
                    perm: &t.perm,
                    values: &t.values,
                };
                $body
            }
        }
    }};
}

// The SIMD modules are the only places `unsafe` is allowed (the crate root denies it): runtime
// feature dispatch and the AVX-512 VBMI intrinsics. Every block states its invariant in a
// `// SAFETY:` comment (clippy's `undocumented_unsafe_blocks` is on).
#[allow(unsafe_code)]
mod batch;
mod derivative;
#[cfg(test)]
mod derivative_tests;
mod fractal;
mod gradient;
mod perlin;
#[cfg(test)]
#[allow(unsafe_code)] // calls the VBMI kernel directly, after detecting the features
mod tests;
mod value;
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod vbmi;

pub use derivative::{
    fractal_styled_grad, fractal_styled_grad_batch, fractal_styled_grad_batch_lanes,
};
pub use fractal::{
    fractal, fractal_batch, fractal_styled, fractal_styled_batch, fractal_styled_batch_lanes,
    LaneOctaves, Octaves, Style,
};

use crate::real::Real;

/// The noise function underlying a noise node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Basis {
    /// Ken Perlin's 2002 improved noise; seed 0 is the published reference. Range within ±1.04.
    Perlin,
    /// Ebert's gradient noise (random unit gradients); zero on lattice points, range ±√3/2.
    Gradient,
    /// Value noise: random values in [0, 1] on lattice points, interpolated.
    Value(Interpolation),
    /// Simplex gradient noise on the skewed grid (see `simplex.rs`); range ±1.
    Simplex,
    /// Cellular (Worley) noise (see `cellular.rs`).
    Cellular(Cellular),
    /// A per-cell random value in [0, 1] (the `WhiteNoise` node; not a fractal basis).
    White,
}

/// Interpolation of value noise between lattice points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Interpolation {
    /// Trilinear: continuous, with creases at cell faces.
    Linear,
    /// Trilinear with smoothstep weights t²(3 - 2t): C¹.
    Smooth,
}

/// Immutable lattice tables for one (basis, seed); Send + Sync; built once at compile time.
///
/// Every table is kept even when the basis does not read it (zeros then): the struct is small
/// (about 6.7 KB) and a fixed layout keeps all indexing free of bounds checks.
#[derive(Clone)]
pub struct NoiseTable {
    basis: Basis,
    seed: u64,
    /// Tiling period of [`NoiseTable::sample`], if any.
    period: Option<Period>,
    /// The permutation of 0..=255, doubled to 512 entries so that a hash plus an index <= 255
    /// needs no wrap.
    perm: [u8; 512],
    /// `perm[i] | perm[i + 1] << 8` (`perm[0]` after the last entry) as i32: the batch kernels'
    /// form of the permutation. Every hash step reads two neighbouring entries, so one 32-bit
    /// table read (a SIMD gather) serves both; see `lattice::corner_hashes_paired`.
    pairs: [i32; 512],
    /// Gradient basis: unit vectors (f32 precision, see the module docs).
    grads: [[f32; 3]; 256],
    /// Value basis: lattice values in [0, 1] (f32 precision); Cellular: the per-cell values of
    /// `CellValue`; White: the per-cell values.
    values: [f32; 256],
    /// Cellular basis: the jittered feature point of each hash value, in [0, 1]³ (f32), as
    /// three planes x, y, z.
    features: [[f32; 256]; 3],
    /// Simplex basis: the gradient of each hash step's last index `j`,
    /// `GRADIENTS[perm[j] % 12]`, as three planes of -1 / 0 / 1 bytes (two's complement), so
    /// that the batch kernel's last lookup gives the gradient directly.
    signs: [[u8; 256]; 3],
}

impl std::fmt::Debug for NoiseTable {
    // The tables themselves are noise to a reader; (basis, seed) determines them.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NoiseTable")
            .field("basis", &self.basis)
            .field("seed", &self.seed)
            .finish_non_exhaustive()
    }
}

impl NoiseTable {
    /// The tables as the GPU path reads them (`gpu/wgsl/common.wgsl`): 2304 32-bit words, the
    /// doubled permutation (512), the Gradient unit vectors (256 × 3, f32 bits), the values
    /// (256, f32 bits), the Cellular feature points (3 planes of 256, f32 bits).
    #[cfg_attr(not(feature = "gpu"), allow(dead_code))]
    pub(crate) fn gpu_words(&self) -> Vec<u32> {
        let mut words = Vec::with_capacity(2304);
        words.extend(self.perm.iter().map(|&p| u32::from(p)));
        words.extend(self.grads.iter().flatten().map(|g| g.to_bits()));
        words.extend(self.values.iter().map(|v| v.to_bits()));
        words.extend(self.features.iter().flatten().map(|f| f.to_bits()));
        words
    }

    /// Builds the tables of `basis` for `seed`: deterministic forever (see `rng.rs`).
    ///
    /// The permutation is the identity shuffled by Fisher–Yates from SplitMix64 seeded with
    /// `seed ^ PERM_SALT`, except that `Perlin` with seed 0 uses the published reference
    /// permutation. Gradient vectors and values come from their own streams
    /// (`seed ^ GRAD_SALT`, `seed ^ VALUE_SALT`), independent of the permutation.
    pub fn new(basis: Basis, seed: u64) -> Self {
        let base = if basis == Basis::Perlin && seed == 0 {
            perlin::REFERENCE_PERMUTATION
        } else {
            rng::shuffled_permutation(seed ^ rng::PERM_SALT)
        };
        let mut perm = [0u8; 512];
        perm[..256].copy_from_slice(&base);
        perm[256..].copy_from_slice(&base);
        let grads = match basis {
            Basis::Gradient => gradient::unit_vectors(seed ^ rng::GRAD_SALT),
            _ => [[0.0; 3]; 256],
        };
        let values = match basis {
            Basis::Value(_) => value::values(seed ^ rng::VALUE_SALT),
            // Per-cell values in [0, 1): one that rounded up to 1 in f32 is held below it.
            Basis::Cellular(_) | Basis::White => {
                value::values(seed ^ rng::VALUE_SALT).map(|v| v.min(1.0f32.next_down()))
            }
            _ => [0.0; 256],
        };
        let features = match basis {
            Basis::Cellular(c) => cellular::features(seed ^ rng::CELL_SALT, c.jitter()),
            _ => [[0.0; 256]; 3],
        };
        let signs = match basis {
            Basis::Simplex => std::array::from_fn(|a| {
                std::array::from_fn(|j| {
                    simplex::GRADIENTS[usize::from(perm[j]) % 12][a] as i8 as u8
                })
            }),
            _ => [[0; 256]; 3],
        };
        let pairs = std::array::from_fn(|i| perm[i] as i32 | (perm[(i + 1) % 512] as i32) << 8);
        NoiseTable {
            basis,
            seed,
            period: None,
            perm,
            pairs,
            grads,
            values,
            features,
            signs,
        }
    }

    /// The same tables, sampled tiled with `period` (cells per axis, each at least 1).
    pub fn periodic(basis: Basis, seed: u64, period: Option<Period>) -> Self {
        NoiseTable {
            period: period.filter(|p| p.iter().all(|&c| c >= 1)),
            ..NoiseTable::new(basis, seed)
        }
    }

    /// The tiling period of [`NoiseTable::sample`], if any.
    pub fn period(&self) -> Option<Period> {
        self.period
    }

    /// The basis these tables serve.
    pub fn basis(&self) -> Basis {
        self.basis
    }

    /// The seed the tables were built from.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Cellular basis: the feature point of integer cell `cell`, in world coordinates (the
    /// cell's corner plus its jittered offset); `None` for other bases. For independent
    /// references (a brute-force search over many cells) and tools.
    pub fn feature_point(&self, cell: [i64; 3]) -> Option<[f64; 3]> {
        let Basis::Cellular(_) = self.basis else {
            return None;
        };
        let h = self.cell_hash(cell);
        Some(std::array::from_fn(|a| {
            cell[a] as f64 + self.features[a][h] as f64
        }))
    }

    /// Cellular and White bases: the random value in [0, 1] of integer cell `cell` (what
    /// `CellValue` and `WhiteNoise` return there); `None` for other bases.
    pub fn cell_value(&self, cell: [i64; 3]) -> Option<f64> {
        match self.basis {
            Basis::Cellular(_) | Basis::White => Some(self.values[self.cell_hash(cell)] as f64),
            _ => None,
        }
    }

    /// The hash of an integer cell (indices mod 256), as every basis hashes a lattice point.
    fn cell_hash(&self, cell: [i64; 3]) -> usize {
        let [i, j, k] = cell.map(|c| c.rem_euclid(256) as usize);
        lattice::corner_hashes(&self.perm, i, j, k)[0]
    }

    /// One sample at p. Positions are f64 (always, also on the f32 path); the interior
    /// arithmetic is in S. Non-finite coordinates give NaN; any finite coordinate (even 1e300)
    /// is fine.
    #[inline]
    pub fn sample<S: Real>(&self, p: [f64; 3]) -> S {
        match self.period {
            None => with_kernel!(self, k => NoiseKernel::sample(&k, p)),
            Some(period) => self.sample_at_period(p, period),
        }
    }

    /// One sample of these tables tiled with `period` (whatever the table's own period): the
    /// fractal sums sample octave i at their own period.
    #[inline]
    pub fn sample_at_period<S: Real>(&self, p: [f64; 3], period: Period) -> S {
        with_kernel!(self, k => k.sample_periodic(p, period))
    }

    /// [`NoiseTable::sample_at_period`] over a batch, bit for bit.
    pub fn sample_batch_at_period<S: Real>(
        &self,
        period: Period,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        check_lengths(x, y, z, out.len());
        with_kernel!(self, k => k.sample_batch_periodic(period, x, y, z, out));
    }

    /// `out[i] = sample(x[i], y[i], z[i])` bit for bit: one basis dispatch per batch, then the
    /// SIMD lane kernels of `batch.rs` (runtime CPU feature detection), or for a handful of lanes
    /// or a CPU without SSE4.1 a straight loop running [`NoiseTable::sample`]'s kernel.
    ///
    /// Panics only if the slices' lengths differ (a caller bug).
    pub fn sample_batch<S: Real>(&self, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
        check_lengths(x, y, z, out.len());
        match self.period {
            None => with_kernel!(self, k => k.sample_batch(x, y, z, out)),
            Some(period) => with_kernel!(self, k => k.sample_batch_periodic(period, x, y, z, out)),
        }
    }

    /// Guaranteed `[min, max]` of [`NoiseTable::sample`] for finite input, in f32 and in f64,
    /// for every seed. Derivation (each basis is a convex combination Σ_c W_c(p) h_c(p) over
    /// the 8 cell corners c, the weights W_c being products of 1D weights in [0, 1] summing to 1):
    ///
    /// - `Value`: `[0, 1]`. The values are in [0, 1] and every step is a lerp `a + t (b - a)`
    ///   with a, b, t in [0, 1]; with round-to-nearest such a lerp stays in [0, 1] (rounding is
    ///   monotone and 0, 1 are representable; the smoothstep weight of a t in [0, 1] also
    ///   rounds into [0, 1]), in f32 as in f64. Tight up to the table.
    /// - `Gradient`: `±0.8661`. |h_c| = |g_c · (p - c)| <= |p - c| (unit g_c), and by
    ///   Cauchy–Schwarz (the W_c sum to 1) Σ W_c |p - c| <= sqrt(Σ_c W_c |p - c|²) =
    ///   sqrt(Σ_axes (1 - s(t)) t² + s(t) (1 - t)²) <= sqrt(3/4) = 0.866025 (each axis term is
    ///   <= 1/4 because s(t) <= t for t <= 1/2), attained only at a cell centre with every
    ///   gradient aimed at it. Rounded up
    ///   to 4 digits; the 7.5e-5 margin covers the f32 rounding of the vectors (2^-24 relative)
    ///   and of the evaluation (~1e-6).
    /// - `Perlin`: `±1.04`. |h_c| = |g_c · (p - c)| <= T(p - c), the sum of the two largest
    ///   |components| (the gradients are the 12 edge vectors (±1, ±1, 0) and permutations), so
    ///   |N(p)| <= F(p) = Σ_c W_c(p) T(p - c), the value with every corner's gradient chosen
    ///   adversarially. F has no closed-form maximum; numerically max F = 1.03635, at about
    ///   (0.355, 0.4825, 0.5) and its mirror images. The test `perlin_range_bound_is_proved`
    ///   proves F <= 1.04 over the whole cell by branch and bound (F is symmetric under
    ///   x -> 1 - x and under axis swaps, and |∂F/∂x| <= 1 + fade'(x)). The 3.6e-3 to spare
    ///   covers the rounding of the f32 evaluation (~1e-6) many times over.
    pub fn range(&self) -> (f64, f64) {
        self.basis.range()
    }

    /// An upper bound on the Lipschitz constant (max |gradient|) of [`NoiseTable::sample`] in
    /// exact arithmetic (floating-point evaluation adds a few ulps of noise on top), for seam
    /// tests. Same for every seed. With N = Σ_c W_c h_c (see [`NoiseTable::range`]) and s the 1D
    /// weight (t, smoothstep, or fade),
    /// ∂N/∂x = Σ_c W_c ∂h_c/∂x + s'(f_x) Σ_yz w_yz (h_1yz - h_0yz):
    ///
    /// - `Value`: h_c is constant in [0, 1], so |∂N/∂x| <= max s', and |∇N| <= √3 max s':
    ///   Linear √3 (1.7321), Smooth 1.5 √3 (2.5981).
    /// - `Gradient`, `Perlin`: the first term is a convex combination of gradients, at most
    ///   max |g| (1, or √2 for Perlin's edge vectors). For the second, |h_c| <= |d_x| + |d_y| +
    ///   |d_z| with d = p - c (unit g; for Perlin, h is ±d_i ± d_j), so |h_1yz| + |h_0yz| <= 1 +
    ///   2 (|d_y| + |d_z|), whose w-weighted sum is <= 1 + 2 (1/2 + 1/2) = 3 (each 1D term
    ///   t (1 - s(t)) + (1 - t) s(t) is <= 1/2). So each component is <= 3 max s' (s' <= 1.5 for
    ///   smoothstep, 15/8 for fade), and |∇N| <= max|g| + 3 √3 max s':
    ///   Gradient 1 + 4.5 √3 (8.795), Perlin √2 + 5.625 √3 (11.157). Not tight (measured
    ///   gradients stay well below); it only has to be safe.
    pub fn lipschitz(&self) -> f64 {
        self.basis.lipschitz()
    }
}

impl Basis {
    /// The range of every table of this basis (see [`NoiseTable::range`]).
    pub fn range(self) -> (f64, f64) {
        match self {
            Basis::Perlin => (-PERLIN_RANGE, PERLIN_RANGE),
            Basis::Gradient => (-GRADIENT_RANGE, GRADIENT_RANGE),
            Basis::Value(_) | Basis::White => (0.0, 1.0),
            Basis::Simplex => (-simplex::RANGE, simplex::RANGE),
            Basis::Cellular(c) => c.range(),
        }
    }

    /// An upper bound on the Lipschitz constant of the basis, the same for every seed; see
    /// [`NoiseTable::lipschitz`].
    pub fn lipschitz(self) -> f64 {
        match self {
            Basis::Perlin => 11.157,
            Basis::Gradient => 8.795,
            Basis::Value(Interpolation::Linear) => 1.7321,
            Basis::Value(Interpolation::Smooth) => 2.5981,
            Basis::Simplex => simplex::LIPSCHITZ,
            Basis::Cellular(c) => c.lipschitz(),
            // Jumps at every cell face.
            Basis::White => f64::INFINITY,
        }
    }

    /// Whether the basis can be summed by `Fbm`, `Turbulence` and the other fractals (all but
    /// white noise, which has no frequency content to scale).
    pub fn is_fractal(self) -> bool {
        !matches!(self, Basis::White)
    }
}

/// Half-width of the `Gradient` range; see [`NoiseTable::range`].
const GRADIENT_RANGE: f64 = 0.8661;

/// Half-width of the `Perlin` range; see [`NoiseTable::range`].
const PERLIN_RANGE: f64 = 1.04;

/// The length check of every batch entry point: mismatched slices are a caller bug, and a loud
/// panic beats silently evaluating only the shortest prefix.
#[inline]
fn check_lengths(x: &[f64], y: &[f64], z: &[f64], n: usize) {
    assert!(
        x.len() == n && y.len() == n && z.len() == n,
        "noise batch: slice lengths differ (x {}, y {}, z {}, out {})",
        x.len(),
        y.len(),
        z.len(),
        n
    );
}

/// NaN as the one canonical NaN, `S::NAN` (positive, quiet, zero payload); other values as they
/// are. Every noise result and fractal sum passes through it, so that a non-finite input gives
/// the same bits on the point and the batch paths: IEEE 754 and Rust leave the sign and payload
/// of a NaN result unspecified, and LLVM may order an addition's operands differently in scalar
/// and in vectorised code (Perlin's `grad` adds `±x + ±y` of two NaNs of opposite signs, and x86
/// returns the first operand's NaN). One compare and one blend per lane in SIMD.
#[inline(always)]
pub(super) fn canonical_nan<S: Real>(v: S) -> S {
    if v.is_nan() {
        S::NAN
    } else {
        v
    }
}

/// [`Basis::Perlin`]'s kernel.
struct PerlinKernel<'a> {
    perm: &'a [u8; 512],
    pairs: &'a [i32; 512],
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
struct GradientKernel<'a> {
    perm: &'a [u8; 512],
    pairs: &'a [i32; 512],
    grads: &'a [[f32; 3]; 256],
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
struct ValueKernel<'a, const SMOOTH: bool> {
    perm: &'a [u8; 512],
    pairs: &'a [i32; 512],
    values: &'a [f32; 256],
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
struct SimplexKernel<'a> {
    perm: &'a [u8; 512],
    signs: &'a [[u8; 256]; 3],
}

impl NoiseKernel for SimplexKernel<'_> {
    #[inline(always)]
    fn sample<S: Real>(&self, p: [f64; 3]) -> S {
        canonical_nan(simplex::sample(self.perm, p))
    }

    /// The lane kernel of `batch.rs`, bit for bit `sample`.
    fn sample_batch<S: Real>(&self, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
        if out.len() < batch::SMALL {
            return reference_batch(|p| self.sample(p), x, y, z, out);
        }
        batch::simplex(self.perm, self.signs, x, y, z, out);
    }

    /// Vertices hashed as their translates into the period box (`simplex::sample_periodic`).
    fn sample_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> S {
        canonical_nan(simplex::sample_periodic(self.perm, p, period))
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
struct CellularKernel<'a> {
    perm: &'a [u8; 512],
    features: &'a [[f32; 256]; 3],
    values: &'a [f32; 256],
    params: Cellular,
}

impl NoiseKernel for CellularKernel<'_> {
    #[inline(always)]
    fn sample<S: Real>(&self, p: [f64; 3]) -> S {
        canonical_nan(cellular::sample(
            self.perm,
            self.features,
            self.values,
            self.params,
            None,
            p,
        ))
    }

    /// The SIMD kernel of `batch.rs` (the 27 nearest cells over lanes), bit for bit `sample`.
    fn sample_batch<S: Real>(&self, x: &[f64], y: &[f64], z: &[f64], out: &mut [S]) {
        if out.len() < batch::SMALL {
            return reference_batch(|p| self.sample(p), x, y, z, out);
        }
        let tables = batch::CellularTables {
            perm: self.perm,
            features: self.features,
            values: self.values,
            params: self.params,
        };
        batch::cellular(&tables, x, y, z, out);
    }

    /// The point reduced into its period, and the neighbour cells wrapped around it.
    fn sample_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> S {
        canonical_nan(cellular::sample(
            self.perm,
            self.features,
            self.values,
            self.params,
            Some(period),
            period::reduce3(p, period).0,
        ))
    }

    fn sample_grad<S: Real>(&self, p: [f64; 3]) -> (S, [S; 3]) {
        let (v, g) =
            cellular::sample_grad(self.perm, self.features, self.values, self.params, None, p);
        (canonical_nan(v), g.map(canonical_nan))
    }

    fn sample_grad_periodic<S: Real>(&self, p: [f64; 3], period: Period) -> (S, [S; 3]) {
        let q = period::reduce3(p, period).0;
        let (v, g) = cellular::sample_grad(
            self.perm,
            self.features,
            self.values,
            self.params,
            Some(period),
            q,
        );
        (canonical_nan(v), g.map(canonical_nan))
    }
}

/// [`Basis::White`]'s kernel.
struct WhiteKernel<'a> {
    perm: &'a [u8; 512],
    values: &'a [f32; 256],
}

impl NoiseKernel for WhiteKernel<'_> {
    #[inline(always)]
    fn sample<S: Real>(&self, p: [f64; 3]) -> S {
        canonical_nan(value::white(self.perm, self.values, p))
    }

    fn sample_grad<S: Real>(&self, p: [f64; 3]) -> (S, [S; 3]) {
        derivative::white_grad(self.sample(p), p)
    }
}
