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
    /// The graph of `tree`'s geometry (its values are not part of it). `tree` must be a valid
    /// tree ([`Octree::validate`]); of another, the graph holds what the walk from its root
    /// could reduce before it met what is not a tree.
    pub fn from_tree(tree: &Octree) -> Self {
        let mut graph = DagBuilder::new(tree.depth);
        if let Some(&root) = tree.nodes.first() {
            let whole = graph.add(0, root, &tree.nodes);
            debug_assert!(whole.is_ok(), "{whole:?}");
        }
        graph.finish()
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

/// A graph built from subtrees handed over in Morton order: a whole tree, or the subtrees at
/// one level of a bake's parts, one after another, then the levels above them
/// ([`DagBuilder::add_top`]). Each level keeps its distinct nodes in the order they are first
/// met, which is the tree's Morton order on that level whatever the subtrees were, so the
/// graph is the one [`Dag::from_tree`] makes of the whole tree.
pub(crate) struct DagBuilder {
    depth: u8,
    levels: Vec<Level>,
    /// Per level above the leaf parents, each distinct node's index by its mask and its
    /// children's indices.
    seen: Vec<FxHashMap<(u8, [u32; 8]), u32>>,
    /// Each leaf parent's index by its mask (`u32::MAX`: none yet): most of a tree's nodes
    /// are leaf parents, and a mask is all that names one.
    leaf_parents: [u32; 256],
    /// Each node's index on the level above the leaf parents by its brick (its leaf parents'
    /// masks, a byte a child): one word names it.
    bricks: FxHashMap<u64, u32>,
}

impl DagBuilder {
    /// An empty graph of a tree of `depth` levels.
    pub(crate) fn new(depth: u8) -> Self {
        let depth_levels = usize::from(depth);
        Self {
            depth,
            levels: vec![Level::default(); depth_levels],
            seen: vec![FxHashMap::default(); depth_levels],
            leaf_parents: [u32::MAX; 256],
            bricks: FxHashMap::default(),
        }
    }

    /// The node of `level` with child mask `mask` and the children `kids` (their indices on
    /// the level below, in child order; none on the leaf parents' level): its index on the
    /// level, added if the level has no such node yet.
    pub(crate) fn node(&mut self, level: usize, mask: u8, kids: &[u32]) -> u32 {
        if level + 1 == usize::from(self.depth) {
            let known = self.leaf_parents[usize::from(mask)];
            if known != u32::MAX {
                return known;
            }
            let out = &mut self.levels[level];
            let k = out.masks.len() as u32;
            out.masks.push(mask);
            out.leaves.push(u64::from(mask.count_ones()));
            self.leaf_parents[usize::from(mask)] = k;
            return k;
        }
        let next = self.levels[level].masks.len() as u32;
        let k = if level + 2 == usize::from(self.depth) {
            let parents = &self.levels[level + 1].masks;
            let mut kid = kids.iter();
            let brick = (0..8).fold(0u64, |b, a| match mask >> a & 1 {
                0 => b,
                _ => b | kid.next().map_or(0, |&c| u64::from(parents[c as usize])) << (8 * a),
            });
            *self.bricks.entry(brick).or_insert(next)
        } else {
            let mut ids = [0u32; 8];
            ids[..kids.len()].copy_from_slice(kids);
            *self.seen[level].entry((mask, ids)).or_insert(next)
        };
        if k == next {
            let below = &self.levels[level + 1].leaves;
            let leaves = kids.iter().map(|&c| below[c as usize]).sum();
            let out = &mut self.levels[level];
            out.masks.push(mask);
            out.leaves.push(leaves);
            out.starts.push(out.children.len() as u32);
            out.children.extend_from_slice(kids);
        }
        k
    }

    /// The leaves below node `k` of `level`.
    #[cfg_attr(not(feature = "io"), allow(dead_code))]
    pub(crate) fn leaves(&self, level: usize, k: u32) -> u64 {
        self.levels[level].leaves[k as usize]
    }

    /// Adds the subtree of `root`, a node on `level` whose children's block (and theirs, down
    /// to the leaf parents) lie in `nodes`, each node's `first` an index into `nodes`; returns
    /// its index on `level`. Only the root of level 0 may have no children. `Err` names what
    /// makes `nodes` no tree of the graph's depth (a block past the end of `nodes`, a leaf
    /// parent above the lowest level or an inner node on it, a node without children, more
    /// nodes met than `nodes` holds), and the levels then hold part of the subtree.
    pub(crate) fn add(
        &mut self,
        level: usize,
        root: Node,
        nodes: &[Node],
    ) -> Result<u32, &'static str> {
        let depth = usize::from(self.depth);
        if level == 0 && root.child_mask() == 0 {
            return Ok(self.node(0, 0, &[]));
        }
        let block = |n: Node, l: usize| -> Result<std::ops::Range<u32>, &'static str> {
            let leaf_parent = l + 1 == depth;
            if n.child_mask() == 0 {
                return Err("a node below the root has no children");
            }
            if n.is_leaf_parent() != leaf_parent {
                return Err("a node's children are leaves above the lowest level, or nodes on it");
            }
            if leaf_parent {
                return Ok(0..0);
            }
            let end = u64::from(n.first) + u64::from(n.child_mask().count_ones());
            if end > nodes.len() as u64 {
                return Err("a node's children lie past the subtree's nodes");
            }
            Ok(n.first..end as u32)
        };
        // The subtree's nodes level by level below its root, each level in Morton order: a
        // node's children follow those of the nodes before it on its level.
        let mut by_level: Vec<Vec<u32>> = Vec::with_capacity(depth.saturating_sub(level + 1));
        let mut next: Vec<u32> = block(root, level)?.collect();
        let mut met = next.len();
        for l in level + 1..depth {
            let mut deeper = Vec::new();
            for &i in &next {
                let kids = block(nodes[i as usize], l)?;
                met += kids.len();
                if met > nodes.len() {
                    return Err("the subtree's nodes are met more than once");
                }
                deeper.extend(kids);
            }
            by_level.push(std::mem::replace(&mut next, deeper));
        }
        // From the leaf parents up, each node's index on its level.
        let mut ids_below: Vec<u32> = Vec::new();
        for (r, list) in by_level.iter().enumerate().rev() {
            let l = level + 1 + r;
            let mut ids = Vec::with_capacity(list.len());
            let mut at = 0;
            for &i in list {
                let n = nodes[i as usize];
                let c = if l + 1 == depth {
                    0
                } else {
                    n.child_mask().count_ones() as usize
                };
                ids.push(self.node(l, n.child_mask(), &ids_below[at..at + c]));
                at += c;
            }
            ids_below = ids;
        }
        Ok(self.node(level, root.child_mask(), &ids_below))
    }

    /// Adds the levels above `level` over that level's nodes, given as their Morton codes on
    /// `level` with their indices, in increasing code (none: the empty tree). Returns the
    /// root's index (0).
    #[cfg_attr(not(feature = "io"), allow(dead_code))]
    pub(crate) fn add_top(&mut self, level: usize, mut cells: Vec<(u64, u32)>) -> u32 {
        if cells.is_empty() {
            return self.node(0, 0, &[]);
        }
        for l in (0..level).rev() {
            let mut up = Vec::with_capacity(cells.len() / 2 + 1);
            let mut rest = cells.as_slice();
            while let Some(&(code, _)) = rest.first() {
                let n = rest.iter().take_while(|c| c.0 >> 3 == code >> 3).count();
                let (group, after) = rest.split_at(n);
                let mask = group.iter().fold(0u8, |m, c| m | 1 << (c.0 & 7));
                let kids: Vec<u32> = group.iter().map(|c| c.1).collect();
                up.push((code >> 3, self.node(l, mask, &kids)));
                rest = after;
            }
            cells = up;
        }
        cells[0].1
    }

    /// The graph.
    pub(crate) fn finish(mut self) -> Dag {
        let depth = usize::from(self.depth);
        for (l, level) in self.levels.iter_mut().enumerate() {
            if l + 1 < depth {
                level.starts.push(level.children.len() as u32);
            }
        }
        Dag {
            depth: self.depth,
            levels: self.levels,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dag::plain;
    use crate::octree::{RootCube, Voxel, scattered_tree};
    use glam::{DVec3, UVec3};

    /// The graph gives the tree's nodes back, for seeded random trees of depths 1 to 7 (dense
    /// and sparse) and the empty tree; its counts add up (each node's leaves, at most the
    /// tree's nodes).
    #[test]
    fn the_graph_gives_the_tree_back() {
        let mut rnd = svo_tests::seeds::xorshift(0xda6);
        for case in 0..80u32 {
            let depth = 1 + (case % 7) as u8;
            let n = match case % 10 {
                0 => 0,
                1 => 4000,
                _ => 1 + rnd() % 300,
            };
            let tree = scattered_tree(&mut rnd, depth, n);
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

    /// The nodes of `tree` at `level` in Morton order, with their codes.
    fn at_level(tree: &Octree, level: usize) -> Vec<(u64, Node)> {
        let mut cells = vec![(0u64, tree.nodes[0])];
        for _ in 0..level {
            let mut next = Vec::new();
            for &(code, n) in &cells {
                let mut first = n.first;
                for c in 0..8u64 {
                    if n.child_mask() >> c & 1 != 0 {
                        next.push((code << 3 | c, tree.nodes[first as usize]));
                        first += 1;
                    }
                }
            }
            cells = next;
        }
        cells
    }

    /// The subtrees at any level handed over one after another in Morton order, then the
    /// levels above them, make the graph of the whole tree (what the merge of a bake's parts
    /// relies on); nodes that are no tree are refused, never a panic.
    #[test]
    fn subtrees_in_morton_order_make_the_graph_of_the_whole_tree() {
        let mut rnd = svo_tests::seeds::xorshift(0xda7);
        let root = RootCube {
            origin: DVec3::ZERO,
            side: 1.0,
        };
        for case in 0..60u32 {
            let depth = 2 + (case % 6) as u8;
            let n = if case % 7 == 0 { 3000 } else { 1 + rnd() % 200 };
            let tree = scattered_tree(&mut rnd, depth, n);
            let whole = Dag::from_tree(&tree);
            for level in 1..usize::from(depth) {
                let mut graph = DagBuilder::new(depth);
                let cells: Vec<(u64, u32)> = at_level(&tree, level)
                    .into_iter()
                    .map(|(code, n)| (code, graph.add(level, n, &tree.nodes).unwrap()))
                    .collect();
                assert_eq!(graph.add_top(level, cells), 0);
                assert_eq!(graph.finish(), whole, "case {case}, level {level}");
            }
            // Damaged nodes: refused or reduced, never a panic or a hang.
            for _ in 0..40 {
                let mut nodes = tree.nodes.clone();
                let k = rnd() as usize % nodes.len();
                match rnd() % 3 {
                    0 => nodes[k].first = rnd() as u32 % (nodes.len() as u32 + 2),
                    1 => nodes[k].info ^= 1 << (rnd() % 8),
                    _ => nodes[k].first = nodes[k].first.wrapping_neg(),
                }
                let mut graph = DagBuilder::new(depth);
                let _ = graph.add(0, nodes[0], &nodes);
            }
        }
        // A root that is its own first child: its nodes met again and again, refused.
        let tree = Octree::from_cells(
            root,
            3,
            [UVec3::new(0, 0, 0), UVec3::new(7, 7, 7)].map(|c| (c, Voxel::glass())),
        )
        .unwrap();
        let mut nodes = tree.nodes.clone();
        nodes[0].first = 0;
        assert!(DagBuilder::new(3).add(0, nodes[0], &nodes).is_err());
    }
}
