//! The default preview scene of a graph file (`texgraph render FILE.ron`): the object, a ground
//! plane, a key light with shadows and a fill light.

use super::desc::{
    default_ambient_light, default_background, default_up, BumpDesc, CameraDesc, ChannelDesc,
    HeightDesc, HeightTexture, LightDesc, MaterialDesc, ObjectDesc, ScaleBy, SceneDesc, ShapeDesc,
    Space, TransformDesc,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
    /// `--bump OUTPUT --bump-strength S`: the object's material bumped by a scalar output.
    pub bump: Option<PreviewBump>,
}

/// The bump of a graph's preview: a scalar output of the graph as the height, evaluated where
/// the diffuse texture is (same `set`, `space` and `transform`).
#[derive(Clone, Debug, PartialEq)]
pub struct PreviewBump {
    pub output: String,
    pub strength: f64,
}

impl PreviewDefaults {
    /// The scene description of the default preview: the object (about 2 units across, its
    /// object space [-1, 1]^3 mapped onto the texture's default bake region [0, 1]^3), a ground
    /// plane under it, a key light with shadows and a fill light.
    pub fn scene_desc(&self, graph: &Path) -> SceneDesc {
        let graph = graph.to_string_lossy().into_owned();
        // [-1, 1]^3 → [0, 1]^3, the default bake region.
        let transform = vec![
            TransformDesc::Scale(ScaleBy::Uniform(0.5)),
            TransformDesc::Translate(0.5, 0.5, 0.5),
        ];
        let bump = self.bump.as_ref().map(|b| BumpDesc {
            height: HeightDesc::Texture(HeightTexture {
                graph: graph.clone(),
                output: Some(b.output.clone()),
                set: self.overrides.iter().cloned().collect(),
                space: self.space,
                transform: transform.clone(),
                multiply: 1.0,
            }),
            strength: b.strength,
        });
        let texture = ChannelDesc::Texture {
            graph,
            output: self.output.clone(),
            set: self.overrides.iter().cloned().collect(),
            space: self.space,
            transform,
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
                bump,
            },
        );
        materials.insert(
            "ground".to_string(),
            MaterialDesc {
                ambient: None,
                diffuse: ChannelDesc::Colour(0.55, 0.55, 0.55),
                specular: ChannelDesc::Value(0.0),
                shininess: ChannelDesc::Value(1.0),
                bump: None,
            },
        );
        let (main, ground_y) = self.main_object();
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
            probe_nodes: false,
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

    /// The previewed object, with the texture's material, and its lowest y (where the ground
    /// goes; NaN for no ground).
    fn main_object(&self) -> (ObjectDesc, f64) {
        let object = |shape, transform| ObjectDesc {
            shape,
            material: "texture".into(),
            transform,
        };
        let rotate = |axis: [f64; 3], degrees| TransformDesc::Rotate { axis, degrees };
        match &self.object {
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
        }
    }
}
