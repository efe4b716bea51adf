//! Evaluation and compile benchmarks (criterion), named `stage/case`.
//!
//! `eval/marble/*`: the seed 003 marble vein |sin(π(1.3·x + 3·fbm8(p)))| with 8 Perlin octaves,
//! on the 16 384 points of one z slice of the 128³ grid over [0, 8)³ (a fixed subset, so one
//! iteration stays short), evaluated by texgraph per point and per batch (f32 and f64) and by a
//! hand-written scalar Rust function of the same formula, so every ratio comes from one run.
//! `eval/cellular`, `eval/cellular_fbm4`, `eval/simplex`, `eval/warp`, `eval/period`: the noise
//! families against their peers (fastnoise-lite, noise-rs, simdnoise) on the same slab as
//! `eval/fbm8`.
//! `eval/gradient`: `Gradient` of the 8-octave Perlin fbm against the fbm alone and against
//! central differences written as a graph, on the same slab.
//! `eval/seed003_marble/far`: the same marble on the same slab moved to x = 1e6, compiled for
//! that extent (its coordinate chain in f64), beside `far_plain_f32` (the plain tape there) and
//! `texgraph_batch_f32_extent` (compiled for the slab's own extent: the plain tape).
//! `eval/simplex/texgraph_batch_f32_tiled`: the same simplex tiled at periods (5, 7, 11).
//! `eval/seed004_wood_grain/{near,far_plain_f32,far,far_f64}`: the wood grain on the slab and
//! at x = 1e6, where the precision plan promotes its noise to f64 (issue 32).
//! `eval/filtered/seed003_marble/{point_batch_f32,filtered_1_128,filtered_1_8}`: the marble's
//! `vein` on the slab, the plain batch beside the filtered form (`filter::Filtered::eval_batch`)
//! with a voxel of side 1/128 (the slab's spacing 1/16 / 8) and 1/8 (issue 33).
//! `compile/N`: parse + check + compile of a generated graph of N nodes (inline nodes included).
//!
//! `eval/seed003_marble/texgraph_batch_lod_f32_{fine,receding}`: `Tape::eval_batch_lod` with
//! every point finer than the finest octave, and with spacings receding along each row.
//! Run: `cargo bench --bench eval` (add `-- eval/` or `-- compile/` to pick a group).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use std::time::Duration;
use texgraph::{check, compile, CheckOptions, CompileOptions, SourceFile, Tape, Workspace};

/// The benchmark points: slice k = 5 of the 128³ voxel centres over [0, 8)³.
fn points() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut x, mut y, mut z) = (Vec::new(), Vec::new(), Vec::new());
    let step = 8.0 / 128.0;
    for k in [5usize] {
        for j in 0..128 {
            for i in 0..128 {
                x.push((i as f64 + 0.5) * step);
                y.push((j as f64 + 0.5) * step);
                z.push((k as f64 + 0.5) * step);
            }
        }
    }
    (x, y, z)
}

fn marble_tape() -> Tape {
    marble_tape_for(None)
}

/// The seed 003 marble compiled for `extent` (precision chosen per instruction).
fn marble_tape_for(extent: Option<texgraph::Extent>) -> Tape {
    let text =
        std::fs::read_to_string("graphs/seed003_marble.ron").expect("run from the crate root");
    let options = CheckOptions {
        overrides: vec![
            ("octaves".into(), 8.0),
            ("period".into(), 1.3),
            ("distortion".into(), 3.0),
            ("scale".into(), 1.0),
        ],
    };
    let graph = check(SourceFile::new("seed003_marble.ron", text), &options).expect("valid graph");
    compile(
        &graph,
        &CompileOptions {
            outputs: vec!["vein".into()],
            extent,
            ..Default::default()
        },
    )
    .expect("compiles")
}

