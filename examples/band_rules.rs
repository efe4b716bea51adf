//! How well can one octave's mean (and spread) over a box be estimated from a few samples?
//! Issue 47 asks for a fade-band rule costing at most one extra kernel call in place of the
//! eight sub-box values (`filter/noise.rs`, `SUB_BAND`); this measures what any *linear* rule on
//! a given set of samples can reach, so the question is answered by figures, not by trying
//! rules one by one in the whole table.
//!
//! For boxes (cubes, axis-aligned in noise space, random centres) of sides that span the
//! sub-sampled band, the reference is the mean and variance of the noise over 1000 stratified
//! points of the box. Each estimator's weights are fitted by least squares on one half of the
//! boxes and its error measured on the other half: the best any rule on those samples can do
//! with fixed weights per box side (for a Gaussian field, the conditional expectation is
//! linear, so this is the best rule outright; noise is nearly Gaussian). Errors are RMS in units
//! of the basis' σ (mean) and σ² (variance). The current rules (the centre's fade, the eight
//! fade-weighted sub-boxes) are measured unfitted beside them.
//!
//! ```sh
//! cargo run --release --example band_rules [-- BASIS]   # perlin (default), simplex, value, value-smooth
//! ```

use texgraph::filter::noise::stats;
use texgraph::noise::{Basis, NoiseTable};

/// SplitMix64 (the crate's own is private): a fixed stream of uniform numbers.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// What is sampled of one box, and the reference.
struct BoxSamples {
    /// The box's mean and variance (1000 stratified points).
    mean: f64,
    var: f64,
    centre: f64,
    grad2: f64,
    laplacian: f64,
    /// The eight half-size sub-boxes' centre values (`filter/noise.rs`' `sub_centres`).
    sub8: [f64; 8],
    /// The half fraction of the eight (`s ∈ {−−−, ++−, +−+, −++}`).
    half4: f64,
    /// The two sub-box centres on the main diagonal, `±(1, 1, 1) L / 4`.
    pair: f64,
    /// Six points on the axes at `±0.35 L`.
    axes6: f64,
    /// The six face centres, `±E_k / 2`.
    face6: [f64; 6],
}

fn sample_box(table: &NoiseTable, c: [f64; 3], side: f64, rng: &mut Rng) -> BoxSamples {
    const K: usize = 10;
    let at = |d: [f64; 3]| -> f64 { table.sample([c[0] + d[0], c[1] + d[1], c[2] + d[2]]) };
    let (mut sum, mut sum2) = (0.0, 0.0);
    for i in 0..K * K * K {
        let cell = [i % K, i / K % K, i / (K * K)];
        let d = cell.map(|k| ((k as f64 + rng.next()) / K as f64 - 0.5) * side);
        let v = at(d);
        sum += v;
        sum2 += v * v;
    }
    let n = (K * K * K) as f64;
    let mean = sum / n;
    let g: [f64; 3] = table.sample_grad(c);
    let h = 1e-3;
    let centre = at([0.0; 3]);
    let laplacian = (0..3)
        .map(|k| {
            let mut e = [0.0; 3];
            e[k] = h;
            (at(e) + at(e.map(|x| -x)) - 2.0 * centre) / (h * h)
        })
        .sum();
    let q = side / 4.0;
    let sub8: [f64; 8] = std::array::from_fn(|j| {
        at(std::array::from_fn(
            |k| if j >> k & 1 == 1 { q } else { -q },
        ))
    });
    // Bits k set = +; −−− is 0, ++− is 3, +−+ is 5, −++ is 6.
    let half4 = (sub8[0] + sub8[3] + sub8[5] + sub8[6]) / 4.0;
    let pair = (sub8[0] + sub8[7]) / 2.0;
    let a = 0.35 * side;
    let axes6 = (0..6)
        .map(|i| {
            let mut e = [0.0; 3];
            e[i % 3] = if i < 3 { a } else { -a };
            at(e)
        })
        .sum::<f64>()
        / 6.0;
    let face6: [f64; 6] = std::array::from_fn(|i| {
        let mut e = [0.0; 3];
        e[i % 3] = if i < 3 { side / 2.0 } else { -side / 2.0 };
        at(e)
    });
    BoxSamples {
        face6,
        mean,
        var: (sum2 / n - mean * mean).max(0.0),
        centre,
        grad2: g.iter().map(|x| x * x).sum(),
        laplacian,
        sub8,
        half4,
        pair,
        axes6,
    }
}

