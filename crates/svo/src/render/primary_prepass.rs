//! The primary-ray prepass of [`crate::render::frame`] and [`crate::render::primary_cast`]: the first hits
//! of a band of camera rays, found by projecting the octree front to back onto the screen
//! instead of walking it once per pixel.
//!
//! All primary rays start at the eye, so one order of the octree's cells is front to back
//! for every one of them: at each node, the children on the eye's side of each mid-plane
//! first (the child index `k ^ eye_octant` for `k = 0..8`; a ray from the eye crosses each
//! mid-plane at most once, away from the eye, so the children it passes through come in that
//! order). A band of [`BAND`] image rows is decided in one depth-first walk of the tree in
//! that order. Each node is projected to a pixel rectangle (its cube grown by a margin that
//! covers the `f32` rounding of the rays, then the bounds of its corners' projections) and
//! skipped when no pixel of the rectangle is still open (every ray there has its hit already:
//! the node is hidden) or when the rectangle misses the band. At a leaf, each open pixel of
//! its rectangle gets the traversal's own plane test: the parameters `(p - o) * (1 / d)` of
//! the cell's six planes, the very values [`crate::trace::traverse`] computes for that cell,
//! so `enter < exit` holds exactly when the traversal would hand this leaf to its callback.
//! The pixel's ray then gets the leaf's [`LeafEntry`], built as the traversal builds it, and
//! the surfaces' hit test: the first leaf in this order that the ray enters and hits is the
//! traversal's first hit, bit for bit.
//!
//! Where a node's rectangle holds few open pixels (eight or fewer), projecting its children
//! would cull little: each of those rays walks the node's subtree instead
//! ([`traverse_node`], which hands over the same leaves and entries as the walk from the
//! root), and a hit there is its first hit for the same reason.
//!
//! Where the rays have a footprint ([`crate::trace::Cone`]), the nodes where they stop
//! depend on the node and the eye alone: such a node is tested as a leaf is (the planes of the
//! box of its leaves, as the walk has them, its entry, the surfaces' test of the node), and
//! nothing below it is projected.
//!
//! A ray that only touches a cell or a walked node (`enter == exit`: through an edge or a
//! corner, which the traversal skips except where a ray starts) is left to the ordinary
//! traversal from the eye ([`PrimaryStart::From`]). Open pixels left when the walk ends hit
//! nothing ([`PrimaryStart::Miss`]). Nodes that hold or touch the eye have no rectangle: they
//! are opened for the whole band.

use crate::geometry::child_classify::child_offset;
use crate::octree::bounds;
use crate::octree::tree::slot_of;
use crate::render::camera::CameraRays;
use crate::render::surfaces::Surfaces;
use crate::render::whitted::{PrimaryStart, Tracer};
use crate::trace::cone::{Cone, node_distance};
use crate::trace::grid_ray::{GridRay, entry_normal_of, exit_normal_of, safe_inverse};
use crate::trace::traverse::{LeafEntry, MAX_STEPS, StartAt, WalkNodes, traverse_from};
use glam::{DVec3, UVec3, Vec3, Vec3A};

/// Rows per band: the unit of parallel work, and of the per-pixel state kept at once.
pub(crate) const BAND: u32 = 32;

/// How far outside its exact bounds a projected corner may land, in pixels (the rounding of
/// the `f64` projection; the `f32` rounding of the rays is covered by the cube's margin).
const PIXEL_SLACK: f64 = 1e-3;

/// What the prepass of one view needs for every band: the camera, the eye in grid space and
/// the projection. Made once per frame by the renderers.
#[derive(Clone, Debug)]
pub(crate) struct PrimaryView {
    rays: CameraRays,
    /// The rays' origin in grid units, as the traversal has it.
    eye: Vec3,
    eye_d: DVec3,
    /// Grid units per scene unit.
    scale: f32,
    /// Margin around each cube, grid units.
    pad: f64,
    /// Points of a box nearer the eye's image plane than `gap * clip` are off the screen.
    clip: f64,
    /// Per grid axis, its unit vector in view space (right, up, forward components).
    cols: [DVec3; 3],
    /// Pixel coordinates from view space: `px = x / z * kx + bx`, `py = -y / z * ky + by`.
    kx: f64,
    bx: f64,
    ky: f64,
    by: f64,
    width: u32,
    height: u32,
    /// The primary rays' footprint: the nodes where they stop.
    cone: Cone,
}

