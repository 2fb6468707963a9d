//! The items most programs need, for `use svo::prelude::*;`: meshes, baking, the tree, files,
//! rays, and glam's vector types.

pub use crate::bake::{BakeOptions, BakeStats, Strategy, bake_mesh};
#[cfg(feature = "io")]
pub use crate::io::BuildInfo;
pub use crate::mesh::{Material, Mesh, MeshFormat};
pub use crate::octree::{Leaf, Octree, RootCube, Voxel};
#[cfg(feature = "trace")]
pub use crate::trace::{Hit, HitMode, Ray};
#[doc(no_inline)]
pub use glam::{DVec3, UVec3, Vec3};
