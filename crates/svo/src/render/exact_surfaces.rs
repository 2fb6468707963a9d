//! The exact leaf hit (the 2019 report's O6b): the octree is traversed as usual, and in each
//! leaf the ray meets the mesh triangles that overlap it, so the hit has no geometric error
//! while the traversal and the leaf materials stay the octree's.
//!
//! The per-leaf triangle lists come from voxelizing the mesh again in the tree's own root
//! cube ([`crate::bake::bake_mesh::voxelize_mesh_in`]); a mesh whose leaves do not line up with the
//! tree's is refused. A hit counts when it lies in the leaf's closed cell (with a rounding
//! margin of `1e-4` cells), so a triangle crossing several leaves is met in the first one
//! the ray reaches it in.

use crate::bake::bake_mesh::voxelize_mesh_in;
use crate::geometry::grid::RootCube;
use crate::mesh::triangle_mesh::Mesh;
use crate::octree::tree::Octree;
use crate::render::surfaces::{LeafShape, OctreeSurfaces};
use crate::render::surfaces_error::SurfacesError;
use crate::trace::grid_ray::GridRay;
use crate::trace::traverse::LeafEntry;
use crate::voxelize::build::LeafTriangles;
use crate::voxelize::strategy::Strategy;
use glam::{UVec3, Vec3};

/// Margin of the in-cell test, in cells.
const CELL_MARGIN: f32 = 1e-4;

/// The triangles of each leaf: how [`HitMode::Exact`](crate::HitMode::Exact) hits a leaf.
#[derive(Debug)]
pub struct ExactLeaves {
    lists: LeafTriangles,
    /// For a solid tree, the list of each leaf (`u32::MAX` for interior leaves, which have
    /// none); empty when the tree's leaves are the lists' one for one.
    list_of: Vec<u32>,
    /// Grid-space vertices per triangle.
    tris: Vec<[Vec3; 3]>,
}

impl ExactLeaves {
    /// The triangles of `mesh` (the mesh `tree` was baked from) per leaf of `tree`; an error
    /// when the mesh is invalid or its leaves differ from the tree's.
    pub fn new(tree: &Octree, mesh: &Mesh) -> Result<Self, SurfacesError> {
        mesh.validate()?;
        let lists = voxelize_mesh_in(mesh, &tree.root, tree.depth, Strategy::Exact);
        // A solid tree's surface leaves are the mesh's, in the same (Morton) order, with
        // interior leaves between them.
        let a = &tree.attributes;
        let solid = a.has_interior();
        let surface = || {
            tree.leaves()
                .filter(move |l| !(solid && a.is_interior(l.index as usize)))
        };
        let surface_count = if solid {
            surface().count()
        } else {
            tree.leaf_count as usize
        };
        let same = lists.cells.len() == surface_count
            && surface()
                .zip(&lists.cells)
                .all(|(l, c)| l.cell == UVec3::from_array(*c));
        if !same {
            return Err(SurfacesError::NotTheSource {
                mesh_leaves: lists.cells.len(),
                tree_leaves: surface_count,
            });
        }
        let mut list_of = Vec::new();
        if solid {
            let mut next = 0u32;
            list_of = (0..tree.leaf_count as usize)
                .map(|i| {
                    if a.is_interior(i) {
                        u32::MAX
                    } else {
                        next += 1;
                        next - 1
                    }
                })
                .collect();
        }
        let root: RootCube = tree.root;
        let tris = mesh
            .triangles
            .iter()
            .map(|t| {
                t.map(|i| {
                    root.to_grid(mesh.positions[i as usize], tree.depth)
                        .as_vec3()
                })
            })
            .collect();
        Ok(Self {
            lists,
            list_of,
            tris,
        })
    }
}

/// The exact-mode surfaces of `tree` with the triangles of `mesh`, its source.
pub fn exact_surfaces<'a>(
    tree: &'a Octree,
    mesh: &Mesh,
) -> Result<OctreeSurfaces<'a, ExactLeaves>, SurfacesError> {
    Ok(OctreeSurfaces::with_shape(
        tree,
        ExactLeaves::new(tree, mesh)?,
    ))
}

impl LeafShape for ExactLeaves {
    /// The nearest triangle hit inside the leaf's closed cell (within `CELL_MARGIN`).
    fn hit(&self, _tree: &Octree, ray: &GridRay, e: &LeafEntry) -> Option<(f32, Vec3)> {
        let lo = e.cell.as_vec3() - CELL_MARGIN;
        let hi = e.cell.as_vec3() + 1.0 + CELL_MARGIN;
        let mut best: Option<(f32, Vec3)> = None;
        let list = match self.list_of.get(e.leaf as usize) {
            None => e.leaf as usize,
            Some(&u32::MAX) => return None,
            Some(&i) => i as usize,
        };
        for &ti in self.lists.triangles(list) {
            let [a, b, c] = self.tris[ti as usize];
            if let Some(t) = moller_trumbore(ray, a, b, c)
                && t >= e.t_enter
                && t <= e.t_exit
                && best.is_none_or(|(bt, _)| t < bt)
            {
                let p = ray.at(t);
                if p.cmpge(lo).all() && p.cmple(hi).all() {
                    best = Some((t, (b - a).cross(c - a).normalize_or_zero()));
                }
            }
        }
        best
    }
}

/// Ray/triangle intersection (Möller and Trumbore), two-sided, edges inclusive, computed in
/// `f64`: the parameter of a ray that meets the triangle at a grazing angle is ill-conditioned
/// (its rounding error grows as one over the angle's cosine), and in `f32` it can be off by
/// thousandths of a cell where the triangle reference is right.
#[inline]
fn moller_trumbore(ray: &GridRay, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let (origin, dir) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let e1 = b - a;
    let e2 = c - a;
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(q) * inv) as f32)
}
