//! Scene files: the RON format (deserialised with serde and the `ron` crate), and resolving a
//! scene into what the renderer runs: objects with transforms, meshes loaded once, and every
//! bound graph file checked and compiled once per set of overrides, for the outputs the scene
//! binds only.
//!
//! ```ron
//! Scene(
//!     camera: Camera(position: (0, 1, 4), look_at: (0, 0, 0), fov: 40),
//!     lights: [
//!         Point(position: (-4, 6, 5), intensity: 0.9),                  // key light, with shadows
//!         Directional(direction: (-1, -0.5, -1), intensity: 0.3, shadows: false), // fill light
//!     ],
//!     materials: {
//!         "marble": Material(
//!             diffuse: Texture(graph: "../seed003_marble.ron", output: "colour",
//!                              set: { "octaves": 8 }, space: Object),
//!             specular: Value(0.4),
//!             shininess: Value(40),
//!         ),
//!         "floor": Material(diffuse: Colour(0.6, 0.6, 0.6), specular: Value(0)),
//!     },
//!     objects: [
//!         Object(shape: Sphere(radius: 1), material: "marble"),
//!         Object(shape: Plane(), material: "floor", transform: [Translate(0, -1, 0)]),
//!     ],
//! )
//! ```
//!
//! The module documentation of `render` describes every field.
//!
//! This module holds the format's types, the resolved scene and loading; `preview` builds the
//! default preview scene of a graph file, `diagnostics` points problems at the scene file, and
//! `resolve` turns a [`SceneDesc`] into a [`Scene`], one phase per part of the scene.

mod diagnostics;
mod preview;
mod resolve;

pub use preview::{PreviewBump, PreviewDefaults, PreviewObject};

use super::geometry::Mesh;
use super::RenderError;
use crate::diagnostic::SourceFile;
use crate::load::read_source;
use crate::syntax;
use crate::tape::Tape;
use diagnostics::{ron_diagnostic, Located};
use glam::{Affine3A, Mat3, Vec3};
use resolve::resolve;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

// ---------------------------------------------------------------------------------------------
// The file format
// ---------------------------------------------------------------------------------------------

/// A scene file: `Scene(camera: ..., lights: [...], materials: {...}, objects: [...])`.
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Scene", deny_unknown_fields)]
pub struct SceneDesc {
    pub camera: CameraDesc,
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    /// Materials by name; objects refer to them by name.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialDesc>,
    pub objects: Vec<ObjectDesc>,
    /// Colour of rays that hit nothing (linear RGB).
    #[serde(default = "default_background", alias = "background_color")]
    pub background: [f64; 3],
    /// Light that reaches every point, multiplied by each material's ambient channel.
    #[serde(default = "default_ambient_light")]
    pub ambient_light: [f64; 3],
    /// Image size (width, height) when the command line gives none.
    #[serde(default)]
    pub size: Option<(u32, u32)>,
    /// Samples per pixel when the command line gives none.
    #[serde(default)]
    pub samples: Option<u32>,
    /// Not in the file format: every named node of every graph may be bound like an output
    /// (`texgraph serve` previews a node an author clicks).
    #[serde(skip)]
    pub probe_nodes: bool,
}

fn default_background() -> [f64; 3] {
    [0.18, 0.19, 0.21]
}
fn default_ambient_light() -> [f64; 3] {
    [0.12, 0.12, 0.12]
}
fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    40.0
}
fn one() -> f64 {
    1.0
}
fn white() -> [f64; 3] {
    [1.0, 1.0, 1.0]
}
fn yes() -> bool {
    true
}

/// A pinhole camera. `fov` is the vertical field of view in degrees.
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Camera", deny_unknown_fields)]
pub struct CameraDesc {
    pub position: [f64; 3],
    pub look_at: [f64; 3],
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    #[serde(default = "default_fov")]
    pub fov: f64,
}

/// A light. Point lights do not fall off with distance (a preview, like seed 003's `rayn`).
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Light", deny_unknown_fields)]
pub enum LightDesc {
    Point {
        position: [f64; 3],
        #[serde(default = "white", alias = "color")]
        colour: [f64; 3],
        #[serde(default = "one")]
        intensity: f64,
        /// Cast shadows (shadow rays).
        #[serde(default = "yes")]
        shadows: bool,
    },
    /// Light from far away, shining in `direction`.
    Directional {
        direction: [f64; 3],
        #[serde(default = "white", alias = "color")]
        colour: [f64; 3],
        #[serde(default = "one")]
        intensity: f64,
        #[serde(default = "yes")]
        shadows: bool,
    },
}

