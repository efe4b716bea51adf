//! The resolved scene: what the renderer runs (objects with their transforms, materials whose
//! channels read compiled tapes, the groups of textures evaluated together at the hits).

use super::desc::Space;
use crate::render::geometry::Mesh;
use crate::tape::Tape;
use glam::{Affine3A, Mat3, Vec3};
use std::path::PathBuf;
use std::sync::Arc;

/// A pinhole camera, ready to make rays.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Camera {
    pub position: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    /// tan(fov / 2).
    pub tan_half: f32,
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum LightKind {
    Point(Vec3),
    /// Unit vector towards the light.
    Directional(Vec3),
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct Light {
    pub kind: LightKind,
    /// Colour × intensity.
    pub radiance: Vec3,
    pub shadows: bool,
}

#[derive(Clone, Debug)]
pub(crate) enum Shape {
    Sphere(f32),
    /// Half extents.
    Box(Vec3),
    Plane(Option<[f32; 2]>),
    Mesh(Arc<Mesh>),
}

#[derive(Clone, Debug)]
pub(crate) struct Object {
    pub shape: Shape,
    pub to_local: Affine3A,
    /// Inverse transpose of the linear part of `to_world`: normals to world space.
    pub normal_to_world: Mat3,
    pub material: usize,
}

/// One channel of a material, resolved.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Channel {
    Constant(Vec3),
    Texture {
        /// Index into the material's `groups`.
        slot: usize,
        /// First channel of the output in the tape's evaluation.
        channel: usize,
        vec3: bool,
        multiply: f32,
    },
}

/// A material's bump, resolved: where its height's gradient is in its evaluation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bump {
    /// Index into the material's `groups`.
    pub slot: usize,
    /// First channel of the gradient output (a vec3) in the tape's evaluation.
    pub channel: usize,
    /// `strength` × the height's `multiply`; never 0 (a zero bump is left out).
    pub strength: f32,
}

#[derive(Clone, Debug)]
pub(crate) struct Material {
    pub ambient: Channel,
    pub diffuse: Channel,
    pub specular: Channel,
    pub shininess: Channel,
    pub bump: Option<Bump>,
    /// The evaluation groups this material reads, in slot order.
    pub groups: Vec<usize>,
}

/// Points evaluated together: one texture, one space, one texture transform. Two channels that
/// share a group share its evaluation.
#[derive(Clone, Debug)]
pub(crate) struct EvalGroup {
    pub texture: usize,
    pub space: Space,
    pub transform: Affine3A,
    /// The transpose of `transform`'s linear part: a gradient with respect to the texture
    /// point to one with respect to the point in `space` (chain rule).
    pub gradient_to_space: Mat3,
}

/// A graph file checked with one set of overrides and compiled for the outputs a scene binds.
#[derive(Debug)]
pub struct CompiledTexture {
    /// The graph file (relative to the working directory when the scene's path was).
    pub graph: PathBuf,
    pub overrides: Vec<(String, f64)>,
    /// The compiled outputs, in tape order; `∇NAME` is the gradient of output `NAME`, compiled
    /// for a bump.
    pub outputs: Vec<String>,
    pub tape: Tape,
}

/// A scene ready to render: everything loaded, checked and compiled.
#[derive(Debug)]
pub struct Scene {
    pub(crate) camera: Camera,
    pub(crate) background: Vec3,
    pub(crate) ambient_light: Vec3,
    pub(crate) lights: Vec<Light>,
    pub(crate) materials: Vec<Material>,
    pub(crate) objects: Vec<Object>,
    pub(crate) groups: Vec<EvalGroup>,
    pub(crate) textures: Vec<CompiledTexture>,
    pub(crate) files: Vec<PathBuf>,
    pub(crate) size: Option<(u32, u32)>,
    pub(crate) samples: Option<u32>,
}

impl Scene {
    /// The compiled graph files: one per (file, overrides) pair, whatever the number of
    /// materials and objects using it.
    pub fn textures(&self) -> &[CompiledTexture] {
        &self.textures
    }

    /// Every file the scene was read from (the scene file, graphs, meshes): what `watch`
    /// watches.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    /// The image size the scene file asks for, if any.
    pub fn size(&self) -> Option<(u32, u32)> {
        self.size
    }

    /// The samples per pixel the scene file asks for, if any.
    pub fn samples(&self) -> Option<u32> {
        self.samples
    }

    /// The number of objects.
    pub fn object_count(&self) -> usize {
        self.objects.len()
    }
}
