//! Casting rays in scene units: the first leaf a ray hits, where, and the normal there.

use crate::octree::tree::Octree;
use crate::trace::grid_ray::GridRay;
use crate::trace::leaf_hit::{HitMode, cast};
use crate::trace::traverse::MAX_STEPS;
use glam::{DVec3, UVec3};

/// A ray in scene space: the points `origin + t * dir` for `t >= 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts, scene units.
    pub origin: DVec3,
    /// Its direction (any length; hit parameters are measured in its units, so with a unit
    /// direction they are distances).
    pub dir: DVec3,
}

impl Ray {
    /// The ray from `origin` along `dir`.
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        Self { origin, dir }
    }
}

/// Where a ray first hits a leaf, in scene units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// The ray parameter: the hit is `origin + t * dir` (the distance for a unit `dir`).
    pub t: f64,
    /// The hit point.
    pub point: DVec3,
    /// The geometric unit normal at the hit, facing the ray: the face of the cell the ray
    /// entered through, or the contour plane it met; zero for a ray that starts inside the
    /// surface.
    pub normal: DVec3,
    /// The leaf's index in the leaf arrays.
    pub leaf: u32,
    /// The leaf's cell (grid coordinates at the tree's depth).
    pub cell: UVec3,
}

impl Octree {
    /// The first leaf surface `ray` hits ([`HitMode::Contour`]: the slab between the leaf's
    /// contour planes where the tree has contours, else the cell cube), or `None` if it hits
    /// nothing, has a zero or non-finite direction, or starts off at infinity.
    ///
    /// The traversal runs in `f32` in the tree's grid space, as on the GPU, and never misses
    /// a leaf the ray enters; the parameter `t` comes back in the units of `ray.dir`.
    ///
    /// ```
    /// use glam::{DVec3, UVec3};
    /// use svo::{Octree, Ray, RootCube, Voxel};
    /// // One cell, [1, 2]^3, in a 4^3 grid over [0, 4]^3.
    /// let root = RootCube { origin: DVec3::ZERO, side: 4.0 };
    /// let tree = Octree::from_cells(root, 2, [(UVec3::ONE, Voxel::default())])?;
    /// let hit = tree.cast(Ray::new(DVec3::new(-1.0, 1.5, 1.5), DVec3::X)).unwrap();
    /// assert_eq!(hit.t, 2.0);
    /// assert_eq!(hit.point, DVec3::new(1.0, 1.5, 1.5));
    /// assert_eq!(hit.normal, -DVec3::X);
    /// # Ok::<(), svo::OctreeError>(())
    /// ```
    pub fn cast(&self, ray: Ray) -> Option<Hit> {
        self.cast_with(ray, HitMode::Contour)
    }

    /// [`Octree::cast`] with the leaves hit as `mode` says ([`HitMode::Exact`] needs the
    /// mesh's triangles, which only a renderer has: here it is the cube).
    pub fn cast_with(&self, ray: Ray, mode: HitMode) -> Option<Hit> {
        let g = GridRay::from_scene(&self.root, self.depth, ray.origin, ray.dir);
        if !g.is_valid() {
            return None;
        }
        let h = cast(self, &g, 0.0, f32::INFINITY, mode, None, MAX_STEPS).hit?;
        let t = f64::from(h.t);
        Some(Hit {
            t,
            point: ray.origin + ray.dir * t,
            normal: h.normal.as_dvec3(),
            leaf: h.leaf,
            cell: h.cell,
        })
    }

    /// [`Octree::cast_with`] for many rays, in parallel with the `parallel` feature; the
    /// hits come back in the rays' order.
    pub fn cast_many(&self, rays: &[Ray], mode: HitMode) -> Vec<Option<Hit>> {
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            rays.par_iter().map(|r| self.cast_with(*r, mode)).collect()
        }
        #[cfg(not(feature = "parallel"))]
        rays.iter().map(|r| self.cast_with(*r, mode)).collect()
    }
}
