//! Resolving a scene description into a [`Scene`]: a [`Resolver`] runs one phase per part of the
//! scene. The checking phases (camera, lights, settings, materials and their channels, graphs,
//! outputs, objects) report every problem they find and go on; only when there is none are the
//! textures compiled and the materials, evaluation groups and objects built.
//!
//! The phases run in the order of [`Resolver::run`]; problems are added in that order (the
//! scene's are then sorted into file order, the other files' keep it), and files are recorded
//! in the order they are read.

mod materials;
mod objects;

use super::desc::{LightDesc, ScaleBy, SceneDesc, Space, TransformDesc};
use super::diagnostics::{Key, Located, Problems};
use super::resolved::{Camera, Light, LightKind, Scene, Shape};
use crate::diagnostic::DiagnosticClass as C;
use crate::graph::CheckedGraph;
use crate::precision::Extent;
use crate::render::error::{check_samples, check_size, RenderError};
use crate::render::geometry::Mesh;
use glam::{Affine3A, Quat, Vec3};
use std::collections::BTreeMap;
use std::path::Component;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Resolves `desc` (relative paths relative to `base`; `located`: the scene file, to point
/// problems at), recording every file it reads (or tries to) in `files`.
pub(super) fn resolve(
    desc: &SceneDesc,
    base: &Path,
    located: Option<&Located>,
    files: &mut Vec<PathBuf>,
) -> Result<Scene, RenderError> {
    Resolver::new(desc, base, located, files).run()
}

/// [`resolve`] with a graph file already read and checked: a texture of that file with the
/// same overrides takes it instead of reading the file again.
#[cfg_attr(not(feature = "serve"), allow(dead_code))]
pub(super) fn resolve_with(
    desc: &SceneDesc,
    base: &Path,
    checked: Checked,
    files: &mut Vec<PathBuf>,
) -> Result<Scene, RenderError> {
    let mut resolver = Resolver::new(desc, base, None, files);
    resolver.checked = Some(checked);
    resolver.run()
}

/// A graph file as read and checked with `overrides` (the `serve` worker's: what it shows of
/// the graph and what it previews come from the one read of the file).
#[derive(Clone, Copy)]
pub struct Checked<'a> {
    pub path: &'a Path,
    pub overrides: &'a [(String, f64)],
    pub graph: &'a CheckedGraph,
}

/// What the phases of resolving a scene share: the description, where its paths start, the
/// problems found so far, the files read, and what each phase found for the later ones.
struct Resolver<'a> {
    desc: &'a SceneDesc,
    /// The folder relative paths start from.
    base: &'a Path,
    problems: Problems<'a>,
    files: &'a mut Vec<PathBuf>,
    /// The materials the objects use, by name, in order of first use.
    used: Vec<&'a str>,
    /// The constant channels of the used materials: (material, channel, value).
    constants: Vec<(&'a str, &'static str, Vec3)>,
    /// The texture channels of the used materials.
    bindings: Vec<Binding<'a>>,
    /// Each (graph file, overrides) the bindings use, in order of first use.
    keys: Vec<TextureKey>,
    /// Each key's checked graph (`None` where it has problems); empty once compiled.
    graphs: Vec<Option<CheckedGraph>>,
    /// The outputs each key is compiled for; empty once compiled.
    outputs: Vec<Vec<String>>,
    /// Each binding's output (`None` where it has problems).
    chosen: Vec<Option<Chosen>>,
    /// Meshes loaded so far, by `obj:PATH:FIT` or `teapot:RESOLUTION:FIT`.
    meshes: Vec<(String, Arc<Mesh>)>,
    /// A graph already checked, taken for the key it matches ([`resolve_with`]).
    checked: Option<Checked<'a>>,
}

/// The key a compiled texture is shared by.
type TextureKey = (PathBuf, Vec<(String, u64)>);

/// A binding's output: (index of its key, output name, whether the output is a vec3).
type Chosen = (usize, String, bool);

/// A texture binding found in a material, before compiling: a channel's texture, or a bump's
/// height (channel `bump`).
#[derive(Clone, Copy)]
struct Binding<'a> {
    material: &'a str,
    channel: &'static str,
    graph: &'a str,
    output: Option<&'a str>,
    set: &'a BTreeMap<String, f64>,
    space: Space,
    transform: &'a [TransformDesc],
    multiply: f64,
    scalar: bool,
    /// A bump's `strength` (1 for channels).
    strength: f64,
    /// A bump's height written `"FILE.OUTPUT"`.
    short: bool,
}

