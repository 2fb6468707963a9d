//! Joining a plan's parts into one `.svo` file, streamed: the top levels of the tree are made
//! from the parts' subtree lists, every subtree's nodes are copied in the order the file
//! places them with their pointers moved, and each channel's values are concatenated in
//! Morton order. Memory holds the parts' headers and copy buffers, never the tree.
//!
//! The file's node order (`docs/format.md`, "Canonical node order") puts a node's children
//! block before its children's subtrees, which follow from the last child to the first; so
//! the subtrees at the parts' level come in decreasing Morton code, which is the parts from
//! last to first, each part's subtrees as it stores them. A channel that every leaf of every
//! part holds with the same value becomes a constant in the header, as the whole bake makes
//! it. The output is written atomically: a missing, foreign, truncated or damaged part leaves
//! no file.

use crate::bake::parts::merge_dag::merge_dag;
use crate::bake::parts::merge_levels::LevelMerge;
use crate::bake::parts::part::{PartHeader, PartStorage, PartSubtree, read_part_header};
use crate::bake::parts::part_levels::node_kinds;
use crate::bake::parts::plan::{BakePlan, PartsError, part_path, read_plan};
use crate::dag::DagValues;
use crate::io::atomic_write::write_atomic;
use crate::io::header::ChunkRecord;
use crate::io::write::{Layout, LevelPlan, Stored, write_layout};
use crate::octree::stitch::{self, Piece, Stub};
use crate::octree::tree::Node;
use crate::octree::validate::MAX_LEAVES;
use std::io::{BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a merge wrote.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
pub struct MergeReport {
    /// Bytes of the `.svo` file.
    pub bytes: u64,
    /// Its format version: 2, 3 when its tree is stored in chunks, 4 with inner-node
    /// attributes or in the DAG layout.
    pub version: u32,
    /// Chunks (version 3), else 0.
    pub chunks: u64,
    /// Nodes.
    pub nodes: u64,
    /// Leaves.
    pub leaves: u64,
    /// Parts joined.
    pub parts: u32,
    /// Seconds.
    pub seconds: f64,
    /// The channels and how the file stores them (`constant` or `per-leaf`), by name.
    pub channels: Vec<(String, String)>,
    /// Overlap tests the parts ran.
    pub overlap_tests: u64,
    /// Leaf/triangle contacts in the parts.
    pub leaf_triangle_pairs: u64,
    /// Leaves no triangle touches (inexact strategies).
    pub false_positives: u64,
}

/// Which format version a merge writes (`docs/format.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum MergeFormat {
    /// Version 2, one node array, when it holds the tree (at most 2^31 leaves and nodes);
    /// past that version 3, the subtrees at the parts' level stored as chunks.
    #[default]
    Auto,
    /// Version 3 whatever the tree's size.
    Chunked,
    /// Version 4's DAG layout (`docs/format.md`, section 12): the geometry as a graph of
    /// distinct subtrees, the parts reduced into it as they are read; the bytes
    /// [`crate::io::write_dag_to`] writes of the tree baked in memory. Refused for a bake with
    /// inner-node attributes and for a tree of depth 1.
    Dag,
    /// [`MergeFormat::Dag`] with the leaves' values kept as [`DagValues`] says: the bytes
    /// [`crate::io::write_dag_to_with`] writes of the tree baked in memory. Values on a level
    /// above the leaves are that level's inner-node attributes, so the plan must make them
    /// ([`crate::BakeOptions::node_attributes`], without contours); values on the leaves
    /// need a plan without them.
    DagWith(DagValues),
}

/// Merges the parts of the plan at `plan_path` (each at [`part_path`]) into `output`.
pub fn merge_parts(
    plan_path: &Path,
    output: &Path,
    format: MergeFormat,
) -> Result<MergeReport, PartsError> {
    let (plan, hash) = read_plan(plan_path)?;
    merge_with(&plan, hash, &|i| part_path(plan_path, i), output, format)
}

