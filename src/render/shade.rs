//! The ray caster: primary rays per tile, textures evaluated in batches at the hits, Blinn–Phong
//! shading with shadow rays, jittered samples per pixel.
//!
//! A tile is rendered in three passes: trace every sample's primary ray and keep the hits;
//! evaluate each evaluation group's tape once over all the tile's hit points that need it
//! (`Tape::eval_batch`, f32 lanes); shade every hit from its channel values, its normal tilted
//! by its material's bump (the gradient of a height, evaluated in the same batches). Sample
//! positions come from a hash of the pixel and sample index, and each pixel averages its samples
//! in order, so an image does not depend on the tile order or the thread count.

use super::geometry::{self, LocalHit, Ray};
use super::scene::{Channel, EvalGroup, LightKind, Material, Object, Scene, Shape, Space};
use crate::eval::Workspace;
use crate::filter::{Filtered, Footprint};
use glam::Vec3;

/// Pixels along a tile's side.
pub(crate) const TILE: u32 = 16;

/// Counters of one render, summed over tiles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    pub primary_rays: u64,
    pub shadow_rays: u64,
    pub hits: u64,
    /// Points at which a tape was evaluated (one per hit per evaluation group).
    pub texture_points: u64,
    /// Texture values that were NaN or infinite (shaded as 0).
    pub non_finite: u64,
}

impl Counters {
    pub(crate) fn add(&mut self, o: &Counters) {
        self.primary_rays += o.primary_rays;
        self.shadow_rays += o.shadow_rays;
        self.hits += o.hits;
        self.texture_points += o.texture_points;
        self.non_finite += o.non_finite;
    }
}

/// What every tile of a render shares: the image size, the samples per pixel, and the factor
/// from a pixel's footprint to one sample's spacing for level of detail (`None`: off) or to
/// one sample's box for filtered textures (`None`: point samples).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    pub width: u32,
    pub height: u32,
    pub samples: u32,
    pub lod: Option<f64>,
    pub filter: Option<f64>,
}

/// A tile: its first pixel and size.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tile {
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
}

pub(crate) fn tiles(width: u32, height: u32) -> Vec<Tile> {
    let mut tiles = Vec::new();
    for y0 in (0..height).step_by(TILE as usize) {
        for x0 in (0..width).step_by(TILE as usize) {
            tiles.push(Tile {
                x0,
                y0,
                w: TILE.min(width - x0),
                h: TILE.min(height - y0),
            });
        }
    }
    tiles
}

/// Per-thread scratch: one workspace per compiled texture (so no re-binding between tapes).
pub(crate) struct Scratch<'a> {
    workspaces: Vec<Workspace<f32>>,
    /// Per texture, its GPU evaluator when the render runs it on the GPU.
    gpus: Vec<Option<std::sync::Arc<crate::gpu::GpuEvaluator>>>,
    /// Per texture, its filtered form when the render filters (`Frame::filter`), else empty.
    filtered: &'a [Filtered<'a>],
    /// The filtered form's slots, kept between groups (any texture's).
    filter_ws: crate::filter::FilterWorkspace<f32>,
}

impl<'a> Scratch<'a> {
    pub(crate) fn new(
        scene: &Scene,
        gpus: &[Option<std::sync::Arc<crate::gpu::GpuEvaluator>>],
        filtered: &'a [Filtered<'a>],
    ) -> Scratch<'a> {
        Scratch {
            workspaces: scene.textures().iter().map(|_| Workspace::new()).collect(),
            gpus: gpus.to_vec(),
            filtered,
            filter_ws: Default::default(),
        }
    }
}

/// A primary-ray hit, in world space.
#[derive(Clone, Copy)]
struct Hit {
    /// Index of the sample in the tile (pixel-major).
    sample: u32,
    object: u32,
    point: Vec3,
    local: Vec3,
    /// Unit shading normal, facing the viewer.
    normal: Vec3,
    /// Unit geometric normal, facing the viewer.
    geometric: Vec3,
    /// Unit vector towards the eye.
    view: Vec3,
    /// How the hit point moves in world space from one pixel to the next, across and down
    /// (ray differentials: Igehy 1999, on the hit's tangent plane).
    dp: [Vec3; 2],
}

