//! Scene files (TOML): meshes and primitives placed with transforms and materials (presets
//! from the 2019 report's table, plus water), point lights and named camera views, and CSG
//! between objects (the `csg` feature, through the Manifold kernel). A loaded [`Scene`] is
//! one mesh with its [`crate::mesh::SceneInfo`], ready to bake; `docs/scenes.md` describes
//! the file.
//!
//! Depends on [`crate::mesh`], the importers and the solid mode (a scene may ask for a solid
//! bake).

#[cfg(feature = "csg")]
pub(crate) mod csg;
pub(crate) mod file;

pub use file::{Scene, SceneError, load_scene};
