use super::kernel::LatticeKernel;
use super::kernels::GradientKernel;
use super::kernels::PerlinKernel;
use super::kernels::ValueKernel;
use super::lattice::lattice;
use super::rng::{shuffled_permutation, SplitMix64, GRAD_SALT, PERM_SALT, VALUE_SALT};
use super::simplex;
use super::*;
use crate::real::Real;

const BASES: [Basis; 4] = [
    Basis::Perlin,
    Basis::Gradient,
    Basis::Value(Interpolation::Linear),
    Basis::Value(Interpolation::Smooth),
];

pub(super) fn cellular(jitter: f64, metric: Metric, value: CellularValue) -> Basis {
    Basis::Cellular(Cellular::new(jitter, metric, value))
}

/// The lattice bases, simplex and cellular noise with a spread of parameters: every basis
/// that is continuous.
fn continuous_bases() -> Vec<Basis> {
    let mut all = BASES.to_vec();
    all.extend([
        Basis::Simplex,
        cellular(1.0, Metric::Euclidean, CellularValue::F1),
        cellular(0.8, Metric::Manhattan, CellularValue::F2),
        cellular(1.0, Metric::Chebyshev, CellularValue::F2MinusF1),
        cellular(0.5, Metric::Euclidean, CellularValue::Edge),
    ]);
    all
}

/// Every basis, the discontinuous ones (cell values, white noise) included.
fn every_basis() -> Vec<Basis> {
    let mut all = continuous_bases();
    all.extend([
        cellular(1.0, Metric::Euclidean, CellularValue::CellValue),
        Basis::White,
    ]);
    all
}

/// Deterministic test points: uniform in [-scale, scale)^3.
fn points(seed: u64, n: usize, scale: f64) -> Vec<[f64; 3]> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            [
                scale * rng.next_signed(),
                scale * rng.next_signed(),
                scale * rng.next_signed(),
            ]
        })
        .collect()
}

/// Points that stress the lattice: integers, cell boundaries, negative and huge coordinates.
fn awkward_points() -> Vec<[f64; 3]> {
    let mut rng = SplitMix64::new(99);
    let two31 = 2f64.powi(31);
    let bases = [
        0.0, -0.0, 1.0, -1.0, 255.0, 256.0, -256.0, -257.0, 1e8, -1e8, two31, -two31, 1e6, -1e6,
    ];
    let offsets = [0.0, 0.25, 0.5, 0.75, 1e-7, -1e-7, 1e-9, -1e-9];
    let mut out = Vec::new();
    for &b in &bases {
        for &o in &offsets {
            let r = rng.next_signed();
            out.push([b + o, b - o + r, -b + o * 3.0 - r]);
        }
    }
    out
}

fn f64_bits<S: Real>(v: S) -> u64 {
    v.to_f64().to_bits()
}

/// A literal transliteration of Perlin's ImprovedNoise.java (int casts and all), as an
/// independent oracle for the reference table.
fn java_improved_noise(x: f64, y: f64, z: f64) -> f64 {
    fn fade(t: f64) -> f64 {
        t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
    }
    fn lerp(t: f64, a: f64, b: f64) -> f64 {
        a + t * (b - a)
    }
    fn grad(hash: i32, x: f64, y: f64, z: f64) -> f64 {
        let h = hash & 15;
        let u = if h < 8 { x } else { y };
        let v = if h < 4 {
            y
        } else if h == 12 || h == 14 {
            x
        } else {
            z
        };
        (if (h & 1) == 0 { u } else { -u }) + (if (h & 2) == 0 { v } else { -v })
    }
    let p: Vec<i32> = (0..512)
        .map(|i| perlin::REFERENCE_PERMUTATION[i % 256] as i32)
        .collect();
    let xx = (x.floor() as i32) & 255;
    let yy = (y.floor() as i32) & 255;
    let zz = (z.floor() as i32) & 255;
    let x = x - x.floor();
    let y = y - y.floor();
    let z = z - z.floor();
    let (u, v, w) = (fade(x), fade(y), fade(z));
    let a = p[xx as usize] + yy;
    let aa = p[a as usize] + zz;
    let ab = p[a as usize + 1] + zz;
    let b = p[xx as usize + 1] + yy;
    let ba = p[b as usize] + zz;
    let bb = p[b as usize + 1] + zz;
    let pg = |i: i32| p[i as usize];
    lerp(
        w,
        lerp(
            v,
            lerp(u, grad(pg(aa), x, y, z), grad(pg(ba), x - 1.0, y, z)),
            lerp(
                u,
                grad(pg(ab), x, y - 1.0, z),
                grad(pg(bb), x - 1.0, y - 1.0, z),
            ),
        ),
        lerp(
            v,
            lerp(
                u,
                grad(pg(aa + 1), x, y, z - 1.0),
                grad(pg(ba + 1), x - 1.0, y, z - 1.0),
            ),
            lerp(
                u,
                grad(pg(ab + 1), x, y - 1.0, z - 1.0),
                grad(pg(bb + 1), x - 1.0, y - 1.0, z - 1.0),
            ),
        ),
    )
}

// ---------------------------------------------------------------------------------------------
// Generator and tables

#[test]
fn splitmix64_matches_published_sequence() {
    // First outputs of SplitMix64 from state 0 (Vigna's splitmix64.c).
    let mut r = SplitMix64::new(0);
    assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
    assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    assert_eq!(r.next_u64(), 0x06C4_5D18_8009_454F);
    let mut r = SplitMix64::new(1);
    for _ in 0..1000 {
        let u = r.next_f64();
        assert!((0.0..1.0).contains(&u));
    }
}

/// FNV-1a over a byte stream: a stable fingerprint of a table.
fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    let mut h = 0xCBF2_9CE4_8422_2325u64;
    for b in bytes {
        h = (h ^ b as u64).wrapping_mul(0x0100_0000_01B3);
    }
    h
}

fn perm_checksum(t: &NoiseTable) -> u64 {
    fnv1a(t.perm[..256].iter().copied())
}
fn grads_checksum(t: &NoiseTable) -> u64 {
    fnv1a(
        t.grads
            .iter()
            .flatten()
            .flat_map(|c| c.to_bits().to_le_bytes()),
    )
}
fn values_checksum(t: &NoiseTable) -> u64 {
    fnv1a(t.values.iter().flat_map(|c| c.to_bits().to_le_bytes()))
}

/// Pins the tables: any change to the generator, the salts, the shuffle or the table
/// construction changes every texture that uses noise, and must fail here first.
#[test]
fn tables_are_pinned() {
    let perlin0 = NoiseTable::new(Basis::Perlin, 0);
    assert_eq!(perlin0.perm[..6], [151, 160, 137, 91, 90, 15]);
    assert_eq!(perlin0.perm[256..262], [151, 160, 137, 91, 90, 15]);

    let perlin1 = NoiseTable::new(Basis::Perlin, 1);
    let grad0 = NoiseTable::new(Basis::Gradient, 0);
    let grad1 = NoiseTable::new(Basis::Gradient, 1);
    let value0 = NoiseTable::new(Basis::Value(Interpolation::Linear), 0);
    let value1 = NoiseTable::new(Basis::Value(Interpolation::Smooth), 1);

    let got = [
        perm_checksum(&perlin0),
        perm_checksum(&perlin1),
        perm_checksum(&grad0),
        perm_checksum(&grad1),
        grads_checksum(&grad0),
        grads_checksum(&grad1),
        values_checksum(&value0),
        values_checksum(&value1),
    ];
    let first = (
        perlin1.perm[..4].to_vec(),
        grad0.perm[..4].to_vec(),
        grad0.grads[0],
        grad1.grads[0],
        value0.values[..2].to_vec(),
        value1.values[..2].to_vec(),
    );
    println!("checksums {got:#018x?}\nfirst entries {first:?}");
    assert_eq!(
        got,
        [
            0xa4d5_c624_dc06_c7d5, // Perlin seed 0: the reference permutation
            0xfa6d_3c8d_2bc3_c413, // permutation of seed 1 (the same for every basis)
            0xbdd7_5e4b_3500_ea47, // permutation of seed 0 (non-Perlin bases)
            0xfa6d_3c8d_2bc3_c413,
            0x98a0_969d_0913_22d4, // gradient vectors, seed 0
            0xe709_574c_f87e_f1be, // gradient vectors, seed 1
            0x090c_c268_41e6_c1d4, // values, seed 0
            0x54b1_1e2e_861b_9e56, // values, seed 1
        ]
    );
    // The first entries, readable, for whoever has to debug a mismatch.
    assert_eq!(first.0, [24, 251, 25, 4]);
    assert_eq!(first.1, [39, 87, 27, 230]);
    assert_eq!(first.2, [0.39697745, -0.72653633, -0.56085104]);
    assert_eq!(first.3, [0.7068686, -0.49297225, 0.5072624]);
    assert_eq!(first.4, [0.40348652, 0.10029235]);
    assert_eq!(first.5, [0.6342676, 0.39579657]);
}

#[test]
fn tables_are_deterministic_and_seed_dependent() {
    for basis in every_basis() {
        let a = NoiseTable::new(basis, 7);
        let b = NoiseTable::new(basis, 7);
        let c = NoiseTable::new(basis, 8);
        assert_eq!(a.perm, b.perm);
        assert_eq!(a.grads, b.grads);
        assert_eq!(a.values, b.values);
        assert_eq!((a.basis(), a.seed()), (basis, 7));
        assert_ne!(a.perm, c.perm, "{basis:?}");
        // Different seeds must also give different noise, not only different tables.
        let pts = points(5, 64, 50.0);
        let differ = pts
            .iter()
            .filter(|&&p| a.sample::<f64>(p) != c.sample::<f64>(p))
            .count();
        assert!(differ > 48, "{basis:?}: only {differ}/64 samples differ");
        for (i, p) in a.perm.iter().enumerate() {
            assert_eq!(*p, a.perm[i % 256]);
        }
        let mut sorted = a.perm[..256].to_vec();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(i, &v)| v as usize == i));
    }
    let g7 = NoiseTable::new(Basis::Gradient, 7);
    assert_ne!(g7.grads, NoiseTable::new(Basis::Gradient, 8).grads);
    let v7 = NoiseTable::new(Basis::Value(Interpolation::Linear), 7);
    assert_ne!(
        v7.values,
        NoiseTable::new(Basis::Value(Interpolation::Linear), 8).values
    );
    // The two value interpolations share the tables of a seed (only the weights differ).
    let s7 = NoiseTable::new(Basis::Value(Interpolation::Smooth), 7);
    assert_eq!((v7.perm, v7.values), (s7.perm, s7.values));
    // Perlin: only seed 0 is the reference table.
    assert_ne!(
        NoiseTable::new(Basis::Perlin, 1).perm[..256],
        perlin::REFERENCE_PERMUTATION
    );
}

#[test]
fn table_streams_are_independent() {
    const { assert!(PERM_SALT != GRAD_SALT && GRAD_SALT != VALUE_SALT && PERM_SALT != VALUE_SALT) };
    // The permutation is not the value stream seen through another lens: with one seed, the
    // permutation's own stream and the value stream start differently.
    let seed = 3;
    assert_ne!(
        SplitMix64::new(seed ^ PERM_SALT).next_u64(),
        SplitMix64::new(seed ^ VALUE_SALT).next_u64()
    );
    assert_eq!(
        NoiseTable::new(Basis::Gradient, seed).perm[..256],
        shuffled_permutation(seed ^ PERM_SALT)
    );
}

