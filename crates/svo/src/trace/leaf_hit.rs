//! What a ray hits inside a leaf: the cell cube, or the contour slab (thesis 1.4.4), and the
//! [`cast`] that stops at the first such hit.
//!
//! - **Cube**: the ray stops where it enters the cell.
//! - **Contour**: the leaf's two planes `near <= n . (p - c) <= far` (`n` the leaf normal, `c`
//!   the cell centre, offsets in cells; [`crate::octree::contour`]). The ray stops at the first point
//!   of the cell that lies between them: its entry point if that is inside the slab, else
//!   where it crosses the plane it is heading for, if that comes before it leaves the cell.
//!   A ray that misses the slab goes on through the tree (the thesis's "parallel" case).
//!   A leaf without a normal or contour is hit as a cube.
//!
//! A hit reports the *geometric* normal at the hit point, facing the ray: the cube face it
//! entered through, or the contour plane. Shading normals come from the leaf attributes.

use crate::octree::contour;
use crate::octree::normal_encoding;
use crate::octree::tree::{Channel, LeafAttributes, Octree};
use crate::trace::grid_ray::GridRay;
use crate::trace::traverse::{LeafEntry, Traversal, traverse};
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
    /// triangles (`svo::render::exact_surfaces`); [`leaf_hit`] alone treats it as
    /// [`Self::Cube`].
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

impl std::str::FromStr for HitMode {
    type Err = String;

    /// Parses a command-line name: `cube`, `contour` or `exact`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "cube" => Ok(Self::Cube),
            "contour" => Ok(Self::Contour),
            "exact" => Ok(Self::Exact),
            _ => Err(format!(
                "unknown hit mode {s:?} (expected cube, contour or exact)"
            )),
        }
    }
}

