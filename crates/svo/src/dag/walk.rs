//! Rays through a graph: [`DagTree`], a tree's geometry with identical subtrees stored once,
//! walked as the tree is ([`crate::trace::traverse`]'s walk, over the graph's nodes), each leaf
//! found with its index in the tree's Morton order from the leaves below the children the walk
//! passes.

use super::build::Dag;
use super::levels::{DagLevels, brick_mask};
use super::values::DagValues;
use crate::octree::RootCube;
use crate::octree::bounds::leaf_parent_code;
use crate::octree::tree::{LeafAttributes, Octree};
use crate::octree::validate::MAX_LEAVES;
use crate::trace::GridRay;
use crate::trace::cone::Cone;
use crate::trace::traverse::{LeafEntry, Traversal, WalkNodes, traverse_from};
use glam::{DVec3, UVec3};
use std::collections::BinaryHeap;
use thiserror::Error;

/// Why a [`DagTree`] cannot be made.
#[derive(Debug, Error, PartialEq, Eq)]
#[non_exhaustive]
pub enum DagError {
    /// A tree of depth 1: a graph's lowest nodes are 4x4x4 bricks, two levels.
    #[error("a DAG needs a tree of depth 2 or more (its lowest nodes are 4x4x4 bricks)")]
    TooShallow,
    /// The values cannot be kept as asked.
    #[error(transparent)]
    Values(#[from] super::values::ValuesError),
    /// More leaves than a leaf index holds, with channels stored per leaf (which the index
    /// reads).
    #[error("{0} leaves with channels stored per leaf: more than 2^31, which a leaf index holds")]
    TooManyLeaves(u64),
}

/// A tree's geometry as a graph of its distinct subtrees (the file form of `docs/format.md`,
/// section 12, with what a walk derives: each node's children as indices and the leaves
/// before each child), and the tree's root cube: rays walk it as they walk the tree and meet
/// the same leaves, with the same indices into the tree's leaf arrays. A graph whose tree has
/// more than 2^31 leaves has no leaf arrays (its channels are constants; a per-leaf array is
/// refused): its leaves' indices are their Morton index modulo 2^32, which nothing reads.
///
/// ```
/// use glam::{DVec3, UVec3, Vec3};
/// use svo::dag::DagTree;
/// use svo::trace::{GridRay, MAX_STEPS, traverse};
/// use svo::{Octree, RootCube, Voxel};
/// let root = RootCube { origin: DVec3::ZERO, side: 1.0 };
/// let cells = [UVec3::new(1, 2, 3), UVec3::new(5, 2, 3), UVec3::new(6, 6, 6)];
/// let tree = Octree::from_cells(root, 3, cells.map(|c| (c, Voxel::glass())))?;
/// let dag = DagTree::from_tree(&tree)?;
/// let ray = GridRay { origin: Vec3::new(-1.0, 2.5, 3.5), dir: Vec3::X };
/// let leaves = |t: &svo::trace::Traversal<u32>| t.hit;
/// let on_dag = dag.traverse(&ray, 0.0, f32::INFINITY, MAX_STEPS, |e| Some(e.leaf));
/// let on_tree = traverse(&tree, &ray, 0.0, f32::INFINITY, MAX_STEPS, |e| Some(e.leaf));
/// assert_eq!(leaves(&on_dag), leaves(&on_tree)); // leaf 0, the cell (1, 2, 3)
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct DagTree {
    root: RootCube,
    pub(super) graph: DagLevels,
    /// Per level above the bricks, per child reference: the values below the earlier children
    /// (the leaves', or the nodes' of level `values`).
    pub(super) before: Vec<Vec<u32>>,
    leaf_count: u64,
    /// The level whose nodes hold the leaves' values (`depth`: each leaf its own).
    values: u8,
    /// The leaves' channels, in Morton order.
    pub(crate) attributes: LeafAttributes,
    /// The codes of the boxes of the nodes' leaves: per level above the bricks, and per brick.
    pub(super) boxes: Vec<Vec<u32>>,
    pub(super) brick_boxes: Vec<u32>,
}

impl DagTree {
    /// The graph of `tree`'s geometry, with a copy of its leaves' channels (its inner nodes'
    /// are not kept: shared subtrees hold no values of their own).
    pub fn from_tree(tree: &Octree) -> Result<Self, DagError> {
        Self::from_tree_with(tree, &DagValues::default())
    }