/// Least squares `y ≈ X w` on the first half, its RMS error on the second half.
fn fitted_rms(rows: &[Vec<f64>], y: &[f64]) -> f64 {
    let half = rows.len() / 2;
    let p = rows[0].len();
    let mut a = vec![vec![0.0; p + 1]; p];
    for (r, &t) in rows[..half].iter().zip(&y[..half]) {
        for i in 0..p {
            for j in 0..p {
                a[i][j] += r[i] * r[j];
            }
            a[i][p] += r[i] * t;
        }
    }
    let w = solve(a);
    let err: f64 = rows[half..]
        .iter()
        .zip(&y[half..])
        .map(|(r, &t)| {
            let e = r.iter().zip(&w).map(|(x, w)| x * w).sum::<f64>() - t;
            e * e
        })
        .sum();
    (err / (rows.len() - half) as f64).sqrt()
}

/// Gaussian elimination with partial pivoting of an augmented system (a few unknowns).
fn solve(mut a: Vec<Vec<f64>>) -> Vec<f64> {
    let p = a.len();
    for col in 0..p {
        let pivot = (col..p)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        a.swap(col, pivot);
        let d = a[col][col];
        if d.abs() < 1e-300 {
            continue;
        }
        let pivot_row = a[col].clone();
        for (r, row) in a.iter_mut().enumerate() {
            if r != col {
                let f = row[col] / d;
                for (x, y) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                    *x -= f * y;
                }
            }
        }
    }
    (0..p)
        .map(|i| {
            if a[i][i] == 0.0 {
                0.0
            } else {
                a[i][p] / a[i][i]
            }
        })
        .collect()
}

fn rms(e: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0.0);
    for e in e {
        s += e * e;
        n += 1.0;
    }
    (s / n).sqrt()
}

