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

use super::geometry::{self, Mesh};
use super::teapot;
use super::RenderError;
use crate::check::CheckOptions;
use crate::compile::{compile, CompileOptions};
use crate::diagnostic::{Diagnostic, DiagnosticClass, Diagnostics, SourceFile, Span};
use crate::graph::{CheckedGraph, Type};
use crate::load::{load_graph, read_source, LoadError};
use crate::syntax;
use crate::tape::Tape;
use glam::{Affine3A, Mat3, Quat, Vec3};
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

#[derive(Clone, Debug)]
pub(crate) struct Material {
    pub ambient: Channel,
    pub diffuse: Channel,
    pub specular: Channel,
    pub shininess: Channel,
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
}

/// A graph file checked with one set of overrides and compiled for the outputs a scene binds.
#[derive(Debug)]
pub struct CompiledTexture {
    /// The graph file (relative to the working directory when the scene's path was).
    pub graph: PathBuf,
    pub overrides: Vec<(String, f64)>,
    /// The compiled outputs, in tape order.
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

/// What the default preview scene of a graph shows.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum PreviewObject {
    #[default]
    Sphere,
    Cube,
    Plane,
    Teapot,
    /// A mesh from an OBJ file, centred and scaled to fit.
    Obj(PathBuf),
}

impl std::str::FromStr for PreviewObject {
    type Err = String;
    /// `sphere`, `cube`, `plane`, `teapot`, or a path ending in `.obj`.
    fn from_str(s: &str) -> Result<PreviewObject, String> {
        match s {
            "sphere" => Ok(PreviewObject::Sphere),
            "cube" | "box" => Ok(PreviewObject::Cube),
            "plane" => Ok(PreviewObject::Plane),
            "teapot" => Ok(PreviewObject::Teapot),
            _ if s.to_ascii_lowercase().ends_with(".obj") => Ok(PreviewObject::Obj(s.into())),
            _ => Err(format!(
                "unknown object `{s}`: expected sphere, cube, plane, teapot or a path to an .obj file"
            )),
        }
    }
}

/// The default preview scene of a graph file (`texgraph render FILE.ron`).
#[derive(Clone, Debug, Default)]
pub struct PreviewDefaults {
    pub object: PreviewObject,
    pub space: Space,
    /// `--set` overrides for the graph.
    pub overrides: Vec<(String, f64)>,
    /// The output bound to the diffuse channel; by default `colour`, else the first colour
    /// output, else the first output (as grey).
    pub output: Option<String>,
}

