//! What the Whitted tracer traces: anything that can give the closest surface along a grid
//! ray and walk the surfaces along a shadow ray. The octree ([`OctreeSurfaces`]) is one; the
//! triangle reference ([`crate::render::mesh_reference`]) is the other, so both render through the
//! same camera, lights and shading and their images can be compared pixel for pixel.

use crate::geometry::grid::RootCube;
use crate::octree::tree::Octree;
use crate::render::leaf_values::{LeafValues, Run};
use crate::render::primary_prepass::PrimaryBand;
use crate::render::whitted::PrimaryStart;
use crate::trace::cone::Cone;
use crate::trace::grid_ray::GridRay;
use crate::trace::leaf_hit::{HitMode, LeafTest, leaf_hit};
use crate::trace::packet::{LANES, traverse_packet_with};
use crate::trace::traverse::{LeafEntry, Traversal, traverse_cone};
use glam::{UVec3, Vec3};

/// The material at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceMaterial {
    /// Linear albedo.
    pub albedo: Vec3,
    /// Reflectivity.
    pub reflectivity: f32,
    /// Refractivity.
    pub refractivity: f32,
    /// Index of refraction.
    pub ior: f32,
}

/// A volumetric medium: the raw refractivity, IOR and colour of transparent leaves that
/// carry no normal (solid blocks from the programmatic builder, as in the 2019 report's
/// scene). A ray inside one passes through its cells and stops where it leaves them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Medium(pub u64);

/// What a closest-hit query asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Query {
    /// The parameter range.
    pub tmin: f32,
    /// The parameter range.
    pub tmax: f32,
    /// A primitive to ignore (the one a secondary ray starts on).
    pub skip: Option<Skip>,
    /// The volumetric medium the ray travels in, if any.
    pub medium: Option<Medium>,
    /// The traversal step cap.
    pub max_steps: u32,
    /// The ray's footprint: surfaces with a level of detail (an octree with inner-node
    /// attributes) may stop at a node as wide as the cone there ([`crate::trace::Cone`]);
    /// [`Cone::EXACT`] for the exact surfaces.
    pub cone: Cone,
}

impl Query {
    /// The whole ray, nothing skipped, in the open, exact.
    pub fn all(max_steps: u32) -> Self {
        Self {
            tmin: 0.0,
            tmax: f32::INFINITY,
            skip: None,
            medium: None,
            max_steps,
            cone: Cone::EXACT,
        }
    }
}

/// The bit a [`SurfaceHit::id`] carries when the hit is on an inner node of an octree drawn in
/// place of its subtree (a walk with a footprint); the bits below it are the node's index.
pub const NODE_ID: u32 = 1 << 31;

/// The id of a hit on entry `e`: the leaf's index, or the node's with [`NODE_ID`].
#[inline]
pub(crate) fn entry_id(e: &LeafEntry) -> u32 {
    if e.side > 1 { NODE_ID | e.leaf } else { e.leaf }
}

/// The primitive a secondary ray starts on, which it does not hit again: the hit's id and
/// cell ([`SurfaceHit::id`], [`SurfaceHit::cell`]). Both are compared, because a graph whose
/// leaves take their values from an ancestor ([`crate::dag::DagTree::values_level`]) gives
/// the leaves below one ancestor the same id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Skip {
    /// The hit's id.
    pub id: u32,
    /// The hit's cell.
    pub cell: UVec3,
}

impl Skip {
    /// The primitive of hit `h`.
    #[inline]
    pub fn of(h: &SurfaceHit) -> Self {
        Self {
            id: h.id,
            cell: h.cell,
        }
    }

    /// Whether `skip` names entry `e` (the same id and cell).
    #[inline]
    pub(crate) fn names(skip: Option<Self>, e: &LeafEntry) -> bool {
        skip.is_some_and(|s| s.id == entry_id(e) && s.cell == e.cell)
    }
}

