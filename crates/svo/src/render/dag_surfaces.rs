//! A tree held as its graph ([`DagSurfaces`]): rays walk the [`DagTree`] (the tree's own walk
//! over the graph's nodes, [`DagTree::traverse`]) and hit its leaves as the tree's are hit, with
//! the leaves' channels the graph carries, so that a DAG file renders without its tree being
//! made. The walks are the tree's over the graph's nodes: one ray at a time, four together
//! (packets), and the primary prepass that projects the nodes front to back. The hits and
//! the image are the tree's.

use crate::dag::DagTree;
use crate::geometry::grid::RootCube;
use crate::octree::normal_encoding;
use crate::render::leaf_values::LeafValues;
use crate::render::primary_prepass::PrimaryBand;
use crate::render::surfaces::{FirstHit, Query, Skip, SurfaceHit, Surfaces, Traced, Walked};
use crate::render::whitted::PrimaryStart;
use crate::trace::cone::Cone;
use crate::trace::grid_ray::GridRay;
use crate::trace::leaf_hit::{HitMode, LeafTest};
use crate::trace::packet::{LANES, traverse_packet_on};
use crate::trace::traverse::{LeafEntry, Traversal};
use glam::Vec3;

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
            LeafTest::Cube => self.stored_normal_or(e, h.normal),
        };
        Some(self.values.hit_of(e, h.t, normal))
    }

    /// Entry `e`'s stored normal, decoded, or `geometric` where the leaves store none.
    #[inline]
    fn stored_normal_or(&self, e: &LeafEntry, geometric: Vec3) -> Vec3 {
        let a = self.values.attributes();
        a.normal
            .get(e.leaf as usize)
            .map_or(geometric, normal_encoding::decode)
    }

    /// The parameter of [`Self::surface_hit`] alone.
    #[inline]
    fn hit_t(&self, ray: &GridRay, e: &LeafEntry) -> Option<f32> {
        if self.values.passes_through(e.leaf) {
            return None;
        }
        let test = LeafTest::of_leaf(self.values.attributes(), e.leaf, self.mode);
        test.hit(ray, e).map(|h| h.t)
    }

    /// The packet walk of the graph ([`traverse_packet_on`]) for the lanes in `active`.
    #[allow(clippy::too_many_arguments)]
    fn packet<const NORMALS: bool, T>(
        &self,
        rays: &[GridRay; LANES],
        tmin: [f32; LANES],
        tmax: [f32; LANES],
        active: u8,
        max_steps: u32,
        on_leaf: impl FnMut(usize, &LeafEntry) -> Option<T>,
    ) -> [Traversal<T>; LANES] {
        let exact = [Cone::EXACT; LANES];
        let depth = self.dag.depth();
        traverse_packet_on::<NORMALS, DagTree, T>(
            self.dag, depth, rays, exact, tmin, tmax, active, max_steps, on_leaf,
        )
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

    fn primary_band(&self, band: &mut PrimaryBand<'_>) {
        // The graph keeps no inner-node values: no cone stops a ray (`level_of_detail`).
        let a = self.values.attributes();
        band.decide(
            (self.dag, self.dag.depth()),
            false,
            |leaf| {
                let through = self.values.passes_through(leaf);
                let test = LeafTest::of_leaf(a, leaf, self.mode);
                move |ray: &GridRay, e: &LeafEntry| {
                    if through {
                        None
                    } else {
                        test.hit(ray, e).map(|h| h.t)
                    }
                }
            },
            |_, _| |_: &GridRay, _: &LeafEntry| None,
        );
    }

    fn closest_primary(&self, ray: &GridRay, q: &Query, start: &PrimaryStart) -> Traced {
        // The entry the prepass hit at `t`, with the leaf's stored normal where it has one (a
        // contour's is that normal), else the face the ray entered through.
        let decided = |e: &LeafEntry, t| {
            let normal = self.stored_normal_or(e, e.entry_normal);
            Some(self.values.hit_of(e, t, normal))
        };
        Traced::from_start(q, start, decided, || self.closest(ray, q))
    }

    fn first_hit(&self, ray: &GridRay, q: &Query, start: &PrimaryStart) -> FirstHit {
        FirstHit::from_start(q, start, || self.closest(ray, q))
    }

    fn closest4(&self, rays: &[GridRay; LANES], q: &[Query; LANES], active: u8) -> [Traced; LANES] {
        let max_steps = q.iter().map(|q| q.max_steps).max().unwrap_or(0);
        if q.iter().any(|x| x.max_steps != max_steps) {
            return std::array::from_fn(|l| self.closest_lane(rays, q, active, l));
        }
        let mut run = [None; LANES];
        let (tmin, tmax) = (q.map(|q| q.tmin), q.map(|q| q.tmax));
        let r = self.packet::<true, _>(rays, tmin, tmax, active, max_steps, |l, e| {
            self.values
                .closest_at(&q[l], &mut run[l], e, || self.surface_hit(&rays[l], e))
        });
        std::array::from_fn(|l| {
            let r = &r[l];
            self.values
                .closest_of(&q[l], run[l], r.hit, r.steps, r.capped)
        })
    }

    fn first_hits(&self, rays: &[GridRay; LANES], n: usize, q: &Query) -> [FirstHit; LANES] {
        if q.medium.is_some() || q.skip.is_some() {
            return FirstHit::first_n(n, |l| self.closest(&rays[l], q).into());
        }
        let active = FirstHit::lanes_mask(n);
        let walks = self.packet::<true, _>(
            rays,
            [q.tmin; LANES],
            [q.tmax; LANES],
            active,
            q.max_steps,
            |l, e| self.hit_t(&rays[l], e).map(|t| (e.leaf, t)),
        );
        walks.each_ref().map(FirstHit::of)
    }

    fn walks(
        &self,
        rays: &[GridRay; LANES],
        tmax: [f32; LANES],
        skip: [Option<Skip>; LANES],
        _cones: [Cone; LANES],
        active: u8,
        max_steps: u32,
        visit: &mut dyn FnMut(usize, &SurfaceHit) -> bool,
    ) -> [Walked; LANES] {
        // The leaves' tests read no entry normals: the walk makes none and the hits carry no
        // shading normal (a walk's hits are for visibility), as on the tree.
        let r = self.packet::<false, _>(rays, [0.0; LANES], tmax, active, max_steps, |l, e| {
            if Skip::names(skip[l], e) {
                return None;
            }
            let h = self.values.hit_of(e, self.hit_t(&rays[l], e)?, Vec3::ZERO);
            visit(l, &h).then_some(())
        });
        r.each_ref().map(Walked::of)
    }

    fn walk(
        &self,
        ray: &GridRay,
        tmax: f32,
        skip: Option<Skip>,
        _cone: Cone,
        max_steps: u32,
        visit: &mut dyn FnMut(&SurfaceHit) -> bool,
    ) -> Walked {
        let r = self.dag.traverse(ray, 0.0, tmax, max_steps, |e| {
            if Skip::names(skip, e) {
                return None;
            }
            let h = self.surface_hit(ray, e)?;
            visit(&h).then_some(())
        });
        Walked::of(&r)
    }
}
