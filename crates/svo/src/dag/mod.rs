//! Compact geometry: a tree's nodes as a directed acyclic graph, identical subtrees stored
//! once ([`Dag`]). The leaves' values stay in the tree's arrays, in Morton order; each node
//! of the graph counts the leaves below it, so a walk finds a leaf's index. Files store the
//! graph as version 4's DAG layout (`docs/format.md`, section 12: the levels above the bricks
//! as bit streams of masks and narrow child indices, the two lowest levels as 64-bit 4x4x4 bricks).

mod build;
mod expand;
#[cfg(feature = "trace")]
mod flat;
pub(crate) mod levels;
mod values;
#[cfg(feature = "trace")]
mod walk;

pub use build::Dag;
#[cfg(feature = "io")]
pub(crate) use build::DagBuilder;
#[cfg(feature = "trace")]
pub use flat::FlatDag;
pub use values::{DagValues, ValuesError};
#[cfg(feature = "trace")]
pub use walk::{DagError, DagTree};

/// The tree's nodes as files store them (bits 8-31 of `info` zero), which a graph gives back.
#[cfg(test)]
fn plain(nodes: &[crate::octree::tree::Node]) -> Vec<crate::octree::tree::Node> {
    nodes
        .iter()
        .map(|n| crate::octree::tree::Node {
            info: n.info & 0xFF,
            ..*n
        })
        .collect()
}