impl PreviewDefaults {
    /// The scene description of the default preview: the object (about 2 units across, its
    /// object space [-1, 1]^3 mapped onto the texture's default bake region [0, 1]^3), a ground
    /// plane under it, a key light with shadows and a fill light.
    pub fn scene_desc(&self, graph: &Path) -> SceneDesc {
        let graph = graph.to_string_lossy().into_owned();
        let texture = ChannelDesc::Texture {
            graph,
            output: self.output.clone(),
            set: self.overrides.iter().cloned().collect(),
            space: self.space,
            // [-1, 1]^3 → [0, 1]^3, the default bake region.
            transform: vec![
                TransformDesc::Scale(ScaleBy::Uniform(0.5)),
                TransformDesc::Translate(0.5, 0.5, 0.5),
            ],
            multiply: 1.0,
        };
        let mut materials = BTreeMap::new();
        materials.insert(
            "texture".to_string(),
            MaterialDesc {
                ambient: None,
                diffuse: texture,
                specular: ChannelDesc::Value(0.35),
                shininess: ChannelDesc::Value(48.0),
            },
        );
        materials.insert(
            "ground".to_string(),
            MaterialDesc {
                ambient: None,
                diffuse: ChannelDesc::Colour(0.55, 0.55, 0.55),
                specular: ChannelDesc::Value(0.0),
                shininess: ChannelDesc::Value(1.0),
            },
        );
        let object = |shape, transform| ObjectDesc {
            shape,
            material: "texture".into(),
            transform,
        };
        let rotate = |axis: [f64; 3], degrees| TransformDesc::Rotate { axis, degrees };
        // (object, lowest y of the object: where the ground goes)
        let (main, ground_y) = match &self.object {
            PreviewObject::Sphere => (object(ShapeDesc::Sphere { radius: 1.0 }, vec![]), -1.0),
            PreviewObject::Cube => (
                object(
                    ShapeDesc::Box {
                        size: [2.0, 2.0, 2.0],
                    },
                    vec![
                        TransformDesc::Scale(ScaleBy::Uniform(0.7)),
                        rotate([0.0, 1.0, 0.0], 35.0),
                    ],
                ),
                -0.7,
            ),
            PreviewObject::Plane => (
                object(
                    ShapeDesc::Plane {
                        size: Some([2.0, 2.0]),
                    },
                    vec![
                        TransformDesc::Scale(ScaleBy::Uniform(1.2)),
                        rotate([0.0, 1.0, 0.0], 20.0),
                    ],
                ),
                f64::NAN,
            ),
            PreviewObject::Teapot => (
                object(
                    ShapeDesc::Teapot {
                        resolution: 12,
                        fit: true,
                    },
                    vec![TransformDesc::Scale(ScaleBy::Uniform(1.45))],
                ),
                // The fitted teapot is 0.966 high (the ratio of its height to its width).
                -0.4827 * 1.45,
            ),
            PreviewObject::Obj(path) => (
                object(
                    ShapeDesc::Mesh {
                        path: path.to_string_lossy().into_owned(),
                        fit: true,
                    },
                    vec![],
                ),
                -1.0,
            ),
        };
        let mut objects = vec![main];
        if ground_y.is_finite() {
            objects.push(ObjectDesc {
                shape: ShapeDesc::Plane { size: None },
                material: "ground".into(),
                transform: vec![TransformDesc::Translate(0.0, ground_y, 0.0)],
            });
        }
        let camera = if self.object == PreviewObject::Plane {
            CameraDesc {
                position: [0.0, 3.2, 2.6],
                look_at: [0.0, 0.0, 0.0],
                up: default_up(),
                fov: 40.0,
            }
        } else {
            CameraDesc {
                position: [0.0, 1.3, 4.6],
                look_at: [0.0, -0.1, 0.0],
                up: default_up(),
                fov: 36.0,
            }
        };
        SceneDesc {
            camera,
            lights: vec![
                LightDesc::Point {
                    position: [-4.0, 6.0, 5.0],
                    colour: [1.0, 0.97, 0.92],
                    intensity: 0.95,
                    shadows: true,
                },
                LightDesc::Directional {
                    direction: [-1.0, -0.4, -0.8],
                    colour: [0.85, 0.9, 1.0],
                    intensity: 0.3,
                    shadows: false,
                },
            ],
            materials,
            objects,
            background: default_background(),
            ambient_light: default_ambient_light(),
            size: None,
            samples: None,
        }
    }
}

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
    let options =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let desc: SceneDesc = options
        .from_str(&source.text)
        .map_err(|e| RenderError::Invalid(vec![ron_diagnostic(&source, &e)]))?;
    // The generic tree only locates later problems; a file ron accepts but it does not is
    // still rendered, with locations left out.
    let tree = syntax::parse(&source.text).ok();
    let base = path.parent().unwrap_or(Path::new(""));
    let located = Located {
        source: &source,
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

    /// Resolves a scene description built in code; relative paths are relative to `base`.
    pub fn from_desc(desc: &SceneDesc, base: &Path) -> Result<Scene, RenderError> {
        let mut files = Vec::new();
        resolve(desc, base, None, &mut files)
    }
}

/// The scene file's text and generic tree, to point diagnostics at what they are about.
struct Located<'a> {
    source: &'a Arc<SourceFile>,
    tree: Option<&'a syntax::Value>,
}

/// One step of a path into the scene file's tree.
#[derive(Clone, Copy, Debug)]
enum Key<'a> {
    Field(&'a str),
    Index(usize),
    /// A map entry's value, by its string key.
    Entry(&'a str),
    /// A map entry's key itself.
    EntryName(&'a str),
}

/// The span of the deepest value along `path` that the file has.
fn locate(tree: &syntax::Value, path: &[Key]) -> Span {
    use syntax::ValueKind as V;
    let mut here = tree;
    for key in path {
        let next = match (&here.kind, key) {
            (V::Struct { fields, .. }, Key::Field(name)) => fields
                .iter()
                .find(|(n, _)| n.value == *name)
                .map(|(_, v)| v),
            (V::List(items), Key::Index(i)) | (V::Tuple { items, .. }, Key::Index(i)) => {
                items.get(*i)
            }
            (V::Map(entries), Key::Entry(name)) => entries
                .iter()
                .find(|(k, _)| matches!(&k.kind, V::Str(s) if s == name))
                .map(|(_, v)| v),
            (V::Map(entries), Key::EntryName(name)) => entries
                .iter()
                .find(|(k, _)| matches!(&k.kind, V::Str(s) if s == name))
                .map(|(k, _)| k),
            // A newtype variant such as `Scale(2)`: look inside.
            (V::Tuple { items, .. }, _) if items.len() == 1 => {
                return locate(&items[0], std::slice::from_ref(key)).to(here.span)
            }
            _ => None,
        };
        match next {
            Some(v) => here = v,
            None => break,
        }
    }
    here.span
}

/// Collects scene problems; each becomes a diagnostic against the scene file (or, for a scene
/// built in code, against a placeholder named after its graph).
struct Problems<'a> {
    located: Option<&'a Located<'a>>,
    scene: Vec<Diagnostic>,
    /// Diagnostics about other files (graphs, meshes).
    other: Vec<Diagnostics>,
}

impl Problems<'_> {
    fn add(&mut self, class: DiagnosticClass, path: &[Key], message: String, help: Option<String>) {
        let mut d = Diagnostic::new(class, message);
        if let Some(Located {
            tree: Some(tree), ..
        }) = self.located
        {
            d = d.at(locate(tree, path));
        }
        if let Some(help) = help {
            d = d.help(help);
        }
        self.scene.push(d);
    }

    fn finish(self) -> Result<(), RenderError> {
        if self.scene.is_empty() && self.other.is_empty() {
            return Ok(());
        }
        let mut all = Vec::new();
        if !self.scene.is_empty() {
            // In file order, as the graph checker reports.
            let mut list = self.scene;
            list.sort_by_key(|d| d.span.map_or(usize::MAX, |s| s.start));
            let file = match self.located {
                Some(l) => l.source.clone(),
                None => SourceFile::new("(preview scene)", ""),
            };
            all.push(Diagnostics { file, list });
        }
        all.extend(self.other);
        Err(RenderError::Invalid(all))
    }
}

