//! Tests of `derivative.rs`. The reference is independent of the code under test: central
//! differences of the f64 value functions (`NoiseTable::sample`, `fractal_styled`). Then the
//! batch forms against the point forms bit for bit, f32 against f64, and the documented values
//! on the sets where a basis is not differentiable.

use super::tests::{batch_pool, cellular, planes, with_table_reads};
use super::*;

use crate::real::Real;
use CellularValue::{CellValue, Edge, F2MinusF1, F1, F2};
use Metric::{Chebyshev, Euclidean, Manhattan};

/// Relative tolerance of the gradient against central differences (relative to
/// `max(|∇|∞, 1)`, so an absolute one for gradients below 1). The difference quotients are
/// accurate to far better than this (see [`step`]); it is also the threshold above which the
/// two one-sided differences are taken to straddle a kink or a jump (see [`compare`]).
const TOL: f64 = 1e-5;

/// Every basis with the parameters its gradient rule distinguishes: each lattice basis,
/// simplex, cellular noise with every metric, value and jitter 0, 0.5, 1, and white noise.
fn grad_bases() -> Vec<Basis> {
    let mut all = vec![
        Basis::Perlin,
        Basis::Gradient,
        Basis::Value(Interpolation::Linear),
        Basis::Value(Interpolation::Smooth),
        Basis::Simplex,
        Basis::White,
    ];
    for jitter in [0.0, 0.5, 1.0] {
        for metric in [Euclidean, Manhattan, Chebyshev] {
            for value in [F1, F2, F2MinusF1, CellValue, Edge] {
                all.push(cellular(jitter, metric, value));
            }
        }
    }
    all
}

/// The bases of the fractal tests: the lattice bases, simplex, and cellular noise with each
/// metric and each value that has a non-zero gradient.
fn fractal_bases() -> Vec<Basis> {
    vec![
        Basis::Perlin,
        Basis::Gradient,
        Basis::Value(Interpolation::Linear),
        Basis::Value(Interpolation::Smooth),
        Basis::Simplex,
        cellular(1.0, Euclidean, F1),
        cellular(0.5, Manhattan, F2MinusF1),
        cellular(0.7, Chebyshev, Edge),
        cellular(1.0, Euclidean, F2),
    ]
}

fn styles() -> [Style; 5] {
    [
        Style::Fbm,
        Style::Turbulence,
        Style::Billow,
        Style::Ridged {
            offset: 1.0,
            sharpness: 2.0,
        },
        Style::Ridged {
            offset: 0.8,
            sharpness: 0.7,
        },
    ]
}

/// The schedules of the fractal tests, and whether their frequencies are powers of two (so that
/// `p · f` is exact and points far out can be differenced; see [`step`]): 8 whole octaves;
/// 3.5 octaves (a fractional last one) with a lacunarity that is not a power of two, from the
/// first octave; 4 octaves tiled (periods multiples of 3, as simplex needs).
fn schedules() -> Vec<(&'static str, Octaves, bool)> {
    vec![
        ("8 octaves", Octaves::new(8.0, 2.0, 0.5, 0), true),
        ("3.5 octaves", Octaves::new(3.5, 1.93, 0.6, 1), false),
        (
            "tiled",
            Octaves::new(4.0, 2.0, 0.5, 0).with_period(Some([3, 6, 3])),
            true,
        ),
    ]
}

/// Test points: a third in [-4, 4)³, the rest spread over [-300, 300)³ and, when `far`, around
/// ±1e6 and -3e7 (a few cells around them, so negative and large coordinates both occur).
/// Without `far`, all in [-8, 8)³: a schedule whose frequencies are not powers of two rounds
/// `p · f`, by more relative to the step the farther out.
fn grad_points(seed: u64, n: usize, far: bool) -> Vec<[f64; 3]> {
    let pts = spread_points(seed, n, far);
    if far {
        pts
    } else {
        pts.into_iter().map(|p| p.map(|v| v % 8.0)).collect()
    }
}

