//! A graph as version 4's DAG layout stores it (`docs/format.md`, section 12), and the checks
//! that a reader makes on it.
//!
//! Levels `0 .. depth - 2` hold the distinct nodes above the bricks, each its 8-bit child mask
//! followed by one reference for each child, the child's index among the next level's nodes
//! (the bricks', below level `depth - 3`), packed into a bit stream with as few bits a
//! reference as the next level's count needs ([`ref_bits`]). Level `depth - 2` holds the
//! distinct subtrees of 4x4x4 cells as 64-bit bricks: bit `8 * a + b` is the leaf at child `b`
//! of child `a` (each a child index of section 4), so the bricks' set bits, lowest first, are
//! its leaves in Morton order. Each level lists its nodes in the order in which the level
//! above first refers to them, the root alone on level 0; no two nodes of a level are equal,
//! and every one is referred to. In memory each node is a mask word followed by its
//! children's indices.
#![cfg_attr(not(feature = "io"), allow(dead_code))]

use super::build::Dag;
use super::expand::{Graph, canonical_nodes, canonical_nodes_to};
use crate::octree::format_check::Check;
use crate::octree::tree::Node;
use crate::octree::validate::Failure;
use rustc_hash::FxHashSet;

/// The child mask of a brick's node: its nonzero bytes, its leaf parents.
#[inline]
pub(crate) fn brick_mask(b: u64) -> u8 {
    let bytes = b.to_le_bytes();
    (0..8).fold(0u8, |m, a| m | u8::from(bytes[a] != 0) << a)
}

/// Most leaves a version-4 file of the DAG layout may stand for (check 9).
pub(crate) const MAX_DAG_LEAVES: u64 = 1 << 48;

/// The bits of a child reference on a level whose next level holds `below` nodes: the fewest,
/// at least 1, that hold every index below `below`.
pub(crate) fn ref_bits(below: u64) -> u32 {
    (64 - below.saturating_sub(1).leading_zeros()).max(1)
}

/// The most bytes a node level's block may take: `nodes` nodes of 8 children each.
pub(crate) fn max_block_len(nodes: u64, below: u64) -> Option<u64> {
    nodes.checked_mul(1 + u64::from(ref_bits(below)))
}

/// Writes fields into a little-endian bit stream, each lowest bit first.
#[derive(Default)]
struct BitWriter {
    bytes: Vec<u8>,
    /// Bits not yet a whole byte, the lowest first, and how many.
    pending: u64,
    held: u32,
}

impl BitWriter {
    /// Appends the `width` (at most 32) lowest bits of `value`.
    fn put(&mut self, value: u32, width: u32) {
        self.pending |= (u64::from(value) & ((1u64 << width) - 1)) << self.held;
        self.held += width;
        while self.held >= 8 {
            self.bytes.push(self.pending as u8);
            self.pending >>= 8;
            self.held -= 8;
        }
    }

    /// The stream's bytes, the last one's bits past the stream zero.
    fn finish(mut self) -> Vec<u8> {
        if self.held > 0 {
            self.bytes.push(self.pending as u8);
        }
        self.bytes
    }
}

/// Reads fields from a little-endian bit stream.
struct BitReader<'a> {
    bytes: &'a [u8],
    bit: u64,
}

impl BitReader<'_> {
    /// The next `width` bits (at most 32), or `None` past the end.
    fn take(&mut self, width: u32) -> Option<u32> {
        if self.bit + u64::from(width) > 8 * self.bytes.len() as u64 {
            return None;
        }
        let mut v = 0u32;
        let mut got = 0u32;
        while got < width {
            let at = self.bit + u64::from(got);
            let byte = self.bytes[(at / 8) as usize] >> (at % 8);
            let n = (8 - (at % 8) as u32).min(width - got);
            v |= (u32::from(byte) & ((1u32 << n) - 1)) << got;
            got += n;
        }
        self.bit += u64::from(width);
        Some(v)
    }
}

