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
//!
//! Each node may carry a value beside its record (its encoded attributes), which moves with
//! the record; a node's value is made with its record, from the sums its children's records
//! carried up ([`Sums`]).

use crate::octree::tree::Node;

/// What a node's record carries up the build for its parent's value.
pub(crate) trait Sums: Copy + Default + Send + Sync + std::fmt::Debug {
    /// Adds a child's sums (called in child order).
    fn add(&mut self, child: &Self);
}

impl Sums for () {
    fn add(&mut self, _: &Self) {}
}

/// Leaf data that travels with a chunk of nodes, and what its nodes carry.
pub(crate) trait LeafStore: Default + Send {
    /// The sums a record carries to its parent.
    type Sums: Sums;
    /// What a node stores beside its record.
    type NodeValue: Copy + Default + Send + Sync + std::fmt::Debug;
    /// How many leaves.
    fn len(&self) -> usize;
}

/// A node's record with its sums and value, before it is placed in its parent's block.
pub(crate) type Record<L> = (Node, <L as LeafStore>::Sums, <L as LeafStore>::NodeValue);

/// The sums of a node whose children's records are `records` (in child order).
pub(crate) fn children_sums<L: LeafStore>(records: &[Record<L>]) -> L::Sums {
    let mut sums = L::Sums::default();
    for r in records {
        sums.add(&r.1);
    }
    sums
}

/// A part of an octree under construction: nodes in post-order, their values and their
/// leaves.
#[derive(Debug, Default)]
pub(crate) struct Chunk<L: LeafStore> {
    /// Nodes, in post-order until [`Chunk::finish`].
    pub nodes: Vec<Node>,
    /// Each node's value, at its node's index.
    pub values: Vec<L::NodeValue>,
    /// The leaves that the chunk's nodes refer to.
    pub leaves: L,
}

impl<L: LeafStore> Chunk<L> {
    /// An empty chunk.
    pub(crate) fn new() -> Self {
        Self {
            nodes: Vec::new(),
            values: Vec::new(),
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

    /// Appends a children block holding `records` (the existing children's, in child-index
    /// order) and returns the parent's record and the sum of the children's sums.
    pub(crate) fn push_children(&mut self, mask: u8, records: &[Record<L>]) -> (Node, L::Sums) {
        debug_assert_eq!(mask.count_ones() as usize, records.len());
        let start = self.nodes.len();
        let sums = children_sums::<L>(records);
        self.nodes.extend(records.iter().rev().map(|r| r.0));
        self.values.extend(records.iter().rev().map(|r| r.2));
        let node = Node {
            info: u32::from(mask),
            first: start as u32,
        };
        (node, sums)
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
    /// the nodes (root at index 0), their values and the leaves. `root = None` gives the
    /// empty tree: one root node with no children.
    pub(crate) fn finish(mut self, root: Option<Record<L>>) -> (Vec<Node>, Vec<L::NodeValue>, L) {
        let (node, value) = root.map_or_else(Default::default, |r| (r.0, r.2));
        self.nodes.push(node);
        self.values.push(value);
        let n = self.nodes.len() as u32;
        self.nodes.reverse();
        self.values.reverse();
        for node in &mut self.nodes {
            if !node.is_leaf_parent() && node.child_mask() != 0 {
                let k = node.child_mask().count_ones();
                node.first = n - node.first - k;
            }
        }
        (self.nodes, self.values, self.leaves)
    }
}