/// SplitMix64 finaliser: a well-mixed 64-bit hash.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Sample `s` of `n` in pixel (x, y): an offset in [0, 1)². One sample is the pixel centre;
/// a square number of samples is stratified (one jittered sample per cell); otherwise jittered.
/// The seed is fixed: images are reproducible.
pub(crate) fn sample_offset(x: u32, y: u32, s: u32, n: u32) -> (f32, f32) {
    if n <= 1 {
        return (0.5, 0.5);
    }
    let h = mix(((x as u64) << 40) ^ ((y as u64) << 16) ^ s as u64 ^ 0x7e57_9a9f_0000_0000);
    let u = (h >> 40) as f32 / (1u64 << 24) as f32;
    let v = ((h >> 16) & 0xff_ffff) as f32 / (1u64 << 24) as f32;
    let k = (n as f64).sqrt() as u32;
    if k * k == n {
        let (cx, cy) = (s % k, s / k);
        ((cx as f32 + u) / k as f32, (cy as f32 + v) / k as f32)
    } else {
        (u, v)
    }
}

/// Nearest hit along a world ray: (t, object index, object-space hit).
fn nearest(
    objects: &[Object],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, usize, LocalHit)> {
    let mut best: Option<(f32, usize, LocalHit)> = None;
    let mut limit = t_max;
    for (i, object) in objects.iter().enumerate() {
        let local = Ray {
            origin: object.to_local.transform_point3(ray.origin),
            direction: object.to_local.transform_vector3(ray.direction),
        };
        if let Some(hit) = intersect(&object.shape, &local, t_min, limit) {
            limit = hit.t;
            best = Some((hit.t, i, hit));
        }
    }
    best
}

fn intersect(shape: &Shape, ray: &Ray, t_min: f32, t_max: f32) -> Option<LocalHit> {
    match shape {
        Shape::Sphere(r) => geometry::intersect_sphere(*r, ray, t_min, t_max),
        Shape::Box(half) => geometry::intersect_box(*half, ray, t_min, t_max),
        Shape::Plane(size) => geometry::intersect_plane(*size, ray, t_min, t_max),
        Shape::Mesh(mesh) => mesh.intersect(ray, t_min, t_max),
    }
}

/// Whether anything blocks the segment from `origin` along `direction` (unit) up to `t_max`.
fn occluded(objects: &[Object], origin: Vec3, direction: Vec3, t_max: f32) -> bool {
    objects.iter().any(|object| {
        let local = Ray {
            origin: object.to_local.transform_point3(origin),
            direction: object.to_local.transform_vector3(direction),
        };
        match &object.shape {
            Shape::Mesh(mesh) => mesh.occluded(&local, 0.0, t_max),
            shape => intersect(shape, &local, 0.0, t_max).is_some(),
        }
    })
}

/// Renders one tile: `out` receives its pixels row by row (linear RGB); the time spent
/// evaluating textures is added to `texture_time`.
pub(crate) fn render_tile(
    scene: &Scene,
    scratch: &mut Scratch<'_>,
    tile: Tile,
    frame: Frame,
    out: &mut Vec<Vec3>,
    texture_time: &mut std::time::Duration,
) -> Counters {
    let samples = frame.samples;
    let mut counters = Counters::default();
    let n_samples = (tile.w * tile.h * samples) as usize;
    let hits = primary_hits(scene, tile, frame, &mut counters);
    counters.hits = hits.len() as u64;
    let textures = evaluate_textures(scene, scratch, &hits, frame, &mut counters, texture_time);

    // Pass 3: shade.
    let mut sample_colours = vec![scene.background; n_samples];
    for (h, hit) in hits.iter().enumerate() {
        let object = &scene.objects[hit.object as usize];
        let material = &scene.materials[object.material];
        let mut fetch = |channel: &Channel| -> Vec3 {
            match *channel {
                Channel::Constant(c) => c,
                Channel::Texture {
                    slot,
                    channel,
                    vec3,
                    multiply,
                } => {
                    let c = textures.get(material, h, slot, channel, vec3) * multiply;
                    if c.is_finite() {
                        c
                    } else {
                        counters.non_finite += 1;
                        Vec3::select(c.is_finite_mask(), c, Vec3::ZERO)
                    }
                }
            }
        };
        let ambient = fetch(&material.ambient);
        let diffuse = fetch(&material.diffuse);
        let specular = fetch(&material.specular);
        let shininess = fetch(&material.shininess).x.clamp(0.0, 1e4);
        let mut shaded = *hit;
        if let Some(bump) = &material.bump {
            let gradient = textures.get(material, h, bump.slot, bump.channel, true);
            let group = &scene.groups[material.groups[bump.slot]];
            let gradient = world_gradient(gradient, group, object) * bump.strength;
            match bumped_normal(hit.normal, gradient) {
                Some(normal) => shaded.normal = normal,
                None => counters.non_finite += 1,
            }
        }
        sample_colours[hit.sample as usize] = shade(
            scene,
            &shaded,
            ambient,
            diffuse,
            specular,
            shininess,
            &mut counters,
        );
    }

    // Average each pixel's samples, in sample order.
    out.clear();
    let inv = 1.0 / samples as f32;
    for pixel in sample_colours.chunks_exact(samples as usize) {
        let mut sum = Vec3::ZERO;
        for c in pixel {
            sum += *c;
        }
        out.push(sum * inv);
    }
    counters
}