#[test]
fn gradient_vectors_are_unit_and_spread() {
    for seed in [0, 1, 12345] {
        let t = NoiseTable::new(Basis::Gradient, seed);
        let mut mean = [0.0f64; 3];
        for g in &t.grads {
            let g = g.map(|c| c as f64);
            let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-6, "length {len}");
            for k in 0..3 {
                mean[k] += g[k] / 256.0;
            }
        }
        // Uniform on the sphere: each mean component has standard deviation sqrt(1/3/256) =
        // 0.036; 0.15 is over 4 sigma.
        assert!(mean.iter().all(|m| m.abs() < 0.15), "{mean:?}");
    }
}

#[test]
fn value_table_is_in_unit_interval_and_spread() {
    let t = NoiseTable::new(Basis::Value(Interpolation::Linear), 0);
    assert!(t.values.iter().all(|v| (0.0..=1.0).contains(v)));
    let mean = t.values.iter().map(|&v| v as f64).sum::<f64>() / 256.0;
    assert!((mean - 0.5).abs() < 0.08, "mean {mean}");
    let lo = t.values.iter().cloned().fold(1.0f32, f32::min);
    let hi = t.values.iter().cloned().fold(0.0f32, f32::max);
    assert!(lo < 0.05 && hi > 0.95, "{lo} {hi}");
}

// ---------------------------------------------------------------------------------------------
// Lattice arithmetic

/// The contract's formula, with the standard library's floor.
fn lattice_reference(x: f64) -> (usize, f64) {
    let c = x.floor();
    let m = c - 256.0 * (c / 256.0).floor();
    (m as usize, x - c)
}

#[test]
fn lattice_index_is_exact_everywhere() {
    let mut rng = SplitMix64::new(5);
    let mut xs: Vec<f64> = vec![
        0.0, -0.0, -1e-20, -1.0, -256.0, -257.0, 255.9, 1e300, -1e300,
    ];
    xs.extend([
        f64::MAX,
        f64::MIN,
        f64::MIN_POSITIVE,
        -f64::MIN_POSITIVE,
        5e-324,
        -5e-324,
    ]);
    xs.extend([
        0.49999999999999994,
        -0.49999999999999994,
        1.0 - f64::EPSILON,
    ]);
    xs.extend([
        -1.0 + f64::EPSILON / 2.0,
        -f64::EPSILON / 4.0,
        9007199254740993.0,
    ]);
    for big in [
        2f64.powi(52),
        2f64.powi(53),
        2f64.powi(61),
        2f64.powi(63),
        2f64.powi(64),
    ] {
        for d in [-2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 256.0] {
            xs.extend([big + d, -big + d, big * 0.75 + d, -(big * 0.75) - d]);
        }
    }
    for e in 0..200 {
        let m = rng.next_signed();
        xs.push(m * 2f64.powf(e as f64 * 0.6));
    }
    for x in xs {
        let (i, f) = lattice(x);
        let (ri, rf) = lattice_reference(x);
        assert_eq!((i, f.to_bits()), (ri, rf.to_bits()), "x = {x:e}");
        assert!(i < 256);
        assert!((0.0..=1.0).contains(&f), "x = {x:e}, f = {f}");
        // Independent check with wide integers, wherever the cell fits in an i128.
        let c = x.floor();
        if c.abs() < 2f64.powi(120) {
            assert_eq!(i as i128, (c as i128).rem_euclid(256), "x = {x:e}");
        } else {
            assert_eq!(i, 0, "x = {x:e}"); // a multiple of 2^68
        }
    }
    for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let (i, f) = lattice(x);
        assert_eq!(i, 0);
        assert!(f.is_nan());
    }
}

// ---------------------------------------------------------------------------------------------
// Perlin reference

#[test]
#[allow(clippy::approx_constant)] // 3.14 is the published test point, not an approximate pi
fn perlin_reproduces_reference_values() {
    let t = NoiseTable::new(Basis::Perlin, 0);
    assert_eq!(t.sample::<f64>([3.14, 42.0, 7.0]), 0.13691995878400012);
    assert_eq!(t.sample::<f64>([-4.2, 10.0, 6.0]), 0.14208000000000043);
}

#[test]
fn perlin_matches_java_transliteration_bit_for_bit() {
    let t = NoiseTable::new(Basis::Perlin, 0);
    let mut pts = points(6, 20_000, 300.0);
    pts.extend(points(7, 2000, 1e6));
    pts.extend(
        awkward_points()
            .into_iter()
            .filter(|p| p.iter().all(|c| c.abs() < 2e9)),
    );
    for p in pts {
        let want = java_improved_noise(p[0], p[1], p[2]);
        let got = t.sample::<f64>(p);
        assert_eq!(got.to_bits(), want.to_bits(), "{p:?}: {got} vs {want}");
    }
}

// ---------------------------------------------------------------------------------------------
// Properties of every basis

#[test]
fn f32_path_tracks_f64_path() {
    let mut pts = points(8, 20_000, 100.0);
    pts.extend(points(9, 2000, 2f64.powi(31)));
    pts.extend(points(10, 2000, 1e8));
    pts.extend(awkward_points());
    let mut bases = continuous_bases();
    // Not CellValue: near a border, the f32 and f64 distances may pick different cells.
    bases.push(Basis::White);
    for basis in bases {
        for seed in [0, 1] {
            let t = NoiseTable::new(basis, seed);
            let mut worst = 0.0f64;
            for &p in &pts {
                let a = t.sample::<f32>(p) as f64;
                let b = t.sample::<f64>(p);
                worst = worst.max((a - b).abs());
            }
            // Perlin's f32 error is the largest: the reference's fade order goes through
            // t * 6 - 15 in [-15, -9] (half an ulp there is 4.8e-7) and the lerps scale
            // weight errors by gradient differences up to 4. Measured over 2e7 random points:
            // at most 2.6e-6 for Perlin, 3.1e-7 for Gradient, 2.3e-7 for Value.
            let tolerance = if matches!(basis, Basis::Perlin | Basis::Simplex) {
                5e-6
            } else {
                1e-6
            };
            assert!(
                worst < tolerance,
                "{basis:?} seed {seed}: |f32 - f64| up to {worst:e}"
            );
        }
    }
}

#[test]
fn gradient_noise_is_zero_on_lattice_points() {
    let t = NoiseTable::new(Basis::Gradient, 3);
    let mut rng = SplitMix64::new(11);
    let mut coords: Vec<f64> = (0..40)
        .map(|_| (rng.next_signed() * 1000.0).round())
        .collect();
    coords.extend([
        0.0,
        -0.0,
        -1.0,
        255.0,
        256.0,
        -256.0,
        2f64.powi(31),
        -2f64.powi(31),
    ]);
    coords.extend([
        1e8,
        -1e8,
        2f64.powi(53),
        1e15,
        -1e15,
        1e300,
        -1e300,
        f64::MAX,
    ]);
    for (i, &x) in coords.iter().enumerate() {
        for k in 0..4 {
            let y = coords[(i + 7 * k + 1) % coords.len()];
            let z = coords[(i + 3 * k + 5) % coords.len()];
            assert_eq!(t.sample::<f64>([x, y, z]), 0.0, "{:?}", [x, y, z]);
            assert_eq!(t.sample::<f32>([x, y, z]), 0.0, "{:?}", [x, y, z]);
        }
    }
}

#[test]
fn value_noise_equals_table_entry_on_lattice_points() {
    for interp in [Interpolation::Linear, Interpolation::Smooth] {
        let t = NoiseTable::new(Basis::Value(interp), 4);
        let perm = |i: i128| t.perm[i.rem_euclid(256) as usize] as i128;
        let mut rng = SplitMix64::new(12);
        let mut pts: Vec<[f64; 3]> = (0..500)
            .map(|_| [0; 3].map(|_: i32| (rng.next_signed() * 600.0).round()))
            .collect();
        pts.push([-1.0, -256.0, 2f64.powi(40) + 3.0]);
        pts.push([-2f64.powi(31), 2f64.powi(31) - 1.0, 1e8]);
        for p in pts {
            let [ix, iy, iz] = p.map(|c| c as i128);
            let want = t.values[perm(ix + perm(iy + perm(iz))) as usize];
            assert_eq!(t.sample::<f64>(p), want as f64, "{p:?}");
            assert_eq!(t.sample::<f32>(p), want, "{p:?}");
        }
        // Huge lattice points are cell 0 mod 256.
        let want = t.values[perm(perm(perm(0))) as usize];
        assert_eq!(t.sample::<f64>([1e300, -1e300, f64::MAX]), want as f64);
    }
}

#[test]
fn continuous_across_cell_boundaries() {
    let mut rng = SplitMix64::new(13);
    for basis in continuous_bases() {
        let t = NoiseTable::new(basis, 21);
        let l = t.lipschitz();
        for _ in 0..3000 {
            let k = (rng.next_signed() * 1000.0).round();
            let axis = (rng.next_u64() % 3) as usize;
            let mut a = [0; 3].map(|_: i32| rng.next_signed() * 1000.0);
            let mut b = a;
            a[axis] = k - 1e-9;
            b[axis] = k + 1e-9;
            let dist = b[axis] - a[axis];
            let d64 = (t.sample::<f64>(a) - t.sample::<f64>(b)).abs();
            assert!(d64 <= l * dist + 1e-12, "{basis:?} {a:?}: jump {d64:e}");
            // Plus the f32 rounding of both sides (see f32_path_tracks_f64_path).
            let rounding = if matches!(basis, Basis::Perlin | Basis::Simplex) {
                1e-5
            } else {
                2e-6
            };
            let d32 = (t.sample::<f32>(a) - t.sample::<f32>(b)).abs() as f64;
            assert!(
                d32 <= l * dist + rounding,
                "{basis:?} {a:?}: f32 jump {d32:e}"
            );
        }
    }
}

#[test]
fn lipschitz_bound_holds_on_random_pairs() {
    let mut rng = SplitMix64::new(14);
    for basis in continuous_bases() {
        let t = NoiseTable::new(basis, 2);
        let l = t.lipschitz();
        let mut worst = 0.0f64;
        for p in points(15, 20_000, 40.0) {
            let h = 1e-4 * rng.next_f64();
            let d = [0; 3].map(|_: i32| h * rng.next_signed());
            let q = [p[0] + d[0], p[1] + d[1], p[2] + d[2]];
            let dist =
                ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2)).sqrt();
            let dn = (t.sample::<f64>(p) - t.sample::<f64>(q)).abs();
            assert!(dn <= l * dist + 1e-12, "{basis:?} at {p:?}");
            if dist > 1e-6 {
                worst = worst.max(dn / dist);
            }
        }
        // The bound is safe but should not be absurdly loose either.
        assert!(
            worst > l / 8.0,
            "{basis:?}: steepest slope {worst} vs bound {l}"
        );
    }
}

#[test]
fn samples_stay_inside_range() {
    // Awkward points first: the shorter share below keeps them.
    let mut pts = awkward_points();
    pts.extend(points(16, 200_000, 256.0));
    for basis in every_basis() {
        for seed in [0, 1, 77] {
            let t = NoiseTable::new(basis, seed);
            let (lo, hi) = t.range();
            // The lattice bases on every point; the others (10x the work per sample in a debug
            // build) on a tenth of them.
            let pts = if BASES.contains(&basis) {
                &pts[..]
            } else {
                &pts[..pts.len() / 10]
            };
            let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
            for &p in pts {
                let v = t.sample::<f64>(p);
                let w = t.sample::<f32>(p) as f64;
                min = min.min(v).min(w);
                max = max.max(v).max(w);
            }
            assert!(
                lo <= min && max <= hi,
                "{basis:?} {seed}: [{min}, {max}] vs [{lo}, {hi}]"
            );
            // And the range is not vacuous: random sampling reaches a good part of it.
            // Cellular's bounds hold for adversarial feature points; random ones stay nearer.
            let share = if matches!(basis, Basis::Cellular(_)) {
                0.25
            } else {
                0.6
            };
            assert!(
                max - min > share * (hi - lo),
                "{basis:?} {seed}: [{min}, {max}]"
            );
        }
    }
}

