//! Grid space and the exact tests on it: the root cube and the mapping from scene space to
//! the `[0, 2^depth]^3` grid ([`RootCube`]), triangles set up in grid space, the thesis's
//! child AABB classification (Algorithm 1), the triangle-plane/box test (Algorithm 2), the
//! separating-axis test on the edge axes (Algorithm 3) and the vertex-inside shortcut, all
//! on closed cells with rigorous rounding-error bounds, and triangles clipped and sliced by
//! cells (the parts whose areas and points make the leaf attributes).
//!
//! Depends on [`crate::mesh`] only. The public pieces are re-exported by [`crate::voxelize`]
//! (the overlap tests) and [`crate::octree`] ([`RootCube`]).

pub(crate) mod child_classify;
pub(crate) mod clip;
pub(crate) mod exact_contact;
pub(crate) mod grid;
pub(crate) mod grid_slice;
pub(crate) mod overlap;
pub(crate) mod triangle_setup;

pub use grid::RootCube;
