//! A graph's arrays as plain words ([`FlatDag`]), for a walk outside the library that indexes
//! them with integer arithmetic alone: the viewer's WGSL port of the walk uploads them as
//! they are.

use super::levels::brick_mask;
use super::walk::DagTree;
use crate::octree::bounds::leaf_parent_code;

/// A [`DagTree`]'s graph in words: what [`DagTree::traverse`] reads, laid out so that a walk
/// finds a node's children, their boxes of leaves and the leaves before them by indexing
/// alone. Levels above the bricks are numbered `0 .. depth - 2` (the root's is 0), the bricks'
/// is `depth - 2`.
///
/// A walk at a node of level `l` enters its child `real` (a child index, `docs/format.md`
/// section 4) of rank `r` (the existing children before it) through reference `first + r`:
/// on levels below `depth - 3` the child is the node record the reference names, on level
/// `depth - 3` the brick; the child's first leaf is the node's plus the reference's leaves
/// before. A brick's child `real` is the leaf parent of mask `(brick >> 8 * real) & 0xFF`,
/// whose first leaf is the brick's plus the brick's set bits below bit `8 * real`, and whose
/// box code is `leaf_parent_boxes[mask]`; its leaf of rank `r` is its first leaf plus `r`.
/// Leaf indices add with wrapping (a tree past 2^32 leaves has no per-leaf arrays to index).
///
/// Where the leaves take their values from a level above ([`DagTree::values_level`]), the
/// indices count that level's nodes instead of leaves (`values`): the references' counts are
/// of them, and inside a brick a leaf parent's first index adds the nonzero bytes below its
/// own (`values` 1: the leaf parents hold the values) or nothing (2: a level above the
/// bricks' children), and a leaf's index is its leaf parent's.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FlatDag {
    /// The levels above the bricks' nodes, level after level from the root, two words a
    /// node: its child mask in bits 0-7 and the code of the box of its leaves in bits 8-31
    /// (as in a tree node's `info` word in memory), then the index of its first child's
    /// reference in `refs` (in references, not words). Empty for a tree of depth 2.
    pub nodes: Vec<u32>,
    /// Two words a child reference, the nodes' references one after another: the child (the
    /// index of its record in `nodes`, counted in records over all levels; on level `depth -
    /// 3`, the brick's index), then the leaves below the node's earlier children.
    pub refs: Vec<u32>,
    /// Three words a brick: its bits 0-31, its bits 32-63, then its child mask (its nonzero
    /// bytes) in bits 0-7 and the code of the box of its leaves in bits 8-31.
    pub bricks: Vec<u32>,
    /// The code of the box of a leaf parent's leaves, by its child mask (256 entries).
    pub leaf_parent_boxes: Vec<u32>,
    /// Which nodes the indices count: 0 the leaves, 1 the leaf parents, 2 nodes of a level
    /// above them.
    pub values: u32,
}

impl FlatDag {
    /// Words in all four arrays.
    pub fn words(&self) -> usize {
        self.nodes.len() + self.refs.len() + self.bricks.len() + self.leaf_parent_boxes.len()
    }
}

impl DagTree {
    /// The words [`Self::flat`] makes ([`FlatDag::words`]), counted without making them.
    pub fn flat_words(&self) -> u64 {
        // The distinct nodes of each level, the bricks last.
        let counts = self.graph.counts();
        let (bricks, levels) = counts.split_last().unwrap_or((&0, &[]));
        let refs: u64 = (0..levels.len())
            .map(|l| self.graph.kids_of(l).len() as u64)
            .sum();
        2 * levels.iter().sum::<u64>() + 2 * refs + 3 * bricks + 256
    }