/// A tree's geometry in the DAG layout: see the module docs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct DagLevels {
    depth: u8,
    /// Levels `0 .. depth - 2`: the nodes' words.
    words: Vec<Vec<u32>>,
    /// Level `depth - 2`: the bricks.
    bricks: Vec<u64>,
    /// Levels `0 .. depth - 2`: each node's children, as indices on the level below (derived).
    kids: Vec<Vec<u32>>,
    /// Levels `0 .. depth - 2`: each node's first word and its first child in `kids`.
    starts: Vec<Vec<(u32, u32)>>,
}

/// How large the tree a graph stands for is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct TreeSize {
    /// Its leaves.
    pub leaves: u64,
    /// Its nodes (saturating).
    pub nodes: u64,
}

impl DagLevels {
    /// The file form of `dag` (of depth 2 or more).
    pub(crate) fn of(dag: &Dag) -> Self {
        let depth = usize::from(dag.depth());
        debug_assert!(depth >= 2);
        let top = depth - 2;
        let mut words = Vec::with_capacity(top);
        for l in 0..top {
            let (masks, starts, children, _) = dag.level_parts(l);
            let mut w = Vec::with_capacity(masks.len() + children.len());
            for (k, &m) in masks.iter().enumerate() {
                w.push(u32::from(m));
                w.extend_from_slice(&children[starts[k] as usize..starts[k + 1] as usize]);
            }
            words.push(w);
        }
        let (masks, starts, children, _) = dag.level_parts(top);
        let (leaf_masks, ..) = dag.level_parts(top + 1);
        let bricks = (0..masks.len())
            .map(|k| {
                let mut b = 0u64;
                let span = &children[starts[k] as usize..starts[k + 1] as usize];
                let mut c = span.iter();
                for a in 0..8 {
                    if masks[k] >> a & 1 != 0
                        && let Some(&lp) = c.next()
                    {
                        b |= u64::from(leaf_masks[lp as usize]) << (8 * a);
                    }
                }
                b
            })
            .collect();
        let mut out = Self {
            depth: dag.depth(),
            words,
            bricks,
            kids: Vec::new(),
            starts: Vec::new(),
        };
        // The nodes' starts (which the counts and a walk use): a graph made from a tree passes
        // the reader's checks, which also derive its children's indices (made in debug builds).
        for l in 0..top {
            let (_, starts, children, _) = dag.level_parts(l);
            out.starts.push(
                starts[..starts.len() - 1]
                    .iter()
                    .enumerate()
                    .map(|(k, &s)| (k as u32 + s, s))
                    .collect(),
            );
            out.kids.push(children.to_vec());
        }
        #[cfg(debug_assertions)]
        {
            let counts = out.counts();
            let mut checked = out.clone();
            if let Err((check, detail)) = checked.derive(&counts) {
                unreachable!("{check}: {detail}");
            }
            debug_assert_eq!(checked, out);
        }
        out
    }

    /// The bytes of each level's block: each node level's bit stream, then the bricks.
    pub(crate) fn blocks(&self) -> Vec<Vec<u8>> {
        let counts = self.counts();
        let mut out: Vec<Vec<u8>> = Vec::with_capacity(self.words.len() + 1);
        for (l, w) in self.words.iter().enumerate() {
            let width = ref_bits(counts[l + 1]);
            let mut bits = BitWriter {
                bytes: Vec::with_capacity(w.len() * (width as usize + 8) / 8 + 1),
                ..BitWriter::default()
            };
            let mut at = 0;
            while at < w.len() {
                let k = w[at].count_ones() as usize;
                bits.put(w[at], 8);
                for &c in &w[at + 1..at + 1 + k] {
                    bits.put(c, width);
                }
                at += 1 + k;
            }
            out.push(bits.finish());
        }
        out.push(bytemuck::cast_slice(&self.bricks).to_vec());
        out
    }

