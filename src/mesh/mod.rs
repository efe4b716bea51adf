//! Texture sets (`bake --mesh`, docs/baking.md "Texture sets"): a graph baked into a mesh's UV
//! layout. `model` reads glTF and OBJ models; `raster` finds the triangle under each texel
//! centre; `tangent` the MikkTSpace frames and the normal map's encoding; `pad` the dilation
//! around UV islands; `bake` evaluates the texels (point or box-filtered over each texel's
//! footprint on the surface) into images; `glb` writes the textured glTF asset.

pub mod bake;
pub mod glb;
pub mod model;
pub mod pad;
pub mod raster;
pub mod tangent;

pub use bake::{
    bake_texture_set, flat_normal_map, gradient_tape, held_bytes, MeshBakeOptions, TextureImage,
    TextureSet,
};
pub use model::{load_model, Model, ModelError, Part, Space};
pub use tangent::GreenAxis;
