//! Validation of an octree: what the file reader runs on untrusted input before anything
//! traverses it (a malicious file must not hang or crash a reader or the GPU), and what
//! [`Octree::validate`] runs on a tree in memory. These are the checks 7 to 10 (as far as a
//! tree in memory has them) and 14 to 18 of `docs/format.md`, each error naming its
//! [`Check`].
//!
//! The tree must be in the canonical layout: children blocks where the canonical node order
//! puts them (level order for a tree with inner-node attributes, else depth-first) and leaves
//! numbered in depth-first child order. Checking positions against
//! counters of where the next block and the next leaf belong rules out cycles, sharing,
//! orphans and out-of-range references at once, and needs no memory per node or leaf.

use crate::geometry::grid::RootCube;
use crate::octree::contour::FULL;
use crate::octree::format_check::CURRENT_VERSION;
use crate::octree::format_check::Check;
use crate::octree::level_order::{check_level_order, keeps_level_order, level_counts};
use crate::octree::tree::{
    Channel, ChannelKind, ChannelStorage, LeafAttributes, NO_NORMAL, Node, Octree, StoredChannel,
};
use glam::DVec3;

/// The most leaves a tree may have: leaf references are `-(leaf_base + 1)` as an `i32`.
pub(crate) const MAX_LEAVES: u64 = 1 << 31;

/// A failed check and what failed.
pub(crate) type Failure = (Check, String);

/// Validates a tree in memory (as a version-2 file would hold it); the error names the check
/// and says what is wrong and where.
pub(crate) fn validate(t: &Octree) -> Result<(), crate::octree::builder::OctreeError> {
    check_tree(t, CURRENT_VERSION, InfoBits::Bounds)
        .map_err(|(check, detail)| crate::octree::builder::OctreeError::Invalid { check, detail })
}

/// What bits 8-31 of the nodes' `info` words may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum InfoBits {
    /// Zeros, as in a file.
    #[cfg_attr(not(feature = "io"), allow(dead_code))]
    Zero,
    /// Zeros or the node's derived bounds, as in a tree in memory.
    Bounds,
    /// Anything: the writer stores zeros whatever they hold.
    #[cfg_attr(not(feature = "io"), allow(dead_code))]
    Cleared,
}

/// Checks 7 to 9 on the values a file's header and a tree in memory both have: the depth,
/// the root cube, and the node and leaf counts.
pub(crate) fn check_root_and_counts(
    depth: u8,
    origin: DVec3,
    side: f64,
    node_count: u64,
    leaf_count: u64,
) -> Result<(), Failure> {
    if !(1..=crate::MAX_DEPTH).contains(&depth) {
        return Err((
            Check::Depth,
            format!("depth {depth} is outside 1..={}", crate::MAX_DEPTH),
        ));
    }
    if !(RootCube { origin, side }).is_valid() {
        return Err((
            Check::RootCube,
            "root cube is not finite and positive (its origin, side and far corner)".into(),
        ));
    }
    if node_count == 0 {
        return Err((Check::Counts, "no root node".into()));
    }
    if leaf_count > MAX_LEAVES || leaf_count > node_count.saturating_mul(8) {
        return Err((
            Check::Counts,
            format!(
                "{leaf_count} leaves: more than 2^31, or more than 8 for each of the \
                 {node_count} nodes"
            ),
        ));
    }
    Ok(())
}

