//! Emitting the packed node layout (DESIGN.md section 3) from a depth-first build.
//!
//! A node is two `u32` words: `info` (bits 0-7: which children exist) and `first`: where
//! the node's existing children sit, packed in child-index order, so child `i` is at
//! `first + popcount(info & ((1 << i) - 1))`. A node one level above the leaves stores
//! `first = -(leaf_base + 1)` as `i32`, and its leaves sit packed from `leaf_base` in the
//! leaf arrays. Node 0 is the root; every pointer points forward, so the tree has no cycles.
//!
//! Builders work bottom-up: a subtree is emitted only once it is known to hold leaves, so an
//! empty subtree costs nothing and no pointer needs patching. Children blocks are therefore
//! appended *after* their subtrees (post-order, with each block's records in reverse child
//! order); [`Chunk::finish`] reverses the array once, which puts the root first, every block
//! in child order and every pointer forward. Independent subtrees (built in parallel) are
//! copied into place with their pointers moved by [`Chunk::relocate`].

use crate::octree::tree::Node;

/// Leaf data that travels with a chunk of nodes.
pub(crate) trait LeafStore: Default + Send {
    /// How many leaves.
    fn len(&self) -> usize;
}

/// A part of an octree under construction: nodes in post-order and their leaves.
#[derive(Debug, Default)]
pub(crate) struct Chunk<L> {
    /// Nodes, in post-order until [`Chunk::finish`].
    pub nodes: Vec<Node>,
    /// The leaves that the chunk's nodes refer to.
    pub leaves: L,
}

impl<L: LeafStore> Chunk<L> {
    /// An empty chunk.
    pub(crate) fn new() -> Self {
        Self {
            nodes: Vec::new(),
            leaves: L::default(),
        }
    }

    /// The record of a node whose children are the leaves `base..base + popcount(mask)`.
    pub(crate) fn leaf_parent(mask: u8, base: usize) -> Node {
        Node {
            info: u32::from(mask),
            first: (-(base as i64) - 1) as i32 as u32,
        }
    }

    /// Appends a children block holding `records` (the existing children's records, in
    /// child-index order) and returns the parent's record.
    pub(crate) fn push_children(&mut self, mask: u8, records: &[Node]) -> Node {
        debug_assert_eq!(mask.count_ones() as usize, records.len());
        let start = self.nodes.len();
        self.nodes.extend(records.iter().rev());
        Node {
            info: u32::from(mask),
            first: start as u32,
        }
    }

    /// Relocates a record of a chunk whose nodes move by `node_off` and leaves by `leaf_off`.
    pub(crate) fn relocate(n: Node, node_off: u32, leaf_off: usize) -> Node {
        if n.is_leaf_parent() {
            let base = n.leaf_base().unwrap_or(0) as usize + leaf_off;
            Self::leaf_parent(n.child_mask(), base)
        } else if n.child_mask() != 0 {
            Node {
                info: n.info,
                first: n.first + node_off,
            }
        } else {
            n
        }
    }

    /// Appends the root record, reverses the post-order into the final layout and returns
    /// the nodes (root at index 0) and the leaves. `root = None` gives the empty tree: one
    /// root node with no children.
    pub(crate) fn finish(mut self, root: Option<Node>) -> (Vec<Node>, L) {
        self.nodes.push(root.unwrap_or_default());
        let n = self.nodes.len() as u32;
        self.nodes.reverse();
        for node in &mut self.nodes {
            if !node.is_leaf_parent() && node.child_mask() != 0 {
                let k = node.child_mask().count_ones();
                node.first = n - node.first - k;
            }
        }
        (self.nodes, self.leaves)
    }
}