/// Where a merge into the DAG layout keeps the leaves' values (`None`: the merge is not into
/// the DAG layout), checked against a plan of `depth` whose parts have the inner nodes'
/// attributes or not: values above the leaves are those attributes, values on the leaves
/// leave them out.
pub(crate) fn dag_values(
    format: MergeFormat,
    depth: u8,
    node_attributes: bool,
) -> Result<Option<DagValues>, PartsError> {
    let values = match format {
        MergeFormat::Dag => DagValues::default(),
        MergeFormat::DagWith(v) => v,
        _ => return Ok(None),
    };
    if depth < 2 {
        return Err(PartsError::Unsupported(
            "the DAG layout needs a tree of depth 2 or more".into(),
        ));
    }
    values
        .check(depth)
        .map_err(|e| PartsError::Unsupported(e.to_string()))?;
    let on_leaves = values.level_for(depth) == depth;
    if on_leaves && node_attributes {
        return Err(PartsError::Unsupported(
            "the DAG layout keeps no inner-node attributes but as the values of a level: bake \
             without them, or keep the values on a level"
                .into(),
        ));
    }
    if !on_leaves && !node_attributes {
        return Err(PartsError::Unsupported(
            crate::dag::ValuesError::NoNodeValues.to_string(),
        ));
    }
    Ok(Some(values))
}

/// The layout of a version-4 file of `plan` (the tree's or the DAG's levels `levels`) with
/// `leaves` leaves and the leaf `channels`.
pub(crate) fn level_layout(
    plan: &BakePlan,
    levels: LevelPlan,
    leaves: u64,
    channels: Vec<(u8, Stored)>,
) -> Layout<'_> {
    Layout {
        root_origin: plan.root_origin,
        root_side: plan.root_side,
        depth: plan.depth,
        node_count: levels.counts.iter().sum(),
        leaf_count: leaves,
        channels,
        build: &plan.build,
        chunks: None,
        levels: Some(levels),
    }
}

/// A subtree and where its part is.
pub(crate) struct Sub {
    pub part: u32,
    pub s: PartSubtree,
}

/// A part's file and its checked header.
pub(crate) type Header = (PathBuf, PartHeader);

/// Merges the parts of `plan` (hash `plan_hash`), part `i` read from `path_of(i)`.
pub(crate) fn merge_with(
    plan: &BakePlan,
    plan_hash: u64,
    path_of: &dyn Fn(u32) -> PathBuf,
    output: &Path,
    format: MergeFormat,
) -> Result<MergeReport, PartsError> {
    let t0 = Instant::now();
    let headers = read_headers(plan, plan_hash, path_of)?;
    let (subs, leaf_off, leaves) = subtrees(&headers);
    let (channels, copied) = channels(&headers, leaves);
    let dag = dag_values(format, plan.depth, plan.node_attributes)?;
    let above = dag.is_some_and(|v| v.level_for(plan.depth) < plan.depth);
    if !plan.leaf_arrays && !above {
        return Err(PartsError::Unsupported(
            "the plan's parts keep no per-leaf values (they were baked for a DAG whose leaves \
             take their values from a level above): merge them so, with the DAG layout and \
             the values on a level"
                .into(),
        ));
    }
    if let Some(values) = dag {
        let (layout, bytes) = merge_dag(
            plan, &headers, &subs, &channels, &copied, leaves, values, output,
        )?;
        return Ok(report(plan, &headers, &layout, bytes, 4, 0, t0));
    }
    if plan.node_attributes && leaves > 0 {
        if format == MergeFormat::Chunked {
            return Err(PartsError::Unsupported(
                "version 3 (chunks) stores no inner-node attributes: merge without --chunked, \
                 or bake without the attributes"
                    .into(),
            ));
        }
        let (merge, levels) =
            LevelMerge::new(plan, &headers, &subs, &leaf_off, &channels, &copied, leaves)?;
        let layout = level_layout(plan, levels, leaves, channels);
        let bytes = merge.write(&layout, output)?;
        return Ok(report(plan, &headers, &layout, bytes, 4, 0, t0));
    }
    let stubs: Vec<Stub> = subs
        .iter()
        .map(|s| Stub {
            code: s.s.code,
            below: s.s.nodes,
        })
        .collect();
    let whole = stitch::node_count(&stubs, plan.level);
    let chunked = format == MergeFormat::Chunked || leaves > MAX_LEAVES || whole > MAX_LEAVES;
    if chunked {
        check_chunks(&subs)?;
    }
    // Version 3 stores each subtree with its root; version 2 adds the levels above them.
    let node_count = if chunked {
        subs.iter().map(|s| 1 + s.s.nodes).sum()
    } else {
        whole
    };
    let layout = Layout {
        root_origin: plan.root_origin,
        root_side: plan.root_side,
        depth: plan.depth,
        node_count,
        leaf_count: leaves,
        channels,
        build: &plan.build,
        chunks: chunked.then_some((plan.level, subs.len() as u64)),
        levels: None,
    };
    let merged = Merged {
        headers: &headers,
        subs: &subs,
        stubs: &stubs,
        leaf_off: &leaf_off,
        copied: &copied,
        level: plan.level,
        chunked,
    };
    let bytes = merged.write(&layout, output)?;
    let (version, chunks) = if chunked {
        (3, subs.len() as u64)
    } else {
        (2, 0)
    };
    Ok(report(plan, &headers, &layout, bytes, version, chunks, t0))
}