/// The checks of a tree read from a file of format `version`, in the document's order.
pub(crate) fn check_tree(t: &Octree, version: u32, bits: InfoBits) -> Result<(), Failure> {
    let fail = |c: Check, m: String| Err((c, m));
    let (n, leaves) = (t.nodes.len(), u64::from(t.leaf_count));
    check_root_and_counts(t.depth, t.root.origin, t.root.side, n as u64, leaves)?;
    check_channel_layout(&t.attributes, leaves, "", "leaves")?;
    check_node_channels(t)?;
    if bits == InfoBits::Zero {
        check_node_words(&t.nodes)?;
    }
    let leaf_order = if keeps_level_order(t) {
        check_level_order_whole(&t.nodes, t.depth, leaves)?;
        true
    } else {
        check_shape_and_node_order(&t.nodes, t.depth, true, leaves)?
    };
    if bits == InfoBits::Bounds && t.nodes.iter().any(|n| n.info >> 8 != 0) {
        // The shape is sound, so each node's bounds are known.
        let mut derived = t.nodes.clone();
        crate::octree::bounds::derive_checked(&mut derived, t.depth);
        for (i, (node, want)) in t.nodes.iter().zip(derived).enumerate() {
            let (have, want) = (node.info & !0xFF, want.info & !0xFF);
            if have != 0 && have != want {
                return fail(
                    Check::NodeWords,
                    format!(
                        "node {i}: bits 8-31 ({have:#x}) are neither zero nor the node's bounds \
                         ({want:#x}); Octree::refresh_bounds derives them"
                    ),
                );
            }
        }
    }
    if !leaf_order {
        check_leaf_order(&t.nodes, leaves)?;
    }
    check_values(t, version)
}

/// The checks of a tree read from a version-4 file once its nodes passed checks 14 to 17 in
/// level order and were put in the canonical order (so they hold there by construction): the
/// counts, the channels' lengths and the values.
#[cfg_attr(not(feature = "io"), allow(dead_code))]
pub(crate) fn check_renumbered(t: &Octree, version: u32) -> Result<(), Failure> {
    let leaves = u64::from(t.leaf_count);
    check_root_and_counts(
        t.depth,
        t.root.origin,
        t.root.side,
        t.nodes.len() as u64,
        leaves,
    )?;
    check_channel_layout(&t.attributes, leaves, "", "leaves")?;
    check_node_channels(t)?;
    check_values(t, version)
}

/// Checks 10 and 12 on the channels of leaves or of nodes (`prefix` "" or "node ", `what`
/// "leaves" or "nodes", `count` of them): a contour channel comes with a normal channel, and
/// every array holds one value for each.
fn check_channel_layout(
    a: &LeafAttributes,
    count: u64,
    prefix: &str,
    what: &str,
) -> Result<(), Failure> {
    if !matches!(a.contour, Channel::Absent) && matches!(a.normal, Channel::Absent) {
        return Err((
            Check::Channels,
            format!("a {prefix}contour channel without a {prefix}normal channel"),
        ));
    }
    for (kind, storage) in a.storage() {
        if let ChannelStorage::PerLeaf(len) = storage
            && len as u64 != count
        {
            return Err((
                Check::ArrayLayout,
                format!(
                    "{prefix}channel {} has {len} values for {count} {what}",
                    kind.name()
                ),
            ));
        }
    }
    Ok(())
}