    /// The graph of `tree`'s geometry with its leaves' values kept as `values` says: each
    /// leaf's own, or its ancestor's on a level above (the tree's inner-node attributes,
    /// [`crate::BakeOptions::node_attributes`]; a walk then finds that ancestor's index among
    /// its level's nodes as a leaf's index, and the channels hold one value for each of them),
    /// with normals in fewer bits where asked.
    ///
    /// ```
    /// use svo::dag::{DagTree, DagValues};
    /// use svo::{BakeOptions, Mesh, bake_mesh};
    /// let sphere = Mesh::sphere(glam::DVec3::splat(0.5), 0.4, 24);
    /// let opts = BakeOptions { depth: 6, node_attributes: true, ..Default::default() };
    /// let mut tree = bake_mesh(&sphere, &opts)?.0;
    /// tree.attributes.contour = svo::octree::Channel::Absent;
    /// let coarse = DagValues { level: Some(4), normal_bits: 16, colour_bits: 4 };
    /// let dag = DagTree::from_tree_with(&tree, &coarse)?;
    /// assert_eq!(dag.values_level(), 4);
    /// // One normal for each node of level 4, far fewer than the leaves.
    /// let normals = match &dag.attributes().normal {
    ///     svo::octree::Channel::PerLeaf(v) => v.len() as u64,
    ///     _ => 0,
    /// };
    /// assert!(normals > 0 && 8 * normals < dag.leaf_count());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn from_tree_with(tree: &Octree, values: &DagValues) -> Result<Self, DagError> {
        if tree.depth < 2 {
            return Err(DagError::TooShallow);
        }
        let attributes = values.of(tree)?;
        let graph = DagLevels::of(&Dag::from_tree(tree));
        let per_value = attributes.per_leaf_bytes() > 0;
        let level = values.level_for(tree.depth);
        let leaves = u64::from(tree.leaf_count);
        let mut dag = Self::from_levels(tree.root, graph, leaves, level, per_value)?;
        dag.attributes = attributes;
        Ok(dag)
    }

    /// The walkable form of a graph that passed the reader's checks, whose tree has `leaves`
    /// leaves, each taking its values from its ancestor on level `values` (1 to the depth,
    /// which is each leaf its own): a walk's index of a leaf is that ancestor's index among
    /// its level's nodes, in Morton order. `per_value`: the channels will include an array,
    /// which refuses more than 2^31 such nodes.
    pub(crate) fn from_levels(
        root: RootCube,
        graph: DagLevels,
        leaves: u64,
        values: u8,
        per_value: bool,
    ) -> Result<Self, DagError> {
        let (before, count) = graph.values_before(values);
        if count > MAX_LEAVES && per_value {
            return Err(DagError::TooManyLeaves(count));
        }
        // Within 2^31 values every partial sum fits; past them, an index is the Morton index
        // modulo 2^32 (the walk adds with wrapping), which no array is read by.
        let before = before
            .into_iter()
            .map(|l| l.into_iter().map(|x| x as u32).collect())
            .collect();
        let (boxes, brick_boxes) = graph.box_codes();
        Ok(Self {
            root,
            graph,
            before,
            leaf_count: leaves,
            values,
            attributes: LeafAttributes::default(),
            boxes,
            brick_boxes,
        })
    }

    /// The root cube.
    pub fn root(&self) -> RootCube {
        self.root
    }

    /// Levels below the root.
    pub fn depth(&self) -> u8 {
        self.graph.depth()
    }

    /// The tree's leaves.
    pub fn leaf_count(&self) -> u64 {
        self.leaf_count
    }

    /// The level whose nodes hold the leaves' values: the depth where each leaf has its own
    /// (a walk's leaf index is then the leaf's), or a level above, whose nodes' values their
    /// leaves take (a walk's leaf index is then the ancestor's on that level, and the channels
    /// hold one value for each node of that level).
    pub fn values_level(&self) -> u8 {
        self.values
    }

    /// The leaves' channels, in the tree's Morton order (what [`crate::io::read_dag_file`]
    /// read, or the tree's that [`Self::from_tree`] copied).
    pub fn attributes(&self) -> &LeafAttributes {
        &self.attributes
    }

    /// The least and greatest cells of the leaves on each axis (`None` for a tree without
    /// leaves): what [`Octree::occupied_cells`] gives for the tree, found by a best-first
    /// descent of the graph per axis and side.
    pub fn occupied_cells(&self) -> Option<(UVec3, UVec3)> {
        let (mut lo, mut hi) = (UVec3::ZERO, UVec3::ZERO);
        for axis in 0..3 {
            lo[axis] = self.extreme_cell(axis, false)?;
            hi[axis] = self.extreme_cell(axis, true)?;
        }
        Some((lo, hi))
    }

