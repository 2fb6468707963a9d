//! The node orders a tree in memory keeps (level order with inner-node attributes, else
//! depth-first), checked from the nodes alone, and the shape two trees share whatever their
//! order.

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

/// Whether the nodes are numbered level by level, each level's children blocks in the order
/// of their parents.
pub fn is_level_order(t: &Octree) -> bool {
    let firsts: Vec<u32> = (t.nodes.iter())
        .filter(|n| !n.is_leaf_parent() && n.child_mask() != 0)
        .map(|n| n.first)
        .collect();
    levels(t).windows(2).all(|w| w[0] <= w[1]) && firsts.windows(2).all(|w| w[0] < w[1])
}

/// Whether two trees have the same shape whatever their node order: as many nodes, and the
/// same leaves in the same cells.
pub fn same_shape(a: &Octree, b: &Octree) -> bool {
    let cells = |t: &Octree| t.leaves().map(|l| (l.index, l.cell)).collect::<Vec<_>>();
    a.depth == b.depth && a.nodes.len() == b.nodes.len() && cells(a) == cells(b)
}
