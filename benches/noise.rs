//! Noise kernel benchmarks (criterion), named `noise/<case>/<mode>`.
//!
//! 16 384 points uniform in [0, 8)³ (a fixed SplitMix64 stream), evaluated the way the tape
//! interpreter does: in chunks of `texgraph::LANES` lanes.
//!
//! - `noise/<basis>_<precision>/batch`: `NoiseTable::sample_batch`, one octave of each basis
//!   (`perlin`, `gradient`, `value_linear`, `value_smooth`), f32 and f64.
//! - `noise/<basis>_<precision>/point`: `NoiseTable::sample` in a loop, the per-point reference.
//! - `noise/fbm8_<basis>_<precision>/batch`: `noise::fractal_batch`, 8 octaves, lacunarity 2,
//!   gain 0.5 (the seed 003 marble's fbm is `fbm8_perlin_f32`).
//! - `noise/fbm8_perlin_<precision>/point`: `noise::fractal` in a loop.
//!
//! Throughput is in points, so criterion's "elem/s" inverts to ns per point.
//! Run: `cargo bench --bench noise` (add e.g. `-- noise/fbm8` to pick cases).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::time::Duration;
use texgraph::noise::{fractal, fractal_batch, Basis, Interpolation, NoiseTable, Octaves};
use texgraph::{Real, LANES};

const N: usize = 16_384;

/// N points uniform in [0, 8)³ from SplitMix64 (fixed seed), as x, y, z planes.
fn points() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut state = 0x5EED_0003_u64;
    let mut next = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        8.0 * ((z >> 11) as f64 * (1.0 / (1u64 << 53) as f64))
    };
    let (mut x, mut y, mut z) = (vec![0.0; N], vec![0.0; N], vec![0.0; N]);
    for i in 0..N {
        x[i] = next();
        y[i] = next();
        z[i] = next();
    }
    (x, y, z)
}

const BASES: [(&str, Basis); 4] = [
    ("perlin", Basis::Perlin),
    ("gradient", Basis::Gradient),
    ("value_linear", Basis::Value(Interpolation::Linear)),
    ("value_smooth", Basis::Value(Interpolation::Smooth)),
];

fn bench_basis<S: Real>(c: &mut Criterion, pts: &(Vec<f64>, Vec<f64>, Vec<f64>)) {
    let (x, y, z) = pts;
    let octaves = Octaves::new(8.0, 2.0, 0.5, 0);
    let mut group = c.benchmark_group("noise");
    group.throughput(Throughput::Elements(N as u64));
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500));
    for (name, basis) in BASES {
        let table = NoiseTable::new(basis, 3);
        let mut out = vec![S::ZERO; N];
        group.bench_function(format!("{name}_{}/batch", S::NAME), |b| {
            b.iter(|| {
                for (k, o) in out.chunks_mut(LANES).enumerate() {
                    let r = k * LANES..k * LANES + o.len();
                    table.sample_batch(&x[r.clone()], &y[r.clone()], &z[r], o);
                }
                black_box(&out);
            })
        });
        group.bench_function(format!("{name}_{}/point", S::NAME), |b| {
            b.iter(|| {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = table.sample(black_box([x[i], y[i], z[i]]));
                }
                black_box(&out);
            })
        });
        group.bench_function(format!("fbm8_{name}_{}/batch", S::NAME), |b| {
            b.iter(|| {
                for (k, o) in out.chunks_mut(LANES).enumerate() {
                    let r = k * LANES..k * LANES + o.len();
                    fractal_batch(
                        &table,
                        &octaves,
                        false,
                        &x[r.clone()],
                        &y[r.clone()],
                        &z[r],
                        o,
                    );
                }
                black_box(&out);
            })
        });
        if basis == Basis::Perlin {
            group.bench_function(format!("fbm8_{name}_{}/point", S::NAME), |b| {
                b.iter(|| {
                    for (i, o) in out.iter_mut().enumerate() {
                        *o = fractal(&table, &octaves, false, black_box([x[i], y[i], z[i]]));
                    }
                    black_box(&out);
                })
            });
        }
    }
    group.finish();
}

fn noise_benches(c: &mut Criterion) {
    let pts = points();
    bench_basis::<f32>(c, &pts);
    bench_basis::<f64>(c, &pts);
}

criterion_group!(benches, noise_benches);
criterion_main!(benches);
