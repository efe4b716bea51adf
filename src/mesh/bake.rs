//! The texture set of a mesh: every output of a tape evaluated at the surface point under each
//! covered texel centre (at the point, or its mean over the texel's footprint on the surface),
//! padded around the UV islands, and the tangent-space normal map of a height's gradient.

use super::model::{Model, Part};
use super::pad;
use super::raster::{Bins, Hit, BAND};
use super::tangent::{bump_normal, corner_tangents, encode, frame, GreenAxis};
use crate::bake::{BakeError, ChannelStats, OutputStats, Precision};
use crate::eval::Workspace;
use crate::filter::{Filter, FilterWorkspace, Filtered, Footprint};
use crate::graph::Type;
use crate::real::Real;
use crate::tape::Tape;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// How to bake a texture set.
#[derive(Clone, Debug)]
pub struct MeshBakeOptions {
    pub width: usize,
    pub height: usize,
    pub filter: Filter,
    /// Uncovered texels within this many texels of an island take its nearest texel's value.
    pub padding: u32,
    pub precision: Precision,
    /// The normal map's strength and green axis, when a gradient tape is given.
    pub normal_strength: f64,
    pub green: GreenAxis,
}

impl Default for MeshBakeOptions {
    fn default() -> Self {
        MeshBakeOptions {
            width: 1024,
            height: 1024,
            filter: Filter::Point,
            padding: 8,
            precision: Precision::F32,
            normal_strength: 1.0,
            green: GreenAxis::Up,
        }
    }
}

/// One image of a texture set: `width × height` texels, row-major from the top-left, each
/// output's channels interleaved (scalar: 1, colour: 3).
#[derive(Clone, Debug)]
pub struct TextureImage {
    pub name: String,
    pub ty: Type,
    pub data: Vec<f32>,
}

/// A baked texture set.
#[derive(Clone, Debug)]
pub struct TextureSet {
    pub width: usize,
    pub height: usize,
    /// One per output of the tape, in output order.
    pub images: Vec<TextureImage>,
    /// The tangent-space normal map, encoded (components · 0.5 + 0.5), when asked for.
    pub normal: Option<TextureImage>,
    /// Statistics of each image over its covered texels (the normal map last).
    pub stats: Vec<OutputStats>,
    pub covered: u64,
    /// Texel centres two triangles cover (the first keeps them).
    pub overlaps: u64,
    /// Uncovered texels filled by padding.
    pub padded: u64,
    /// Per part, MikkTSpace's tangent per triangle corner (when a normal map was made).
    pub tangents: Vec<Vec<[[f32; 4]; 3]>>,
}

/// `f` of every triangle (its part and vertex indices), per part.
fn per_triangle<T>(model: &Model, f: impl Fn(&Part, [u32; 3]) -> T) -> Vec<Vec<T>> {
    model
        .parts
        .iter()
        .map(|part| part.triangles.iter().map(|&t| f(part, t)).collect())
        .collect()
}

/// A triangle's corners' positions.
fn corners(part: &Part, t: [u32; 3]) -> [DVec3; 3] {
    t.map(|i| DVec3::from(part.positions[i as usize]))
}

/// Per part and triangle: the texel's footprint on the surface, the parallelogram the
/// UV-to-position Jacobian maps a texel to (a point where the UVs are degenerate).
fn triangle_footprints(model: &Model, width: usize, height: usize) -> Vec<Vec<Footprint>> {
    per_triangle(model, |part, t| {
        let p = corners(part, t);
        let uv = t.map(|i| part.uvs[i as usize]);
        let (p1, p2) = (p[1] - p[0], p[2] - p[0]);
        let (du1, dv1) = (uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]);
        let (du2, dv2) = (uv[2][0] - uv[0][0], uv[2][1] - uv[0][1]);
        let det = du1 * dv2 - du2 * dv1;
        let pu = (p1 * dv2 - p2 * dv1) / det;
        let pv = (p2 * du1 - p1 * du2) / det;
        let edges = [
            (pu / width as f64).to_array(),
            (pv / height as f64).to_array(),
            [0.0; 3],
        ];
        Footprint::from_edges(edges).unwrap_or(Footprint::POINT)
    })
}

/// What one worker keeps between its evaluations (no allocation after the first band).
struct Scratch<S: Real> {
    ws: Workspace<S>,
    fws: FilterWorkspace<S>,
    owner: Vec<u32>,
    hits: Vec<Hit>,
    coords: [Vec<f64>; 3],
    footprints: Vec<Footprint>,
    planar: Vec<S>,
}