impl PrimaryView {
    /// The prepass of `rays` (the tracer's camera) whose rays have footprint `cone`, when the
    /// tracer's options ask for one.
    pub(crate) fn new<S: Surfaces>(
        tracer: &Tracer<S>,
        rays: &CameraRays,
        cone: Cone,
    ) -> Option<Self> {
        if !tracer.options().prepass {
            return None;
        }
        let (w, h) = rays.size();
        let eye = tracer.to_grid(rays.eye());
        let (_, depth) = tracer.surfaces().grid();
        if !eye.is_finite() || !(1..=24).contains(&depth) {
            return None;
        }
        // The margin covers the f32 rounding of the rays (direction and origin, relative
        // 1e-7 of the coordinates and of the distance from the eye) with a wide berth.
        let side = f64::from(1u32 << depth);
        let eye_d = eye.as_dvec3();
        let pad = 1e-3 + 1e-5 * side.max(eye_d.abs().max_element());
        // Points of a box at distance `g` from the eye nearer its image plane than
        // `zc = g * clip` are off the screen: such a point lies at least `g` from the eye, so
        // its distance from the view axis is at least `g * sqrt(1 - clip^2) >= 0.86 g`,
        // while a point on the screen at depth `z` is within `z * sqrt(2) * reach < 0.36 g`
        // of the axis (`reach`: the larger half extent of the image plane at depth 1).
        let half = rays.half_extent();
        let clip = 1.0 / (4.0 * half.max_element() + 2.0);
        let (right, up, fwd) = (rays.right(), rays.up(), rays.forward());
        let cols = [
            DVec3::new(right.x, up.x, fwd.x),
            DVec3::new(right.y, up.y, fwd.y),
            DVec3::new(right.z, up.z, fwd.z),
        ];
        Some(Self {
            rays: *rays,
            eye,
            eye_d,
            scale: tracer.scale(),
            pad,
            clip,
            cols,
            kx: 0.5 * f64::from(w) / half.x,
            bx: 0.5 * f64::from(w) - 0.5,
            ky: 0.5 * f64::from(h) / half.y,
            by: 0.5 * f64::from(h) - 0.5,
            width: w,
            height: h,
            cone,
        })
    }

    /// The grid ray of pixel `(x, y)`, as the tracer makes it.
    #[inline]
    pub(crate) fn ray(&self, x: u32, y: u32) -> GridRay {
        GridRay {
            origin: self.eye,
            dir: self.rays.dir_f32(x, y) * self.scale,
        }
    }

    /// The pixel bounds `[x0, y0, x1, y1]` of the cube at `origin` with `side` cells, grown
    /// by the margin: `Whole` when it holds or touches the eye, `Off` when it lies off the
    /// screen or behind the eye.
    fn project(&self, origin: UVec3, side: u32) -> Projection {
        let lo = origin.as_dvec3() - self.pad;
        let s = f64::from(side) + 2.0 * self.pad;
        let v0 = lo - self.eye_d;
        let c0 = self.cols[0] * v0.x + self.cols[1] * v0.y + self.cols[2] * v0.z;
        let (ex, ey, ez) = (self.cols[0] * s, self.cols[1] * s, self.cols[2] * s);
        // The corners in view space, one array per coordinate (corner `i` adds the edges of
        // its bits: x = 4, y = 2, z = 1).
        let mut cx = [c0.x; 8];
        let mut cy = [c0.y; 8];
        let mut cz = [c0.z; 8];
        for (bit, e) in [(1, ez), (2, ey), (4, ex)] {
            for i in 0..bit {
                cx[i + bit] = cx[i] + e.x;
                cy[i + bit] = cy[i] + e.y;
                cz[i + bit] = cz[i] + e.z;
            }
        }
        // Plain comparisons: no NaN arises here (finite inputs), and `f64::min` would pay
        // for NaN handling.
        let lt = |a: f64, b: f64| if a < b { a } else { b };
        let gt = |a: f64, b: f64| if a > b { a } else { b };
        let zmin = cz.iter().fold(f64::INFINITY, |m, &z| lt(m, z));
        // Every corner well in front of the eye (by far more than the rounding of these
        // sums): the bounds of the corners' projections bound the box's.
        let size = v0.x.abs() + v0.y.abs() + v0.z.abs() + 3.0 * s;
        if zmin > 1e-9 * size {
            let (mut x0, mut y0, mut x1, mut y1) = (
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            );
            for i in 0..8 {
                let r = 1.0 / cz[i];
                let (px, py) = (cx[i] * r, cy[i] * r);
                (x0, y0, x1, y1) = (lt(x0, px), lt(y0, py), gt(x1, px), gt(y1, py));
            }
            return Projection::Bounds([
                x0 * self.kx + self.bx,
                -y1 * self.ky + self.by,
                x1 * self.kx + self.bx,
                -y0 * self.ky + self.by,
            ]);
        }
        self.project_near(lo, s, [cx, cy, cz])
    }