/// A ray's hit on a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceHit {
    /// Ray parameter (scene units along a unit scene direction).
    pub t: f32,
    /// Where the ray leaves the primitive's cell (octree) or `t` (triangles).
    pub t_exit: f32,
    /// Leaf or triangle index; an inner node's index with [`NODE_ID`] set.
    pub id: u32,
    /// The cell hit, in leaves (an inner node's minimum cell); zero for a triangle.
    pub cell: UVec3,
    /// The side of the cell hit, in leaves: 1 for a leaf or a triangle, more for an inner
    /// node drawn in place of its subtree. Secondary rays start that many times further off
    /// the surface.
    pub side: u32,
    /// The unit shading normal, oriented as the surface is (outwards for closed meshes), or
    /// zero if unknown.
    pub normal: Vec3,
    /// The material.
    pub material: SurfaceMaterial,
    /// The volumetric medium the primitive belongs to (a refracted ray entering it travels
    /// inside it), if any.
    pub medium: Option<Medium>,
}

/// The outcome of a closest-hit query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Traced {
    /// The closest hit.
    pub hit: Option<SurfaceHit>,
    /// Traversal steps.
    pub steps: u32,
    /// Whether the step cap stopped the ray.
    pub capped: bool,
}

impl Traced {
    /// No hit, no step.
    pub const NONE: Self = Self {
        hit: None,
        steps: 0,
        capped: false,
    };
}

/// The outcome of a ray cast ([`Surfaces::first_hit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstHit {
    /// The primitive (leaf or triangle) hit and the hit's parameter.
    pub hit: Option<(u32, f32)>,
    /// Traversal steps.
    pub steps: u32,
    /// Whether the step cap stopped the ray.
    pub capped: bool,
}

impl FirstHit {
    /// What a ray cast returns for a ray the prepass decided (its hit or its miss), `None`
    /// for one it left to the traversal.
    pub fn decided(start: &PrimaryStart) -> Option<Self> {
        match *start {
            PrimaryStart::From(_) => None,
            PrimaryStart::Miss { tests } => Some(Self {
                hit: None,
                steps: tests,
                capped: false,
            }),
            PrimaryStart::Leaf { entry, t, tests } => Some(Self {
                hit: Some((entry_id(&entry), t)),
                steps: tests,
                capped: false,
            }),
        }
    }
}

impl FirstHit {
    /// No hit, no step.
    pub const MISS: Self = Self {
        hit: None,
        steps: 0,
        capped: false,
    };

    /// The first `n` lanes' outcomes, `each(lane)`, the lanes from `n` on missed without a
    /// step.
    pub(crate) fn first_n(n: usize, each: impl Fn(usize) -> Self) -> [Self; LANES] {
        std::array::from_fn(|l| if l < n { each(l) } else { Self::MISS })
    }

    /// The mask of the first `n` of [`LANES`] lanes (bit `l` for lane `l`).
    pub(crate) fn lanes_mask(n: usize) -> u8 {
        ((1u16 << n.min(LANES)) - 1) as u8
    }

    /// A ray cast's outcome from its walk, whose hits are `(id, t)`.
    pub(crate) fn of(r: &Traversal<(u32, f32)>) -> Self {
        Self {
            hit: r.hit,
            steps: r.steps,
            capped: r.capped,
        }
    }

    /// [`Surfaces::first_hit`] of surfaces that decide primary rays: what the prepass
    /// decided (`start`), else, or for a secondary query, `closest`'s.
    pub(crate) fn from_start(
        q: &Query,
        start: &PrimaryStart,
        closest: impl FnOnce() -> Traced,
    ) -> Self {
        if q.medium.is_some() || q.skip.is_some() {
            return closest().into();
        }
        Self::decided(start).unwrap_or_else(|| closest().into())
    }
}

impl Traced {
    /// [`Surfaces::closest_primary`] of surfaces that decide primary rays: the prepass's
    /// miss, its hit (`decided` of the entry it hit at `t`, where that gives one), else, or
    /// for a secondary query, `closest`'s.
    pub(crate) fn from_start(
        q: &Query,
        start: &PrimaryStart,
        decided: impl FnOnce(&LeafEntry, f32) -> Option<SurfaceHit>,
        closest: impl FnOnce() -> Traced,
    ) -> Self {
        if q.medium.is_some() || q.skip.is_some() {
            return closest();
        }
        match *start {
            PrimaryStart::From(_) => closest(),
            PrimaryStart::Miss { tests } => Self {
                hit: None,
                steps: tests,
                capped: false,
            },
            PrimaryStart::Leaf { entry, t, tests } => match decided(&entry, t) {
                Some(h) => Self {
                    hit: Some(h),
                    steps: tests,
                    capped: false,
                },
                // Not reached: the prepass hit the same entry.
                None => closest(),
            },
        }
    }
}

