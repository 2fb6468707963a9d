//! Rays in grid space, and their octant-mirrored form that the traversals use.
//!
//! The tracer works in the tree's *grid space* (the root is `[0, 2^depth]^3`, a leaf the unit
//! cube at its integer cell; see [`crate::geometry::grid`]) in `f32`, as the GPU does. A scene ray
//! `o + t d` becomes the grid ray `G(o) + t (d * 2^depth / side)`: the direction is scaled
//! with the grid, so the ray parameter `t` is the same in both spaces and every hit distance
//! is in scene units along the caller's direction. The conversion runs in `f64`, so a scene
//! far from its origin keeps its precision.
//!
//! ## Mirroring (thesis 1.4.4)
//! The traversals need a direction with no negative component. Each axis whose direction has
//! its *sign bit* set (so `-0.0` counts as negative) is mirrored about the root's centre, and
//! the axis's child bit (x = 4, y = 2, z = 1) goes into a mask that maps mirrored child
//! indices back with `xor`. A component that is zero, or tiny, is raised to [`TINY`]
//! (`2^-100`), so `1 / d` is finite and no NaN ever reaches a comparison. The raise moves a
//! point at distance `D` cells from the origin by at most `D * TINY / max|d|` cells: below
//! `2^-30 D`, far below `f32`'s own rounding, while the direction's largest component is at
//! least `2^-69` (a normalized scene direction in a tree of depth `k` over a root of side
//! `s`: `s` up to about `3e20 * 2^k`). Plane parameters `(p - o) / d` are finite while
//! `|p - o| < 2^28` cells; farther, a near-parallel axis's are infinite, which still orders
//! correctly (the axis's planes lie beyond every finite crossing).

use crate::geometry::grid::RootCube;
use glam::{DVec3, UVec3, Vec3, Vec3A};

/// The smallest direction component the traversals use (`2^-100`): large enough that
/// `1 / TINY` is finite and `(p - o) / TINY` is for `|p - o| < 2^28` cells, small enough that
/// a direction whose largest component is at least `2^-69` is perturbed by less than
/// `2^-30` of the distance travelled (see the module overview).
pub const TINY: f32 = 7.888_609e-31;

/// A ray in grid space: `origin + t * dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridRay {
    /// The origin, in grid units.
    pub origin: Vec3,
    /// The direction (any length; `t` is measured in its units).
    pub dir: Vec3,
}

impl GridRay {
    /// The grid ray of the scene ray `origin + t * dir` for a tree over `root` at `depth`.
    pub fn from_scene(root: &RootCube, depth: u8, origin: DVec3, dir: DVec3) -> Self {
        let scale = (1u64 << depth) as f64 / root.side;
        Self {
            origin: root.to_grid(origin, depth).as_vec3(),
            dir: (dir * scale).as_vec3(),
        }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// Whether the ray can be traced: finite origin, finite non-zero direction.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite() && self.dir.is_finite() && self.dir != Vec3::ZERO
    }
}

/// `1 / d` per axis with each component of `d` first moved away from zero to at least
/// [`TINY`] in magnitude, keeping its sign bit (`-0.0` becomes `-TINY`): finite and non-zero
/// for every finite `d`. Every traversal's plane parameters are `(p - o) * safe_inverse(d)`.
#[inline]
pub(crate) fn safe_inverse(d: Vec3) -> Vec3A {
    let raise = |c: f32| {
        if c.is_sign_negative() {
            c.min(-TINY)
        } else {
            c.max(TINY)
        }
    };
    Vec3A::new(raise(d.x), raise(d.y), raise(d.z)).recip()
}

/// A ray mirrored into the positive octant of a root of `n` cells per axis.
///
/// The origin itself is not mirrored (that would round it to the precision of the root's far
/// side): the traversal works with mirrored *integer plane coordinates*, which are mapped back
/// exactly (`n - p`) before the ray parameter `(p - o) / d` is computed in real space.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MirroredRay {
    /// The real origin.
    pub o: Vec3A,
    /// `1 / d` of the real direction with tiny components raised to [`TINY`] in magnitude:
    /// finite and non-zero.
    pub inv: Vec3A,
    /// Child bits of the mirrored axes (x = 4, y = 2, z = 1).
    pub mask: u8,
    /// Cells per axis.
    pub n: u32,
    /// Per axis, all ones and `n + 1` for mirrored axes, zeros for the others: the real
    /// plane of mirrored plane `p` is `(p ^ flip) + add` (wrapping), `n - p` or `p`, in
    /// integers. Its conversion to `f32` is then exact wherever the real coordinate is below
    /// `2^24`, on mirrored axes too (mirroring in floats, `n - p` would lose its low bits
    /// once `n` is above `2^24`, near the low faces of trees deeper than 24).
    flip: UVec3,
    add: UVec3,
}