/// The report of a merge that wrote `bytes` of `layout` in format `version`.
fn report(
    plan: &BakePlan,
    headers: &[Header],
    layout: &Layout<'_>,
    bytes: u64,
    version: u32,
    chunks: u64,
    t0: Instant,
) -> MergeReport {
    let sum = |f: fn(&PartHeader) -> u64| headers.iter().map(|(_, h)| f(h)).sum();
    MergeReport {
        bytes,
        version,
        chunks,
        nodes: layout.node_count,
        leaves: layout.leaf_count,
        parts: plan.part_count(),
        seconds: t0.elapsed().as_secs_f64(),
        channels: channel_names(&layout.channels),
        overlap_tests: sum(|h| h.stats.overlap_tests),
        leaf_triangle_pairs: sum(|h| h.stats.leaf_triangle_pairs),
        false_positives: sum(|h| h.stats.false_positives),
    }
}

/// Writes the file of `layout` atomically, array `i` from `fill(i, out)`; its bytes. A
/// part's error comes back as it was.
pub(crate) fn write_streamed(
    layout: &Layout<'_>,
    output: &Path,
    fill: &mut dyn FnMut(usize, &mut dyn Write) -> Result<(), PartsError>,
) -> Result<u64, PartsError> {
    let failure: std::cell::RefCell<Option<PartsError>> = Default::default();
    let mut bytes = 0;
    let written = write_atomic(output, |w| {
        bytes = write_layout(layout, w, &mut |i, out| {
            fill(i, out).map_err(|e| {
                let msg = e.to_string();
                *failure.borrow_mut() = Some(e);
                std::io::Error::other(msg)
            })
        })?;
        Ok(())
    });
    match written {
        Ok(()) => Ok(bytes),
        Err(e) => Err(failure
            .into_inner()
            .unwrap_or_else(|| PartsError::io(output, e))),
    }
}

/// Every part's header, read and checked ([`check_part`]); an error names the part that is
/// missing, foreign or malformed.
fn read_headers(
    plan: &BakePlan,
    plan_hash: u64,
    path_of: &dyn Fn(u32) -> PathBuf,
) -> Result<Vec<Header>, PartsError> {
    let count = plan.part_count();
    let mut headers: Vec<Header> = Vec::with_capacity(count as usize);
    for i in 0..count {
        let path = path_of(i);
        if !path.exists() {
            return Err(PartsError::MissingPart {
                index: i,
                count,
                path: path.display().to_string(),
            });
        }
        let h = read_part_header(&path)?;
        check_part(plan, plan_hash, i, &h, &headers).map_err(|(mismatch, detail)| {
            let path = path.display().to_string();
            if mismatch {
                PartsError::Mismatch { path, detail }
            } else {
                PartsError::Corrupt { path, detail }
            }
        })?;
        headers.push((path, h));
    }
    Ok(headers)
}

