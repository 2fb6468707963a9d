//! The tree's geometry as a DAG (`svo::dag::Dag`): distinct nodes, pointers and bits a leaf
//! beside the tree's, and the time to build the graph beside the bake's.

use std::time::Instant;
use svo::dag::Dag;
use svo::mesh::Mesh;
use svo::{BakeOptions, bake_mesh};

/// One mesh at one depth.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DagRow {
    /// The mesh's file name.
    pub mesh: String,
    /// Tree depth.
    pub depth: u8,
    /// Leaves.
    pub leaves: u64,
    /// The tree's nodes.
    pub tree_nodes: u64,
    /// The graph's distinct nodes.
    pub dag_nodes: u64,
    /// The graph's pointers.
    pub pointers: u64,
    /// The graph's distinct nodes two levels above the leaves: its 4x4x4 bricks.
    pub bricks: u64,
    /// Nodes above the bricks and their pointers.
    pub above_bricks: (u64, u64),
    /// Seconds of the bake (geometry and every channel), one run.
    pub bake_s: f64,
    /// Seconds building the graph from the tree, one run.
    pub dag_s: f64,
}

impl DagRow {
    /// Bits a leaf of the tree's node array (8 bytes a node).
    pub fn tree_bits(&self) -> f64 {
        64.0 * self.tree_nodes as f64 / self.leaves.max(1) as f64
    }

    /// Bits a leaf of the graph at 4 bytes a node (its mask) and 4 a pointer.
    pub fn dag_bits(&self) -> f64 {
        32.0 * (self.dag_nodes + self.pointers) as f64 / self.leaves.max(1) as f64
    }

    /// [`Self::dag_bits`] with a 4-byte count of leaves a node above the leaf parents (what
    /// keeps the leaves' values in one array in Morton order).
    pub fn dag_counted_bits(&self) -> f64 {
        let (n, _) = self.above_bricks;
        self.dag_bits() + 32.0 * (n + self.bricks) as f64 / self.leaves.max(1) as f64
    }

    /// Bits a leaf with the two lowest levels as 4x4x4 bricks of 64 bits (8 bytes a distinct
    /// brick), leaf counts included.
    pub fn brick_bits(&self) -> f64 {
        let (n, p) = self.above_bricks;
        (32.0 * (2 * n + p) as f64 + 64.0 * self.bricks as f64) / self.leaves.max(1) as f64
    }
}

/// Bakes `mesh` (named `name`) at each of `depths` (geometry and every channel, as the
/// default bake) and builds each tree's graph.
pub fn measure(
    mesh: &Mesh,
    name: &str,
    depths: impl IntoIterator<Item = u8>,
) -> anyhow::Result<Vec<DagRow>> {
    let mut rows = Vec::new();
    for depth in depths {
        let opts = BakeOptions {
            depth,
            ..Default::default()
        };
        let t = Instant::now();
        let tree = bake_mesh(mesh, &opts)?.0;
        let bake_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let dag = Dag::from_tree(&tree);
        let dag_s = t.elapsed().as_secs_f64();
        let counts = dag.level_counts();
        let pointers = dag.level_pointer_counts();
        let k = counts.len().saturating_sub(2);
        rows.push(DagRow {
            mesh: name.to_string(),
            depth,
            leaves: dag.leaf_count(),
            tree_nodes: tree.nodes.len() as u64,
            dag_nodes: dag.node_count(),
            pointers: dag.pointer_count(),
            bricks: counts.get(k).copied().unwrap_or(0),
            above_bricks: (counts[..k].iter().sum(), pointers[..k].iter().sum()),
            bake_s,
            dag_s,
        });
    }
    Ok(rows)
}
