//! Leaf attributes: what each leaf stores about the surface inside it, computed as the
//! voxelizer emits the leaf from the triangle parts it clipped to the cell: the
//! area-weighted normal, colour (texture-sampled where the mesh has a texture),
//! reflectivity, refractivity and index of refraction, and the contour (two parallel planes
//! that bound the surface inside the cell). [`ChannelSelection`] picks the channels a bake
//! computes; channels that are the same for every leaf are stored once. Inner nodes get the
//! same channels for the surface inside their cells (`surface_sums.rs`, `node_attributes.rs`):
//! what a renderer draws in place of their subtrees.
//!
//! Depends on [`crate::mesh`], [`crate::geometry`] and [`crate::octree`] (the encodings).

pub(crate) mod leaf_attributes;
pub(crate) mod node_attributes;
pub(crate) mod selection;
pub(crate) mod surface_sums;

pub use leaf_attributes::ContourStats;
pub use selection::ChannelSelection;
