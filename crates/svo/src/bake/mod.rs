//! Baking: a mesh to an octree with its attributes and contours ([`bake_mesh`]), checked
//! first (valid mesh, depth, the memory the bake could need against a limit, a closed mesh
//! for a closed solid bake), with timings and statistics ([`BakeStats`]); the voxelization alone
//! ([`voxelize_mesh`]: the leaf cells and the triangles touching each); and, with the `io`
//! feature, the bake in parts ([`parts`]: plan, parts on any machine, streamed merge, or all
//! of it within a memory budget).
//!
//! Depends on every folder below it: [`crate::mesh`], the importers, [`crate::voxelize`],
//! the attributes, the solid fill, [`crate::octree`], and for [`parts`] [`crate::io`].

pub(crate) mod bake_mesh;
pub(crate) mod estimate;
#[cfg(feature = "io")]
pub mod parts;

pub use crate::attributes::{ChannelSelection, ContourStats};
pub use crate::solid::SolidMode;
pub use crate::voxelize::Strategy;
pub use crate::voxelize::build::LeafTriangles;
pub use bake_mesh::{
    BakeError, BakeOptions, BakeStats, Phase, bake_mesh, bake_mesh_with_progress, estimate_bake,
    voxelize_mesh,
};
pub use estimate::{Estimate, available_memory};
