//! A tree's geometry as a directed acyclic graph: identical subtrees stored once (Kampe,
//! Sintorn and Assarsson 2013), reduced bottom-up level by level.
//!
//! Two subtrees are identical when their roots have the same child mask and their children
//! are, child by child, identical: so a leaf parent is its mask, and a node above is its mask
//! and its children's indices on the level below. Each level keeps the first of each kind in
//! the tree's Morton order, so the graph of a tree is one graph whatever built it. Every
//! pointer goes one level down: the graph has no cycle. Each node keeps the leaves below it,
//! so a walk from the root counts the leaves before a leaf (its index in the tree's leaf
//! arrays, which stay in Morton order) by adding the counts of the children it passes.

use super::expand::{Graph, canonical_nodes};
use crate::octree::tree::{Node, Octree};
use rustc_hash::FxHashMap;

/// The geometry of an [`Octree`] with identical subtrees stored once: see the module docs.
///
/// ```
/// use glam::{DVec3, UVec3};
/// use svo::dag::Dag;
/// use svo::{Octree, RootCube, Voxel};
/// let root = RootCube { origin: DVec3::ZERO, side: 1.0 };
/// // The same two cells in each of the root's eight children: one subtree, stored once.
/// let cells = (0..8u32).flat_map(|c| {
///     let o = UVec3::new(c >> 2 & 1, c >> 1 & 1, c & 1) * 4;
///     [o, o + UVec3::new(1, 2, 3)]
/// });
/// let tree = Octree::from_cells(root, 3, cells.map(|c| (c, Voxel::glass())))?;
/// let dag = Dag::from_tree(&tree);
/// assert_eq!(dag.level_counts(), vec![1, 1, 2]); // the root, one child kind, two leaf parents
/// assert_eq!((dag.leaf_count(), dag.node_count(), tree.nodes.len()), (16, 4, 25));
/// let plain: Vec<_> = tree.nodes.iter().map(|n| svo::octree::Node { info: n.info & 0xFF, ..*n }).collect();
/// assert_eq!(dag.to_nodes(), plain); // the tree's nodes again
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Dag {
    depth: u8,
    /// Levels 0 (the root) to `depth - 1` (the leaf parents).
    levels: Vec<Level>,
}

/// One level's distinct nodes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
struct Level {
    /// Each node's child mask.
    masks: Vec<u8>,
    /// Each node's first child in `children`, and one past the last node's (empty on the
    /// leaf parents' level, whose children are leaves).
    starts: Vec<u32>,
    /// The nodes' children, as indices on the level below, in child order.
    children: Vec<u32>,
    /// The leaves below each node.
    leaves: Vec<u64>,
}

impl Dag {
    /// The graph of `tree`'s geometry (its values are not part of it).
    pub fn from_tree(tree: &Octree) -> Self {
        let depth = usize::from(tree.depth);
        let nodes = &tree.nodes;
        // The tree's nodes level by level, each level in Morton order.
        let mut by_level: Vec<Vec<u32>> = Vec::with_capacity(depth);
        let mut level = vec![0u32];
        for _ in 0..depth {
            let mut next = Vec::new();
            for &i in &level {
                let n = nodes[i as usize];
                if !n.is_leaf_parent() && n.child_mask() != 0 {
                    next.extend(n.first..n.first + n.child_mask().count_ones());
                }
            }
            by_level.push(level);
            level = next;
        }
        // From the leaf parents up: each tree node's index among its level's distinct nodes.
        let mut id = vec![0u32; nodes.len()];
        let mut levels = vec![Level::default(); depth];
        for l in (0..depth).rev() {
            // Keyed by the mask and the children's ids in a fixed array (compared inline, unlike a
            // slice): a node has at most 8 children, and the mask says how many.
            let mut seen: FxHashMap<(u8, [u32; 8]), u32> = FxHashMap::default();
            let mut kids: Vec<u32> = Vec::new();
            // The children's ids of every node of the level, one after another.
            let mut spans = Vec::with_capacity(by_level[l].len());
            for &i in &by_level[l] {
                let n = nodes[i as usize];
                let start = kids.len();
                if !n.is_leaf_parent() && n.child_mask() != 0 {
                    let block = n.first..n.first + n.child_mask().count_ones();
                    kids.extend(block.map(|c| id[c as usize]));
                }
                spans.push(start..kids.len());
            }
            let below = levels
                .get(l + 1)
                .map(|b| b.leaves.clone())
                .unwrap_or_default();
            let out = &mut levels[l];
            for (&i, span) in by_level[l].iter().zip(spans) {
                let n = nodes[i as usize];
                let mut ids = [0u32; 8];
                ids[..span.len()].copy_from_slice(&kids[span.clone()]);
                let key = (n.child_mask(), ids);
                let next = out.masks.len() as u32;
                let k = *seen.entry(key).or_insert(next);
                if k == next {
                    out.masks.push(n.child_mask());
                    let leaves = if n.is_leaf_parent() {
                        u64::from(n.child_mask().count_ones())
                    } else {
                        kids[span.clone()].iter().map(|&c| below[c as usize]).sum()
                    };
                    out.leaves.push(leaves);
                    if l + 1 < depth {
                        out.starts.push(out.children.len() as u32);
                        out.children.extend_from_slice(&kids[span]);
                    }
                }
                id[i as usize] = k;
            }
            if l + 1 < depth {
                out.starts.push(out.children.len() as u32);
            }
        }
        Self {
            depth: tree.depth,
            levels,
        }
    }

    /// The tree's depth (the levels of nodes are `0 .. depth`).
    pub fn depth(&self) -> u8 {
        self.depth
    }

