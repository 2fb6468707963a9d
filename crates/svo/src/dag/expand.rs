//! The tree a graph stands for, as the canonical node array of `docs/format.md` (section 4):
//! each node's children block, then its children's subtrees from the last child to the
//! first, the leaf parents' leaves numbered in Morton order. Shared by [`super::Dag`] and the
//! file form of a graph ([`super::levels::DagLevels`]).

use crate::octree::tree::Node;

/// A graph seen from the tree it stands for: the root, each node's child mask and its
/// children (as nodes of the graph, in child order).
pub(crate) trait Graph {
    /// A node of the graph, with what places it (its level).
    type Ref: Copy;
    /// The root.
    fn root(&self) -> Self::Ref;
    /// The node's child mask.
    fn mask(&self, r: Self::Ref) -> u8;
    /// Whether the node's children are leaves.
    fn is_leaf_parent(&self, r: Self::Ref) -> bool;
    /// Appends the node's children to `out`, in child order (not called on leaf parents).
    fn children(&self, r: Self::Ref, out: &mut Vec<Self::Ref>);
}

/// The canonical node array of the tree `g` stands for (bits 8-31 of `info` zero).
pub(crate) fn canonical_nodes<G: Graph>(g: &G) -> Vec<Node> {
    canonical_nodes_to(g, usize::MAX)
}

/// The canonical node array of the top `levels` levels of the tree `g` stands for: its nodes
/// on level `levels - 1` are leaf parents, their children the leaves.
pub(crate) fn canonical_nodes_to<G: Graph>(g: &G, levels: usize) -> Vec<Node> {
    let root = g.root();
    let mut out = vec![Node {
        info: u32::from(g.mask(root)),
        first: 0,
    }];
    let mut of = vec![root];
    // Each placed node's level.
    let mut level = vec![0usize];
    let leaf_parent = |r: G::Ref, l: usize| g.is_leaf_parent(r) || l + 1 >= levels;
    let mut stack = vec![0usize];
    let mut kids = Vec::with_capacity(8);
    while let Some(b) = stack.pop() {
        let r = of[b];
        if leaf_parent(r, level[b]) || g.mask(r) == 0 {
            continue;
        }
        kids.clear();
        g.children(r, &mut kids);
        let first = out.len();
        out[b].first = first as u32;
        for &c in &kids {
            out.push(Node {
                info: u32::from(g.mask(c)),
                first: 0,
            });
            of.push(c);
            level.push(level[b] + 1);
        }
        // Placed children's subtrees follow from the last child to the first.
        stack.extend(first..out.len());
    }
    // The leaf parents' leaves, in Morton order: a walk in child order.
    let mut next_leaf = 0u32;
    let mut walk = vec![0usize];
    while let Some(i) = walk.pop() {
        let n = out[i];
        if n.child_mask() == 0 {
            // The empty root: no children.
        } else if leaf_parent(of[i], level[i]) {
            out[i].first = (-i64::from(next_leaf) - 1) as i32 as u32;
            next_leaf += n.child_mask().count_ones();
        } else {
            let k = n.child_mask().count_ones() as usize;
            let f = n.first as usize;
            walk.extend((f..f + k).rev());
        }
    }
    out
}