/// A Blinn–Phong material; each channel is a constant or a graph output.
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Material", deny_unknown_fields)]
pub struct MaterialDesc {
    /// Reflectance for the ambient light; the diffuse channel when left out.
    #[serde(default)]
    pub ambient: Option<ChannelDesc>,
    #[serde(default = "default_diffuse")]
    pub diffuse: ChannelDesc,
    #[serde(default = "default_specular")]
    pub specular: ChannelDesc,
    /// Blinn–Phong exponent (a scalar channel).
    #[serde(default = "default_shininess")]
    pub shininess: ChannelDesc,
    /// Bump mapping: the shading normal tilted by the gradient of a scalar graph output.
    #[serde(default)]
    pub bump: Option<BumpDesc>,
}

/// `bump: (height: ..., strength: 1.0)`: the shading normal n becomes
/// normalize(n − strength · (g − (g·n) n)), g the world-space gradient of the height (Blinn
/// 1978, for a solid height field).
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Bump", deny_unknown_fields)]
pub struct BumpDesc {
    /// The height: a scalar graph output.
    pub height: HeightDesc,
    /// A factor on the height's gradient; negative inverts the bumps.
    #[serde(default = "one")]
    pub strength: f64,
}

/// A bump's height: `"FILE.OUTPUT"` (split at the last dot) or the `Texture(...)` form of the
/// channels, with its `set`, `space`, `transform` and `multiply`.
#[derive(Clone, Debug)]
pub enum HeightDesc {
    /// `"stone.ron.height"`: output `height` of the graph file `stone.ron`, in object space
    /// with no transform.
    Output(String),
    /// The fields of a `Texture(...)` channel.
    Texture(HeightTexture),
}

/// The fields of `Texture(...)` in a height, read through a map (the form is told apart from a
/// string by what the reader finds; the name `Texture` is checked against the spanned tree).
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Texture", deny_unknown_fields)]
pub struct HeightTexture {
    pub graph: String,
    /// By default the graph's first scalar output.
    #[serde(default)]
    pub output: Option<String>,
    #[serde(default)]
    pub set: BTreeMap<String, f64>,
    #[serde(default)]
    pub space: Space,
    #[serde(default)]
    pub transform: Vec<TransformDesc>,
    #[serde(default = "one")]
    pub multiply: f64,
}

impl<'de> Deserialize<'de> for HeightDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<HeightDesc, D::Error> {
        struct Height;
        impl<'de> serde::de::Visitor<'de> for Height {
            type Value = HeightDesc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a string \"FILE.OUTPUT\" or Texture(graph: ..., output: ...)")
            }
            fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<HeightDesc, E> {
                Ok(HeightDesc::Output(s.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<HeightDesc, A::Error> {
                HeightTexture::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(HeightDesc::Texture)
            }
        }
        d.deserialize_any(Height)
    }
}

fn default_diffuse() -> ChannelDesc {
    ChannelDesc::Value(0.8)
}
fn default_specular() -> ChannelDesc {
    ChannelDesc::Value(0.25)
}
fn default_shininess() -> ChannelDesc {
    ChannelDesc::Value(32.0)
}

impl Default for MaterialDesc {
    fn default() -> MaterialDesc {
        MaterialDesc {
            ambient: None,
            diffuse: default_diffuse(),
            specular: default_specular(),
            shininess: default_shininess(),
            bump: None,
        }
    }
}

