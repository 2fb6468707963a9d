//! The merge of a plan's parts into version 4's DAG layout (`docs/format.md`, section 12):
//! each part's subtrees reduced into one graph as the part is read, the parts in Morton
//! order, so that each level's distinct nodes come in the order the reduction of the whole
//! tree finds them ([`DagBuilder`]); then the levels above the parts' level, made from the
//! subtrees' roots; then the graph written, with the leaves' channels copied from the parts
//! in Morton order (normals and colours in fewer bits packed as they are copied). Memory holds the graph
//! and one part's nodes, never the tree, so the file is the one `svo::io::write_dag_to_with`
//! writes of the tree baked in memory, byte for byte.
//!
//! Values on a level above the leaves ([`DagValues`]) are that level's inner-node attributes:
//! the parts were baked with them and store their nodes level by level
//! ([`crate::bake::parts::part_levels`]). The graph is then reduced from those levels, and the
//! values are the level's nodes' from the parts (a level below the parts' level), or from the
//! nodes the merge makes above them out of the subtrees' roots
//! ([`crate::bake::parts::merge_levels::top_levels`]).

use crate::attributes::surface_sums::NodeRule;
use crate::bake::parts::merge::{
    Header, Sub, copy_array, corrupt, level_layout, per_leaf_rank, read_array, write_streamed,
};
use crate::bake::parts::merge_levels::top_levels;
use crate::bake::parts::part_levels::push_value;
use crate::bake::parts::plan::{BakePlan, PartsError};
use crate::dag::{DagBuilder, DagValues};
use crate::io::packed::{Packer, element_bits, pack, packed_len, stored_bits, word};
use crate::io::write::{Layout, Stored, dag_blocks};
use crate::octree::ChannelKind;
use crate::octree::normal_encoding::quantize;
use crate::octree::tree::Node;
use std::io::Write;
use std::path::Path;

/// Merges the parts (`headers`, checked; their subtrees `subs` in increasing code) of `plan`
/// into `output` as the DAG layout with the leaves' values kept as `values` says: the leaf
/// channels as the merge stores them (`channels`; `copied` are the parts' channel indices
/// copied per leaf), `leaves` in all. Returns the layout written and its bytes.
#[allow(clippy::too_many_arguments)]
pub(crate) fn merge_dag<'a>(
    plan: &'a BakePlan,
    headers: &[Header],
    subs: &[Sub],
    channels: &[(u8, Stored)],
    copied: &[usize],
    leaves: u64,
    values: DagValues,
    output: &Path,
) -> Result<(Layout<'a>, u64), PartsError> {
    let level = values.level_for(plan.depth);
    let bits = values.normal_bits;
    let (graph, level_values) = if level == plan.depth {
        (graph_of_subtrees(plan, headers)?, None)
    } else {
        let graph = graph_of_levels(plan, headers)?;
        let values = values_on_level(plan, headers, subs, channels, level)?;
        (graph, Some(values))
    };
    let dag = graph.finish();
    debug_assert_eq!(dag.leaf_count(), leaves);
    let (levels, blocks) = dag_blocks(&dag);
    // How each leaf channel is stored: a constant (a normal in `bits` bits, as its decoded
    // word), each leaf's own as the parts hold it, or packed on `level`.
    let mut stored = Vec::with_capacity(channels.len());
    for &(kind, s) in channels {
        let kind_bits = stored_bits(kind, bits, values.colour_bits);
        let own_width = u32::from(kind_bits) == element_bits(kind);
        stored.push((
            kind,
            match s {
                Stored::Constant(v) if kind == 0 && bits < 32 => {
                    Stored::Constant(quantize(v, u32::from(bits)).1)
                }
                Stored::Constant(v) => Stored::Constant(v),
                Stored::PerLeaf(len) if level == plan.depth && own_width => Stored::PerLeaf(len),
                Stored::PerLeaf(_) | Stored::Packed { .. } => {
                    let count = match &level_values {
                        Some(v) => v.count,
                        None => leaves,
                    };
                    Stored::Packed {
                        level,
                        bits: kind_bits,
                        len: packed_len(kind, count, kind_bits).unwrap_or(u64::MAX),
                    }
                }
            },
        ));
    }
    let layout = level_layout(plan, levels, leaves, stored);
    // The arrays after the graph's blocks: one for each channel not constant, in order.
    let arrays: Vec<(u8, Stored)> = layout
        .channels
        .iter()
        .filter(|(_, s)| !matches!(s, Stored::Constant(_)))
        .copied()
        .collect();
    let bytes = write_streamed(&layout, output, &mut |i, out: &mut dyn Write| {
        if let Some(b) = blocks.get(i) {
            return out.write_all(b).map_err(|e| PartsError::io(output, e));
        }
        let j = i - blocks.len();
        let (kind, s) = arrays[j];
        if let (Some(v), Stored::Packed { bits, .. }) = (&level_values, s) {
            let packed = v.packed(kind, bits);
            return out
                .write_all(&packed)
                .map_err(|e| PartsError::io(output, e));
        }
        let k = copied[j];
        match s {
            Stored::Packed { bits, .. } => {
                let mut packer = Packer::new(kind, bits);
                let size = ChannelKind::ALL[usize::from(kind)].element_size();
                let mut buf = Vec::new();
                for (path, h) in headers {
                    let a = h.arrays[1 + per_leaf_rank(h, k)];
                    read_array(path, a, "channel array", &mut |bytes| {
                        buf.clear();
                        for w in bytes.chunks_exact(size) {
                            packer.push(word(w), &mut buf);
                        }
                        out.write_all(&buf).map_err(|e| PartsError::io(output, e))
                    })?;
                }
                buf.clear();
                packer.finish(&mut buf);
                out.write_all(&buf).map_err(|e| PartsError::io(output, e))
            }
            _ => {
                for (path, h) in headers {
                    copy_array(path, h.arrays[1 + per_leaf_rank(h, k)], out)?;
                }
                Ok(())
            }
        }
    })?;
    Ok((layout, bytes))
}

