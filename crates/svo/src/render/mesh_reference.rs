//! The triangle reference: the original mesh traced through a BVH from the `obvhs` crate, in
//! the same grid space, camera, lights and shading as the octree, so every SVO image has a
//! ground truth to be measured against (RMSE, PSNR, hit/miss disagreement).
//!
//! Shading normals are the triangles' geometric normals (the winding decides which side is
//! out, as the voxelizer's leaf normals do); materials are the mesh's, with the texture
//! sampled at the hit point.

use crate::geometry::grid::RootCube;
use crate::mesh::triangle_mesh::Mesh;
use crate::render::surfaces::{Query, Skip, SurfaceHit, SurfaceMaterial, Surfaces, Traced, Walked};
use crate::trace::cone::Cone;
use crate::trace::grid_ray::GridRay;
use glam::{UVec3, Vec3, Vec3A};
use obvhs::bvh2::Bvh2;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;

/// A mesh ready to trace.
pub struct MeshSurfaces {
    root: RootCube,
    depth: u8,
    tris: Vec<Triangle>,
    normals: Vec<Vec3>,
    materials: Vec<SurfaceMaterial>,
    bvh: Bvh2,
    mesh: Mesh,
}

impl std::fmt::Debug for MeshSurfaces {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MeshSurfaces")
            .field("triangles", &self.tris.len())
            .finish_non_exhaustive()
    }
}

impl MeshSurfaces {
    /// Prepares `mesh` in the grid space of `root` at `depth` (use the octree's, so both
    /// render the same rays).
    pub fn new(mesh: Mesh, root: RootCube, depth: u8) -> Self {
        let g = |i: u32| Vec3A::from(root.to_grid(mesh.positions[i as usize], depth).as_vec3());
        let tris: Vec<Triangle> = mesh
            .triangles
            .iter()
            .map(|t| Triangle {
                v0: g(t[0]),
                v1: g(t[1]),
                v2: g(t[2]),
            })
            .collect();
        let normals = tris
            .iter()
            .map(|t| Vec3::from((t.v1 - t.v0).cross(t.v2 - t.v0).normalize_or_zero()))
            .collect();
        let materials = (0..tris.len())
            .map(|i| {
                let m = mesh.material_of(i);
                let (reflectivity, refractivity) = m.optics_at(m.colour[3]);
                SurfaceMaterial {
                    albedo: Vec3::new(m.colour[0], m.colour[1], m.colour[2]),
                    reflectivity,
                    refractivity,
                    ior: m.ior,
                }
            })
            .collect();
        let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(
            &tris,
            obvhs::BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        Self {
            root,
            depth,
            tris,
            normals,
            materials,
            bvh,
            mesh,
        }
    }

    /// Triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// Whether there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    fn hit_of(&self, id: u32, t: f32, ray: &GridRay) -> SurfaceHit {
        let mut material = self.materials[id as usize];
        let m = self.mesh.material_of(id as usize);
        if let (Some(tex), Some(uvi)) = (
            m.texture.and_then(|i| self.mesh.textures.get(i)),
            self.mesh.triangle_uvs.get(id as usize),
        ) {
            let b = barycentric(&self.tris[id as usize], ray);
            let uv = |i: u32| self.mesh.uvs.get(i as usize).copied().unwrap_or_default();
            let st = uv(uvi[0]) * (1.0 - b.x - b.y) + uv(uvi[1]) * b.x + uv(uvi[2]) * b.y;
            let s = tex.sample_linear(st);
            material.albedo *= Vec3::new(s[0], s[1], s[2]);
        }
        SurfaceHit {
            t,
            t_exit: t,
            id,
            cell: UVec3::ZERO,
            side: 1,
            normal: self.normals[id as usize],
            material,
            medium: None,
        }
    }
}

impl Surfaces for MeshSurfaces {
    fn grid(&self) -> (RootCube, u8) {
        (self.root, self.depth)
    }

    fn closest(&self, ray: &GridRay, q: &Query) -> Traced {
        let skip = q.skip.map(|s| s.id);
        let r = Ray::new(
            Vec3A::from(ray.origin),
            Vec3A::from(ray.dir),
            q.tmin,
            q.tmax,
        );
        let mut hit = RayHit::none();
        let found = self.bvh.ray_traverse(r, &mut hit, |r, i| {
            let id = self.bvh.primitive_indices[i];
            if Some(id) == skip {
                f32::INFINITY
            } else {
                self.tris[id as usize].intersect(r)
            }
        });
        Traced {
            hit: found.then(|| {
                self.hit_of(
                    self.bvh.primitive_indices[hit.primitive_id as usize],
                    hit.t,
                    ray,
                )
            }),
            steps: 0,
            capped: false,
        }
    }

    fn walk(
        &self,
        ray: &GridRay,
        tmax: f32,
        skip: Option<Skip>,
        _cone: Cone,
        _max_steps: u32,
        visit: &mut dyn FnMut(&SurfaceHit) -> bool,
    ) -> Walked {
        let skip = skip.map(|s| s.id);
        let r = Ray::new(Vec3A::from(ray.origin), Vec3A::from(ray.dir), 0.0, tmax);
        let mut hits: Vec<(f32, u32)> = Vec::new();
        self.bvh.ray_traverse_anyhit(r, |r, i| {
            let id = self.bvh.primitive_indices[i];
            if Some(id) != skip {
                let t = self.tris[id as usize].intersect(r);
                if t.is_finite() {
                    hits.push((t, id));
                }
            }
        });
        hits.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let blocked = hits.iter().any(|&(t, id)| visit(&self.hit_of(id, t, ray)));
        Walked {
            blocked,
            steps: 0,
            capped: false,
        }
    }
}

/// The barycentric coordinates `(b1, b2)` (the weights of the second and third vertices) of
/// where `ray`'s line meets `tri`'s plane. (obvhs 0.4's `Triangle::compute_barycentric`
/// divides by the unit normal instead of the edges' cross product, which scales both by
/// twice the triangle's area.)
fn barycentric(tri: &Triangle, ray: &GridRay) -> glam::Vec2 {
    let (o, d) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
    let e1 = tri.v0 - tri.v1;
    let e2 = tri.v2 - tri.v0;
    let ng = e1.cross(e2);
    let r = d.cross(tri.v0 - o);
    glam::Vec2::new(r.dot(e2), r.dot(e1)) / ng.dot(d)
}