/// The parts' subtrees in increasing code, each part's first leaf, and the leaves in all.
fn subtrees(headers: &[Header]) -> (Vec<Sub>, Vec<u64>, u64) {
    let mut subs: Vec<Sub> = Vec::new();
    let mut leaf_off = Vec::with_capacity(headers.len());
    let mut leaves = 0u64;
    for (i, (_, h)) in headers.iter().enumerate() {
        leaf_off.push(leaves);
        leaves += h.leaves();
        subs.extend(h.subtrees.iter().rev().map(|&s| Sub { part: i as u32, s }));
    }
    (subs, leaf_off, leaves)
}

/// Refuses a tree in chunks one of whose subtrees is larger than a chunk holds.
fn check_chunks(subs: &[Sub]) -> Result<(), PartsError> {
    match subs
        .iter()
        .find(|s| s.s.nodes >= MAX_LEAVES || s.s.leaves > MAX_LEAVES)
    {
        Some(s) => Err(PartsError::Unsupported(format!(
            "the subtree {} at the parts' level holds {} nodes and {} leaves, more than a chunk \
             holds (2^31 each): plan more parts, which cuts the tree deeper",
            s.s.code,
            s.s.nodes + 1,
            s.s.leaves
        ))),
        None => Ok(()),
    }
}

/// The merged file's channels, and which of them are copied from the parts' arrays (their
/// indices in part 0's channel list). The parts agree on kinds and storage (checked); a
/// per-leaf channel whose leaves all hold one value becomes a constant, as the whole bake's
/// compaction does.
fn channels(headers: &[Header], leaves: u64) -> (Vec<(u8, Stored)>, Vec<usize>) {
    let first = headers
        .first()
        .map(|(_, h)| h.channels.clone())
        .unwrap_or_default();
    let mut channels = Vec::new();
    let mut copied = Vec::new();
    for (k, &(kind, storage)) in first.iter().enumerate() {
        match storage {
            PartStorage::Constant(v) => channels.push((kind, Stored::Constant(v))),
            PartStorage::PerLeaf { size, .. } => {
                let mut values =
                    headers
                        .iter()
                        .filter(|(_, h)| h.leaves() > 0)
                        .map(|(_, h)| match h.channels[k].1 {
                            PartStorage::PerLeaf { uniform, .. } => uniform,
                            PartStorage::Constant(_) => None,
                        });
                let one = values.next().flatten();
                if leaves > 0 && one.is_some() && values.all(|v| v == one) {
                    channels.push((kind, Stored::Constant(one.unwrap_or_default())));
                } else {
                    channels.push((kind, Stored::PerLeaf(leaves * u64::from(size))));
                    copied.push(k);
                }
            }
        }
    }
    (channels, copied)
}

/// The channels' names and how the file stores them, for the report.
fn channel_names(channels: &[(u8, Stored)]) -> Vec<(String, String)> {
    channels
        .iter()
        .map(|&(kind, s)| {
            let name = crate::octree::ChannelKind::ALL
                .get(usize::from(kind))
                .map_or("?", |k| k.name());
            let storage = match s {
                Stored::Constant(_) => "constant",
                Stored::PerLeaf(_) => "per-leaf",
                Stored::Packed { .. } => "on a level",
            };
            (name.to_string(), storage.to_string())
        })
        .collect()
}

/// What the merged file is made of: the parts, their subtrees in increasing code, and the
/// channels copied from their arrays.
struct Merged<'a> {
    headers: &'a [Header],
    subs: &'a [Sub],
    stubs: &'a [Stub],
    leaf_off: &'a [u64],
    copied: &'a [usize],
    level: u8,
    chunked: bool,
}