/// Hand-written scalar marble, the way one writes it without texgraph: f32 throughout, Ken
/// Perlin's improved noise with the reference permutation, an 8-octave loop.
mod handwritten {
    const P: [u8; 256] = [
        151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30,
        69, 142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94,
        252, 219, 203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171,
        168, 68, 175, 74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60,
        211, 133, 230, 220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1,
        216, 80, 73, 209, 76, 132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86,
        164, 100, 109, 198, 173, 186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118,
        126, 255, 82, 85, 212, 207, 206, 59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170,
        213, 119, 248, 152, 2, 44, 154, 163, 70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39,
        253, 19, 98, 108, 110, 79, 113, 224, 232, 178, 185, 112, 104, 218, 246, 97, 228, 251, 34,
        242, 193, 238, 210, 144, 12, 191, 179, 162, 241, 81, 51, 145, 235, 249, 14, 239, 107, 49,
        192, 214, 31, 181, 199, 106, 157, 184, 84, 204, 176, 115, 121, 50, 45, 127, 4, 150, 254,
        138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195, 78, 66, 215, 61, 156, 180,
    ];

    #[inline(always)]
    fn perm(i: usize) -> usize {
        P[i & 255] as usize
    }
    #[inline(always)]
    fn fade(t: f32) -> f32 {
        t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
    }
    #[inline(always)]
    fn lerp(t: f32, a: f32, b: f32) -> f32 {
        a + t * (b - a)
    }
    /// Perlin's 12 edge gradients (+4 repeats) as a table: a dot product instead of the
    /// reference's data-dependent branches, which mispredict on every lattice corner.
    const GRADIENTS: [[f32; 3]; 16] = [
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
        [1.0, -1.0, 0.0],
        [-1.0, -1.0, 0.0],
        [1.0, 0.0, 1.0],
        [-1.0, 0.0, 1.0],
        [1.0, 0.0, -1.0],
        [-1.0, 0.0, -1.0],
        [0.0, 1.0, 1.0],
        [0.0, -1.0, 1.0],
        [0.0, 1.0, -1.0],
        [0.0, -1.0, -1.0],
        [1.0, 1.0, 0.0],
        [0.0, -1.0, 1.0],
        [-1.0, 1.0, 0.0],
        [0.0, -1.0, -1.0],
    ];

    #[inline(always)]
    fn grad(hash: usize, x: f32, y: f32, z: f32) -> f32 {
        let g = GRADIENTS[hash & 15];
        g[0] * x + g[1] * y + g[2] * z
    }

    /// The usual fast floor (truncate, then step down for negatives): `f32::floor` is a libm
    /// call on baseline x86-64, and anyone tuning this function by hand replaces it.
    #[inline(always)]
    fn fast_floor(x: f32) -> i32 {
        let t = x as i32;
        if x < t as f32 {
            t - 1
        } else {
            t
        }
    }

    pub fn noise(x: f32, y: f32, z: f32) -> f32 {
        let (ix, iy, iz) = (fast_floor(x), fast_floor(y), fast_floor(z));
        let (fx, fy, fz) = (ix as f32, iy as f32, iz as f32);
        let (xi, yi, zi) = (
            (ix & 255) as usize,
            (iy & 255) as usize,
            (iz & 255) as usize,
        );
        let (x, y, z) = (x - fx, y - fy, z - fz);
        let (u, v, w) = (fade(x), fade(y), fade(z));
        let a = perm(xi) + yi;
        let aa = perm(a) + zi;
        let ab = perm(a + 1) + zi;
        let b = perm(xi + 1) + yi;
        let ba = perm(b) + zi;
        let bb = perm(b + 1) + zi;
        lerp(
            w,
            lerp(
                v,
                lerp(u, grad(perm(aa), x, y, z), grad(perm(ba), x - 1.0, y, z)),
                lerp(
                    u,
                    grad(perm(ab), x, y - 1.0, z),
                    grad(perm(bb), x - 1.0, y - 1.0, z),
                ),
            ),
            lerp(
                v,
                lerp(
                    u,
                    grad(perm(aa + 1), x, y, z - 1.0),
                    grad(perm(ba + 1), x - 1.0, y, z - 1.0),
                ),
                lerp(
                    u,
                    grad(perm(ab + 1), x, y - 1.0, z - 1.0),
                    grad(perm(bb + 1), x - 1.0, y - 1.0, z - 1.0),
                ),
            ),
        )
    }

    pub fn fbm8(x: f32, y: f32, z: f32) -> f32 {
        let mut fbm = 0.0;
        let mut frequency = 1.0;
        let mut amplitude = 1.0;
        for _ in 0..8 {
            fbm += amplitude * noise(x * frequency, y * frequency, z * frequency);
            frequency *= 2.0;
            amplitude *= 0.5;
        }
        fbm
    }