    /// [`Self::project`] for a box (low corner `lo`, side `s`, corners in view space `c`)
    /// that reaches near or behind the eye's image plane.
    fn project_near(&self, lo: DVec3, s: f64, c: [[f64; 8]; 3]) -> Projection {
        let hi = lo + s;
        // The box's distance from the eye: a box that holds the eye or touches it has no
        // rectangle.
        let gap = (lo - self.eye_d)
            .max(self.eye_d - hi)
            .max(DVec3::ZERO)
            .length();
        if !(gap > 0.0) {
            return Projection::Whole;
        }
        let zc = gap * self.clip;
        let corners: [DVec3; 8] = std::array::from_fn(|i| DVec3::new(c[0][i], c[1][i], c[2][i]));
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut add = |c: DVec3| {
            let px = c.x / c.z * self.kx + self.bx;
            let py = -c.y / c.z * self.ky + self.by;
            b = [b[0].min(px), b[1].min(py), b[2].max(px), b[3].max(py)];
        };
        // The part in front of the plane at `zc`: its corners there and where its edges
        // cross the plane. The rest of the box is off the screen or behind the eye.
        let mut any = false;
        for (i, &a) in corners.iter().enumerate() {
            if a.z >= zc {
                add(a);
                any = true;
            }
            for bit in [4, 2, 1] {
                if i & bit == 0 {
                    let c = corners[i | bit];
                    if (a.z < zc) != (c.z < zc) {
                        add(a + (c - a) * ((zc - a.z) / (c.z - a.z)));
                        any = true;
                    }
                }
            }
        }
        if !any {
            return Projection::Off;
        }
        if b.iter().any(|v| v.is_nan()) {
            return Projection::Whole;
        }
        Projection::Bounds(b)
    }
}

/// A cube's place on the screen.
enum Projection {
    /// Off the screen or behind the eye.
    Off,
    /// Holds or touches the eye: every pixel may see it.
    Whole,
    /// Pixel bounds `[x0, y0, x1, y1]` (pixel centres are at integers).
    Bounds([f64; 4]),
}

/// Pixels of a band: columns `x0..=x1`, band rows `r0..=r1`.
#[derive(Clone, Copy, Debug)]
struct Rect {
    x0: u32,
    x1: u32,
    r0: u32,
    r1: u32,
}

/// A node waiting on the walk's stack: the node as the walk holds it, the index its values
/// are found by (a tree's node index), its minimum cell and side.
#[derive(Clone, Copy, Debug)]
struct Pending<N> {
    node: N,
    index: u32,
    origin: UVec3,
    side: u32,
}

/// The slot of a pixel whose ray is still open (at the end: hits nothing).
const OPEN: u32 = u32::MAX;

/// The slot of a pixel left to the traversal from the eye.
const DEFER: u32 = u32::MAX - 1;

/// Open pixels of a node's rectangle at or below which their rays walk the node's subtree
/// ([`traverse_node`]) rather than the node's children being projected: projecting pays
/// while it culls many pixels at once.
const WALK_PIXELS: u32 = 8;

