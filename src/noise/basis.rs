//! The noise bases as graphs name them ([`Basis`], [`Interpolation`]) and what every table of a
//! basis guarantees: its range and Lipschitz bound (derivations on
//! [`NoiseTable::range`](super::table::NoiseTable::range) and
//! [`NoiseTable::lipschitz`](super::table::NoiseTable::lipschitz)).

use super::cellular::Cellular;
use super::simplex;

/// The noise function underlying a noise node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Basis {
    /// Ken Perlin's 2002 improved noise; seed 0 is the published reference. Range within ±1.04.
    Perlin,
    /// Ebert's gradient noise (random unit gradients); zero on lattice points, range ±√3/2.
    Gradient,
    /// Value noise: random values in [0, 1] on lattice points, interpolated.
    Value(Interpolation),
    /// Simplex gradient noise on the body-centred cubic lattice (see `simplex.rs`); range ±1.
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

impl Basis {
    /// The range of every table of this basis (see [`NoiseTable::range`](super::table::NoiseTable::range)).
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
    /// [`NoiseTable::lipschitz`](super::table::NoiseTable::lipschitz).
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