impl Merged<'_> {
    /// Writes the file of `layout` atomically, its arrays streamed from the parts; its bytes.
    fn write(&self, layout: &Layout<'_>, output: &Path) -> Result<u64, PartsError> {
        write_streamed(layout, output, &mut |i, out| {
            let failed = std::cell::RefCell::new(None);
            let fail = |e: PartsError| {
                let msg = e.to_string();
                *failed.borrow_mut() = Some(e);
                std::io::Error::other(msg)
            };
            let r = self.array(i, out, &fail);
            match (r, failed.into_inner()) {
                (_, Some(e)) => Err(e),
                (Err(e), None) => Err(PartsError::io(output, e)),
                (Ok(()), None) => Ok(()),
            }
        })
    }

    /// Writes array `i` of the layout (version 3: the chunk table, the chunks, the channels;
    /// version 2: the nodes, the channels); a part's error goes through `fail`.
    fn array(
        &self,
        i: usize,
        out: &mut dyn Write,
        fail: &dyn Fn(PartsError) -> std::io::Error,
    ) -> std::io::Result<()> {
        let i = if self.chunked {
            match i {
                0 => return write_chunk_table(self.subs, out),
                1 => return write_chunks(self.headers, self.subs, out).map_err(fail),
                _ => i - 1,
            }
        } else {
            i
        };
        if i == 0 {
            return self.nodes(out, fail);
        }
        let k = self.copied[i - 1];
        for (path, h) in self.headers {
            let a = h.arrays[1 + per_leaf_rank(h, k)];
            copy_array(path, a, out).map_err(fail)?;
        }
        Ok(())
    }

    /// Writes the version-2 node array: the levels above the parts' subtrees and the
    /// subtrees below them, in the canonical node order.
    fn nodes(
        &self,
        out: &mut dyn Write,
        fail: &dyn Fn(PartsError) -> std::io::Error,
    ) -> std::io::Result<()> {
        let mut nodes = NodeWriter {
            out,
            headers: self.headers,
            leaf_off: self.leaf_off,
            reader: None,
            buf: Vec::new(),
        };
        stitch::stitch(self.stubs, self.level, &mut |piece| match piece {
            Piece::Top(n) => nodes.put(n),
            Piece::Root { index, at } => nodes.put(Node {
                info: u32::from(self.subs[index].s.mask),
                first: at as u32,
            }),
            Piece::Below { index, at } => nodes.region(&self.subs[index], at).map_err(fail),
        })?;
        nodes.finish_part().map_err(fail)?;
        nodes.flush()
    }
}

/// The rank of channel `k` among the part's per-leaf channels (its array is `1 +` that).
pub(crate) fn per_leaf_rank(h: &PartHeader, k: usize) -> usize {
    h.channels[..k]
        .iter()
        .filter(|(_, s)| matches!(s, PartStorage::PerLeaf { .. }))
        .count()
}

