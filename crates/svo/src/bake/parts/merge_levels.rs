//! The merge of a bake with inner-node attributes: a version-4 file (`docs/format.md`,
//! section 11) streamed a level at a time from the parts' levels
//! ([`crate::bake::parts::part_levels`]).
//!
//! The levels above the parts' level are made here from the subtrees' roots, as the bake in
//! memory makes them: a node's sums are its children's added in child order, its values are
//! encoded from them and its contour encloses its children's. The parts' level is the roots,
//! with the values their parts computed. Each level below is the parts' nodes of that level,
//! part after part, pointers moved by the nodes and leaves of the parts before. A level's
//! block hash goes in the header, before the blocks: a first pass over the levels computes
//! the hashes, a second writes the file. Every piece read from a part is checked against the
//! hash the part recorded for it.

use crate::attributes::node_attributes::{Uniform, contour_of, node_slab, normal_storage};
use crate::attributes::surface_sums::{NodeRule, NodeValue, SurfaceSums};
use crate::bake::parts::merge::{Header, Sub, copy_array, corrupt, per_leaf_rank, read_array};
use crate::bake::parts::part_levels::{PartLevels, push_value};
use crate::bake::parts::plan::{BakePlan, PartsError};
use crate::io::header::{NodeChannelEntry, NodeStorage};
use crate::io::write::{Layout, LevelPlan, Stored};
use crate::octree::ChannelKind;
use crate::octree::layout::Sums;
use crate::octree::tree::{Channel, Node};
use crate::octree::validate::MAX_LEAVES;
use std::io::Write;
use std::path::Path;

/// A node of the levels made here (above the parts' and the parts' own): its code on its
/// level, children, sums, values and contour.
pub(crate) struct TopNode {
    code: u64,
    mask: u8,
    sums: SurfaceSums,
    pub value: NodeValue,
    contour: u32,
}

/// What the version-4 merge writes, beside what [`Layout`] says.
pub(crate) struct LevelMerge<'a> {
    headers: &'a [Header],
    /// Each part's levels (the parts' headers', checked).
    levels: Vec<&'a PartLevels>,
    /// The levels down to the parts' level, the root's first (the last is the roots).
    top: Vec<Vec<TopNode>>,
    /// Nodes on each level of the tree.
    counts: Vec<u64>,
    /// For each part and each level below the roots, the nodes of the parts before it there.
    before: Vec<Vec<u64>>,
    /// Each part's first leaf.
    leaf_off: &'a [u64],
    /// The inner-node channels stored per node, in kind order.
    per_node: Vec<u8>,
    /// The leaf channels copied from the parts (indices in part 0's channel list).
    copied: &'a [usize],
    depth: u8,
}

/// The file's inner-node channels, from its leaf channels (`channels`) and the normals of the
/// nodes that keep values (`normals`): as the bake in memory stores them
/// ([`crate::attributes::node_attributes`]).
fn node_channels(channels: &[(u8, Stored)], normals: Uniform) -> Vec<NodeChannelEntry> {
    let normal = ChannelKind::Normal as u8;
    let has_normal = channels.iter().any(|(k, _)| *k == normal);
    channels
        .iter()
        .filter(|(k, _)| *k != ChannelKind::Contour as u8 || has_normal)
        .map(|&(kind, s)| {
            let storage = match s {
                Stored::Constant(v) if kind == normal => {
                    match normal_storage(&Channel::Constant(v), normals) {
                        Some(Channel::Constant(v)) => NodeStorage::Constant(v),
                        _ => NodeStorage::PerNode,
                    }
                }
                _ if kind == ChannelKind::Contour as u8 => NodeStorage::PerNode,
                Stored::Constant(v) => NodeStorage::Constant(v),
                Stored::PerLeaf(_) | Stored::Packed { .. } => NodeStorage::PerNode,
            };
            NodeChannelEntry { kind, storage }
        })
        .collect()
}

