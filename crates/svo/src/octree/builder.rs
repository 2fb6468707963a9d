//! Building an octree programmatically: from a list of cells with their attributes, or from
//! a function over cells (the 2019 report builds its scene this way). Both go through the
//! same packed layout as the voxelizer (`layout.rs`).

use crate::geometry::child_classify::child_offset;
use crate::geometry::grid::RootCube;
use crate::mesh::presets::Preset;
use crate::octree::encoding::{encode_colour, ior_encode, unorm8};
use crate::octree::layout::{Chunk, LeafStore};
use crate::octree::normal_encoding;
use crate::octree::tree::{Channel, LeafAttributes, Octree};
use glam::{UVec3, Vec3};
use thiserror::Error;

/// Errors of the octree: its programmatic builder, and a tree that fails the checks every
/// file passes ([`Octree::validate`](crate::Octree::validate)).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum OctreeError {
    /// The depth is 0 or too large.
    #[error("depth {0} is outside 1..={max}", max = crate::MAX_DEPTH)]
    Depth(u8),
    /// A cell lies outside the `2^depth` grid.
    #[error("cell {cell} lies outside the {side}^3 grid")]
    CellOutOfRange {
        /// The cell.
        cell: UVec3,
        /// Cells per axis.
        side: u64,
    },
    /// The root cube is not finite and positive (its origin, side and far corner).
    #[error("root cube is not finite and positive (its origin, side and far corner)")]
    BadRoot,
    /// The tree fails one of the format's numbered checks (`docs/format.md`).
    #[error("{check}: {detail}")]
    Invalid {
        /// The check it fails.
        check: crate::octree::format_check::Check,
        /// What is wrong, and where.
        detail: String,
    },
}

/// The attributes of one cell given to the builder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Voxel {
    /// Linear RGBA colour.
    pub colour: [f32; 4],
    /// Reflectivity in `[0, 1]`.
    pub reflectivity: f32,
    /// Refractivity (transparency) in `[0, 1]`.
    pub refractivity: f32,
    /// Index of refraction.
    pub ior: f32,
    /// A surface normal; cells without one are rendered as cubes.
    pub normal: Option<Vec3>,
}

impl Default for Voxel {
    fn default() -> Self {
        Self {
            colour: [0.8, 0.8, 0.8, 1.0],
            reflectivity: 0.0,
            refractivity: 0.0,
            ior: 1.5,
            normal: None,
        }
    }
}

impl Voxel {
    /// The 2019 report's "void" material: empty (callers simply leave such cells out).
    pub const VOID: Option<Voxel> = None;

    /// The voxel of a preset's material with `colour`, without a normal; `None` for void.
    pub fn preset(p: Preset, colour: Option<[f32; 4]>) -> Option<Self> {
        p.material().map(|m| Self {
            colour: colour.unwrap_or(m.colour),
            reflectivity: m.reflectivity,
            refractivity: m.refractivity,
            ior: m.ior,
            normal: None,
        })
    }

    /// The 2019 report's "glass" ([`Preset::Glass`]).
    pub fn glass() -> Self {
        Self::preset(Preset::Glass, None).unwrap_or_default()
    }

    /// The 2019 report's "semi-solid" ([`Preset::SemiSolid`]) in `colour`.
    pub fn semi_solid(colour: [f32; 4]) -> Self {
        Self::preset(Preset::SemiSolid, Some(colour)).unwrap_or_default()
    }

    /// The 2019 report's "solid" ([`Preset::Solid`]) in `colour`.
    pub fn solid(colour: [f32; 4]) -> Self {
        Self::preset(Preset::Solid, Some(colour)).unwrap_or_default()
    }

    /// Water ([`Preset::Water`]).
    pub fn water() -> Self {
        Self::preset(Preset::Water, None).unwrap_or_default()
    }
}

/// Leaves of any type, for the builders that keep one value per leaf.
pub(crate) struct LeafVec<T>(pub Vec<T>);

impl<T> Default for LeafVec<T> {
    fn default() -> Self {
        Self(Vec::new())
    }
}

impl<T: Send> LeafStore for LeafVec<T> {
    type Sums = ();
    type NodeValue = ();
    fn len(&self) -> usize {
        self.0.len()
    }
}

type Voxels = LeafVec<Voxel>;

/// The Morton key of a cell: child indices from the root down, 3 bits a level.
pub(crate) fn morton(c: UVec3, depth: u8) -> u128 {
    let mut k = 0u128;
    for level in (0..depth).rev() {
        let i = ((c.x >> level) & 1) << 2 | ((c.y >> level) & 1) << 1 | ((c.z >> level) & 1);
        k = k << 3 | u128::from(i);
    }
    k
}

