//! The root cube and grid space.
//!
//! The root cube's origin is the scene's AABB minimum and its side the largest extent (the
//! thesis's rule), optionally padded by whole cells. Voxelization runs in *grid space*, where
//! the root is `[0, 2^depth]^3` and a leaf is the unit cube at integer cell `(x, y, z)`;
//! the mapping is a translation and one uniform scale, done in `f64`.

use glam::DVec3;

/// `floor` as an integer without a libm call (baseline x86-64 has no rounding
/// instruction); `x` is finite and far below `2^62` in magnitude.
#[inline]
pub(crate) fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t - i64::from((t as f64) > x)
}

/// The unit cells `i` that the closed interval `[lo, hi]` reaches (`i <= hi` and
/// `i + 1 >= lo`: a bound on a cell face reaches the cells on both sides), as the first and
/// last index; empty (first > last) when `lo > hi`.
#[inline]
pub(crate) fn closed_cells(lo: f64, hi: f64) -> (i64, i64) {
    let fl = floor_i64(lo);
    (fl - i64::from(fl as f64 == lo), floor_i64(hi))
}

/// The cube that the octree's root covers, in scene units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RootCube {
    /// The minimum corner.
    pub origin: DVec3,
    /// The side length (positive, finite).
    pub side: f64,
}

impl RootCube {
    /// Whether the cube is one the format allows (check 8 of `docs/format.md`): its origin,
    /// its side and its far corner `origin + side` finite, its side positive.
    pub(crate) fn is_valid(&self) -> bool {
        self.side.is_finite() && self.side > 0.0 && (self.origin + self.side).is_finite()
    }

    /// The thesis's root: origin at the bounds' minimum, side the largest extent. `pad`
    /// leaves an empty margin of that many cells (at `depth`) on every side. A flat or
    /// point-like mesh gets a side of 1 scene unit times its magnitude so the grid is valid.
    pub fn around(lo: DVec3, hi: DVec3, depth: u8, pad: u32) -> Self {
        let mut side = (hi - lo).max_element();
        if side <= 0.0 || !side.is_normal() {
            // A single point or a mesh with no extent: pick a positive side that keeps the
            // coordinates exact.
            side = lo.abs().max_element().max(1.0) * 1e-9;
            if side == 0.0 {
                side = 1.0;
            }
        }
        let cells = (1u64 << depth) as f64;
        // `pad` empty cells on every side: with closed cells a mesh whose bounds lie on a
        // cell face also marks the cell beyond it, so the bounds are put half a cell further
        // in, in the middle of the cell next to the margin.
        let pad = f64::from(pad).min(cells / 2.0 - 1.0).max(0.0);
        if pad > 0.0 {
            let margin = pad + 0.5;
            let side_p = side * cells / (cells - 2.0 * margin);
            let cell = side_p / cells;
            Self {
                origin: lo - DVec3::splat(margin * cell),
                side: side_p,
            }
        } else {
            Self { origin: lo, side }
        }
    }

    /// The side of one leaf cell at `depth`, in scene units.
    pub fn cell_size(&self, depth: u8) -> f64 {
        self.side / (1u64 << depth) as f64
    }

    /// Scene point to grid space at `depth`.
    pub fn to_grid(&self, p: DVec3, depth: u8) -> DVec3 {
        // Divide by the side first: `(hi - lo) / side` is exactly 1 on the largest axis, so
        // the mesh's far faces land exactly on the root's far faces (a power of two).
        (p - self.origin) / self.side * (1u64 << depth) as f64
    }

    /// Grid point at `depth` to scene space.
    pub fn to_scene(&self, g: DVec3, depth: u8) -> DVec3 {
        self.origin + g * (self.side / (1u64 << depth) as f64)
    }
}