    /// [`Self::occupied_cells`] in scene units: the box of the leaves' cells, the root cube
    /// for a tree without leaves.
    pub fn occupied_bounds(&self) -> (DVec3, DVec3) {
        let Some((lo, hi)) = self.occupied_cells() else {
            return (self.root.origin, self.root.origin + self.root.side);
        };
        let at = |c: DVec3| self.root.to_scene(c, self.depth());
        (at(lo.as_dvec3()), at(hi.as_dvec3() + DVec3::ONE))
    }

    /// The least (or, with `max`, the greatest) coordinate on `axis` of a leaf's cell.
    fn extreme_cell(&self, axis: usize, max: bool) -> Option<u32> {
        // How far a cube reaches toward the side sought, larger is further.
        let reach = |origin: UVec3, side: u32| {
            if max {
                origin[axis] + (side - 1)
            } else {
                u32::MAX - origin[axis]
            }
        };
        // A max-heap of (reach, side's complement, node in `nodes`, minimum cell): the
        // furthest first and, among equals, the smallest; a side of 0 is a leaf.
        let mut nodes = vec![WalkNodes::root(self)?];
        let mut heap = BinaryHeap::new();
        let n = 1u32 << self.depth();
        heap.push((reach(UVec3::ZERO, n), u32::MAX - n, 0usize, [0u32; 3]));
        while let Some((_, inv, k, origin)) = heap.pop() {
            let (side, origin) = (u32::MAX - inv, UVec3::from_array(origin));
            if side == 0 {
                return Some(origin[axis]);
            }
            let node = nodes[k];
            let half = side / 2;
            let mask = Self::mask(node);
            for real in (0..8u8).filter(|c| mask >> c & 1 == 1) {
                let offset = UVec3::new(
                    u32::from(real >> 2 & 1),
                    u32::from(real >> 1 & 1),
                    u32::from(real & 1),
                ) * half;
                let at = origin + offset;
                if Self::is_leaf_parent(node) {
                    heap.push((reach(at, 1), u32::MAX, 0, at.to_array()));
                    continue;
                }
                let rank = (mask & ((1u8 << real) - 1)).count_ones();
                let child = self.child(node, real, rank)?;
                nodes.push(child);
                heap.push((
                    reach(at, half),
                    u32::MAX - half,
                    nodes.len() - 1,
                    at.to_array(),
                ));
            }
        }
        None
    }

    /// Distinct nodes on each level, the root's first, the bricks last (`depth - 1` levels).
    pub fn level_counts(&self) -> Vec<u64> {
        self.graph.counts()
    }

    /// [`crate::trace::traverse`] on the graph: the same leaves, front to back, with the same
    /// entries (indices into the tree's leaf arrays, cells, parameters and normals) and the
    /// same steps as on the tree (each distinct node keeps the box of its leaves, as the tree's
    /// nodes do).
    pub fn traverse<T>(
        &self,
        ray: &GridRay,
        tmin: f32,
        tmax: f32,
        max_steps: u32,
        on_leaf: impl FnMut(&LeafEntry) -> Option<T>,
    ) -> Traversal<T> {
        let depth = self.depth();
        traverse_from(
            self,
            depth,
            ray,
            None,
            Cone::EXACT,
            tmin,
            tmax,
            max_steps,
            on_leaf,
        )
        .unwrap_or_else(Traversal::missed)
    }
}

/// A node of the graph as the walk holds it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DagNode {
    /// 0: a node above the bricks; 1: a brick; 2: a leaf parent (a byte of a brick).
    kind: u8,
    mask: u8,
    /// A node's level (above the bricks).
    level: u8,
    /// A node's index on its level, or a brick's (also a leaf parent's brick).
    index: u32,
    /// The index of the node's first leaf in the tree's leaf arrays.
    base: u32,
    /// The code of the box of its leaves.
    boxed: u32,
    /// Which nodes hold the values: 0 the leaves, 1 the leaf parents, 2 nodes above them.
    units: u8,
}

impl DagTree {
    /// Node `k` of level `l`, or brick `k` where `l` is the bricks' level, with first leaf `base`.
    #[inline]
    fn node(&self, l: usize, k: u32, base: u32) -> DagNode {
        let units = (self.depth() - self.values).min(2);
        if l + 2 == usize::from(self.depth()) {
            DagNode {
                kind: 1,
                mask: brick_mask(self.graph.brick(k)),
                level: l as u8,
                index: k,
                base,
                boxed: self.brick_boxes[k as usize],
                units,
            }
        } else {
            DagNode {
                kind: 0,
                mask: self.graph.mask_of(l, k),
                level: l as u8,
                index: k,
                base,
                boxed: self.boxes[l][k as usize],
                units,
            }
        }
    }
}

