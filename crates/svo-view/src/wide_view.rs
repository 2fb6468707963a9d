//! The 64-ary view of an octree, built when a tree is uploaded for the GPU's traversal
//! ([`crate::gpu_render::GpuLayout::wide_view`]): every second level of the octree as nodes
//! of 4x4x4 cells, so a ray crosses a node's cells in one loop instead of descending through
//! the level between.
//!
//! A view node stands for an octree node two, four, six... levels above the leaves and
//! holds its grandchildren: four words, the 64-bit mask of the grandchildren that exist
//! (low word first), the index of the first of them, and the octree node's `info` word (its
//! child mask and its box of leaves, [`svo::octree::Node::info`]). Bit `8 * o + i` of the
//! mask is grandchild `i` of child `o`, the octree's own child indices (bit 2 x, 1 y, 0 z),
//! so a cell at coordinates `(x, y, z)` in `0..4` is bit `8 * (x / 2 * 4 + y / 2 * 2 + z /
//! 2) + (x % 2 * 4 + y % 2 * 2 + z % 2)`, and the grandchildren that exist are numbered by
//! the bits below theirs. Above the leaves they are view nodes, numbered breadth first; at
//! the level above the leaves they are leaves, whose indices must then run on without gaps
//! (the depth-first order of the leaf arrays of every tree `svo` builds or reads).
//!
//! A tree of odd depth has, above those, a root of 2x2x2 cells (bit `o` of its mask for
//! child `o`). A tree whose leaves are in another order has no view ([`build`] returns
//! `None`) and is walked as an octree.
//!
//! Its size is 16 bytes a node for every second level of the octree's nodes: for the bunny
//! at depth 8 (224,716 leaves) 14,842 nodes, 0.24 MB, about 1.06 bytes a leaf.

use svo::octree::{Node, Octree};

/// Words of a view node.
pub const NODE_WORDS: usize = 4;

/// The 64-ary view of `tree` as `u32` words, four a node, the root first; `None` for trees
/// whose leaves are not in depth-first order (and for malformed trees).
pub fn build(tree: &Octree) -> Option<Vec<u32>> {
    let depth = u32::from(tree.depth);
    let nodes = &tree.nodes;
    let root = *nodes.first()?;
    if depth == 0 {
        return None;
    }
    let mut out: Vec<u32> = Vec::new();
    // The octree nodes the view nodes stand for, with their levels, in view order.
    let mut queue = std::collections::VecDeque::new();
    let mut next_free = 1u64;
    let mut kids: Vec<u32> = Vec::with_capacity(64);
    // The first of a node's children in the view: the first of its leaves, which must run on
    // without gaps, or the next view node, the children queued.
    let mut first_of = |kids: &[u32],
                        leaves: bool,
                        level: u32,
                        queue: &mut std::collections::VecDeque<(u32, u32)>| {
        if leaves {
            let f = kids.first().copied().unwrap_or(0);
            let runs_on = kids
                .iter()
                .zip(0u32..)
                .all(|(&l, k)| Some(l) == f.checked_add(k));
            return runs_on.then_some(f);
        }
        let f = u32::try_from(next_free).ok()?;
        next_free += kids.len() as u64;
        queue.extend(kids.iter().map(|&k| (k, level)));
        Some(f)
    };
    if depth % 2 == 1 {
        // An odd depth: the root alone is a node of 2x2x2 cells, bit `o` for its child `o`.
        push_children(root, depth == 1, &mut kids)?;
        let first = first_of(&kids, depth == 1, 1, &mut queue)?;
        out.extend([u32::from(root.child_mask()), 0, first, root.info]);
    } else {
        queue.push_back((0u32, 0u32));
    }
    while let Some((index, level)) = queue.pop_front() {
        let node = *nodes.get(index as usize)?;
        let last = level + 2 == depth;
        let mut mask = 0u64;
        kids.clear();
        for o in 0..8u8 {
            let Some(r) = node.child_rank(o) else {
                continue;
            };
            if node.is_leaf_parent() {
                return None;
            }
            let child = *nodes.get(node.first.checked_add(r)? as usize)?;
            push_children(child, last, &mut kids)?;
            mask |= u64::from(child.child_mask()) << (8 * u32::from(o));
        }
        let first = first_of(&kids, last, level + 2, &mut queue)?;
        out.extend([mask as u32, (mask >> 32) as u32, first, node.info]);
    }
    Some(out)
}