impl<'a> Binding<'a> {
    /// Whether this binding is a bump's height.
    fn is_bump(&self) -> bool {
        self.channel == "bump"
    }

    /// Where this binding's value `tail` is in the scene file: under the channel, or under a
    /// bump's `height`.
    fn at(&self, tail: &[Key<'a>]) -> Vec<Key<'a>> {
        let mut at = vec![
            Key::Field("materials"),
            Key::Entry(self.material),
            Key::Field(self.channel),
        ];
        if self.is_bump() {
            at.push(Key::Field("height"));
        }
        at.extend_from_slice(tail);
        at
    }

    /// The (graph file, overrides) this binding's texture is shared by, paths relative to `base`.
    fn key(&self, base: &Path) -> TextureKey {
        (
            join_normalised(base, self.graph),
            self.set
                .iter()
                .map(|(k, v)| (k.clone(), v.to_bits()))
                .collect(),
        )
    }
}

impl<'a> Resolver<'a> {
    /// A resolver of `desc` that has found nothing yet.
    fn new(
        desc: &'a SceneDesc,
        base: &'a Path,
        located: Option<&'a Located<'a>>,
        files: &'a mut Vec<PathBuf>,
    ) -> Resolver<'a> {
        Resolver {
            desc,
            base,
            problems: Problems::new(located),
            files,
            used: Vec::new(),
            constants: Vec::new(),
            bindings: Vec::new(),
            keys: Vec::new(),
            graphs: Vec::new(),
            outputs: Vec::new(),
            chosen: Vec::new(),
            meshes: Vec::new(),
            checked: None,
        }
    }

    /// Runs every checking phase, then (when no problem was found) builds the scene.
    fn run(mut self) -> Result<Scene, RenderError> {
        let camera = self.camera();
        let lights = self.lights();
        self.settings();
        self.material_uses();
        self.channels();
        self.graphs();
        self.outputs();
        let objects = self.objects();
        self.finish(camera, lights, objects)
    }

    /// Checks the camera and makes it ready to make rays.
    fn camera(&mut self) -> Camera {
        let cam = &self.desc.camera;
        let position = vec3(cam.position);
        let forward = vec3(cam.look_at) - position;
        let up_hint = vec3(cam.up);
        let camera_path = [Key::Field("camera")];
        if !finite(&cam.position) || !finite(&cam.look_at) || !finite(&cam.up) {
            self.problems.add(
                C::BadParameter,
                &camera_path,
                "camera: coordinates must be finite".into(),
                None,
            );
        } else if forward.length_squared() == 0.0 {
            self.problems.add(
                C::BadParameter,
                &[Key::Field("camera"), Key::Field("look_at")],
                "camera: `look_at` is the camera's own position".into(),
                None,
            );
        } else if up_hint.cross(forward).length_squared()
            <= 1e-12 * forward.length_squared() * up_hint.length_squared().max(1e-30)
        {
            self.problems.add(
                C::BadParameter,
                &[Key::Field("camera"), Key::Field("up")],
                "camera: `up` is zero or parallel to the viewing direction".into(),
                Some("the default `up` is (0, 1, 0); choose another for a camera looking straight up or down".into()),
            );
        }
        if !(cam.fov > 0.0 && cam.fov < 180.0) {
            self.problems.add(
                C::BadParameter,
                &[Key::Field("camera"), Key::Field("fov")],
                format!(
                    "camera: `fov` is {}; it must be between 0 and 180 degrees",
                    cam.fov
                ),
                None,
            );
        }
        let forward = forward.normalize_or_zero();
        let right = forward.cross(up_hint).normalize_or_zero();
        Camera {
            position,
            forward,
            right,
            up: right.cross(forward),
            tan_half: ((cam.fov as f32).to_radians() * 0.5).tan(),
        }
    }

    /// Checks and resolves every light.
    fn lights(&mut self) -> Vec<Light> {
        let desc = self.desc;
        desc.lights
            .iter()
            .enumerate()
            .map(|(i, light)| self.light(i, light))
            .collect()
    }

    /// Checks and resolves light `i`: colour × intensity, and the direction towards the light.
    fn light(&mut self, i: usize, light: &LightDesc) -> Light {
        let at = [Key::Field("lights"), Key::Index(i)];
        let (kind, colour, intensity, shadows) = match light {
            LightDesc::Point {
                position,
                colour,
                intensity,
                shadows,
            } => {
                if !finite(position) {
                    self.problems.add(
                        C::BadParameter,
                        &at,
                        format!("light {}: the position must be finite", i + 1),
                        None,
                    );
                }
                (
                    LightKind::Point(vec3(*position)),
                    colour,
                    intensity,
                    shadows,
                )
            }
            LightDesc::Directional {
                direction,
                colour,
                intensity,
                shadows,
            } => {
                let d = vec3(*direction);
                if !finite(direction) || d.length_squared() == 0.0 {
                    self.problems.add(
                        C::BadParameter,
                        &at,
                        format!("light {}: the direction must be finite and not zero", i + 1),
                        None,
                    );
                }
                (
                    LightKind::Directional(-d.normalize_or_zero()),
                    colour,
                    intensity,
                    shadows,
                )
            }
        };
        if !finite(colour)
            || !finite(&[*intensity])
            || colour.iter().any(|c| *c < 0.0)
            || *intensity < 0.0
        {
            self.problems.add(
                C::BadParameter,
                &at,
                format!(
                    "light {}: colour and intensity must be finite and not negative",
                    i + 1
                ),
                None,
            );
        }
        Light {
            kind,
            radiance: vec3(*colour) * *intensity as f32,
            shadows: *shadows,
        }
    }

    /// Checks the scene-wide settings: background, ambient light, image size and samples.
    fn settings(&mut self) {
        let desc = self.desc;
        for (what, v) in [
            ("background", &desc.background),
            ("ambient_light", &desc.ambient_light),
        ] {
            if !finite(v) || v.iter().any(|c| *c < 0.0) {
                self.problems.add(
                    C::BadParameter,
                    &[Key::Field(what)],
                    format!("`{what}` must be finite and not negative"),
                    None,
                );
            }
        }
        if let Some((w, h)) = desc.size {
            if let Err(m) = check_size(w, h) {
                self.problems
                    .add(C::BadParameter, &[Key::Field("size")], m, None);
            }
        }
        if let Some(s) = desc.samples {
            if let Err(m) = check_samples(s) {
                self.problems
                    .add(C::BadParameter, &[Key::Field("samples")], m, None);
            }
        }
    }

    /// Reports every problem found, or compiles the textures and builds the scene.
    fn finish(
        mut self,
        camera: Camera,
        lights: Vec<Light>,
        objects: Vec<(Option<Shape>, Affine3A)>,
    ) -> Result<Scene, RenderError> {
        self.problems.finish()?;
        let extents = self.texture_extents(&objects);
        let textures = self.compile_textures(&extents)?;
        let (materials, groups) = self.materials(&textures);
        let objects = self.place_objects(objects);
        let desc = self.desc;
        Ok(Scene {
            camera,
            background: vec3(desc.background),
            ambient_light: vec3(desc.ambient_light),
            lights,
            materials,
            objects,
            groups,
            textures,
            files: self.files.clone(),
            size: desc.size,
            samples: desc.samples,
        })
    }
}

impl Resolver<'_> {
    /// The box each texture is evaluated over, for its precision plan: for every binding of a
    /// material some object uses, each such object's shape bounds (in object space, or through
    /// the object's transform in world space) through the binding's texture transform,
    /// widened a little for the f32 rounding of hit points. `None` for a texture an unbounded
    /// shape (an infinite plane) uses: it is compiled without a plan, in f32 as before.
    fn texture_extents(&self, objects: &[(Option<Shape>, Affine3A)]) -> Vec<Option<Extent>> {
        let mut boxes: Vec<Option<Option<(Vec3, Vec3)>>> = vec![None; self.keys.len()];
        for (binding, chosen) in self.bindings.iter().zip(&self.chosen) {
            let (Some((key, _, _)), Ok(texture)) = (chosen, transform_of(binding.transform)) else {
                continue;
            };
            let users = self.desc.objects.iter().zip(objects);
            for (_, (shape, to_world)) in users.filter(|(d, _)| d.material == binding.material) {
                let local = shape.as_ref().and_then(shape_bounds);
                let found = local.map(|(lo, hi)| {
                    let (lo, hi) = match binding.space {
                        Space::Object => (lo, hi),
                        Space::World => transformed_box(to_world, lo, hi),
                    };
                    transformed_box(&texture, lo, hi)
                });
                let slot = &mut boxes[*key];
                *slot = Some(match (*slot, found) {
                    (Some(None), _) | (_, None) => None,
                    (None, Some(b)) => Some(b),
                    (Some(Some((lo, hi))), Some((l, h))) => Some((lo.min(l), hi.max(h))),
                });
            }
        }
        boxes
            .into_iter()
            .map(|b| {
                let (lo, hi) = b??;
                // Hit points are f32: a little outside the exact surface.
                let pad = |v: Vec3| Vec3::splat(1e-6) + v.abs() * 1e-5;
                let (lo, hi) = (lo - pad(lo), hi + pad(hi));
                (lo.is_finite() && hi.is_finite()).then(|| {
                    Extent::new(lo.to_array().map(f64::from), hi.to_array().map(f64::from))
                })
            })
            .collect()
    }
}