/// The graph of the parts' subtrees, each part's node array (its subtrees depth-first) read
/// whole, then the levels above them.
fn graph_of_subtrees(plan: &BakePlan, headers: &[Header]) -> Result<DagBuilder, PartsError> {
    let level = usize::from(plan.level);
    let mut graph = DagBuilder::new(plan.depth);
    // Each subtree's code and index on the parts' level, in increasing code.
    let mut cells: Vec<(u64, u32)> = Vec::new();
    for (path, h) in headers {
        let nodes = read_nodes(path, h.arrays[0])?;
        // The part stores its subtrees highest code first, one after another; the graph
        // takes them in increasing code.
        let mut end = nodes.len();
        for s in h.subtrees.iter().rev() {
            let start = end - s.nodes as usize;
            // The subtree's root is its parent's record: its children's block starts its nodes.
            let root = Node {
                info: u32::from(s.mask),
                first: if level + 1 == usize::from(plan.depth) {
                    u32::MAX
                } else {
                    0
                },
            };
            let id = graph
                .add(level, root, &nodes[start..end])
                .map_err(|e| corrupt(path, &format!("corrupt part file: {e}")))?;
            if graph.leaves(level, id) != s.leaves {
                return Err(corrupt(
                    path,
                    "corrupt part file: a subtree's leaves are not its header's count",
                ));
            }
            cells.push((s.code, id));
            end = start;
        }
    }
    graph.add_top(level, cells);
    Ok(graph)
}

/// The graph of parts that store their nodes level by level (baked with inner-node
/// attributes): each part's levels reduced from its leaf parents up (each level in Morton
/// order, as [`DagBuilder::add`] meets a subtree's), then its subtrees' roots, then the
/// levels above them.
fn graph_of_levels(plan: &BakePlan, headers: &[Header]) -> Result<DagBuilder, PartsError> {
    let (level, depth) = (usize::from(plan.level), usize::from(plan.depth));
    let mut graph = DagBuilder::new(plan.depth);
    let mut cells: Vec<(u64, u32)> = Vec::new();
    for (path, h) in headers {
        let Some(levels) = h.levels.as_ref() else {
            return Err(corrupt(
                path,
                "the part has no levels: it is not of this plan",
            ));
        };
        let bad = |what: &str| corrupt(path, &format!("corrupt part file: {what}"));
        let per_level = 1 + levels.kinds.len();
        let mut ids_below: Vec<u32> = Vec::new();
        for r in (1..=levels.counts.len()).rev() {
            let l = level + r;
            let nodes = read_nodes(path, h.arrays[(r - 1) * per_level])?;
            if nodes.len() as u64 != levels.counts[r - 1] {
                return Err(bad("a level's nodes are not its header's count"));
            }
            let mut ids = Vec::with_capacity(nodes.len());
            for n in nodes {
                let mask = n.child_mask();
                if mask == 0 || n.is_leaf_parent() != (l + 1 == depth) {
                    return Err(bad(
                        "a node has no children, or leaves off the lowest level",
                    ));
                }
                let kids: &[u32] = if l + 1 == depth {
                    &[]
                } else {
                    let first = n.first as usize;
                    ids_below
                        .get(first..first + mask.count_ones() as usize)
                        .ok_or_else(|| bad("a node's children lie past its level"))?
                };
                ids.push(graph.node(l, mask, kids));
            }
            ids_below = ids;
        }
        let mut at = 0usize;
        for s in h.subtrees.iter().rev() {
            let k = if level + 1 == depth {
                0
            } else {
                s.mask.count_ones() as usize
            };
            let kids = ids_below
                .get(at..at + k)
                .ok_or_else(|| bad("a subtree's children lie past its level"))?;
            at += k;
            let id = graph.node(level, s.mask, kids);
            if graph.leaves(level, id) != s.leaves {
                return Err(bad("a subtree's leaves are not its header's count"));
            }
            cells.push((s.code, id));
        }
        if at != ids_below.len() {
            return Err(bad("a level holds nodes that no subtree reaches"));
        }
    }
    graph.add_top(level, cells);
    Ok(graph)
}

