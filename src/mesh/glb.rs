//! The texture set as an engine-ready glTF 2.0 asset (`bake --mesh --gltf`): the baked mesh
//! (positions in the space baked, normals, UVs, and `TANGENT` from the same MikkTSpace frames
//! as the normal map) with one metallic-roughness material whose textures are embedded PNGs.
//! The JSON is written with serde_json and the container by the `gltf` crate's `Glb`.

use super::bake::{TextureImage, TextureSet};
use super::model::Model;
use super::tangent::GreenAxis;
use crate::graph::Type;
use serde_json::{json, Value};

/// Which baked images the material uses.
#[derive(Clone, Debug, Default)]
pub struct MaterialImages<'a> {
    pub base_color: Option<&'a TextureImage>,
    pub normal: Option<&'a TextureImage>,
    pub roughness: Option<&'a TextureImage>,
    pub metallic: Option<&'a TextureImage>,
    /// The green axis the normal image was encoded with (glTF wants up: flipped if down).
    pub normal_green: GreenAxis,
}

/// The binary chunk and the JSON arrays that index into it.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    images: Vec<Value>,
}

impl Builder {
    /// Appends `bytes` as a buffer view (4-byte aligned); returns its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut view =
            json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(view);
        self.views.len() - 1
    }

    /// A float vector attribute (`VEC2`, `VEC3`, `VEC4`); POSITION gets its min and max.
    fn floats<const N: usize>(&mut self, data: &[[f32; N]], bounds: bool) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let view = self.view(&bytes, Some(34962));
        let mut accessor = json!({
            "bufferView": view, "componentType": 5126, "count": data.len(),
            "type": format!("VEC{N}"),
        });
        if bounds {
            let min: Vec<f32> = (0..N)
                .map(|c| data.iter().map(|v| v[c]).fold(f32::INFINITY, f32::min))
                .collect();
            let max: Vec<f32> = (0..N)
                .map(|c| data.iter().map(|v| v[c]).fold(f32::NEG_INFINITY, f32::max))
                .collect();
            accessor["min"] = json!(min);
            accessor["max"] = json!(max);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34963));
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }

    /// An embedded PNG image; returns its index.
    fn png(&mut self, bytes: &[u8]) -> usize {
        let view = self.view(bytes, None);
        self.images
            .push(json!({"bufferView": view, "mimeType": "image/png"}));
        self.images.len() - 1
    }
}

/// One part's vertices as written: with a normal map, a vertex whose corners got different
/// MikkTSpace tangents is split (a tangent is per vertex in glTF).
struct Vertices {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    tangents: Vec<[f32; 4]>,
    indices: Vec<u32>,
}

fn vertices(part: &super::model::Part, tangents: Option<&[[[f32; 4]; 3]]>) -> Vertices {
    let mut out = Vertices {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        tangents: Vec::new(),
        indices: Vec::new(),
    };
    let mut seen: std::collections::HashMap<(u32, [u32; 4]), u32> = Default::default();
    for (t, triangle) in part.triangles.iter().enumerate() {
        for (k, &i) in triangle.iter().enumerate() {
            let tangent = tangents.map_or([0.0; 4], |ts| ts[t][k]);
            let key = (i, tangent.map(f32::to_bits));
            let next = out.positions.len() as u32;
            let index = *seen.entry(key).or_insert(next);
            if index == next {
                out.positions
                    .push(part.positions[i as usize].map(|c| c as f32));
                out.normals.push(part.normals[i as usize].map(|c| c as f32));
                out.uvs.push(part.uvs[i as usize].map(|c| c as f32));
                out.tangents
                    .push(unit_tangent(tangent, part.normals[i as usize]));
            }
            out.indices.push(index);
        }
    }
    out
}

/// A tangent the glTF validator accepts: unit xyz (one perpendicular to the normal where
/// MikkTSpace left none), w = ±1.
fn unit_tangent(t: [f32; 4], normal: [f64; 3]) -> [f32; 4] {
    let v = glam::Vec3::new(t[0], t[1], t[2]);
    let v = if v.length_squared() > 1e-12 {
        v.normalize()
    } else {
        let n = glam::DVec3::from(normal).as_vec3();
        n.any_orthonormal_vector()
    };
    [v.x, v.y, v.z, if t[3] < 0.0 { -1.0 } else { 1.0 }]
}