/// Pass 1: a tile's primary rays and the nearest hit of each (misses are left out).
fn primary_hits(scene: &Scene, tile: Tile, frame: Frame, counters: &mut Counters) -> Vec<Hit> {
    let Frame {
        width,
        height,
        samples,
        ..
    } = frame;
    let cam = &scene.camera;
    let aspect = width as f32 / height as f32;
    // How the unnormalised ray direction changes from one pixel to the next.
    let step = [
        cam.right * (2.0 / width as f32 * cam.tan_half * aspect),
        cam.up * (-2.0 / height as f32 * cam.tan_half),
    ];
    let n_samples = (tile.w * tile.h * samples) as usize;
    let mut hits: Vec<Hit> = Vec::with_capacity(n_samples);
    for py in 0..tile.h {
        for px in 0..tile.w {
            let (x, y) = (tile.x0 + px, tile.y0 + py);
            for s in 0..samples {
                let (ox, oy) = sample_offset(x, y, s, samples);
                let ndc_x = ((x as f32 + ox) / width as f32) * 2.0 - 1.0;
                let ndc_y = 1.0 - ((y as f32 + oy) / height as f32) * 2.0;
                let unnormalised = cam.forward
                    + cam.right * (ndc_x * cam.tan_half * aspect)
                    + cam.up * (ndc_y * cam.tan_half);
                let direction = unnormalised.normalize();
                let ray = Ray {
                    origin: cam.position,
                    direction,
                };
                counters.primary_rays += 1;
                let Some((t, index, local_hit)) =
                    nearest(&scene.objects, &ray, 1e-4, f32::INFINITY)
                else {
                    continue;
                };
                let object = &scene.objects[index];
                let mut geometric =
                    (object.normal_to_world * local_hit.geometric_normal).normalize_or_zero();
                let mut normal =
                    (object.normal_to_world * local_hit.shading_normal).normalize_or_zero();
                if geometric.dot(direction) > 0.0 {
                    geometric = -geometric;
                }
                if normal.dot(geometric) < 0.0 {
                    normal = -normal;
                }
                if normal == Vec3::ZERO {
                    normal = geometric;
                }
                hits.push(Hit {
                    sample: ((py * tile.w + px) * samples + s),
                    object: index as u32,
                    point: ray.at(t),
                    local: local_hit.point,
                    normal,
                    geometric,
                    view: -direction,
                    dp: step.map(|s| hit_differential(s, unnormalised, t, geometric)),
                });
            }
        }
    }

    hits
}

/// How a hit at distance `t` along the unit direction `d = D / |D|` moves on its tangent plane
/// (normal `n`) when the unnormalised direction `D` changes by `dd` (Igehy 1999, "Tracing ray
/// differentials"): the direction's change `(dD - d (d · dD)) / |D|`, carried to the plane,
/// `t (d' - d (d' · n) / (d · n))`. Infinite at grazing incidence.
fn hit_differential(dd: Vec3, unnormalised: Vec3, t: f32, n: Vec3) -> Vec3 {
    let length = unnormalised.length();
    let d = unnormalised / length;
    let turn = (dd - d * d.dot(dd)) / length;
    let along = turn.dot(n) / d.dot(n);
    if !along.is_finite() {
        return Vec3::INFINITY;
    }
    t * (turn - d * along)
}