    // 3.14159265 is the constant the graph file writes; the same number keeps the formulas equal.
    #[allow(clippy::approx_constant, clippy::excessive_precision)]
    pub fn vein(x: f32, y: f32, z: f32) -> f32 {
        (3.14159265 * (1.3 * x + 3.0 * fbm8(x, y, z))).sin().abs()
    }
}

fn compile_text(text: &str, outputs: &[&str]) -> Tape {
    let graph = check(
        SourceFile::new("bench.ron", text.to_string()),
        &CheckOptions::default(),
    )
    .expect("valid graph");
    compile(
        &graph,
        &CompileOptions {
            outputs: outputs.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        },
    )
    .expect("compiles")
}

/// The issue's peer workload: 8-octave Perlin fBm (lacunarity 2, gain 0.5) over 128 × 128 × 4
/// voxel centres of the 128³ grid over [0, 8)³; and the marble abs(sin(6x + 4·fbm8)).
const FBM8: &str = r#"Graph(outputs: { "f": Fbm(input: Position, basis: Perlin, octaves: 8.0) })"#;
const MARBLE: &str = r#"Graph(nodes: { "p": Position }, outputs: { "m": Abs(Sin(Add(Mul(6.0, "p.x"), Mul(4.0, Fbm(input: "p", basis: Perlin, octaves: 8.0))))) })"#;

fn slab() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut x, mut y, mut z) = (Vec::new(), Vec::new(), Vec::new());
    let step = 8.0 / 128.0;
    for k in 0..4 {
        for j in 0..128 {
            for i in 0..128 {
                x.push((i as f64 + 0.5) * step);
                y.push((j as f64 + 0.5) * step);
                z.push((k as f64 + 0.5) * step);
            }
        }
    }
    (x, y, z)
}

/// Benches one workload: texgraph (batch, point) and every peer, in one group.
fn peer_group(c: &mut Criterion, name: &str, source: &str, finish: fn(f32, f32) -> f32) {
    let tape = compile_text(source, &[]);
    let (x, y, z) = slab();
    let n = x.len();
    let (xf, yf, zf): (Vec<f32>, Vec<f32>, Vec<f32>) = (
        x.iter().map(|v| *v as f32).collect(),
        y.iter().map(|v| *v as f32).collect(),
        z.iter().map(|v| *v as f32).collect(),
    );
    let mut group = c.benchmark_group(format!("eval/{name}"));
    group.throughput(Throughput::Elements(n as u64));
    group
        .sample_size(15)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    texgraph_pair(&mut group, &tape);
    group.bench_function("handwritten_f32", |b| {
        let mut out = vec![0f32; n];
        b.iter(|| {
            for i in 0..n {
                out[i] = finish(xf[i], handwritten::fbm8(xf[i], yf[i], zf[i]));
            }
            black_box(&out);
        })
    });
    group.bench_function("noise_rs", |b| {
        use noise::{MultiFractal, NoiseFn};
        let fbm = noise::Fbm::<noise::Perlin>::new(0)
            .set_octaves(8)
            .set_frequency(1.0)
            .set_lacunarity(2.0)
            .set_persistence(0.5);
        let mut out = vec![0f32; n];
        b.iter(|| {
            for i in 0..n {
                out[i] = finish(xf[i], fbm.get([x[i], y[i], z[i]]) as f32);
            }
            black_box(&out);
        })
    });
    group.bench_function("fastnoise_lite", |b| {
        let mut noise = fastnoise_lite::FastNoiseLite::new();
        noise.set_noise_type(Some(fastnoise_lite::NoiseType::Perlin));
        noise.set_fractal_type(Some(fastnoise_lite::FractalType::FBm));
        noise.set_fractal_octaves(Some(8));
        noise.set_fractal_lacunarity(Some(2.0));
        noise.set_fractal_gain(Some(0.5));
        noise.set_frequency(Some(1.0));
        let mut out = vec![0f32; n];
        b.iter(|| {
            for i in 0..n {
                out[i] = finish(xf[i], noise.get_noise_3d(xf[i], yf[i], zf[i]));
            }
            black_box(&out);
        })
    });
    group.bench_function("simdnoise_simplex", |b| {
        // simdnoise generates a whole grid (runtime SIMD dispatch); simplex, not Perlin.
        let mut out = vec![0f32; n];
        b.iter(|| {
            let (grid, _, _) = simdnoise::NoiseBuilder::fbm_3d(128, 128, 4)
                .with_freq(8.0 / 128.0)
                .with_octaves(8)
                .with_gain(0.5)
                .with_lacunarity(2.0)
                .generate();
            for i in 0..n {
                out[i] = finish(xf[i], grid[i]);
            }
            black_box(&out);
        })
    });
    group.finish();
}