impl From<Traced> for FirstHit {
    fn from(r: Traced) -> Self {
        Self {
            hit: r.hit.map(|h| (h.id, h.t)),
            steps: r.steps,
            capped: r.capped,
        }
    }
}

/// The outcome of a shadow walk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Walked {
    /// Whether the visitor stopped the walk (the light is blocked).
    pub blocked: bool,
    /// Traversal steps.
    pub steps: u32,
    /// Whether the step cap stopped the ray.
    pub capped: bool,
}

impl Walked {
    /// Not walked: nothing met, no step.
    pub const NONE: Self = Self {
        blocked: false,
        steps: 0,
        capped: false,
    };

    /// A walk's outcome from its traversal: blocked where the visitor stopped it.
    pub(crate) fn of<T>(r: &Traversal<T>) -> Self {
        Self {
            blocked: r.hit.is_some(),
            steps: r.steps,
            capped: r.capped,
        }
    }
}

/// Surfaces a [`Tracer`](crate::render::Tracer) can trace, in the grid space of a root cube:
/// the octree ([`OctreeSurfaces`]) and the triangle reference
/// ([`MeshSurfaces`](crate::render::MeshSurfaces)). Implement [`Self::grid`], [`Self::closest`]
/// and [`Self::walk`] to render surfaces of one's own through the same camera, lights and
/// shading.
pub trait Surfaces: Sync {
    /// The root cube and depth whose grid space the rays are in.
    fn grid(&self) -> (RootCube, u8);

    /// The closest hit (a boundary of the query's medium, when it has one).
    fn closest(&self, ray: &GridRay, q: &Query) -> Traced;

    /// [`Self::closest`] for the lanes of `rays` in `active` (bit `l` for lane `l`), lane
    /// `l` under query `q[l]`: the same outcome per lane. Surfaces that walk rays in packets
    /// (the octree) walk them together; lanes outside `active` are missed without a step.
    #[doc(hidden)]
    fn closest4(&self, rays: &[GridRay; LANES], q: &[Query; LANES], active: u8) -> [Traced; LANES] {
        std::array::from_fn(|l| self.closest_lane(rays, q, active, l))
    }

    /// Lane `l` of [`Self::closest4`], alone.
    #[doc(hidden)]
    fn closest_lane(
        &self,
        rays: &[GridRay; LANES],
        q: &[Query; LANES],
        active: u8,
        l: usize,
    ) -> Traced {
        if active >> l & 1 == 0 {
            return Traced::NONE;
        }
        self.closest(&rays[l], &q[l])
    }

    /// Whether a ray's cone ([`Query::cone`]) can stop it before the finest surface: an
    /// octree whose inner nodes carry attributes. Renders with a level of detail trace the
    /// rays of others exactly, as they would without one.
    fn level_of_detail(&self) -> bool {
        false
    }

    /// Decides the primary rays of a band of image rows at once, where the surfaces know
    /// how (the octree: its primary prepass); others leave the band's starts as they
    /// are (every ray traced from the eye).
    #[doc(hidden)]
    fn primary_band(&self, band: &mut PrimaryBand<'_>) {
        let _ = band;
    }

    /// The closest hit of a primary ray with what the render's prepass knows of it
    /// (`start`): the same as [`Self::closest`] from the start's lower bound (which this
    /// does by default: only surfaces that decide bands get decided starts).
    #[doc(hidden)]
    fn closest_primary(&self, ray: &GridRay, q: &Query, start: &PrimaryStart) -> Traced {
        let _ = start;
        self.closest(ray, q)
    }

    /// [`Self::closest_primary`] reduced to what a ray cast returns: the primitive hit and
    /// its parameter (the same as `closest_primary` gives; surfaces may skip the normal and
    /// material).
    #[doc(hidden)]
    fn first_hit(&self, ray: &GridRay, q: &Query, start: &PrimaryStart) -> FirstHit {
        self.closest_primary(ray, q, start).into()
    }