fn check(root: &RootCube, depth: u8) -> Result<(), OctreeError> {
    if !(1..=crate::MAX_DEPTH).contains(&depth) {
        return Err(OctreeError::Depth(depth));
    }
    if !root.is_valid() {
        return Err(OctreeError::BadRoot);
    }
    Ok(())
}

/// See [`Octree::from_cells`].
pub(crate) fn from_cells(
    root: RootCube,
    depth: u8,
    cells: impl IntoIterator<Item = (UVec3, Voxel)>,
) -> Result<Octree, OctreeError> {
    check(&root, depth)?;
    let side = 1u64 << depth;
    let mut v: Vec<(u128, usize, Voxel)> = Vec::new();
    for (n, (c, vox)) in cells.into_iter().enumerate() {
        if u64::from(c.max_element()) >= side {
            return Err(OctreeError::CellOutOfRange { cell: c, side });
        }
        v.push((morton(c, depth), n, vox));
    }
    // Sort by key, later entries last, then keep the last of each key.
    v.sort_by_key(|&(k, n, _)| (k, n));
    let mut dedup: Vec<(u128, Voxel)> = Vec::with_capacity(v.len());
    for (k, _, vox) in v {
        match dedup.last_mut() {
            Some(last) if last.0 == k => last.1 = vox,
            _ => dedup.push((k, vox)),
        }
    }
    let mut chunk = Chunk::<Voxels>::new();
    let rec = build_sorted(&dedup, depth, 0, &mut chunk);
    Ok(finish(root, depth, chunk, rec))
}

/// The packed nodes over cells sorted by strictly increasing Morton key, and their values in
/// leaf order (which is the key order).
#[cfg(any(feature = "solid", feature = "io"))]
pub(crate) fn layout_sorted<T: Copy + Send>(
    cells: &[(u128, T)],
    depth: u8,
) -> (Vec<crate::octree::tree::Node>, Vec<T>) {
    let mut chunk = Chunk::<LeafVec<T>>::new();
    let rec = build_sorted(cells, depth, 0, &mut chunk);
    let (nodes, _, LeafVec(values)) = chunk.finish(rec.map(|r| (r, (), ())));
    (nodes, values)
}

fn build_sorted<T: Copy + Send>(
    cells: &[(u128, T)],
    depth: u8,
    level: u8,
    chunk: &mut Chunk<LeafVec<T>>,
) -> Option<crate::octree::tree::Node> {
    if cells.is_empty() {
        return None;
    }
    let shift = 3 * u32::from(depth - level - 1);
    let child = |k: u128| ((k >> shift) & 7) as u8;
    let mut mask = 0u8;
    if level + 1 == depth {
        let base = chunk.leaves.len();
        for &(k, vox) in cells {
            mask |= 1 << child(k);
            chunk.leaves.0.push(vox);
        }
        return Some(Chunk::<LeafVec<T>>::leaf_parent(mask, base));
    }
    let mut records = Vec::with_capacity(8);
    let mut start = 0;
    while start < cells.len() {
        let i = child(cells[start].0);
        let end = start + cells[start..].partition_point(|&(k, _)| child(k) == i);
        if let Some(r) = build_sorted(&cells[start..end], depth, level + 1, chunk) {
            mask |= 1 << i;
            records.push((r, (), ()));
        }
        start = end;
    }
    Some(chunk.push_children(mask, &records).0)
}

/// See [`Octree::from_fn`].
pub(crate) fn from_fn(
    root: RootCube,
    depth: u8,
    may_contain: impl Fn(UVec3, u32) -> bool,
    f: impl Fn(UVec3) -> Option<Voxel>,
) -> Result<Octree, OctreeError> {
    check(&root, depth)?;
    let mut chunk = Chunk::<Voxels>::new();
    let rec = build_fn(&may_contain, &f, depth, 0, UVec3::ZERO, &mut chunk);
    Ok(finish(root, depth, chunk, rec))
}