/// Per-band buffers, reused from band to band by one worker.
#[derive(Debug, Default)]
pub(crate) struct PrimaryScratch {
    /// Per pixel, its grid ray's direction and `1 / d` as the traversal makes them.
    rays: Vec<PixelRay>,
    /// Per pixel, one bit: the direction and inverse above are made.
    ready: Vec<u64>,
    /// Per pixel, one bit: the ray has no decided hit yet.
    open: Vec<u64>,
    /// Per pixel, [`OPEN`], [`DEFER`] or the index of its hit in `hits`.
    slot: Vec<u32>,
    /// Per pixel, leaf tests and walk steps made.
    tests: Vec<u32>,
    /// The decided hits: the leaf's entry and the hit's parameter.
    hits: Vec<(LeafEntry, f32)>,
}

/// A pixel's grid ray, as the prepass keeps it once made ([`PrimaryView::ray`]).
#[derive(Clone, Copy, Debug, Default)]
struct PixelRay {
    dir: Vec3,
    /// `1 / dir` as the traversal makes it ([`safe_inverse`]).
    inv: Vec3A,
    /// The ray's mirrored axes (negative direction components: x = 4, y = 2, z = 1).
    mask: u8,
}

/// How a pixel's ray meets a box whose planes are the grid's.
enum Pass {
    /// It misses it, or meets it only behind the eye.
    Misses,
    /// It only touches it (an edge, a corner, or a face it runs along).
    Touches,
    /// It passes through it with positive length: the parameters at its entry planes and
    /// at its exit planes, and the ray's mirrored axes (x = 4, y = 2, z = 1).
    Enters(Vec3A, Vec3A, u8),
}

impl PrimaryScratch {
    /// The plane test of pixel `(x, y)` (band index `i`, bit `b` of word `at`) against the
    /// box whose low and high planes, relative to the eye, are `lo` and `hi`: the
    /// traversal's `(p - o) * (1 / d)` for each plane, so the traversal sees the same.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn planes(
        &mut self,
        view: &PrimaryView,
        at: usize,
        b: usize,
        i: usize,
        x: u32,
        y: u32,
        lo: Vec3A,
        hi: Vec3A,
    ) -> Pass {
        let ray = &mut self.rays[i];
        if self.ready[at] >> b & 1 == 0 {
            ray.dir = view.ray(x, y).dir;
            ray.inv = safe_inverse(ray.dir);
            // The inverse keeps the direction's sign.
            let inv = ray.inv;
            ray.mask =
                (u8::from(inv.x < 0.0) << 2) | (u8::from(inv.y < 0.0) << 1) | u8::from(inv.z < 0.0);
            self.ready[at] |= 1 << b;
        }
        let (a, c) = (lo * ray.inv, hi * ray.inv);
        // The entry plane of an axis is the low one where the direction is positive: the
        // smaller parameter either way. Lane by lane `min` and `max` here give what the
        // scalar `if a < b { a } else { b }` and its twin give: an axis's two parameters are
        // never NaN and never zeros of opposite signs (one plane is at least half a cell from
        // the eye, and the inverse is finite and non-zero), and where they are equal they are
        // the same bits.
        let (t0, t1) = (a.min(c), a.max(c));
        let enter = max(max(max(t0.x, t0.y), t0.z), 0.0);
        let exit = min(min(t1.x, t1.y), t1.z);
        if enter > exit {
            Pass::Misses
        } else if enter == exit {
            Pass::Touches
        } else {
            Pass::Enters(t0, t1, ray.mask)
        }
    }

    /// Closes pixel `i` (bit `b` of word `at`) with slot `slot`.
    #[inline]
    fn close(&mut self, at: usize, b: usize, i: usize, slot: u32) {
        self.slot[i] = slot;
        self.open[at] &= !(1u64 << b);
    }

    /// Closes pixel `i` with a hit: the leaf's entry and the hit's parameter.
    #[inline]
    fn close_hit(&mut self, at: usize, b: usize, i: usize, hit: (LeafEntry, f32)) {
        let k = self.hits.len() as u32;
        self.hits.push(hit);
        self.close(at, b, i, k);
    }
}

