//! Reading a model for `bake --mesh`: glTF 2.0 (`.gltf` with its buffers, or `.glb`) through
//! the `gltf` crate, Wavefront OBJ through `tobj`, into triangle lists with positions, normals
//! and UVs in glTF's convention (origin at the top-left, v downwards; OBJ's `vt` is flipped).

use std::path::{Path, PathBuf};

/// The space the graph is evaluated in: the mesh's object space as stored, or the default
/// scene's world space (node transforms applied).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Space {
    #[default]
    Object,
    World,
}

/// One triangle list: a glTF primitive (in world space: one per node instance) or an OBJ
/// object.
#[derive(Clone, Debug)]
pub struct Part {
    /// How messages name it: `mesh "Name" primitive 0` or `object "Name"`.
    pub name: String,
    pub positions: Vec<[f64; 3]>,
    /// Unit vertex normals (flat ones, the vertices unwelded, where the file has none: what
    /// glTF asks a client to use then).
    pub normals: Vec<[f64; 3]>,
    /// UVs in glTF's convention.
    pub uvs: Vec<[f64; 2]>,
    pub triangles: Vec<[u32; 3]>,
}

/// A model's triangle lists, in file order.
#[derive(Clone, Debug)]
pub struct Model {
    pub path: PathBuf,
    pub parts: Vec<Part>,
    /// Primitives that are not triangle lists (points, lines, strips, fans), left out.
    pub skipped: usize,
}

impl Model {
    pub fn triangles(&self) -> usize {
        self.parts.iter().map(|p| p.triangles.len()).sum()
    }
}

/// Why a model could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The file is missing or unreadable (exit code 2).
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file is not a model texgraph can parse (exit code 2).
    #[error("{}: {message}", path.display())]
    Corrupt { path: PathBuf, message: String },
    /// The model parses but cannot be baked onto: no UVs, non-finite positions, no triangles
    /// (exit code 1).
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
}

impl ModelError {
    /// The CLI exit code: 1 for a model that cannot be baked onto, 2 for a missing or corrupt
    /// file.
    pub fn exit_code(&self) -> u8 {
        match self {
            ModelError::Invalid { .. } => 1,
            _ => 2,
        }
    }
}

/// Reads `path` by its extension (`.gltf`, `.glb`, `.obj`, any case).
pub fn load_model(path: &Path, space: Space) -> Result<Model, ModelError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let bytes = std::fs::read(path).map_err(|source| ModelError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let model = match extension.as_deref() {
        Some("gltf" | "glb") => read_gltf(path, &bytes, space)?,
        Some("obj") => read_obj(path, &bytes)?,
        _ => {
            return Err(ModelError::Corrupt {
                path: path.to_path_buf(),
                message: "not a model texgraph reads: give a .gltf, .glb or .obj file".into(),
            })
        }
    };
    check_model(&model)?;
    Ok(model)
}

/// What every model must have: triangles, and finite positions and UVs.
fn check_model(model: &Model) -> Result<(), ModelError> {
    let invalid = |message: String| ModelError::Invalid {
        path: model.path.clone(),
        message,
    };
    if model.triangles() == 0 {
        return Err(invalid("the model has no triangles".into()));
    }
    for part in &model.parts {
        let vertex = [
            ("position", first_non_finite(&part.positions)),
            ("texture coordinate", first_non_finite(&part.uvs)),
        ];
        if let Some((what, i)) = vertex.into_iter().find_map(|(w, i)| i.map(|i| (w, i))) {
            return Err(invalid(format!(
                "{}: vertex {i} has a non-finite {what}",
                part.name
            )));
        }
    }
    Ok(())
}

/// The first vertex with a component that is not finite.
fn first_non_finite<const N: usize>(values: &[[f64; N]]) -> Option<usize> {
    values.iter().position(|v| v.iter().any(|c| !c.is_finite()))
}

