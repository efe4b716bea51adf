//! How much level of detail and box filtering per pixel buy a render: the same scene at one
//! sample per pixel with point samples (with and without level of detail) and box-filtered,
//! and at four point samples per pixel, against a many-sample render without level of detail
//! (the pixel's true average, up to the reference's own noise), in RMS error and in texture
//! time. `examples/horizon_lod.rs`
//! prints these figures for `graphs/scenes/horizon.ron`; `tests/it/render.rs` pins that level of
//! detail brings a render closer to its reference.

use super::{render, RenderError, RenderFilter, RenderLod, RenderOptions, RenderedImage, Scene};

/// What to render.
#[derive(Clone, Debug)]
pub struct LodComparison {
    pub size: (u32, u32),
    /// Samples per pixel of the reference (without level of detail).
    pub reference_samples: u32,
    /// Renders of each one-sample image; the texture time quoted is their median.
    pub runs: usize,
    pub threads: Option<usize>,
    /// The level-of-detail bias of the one-sample render with level of detail.
    pub bias: f64,
}

/// The figures: RMS error of each one-sample render against the reference (linear RGB, every
/// channel of every pixel), and the median texture time of each (CPU seconds).
#[derive(Clone, Debug, PartialEq)]
pub struct LodFigures {
    pub rms_lod: f64,
    pub rms_plain: f64,
    pub texture_seconds_lod: f64,
    pub texture_seconds_plain: f64,
    /// One box-filtered sample per pixel (issue 33's goal: at most `rms_four`'s error at
    /// at most twice `texture_seconds_plain`).
    pub rms_filtered: f64,
    pub texture_seconds_filtered: f64,
    /// Four point samples per pixel with level of detail.
    pub rms_four: f64,
    pub texture_seconds_four: f64,
    /// Equal time (issue 47): as many point samples per pixel with level of detail as fit in
    /// the box-filtered render's texture time (its median over the one-sample point render's,
    /// at least 1, at most a quarter of the reference's samples), rendered once.
    pub equal_samples: u32,
    pub rms_equal: f64,
    pub texture_seconds_equal: f64,
    /// The median over the runs of each pair's texture-time ratio (with over without): robust
    /// to a machine whose speed drifts between runs.
    pub pair_time_ratio: f64,
    pub reference_seconds: f64,
}

impl LodFigures {
    /// RMS error with level of detail over that without.
    pub fn error_ratio(&self) -> f64 {
        self.rms_lod / self.rms_plain
    }

    /// Texture time with level of detail over that without (median over median).
    pub fn time_ratio(&self) -> f64 {
        self.texture_seconds_lod / self.texture_seconds_plain
    }

    /// Whether one box-filtered sample per pixel is closer to the reference than the point
    /// samples that fit in its texture time.
    pub fn filtered_wins_at_equal_time(&self) -> bool {
        self.rms_filtered <= self.rms_equal
    }
}

/// Renders the reference and both one-sample images (alternately, `runs` times each).
pub fn compare_lod(scene: &Scene, comparison: &LodComparison) -> Result<LodFigures, RenderError> {
    let options = |samples: u32, lod: RenderLod, filter: RenderFilter| RenderOptions {
        size: Some(comparison.size),
        samples: Some(samples),
        threads: comparison.threads,
        lod,
        filter,
        ..Default::default()
    };
    let point = RenderFilter::Point;
    let (reference, stats) = render(
        scene,
        &options(comparison.reference_samples, RenderLod::Off, point),
    )?;
    let lod = RenderLod::On {
        bias: comparison.bias,
    };
    let (mut lod_times, mut plain_times) = (Vec::new(), Vec::new());
    let (mut filtered_times, mut four_times) = (Vec::new(), Vec::new());
    let (mut rms_lod, mut rms_plain, mut rms_filtered, mut rms_four) = (0.0, 0.0, 0.0, 0.0);
    for _ in 0..comparison.runs.max(1) {
        let (image, s) = render(scene, &options(1, lod, point))?;
        rms_lod = rms(&image, &reference);
        lod_times.push(s.texture_seconds);
        let (image, s) = render(scene, &options(1, RenderLod::Off, point))?;
        rms_plain = rms(&image, &reference);
        plain_times.push(s.texture_seconds);
        let (image, s) = render(scene, &options(1, lod, RenderFilter::Box))?;
        rms_filtered = rms(&image, &reference);
        filtered_times.push(s.texture_seconds);
        let (image, s) = render(scene, &options(4, lod, point))?;
        rms_four = rms(&image, &reference);
        four_times.push(s.texture_seconds);
    }
    let mut ratios: Vec<f64> = lod_times
        .iter()
        .zip(&plain_times)
        .map(|(a, b)| a / b)
        .collect();
    let texture_seconds_lod = median(&mut lod_times);
    let texture_seconds_filtered = median(&mut filtered_times);
    let equal_samples = ((texture_seconds_filtered / texture_seconds_lod).floor() as u32)
        .clamp(1, (comparison.reference_samples / 4).max(1));
    let (image, s) = render(scene, &options(equal_samples, lod, point))?;
    Ok(LodFigures {
        equal_samples,
        rms_equal: rms(&image, &reference),
        texture_seconds_equal: s.texture_seconds,
        rms_lod,
        rms_plain,
        pair_time_ratio: median(&mut ratios),
        texture_seconds_lod,
        texture_seconds_plain: median(&mut plain_times),
        rms_filtered,
        texture_seconds_filtered,
        rms_four,
        texture_seconds_four: median(&mut four_times),
        reference_seconds: stats.seconds,
    })
}

/// Root-mean-square difference of two images of one size, over every channel of every pixel
/// (linear RGB).
pub fn rms(a: &RenderedImage, b: &RenderedImage) -> f64 {
    assert_eq!(
        (a.width, a.height),
        (b.width, b.height),
        "images of one size"
    );
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from(p[c] - q[c]).powi(2)))
        .sum();
    (sum / (3 * a.pixels.len()).max(1) as f64).sqrt()
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(0.0)
}