    /// [`Self::first_hit`] for the first `n` of up to [`LANES`] rays traced from `q.tmin`
    /// (no prepass start): the same outcome per ray. Surfaces that walk rays in packets
    /// (the octree: [`crate::trace::traverse_packet`]) trace them together; lanes from `n`
    /// on are missed without a step.
    #[doc(hidden)]
    fn first_hits(&self, rays: &[GridRay; LANES], n: usize, q: &Query) -> [FirstHit; LANES] {
        FirstHit::first_n(n, |l| {
            self.first_hit(&rays[l], q, &PrimaryStart::From(q.tmin))
        })
    }

    /// Calls `visit` for the hits in `[0, tmax]` front to back (ignoring `skip`) until it
    /// returns `true`; surfaces with a level of detail may stop at nodes as wide as `cone`.
    fn walk(
        &self,
        ray: &GridRay,
        tmax: f32,
        skip: Option<Skip>,
        cone: Cone,
        max_steps: u32,
        visit: &mut dyn FnMut(&SurfaceHit) -> bool,
    ) -> Walked;

    /// [`Self::walk`] for the lanes of `rays` in `active` (bit `l` for lane `l`), with
    /// `visit(l, hit)` per lane: the same outcome per lane as `walk` alone. Surfaces that walk
    /// rays in packets (the octree) walk them together; lanes outside `active` are not walked.
    /// A hit's `normal` may be zero here (the octree leaves it out where its leaves' test does
    /// not need it).
    #[doc(hidden)]
    #[allow(clippy::too_many_arguments)]
    fn walks(
        &self,
        rays: &[GridRay; LANES],
        tmax: [f32; LANES],
        skip: [Option<Skip>; LANES],
        cones: [Cone; LANES],
        active: u8,
        max_steps: u32,
        visit: &mut dyn FnMut(usize, &SurfaceHit) -> bool,
    ) -> [Walked; LANES] {
        std::array::from_fn(|l| {
            if active >> l & 1 == 0 {
                return Walked::NONE;
            }
            self.walk(&rays[l], tmax[l], skip[l], cones[l], max_steps, &mut |h| {
                visit(l, h)
            })
        })
    }
}

/// How an octree's leaves are intersected: the leaf hit modes of [`crate::trace::leaf_hit`], or
/// the leaves' triangles ([`crate::render::exact_surfaces::ExactLeaves`]).
pub trait LeafShape: Sync {
    /// The hit of `ray` inside leaf entry `e`: its parameter and unit shading normal (for a
    /// mode without its own, the leaf's stored normal, else the geometric one).
    fn hit(&self, tree: &Octree, ray: &GridRay, e: &LeafEntry) -> Option<(f32, Vec3)>;

    /// The parameter of [`Self::hit`] alone.
    fn hit_t(&self, tree: &Octree, ray: &GridRay, e: &LeafEntry) -> Option<f32> {
        self.hit(tree, ray, e).map(|h| h.0)
    }

    /// [`Self::hit`] of entry `e`, known to be hit at parameter `t` (found by
    /// [`Self::leaf_hit_t`] on the same ray and entry): the same parameter and normal. Shapes
    /// whose normal does not depend on the ray's path through the cell need not test again.
    fn hit_at(&self, tree: &Octree, ray: &GridRay, e: &LeafEntry, t: f32) -> Option<(f32, Vec3)> {
        let _ = t;
        self.hit(tree, ray, e)
    }

    /// [`Self::hit_t`] for entries of leaf `leaf` only, for testing many rays against one leaf
    /// (what a shape reads of the leaf may be read once).
    fn leaf_hit_t<'a>(
        &'a self,
        tree: &'a Octree,
        leaf: u32,
    ) -> impl Fn(&GridRay, &LeafEntry) -> Option<f32> + 'a {
        let _ = leaf;
        move |ray, e| self.hit_t(tree, ray, e)
    }

    /// How an inner node drawn in place of its subtree (a walk with a footprint) is hit: its
    /// contour ([`HitMode::Contour`], the default) or its cube ([`HitMode::Cube`]).
    fn node_mode(&self) -> HitMode {
        HitMode::Contour
    }

    /// Whether [`Self::leaf_hit_t`]'s answer depends on the entry's face normals
    /// ([`LeafEntry::entry_normal`], [`LeafEntry::exit_normal`]). Where it does not, the
    /// primary prepass tests its entries with those left zero and works them out for the
    /// hits alone (an entry a hit keeps has them, as always).
    fn hit_t_reads_normals(&self) -> bool {
        true
    }
}