/// One band of image rows: the view, the band's first row and row count, and the buffers
/// where the surfaces decide its primary rays ([`Surfaces::primary_band`]).
pub struct PrimaryBand<'a> {
    view: &'a PrimaryView,
    y0: u32,
    rows: u32,
    /// Whether the surfaces decided the band (else every ray is traced from the eye).
    decided: bool,
    s: &'a mut PrimaryScratch,
}

impl<'a> PrimaryBand<'a> {
    /// The band of `rows` rows from row `y0`, its primary rays decided by `surfaces`
    /// ([`Surfaces::primary_band`]), as the renderer and the primary cast both start a band.
    pub(crate) fn decided_by<S: Surfaces>(
        view: &'a PrimaryView,
        surfaces: &S,
        y0: u32,
        rows: u32,
        s: &'a mut PrimaryScratch,
    ) -> Self {
        let mut band = Self {
            view,
            y0,
            rows,
            decided: false,
            s,
        };
        surfaces.primary_band(&mut band);
        band
    }

    /// What the prepass knows of pixel `i` of the band (row-major from the band's first
    /// row): a decided hit or miss, or tracing from the eye.
    #[inline]
    pub(crate) fn start(&self, i: usize) -> PrimaryStart {
        if !self.decided {
            return PrimaryStart::From(0.0);
        }
        match self.s.slot[i] {
            OPEN => PrimaryStart::Miss {
                tests: self.s.tests[i],
            },
            DEFER => PrimaryStart::From(0.0),
            k => {
                let (entry, t) = self.s.hits[k as usize];
                PrimaryStart::Leaf {
                    entry,
                    t,
                    tests: self.s.tests[i],
                }
            }
        }
    }

    /// Words of open (and ready) bits per row.
    fn words(&self) -> usize {
        (self.view.width as usize).div_ceil(64)
    }