/// A material channel: a constant or a texture procedure (seed 003's "channels").
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Channel", deny_unknown_fields)]
pub enum ChannelDesc {
    /// A constant colour (linear RGB). Not for scalar channels (shininess).
    #[serde(alias = "Color", alias = "Rgb")]
    Colour(f64, f64, f64),
    /// A constant number; a grey for colour channels.
    Value(f64),
    /// An output of a graph file, evaluated at each ray hit.
    Texture {
        /// The graph file, relative to the scene file.
        graph: String,
        /// The output; by default `colour` (or the first colour output, or the first output)
        /// for colour channels and the first scalar output for scalar channels.
        #[serde(default)]
        output: Option<String>,
        /// Param overrides, as `--set NAME=VALUE` does.
        #[serde(default)]
        set: BTreeMap<String, f64>,
        /// Where the texture is evaluated: `Object` (it moves with the object) or `World`.
        #[serde(default)]
        space: Space,
        /// Applied to the point (in the chosen space) before evaluation, in order.
        #[serde(default)]
        transform: Vec<TransformDesc>,
        /// A factor on the value.
        #[serde(default = "one")]
        multiply: f64,
    },
}

/// The space a texture is evaluated in (seed 004: "world space coordinates v. object space
/// coordinates").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize, clap::ValueEnum)]
pub enum Space {
    /// Object space: hit points are moved back by the object's inverse transform, so the
    /// texture is fixed to the object.
    #[default]
    Object,
    /// World space: the object moves through the texture.
    World,
}

/// One step of a transform; a list applies its steps in order (the first step first).
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Transform", deny_unknown_fields)]
pub enum TransformDesc {
    Translate(f64, f64, f64),
    /// Rotation about `axis` (through the origin) by `degrees`, counter-clockwise looking down
    /// the axis.
    Rotate {
        axis: [f64; 3],
        degrees: f64,
    },
    /// `Scale(2)` or `Scale((1, 2, 1))`.
    Scale(ScaleBy),
}

#[derive(Clone, Debug, Deserialize)]
#[serde(untagged, expecting = "a number or a tuple (x, y, z)")]
pub enum ScaleBy {
    Uniform(f64),
    Axes([f64; 3]),
}

/// An object: a shape, a material by name, a transform (object → world).
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Object", deny_unknown_fields)]
pub struct ObjectDesc {
    pub shape: ShapeDesc,
    pub material: String,
    #[serde(default)]
    pub transform: Vec<TransformDesc>,
}

/// The shapes, in their object space.
#[derive(Clone, Debug, Deserialize)]
#[serde(rename = "Shape", deny_unknown_fields)]
pub enum ShapeDesc {
    /// A sphere around the origin.
    Sphere {
        #[serde(default = "one")]
        radius: f64,
    },
    /// A box centred on the origin.
    #[serde(alias = "Cube")]
    Box {
        #[serde(default = "unit_size")]
        size: [f64; 3],
    },
    /// The plane y = 0 (normal +y), infinite or `size: (x extent, z extent)` centred on the
    /// origin.
    Plane {
        #[serde(default)]
        size: Option<[f64; 2]>,
    },
    /// A triangle mesh from a Wavefront OBJ file (relative to the scene file). With `fit`, it
    /// is centred and scaled to fit in the cube [-1, 1]^3 (that is then its object space).
    Mesh {
        path: String,
        #[serde(default)]
        fit: bool,
    },
    /// The Newell teapot, y up, standing on y = 0 with a body of radius 1; `resolution`
    /// segments per patch edge (1 to 64). With `fit`, centred and scaled into [-1, 1]^3.
    Teapot {
        #[serde(default = "default_resolution")]
        resolution: u32,
        #[serde(default)]
        fit: bool,
    },
}

fn unit_size() -> [f64; 3] {
    [1.0, 1.0, 1.0]
}
fn default_resolution() -> u32 {
    10
}

// ---------------------------------------------------------------------------------------------
// The resolved scene
// ---------------------------------------------------------------------------------------------

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
    textures: Vec<CompiledTexture>,
    files: Vec<PathBuf>,
    size: Option<(u32, u32)>,
    samples: Option<u32>,
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

// ---------------------------------------------------------------------------------------------
// Loading
// ---------------------------------------------------------------------------------------------

/// Reads, checks and compiles a scene file.
pub fn load_scene(path: &Path) -> Result<Scene, RenderError> {
    let mut files = Vec::new();
    load_scene_tracking(path, &mut files)
}

/// [`load_scene`], recording every file it reads (or tries to) in `files`, also on failure.
pub(crate) fn load_scene_tracking(
    path: &Path,
    files: &mut Vec<PathBuf>,
) -> Result<Scene, RenderError> {
    files.push(path.to_path_buf());
    let source = read_source(path).map_err(RenderError::from_load)?;
    resolve_source(path, &source, files)
}