impl MirroredRay {
    /// Mirrors `ray` for a root of `n` cells per axis; `None` for an invalid ray.
    #[inline]
    pub(crate) fn new(ray: &GridRay, n: u32) -> Option<Self> {
        if !ray.is_valid() {
            return None;
        }
        let mut mask = 0u8;
        for axis in 0..3 {
            if ray.dir[axis].is_sign_negative() {
                mask |= 4 >> axis;
            }
        }
        let m = |bit: u8, v: u32| if mask & bit != 0 { v } else { 0 };
        Some(Self {
            o: ray.origin.into(),
            inv: safe_inverse(ray.dir),
            mask,
            n,
            flip: UVec3::new(m(4, u32::MAX), m(2, u32::MAX), m(1, u32::MAX)),
            add: UVec3::new(m(4, n + 1), m(2, n + 1), m(1, n + 1)),
        })
    }

    /// The ray parameters where it crosses the mirrored planes `x = p.x`, `y = p.y`,
    /// `z = p.z` (integer grid coordinates). The same plane always gives the same value,
    /// which is what keeps neighbouring cells gap-free.
    #[inline]
    pub(crate) fn t_planes(&self, p: UVec3) -> Vec3A {
        (self.real_planes(p) - self.o) * self.inv
    }

    /// The real coordinates of mirrored planes `p`, as `f32`.
    #[inline]
    pub(crate) fn real_planes(&self, p: UVec3) -> Vec3A {
        // At most n <= 2^30: the signed conversion is exact below 2^24 and rounds above.
        (p ^ self.flip).wrapping_add(self.add).as_ivec3().as_vec3a()
    }

    /// Where the ray meets the root within `[tmin, tmax]`: the parameters of the root's low
    /// and high planes and the entry parameter, or `None` when it misses (or the range is
    /// empty or NaN).
    #[inline]
    pub(crate) fn root_entry(&self, tmin: f32, tmax: f32) -> Option<(Vec3A, Vec3A, f32)> {
        self.node_entry(UVec3::ZERO, self.n, tmin, tmax)
    }

    /// [`Self::root_entry`] for the node whose mirrored minimum cell is `origin` and whose
    /// side is `side` cells.
    #[inline]
    pub(crate) fn node_entry(
        &self,
        origin: UVec3,
        side: u32,
        tmin: f32,
        tmax: f32,
    ) -> Option<(Vec3A, Vec3A, f32)> {
        if !(tmin <= tmax) {
            return None;
        }
        let t0 = self.t_planes(origin);
        let t1 = self.t_planes(origin + UVec3::splat(side));
        let enter = t0.max_element().max(tmin);
        (enter <= t1.min_element().min(tmax)).then_some((t0, t1, enter))
    }

    /// Maps a mirrored leaf cell back to the real cell.
    #[inline]
    pub(crate) fn unmirror_cell(&self, m: UVec3) -> UVec3 {
        self.flip(m, 1)
    }

    /// The minimum corner, on the other side of the mirror, of the cube of `side` cells
    /// whose minimum corner is `c` (real to mirrored or back: the map is its own inverse).
    #[inline]
    pub(crate) fn flip(&self, c: UVec3, side: u32) -> UVec3 {
        let f = |axis: usize, v: u32| {
            if self.mask & (4 >> axis) != 0 {
                self.n - side - v
            } else {
                v
            }
        };
        UVec3::new(f(0, c.x), f(1, c.y), f(2, c.z))
    }

    /// The real-space unit normal of the face through which the ray enters a cell whose
    /// entry-plane parameters are `c0` (the latest of the three; ties prefer x, then y),
    /// facing the ray; zero when the ray starts inside (`max(c0) < tmin`).
    #[inline]
    pub(crate) fn entry_normal_of(&self, c0: Vec3A, tmin: f32) -> Vec3 {
        entry_normal_of(self.mask, c0, tmin)
    }