/// texgraph's batch and per-point paths over the slab, as the first two functions of a group.
fn texgraph_pair(
    group: &mut criterion::BenchmarkGroup<criterion::measurement::WallTime>,
    tape: &Tape,
) {
    let (x, y, z) = slab();
    let n = x.len();
    group.bench_function("texgraph_batch_f32", |b| {
        let mut ws = Workspace::<f32>::new();
        let mut out = vec![0f32; n];
        b.iter(|| {
            tape.eval_batch(&mut ws, &x, &y, &z, &mut out);
            black_box(&out);
        })
    });
    group.bench_function("texgraph_point_f32", |b| {
        let mut ws = Workspace::<f32>::new();
        let mut out = vec![0f32; n];
        b.iter(|| {
            for i in 0..n {
                tape.eval_point(&mut ws, [x[i], y[i], z[i]], &mut out[i..i + 1]);
            }
            black_box(&out);
        })
    });
}

fn new_group<'a>(
    c: &'a mut Criterion,
    name: &str,
) -> criterion::BenchmarkGroup<'a, criterion::measurement::WallTime> {
    let mut group = c.benchmark_group(name.to_string());
    group.throughput(Throughput::Elements(slab().0.len() as u64));
    group
        .sample_size(15)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    group
}

/// A peer evaluated point by point over the slab (f32 coordinates where the peer takes them).
fn peer(
    group: &mut criterion::BenchmarkGroup<criterion::measurement::WallTime>,
    name: &str,
    f: &dyn Fn([f64; 3]) -> f32,
) {
    let (x, y, z) = slab();
    let n = x.len();
    group.bench_function(name, |b| {
        let mut out = vec![0f32; n];
        b.iter(|| {
            for i in 0..n {
                out[i] = f([x[i], y[i], z[i]]);
            }
            black_box(&out);
        })
    });
}