/// The inner nodes' channels of a tree in memory ([`Octree::node_attributes`]): a value per
/// node where they have one per node, a contour only beside a normal, and the normal and
/// contour words as check 18 has them for leaves (no interior-leaf word).
fn check_node_channels(t: &Octree) -> Result<(), Failure> {
    let a = &t.node_attributes;
    check_channel_layout(a, t.nodes.len() as u64, "node ", "nodes")?;
    let present = |a: &LeafAttributes| a.storage().map(|(_, s)| s != ChannelStorage::Absent);
    if present(a).contains(&true) && present(a) != present(&t.attributes) {
        return Err((
            Check::Channels,
            "the nodes' channels are not the leaves' kinds".into(),
        ));
    }
    // A leaf parent's values are not stored (a file's level `depth - 1` has no node arrays).
    let leaf_level = |i: usize, n: &Node| n.is_leaf_parent() || (t.depth == 1 && i == 0);
    for (kind, bytes, size) in a.stored().into_iter().filter_map(|(k, c)| match c {
        StoredChannel::PerLeaf { bytes, size } => Some((k, bytes, size)),
        StoredChannel::Constant(_) => None,
    }) {
        if let Some(i) = bytes
            .chunks_exact(size)
            .zip(&t.nodes)
            .enumerate()
            .position(|(i, (v, n))| leaf_level(i, n) && v.iter().any(|&b| b != 0))
        {
            return Err((
                Check::Values,
                format!(
                    "node {i}, a leaf parent, has a value in node channel {}: leaf parents' are 0",
                    ChannelKind::ALL[usize::from(kind)].name()
                ),
            ));
        }
    }
    let bad_normal = |w: u32| (w & 0xFFFF) == 0x8000 || (w >> 16) == 0x8000;
    if let Some((at, w)) = first_bad(&a.normal, bad_normal) {
        return Err((
            Check::Values,
            format!("node channel, {at}: normal word {w:#010x} has a half 0x8000"),
        ));
    }
    if let Some((at, c)) = first_bad(&a.contour, |c| (c & 0xFFFF) > (c >> 16)) {
        return Err((
            Check::Values,
            format!(
                "node channel, {at}: contour {c:#010x} has its near plane beyond its far plane"
            ),
        ));
    }
    Ok(())
}

/// Check 14: bits 8-31 of every node's `info` are zero, as files store them.
pub(crate) fn check_node_words(nodes: &[Node]) -> Result<(), Failure> {
    match nodes.iter().position(|n| n.info >> 8 != 0) {
        Some(i) => Err((
            Check::NodeWords,
            format!("node {i}: reserved info bits set ({:#x})", nodes[i].info),
        )),
        None => Ok(()),
    }
}

/// Checks 14 to 17 on one chunk of a version-3 file (`docs/format.md`, section 10): a tree of
/// `levels` levels whose root has children and whose leaves are `leaves`.
#[cfg_attr(not(feature = "io"), allow(dead_code))]
pub(crate) fn check_chunk(nodes: &[Node], levels: u8, leaves: u64) -> Result<(), Failure> {
    check_node_words(nodes)?;
    if !check_shape_and_node_order(nodes, levels, false, leaves)? {
        check_leaf_order(nodes, leaves)?;
    }
    Ok(())
}

/// Checks 15 to 17 on the node array of a tree of `depth` levels in level order (a tree with
/// inner-node attributes), its levels' counts read from the array itself.
fn check_level_order_whole(nodes: &[Node], depth: u8, leaf_count: u64) -> Result<(), Failure> {
    let counts = level_counts(nodes, depth);
    let (walked, n) = (counts.iter().sum::<u64>(), nodes.len() as u64);
    if walked != n {
        return Err((
            Check::NodeOrder,
            format!("nodes {walked}..{n} are not in the tree"),
        ));
    }
    check_level_order(nodes, &counts, usize::from(depth), depth, leaf_count)
}