fn spread_points(seed: u64, n: usize, far: bool) -> Vec<[f64; 3]> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|i| {
            let centre = match (i % 6, far) {
                (0 | 1, _) => 0.0,
                (2 | 3, _) | (_, false) => 0.0,
                (4, true) => 1e6,
                _ => -3e7,
            };
            let scale = match i % 6 {
                0 | 1 => 4.0,
                2 | 3 => 300.0,
                _ => 8.0,
            };
            let sign = if i % 12 == 4 { -1.0 } else { 1.0 };
            std::array::from_fn(|_| sign * centre + scale * rng.next_signed())
        })
        .collect()
}

/// The difference step at `p` for a function whose highest frequency is `f_max`: 1e-7 cells
/// at that frequency, the smallest step at which the f64 values' rounding (about 1e-15 on a
/// sum of a few octaves of values below ~2) stays below 1e-8 relative; at least 8 f64 spacings
/// of the largest coordinate, so that far out the step is several ulps (the steps are exact:
/// [`compare`] divides by the difference of the two points actually evaluated). The truncation
/// error `h² f'''/6` is then far below [`TOL`], and so is `h |f''|`, the amount by which the
/// two one-sided differences of a smooth function differ.
fn step(p: [f64; 3], f_max: f64) -> f64 {
    let m = p.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    (1e-7 / f_max).max(8.0 * f64::EPSILON * m)
}

/// What a comparison with central differences found at one point.
enum Compared {
    /// The largest error over the axes, relative to `max(|∇|∞, 1)`.
    Error(f64),
    /// On some axis the forward and backward differences disagree by more than the function's
    /// curvature explains: a kink or a jump lies within the step (cell borders, faces,
    /// |n| = 0, clamps).
    Kink,
}

/// Along axis `a` at `p` with step `h`: the forward, backward and central differences, each
/// divided by the exact distance between the two points actually evaluated.
fn differences(value: &dyn Fn([f64; 3]) -> f64, p: [f64; 3], a: usize, h: f64) -> [f64; 3] {
    let (mut up, mut down) = (p, p);
    up[a] = p[a] + h;
    down[a] = p[a] - h;
    let (f0, fu, fd) = (value(p), value(up), value(down));
    let forward = (fu - f0) / (up[a] - p[a]);
    let backward = (f0 - fd) / (p[a] - down[a]);
    let central = (fu - fd) / (up[a] - down[a]);
    [forward, backward, central]
}

/// `grad` against central differences of `value` at `p`, step `h`, per axis.
///
/// The kink test: for a smooth function the two one-sided differences differ by about `h f''`,
/// so their difference divided by the step, `K(s) = (D+(s) - D-(s)) / s`, estimates the
/// curvature and is the same at every small step; a crease at distance δ < h with slope jump Δ
/// adds `Δ (1 - δ/h)` to `D+ - D-`, which does not scale with the step. So the point is skipped
/// when `h |K(h) - K(2h)|` or `h |K(h/2) - K(h)|` exceeds [`TOL`] (relative): for a crease
/// within the step the two never vanish together (the first only at δ = 2h/3, the second at
/// h/3 and h), and a crease within the step is the only way for the central difference
/// `(D+ + D-) / 2` to err by more than its truncation (`h² f'''/6`). Jumps (white noise, cell
/// values) are caught the same way.
fn compare(value: &dyn Fn([f64; 3]) -> f64, grad: [f64; 3], p: [f64; 3], h: f64) -> Compared {
    let scale = grad.iter().fold(1.0f64, |m, g| m.max(g.abs()));
    let mut worst = 0.0f64;
    for (a, &g) in grad.iter().enumerate() {
        let curvature = |s: f64| {
            let [forward, backward, _] = differences(value, p, a, s);
            (forward - backward) / s
        };
        let (half, whole, double) = (curvature(h / 2.0), curvature(h), curvature(2.0 * h));
        if h * (half - whole).abs().max((whole - double).abs()) > TOL * scale {
            return Compared::Kink;
        }
        let [_, _, central] = differences(value, p, a, h);
        worst = worst.max((g - central).abs() / scale);
    }
    Compared::Error(worst)
}