/// A hit's two pixel differentials in the texture space of `group`: through the linear parts
/// of the object's (in object space) and the texture's transforms.
fn texture_differentials(hit: &Hit, group: &EvalGroup, object: &Object) -> [Vec3; 2] {
    let to_texture = match group.space {
        Space::Object => group.transform.matrix3 * object.to_local.matrix3,
        Space::World => group.transform.matrix3,
    };
    hit.dp.map(|v| to_texture * v)
}

/// The sample spacing in texture space of a hit for `group`: the longer of its two pixel
/// differentials, times `factor`; the largest finite spacing where it is not finite (grazing
/// incidence: every octave it can drop is dropped).
fn texture_spacing(hit: &Hit, group: &EvalGroup, object: &Object, factor: f64) -> f64 {
    let across = texture_differentials(hit, group, object).map(|v| f64::from(v.length()));
    let spacing = across[0].max(across[1]) * factor;
    if spacing.is_nan() || spacing == f64::INFINITY {
        f64::MAX
    } else {
        spacing
    }
}

/// A side beyond every feature of a texture: the footprint of a grazing hit, whose
/// differentials are infinite (the filtered value is then the texture's mean).
const GRAZING: f64 = 1e9;

/// The footprint in texture space of a hit for `group`: the parallelogram its two pixel
/// differentials span, times `factor` (anisotropic: long along the view at grazing angles,
/// narrow across it; never collapsed to one side). A cube of side [`GRAZING`] where a
/// differential is not finite.
fn texture_footprint(hit: &Hit, group: &EvalGroup, object: &Object, factor: f64) -> Footprint {
    let [a, b] = texture_differentials(hit, group, object)
        .map(|v| v.to_array().map(|c| f64::from(c) * factor));
    Footprint::from_edges([a, b, [0.0; 3]])
        .or_else(|_| Footprint::cube(GRAZING))
        .unwrap_or(Footprint::POINT)
}

/// The texture values of a tile's hits: per evaluation group, one batch of all its points.
struct TextureValues {
    /// Points in each group's batch.
    counts: Vec<usize>,
    /// For hit h, `slots[slot_base[h] + j]` is its index in the batch of its material's group j.
    slot_base: Vec<u32>,
    slots: Vec<u32>,
    /// Per group, channel-major values (`channel * count + index`).
    values: Vec<Vec<f32>>,
}

impl TextureValues {
    /// The value at hit `h` of the output at `channel` in the tape of `material`'s evaluation
    /// group `slot`: three channels for a vec3, else a grey.
    fn get(&self, material: &Material, h: usize, slot: usize, channel: usize, vec3: bool) -> Vec3 {
        let g = material.groups[slot];
        let n = self.counts[g];
        let i = self.slots[self.slot_base[h] as usize + slot] as usize;
        let v = &self.values[g];
        if vec3 {
            Vec3::new(
                v[channel * n + i],
                v[(channel + 1) * n + i],
                v[(channel + 2) * n + i],
            )
        } else {
            Vec3::splat(v[channel * n + i])
        }
    }
}

/// A GPU evaluation failed: said once per process; the batch is evaluated on the CPU.
fn gpu_failed(error: crate::gpu::GpuError) {
    static SAID: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    if !SAID.swap(true, std::sync::atomic::Ordering::Relaxed) {
        eprintln!("warning: {error}; textures are evaluated on the CPU where it fails");
    }
}

