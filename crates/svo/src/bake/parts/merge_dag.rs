//! The merge of a plan's parts into version 4's DAG layout (`docs/format.md`, section 12):
//! each part's subtrees reduced into one graph as the part is read, the parts in Morton
//! order, so that each level's distinct nodes come in the order the reduction of the whole
//! tree finds them ([`DagBuilder`]); then the levels above the parts' level, made from the
//! subtrees' roots; then the graph written, with the leaves' channels copied from the parts
//! in Morton order. Memory holds the graph and one part's nodes, never the tree, so the file
//! is the one `svo::io::write_dag_to` writes of the tree baked in memory, byte for byte.

use crate::bake::parts::merge::{
    Header, copy_array, corrupt, per_leaf_rank, read_array, write_streamed,
};
use crate::bake::parts::plan::{BakePlan, PartsError};
use crate::dag::DagBuilder;
use crate::io::write::{Layout, Stored, dag_blocks};
use crate::octree::tree::Node;
use std::io::Write;
use std::path::Path;

/// Merges the parts (`headers`, checked) of `plan` into `output` as the DAG layout: the
/// channels as the merge stores them (`channels`; `copied` are the parts' channel indices
/// copied per leaf), `leaves` in all. Returns the layout written and its bytes.
pub(crate) fn merge_dag<'a>(
    plan: &'a BakePlan,
    headers: &[Header],
    channels: Vec<(u8, Stored)>,
    copied: &[usize],
    leaves: u64,
    output: &Path,
) -> Result<(Layout<'a>, u64), PartsError> {
    let level = usize::from(plan.level);
    let mut graph = DagBuilder::new(plan.depth);
    // Each subtree's code and index on the parts' level, in increasing code.
    let mut cells: Vec<(u64, u32)> = Vec::new();
    for (path, h) in headers {
        let a = h.arrays[0];
        let on_disk = std::fs::metadata(path)
            .map_err(|e| PartsError::io(path, e))?
            .len();
        if a.offset.saturating_add(a.len) > on_disk {
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
    let dag = graph.finish();
    debug_assert_eq!(dag.leaf_count(), leaves);
    let (levels, blocks) = dag_blocks(&dag);
    let layout = Layout {
        root_origin: plan.root_origin,
        root_side: plan.root_side,
        depth: plan.depth,
        node_count: levels.counts.iter().sum(),
        leaf_count: leaves,
        channels,
        build: &plan.build,
        chunks: None,
        levels: Some(levels),
    };
    let bytes = write_streamed(&layout, output, &mut |i, out: &mut dyn Write| {
        if let Some(b) = blocks.get(i) {
            return out.write_all(b).map_err(|e| PartsError::io(output, e));
        }
        let k = copied[i - blocks.len()];
        for (path, h) in headers {
            copy_array(path, h.arrays[1 + per_leaf_rank(h, k)], out)?;
        }
        Ok(())
    })?;
    Ok((layout, bytes))
}
