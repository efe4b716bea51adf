//! The object phases: each object's shape (meshes loaded once per file, teapots tessellated once
//! per resolution) and transform, and, once everything checks, the objects placed in the world.

use super::join_normalised;
use super::{finite, transform_of, vec3, Resolver};
use crate::diagnostic::{Diagnostic, DiagnosticClass as C, Diagnostics, SourceFile, Span};
use crate::render::geometry::{self, Mesh};
use crate::render::scene::desc::{ShapeDesc, TransformDesc};
use crate::render::scene::diagnostics::{offset_of, Key};
use crate::render::scene::resolved::{Object, Shape};
use crate::render::teapot;
use glam::{Affine3A, Mat3};
use std::path::Path;
use std::sync::Arc;

impl Resolver<'_> {
    /// Checks and resolves every object's shape and transform (object → world).
    pub(super) fn objects(&mut self) -> Vec<(Option<Shape>, Affine3A)> {
        let desc = self.desc;
        let mut objects = Vec::with_capacity(desc.objects.len());
        for (i, object) in desc.objects.iter().enumerate() {
            let shape = self.shape(i, &object.shape);
            let transform = self.object_transform(i, &object.transform);
            objects.push((shape, transform));
        }
        objects
    }

    /// Checks and resolves object `i`'s shape; `None` where it cannot be made.
    fn shape(&mut self, i: usize, shape: &ShapeDesc) -> Option<Shape> {
        match shape {
            ShapeDesc::Sphere { radius } => {
                if !(finite(&[*radius]) && *radius > 0.0) {
                    self.bad_shape(
                        i,
                        "radius",
                        format!("the sphere's radius is {radius}; it must be positive"),
                    );
                }
                Some(Shape::Sphere(*radius as f32))
            }
            ShapeDesc::Box { size } => {
                if !(finite(size) && size.iter().all(|s| *s > 0.0)) {
                    self.bad_shape(
                        i,
                        "size",
                        "the box's size must be positive along every axis".into(),
                    );
                }
                Some(Shape::Box(vec3(*size) * 0.5))
            }
            ShapeDesc::Plane { size } => {
                if let Some(s) = size {
                    if !(finite(s) && s.iter().all(|v| *v > 0.0)) {
                        self.bad_shape(i, "size", "the plane's size must be positive".into());
                    }
                }
                Some(Shape::Plane(size.map(|[x, z]| [x as f32, z as f32])))
            }
            ShapeDesc::Teapot { resolution, fit } => self.teapot(i, *resolution, *fit),
            ShapeDesc::Mesh { path, fit } => self.mesh(i, path, *fit),
        }
    }

    /// Object `i`'s teapot, tessellated once per (resolution, fit).
    fn teapot(&mut self, i: usize, resolution: u32, fit: bool) -> Option<Shape> {
        if !(1..=teapot::MAX_RESOLUTION).contains(&resolution) {
            self.bad_shape(
                i,
                "resolution",
                format!(
                    "the teapot's resolution is {resolution}; it must be 1 to {}",
                    teapot::MAX_RESOLUTION
                ),
            );
            return None;
        }
        let key = format!("teapot:{resolution}:{fit}");
        Some(Shape::Mesh(cached(&mut self.meshes, key, || {
            let mesh = teapot::tessellate(resolution);
            if fit {
                mesh.fitted()
            } else {
                mesh
            }
        })))
    }

    /// Object `i`'s OBJ mesh (`path` relative to the scene file), loaded once per (file, fit).
    fn mesh(&mut self, i: usize, path: &str, fit: bool) -> Option<Shape> {
        let full = join_normalised(self.base, path);
        if !self.files.contains(&full) {
            self.files.push(full.clone());
        }
        let key = format!("obj:{}:{fit}", full.display());
        if let Some((_, m)) = self.meshes.iter().find(|(k, _)| *k == key) {
            return Some(Shape::Mesh(m.clone()));
        }
        match load_mesh(&full) {
            Ok(mesh) => {
                let mesh = Arc::new(if fit { mesh.fitted() } else { mesh });
                if mesh.triangle_count() == 0 {
                    self.bad_shape(i, "path", format!("{} has no faces", full.display()));
                }
                self.meshes.push((key, mesh.clone()));
                Some(Shape::Mesh(mesh))
            }
            Err(MeshError::Io(e)) => {
                self.problems.add(
                    C::UnknownReference,
                    &shape_at(i, "path"),
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
                self.problems.other.push(d);
                None
            }
        }
    }

    /// Reports a bad value of object `i`'s shape's `field`.
    fn bad_shape(&mut self, i: usize, field: &str, message: String) {
        self.problems.add(
            C::BadParameter,
            &shape_at(i, field),
            format!("object {}: {message}", i + 1),
            None,
        );
    }

    /// Object `i`'s transform (object → world); the identity after a problem.
    fn object_transform(&mut self, i: usize, steps: &[TransformDesc]) -> Affine3A {
        match transform_of(steps) {
            Ok(m) => m,
            Err((step, message)) => {
                self.problems.add(
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
                Affine3A::IDENTITY
            }
        }
    }

    /// The objects ready to render, from their checked shapes and transforms.
    pub(super) fn place_objects(&self, objects: Vec<(Option<Shape>, Affine3A)>) -> Vec<Object> {
        self.desc
            .objects
            .iter()
            .zip(objects)
            .map(|(o, (shape, to_world))| {
                let material = self
                    .used
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
            .collect()
    }
}

/// Where field `field` of object `i`'s shape is in the scene file.
fn shape_at(i: usize, field: &str) -> [Key<'_>; 4] {
    [
        Key::Field("objects"),
        Key::Index(i),
        Key::Field("shape"),
        Key::Field(field),
    ]
}

/// The mesh stored under `key`, made by `make` (and stored) the first time.
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

/// Why an OBJ file gave no mesh: it cannot be read, or it is not valid OBJ.
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
                list: vec![Diagnostic::new(C::Syntax, format!("OBJ: {}", e.message))
                    .at(Span::new(offset, offset))],
            }))
        }
    }
}
