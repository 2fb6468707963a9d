//! The tree's geometry as a DAG (`svo::dag::Dag`): distinct nodes, pointers and bits a leaf
//! beside the tree's, the sizes of both layouts' files (geometry alone and with every
//! channel), and the time to build the graph and write its file beside the bake's.

use std::time::Instant;
use svo::dag::Dag;
use svo::io::{BuildInfo, write_dag_to, write_to};
use svo::mesh::Mesh;
use svo::octree::LeafAttributes;
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
    /// Bytes of the tree-layout file with every channel, and of its geometry alone.
    pub tree_file: (u64, u64),
    /// Bytes of the DAG-layout file with every channel, and of its geometry alone.
    pub dag_file: (u64, u64),
    /// Seconds writing the DAG-layout file of the geometry (the graph built again, its
    /// levels encoded, hashed and streamed to nowhere), one run.
    pub dag_write_s: f64,
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

    /// Bits a leaf of a file of `bytes`.
    pub fn file_bits(&self, bytes: u64) -> f64 {
        8.0 * bytes as f64 / self.leaves.max(1) as f64
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
        let mut tree = bake_mesh(mesh, &opts)?.0;
        let bake_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let dag = Dag::from_tree(&tree);
        let dag_s = t.elapsed().as_secs_f64();
        let counts = dag.level_counts();
        let pointers = dag.level_pointer_counts();
        let k = counts.len().saturating_sub(2);
        let build = BuildInfo::new();
        let sink = &mut std::io::sink();
        let tree_all = write_to(&tree, &build, sink)?;
        let dag_all = write_dag_to(&tree, &build, sink)?;
        tree.attributes = LeafAttributes::default();
        let tree_geometry = write_to(&tree, &build, sink)?;
        let t = Instant::now();
        let dag_geometry = write_dag_to(&tree, &build, sink)?;
        let dag_write_s = t.elapsed().as_secs_f64();
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
            tree_file: (tree_all, tree_geometry),
            dag_file: (dag_all, dag_geometry),
            dag_write_s,
        });
    }
    Ok(rows)
}