impl LeafShape for HitMode {
    #[inline]
    fn hit(&self, tree: &Octree, ray: &GridRay, e: &LeafEntry) -> Option<(f32, Vec3)> {
        let test = LeafTest::of_entry(tree, e, *self);
        let h = test.hit(ray, e)?;
        let n = match test {
            // The slab's normal is the stored one, decoded.
            LeafTest::Slab { n, .. } => n,
            LeafTest::Cube => stored_normal_or(tree, e, h.normal),
        };
        Some((h.t, n))
    }

    #[inline]
    fn hit_t(&self, tree: &Octree, ray: &GridRay, e: &LeafEntry) -> Option<f32> {
        leaf_hit(tree, ray, e, *self).map(|h| h.t)
    }

    /// The stored normal wherever there is one (a slab's normal is that normal decoded), else
    /// the face the ray entered through: [`Self::hit`]'s normal without the test.
    #[inline]
    fn hit_at(&self, tree: &Octree, _: &GridRay, e: &LeafEntry, t: f32) -> Option<(f32, Vec3)> {
        Some((t, stored_normal_or(tree, e, e.entry_normal)))
    }

    #[inline]
    fn leaf_hit_t<'a>(
        &'a self,
        tree: &'a Octree,
        leaf: u32,
    ) -> impl Fn(&GridRay, &LeafEntry) -> Option<f32> + 'a {
        let test = LeafTest::new(tree, leaf, *self);
        move |ray, e| test.hit(ray, e).map(|h| h.t)
    }

    fn node_mode(&self) -> HitMode {
        match self {
            Self::Cube => Self::Cube,
            _ => Self::Contour,
        }
    }

    /// The cube's and the slab's parameters come from the entry's parameters alone.
    #[inline]
    fn hit_t_reads_normals(&self) -> bool {
        false
    }
}

/// Entry `e`'s stored normal (its leaf's, or its inner node's), decoded, or `geometric`
/// where the tree stores none.
#[inline]
fn stored_normal_or(tree: &Octree, e: &LeafEntry, geometric: Vec3) -> Vec3 {
    let a = if e.side > 1 {
        &tree.node_attributes
    } else {
        &tree.attributes
    };
    a.normal
        .get(e.leaf as usize)
        .map_or(geometric, crate::octree::normal_encoding::decode)
}

/// An octree traced with a leaf shape: one of the hit modes by default.
#[derive(Clone, Debug)]
pub struct OctreeSurfaces<'a, L = HitMode> {
    tree: &'a Octree,
    shape: L,
    values: LeafValues<'a>,
    /// Whether the inner nodes carry attributes: only then may a ray's cone stop at them.
    coarse: bool,
}

impl<'a> OctreeSurfaces<'a> {
    /// `tree` hit in `mode`.
    pub fn new(tree: &'a Octree, mode: HitMode) -> Self {
        Self::with_shape(tree, mode)
    }
}

impl<'a, L: LeafShape> OctreeSurfaces<'a, L> {
    /// `tree` hit as `shape` says.
    pub fn with_shape(tree: &'a Octree, shape: L) -> Self {
        Self {
            tree,
            shape,
            values: LeafValues::new(&tree.attributes),
            coarse: !tree.node_attributes.stored().is_empty(),
        }
    }

