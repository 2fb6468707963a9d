//! The library's integration tests, one binary: each module a subject, all of them held to
//! references that share no code with the library (`svo_tests`: the exact voxelization
//! oracle, the integer separating-axis test, the rational ray reference, the fuzz checks).
//! Seeded tests draw their seeds through `svo_tests::seeds`, so `SVO_TEST_SEED` moves them
//! all to new random cases for a soak.

mod alpha_cut;
mod attributes;
mod bake_sliced;
mod deep_precision;
mod deep_trees;
mod exact_oracle;
mod format_dag;
mod format_levels;
mod format_roundtrip;
mod fuzz_regressions;
mod gltf_scene;
mod golden_images;
mod level_of_detail;
mod node_attributes;
mod octree_bruteforce;
mod overlap_exact;
mod render;
mod render_extremes;
mod solid;
mod traversal_bruteforce;
mod traversal_dda;

/// What the modules share, from the support crate.
mod common {
    pub use svo_tests::exact_sat::*;
    pub use svo_tests::geometry::*;
    pub use svo_tests::{fuzz_cases, oracle, ray_check, ray_reference};
}

/// The node orders a tree in memory keeps: level order with inner-node attributes, else
/// depth-first.
mod order {
    use svo::Octree;

    /// Each node's level, following the children from the root.
    fn levels(t: &Octree) -> Vec<u8> {
        let mut level = vec![0u8; t.nodes.len()];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = t.nodes[i];
            if n.is_leaf_parent() || n.child_mask() == 0 {
                continue;
            }
            for c in n.first as usize..n.first as usize + n.child_mask().count_ones() as usize {
                level[c] = level[i] + 1;
                stack.push(c);
            }
        }
        level
    }

    /// Whether the nodes are numbered level by level, each level's children blocks in the
    /// order of their parents.
    pub fn is_level_order(t: &Octree) -> bool {
        let firsts: Vec<u32> = (t.nodes.iter())
            .filter(|n| !n.is_leaf_parent() && n.child_mask() != 0)
            .map(|n| n.first)
            .collect();
        levels(t).windows(2).all(|w| w[0] <= w[1]) && firsts.windows(2).all(|w| w[0] < w[1])
    }

    /// Whether two trees have the same shape whatever their node order: as many nodes, and
    /// the same leaves in the same cells.
    pub fn same_shape(a: &Octree, b: &Octree) -> bool {
        let cells = |t: &Octree| t.leaves().map(|l| (l.index, l.cell)).collect::<Vec<_>>();
        a.depth == b.depth && a.nodes.len() == b.nodes.len() && cells(a) == cells(b)
    }
}