    /// Nodes on each level, the root's first, the bricks last.
    pub(crate) fn counts(&self) -> Vec<u64> {
        let mut c: Vec<u64> = self.starts.iter().map(|s| s.len() as u64).collect();
        c.push(self.bricks.len() as u64);
        c
    }

    /// The nodes on each level of the tree the graph stands for, the root's first (`depth`
    /// entries), then its leaves (saturating): each node counted as often as paths from the
    /// root reach it.
    pub(crate) fn tree_counts(&self) -> Vec<u64> {
        let top = usize::from(self.depth) - 2;
        let mut counts = Vec::with_capacity(top + 3);
        // How many of the tree's nodes each node of the level stands for.
        let mut times = vec![1u64];
        for l in 0..top {
            counts.push(times.iter().fold(0u64, |a, &t| a.saturating_add(t)));
            let below = if l + 1 == top {
                self.bricks.len()
            } else {
                self.starts[l + 1].len()
            };
            let mut next = vec![0u64; below];
            for (k, &(s, first)) in self.starts[l].iter().enumerate() {
                let n = self.words[l][s as usize].count_ones() as usize;
                let f = first as usize;
                for &c in &self.kids[l][f..f + n] {
                    next[c as usize] = next[c as usize].saturating_add(times[k]);
                }
            }
            times = next;
        }
        let sum = |per: &dyn Fn(u64) -> u64| {
            self.bricks.iter().zip(&times).fold(0u64, |a, (&b, &t)| {
                a.saturating_add(t.saturating_mul(per(b)))
            })
        };
        counts.push(sum(&|_| 1));
        counts.push(sum(&|b| u64::from(brick_mask(b).count_ones())));
        counts.push(sum(&|b| u64::from(b.count_ones())));
        counts
    }

    /// Checks 14 to 16 (`docs/format.md`, section 12) on the blocks of a graph of `depth`
    /// levels (2 or more): `blocks[l]` holds level `l`'s bytes (a bit stream on the node
    /// levels, 8 bytes a brick on the bricks' level) and `counts[l]` the nodes the level table
    /// gives it.
    pub(crate) fn from_blocks(
        depth: u8,
        blocks: &[&[u8]],
        counts: &[u64],
    ) -> Result<Self, Failure> {
        let top = usize::from(depth) - 2;
        let mut words = Vec::with_capacity(top);
        for l in 0..top {
            words.push(decode_level(l, blocks[l], counts[l], counts[l + 1])?);
        }
        let bricks = bytemuck::pod_collect_to_vec::<u8, u64>(blocks[top]);
        let mut out = Self {
            depth,
            words,
            bricks,
            kids: Vec::new(),
            starts: Vec::new(),
        };
        out.derive(counts)?;
        Ok(out)
    }

