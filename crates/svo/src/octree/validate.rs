//! Structural validation of an octree: what the file reader runs on untrusted input before
//! anything traverses it (a malicious file must not hang or crash a reader or the GPU).
//!
//! Checks: a root exists; reserved info bits are zero; only the root may have no children;
//! leaf references appear exactly at the level above the leaves and stay in range; every
//! child pointer points forward and in range; every node and every leaf is referenced
//! exactly once (so there are no cycles, no sharing and no orphans); per-leaf channels have
//! one value per leaf.

use crate::octree::tree::{ChannelStorage, Octree};

/// Validates the tree's structure; the error says what is wrong and where.
pub fn validate(t: &Octree) -> Result<(), String> {
    if !(1..=crate::MAX_DEPTH).contains(&t.depth) {
        return Err(format!(
            "depth {} is outside 1..={}",
            t.depth,
            crate::MAX_DEPTH
        ));
    }
    if !(t.root.side.is_finite() && t.root.side > 0.0 && t.root.origin.is_finite()) {
        return Err("root cube is not finite and positive".into());
    }
    let n = t.nodes.len();
    if n == 0 {
        return Err("no root node".into());
    }
    let leaves = t.leaf_count as usize;
    let a = &t.attributes;
    for (kind, storage) in a.storage() {
        if let ChannelStorage::PerLeaf(len) = storage
            && len != leaves
        {
            return Err(format!(
                "channel {} has {len} values for {leaves} leaves",
                kind.name()
            ));
        }
    }
    let mut seen_node = vec![false; n];
    let mut seen_leaf = vec![false; leaves];
    seen_node[0] = true;
    let mut stack: Vec<(usize, u8)> = vec![(0, 0)];
    while let Some((i, level)) = stack.pop() {
        let node = t.nodes[i];
        if node.info >> 8 != 0 {
            return Err(format!(
                "node {i}: reserved info bits set ({:#x})",
                node.info
            ));
        }
        let mask = node.child_mask();
        let k = mask.count_ones() as usize;
        if mask == 0 {
            if i != 0 {
                return Err(format!("node {i}: interior node without children"));
            }
            continue;
        }
        if level + 1 == t.depth {
            let Some(base) = node.leaf_base() else {
                return Err(format!(
                    "node {i} at the level above the leaves does not point to leaves"
                ));
            };
            let base = base as usize;
            if base.checked_add(k).is_none_or(|e| e > leaves) {
                return Err(format!(
                    "node {i}: leaves {base}..{} out of range ({leaves} leaves)",
                    base + k
                ));
            }
            for s in &mut seen_leaf[base..base + k] {
                if *s {
                    return Err(format!("node {i}: leaf referenced twice"));
                }
                *s = true;
            }
        } else {
            if node.is_leaf_parent() {
                return Err(format!(
                    "node {i} at level {level} points to leaves above the leaf level"
                ));
            }
            let first = node.first as usize;
            if first <= i {
                return Err(format!(
                    "node {i}: child pointer {first} does not point forward"
                ));
            }
            if first.checked_add(k).is_none_or(|e| e > n) {
                return Err(format!(
                    "node {i}: children {first}..{} out of range ({n} nodes)",
                    first + k
                ));
            }
            for (j, seen) in seen_node.iter_mut().enumerate().skip(first).take(k) {
                if *seen {
                    return Err(format!("node {i}: node {j} referenced twice"));
                }
                *seen = true;
                stack.push((j, level + 1));
            }
        }
    }
    if let Some(j) = seen_node.iter().position(|s| !s) {
        return Err(format!("node {j} is not reachable from the root"));
    }
    if let Some(j) = seen_leaf.iter().position(|s| !s) {
        return Err(format!("leaf {j} is not referenced by any node"));
    }
    Ok(())
}