impl WalkNodes for DagTree {
    type N = DagNode;

    #[inline]
    fn root(&self) -> Option<DagNode> {
        Some(self.node(0, 0, 0))
    }

    #[inline]
    fn mask(n: DagNode) -> u8 {
        n.mask
    }

    #[inline]
    fn leaf_base(n: DagNode) -> Option<u32> {
        (n.kind == 2).then_some(n.base)
    }

    #[inline]
    fn child(&self, n: DagNode, real: u8, rank: u32) -> Option<DagNode> {
        match n.kind {
            0 => {
                let l = usize::from(n.level);
                let (_, first) = self.graph.start_of(l, n.index);
                let at = (first + rank) as usize;
                let k = *self.graph.kids_of(l).get(at)?;
                let base = n.base.wrapping_add(*self.before[l].get(at)?);
                Some(self.node(l + 1, k, base))
            }
            1 => {
                let b = self.graph.brick(n.index);
                let shift = 8 * u32::from(real);
                let below = b & ((1u64 << shift) - 1);
                let mask = (b >> shift) as u8;
                // The values below the earlier leaf parents: their leaves, or themselves.
                let before = match n.units {
                    0 => below.count_ones(),
                    1 => brick_mask(below).count_ones(),
                    _ => 0,
                };
                Some(DagNode {
                    kind: 2,
                    mask,
                    level: n.level + 1,
                    index: n.index,
                    base: n.base.wrapping_add(before),
                    boxed: leaf_parent_code(mask),
                    units: n.units,
                })
            }
            _ => None,
        }
    }

    #[inline]
    fn leaf_of(n: DagNode, base: u32, rank: u32) -> u32 {
        if n.units == 0 {
            base.wrapping_add(rank)
        } else {
            base
        }
    }

    #[inline]
    fn is_leaf_parent(n: DagNode) -> bool {
        n.kind == 2
    }

    #[inline]
    fn leaf_box(n: DagNode) -> u32 {
        n.boxed
    }

    #[inline]
    fn child_index(_n: DagNode, _rank: u32) -> u32 {
        // A graph keeps no inner-node values: its walks have no footprint.
        0
    }

    type Saved = (DagNode, u8, f32);
    const EMPTY: Self::Saved = (
        DagNode {
            kind: 0,
            mask: 0,
            level: 0,
            index: 0,
            base: 0,
            boxed: 0,
            units: 0,
        },
        0,
        0.0,
    );

    #[inline]
    fn save(n: DagNode, next: u8, enter: f32) -> Self::Saved {
        (n, next, enter)
    }

    #[inline]
    fn restore(s: Self::Saved) -> (DagNode, u8, f32) {
        s
    }
}

#[cfg(all(test, feature = "io"))]
mod tests {
    use super::*;
    use crate::dag::DagBuilder;
    use crate::io::BuildInfo;
    use crate::io::write::{Layout, dag_blocks, write_layout};
    use crate::trace::MAX_STEPS;
    use glam::Vec3;

    /// The Morton index of cell `c` in a full grid of `depth` levels.
    fn morton(c: UVec3, depth: u8) -> u64 {
        (0..depth).rev().fold(0u64, |code, l| {
            code << 3
                | u64::from(c.x >> l & 1) << 2
                | u64::from(c.y >> l & 1) << 1
                | u64::from(c.z >> l & 1)
        })
    }