    /// Derives each node's start and children from the words and bricks: the bricks without
    /// leaves (check 15), then level by level from 1 down the references of the level above
    /// (check 16) and the level's nodes being distinct (check 16), as section 12 orders them
    /// after reading the nodes ([`decode_level`]).
    fn derive(&mut self, counts: &[u64]) -> Result<(), Failure> {
        let top = usize::from(self.depth) - 2;
        self.kids = Vec::with_capacity(top);
        self.starts = Vec::with_capacity(top);
        let fail = |c: Check, m: String| Err((c, m));
        if let Some(k) = self
            .bricks
            .iter()
            .enumerate()
            .position(|(k, &b)| b == 0 && !(top == 0 && k == 0))
        {
            return fail(
                Check::TreeShape,
                format!("level {top}: brick {k} has no leaves"),
            );
        }
        for (l, &want) in counts.iter().enumerate().take(top + 1) {
            // (a) The level's nodes, one after another.
            let count = if l == top {
                self.bricks.len()
            } else {
                let w = &self.words[l];
                let mut starts = Vec::new();
                let mut at = 0usize;
                while at < w.len() {
                    let k = w[at].count_ones() as usize;
                    if at + 1 + k > w.len() {
                        return fail(
                            Check::NodeOrder,
                            format!("level {l}, word {at}: the node's children run past the level"),
                        );
                    }
                    starts.push((at as u32, 0u32));
                    at += 1 + k;
                }
                self.starts.push(starts);
                self.starts[l].len()
            };
            if count as u64 != want {
                return fail(
                    Check::NodeOrder,
                    format!("level {l} holds {count} nodes, the level table says {want}"),
                );
            }
            // (b) The level above refers to every node of this one, first references in order.
            if l > 0 {
                let above = &self.words[l - 1];
                let mut kids = Vec::with_capacity(above.len());
                let mut seen = 0usize;
                for (k, s) in self.starts[l - 1].iter_mut().enumerate() {
                    s.1 = kids.len() as u32;
                    let at = s.0 as usize;
                    let n = above[at].count_ones() as usize;
                    for &p in &above[at + 1..at + 1 + n] {
                        let Some(i) = ((p as usize) < count).then_some(p as usize) else {
                            return fail(
                                Check::NodeOrder,
                                format!(
                                    "level {}, node {k}: child {p} is not a node of level {l}",
                                    l - 1
                                ),
                            );
                        };
                        if i > seen {
                            return fail(
                                Check::NodeOrder,
                                format!(
                                    "level {}, node {k}: child {i} of level {l} comes before \
                                     child {seen}, which is first referred to later",
                                    l - 1
                                ),
                            );
                        }
                        seen += usize::from(i == seen);
                        kids.push(i as u32);
                    }
                }
                if seen != count {
                    return fail(
                        Check::NodeOrder,
                        format!(
                            "level {l}: node {seen} is not referred to from level {}",
                            l - 1
                        ),
                    );
                }
                self.kids.push(kids);
            }
            // (c) No node twice.
            let twice = if l == top {
                let mut set = FxHashSet::with_capacity_and_hasher(count, Default::default());
                self.bricks.iter().position(|b| !set.insert(*b))
            } else {
                let w = &self.words[l];
                let mut set = FxHashSet::with_capacity_and_hasher(count, Default::default());
                self.starts[l].iter().position(|&(s, _)| {
                    let s = s as usize;
                    !set.insert(&w[s..s + 1 + w[s].count_ones() as usize])
                })
            };
            if let Some(k) = twice {
                return fail(
                    Check::NodeOrder,
                    format!("level {l}: node {k} equals an earlier node of the level"),
                );
            }
        }
        Ok(())
    }

    /// Every node's value from the bricks up: `brick(b)` for each brick, then level by level
    /// from the one above the bricks to the root, `node(l, mask, values)` for each node of level
    /// `l` with the values of its children in child order. The values of the levels above the
    /// bricks, and the bricks'.
    fn bottom_up<T: Copy + Default>(
        &self,
        brick: impl Fn(u64) -> T,
        mut node: impl FnMut(usize, u8, &[T]) -> T,
    ) -> (Vec<Vec<T>>, Vec<T>) {
        let top = usize::from(self.depth) - 2;
        let bricks: Vec<T> = self.bricks.iter().map(|&b| brick(b)).collect();
        let mut levels = vec![Vec::new(); top];
        for l in (0..top).rev() {
            let below = if l + 1 == top {
                &bricks
            } else {
                &levels[l + 1]
            };
            let w = &self.words[l];
            let mut kids = [T::default(); 8];
            let values = self.starts[l]
                .iter()
                .map(|&(s, first)| {
                    let mask = w[s as usize] as u8;
                    let (f, n) = (first as usize, mask.count_ones() as usize);
                    for (v, &c) in kids.iter_mut().zip(&self.kids[l][f..f + n]) {
                        *v = below[c as usize];
                    }
                    node(l, mask, &kids[..n])
                })
                .collect();
            levels[l] = values;
        }
        (levels, bricks)
    }