/// Pass 2: texture points per evaluation group, one batch each.
fn evaluate_textures(
    scene: &Scene,
    scratch: &mut Scratch<'_>,
    hits: &[Hit],
    frame: Frame,
    counters: &mut Counters,
    texture_time: &mut std::time::Duration,
) -> TextureValues {
    let groups = &scene.groups;
    let mut xs: Vec<Vec<f64>> = vec![Vec::new(); groups.len()];
    let mut ys: Vec<Vec<f64>> = vec![Vec::new(); groups.len()];
    let mut zs: Vec<Vec<f64>> = vec![Vec::new(); groups.len()];
    let mut spacings: Vec<Vec<f64>> = vec![Vec::new(); groups.len()];
    let mut footprints: Vec<Vec<Footprint>> = vec![Vec::new(); groups.len()];
    let (lod, filter) = (frame.lod, frame.filter);
    let mut slot_base: Vec<u32> = Vec::with_capacity(hits.len());
    let mut slots: Vec<u32> = Vec::new();
    for hit in hits {
        let object = &scene.objects[hit.object as usize];
        let material = &scene.materials[object.material];
        slot_base.push(slots.len() as u32);
        for &g in &material.groups {
            let group = &groups[g];
            let p = match group.space {
                Space::Object => hit.local,
                Space::World => hit.point,
            };
            let p = group.transform.transform_point3(p);
            slots.push(xs[g].len() as u32);
            xs[g].push(p.x as f64);
            ys[g].push(p.y as f64);
            zs[g].push(p.z as f64);
            if let Some(factor) = lod {
                spacings[g].push(texture_spacing(hit, group, object, factor));
            }
            if let Some(factor) = filter {
                footprints[g].push(texture_footprint(hit, group, object, factor));
            }
        }
    }
    let mut values: Vec<Vec<f32>> = Vec::with_capacity(groups.len());
    let started = std::time::Instant::now();
    for (g, group) in groups.iter().enumerate() {
        let n = xs[g].len();
        let texture = &scene.textures()[group.texture];
        let mut out = vec![0.0f32; texture.tape.channels() * n];
        let points = [&xs[g][..], &ys[g], &zs[g]];
        // The GPU first (its filtered form with a footprint per pixel when box-filtered); the
        // CPU where there is none for this texture or it fails.
        let on_gpu = match &scratch.gpus[group.texture] {
            Some(gpu) if n > 0 => {
                let result = match (filter, lod) {
                    (Some(_), _) => gpu.eval_batch_filtered(points, &footprints[g], &mut out),
                    (None, Some(_)) => gpu.eval_batch_lod(points, &spacings[g], &mut out),
                    (None, None) => gpu.eval_batch(points[0], points[1], points[2], &mut out),
                };
                result.map_err(gpu_failed).is_ok()
            }
            _ => false,
        };
        if n > 0 && on_gpu {
            counters.texture_points += n as u64;
        } else if let (Some(filtered), true) = (scratch.filtered.get(group.texture), n > 0) {
            filtered.eval_batch_with(&mut scratch.filter_ws, points, &footprints[g], &mut out);
            counters.texture_points += n as u64;
        } else if n > 0 {
            let workspace = &mut scratch.workspaces[group.texture];
            match lod {
                Some(_) => texture
                    .tape
                    .eval_batch_lod(workspace, points, &spacings[g], &mut out),
                None => texture
                    .tape
                    .eval_batch(workspace, points[0], points[1], points[2], &mut out),
            }
            counters.texture_points += n as u64;
        }
        values.push(out);
    }
    *texture_time += started.elapsed();

    TextureValues {
        counts: xs.iter().map(Vec::len).collect(),
        slot_base,
        slots,
        values,
    }
}

/// The gradient of a texture with respect to the world point, from its gradient `g` with
/// respect to the texture point (its evaluation's `Position`). The texture point is an affine
/// map of the world point, p_t = T(S(p_w)) (S: the object's world → object map in object space,
/// else the identity; T: the texture's transform); by the chain rule ∇_w = Sᵀ Tᵀ g with Sᵀ, Tᵀ
/// the transposes of their linear parts. Sᵀ is the object's normal matrix (the inverse
/// transpose of its object → world map).
pub(crate) fn world_gradient(g: Vec3, group: &EvalGroup, object: &Object) -> Vec3 {
    let g = group.gradient_to_space * g;
    match group.space {
        Space::Object => object.normal_to_world * g,
        Space::World => g,
    }
}

/// Blinn's (1978) bump perturbation of the unit normal `n` by `g`, the world-space gradient of
/// the height times the strength: n' = normalize(n − (g − (g·n) n)), the normal of the surface
/// moved by the height along n (to first order). `None` when n' is not finite (a NaN
/// gradient, or one so large that nothing of n is left).
pub(crate) fn bumped_normal(n: Vec3, g: Vec3) -> Option<Vec3> {
    let tangential = g - g.dot(n) * n;
    let bumped = (n - tangential).normalize();
    bumped.is_finite().then_some(bumped)
}