    /// A full grid of 2^12 cells a side (2^36 leaves, one node a level as a graph) as a file:
    /// its tree is refused as too large, its top levels and level sizes read, it is described
    /// from its graph, and its graph
    /// walked, each leaf met with its Morton index modulo 2^32; with a channel stored per leaf
    /// the graph is refused.
    #[test]
    fn a_graph_past_2_31_leaves_opens_coarse_and_is_walked_without_leaf_arrays() {
        let depth = 12u8;
        let dag = dag_full(depth);
        assert_eq!(dag.leaf_count(), 1 << 36);
        let (plan, blocks) = dag_blocks(&dag);
        let layout = Layout {
            root_origin: [0.0; 3],
            root_side: 1.0,
            depth,
            node_count: plan.counts.iter().sum(),
            leaf_count: 1 << 36,
            channels: Vec::new(),
            build: &BuildInfo::new(),
            chunks: None,
            levels: Some(plan),
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("full.svo");
        let mut bytes = Vec::new();
        write_layout(&layout, &mut bytes, &mut |i, out| out.write_all(&blocks[i])).unwrap();
        std::fs::write(&path, &bytes).unwrap();
        assert!(matches!(
            crate::io::read_file(&path),
            Err(crate::io::FormatError::DagTooLarge { .. })
        ));
        let sizes = crate::io::read_level_sizes(&path).unwrap().unwrap();
        let want: Vec<u64> = (0..=depth).map(|l| 8u64.pow(u32::from(l))).collect();
        assert_eq!(sizes.counts, want);
        // `svo-view --info` describes it from the graph.
        let text = crate::io::describe_file(&path).unwrap();
        assert!(text.contains("leaves         68719476736"), "{text}");
        assert!(
            text.contains(&format!("nodes/level    {:?}", &want[..12])),
            "{text}"
        );
        let (top, _) = crate::io::read_file_to_depth(&path, 4).unwrap();
        assert_eq!((top.depth, top.leaf_count), (4, 4096));
        let (dag, _) = crate::io::read_dag_file(&path).unwrap();
        assert_eq!(dag.leaf_count(), 1 << 36);
        let ray = GridRay {
            origin: Vec3::new(-1.0, 3000.5, 2000.5),
            dir: Vec3::X,
        };
        let mut met = Vec::new();
        dag.traverse(&ray, 0.0, f32::INFINITY, MAX_STEPS, |e| {
            met.push((e.leaf, e.cell));
            (met.len() == 3).then_some(())
        });
        let want: Vec<(u32, UVec3)> = (0..3)
            .map(|x| {
                let c = UVec3::new(x, 3000, 2000);
                (morton(c, depth) as u32, c)
            })
            .collect();
        assert_eq!(met, want);
        // A per-leaf channel's index would pass 32 bits: refused.
        let graph = DagLevels::of(&dag_full(depth));
        assert_eq!(
            DagTree::from_levels(dag.root(), graph, 1 << 36, depth, true).unwrap_err(),
            DagError::TooManyLeaves(1 << 36)
        );
    }

    /// With values on a level above the leaves, a walk hands over, as each leaf's index, its
    /// ancestor's index among the nodes of that level in Morton order, on every level (the
    /// leaf parents' and the bricks' included) of random trees; at the depth, the leaf's own.
    #[test]
    fn a_leaf_finds_its_ancestors_values() {
        let mut rnd = svo_tests::seeds::xorshift(0xa11e);
        for depth in [3u8, 5, 6] {
            let tree = crate::octree::scattered_tree(&mut rnd, depth, 400);
            for level in 1..=depth {
                let graph = DagLevels::of(&Dag::from_tree(&tree));
                let leaves = u64::from(tree.leaf_count);
                let dag = DagTree::from_levels(tree.root, graph, leaves, level, false).unwrap();
                assert_eq!(dag.values_level(), level);
                let cells: Vec<UVec3> = tree.leaves().map(|l| l.cell).collect();
                let up = |c: UVec3| c >> u32::from(depth - level);
                let mut ancestors: Vec<u64> = cells.iter().map(|&c| morton(up(c), level)).collect();
                ancestors.sort_unstable();
                ancestors.dedup();
                // Every leaf, met by rays along x through each row of cells.
                let n = 1u32 << depth;
                let mut met = 0;
                for y in 0..n {
                    for z in 0..n {
                        let ray = GridRay {
                            origin: Vec3::new(-1.0, y as f32 + 0.5, z as f32 + 0.5),
                            dir: Vec3::X,
                        };
                        dag.traverse(&ray, 0.0, f32::INFINITY, MAX_STEPS, |e| {
                            let want = ancestors.binary_search(&morton(up(e.cell), level)).unwrap();
                            assert_eq!(
                                e.leaf as usize, want,
                                "depth {depth}, level {level}, {}",
                                e.cell
                            );
                            met += 1;
                            None::<()>
                        });
                    }
                }
                assert_eq!(met, cells.len());
            }
        }
    }

    fn dag_full(depth: u8) -> Dag {
        let mut graph = DagBuilder::new(depth);
        for l in (0..usize::from(depth)).rev() {
            let kids = if l + 1 == usize::from(depth) { 0 } else { 8 };
            graph.node(l, 0xFF, &[0; 8][..kids]);
        }
        graph.finish()
    }
}