    /// The tree.
    pub fn tree(&self) -> &'a Octree {
        self.tree
    }

    /// The material of leaf `i`, with defaults for absent channels (grey 0.8, not
    /// reflective, opaque, IOR 1.5).
    #[inline]
    pub fn material(&self, i: u32) -> SurfaceMaterial {
        self.values.material(i)
    }

    /// Whether rays pass through leaf `i`: an interior cell of a solid.
    #[inline]
    fn passes_through(&self, i: u32) -> bool {
        self.values.passes_through(i)
    }

    /// The cone a walk with `cone` uses here: none where the inner nodes carry nothing, or
    /// where it never reaches the width of the narrowest node that can stop it (4 cells: leaf
    /// parents keep no values), which walks the same and may go in packets.
    #[inline]
    fn cone(&self, cone: Cone) -> Cone {
        if self.coarse && !(cone.spread <= 0.0 && cone.width < 4.0) {
            cone
        } else {
            Cone::EXACT
        }
    }

    /// The surface hit of leaf entry `e`, if the shape is hit.
    #[inline]
    fn surface_hit(&self, ray: &GridRay, e: &LeafEntry) -> Option<SurfaceHit> {
        if e.side > 1 {
            return self.node_hit(ray, e);
        }
        if self.passes_through(e.leaf) {
            return None;
        }
        let (t, normal) = self.shape.hit(self.tree, ray, e)?;
        Some(self.hit_of(e, t, normal))
    }

    /// [`Self::surface_hit`] of an entry the prepass found hit at `t`.
    #[inline]
    fn decided_hit(&self, ray: &GridRay, e: &LeafEntry, t: f32) -> Option<SurfaceHit> {
        if e.side > 1 {
            return self.node_hit(ray, e);
        }
        let (t, normal) = self.shape.hit_at(self.tree, ray, e, t)?;
        Some(self.hit_of(e, t, normal))
    }

    /// The hit of an inner node's entry `e` (a walk with a footprint): its contour or cube
    /// ([`LeafShape::node_mode`]) with the node's attributes.
    fn node_hit(&self, ray: &GridRay, e: &LeafEntry) -> Option<SurfaceHit> {
        let test = LeafTest::of_entry(self.tree, e, self.shape.node_mode());
        let h = test.hit(ray, e)?;
        let normal = match test {
            LeafTest::Slab { n, .. } => n,
            LeafTest::Cube => stored_normal_or(self.tree, e, h.normal),
        };
        Some(SurfaceHit {
            t: h.t,
            t_exit: e.t_exit,
            id: entry_id(e),
            cell: e.cell,
            side: e.side,
            normal,
            material: self.values.material_in(&self.tree.node_attributes, e.leaf),
            medium: None,
        })
    }

    /// The hit of entry `e` at `t` with shading normal `normal`: the leaf's material and
    /// medium read.
    #[inline]
    fn hit_of(&self, e: &LeafEntry, t: f32, normal: Vec3) -> SurfaceHit {
        self.values.hit_of(e, t, normal)
    }

    /// The closest-hit walk's callback for leaf entry `e` of `ray` under query `q`.
    #[inline]
    fn closest_at(
        &self,
        ray: &GridRay,
        q: &Query,
        run: &mut Run,
        e: &LeafEntry,
    ) -> Option<SurfaceHit> {
        self.values
            .closest_at(q, run, e, || self.surface_hit(ray, e))
    }

    /// The volumetric medium of leaf `i`: transparent and without a stored normal.
    #[inline]
    pub fn medium_of(&self, i: u32) -> Option<Medium> {
        self.values.medium_of(i)
    }
}

