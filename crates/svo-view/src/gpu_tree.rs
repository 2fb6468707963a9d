//! What the GPU traces: a tree ([`Octree`], its node array as stored) or a tree's graph
//! ([`DagTree`], its distinct subtrees as [`svo::dag::FlatDag`]'s words), with the same leaf
//! channels. The renderer, the shader variant and the uniforms take either; the shader's walk
//! is linked for the one given (the WESL feature `dag`).

use glam::DVec3;
use svo::RootCube;
use svo::dag::DagTree;
use svo::octree::{LeafAttributes, Octree};

/// A tree or its graph, as the GPU renderer takes it (`&Octree` and `&DagTree` convert).
#[derive(Clone, Copy, Debug)]
pub enum GpuTree<'a> {
    /// A tree: its node array.
    Tree(&'a Octree),
    /// A tree's graph: identical subtrees stored once, walked with the same leaves and
    /// steps as the tree.
    Dag(&'a DagTree),
}

impl<'a> From<&'a Octree> for GpuTree<'a> {
    fn from(t: &'a Octree) -> Self {
        Self::Tree(t)
    }
}

impl<'a> From<&'a DagTree> for GpuTree<'a> {
    fn from(d: &'a DagTree) -> Self {
        Self::Dag(d)
    }
}

impl<'a> GpuTree<'a> {
    /// Levels below the root.
    pub fn depth(self) -> u8 {
        match self {
            Self::Tree(t) => t.depth,
            Self::Dag(d) => d.depth(),
        }
    }

    /// The root cube.
    pub fn root(self) -> RootCube {
        match self {
            Self::Tree(t) => t.root,
            Self::Dag(d) => d.root(),
        }
    }

    /// The tree's leaves.
    pub fn leaf_count(self) -> u64 {
        match self {
            Self::Tree(t) => u64::from(t.leaf_count),
            Self::Dag(d) => d.leaf_count(),
        }
    }

    /// The leaves' channels.
    pub fn attributes(self) -> &'a LeafAttributes {
        match self {
            Self::Tree(t) => &t.attributes,
            Self::Dag(d) => d.attributes(),
        }
    }

    /// The tree, where it is one.
    pub fn tree(self) -> Option<&'a Octree> {
        match self {
            Self::Tree(t) => Some(t),
            Self::Dag(_) => None,
        }
    }

    /// The inner nodes' channels (a graph keeps none).
    pub fn node_attributes(self) -> Option<&'a LeafAttributes> {
        self.tree().map(|t| &t.node_attributes)
    }

    /// The box of the leaves' cells in scene units (the root cube without leaves).
    pub fn occupied_bounds(self) -> (DVec3, DVec3) {
        match self {
            Self::Tree(t) => t.occupied_bounds(),
            Self::Dag(d) => d.occupied_bounds(),
        }
    }

    /// Whether it is a graph.
    pub fn is_dag(self) -> bool {
        matches!(self, Self::Dag(_))
    }
}