fn build_fn(
    may: &dyn Fn(UVec3, u32) -> bool,
    f: &dyn Fn(UVec3) -> Option<Voxel>,
    depth: u8,
    level: u8,
    min: UVec3,
    chunk: &mut Chunk<Voxels>,
) -> Option<crate::octree::tree::Node> {
    let size = 1u32 << (depth - level);
    if !may(min, size) {
        return None;
    }
    let half = size / 2;
    let mut mask = 0u8;
    if level + 1 == depth {
        let base = chunk.leaves.len();
        for i in 0..8u8 {
            let c = min + UVec3::from_array(child_offset(i));
            if let Some(v) = f(c) {
                mask |= 1 << i;
                chunk.leaves.0.push(v);
            }
        }
        return (mask != 0).then(|| Chunk::<Voxels>::leaf_parent(mask, base));
    }
    let mut records = Vec::with_capacity(8);
    for i in 0..8u8 {
        let o = UVec3::from_array(child_offset(i)) * half;
        if let Some(r) = build_fn(may, f, depth, level + 1, min + o, chunk) {
            mask |= 1 << i;
            records.push((r, (), ()));
        }
    }
    (mask != 0).then(|| chunk.push_children(mask, &records).0)
}

fn finish(
    root: RootCube,
    depth: u8,
    chunk: Chunk<Voxels>,
    rec: Option<crate::octree::tree::Node>,
) -> Octree {
    let (nodes, _, LeafVec(vox)) = chunk.finish(rec.map(|r| (r, (), ())));
    let mut attributes = LeafAttributes {
        colour: Channel::PerLeaf(vox.iter().map(|v| encode_colour(v.colour)).collect()),
        reflectivity: Channel::PerLeaf(vox.iter().map(|v| unorm8(v.reflectivity)).collect()),
        refractivity: Channel::PerLeaf(vox.iter().map(|v| unorm8(v.refractivity)).collect()),
        ior: Channel::PerLeaf(vox.iter().map(|v| ior_encode(v.ior)).collect()),
        ..LeafAttributes::default()
    };
    if vox.iter().any(|v| v.normal.is_some()) {
        attributes.normal = Channel::PerLeaf(
            vox.iter()
                .map(|v| normal_encoding::encode(v.normal.unwrap_or(Vec3::Z)))
                .collect(),
        );
    }
    if !vox.is_empty() {
        attributes.compact();
    }
    let mut tree = Octree {
        root,
        depth,
        nodes,
        leaf_count: vox.len() as u32,
        attributes,
        node_attributes: Default::default(),
    };
    tree.refresh_bounds();
    tree
}

impl Octree {
    /// An octree holding exactly the given cells (integer coordinates in the `2^depth` grid
    /// over `root`), each with its attributes. A cell listed twice keeps its last voxel.
    ///
    /// ```
    /// use glam::{DVec3, UVec3};
    /// use svo::{Octree, RootCube, Voxel};
    /// let root = RootCube { origin: DVec3::ZERO, side: 1.0 };
    /// let cells = [(UVec3::new(0, 0, 0), Voxel::default()), (UVec3::new(3, 3, 3), Voxel::glass())];
    /// let tree = Octree::from_cells(root, 2, cells)?;
    /// assert_eq!(tree.leaf_count, 2);
    /// assert!(tree.contains(DVec3::splat(0.9)));
    /// # Ok::<(), svo::OctreeError>(())
    /// ```
    pub fn from_cells(
        root: RootCube,
        depth: u8,
        cells: impl IntoIterator<Item = (UVec3, Voxel)>,
    ) -> Result<Octree, OctreeError> {
        from_cells(root, depth, cells)
    }

    /// An octree of the cells where `f` returns a voxel. `may_contain(min_cell, size)` may
    /// prune whole nodes (cubes of `size` cells from `min_cell`) that hold no voxel; return
    /// `true` when unsure. Without pruning every one of the `8^depth` cells is visited.
    ///
    /// ```
    /// use glam::{DVec3, UVec3};
    /// use svo::{Octree, RootCube, Voxel};
    /// // A ball of radius 6 cells in a 16^3 grid; nodes beyond it are pruned whole.
    /// let c = DVec3::splat(8.0);
    /// let dist = |lo: UVec3, size: u32| {
    ///     let lo = lo.as_dvec3();
    ///     c.clamp(lo, lo + f64::from(size)).distance(c)
    /// };
    /// let root = RootCube { origin: DVec3::ZERO, side: 1.0 };
    /// let tree = Octree::from_fn(root, 4, |lo, size| dist(lo, size) <= 6.0, |cell| {
    ///     (dist(cell, 1) <= 6.0).then(Voxel::default)
    /// })?;
    /// assert!(tree.contains(DVec3::splat(0.5)));
    /// # Ok::<(), svo::OctreeError>(())
    /// ```
    pub fn from_fn(
        root: RootCube,
        depth: u8,
        may_contain: impl Fn(UVec3, u32) -> bool,
        f: impl Fn(UVec3) -> Option<Voxel>,
    ) -> Result<Octree, OctreeError> {
        from_fn(root, depth, may_contain, f)
    }
}