/// A glTF file's buffers: the GLB's binary chunk, `data:` URIs, files beside the `.gltf`.
fn gltf_buffers(path: &Path, gltf: &gltf::Gltf) -> Result<Vec<Vec<u8>>, ModelError> {
    use base64::Engine;
    let corrupt = |message: String| ModelError::Corrupt {
        path: path.to_path_buf(),
        message,
    };
    let mut buffers = Vec::new();
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                corrupt("buffer 0 refers to a GLB binary chunk, but there is none".into())
            })?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                let (_, payload) = uri.split_once(";base64,").ok_or_else(|| {
                    corrupt(format!(
                        "buffer {}: a data URI that is not base64",
                        buffer.index()
                    ))
                })?;
                base64::engine::general_purpose::STANDARD
                    .decode(payload)
                    .map_err(|e| corrupt(format!("buffer {}: {e}", buffer.index())))?
            }
            gltf::buffer::Source::Uri(uri) => {
                if uri.contains("://") {
                    return Err(corrupt(format!(
                        "buffer {} is at {uri}: texgraph reads buffers from files beside the model only",
                        buffer.index()
                    )));
                }
                let file = path
                    .parent()
                    .unwrap_or(Path::new("."))
                    .join(percent_decode(uri));
                std::fs::read(&file).map_err(|source| ModelError::Io { path: file, source })?
            }
        };
        if data.len() < buffer.length() {
            return Err(corrupt(format!(
                "buffer {} holds {} bytes, its byteLength says {}",
                buffer.index(),
                data.len(),
                buffer.length()
            )));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// `%20` and the like in a relative URI (glTF URIs are RFC 3986 references).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn read_gltf(path: &Path, bytes: &[u8], space: Space) -> Result<Model, ModelError> {
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| ModelError::Corrupt {
        path: path.to_path_buf(),
        message: format!("not a valid glTF 2.0 file: {e}"),
    })?;
    let buffers = gltf_buffers(path, &gltf)?;
    let document = &gltf.document;
    // The meshes to bake, each with the transform that takes it into the evaluation space:
    // the default scene's (or the first scene's) node tree, else the first mesh.
    let mut instances: Vec<(gltf::Mesh, glam::DMat4)> = Vec::new();
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    if let Some(scene) = scene {
        let mut stack: Vec<(gltf::Node, glam::DMat4)> =
            scene.nodes().map(|n| (n, glam::DMat4::IDENTITY)).collect();
        stack.reverse();
        while let Some((node, parent)) = stack.pop() {
            let local = glam::Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
            let world = parent * local;
            if let Some(mesh) = node.mesh() {
                match space {
                    Space::World => instances.push((mesh, world)),
                    Space::Object if !instances.iter().any(|(m, _)| m.index() == mesh.index()) => {
                        instances.push((mesh, glam::DMat4::IDENTITY))
                    }
                    Space::Object => {}
                }
            }
            let children: Vec<_> = node.children().map(|c| (c, world)).collect();
            stack.extend(children.into_iter().rev());
        }
    }
    if instances.is_empty() {
        if let Some(mesh) = document.meshes().next() {
            instances.push((mesh, glam::DMat4::IDENTITY));
        }
    }
    let mut model = Model {
        path: path.to_path_buf(),
        parts: Vec::new(),
        skipped: 0,
    };
    for (mesh, transform) in instances {
        for primitive in mesh.primitives() {
            if primitive.mode() != gltf::mesh::Mode::Triangles {
                model.skipped += 1;
                continue;
            }
            let name = match mesh.name() {
                Some(n) => format!("mesh \"{n}\" primitive {}", primitive.index()),
                None => format!("mesh {} primitive {}", mesh.index(), primitive.index()),
            };
            let part = gltf_part(path, &buffers, &primitive, name, transform)?;
            model.parts.push(part);
        }
    }
    Ok(model)
}