impl<S: Real> Scratch<S> {
    fn new() -> Scratch<S> {
        Scratch {
            ws: Workspace::new(),
            fws: FilterWorkspace::default(),
            owner: Vec::new(),
            hits: Vec::new(),
            coords: Default::default(),
            footprints: Vec::new(),
            planar: Vec::new(),
        }
    }

    /// `tape` at the points in `coords` (filtered over `footprints` when `filtered`: one per
    /// point, or one for all), planar into `planar`.
    fn evaluate(&mut self, tape: &Tape, filtered: Option<&Filtered>) {
        let n = self.coords[0].len();
        self.planar.clear();
        self.planar.resize(tape.channels() * n, S::ZERO);
        let [x, y, z] = &self.coords;
        match filtered {
            Some(filtered) => filtered.eval_batch_with(
                &mut self.fws,
                [x, y, z],
                &self.footprints,
                &mut self.planar,
            ),
            None => tape.eval_batch(&mut self.ws, x, y, z, &mut self.planar),
        }
    }
}

/// What every band of a texture set bake reads.
struct Bake<'a> {
    model: &'a Model,
    tape: &'a Tape,
    filtered: Option<Filtered<'a>>,
    gradient: Option<(&'a Tape, Option<Filtered<'a>>)>,
    bins: Bins,
    /// Per part and triangle, its corners' positions.
    corners: Vec<Vec<[DVec3; 3]>>,
    /// Per part and triangle, the texel's footprint (box filter only).
    footprints: Vec<Vec<Footprint>>,
    tangents: Vec<Vec<[[f32; 4]; 3]>>,
    options: &'a MeshBakeOptions,
    /// Channels per texel: every output's, then the normal's 3 (numbered across images).
    channels: usize,
    cancel: Option<&'a AtomicBool>,
}

/// A band's rows of every image (each output's, then the normal map's) and of the mask.
struct BandRows<'a> {
    images: Vec<&'a mut [f32]>,
    mask: &'a mut [bool],
}

/// What a band found.
struct Band {
    covered: u64,
    overlaps: u64,
    /// Per channel (numbered across images), over the band's covered texels.
    stats: Vec<ChannelStats>,
}