/// Compares at every point; asserts that the error stays within [`TOL`] and that at least
/// `min_compared` of the points were compared (not skipped as kinks); returns the worst error.
fn check_all(
    what: &str,
    pts: &[[f64; 3]],
    f_max: f64,
    min_compared: f64,
    value: &dyn Fn([f64; 3]) -> f64,
    grad: &dyn Fn([f64; 3]) -> [f64; 3],
) -> f64 {
    let (mut worst, mut compared) = (0.0f64, 0usize);
    for &p in pts {
        match compare(value, grad(p), p, step(p, f_max)) {
            Compared::Error(e) => {
                assert!(
                    e <= TOL,
                    "{what}: at {p:?} the gradient {:?} is off by {e:e} (relative)",
                    grad(p)
                );
                worst = worst.max(e);
                compared += 1;
            }
            Compared::Kink => {}
        }
    }
    let fraction = compared as f64 / pts.len() as f64;
    println!(
        "{what}: worst relative error {worst:.2e}, {compared} of {} points compared",
        pts.len()
    );
    assert!(
        fraction >= min_compared,
        "{what}: only {compared} of {} points compared",
        pts.len()
    );
    worst
}

/// The fraction of points that must be compared: nearly all for the bases that are
/// differentiable everywhere (none in practice is skipped), most for cellular noise and the
/// linear value basis (creases on a null set, met only within a step of them).
fn min_compared(basis: Basis) -> f64 {
    match basis {
        Basis::Perlin | Basis::Gradient | Basis::Value(_) | Basis::Simplex => 0.99,
        Basis::Cellular(_) | Basis::White => 0.9,
    }
}

#[test]
fn basis_gradients_match_central_differences() {
    let pts = grad_points(1, 800, true);
    let mut report = Vec::new();
    for basis in grad_bases() {
        for seed in [0, 5] {
            let t = NoiseTable::new(basis, seed);
            let what = format!("{basis:?} seed {seed}");
            let worst = check_all(
                &what,
                &pts,
                1.0,
                min_compared(basis),
                &|p| t.sample::<f64>(p),
                &|p| t.sample_grad::<f64>(p),
            );
            report.push((what, worst));
        }
    }
    // Tiled tables, on points that cross many seams.
    let near = grad_points(2, 800, false);
    let tiled = [
        (Basis::Perlin, [2, 5, 7]),
        (Basis::Gradient, [3, 3, 3]),
        (Basis::Value(Interpolation::Linear), [1, 4, 256]),
        (Basis::Value(Interpolation::Smooth), [1, 4, 256]),
        (Basis::Simplex, [3, 6, 9]),
        (cellular(1.0, Euclidean, F1), [2, 3, 5]),
        (cellular(0.5, Chebyshev, F2), [1, 3, 300]),
        (Basis::White, [3, 3, 3]),
    ];
    for (basis, period) in tiled {
        let t = NoiseTable::periodic(basis, 3, Some(period));
        let what = format!("{basis:?} tiled {period:?}");
        let worst = check_all(
            &what,
            &near,
            1.0,
            min_compared(basis),
            &|p| t.sample::<f64>(p),
            &|p| t.sample_grad::<f64>(p),
        );
        report.push((what, worst));
    }
    let worst = report.iter().fold(0.0f64, |m, (_, e)| m.max(*e));
    println!("worst over every basis: {worst:.2e}");
}

#[test]
fn fractal_gradients_match_central_differences() {
    let mut worst_by_style = [0.0f64; 5];
    for (name, octaves, dyadic) in schedules() {
        let pts = grad_points(3, 300, dyadic);
        let f_max = octaves.frequencies.iter().fold(1.0f64, |m, &f| m.max(f));
        for basis in fractal_bases() {
            let t = NoiseTable::new(basis, 9);
            for (s, style) in styles().into_iter().enumerate() {
                let what = format!("{basis:?} {style:?} {name}");
                // Ridged with a sharpness below 1 has an unbounded slope where a ridge meets 0,
                // and every style adds the creases of the octaves' cellular borders.
                let min = match (style, basis) {
                    (Style::Ridged { .. }, _) | (_, Basis::Cellular(_)) => 0.8,
                    _ => min_compared(basis).min(0.95),
                };
                let worst = check_all(
                    &what,
                    &pts,
                    f_max,
                    min,
                    &|p| fractal_styled::<f64>(&t, &octaves, style, p),
                    &|p| fractal_styled_grad::<f64>(&t, &octaves, style, p),
                );
                worst_by_style[s] = worst_by_style[s].max(worst);
            }
        }
    }
    // A tiled table under an untiled schedule: Billow and Ridged sample at the table's period
    // (as `fractal_styled` does), Fbm and Turbulence the plain basis.
    let pts = grad_points(3, 300, false);
    let octaves = Octaves::new(3.0, 2.0, 0.5, 0);
    for basis in [Basis::Perlin, Basis::Simplex, cellular(1.0, Euclidean, F1)] {
        let t = NoiseTable::periodic(basis, 9, Some([3, 6, 3]));
        for (s, style) in styles().into_iter().enumerate() {
            let what = format!("{basis:?} {style:?} tiled table");
            let worst = check_all(
                &what,
                &pts,
                4.0,
                0.8,
                &|p| fractal_styled::<f64>(&t, &octaves, style, p),
                &|p| fractal_styled_grad::<f64>(&t, &octaves, style, p),
            );
            worst_by_style[s] = worst_by_style[s].max(worst);
        }
    }
    for (style, worst) in styles().iter().zip(worst_by_style) {
        println!("{style:?}: worst relative error {worst:.2e}");
    }
}