    /// The leaves and nodes of the tree the graph stands for.
    pub(crate) fn tree_size(&self) -> TreeSize {
        let (levels, bricks) = self.bottom_up(
            |b| {
                (
                    u64::from(b.count_ones()),
                    1 + u64::from(brick_mask(b).count_ones()),
                )
            },
            |_, _, kids| {
                kids.iter().fold((0u64, 1u64), |(a, b), &(x, y)| {
                    (a.saturating_add(x), b.saturating_add(y))
                })
            },
        );
        let root = levels.first().map_or(bricks.first(), |l| l.first());
        let (leaves, nodes) = root.copied().unwrap_or((0, 1));
        TreeSize { leaves, nodes }
    }

    /// For each level above the bricks, for each child reference of its nodes in order: the
    /// nodes of the tree on level `values` (`depth`: the leaves) below the node's earlier
    /// children (what a walk adds to the index of the values it finds when it enters that
    /// child), and the tree's nodes on that level. A node below level `values` counts none:
    /// its leaves take its ancestor's values.
    #[cfg(feature = "trace")]
    pub(crate) fn values_before(&self, values: u8) -> (Vec<Vec<u64>>, u64) {
        let depth = self.depth;
        let mut before = vec![Vec::new(); usize::from(depth) - 2];
        let (levels, bricks) = self.bottom_up(
            |b| match depth - values.min(depth) {
                0 => u64::from(b.count_ones()),
                1 => u64::from(brick_mask(b).count_ones()),
                2 => 1,
                _ => 0,
            },
            |l, _, kids| {
                let mut sum = 0u64;
                for &k in kids {
                    before[l].push(sum);
                    sum = sum.saturating_add(k);
                }
                match l.cmp(&usize::from(values)) {
                    std::cmp::Ordering::Less => sum,
                    std::cmp::Ordering::Equal => 1,
                    std::cmp::Ordering::Greater => 0,
                }
            },
        );
        let root = levels.first().map_or(bricks.first(), |l| l.first());
        (before, root.copied().unwrap_or(0))
    }

    /// The codes of the boxes of the nodes' leaves (`crate::octree::bounds`), which the tree
    /// keeps in its nodes' spare bits: per level above the bricks one per node, and one per
    /// brick. A subtree's code depends on its shape alone, so a graph's node has its tree
    /// nodes' code.
    #[cfg(feature = "trace")]
    pub(crate) fn box_codes(&self) -> (Vec<Vec<u32>>, Vec<u32>) {
        use crate::octree::bounds::{combine_codes, leaf_parent_code};
        let depth = u32::from(self.depth);
        self.bottom_up(
            |b| {
                let parents = b.to_le_bytes().into_iter().filter(|&x| x != 0);
                combine_codes(brick_mask(b), parents.map(leaf_parent_code), 2)
            },
            |l, mask, kids| combine_codes(mask, kids.iter().copied(), depth - l as u32),
        )
    }

    /// The graph's depth.
    #[cfg(feature = "trace")]
    pub(crate) fn depth(&self) -> u8 {
        self.depth
    }

    /// Node `k` of level `l` (above the bricks): its mask word's index and its first child's
    /// index in [`Self::kids_of`].
    #[inline]
    #[cfg(feature = "trace")]
    pub(crate) fn start_of(&self, l: usize, k: u32) -> (u32, u32) {
        self.starts[l][k as usize]
    }

    /// The mask of node `k` of level `l` (above the bricks).
    #[inline]
    #[cfg(feature = "trace")]
    pub(crate) fn mask_of(&self, l: usize, k: u32) -> u8 {
        self.words[l][self.starts[l][k as usize].0 as usize] as u8
    }

    /// The children of level `l`'s nodes, one after another, as indices on the level below.
    #[inline]
    #[cfg(feature = "trace")]
    pub(crate) fn kids_of(&self, l: usize) -> &[u32] {
        &self.kids[l]
    }

