//! What a ray hits inside a leaf: the cell cube, or the contour slab (thesis 1.4.4), and the
//! [`cast`] that stops at the first such hit.
//!
//! - **Cube**: the ray stops where it enters the cell.
//! - **Contour**: the leaf's two planes `near <= n . (p - c) <= far` (`n` the leaf normal, `c`
//!   the cell centre, offsets in cells; [`crate::contour`]). The ray stops at the first point
//!   of the cell that lies between them: its entry point if that is inside the slab, else
//!   where it crosses the plane it is heading for, if that comes before it leaves the cell.
//!   A ray that misses the slab goes on through the tree (the thesis's "parallel" case).
//!   A leaf without a normal or contour is hit as a cube.
//!
//! A hit reports the *geometric* normal at the hit point, facing the ray: the cube face it
//! entered through, or the contour plane. Shading normals come from the leaf attributes.

use crate::contour;
use crate::grid_ray::GridRay;
use crate::normal_encoding;
use crate::octree::{Channel, Octree};
use crate::octree_traverse::{LeafEntry, Traversal, traverse};
use glam::{UVec3, Vec3};

/// How a leaf is intersected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum HitMode {
    /// The cell cube.
    Cube,
    /// The slab between the leaf's two contour planes, inside the cell.
    #[default]
    Contour,
    /// The mesh triangles that overlap the leaf (the 2019 report's O6b). Needs the
    /// triangles ([`crate::exact_surfaces`]); [`leaf_hit`] alone treats it as [`Self::Cube`].
    Exact,
}

impl HitMode {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Cube => "cube",
            Self::Contour => "contour",
            Self::Exact => "exact",
        }
    }
}

/// A ray's hit on a leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (scene units along the caller's direction).
    pub t: f32,
    /// Where the ray leaves the cell.
    pub t_exit: f32,
    /// The leaf index.
    pub leaf: u32,
    /// Its cell.
    pub cell: UVec3,
    /// Geometric unit normal at the hit, facing the ray (zero if the ray starts inside the
    /// cell and inside the slab).
    pub normal: Vec3,
}

/// The cube hit of a leaf entry.
#[inline]
pub fn cube_hit(e: &LeafEntry) -> Hit {
    Hit {
        t: e.t_enter,
        t_exit: e.t_exit,
        leaf: e.leaf,
        cell: e.cell,
        normal: e.entry_normal,
    }
}

/// The slab hit of a leaf entry, for the leaf's unit normal `n` and contour offsets
/// `(near, far)` in cells from the cell centre.
#[inline]
pub fn slab_hit(ray: &GridRay, e: &LeafEntry, n: Vec3, near: f32, far: f32) -> Option<Hit> {
    // Relative to the cell centre first: `o - c` is small and nearly exact even where the
    // grid coordinates are large, which `o + t d - c` would not be.
    let centre = e.cell.as_vec3() + Vec3::splat(0.5);
    let sd = n.dot(ray.dir);
    let s = n.dot(ray.origin - centre) + e.t_enter * sd;
    let (t, normal) = if s < near {
        if !(sd > 0.0) {
            return None;
        }
        (e.t_enter + (near - s) / sd, -n)
    } else if s > far {
        if !(sd < 0.0) {
            return None;
        }
        (e.t_enter + (far - s) / sd, n)
    } else {
        (e.t_enter, e.entry_normal)
    };
    (t <= e.t_exit).then_some(Hit {
        t,
        t_exit: e.t_exit,
        leaf: e.leaf,
        cell: e.cell,
        normal,
    })
}

/// The hit of `ray` on leaf entry `e` in `mode`.
#[inline]
pub fn leaf_hit(tree: &Octree, ray: &GridRay, e: &LeafEntry, mode: HitMode) -> Option<Hit> {
    match mode {
        HitMode::Cube | HitMode::Exact => Some(cube_hit(e)),
        HitMode::Contour => {
            let a = &tree.attributes;
            let (Some(nw), Some(cw)) = (
                channel_word(&a.normal, e.leaf),
                channel_word(&a.contour, e.leaf),
            ) else {
                return Some(cube_hit(e));
            };
            let n = normal_encoding::decode(nw);
            let (near, far) = contour::offsets(cw, n);
            slab_hit(ray, e, n, near, far)
        }
    }
}

#[inline]
fn channel_word(c: &Channel<u32>, i: u32) -> Option<u32> {
    match c {
        Channel::Absent => None,
        Channel::Constant(v) => Some(*v),
        Channel::PerLeaf(v) => v.get(i as usize).copied(),
    }
}

/// The first hit of `ray` in `[tmin, tmax]`, ignoring leaf `skip` (the leaf a secondary ray
/// starts from), with at most `max_steps` traversal steps.
pub fn cast(
    tree: &Octree,
    ray: &GridRay,
    tmin: f32,
    tmax: f32,
    mode: HitMode,
    skip: Option<u32>,
    max_steps: u32,
) -> Traversal<Hit> {
    traverse(tree, ray, tmin, tmax, max_steps, |e| {
        if Some(e.leaf) == skip {
            return None;
        }
        leaf_hit(tree, ray, e, mode)
    })
}