/// Pushes the index of each of `node`'s children onto `kids` in child order: its leaves'
/// where `leaves`, else its child nodes'; `None` where the node's children are of the other
/// kind (or their indices overflow).
fn push_children(node: Node, leaves: bool, kids: &mut Vec<u32>) -> Option<()> {
    for i in 0..8u8 {
        let Some(r) = node.child_rank(i) else {
            continue;
        };
        kids.push(match (node.leaf_base(), leaves) {
            (Some(base), true) => base.checked_add(r)?,
            (None, false) => node.first.checked_add(r)?,
            _ => return None,
        });
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec3, UVec3};
    use svo::octree::{RootCube, Voxel};

    fn tree_of(depth: u8, cells: &[UVec3]) -> Octree {
        let root = RootCube {
            origin: DVec3::ZERO,
            side: 1.0,
        };
        Octree::from_cells(root, depth, cells.iter().map(|&c| (c, Voxel::default()))).unwrap()
    }

    /// The leaf that the view finds for `cell` by walking its nodes as the shader does.
    fn view_leaf(view: &[u32], depth: u8, cell: UVec3) -> Option<u32> {
        let mut node = 0usize;
        let mut side = 1u32 << depth;
        // The root of an odd depth has 2x2x2 cells.
        let mut cells = if depth % 2 == 1 { 2 } else { 4 };
        loop {
            let q = side / cells;
            let c = (cell % side) / q;
            let (o, i) = (c / 2, c % 2);
            let b = 8 * (o.x * 4 + o.y * 2 + o.z) + (i.x * 4 + i.y * 2 + i.z);
            cells = 4;
            let w = &view[NODE_WORDS * node..NODE_WORDS * node + NODE_WORDS];
            let mask = u64::from(w[0]) | u64::from(w[1]) << 32;
            if mask >> b & 1 == 0 {
                return None;
            }
            let index = w[2] + (mask & ((1u64 << b) - 1)).count_ones();
            if q == 1 {
                return Some(index);
            }
            node = index as usize;
            side = q;
        }
    }

    /// Seeded random trees at depths 1 to 7: every cell's leaf through the view is the
    /// octree's, every empty cell is empty, and each view node carries its octree node's
    /// `info` (child mask and box).
    #[test]
    fn the_view_finds_every_leaf_of_the_octree() {
        let mut state = 0x5EED_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for depth in 1..=7u8 {
            for density in [1u64, 10, 60] {
                let n = 1u32 << depth;
                let mut cells = Vec::new();
                for x in 0..n {
                    for y in 0..n {
                        for z in 0..n {
                            if next() % 100 < density {
                                cells.push(UVec3::new(x, y, z));
                            }
                        }
                    }
                }
                if cells.is_empty() {
                    continue;
                }
                let tree = tree_of(depth, &cells);
                let view = build(&tree).expect("a tree svo builds has a view");
                assert_eq!(view[3], tree.nodes[0].info);
                for x in 0..n {
                    for y in 0..n {
                        for z in 0..n {
                            let cell = UVec3::new(x, y, z);
                            assert_eq!(view_leaf(&view, depth, cell), tree.leaf_at(cell));
                        }
                    }
                }
            }
        }
    }

    /// Leaves out of depth-first order under one view node have no view, at even and odd
    /// depths.
    #[test]
    fn other_leaf_orders_have_none() {
        for depth in [2u8, 3] {
            let cells = [UVec3::new(0, 0, 0), UVec3::new(3, 3, 3)];
            let mut tree = tree_of(depth, &cells);
            assert!(build(&tree).is_some());
            let parents: Vec<usize> = (0..tree.nodes.len())
                .filter(|&i| tree.nodes[i].is_leaf_parent())
                .collect();
            assert_eq!(parents.len(), 2);
            let (a, b) = (tree.nodes[parents[0]].first, tree.nodes[parents[1]].first);
            tree.nodes[parents[0]].first = b;
            tree.nodes[parents[1]].first = a;
            assert!(build(&tree).is_none(), "depth {depth}");
        }
    }
}
