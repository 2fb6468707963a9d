//! [`SurfacesError`]: why the leaves' triangles ([`crate::render::ExactLeaves`]) or a tree
//! held as chunks ([`crate::render::ChunkedSurfaces`]) cannot be traced.

use crate::mesh::triangle_mesh::MeshError;
use crate::octree::builder::OctreeError;
use glam::UVec3;
use thiserror::Error;

/// Errors of the surfaces that need more than the tree: the mesh it was baked from, or its
/// chunks.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SurfacesError {
    /// The mesh is invalid.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The mesh's leaves in the tree's grid are not the tree's.
    #[error(
        "the mesh gives {mesh_leaves} leaves in the tree's grid, the tree has {tree_leaves} surface leaves: it is not the mesh the tree was baked from"
    )]
    NotTheSource {
        /// Leaves the mesh makes in the tree's grid.
        mesh_leaves: usize,
        /// The tree's surface leaves.
        tree_leaves: usize,
    },
    /// More leaves than 32-bit leaf indices number.
    #[error("{0} leaves: rendering numbers hits by 32-bit leaf indices")]
    TooManyLeaves(u64),
    /// The chunk level does not split the tree.
    #[error("chunk level {level} at depth {depth}")]
    Level {
        /// The chunk level.
        level: u8,
        /// The tree's depth.
        depth: u8,
    },
    /// A chunk does not fit the tree's depth, its level or the leaves before it.
    #[error("chunk at cell {cell} does not fit depth {depth} and level {level}")]
    Misfit {
        /// The chunk's cell at the chunk level.
        cell: UVec3,
        /// The tree's depth.
        depth: u8,
        /// The chunk level.
        level: u8,
    },
    /// The tree of the chunks' cells could not be built (a cell outside the chunk level's
    /// grid).
    #[error("the chunks' cells: {0}")]
    Cells(#[from] OctreeError),
    /// Two chunks at one cell.
    #[error("two chunks at one cell")]
    SharedCell,
}