/// A RON error as a diagnostic at its position.
fn ron_diagnostic(source: &Arc<SourceFile>, e: &ron::error::SpannedError) -> Diagnostics {
    use ron::Error as E;
    let class = match &e.code {
        E::NoSuchStructField { .. } => DiagnosticClass::UnknownArgument,
        E::MissingStructField { .. } => DiagnosticClass::MissingArgument,
        E::NoSuchEnumVariant { .. } => DiagnosticClass::UnknownKind,
        E::DuplicateStructField { .. } => DiagnosticClass::DuplicateName,
        E::InvalidValueForType { .. } | E::ExpectedDifferentLength { .. } => DiagnosticClass::Type,
        _ => DiagnosticClass::Syntax,
    };
    let offset = offset_of(&source.text, e.position.line, e.position.col);
    // ron reports the position after a bad name: underline the name itself.
    let name = match &e.code {
        E::NoSuchEnumVariant { found, .. } | E::NoSuchStructField { found, .. } => {
            Some(found.as_str())
        }
        E::DuplicateStructField { field, .. } => Some(*field),
        _ => None,
    };
    let before = &source.text[..offset];
    let span = name
        .and_then(|n| {
            let start = before.rfind(n)?;
            (offset - start <= n.len() + 16).then(|| Span::new(start, start + n.len()))
        })
        .unwrap_or(Span::new(offset, offset));
    let message = without_rust_names(&e.code.to_string());
    let mut diagnostic = Diagnostic::new(class, format!("scene: {message}")).at(span);
    if class == DiagnosticClass::Syntax {
        diagnostic = diagnostic.help(
            "a scene file is `Scene(camera: Camera(...), lights: [...], materials: {...}, objects: [...])`",
        );
    }
    Diagnostics {
        file: source.clone(),
        list: vec![diagnostic],
    }
}

/// ron's messages name the Rust types the scene is read into (`tuple variant
/// TransformDesc::Translate`, `struct CameraDesc`): an author knows them as `Translate` and
/// `Camera`. Drops every `Path::` qualifier and the `Desc` suffix of the format's type names.
fn without_rust_names(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        let shown = word
            .strip_suffix("Desc")
            .filter(|w| !w.is_empty())
            .unwrap_or(word);
        out.push_str(shown);
        word.clear();
    };
    let mut chars = message.chars().peekable();
    while let Some(c) = chars.next() {
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
        } else if c == ':' && chars.peek() == Some(&':') && !word.is_empty() {
            chars.next();
            word.clear(); // the qualifier goes
        } else {
            flush(&mut word, &mut out);
            out.push(c);
        }
    }
    flush(&mut word, &mut out);
    out
}

/// Byte offset of a 1-based line and column (in characters), clamped to the text.
fn offset_of(text: &str, line: usize, col: usize) -> usize {
    let mut offset = 0;
    for _ in 1..line.max(1) {
        match text[offset..].find('\n') {
            Some(i) => offset += i + 1,
            None => return text.len(),
        }
    }
    let rest = &text[offset..];
    let line_end = rest.find('\n').unwrap_or(rest.len());
    let within: usize = rest[..line_end]
        .char_indices()
        .nth(col.saturating_sub(1))
        .map_or(line_end, |(i, _)| i);
    offset + within
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

fn vec3(v: [f64; 3]) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// Finite also once made f32, as the renderer uses it.
fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| (*x as f32).is_finite())
}

