//! A tree held as its graph ([`DagSurfaces`]): rays walk the [`DagTree`] (the tree's own walk
//! over the graph's nodes, [`DagTree::traverse`]) and hit its leaves as the tree's are hit, with
//! the leaves' channels the graph carries, so that a DAG file renders without its tree being
//! made. The walks are single rays (no primary prepass, no packets), which give the same hits
//! and the same image as the tree's.

use crate::dag::DagTree;
use crate::geometry::grid::RootCube;
use crate::octree::normal_encoding;
use crate::render::leaf_values::LeafValues;
use crate::render::surfaces::{Query, SurfaceHit, Surfaces, Traced, Walked, entry_id};
use crate::trace::cone::Cone;
use crate::trace::grid_ray::GridRay;
use crate::trace::leaf_hit::{HitMode, LeafTest};
use crate::trace::traverse::LeafEntry;

/// The surfaces of a graph's leaves (a tree's geometry with identical subtrees stored once),
/// hit in one of the [`HitMode`]s ([`HitMode::Exact`], which needs the triangles, as cubes):
/// the same hits as [`crate::render::OctreeSurfaces`] on the tree the graph was made of, hits
/// numbered by the tree's leaf index.
///
/// ```
/// use glam::{DVec3, Vec3};
/// use svo::dag::DagTree;
/// use svo::render::{Camera, DagSurfaces, OctreeSurfaces, Phong, PointLight, Sky};
/// use svo::render::{TraceOptions, Tracer, render};
/// use svo::trace::HitMode;
/// use svo::{BakeOptions, Mesh, bake_mesh};
/// let tree = bake_mesh(&Mesh::sphere(DVec3::splat(0.5), 0.4, 16), &BakeOptions::default())?.0;
/// let dag = DagTree::from_tree(&tree)?; // the tree's geometry as a graph, its leaves' values
/// let camera = Camera::framing(DVec3::ZERO, DVec3::ONE, 64, 48, 40.0);
/// let position = DVec3::new(2.0, 2.0, 2.0);
/// let light = [PointLight { position, colour: Vec3::ONE, intensity: 4.0 }];
/// let opts = TraceOptions::default();
/// let on_tree = OctreeSurfaces::new(&tree, HitMode::Contour);
/// let a = render(&Tracer::new(on_tree, &light, Sky::default(), Phong::default(), opts), &camera)?;
/// let on_dag = DagSurfaces::new(&dag, HitMode::Contour);
/// let b = render(&Tracer::new(on_dag, &light, Sky::default(), Phong::default(), opts), &camera)?;
/// assert_eq!(a.colour, b.colour); // the same image
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct DagSurfaces<'a> {
    dag: &'a DagTree,
    mode: HitMode,
    values: LeafValues<'a>,
}

impl<'a> DagSurfaces<'a> {
    /// `dag`'s leaves hit in `mode`, with the channels it carries ([`DagTree::attributes`]).
    pub fn new(dag: &'a DagTree, mode: HitMode) -> Self {
        Self {
            dag,
            mode,
            values: LeafValues::new(dag.attributes()),
        }
    }

    /// The surface hit of leaf entry `e`, if the leaf is hit: its contour or cube, as
    /// [`HitMode`]'s leaf shape hits a tree's leaf.
    #[inline]
    fn surface_hit(&self, ray: &GridRay, e: &LeafEntry) -> Option<SurfaceHit> {
        if self.values.passes_through(e.leaf) {
            return None;
        }
        let a = self.values.attributes();
        let test = LeafTest::of_leaf(a, e.leaf, self.mode);
        let h = test.hit(ray, e)?;
        let normal = match test {
            LeafTest::Slab { n, .. } => n,
            LeafTest::Cube => a
                .normal
                .get(e.leaf as usize)
                .map_or(h.normal, normal_encoding::decode),
        };
        Some(self.values.hit_of(e, h.t, normal))
    }
}

impl Surfaces for DagSurfaces<'_> {
    fn grid(&self) -> (RootCube, u8) {
        (self.dag.root(), self.dag.depth())
    }

    fn closest(&self, ray: &GridRay, q: &Query) -> Traced {
        let mut run = None;
        let r = self.dag.traverse(ray, q.tmin, q.tmax, q.max_steps, |e| {
            self.values
                .closest_at(q, &mut run, e, || self.surface_hit(ray, e))
        });
        self.values.closest_of(q, run, r.hit, r.steps, r.capped)
    }

    fn walk(
        &self,
        ray: &GridRay,
        tmax: f32,
        skip: Option<u32>,
        _cone: Cone,
        max_steps: u32,
        visit: &mut dyn FnMut(&SurfaceHit) -> bool,
    ) -> Walked {
        let r = self.dag.traverse(ray, 0.0, tmax, max_steps, |e| {
            if Some(entry_id(e)) == skip {
                return None;
            }
            let h = self.surface_hit(ray, e)?;
            visit(&h).then_some(())
        });
        Walked {
            blocked: r.hit.is_some(),
            steps: r.steps,
            capped: r.capped,
        }
    }
}