    /// Brick `b`.
    #[inline]
    #[cfg(feature = "trace")]
    pub(crate) fn brick(&self, b: u32) -> u64 {
        self.bricks[b as usize]
    }

    /// The canonical node array of the tree the graph stands for.
    pub(crate) fn to_nodes(&self) -> Vec<Node> {
        canonical_nodes(self)
    }

    /// The canonical node array of the tree's top `levels` levels (its nodes on level
    /// `levels - 1` as leaf parents).
    pub(crate) fn to_nodes_to(&self, levels: usize) -> Vec<Node> {
        canonical_nodes_to(self, levels)
    }
}

/// The words (each node's mask word, then its children's indices) of node level `l`'s block:
/// its `count` nodes read one after another, references of [`ref_bits`]`(below)` bits. A
/// mask 0 below the root fails check 15, a node past the block's end check 16, and bits left
/// after the last node (8 or more, or any set) check 14.
fn decode_level(l: usize, block: &[u8], count: u64, below: u64) -> Result<Vec<u32>, Failure> {
    let width = ref_bits(below);
    let mut bits = BitReader {
        bytes: block,
        bit: 0,
    };
    // At most 9 words a node, and a node takes at least a byte (check 12 bounds the count).
    let mut words = Vec::with_capacity(block.len().min(count as usize) * 2);
    for k in 0..count {
        let past = || {
            Err((
                Check::NodeOrder,
                format!("level {l}, node {k}: the node runs past the level's block"),
            ))
        };
        let Some(mask) = bits.take(8) else {
            return past();
        };
        if mask == 0 && !(l == 0 && k == 0) {
            return Err((
                Check::TreeShape,
                format!("level {l}, node {k}: a node without children"),
            ));
        }
        words.push(mask);
        for _ in 0..mask.count_ones() {
            let Some(c) = bits.take(width) else {
                return past();
            };
            words.push(c);
        }
    }
    let left = 8 * block.len() as u64 - bits.bit;
    if left >= 8 || bits.take(left as u32).is_some_and(|v| v != 0) {
        return Err((
            Check::NodeWords,
            format!(
                "level {l}: {left} bits after the last node, which must be fewer than 8 and zero"
            ),
        ));
    }
    Ok(words)
}

/// A node of [`DagLevels`]: one above the bricks (level, index), a brick, or a leaf parent
/// (its mask, a byte of a brick).
#[derive(Clone, Copy, Debug)]
pub(crate) enum DagRef {
    Node(usize, u32),
    Brick(u32),
    LeafParent(u8),
}

impl Graph for DagLevels {
    type Ref = DagRef;

    fn root(&self) -> DagRef {
        if self.depth == 2 {
            DagRef::Brick(0)
        } else {
            DagRef::Node(0, 0)
        }
    }

    fn mask(&self, r: DagRef) -> u8 {
        match r {
            DagRef::Node(l, k) => self.words[l][self.starts[l][k as usize].0 as usize] as u8,
            DagRef::Brick(b) => brick_mask(self.bricks[b as usize]),
            DagRef::LeafParent(m) => m,
        }
    }

    fn is_leaf_parent(&self, r: DagRef) -> bool {
        matches!(r, DagRef::LeafParent(_))
    }