    /// Distinct nodes on each level, the root's first, down to the leaf parents'.
    pub fn level_counts(&self) -> Vec<u64> {
        self.levels.iter().map(|l| l.masks.len() as u64).collect()
    }

    /// Distinct nodes in all.
    pub fn node_count(&self) -> u64 {
        self.levels.iter().map(|l| l.masks.len() as u64).sum()
    }

    /// Pointers from nodes to their children (the leaf parents' children are leaves, not
    /// pointed to).
    pub fn pointer_count(&self) -> u64 {
        self.levels.iter().map(|l| l.children.len() as u64).sum()
    }

    /// Pointers from each level's nodes to their children, the root's level first.
    pub fn level_pointer_counts(&self) -> Vec<u64> {
        self.levels
            .iter()
            .map(|l| l.children.len() as u64)
            .collect()
    }

    /// The leaves of the tree (below the root).
    pub fn leaf_count(&self) -> u64 {
        self.levels
            .first()
            .and_then(|l| l.leaves.first())
            .copied()
            .unwrap_or(0)
    }

    /// The tree's nodes again, in the canonical order of a tree (`docs/format.md`, section 4;
    /// bits 8-31 of `info` zero): each node's children block, then its children's subtrees
    /// from the last child to the first, the leaf parents' leaves numbered in Morton order.
    pub fn to_nodes(&self) -> Vec<Node> {
        if self.levels.is_empty() {
            return Vec::new();
        }
        canonical_nodes(self)
    }

    /// Level `l`'s distinct nodes: masks, children spans and leaf counts.
    pub(crate) fn level_parts(&self, l: usize) -> (&[u8], &[u32], &[u32], &[u64]) {
        let v = &self.levels[l];
        (&v.masks, &v.starts, &v.children, &v.leaves)
    }
}

impl Graph for Dag {
    /// (level, index on the level).
    type Ref = (usize, u32);

    fn root(&self) -> Self::Ref {
        (0, 0)
    }

    fn mask(&self, (l, k): Self::Ref) -> u8 {
        self.levels[l].masks[k as usize]
    }

    fn is_leaf_parent(&self, (l, _): Self::Ref) -> bool {
        l + 1 == usize::from(self.depth)
    }

    fn children(&self, (l, k): Self::Ref, out: &mut Vec<Self::Ref>) {
        let level = &self.levels[l];
        let (s, e) = (
            level.starts[k as usize] as usize,
            level.starts[k as usize + 1] as usize,
        );
        out.extend(level.children[s..e].iter().map(|&c| (l + 1, c)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dag::plain;
    use crate::octree::{RootCube, Voxel};
    use glam::{DVec3, UVec3};

    /// The graph gives the tree's nodes back, for seeded random trees of depths 1 to 7 (dense
    /// and sparse) and the empty tree; its counts add up (each node's leaves, at most the
    /// tree's nodes).
    #[test]
    fn the_graph_gives_the_tree_back() {
        let mut rnd = svo_tests::seeds::xorshift(0xda6);
        let root = RootCube {
            origin: DVec3::ZERO,
            side: 1.0,
        };
        for case in 0..80u32 {
            let depth = 1 + (case % 7) as u8;
            let side = 1u32 << depth;
            let n = match case % 10 {
                0 => 0,
                1 => 4000,
                _ => 1 + rnd() % 300,
            };
            let cells = (0..n).map(|_| {
                let c = UVec3::new(rnd() as u32, rnd() as u32, rnd() as u32) % side;
                (c, Voxel::glass())
            });
            let tree = Octree::from_cells(root, depth, cells).unwrap();
            let dag = Dag::from_tree(&tree);
            assert_eq!(dag.to_nodes(), plain(&tree.nodes), "case {case}");
            assert_eq!(dag.leaf_count(), u64::from(tree.leaf_count), "case {case}");
            assert_eq!(dag.level_counts().len(), usize::from(depth));
            assert!(dag.node_count() <= tree.nodes.len() as u64);
            assert_eq!(dag.level_counts()[0], 1);
        }
    }

    /// A lattice (every cell whose coordinates are all even): every subtree of a level is the
    /// same, one node a level; a bake's graph gives its tree back and shares subtrees.
    #[test]
    fn identical_subtrees_are_stored_once() {
        let root = RootCube {
            origin: DVec3::ZERO,
            side: 1.0,
        };
        let depth = 5u8;
        let side = 1u32 << depth;
        let cells = (0..side * side * side)
            .map(|i| UVec3::new(i % side, i / side % side, i / side / side))
            .filter(|c| c.x % 2 == 0 && c.y % 2 == 0 && c.z % 2 == 0)
            .map(|c| (c, Voxel::glass()));
        let tree = Octree::from_cells(root, depth, cells).unwrap();
        let dag = Dag::from_tree(&tree);
        assert_eq!(dag.level_counts(), vec![1; 5]);
        assert_eq!(dag.pointer_count(), 4 * 8);
        assert_eq!(dag.leaf_count(), 4096);
        assert_eq!(dag.to_nodes(), plain(&tree.nodes));
        let torus = crate::Mesh::load(svo_tests::repo_root().join("fixtures/torus.obj")).unwrap();
        let opts = crate::BakeOptions {
            depth: 8,
            ..Default::default()
        };
        let tree = crate::bake_mesh(&torus, &opts).unwrap().0;
        let dag = Dag::from_tree(&tree);
        assert_eq!(dag.to_nodes(), plain(&tree.nodes));
        assert!(
            dag.node_count() * 3 < tree.nodes.len() as u64,
            "{}",
            dag.node_count()
        );
    }
}