impl<'a> LevelMerge<'a> {
    /// Plans the merge of `headers` (the parts, checked; their subtrees `subs` in increasing
    /// code, each part's first leaf `leaf_off`) into a file with the leaf `channels` (those
    /// `copied` from the parts): the levels made here, the counts and the inner-node
    /// channels. Refuses a tree past version 4's limits.
    pub(crate) fn new(
        plan: &BakePlan,
        headers: &'a [Header],
        subs: &[Sub],
        leaf_off: &'a [u64],
        channels: &[(u8, Stored)],
        copied: &'a [usize],
        leaves: u64,
    ) -> Result<(Self, LevelPlan), PartsError> {
        let levels: Vec<&PartLevels> = headers
            .iter()
            .filter_map(|(_, h)| h.levels.as_ref())
            .collect();
        let rule = levels.first().map_or(NodeRule::default(), |l| l.rule);
        let top = top_levels(plan, headers, subs, rule)?;
        let below = usize::from(plan.depth - plan.level - 1);
        let mut counts: Vec<u64> = top.iter().map(|l| l.len() as u64).collect();
        let mut before = Vec::with_capacity(levels.len());
        let mut sums = vec![0u64; below];
        for l in &levels {
            before.push(sums.clone());
            for (s, c) in sums.iter_mut().zip(&l.counts) {
                *s += c;
            }
        }
        counts.extend(&sums);
        let nodes: u64 = counts.iter().sum();
        if nodes > MAX_LEAVES || leaves > MAX_LEAVES {
            return Err(PartsError::Unsupported(format!(
                "the tree has {nodes} nodes and {leaves} leaves; format version 4, which the \
                 inner nodes' attributes need, holds at most 2^31 of each: bake without them"
            )));
        }
        // The normals of the nodes that keep values: the parts' (their roots' included) and
        // those of the levels above.
        let mut normals = levels.iter().fold(Uniform::Empty, |u, l| u.and(l.normals));
        if let Some((_, above)) = top.split_last() {
            for n in above.iter().flatten() {
                normals = normals.and(Uniform::One(n.value.normal));
            }
        }
        let node_channels = node_channels(channels, normals);
        let per_node: Vec<u8> = node_channels
            .iter()
            .filter(|e| e.storage == NodeStorage::PerNode)
            .map(|e| e.kind)
            .collect();
        let merge = Self {
            headers,
            levels,
            top,
            counts: counts.clone(),
            before,
            leaf_off,
            per_node,
            copied,
            depth: plan.depth,
        };
        let mut hashes = Vec::with_capacity(counts.len());
        for l in 0..counts.len() {
            let mut h = HashWriter(xxhash_rust::xxh3::Xxh3::new());
            let mut last_len = None;
            for j in 0..merge.arrays_on(l) {
                if let Some(len) = last_len {
                    h.write_all(&[0u8; 8][..(8 - len % 8) % 8])
                        .map_err(|e| PartsError::io(Path::new("<hash>"), e))?;
                }
                last_len = Some(merge.array_len(l, j) as usize);
                merge.level_array(l, j, &mut h)?;
            }
            hashes.push(h.0.digest());
        }
        let plan = LevelPlan {
            layout: 0,
            block_lens: Vec::new(),
            counts,
            hashes,
            node_channels,
        };
        Ok((merge, plan))
    }

    /// Arrays in level `l`'s block: the records, then above the leaf parents one a per-node
    /// channel.
    fn arrays_on(&self, l: usize) -> usize {
        if l + 2 <= usize::from(self.depth) {
            1 + self.per_node.len()
        } else {
            1
        }
    }

    /// Bytes of array `j` of level `l`'s block.
    fn array_len(&self, l: usize, j: usize) -> u64 {
        let size = match j {
            0 => 8,
            _ => ChannelKind::ALL[usize::from(self.per_node[j - 1])].element_size() as u64,
        };
        self.counts[l] * size
    }

    /// Writes array `i` of the file (the levels' arrays in order, then the leaf channels').
    pub(crate) fn array(&self, mut i: usize, out: &mut dyn Write) -> Result<(), PartsError> {
        for l in 0..self.counts.len() {
            let k = self.arrays_on(l);
            if i < k {
                return self.level_array(l, i, out);
            }
            i -= k;
        }
        let k = self.copied[i];
        for (path, h) in self.headers {
            let a = h.arrays[self.leaf_array(h) + per_leaf_rank(h, k)];
            copy_array(path, a, out)?;
        }
        Ok(())
    }

    /// Index of a part's first leaf-channel array.
    fn leaf_array(&self, h: &crate::bake::parts::part::PartHeader) -> usize {
        h.levels.as_ref().map_or(1, |l| {
            let r = l.counts.len();
            r + (r - 1) * l.kinds.len()
        })
    }