    /// The graph as [`FlatDag`]'s words.
    pub fn flat(&self) -> FlatDag {
        let counts = self.graph.counts();
        let (&brick_count, level_counts) = counts.split_last().unwrap_or((&0, &[]));
        let levels = level_counts.len();
        // Each level's first record over all levels.
        let mut base = Vec::with_capacity(levels);
        let mut total = 0u32;
        for &n in level_counts {
            base.push(total);
            total += n as u32;
        }
        let refs_len: usize = (0..levels).map(|l| self.graph.kids_of(l).len()).sum();
        let mut nodes = Vec::with_capacity(2 * total as usize);
        let mut refs = Vec::with_capacity(2 * refs_len);
        let mut slot = 0u32;
        for l in 0..levels {
            let kids = self.graph.kids_of(l);
            for k in 0..level_counts[l] as u32 {
                let (_, first) = self.graph.start_of(l, k);
                nodes.push(u32::from(self.graph.mask_of(l, k)) | self.boxes[l][k as usize] << 8);
                nodes.push(slot + first);
            }
            // The next level's records are numbered after this level's (none for the bricks).
            let next = if l + 1 < levels { base[l + 1] } else { 0 };
            for (at, &kid) in kids.iter().enumerate() {
                refs.push(next + kid);
                refs.push(self.before[l][at]);
            }
            slot += kids.len() as u32;
        }
        let bricks = (0..brick_count as u32)
            .flat_map(|b| {
                let v = self.graph.brick(b);
                [
                    v as u32,
                    (v >> 32) as u32,
                    u32::from(brick_mask(v)) | self.brick_boxes[b as usize] << 8,
                ]
            })
            .collect();
        let leaf_parent_boxes = (0..=255u8).map(leaf_parent_code).collect();
        FlatDag {
            nodes,
            refs,
            bricks,
            leaf_parent_boxes,
            values: u32::from((self.depth() - self.values_level()).min(2)),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::dag::DagTree;
    use crate::octree::{RootCube, Voxel};
    use crate::trace::{GridRay, MAX_STEPS};
    use crate::{Octree, trace};
    use glam::{DVec3, UVec3, Vec3};

    /// A walk written from [`super::FlatDag`]'s documentation alone, over its words: for every
    /// ray of a seeded set, the leaves it enters (without the boxes' shortcut, every existing
    /// child in the ray's order) are the tree's, with the same indices.
    #[test]
    fn the_flat_words_lead_a_walk_to_the_trees_leaves() {
        for depth in [2u8, 3, 5] {
            let mut rnd = svo_tests::seeds::xorshift(0x5eed ^ u64::from(depth));
            let tree = crate::octree::scattered_tree(&mut rnd, depth, 300);
            let dag = DagTree::from_tree(&tree).unwrap();
            let f = dag.flat();
            // Every leaf's cell and index, walking all children depth first.
            let mut got = Vec::new();
            walk_all(&f, depth, &mut got);
            let want: Vec<(u32, UVec3)> = tree
                .leaves()
                .enumerate()
                .map(|(i, l)| (i as u32, l.cell))
                .collect();
            got.sort_by_key(|&(i, _)| i);
            assert_eq!(got, want, "depth {depth}");
            assert_eq!(f.words() as u64, dag.flat_words());
            // The boxes: the root's mask and box code are its tree node's info word.
            let root_info = if depth == 2 { f.bricks[2] } else { f.nodes[0] };
            assert_eq!(root_info, tree.nodes[0].info, "depth {depth}");
            let ray = GridRay {
                origin: Vec3::new(-1.0, 0.5, 0.5),
                dir: Vec3::new(1.0, 0.3, 0.2).normalize(),
            };
            let a = dag.traverse(&ray, 0.0, f32::INFINITY, MAX_STEPS, |e| Some(e.leaf));
            let b = trace::traverse(&tree, &ray, 0.0, f32::INFINITY, MAX_STEPS, |e| Some(e.leaf));
            assert_eq!((a.hit, a.steps), (b.hit, b.steps));
        }
        // Depth 2: the root is brick 0, and no node records.
        let root = RootCube {
            origin: DVec3::ZERO,
            side: 1.0,
        };
        let cells = [UVec3::new(0, 0, 0), UVec3::new(3, 3, 3)];
        let tree = Octree::from_cells(root, 2, cells.map(|c| (c, Voxel::glass()))).unwrap();
        let f = DagTree::from_tree(&tree).unwrap().flat();
        assert!(f.nodes.is_empty() && f.refs.is_empty());
        assert_eq!(f.bricks.len(), 3);
        assert_eq!(f.leaf_parent_boxes.len(), 256);
        assert_eq!(f.words(), 3 + 256);
    }

    /// Every leaf under the root of `f`, with its cell.
    fn walk_all(f: &super::FlatDag, depth: u8, out: &mut Vec<(u32, UVec3)>) {
        let bricks_level = usize::from(depth) - 2;
        // (level, record or brick, first leaf, corner)
        let mut stack = vec![(0usize, 0u32, 0u32, UVec3::ZERO)];
        while let Some((l, k, base, corner)) = stack.pop() {
            let half = 1u32 << (usize::from(depth) - l - 1);
            let offset = |real: u32| UVec3::new(real >> 2 & 1, real >> 1 & 1, real & 1) * half;
            if l == bricks_level {
                let at = 3 * k as usize;
                let b = u64::from(f.bricks[at]) | u64::from(f.bricks[at + 1]) << 32;
                for real in 0..8u32 {
                    let mask = (b >> (8 * real)) as u8;
                    let below = (b & ((1u64 << (8 * real)) - 1)).count_ones();
                    let leaves = (0..8u32).filter(|c| mask >> c & 1 == 1);
                    for (n, leaf) in (0u32..).zip(leaves) {
                        let cell = corner
                            + offset(real)
                            + UVec3::new(leaf >> 2 & 1, leaf >> 1 & 1, leaf & 1);
                        out.push((base.wrapping_add(below + n), cell));
                    }
                }
                continue;
            }
            let (info, first) = (f.nodes[2 * k as usize], f.nodes[2 * k as usize + 1]);
            let kids = (0..8u32).filter(|c| info >> c & 1 == 1);
            for (rank, real) in (0u32..).zip(kids) {
                let r = 2 * (first + rank) as usize;
                stack.push((
                    l + 1,
                    f.refs[r],
                    base.wrapping_add(f.refs[r + 1]),
                    corner + offset(real),
                ));
            }
        }
    }
}
