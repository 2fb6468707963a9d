//! The sparse voxel octree: packed nodes (an info byte of existing children, children
//! packed after `first`, negative references for leaves), the per-leaf attribute channels
//! as separate arrays (absent, constant, or one value per leaf), queries in scene units,
//! the programmatic builder ([`Octree::from_cells`], [`Octree::from_fn`]), the checks of a
//! tree's structure, and the encodings of the stored values (octahedral normals, contours,
//! unorm8, sRGB colour, IOR). `docs/format.md` describes the layout byte for byte.
//!
//! Depends on [`crate::mesh`] (material presets for the builder) and the grid geometry (the
//! root cube, child offsets). Everything that makes or reads trees depends on it.

pub(crate) mod bounds;
pub(crate) mod builder;
pub(crate) mod colour_encoding;
pub(crate) mod contour;
pub(crate) mod encoding;
pub(crate) mod format_check;
pub(crate) mod layout;
pub(crate) mod level_order;
pub(crate) mod normal_encoding;
pub(crate) mod query;
#[cfg(feature = "io")]
pub(crate) mod stitch;
pub(crate) mod tree;
pub(crate) mod validate;

pub use crate::geometry::RootCube;
pub use builder::{OctreeError, Voxel};
pub use format_check::Check;
pub use query::Leaf;
pub use tree::{
    Channel, ChannelKind, ChannelStorage, LeafAttributes, LeafValue, NO_NORMAL, Node, Octree,
};

/// A tree in the unit cube of `n` cells drawn by `rnd` uniformly from the `2^depth` grid (a
/// cell drawn twice is one leaf; none drawn, the empty tree): what the seeded random tests of
/// the node orders and the graphs build.
#[cfg(test)]
pub(crate) fn scattered_tree(rnd: &mut impl FnMut() -> u64, depth: u8, n: u64) -> Octree {
    use glam::{DVec3, UVec3};
    let side = 1u32 << depth;
    let cells: Vec<_> = (0..n)
        .map(|_| {
            let c = UVec3::new(rnd() as u32, rnd() as u32, rnd() as u32) % side;
            (c, Voxel::glass())
        })
        .collect();
    let root = RootCube {
        origin: DVec3::ZERO,
        side: 1.0,
    };
    Octree::from_cells(root, depth, cells).unwrap()
}
