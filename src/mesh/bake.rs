//! The texture set of a mesh: every output of a tape evaluated at the surface point under each
//! covered texel centre (at the point, or its mean over the texel's footprint on the surface),
//! padded around the UV islands, and the tangent-space normal map of a height's gradient.

use super::model::Model;
use super::pad::nearest_covered;
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

/// The surface point under a hit.
fn surface_point(model: &Model, hit: &Hit) -> [f64; 3] {
    let part = &model.parts[hit.part as usize];
    let t = part.triangles[hit.triangle as usize];
    let mut p = [0.0; 3];
    for (k, &i) in t.iter().enumerate() {
        for (c, value) in p.iter_mut().enumerate() {
            *value += hit.bary[k] * part.positions[i as usize][c];
        }
    }
    p
}

/// Per part and triangle: the texel's footprint on the surface, the parallelogram the
/// UV-to-position Jacobian maps a texel to (a point where the UVs are degenerate).
fn triangle_footprints(model: &Model, width: usize, height: usize) -> Vec<Vec<Footprint>> {
    model
        .parts
        .iter()
        .map(|part| {
            part.triangles
                .iter()
                .map(|t| {
                    let p = t.map(|i| DVec3::from(part.positions[i as usize]));
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
                .collect()
        })
        .collect()
}

/// What one worker keeps between its evaluations (no allocation after the first band).
struct Scratch<S: Real> {
    ws: Workspace<S>,
    fws: FilterWorkspace<S>,
    coords: [Vec<f64>; 3],
    footprints: Vec<Footprint>,
    planar: Vec<S>,
}

impl<S: Real> Scratch<S> {
    fn new() -> Scratch<S> {
        Scratch {
            ws: Workspace::new(),
            fws: FilterWorkspace::default(),
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
    /// Per part and triangle, the texel's footprint (box filter only).
    footprints: Vec<Vec<Footprint>>,
    tangents: Vec<Vec<[[f32; 4]; 3]>>,
    options: &'a MeshBakeOptions,
    /// Values per texel in the band buffers: every output's channels, then the normal's 3.
    stride: usize,
    cancel: Option<&'a AtomicBool>,
}

/// What a band found.
struct Band {
    covered: u64,
    overlaps: u64,
    /// Per value of the stride, over the band's covered texels.
    stats: Vec<ChannelStats>,
}

impl Bake<'_> {
    /// Rasterises band `band` and evaluates its covered texels into `texels` (the band's rows,
    /// `stride` values per texel) and `mask`; `None` when cancelled.
    fn band<S: Real>(
        &self,
        scratch: &mut Scratch<S>,
        band: usize,
        texels: &mut [f32],
        mask: &mut [bool],
    ) -> Option<Band> {
        if self.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return None;
        }
        let (hits, overlaps) = self.bins.band(band);
        let first = band * BAND * self.options.width;
        for c in &mut scratch.coords {
            c.clear();
        }
        scratch.footprints.clear();
        for hit in &hits {
            let p = surface_point(self.model, hit);
            for (c, coords) in scratch.coords.iter_mut().enumerate() {
                coords.push(p[c]);
            }
            if self.filtered.is_some() {
                scratch
                    .footprints
                    .push(self.footprints[hit.part as usize][hit.triangle as usize]);
            }
        }
        let (n, channels) = (hits.len(), self.tape.channels());
        scratch.evaluate(self.tape, self.filtered.as_ref());
        for (h, hit) in hits.iter().enumerate() {
            let at = (hit.texel as usize - first) * self.stride;
            for c in 0..channels {
                texels[at + c] = scratch.planar[c * n + h].to_f64() as f32;
            }
            mask[hit.texel as usize - first] = true;
        }
        if let Some((gradient, filtered)) = &self.gradient {
            scratch.evaluate(gradient, filtered.as_ref());
            for (h, hit) in hits.iter().enumerate() {
                let g = [0, 1, 2].map(|c| scratch.planar[c * n + h].to_f64());
                let at = (hit.texel as usize - first) * self.stride + channels;
                texels[at..at + 3].copy_from_slice(&self.normal(hit, g));
            }
        }
        let mut stats = vec![ChannelStats::default(); self.stride];
        for hit in &hits {
            let at = (hit.texel as usize - first) * self.stride;
            for (c, stats) in stats.iter_mut().enumerate() {
                stats.add(texels[at + c]);
            }
        }
        Some(Band {
            covered: n as u64,
            overlaps,
            stats,
        })
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

    /// Every band in parallel into `texels` and `mask`, their findings in band order.
    fn run<S: Real>(&self, texels: &mut [f32], mask: &mut [bool]) -> Option<Vec<Band>> {
        let width = self.options.width;
        texels
            .par_chunks_mut(BAND * width * self.stride)
            .zip(mask.par_chunks_mut(BAND * width))
            .enumerate()
            .map_init(Scratch::<S>::new, |scratch, (band, (texels, mask))| {
                self.band(scratch, band, texels, mask)
            })
            .collect()
    }
}

/// Channels `first..first + k` of every texel of `texels` (`stride` values each) as an image,
/// an uncovered texel taking its padding source's values (0 without one).
fn gather(
    texels: &[f32],
    stride: usize,
    first: usize,
    k: usize,
    sources: &[u32],
    width: usize,
) -> Vec<f32> {
    let mut data = vec![0.0f32; sources.len() * k];
    data.par_chunks_mut(width * k)
        .zip(sources.par_chunks(width))
        .for_each(|(row, sources)| {
            for (texel, &source) in row.chunks_exact_mut(k).zip(sources) {
                if source != super::pad::NONE {
                    let at = source as usize * stride + first;
                    texel.copy_from_slice(&texels[at..at + k]);
                }
            }
        });
    data
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
    let channels = tape.channels();
    let bake = Bake {
        model,
        tape,
        filtered: boxed.then(|| Filtered::new(tape)),
        gradient: gradient.map(|g| (g, boxed.then(|| Filtered::new(g)))),
        bins: Bins::new(model, width, height),
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
        stride: channels + if gradient.is_some() { 3 } else { 0 },
        cancel,
    };
    let mut texels = vec![0.0f32; width * height * bake.stride];
    let mut mask = vec![false; width * height];
    let bands = match options.precision {
        Precision::F32 => bake.run::<f32>(&mut texels, &mut mask),
        Precision::F64 => bake.run::<f64>(&mut texels, &mut mask),
    }
    .ok_or(BakeError::Cancelled)?;
    let mut stats = vec![ChannelStats::default(); bake.stride];
    let (mut covered, mut overlaps) = (0, 0);
    for band in &bands {
        covered += band.covered;
        overlaps += band.overlaps;
        for (all, part) in stats.iter_mut().zip(&band.stats) {
            all.merge(part);
        }
    }
    let sources = nearest_covered(&mask, width, height, options.padding);
    let padded = sources
        .par_iter()
        .zip(&mask)
        .filter(|(s, c)| !**c && **s != super::pad::NONE)
        .count() as u64;
    let image = |name: &str, ty: Type, first: usize| TextureImage {
        name: name.to_string(),
        ty,
        data: gather(&texels, bake.stride, first, ty.channels(), &sources, width),
    };
    let images: Vec<TextureImage> = tape
        .outputs()
        .iter()
        .map(|o| image(&o.name, o.ty, o.first_channel))
        .collect();
    let normal = gradient.map(|_| image("normal", Type::Vec3, channels));
    let stats = images
        .iter()
        .chain(normal.as_ref())
        .scan(0, |first, image| {
            let k = image.ty.channels();
            let output = OutputStats {
                name: image.name.clone(),
                channels: stats[*first..*first + k].to_vec(),
            };
            *first += k;
            Some(output)
        })
        .collect();
    Ok(TextureSet {
        width,
        height,
        images,
        normal,
        stats,
        covered,
        overlaps,
        padded,
        tangents: bake.tangents,
    })
}

/// Bytes a `width` × `height` texture set holds while it is made, with `values` values per
/// texel (every output's channels, and 3 for a normal map): the band buffer and the images
/// (4 bytes each per value), the coverage mask, the padding's source and row tables.
pub fn held_bytes(width: usize, height: usize, values: usize) -> u64 {
    let per_texel = 8 * values as u64 + 1 + 4 + 4;
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