/// A ray's hit on a leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafHit {
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
pub(crate) fn cube_hit(e: &LeafEntry) -> LeafHit {
    LeafHit {
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
pub(crate) fn slab_hit(
    ray: &GridRay,
    e: &LeafEntry,
    n: Vec3,
    near: f32,
    far: f32,
) -> Option<LeafHit> {
    // Relative to the cell centre first: `o - c` is small and nearly exact even where the
    // grid coordinates are large, which `o + t d - c` would not be.
    let centre = e.cell.as_vec3() + Vec3::splat(0.5 * e.side as f32);
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
    (t <= e.t_exit).then_some(LeafHit {
        t,
        t_exit: e.t_exit,
        leaf: e.leaf,
        cell: e.cell,
        normal,
    })
}

/// The hit of `ray` on leaf entry `e` in `mode`. An inner node's entry (`e.side > 1`, from a
/// walk with a footprint) is hit on the node's contour slab, scaled to its cube, where the
/// tree stores one and the mode is not [`HitMode::Cube`]; else on its cube.
#[inline]
pub fn leaf_hit(tree: &Octree, ray: &GridRay, e: &LeafEntry, mode: HitMode) -> Option<LeafHit> {
    LeafTest::of_entry(tree, e, mode).hit(ray, e)
}

/// [`leaf_hit`] for one leaf, its stored normal and contour decoded once, for testing many
/// rays against it (the same hits).
#[derive(Clone, Copy, Debug)]
pub(crate) enum LeafTest {
    /// Hit where the ray enters the cell.
    Cube,
    /// Hit on the slab of unit normal `n` between offsets `near` and `far` from the centre.
    Slab { n: Vec3, near: f32, far: f32 },
}

impl LeafTest {
    /// The test of leaf `leaf` of `tree` in `mode`.
    #[inline]
    pub(crate) fn new(tree: &Octree, leaf: u32, mode: HitMode) -> Self {
        Self::of_leaf(&tree.attributes, leaf, mode)
    }

    /// [`Self::new`] for leaf `leaf` of the leaf channels `a`.
    #[inline]
    pub(crate) fn of_leaf(a: &LeafAttributes, leaf: u32, mode: HitMode) -> Self {
        match mode {
            HitMode::Cube | HitMode::Exact => Self::Cube,
            HitMode::Contour => Self::slab(a, leaf, 1),
        }
    }

    /// The test of entry `e`: its leaf's ([`Self::new`]) or, for an inner node, the node's
    /// (its contour in `mode` [`HitMode::Contour`] or [`HitMode::Exact`], else its cube).
    #[inline]
    pub(crate) fn of_entry(tree: &Octree, e: &LeafEntry, mode: HitMode) -> Self {
        if e.side <= 1 {
            return Self::new(tree, e.leaf, mode);
        }
        Self::of_node(tree, e.leaf, e.side, mode)
    }

    /// The test of inner node `node` of `side` cells standing for its subtree (see
    /// [`Self::of_entry`]).
    #[inline]
    pub(crate) fn of_node(tree: &Octree, node: u32, side: u32, mode: HitMode) -> Self {
        if mode == HitMode::Cube {
            return Self::Cube;
        }
        Self::slab(&tree.node_attributes, node, side)
    }

    /// The slab of entry `i` of channels `a` (the leaves' or the inner nodes') for a cell of
    /// `side` cells, its offsets scaled to it; the cube where `a` holds no normal or contour.
    #[inline]
    fn slab(a: &LeafAttributes, i: u32, side: u32) -> Self {
        let (Some(nw), Some(cw)) = (channel_word(&a.normal, i), channel_word(&a.contour, i)) else {
            return Self::Cube;
        };
        let n = normal_encoding::decode(nw);
        let (near, far) = contour::offsets(cw, n);
        if side <= 1 {
            return Self::Slab { n, near, far };
        }
        let s = side as f32;
        Self::Slab {
            n,
            near: near * s,
            far: far * s,
        }
    }

    /// The hit of `ray` on entry `e` of the leaf.
    #[inline]
    pub(crate) fn hit(self, ray: &GridRay, e: &LeafEntry) -> Option<LeafHit> {
        match self {
            Self::Cube => Some(cube_hit(e)),
            Self::Slab { n, near, far } => slab_hit(ray, e, n, near, far),
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
) -> Traversal<LeafHit> {
    traverse(tree, ray, tmin, tmax, max_steps, |e| {
        if Some(e.leaf) == skip {
            return None;
        }
        leaf_hit(tree, ray, e, mode)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The entry of the unit cell at the origin for `ray` (an `f64` slab test).
    fn entry(ray: &GridRay) -> Option<LeafEntry> {
        let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            if d[a] == 0.0 {
                if !(0.0..=1.0).contains(&o[a]) {
                    return None;
                }
                continue;
            }
            let (p, q) = (-o[a] / d[a], (1.0 - o[a]) / d[a]);
            t0 = t0.max(p.min(q));
            t1 = t1.min(p.max(q));
        }
        (t0 <= t1).then_some(LeafEntry {
            leaf: 0,
            cell: UVec3::ZERO,
            side: 1,
            t_enter: t0 as f32,
            t_exit: t1 as f32,
            entry_normal: Vec3::X,
            exit_normal: Vec3::X,
        })
    }

    /// Each mode's command-line name parses back to it; anything else is an error that
    /// lists the names.
    #[test]
    fn names_round_trip() {
        for mode in [HitMode::Cube, HitMode::Contour, HitMode::Exact] {
            assert_eq!(mode.name().parse::<HitMode>(), Ok(mode));
        }
        let e = "cubes".parse::<HitMode>().unwrap_err();
        assert!(e.contains("cube, contour or exact"), "{e}");
    }

    /// A plane met exactly where the ray leaves the cell is hit there: the slab touches the
    /// cell's exit face (the hit is on the boundary, as a cube hit on the entry face is).
    #[test]
    fn a_plane_on_the_exit_face_is_hit_at_the_exit() {
        let ray = GridRay {
            origin: Vec3::new(-1.0, 0.5, 0.5),
            dir: Vec3::X,
        };
        let en = entry(&ray).unwrap();
        assert_eq!((en.t_enter, en.t_exit), (1.0, 2.0));
        // The plane x = 1: offset 0.5 from the centre along +x.
        let h = slab_hit(&ray, &en, Vec3::X, 0.5, 0.5).expect("the plane on the exit face");
        assert_eq!((h.t, h.normal), (2.0, Vec3::NEG_X));
    }

    /// The slab is closed: a ray that enters the cell exactly on the near or the far plane,
    /// running along it, is in the slab there and hits at its entry, through the cell face.
    #[test]
    fn a_ray_entering_on_a_plane_is_in_the_slab() {
        let ray = GridRay {
            origin: Vec3::new(-1.0, 0.5, 0.5),
            dir: Vec3::X,
        };
        let en = entry(&ray).unwrap();
        // The planes y = 0.5 (offset 0 along +y) on either side of the slab.
        for (near, far) in [(0.0, 0.3), (-0.3, 0.0), (0.0, 0.0)] {
            let h = slab_hit(&ray, &en, Vec3::Y, near, far)
                .unwrap_or_else(|| panic!("missed the slab [{near}, {far}]"));
            assert_eq!((h.t, h.normal), (1.0, en.entry_normal), "[{near}, {far}]");
        }
    }

    /// Zero-thickness and full-thickness contours, and rays parallel to the contour planes
    /// (with `+0.0` and `-0.0` components), grazing along them and crossing them: never a
    /// NaN parameter; a zero-thickness slab is hit where the `f64` plane is, within `1e-5`;
    /// a parallel ray hits only when it runs inside the slab; a full slab is the cube.
    #[test]
    fn thin_full_and_grazing_contours() {
        let n = Vec3::new(1.0, 2.0, 2.0) / 3.0;
        let e = 0.5 * (n.x.abs() + n.y.abs() + n.z.abs());
        // A direction in the plane: perpendicular to n.
        let along = Vec3::new(2.0, -1.0, 0.0).normalize();
        let mut parallel = 0;
        for k in 0..=40 {
            let offset = -e + 2.0 * e * k as f32 / 40.0;
            // Zero thickness at `offset`.
            for (dir, start) in [
                (-n, Vec3::splat(0.5) + n * 2.0),
                (n, Vec3::splat(0.5) - n * 2.0),
                (along, Vec3::splat(0.5) + n * offset - along * 2.0),
                (along * -1.0, Vec3::splat(0.5) + n * offset + along * 2.0),
                (Vec3::new(0.0, -0.0, 1.0), Vec3::new(0.5, 0.5, -1.0)),
                (Vec3::new(-0.0, 0.0, -1.0), Vec3::new(0.5, 0.5, 2.0)),
            ] {
                let ray = GridRay { origin: start, dir };
                let Some(en) = entry(&ray) else { continue };
                let h = slab_hit(&ray, &en, n, offset, offset);
                let sd = n.dot(dir);
                if sd == 0.0 || sd.abs() < 1e-6 {
                    parallel += 1;
                    // Runs in the plane (start on it) or beside it.
                    if let Some(h) = h {
                        assert!(h.t.is_finite() && h.t >= en.t_enter);
                    }
                    continue;
                }
                // Where the f64 ray meets the plane n . (p - c) = offset.
                let c = glam::DVec3::splat(0.5);
                let (o, d, nd) = (start.as_dvec3(), dir.as_dvec3(), n.as_dvec3());
                let t_plane = (f64::from(offset) - nd.dot(o - c)) / nd.dot(d);
                let inside = t_plane >= f64::from(en.t_enter) - 1e-5
                    && t_plane <= f64::from(en.t_exit) + 1e-5;
                match h {
                    Some(h) => {
                        assert!(h.t.is_finite());
                        assert!(
                            (f64::from(h.t) - t_plane).abs() < 1e-5,
                            "{k} {dir}: {} vs {t_plane}",
                            h.t
                        );
                    }
                    // A plane met within rounding of where the ray enters or leaves the
                    // cell touches it only at its boundary: either answer is right.
                    None => assert!(
                        !inside
                            || (t_plane - f64::from(en.t_exit)).abs() < 1e-5
                            || (t_plane - f64::from(en.t_enter)).abs() < 1e-5,
                        "{k} {dir}: missed the plane at {t_plane}"
                    ),
                }
                // The full slab is the cube.
                let full = slab_hit(&ray, &en, n, -e, e).expect("the full slab fills the cell");
                assert_eq!(full.t, en.t_enter);
            }
        }
        assert!(parallel > 0, "no ray ran parallel to the planes");
    }
}