/// What the merge relies on in a part: the plan's hash and its own index, subtrees in the
/// part's range in decreasing code with children, arrays of the lengths the counts give,
/// and the same channels as the parts before it. `Err((true, _))` for a part of another plan
/// or index, `Err((false, _))` for a malformed one.
fn check_part(
    plan: &BakePlan,
    plan_hash: u64,
    index: u32,
    h: &PartHeader,
    before: &[(PathBuf, PartHeader)],
) -> Result<(), (bool, String)> {
    if h.plan_hash != plan_hash {
        return Err((
            true,
            format!(
                "part of another plan (plan hash {:#018x}, this plan's is {plan_hash:#018x})",
                h.plan_hash
            ),
        ));
    }
    if h.index != index {
        return Err((true, format!("this is part {}, not part {index}", h.index)));
    }
    let bad = |d: String| Err((false, d));
    let range = &plan.parts[index as usize];
    let mut prev = None;
    for s in &h.subtrees {
        if s.code < range.start || s.code >= range.end || prev.is_some_and(|p| p <= s.code) {
            return bad(format!(
                "subtree {} is out of the part's range or order",
                s.code
            ));
        }
        if s.mask == 0 || s.leaves == 0 || s.nodes == 0 {
            return bad(format!("subtree {} is empty", s.code));
        }
        prev = Some(s.code);
    }
    let per_leaf: Vec<u8> = h
        .channels
        .iter()
        .filter_map(|(_, s)| match s {
            PartStorage::PerLeaf { size, .. } => Some(*size),
            PartStorage::Constant(_) => None,
        })
        .collect();
    let nodes: u64 = h.subtrees.iter().map(|s| s.nodes).sum();
    // The node arrays' lengths, in order.
    let node_lens: Vec<u64> = match (&h.levels, plan.node_attributes) {
        (None, false) => vec![nodes.saturating_mul(8)],
        (Some(l), true) => {
            let below = usize::from(plan.depth - plan.level - 1);
            let roots_children: u64 = h
                .subtrees
                .iter()
                .map(|s| u64::from(s.mask.count_ones()))
                .sum();
            if l.counts.len() != below
                || l.roots.len() != h.subtrees.len()
                || l.kinds != node_kinds(&h.channels)
                || l.counts.iter().sum::<u64>() != nodes
                || l.counts.first().copied().unwrap_or(0) != roots_children
            {
                return bad("its levels do not match its subtrees and channels".into());
            }
            let mut lens = Vec::new();
            for (r, &count) in l.counts.iter().enumerate() {
                lens.push(count.saturating_mul(8));
                if r + 1 < below {
                    lens.extend(l.kinds.iter().map(|&k| {
                        count.saturating_mul(
                            crate::octree::ChannelKind::ALL[usize::from(k)].element_size() as u64,
                        )
                    }));
                }
            }
            lens
        }
        _ => return Err((true, "its inner-node attributes are not the plan's".into())),
    };
    let per_leaf = if plan.leaf_arrays {
        per_leaf
    } else {
        Vec::new()
    };
    if h.arrays.len() != node_lens.len() + per_leaf.len() {
        return bad("its arrays do not match its channels".into());
    }
    let (node_arrays, leaf_arrays) = h.arrays.split_at(node_lens.len());
    if node_arrays
        .iter()
        .zip(&node_lens)
        .any(|(a, &len)| a.len != len)
        || per_leaf
            .iter()
            .zip(leaf_arrays)
            .any(|(&size, a)| a.len != h.leaves().saturating_mul(u64::from(size)))
    {
        return bad("an array's length does not match its counts".into());
    }
    if let Some((_, first)) = before.first() {
        let kinds = |h: &PartHeader| -> Vec<(u8, Option<u32>, Option<u8>)> {
            h.channels
                .iter()
                .map(|&(k, s)| match s {
                    PartStorage::Constant(v) => (k, Some(v), None),
                    PartStorage::PerLeaf { size, .. } => (k, None, Some(size)),
                })
                .collect()
        };
        if kinds(first) != kinds(h)
            || first.levels.as_ref().map(|l| l.rule) != h.levels.as_ref().map(|l| l.rule)
        {
            return Err((true, "its channels are not those of part 0".into()));
        }
    }
    Ok(())
}

/// Writes a version-3 chunk table: a chunk per subtree, in increasing code.
fn write_chunk_table(subs: &[Sub], out: &mut dyn Write) -> std::io::Result<()> {
    let table: Vec<ChunkRecord> = subs
        .iter()
        .map(|s| ChunkRecord {
            code: s.s.code,
            nodes: 1 + s.s.nodes,
            leaves: s.s.leaves,
        })
        .collect();
    out.write_all(bytemuck::cast_slice(&table))
}