/// The lattice bases' gradients are the documented closed forms at lattice points: the fade
/// slopes vanish there, so Perlin's and Gradient's gradient is the corner's own gradient
/// vector, and value noise's is 0 (Smooth) or the lower cell's edge differences (Linear).
#[test]
fn lattice_point_gradients_are_the_corner_gradients() {
    let t = NoiseTable::new(Basis::Perlin, 0);
    let perlin_corner = |hash: u8| -> [f64; 3] {
        // The reference `grad`'s edge vectors, written out.
        const G: [[f64; 3]; 16] = [
            [1., 1., 0.],
            [-1., 1., 0.],
            [1., -1., 0.],
            [-1., -1., 0.],
            [1., 0., 1.],
            [-1., 0., 1.],
            [1., 0., -1.],
            [-1., 0., -1.],
            [0., 1., 1.],
            [0., -1., 1.],
            [0., 1., -1.],
            [0., -1., -1.],
            [1., 1., 0.],
            [0., -1., 1.],
            [-1., 1., 0.],
            [0., -1., -1.],
        ];
        G[usize::from(hash & 15)]
    };
    for cell in [[0i64, 0, 0], [3, -7, 12], [255, 256, -257]] {
        let p = cell.map(|c| c as f64);
        let [i, j, k] = cell.map(|c| c.rem_euclid(256) as usize);
        let perm = &t.perm;
        let hash = perm[perm[perm[i] as usize + j] as usize + k];
        assert_eq!(t.sample_grad::<f64>(p), perlin_corner(hash), "{cell:?}");
        let g = NoiseTable::new(Basis::Gradient, 4);
        let h = lattice::corner_hashes(&g.perm, i, j, k)[0];
        assert_eq!(
            g.sample_grad::<f64>(p),
            g.grads[h].map(f64::from),
            "{cell:?}"
        );
        let v = NoiseTable::new(Basis::Value(Interpolation::Smooth), 4);
        assert_eq!(v.sample_grad::<f64>(p), [0.0; 3]);
    }
}

/// On a cell face the linear value basis is creased; its gradient there is the one of the cell
/// the point lies in (fraction 0: the upper side), i.e. the forward difference.
#[test]
fn value_linear_gradient_on_a_face_is_the_upper_side() {
    let t = NoiseTable::new(Basis::Value(Interpolation::Linear), 8);
    let mut rng = SplitMix64::new(8);
    let mut differ = 0;
    for _ in 0..200 {
        let mut p: [f64; 3] = std::array::from_fn(|_| 50.0 * rng.next_signed());
        p[0] = p[0].floor();
        let g = t.sample_grad::<f64>(p);
        let h = 1e-7;
        let (mut up, mut down) = (p, p);
        up[0] += h;
        down[0] -= h;
        let forward = (t.sample::<f64>(up) - t.sample::<f64>(p)) / (up[0] - p[0]);
        let backward = (t.sample::<f64>(p) - t.sample::<f64>(down)) / (p[0] - down[0]);
        assert!(
            (g[0] - forward).abs() <= 1e-6,
            "{p:?}: {} vs {forward}",
            g[0]
        );
        differ += usize::from((g[0] - backward).abs() > 1e-3);
    }
    // The two sides do differ: the test is not vacuous.
    assert!(differ > 150, "{differ}");
}