/// A transform list as one affine map (the first step applied first), or a message.
fn transform_of(steps: &[TransformDesc]) -> Result<Affine3A, (usize, String)> {
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

/// The key a compiled texture is shared by.
type TextureKey = (PathBuf, Vec<(String, u64)>);

/// A texture binding found in a material, before compiling.
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
}

fn resolve(
    desc: &SceneDesc,
    base: &Path,
    located: Option<&Located>,
    files: &mut Vec<PathBuf>,
) -> Result<Scene, RenderError> {
    let mut problems = Problems {
        located,
        scene: Vec::new(),
        other: Vec::new(),
    };
    use DiagnosticClass as C;

    // Camera.
    let cam = &desc.camera;
    let position = vec3(cam.position);
    let forward = vec3(cam.look_at) - position;
    let up_hint = vec3(cam.up);
    let camera_path = [Key::Field("camera")];
    if !finite(&cam.position) || !finite(&cam.look_at) || !finite(&cam.up) {
        problems.add(
            C::BadParameter,
            &camera_path,
            "camera: coordinates must be finite".into(),
            None,
        );
    } else if forward.length_squared() == 0.0 {
        problems.add(
            C::BadParameter,
            &[Key::Field("camera"), Key::Field("look_at")],
            "camera: `look_at` is the camera's own position".into(),
            None,
        );
    } else if up_hint.cross(forward).length_squared()
        <= 1e-12 * forward.length_squared() * up_hint.length_squared().max(1e-30)
    {
        problems.add(
            C::BadParameter,
            &[Key::Field("camera"), Key::Field("up")],
            "camera: `up` is zero or parallel to the viewing direction".into(),
            Some("the default `up` is (0, 1, 0); choose another for a camera looking straight up or down".into()),
        );
    }
    if !(cam.fov > 0.0 && cam.fov < 180.0) {
        problems.add(
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
    let camera = Camera {
        position,
        forward,
        right,
        up: right.cross(forward),
        tan_half: ((cam.fov as f32).to_radians() * 0.5).tan(),
    };

    // Lights.
    let mut lights = Vec::new();
    for (i, light) in desc.lights.iter().enumerate() {
        let at = [Key::Field("lights"), Key::Index(i)];
        let (kind, colour, intensity, shadows) = match light {
            LightDesc::Point {
                position,
                colour,
                intensity,
                shadows,
            } => {
                if !finite(position) {
                    problems.add(
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
                    problems.add(
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
            problems.add(
                C::BadParameter,
                &at,
                format!(
                    "light {}: colour and intensity must be finite and not negative",
                    i + 1
                ),
                None,
            );
        }
        lights.push(Light {
            kind,
            radiance: vec3(*colour) * *intensity as f32,
            shadows: *shadows,
        });
    }
    for (what, v) in [
        ("background", &desc.background),
        ("ambient_light", &desc.ambient_light),
    ] {
        if !finite(v) || v.iter().any(|c| *c < 0.0) {
            problems.add(
                C::BadParameter,
                &[Key::Field(what)],
                format!("`{what}` must be finite and not negative"),
                None,
            );
        }
    }
    if let Some((w, h)) = desc.size {
        if let Err(m) = super::check_size(w, h) {
            problems.add(C::BadParameter, &[Key::Field("size")], m, None);
        }
    }
    if let Some(s) = desc.samples {
        if let Err(m) = super::check_samples(s) {
            problems.add(C::BadParameter, &[Key::Field("samples")], m, None);
        }
    }

    // Which materials the objects use, in order of first use.
    let mut used: Vec<&str> = Vec::new();
    for (i, object) in desc.objects.iter().enumerate() {
        let name = object.material.as_str();
        if desc.materials.contains_key(name) {
            if !used.contains(&name) {
                used.push(name);
            }
        } else {
            let known: Vec<&str> = desc.materials.keys().map(|k| k.as_str()).collect();
            let help = match crate::nodes::suggest_from(name, known.iter().copied()) {
                Some(s) => format!("did you mean \"{s}\"?"),
                None if known.is_empty() => {
                    "the scene has no materials: add `materials: { \"name\": Material(...) }`"
                        .into()
                }
                None => format!("its materials are: {}", known.join(", ")),
            };
            problems.add(
                C::UnknownReference,
                &[Key::Field("objects"), Key::Index(i), Key::Field("material")],
                format!("object {}: no material named \"{name}\"", i + 1),
                Some(help),
            );
        }
    }

    // Texture bindings of the used materials.
    let mut bindings: Vec<Binding> = Vec::new();
    let mut constants: Vec<(String, &'static str, Vec3)> = Vec::new();
    for name in &used {
        let m = &desc.materials[*name];
        let channels: [(&'static str, Option<&ChannelDesc>, bool); 4] = [
            ("ambient", m.ambient.as_ref(), false),
            ("diffuse", Some(&m.diffuse), false),
            ("specular", Some(&m.specular), false),
            ("shininess", Some(&m.shininess), true),
        ];
        for (channel, c, scalar) in channels {
            let at = [
                Key::Field("materials"),
                Key::Entry(name),
                Key::Field(channel),
            ];
            match c {
                None => {}
                Some(ChannelDesc::Colour(r, g, b)) => {
                    if scalar {
                        problems.add(
                            C::Type,
                            &at,
                            format!("material \"{name}\": `{channel}` is a number, not a colour"),
                            Some(format!("write `{channel}: Value(...)`")),
                        );
                    } else if !finite(&[*r, *g, *b]) {
                        problems.add(
                            C::BadParameter,
                            &at,
                            format!("material \"{name}\": `{channel}` must be finite"),
                            None,
                        );
                    }
                    constants.push((name.to_string(), channel, vec3([*r, *g, *b])));
                }
                Some(ChannelDesc::Value(v)) => {
                    if !finite(&[*v]) || (scalar && *v < 0.0) {
                        problems.add(
                            C::BadParameter,
                            &at,
                            format!(
                                "material \"{name}\": `{channel}` must be finite{}",
                                if scalar { " and not negative" } else { "" }
                            ),
                            None,
                        );
                    }
                    constants.push((name.to_string(), channel, Vec3::splat(*v as f32)));
                }
                Some(ChannelDesc::Texture {
                    graph,
                    output,
                    set,
                    space,
                    transform,
                    multiply,
                }) => {
                    if let Some((bad, message)) = set
                        .iter()
                        .find(|(_, v)| !v.is_finite())
                        .map(|(k, _)| (k, "must be finite".to_string()))
                    {
                        problems.add(
                            C::BadParameter,
                            &[
                                Key::Field("materials"),
                                Key::Entry(name),
                                Key::Field(channel),
                                Key::Field("set"),
                                Key::Entry(bad),
                            ],
                            format!("material \"{name}\": `{channel}`: param \"{bad}\" {message}"),
                            None,
                        );
                    }
                    if !finite(&[*multiply]) {
                        problems.add(
                            C::BadParameter,
                            &at,
                            format!("material \"{name}\": `{channel}`: `multiply` must be finite"),
                            None,
                        );
                    }
                    if let Err((step, message)) = transform_of(transform) {
                        problems.add(
                            C::BadParameter,
                            &[
                                Key::Field("materials"),
                                Key::Entry(name),
                                Key::Field(channel),
                                Key::Field("transform"),
                                Key::Index(step),
                            ],
                            format!("material \"{name}\": `{channel}`: {message}"),
                            None,
                        );
                    }
                    bindings.push(Binding {
                        material: name,
                        channel,
                        graph,
                        output: output.as_deref(),
                        set,
                        space: *space,
                        transform,
                        multiply: *multiply,
                        scalar,
                    });
                }
            }
        }
    }

    // Check each (graph file, overrides) once.
    let key_of = |b: &Binding| -> TextureKey {
        (
            join_normalised(base, b.graph),
            b.set
                .iter()
                .map(|(k, v)| (k.clone(), v.to_bits()))
                .collect(),
        )
    };
    let mut keys: Vec<TextureKey> = Vec::new();
    for b in &bindings {
        let key = key_of(b);
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    let mut graphs: Vec<Option<CheckedGraph>> = Vec::with_capacity(keys.len());
    for key in &keys {
        let path = &key.0;
        if !files.contains(path) {
            files.push(path.clone());
        }
        let first = bindings
            .iter()
            .find(|b| key_of(b) == *key)
            .expect("every key has a binding");
        let at = [
            Key::Field("materials"),
            Key::Entry(first.material),
            Key::Field(first.channel),
            Key::Field("graph"),
        ];
        let overrides: Vec<(String, f64)> =
            first.set.iter().map(|(k, v)| (k.clone(), *v)).collect();
        match load_graph(path, &CheckOptions { overrides }) {
            Ok(g) => graphs.push(Some(g)),
            Err(LoadError::Io { source, .. }) => {
                problems.add(
                    C::UnknownReference,
                    &at,
                    format!(
                        "material \"{}\": cannot read the graph file {}: {source}",
                        first.material,
                        path.display()
                    ),
                    Some("graph paths are relative to the scene file".into()),
                );
                graphs.push(None);
            }
            Err(LoadError::Invalid(diagnostics)) if problems.located.is_none() => {
                // A preview scene built in code: its overrides are the command line's `--set`,
                // which the checker's own messages name.
                problems.other.push(diagnostics);
                graphs.push(None);
            }
            Err(LoadError::Invalid(diagnostics)) => {
                // An override of a param the graph does not have is the scene's mistake: point
                // at the scene's `set` entry. Everything else is about the graph file.
                let (params, rest): (Vec<Diagnostic>, Vec<Diagnostic>) = diagnostics
                    .list
                    .into_iter()
                    .partition(|d| d.class == C::UnknownParam && d.span.is_none());
                for d in params {
                    let param = first
                        .set
                        .keys()
                        .find(|k| d.message.contains(&format!("\"{k}\"")))
                        .map(String::as_str)
                        .unwrap_or("");
                    problems.add(
                        C::UnknownParam,
                        &[
                            Key::Field("materials"),
                            Key::Entry(first.material),
                            Key::Field(first.channel),
                            Key::Field("set"),
                            Key::EntryName(param),
                        ],
                        format!(
                            "material \"{}\": `{}`: the graph {} has no param \"{param}\"",
                            first.material,
                            first.channel,
                            path.display()
                        ),
                        d.help.clone(),
                    );
                }
                if !rest.is_empty() {
                    problems.other.push(Diagnostics {
                        file: diagnostics.file,
                        list: rest,
                    });
                }
                graphs.push(None);
            }
        }
    }

    // Outputs each key needs, and each binding's output name.
    let mut outputs: Vec<Vec<String>> = vec![Vec::new(); keys.len()];
    let mut chosen: Vec<Option<(usize, String, bool)>> = Vec::with_capacity(bindings.len());
    for b in &bindings {
        let k = keys.iter().position(|key| *key == key_of(b)).expect("key");
        let Some(graph) = &graphs[k] else {
            chosen.push(None);
            continue;
        };
        let at = [
            Key::Field("materials"),
            Key::Entry(b.material),
            Key::Field(b.channel),
            Key::Field("output"),
        ];
        let names: Vec<&str> = graph.outputs.iter().map(|o| o.name.as_str()).collect();
        let name =
            match b.output {
                Some(name) => match graph.output(name) {
                    Some(_) => Some(name.to_string()),
                    None => {
                        let help = match crate::nodes::suggest_from(name, names.iter().copied()) {
                            Some(s) => format!(
                                "did you mean \"{s}\"? Its outputs are: {}",
                                names.join(", ")
                            ),
                            None => format!("its outputs are: {}", names.join(", ")),
                        };
                        problems.add(
                            C::UnknownOutput,
                            &at,
                            format!(
                                "material \"{}\": `{}`: the graph {} has no output \"{name}\"",
                                b.material,
                                b.channel,
                                keys[k].0.display()
                            ),
                            Some(help),
                        );
                        None
                    }
                },
                None => {
                    let pick = if b.scalar {
                        graph
                            .outputs
                            .iter()
                            .find(|o| output_type(graph, o) == Type::Scalar)
                    } else {
                        graph
                            .output("colour")
                            .filter(|o| output_type(graph, o) == Type::Vec3)
                            .or_else(|| {
                                graph
                                    .outputs
                                    .iter()
                                    .find(|o| output_type(graph, o) == Type::Vec3)
                            })
                            .or_else(|| graph.outputs.first())
                    };
                    match pick {
                        Some(o) => Some(o.name.clone()),
                        None => {
                            problems.add(
                                C::UnknownOutput,
                                &[
                                    Key::Field("materials"),
                                    Key::Entry(b.material),
                                    Key::Field(b.channel),
                                ],
                                format!(
                                "material \"{}\": `{}` needs a {} output and the graph {} has none",
                                b.material,
                                b.channel,
                                if b.scalar { "scalar" } else { "colour or scalar" },
                                keys[k].0.display()
                            ),
                                Some(format!("its outputs are: {}", names.join(", "))),
                            );
                            None
                        }
                    }
                }
            };
        let Some(name) = name else {
            chosen.push(None);
            continue;
        };
        let ty = graph
            .output(&name)
            .map_or(Type::Scalar, |o| output_type(graph, o));
        if b.scalar && ty == Type::Vec3 {
            problems.add(
                C::Type,
                &at,
                format!(
                    "material \"{}\": `{}` is a number, and output \"{name}\" is a colour",
                    b.material, b.channel
                ),
                Some("bind a scalar output".into()),
            );
            chosen.push(None);
            continue;
        }
        if !outputs[k].contains(&name) {
            outputs[k].push(name.clone());
        }
        chosen.push(Some((k, name, ty == Type::Vec3)));
    }

    // Shapes (meshes loaded once per file, teapots once per resolution).
    let mut meshes: Vec<(String, Arc<Mesh>)> = Vec::new();
    let mut shapes: Vec<Option<Shape>> = Vec::new();
    let mut transforms: Vec<Affine3A> = Vec::new();
    for (i, object) in desc.objects.iter().enumerate() {
        let at = |field| {
            [
                Key::Field("objects"),
                Key::Index(i),
                Key::Field("shape"),
                Key::Field(field),
            ]
        };
        let bad = |problems: &mut Problems, field, message: String| {
            problems.add(
                C::BadParameter,
                &at(field),
                format!("object {}: {message}", i + 1),
                None,
            )
        };
        let shape = match &object.shape {
            ShapeDesc::Sphere { radius } => {
                if !(finite(&[*radius]) && *radius > 0.0) {
                    bad(
                        &mut problems,
                        "radius",
                        format!("the sphere's radius is {radius}; it must be positive"),
                    );
                }
                Some(Shape::Sphere(*radius as f32))
            }
            ShapeDesc::Box { size } => {
                if !(finite(size) && size.iter().all(|s| *s > 0.0)) {
                    bad(
                        &mut problems,
                        "size",
                        "the box's size must be positive along every axis".into(),
                    );
                }
                Some(Shape::Box(vec3(*size) * 0.5))
            }
            ShapeDesc::Plane { size } => {
                if let Some(s) = size {
                    if !(finite(s) && s.iter().all(|v| *v > 0.0)) {
                        bad(
                            &mut problems,
                            "size",
                            "the plane's size must be positive".into(),
                        );
                    }
                }
                Some(Shape::Plane(size.map(|[x, z]| [x as f32, z as f32])))
            }
            ShapeDesc::Teapot { resolution, fit } => {
                if !(1..=teapot::MAX_RESOLUTION).contains(resolution) {
                    bad(
                        &mut problems,
                        "resolution",
                        format!(
                            "the teapot's resolution is {resolution}; it must be 1 to {}",
                            teapot::MAX_RESOLUTION
                        ),
                    );
                    None
                } else {
                    let key = format!("teapot:{resolution}:{fit}");
                    Some(Shape::Mesh(cached(&mut meshes, key, || {
                        let mesh = teapot::tessellate(*resolution);
                        if *fit {
                            mesh.fitted()
                        } else {
                            mesh
                        }
                    })))
                }
            }
            ShapeDesc::Mesh { path, fit } => {
                let full = join_normalised(base, path);
                if !files.contains(&full) {
                    files.push(full.clone());
                }
                let key = format!("obj:{}:{fit}", full.display());
                if let Some((_, m)) = meshes.iter().find(|(k, _)| *k == key) {
                    Some(Shape::Mesh(m.clone()))
                } else {
                    match load_mesh(&full) {
                        Ok(mesh) => {
                            let mesh = Arc::new(if *fit { mesh.fitted() } else { mesh });
                            if mesh.triangle_count() == 0 {
                                bad(
                                    &mut problems,
                                    "path",
                                    format!("{} has no faces", full.display()),
                                );
                            }
                            meshes.push((key, mesh.clone()));
                            Some(Shape::Mesh(mesh))
                        }
                        Err(MeshError::Io(e)) => {
                            problems.add(
                                C::UnknownReference,
                                &at("path"),
                                format!(
                                    "object {}: cannot read the mesh {}: {e}",
                                    i + 1,
                                    full.display()
                                ),
                                Some("mesh paths are relative to the scene file".into()),
                            );
                            None
                        }
                        Err(MeshError::Invalid(d)) => {
                            problems.other.push(d);
                            None
                        }
                    }
                }
            }
        };
        shapes.push(shape);
        match transform_of(&object.transform) {
            Ok(m) => transforms.push(m),
            Err((step, message)) => {
                problems.add(
                    C::BadParameter,
                    &[
                        Key::Field("objects"),
                        Key::Index(i),
                        Key::Field("transform"),
                        Key::Index(step),
                    ],
                    format!("object {}: {message}", i + 1),
                    None,
                );
                transforms.push(Affine3A::IDENTITY);
            }
        }
    }

    problems.finish()?;

    // Compile each texture for exactly the outputs bound to it.
    let mut textures = Vec::with_capacity(keys.len());
    for ((key, graph), outputs) in keys.iter().zip(graphs).zip(outputs) {
        let graph = graph.expect("checked above");
        let tape = compile(
            &graph,
            &CompileOptions {
                outputs: outputs.clone(),
                spacing: None,
            },
        )
        .map_err(|d| RenderError::Invalid(vec![d]))?;
        textures.push(CompiledTexture {
            graph: key.0.clone(),
            overrides: key
                .1
                .iter()
                .map(|(k, v)| (k.clone(), f64::from_bits(*v)))
                .collect(),
            outputs,
            tape,
        });
    }

    // Materials and their evaluation groups.
    let mut groups: Vec<EvalGroup> = Vec::new();
    let mut group_keys: Vec<(usize, Space, [u32; 12])> = Vec::new();
    let mut materials: Vec<Material> = Vec::new();
    for name in &used {
        let mut material = Material {
            ambient: Channel::Constant(Vec3::ZERO),
            diffuse: Channel::Constant(Vec3::ZERO),
            specular: Channel::Constant(Vec3::ZERO),
            shininess: Channel::Constant(Vec3::ZERO),
            groups: Vec::new(),
        };
        let mut has_ambient = false;
        for (c, value) in constants
            .iter()
            .filter(|c| c.0 == *name)
            .map(|c| (c.1, c.2))
        {
            *channel_mut(&mut material, c) = Channel::Constant(value);
            has_ambient |= c == "ambient";
        }
        for (b, chosen) in bindings
            .iter()
            .zip(&chosen)
            .filter(|(b, _)| b.material == *name)
        {
            let (k, output, vec3) = chosen.as_ref().expect("checked above");
            let transform = transform_of(b.transform).expect("checked above");
            let bits: [u32; 12] = std::array::from_fn(|i| transform.to_cols_array()[i].to_bits());
            let gkey = (*k, b.space, bits);
            let g = match group_keys.iter().position(|x| *x == gkey) {
                Some(g) => g,
                None => {
                    group_keys.push(gkey);
                    groups.push(EvalGroup {
                        texture: *k,
                        space: b.space,
                        transform,
                    });
                    groups.len() - 1
                }
            };
            let slot = match material.groups.iter().position(|x| *x == g) {
                Some(s) => s,
                None => {
                    material.groups.push(g);
                    material.groups.len() - 1
                }
            };
            let tape = &textures[*k].tape;
            let channel = tape.output(output).expect("compiled").first_channel;
            *channel_mut(&mut material, b.channel) = Channel::Texture {
                slot,
                channel,
                vec3: *vec3,
                multiply: b.multiply as f32,
            };
            has_ambient |= b.channel == "ambient";
        }
        if !has_ambient {
            material.ambient = material.diffuse;
        }
        materials.push(material);
    }

    let objects = desc
        .objects
        .iter()
        .zip(shapes)
        .zip(transforms)
        .map(|((o, shape), to_world)| {
            let material = used
                .iter()
                .position(|m| *m == o.material)
                .expect("checked above");
            let to_local = to_world.inverse();
            Object {
                shape: shape.expect("checked above"),
                to_local,
                normal_to_world: Mat3::from(to_local.matrix3).transpose(),
                material,
            }
        })
        .collect();

    Ok(Scene {
        camera,
        background: vec3(desc.background),
        ambient_light: vec3(desc.ambient_light),
        lights,
        materials,
        objects,
        groups,
        textures,
        files: files.clone(),
        size: desc.size,
        samples: desc.samples,
    })
}

fn output_type(graph: &CheckedGraph, output: &crate::graph::Output) -> Type {
    graph.nodes[output.node as usize].ty
}

fn channel_mut<'a>(m: &'a mut Material, name: &str) -> &'a mut Channel {
    match name {
        "ambient" => &mut m.ambient,
        "diffuse" => &mut m.diffuse,
        "specular" => &mut m.specular,
        _ => &mut m.shininess,
    }
}

fn cached(
    meshes: &mut Vec<(String, Arc<Mesh>)>,
    key: String,
    make: impl FnOnce() -> Mesh,
) -> Arc<Mesh> {
    if let Some((_, m)) = meshes.iter().find(|(k, _)| *k == key) {
        return m.clone();
    }
    let mesh = Arc::new(make());
    meshes.push((key, mesh.clone()));
    mesh
}

enum MeshError {
    Io(std::io::Error),
    Invalid(Diagnostics),
}

/// Reads an OBJ file; a problem in it becomes a diagnostic at its line and column.
fn load_mesh(path: &Path) -> Result<Mesh, MeshError> {
    let text = std::fs::read(path).map_err(MeshError::Io)?;
    let text = String::from_utf8(text).map_err(|e| {
        MeshError::Io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text: {e}"),
        ))
    })?;
    match geometry::parse_obj(&text) {
        Ok(triangles) => Ok(Mesh::new(triangles)),
        Err(e) => {
            let offset = offset_of(&text, e.line, e.column);
            let file = SourceFile::new(path.display().to_string(), text);
            Err(MeshError::Invalid(Diagnostics {
                file,
                list: vec![
                    Diagnostic::new(DiagnosticClass::Syntax, format!("OBJ: {}", e.message))
                        .at(Span::new(offset, offset)),
                ],
            }))
        }
    }
}

#[cfg(test)]
mod tests {
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
            materials: { "m": Material(diffuse: Colour(1, 0, 0), shininess: Value(10)),
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
