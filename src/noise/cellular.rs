//! Cellular (Worley) noise: one feature point per integer cell, and the distances from the
//! sample point to the nearest ones (Steven Worley, "A cellular texture basis function",
//! SIGGRAPH 1996).
//!
//! The feature point of cell c is `c + 0.5 + jitter (u - 0.5)`, u uniform in [0, 1)³ per cell
//! from the full-width hash of the cell's exact integer coordinates and the seed (`hash.rs`), so
//! the pattern never repeats (tiled, it repeats with its period only); the jittered offsets are
//! rounded to f32 once, so the f32 and f64 paths (and the GPU) place the same points and
//! jitter 0 gives exactly the cell centres. `CellValue` is the nearest point's cell's value from
//! the same hash, 24 bits in f32 and 53 in f64.
//!
//! Exact search, for every jitter in [0, 1]: the 27 cells around the point's cell first, then
//! further rings of cells (the 98 at Chebyshev distance 2, then 218 at 3, ...) only while a ring
//! could still hold a point nearer than the distance needed (F1, or F2 for the values that use
//! it). A cell at ring r has one axis offset of ±r, so every point in it is at least that axis's
//! gap away in every metric (each of L1, L2 and L∞ is at least |any component|): the gap from the
//! point's coordinate to the nearest possible feature coordinate, `r + 0.5 - jitter/2 - f` or
//! `f + r - 0.5 - jitter/2`. F1 is at most the distance to the own cell's point (√3 Euclidean),
//! so ring 2 can matter for F1 only when the point is near a corner of its cell and the own and
//! neighbouring points are all far; F2 reaches further, so it needs the rings more often. With
//! random feature points the 27 cells held both at every one of 20 000 test points (the test
//! `cellular_f2_is_exact`), so the rings cost almost nothing; but they make the result exact
//! for every placement instead of usually right.
//!
//! Positions stay f64 until the fraction within the cell (as in the lattice bases), so the
//! pattern is exact at any magnitude; distances are computed in `S` from small numbers.

use super::hash;
use super::lattice::lattice;
use super::period::Period;
use crate::real::Real;

/// How distances are measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Metric {
    Euclidean,
    Manhattan,
    Chebyshev,
}

/// What a cellular sample returns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CellularValue {
    /// Distance to the nearest feature point.
    F1,
    /// Distance to the second nearest.
    F2,
    /// F2 - F1: 0 on the cell borders.
    F2MinusF1,
    /// A per-cell random value in [0, 1) of the nearest point's cell (flat-coloured cells).
    CellValue,
    /// (F2 - F1) / 2: 0 on the borders and, along the line through the two nearest points,
    /// exactly the distance to the border between their cells; as Lipschitz as F1.
    Edge,
}

/// The parameters of a cellular basis. The jitter is kept as its f64 bits so that the basis
/// can be hashed and compared (it is a constant checked to lie in [0, 1]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Cellular {
    jitter_bits: u64,
    pub metric: Metric,
    pub value: CellularValue,
}

impl Cellular {
    /// `jitter` in [0, 1] (the checker's range; clamped here for library callers), rounded to
    /// the nearest multiple of 1/256, which keeps every feature point exact in f32 on every
    /// device (`hash::feature`).
    pub fn new(jitter: f64, metric: Metric, value: CellularValue) -> Self {
        let jitter = if jitter.is_nan() {
            1.0
        } else {
            (jitter.clamp(0.0, 1.0) * 256.0).round() / 256.0
        };
        Cellular {
            jitter_bits: (jitter + 0.0).to_bits(),
            metric,
            value,
        }
    }

    pub fn jitter(&self) -> f64 {
        f64::from_bits(self.jitter_bits)
    }

    /// The jitter in f32 (exact: a multiple of 1/256).
    pub(super) fn jitter_f32(&self) -> f32 {
        self.jitter() as f32
    }

    /// Guaranteed range for finite input. F1 is at most the distance to the own cell's point;
    /// F2 at most the larger of that and the distance to the point of the neighbour cell
    /// across the nearer x face (|dx| <= 1.5, |dy|, |dz| <= 1).
    pub fn range(&self) -> (f64, f64) {
        let (f1, f2) = match self.metric {
            Metric::Euclidean => (3f64.sqrt(), 4.25f64.sqrt()),
            Metric::Manhattan => (3.0, 3.5),
            Metric::Chebyshev => (1.0, 1.5),
        };
        match self.value {
            CellularValue::F1 => (0.0, f1),
            CellularValue::F2 | CellularValue::F2MinusF1 => (0.0, f2),
            CellularValue::CellValue => (0.0, 1.0),
            CellularValue::Edge => (0.0, f2 / 2.0),
        }
    }