/// F(p) = Σ_c W_c(p) T(p - c): Perlin noise with adversarially chosen gradients, for
/// `perlin_range_bound_is_proved`.
fn perlin_adversary(p: [f64; 3]) -> f64 {
    fn fade(t: f64) -> f64 {
        t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
    }
    let w = p.map(fade);
    let mut sum = 0.0;
    for c in 0..8 {
        let mut weight = 1.0;
        let mut a = [0.0; 3];
        for k in 0..3 {
            let corner = (c >> k) & 1;
            weight *= if corner == 1 { w[k] } else { 1.0 - w[k] };
            a[k] = (p[k] - corner as f64).abs();
        }
        let two_largest = a[0] + a[1] + a[2] - a[0].min(a[1]).min(a[2]);
        sum += weight * two_largest;
    }
    sum
}

/// Branch and bound: is F <= target on the box [lo, hi]? An upper bound of F on a box is
/// F(centre) + Σ_k L_k h_k, h_k the half-widths and L_k = 1 + max fade' on the box's k-range
/// (|∂F/∂x| <= Σ_c W_c |∂T_c/∂x| + fade'(x) Σ_yz w_yz |T_1yz - T_0yz| <= 1 + fade'(x), since
/// T is 1-Lipschitz in each component and the two x-corners differ by 1 in d_x).
fn adversary_below(lo: [f64; 3], hi: [f64; 3], target: f64, depth: u32) -> bool {
    // By the symmetries of F, the sorted half cell 0 <= x <= y <= z <= 1/2 covers everything.
    if lo[0] > hi[1] || lo[1] > hi[2] {
        return true;
    }
    let dfade = |t: f64| 30.0 * t * t * (1.0 - t) * (1.0 - t);
    let c = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let mut bound = perlin_adversary(c);
    for k in 0..3 {
        // fade' increases on [0, 1/2], so its maximum on the box is at the upper end.
        bound += (1.0 + dfade(hi[k])) * 0.5 * (hi[k] - lo[k]);
    }
    if bound <= target {
        return true;
    }
    if depth == 24 {
        return false;
    }
    (0..8).all(|o| {
        let (mut l, mut h) = (lo, hi);
        for k in 0..3 {
            if (o >> k) & 1 == 0 {
                h[k] = c[k];
            } else {
                l[k] = c[k];
            }
        }
        adversary_below(l, h, target, depth + 1)
    })
}

#[test]
fn perlin_range_bound_is_proved() {
    let (lo, hi) = NoiseTable::new(Basis::Perlin, 0).range();
    assert_eq!(lo, -hi);
    assert!(adversary_below([0.0; 3], [0.5; 3], hi, 0));
    // The bound is nearly tight: the adversary itself gets within 0.4% of it.
    assert!(perlin_adversary([0.355, 0.4825, 0.5]) > 1.0363);
}

#[test]
fn non_finite_input_gives_nan_without_panicking() {
    for basis in every_basis() {
        let t = NoiseTable::new(basis, 5);
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for axis in 0..3 {
                let mut p = [0.3, -7.6, 12.25];
                p[axis] = bad;
                assert!(t.sample::<f64>(p).is_nan(), "{basis:?} {p:?}");
                assert!(t.sample::<f32>(p).is_nan(), "{basis:?} {p:?}");
                let mut out = [0.0f32; 1];
                t.sample_batch(&[p[0]], &[p[1]], &[p[2]], &mut out);
                assert!(out[0].is_nan());
            }
        }
    }
}

#[test]
fn huge_and_tiny_coordinates_are_fine() {
    let specials = [
        1e300,
        -1e300,
        f64::MAX,
        f64::MIN,
        2f64.powi(63),
        -2f64.powi(63),
        2f64.powi(53) + 2.0,
        -1e-300,
        5e-324,
        -0.0,
    ];
    for basis in every_basis() {
        let t = NoiseTable::new(basis, 6);
        let (lo, hi) = t.range();
        for &a in &specials {
            for &b in &specials {
                let p = [a, b, 0.37];
                let v = t.sample::<f64>(p);
                let w = t.sample::<f32>(p);
                assert!(lo <= v && v <= hi, "{basis:?} {p:?}: {v}");
                assert!(lo <= w as f64 && w as f64 <= hi, "{basis:?} {p:?}: {w}");
            }
        }
        // Far from the origin the noise keeps varying (the cell index is still exact).
        let x = 2f64.powi(40);
        assert_ne!(
            t.sample::<f64>([x + 0.5, 0.3, 0.3]),
            t.sample::<f64>([x + 1.5, 0.3, 0.3])
        );
    }
}

#[test]
fn batch_equals_point_bit_for_bit() {
    let mut pts = points(17, 1000, 300.0);
    pts.extend(awkward_points());
    pts.extend([
        [f64::NAN, 0.0, 0.0],
        [1e300, -0.0, f64::INFINITY],
        [-0.0, -0.0, -0.0],
    ]);
    let x: Vec<f64> = pts.iter().map(|p| p[0]).collect();
    let y: Vec<f64> = pts.iter().map(|p| p[1]).collect();
    let z: Vec<f64> = pts.iter().map(|p| p[2]).collect();
    for basis in every_basis() {
        let t = NoiseTable::new(basis, 8);
        let mut o64 = vec![0.0f64; pts.len()];
        let mut o32 = vec![0.0f32; pts.len()];
        t.sample_batch(&x, &y, &z, &mut o64);
        t.sample_batch(&x, &y, &z, &mut o32);
        for (i, &p) in pts.iter().enumerate() {
            assert_eq!(
                o64[i].to_bits(),
                t.sample::<f64>(p).to_bits(),
                "{basis:?} {p:?}"
            );
            assert_eq!(
                o32[i].to_bits(),
                t.sample::<f32>(p).to_bits(),
                "{basis:?} {p:?}"
            );
        }
    }
}

#[test]
#[should_panic(expected = "slice lengths differ")]
fn batch_rejects_mismatched_lengths() {
    let t = NoiseTable::new(Basis::Perlin, 0);
    let mut out = [0.0f64; 3];
    t.sample_batch(&[0.0; 3], &[0.0; 2], &[0.0; 3], &mut out);
}

#[test]
#[should_panic(expected = "slice lengths differ")]
fn fractal_batch_rejects_mismatched_lengths() {
    let t = NoiseTable::new(Basis::Perlin, 0);
    let o = Octaves::new(2.0, 2.0, 0.5, 0);
    let mut out = [0.0f32; 2];
    fractal_batch(&t, &o, false, &[0.0; 3], &[0.0; 3], &[0.0; 3], &mut out);
}

#[test]
fn tables_are_send_sync_and_debug_is_short() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<NoiseTable>();
    let s = format!(
        "{:?}",
        NoiseTable::new(Basis::Value(Interpolation::Smooth), 9)
    );
    assert!(
        s.contains("Smooth") && s.contains("seed: 9") && s.len() < 100,
        "{s}"
    );
}

// ---------------------------------------------------------------------------------------------
// Octaves and fractal sums

#[test]
fn octaves_with_partial_last_octave() {
    let o = Octaves::new(2.5, 2.0, 0.5, 0);
    assert_eq!(o.frequencies, [1.0, 2.0, 4.0]);
    assert_eq!(o.amplitudes, [1.0, 0.5, 0.125]);
    assert_eq!(o.len(), 3);
    assert!(!o.is_empty());
    let o = Octaves::new(3.0, 2.0, 0.5, 0);
    assert_eq!(o.frequencies, [1.0, 2.0, 4.0]);
    assert_eq!(o.amplitudes, [1.0, 0.5, 0.25]);
    let o = Octaves::new(0.25, 3.0, 0.5, 0);
    assert_eq!((o.frequencies, o.amplitudes), (vec![1.0], vec![0.25]));
}

#[test]
fn octaves_with_first_octave() {
    let o = Octaves::new(3.0, 2.0, 0.5, 2);
    assert_eq!(o.frequencies, [4.0, 8.0, 16.0]);
    assert_eq!(o.amplitudes, [0.25, 0.125, 0.0625]);
    let o = Octaves::new(1.5, 3.0, 0.25, 2);
    assert_eq!(o.frequencies, [9.0, 27.0]);
    assert_eq!(o.amplitudes, [0.0625, 0.015625 * 0.5]);
}

#[test]
fn octaves_empty_schedule_sums_to_zero() {
    let o = Octaves::new(0.0, 2.0, 0.5, 0);
    assert!(o.is_empty());
    assert_eq!(o.len(), 0);
    let t = NoiseTable::new(Basis::Perlin, 0);
    assert_eq!(fractal::<f64>(&t, &o, false, [0.3, 0.4, 0.5]), 0.0);
    let mut out = [7.0f32; 4];
    fractal_batch(&t, &o, true, &[0.1; 4], &[0.2; 4], &[0.3; 4], &mut out);
    assert_eq!(out, [0.0; 4]);
}

#[test]
fn octave_powers_match_powi() {
    use std::hint::black_box;
    for base in [1.9, 2.0, 0.5, 0.47, 2.7, 1.0 / 3.0] {
        let o = Octaves::new(black_box(20.0), base, base, 0);
        for (i, (&f, &a)) in o.frequencies.iter().zip(&o.amplitudes).enumerate() {
            let want = black_box(base).powi(black_box(i as i32));
            assert_eq!(f, want, "{base}^{i}");
            assert_eq!(a, want, "{base}^{i}");
        }
    }
}

#[test]
fn fractal_is_the_documented_sum() {
    let t = NoiseTable::new(Basis::Gradient, 1);
    let o = Octaves::new(3.7, 1.97, 0.55, 1);
    for p in points(18, 500, 20.0) {
        for turbulence in [false, true] {
            let mut want = 0.0f32;
            for (&f, &a) in o.frequencies.iter().zip(&o.amplitudes) {
                let n: f32 = t.sample([p[0] * f, p[1] * f, p[2] * f]);
                let n = if turbulence { n.abs() } else { n };
                want += a as f32 * n;
            }
            let got = fractal::<f32>(&t, &o, turbulence, p);
            assert_eq!(got.to_bits(), want.to_bits());
        }
    }
    // One unit octave is the basis itself.
    let one = Octaves::new(1.0, 2.0, 0.5, 0);
    for p in points(19, 100, 20.0) {
        assert_eq!(fractal::<f64>(&t, &one, false, p), t.sample::<f64>(p));
    }
}

#[test]
fn turbulence_is_non_negative_and_fbm_is_bounded() {
    let o = Octaves::new(4.5, 2.0, 0.5, 0);
    let total: f64 = o.amplitudes.iter().sum();
    for basis in BASES {
        let t = NoiseTable::new(basis, 10);
        let (lo, hi) = t.range();
        let bound = total * lo.abs().max(hi.abs());
        for p in points(20, 5000, 64.0) {
            let turb = fractal::<f32>(&t, &o, true, p);
            assert!(turb >= 0.0, "{basis:?} {p:?}: {turb}");
            assert!((turb as f64) <= bound + 1e-5);
            let fbm = fractal::<f64>(&t, &o, false, p);
            assert!(fbm.abs() <= bound, "{basis:?} {p:?}: {fbm}");
        }
    }
}