/// The noise families (issue 14): cellular, simplex, warping and tiling, each against its
/// peers on the slab (128 × 128 × 4 voxel centres of the 128³ grid over [0, 8)³).
fn family_benches(c: &mut Criterion) {
    // Cellular F1 (Euclidean, jitter 1) and a 4-octave cellular fbm.
    let mut group = new_group(c, "eval/cellular");
    texgraph_pair(
        &mut group,
        &compile_text(r#"Graph(outputs: { "c": Cellular(input: Position) })"#, &[]),
    );
    let mut fnl = fastnoise_lite::FastNoiseLite::new();
    fnl.set_noise_type(Some(fastnoise_lite::NoiseType::Cellular));
    fnl.set_cellular_distance_function(Some(fastnoise_lite::CellularDistanceFunction::Euclidean));
    fnl.set_cellular_return_type(Some(fastnoise_lite::CellularReturnType::Distance));
    fnl.set_cellular_jitter(Some(1.0));
    fnl.set_frequency(Some(1.0));
    peer(&mut group, "fastnoise_lite", &|p| {
        fnl.get_noise_3d(p[0] as f32, p[1] as f32, p[2] as f32)
    });
    let worley = noise::Worley::new(0).set_return_type(noise::core::worley::ReturnType::Distance);
    peer(&mut group, "noise_rs_worley", &|p| {
        use noise::NoiseFn;
        worley.get(p) as f32
    });
    group.finish();
    let mut group = new_group(c, "eval/cellular_fbm4");
    texgraph_pair(
        &mut group,
        &compile_text(
            r#"Graph(outputs: { "c": Fbm(input: Position, basis: Cellular, octaves: 4.0) })"#,
            &[],
        ),
    );
    let mut fnl4 = fastnoise_lite::FastNoiseLite::new();
    fnl4.set_noise_type(Some(fastnoise_lite::NoiseType::Cellular));
    fnl4.set_cellular_return_type(Some(fastnoise_lite::CellularReturnType::Distance));
    fnl4.set_fractal_type(Some(fastnoise_lite::FractalType::FBm));
    fnl4.set_fractal_octaves(Some(4));
    fnl4.set_frequency(Some(1.0));
    peer(&mut group, "fastnoise_lite", &|p| {
        fnl4.get_noise_3d(p[0] as f32, p[1] as f32, p[2] as f32)
    });
    group.finish();

    // Simplex, one octave.
    let mut group = new_group(c, "eval/simplex");
    texgraph_pair(
        &mut group,
        &compile_text(
            r#"Graph(outputs: { "s": Noise(input: Position, basis: Simplex) })"#,
            &[],
        ),
    );
    // Tiled at periods no power of two and no multiple of 3 (the old lattice's only ones).
    let tiled = compile_text(
        r#"Graph(outputs: { "s": Noise(input: Position, basis: Simplex, period: (5, 7, 11)) })"#,
        &[],
    );
    let (x, y, z) = slab();
    group.bench_function("texgraph_batch_f32_tiled", |b| {
        let mut ws = Workspace::<f32>::new();
        let mut out = vec![0f32; x.len()];
        b.iter(|| {
            tiled.eval_batch(&mut ws, &x, &y, &z, &mut out);
            black_box(&out);
        })
    });
    let mut os2 = fastnoise_lite::FastNoiseLite::new();
    os2.set_noise_type(Some(fastnoise_lite::NoiseType::OpenSimplex2));
    os2.set_frequency(Some(1.0));
    peer(&mut group, "fastnoise_lite_opensimplex2", &|p| {
        os2.get_noise_3d(p[0] as f32, p[1] as f32, p[2] as f32)
    });
    group.bench_function("simdnoise", |b| {
        // simdnoise generates a whole grid (runtime SIMD dispatch).
        b.iter(|| {
            let (grid, _, _) = simdnoise::NoiseBuilder::gradient_3d(128, 128, 4)
                .with_freq(8.0 / 128.0)
                .generate();
            black_box(grid);
        })
    });
    group.finish();

    // A two-level warp of Perlin fbm: fbm4(warp(warp(p))).
    let mut group = new_group(c, "eval/warp");
    texgraph_pair(
        &mut group,
        &compile_text(
            r#"Graph(outputs: { "w": Fbm(input: Warp(input: Warp(input: Position, amount: 0.5, basis: Perlin, octaves: 3.0), amount: 0.5, basis: Perlin, seed: 1, octaves: 3.0), basis: Perlin, octaves: 4.0) })"#,
            &[],
        ),
    );
    group.finish();

    // The cost of tiling: the same 8-octave Perlin fbm with and without a period.
    let mut group = new_group(c, "eval/period");
    let plain = compile_text(FBM8, &[]);
    let tiled = compile_text(
        r#"Graph(outputs: { "f": Fbm(input: Position, basis: Perlin, octaves: 8.0, period: 8) })"#,
        &[],
    );
    // Period 3 on the [0, 8) slab: every point reduced into its period (the general path; the
    // one above bakes exactly one tile, where the reduction is the identity).
    let reduced = compile_text(
        r#"Graph(outputs: { "f": Fbm(input: Position, basis: Perlin, octaves: 8.0, period: 3) })"#,
        &[],
    );
    let (x, y, z) = slab();
    let n = x.len();
    for (name, tape) in [
        ("fbm8_batch_f32", &plain),
        ("fbm8_period_batch_f32", &tiled),
        ("fbm8_period3_batch_f32", &reduced),
    ] {
        group.bench_function(name, |b| {
            let mut ws = Workspace::<f32>::new();
            let mut out = vec![0f32; n];
            b.iter(|| {
                tape.eval_batch(&mut ws, &x, &y, &z, &mut out);
                black_box(&out);
            })
        });
    }
    group.finish();
}

/// `eval/gradient/*`: the gradient of the 8-octave Perlin fbm by `Gradient` (analytic, one
/// instruction) against the fbm alone and against central differences written in the graph
/// language (six more fbm evaluations at p ± h along each axis: what an author without
/// `Gradient` writes; forward differences would still need three).
fn gradient_benches(c: &mut Criterion) {
    let mut group = new_group(c, "eval/gradient");
    let fbm = |p: &str| format!("Fbm(input: {p}, basis: Perlin, octaves: 8.0)");
    let value = compile_text(FBM8, &[]);
    let analytic = compile_text(
        &format!(
            r#"Graph(outputs: {{ "g": Gradient(of: {}) }})"#,
            fbm("Position")
        ),
        &[],
    );
    let h = 1e-3;
    let axis = |k: usize, sign: f64| {
        let mut v = [0.0; 3];
        v[k] = sign * h;
        fbm(&format!(
            "Translate(input: Position, by: ({:?}, {:?}, {:?}))",
            v[0], v[1], v[2]
        ))
    };
    let central: Vec<String> = (0..3)
        .map(|k| {
            format!(
                "Mul(Sub({}, {}), {:?})",
                axis(k, 1.0),
                axis(k, -1.0),
                0.5 / h
            )
        })
        .collect();
    let differences = compile_text(
        &format!(
            r#"Graph(outputs: {{ "g": Combine({}, {}, {}) }})"#,
            central[0], central[1], central[2]
        ),
        &[],
    );
    let (x, y, z) = slab();
    let n = x.len();
    for (name, tape) in [
        ("fbm8_value_batch_f32", &value),
        ("fbm8_gradient_batch_f32", &analytic),
        ("fbm8_central_differences_batch_f32", &differences),
    ] {
        group.bench_function(name, |b| {
            let mut ws = Workspace::<f32>::new();
            let mut out = vec![0f32; n * tape.channels()];
            b.iter(|| {
                tape.eval_batch(&mut ws, &x, &y, &z, &mut out);
                black_box(&out);
            })
        });
    }
    group.finish();
}

fn eval_benches(c: &mut Criterion) {
    peer_group(c, "fbm8", FBM8, |_, f| f);
    peer_group(c, "marble", MARBLE, |x, f| (6.0 * x + 4.0 * f).sin().abs());

    // The seed 003 marble (issue 2's figure): the graph file as written, 8 octaves.
    let tape = marble_tape();
    let (x, y, z) = points();
    let n = x.len();
    let mut group = c.benchmark_group("eval/seed003_marble");
    group.throughput(Throughput::Elements(n as u64));
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));

    group.bench_function("handwritten_f32", |b| {
        let mut out = vec![0f32; n];
        b.iter(|| {
            for i in 0..n {
                out[i] = handwritten::vein(x[i] as f32, y[i] as f32, z[i] as f32);
            }
            black_box(&out);
        })
    });
    group.bench_function("texgraph_point_f32", |b| {
        let mut ws = Workspace::<f32>::new();
        let mut out = vec![0f32; n];
        b.iter(|| {
            for i in 0..n {
                tape.eval_point(&mut ws, [x[i], y[i], z[i]], &mut out[i..i + 1]);
            }
            black_box(&out);
        })
    });
    group.bench_function("texgraph_batch_f32", |b| {
        let mut ws = Workspace::<f32>::new();
        let mut out = vec![0f32; n];
        b.iter(|| {
            tape.eval_batch(&mut ws, &x, &y, &z, &mut out);
            black_box(&out);
        })
    });
    group.bench_function("texgraph_batch_f64", |b| {
        let mut ws = Workspace::<f64>::new();
        let mut out = vec![0f64; n];
        b.iter(|| {
            tape.eval_batch(&mut ws, &x, &y, &z, &mut out);
            black_box(&out);
        })
    });
    // Level of detail per point: every point finer than the finest octave (nothing dropped:
    // the cost of asking), and spacings growing along each row from 1/4096 to 1/4 (the
    // footprints of a floor receding from the camera).
    let fine = vec![1e-6; n];
    let receding: Vec<f64> = (0..n)
        .map(|i| (i % 128) as f64 / 127.0)
        .map(|t| (4096f64).powf(-1.0 + t) * 0.25)
        .collect();
    for (name, spacing) in [
        ("texgraph_batch_lod_f32_fine", &fine),
        ("texgraph_batch_lod_f32_receding", &receding),
    ] {
        group.bench_function(name, |b| {
            let mut ws = Workspace::<f32>::new();
            let mut out = vec![0f32; n];
            b.iter(|| {
                tape.eval_batch_lod(&mut ws, [&x, &y, &z], spacing, &mut out);
                black_box(&out);
            })
        });
    }
    // Precision per instruction: compiled for the slab's own extent (nothing needs f64: the
    // same tape), and the same slab moved to x = 1e6 with the plain tape (wrong in f32) and
    // with the tape compiled for that extent (the coordinate chain in f64).
    let near = marble_tape_for(Some(texgraph::Extent::new([0.0; 3], [8.0; 3])));
    assert_eq!(
        near.to_string(),
        tape.to_string(),
        "[0, 8]³ needs no promotion"
    );
    let far_x: Vec<f64> = x.iter().map(|v| v + 1e6).collect();
    let far = marble_tape_for(Some(texgraph::Extent::new(
        [1e6, 0.0, 0.0],
        [1e6 + 8.0, 8.0, 8.0],
    )));
    assert!(
        far.wide_instructions() > 0,
        "the far marble promotes its coordinate chain"
    );
    for (name, tape, xs) in [
        ("texgraph_batch_f32_extent", &near, &x),
        ("far_plain_f32", &tape, &far_x),
        ("far", &far, &far_x),
    ] {
        group.bench_function(name, |b| {
            let mut ws = Workspace::<f32>::new();
            let mut out = vec![0f32; n];
            b.iter(|| {
                tape.eval_batch(&mut ws, xs, &y, &z, &mut out);
                black_box(&out);
            })
        });
    }
    group.finish();
}