    /// Lipschitz bound: a distance to a fixed point is 1-Lipschitz in L2 and L∞ and
    /// √3-Lipschitz in L1 (its gradient is (±1, ±1, ±1)); the k-th smallest of such functions
    /// keeps the constant, F2 - F1 doubles it, Edge halves that. CellValue jumps.
    pub fn lipschitz(&self) -> f64 {
        let one = match self.metric {
            Metric::Manhattan => 3f64.sqrt(),
            Metric::Euclidean | Metric::Chebyshev => 1.0,
        };
        match self.value {
            CellularValue::F1 | CellularValue::F2 | CellularValue::Edge => one,
            CellularValue::F2MinusF1 => 2.0 * one,
            CellularValue::CellValue => f64::INFINITY,
        }
    }
}

/// The two nearest distances so far (in the metric's comparable form: squared for Euclidean)
/// and the hash state of the nearest point's cell.
pub(super) struct Nearest<S> {
    pub f1: S,
    pub f2: S,
    pub cell: [u32; 2],
}

/// One sample of cellular noise with the given tables.
#[inline(always)]
pub(super) fn sample<S: Real>(
    key: [u32; 2],
    params: Cellular,
    period: Option<Period>,
    p: [f64; 3],
) -> S {
    match search::<S, false>(key, params, period, p) {
        Some((best, _)) => finish(params.metric, params.value, best),
        None => S::NAN,
    }
}

/// [`sample`]'s value (its bits) and its gradient with respect to the point: the gradient of
/// the distance to the feature point(s) the value picks (see `derivative.rs` and
/// [`finish_grad`]). NaN on every component for non-finite input.
#[inline(always)]
pub(super) fn sample_grad<S: Real>(
    key: [u32; 2],
    params: Cellular,
    period: Option<Period>,
    p: [f64; 3],
) -> (S, [S; 3]) {
    match search::<S, true>(key, params, period, p) {
        Some((best, offsets)) => {
            let g = finish_grad(params.metric, params.value, &best, offsets);
            (finish(params.metric, params.value, best), g)
        }
        None => (S::NAN, [S::NAN; 3]),
    }
}

/// The exact search of [`sample`]: the two nearest distances and the nearest point's cell
/// state, and when `TRACK` also the offsets `feature - p` of the nearest and second nearest
/// points (the same comparisons pick them); `None` for non-finite input.
#[inline(always)]
fn search<S: Real, const TRACK: bool>(
    key: [u32; 2],
    params: Cellular,
    period: Option<Period>,
    p: [f64; 3],
) -> Option<(Nearest<S>, [[S; 3]; 2])> {
    let (_, fx) = lattice(p[0]);
    let (_, fy) = lattice(p[1]);
    let (_, fz) = lattice(p[2]);
    if fx.is_nan() || fy.is_nan() || fz.is_nan() {
        return None;
    }
    let c = p.map(hash::cell_index);
    // Tiled: `p` is reduced into its period, so its cell is `floor(p)` < P exactly, and a
    // neighbour's index is taken mod P before it is hashed.
    let index = |a: usize, o: i64| match period {
        Some(period) if (1..=1 << 52).contains(&period[a]) => {
            (c[a] + o).rem_euclid(period[a] as i64)
        }
        _ => c[a].wrapping_add(o),
    };
    let f = [S::from_f64(fx), S::from_f64(fy), S::from_f64(fz)];
    let metric = params.metric;
    let jitter = params.jitter();
    let mut best = Nearest {
        f1: S::from_f64(f64::INFINITY),
        f2: S::from_f64(f64::INFINITY),
        cell: [0; 2],
    };
    // The offsets `feature - p` of the nearest and second nearest points (when `TRACK`).
    let mut offsets = [[S::ZERO; 3]; 2];
    let mut visit = |best: &mut Nearest<S>, state: [u32; 2], o: [i64; 3]| {
        let point = hash::feature(state, params.jitter_f32());
        let d: [S; 3] =
            std::array::from_fn(|a| S::from_f64(o[a] as f64) + S::from_f64(point[a] as f64) - f[a]);
        let dist = distance(metric, d);
        if dist < best.f1 {
            best.f2 = best.f1;
            best.f1 = dist;
            best.cell = state;
            if TRACK {
                offsets = [d, offsets[0]];
            }
        } else if dist < best.f2 {
            best.f2 = dist;
            if TRACK {
                offsets[1] = d;
            }
        }
    };
    // The cells at Chebyshev distance up to `ring` from the point's cell, z outer, then y, x
    // inner, each ascending (the order decides between equal distances); `only` keeps the
    // cells of the ring itself. The hash's inner steps (z, then y) are shared by a row.
    let mut scan = |best: &mut Nearest<S>, ring: i64, only: bool| {
        for dz in -ring..=ring {
            let sz = hash::absorb(key, index(2, dz));
            for dy in -ring..=ring {
                let syz = hash::absorb(sz, index(1, dy));
                let full = !only || dz.abs() == ring || dy.abs() == ring;
                let step = if full { 1 } else { 2 * ring as usize };
                for dx in (-ring..=ring).step_by(step.max(1)) {
                    visit(best, hash::absorb(syz, index(0, dx)), [dx, dy, dz]);
                }
            }
        }
    };
    scan(&mut best, 1, false);
    let uses_f2 = !matches!(params.value, CellularValue::F1 | CellularValue::CellValue);
    let mut ring = 2i64;
    loop {
        let needed = if uses_f2 { best.f2 } else { best.f1 };
        let gap = ring_gap::<S>(ring, jitter, [fx, fy, fz]);
        let gap = if metric == Metric::Euclidean {
            gap * gap
        } else {
            gap
        };
        if gap >= needed {
            break;
        }
        scan(&mut best, ring, true);
        ring += 1;
    }
    Some((best, offsets))
}