/// [`load_scene_tracking`] of a scene file already read (`source`, the text of `path`): its text
/// is not read again.
pub(crate) fn load_scene_source(
    path: &Path,
    source: &Arc<SourceFile>,
    files: &mut Vec<PathBuf>,
) -> Result<Scene, RenderError> {
    files.push(path.to_path_buf());
    resolve_source(path, source, files)
}

/// Parses a scene file's text once with `ron` (the scene) and once with `crate::syntax` (the
/// spanned tree that locates problems), then resolves it.
fn resolve_source(
    path: &Path,
    source: &Arc<SourceFile>,
    files: &mut Vec<PathBuf>,
) -> Result<Scene, RenderError> {
    let options =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let desc: SceneDesc = options
        .from_str(&source.text)
        .map_err(|e| RenderError::Invalid(vec![ron_diagnostic(source, &e)]))?;
    // The generic tree only locates later problems; a file ron accepts but it does not is
    // still rendered, with locations left out.
    let tree = syntax::parse(&source.text).ok();
    if let Some(tree) = &tree {
        // `materials` is read into a map, where a second definition would silently win.
        let twice = diagnostics::duplicate_materials(tree);
        if !twice.is_empty() {
            return Err(RenderError::Invalid(vec![crate::diagnostic::Diagnostics {
                file: source.clone(),
                list: twice,
            }]));
        }
    }
    let base = path.parent().unwrap_or(Path::new(""));
    let located = Located {
        source,
        tree: tree.as_ref(),
    };
    resolve(&desc, base, Some(&located), files)
}

impl Scene {
    /// The default preview scene of a graph file (see [`PreviewDefaults::scene_desc`]).
    pub fn from_graph_default(
        graph: &Path,
        defaults: &PreviewDefaults,
    ) -> Result<Scene, RenderError> {
        let mut files = Vec::new();
        Scene::from_graph_default_tracking(graph, defaults, &mut files)
    }

    pub(crate) fn from_graph_default_tracking(
        graph: &Path,
        defaults: &PreviewDefaults,
        files: &mut Vec<PathBuf>,
    ) -> Result<Scene, RenderError> {
        let desc = defaults.scene_desc(graph);
        resolve(&desc, Path::new(""), None, files)
    }

    /// [`Scene::from_desc`], adding every file it read (graphs, their imports, meshes) to
    /// `files`, also when it fails (what to watch for a fix).
    pub(crate) fn from_desc_tracking(
        desc: &SceneDesc,
        base: &Path,
        files: &mut Vec<PathBuf>,
    ) -> Result<Scene, RenderError> {
        resolve(desc, base, None, files)
    }

    /// Resolves a scene description built in code; relative paths are relative to `base`.
    pub fn from_desc(desc: &SceneDesc, base: &Path) -> Result<Scene, RenderError> {
        let mut files = Vec::new();
        resolve(desc, base, None, &mut files)
    }
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

#[cfg(test)]
mod tests {
    use super::diagnostics::{offset_of, without_rust_names};
    use super::resolve::transform_of;
    use super::*;

    #[test]
    fn messages_name_the_format_not_the_rust_types() {
        assert_eq!(
            without_rust_names(
                "Expected tuple variant TransformDesc::Translate with 3 elements but found 2 elements"
            ),
            "Expected tuple variant Translate with 3 elements but found 2 elements"
        );
        assert_eq!(
            without_rust_names("Unexpected field `x` in struct CameraDesc"),
            "Unexpected field `x` in struct Camera"
        );
        assert_eq!(
            without_rust_names("`Desc` and Description"),
            "`Desc` and Description"
        );
    }

    #[test]
    fn paths_are_normalised() {
        assert_eq!(
            join_normalised(Path::new("graphs/scenes"), "../seed003_marble.ron"),
            PathBuf::from("graphs/seed003_marble.ron")
        );
        assert_eq!(
            join_normalised(Path::new(""), "./a/../../b.ron"),
            PathBuf::from("../b.ron")
        );
        assert_eq!(
            join_normalised(Path::new("/x"), "../../b.ron"),
            PathBuf::from("/b.ron")
        );
        assert_eq!(
            join_normalised(Path::new("a"), "/abs.ron"),
            PathBuf::from("/abs.ron")
        );
    }