/// The seed 004 wood grain on the slab and moved to x = 1e6 (issue 32): near, compiled for the
/// slab (the plain tape); `far_plain_f32`, the plain tape there (its noise and coordinate
/// chain rounded in f32: off by up to 1 in the grain); `far`, compiled for that extent (the
/// coordinate chain and both noises promoted: the Perlin samples run their f64 kernels); and
/// `far_f64`, the whole tape in f64, the reference.
/// The filtered form against the plain batch on the same points (issue 33's cost goal: ≤ 2×).
fn filtered_benches(c: &mut Criterion) {
    use texgraph::filter::{Filtered, Footprint};
    let text =
        std::fs::read_to_string("graphs/seed003_marble.ron").expect("run from the crate root");
    let graph = check(
        SourceFile::new("seed003_marble.ron", text),
        &CheckOptions::default(),
    )
    .expect("valid graph");
    let options = CompileOptions {
        outputs: vec!["vein".into()],
        ..Default::default()
    };
    let tape = compile(&graph, &options).expect("compiles");
    let (x, y, z) = slab();
    let n = x.len();
    let filtered = Filtered::new(&tape);
    let mut group = new_group(c, "eval/filtered/seed003_marble");
    let mut out = vec![0f32; n];
    let mut ws = Workspace::<f32>::new();
    group.bench_function("point_batch_f32", |b| {
        b.iter(|| tape.eval_batch(&mut ws, &x, &y, &z, black_box(&mut out)))
    });
    for (name, side) in [("filtered_1_128", 1.0 / 128.0), ("filtered_1_8", 0.125)] {
        let footprint = [Footprint::cube(side).expect("finite")];
        group.bench_function(name, |b| {
            b.iter(|| filtered.eval_batch([&x, &y, &z], &footprint, black_box(&mut out)))
        });
    }
    group.finish();
}