/// The distance in `metric`, Euclidean left squared (compared squared, rooted at the end).
#[inline(always)]
pub(super) fn distance<S: Real>(metric: Metric, d: [S; 3]) -> S {
    match metric {
        Metric::Euclidean => d[0] * d[0] + d[1] * d[1] + d[2] * d[2],
        Metric::Manhattan => d[0].abs() + d[1].abs() + d[2].abs(),
        Metric::Chebyshev => d[0].abs().max_nan(d[1].abs()).max_nan(d[2].abs()),
    }
}

/// A lower bound on the distance from the point (fractions `f`) to any feature point in the
/// cells at Chebyshev ring `ring`: the smallest per-axis gap to the nearest possible feature
/// coordinate of a cell offset by ±ring along that axis.
#[inline(always)]
pub(super) fn ring_gap<S: Real>(ring: i64, jitter: f64, f: [f64; 3]) -> S {
    let (lo, hi) = (0.5 - jitter / 2.0, 0.5 + jitter / 2.0);
    let r = ring as f64;
    let gap = f
        .iter()
        .map(|&f| (r + lo - f).min(f + r - hi))
        .fold(f64::INFINITY, f64::min);
    // Rounded down a little, so that rounding the exact gap can never skip a needed ring.
    S::from_f64(gap * (1.0 - 1e-6) - 1e-6)
}

/// The requested value from the two nearest distances.
#[inline(always)]
pub(super) fn finish<S: Real>(metric: Metric, value: CellularValue, best: Nearest<S>) -> S {
    let root = |v: S| {
        if metric == Metric::Euclidean {
            v.sqrt()
        } else {
            v
        }
    };
    match value {
        CellularValue::F1 => root(best.f1),
        CellularValue::F2 => root(best.f2),
        CellularValue::F2MinusF1 => root(best.f2) - root(best.f1),
        CellularValue::CellValue => hash::value(best.cell),
        CellularValue::Edge => (root(best.f2) - root(best.f1)) * S::from_f64(0.5),
    }
}

/// The gradient of [`finish`]'s value with respect to the point, from the offsets
/// `d = feature - p` of the nearest and second nearest points (see `derivative.rs`).
#[inline(always)]
pub(super) fn finish_grad<S: Real>(
    metric: Metric,
    value: CellularValue,
    best: &Nearest<S>,
    [d1, d2]: [[S; 3]; 2],
) -> [S; 3] {
    let g1 = || distance_grad(metric, best.f1, d1);
    let g2 = || distance_grad(metric, best.f2, d2);
    let difference = || {
        let (g1, g2) = (g1(), g2());
        std::array::from_fn(|a| g2[a] - g1[a])
    };
    match value {
        CellularValue::F1 => g1(),
        CellularValue::F2 => g2(),
        CellularValue::F2MinusF1 => difference(),
        // Piecewise constant: 0 inside a cell, no derivative across its border.
        CellularValue::CellValue => [S::ZERO; 3],
        CellularValue::Edge => difference().map(|g| g * S::from_f64(0.5)),
    }
}

/// The gradient with respect to the point p of the distance `dist` (in [`distance`]'s form:
/// squared for Euclidean) from p to a feature point at offset `d = feature - p`, so the
/// derivative of `|p - feature|` in the metric: Euclidean `-d / |d|` (0 at the point itself),
/// Manhattan `-sign(d)` per component (sign(0) = 0), Chebyshev `-sign(d_k) e_k` on the axis k
/// of the largest |component|, the first of equals (as [`distance`]'s `max` keeps the first).
#[inline(always)]
fn distance_grad<S: Real>(metric: Metric, dist: S, d: [S; 3]) -> [S; 3] {
    use super::lanes::sign;
    match metric {
        Metric::Euclidean => {
            let r = dist.sqrt();
            if r > S::ZERO {
                d.map(|c| -c / r)
            } else {
                [S::ZERO; 3]
            }
        }
        Metric::Manhattan => d.map(|c| -sign(c)),
        Metric::Chebyshev => {
            let m = d.map(S::abs);
            let k = if m[1] > m[0] { 1 } else { 0 };
            let k = if m[2] > m[k] { 2 } else { k };
            let mut g = [S::ZERO; 3];
            g[k] = -sign(d[k]);
            g
        }
    }
}
