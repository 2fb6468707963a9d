//! Subtrees cut at one level, put back into one node array in the canonical node order
//! (`docs/format.md`, "Canonical node order"): what the merge of a bake's parts and the
//! reader of a chunked (version 3) file both do.
//!
//! The cut leaves the subtrees' roots at level `T` (their Morton codes at that level) and the
//! top levels above them, which the codes alone determine. The order puts a node's children
//! block before its children's own nodes, which follow from the last child to the first; so
//! the pieces come out in file order: top records, the records of the subtrees' roots (in
//! their parents' blocks), and each subtree's nodes below its root, for the caller to copy
//! with its pointers moved.

use crate::octree::tree::Node;
use std::ops::Range;

/// A node record with its pointers moved: an inner node's `first` by `nodes_by`, a leaf
/// parent's leaf base by `leaves_by`; a node without children is left as it is. `None` when
/// a moved pointer leaves `0..2^31`, which the file's words cannot hold.
pub(crate) fn moved(n: Node, nodes_by: i64, leaves_by: i64) -> Option<Node> {
    let fits = |v: i64| (0..1i64 << 31).contains(&v);
    let info = n.info & 0xFF;
    if let Some(base) = n.leaf_base() {
        let base = i64::from(base) + leaves_by;
        fits(base).then_some(Node {
            info,
            first: (-base - 1) as i32 as u32,
        })
    } else if info != 0 {
        let first = i64::from(n.first) + nodes_by;
        fits(first).then_some(Node {
            info,
            first: first as u32,
        })
    } else {
        Some(Node {
            info,
            first: n.first,
        })
    }
}

/// A subtree of a tree cut at a level, as a tree of its own: its root is `nodes[root]`, the
/// nodes below it are `nodes[below]` (contiguous in the depth-first order), and its
/// leaves are `leaf_base..leaf_base + leaves`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Cut {
    /// The root's Morton code at the cut level.
    pub code: u64,
    /// The root's index.
    pub root: usize,
    /// The nodes below the root.
    pub below: Range<usize>,
    /// The first leaf.
    pub leaf_base: u64,
    /// Its leaves.
    pub leaves: u64,
}

impl Cut {
    /// Node `i` of the subtree numbered on its own (the root 0, the nodes below it from 1),
    /// its leaves from 0: `None` past its last node.
    pub(crate) fn local(&self, nodes: &[Node], i: usize) -> Option<Node> {
        let n = if i == 0 {
            nodes[self.root]
        } else {
            *nodes
                .get(self.below.start + i - 1)
                .filter(|_| i <= self.below.len())?
        };
        moved(n, 1 - self.below.start as i64, -(self.leaf_base as i64))
    }
}

/// The subtrees of the tree of depth-first `nodes` under the nodes at `level` (above its
/// depth), in increasing code; none for the empty tree.
pub(crate) fn cut(nodes: &[Node], level: u8) -> Vec<Cut> {
    let mut out = Vec::new();
    let mut leaf_base = 0u64;
    // (node, level, code), children pushed last first so they pop in child order.
    let mut stack = vec![(0usize, 0u8, 0u64)];
    while let Some((i, l, code)) = stack.pop() {
        let n = nodes[i];
        if n.child_mask() == 0 {
            continue;
        }
        if l == level {
            let (below, leaves) = extent(nodes, i);
            out.push(Cut {
                code,
                root: i,
                below,
                leaf_base,
                leaves,
            });
            leaf_base += leaves;
            continue;
        }
        let mask = n.child_mask();
        let mut slot = n.first as usize + mask.count_ones() as usize;
        for c in (0..8u64).rev().filter(|c| mask >> c & 1 == 1) {
            slot -= 1;
            stack.push((slot, l + 1, code << 3 | c));
        }
    }
    out
}

