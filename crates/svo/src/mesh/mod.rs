//! The triangle mesh every importer produces and every bake starts from: positions in `f64`,
//! triangles, one [`Material`] per triangle, textures, and the lights and camera views
//! ([`SceneInfo`]) that travel with a mesh into its tree. Also the mesh file formats, the
//! material presets of the 2019 report, open-edge counting and primitive meshes.
//!
//! Loading lives in [`Mesh::load`], [`Mesh::from_bytes`] and [`Mesh::read`] (the importers,
//! one cargo feature per format).
//!
//! Depends on nothing else in the crate; every other folder may depend on it.

mod alpha_cut;
pub(crate) mod closed;
pub(crate) mod format;
pub(crate) mod presets;
pub(crate) mod primitives;
pub(crate) mod scene_info;
pub(crate) mod triangle_mesh;

pub use format::MeshFormat;
pub use presets::Preset;
pub use scene_info::{SceneInfo, StoredCamera, StoredLight};
pub use triangle_mesh::{Material, Mesh, MeshError, Texture, srgb_to_linear};