fn wood_grain_benches(c: &mut Criterion) {
    let text =
        std::fs::read_to_string("graphs/seed004_wood_grain.ron").expect("run from the crate root");
    let graph = check(
        SourceFile::new("seed004_wood_grain.ron", text),
        &CheckOptions::default(),
    )
    .expect("valid graph");
    let tape_for = |extent: Option<texgraph::Extent>| {
        let options = CompileOptions {
            outputs: vec!["grain".into()],
            extent,
            ..Default::default()
        };
        compile(&graph, &options).expect("compiles")
    };
    let (x, y, z) = slab();
    let n = x.len();
    let plain = tape_for(None);
    let near = tape_for(Some(texgraph::Extent::new([0.0; 3], [8.0; 3])));
    let far_x: Vec<f64> = x.iter().map(|v| v + 1e6).collect();
    let far = tape_for(Some(texgraph::Extent::new(
        [1e6, 0.0, 0.0],
        [1e6 + 8.0, 8.0, 8.0],
    )));
    // Listing lines `NNNN  dK = noise v…`: noise written to a wide slot.
    let listing = far.to_string();
    let promoted_noise = listing
        .lines()
        .filter(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            w.len() > 3 && w[1].starts_with('d') && w[3] == "noise"
        })
        .count();
    assert!(
        promoted_noise >= 1,
        "the far wood grain promotes its noise:\n{listing}"
    );
    let mut group = new_group(c, "eval/seed004_wood_grain");
    for (name, tape, xs) in [
        ("near", &near, &x),
        ("far_plain_f32", &plain, &far_x),
        ("far", &far, &far_x),
    ] {
        group.bench_function(name, |b| {
            let mut ws = Workspace::<f32>::new();
            let mut out = vec![0f32; n];
            b.iter(|| {
                tape.eval_batch(&mut ws, xs, &y, &z, &mut out);
                black_box(&out);
            })
        });
    }
    group.bench_function("far_f64", |b| {
        let mut ws = Workspace::<f64>::new();
        let mut out = vec![0f64; n];
        b.iter(|| {
            plain.eval_batch(&mut ws, &far_x, &y, &z, &mut out);
            black_box(&out);
        })
    });
    group.finish();
}