/// The nodes below node `i` (a contiguous range in the canonical order) and its leaves.
fn extent(nodes: &[Node], i: usize) -> (Range<usize>, u64) {
    let n = nodes[i];
    if n.is_leaf_parent() {
        let at = i + 1;
        return (at..at, u64::from(n.child_mask().count_ones()));
    }
    let (mut count, mut leaves) = (0usize, 0u64);
    let mut stack = vec![i];
    while let Some(j) = stack.pop() {
        let m = nodes[j];
        let k = m.child_mask().count_ones() as usize;
        if m.is_leaf_parent() {
            leaves += k as u64;
        } else if k > 0 {
            count += k;
            stack.extend(m.first as usize..m.first as usize + k);
        }
    }
    let start = n.first as usize;
    (start..start + count, leaves)
}

/// A subtree under the cut: its root's Morton code at the cut level and how many nodes lie
/// below its root.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Stub {
    /// The root's code at the cut level (x in bit 2, y in bit 1, z in bit 0 at each level,
    /// the root's child first).
    pub code: u64,
    /// Nodes below the root (0 when the root's children are leaves).
    pub below: u64,
}

/// One piece of the node array, in file order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Piece {
    /// A node above the cut, complete.
    Top(Node),
    /// The root of subtree `index`, whose nodes below it are placed from `at`.
    Root {
        /// The subtree.
        index: usize,
        /// Where its nodes below the root start.
        at: u64,
    },
    /// The nodes below the root of subtree `index`, placed from `at`.
    Below {
        /// The subtree.
        index: usize,
        /// Where they start.
        at: u64,
    },
}

/// The child index at `level + 1` of a code at `target`.
fn child_of(code: u64, level: u8, target: u8) -> u8 {
    (code >> (3 * u32::from(target - level - 1)) & 7) as u8
}

/// The subtrees in `range` (one node's, at `level`, in increasing code) split by the node's
/// children.
fn by_child(stubs: &[Stub], range: Range<usize>, level: u8, target: u8) -> Vec<(u8, Range<usize>)> {
    let mut out = Vec::new();
    let mut at = range.start;
    while at < range.end {
        let c = child_of(stubs[at].code, level, target);
        let mut end = at + 1;
        while end < range.end && child_of(stubs[end].code, level, target) == c {
            end += 1;
        }
        out.push((c, at..end));
        at = end;
    }
    out
}

/// Nodes placed for a child at `level + 1` whose subtrees are `range`: its record and all
/// below it.
fn child_size(stubs: &[Stub], range: Range<usize>, level: u8, target: u8) -> u64 {
    1 + if level + 1 == target {
        stubs[range.start].below
    } else {
        below(stubs, range, level + 1, target)
    }
}

/// Nodes placed after a node at `level` above the cut whose subtrees are `range`: its
/// children block and each child's own.
fn below(stubs: &[Stub], range: Range<usize>, level: u8, target: u8) -> u64 {
    by_child(stubs, range, level, target)
        .into_iter()
        .map(|(_, r)| child_size(stubs, r, level, target))
        .sum()
}

/// The record of a node at `level` above the cut whose children block is placed at `at`.
fn top_record(stubs: &[Stub], range: Range<usize>, level: u8, target: u8, at: u64) -> Node {
    let mask = by_child(stubs, range, level, target)
        .iter()
        .fold(0u8, |m, (c, _)| m | 1 << c);
    Node {
        info: u32::from(mask),
        first: if mask == 0 { 0 } else { at as u32 },
    }
}

/// The nodes of the whole tree: the top levels, the subtrees' roots and their nodes.
/// `stubs` are in increasing code, at most one per code, all below `8^target`.
pub(crate) fn node_count(stubs: &[Stub], target: u8) -> u64 {
    match stubs.first() {
        None => 1,
        Some(s) if target == 0 => 1 + s.below,
        Some(_) => 1 + below(stubs, 0..stubs.len(), 0, target),
    }
}

/// Calls `emit` with the pieces of the node array in file order (see [`Piece`]), stopping at
/// its first error. `stubs` as for [`node_count`]; top records hold node indices, which must
/// fit the file's words (the caller checks [`node_count`] first).
pub(crate) fn stitch<E>(
    stubs: &[Stub],
    target: u8,
    emit: &mut dyn FnMut(Piece) -> Result<(), E>,
) -> Result<(), E> {
    if target == 0 {
        if stubs.is_empty() {
            return emit(Piece::Top(Node::default()));
        }
        emit(Piece::Root { index: 0, at: 1 })?;
        return emit(Piece::Below { index: 0, at: 1 });
    }
    emit(Piece::Top(top_record(stubs, 0..stubs.len(), 0, target, 1)))?;
    place(stubs, 0..stubs.len(), 0, target, 1, emit)
}

