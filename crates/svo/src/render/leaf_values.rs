//! What the renderer reads of a tree's stored values, whatever holds its geometry (the tree's
//! nodes or its graph, [`crate::render::DagSurfaces`]): a leaf's or a node's material, the
//! volumetric medium of a leaf, and how a closest-hit walk crosses a medium's cells.

use crate::mesh::triangle_mesh::srgb_to_linear;
use crate::octree::encoding::ior_decode;
use crate::octree::tree::LeafAttributes;
use crate::render::surfaces::{Medium, Query, Skip, SurfaceHit, SurfaceMaterial, Traced};
use crate::trace::traverse::LeafEntry;
use glam::{UVec3, Vec3};

/// Where a ray inside a medium has come to: the exit parameter and outward normal of the last
/// cell of the medium's run along it, and that cell's leaf and cell.
pub(crate) type Run = Option<(f32, Vec3, u32, UVec3)>;

/// A tree's leaf channels as the renderer reads them.
#[derive(Clone, Debug)]
pub(crate) struct LeafValues<'a> {
    attributes: &'a LeafAttributes,
    srgb: [f32; 256],
    /// Whether some leaf is an interior cell of a solid bake (rays pass through those).
    interior: bool,
}

impl<'a> LeafValues<'a> {
    /// The values of leaves with channels `attributes`.
    pub(crate) fn new(attributes: &'a LeafAttributes) -> Self {
        Self {
            attributes,
            srgb: std::array::from_fn(|i| srgb_to_linear(i as u8)),
            interior: attributes.has_interior(),
        }
    }

    /// The leaves' channels.
    #[inline]
    pub(crate) fn attributes(&self) -> &'a LeafAttributes {
        self.attributes
    }

    /// The material of leaf `i`, with defaults for absent channels (grey 0.8, not reflective,
    /// opaque, IOR 1.5).
    #[inline]
    pub(crate) fn material(&self, i: u32) -> SurfaceMaterial {
        self.material_in(self.attributes, i)
    }

    /// The material of entry `i` of channels `a` (the leaves' or the inner nodes').
    #[inline]
    pub(crate) fn material_in(&self, a: &LeafAttributes, i: u32) -> SurfaceMaterial {
        let i = i as usize;
        let albedo = a.colour.get(i).map_or(Vec3::splat(0.8), |c| {
            let b = c.to_le_bytes();
            Vec3::new(
                self.srgb[usize::from(b[0])],
                self.srgb[usize::from(b[1])],
                self.srgb[usize::from(b[2])],
            )
        });
        SurfaceMaterial {
            albedo,
            reflectivity: a.reflectivity.get(i).map_or(0.0, |v| f32::from(v) / 255.0),
            refractivity: a.refractivity.get(i).map_or(0.0, |v| f32::from(v) / 255.0),
            ior: a.ior.get(i).map_or(1.5, ior_decode),
        }
    }

    /// Whether rays pass through leaf `i`: an interior cell of a solid (the surface leaves
    /// around it are the interfaces).
    #[inline]
    pub(crate) fn passes_through(&self, i: u32) -> bool {
        self.interior && self.attributes.is_interior(i as usize)
    }

    /// The volumetric medium of leaf `i`: transparent and without a stored normal.
    #[inline]
    pub(crate) fn medium_of(&self, i: u32) -> Option<Medium> {
        let a = self.attributes;
        let i = i as usize;
        if a.normal.get(i).is_some() {
            return None;
        }
        let kt = a.refractivity.get(i).unwrap_or(0);
        (kt > 0).then(|| {
            Medium(
                u64::from(kt)
                    | u64::from(a.ior.get(i).unwrap_or(0)) << 8
                    | u64::from(a.colour.get(i).unwrap_or(0)) << 24,
            )
        })
    }

    /// The closest-hit walk's callback for entry `e` of `ray` under query `q`, with `hit` the
    /// surfaces' hit of the entry. Inside a medium, the run of its cells along the ray ends at
    /// `run`.
    #[inline]
    pub(crate) fn closest_at(
        &self,
        q: &Query,
        run: &mut Run,
        e: &LeafEntry,
        hit: impl FnOnce() -> Option<SurfaceHit>,
    ) -> Option<SurfaceHit> {
        if let Some(m) = q.medium {
            if let Some(x) = *run
                && e.t_enter > x.0
            {
                // A gap after the medium's cells: the ray left it there.
                return Some(self.medium_exit(q, x));
            }
            if e.side == 1 && self.medium_of(e.leaf) == Some(m) {
                *run = Some((e.t_exit, e.exit_normal, e.leaf, e.cell));
                return None;
            }
        }
        if Skip::names(q.skip, e) {
            return None;
        }
        hit()
    }

    /// Where a ray inside `q`'s medium leaves it: the end of the run of its cells.
    fn medium_exit(&self, q: &Query, (t, n, leaf, cell): (f32, Vec3, u32, UVec3)) -> SurfaceHit {
        SurfaceHit {
            t,
            t_exit: t,
            id: leaf,
            cell,
            side: 1,
            normal: n,
            material: self.material(leaf),
            medium: q.medium,
        }
    }

    /// The closest-hit walk's outcome: its hit, or where the medium's run ended.
    pub(crate) fn closest_of(
        &self,
        q: &Query,
        run: Run,
        hit: Option<SurfaceHit>,
        steps: u32,
        capped: bool,
    ) -> Traced {
        let hit = match (hit, run) {
            (None, Some(x)) if !capped => Some(self.medium_exit(q, x)),
            (h, _) => h,
        };
        Traced { hit, steps, capped }
    }

    /// The hit of leaf entry `e` at `t` with shading normal `normal`: the leaf's material and
    /// medium read.
    #[inline]
    pub(crate) fn hit_of(&self, e: &LeafEntry, t: f32, normal: Vec3) -> SurfaceHit {
        SurfaceHit {
            t,
            t_exit: e.t_exit,
            id: e.leaf,
            cell: e.cell,
            side: 1,
            normal,
            material: self.material(e.leaf),
            medium: self.medium_of(e.leaf),
        }
    }
}
