//! The voxelizer: a parallel, depth-first, deterministic recursion over the octree that
//! files each triangle into the children it touches (child AABB classification, then the
//! overlap tests of the chosen [`Strategy`]), and at the bottom five levels slices each
//! triangle through its block of cells at once. Leaves are emitted in post-order with their
//! attributes, into the packed layout of [`crate::octree`].
//!
//! The exact triangle/cell tests it is built from are public for users who want them alone:
//! [`triangle_box_overlap`] (all of them, the default strategy's answer), and the bounding
//! box ([`aabb_overlaps`]), plane ([`plane_overlaps`]), edge-axis ([`edges_overlap`]) and
//! vertex-inside ([`vertex_inside`]) tests, on a [`GridTriangle`]. Every one treats cells as closed and separates only beyond
//! a rigorous rounding-error bound, so a touched cell is never missed.
//!
//! Depends on the grid geometry (`geometry/`), [`crate::octree`] and the leaf attributes
//! (`attributes/`). A whole bake (validation, attributes, statistics) is [`crate::bake`].

pub(crate) mod build;
pub(crate) mod scatter;
pub(crate) mod strategy;

pub use crate::geometry::overlap::{
    aabb_overlaps, edges_overlap, plane_overlaps, triangle_box_overlap, vertex_inside,
};
pub use crate::geometry::triangle_setup::GridTriangle;
pub use strategy::Strategy;