/// One triangle primitive's vertices, transformed by `transform` (normals by its inverse
/// transpose).
fn gltf_part(
    path: &Path,
    buffers: &[Vec<u8>],
    primitive: &gltf::Primitive,
    name: String,
    transform: glam::DMat4,
) -> Result<Part, ModelError> {
    let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
    let invalid = |message: String| ModelError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    let positions: Vec<[f64; 3]> = reader
        .read_positions()
        .ok_or_else(|| invalid(format!("{name} has no POSITION attribute")))?
        .map(|p| {
            transform
                .transform_point3(glam::Vec3::from(p).as_dvec3())
                .to_array()
        })
        .collect();
    let uvs: Vec<[f64; 2]> = reader
        .read_tex_coords(0)
        .ok_or_else(|| {
            invalid(format!(
                "{name} has no TEXCOORD_0 attribute: a mesh bake needs texture coordinates (a UV layout)"
            ))
        })?
        .into_f32()
        .map(|[u, v]| [f64::from(u), f64::from(v)])
        .collect();
    let normal_matrix = glam::DMat3::from_mat4(transform).inverse().transpose();
    let normals: Option<Vec<[f64; 3]>> = reader.read_normals().map(|ns| {
        ns.map(|n| {
            normal_matrix
                .mul_vec3(glam::Vec3::from(n).as_dvec3())
                .normalize_or_zero()
                .to_array()
        })
        .collect()
    });
    let count = positions.len();
    let triangles: Vec<[u32; 3]> = match reader.read_indices() {
        Some(indices) => {
            let flat: Vec<u32> = indices.into_u32().collect();
            flat.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
        }
        None => (0..count as u32 / 3)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect(),
    };
    if uvs.len() != count || normals.as_ref().is_some_and(|n| n.len() != count) {
        return Err(ModelError::Corrupt {
            path: path.to_path_buf(),
            message: format!("{name}: its attributes have different vertex counts"),
        });
    }
    if let Some(t) = triangles.iter().flatten().find(|&&i| i as usize >= count) {
        return Err(ModelError::Corrupt {
            path: path.to_path_buf(),
            message: format!("{name}: index {t} is past its {count} vertices"),
        });
    }
    Ok(with_normals(Part {
        name,
        positions,
        normals: normals.unwrap_or_default(),
        uvs,
        triangles,
    }))
}

fn read_obj(path: &Path, bytes: &[u8]) -> Result<Model, ModelError> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // Materials are not read (a mesh bake makes its own); `mtllib` lines are ignored.
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &options, |_| {
        Ok(Default::default())
    })
    .map_err(|e| ModelError::Corrupt {
        path: path.to_path_buf(),
        message: format!("not a valid OBJ file: {e}"),
    })?;
    let mut model = Model {
        path: path.to_path_buf(),
        parts: Vec::new(),
        skipped: 0,
    };
    for object in models {
        let mesh = &object.mesh;
        if mesh.indices.is_empty() {
            continue;
        }
        let name = format!("object \"{}\"", object.name);
        if mesh.texcoords.is_empty() {
            return Err(ModelError::Invalid {
                path: path.to_path_buf(),
                message: format!(
                    "{name} has no texture coordinates (`vt`): a mesh bake needs a UV layout"
                ),
            });
        }
        let positions: Vec<[f64; 3]> = mesh
            .positions
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]].map(f64::from))
            .collect();
        // OBJ's v runs upwards: flipped into glTF's convention.
        let uvs = mesh
            .texcoords
            .chunks_exact(2)
            .map(|t| [f64::from(t[0]), 1.0 - f64::from(t[1])])
            .collect();
        let normals = mesh
            .normals
            .chunks_exact(3)
            .map(|n| {
                glam::DVec3::new(n[0].into(), n[1].into(), n[2].into())
                    .normalize_or_zero()
                    .to_array()
            })
            .collect();
        let triangles = mesh
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        model.parts.push(with_normals(Part {
            name,
            positions,
            normals,
            uvs,
            triangles,
        }));
    }
    Ok(model)
}

/// A part whose file has no normals (or not one per vertex) gets flat ones: every triangle its
/// own three vertices with its face normal.
fn with_normals(part: Part) -> Part {
    if part.normals.len() == part.positions.len() && !part.normals.is_empty() {
        return part;
    }
    let mut flat = Part {
        name: part.name,
        positions: Vec::with_capacity(part.triangles.len() * 3),
        normals: Vec::with_capacity(part.triangles.len() * 3),
        uvs: Vec::with_capacity(part.triangles.len() * 3),
        triangles: Vec::with_capacity(part.triangles.len()),
    };
    for t in &part.triangles {
        let p = t.map(|i| glam::DVec3::from(part.positions[i as usize]));
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        let first = flat.positions.len() as u32;
        for &i in t {
            flat.positions.push(part.positions[i as usize]);
            flat.uvs.push(part.uvs[i as usize]);
            flat.normals.push(n.to_array());
        }
        flat.triangles.push([first, first + 1, first + 2]);
    }
    flat
}