impl Bake<'_> {
    /// Rasterises band `band` and evaluates its covered texels into `rows`; `None` when
    /// cancelled.
    fn band<S: Real>(
        &self,
        scratch: &mut Scratch<S>,
        band: usize,
        rows: &mut BandRows<'_>,
    ) -> Option<Band> {
        if self.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return None;
        }
        let overlaps = self
            .bins
            .band_into(band, &mut scratch.owner, &mut scratch.hits);
        let hits = std::mem::take(&mut scratch.hits);
        let first = band * BAND * self.options.width;
        let n = hits.len();
        self.surface_points(scratch, &hits);
        scratch.evaluate(self.tape, self.filtered.as_ref());
        let mut stats = vec![ChannelStats::default(); self.channels];
        for (output, image) in self.tape.outputs().iter().zip(&mut rows.images) {
            let k = output.ty.channels();
            for c in 0..k {
                let channel = output.first_channel + c;
                let values = &scratch.planar[channel * n..(channel + 1) * n];
                let stats = &mut stats[channel];
                for (hit, value) in hits.iter().zip(values) {
                    let value = value.to_f64() as f32;
                    image[(hit.texel as usize - first) * k + c] = value;
                    stats.add(value);
                }
            }
        }
        for hit in &hits {
            rows.mask[hit.texel as usize - first] = true;
        }
        if let Some((gradient, filtered)) = &self.gradient {
            scratch.evaluate(gradient, filtered.as_ref());
            let first_channel = self.tape.channels();
            let image = rows.images.last_mut().expect("the normal map's rows");
            for (h, hit) in hits.iter().enumerate() {
                let g = [0, 1, 2].map(|c| scratch.planar[c * n + h].to_f64());
                let normal = self.normal(hit, g);
                let at = (hit.texel as usize - first) * 3;
                image[at..at + 3].copy_from_slice(&normal);
                for (c, &v) in normal.iter().enumerate() {
                    stats[first_channel + c].add(v);
                }
            }
        }
        scratch.hits = hits;
        Some(Band {
            covered: n as u64,
            overlaps,
            stats,
        })
    }

    /// The surface points under `hits` into the scratch's coordinates (and their footprints
    /// when filtering).
    fn surface_points<S: Real>(&self, scratch: &mut Scratch<S>, hits: &[Hit]) {
        let [x, y, z] = &mut scratch.coords;
        for c in [&mut *x, &mut *y, &mut *z] {
            c.clear();
            c.reserve(hits.len());
        }
        for hit in hits {
            let [a, b, c] = self.corners[hit.part as usize][hit.triangle as usize];
            let p = a * hit.bary[0] + b * hit.bary[1] + c * hit.bary[2];
            x.push(p.x);
            y.push(p.y);
            z.push(p.z);
        }
        scratch.footprints.clear();
        if self.filtered.is_some() {
            scratch.footprints.extend(
                hits.iter()
                    .map(|hit| self.footprints[hit.part as usize][hit.triangle as usize]),
            );
        }
    }

    /// The encoded tangent-space normal at a hit from the height's gradient there.
    fn normal(&self, hit: &Hit, gradient: [f64; 3]) -> [f32; 3] {
        let part = &self.model.parts[hit.part as usize];
        let t = part.triangles[hit.triangle as usize];
        let normals = t.map(|i| DVec3::from(part.normals[i as usize]));
        let tangents = self.tangents[hit.part as usize][hit.triangle as usize];
        let frame = frame(normals, tangents, hit.bary);
        let n = frame[2].normalize_or(DVec3::Z);
        let bumped = bump_normal(n, DVec3::from(gradient), self.options.normal_strength);
        encode(frame, bumped, self.options.green)
    }

    /// Every band in parallel into `images` and `mask`, their findings in band order.
    fn run<S: Real>(&self, images: &mut [TextureImage], mask: &mut [bool]) -> Option<Vec<Band>> {
        let rows = BAND * self.options.width;
        let mut bands: Vec<BandRows<'_>> = mask
            .chunks_mut(rows)
            .map(|mask| BandRows {
                images: Vec::with_capacity(images.len()),
                mask,
            })
            .collect();
        for image in images.iter_mut() {
            let k = image.ty.channels();
            for (band, rows) in bands.iter_mut().zip(image.data.chunks_mut(rows * k)) {
                band.images.push(rows);
            }
        }
        bands
            .into_par_iter()
            .enumerate()
            .map_init(Scratch::<S>::new, |scratch, (band, mut rows)| {
                self.band(scratch, band, &mut rows)
            })
            .collect()
    }
}

/// Bakes every output of `tape` into `model`'s UV layout; with `gradient` (a tape whose one
/// output is a height's gradient, [`gradient_tape`]) also the normal map. Bands of rows are
/// rasterised and evaluated in parallel (each band's covered texels one batch), then padded.
pub fn bake_texture_set(
    tape: &Tape,
    gradient: Option<&Tape>,
    model: &Model,
    options: &MeshBakeOptions,
    cancel: Option<&AtomicBool>,
) -> Result<TextureSet, BakeError> {
    let (width, height) = (options.width, options.height);
    let boxed = options.filter == Filter::Box;
    let bake = Bake {
        model,
        tape,
        filtered: boxed.then(|| Filtered::new(tape)),
        gradient: gradient.map(|g| (g, boxed.then(|| Filtered::new(g)))),
        bins: Bins::new(model, width, height),
        corners: per_triangle(model, corners),
        footprints: if boxed {
            triangle_footprints(model, width, height)
        } else {
            Vec::new()
        },
        tangents: if gradient.is_some() {
            model.parts.iter().map(corner_tangents).collect()
        } else {
            Vec::new()
        },
        options,
        channels: tape.channels() + if gradient.is_some() { 3 } else { 0 },
        cancel,
    };
    // Every output's image, then the normal map's.
    let blank = |name: &str, ty: Type| TextureImage {
        name: name.to_string(),
        ty,
        data: vec![0.0f32; width * height * ty.channels()],
    };
    let mut images: Vec<TextureImage> = tape
        .outputs()
        .iter()
        .map(|o| blank(&o.name, o.ty))
        .chain(gradient.map(|_| blank("normal", Type::Vec3)))
        .collect();
    let mut mask = vec![false; width * height];
    let bands = match options.precision {
        Precision::F32 => bake.run::<f32>(&mut images, &mut mask),
        Precision::F64 => bake.run::<f64>(&mut images, &mut mask),
    }
    .ok_or(BakeError::Cancelled)?;
    let mut stats = vec![ChannelStats::default(); bake.channels];
    let (mut covered, mut overlaps) = (0, 0);
    for band in &bands {
        covered += band.covered;
        overlaps += band.overlaps;
        for (all, part) in stats.iter_mut().zip(&band.stats) {
            all.merge(part);
        }
    }
    let pairs = pad::padding(&mask, width, height, options.padding);
    images
        .par_iter_mut()
        .for_each(|image| pad::apply(&pairs, &mut image.data, image.ty.channels()));
    let normal = gradient.and_then(|_| images.pop());
    let mut stats_by_output = crate::bake::collect_stats(tape, &stats);
    if let Some(normal) = &normal {
        stats_by_output.push(OutputStats {
            name: normal.name.clone(),
            channels: stats[tape.channels()..].to_vec(),
        });
    }
    Ok(TextureSet {
        width,
        height,
        images,
        normal,
        stats: stats_by_output,
        covered,
        overlaps,
        padded: pairs.len() as u64,
        tangents: bake.tangents,
    })
}