/// A generated graph of `n` nodes, counted as the checker counts them ("written", inline nodes
/// included; `texgraph check` prints both counts): a chain of fbm, math and transform nodes
/// with cross links, some of them nested. 1 000 nodes are 625 ids in `nodes`, 1 502 nodes
/// after checking (constants and component picks included).
fn generated_graph(n: usize) -> String {
    let mut nodes = String::from("\"n0\": Scale(input: Position, by: 1.5),\n");
    let mut written = 2; // Scale and its Position
    let mut i: usize = 0;
    while written < n {
        i += 1;
        // (line, nodes it writes); when one node is left, a one-node line.
        let kind = if n - written == 1 { 5 } else { i % 5 };
        let (line, count) = match kind {
            0 => (
                format!("\"n{i}\": Add(\"n{}\", Mul(0.5, \"n{}.x\")),\n", i - 1, i - 5),
                2,
            ),
            1 => (
                format!("\"n{i}\": Fbm(input: \"n{}\", basis: Perlin, octaves: 4.0),\n", i - 1),
                1,
            ),
            2 => (
                format!(
                    "\"n{i}\": Translate(input: \"n{}\", by: \"n{}\"),\n",
                    i - 2,
                    i - 1
                ),
                1,
            ),
            3 => (format!("\"n{i}\": Sin(Mul(\"n{}.y\", 3.0)),\n", i - 1), 2),
            5 => (format!("\"n{i}\": Abs(\"n{}\"),\n", i - 1), 1),
            _ => (
                format!(
                    "\"n{i}\": Rotate(input: \"n{}\", axis: (0, 1, 0), degrees: Mul(\"n{}\", 90.0)),\n",
                    i - 4,
                    i - 1
                ),
                2,
            ),
        };
        written += count;
        nodes.push_str(&line);
    }
    format!("Graph(nodes: {{ {nodes} }}, outputs: {{ \"out\": \"n{i}\" }})")
}

fn compile_benches(c: &mut Criterion) {
    let mut group = c.benchmark_group("compile");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    for n in [10usize, 100, 1000, 10_000] {
        let text = generated_graph(n);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &text, |b, text| {
            b.iter(|| {
                let graph = check(
                    SourceFile::new("generated.ron", text.clone()),
                    &CheckOptions::default(),
                )
                .expect("valid");
                black_box(compile(&graph, &CompileOptions::default()).expect("compiles"))
            })
        });
    }
    group.finish();
}

criterion_group!(
    benches,
    eval_benches,
    family_benches,
    wood_grain_benches,
    filtered_benches,
    gradient_benches,
    compile_benches
);
criterion_main!(benches);
