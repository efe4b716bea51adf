//! [`NoiseTable`]: the immutable lattice tables of one (basis, seed), and the point and batch
//! entry points every caller samples a basis through.

use super::basis::Basis;
use super::gradient;
use super::hash;
use super::kernel::NoiseKernel;
use super::kernels::with_kernel;
use super::lanes::check_lengths;
use super::period::Period;
use super::perlin;
use super::rng;
use super::simplex;
use super::value;
use crate::real::Real;

/// Immutable lattice tables for one (basis, seed); Send + Sync; built once at compile time.
///
/// Every table is kept even when the basis does not read it (zeros then): the struct is small
/// (about 7 KB) and a fixed layout keeps all indexing free of bounds checks.
#[derive(Clone)]
pub struct NoiseTable {
    pub(super) basis: Basis,
    pub(super) seed: u64,
    /// Tiling period of [`NoiseTable::sample`], if any.
    pub(super) period: Option<Period>,
    /// The permutation of 0..=255, doubled to 512 entries so that a hash plus an index <= 255
    /// needs no wrap.
    pub(super) perm: [u8; 512],
    /// `perm[i] | perm[i + 1] << 8` (`perm[0]` after the last entry) as i32: the batch kernels'
    /// form of the permutation. Every hash step reads two neighbouring entries, so one 32-bit
    /// table read (a SIMD gather) serves both; see `lattice::corner_hashes_paired`.
    pub(super) pairs: [i32; 512],
    /// Gradient basis: unit vectors (f32 precision, see the module docs).
    pub(super) grads: [[f32; 3]; 256],
    /// Value basis: lattice values in [0, 1] (f32 precision).
    pub(super) values: [f32; 256],
    /// Cellular and White bases: the seed's starting state of the cell hash (`hash.rs`).
    pub(super) key: [u32; 2],
    /// Simplex basis: the gradient of each hash step's last index `j`,
    /// `GRADIENTS[perm[j] % 12]`, as three planes of -1 / 0 / 1 bytes (two's complement), so
    /// that the batch kernel's last lookup gives the gradient directly.
    pub(super) signs: [[u8; 256]; 3],
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
    /// The tables as the GPU path reads them (`gpu/wgsl/common.wgsl`): 1544 32-bit words, the
    /// doubled permutation (512), the Gradient unit vectors (256 × 3, f32 bits), the values
    /// (256, f32 bits), the cell hash's key (2), then zeros to a multiple of 8.
    #[cfg_attr(not(feature = "gpu"), allow(dead_code))]
    pub(crate) fn gpu_words(&self) -> Vec<u32> {
        let mut words = Vec::with_capacity(1544);
        words.extend(self.perm.iter().map(|&p| u32::from(p)));
        words.extend(self.grads.iter().flatten().map(|g| g.to_bits()));
        words.extend(self.values.iter().map(|v| v.to_bits()));
        words.extend(self.key);
        words.resize(1544, 0);
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
            _ => [0.0; 256],
        };
        let key = match basis {
            Basis::Cellular(_) | Basis::White => hash::key(seed ^ rng::CELL_SALT),
            _ => [0; 2],
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
            key,
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
        let Basis::Cellular(c) = self.basis else {
            return None;
        };
        let offset = hash::feature(hash::cell(self.key, cell), c.jitter_f32());
        Some(std::array::from_fn(|a| cell[a] as f64 + offset[a] as f64))
    }

    /// Cellular and White bases: the random value in [0, 1) of integer cell `cell` (what
    /// `CellValue` and `WhiteNoise` return there), as the f64 path has it (53 bits; the f32
    /// path has its top 24); `None` for other bases.
    pub fn cell_value(&self, cell: [i64; 3]) -> Option<f64> {
        match self.basis {
            Basis::Cellular(_) | Basis::White => Some(hash::value(hash::cell(self.key, cell))),
            _ => None,
        }
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
    /// SIMD lane kernels of `batch/` (runtime CPU feature detection), or for a handful of lanes
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