/// Bytes a `width` × `height` texture set of `channels` channels (every output's), and a
/// normal map when `normal`, holds while it is made: the images (4 bytes a value), the coverage
/// mask, the padding's row table and its (texel, source) pairs (at most one a texel).
pub fn held_bytes(width: usize, height: usize, channels: usize, normal: bool) -> u64 {
    let values = channels as u64 + if normal { 3 } else { 0 };
    let per_texel = 4 * values + 1 + 4 + 8;
    (width as u64)
        .saturating_mul(height as u64)
        .saturating_mul(per_texel)
}

/// The tape of scalar output `height`'s exact gradient (one vec3 output), compiled with
/// `options` but for that output alone: what a normal map is made from.
pub fn gradient_tape(
    graph: &crate::graph::CheckedGraph,
    height: &str,
    options: &crate::compile::CompileOptions,
) -> Result<Tape, String> {
    const NAME: &str = "texgraph_normal_gradient";
    if graph.output("normal").is_some() {
        return Err("the graph has an output named `normal`, which the normal map (STEM.normal) would overwrite".into());
    }
    let with = graph.with_gradient_output(height, NAME)?;
    let mut options = options.clone();
    options.outputs = vec![NAME.to_string()];
    crate::compile::compile(&with, &options).map_err(|d| d.render(false))
}

/// The normal map of a flat bake (a grid one voxel deep, `--size W,H,1`): voxel (i, j) at
/// texel (i, j), in the image's frame as a plane mesh with u along x and v along y would have
/// it: tangent +x (right), bitangent −y (up the image: rows run along +y), normal +z (out).
pub fn flat_normal_map(
    gradient: &Tape,
    grid: &crate::grid::Grid,
    options: &MeshBakeOptions,
    cancel: Option<&AtomicBool>,
) -> Result<TextureImage, BakeError> {
    let [nx, ny, _] = grid.size;
    let z = grid.centre(2, 0);
    let filtered = (options.filter == Filter::Box).then(|| Filtered::new(gradient));
    let footprint =
        match options.filter {
            Filter::Box => vec![Footprint::from_sides(grid.spacing())
                .map_err(|e| BakeError::Refused(e.to_string()))?],
            Filter::Point => Vec::new(),
        };
    let frame = [DVec3::X, -DVec3::Y, DVec3::Z];
    let mut data = vec![0.0f32; nx * ny * 3];
    let done = data
        .par_chunks_mut(nx * 3)
        .enumerate()
        .map_init(Scratch::<f64>::new, |scratch, (j, row)| {
            if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return false;
            }
            scratch.coords = [
                (0..nx).map(|i| grid.centre(0, i)).collect(),
                vec![grid.centre(1, j); nx],
                vec![z; nx],
            ];
            scratch.footprints.clone_from(&footprint);
            scratch.evaluate(gradient, filtered.as_ref());
            for (i, texel) in row.chunks_exact_mut(3).enumerate() {
                let g = DVec3::new(
                    scratch.planar[i],
                    scratch.planar[nx + i],
                    scratch.planar[2 * nx + i],
                );
                let bumped = bump_normal(DVec3::Z, g, options.normal_strength);
                texel.copy_from_slice(&encode(frame, bumped, options.green));
            }
            true
        })
        .all(|done| done);
    if !done {
        return Err(BakeError::Cancelled);
    }
    Ok(TextureImage {
        name: "normal".into(),
        ty: Type::Vec3,
        data,
    })
}
