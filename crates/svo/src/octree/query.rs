//! Queries in scene units: the leaf at a point, whether a point lies in a leaf, and the
//! leaves with their cell bounds and decoded attributes.

use crate::octree::builder::OctreeError;
use crate::octree::tree::{LeafValue, Octree};
use glam::{DVec3, UVec3};

/// A leaf with where it is and what it stores, as [`Octree::leaves`] and
/// [`Octree::leaf_at_point`] give it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leaf {
    /// Index into the leaf arrays (the channels of [`Octree::attributes`]).
    pub index: u32,
    /// Integer cell coordinates at the tree's depth (grid space: the root is
    /// `[0, 2^depth]^3`).
    pub cell: UVec3,
    /// The cell's minimum corner, scene units.
    pub min: DVec3,
    /// The cell's maximum corner, scene units.
    pub max: DVec3,
    /// Whether the leaf is an interior cell of a solid bake (it has no surface; renderers
    /// pass through it).
    pub interior: bool,
    /// The stored attributes, decoded (`None` where a channel is absent).
    pub attributes: LeafValue,
}

impl Octree {
    /// The leaf `index` at `cell`, with its bounds and attributes.
    fn leaf(&self, index: u32, cell: UVec3) -> Leaf {
        let (min, max) = self.cell_bounds(cell);
        Leaf {
            index,
            cell,
            min,
            max,
            interior: self.attributes.is_interior(index as usize),
            attributes: self.attributes.get(index as usize),
        }
    }

    /// The leaves depth-first in child-index order (the order of the leaf arrays for trees
    /// that `svo` builds), each with its cell bounds in scene units and its attributes.
    ///
    /// ```
    /// use glam::UVec3;
    /// use svo::{Octree, RootCube, Voxel};
    /// let root = RootCube { origin: glam::DVec3::ZERO, side: 2.0 };
    /// let tree = Octree::from_cells(root, 1, [(UVec3::new(1, 0, 0), Voxel::default())])?;
    /// let leaf = tree.leaves().next().unwrap();
    /// assert_eq!((leaf.min.x, leaf.max.x), (1.0, 2.0));
    /// # Ok::<(), svo::OctreeError>(())
    /// ```
    pub fn leaves(&self) -> impl Iterator<Item = Leaf> + '_ {
        self.leaf_cells().map(|l| self.leaf(l.index, l.cell))
    }

    /// The grid cell that contains the scene point `p`, or `None` outside the (closed) root
    /// cube. Cells are half-open here: a point on a face shared by two cells is in the upper
    /// one, and a point on one of the root cube's upper faces in the cell below that face.
    ///
    /// ```
    /// use glam::{DVec3, UVec3};
    /// use svo::{Octree, RootCube, Voxel};
    /// let root = RootCube { origin: DVec3::ZERO, side: 4.0 };
    /// let tree = Octree::from_cells(root, 2, [(UVec3::new(3, 0, 0), Voxel::default())])?;
    /// assert_eq!(tree.cell_at_point(DVec3::new(1.0, 0.5, 0.5)), Some(UVec3::new(1, 0, 0)));
    /// assert_eq!(tree.cell_at_point(DVec3::new(4.0, 0.5, 0.5)), Some(UVec3::new(3, 0, 0)));
    /// assert!(tree.contains(DVec3::new(4.0, 0.0, 0.0)));
    /// assert_eq!(tree.cell_at_point(DVec3::new(4.0 + 1e-9, 0.5, 0.5)), None);
    /// assert_eq!(tree.cell_at_point(DVec3::new(f64::NAN, 0.5, 0.5)), None);
    /// # Ok::<(), svo::OctreeError>(())
    /// ```
    pub fn cell_at_point(&self, p: DVec3) -> Option<UVec3> {
        let g = self.root.to_grid(p, self.depth);
        let n = (1u64 << self.depth) as f64;
        // NaN fails both comparisons.
        if !(g.cmpge(DVec3::ZERO).all() && g.cmple(DVec3::splat(n)).all()) {
            return None;
        }
        Some(g.floor().min(DVec3::splat(n - 1.0)).as_uvec3())
    }

    /// The leaf whose cell contains the scene point `p`, with its bounds and attributes.
    pub fn leaf_at_point(&self, p: DVec3) -> Option<Leaf> {
        let cell = self.cell_at_point(p)?;
        self.leaf_at(cell).map(|i| self.leaf(i, cell))
    }

    /// The bounds of the leaves' cells in scene units (the root cube for a tree without
    /// leaves): what a camera frames.
    pub fn occupied_bounds(&self) -> (DVec3, DVec3) {
        let Some((lo, hi)) = self.occupied_cells() else {
            return (self.root.origin, self.root.origin + self.root.side);
        };
        (self.cell_bounds(lo).0, self.cell_bounds(hi).1)
    }

    /// Whether the scene point `p` lies in a leaf cell (surface or interior).
    pub fn contains(&self, p: DVec3) -> bool {
        self.cell_at_point(p)
            .is_some_and(|c| self.leaf_at(c).is_some())
    }

    /// Checks the tree as the `.svo` reader checks every file (`docs/format.md`, checks 7 to
    /// 10 and 14 to 18): depth, root cube, counts, channels, the tree's shape, the canonical
    /// node order (level order for a tree with inner-node attributes, else depth-first; see
    /// [`Octree::nodes`]), leaves numbered depth-first, and the stored values; and bits 8-31 of the
    /// nodes' `info` words, which must be zero (as in a file) or the nodes' bounds
    /// ([`Octree::refresh_bounds`]). The error ([`OctreeError::Invalid`]) names the check
    /// (`check 16 (node order): ...`).
    /// Trees that `svo` builds pass; a tree assembled by hand from its public fields should be
    /// checked before it is traced, and the writer refuses one that fails the file's checks
    /// (it writes bits 8-31 as zeros).
    pub fn validate(&self) -> Result<(), OctreeError> {
        crate::octree::validate::validate(self)
    }
}