    /// Decides the band's rays on `tree`, with `leaf_test(leaf)` the surfaces' hit test of
    /// that leaf's entries (the parameter of the hit, or `None` where the ray goes on through
    /// the leaf), made once for all the rays tested against the leaf, and `node_test(node, side)`
    /// the same for an inner node of `side` cells where the view's rays have a footprint that
    /// stops there
    /// ([`crate::trace::Cone`]: the nodes no wider than the cone at their distance from the
    /// eye, tested as the walk hands them over, in place of their leaves). Unless
    /// `reads_normals`, the tests are given the entries with their face normals zero, and a
    /// hit's entry gets them before it is kept.
    pub(crate) fn decide<W: WalkNodes, T, N>(
        &mut self,
        (tree, depth): (&W, u8),
        reads_normals: bool,
        leaf_test: impl Fn(u32) -> T,
        node_test: impl Fn(u32, u32) -> N,
    ) where
        T: Fn(&GridRay, &LeafEntry) -> Option<f32>,
        N: Fn(&GridRay, &LeafEntry) -> Option<f32>,
    {
        let tests = Tests {
            leaf: leaf_test,
            node: node_test,
        };
        if !(1..=24).contains(&depth) {
            return;
        }
        let n = 1u32 << depth;
        let w = self.view.width as usize;
        let px = w * self.rows as usize;
        let words = self.words();
        let s = &mut *self.s;
        s.rays.resize(px, PixelRay::default());
        s.tests.clear();
        s.tests.resize(px, 0);
        s.slot.clear();
        s.slot.resize(px, OPEN);
        s.hits.clear();
        s.ready.clear();
        s.ready.resize(self.rows as usize * words, 0);
        s.open.clear();
        s.open.resize(self.rows as usize * words, u64::MAX);
        if !w.is_multiple_of(64) {
            let last = u64::MAX >> (64 - w % 64);
            for r in 0..self.rows as usize {
                s.open[r * words + words - 1] = last;
            }
        }
        self.decided = true;
        let mut stack = Vec::with_capacity(64);
        if let Some(root) = tree.root().filter(|&r| W::mask(r) != 0) {
            stack.push(Pending {
                node: root,
                index: 0,
                origin: UVec3::ZERO,
                side: n,
            });
        }
        let eye = self.view.eye;
        let cone = self.view.cone;
        let coarse = !cone.is_exact();
        while let Some(p) = stack.pop() {
            let Some(rect) = self.rect(p.origin, p.side) else {
                continue;
            };
            let open = self.open_count(rect, WALK_PIXELS);
            if open == 0 {
                continue;
            }
            let node = p.node;
            if coarse
                && p.side < n
                && !W::is_leaf_parent(node)
                && cone.stops_at(p.side, node_distance(eye, p.origin, p.side))
            {
                // The node stands for its subtree, within the box of its leaves.
                let planes = bounds::cell_box(W::leaf_box(node), p.origin, p.side);
                let cell = (p.index, p.origin, p.side);
                let test = |node| (tests.node)(node, p.side);
                self.test_cell(cell, planes, rect, reads_normals, &test);
                continue;
            }
            if open <= WALK_PIXELS {
                self.walk_node((tree, depth), p, rect, &tests);
                continue;
            }
            let half = p.side / 2;
            let mid = (p.origin + UVec3::splat(half)).as_vec3();
            // The children on the eye's side of each mid-plane first.
            let near = (u8::from(eye.x >= mid.x) << 2)
                | (u8::from(eye.y >= mid.y) << 1)
                | u8::from(eye.z >= mid.z);
            let child = |c: u8| p.origin + UVec3::from_array(child_offset(c)) * half;
            let mask = W::mask(node);
            let rank_of = |c: u8| (mask >> c & 1 == 1).then(|| slot_of(mask, c));
            if let Some(base) = W::leaf_base(node) {
                if half != 1 {
                    // Not a valid tree (leaves one cell wide only).
                    continue;
                }
                for k in 0..8u8 {
                    let c = k ^ near;
                    let Some(rank) = rank_of(c) else {
                        continue;
                    };
                    let cell = child(c);
                    if let Some(r) = self.rect(cell, 1) {
                        let planes = (cell, cell + UVec3::ONE);
                        self.test_cell(
                            (W::leaf_of(node, base, rank), cell, 1),
                            planes,
                            r,
                            reads_normals,
                            &tests.leaf,
                        );
                    }
                }
            } else if half >= 2 {
                // Pushed far to near, so the nearest comes off the stack first.
                for k in (0..8u8).rev() {
                    let c = k ^ near;
                    let Some(rank) = rank_of(c) else {
                        continue;
                    };
                    if let Some(child_node) = tree.child(node, c, rank) {
                        stack.push(Pending {
                            node: child_node,
                            index: W::child_index(node, rank),
                            origin: child(c),
                            side: half,
                        });
                    }
                }
            }
        }
    }

    /// The band's pixels that may see the cube at `origin` with `side` cells, `None` if
    /// none.
    fn rect(&self, origin: UVec3, side: u32) -> Option<Rect> {
        let (w, rows) = (self.view.width, self.rows);
        match self.view.project(origin, side) {
            Projection::Off => None,
            Projection::Whole => Some(Rect {
                x0: 0,
                x1: w - 1,
                r0: 0,
                r1: rows - 1,
            }),
            Projection::Bounds([x0, y0, x1, y1]) => {
                // Pixel centres are at integers: the pixels whose centres lie in the bounds.
                let x0 = ceil_within(x0 - PIXEL_SLACK, w).max(0);
                let x1 = floor_within(x1 + PIXEL_SLACK, w).min(i64::from(w) - 1);
                let y0 = ceil_within(y0 - PIXEL_SLACK, self.view.height);
                let y1 = floor_within(y1 + PIXEL_SLACK, self.view.height);
                let r0 = (y0 - i64::from(self.y0)).max(0);
                let r1 = (y1 - i64::from(self.y0)).min(i64::from(rows) - 1);
                (x0 <= x1 && r0 <= r1).then_some(Rect {
                    x0: x0 as u32,
                    x1: x1 as u32,
                    r0: r0 as u32,
                    r1: r1 as u32,
                })
            }
        }
    }