/// Where an octave's noise is 0, |n| is creased: Turbulence and Billow take sign(0) = 0. Perlin
/// noise is 0 at every lattice point, so a one-octave turbulence there has gradient 0 while the
/// fbm has the corner's gradient.
#[test]
fn turbulence_gradient_is_zero_where_the_noise_is() {
    let t = NoiseTable::new(Basis::Perlin, 0);
    let one = Octaves::new(1.0, 2.0, 0.5, 0);
    let p = [3.0, -7.0, 12.0];
    assert_eq!(t.sample::<f64>(p), 0.0);
    for style in [Style::Turbulence, Style::Billow] {
        assert_eq!(fractal_styled_grad::<f64>(&t, &one, style, p), [0.0; 3]);
    }
    assert_ne!(
        fractal_styled_grad::<f64>(&t, &one, Style::Fbm, p),
        [0.0; 3]
    );
}

/// At a feature point (jitter 0: the cell centres) every metric's F1 gradient is 0; Chebyshev
/// ties go to the first axis; Euclidean is the unit vector away from the point.
#[test]
fn cellular_gradients_at_feature_points_and_ties() {
    for metric in [Euclidean, Manhattan, Chebyshev] {
        let t = NoiseTable::new(cellular(0.0, metric, F1), 2);
        assert_eq!(
            t.sample_grad::<f64>([3.5, -6.5, 100.5]),
            [0.0; 3],
            "{metric:?}"
        );
        assert_eq!(
            t.sample_grad::<f32>([3.5, -6.5, 100.5]),
            [0.0; 3],
            "{metric:?}"
        );
    }
    let t = NoiseTable::new(cellular(0.0, Chebyshev, F1), 2);
    // Offsets from the centre (0.2, 0.2, -0.1), then (-0.2, -0.2, 0.1): x and y tie exactly
    // (the same f64 differences); the first axis wins.
    assert_eq!(t.sample_grad::<f64>([0.7, 0.7, 0.4]), [1.0, 0.0, 0.0]);
    assert_eq!(t.sample_grad::<f64>([0.3, 0.3, 0.6]), [-1.0, 0.0, 0.0]);
    let t = NoiseTable::new(cellular(0.0, Euclidean, F1), 2);
    let g = t.sample_grad::<f64>([0.8, 0.5, 0.1]);
    assert!((g[0] - 0.6).abs() < 1e-12 && g[1] == 0.0 && (g[2] + 0.8).abs() < 1e-12);
    let t = NoiseTable::new(cellular(0.0, Manhattan, F1), 2);
    assert_eq!(t.sample_grad::<f64>([0.8, 0.5, 0.1]), [1.0, 0.0, -1.0]);
}

/// White noise and cell values are piecewise constant: gradient 0 everywhere.
#[test]
fn piecewise_constant_bases_have_zero_gradient() {
    for basis in [Basis::White, cellular(0.6, Euclidean, CellValue)] {
        let t = NoiseTable::new(basis, 1);
        for p in grad_points(4, 200, true) {
            assert_eq!(t.sample_grad::<f64>(p), [0.0; 3]);
            assert_eq!(t.sample_grad::<f32>(p), [0.0; 3]);
        }
    }
}

