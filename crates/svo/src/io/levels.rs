//! Version 4's node order: the nodes level by level, each level's children blocks in the order
//! of their parents (so the leaf parents, and with them the leaves, stay in depth-first
//! order). Files store it so that the top levels of a tree are a prefix of the file; trees in
//! memory keep the canonical depth-first order, which the traversal walks faster (subtrees
//! stay together), so the writer renumbers the nodes one way and the reader the other. Checks
//! 15 to 17 of `docs/format.md` on a node array in this order are here too.

use crate::octree::format_check::Check;
use crate::octree::tree::Node;
use crate::octree::validate::{Failure, check_node_shape};

/// A canonical tree's nodes in level order.
pub(crate) struct LevelOrder {
    /// For each node in level order, its index in the depth-first array.
    pub from: Vec<u32>,
    /// The nodes in level order, as files store them: bits 8-31 of `info` zero, and an inner
    /// node's `first` the level-order index of its children block.
    pub nodes: Vec<Node>,
    /// Nodes on each level, the root's first (`depth` entries; levels below an empty root
    /// have none).
    pub counts: Vec<u64>,
}

/// Renumbers the nodes of a tree of `depth` levels whose shape and node order passed checks 15
/// and 16 level by level.
pub(crate) fn level_order(nodes: &[Node], depth: u8) -> LevelOrder {
    let mut from = Vec::with_capacity(nodes.len());
    let mut out = Vec::with_capacity(nodes.len());
    let mut counts = vec![0u64; usize::from(depth)];
    from.push(0u32);
    let (mut level, mut level_end) = (0usize, 1usize);
    let mut i = 0;
    while i < from.len() {
        if i == level_end {
            level += 1;
            level_end = from.len();
        }
        counts[level] += 1;
        let n = nodes[from[i] as usize];
        let mut first = n.first;
        if !n.is_leaf_parent() && n.child_mask() != 0 {
            first = from.len() as u32;
            from.extend((0..n.child_mask().count_ones()).map(|j| n.first + j));
        }
        out.push(Node {
            info: n.info & 0xFF,
            first,
        });
        i += 1;
    }
    LevelOrder {
        from,
        nodes: out,
        counts,
    }
}

/// The canonical depth-first node array of a tree whose nodes are in level order (and passed
/// [`check_level_order`]), and for each node in level order its depth-first index.
pub(crate) fn depth_first(nodes: &[Node]) -> (Vec<Node>, Vec<u32>) {
    let n = nodes.len();
    let mut out = vec![Node::default(); n];
    let mut at = vec![0u32; n];
    if n == 0 {
        return (out, at);
    }
    out[0] = nodes[0];
    let mut next = 1u32;
    let mut stack = vec![0u32];
    while let Some(b) = stack.pop() {
        let node = nodes[b as usize];
        let k = node.child_mask().count_ones();
        if node.is_leaf_parent() || k == 0 {
            continue;
        }
        out[at[b as usize] as usize].first = next;
        for j in 0..k {
            let c = node.first + j;
            at[c as usize] = next + j;
            out[(next + j) as usize] = nodes[c as usize];
            // Placed children's subtrees follow from the last child to the first.
            stack.push(c);
        }
        next += k;
    }
    (out, at)
}

/// Checks 15 and 16 (one walk, level by level, 15 before 16 at the same node), then 17, on the
/// first `walked` levels of a node array in level order (`counts` the nodes a level, as the
/// level table has them): only the root may have no children, and then its `first` is 0;
/// exactly the nodes of level `depth - 1` point to leaves; every other inner node's block is
/// the next one on the level below, and each level below a walked one has exactly the nodes
/// its parents' blocks hold; the leaf parents' leaves follow one another from 0 to
/// `leaf_count`. With `walked < depth` (a file's top levels read alone) the nodes of level
/// `walked`, which hold the nodes' `first`s point to, are not walked.
pub(crate) fn check_level_order(
    nodes: &[Node],
    counts: &[u64],
    walked: usize,
    depth: u8,
    leaf_count: u64,
) -> Result<(), Failure> {
    let depth = usize::from(depth);
    let (mut start, mut next) = (0u64, counts[0]);
    for l in 0..walked {
        let end = start + counts[l];
        let below_end = end + counts.get(l + 1).copied().unwrap_or(0);
        for i in start..end {
            let node = nodes[i as usize];
            let k = u64::from(node.child_mask().count_ones());
            // Not a leaf parent, nor the empty root: its block is on the level below.
            if check_node_shape(i, node, l as u8, depth as u8, true)? != Some(false) {
                continue;
            }
            let first = u64::from(node.first);
            if first != next || first + k > below_end {
                return Err((
                    Check::NodeOrder,
                    format!(
                        "node {i}: its children are at {first}, level order puts them at \
                         {next} (level {} holds nodes up to {below_end})",
                        l + 1
                    ),
                ));
            }
            next += k;
        }
        if l + 1 < depth && next != below_end {
            return Err((
                Check::NodeOrder,
                format!(
                    "level {} holds nodes up to {below_end}, the nodes of level {l} have \
                     children up to {next}",
                    l + 1
                ),
            ));
        }
        start = end;
    }
    if walked < depth {
        return Ok(());
    }
    // 17: the leaf parents, all on the last level, in order.
    let mut seen = 0u64;
    let last: u64 = counts[..depth - 1].iter().sum();
    for i in last..last + counts[depth - 1] {
        let node = nodes[i as usize];
        if let Some(base) = node.leaf_base() {
            if u64::from(base) != seen {
                return Err((
                    Check::LeafOrder,
                    format!(
                        "node {i}: its leaves start at {base}, level order puts them at {seen}"
                    ),
                ));
            }
            seen += u64::from(node.child_mask().count_ones());
        }
    }
    if seen != leaf_count {
        return Err((
            Check::LeafOrder,
            format!("the tree refers to {seen} leaves, the count says {leaf_count}"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::octree::{Octree, RootCube, Voxel};
    use glam::{DVec3, UVec3};

    /// Level order and back gives the canonical array, for seeded random trees of depths 1 to
    /// 6 and the empty tree, and the level order passes checks 15 to 17.
    #[test]
    fn level_order_round_trips() {
        let mut rnd = svo_tests::seeds::xorshift(0x1e7e1);
        let root = RootCube {
            origin: DVec3::ZERO,
            side: 1.0,
        };
        for case in 0..60u32 {
            let depth = 1 + (case % 6) as u8;
            let side = 1u32 << depth;
            let n = if case % 10 == 0 { 0 } else { 1 + rnd() % 200 };
            let cells = (0..n).map(|_| {
                let c = UVec3::new(rnd() as u32, rnd() as u32, rnd() as u32) % side;
                (c, Voxel::glass())
            });
            let tree = Octree::from_cells(root, depth, cells).unwrap();
            let lo = level_order(&tree.nodes, depth);
            assert_eq!(lo.counts.iter().sum::<u64>(), tree.nodes.len() as u64);
            check_level_order(
                &lo.nodes,
                &lo.counts,
                usize::from(depth),
                depth,
                u64::from(tree.leaf_count),
            )
            .unwrap();
            let (back, at) = depth_first(&lo.nodes);
            let mut plain = tree.nodes.clone();
            plain.iter_mut().for_each(|n| n.info &= 0xFF);
            assert_eq!(back, plain, "case {case}");
            for (b, &f) in at.iter().zip(&lo.from) {
                assert_eq!(*b, f);
            }
        }
    }
}