    /// Writes array `j` of level `l`'s block.
    fn level_array(&self, l: usize, j: usize, out: &mut dyn Write) -> Result<(), PartsError> {
        let io = |e| PartsError::io(Path::new("<output>"), e);
        let roots = self.top.len() - 1;
        if l <= roots {
            let mut buf = Vec::with_capacity(self.top[l].len() * 8);
            if j == 0 {
                // Children blocks follow one another on the level below, in parents' order.
                let mut next: u64 = self.counts[..=l].iter().sum();
                for n in &self.top[l] {
                    buf.extend_from_slice(&u32::from(n.mask).to_le_bytes());
                    buf.extend_from_slice(&(next as u32).to_le_bytes());
                    next += u64::from(n.mask.count_ones());
                }
            } else {
                let kind = self.per_node[j - 1];
                for n in &self.top[l] {
                    push_value(kind, &n.value, n.contour, &mut buf);
                }
            }
            return out.write_all(&buf).map_err(io);
        }
        // Level `r` below the roots, from each part.
        let r = l - roots;
        let start_below: u64 = self.counts[..=l].iter().sum();
        for (p, ((path, h), levels)) in self.headers.iter().zip(&self.levels).enumerate() {
            let per_level = 1 + levels.kinds.len();
            let at = (r - 1) * per_level;
            let a = if j == 0 {
                h.arrays[at]
            } else {
                let kind = self.per_node[j - 1];
                let Some(k) = levels.kinds.iter().position(|&x| x == kind) else {
                    return Err(corrupt(path, "a part lacks an inner-node channel"));
                };
                h.arrays[at + 1 + k]
            };
            if j > 0 {
                copy_array(path, a, out)?;
                continue;
            }
            let below = levels.counts.get(r).copied().unwrap_or(0);
            let first = start_below + self.before[p].get(r).copied().unwrap_or(0);
            let leaves = h.leaves();
            let leaf_off = self.leaf_off[p];
            let last = r == levels.counts.len();
            let move_node = |n: Node| -> Option<Node> {
                let k = u64::from(n.child_mask().count_ones());
                if k == 0 {
                    return None;
                }
                match n.leaf_base() {
                    Some(base) if last && u64::from(base) + k <= leaves => {
                        let b = u64::from(base) + leaf_off;
                        Some(Node {
                            info: n.info & 0xFF,
                            first: (-(b as i64) - 1) as i32 as u32,
                        })
                    }
                    None if !last && u64::from(n.first) + k <= below => Some(Node {
                        info: n.info & 0xFF,
                        first: (u64::from(n.first) + first) as u32,
                    }),
                    _ => None,
                }
            };
            read_array(path, a, "node array", &mut |bytes: &[u8]| {
                let mut moved = Vec::with_capacity(bytes.len());
                for rec in bytes.chunks_exact(8) {
                    let n: Node = bytemuck::pod_read_unaligned(rec);
                    let n = move_node(n).ok_or_else(|| {
                        corrupt(
                            path,
                            "corrupt part file: a node points outside its part's levels",
                        )
                    })?;
                    moved.extend_from_slice(bytemuck::bytes_of(&n));
                }
                out.write_all(&moved).map_err(|e| PartsError::io(path, e))
            })?;
        }
        Ok(())
    }

    /// Writes the file of `layout` (whose levels are this merge's plan) atomically.
    pub(crate) fn write(&self, layout: &Layout<'_>, output: &Path) -> Result<u64, PartsError> {
        crate::bake::parts::merge::write_streamed(layout, output, &mut |i, out| self.array(i, out))
    }
}

/// The levels from the root down to the parts' level (the subtrees' roots, from the parts'
/// headers), each in code order, with their values.
pub(crate) fn top_levels(
    plan: &BakePlan,
    headers: &[Header],
    subs: &[Sub],
    rule: NodeRule,
) -> Result<Vec<Vec<TopNode>>, PartsError> {
    let mut roots = Vec::with_capacity(subs.len());
    // In increasing code: each part's subtrees from the last its header lists.
    for (path, h) in headers {
        let Some(levels) = h.levels.as_ref() else {
            return Err(corrupt(
                path,
                "the part has no levels: it is not of this plan",
            ));
        };
        for (s, root) in h.subtrees.iter().zip(&levels.roots).rev() {
            let Some(sums) = SurfaceSums::from_words(&root.sums) else {
                return Err(corrupt(path, "corrupt part file: a subtree root's sums"));
            };
            roots.push(TopNode {
                code: s.code,
                mask: s.mask,
                sums,
                value: root.value,
                contour: root.contour,
            });
        }
    }
    debug_assert_eq!(roots.len(), subs.len());
    let contours = headers
        .first()
        .and_then(|(_, h)| h.levels.as_ref())
        .is_some_and(|l| l.kinds.contains(&(ChannelKind::Contour as u8)));
    let mut top = vec![roots];
    for _ in 0..plan.level {
        let below = top.last().map_or(&[][..], Vec::as_slice);
        let mut level: Vec<TopNode> = Vec::new();
        let mut i = 0;
        while i < below.len() {
            let code = below[i].code >> 3;
            let mut j = i;
            let mut sums = SurfaceSums::default();
            let mut mask = 0u8;
            while j < below.len() && below[j].code >> 3 == code {
                sums.add(&below[j].sums);
                mask |= 1 << (below[j].code & 7);
                j += 1;
            }
            let value = rule.value(&mut sums);
            let contour = if contours {
                contour_of(
                    value.normal,
                    below[i..j].iter().map(|c| {
                        (
                            (c.code & 7) as u8,
                            Some(node_slab(c.value.normal, c.contour)),
                        )
                    }),
                )
            } else {
                0
            };
            level.push(TopNode {
                code,
                mask,
                sums,
                value,
                contour,
            });
            i = j;
        }
        top.push(level);
    }
    top.reverse();
    Ok(top)
}

/// Hashes what is written to it.
struct HashWriter(xxhash_rust::xxh3::Xxh3);

impl Write for HashWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.update(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}