/// Places a node at `level` above the cut whose children block starts at `at`: the block,
/// then each child's subtree from the last child to the first.
fn place<E>(
    stubs: &[Stub],
    range: Range<usize>,
    level: u8,
    target: u8,
    at: u64,
    emit: &mut dyn FnMut(Piece) -> Result<(), E>,
) -> Result<(), E> {
    let children = by_child(stubs, range, level, target);
    // Child j's own nodes start after the block and the subtrees of the children after it.
    let mut starts = vec![0u64; children.len()];
    let mut next = at + children.len() as u64;
    for j in (0..children.len()).rev() {
        starts[j] = next;
        next += child_size(stubs, children[j].1.clone(), level, target) - 1;
    }
    for (j, (_, r)) in children.iter().enumerate() {
        emit(if level + 1 == target {
            Piece::Root {
                index: r.start,
                at: starts[j],
            }
        } else {
            Piece::Top(top_record(stubs, r.clone(), level + 1, target, starts[j]))
        })?;
    }
    for j in (0..children.len()).rev() {
        let r = children[j].1.clone();
        if level + 1 == target {
            emit(Piece::Below {
                index: r.start,
                at: starts[j],
            })?;
        } else {
            place(stubs, r, level + 1, target, starts[j], emit)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::grid::RootCube;
    use crate::octree::builder::Voxel;
    use crate::octree::tree::Octree;
    use glam::{DVec3, UVec3};

    /// Cutting a tree at every level and stitching its subtrees back gives its node array.
    #[test]
    fn stitching_the_cut_subtrees_gives_the_tree_back() {
        let mut rnd = svo_tests::seeds::xorshift(0x5717_c4ed);
        for depth in [1u8, 2, 3, 5] {
            for density in [1u32, 8, 64] {
                let side = 1u32 << depth;
                let cells: Vec<_> = (0..side * side * side)
                    .filter(|_| rnd() % 97 < u64::from(density))
                    .map(|i| {
                        (
                            UVec3::new(i % side, i / side % side, i / side / side),
                            Voxel::glass(),
                        )
                    })
                    .collect();
                let root = RootCube {
                    origin: DVec3::ZERO,
                    side: 1.0,
                };
                let tree = Octree::from_cells(root, depth, cells).unwrap();
                for target in 0..depth {
                    let subs = cut(&tree.nodes, target);
                    assert_eq!(
                        subs.iter().map(|s| s.leaves).sum::<u64>(),
                        u64::from(tree.leaf_count)
                    );
                    let stubs: Vec<Stub> = subs
                        .iter()
                        .map(|s| Stub {
                            code: s.code,
                            below: s.below.len() as u64,
                        })
                        .collect();
                    assert_eq!(node_count(&stubs, target), tree.nodes.len() as u64);
                    let mut nodes = Vec::new();
                    let back = |s: &Cut, i: usize, at: u64| {
                        let n = s.local(&tree.nodes, i).unwrap();
                        moved(n, at as i64 - 1, s.leaf_base as i64).unwrap()
                    };
                    stitch::<()>(&stubs, target, &mut |p| {
                        match p {
                            Piece::Top(n) => nodes.push(n),
                            Piece::Root { index, at } => nodes.push(back(&subs[index], 0, at)),
                            Piece::Below { index, at } => {
                                let s = &subs[index];
                                assert_eq!(nodes.len() as u64, at);
                                for i in 1..=s.below.len() {
                                    nodes.push(back(s, i, at));
                                }
                            }
                        }
                        Ok(())
                    })
                    .unwrap();
                    let plain: Vec<Node> = tree
                        .nodes
                        .iter()
                        .map(|n| Node {
                            info: n.info & 0xFF,
                            first: n.first,
                        })
                        .collect();
                    assert_eq!(nodes, plain, "depth {depth} density {density} cut {target}");
                }
            }
        }
    }
}
