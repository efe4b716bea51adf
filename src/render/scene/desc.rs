//! The scene file format: the types `ron` deserialises a scene file into (docs/scenes.md
//! describes every field).

use serde::Deserialize;
use std::collections::BTreeMap;

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

pub(super) fn default_background() -> [f64; 3] {
    [0.18, 0.19, 0.21]
}
pub(super) fn default_ambient_light() -> [f64; 3] {
    [0.12, 0.12, 0.12]
}
pub(super) fn default_up() -> [f64; 3] {
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
