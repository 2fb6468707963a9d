//! A ray's footprint for level of detail: the cone of a pixel, and where a walk may stop at an
//! inner node instead of going down to its leaves.
//!
//! A [`Cone`] is `width + spread * d` grid cells wide at distance `d` (grid cells) from the
//! ray's origin. The walk stops at an inner node of side `s` cells (a node with values of its
//! own: not a leaf parent, and not the root) where `s <= width + spread * d` for the distance
//! `d > 0` from the ray's origin to the node's cube ([`node_distance`]), and hands the node to
//! the leaf callback as an entry of side `s` ([`crate::trace::LeafEntry::side`]): the renderer
//! then hits the node's contour or cube with the node's attributes. A node that holds or
//! touches the origin is never a stop. [`Cone::EXACT`] (all zero) never stops early: the walk
//! is the exact one, bit for bit.
//!
//! The distance to the cube, not the ray's parameter where it enters it, decides, so that
//! whether a node stands for its subtree depends on the node and the origin alone: every
//! primary ray of a view stops at the same cut of the tree, which the primary prepass
//! projects as the walk would find it. It differs from the parameter by at most the node's
//! diagonal.
//!
//! A renderer makes a primary ray's cone from its pixel (`width` 0 at the eye, `spread` the
//! pixel's angle), scaled by its level-of-detail factor: at factor 1 a ray stops at the first
//! node no wider than its pixel, as ESVO does (Laine and Karras 2010).

use glam::{UVec3, Vec3, Vec3A};

/// A ray's cone in grid cells: `width + spread * d` wide at distance `d` from its origin.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cone {
    /// The width at the origin, in grid cells.
    pub width: f32,
    /// The growth of the width per grid cell of distance from the origin (the cone's angle, in
    /// radians, for a narrow cone).
    pub spread: f32,
}

impl Cone {
    /// No footprint: the exact walk, down to the leaves.
    pub const EXACT: Self = Self {
        width: 0.0,
        spread: 0.0,
    };

    /// The width at distance `d` (grid cells) from the origin, in grid cells.
    #[inline]
    pub fn width_at(&self, d: f32) -> f32 {
        self.width + self.spread * d
    }

    /// Whether a node of `side` cells whose cube is `distance` (from [`node_distance`]) from
    /// the origin stands for its subtree: it does not touch the origin and is no wider than
    /// the cone there.
    #[inline]
    pub(crate) fn stops_at(&self, side: u32, distance: f32) -> bool {
        distance > 0.0 && side as f32 <= self.width_at(distance)
    }

    /// Whether the cone can stop a walk before the leaves (some width somewhere). Only
    /// positive, finite widths count: a NaN or negative cone is the exact walk.
    #[inline]
    pub fn is_exact(&self) -> bool {
        !(self.width > 0.0 || self.spread > 0.0)
    }

    /// The cone scaled by `f` (a renderer's level-of-detail factor).
    #[inline]
    pub fn scaled(&self, f: f32) -> Self {
        Self {
            width: self.width * f,
            spread: self.spread * f,
        }
    }
}

/// The distance, in grid cells, from `origin` to the cube of `side` cells whose minimum cell
/// is `lo` (0 where the cube holds the origin): the one computation both the walk and the
/// primary prepass make (and the GPU port, term for term), so that they stop at the same
/// nodes.
#[inline]
pub(crate) fn node_distance(origin: Vec3, lo: UVec3, side: u32) -> f32 {
    let o = Vec3A::from(origin);
    let lo = Vec3A::from(lo.as_vec3());
    let hi = lo + Vec3A::splat(side as f32);
    let d = (lo - o).max(o - hi).max(Vec3A::ZERO);
    (d.x * d.x + d.y * d.y + d.z * d.z).sqrt()
}