/// A part's node array, read whole.
fn read_nodes(
    path: &Path,
    a: crate::bake::parts::part::PartArray,
) -> Result<Vec<Node>, PartsError> {
    let on_disk = std::fs::metadata(path)
        .map_err(|e| PartsError::io(path, e))?
        .len();
    if a.offset.saturating_add(a.len) > on_disk || !a.len.is_multiple_of(8) {
        return Err(corrupt(path, "truncated part file"));
    }
    let mut nodes = vec![Node::default(); (a.len / 8) as usize];
    let mut at = 0usize;
    read_array(path, a, "node array", &mut |bytes| {
        let dst: &mut [u8] = bytemuck::cast_slice_mut(&mut nodes);
        dst[at..at + bytes.len()].copy_from_slice(bytes);
        at += bytes.len();
        Ok(())
    })?;
    Ok(nodes)
}

/// The values of a level's nodes, in Morton order: for each leaf channel stored per leaf,
/// the nodes' values as the file stores them (little-endian elements).
struct LevelValues {
    /// Nodes on the level.
    count: u64,
    /// Per channel kind, its values' bytes.
    bytes: Vec<(u8, Vec<u8>)>,
}

impl LevelValues {
    /// Channel `kind`'s values packed in `bits` bits each.
    fn packed(&self, kind: u8, bits: u8) -> Vec<u8> {
        let size = ChannelKind::ALL[usize::from(kind)].element_size();
        let bytes = self
            .bytes
            .iter()
            .find(|(k, _)| *k == kind)
            .map_or(&[][..], |(_, b)| b.as_slice());
        pack(kind, bits, bytes.chunks_exact(size).map(word))
    }
}

/// The values of `level`'s nodes for the leaf channels stored per leaf (`channels`): from
/// the levels the merge makes (the parts' level and above) or from the parts' levels.
fn values_on_level(
    plan: &BakePlan,
    headers: &[Header],
    subs: &[Sub],
    channels: &[(u8, Stored)],
    level: u8,
) -> Result<LevelValues, PartsError> {
    let kinds: Vec<u8> = channels
        .iter()
        .filter(|(_, s)| !matches!(s, Stored::Constant(_)))
        .map(|&(k, _)| k)
        .collect();
    if kinds.contains(&(ChannelKind::Contour as u8)) {
        return Err(PartsError::Unsupported(
            crate::dag::ValuesError::Contour.to_string(),
        ));
    }
    let mut bytes: Vec<(u8, Vec<u8>)> = kinds.iter().map(|&k| (k, Vec::new())).collect();
    if level <= plan.level {
        let rule = headers
            .iter()
            .find_map(|(_, h)| h.levels.as_ref())
            .map_or(NodeRule::default(), |l| l.rule);
        let top = top_levels(plan, headers, subs, rule)?;
        let nodes = &top[usize::from(level)];
        for (kind, out) in &mut bytes {
            for n in nodes {
                push_value(*kind, &n.value, 0, out);
            }
        }
        return Ok(LevelValues {
            count: nodes.len() as u64,
            bytes,
        });
    }
    // Level `r` below the parts' level: each part's values of it, part after part.
    let r = usize::from(level - plan.level);
    let mut count = 0u64;
    for (path, h) in headers {
        let Some(levels) = h.levels.as_ref() else {
            return Err(corrupt(
                path,
                "the part has no levels: it is not of this plan",
            ));
        };
        if r >= levels.counts.len() {
            return Err(corrupt(path, "the part keeps no values on that level"));
        }
        count += levels.counts[r - 1];
        let at = (r - 1) * (1 + levels.kinds.len());
        for (kind, out) in &mut bytes {
            let Some(k) = levels.kinds.iter().position(|x| x == kind) else {
                return Err(corrupt(path, "a part lacks an inner-node channel"));
            };
            read_array(path, h.arrays[at + 1 + k], "value array", &mut |b| {
                out.extend_from_slice(b);
                Ok(())
            })?;
        }
    }
    for (kind, out) in &bytes {
        let size = ChannelKind::ALL[usize::from(*kind)].element_size() as u64;
        if out.len() as u64 != count * size {
            return Err(PartsError::Unsupported(
                "the parts' values on the level do not match their nodes".into(),
            ));
        }
    }
    Ok(LevelValues { count, bytes })
}