    /// How many pixels of `r` are still open, counting no further than past `limit`.
    fn open_count(&self, r: Rect, limit: u32) -> u32 {
        let words = self.words();
        let (w0, w1) = (r.x0 as usize / 64, r.x1 as usize / 64);
        let mut count = 0;
        for row in r.r0..=r.r1 {
            let line = &self.s.open[row as usize * words + w0..=row as usize * words + w1];
            for (k, word) in (w0..).zip(line) {
                count += (word & span_mask(k, r.x0, r.x1)).count_ones();
            }
            if count > limit {
                break;
            }
        }
        count
    }

    /// Calls `f(at, b, i, x, y)` for each open pixel of `r`: its word and bit in the open
    /// bits, its band index and its image coordinates. `f` may close the pixel it is given.
    #[inline]
    fn each_open(&mut self, r: Rect, mut f: impl FnMut(&mut Self, usize, usize, usize, u32, u32)) {
        let words = self.words();
        let w = self.view.width as usize;
        let (w0, w1) = (r.x0 as usize / 64, r.x1 as usize / 64);
        for row in r.r0..=r.r1 {
            let y = self.y0 + row;
            for k in w0..=w1 {
                let at = row as usize * words + k;
                let mut bits = self.s.open[at] & span_mask(k, r.x0, r.x1);
                while bits != 0 {
                    let b = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let x = k * 64 + b;
                    f(self, at, b, row as usize * w + x, x as u32, y);
                }
            }
        }
    }

    /// Decides the open pixels of `r` by walking node `p`'s subtree along each one's ray
    /// ([`traverse_node`]: the leaves and entries of the walk from the root, within it).
    fn walk_node<W: WalkNodes, T, N>(
        &mut self,
        (tree, depth): (&W, u8),
        p: Pending<W::N>,
        r: Rect,
        tests: &Tests<impl Fn(u32) -> T, impl Fn(u32, u32) -> N>,
    ) where
        T: Fn(&GridRay, &LeafEntry) -> Option<f32>,
        N: Fn(&GridRay, &LeafEntry) -> Option<f32>,
    {
        let start = StartAt {
            node: p.node,
            origin: p.origin,
            side: p.side,
        };
        self.each_open(r, |band, at, b, i, x, y| {
            let ray = if band.s.ready[at] >> b & 1 != 0 {
                GridRay {
                    origin: band.view.eye,
                    dir: band.s.rays[i].dir,
                }
            } else {
                band.view.ray(x, y)
            };
            let cone = band.view.cone;
            let walk = traverse_from(
                tree,
                depth,
                &ray,
                Some(start),
                cone,
                0.0,
                f32::INFINITY,
                MAX_STEPS,
                |e| {
                    let t = if e.side > 1 {
                        (tests.node)(e.leaf, e.side)(&ray, e)
                    } else {
                        (tests.leaf)(e.leaf)(&ray, e)
                    };
                    t.map(|t| (*e, t))
                },
            );
            let s = &mut *band.s;
            match walk {
                Some(tr) => {
                    s.tests[i] += tr.steps;
                    if tr.capped {
                        s.close(at, b, i, DEFER);
                    } else if let Some(hit) = tr.hit {
                        s.close_hit(at, b, i, hit);
                    }
                }
                // The ray only touches the node: the traversal from the eye decides.
                None => s.close(at, b, i, DEFER),
            }
        });
    }