    #[test]
    fn offsets_of_lines_and_columns() {
        let text = "ab\ncdé\nf";
        assert_eq!(offset_of(text, 1, 1), 0);
        assert_eq!(offset_of(text, 2, 3), 5);
        assert_eq!(offset_of(text, 2, 4), 7);
        assert_eq!(offset_of(text, 3, 1), 8);
        assert_eq!(offset_of(text, 9, 9), text.len());
    }

    #[test]
    fn transforms_apply_in_order() {
        let m = transform_of(&[
            TransformDesc::Scale(ScaleBy::Uniform(2.0)),
            TransformDesc::Translate(1.0, 0.0, 0.0),
        ])
        .unwrap();
        assert_eq!(m.transform_point3(Vec3::X), Vec3::new(3.0, 0.0, 0.0));
        let r = transform_of(&[TransformDesc::Rotate {
            axis: [0.0, 0.0, 1.0],
            degrees: 90.0,
        }])
        .unwrap();
        assert!((r.transform_point3(Vec3::X) - Vec3::Y).length() < 1e-6);
        assert!(transform_of(&[TransformDesc::Scale(ScaleBy::Axes([1.0, 0.0, 1.0]))]).is_err());
    }

    #[test]
    fn the_format_reads_its_shorthands() {
        let options = ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
        let text = r#"Scene(
            camera: Camera(position: (0, 1, 4), look_at: (0, 0, 0)),
            lights: [Point(position: (1, 2, 3)), Directional(direction: (0, -1, 0), color: (1, 0.5, 0.5), shadows: false)],
            materials: { "m": Material(diffuse: Colour(1, 0, 0), shininess: Value(10),
                                       bump: (height: "dir.v2/stone.ron.height")),
                         "b": Material(bump: Bump(height: Texture(graph: "g.ron", space: World), strength: -0.5)),
                         "t": Material(diffuse: Texture(graph: "g.ron", set: { "octaves": 4 }, space: World,
                                                        transform: [Scale(2), Scale((1, 2, 3)), Rotate(axis: (0, 1, 0), degrees: 30)])) },
            objects: [
                Object(shape: Sphere(), material: "m"),
                Object(shape: Sphere(radius: 2), material: "m", transform: [Translate(1, 2, 3)]),
                Object(shape: Cube(size: (1, 2, 3)), material: "m"),
                Object(shape: Plane(), material: "m"),
                Object(shape: Plane(size: (2, 2)), material: "m"),
                Object(shape: Teapot(resolution: 4), material: "t"),
                Object(shape: Mesh(path: "x.obj", fit: true), material: "t"),
            ],
            size: (64, 48),
        )"#;
        let scene: SceneDesc = options.from_str(text).unwrap();
        assert_eq!(scene.objects.len(), 7);
        assert!(matches!(scene.objects[0].shape, ShapeDesc::Sphere { radius } if radius == 1.0));
        assert!(matches!(
            scene.objects[4].shape,
            ShapeDesc::Plane { size: Some(_) }
        ));
        assert_eq!(scene.size, Some((64, 48)));
        let bump = scene.materials["m"].bump.as_ref().unwrap();
        assert!(matches!(&bump.height, HeightDesc::Output(s) if s == "dir.v2/stone.ron.height"));
        assert_eq!(bump.strength, 1.0);
        let bump = scene.materials["b"].bump.as_ref().unwrap();
        assert_eq!(bump.strength, -0.5);
        assert!(matches!(
            &bump.height,
            HeightDesc::Texture(t)
                if t.graph == "g.ron" && t.output.is_none() && t.space == Space::World && t.multiply == 1.0
        ));
        assert!(scene.materials["t"].bump.is_none());
        match &scene.materials["t"].diffuse {
            ChannelDesc::Texture {
                transform, space, ..
            } => {
                assert_eq!(*space, Space::World);
                assert!(
                    matches!(transform[0], TransformDesc::Scale(ScaleBy::Uniform(s)) if s == 2.0)
                );
                assert!(matches!(
                    transform[1],
                    TransformDesc::Scale(ScaleBy::Axes(_))
                ));
            }
            other => panic!("{other:?}"),
        }
    }
}
