//! Level order: the nodes level by level, each level's children blocks in the order of their
//! parents (so the leaf parents, and with them the leaves, stay in depth-first order).
//! Version-4 files store it so that the top levels of a tree are a prefix of the file. In
//! memory a tree with inner-node attributes keeps it too ([`keeps_level_order`]): a walk that
//! stops at its footprint reads the nodes of a few levels, which then lie together; a tree
//! without them keeps the depth-first order, where a subtree's nodes lie together for the
//! exact walk. The renumbering either way, and checks 15 to 17 of `docs/format.md` on a node
//! array in level order, are here.

use crate::octree::format_check::Check;
use crate::octree::tree::{Channel, LeafAttributes, Node, Octree};
use crate::octree::validate::{Failure, check_node_shape};

/// Whether `tree`'s nodes are (and must be) in level order: exactly when it has inner-node
/// attributes; else they are in depth-first order.
pub(crate) fn keeps_level_order(tree: &Octree) -> bool {
    !tree.node_attributes.stored().is_empty()
}

/// Puts the nodes of a depth-first tree, and its inner nodes' channels with them, in level
/// order (the nodes' bounds move with them).
pub(crate) fn into_level_order(tree: &mut Octree) {
    let order = level_order(&tree.nodes, tree.depth);
    let mut nodes = order.nodes;
    for (n, &f) in nodes.iter_mut().zip(&order.from) {
        n.info = tree.nodes[f as usize].info;
    }
    tree.nodes = nodes;
    permute(&mut tree.node_attributes, &order.from);
}

/// Channels whose value `i` becomes the value `from[i]` had.
fn permute(a: &mut LeafAttributes, from: &[u32]) {
    fn one<T: Copy>(c: &mut Channel<T>, from: &[u32]) {
        if let Channel::PerLeaf(v) = c {
            let old = std::mem::take(v);
            *v = from.iter().map(|&f| old[f as usize]).collect();
        }
    }
    one(&mut a.normal, from);
    one(&mut a.contour, from);
    one(&mut a.colour, from);
    one(&mut a.reflectivity, from);
    one(&mut a.refractivity, from);
    one(&mut a.ior, from);
}

/// The nodes on each of a tree's `depth` levels (the root's first), reading `nodes` as a node
/// array in level order: a level holds the children blocks of the inner nodes of the level
/// above. Counts past the array's end are cut there; [`check_level_order`] then finds what is
/// wrong.
pub(crate) fn level_counts(nodes: &[Node], depth: u8) -> Vec<u64> {
    let n = nodes.len() as u64;
    let mut counts = vec![0u64; usize::from(depth)];
    let (mut start, mut end) = (0u64, n.min(1));
    for count in &mut counts {
        *count = end - start;
        let mut below = 0u64;
        for node in &nodes[start as usize..end as usize] {
            if !node.is_leaf_parent() {
                below += u64::from(node.child_mask().count_ones());
            }
        }
        (start, end) = (end, (end + below).min(n));
    }
    counts
}

/// A canonical tree's nodes in level order.
pub(crate) struct LevelOrder {
    /// For each node in level order, its index in the tree's array.
    pub from: Vec<u32>,
    /// The nodes in level order, as files store them: bits 8-31 of `info` zero, and an inner
    /// node's `first` the level-order index of its children block.
    pub nodes: Vec<Node>,
    /// Nodes on each level, the root's first (`depth` entries; levels below an empty root
    /// have none). Read by the writer only.
    #[cfg_attr(not(feature = "io"), allow(dead_code))]
    pub counts: Vec<u64>,
}

/// Renumbers the nodes of a tree of `depth` levels whose shape passed checks 15 and 16 (in
/// either canonical order: the walk follows the pointers), level by level.
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

#[cfg_attr(not(feature = "io"), allow(dead_code))]
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

    /// `tree` with inner-node channels of its leaves' kinds (zeros, or the leaves' constants).
    fn with_node_channels(mut tree: Octree) -> Octree {
        fn like<T: Copy + Default>(c: &Channel<T>, n: usize) -> Channel<T> {
            match c {
                Channel::Absent => Channel::Absent,
                Channel::Constant(v) => Channel::Constant(*v),
                Channel::PerLeaf(_) => Channel::PerLeaf(vec![T::default(); n]),
            }
        }
        let (a, n) = (&tree.attributes, tree.nodes.len());
        tree.node_attributes = LeafAttributes {
            normal: like(&a.normal, n),
            contour: like(&a.contour, n),
            colour: like(&a.colour, n),
            reflectivity: like(&a.reflectivity, n),
            refractivity: like(&a.refractivity, n),
            ior: like(&a.ior, n),
        };
        tree
    }

    /// A tree with inner-node channels is valid in level order and refused (check 16) in
    /// depth-first order; random edits of its nodes' words are refused or valid, never a panic,
    /// and the edits the checks let through still make a tree in level order.
    #[test]
    fn trees_with_node_channels_are_checked_in_level_order() {
        let mut rnd = svo_tests::seeds::xorshift(0x1e7e2);
        let (mut refused, mut valid) = (0, 0);
        for case in 0..40u32 {
            let depth = 3 + (case % 4) as u8;
            let n = 1 + rnd() % 300;
            let plain = crate::octree::scattered_tree(&mut rnd, depth, n);
            let depth_first = with_node_channels(plain.clone());
            let mut tree = depth_first.clone();
            into_level_order(&mut tree);
            tree.validate().unwrap();
            assert_eq!(
                level_counts(&tree.nodes, depth).iter().sum::<u64>(),
                tree.nodes.len() as u64
            );
            if level_order(&plain.nodes, depth).nodes != plain.nodes {
                let e = depth_first.validate().unwrap_err().to_string();
                assert!(e.contains("check 16"), "case {case}: {e}");
            }
            for _ in 0..50 {
                let mut bad = tree.clone();
                let i = (rnd() % bad.nodes.len() as u64) as usize;
                match rnd() % 3 {
                    0 => bad.nodes[i].first = rnd() as u32 % (bad.nodes.len() as u32 + 3),
                    1 => bad.nodes[i].first ^= 1 << (rnd() % 32),
                    _ => bad.nodes[i].info ^= 1 << (rnd() % 8),
                }
                match bad.validate() {
                    Ok(()) => {
                        valid += 1;
                        assert_eq!(level_order(&bad.nodes, depth).nodes.len(), bad.nodes.len());
                    }
                    Err(_) => refused += 1,
                }
            }
        }
        assert!(refused > 1000, "{refused} refused, {valid} valid");
    }

    /// Level order and back gives the canonical array, for seeded random trees of depths 1 to
    /// 6 and the empty tree, and the level order passes checks 15 to 17.
    #[test]
    fn level_order_round_trips() {
        let mut rnd = svo_tests::seeds::xorshift(0x1e7e1);
        for case in 0..60u32 {
            let depth = 1 + (case % 6) as u8;
            let n = if case % 10 == 0 { 0 } else { 1 + rnd() % 200 };
            let tree = crate::octree::scattered_tree(&mut rnd, depth, n);
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