/// Writes a version-3 node array: each subtree (in increasing code, which is the reverse of
/// its part's order) as a tree of its own, its root first and its leaves counted from 0. Each
/// part's node array is read once whole for its hash, then subtree by subtree.
fn write_chunks(
    headers: &[(PathBuf, PartHeader)],
    subs: &[Sub],
    out: &mut dyn Write,
) -> Result<(), PartsError> {
    for (part, (path, h)) in headers.iter().enumerate() {
        copy_array(path, h.arrays[0], &mut std::io::sink())?;
        let mut f = BufReader::with_capacity(
            1 << 20,
            std::fs::File::open(path).map_err(|e| PartsError::io(path, e))?,
        );
        // Where each subtree's nodes start in the part (they are stored highest code first),
        // and its first leaf (leaves are in increasing code).
        let mut node_at = h.arrays[0].offset;
        let mut starts = Vec::with_capacity(h.subtrees.len());
        for s in &h.subtrees {
            starts.push(node_at);
            node_at += 8 * s.nodes;
        }
        let mut leaf_at = 0u64;
        let mut buf = Vec::new();
        for (j, sub) in subs.iter().filter(|s| s.part == part as u32).enumerate() {
            let k = h.subtrees.len() - 1 - j;
            let s = sub.s;
            f.seek(SeekFrom::Start(starts[k]))
                .map_err(|e| PartsError::io(path, e))?;
            buf.clear();
            buf.push(Node {
                info: u32::from(s.mask),
                first: 1,
            });
            buf.resize(1 + s.nodes as usize, Node::default());
            f.read_exact(bytemuck::cast_slice_mut(&mut buf[1..]))
                .map_err(|e| PartsError::io(path, e))?;
            for rec in &mut buf[1..] {
                *rec = relocate(*rec, s.nodes, 1, -(leaf_at as i64)).ok_or_else(|| {
                    corrupt(
                        path,
                        "corrupt part file: a node points outside its subtree or the file's limits",
                    )
                })?;
            }
            out.write_all(bytemuck::cast_slice(&buf))
                .map_err(|e| PartsError::io(path, e))?;
            leaf_at += s.leaves;
        }
    }
    Ok(())
}

/// Writes the node array: records, and the parts' subtrees copied with their pointers moved.
struct NodeWriter<'a> {
    out: &'a mut dyn Write,
    headers: &'a [(PathBuf, PartHeader)],
    leaf_off: &'a [u64],
    /// The part being read: its index, its node array's reader and hash, and the subtrees
    /// of it copied so far.
    reader: Option<(
        u32,
        BufReader<std::fs::File>,
        xxhash_rust::xxh3::Xxh3,
        usize,
    )>,
    buf: Vec<Node>,
}