/// A shape's bounds in its own space; `None` for an infinite plane.
fn shape_bounds(shape: &Shape) -> Option<(Vec3, Vec3)> {
    match shape {
        Shape::Sphere(r) => Some((Vec3::splat(-r), Vec3::splat(*r))),
        Shape::Box(half) => Some((-*half, *half)),
        Shape::Plane(Some([x, z])) => {
            let half = Vec3::new(x / 2.0, 0.0, z / 2.0);
            Some((-half, half))
        }
        Shape::Plane(None) => None,
        Shape::Mesh(mesh) => Some(mesh.bounds()),
    }
}

/// The bounds of the box `[lo, hi]` through `m`: its eight corners mapped.
fn transformed_box(m: &Affine3A, lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    (0..8).fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(a, b), c| {
            let corner = Vec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            );
            let p = m.transform_point3(corner);
            (a.min(p), b.max(p))
        },
    )
}

/// An `[f64; 3]` as the renderer's `Vec3` (f32).
fn vec3(v: [f64; 3]) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// Finite also once made f32, as the renderer uses it.
fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| (*x as f32).is_finite())
}

/// A transform list as one affine map (the first step applied first), or a message.
pub(super) fn transform_of(steps: &[TransformDesc]) -> Result<Affine3A, (usize, String)> {
    let mut m = Affine3A::IDENTITY;
    for (i, step) in steps.iter().enumerate() {
        let s = match step {
            TransformDesc::Translate(x, y, z) => {
                if !finite(&[*x, *y, *z]) {
                    return Err((i, "Translate: the offset must be finite".into()));
                }
                Affine3A::from_translation(vec3([*x, *y, *z]))
            }
            TransformDesc::Rotate { axis, degrees } => {
                let a = vec3(*axis);
                if !finite(axis) || !finite(&[*degrees]) || a.length_squared() == 0.0 {
                    return Err((
                        i,
                        "Rotate: the axis must be a finite, non-zero vector and the angle finite"
                            .into(),
                    ));
                }
                Affine3A::from_quat(Quat::from_axis_angle(
                    a.normalize(),
                    (*degrees as f32).to_radians(),
                ))
            }
            TransformDesc::Scale(by) => {
                let s = match by {
                    ScaleBy::Uniform(s) => [*s; 3],
                    ScaleBy::Axes(a) => *a,
                };
                if !finite(&s)
                    || s.iter()
                        .any(|v| *v == 0.0 || v.abs() > 1e12 || v.abs() < 1e-12)
                {
                    return Err((
                        i,
                        "Scale: every factor must be finite and not zero (a flat object cannot be inverted)".into(),
                    ));
                }
                Affine3A::from_scale(vec3(s))
            }
        };
        m = s * m;
    }
    Ok(m)
}

/// `base/relative`, with `.` and `..` folded away lexically (a graph at
/// `graphs/scenes/../seed003_marble.ron` is reported as `graphs/seed003_marble.ron`, and the
/// two spellings share one compiled tape).
pub(crate) fn join_normalised(base: &Path, relative: &str) -> PathBuf {
    let joined = base.join(relative);
    let mut out = PathBuf::new();
    for c in joined.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                let last = out.components().next_back();
                if matches!(last, Some(Component::Normal(_))) {
                    out.pop();
                } else if !matches!(last, Some(Component::RootDir | Component::Prefix(_))) {
                    out.push("..");
                }
            }
            other => out.push(other.as_os_str()),
        }
    }
    if out.as_os_str().is_empty() {
        out.push(".");
    }
    out
}
