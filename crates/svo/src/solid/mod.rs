//! Solid voxelization: the inside of a closed mesh (or, by a vote of three axes, of a mesh
//! with holes) as interior leaves, found by exact column parity with `robust`'s orientation
//! predicates and merged with the surface tree. Interior leaves carry the normal word
//! [`crate::octree::NO_NORMAL`]; renderers pass through them.
//!
//! [`SolidMode`] is always compiled (a bake option); the fill itself needs the `solid`
//! feature. Depends on [`crate::mesh`] and [`crate::octree`].

#[cfg(feature = "solid")]
pub(crate) mod fill;
pub(crate) mod mode;

pub use mode::SolidMode;