impl NodeWriter<'_> {
    fn put(&mut self, n: Node) -> std::io::Result<()> {
        self.buf.push(n);
        if self.buf.len() >= 1 << 16 {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.write_all(bytemuck::cast_slice(&self.buf))?;
        self.buf.clear();
        Ok(())
    }

    /// Checks that the part being read was read whole and matches its hash.
    fn finish_part(&mut self) -> Result<(), PartsError> {
        if let Some((part, _, hash, done)) = self.reader.take() {
            let (path, h) = &self.headers[part as usize];
            if done != h.subtrees.len() || hash.digest() != h.arrays[0].hash {
                return Err(corrupt(
                    path,
                    "node array checksum mismatch: the part file is corrupt",
                ));
            }
        }
        Ok(())
    }

    /// Copies subtree `sub`'s nodes, which the file places from index `at`.
    fn region(&mut self, sub: &Sub, at: u64) -> Result<(), PartsError> {
        // The records put before it come first.
        self.flush()
            .map_err(|e| PartsError::io(&self.headers[sub.part as usize].0, e))?;
        if self.reader.as_ref().map(|r| r.0) != Some(sub.part) {
            self.finish_part()?;
            let (path, h) = &self.headers[sub.part as usize];
            let mut f = std::fs::File::open(path).map_err(|e| PartsError::io(path, e))?;
            f.seek(SeekFrom::Start(h.arrays[0].offset))
                .map_err(|e| PartsError::io(path, e))?;
            self.reader = Some((
                sub.part,
                BufReader::with_capacity(1 << 20, f),
                xxhash_rust::xxh3::Xxh3::new(),
                0,
            ));
        }
        let (path, h) = &self.headers[sub.part as usize];
        let leaf_off = self.leaf_off[sub.part as usize];
        let Some((_, reader, hash, done)) = self.reader.as_mut() else {
            return Ok(());
        };
        if h.subtrees.get(*done).map(|s| s.code) != Some(sub.s.code) {
            return Err(corrupt(path, "corrupt part file: subtrees out of order"));
        }
        *done += 1;
        let n = sub.s.nodes;
        let mut chunk = vec![Node::default(); (n as usize).min(1 << 16)];
        let mut left = n;
        while left > 0 {
            let k = (left as usize).min(chunk.len());
            let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut chunk[..k]);
            reader.read_exact(bytes).map_err(|e| {
                if e.kind() == std::io::ErrorKind::UnexpectedEof {
                    corrupt(path, "truncated part file")
                } else {
                    PartsError::io(path, e)
                }
            })?;
            hash.update(bytes);
            for rec in &mut chunk[..k] {
                *rec = relocate(*rec, n, at as i64, leaf_off as i64).ok_or_else(|| {
                    corrupt(
                        path,
                        "corrupt part file: a node points outside its subtree or the file's limits",
                    )
                })?;
            }
            self.out
                .write_all(bytemuck::cast_slice(&chunk[..k]))
                .map_err(|e| PartsError::io(path, e))?;
            left -= k as u64;
        }
        Ok(())
    }
}

/// A subtree's record moved to the file: inner pointers (counted from the subtree's first
/// node, of `n`) by `at`, leaf bases by `leaf_off`. `None` for a pointer out of range.
fn relocate(rec: Node, n: u64, at: i64, leaf_off: i64) -> Option<Node> {
    let inside = rec.is_leaf_parent()
        || u64::from(rec.first) + u64::from(rec.child_mask().count_ones()) <= n;
    inside.then(|| stitch::moved(rec, at, leaf_off))?
}

pub(crate) fn corrupt(path: &Path, detail: &str) -> PartsError {
    PartsError::Corrupt {
        path: path.display().to_string(),
        detail: detail.to_string(),
    }
}

/// Copies one array of a part file to `out`, checking its hash.
pub(crate) fn copy_array(
    path: &Path,
    a: crate::bake::parts::part::PartArray,
    out: &mut dyn Write,
) -> Result<(), PartsError> {
    read_array(path, a, "channel array", &mut |bytes| {
        out.write_all(bytes).map_err(|e| PartsError::io(path, e))
    })
}

/// Reads array `a` of a part file in pieces of whole 8-byte words (up to 1 MiB), handing each
/// to `each`, and checks its hash (a mismatch names the array as `what`).
pub(crate) fn read_array(
    path: &Path,
    a: crate::bake::parts::part::PartArray,
    what: &str,
    each: &mut dyn FnMut(&[u8]) -> Result<(), PartsError>,
) -> Result<(), PartsError> {
    let mut f = std::fs::File::open(path).map_err(|e| PartsError::io(path, e))?;
    f.seek(SeekFrom::Start(a.offset))
        .map_err(|e| PartsError::io(path, e))?;
    let mut hash = xxhash_rust::xxh3::Xxh3::new();
    let mut buf = vec![0u8; (a.len as usize).clamp(8, 1 << 20)];
    let mut left = a.len;
    while left > 0 {
        let n = left.min(buf.len() as u64) as usize;
        f.read_exact(&mut buf[..n]).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                corrupt(path, "truncated part file")
            } else {
                PartsError::io(path, e)
            }
        })?;
        hash.update(&buf[..n]);
        each(&buf[..n])?;
        left -= n as u64;
    }
    if hash.digest() != a.hash {
        return Err(corrupt(
            path,
            &format!("{what} checksum mismatch: the part file is corrupt"),
        ));
    }
    Ok(())
}