/// Checks 15 and 16 on the node array of a tree of `depth` levels: walks the nodes in the
/// canonical placement order (a node's children block, then the children's subtrees from the
/// last child to the first), and requires each block where the next free index is. Only the
/// root may have no children, and only if `empty_root` (a version-3 chunk's may not).
///
/// The same walk tells whether check 17 holds for `leaf_count` leaves (`Ok(true)`): it meets
/// the leaf parents, all on one level, in the reverse of their depth-first order, so their
/// leaves must end at `leaf_count` and each parent's must end where the one met before it
/// starts. Only where it does not hold need [`check_leaf_order`] walk again, for its message.
pub(crate) fn check_shape_and_node_order(
    nodes: &[Node],
    depth: u8,
    empty_root: bool,
    leaf_count: u64,
) -> Result<bool, Failure> {
    let n = nodes.len();
    let mut next = 1usize;
    let (mut leaves_end, mut leaf_order) = (leaf_count, true);
    let mut stack: Vec<(usize, u8)> = Vec::with_capacity(7 * usize::from(depth) + 2);
    stack.push((0, 0));
    while let Some((i, level)) = stack.pop() {
        let node = nodes[i];
        let k = node.child_mask().count_ones() as usize;
        let Some(leaf_level) = check_node_shape(i as u64, node, level, depth, empty_root)? else {
            continue;
        };
        if leaf_level {
            // A leaf parent (just checked): its leaves end where the next one's start.
            let base = u64::from(node.leaf_base().unwrap_or(0));
            leaf_order &= base + k as u64 == leaves_end;
            leaves_end = base;
            continue;
        }
        let first = node.first as usize;
        if first != next || first + k > n {
            return Err((
                Check::NodeOrder,
                format!(
                    "node {i}: its children are at {first}, the canonical order puts them at \
                     {next} ({n} nodes)"
                ),
            ));
        }
        next += k;
        for j in first..first + k {
            stack.push((j, level + 1));
        }
    }
    if next != n {
        return Err((
            Check::NodeOrder,
            format!("nodes {next}..{n} are not in the tree"),
        ));
    }
    Ok(leaf_order && leaves_end == 0)
}

/// Checks 15 and 16 on node `i` of a tree of `depth` levels, met on `level` by a walk in
/// either order (depth-first, or version 4's level order): only the root may have no
/// children (and only if `empty_root`), and then its `first` is 0; exactly the nodes one
/// level above the leaves point to leaves. `None` for the empty root, else whether the node
/// is a leaf parent (the caller checks where an inner node's block lies).
pub(crate) fn check_node_shape(
    i: u64,
    node: Node,
    level: u8,
    depth: u8,
    empty_root: bool,
) -> Result<Option<bool>, Failure> {
    if node.child_mask() == 0 {
        if i != 0 || !empty_root {
            return Err((Check::TreeShape, format!("node {i} has no children")));
        }
        if node.first != 0 {
            return Err((
                Check::NodeOrder,
                format!("the empty root's first is {}, not 0", node.first),
            ));
        }
        return Ok(None);
    }
    let leaf_level = level + 1 == depth;
    if leaf_level != node.is_leaf_parent() {
        return Err((
            Check::TreeShape,
            if leaf_level {
                format!("node {i} at the level above the leaves does not point to leaves")
            } else {
                format!("node {i} at level {level} points to leaves above the leaf level")
            },
        ));
    }
    Ok(Some(leaf_level))
}

/// Check 17: the leaf parents, visited depth-first in child order, number their leaves from 0
/// without gaps, and their total is `leaf_count`. (Runs after check 16, so the walk is a
/// tree.)
pub(crate) fn check_leaf_order(nodes: &[Node], leaf_count: u64) -> Result<(), Failure> {
    let mut next = 0u64;
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        let node = nodes[i];
        let k = node.child_mask().count_ones();
        if let Some(base) = node.leaf_base() {
            if u64::from(base) != next {
                return Err((
                    Check::LeafOrder,
                    format!(
                        "node {i}: its leaves start at {base}, depth-first order puts them at {next}"
                    ),
                ));
            }
            next += u64::from(k);
        } else if k > 0 {
            let first = node.first as usize;
            stack.extend((first..first + k as usize).rev());
        }
    }
    if next != leaf_count {
        return Err((
            Check::LeafOrder,
            format!("the tree refers to {next} leaves, the count says {leaf_count}"),
        ));
    }
    Ok(())
}