fn main() {
    let basis = match std::env::args().nth(1).as_deref() {
        Some("simplex") => Basis::Simplex,
        Some("value") => Basis::Value(texgraph::noise::Interpolation::Linear),
        Some("value-smooth") => Basis::Value(texgraph::noise::Interpolation::Smooth),
        _ => Basis::Perlin,
    };
    let table = NoiseTable::new(basis, 0);
    let st = stats(&table);
    let sigma = st.var.sqrt();
    println!(
        "{basis:?}: μ {:.4}, σ² {:.4}, κ² {:.2}",
        st.mean, st.var, st.kappa2
    );
    println!();
    println!("Mean over the box, RMS error / σ (fitted rules: best linear weights per side)");
    println!();
    println!("| side (cells) | fade α | box-mean sd | centre (now) | centre, best | centre + Laplacian, best | centre + 2, best | half fraction (4) | centre + 6 axes, best | 6 faces | 8 sub-boxes (now) | 8, best |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut var_rows = Vec::new();
    for side in [
        0.0625, 0.125, 0.25, 0.5, 0.71, 1.0, 1.41, 2.0, 2.83, 4.0, 5.66, 8.0,
    ] {
        const N: usize = 3000;
        let mut rng = Rng(0x47);
        let boxes: Vec<BoxSamples> = (0..N)
            .map(|_| {
                let c = [0; 3].map(|_| rng.next() * 200.0 - 100.0);
                sample_box(&table, c, side, &mut rng)
            })
            .collect();
        let fade = |l2: f64| (1.0 + st.kappa2 * l2 / 12.0).powf(-1.5);
        let alpha = fade(side * side);
        let alpha_half = fade(side * side / 4.0);
        let y: Vec<f64> = boxes.iter().map(|b| b.mean).collect();
        let sd = rms(boxes.iter().map(|b| b.mean - st.mean));
        let fit = |f: &dyn Fn(&BoxSamples) -> Vec<f64>| {
            let rows: Vec<Vec<f64>> = boxes.iter().map(f).collect();
            fitted_rms(&rows, &y) / sigma
        };
        let err = |f: &dyn Fn(&BoxSamples) -> f64| rms(boxes.iter().map(|b| f(b) - b.mean)) / sigma;
        let mean8 = |b: &BoxSamples| b.sub8.iter().sum::<f64>() / 8.0;
        let mean6 = |b: &BoxSamples| b.face6.iter().sum::<f64>() / 6.0;
        println!(
            "| {side} | {alpha:.3} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} |",
            sd / sigma,
            err(&|b| alpha * b.centre + (1.0 - alpha) * st.mean),
            fit(&|b| vec![1.0, b.centre]),
            fit(&|b| vec![1.0, b.centre, b.laplacian]),
            fit(&|b| vec![1.0, b.centre, b.pair]),
            err(&|b| alpha_half * b.half4 + (1.0 - alpha_half) * st.mean),
            fit(&|b| vec![1.0, b.centre, b.axes6]),
            err(&|b| mean6(b)),
            err(&|b| alpha_half * mean8(b) + (1.0 - alpha_half) * st.mean),
            fit(&|b| vec![1.0, mean8(b)]),
        );
        // The spread within the box (what a downstream `sin`, step or ramp sees).
        let v: Vec<f64> = boxes.iter().map(|b| b.var).collect();
        let fit_v = |f: &dyn Fn(&BoxSamples) -> Vec<f64>| {
            let rows: Vec<Vec<f64>> = boxes.iter().map(f).collect();
            fitted_rms(&rows, &v) / st.var
        };
        let err_v =
            |f: &dyn Fn(&BoxSamples) -> f64| rms(boxes.iter().map(|b| f(b) - b.var)) / st.var;
        let between8 = |b: &BoxSamples| {
            let m = mean8(b);
            b.sub8.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / 8.0
        };
        let between6 = |b: &BoxSamples| {
            let m = mean6(b);
            b.face6.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / 6.0
        };
        let a2 = alpha_half * alpha_half;
        let v_mean = v.iter().sum::<f64>() / N as f64;
        // The centre rule's total variance: the linear part (the gradient faded and damped,
        // `β = 1 / (1 + κ² L² / 12)`) or what the fade takes, whichever is larger; and the
        // linear part plus what the fade takes beyond the linear part's expectation.
        let faded = (1.0 - alpha * alpha) * st.var;
        let beta = 1.0 / (1.0 + st.kappa2 * side * side / 12.0);
        let lin = |b: &BoxSamples| (alpha * beta).powi(2) * b.grad2 * side * side / 12.0;
        let expected = (alpha * beta).powi(2) * 3.0 * st.grad_sq * side * side / 12.0;
        var_rows.push(format!(
            "| {side} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} |",
            rms(v.iter().map(|x| x - v_mean)) / st.var,
            err_v(&|b| faded.max(lin(b))),
            err_v(&|b| lin(b) + (faded - expected).max(0.0)),
            fit_v(&|b| vec![1.0, b.grad2]),
            err_v(&|b| between6(b)),
            err_v(&|b| a2 * between8(b) + (1.0 - a2) * st.var),
            fit_v(&|b| vec![1.0, between8(b)]),
        ));
    }
    println!();
    println!("Variance within the box, RMS error / σ²");
    println!();
    println!("| side (cells) | its sd | centre (now) | centre, linear part + the rest | centre + gradient, best | 6 faces' spread | 8 sub-boxes (now) | 8, best |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in var_rows {
        println!("{r}");
    }
}