/// An image as the PNG glTF wants for `role`: 8-bit RGB, base colour sRGB-encoded, the others
/// linear; a scalar image repeated into the three channels.
fn rgb_png(
    image: &TextureImage,
    width: usize,
    height: usize,
    srgb: bool,
) -> Result<Vec<u8>, String> {
    let rgb: Vec<f32> = match image.ty {
        Type::Vec3 => image.data.clone(),
        Type::Scalar => image.data.iter().flat_map(|&v| [v; 3]).collect(),
    };
    crate::bake::png_bytes(&rgb, width, height, Type::Vec3, false, srgb)
}

/// The metallic-roughness texture: roughness in G, metallic in B (R unused, 0).
fn metallic_roughness(
    roughness: Option<&TextureImage>,
    metallic: Option<&TextureImage>,
    texels: usize,
) -> Vec<f32> {
    let channel =
        |image: Option<&TextureImage>, t: usize| image.map_or(0.0, |i| i.data[t * i.ty.channels()]);
    (0..texels)
        .flat_map(|t| [0.0, channel(roughness, t), channel(metallic, t)])
        .collect()
}

/// The GLB of `model` with `set`'s images as its material.
pub fn glb_bytes(
    model: &Model,
    set: &TextureSet,
    images: &MaterialImages,
) -> Result<Vec<u8>, String> {
    let (width, height) = (set.width, set.height);
    let mut b = Builder::default();
    let mut material = json!({"name": "texgraph", "pbrMetallicRoughness": {}});
    let mut textures = Vec::new();
    let mut texture = |b: &mut Builder, png: Vec<u8>| {
        let source = b.png(&png);
        textures.push(json!({"source": source, "sampler": 0}));
        json!({"index": textures.len() - 1})
    };
    if let Some(base) = images.base_color {
        material["pbrMetallicRoughness"]["baseColorTexture"] =
            texture(&mut b, rgb_png(base, width, height, true)?);
    }
    if images.roughness.is_some() || images.metallic.is_some() {
        let data = metallic_roughness(images.roughness, images.metallic, width * height);
        let png = crate::bake::png_bytes(&data, width, height, Type::Vec3, false, false)?;
        material["pbrMetallicRoughness"]["metallicRoughnessTexture"] = texture(&mut b, png);
    }
    // Without a metallic image the surface is a dielectric (glTF's default factor is 1).
    material["pbrMetallicRoughness"]["metallicFactor"] =
        json!(if images.metallic.is_some() { 1.0 } else { 0.0 });
    material["pbrMetallicRoughness"]["roughnessFactor"] = json!(1.0);
    if let Some(normal) = images.normal {
        let mut up = normal.clone();
        if images.normal_green == GreenAxis::Down {
            for texel in up.data.chunks_exact_mut(3) {
                texel[1] = 1.0 - texel[1];
            }
        }
        material["normalTexture"] = texture(&mut b, rgb_png(&up, width, height, false)?);
    }
    let mut primitives = Vec::new();
    for (p, part) in model.parts.iter().enumerate() {
        let tangents = images.normal.and(set.tangents.get(p)).map(|t| t.as_slice());
        let v = vertices(part, tangents);
        let mut attributes = json!({
            "POSITION": b.floats(&v.positions, true),
            "NORMAL": b.floats(&v.normals, false),
            "TEXCOORD_0": b.floats(&v.uvs, false),
        });
        if tangents.is_some() {
            attributes["TANGENT"] = json!(b.floats(&v.tangents, false));
        }
        let indices = b.indices(&v.indices);
        primitives.push(json!({"attributes": attributes, "indices": indices, "material": 0}));
    }
    while !b.bin.len().is_multiple_of(4) {
        b.bin.push(0);
    }
    let mut root = json!({
        "asset": {"version": "2.0", "generator": concat!("texgraph ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "texgraph"}],
        "meshes": [{"primitives": primitives, "name": "texgraph"}],
        "materials": [material],
        "buffers": [{"byteLength": b.bin.len()}],
        "bufferViews": b.views,
        "accessors": b.accessors,
    });
    if !textures.is_empty() {
        root["textures"] = json!(textures);
        root["images"] = json!(b.images);
        // Linear filtering with mipmaps, repeat wrapping: what a texture set is made for.
        root["samplers"] =
            json!([{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}]);
    }
    let text = serde_json::to_vec(&root).map_err(|e| e.to_string())?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: 0,
        },
        json: std::borrow::Cow::Owned(text),
        bin: Some(std::borrow::Cow::Owned(b.bin)),
    };
    glb.to_vec().map_err(|e| e.to_string())
}
