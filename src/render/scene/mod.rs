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

mod desc;
mod diagnostics;
mod preview;
mod resolve;
pub(super) mod resolved;

pub use desc::{
    BumpDesc, CameraDesc, ChannelDesc, HeightDesc, HeightTexture, LightDesc, MaterialDesc,
    ObjectDesc, ScaleBy, SceneDesc, ShapeDesc, Space, TransformDesc,
};
pub use preview::{PreviewBump, PreviewDefaults, PreviewObject};
pub(crate) use resolved::{Channel, EvalGroup, LightKind, Material, Object, Shape};
pub use resolved::{CompiledTexture, Scene};

use super::error::RenderError;
use crate::diagnostic::SourceFile;
use crate::source::read_source;
use crate::syntax;
use diagnostics::{ron_diagnostic, Located};
pub(crate) use resolve::Checked;
use resolve::{resolve, resolve_with};
use std::path::{Path, PathBuf};
use std::sync::Arc;

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
    /// `files`, also when it fails (what to watch for a fix), and taking the graph `checked`
    /// where a texture names its file with its overrides instead of reading the file again.
    #[cfg_attr(not(feature = "serve"), allow(dead_code))]
    pub(crate) fn from_desc_tracking(
        desc: &SceneDesc,
        base: &Path,
        checked: Checked,
        files: &mut Vec<PathBuf>,
    ) -> Result<Scene, RenderError> {
        resolve_with(desc, base, checked, files)
    }

    /// Resolves a scene description built in code; relative paths are relative to `base`.
    pub fn from_desc(desc: &SceneDesc, base: &Path) -> Result<Scene, RenderError> {
        let mut files = Vec::new();
        resolve(desc, base, None, &mut files)
    }
}

#[cfg(test)]
mod tests {
    use super::diagnostics::{offset_of, without_rust_names};
    use super::resolve::{join_normalised, transform_of};
    use super::*;
    use glam::Vec3;

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
