//! Where a graph's leaves find their values ([`DagValues`]): each leaf its own, or the values
//! of its ancestor on a level above (a tree's inner-node attributes, area-weighted over the
//! surface in the ancestor's cell), and normals and colours in fewer bits. A graph shares subtrees but
//! not values, so the values are what grows with depth: kept on a level `A` above the leaves,
//! they grow with that level's node count instead.

use crate::octree::colour_encoding::round_trip;
use crate::octree::level_order::level_counts;
use crate::octree::normal_encoding::quantize;
use crate::octree::tree::{Channel, LeafAttributes, Octree};
use thiserror::Error;

/// Where and how finely a graph keeps its leaves' values (the default: each leaf its own,
/// normals as they are).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DagValues {
    /// The tree level whose nodes hold the values: the tree's depth (each leaf its own), or a
    /// level from 1 to `depth - 2` whose inner-node attributes
    /// ([`crate::BakeOptions::node_attributes`]) the leaves below take. `None`: the depth.
    pub level: Option<u8>,
    /// The bits a normal is kept in: an even number from 4 to 32, half of them a component of
    /// its octahedral encoding (`docs/format.md`, section 5); 32 keeps the normals as they are.
    pub normal_bits: u8,
    /// The bits a colour is kept in: 32 as it is (RGBA8), 16 as R5G6B5, or 4 in blocks of 16
    /// colours in Morton order, two R5G6B5 ends and a 2-bit choice a colour among four
    /// (`docs/format.md`, section 12); 16 and 4 keep no alpha.
    pub colour_bits: u8,
}

impl Default for DagValues {
    fn default() -> Self {
        Self {
            level: None,
            normal_bits: 32,
            colour_bits: 32,
        }
    }
}

/// Why a tree's values cannot be kept as [`DagValues`] asks.
#[derive(Debug, Error, PartialEq, Eq)]
#[non_exhaustive]
pub enum ValuesError {
    /// A level that holds no values.
    #[error(
        "values on level {level} of a tree of depth {depth}: the levels that hold values are 1 to {} (the inner nodes') and {depth} (the leaves)",
        depth.saturating_sub(2)
    )]
    Level {
        /// The level asked for.
        level: u8,
        /// The tree's depth.
        depth: u8,
    },
    /// Values above the leaves from a tree whose inner nodes have none.
    #[error(
        "values above the leaves are the inner nodes' attributes, which this tree has not (bake it with node attributes)"
    )]
    NoNodeValues,
    /// A contour above the leaves.
    #[error(
        "a contour is measured in its own cell: with values above the leaves, leave the contour channel out"
    )]
    Contour,
    /// A normal width not allowed.
    #[error("{0} bits a normal: an even number from 4 to 32")]
    NormalBits(u8),
    /// A colour width not allowed.
    #[error("{0} bits a colour: 32 (as it is), 16 (R5G6B5) or 4 (blocks of 16)")]
    ColourBits(u8),
}

impl DagValues {
    /// The level, resolved for a tree of `depth`.
    pub fn level_for(&self, depth: u8) -> u8 {
        self.level.unwrap_or(depth)
    }

    /// Checks the settings for a tree of `depth`.
    pub fn check(&self, depth: u8) -> Result<(), ValuesError> {
        let b = self.normal_bits;
        if !(4..=32).contains(&b) || !b.is_multiple_of(2) {
            return Err(ValuesError::NormalBits(b));
        }
        if ![4, 16, 32].contains(&self.colour_bits) {
            return Err(ValuesError::ColourBits(self.colour_bits));
        }
        let level = self.level_for(depth);
        if level != depth && !(1..=depth.saturating_sub(2)).contains(&level) {
            return Err(ValuesError::Level { level, depth });
        }
        Ok(())
    }

    /// The values `tree`'s leaves get: its leaves' channels, or its inner nodes' on the
    /// level (one value for each node of that level, in Morton order), constants kept, with
    /// the normals in `normal_bits` bits and the colours in `colour_bits` (a constant colour
    /// as it is: a file stores it whole).
    #[cfg_attr(not(feature = "trace"), allow(dead_code))]
    pub(crate) fn of(&self, tree: &Octree) -> Result<LeafAttributes, ValuesError> {
        let mut a = self.packed_values(tree)?;
        if let Channel::PerLeaf(v) = &mut a.colour {
            round_trip(v, self.colour_bits);
        }
        Ok(a)
    }

    /// [`Self::of`] before the colours are kept in their bits: what a writer packs (a block
    /// of colours is encoded from the colours themselves, not from a decoded block).
    #[cfg_attr(not(any(feature = "io", feature = "trace")), allow(dead_code))]
    pub(crate) fn packed_values(&self, tree: &Octree) -> Result<LeafAttributes, ValuesError> {
        self.check(tree.depth)?;
        let level = self.level_for(tree.depth);
        let mut a = if level == tree.depth {
            tree.attributes.clone()
        } else {
            level_values(tree, level)?
        };
        if self.normal_bits < 32 {
            let bits = u32::from(self.normal_bits);
            match &mut a.normal {
                Channel::PerLeaf(v) => v.iter_mut().for_each(|e| *e = quantize(*e, bits).1),
                Channel::Constant(e) => *e = quantize(*e, bits).1,
                Channel::Absent => {}
            }
        }
        Ok(a)
    }
}

/// The inner nodes' values on `level` (above the leaf parents) of a tree with inner-node
/// attributes (its nodes in level order), for the channels its leaves have.
#[cfg_attr(not(any(feature = "io", feature = "trace")), allow(dead_code))]
fn level_values(tree: &Octree, level: u8) -> Result<LeafAttributes, ValuesError> {
    let (a, na) = (&tree.attributes, &tree.node_attributes);
    if !matches!(a.contour, Channel::Absent) {
        return Err(ValuesError::Contour);
    }
    let counts = level_counts(&tree.nodes, tree.depth);
    let start = counts[..usize::from(level)].iter().sum::<u64>() as usize;
    let range = start..start + counts[usize::from(level)] as usize;
    fn pick<T: Copy>(
        leaf: &Channel<T>,
        node: &Channel<T>,
        range: &std::ops::Range<usize>,
    ) -> Result<Channel<T>, ValuesError> {
        Ok(match (leaf, node) {
            (Channel::Absent, _) => Channel::Absent,
            (Channel::Constant(v), _) => Channel::Constant(*v),
            (Channel::PerLeaf(_), Channel::PerLeaf(n)) => Channel::PerLeaf(
                n.get(range.clone())
                    .ok_or(ValuesError::NoNodeValues)?
                    .to_vec(),
            ),
            (Channel::PerLeaf(_), Channel::Constant(v)) => Channel::Constant(*v),
            (Channel::PerLeaf(_), Channel::Absent) => return Err(ValuesError::NoNodeValues),
        })
    }
    Ok(LeafAttributes {
        normal: pick(&a.normal, &na.normal, &range)?,
        contour: Channel::Absent,
        colour: pick(&a.colour, &na.colour, &range)?,
        reflectivity: pick(&a.reflectivity, &na.reflectivity, &range)?,
        refractivity: pick(&a.refractivity, &na.refractivity, &range)?,
        ior: pick(&a.ior, &na.ior, &range)?,
    })
}
