//! A part's nodes level by level, as a bake with inner-node attributes stores them: what the
//! merge needs to write a version-4 file (`docs/format.md`, section 11) a level at a time.
//!
//! Version 4 stores the tree's levels one after another, each with its nodes' values beside
//! its records. The nodes of a level below the parts' level are the parts' nodes of that
//! level, part after part (the parts' ranges follow Morton order, and so does a level), so a
//! part stores, for each level below its subtrees' roots, its nodes of that level in level
//! order (its subtrees in increasing code), an inner node's `first` counted from the part's
//! first node on the level below and a leaf parent's leaves from the part's first leaf, and
//! on the levels that keep values, each inner-node channel's values. The roots themselves go
//! in the part's header with their values, their contours and the sums their parents' values
//! are made from ([`crate::attributes::surface_sums`]): the merge makes the levels above them.

use crate::attributes::node_attributes::{Uniform, node_contours};
use crate::attributes::surface_sums::{NodeRule, NodeValue, SurfaceSums};
use crate::bake::parts::part::PartStorage;
use crate::octree::ChannelKind;
use crate::octree::level_order::level_order;
use crate::octree::tree::{LeafAttributes, Node};
use crate::voxelize::build::Subtree;
use serde::{Deserialize, Serialize};

/// What a part with inner-node attributes says of its levels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct PartLevels {
    /// Nodes on each level below the subtrees' roots, the one under them first, down to the
    /// leaf parents' (`depth - level - 1` entries).
    pub counts: Vec<u64>,
    /// The inner-node channels whose values the levels that keep values store, in increasing
    /// kind ([`node_kinds`]).
    pub kinds: Vec<u8>,
    /// Which values a node's sums are encoded into.
    pub rule: NodeRule,
    /// The normals of the part's nodes that keep values, its roots' included.
    pub normals: Uniform,
    /// The subtrees' roots, in the order of the header's subtrees (the highest code first).
    pub roots: Vec<PartRoot>,
}

/// A subtree's root: its sums, values and contour.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct PartRoot {
    /// [`SurfaceSums::to_words`].
    pub sums: Vec<f64>,
    /// Its encoded values.
    pub value: NodeValue,
    /// Its contour (0 without contours).
    pub contour: u32,
}

/// The inner-node channels that a part with these leaf channels stores per node: those it
/// stores per leaf, the contour only beside the normal (a node's contour is fitted along its
/// normal).
pub(crate) fn node_kinds(channels: &[(u8, PartStorage)]) -> Vec<u8> {
    let normal = ChannelKind::Normal as u8;
    let has_normal = channels.iter().any(|(k, _)| *k == normal);
    channels
        .iter()
        .filter(|(k, s)| {
            matches!(s, PartStorage::PerLeaf { .. })
                && (*k != ChannelKind::Contour as u8 || has_normal)
        })
        .map(|(k, _)| *k)
        .collect()
}

/// Appends the value of channel `kind` of a node with values `v` and contour `contour`, as the
/// file stores it (little-endian).
pub(crate) fn push_value(kind: u8, v: &NodeValue, contour: u32, out: &mut Vec<u8>) {
    match ChannelKind::ALL.get(usize::from(kind)) {
        Some(ChannelKind::Normal) => out.extend_from_slice(&v.normal.to_le_bytes()),
        Some(ChannelKind::Contour) => out.extend_from_slice(&contour.to_le_bytes()),
        Some(ChannelKind::Colour) => out.extend_from_slice(&v.colour.to_le_bytes()),
        Some(ChannelKind::Reflectivity) => out.push(v.reflectivity),
        Some(ChannelKind::Refractivity) => out.push(v.refractivity),
        Some(ChannelKind::Ior) => out.extend_from_slice(&v.ior.to_le_bytes()),
        None => {}
    }
}

/// The level arrays of a part whose subtrees (in increasing code, each with its first leaf
/// in the part at `leaf_off`) have `below` levels under their roots, and whose leaves have
/// the values `leaves`: for each level, the records then (above the leaf parents) each of
/// `kinds`' values; and what its header says of them (`roots` in increasing code: the caller
/// lists them as it lists the subtrees).
pub(crate) fn part_levels(
    subtrees: &[Subtree<SurfaceSums>],
    leaf_off: &[usize],
    leaves: &LeafAttributes,
    kinds: &[u8],
    below: u8,
    rule: NodeRule,
) -> (PartLevels, Vec<Vec<u8>>) {
    let below = usize::from(below);
    let contours_wanted = kinds.contains(&(ChannelKind::Contour as u8));
    // Level `r` (1 to `below`) at index `r - 1`.
    let mut records: Vec<Vec<Node>> = vec![Vec::new(); below];
    let mut values: Vec<Vec<Vec<u8>>> = vec![vec![Vec::new(); kinds.len()]; below];
    let mut roots = Vec::with_capacity(subtrees.len());
    let mut normals = Uniform::Empty;
    for (s, &off) in subtrees.iter().zip(leaf_off) {
        let contours = if contours_wanted {
            node_contours(&s.nodes, &s.values, leaves, off)
        } else {
            Vec::new()
        };
        let contour = |i: usize| contours.get(i).copied().unwrap_or(0);
        let order = level_order(&s.nodes, below as u8 + 1);
        let mut start = 0usize;
        let starts: Vec<usize> = order
            .counts
            .iter()
            .map(|&c| {
                let at = start;
                start += c as usize;
                at
            })
            .collect();
        // Where this subtree's nodes of each level start among the part's.
        let before: Vec<usize> = records.iter().map(Vec::len).collect();
        for r in 1..=below {
            let (first, count) = (starts[r], order.counts[r] as usize);
            for i in first..first + count {
                let n = order.nodes[i];
                let n = if let Some(base) = n.leaf_base() {
                    crate::octree::layout::Chunk::<crate::voxelize::build::Baked<()>>::leaf_parent(
                        n.child_mask(),
                        base as usize + off,
                    )
                } else if n.child_mask() != 0 {
                    Node {
                        info: n.info,
                        first: (n.first as usize - starts[r + 1] + before[r]) as u32,
                    }
                } else {
                    n
                };
                records[r - 1].push(n);
                if r < below {
                    let k = order.from[i] as usize;
                    normals = normals.and(Uniform::One(s.values[k].normal));
                    for (arr, &kind) in values[r - 1].iter_mut().zip(kinds) {
                        push_value(kind, &s.values[k], contour(k), arr);
                    }
                }
            }
        }
        normals = normals.and(Uniform::One(s.values[0].normal));
        roots.push(PartRoot {
            sums: s.sums.to_words(),
            value: s.values[0],
            contour: contour(0),
        });
    }
    let counts = records.iter().map(|r| r.len() as u64).collect();
    let mut arrays = Vec::new();
    for (r, (recs, vals)) in records.into_iter().zip(values).enumerate() {
        arrays.push(bytemuck::cast_slice::<Node, u8>(&recs).to_vec());
        drop(recs);
        if r + 1 < below {
            arrays.extend(vals);
        }
    }
    roots.reverse();
    let levels = PartLevels {
        counts,
        kinds: kinds.to_vec(),
        rule,
        normals,
        roots,
    };
    (levels, arrays)
}