    /// The real-space outward unit normal of the face through which the ray leaves a cell
    /// whose exit-plane parameters are `c1` (the earliest of the three; ties prefer x, then
    /// y): it points along the ray.
    #[inline]
    pub(crate) fn exit_normal_of(&self, c1: Vec3A) -> Vec3 {
        exit_normal_of(self.mask, c1)
    }
}

/// [`MirroredRay::entry_normal_of`] for a ray whose mirrored axes are `mask`.
#[inline]
pub(crate) fn entry_normal_of(mask: u8, c0: Vec3A, tmin: f32) -> Vec3 {
    if c0.max_element() < tmin {
        return Vec3::ZERO;
    }
    let axis = if c0.x >= c0.y && c0.x >= c0.z {
        0
    } else if c0.y >= c0.z {
        1
    } else {
        2
    };
    entry_normal(mask, axis)
}

/// [`MirroredRay::exit_normal_of`] for a ray whose mirrored axes are `mask`.
#[inline]
pub(crate) fn exit_normal_of(mask: u8, c1: Vec3A) -> Vec3 {
    let axis = if c1.x <= c1.y && c1.x <= c1.z {
        0
    } else if c1.y <= c1.z {
        1
    } else {
        2
    };
    -entry_normal(mask, axis)
}

/// The real-space unit normal of the face through which a ray whose mirrored axes are
/// `mask` enters on `axis` (it faces the ray).
#[inline]
fn entry_normal(mask: u8, axis: usize) -> Vec3 {
    let mut n = Vec3::ZERO;
    n[axis] = if mask & (4 >> axis) != 0 { 1.0 } else { -1.0 };
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_zero_is_mirrored_and_zero_is_raised() {
        let r = GridRay {
            origin: Vec3::new(1.0, 2.0, 3.0),
            dir: Vec3::new(-0.0, 0.0, -1.0),
        };
        let m = MirroredRay::new(&r, 8).unwrap();
        assert_eq!(m.mask, 0b101);
        assert!(m.inv.is_finite());
        // Mirrored planes: x = 8 - 7 = 1 and z = 8 - 5 = 3 are the origin's own planes, so
        // t = 0 there, not NaN; the mirrored direction is positive on every axis.
        assert_eq!(m.t_planes(UVec3::new(7, 2, 5)), Vec3A::ZERO);
        let ahead = m.t_planes(UVec3::new(8, 3, 6));
        assert!(ahead.cmpgt(Vec3A::ZERO).all(), "{ahead}");
    }

    /// A scene ray in a root at `(1, 2, 3)` of side 4, at depth 3 (8 cells of side 0.5): the
    /// origin maps to its cell coordinates and the direction scales by 2 cells per unit, so
    /// the parameter is the same in both spaces.
    #[test]
    fn scene_rays_map_to_grid_rays_with_the_same_parameter() {
        let root = RootCube {
            origin: DVec3::new(1.0, 2.0, 3.0),
            side: 4.0,
        };
        let r = GridRay::from_scene(
            &root,
            3,
            DVec3::new(2.0, 2.5, -1.0),
            DVec3::new(0.5, -1.0, 3.0),
        );
        assert_eq!(r.origin, Vec3::new(2.0, 1.0, -8.0));
        assert_eq!(r.dir, Vec3::new(1.0, -2.0, 6.0));
        // The scene point at t = 0.75 is the grid point at t = 0.75.
        let scene = DVec3::new(2.0, 2.5, -1.0) + DVec3::new(0.5, -1.0, 3.0) * 0.75;
        assert_eq!(root.to_grid(scene, 3).as_vec3(), r.at(0.75));
    }

    #[test]
    fn invalid_rays_are_refused() {
        for (o, d) in [
            (Vec3::ZERO, Vec3::ZERO),
            (Vec3::NAN, Vec3::X),
            (Vec3::ZERO, Vec3::new(f32::INFINITY, 0.0, 0.0)),
        ] {
            assert!(MirroredRay::new(&GridRay { origin: o, dir: d }, 4).is_none());
        }
    }
}