    fn children(&self, r: DagRef, out: &mut Vec<DagRef>) {
        let top = usize::from(self.depth) - 2;
        match r {
            DagRef::Node(l, k) => {
                let (s, first) = self.starts[l][k as usize];
                let n = self.words[l][s as usize].count_ones() as usize;
                let f = first as usize;
                out.extend(self.kids[l][f..f + n].iter().map(|&c| {
                    if l + 1 == top {
                        DagRef::Brick(c)
                    } else {
                        DagRef::Node(l + 1, c)
                    }
                }));
            }
            DagRef::Brick(b) => {
                let bytes = self.bricks[b as usize].to_le_bytes();
                out.extend(
                    bytes
                        .iter()
                        .filter(|&&x| x != 0)
                        .map(|&x| DagRef::LeafParent(x)),
                );
            }
            DagRef::LeafParent(_) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dag::plain;
    use crate::octree::tree::Octree;
    use crate::octree::{RootCube, Voxel};
    use glam::{DVec3, UVec3};

    fn tree(depth: u8, cells: impl IntoIterator<Item = UVec3>) -> Octree {
        let root = RootCube {
            origin: DVec3::ZERO,
            side: 1.0,
        };
        Octree::from_cells(root, depth, cells.into_iter().map(|c| (c, Voxel::glass()))).unwrap()
    }

    /// Parses blocks as a reader does.
    fn parse(blocks: &[Vec<u8>], counts: &[u64], depth: u8) -> Result<DagLevels, Failure> {
        let arrays: Vec<&[u8]> = blocks.iter().map(Vec::as_slice).collect();
        DagLevels::from_blocks(depth, &arrays, counts)
    }

    /// For seeded random trees of depths 2 to 8 (empty, one cell, sparse and dense), the
    /// blocks parse back (checks 14 to 16 hold) into the same graph, which stands for the
    /// tree: its node array, leaves and node count.
    #[test]
    fn a_graphs_blocks_give_its_tree_back() {
        let mut rnd = svo_tests::seeds::xorshift(0xb21c);
        for case in 0..120u32 {
            let depth = 2 + (case % 7) as u8;
            let side = 1u32 << depth;
            let n = match case % 12 {
                0 => 0,
                1 => 1,
                2 => 5000,
                _ => 1 + rnd() % 400,
            };
            let t = tree(
                depth,
                (0..n).map(|_| UVec3::new(rnd() as u32, rnd() as u32, rnd() as u32) % side),
            );
            let dag = DagLevels::of(&Dag::from_tree(&t));
            let back = parse(&dag.blocks(), &dag.counts(), depth).unwrap();
            assert_eq!(back, dag, "case {case}");
            assert_eq!(back.to_nodes(), plain(&t.nodes), "case {case}");
            assert_eq!(
                back.tree_size(),
                TreeSize {
                    leaves: u64::from(t.leaf_count),
                    nodes: t.nodes.len() as u64
                },
                "case {case}"
            );
        }
    }

    /// Each rule of the levels, broken on its own in a depth-5 graph, fails at its check:
    /// bits left after a level's last node (14), a node or brick without children (15), a
    /// node past its block, a reference past the next level, children out of first-reference
    /// order, a node twice, a node nobody refers to and counts the table does not give (16).
    #[test]
    fn every_rule_of_the_levels_is_checked() {
        let mut rnd = svo_tests::seeds::xorshift(0x5ca1e);
        let cells = (0..300).map(|_| UVec3::new(rnd() as u32, rnd() as u32, rnd() as u32) % 32);
        let t = tree(5, cells);
        let dag = DagLevels::of(&Dag::from_tree(&t));
        let (blocks, counts) = (dag.blocks(), dag.counts());
        assert!(counts[1] >= 2 && counts[3] >= 3, "{counts:?}");
        assert!(parse(&blocks, &counts, 5).is_ok());
        // The field of `width` bits at bit `at` of level `l`'s block.
        let get = |b: &[Vec<u8>], l: usize, at: u64, width: u32| {
            (0..u64::from(width)).fold(0u32, |v, i| {
                let x = at + i;
                v | u32::from(b[l][(x / 8) as usize] >> (x % 8) & 1) << i
            })
        };
        let set = |b: &mut [Vec<u8>], l: usize, at: u64, width: u32, v: u32| {
            for i in 0..u64::from(width) {
                let x = at + i;
                let byte = &mut b[l][(x / 8) as usize];
                *byte = *byte & !(1 << (x % 8)) | ((v >> i & 1) as u8) << (x % 8);
            }
        };
        let w0 = ref_bits(counts[1]);
        let root_ref = |j: u64| 8 + j * u64::from(w0);
        let check = |b: &[Vec<u8>], c: &[u64]| parse(b, c, 5).err().map(|e| e.0);
        // 14: a byte more after level 0's node.
        let mut b = blocks.clone();
        b[0].push(0);
        assert_eq!(check(&b, &counts), Some(Check::NodeWords));
        // 15: a node of level 1 without children; a brick without leaves.
        let mut b = blocks.clone();
        set(&mut b, 1, 0, 8, 0);
        assert_eq!(check(&b, &counts), Some(Check::TreeShape));
        let mut b = blocks.clone();
        b[3][8..16].fill(0);
        assert_eq!(check(&b, &counts), Some(Check::TreeShape));
        // 16: level 1's last node cut short; a reference past the next level's nodes where the
        // width holds one.
        let mut b = blocks.clone();
        b[1].pop();
        assert_eq!(check(&b, &counts), Some(Check::NodeOrder));
        let l = (0..3)
            .find(|&l| 1u64 << ref_bits(counts[l + 1]) > counts[l + 1])
            .unwrap();
        let mut b = blocks.clone();
        set(&mut b, l, 8, ref_bits(counts[l + 1]), counts[l + 1] as u32);
        assert_eq!(check(&b, &counts), Some(Check::NodeOrder));
        // 16: the root's first two children swapped (the second is first referred to later).
        let (a, c) = (
            get(&blocks, 0, root_ref(0), w0),
            get(&blocks, 0, root_ref(1), w0),
        );
        assert_ne!(a, c);
        let mut b = blocks.clone();
        set(&mut b, 0, root_ref(0), w0, c);
        set(&mut b, 0, root_ref(1), w0, a);
        assert_eq!(check(&b, &counts), Some(Check::NodeOrder));
        // 16: two equal bricks; a brick nobody refers to; a count the table does not give (on a
        // level whose count is no power of two, so the references above keep their width).
        let mut b = blocks.clone();
        let first = b[3][..8].to_vec();
        b[3][8..16].copy_from_slice(&first);
        assert_eq!(check(&b, &counts), Some(Check::NodeOrder));
        let mut b = blocks.clone();
        b[3].extend_from_slice(&u64::MAX.to_le_bytes());
        assert_eq!(check(&b, &counts), Some(Check::NodeOrder));
        let l = (1..=3).find(|&l| !counts[l].is_power_of_two()).unwrap();
        let mut c = counts.clone();
        c[l] += 1;
        assert_eq!(check(&blocks, &c), Some(Check::NodeOrder));
        // 16: an empty root above nodes.
        let mut b = blocks.clone();
        b[0] = vec![0];
        assert_eq!(check(&b, &counts), Some(Check::NodeOrder));
    }

    /// A reference takes the fewest bits that hold every index of the level below, at least
    /// one; the blocks are that long.
    #[test]
    fn references_take_the_bits_the_level_below_needs() {
        assert_eq!(
            [0, 1, 2, 3, 4, 5, 256, 257, 1 << 32].map(ref_bits),
            [1, 1, 1, 2, 2, 3, 8, 9, 32]
        );
        let t = tree(
            4,
            (0..64u32).map(|i| UVec3::new(i % 4, i / 4 % 4, i / 16) * 4),
        );
        let dag = DagLevels::of(&Dag::from_tree(&t));
        // One node a level: the root's 8 references of 1 bit, then the level-1 node's.
        assert_eq!(dag.counts(), vec![1, 1, 1]);
        assert_eq!(dag.blocks()[..2], [vec![0xFF, 0], vec![0xFF, 0]]);
        assert_eq!(max_block_len(1, 1), Some(2));
    }
}