#[test]
fn fractal_batch_equals_fractal_bit_for_bit() {
    let mut pts = points(21, 700, 100.0);
    pts.extend(awkward_points());
    pts.push([f64::NAN, 1.0, 2.0]);
    let x: Vec<f64> = pts.iter().map(|p| p[0]).collect();
    let y: Vec<f64> = pts.iter().map(|p| p[1]).collect();
    let z: Vec<f64> = pts.iter().map(|p| p[2]).collect();
    let schedules = [
        Octaves::new(5.0, 2.0, 0.5, 0),
        Octaves::new(2.5, 1.93, 0.6, 3),
        Octaves::new(0.5, 2.0, 0.5, 0),
    ];
    for basis in every_basis() {
        let t = NoiseTable::new(basis, 11);
        for o in &schedules {
            for turbulence in [false, true] {
                let mut o64 = vec![f64::NAN; pts.len()];
                let mut o32 = vec![f32::NAN; pts.len()];
                fractal_batch(&t, o, turbulence, &x, &y, &z, &mut o64);
                fractal_batch(&t, o, turbulence, &x, &y, &z, &mut o32);
                for (i, &p) in pts.iter().enumerate() {
                    let w64 = fractal::<f64>(&t, o, turbulence, p);
                    let w32 = fractal::<f32>(&t, o, turbulence, p);
                    assert_eq!(f64_bits(o64[i]), f64_bits(w64), "{basis:?} {p:?}");
                    assert_eq!(f64_bits(o32[i]), f64_bits(w32), "{basis:?} {p:?}");
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Batch kernels (batch/, vbmi.rs): bit for bit the point functions

/// A pool of points mixing the first `kinds` kinds of coordinate: random at scales from 1 to
/// 2^40, integers, points just off integers and off multiples of 256, ±0 and negatives (kinds
/// 0..8: every chunk takes the fast lattice path); magnitudes near 2^50 and 2^51, the fast
/// path's limit (8..10: fast or exact, by chunk and octave frequency); huge and non-finite
/// coordinates (10..12: their chunk takes the exact path).
pub(super) fn batch_pool(seed: u64, n: usize, kinds: u64) -> Vec<[f64; 3]> {
    let mut rng = SplitMix64::new(seed);
    let coordinate = |rng: &mut SplitMix64| -> f64 {
        let r = rng.next_signed();
        let k = (rng.next_u64() % 2048) as f64 - 1024.0;
        let pick = |rng: &mut SplitMix64, options: &[f64]| {
            options[(rng.next_u64() % options.len() as u64) as usize]
        };
        match rng.next_u64() % kinds {
            0 => 8.0 * r.abs(),
            1 => 300.0 * r,
            2 => 1e6 * r,
            3 => 2f64.powi(40) * r,
            4 => k,
            // -1e-17 and the least subnormal below a whole k: its fraction rounds to 1.0 (a
            // point at the next cell's corner in all but name).
            5 => {
                k + pick(
                    rng,
                    &[1e-9, -1e-9, 0.5, f64::EPSILON, -f64::EPSILON, -1e-17],
                )
            }
            6 if k == 0.0 => pick(rng, &[-1e-17, -5e-324, -1e-300]),
            6 => 256.0 * k + pick(rng, &[0.0, 1e-7, -1e-7]),
            7 => pick(rng, &[0.0, -0.0, 1.0, -1.0, 255.0, -256.0]),
            8 => 2f64.powi(50) * r,
            9 => 2f64.powi(51) * r.signum() + r,
            10 => pick(
                rng,
                &[
                    1e300,
                    -1e300,
                    2f64.powi(52) + 2.0,
                    -2f64.powi(61),
                    2f64.powi(51),
                ],
            ),
            _ => pick(rng, &[f64::NAN, f64::INFINITY, f64::NEG_INFINITY]),
        }
    };
    (0..n)
        .map(|_| {
            [
                coordinate(&mut rng),
                coordinate(&mut rng),
                coordinate(&mut rng),
            ]
        })
        .collect()
}

pub(super) fn planes(pts: &[[f64; 3]]) -> [Vec<f64>; 3] {
    [0, 1, 2].map(|a| pts.iter().map(|p| p[a]).collect())
}

/// Bits of a result, NaN included (the point and batch paths return the same canonical NaN).
fn bits_of<S: Real>(v: &[S]) -> Vec<u64> {
    v.iter().map(|v| v.to_f64().to_bits()).collect()
}

/// `sample_batch` gives `sample`'s bits on every lane.
fn assert_sample_batch_is_point<S: Real>(t: &NoiseTable, pts: &[[f64; 3]], what: &str) {
    let [x, y, z] = planes(pts);
    let mut out = vec![S::ZERO; pts.len()];
    t.sample_batch(&x, &y, &z, &mut out);
    let want: Vec<S> = pts.iter().map(|&p| t.sample(p)).collect();
    assert_eq!(
        bits_of(&out),
        bits_of(&want),
        "{what}: sample_batch, {} lanes",
        pts.len()
    );
}

fn check_batches<S: Real>(t: &NoiseTable, schedule: &Octaves, pts: &[[f64; 3]], what: &str) {
    assert_sample_batch_is_point::<S>(t, pts, what);
    let [x, y, z] = planes(pts);
    let n = pts.len();
    let mut out = vec![S::ZERO; n];
    for turbulence in [false, true] {
        fractal_batch(t, schedule, turbulence, &x, &y, &z, &mut out);
        let want: Vec<S> = pts
            .iter()
            .map(|&p| fractal(t, schedule, turbulence, p))
            .collect();
        assert_eq!(
            bits_of(&out),
            bits_of(&want),
            "{what}: fractal_batch (turbulence {turbulence}), {n} lanes"
        );
    }
}

/// Every batch length from 1 to 300 (below and above the per-point threshold, not multiples of
/// 8 or 16, across the 256-lane chunk), every basis, both precisions, on points that take the
/// fast lattice path and on points that take the exact one.
#[test]
fn batch_kernels_equal_point_functions_for_every_length() {
    let tame = batch_pool(31, 340, 8);
    let edge = batch_pool(32, 340, 10);
    let wild = batch_pool(33, 340, 12);
    assert!(wild.iter().flatten().any(|v| v.is_nan()));
    let schedule = Octaves::new(2.5, 2.0, 0.5, 0);
    for basis in BASES {
        let t = NoiseTable::new(basis, 41);
        for len in 1..=300 {
            let start = len % 37;
            for (pool, name) in [(&tame, "tame"), (&edge, "edge"), (&wild, "wild")] {
                let pts = &pool[start..start + len];
                let what = format!("{basis:?} {name}");
                check_batches::<f32>(&t, &schedule, pts, &what);
                check_batches::<f64>(&t, &schedule, pts, &what);
            }
        }
    }
}

/// Long batches (several chunks, one of them wild) with the marble's 8-octave schedule and the
/// reference permutation; with the byte-shuffle hashing where the CPU has it, and with the
/// table reads every CPU can run.
#[test]
fn batch_kernels_equal_point_functions_on_long_batches() {
    check_long_batches();
    with_table_reads(check_long_batches);
}

fn check_long_batches() {
    let mut pts = batch_pool(34, 700, 8);
    pts.extend(batch_pool(35, 300, 12));
    pts.extend(batch_pool(36, 301, 10));
    let schedule = Octaves::new(8.0, 2.0, 0.5, 0);
    for basis in every_basis() {
        for seed in [0, 7] {
            let t = NoiseTable::new(basis, seed);
            check_batches::<f32>(&t, &schedule, &pts, &format!("{basis:?} seed {seed}"));
            check_batches::<f64>(&t, &schedule, &pts, &format!("{basis:?} seed {seed}"));
        }
    }
}

/// Batches under the per-point threshold take each point's octaves as the SIMD lanes (8, 16 or
/// 32 of them): every schedule length up to the limit, fractional and shifted schedules,
/// lacunarities that push octaves across the fast lattice path's limit, and wild points.
#[test]
fn octave_lanes_equal_point_functions_for_every_schedule_length() {
    let mut pts = batch_pool(38, 40, 8);
    pts.extend(batch_pool(39, 40, 10));
    pts.extend(batch_pool(40, 40, 12));
    for basis in BASES {
        let t = NoiseTable::new(basis, 3);
        for octaves in (0..=64).map(|i| i as f64 * 0.5) {
            for (lacunarity, first) in [(2.0, 0), (1.93, 3), (3.5, 0), (0.5, 1)] {
                let schedule = Octaves::new(octaves, lacunarity, 0.6, first);
                for chunk in pts.chunks(7) {
                    let what = format!("{basis:?} octaves {octaves} lacunarity {lacunarity}");
                    check_batches::<f32>(&t, &schedule, chunk, &what);
                    check_batches::<f64>(&t, &schedule, chunk, &what);
                }
            }
        }
    }
}

#[test]
fn batch_lattice_lanes_match_lattice() {
    use super::batch::{lattice_lane_exact, lattice_lane_fast, TWO51};
    let mut xs: Vec<f64> = batch_pool(37, 3000, 12).into_iter().flatten().collect();
    xs.extend([
        0.0,
        -0.0,
        -1e-300,
        5e-324,
        -5e-324,
        f64::MAX,
        f64::MIN,
        1.0 - f64::EPSILON,
    ]);
    for e in [51, 52, 53, 60, 61, 62, 64, 100] {
        let big = 2f64.powi(e);
        for d in [-2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 256.0] {
            xs.extend([big + d, -big + d, big * 0.75 + d, -(big * 0.75) - d]);
        }
    }
    for x in xs {
        let (i64_, f64_) = lattice_lane_exact::<f64>(x);
        let (i32_, f32_) = lattice_lane_exact::<f32>(x);
        assert_eq!(i64_, i32_);
        if x.is_finite() {
            let (i, f) = lattice(x);
            assert_eq!(
                (i64_ as usize, f64_.to_bits()),
                (i, f.to_bits()),
                "x = {x:e}"
            );
            assert_eq!(f32_.to_bits(), (f as f32).to_bits(), "x = {x:e}");
        } else {
            assert!(f64_.is_nan() && f32_.is_nan(), "x = {x:e}");
        }
        if x.abs() < TWO51 {
            assert_eq!(lattice_lane_fast::<f64>(x).0, i64_, "x = {x:e}");
            assert_eq!(lattice_lane_fast::<f64>(x).1.to_bits(), f64_.to_bits());
        }
    }
}

#[test]
fn fast_lattice_is_used_only_where_it_is_exact() {
    use super::batch::{fits, TWO51};
    let ok = [1.0, -3.5, 1e6];
    assert!(fits([&ok, &ok, &ok], 1.0));
    assert!(fits([&ok, &ok, &ok], 2f64.powi(20)));
    assert!(!fits([&ok, &ok, &ok], 2f64.powi(40)));
    assert!(fits([&ok, &ok, &ok], 0.0));
    for bad in [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        TWO51,
        -TWO51,
        1e300,
    ] {
        let p = [1.0, bad, 2.0];
        assert!(!fits([&ok, &p, &ok], 1.0), "{bad}");
    }
    assert!(fits([&[TWO51 / 2.0], &ok, &ok], 1.0));
    assert!(!fits([&[TWO51 / 2.0], &ok, &ok], 2.0));
    assert!(!fits([&ok, &ok, &ok], f64::NAN));
}

/// The reference's fourteen permutation reads (Perlin's A, AA, AB, B, BA, BB), on a
/// `perm[i & 255]` table: the ground truth for the paired and the byte-shuffle hashes.
fn perlin_hashes_reference(perm: &[u8; 512], [x, y, z]: [usize; 3]) -> [u8; 8] {
    let p = |i: usize| perm[i & 255] as usize;
    let a = p(x) + y;
    let (aa, ab) = (p(a) + z, p(a + 1) + z);
    let b = p(x + 1) + y;
    let (ba, bb) = (p(b) + z, p(b + 1) + z);
    [aa, ba, ab, bb, aa + 1, ba + 1, ab + 1, bb + 1].map(|i| p(i) as u8)
}

/// Random cells plus every cell with coordinates in {0, 1, 254, 255}.
fn hash_cells() -> Vec<[usize; 3]> {
    let mut rng = SplitMix64::new(37);
    let mut cells: Vec<[usize; 3]> = (0..20_000)
        .map(|_| [0, 0, 0].map(|_: usize| (rng.next_u64() % 256) as usize))
        .collect();
    let edges = [0, 1, 254, 255];
    for x in edges {
        for y in edges {
            for z in edges {
                cells.push([x, y, z]);
            }
        }
    }
    cells
}

#[test]
fn paired_hashes_match_the_permutation_reads() {
    use super::lattice::{corner_hashes, corner_hashes_paired};
    for seed in [0, 1, 99] {
        let t = NoiseTable::new(Basis::Perlin, seed);
        for c in hash_cells() {
            let cell = c.map(|v| v as i32);
            assert_eq!(
                perlin::hashes_paired(&t.pairs, cell),
                perlin_hashes_reference(&t.perm, c),
                "seed {seed} cell {c:?}"
            );
            let [x, y, z] = c;
            assert_eq!(
                corner_hashes_paired(&t.pairs, cell),
                corner_hashes(&t.perm, x, y, z).map(|h| h as u8),
                "seed {seed} cell {c:?}"
            );
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) fn has_vbmi() -> bool {
    is_x86_feature_detected!("avx512f")
        && is_x86_feature_detected!("avx512bw")
        && is_x86_feature_detected!("avx512vbmi")
}

#[cfg(target_arch = "x86_64")]
#[test]
fn byte_shuffle_hashes_match_the_paired_hashes() {
    use super::lanes::CHUNK;
    use super::lattice::corner_hashes_paired;
    if !has_vbmi() {
        eprintln!(
            "NOTE: no AVX-512 VBMI on this CPU: the byte-shuffle hashing itself is not run here; \
             its table lookup is tested through the portable emulation \
             (byte_lookup_reads_the_whole_table)"
        );
        return;
    }
    let cells = hash_cells();
    for seed in [0, 5] {
        let t = NoiseTable::new(Basis::Perlin, seed);
        for group in cells.chunks(CHUNK) {
            let mut cell = [[0u8; CHUNK]; 3];
            for (i, c) in group.iter().enumerate() {
                for a in 0..3 {
                    cell[a][i] = c[a] as u8;
                }
            }
            let mut perlin_h = [[0u8; CHUNK]; 8];
            let mut ebert_h = [[0u8; CHUNK]; 8];
            // SAFETY: the features were detected above.
            unsafe {
                super::vbmi::corner_hashes::<true>(&t.perm, &cell, group.len(), &mut perlin_h);
                super::vbmi::corner_hashes::<false>(&t.perm, &cell, group.len(), &mut ebert_h);
            }
            for (i, c) in group.iter().enumerate() {
                let cell = c.map(|v| v as i32);
                let want_p = perlin::hashes_paired(&t.pairs, cell);
                let want_e = corner_hashes_paired(&t.pairs, cell);
                for k in 0..8 {
                    assert_eq!(perlin_h[k][i], want_p[k], "seed {seed} {c:?} corner {k}");
                    assert_eq!(ebert_h[k][i], want_e[k], "seed {seed} {c:?} corner {k}");
                }
            }
        }
    }
}

/// The byte-shuffle table lookup, on every x86-64 CPU through its portable emulation (every
/// index 0..=255 reads its table entry, for several tables), and on a CPU with VBMI the
/// instructions themselves against the emulation, byte for byte.
#[cfg(target_arch = "x86_64")]
#[test]
fn byte_lookup_reads_the_whole_table() {
    use super::vbmi::{lookup_bytes, lookup_portable};
    let vbmi = has_vbmi();
    for seed in [0, 5, 1234] {
        let t = NoiseTable::new(Basis::Perlin, seed);
        let table: [[u8; 64]; 4] =
            std::array::from_fn(|r| std::array::from_fn(|j| t.perm[r * 64 + j]));
        for part in 0..4 {
            // Indices in a scrambled order, so lanes do not just read their own position.
            let idx: [u8; 64] = std::array::from_fn(|j| ((part * 64 + j) as u8).wrapping_mul(167));
            let got = lookup_portable(&table, &idx);
            for j in 0..64 {
                assert_eq!(
                    got[j], t.perm[idx[j] as usize],
                    "seed {seed} index {}",
                    idx[j]
                );
            }
            if vbmi {
                // SAFETY: the features were detected above.
                let real = unsafe { lookup_bytes(&table, &idx) };
                assert_eq!(real, got, "seed {seed} part {part}");
            }
        }
    }
}

/// The two forms of step 2 (hashes gathered in the loop; hashes precomputed, as the byte-shuffle
/// path does) agree, whichever of them this CPU's dispatch runs.
#[test]
fn both_forms_of_the_lane_loop_agree() {
    use super::batch::lattice::Lattice;
    use super::lanes::CHUNK;
    fn run<S: Real>(t: &NoiseTable, pts: &[[f64; 3]]) {
        match t.basis {
            Basis::Perlin => run_kernel::<S, _>(
                t,
                &PerlinKernel {
                    perm: &t.perm,
                    pairs: &t.pairs,
                },
                pts,
            ),
            Basis::Gradient => run_kernel::<S, _>(
                t,
                &GradientKernel {
                    perm: &t.perm,
                    pairs: &t.pairs,
                    grads: &t.grads,
                },
                pts,
            ),
            Basis::Value(Interpolation::Linear) => run_kernel::<S, _>(
                t,
                &ValueKernel::<false> {
                    perm: &t.perm,
                    pairs: &t.pairs,
                    values: &t.values,
                },
                pts,
            ),
            Basis::Value(Interpolation::Smooth) => run_kernel::<S, _>(
                t,
                &ValueKernel::<true> {
                    perm: &t.perm,
                    pairs: &t.pairs,
                    values: &t.values,
                },
                pts,
            ),
            // Not lattice bases: no lattice loop to compare.
            Basis::Simplex | Basis::Cellular(_) | Basis::White => {}
        }
    }
    fn run_kernel<S: Real, K: LatticeKernel>(t: &NoiseTable, k: &K, pts: &[[f64; 3]]) {
        let [x, y, z] = planes(pts);
        let n = pts.len();
        let mut lattice = Lattice::<S>::new();
        lattice.fill::<false>(false, 1.0, [&x, &y, &z]);
        let mut fused = vec![S::ZERO; n];
        lattice.noise::<_, false, false, false>(k, S::ONE, &mut fused);
        for i in 0..n {
            let h = k.hashes([0, 1, 2].map(|a| lattice.cell[a][i] as i32));
            for (plane, h) in lattice.hashes.iter_mut().zip(h) {
                plane[i] = h;
            }
        }
        let mut split = vec![S::ZERO; n];
        lattice.noise_hashed::<_, false, false, true>(k, S::ONE, &mut split);
        assert_eq!(bits_of(&fused), bits_of(&split), "{:?}", t.basis());
        let want: Vec<S> = pts.iter().map(|&p| t.sample(p)).collect();
        assert_eq!(bits_of(&fused), bits_of(&want), "{:?}", t.basis());
    }
    let pts = batch_pool(38, CHUNK, 12);
    for basis in BASES {
        let t = NoiseTable::new(basis, 12);
        run::<f32>(&t, &pts);
        run::<f64>(&t, &pts);
    }
}

// ---------------------------------------------------------------------------------------------
// Simplex

/// The BCC lattice's vertices around `p`: the integer and the half-integer points of the
/// cubes around its cell (every vertex within distance 2).
fn bcc_vertices_near(p: [f64; 3]) -> Vec<[f64; 3]> {
    let base = p.map(|c| c.floor());
    let mut out = Vec::new();
    for i in -2..=3 {
        for j in -2..=3 {
            for k in -2..=3 {
                let v = [
                    base[0] + f64::from(i),
                    base[1] + f64::from(j),
                    base[2] + f64::from(k),
                ];
                out.push(v);
                out.push(v.map(|c| c + 0.5));
            }
        }
    }
    out
}

/// An independent simplex reference: from absolute coordinates, every vertex of the BCC lattice
/// near the point (no tetrahedron logic), its hash from its skewed coordinates `M V`
/// (`(Vy + Vz, Vx + Vz, Vx + Vy)`, integers) mod 256, the kernel `(0.5 - r²)⁴ (g · d)` for
/// every vertex within √0.5, plain f64.
fn simplex_brute_force(t: &NoiseTable, p: [f64; 3]) -> f64 {
    let mut sum = 0.0;
    for v in bcc_vertices_near(p) {
        let d: [f64; 3] = std::array::from_fn(|a| p[a] - v[a]);
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if r2 >= 0.5 {
            continue;
        }
        let skewed =
            [v[1] + v[2], v[0] + v[2], v[0] + v[1]].map(|c| (c as i64).rem_euclid(256) as usize);
        let [a, b, c] = skewed;
        let h = t.perm[a + t.perm[b + t.perm[c] as usize] as usize] as usize;
        let g = simplex::GRADIENTS[h % 12].map(f64::from);
        sum += (0.5 - r2).powi(4) * (g[0] * d[0] + g[1] * d[1] + g[2] * d[2]);
    }
    76.0 * sum
}

/// The four vertices of a point's tetrahedron are all the kernel reaches: the noise equals the
/// sum over every vertex (also checks the exact skewed cells, the carries and the tetrahedron
/// choice), near the origin and far from it.
#[test]
fn simplex_matches_a_brute_force_sum_over_every_vertex() {
    for seed in [0, 9] {
        let t = NoiseTable::new(Basis::Simplex, seed);
        let mut pts = points(40, 20_000, 60.0);
        pts.extend(points(41, 2000, 3.0));
        pts.extend(
            points(42, 500, 1e9)
                .into_iter()
                .map(|p| p.map(|c| c.round() + 0.3125)),
        );
        for p in pts {
            let want = simplex_brute_force(&t, p);
            let got = t.sample::<f64>(p);
            assert!((got - want).abs() < 1e-12, "{p:?}: {got} vs {want}");
        }
    }
}

/// The tetrahedron's order of the skewed fractions: the largest first, then the second largest,
/// ties to the lower axis, for every permutation of three values with and without ties.
#[test]
fn simplex_orders_rank_the_skewed_fractions() {
    use simplex::{order, Order};
    for s in [
        [0.3f64, 0.2, 0.1],
        [0.25, 0.25, 0.1],
        [0.5, 0.5, 0.5],
        [0.1, 0.1, 0.4],
        [0.0, 0.7, 0.7],
    ] {
        for perm in [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ] {
            let v = [s[perm[0]], s[perm[1]], s[perm[2]]];
            let mut axes = [0usize, 1, 2];
            // Largest first; equal values keep the lower axis first (a stable sort).
            axes.sort_by(|&a, &b| v[b].total_cmp(&v[a]));
            assert_eq!(
                order(v),
                Order {
                    first: axes[0],
                    second: axes[1]
                },
                "{v:?}"
            );
        }
    }
    assert_eq!(order([f64::NAN; 3]).first, 2);
}

/// Zero on the grid's vertices, the integer points and the half-integer points, exactly
/// representable at every magnitude up to 2^51.
#[test]
fn simplex_is_zero_on_its_vertices() {
    let t = NoiseTable::new(Basis::Simplex, 4);
    let mut rng = SplitMix64::new(42);
    let mut checked = 0;
    for scale in [10.0, 1e6, 2f64.powi(31), 2f64.powi(45)] {
        for half in [0.0, 0.5] {
            for _ in 0..150 {
                let p = [0; 3].map(|_: i32| (rng.next_signed() * scale).round() + half);
                assert_eq!(t.sample::<f64>(p), 0.0, "{p:?}");
                assert_eq!(t.sample::<f32>(p), 0.0, "{p:?}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 1200);
    // Other points are not zero: the noise is not trivially flat.
    assert_ne!(t.sample::<f64>([0.25, 0.0, 0.0]), 0.0);
}

/// Exact at any magnitude: far out, the noise of `p` equals that of `p` moved back by a whole
/// number of its untiled periods (256 along each axis: the hash reads the skewed cells mod
/// 256), bit for bit.
#[test]
fn simplex_repeats_every_256_exactly_far_out() {
    let t = NoiseTable::new(Basis::Simplex, 5);
    for p in points(43, 2000, 100.0) {
        for far in [256.0 * 1e6, 256.0 * 2f64.powi(30), -256.0 * 3.0e9] {
            let q = [p[0] + far, p[1] - far, p[2] + 2.0 * far];
            // The fraction must survive the shift for the comparison to be fair.
            if q[0] - far != p[0] || q[1] + far != p[1] || q[2] - 2.0 * far != p[2] {
                continue;
            }
            assert_eq!(
                t.sample::<f64>(q).to_bits(),
                t.sample::<f64>(p).to_bits(),
                "{p:?} + {far}"
            );
        }
    }
}

/// Every integer period from 1 to 64 on each axis tiles bit for bit (issue 32): `N(p + P eₐ) =
/// N(p)` for random points, in f32 and f64, the value and the gradient.
#[test]
fn simplex_tiles_at_every_period_up_to_64() {
    let mut rng = SplitMix64::new(47);
    for p_len in 1..=64u64 {
        for axis in 0..3 {
            let mut period = [0u64; 3].map(|_| 1 + (rng.next_f64() * 64.0) as u64);
            period[axis] = p_len;
            let t = NoiseTable::periodic(Basis::Simplex, 3, Some(period));
            for _ in 0..8 {
                let p = [0; 3].map(|_: u8| rng.next_signed() * 100.0);
                let k = (rng.next_signed() * 20.0).round();
                let mut q = p;
                q[axis] += k * p_len as f64;
                if q[axis] - k * p_len as f64 != p[axis] {
                    continue;
                }
                assert_eq!(
                    t.sample::<f64>(p).to_bits(),
                    t.sample::<f64>(q).to_bits(),
                    "period {period:?}, axis {axis}, {p:?}"
                );
                assert_eq!(t.sample::<f32>(p).to_bits(), t.sample::<f32>(q).to_bits());
                let (g, h) = (t.sample_grad::<f64>(p), t.sample_grad::<f64>(q));
                assert_eq!(g.map(f64::to_bits), h.map(f64::to_bits), "{period:?} {p:?}");
            }
        }
    }
}

/// Sum over the BCC vertices within reach of `x` of `term(r², d)`, and a bound on the sum's
/// change within distance `slack`: the sum over the vertices that can come within reach of
/// `slope(r_lo, r_hi)`, the largest slope of one term for a vertex at a distance in
/// [r_lo, r_hi].
fn simplex_vertex_sum(
    x: [f64; 3],
    slack: f64,
    term: &dyn Fn(f64, [f64; 3]) -> f64,
    slope: &dyn Fn(f64, f64) -> f64,
) -> (f64, f64) {
    let reach = 0.5f64.sqrt();
    let (mut sum, mut change) = (0.0, 0.0);
    for v in bcc_vertices_near(x) {
        let d: [f64; 3] = std::array::from_fn(|a| x[a] - v[a]);
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if r2 < 0.5 {
            sum += term(r2, d);
        }
        let r = r2.sqrt();
        if r - slack < reach {
            change += slack * slope((r - slack).max(0.0), (r + slack).min(reach));
        }
    }
    (sum, change)
}

/// Branch and bound over the lattice's fundamental region: the BCC lattice (and every term
/// below, a function of |components|) is symmetric under integer translations, the reflections
/// `x -> 1 - x` and axis permutations, so `1/2 >= x >= y >= z >= 0` covers space. Is the vertex
/// sum of `term` at most `target` everywhere? A box's bound is the sum at its centre plus the
/// change bound of [`simplex_vertex_sum`] over the box's half-diagonal.
fn simplex_sum_below(
    term: &dyn Fn(f64, [f64; 3]) -> f64,
    slope: &dyn Fn(f64, f64) -> f64,
    target: f64,
) -> bool {
    let mut stack = vec![([0.0f64; 3], [0.5f64; 3])];
    while let Some((lo, hi)) = stack.pop() {
        if hi[0] < lo[1] || hi[1] < lo[2] {
            continue;
        }
        let c: [f64; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
        let half: f64 = (0..3)
            .map(|a| (0.5 * (hi[a] - lo[a])).powi(2))
            .sum::<f64>()
            .sqrt();
        let (value, change) = simplex_vertex_sum(c, half, term, slope);
        if value + change <= target {
            continue;
        }
        if half < 1e-6 {
            return false;
        }
        for o in 0..8 {
            let (mut l, mut h) = (lo, hi);
            for a in 0..3 {
                if (o >> a) & 1 == 0 {
                    h[a] = c[a];
                } else {
                    l[a] = c[a];
                }
            }
            stack.push((l, h));
        }
    }
    true
}

/// The range ±1: |N| <= 76 Σ (0.5 - r²)⁴ |g · d| <= 76 Σ (0.5 - r²)⁴ T(d), T the sum of the two
/// largest |components| (the largest |g · d| over the 12 edge gradients), and that sum stays
/// below 1/76. Each term's slope in position is at most √2 (0.5 - r²)³ (0.5 + 7 r²).
/// The Lipschitz bound: |∇N| <= 76 Σ √2 (0.5 - r²)³ (0.5 + 7 r²) (see `simplex::LIPSCHITZ`), and
/// that sum stays below 12.5 / 76 (its maximum is about 0.15645, at (1/4, 1/4, 1/4)); each of
/// its terms has slope at most 0.4425 in r (the maximum of |d/dr| of it,
/// √2 r (0.5 - r²)² |4 - 56 r²|, is 0.44244, at r = 0.4944).
#[test]
fn simplex_range_and_lipschitz_bounds_are_proved() {
    let (lo, hi) = NoiseTable::new(Basis::Simplex, 0).range();
    assert_eq!((lo, hi), (-1.0, 1.0));
    let adversary = |r2: f64, d: [f64; 3]| {
        let mut a = d.map(f64::abs);
        a.sort_by(f64::total_cmp);
        (0.5 - r2).powi(4) * (a[1] + a[2])
    };
    // One term's gradient, √2 (0.5 - r²)³ (0.5 + 7 r²), rises to its peak at r² = 0.5/7 and
    // falls after: its maximum over [a, b] is at the point of [a, b] nearest the peak.
    let term_slope = |r: f64| 2f64.sqrt() * (0.5 - r * r).powi(3) * (0.5 + 7.0 * r * r);
    let peak = (0.5f64 / 7.0).sqrt();
    let range_slope = |a: f64, b: f64| term_slope(peak.clamp(a, b));
    assert!(simplex_sum_below(
        &adversary,
        &range_slope,
        hi / simplex::SCALE
    ));
    let slope = |r2: f64, _: [f64; 3]| term_slope(r2.sqrt());
    assert!(simplex_sum_below(
        &slope,
        &|_, _| 0.4425,
        simplex::LIPSCHITZ / simplex::SCALE
    ));
    // The slope bound of one Lipschitz term, checked on a fine grid of r.
    let slope_of_slope =
        |r: f64| 2f64.sqrt() * r * (0.5 - r * r).powi(2) * (4.0 - 56.0 * r * r).abs();
    assert!((0..=10_000).all(|i| slope_of_slope(f64::from(i) * 0.5f64.sqrt() / 1e4) <= 0.4425));
    // Both are nearly tight: the adversary reaches 0.9886 of the range.
    let x0 = [1.0 / 6.0, 1.0 / 6.0, 0.0];
    assert!(simplex::SCALE * simplex_vertex_sum(x0, 0.0, &adversary, &range_slope).0 > 0.988);
}

// ---------------------------------------------------------------------------------------------
// Cellular

/// F1 >= 0, F2 >= F1 (same feature points: same seed and jitter), Edge = (F2 - F1) / 2,
/// and Euclidean F1 is 1-Lipschitz at every distance, not only for close pairs.
#[test]
fn cellular_invariants() {
    for metric in [Metric::Euclidean, Metric::Manhattan, Metric::Chebyshev] {
        for jitter in [1.0, 0.6, 0.0] {
            let table = |value| NoiseTable::new(cellular(jitter, metric, value), 3);
            let (f1, f2, edge) = (
                table(CellularValue::F1),
                table(CellularValue::F2),
                table(CellularValue::Edge),
            );
            for p in points(50, 3000, 50.0) {
                let (a, b) = (f1.sample::<f64>(p), f2.sample::<f64>(p));
                assert!(a >= 0.0 && b >= a, "{metric:?} {jitter} {p:?}: {a} {b}");
                assert_eq!(edge.sample::<f64>(p), (b - a) * 0.5);
            }
        }
    }
    let f1 = NoiseTable::new(cellular(1.0, Metric::Euclidean, CellularValue::F1), 8);
    let pts = points(51, 4000, 20.0);
    for pair in pts.windows(2) {
        let (p, q) = (pair[0], pair[1]);
        let dist = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
        let dn = (f1.sample::<f64>(p) - f1.sample::<f64>(q)).abs();
        assert!(dn <= dist * (1.0 + 1e-12), "{p:?} {q:?}");
    }
}

/// Jitter 0 is the regular grid: F1 is exactly the distance to the nearest cell centre (the
/// centre of the point's own cell).
#[test]
fn cellular_jitter_zero_is_the_regular_grid() {
    let t = NoiseTable::new(cellular(0.0, Metric::Euclidean, CellularValue::F1), 6);
    for p in points(52, 5000, 1000.0) {
        let d = p.map(|c| 0.5 - (c - c.floor()));
        let want = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        assert_eq!(t.sample::<f64>(p), want, "{p:?}");
    }
}

/// CellValue is constant over a cell's region: the segment from a point to its nearest feature
/// point lies inside that point's (convex) Voronoi cell.
#[test]
fn cellular_cell_value_is_constant_inside_a_cell() {
    let basis = |value| cellular(0.9, Metric::Euclidean, value);
    let values = NoiseTable::new(basis(CellularValue::CellValue), 2);
    let points_table = NoiseTable::new(basis(CellularValue::F1), 2);
    for p in points(53, 500, 30.0) {
        let base = p.map(|c| c.floor() as i64);
        let mut nearest = (f64::INFINITY, [0.0; 3]);
        for o in 0..27i64 {
            let cell = [
                base[0] + o % 3 - 1,
                base[1] + (o / 3) % 3 - 1,
                base[2] + o / 9 - 1,
            ];
            let q = points_table.feature_point(cell).unwrap();
            let d = ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2)).sqrt();
            if d < nearest.0 {
                nearest = (d, q);
            }
        }
        let here = values.sample::<f64>(p);
        for s in 1..10 {
            let t = s as f64 / 10.0;
            let on: [f64; 3] = std::array::from_fn(|a| p[a] + t * (nearest.1[a] - p[a]));
            assert_eq!(
                values.sample::<f64>(on),
                here,
                "{p:?} towards {:?}",
                nearest.1
            );
        }
    }
}

/// Exact F2 against a 7³ brute force, and how often a 27-cell search (what many libraries do)
/// would have been enough: always, at these random points; the outer rings are searched only
/// when the bound cannot rule them out, so exactness costs nothing measurable.
#[test]
fn cellular_f2_is_exact() {
    let t = NoiseTable::new(cellular(1.0, Metric::Euclidean, CellularValue::F2), 1);
    let mut wrong_27 = 0;
    let pts = points(54, 20_000, 100.0);
    for &p in &pts {
        let base = p.map(|c| c.floor() as i64);
        let mut near: Vec<f64> = Vec::new();
        let mut near_27: Vec<f64> = Vec::new();
        for i in -3..=3i64 {
            for j in -3..=3i64 {
                for k in -3..=3i64 {
                    let q = t
                        .feature_point([base[0] + i, base[1] + j, base[2] + k])
                        .unwrap();
                    let d = ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2))
                        .sqrt();
                    near.push(d);
                    if i.abs() <= 1 && j.abs() <= 1 && k.abs() <= 1 {
                        near_27.push(d);
                    }
                }
            }
        }
        near.sort_by(f64::total_cmp);
        near_27.sort_by(f64::total_cmp);
        let got = t.sample::<f64>(p);
        assert!((got - near[1]).abs() < 1e-12, "{p:?}: {got} vs {}", near[1]);
        wrong_27 += usize::from(near_27[1] != near[1]);
    }
    assert!(wrong_27 < pts.len() / 1000, "{wrong_27} of {}", pts.len());
}

// ---------------------------------------------------------------------------------------------
// Tiling

/// Every basis with a spread of periods (Simplex with odd and even ones too: its lattice tiles
/// at every integer period).
fn tiling_cases() -> Vec<(Basis, Period)> {
    let mut cases = Vec::new();
    for basis in every_basis() {
        for period in [
            [1, 1, 1],
            [3, 3, 3],
            [2, 5, 7],
            [256, 3, 300],
            [1000, 1, 17],
        ] {
            cases.push((basis, period));
        }
    }
    for period in [[4, 4, 4], [6, 9, 3], [768, 3, 300], [999, 1026, 24]] {
        cases.push((Basis::Simplex, period));
    }
    cases
}

/// `N(p + k P) = N(p)` bit for bit wherever `p + k P` is exact, in f32 and f64, and inside the
/// first period (below its last cell) the tiled noise is the plain noise.
#[test]
fn tiled_noise_repeats_bit_for_bit() {
    let mut rng = SplitMix64::new(60);
    for (basis, period) in tiling_cases() {
        let t = NoiseTable::periodic(basis, 3, Some(period));
        let plain = NoiseTable::new(basis, 3);
        for p in points(61, 400, 40.0) {
            let k: [f64; 3] = std::array::from_fn(|_| (rng.next_signed() * 1000.0).round());
            let q: [f64; 3] = std::array::from_fn(|a| p[a] + k[a] * period[a] as f64);
            if (0..3).any(|a| q[a] - k[a] * period[a] as f64 != p[a]) {
                continue;
            }
            assert_eq!(
                t.sample::<f64>(p).to_bits(),
                t.sample::<f64>(q).to_bits(),
                "{basis:?} {period:?} {p:?} {q:?}"
            );
            assert_eq!(t.sample::<f32>(p).to_bits(), t.sample::<f32>(q).to_bits());
            let inside: [f64; 3] = std::array::from_fn(|a| {
                p[a].rem_euclid(period[a] as f64)
                    .min(period[a] as f64 - 1.0)
                    * 0.999
            });
            // (Cellular and Simplex reach features outside the box from inside it.)
            if !matches!(basis, Basis::Cellular(_) | Basis::Simplex) {
                assert_eq!(
                    t.sample::<f64>(inside),
                    plain.sample::<f64>(inside),
                    "{basis:?} {inside:?}"
                );
            }
        }
    }
}

/// Continuous across the seam: just below and just above a multiple of the period differ by at
/// most the Lipschitz bound times the step (plus f32 rounding).
#[test]
fn tiled_noise_is_continuous_across_the_seam() {
    let mut rng = SplitMix64::new(62);
    for (basis, period) in tiling_cases() {
        if matches!(basis, Basis::White)
            || matches!(basis, Basis::Cellular(c) if c.value == CellularValue::CellValue)
        {
            continue;
        }
        let t = NoiseTable::periodic(basis, 5, Some(period));
        let l = t.lipschitz();
        for _ in 0..300 {
            let axis = (rng.next_u64() % 3) as usize;
            let k = (rng.next_signed() * 20.0).round() * period[axis] as f64;
            let mut a = [0; 3].map(|_: i32| rng.next_signed() * 50.0);
            let mut b = a;
            a[axis] = k - 1e-9;
            b[axis] = k + 1e-9;
            let d = (t.sample::<f64>(a) - t.sample::<f64>(b)).abs();
            let dist = b[axis] - a[axis];
            assert!(
                d <= l * dist + 1e-11,
                "{basis:?} {period:?} {a:?}: jump {d:e}"
            );
        }
    }
}

/// Tiled batches (SIMD on the reduced points, the seam lanes again per point) give the point
/// function's bits, also for fractal sums, whose octave i tiles at period × frequency.
#[test]
fn tiled_batch_equals_point_bit_for_bit() {
    check_tiled_batches();
    with_table_reads(check_tiled_batches);
}

fn check_tiled_batches() {
    let mut pts = batch_pool(63, 600, 10);
    // Many lanes in a period's last cell.
    pts.extend(
        points(64, 300, 6.0)
            .into_iter()
            .map(|p| p.map(|c| c.floor() + 0.999)),
    );
    let [x, y, z] = planes(&pts);
    let schedule = Octaves::new(3.5, 2.0, 0.5, 1).with_period(Some([3, 2, 5]));
    // Simplex's lane kernel also takes period 1, an untiled axis (0) and 2^20.
    let simplex_edges = [[1, 0, 5], [1, 1, 1], [1 << 20, 3, 1 << 20]].map(|p| (Basis::Simplex, p));
    for (basis, period) in tiling_cases().into_iter().chain(simplex_edges) {
        let t = NoiseTable::periodic(basis, 7, Some(period));
        let what = format!("{basis:?} {period:?}");
        assert_sample_batch_is_point::<f32>(&t, &pts, &what);
        assert_sample_batch_is_point::<f64>(&t, &pts, &what);
        let mut o64 = vec![0.0f64; pts.len()];
        if basis.is_fractal() {
            let plain = NoiseTable::new(basis, 7);
            for style in [
                Style::Fbm,
                Style::Ridged {
                    offset: 1.0,
                    sharpness: 2.0,
                },
            ] {
                fractal_styled_batch(&plain, &schedule, style, &x, &y, &z, &mut o64);
                let want: Vec<f64> = pts
                    .iter()
                    .map(|&p| fractal_styled(&plain, &schedule, style, p))
                    .collect();
                assert_eq!(bits_of(&o64), bits_of(&want), "{basis:?} {style:?}");
            }
        }
    }
}

/// Batches whose points all lie inside the first period box (baking one tile: the kernels skip
/// the reduction there and find the last-cell lanes from the cell bytes, or need none at
/// periods that are multiples of 256), many of them in the last cell and just below its far
/// edge: the point function's bits, noise and fractal sums (octave i inside its own period),
/// with and without the byte-shuffle hashing.
#[test]
fn tiled_batches_inside_one_period_equal_point() {
    let check = || {
        let mut rng = SplitMix64::new(65);
        for basis in BASES.into_iter().chain([Basis::White]) {
            for period in [[3, 1, 5], [255, 256, 512], [300, 7, 1024], [8, 384, 8]] {
                let t = NoiseTable::periodic(basis, 8, Some(period));
                let pts: Vec<[f64; 3]> = (0..700)
                    .map(|i| {
                        std::array::from_fn(|a| {
                            let p = period[a] as f64;
                            match i % 4 {
                                0 => rng.next_f64() * p,
                                1 => p - 1.0 + rng.next_f64(),
                                2 => p - p * f64::EPSILON,
                                _ => (rng.next_f64() * p).floor(),
                            }
                        })
                    })
                    .collect();
                let what = format!("{basis:?} {period:?}");
                assert_sample_batch_is_point::<f32>(&t, &pts, &what);
                assert_sample_batch_is_point::<f64>(&t, &pts, &what);
                if basis.is_fractal() {
                    let schedule = Octaves::new(4.0, 2.0, 0.5, 1).with_period(Some(period));
                    check_batches::<f32>(&t, &schedule, &pts, &what);
                }
            }
        }
    };
    check();
    with_table_reads(check);
}

/// Tiled batches whose chunks are inside one period except for one wild lane (NaN, ±inf, 2^60,
/// -0.5, exactly P) on one axis, at several positions in the chunk: the per-chunk bounds that
/// pick the identity reduction and the fast lattice step must see that lane (a NaN on one axis
/// must not hide a huge value on another), and every lane must still equal the point function.
#[test]
fn tiled_batches_with_one_wild_lane_equal_point() {
    // Not powers of two: the fast reduction of a huge coordinate would be wrong.
    let period = [3, 5, 7];
    let mut rng = SplitMix64::new(66);
    for basis in BASES {
        let t = NoiseTable::periodic(basis, 8, Some(period));
        let schedule = Octaves::new(4.0, 2.0, 0.5, 1).with_period(Some(period));
        for wild in [
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
            2f64.powi(60) + 4096.0,
            -0.5,
            5.0,
        ] {
            for (axis, at) in [(0, 0), (1, 100), (2, 255), (0, 256), (1, 299)] {
                let mut pts: Vec<[f64; 3]> = (0..300)
                    .map(|_| std::array::from_fn(|a| rng.next_f64() * period[a] as f64))
                    .collect();
                pts[at][axis] = wild;
                if wild.is_nan() {
                    // And a huge value on the axis before it in another lane of the same chunk
                    // (a NaN taken for "no bound" would hide it from the axes after).
                    pts[at ^ 1][(axis + 2) % 3] = 2f64.powi(55) + 24.0;
                }
                let what = format!("{basis:?} wild {wild} on axis {axis} at lane {at}");
                assert_sample_batch_is_point::<f32>(&t, &pts, &what);
                assert_sample_batch_is_point::<f64>(&t, &pts, &what);
                check_batches::<f32>(&t, &schedule, &pts, &what);
                check_batches::<f64>(&t, &schedule, &pts, &what);
            }
        }
    }
}

/// Every metric with every value of cellular noise.
fn cellular_kinds() -> impl Iterator<Item = (Metric, CellularValue)> {
    let values = [
        CellularValue::F1,
        CellularValue::F2,
        CellularValue::F2MinusF1,
        CellularValue::CellValue,
        CellularValue::Edge,
    ];
    [Metric::Euclidean, Metric::Manhattan, Metric::Chebyshev]
        .into_iter()
        .flat_map(move |metric| values.map(|value| (metric, value)))
}

/// The cellular SIMD kernel against the point function for batch lengths around its chunk and
/// the per-point threshold, on tame, edge and wild (huge, non-finite) points, for every metric
/// and value.
#[test]
fn cellular_batch_equals_point_for_every_length() {
    let pools = [
        batch_pool(70, 200, 8),
        batch_pool(71, 200, 10),
        batch_pool(72, 200, 12),
    ];
    for (metric, value) in cellular_kinds() {
        let t = NoiseTable::new(cellular(0.85, metric, value), 13);
        for len in [1, 7, 8, 9, 63, 64, 65, 130, 200] {
            for pool in &pools {
                let pts = &pool[..len];
                let what = format!("{metric:?} {value:?} {len}");
                assert_sample_batch_is_point::<f32>(&t, pts, &what);
                assert_sample_batch_is_point::<f64>(&t, pts, &what);
            }
        }
    }
}

/// The cellular lane kernel's coherent groups (lanes whose cells lie close together, as in a
/// bake) against the point function: rows and blocks of voxel-like points along each axis at
/// several spacings (one cell per group up to more cells than a group may span), starting on
/// and beside cell borders, near zero, negative, far out and near 2^53 (where neighbouring
/// integers are 2 apart), with jitter 0 (a regular grid: exact ties between cells, which the
/// scan order must break as the point function does), 0.5 and 1, for every metric and value;
/// both the coherent and the gathered search must be reached.
#[test]
fn cellular_coherent_groups_equal_point() {
    let origins = [
        [0.0, 0.0, 0.0],
        [0.03125, 0.5, 0.5],
        [-3.0, 5.5, -0.25],
        [-0.5, -1e-9, 17.0],
        [1e6 + 0.5, -1e6, 3.75],
        [255.5, -256.0, 511.9375],
        [2f64.powi(53) - 8.0, 2f64.powi(53), -2f64.powi(53)],
    ];
    let before = super::batch::COHERENT_GROUPS.with(std::cell::Cell::get);
    let mut pts = Vec::new();
    for &origin in &origins {
        for step in [1.0 / 16.0, 0.125, 0.25, 1.0 / 3.0, 0.5, 1.0] {
            for axis in 0..3 {
                // A row of 64 along the axis, then a 4 × 4 × 4 block.
                for i in 0..64 {
                    let mut p = origin;
                    p[axis] += i as f64 * step;
                    pts.push(p);
                }
                for i in 0..64 {
                    let mut p = origin;
                    p[axis] += (i % 4) as f64 * step;
                    p[(axis + 1) % 3] += (i / 4 % 4) as f64 * step;
                    p[(axis + 2) % 3] += (i / 16) as f64 * step;
                    pts.push(p);
                }
            }
        }
    }
    for jitter in [0.0, 0.5, 1.0] {
        for (metric, value) in cellular_kinds() {
            let t = NoiseTable::new(cellular(jitter, metric, value), 29);
            let what = format!("jitter {jitter} {metric:?} {value:?}");
            assert_sample_batch_is_point::<f32>(&t, &pts, &what);
            assert_sample_batch_is_point::<f64>(&t, &pts, &what);
            // Odd starts and lengths: groups cut at other lanes, tails shorter than a group.
            assert_sample_batch_is_point::<f32>(&t, &pts[5..100], &what);
            assert_sample_batch_is_point::<f64>(&t, &pts[37..90], &what);
        }
    }
    let coherent = super::batch::COHERENT_GROUPS.with(std::cell::Cell::get) - before;
    // 45 tables × 2 precisions × (1008 + 7) groups of 16 ≈ 91 000 groups; all but the widest
    // spacings' are coherent (about 68 000).
    assert!(coherent > 40_000, "only {coherent} coherent groups");
}

/// The simplex lane kernel against the point function for every batch length up to 140
/// (below and above the per-point threshold and the 64-lane chunk), on tame, edge and wild
/// points, in both precisions.
#[test]
fn simplex_batch_equals_point_for_every_length() {
    let pools = [
        batch_pool(73, 200, 8),
        batch_pool(74, 200, 10),
        batch_pool(75, 200, 12),
    ];
    let t = NoiseTable::new(Basis::Simplex, 17);
    for len in 1..=140 {
        for pool in &pools {
            let pts = &pool[len % 50..len % 50 + len];
            assert_sample_batch_is_point::<f32>(&t, pts, &format!("{len}"));
            assert_sample_batch_is_point::<f64>(&t, pts, &format!("{len}"));
            assert_simplex_table_reads_are_point::<f32>(&t, pts);
            assert_simplex_table_reads_are_point::<f64>(&t, pts);
        }
    }
}

/// Coordinates just below a whole number whose fraction `x - floor(x)` rounds to 1.0 (so the
/// point sits on the next cell's corner): on two or three axes at once a skewed fraction sum
/// reaches 2.0 and simplex carries 2. Every basis' batch kernel, untiled and tiled (the lane
/// kernels run for 64 lanes; the chunk mixes these points with ordinary ones), equals its
/// point function. The random-graph test found simplex carrying 1 there (a wrong tetrahedron,
/// 0 for a value of 4.75e-9).
#[test]
fn fractions_that_round_to_one_batch_as_the_point() {
    let tiny = [-1e-17, -5e-324, -1e-300, -2f64.powi(-54)];
    let mut rng = SplitMix64::new(91);
    let pts: Vec<[f64; 3]> = (0..64)
        .map(|i| {
            let mut p = [0.0; 3];
            for (a, c) in p.iter_mut().enumerate() {
                let whole = (rng.next_u64() % 7) as f64 - 3.0;
                // Axes picked by the lane number: every pair and the triple.
                *c = if (i >> a) & 1 == 1 || i % 8 == 7 {
                    whole + tiny[(rng.next_u64() % 4) as usize]
                } else {
                    whole + rng.next_signed().abs()
                };
            }
            p
        })
        .collect();
    let mut bases = continuous_bases();
    bases.push(Basis::White);
    for basis in bases {
        let t = NoiseTable::new(basis, 5);
        assert_sample_batch_is_point::<f32>(&t, &pts, &format!("{basis:?}"));
        assert_sample_batch_is_point::<f64>(&t, &pts, &format!("{basis:?}"));
        for period in [[4, 4, 4], [3, 0, 5]] {
            let [x, y, z] = planes(&pts);
            let mut out = vec![0f64; pts.len()];
            t.sample_batch_at_period(period, &x, &y, &z, &mut out);
            let want: Vec<f64> = pts.iter().map(|&p| t.sample_at_period(p, period)).collect();
            for i in 0..pts.len() {
                assert_eq!(
                    out[i].to_bits(),
                    want[i].to_bits(),
                    "{basis:?} tiled {period:?} at {:?}: {} against {}",
                    pts[i],
                    out[i],
                    want[i]
                );
            }
        }
    }
    let t = NoiseTable::new(Basis::Simplex, 5);
    assert_simplex_table_reads_are_point::<f32>(&t, &pts);
}

/// The simplex lane kernel with its table-read gradients (the form CPUs without AVX-512 VBMI
/// run; `sample_batch` here may take the byte shuffles) against the point function.
fn assert_simplex_table_reads_are_point<S: Real>(t: &NoiseTable, pts: &[[f64; 3]]) {
    with_table_reads(|| assert_sample_batch_is_point::<S>(t, pts, "table reads"));
}

/// Runs `f` with the batch kernels' table-read forms forced on this thread.
pub(super) fn with_table_reads(f: impl FnOnce()) {
    batch::TABLE_READS.with(|c| c.set(true));
    f();
    batch::TABLE_READS.with(|c| c.set(false));
}

/// White noise and cell values stay in [0, 1) in both precisions, and the f32 value is the
/// f64 value with its low bits dropped (24 of the hash's bits against 53).
#[test]
fn cell_values_stay_below_one() {
    let mut rng = SplitMix64::new(41);
    let cellular = Basis::Cellular(Cellular::new(
        1.0,
        Metric::Euclidean,
        CellularValue::CellValue,
    ));
    for seed in 0..200 {
        for basis in [Basis::White, cellular] {
            let t = NoiseTable::new(basis, seed);
            for _ in 0..50 {
                let p = [0; 3].map(|_: u8| rng.next_signed() * 1e6);
                let (v64, v32) = (t.sample::<f64>(p), t.sample::<f32>(p));
                assert!(
                    (0.0..1.0).contains(&v64) && (0.0..1.0).contains(&v32),
                    "{v64} {v32}"
                );
                assert_eq!(
                    v32 as f64,
                    (v64 * 16_777_216.0).floor() / 16_777_216.0,
                    "{p:?}"
                );
            }
        }
    }
}

/// The per-cell bases have no period of their own (issue 32): the hash of the exact integer
/// cell, not a 256-entry table, so a shift by 256 cells, or any power of two up to 2^20, along
/// any axis lands on another value (white noise, cell values, every cellular distance).
#[test]
fn per_cell_bases_repeat_at_no_power_of_two() {
    let mut rng = SplitMix64::new(42);
    let mut bases = vec![Basis::White];
    for value in [
        CellularValue::F1,
        CellularValue::F2,
        CellularValue::F2MinusF1,
        CellularValue::CellValue,
        CellularValue::Edge,
    ] {
        bases.push(Basis::Cellular(Cellular::new(
            1.0,
            Metric::Euclidean,
            value,
        )));
    }
    for basis in bases {
        let t = NoiseTable::new(basis, 7);
        for k in 8..=20 {
            let shift = f64::from(1u32 << k);
            for axis in 0..3 {
                let mut same = 0;
                for _ in 0..100 {
                    let p = [0; 3].map(|_: u8| rng.next_signed() * 1000.0);
                    let mut q = p;
                    q[axis] += shift;
                    if t.sample::<f32>(p) == t.sample::<f32>(q) {
                        same += 1;
                    }
                }
                assert!(
                    same <= 1,
                    "{basis:?} repeats at 2^{k} along axis {axis}: {same} of 100"
                );
            }
        }
    }
}

/// 60 random cells in [-1000, 1000]³ get 60 different values (the old 256-entry table gave 49),
/// over many trials: the collisions a 24-bit value gives (about 1e-4 per trial in f32) and none
/// in f64's 53 bits. (White noise, and cellular cell values read at the cells' feature points.)
#[test]
fn sixty_cells_get_sixty_values() {
    let mut rng = SplitMix64::new(43);
    let cellular = Basis::Cellular(Cellular::new(
        0.9,
        Metric::Euclidean,
        CellularValue::CellValue,
    ));
    for basis in [Basis::White, cellular] {
        let (mut collisions32, mut collisions64) = (0, 0);
        for trial in 0..2000 {
            let t = NoiseTable::new(basis, trial);
            let cells: Vec<[i64; 3]> = (0..60)
                .map(|_| [0; 3].map(|_: u8| (rng.next_signed() * 1000.0).floor() as i64))
                .collect();
            let mut v32: Vec<u32> = Vec::new();
            let mut v64: Vec<u64> = Vec::new();
            for c in &cells {
                // At the cell's feature point (cellular) or its centre (white): the cell's own value.
                let p = t.feature_point(*c).unwrap_or(c.map(|v| v as f64 + 0.5));
                v32.push(t.sample::<f32>(p).to_bits());
                v64.push(t.sample::<f64>(p).to_bits());
                assert_eq!(
                    t.sample::<f64>(p),
                    t.cell_value(*c).unwrap(),
                    "{basis:?} {c:?}"
                );
            }
            let distinct = |mut v: Vec<u64>| {
                v.sort_unstable();
                v.dedup();
                v.len()
            };
            let mut unique_cells = cells.clone();
            unique_cells.sort_unstable();
            unique_cells.dedup();
            let n = unique_cells.len();
            collisions32 += n - distinct(v32.iter().map(|&v| u64::from(v)).collect());
            collisions64 += n - distinct(v64);
        }
        assert!(
            collisions32 <= 4,
            "{basis:?}: {collisions32} collisions in f32"
        );
        assert_eq!(collisions64, 0, "{basis:?}: collisions in f64");
    }
}