/// Non-finite coordinates give the canonical NaN on every component, for every basis and sum.
#[test]
fn non_finite_input_gives_nan_gradients() {
    let octaves = Octaves::new(3.5, 2.0, 0.5, 0);
    for basis in grad_bases() {
        let t = NoiseTable::new(basis, 1);
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for axis in 0..3 {
                let mut p = [0.3, -1.7, 2.2];
                p[axis] = bad;
                let nan32 = f32::NAN.to_bits();
                let nan64 = f64::NAN.to_bits();
                for g in t.sample_grad::<f32>(p) {
                    assert_eq!(g.to_bits(), nan32, "{basis:?} {p:?}");
                }
                for g in t.sample_grad::<f64>(p) {
                    assert_eq!(g.to_bits(), nan64, "{basis:?} {p:?}");
                }
                if basis.is_fractal() {
                    for style in styles() {
                        for g in fractal_styled_grad::<f64>(&t, &octaves, style, p) {
                            assert_eq!(g.to_bits(), nan64, "{basis:?} {style:?} {p:?}");
                        }
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Batch = point, bit for bit

const LENGTHS: [usize; 14] = [1, 7, 8, 9, 63, 64, 65, 255, 256, 257, 300, 513, 700, 1000];

fn grad_bits(g: &[f64]) -> Vec<u64> {
    g.iter().map(|v| v.to_bits()).collect()
}

fn assert_grad_batch_is_point<S: Real>(t: &NoiseTable, pts: &[[f64; 3]], what: &str) {
    let [x, y, z] = planes(pts);
    let n = pts.len();
    let (mut gx, mut gy, mut gz) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    t.sample_grad_batch::<S>(&x, &y, &z, [&mut gx, &mut gy, &mut gz]);
    let want: Vec<[S; 3]> = pts.iter().map(|&p| t.sample_grad::<S>(p)).collect();
    for (c, got) in [&gx, &gy, &gz].into_iter().enumerate() {
        let want: Vec<f64> = want.iter().map(|g| g[c].to_f64()).collect();
        assert_eq!(
            grad_bits(got),
            grad_bits(&want),
            "{what}: sample_grad_batch::<{}> component {c}, {n} lanes",
            S::NAME
        );
    }
}

fn assert_fractal_grad_batch_is_point<S: Real>(
    t: &NoiseTable,
    octaves: &Octaves,
    style: Style,
    pts: &[[f64; 3]],
    what: &str,
) {
    let [x, y, z] = planes(pts);
    let n = pts.len();
    let (mut gx, mut gy, mut gz) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    fractal_styled_grad_batch::<S>(t, octaves, style, &x, &y, &z, [&mut gx, &mut gy, &mut gz]);
    let want: Vec<[S; 3]> = pts
        .iter()
        .map(|&p| fractal_styled_grad::<S>(t, octaves, style, p))
        .collect();
    for (c, got) in [&gx, &gy, &gz].into_iter().enumerate() {
        let want: Vec<f64> = want.iter().map(|g| g[c].to_f64()).collect();
        assert_eq!(
            grad_bits(got),
            grad_bits(&want),
            "{what}: fractal_styled_grad_batch::<{}> {style:?} component {c}, {n} lanes",
            S::NAME
        );
    }
}

/// A pool of awkward points (random at every scale, integers and points just off them, ±0,
/// near 2^51, huge and non-finite): `batch_pool`'s kinds 0..12.
fn awkward_pool() -> Vec<[f64; 3]> {
    let mut pts = batch_pool(70, 1100, 8);
    // Mix in the wild kinds without making every chunk wild.
    for (i, p) in batch_pool(71, 1100, 12).into_iter().enumerate() {
        if i % 5 == 0 {
            pts[i] = p;
        }
    }
    pts
}

fn check_basis_batches(bases: &[Basis]) {
    let pool = awkward_pool();
    for &basis in bases {
        let tables = [
            NoiseTable::new(basis, 6),
            NoiseTable::periodic(basis, 6, Some([3, 6, 300])),
        ];
        for t in &tables {
            for len in LENGTHS {
                let start = len % 41;
                let pts = &pool[start..start + len];
                let what = format!("{basis:?} period {:?}", t.period());
                assert_grad_batch_is_point::<f32>(t, pts, &what);
                assert_grad_batch_is_point::<f64>(t, pts, &what);
            }
        }
    }
}

fn check_fractal_batches(bases: &[Basis], lengths: &[usize]) {
    let pool = awkward_pool();
    for &basis in bases {
        let t = NoiseTable::new(basis, 6);
        let tiled = NoiseTable::periodic(basis, 6, Some([3, 6, 3]));
        let mut cases: Vec<_> = schedules()
            .into_iter()
            .map(|(n, o, _)| (n, o, &t))
            .collect();
        cases.push(("tiled table", Octaves::new(3.0, 2.0, 0.5, 0), &tiled));
        for (name, octaves, t) in cases {
            for style in styles() {
                for &len in lengths {
                    let start = len % 37;
                    let pts = &pool[start..start + len];
                    let what = format!("{basis:?} {name}");
                    assert_fractal_grad_batch_is_point::<f32>(t, &octaves, style, pts, &what);
                    assert_fractal_grad_batch_is_point::<f64>(t, &octaves, style, pts, &what);
                }
            }
        }
    }
}

const LATTICE: [Basis; 4] = [
    Basis::Perlin,
    Basis::Gradient,
    Basis::Value(Interpolation::Linear),
    Basis::Value(Interpolation::Smooth),
];

/// Every basis, plain and tiled, every length across the per-point threshold and the chunk
/// boundaries, both precisions.
#[test]
fn gradient_batches_equal_point_gradients() {
    let mut bases = LATTICE.to_vec();
    bases.extend([
        Basis::Simplex,
        Basis::White,
        cellular(0.0, Euclidean, F1),
        cellular(0.5, Manhattan, F2),
        cellular(1.0, Chebyshev, F2MinusF1),
        cellular(1.0, Euclidean, Edge),
        cellular(0.5, Euclidean, CellValue),
    ]);
    check_basis_batches(&bases);
}

/// Every style, plain, fractional and tiled schedules, for the lattice bases (their own lane
/// kernels, the fused fbm one included) and the others (the per-point loops).
#[test]
fn fractal_gradient_batches_equal_point_gradients() {
    check_fractal_batches(&LATTICE, &[1, 7, 8, 63, 64, 65, 257, 300]);
    check_fractal_batches(
        &[
            Basis::Simplex,
            cellular(1.0, Euclidean, F1),
            cellular(0.5, Chebyshev, Edge),
        ],
        &[7, 65],
    );
}

/// The lattice lane kernels with the table-read hashing (what CPUs without AVX-512 VBMI run)
/// forced on this CPU too. (Elsewhere the tests above already run it.)
#[test]
fn gradient_batches_with_table_reads_equal_point_gradients() {
    with_table_reads(|| {
        check_basis_batches(&LATTICE);
        check_fractal_batches(&LATTICE, &[8, 65, 300]);
    });
}

// ---------------------------------------------------------------------------------------------
// f32 against f64

/// Relative tolerance of the f32 gradients against the f64 ones (relative to `max(|∇|∞, 1)`):
/// the fraction enters the interior rounded to f32 (2^-24) and the interior arithmetic rounds
/// at about 1e-7 per operation; a few tens of operations and eight octaves stay well inside.
const TOL32: f64 = 1e-4;

/// Whether a kink or jump of `value` lies within `h` of `p` on some axis: there the f32 and f64
/// paths may pick different sides (a different nearest point, a different sign of |n|).
fn near_kink(value: &dyn Fn([f64; 3]) -> f64, p: [f64; 3], h: f64) -> bool {
    let f0 = value(p);
    (0..3).any(|a| {
        let (mut up, mut down) = (p, p);
        up[a] += h;
        down[a] -= h;
        let forward = (value(up) - f0) / (up[a] - p[a]);
        let backward = (f0 - value(down)) / (p[a] - down[a]);
        (forward - backward).abs() > 1e-2 * forward.abs().max(backward.abs()).max(1.0)
    })
}

fn assert_f32_near_f64(
    what: &str,
    pts: &[[f64; 3]],
    h: f64,
    value: &dyn Fn([f64; 3]) -> f64,
    g32: &dyn Fn([f64; 3]) -> [f32; 3],
    g64: &dyn Fn([f64; 3]) -> [f64; 3],
) -> f64 {
    let (mut worst, mut compared) = (0.0f64, 0);
    for &p in pts {
        if near_kink(value, p, h) {
            continue;
        }
        let (a, b) = (g32(p), g64(p));
        let scale = b.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let e = (0..3).fold(0.0f64, |m, c| m.max((a[c] as f64 - b[c]).abs() / scale));
        assert!(
            e <= TOL32,
            "{what}: at {p:?} f32 {a:?} vs f64 {b:?} ({e:e})"
        );
        worst = worst.max(e);
        compared += 1;
    }
    assert!(
        compared * 10 >= pts.len() * 8,
        "{what}: {compared} compared"
    );
    worst
}

#[test]
fn f32_gradients_track_f64() {
    let pts = grad_points(5, 600, true);
    let mut worst = 0.0f64;
    for basis in grad_bases() {
        let t = NoiseTable::new(basis, 3);
        let e = assert_f32_near_f64(
            &format!("{basis:?}"),
            &pts,
            1e-4,
            &|p| t.sample::<f64>(p),
            &|p| t.sample_grad::<f32>(p),
            &|p| t.sample_grad::<f64>(p),
        );
        worst = worst.max(e);
    }
    println!("bases: worst f32 error {worst:.2e}");
    let mut worst = 0.0f64;
    for (name, octaves, dyadic) in schedules() {
        let pts = grad_points(6, 200, dyadic);
        let f_max = octaves.frequencies.iter().fold(1.0f64, |m, &f| m.max(f));
        for basis in fractal_bases() {
            let t = NoiseTable::new(basis, 3);
            for style in styles() {
                let e = assert_f32_near_f64(
                    &format!("{basis:?} {style:?} {name}"),
                    &pts,
                    1e-4 / f_max,
                    &|p| fractal_styled::<f64>(&t, &octaves, style, p),
                    &|p| fractal_styled_grad::<f32>(&t, &octaves, style, p),
                    &|p| fractal_styled_grad::<f64>(&t, &octaves, style, p),
                );
                worst = worst.max(e);
            }
        }
    }
    println!("fractals: worst f32 error {worst:.2e}");
}

// ---------------------------------------------------------------------------------------------
// Timing

/// A rough timing of the 8-octave Perlin fbm in f32 on 65 536 points in [0, 8)³ (the benches'
/// slab): the value batch against the gradient batch. Run it in release:
/// `cargo test --release --lib gradient_timing -- --ignored --nocapture`.
#[test]
#[ignore]
fn gradient_timing() {
    use std::time::Instant;
    let n = 65_536;
    let pts = grad_points(7, n, false)
        .into_iter()
        .map(|p| p.map(|v| (v.abs() * 8.0) % 8.0))
        .collect::<Vec<_>>();
    let [x, y, z] = planes(&pts);
    let t = NoiseTable::new(Basis::Perlin, 0);
    let octaves = Octaves::new(8.0, 2.0, 0.5, 0);
    let mut value = vec![0.0f32; n];
    let (mut gx, mut gy, mut gz) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    // Alternating runs, the best of each: the machine may be shared, and the minimum is the
    // run least disturbed.
    let (mut v, mut g) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..20 {
        let start = Instant::now();
        fractal_styled_batch(&t, &octaves, Style::Fbm, &x, &y, &z, &mut value);
        v = v.min(start.elapsed().as_secs_f64());
        let start = Instant::now();
        let out = [&mut gx[..], &mut gy[..], &mut gz[..]];
        fractal_styled_grad_batch::<f32>(&t, &octaves, Style::Fbm, &x, &y, &z, out);
        g = g.min(start.elapsed().as_secs_f64());
    }
    let per = |s: f64| s * 1e9 / n as f64;
    println!(
        "fbm8 Perlin f32, {n} points: value {:.1} ns/point, gradient {:.1} ns/point, ratio {:.2}",
        per(v),
        per(g),
        g / v
    );
    std::hint::black_box((&value, &gx, &gy, &gz));
}

/// The kink test of [`compare`] does skip the points it must (a crease or a jump within the
/// step), and only those: the central-difference tests above then compare everywhere else.
#[test]
fn kinks_and_jumps_within_the_step_are_skipped() {
    let h = 1e-7;
    let skipped = |t: &NoiseTable, p: [f64; 3]| {
        let value = |p: [f64; 3]| t.sample::<f64>(p);
        matches!(compare(&value, t.sample_grad(p), p, h), Compared::Kink)
    };
    // Jitter 0: the feature points are the cell centres, so F1's borders are the cell faces.
    let f1 = NoiseTable::new(cellular(0.0, Euclidean, F1), 1);
    assert!(skipped(&f1, [1.0, 0.3, 0.4]));
    assert!(skipped(&f1, [1.0 + h / 3.0, 0.3, 0.4]));
    assert!(!skipped(&f1, [1.0 + 2.5 * h, 0.3, 0.4]));
    let linear = NoiseTable::new(Basis::Value(Interpolation::Linear), 1);
    assert!(skipped(&linear, [2.0, 0.3, 0.4]));
    assert!(!skipped(&linear, [2.1, 0.3, 0.4]));
    let white = NoiseTable::new(Basis::White, 1);
    assert!(skipped(&white, [0.3, -5.0, 0.4]));
    assert!(!skipped(&white, [0.3, -4.9, 0.4]));
}