/// Check 18: normal words (a half `0x8000` only in the interior-leaf word, and that only from
/// version 2), contours (near plane not beyond the far one; the whole cell for interior
/// leaves). Constants are stored values too, whatever the leaf count.
pub(crate) fn check_values(t: &Octree, version: u32) -> Result<(), Failure> {
    let a = &t.attributes;
    let bad_normal =
        |w: u32| ((w & 0xFFFF) == 0x8000 || (w >> 16) == 0x8000) && (w != NO_NORMAL || version < 2);
    if let Some((at, w)) = first_bad(&a.normal, bad_normal) {
        return Err((
            Check::Values,
            format!(
                "{at}: normal word {w:#010x} (a half 0x8000 is only allowed in the \
                 interior-leaf word 0x80008000, from version 2)"
            ),
        ));
    }
    if let Some((at, c)) = first_bad(&a.contour, |c| (c & 0xFFFF) > (c >> 16)) {
        return Err((
            Check::Values,
            format!("{at}: contour {c:#010x} has its near plane beyond its far plane"),
        ));
    }
    if !matches!(a.contour, Channel::Absent) && a.has_interior() {
        for i in 0..t.leaf_count as usize {
            let c = a.contour.get(i).unwrap_or(FULL);
            if a.normal.get(i) == Some(NO_NORMAL) && c != FULL {
                return Err((
                    Check::Values,
                    format!(
                        "leaf {i}: an interior leaf's contour is {c:#010x}, not the whole cell \
                         0xffff0000"
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The first stored value of a channel (the constant, or a per-leaf value) for which `bad`
/// holds, with where it is.
fn first_bad(c: &Channel<u32>, bad: impl Fn(u32) -> bool) -> Option<(String, u32)> {
    match c {
        Channel::Constant(w) if bad(*w) => Some(("the constant".into(), *w)),
        Channel::PerLeaf(v) => v
            .iter()
            .position(|&w| bad(w))
            .map(|i| (format!("leaf {i}"), v[i])),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::octree::{RootCube, Voxel};
    use glam::DVec3;

    /// What the shape walk says of check 17 is what check 17's own walk finds: on seeded
    /// random trees, and on the same trees with one leaf more or fewer counted, with two leaf
    /// parents' leaves swapped, and with one leaf parent's leaves moved by one.
    #[test]
    fn the_shape_walk_tells_the_leaf_order_as_its_own_walk_does() {
        let mut next = svo_tests::seeds::xorshift(0x001E_AF0D);
        let (mut valid, mut invalid) = (0, 0);
        for depth in 1..=7u8 {
            for count in [1usize, 3, 20, 300] {
                let cells = svo_tests::seeds::random_cells(&mut next, depth, count)
                    .into_iter()
                    .map(|c| (c, Voxel::default()));
                let root = RootCube {
                    origin: DVec3::ZERO,
                    side: 1.0,
                };
                let t = Octree::from_cells(root, depth, cells).unwrap();
                let leaves = u64::from(t.leaf_count);
                let parents: Vec<usize> = (0..t.nodes.len())
                    .filter(|&i| t.nodes[i].is_leaf_parent())
                    .collect();
                let mut cases = vec![(t.nodes.clone(), leaves)];
                cases.push((t.nodes.clone(), leaves + 1));
                cases.push((t.nodes.clone(), leaves - 1));
                if parents.len() >= 2 {
                    let mut swapped = t.nodes.clone();
                    let (a, b) = (parents[0], parents[parents.len() - 1]);
                    let first = swapped[a].first;
                    swapped[a].first = swapped[b].first;
                    swapped[b].first = first;
                    cases.push((swapped, leaves));
                }
                let mut moved = t.nodes.clone();
                let p = parents[next() as usize % parents.len()];
                moved[p].first = moved[p].first.wrapping_sub(1);
                cases.push((moved, leaves));
                for (nodes, leaves) in cases {
                    let shape = check_shape_and_node_order(&nodes, depth, true, leaves)
                        .expect("the shape is a tree's");
                    let own = check_leaf_order(&nodes, leaves).is_ok();
                    assert_eq!(shape, own, "depth {depth}, {count} cells, {leaves} leaves");
                    if own {
                        valid += 1;
                    } else {
                        invalid += 1;
                    }
                }
            }
        }
        assert!(
            valid >= 28 && invalid >= 60,
            "{valid} valid, {invalid} invalid"
        );
    }
}