impl<L: LeafShape> Surfaces for OctreeSurfaces<'_, L> {
    fn grid(&self) -> (RootCube, u8) {
        (self.tree.root, self.tree.depth)
    }

    fn level_of_detail(&self) -> bool {
        self.coarse
    }

    fn primary_band(&self, band: &mut PrimaryBand<'_>) {
        band.decide(
            (self.tree, self.tree.depth),
            self.shape.hit_t_reads_normals(),
            |leaf| {
                let through = self.passes_through(leaf);
                let hit_t = self.shape.leaf_hit_t(self.tree, leaf);
                move |ray: &GridRay, e: &LeafEntry| if through { None } else { hit_t(ray, e) }
            },
            |node, side| {
                let test = LeafTest::of_node(self.tree, node, side, self.shape.node_mode());
                move |ray: &GridRay, e: &LeafEntry| test.hit(ray, e).map(|h| h.t)
            },
        );
    }

    fn closest_primary(&self, ray: &GridRay, q: &Query, start: &PrimaryStart) -> Traced {
        let decided = |e: &LeafEntry, t| self.decided_hit(ray, e, t);
        Traced::from_start(q, start, decided, || self.closest(ray, q))
    }

    fn first_hit(&self, ray: &GridRay, q: &Query, start: &PrimaryStart) -> FirstHit {
        FirstHit::from_start(q, start, || self.closest(ray, q))
    }

    fn first_hits(&self, rays: &[GridRay; LANES], n: usize, q: &Query) -> [FirstHit; LANES] {
        if q.medium.is_some() || q.skip.is_some() {
            return FirstHit::first_n(n, |l| self.closest(&rays[l], q).into());
        }
        let active = FirstHit::lanes_mask(n);
        let walks = traverse_packet_with::<true, _>(
            self.tree,
            rays,
            [self.cone(q.cone); LANES],
            [q.tmin; LANES],
            [q.tmax; LANES],
            active,
            q.max_steps,
            |l, e| {
                if e.side > 1 {
                    return self.node_hit(&rays[l], e).map(|h| (h.id, h.t));
                }
                if self.passes_through(e.leaf) {
                    return None;
                }
                self.shape
                    .hit_t(self.tree, &rays[l], e)
                    .map(|t| (e.leaf, t))
            },
        );
        walks.each_ref().map(FirstHit::of)
    }

    fn closest(&self, ray: &GridRay, q: &Query) -> Traced {
        let mut run = None;
        let cone = self.cone(q.cone);
        let r = traverse_cone(self.tree, ray, cone, q.tmin, q.tmax, q.max_steps, |e| {
            self.closest_at(ray, q, &mut run, e)
        });
        self.values.closest_of(q, run, r.hit, r.steps, r.capped)
    }

    fn closest4(&self, rays: &[GridRay; LANES], q: &[Query; LANES], active: u8) -> [Traced; LANES] {
        let max_steps = q.iter().map(|q| q.max_steps).max().unwrap_or(0);
        if q.iter().any(|x| x.max_steps != max_steps) {
            return std::array::from_fn(|l| self.closest_lane(rays, q, active, l));
        }
        let mut run = [None; LANES];
        let r = traverse_packet_with::<true, _>(
            self.tree,
            rays,
            q.map(|q| self.cone(q.cone)),
            q.map(|q| q.tmin),
            q.map(|q| q.tmax),
            active,
            max_steps,
            |l, e| self.closest_at(&rays[l], &q[l], &mut run[l], e),
        );
        std::array::from_fn(|l| {
            self.values
                .closest_of(&q[l], run[l], r[l].hit, r[l].steps, r[l].capped)
        })
    }

    fn walk(
        &self,
        ray: &GridRay,
        tmax: f32,
        skip: Option<Skip>,
        cone: Cone,
        max_steps: u32,
        visit: &mut dyn FnMut(&SurfaceHit) -> bool,
    ) -> Walked {
        let cone = self.cone(cone);
        let r = traverse_cone(self.tree, ray, cone, 0.0, tmax, max_steps, |e| {
            if Skip::names(skip, e) {
                return None;
            }
            let h = self.surface_hit(ray, e)?;
            visit(&h).then_some(())
        });
        Walked::of(&r)
    }

    fn walks(
        &self,
        rays: &[GridRay; LANES],
        tmax: [f32; LANES],
        skip: [Option<Skip>; LANES],
        cones: [Cone; LANES],
        active: u8,
        max_steps: u32,
        visit: &mut dyn FnMut(usize, &SurfaceHit) -> bool,
    ) -> [Walked; LANES] {
        // Where the shape's test reads no entry normals, the walk makes none and the hits
        // carry no shading normal (a walk's hits are for visibility).
        let normals = self.shape.hit_t_reads_normals();
        let cones = cones.map(|c| self.cone(c));
        let on_leaf = |l: usize, e: &LeafEntry| {
            if Skip::names(skip[l], e) {
                return None;
            }
            let h = if normals || e.side > 1 {
                self.surface_hit(&rays[l], e)?
            } else if self.passes_through(e.leaf) {
                return None;
            } else {
                self.hit_of(e, self.shape.hit_t(self.tree, &rays[l], e)?, Vec3::ZERO)
            };
            visit(l, &h).then_some(())
        };
        let (tree, tmin) = (self.tree, [0.0; LANES]);
        let r = if normals {
            traverse_packet_with::<true, _>(
                tree, rays, cones, tmin, tmax, active, max_steps, on_leaf,
            )
        } else {
            traverse_packet_with::<false, _>(
                tree, rays, cones, tmin, tmax, active, max_steps, on_leaf,
            )
        };
        r.each_ref().map(Walked::of)
    }
}
