//! # svo: exact sparse voxel octrees from triangle meshes
//!
//! The library behind `svo-bake` and `svo-view`:
//!
//! - [`mesh`]: the in-memory triangle mesh with materials and textures, and its validation;
//!   importers for OBJ/MTL (and `.obj.gz`), PLY and glTF 2.0 live in [`import`] behind the
//!   `obj`, `ply` and `gltf` features.
//! - [`grid`]: the root cube and the mapping from scene space to grid space (`[0, 2^depth]^3`).
//! - [`child_classify`] and [`overlap`]: the thesis's child AABB classification (Algorithm 1),
//!   the triangle-plane/box test (Algorithm 2), the separating axis test on the edge axes
//!   (Algorithm 3) and the vertex-inside shortcut, all with closed cells and a rigorous
//!   floating-point tolerance so that no touched cell is ever missed.
//! - [`octree_build`]: the parallel, depth-first, deterministic voxelizer with its
//!   [`Strategy`] choices; [`octree_layout`] the packed node layout they share with the
//!   programmatic [`builder`].
//! - [`leaf_attributes`] and [`contour`]: clipped-area-weighted normals, colours and
//!   materials per leaf, and the two planes that bound the surface inside each leaf.
//! - [`octree`]: the [`Octree`] itself: nodes, leaf channels, iteration and cell queries.
//! - [`format_write`] / [`format_read`]: the versioned `.svo` file (feature `io`), plus
//!   [`export_binvox`] and [`export_vox`].
//! - [`bake`]: the whole pipeline with options, timings and the summary report.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

#[cfg(feature = "trace")]
pub mod aov;
pub mod bake;
pub mod builder;
#[cfg(feature = "trace")]
pub mod camera;
pub mod child_classify;
pub mod clip;
pub mod contour;
#[cfg(feature = "io")]
pub mod describe;
pub mod estimate;
#[cfg(feature = "trace")]
pub mod exact_surfaces;
pub mod grid;
#[cfg(feature = "trace")]
pub mod grid_dda;
#[cfg(feature = "trace")]
pub mod grid_ray;
pub mod grid_slice;
#[cfg(feature = "trace")]
pub mod image_compare;
#[cfg(feature = "image-io")]
pub mod image_write;
pub mod import;
pub mod leaf_attributes;
#[cfg(feature = "trace")]
pub mod leaf_hit;
pub mod material_presets;
pub mod mesh;
pub mod mesh_closed;
#[cfg(feature = "reference")]
pub mod mesh_reference;
pub mod normal_encoding;
pub mod octree;
pub mod octree_build;
pub mod octree_layout;
pub mod octree_scatter;
#[cfg(feature = "trace")]
pub mod octree_traverse;
pub mod octree_validate;
pub mod overlap;
#[cfg(feature = "trace")]
pub mod primary_cast;
#[cfg(feature = "trace")]
pub mod primary_prepass;
pub mod primitives;
#[cfg(feature = "trace")]
pub mod render;
#[cfg(all(feature = "image-io", feature = "reference"))]
pub mod render_job;
#[cfg(feature = "csg")]
pub mod scene_csg;
#[cfg(feature = "scene")]
pub mod scene_file;
pub mod scene_info;
#[cfg(feature = "trace")]
pub mod scene_report2019;
#[cfg(feature = "trace")]
pub mod shading;
#[cfg(feature = "trace")]
pub mod sky;
#[cfg(feature = "solid")]
pub mod solid_fill;
pub mod solid_mode;
pub mod strategy;
#[cfg(feature = "trace")]
pub mod surfaces;
#[cfg(test)]
mod test_rng;
pub mod thread_pool;
pub mod triangle_setup;
#[cfg(feature = "trace")]
pub mod whitted;

#[cfg(feature = "io")]
pub mod atomic_write;
#[cfg(feature = "io")]
pub mod export_binvox;
#[cfg(feature = "vox")]
pub mod export_vox;
#[cfg(feature = "io")]
pub mod format_header;
#[cfg(feature = "io")]
pub mod format_read;
#[cfg(feature = "io")]
pub mod format_write;
#[cfg(feature = "io")]
pub mod pipeline;

pub use bake::{BakeError, BakeOptions, BakeStats, bake_mesh};
pub use grid::RootCube;
pub use mesh::{Material, Mesh, MeshError, Texture};
pub use octree::{Channel, ChannelKind, LeafAttributes, LeafValue, Node, Octree};
pub use strategy::Strategy;

/// The deepest tree the library builds: cells are addressed by `u32` coordinates and grid
/// space must stay exact in `f64` far below a cell.
pub const MAX_DEPTH: u8 = 30;