/// Blinn–Phong: ambient light × ambient + Σ over lights reaching the point of radiance ×
/// (diffuse · n·l + specular · (n·h)^shininess).
#[allow(clippy::too_many_arguments)]
fn shade(
    scene: &Scene,
    hit: &Hit,
    ambient: Vec3,
    diffuse: Vec3,
    specular: Vec3,
    shininess: f32,
    counters: &mut Counters,
) -> Vec3 {
    let mut colour = scene.ambient_light * ambient;
    // Shadow rays start a little off the surface, scaled to the point's magnitude so that f32
    // rounding far from the origin does not shadow a surface by itself.
    let eps = 1e-4 * hit.point.abs().max_element().max(1.0);
    let origin = hit.point + hit.geometric * eps;
    for light in &scene.lights {
        let (l, distance) = match light.kind {
            LightKind::Point(p) => {
                let d = p - hit.point;
                let len = d.length();
                if len == 0.0 {
                    continue;
                }
                (d / len, len)
            }
            LightKind::Directional(towards) => (towards, f32::INFINITY),
        };
        let n_dot_l = hit.normal.dot(l);
        if n_dot_l <= 0.0 || hit.geometric.dot(l) <= 0.0 {
            continue;
        }
        if light.shadows {
            counters.shadow_rays += 1;
            if occluded(&scene.objects, origin, l, distance - eps) {
                continue;
            }
        }
        let h = (l + hit.view).normalize_or_zero();
        let n_dot_h = hit.normal.dot(h).max(0.0);
        let highlight = if n_dot_h > 0.0 {
            n_dot_h.powf(shininess)
        } else {
            0.0
        };
        colour += light.radiance * (diffuse * n_dot_l + specular * highlight);
    }
    colour
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The differential of a hit on a plane is the first-order distance to where the next
    /// pixel's ray meets the plane: checked against intersecting both rays outright, in f64,
    /// head-on and at grazing angles, for either pixel axis.
    #[test]
    fn hit_differentials_match_the_next_pixels_hit() {
        let plane_hit = |o: [f64; 3], d: [f64; 3]| {
            let t = -o[1] / d[1]; // the plane y = 0
            [o[0] + t * d[0], 0.0, o[2] + t * d[2]]
        };
        let eye = Vec3::new(0.3, 1.7, 0.2);
        let n = Vec3::Y;
        for (forward, step) in [
            (Vec3::new(0.0, -1.0, 0.0), Vec3::new(1e-3, 0.0, 0.0)),
            (Vec3::new(0.0, -1.0, -1.0), Vec3::new(0.0, 1e-3, -1e-3)),
            (Vec3::new(0.2, -0.1, -1.0), Vec3::new(0.0, -1e-3, 0.0)),
            (Vec3::new(0.5, -0.05, -1.0), Vec3::new(7e-4, 0.0, 3e-4)),
        ] {
            let d = forward.normalize();
            let t = -eye.y / d.y;
            let dp = hit_differential(step, forward, t, n);
            let f64s = |v: Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
            let (o, a, b) = (f64s(eye), f64s(forward), f64s(forward + step));
            let here = plane_hit(o, a);
            let next = plane_hit(o, b);
            let moved = [0, 1, 2].map(|c| next[c] - here[c]);
            for c in 0..3 {
                let tolerance = 0.02 * f64s(dp).iter().map(|v| v.abs()).fold(0.0, f64::max);
                assert!(
                    (f64::from(dp[c]) - moved[c]).abs() <= tolerance,
                    "{forward:?} step {step:?}: differential {dp:?}, next pixel's hit moved {moved:?}"
                );
            }
        }
        // Grazing: the footprint is unbounded, never NaN.
        let dp = hit_differential(Vec3::new(0.0, 1e-3, 0.0), Vec3::new(0.0, 0.0, -1.0), 5.0, n);
        assert!(dp.length() == f32::INFINITY, "{dp:?}");
    }

    #[test]
    fn samples_are_stratified_and_fixed() {
        assert_eq!(sample_offset(3, 4, 0, 1), (0.5, 0.5));
        for s in 0..4 {
            let (u, v) = sample_offset(10, 20, s, 4);
            assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v));
            assert_eq!((u >= 0.5) as u32 + 2 * (v >= 0.5) as u32, s);
            assert_eq!((u, v), sample_offset(10, 20, s, 4));
        }
        assert_ne!(sample_offset(10, 20, 0, 3), sample_offset(11, 20, 0, 3));
    }

    #[test]
    fn tiles_cover_the_image_once() {
        let t = tiles(37, 20);
        let covered: u32 = t.iter().map(|t| t.w * t.h).sum();
        assert_eq!(covered, 37 * 20);
        assert_eq!(t.len(), 3 * 2);
    }
}