    /// Tests leaf `leaf` at `cell` (`side` 1), or inner node `leaf` standing for its subtree
    /// (its cube of `side` cells from `cell`), between the planes `(lo, hi)` (the cell's, or the
    /// box of the node's leaves), against the open pixels of `r` with `make_test(leaf)` (the
    /// entries' face normals made before the test where it `reads_normals`, else for the hits
    /// alone).
    fn test_cell<T: Fn(&GridRay, &LeafEntry) -> Option<f32>>(
        &mut self,
        (leaf, cell, side): (u32, UVec3, u32),
        (lo, hi): (UVec3, UVec3),
        r: Rect,
        reads_normals: bool,
        make_test: &impl Fn(u32) -> T,
    ) {
        // The leaf's test, made when the first ray enters the cell.
        let mut test = None;
        // The planes relative to the eye, as the traversal has them.
        let eye = Vec3A::from(self.view.eye);
        let lo = Vec3A::from(lo.as_vec3()) - eye;
        let hi = Vec3A::from(hi.as_vec3()) - eye;
        self.each_open(r, |band, at, b, i, x, y| {
            let view = band.view;
            let s = &mut *band.s;
            let pass = s.planes(view, at, b, i, x, y, lo, hi);
            s.tests[i] += 1;
            match pass {
                Pass::Misses => {}
                // It only touches the cell: the traversal from the eye decides.
                Pass::Touches => s.close(at, b, i, DEFER),
                Pass::Enters(t0, t1, mask) => {
                    // The ray passes through the cell: the traversal's entry for it.
                    let ray = GridRay {
                        origin: view.eye,
                        dir: s.rays[i].dir,
                    };
                    match cell_entry(t0, t1, leaf, cell, side) {
                        Some(mut e) => {
                            if reads_normals {
                                add_normals(&mut e, t0, t1, mask);
                            }
                            let hit_t = test.get_or_insert_with(|| make_test(leaf));
                            if let Some(t) = hit_t(&ray, &e) {
                                if !reads_normals {
                                    add_normals(&mut e, t0, t1, mask);
                                }
                                s.close_hit(at, b, i, (e, t));
                            }
                        }
                        None => s.close(at, b, i, DEFER),
                    }
                }
            }
        });
    }
}

/// `ceil(v)` for `v` within `[-2, hi + 2]`, else the nearer end (NaN: `-2`).
#[inline]
fn ceil_within(v: f64, hi: u32) -> i64 {
    let v = v.clamp(-2.0, f64::from(hi) + 2.0);
    let i = v as i64;
    if (i as f64) < v { i + 1 } else { i }
}

/// `floor(v)` for `v` within `[-2, hi + 2]`, else the nearer end (NaN: `-2`).
#[inline]
fn floor_within(v: f64, hi: u32) -> i64 {
    let v = v.clamp(-2.0, f64::from(hi) + 2.0);
    let i = v as i64;
    if (i as f64) > v { i - 1 } else { i }
}

/// The bits of word `k` (pixels `64 k ..`) that lie in `x0..=x1`.
#[inline]
fn span_mask(k: usize, x0: u32, x1: u32) -> u64 {
    let base = k as u32 * 64;
    let lo = x0.saturating_sub(base);
    let hi = (x1 - base).min(63);
    (u64::MAX << lo) & (u64::MAX >> (63 - hi))
}

/// The traversal's [`LeafEntry`] (from parameter 0, unbounded) of leaf `leaf` at `cell`
/// (or of a node of `side` cells there) for a ray whose parameters at the cell's entry planes
/// are `t0` and at its exit planes `t1` (the traversal's `(p - o) * (1 / d)`), when the ray
/// passes through the cell with positive length; its face normals zero until
/// [`add_normals`] makes them.
#[inline]
fn cell_entry(t0: Vec3A, t1: Vec3A, leaf: u32, cell: UVec3, side: u32) -> Option<LeafEntry> {
    let t_enter = max(t0.max_element(), 0.0);
    let t_exit = t1.min_element();
    (t_enter < t_exit).then_some(LeafEntry {
        leaf,
        cell,
        side,
        t_enter,
        t_exit,
        entry_normal: Vec3::ZERO,
        exit_normal: Vec3::ZERO,
    })
}

/// The hit tests the surfaces give a band: per leaf and per inner node standing for its
/// subtree.
struct Tests<L, N> {
    leaf: L,
    node: N,
}

/// The face normals of entry `e` ([`cell_entry`]'s `t0` and `t1`) for a ray whose mirrored
/// axes (negative direction components) are `mask`, as the traversal makes them.
#[inline]
fn add_normals(e: &mut LeafEntry, t0: Vec3A, t1: Vec3A, mask: u8) {
    e.entry_normal = entry_normal_of(mask, t0, 0.0);
    e.exit_normal = exit_normal_of(mask, t1);
}

#[inline]
fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

#[inline]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}
