//! The primary-ray prepass of [`crate::render`]: per pixel, a lower bound of the parameter
//! of the primary ray's first hit, `+inf` where the ray can hit nothing, so a render starts
//! each ray near its hit and skips the rays that miss.
//!
//! The surfaces offer boxes that together hold every surface
//! ([`crate::surfaces::Surfaces::coarse_boxes`]: for an octree, its occupied nodes a few
//! levels above the leaves). Each box is projected to a pixel rectangle (grown by a pixel)
//! and filed under the bands of rows it covers. A row then tests each pixel's ray against
//! the boxes whose rectangles hold it (a slab test on the box grown by a margin that covers
//! the `f32` rounding of the traversal's own planes). A ray's first hit lies in some box the
//! ray meets, and it meets that box no later than the hit, so the smallest entry over the
//! boxes it meets is a lower bound of the hit; a ray that meets none hits nothing.
//!
//! There is no prepass (every ray starts at the eye) when a box reaches behind the image
//! plane through the eye (its projection is not a rectangle) or when the rectangles would
//! cost more slab tests than they save rays.

use crate::camera::CameraRays;
use crate::surfaces::Surfaces;
use crate::whitted::{NO_BOX, PrimaryStart, START_BOXES, Tracer};
use glam::{DVec3, Vec3A};

/// Rows per band of the box lists.
const BAND: u32 = 8;

/// The fewest pixels per box projected (a set with more boxes is passed over for a
/// coarser one, where there is one).
const PIXELS_PER_BOX: u64 = 8;

/// The most slab tests per pixel (a test costs a few percent of tracing a ray from the eye).
const MAX_TESTS_PER_PIXEL: u64 = 16;

/// One box: its pixel rectangle (inclusive) and its corners relative to the eye, in grid
/// units, grown by the margin.
#[derive(Clone, Copy, Debug)]
struct Rect {
    /// Index into the coarse boxes.
    id: u32,
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    lo: Vec3A,
    hi: Vec3A,
}

/// The boxes of one view, filed by bands of rows, ready to give each row its ray starts.
#[derive(Debug)]
pub(crate) struct PrimaryPrepass {
    rects: Vec<Rect>,
    /// Per band of [`BAND`] rows, the indices of the rectangles that reach into it.
    bands: Vec<Vec<u32>>,
    /// The tracer's grid units per scene unit (ray parameters are in scene units).
    scale: f32,
}

impl PrimaryPrepass {
    /// The prepass of a view, when the tracer's options ask for one ([`Self::new`]).
    pub(crate) fn of_view<S: Surfaces>(tracer: &Tracer<S>, rays: &CameraRays) -> Option<Self> {
        if tracer.options().prepass {
            Self::new(tracer, rays)
        } else {
            None
        }
    }

    /// The starts of row `y` of a `width`-pixel image: from `prepass` ([`Self::row`]), or
    /// from the eye without one.
    pub(crate) fn starts(
        prepass: Option<&Self>,
        rays: &CameraRays,
        y: u32,
        width: u32,
    ) -> Vec<PrimaryStart> {
        let mut starts = vec![PrimaryStart::from(0.0); width as usize];
        if let Some(p) = prepass {
            p.row(rays, y, &mut starts);
        }
        starts
    }

    /// The prepass of `rays` (the tracer's camera) over `tracer`'s surfaces, or `None` when
    /// there is none to make (see the module notes).
    pub(crate) fn new<S: Surfaces>(tracer: &Tracer<S>, rays: &CameraRays) -> Option<Self> {
        let (w, h) = rays.size();
        let eye = tracer.to_grid(rays.eye());
        let (root, depth) = tracer.surfaces().grid();
        // Grid units: the margin covers the f32 rounding of the traversal's rays and planes
        // (relative 1e-7 of the coordinates and of the distance from the eye).
        let side = f64::from(1u32 << depth.min(31));
        let pad = 1e-3 + 1e-5 * side.max(f64::from(eye.abs().max_element()));
        let eye_d = eye.as_dvec3();
        let eye_s = rays.eye();
        let forward = rays.forward();
        // Points of a box at distance `g` from the eye that lie nearer the eye's image plane
        // than `zc = g * clip` are off the screen: such a point has depth `z < zc` and lies
        // at least `g` from the eye, so its distance from the view axis is at least
        // `g * sqrt(1 - clip^2) >= 0.86 g`, while a point on the screen at depth `z` is within
        // `z * sqrt(2) * reach < 0.36 g` of the axis (`reach`: the larger half extent of the
        // image plane at depth 1; `clip <= 1 / (4 reach)`).
        let reach = rays.half_extent().max_element();
        let clip = 1.0 / (4.0 * reach + 2.0);
        let (right, up) = (rays.right(), rays.up());
        // The rectangle (grown by a pixel, within the image) of the projection bounds, with
        // the box relative to the eye; `None` off the image.
        let rect = |id: u32, [x0, y0, x1, y1]: [f64; 4], lo: DVec3, hi: DVec3| {
            let rx0 = ((x0.floor() as i64) - 1).max(0);
            let ry0 = ((y0.floor() as i64) - 1).max(0);
            let rx1 = ((x1.ceil() as i64) + 1).min(i64::from(w) - 1);
            let ry1 = ((y1.ceil() as i64) + 1).min(i64::from(h) - 1);
            if rx0 > rx1 || ry0 > ry1 {
                return None;
            }
            // Relative to the eye; a corner exactly at the eye's coordinate moves out by the
            // margin again, so no slab test multiplies 0 by an infinite inverse.
            let rel = |v: DVec3, out: f64| {
                let r = v - eye_d;
                let fix = |c: f64| if c == 0.0 { out } else { c };
                Vec3A::new(fix(r.x) as f32, fix(r.y) as f32, fix(r.z) as f32)
            };
            Some(Rect {
                id,
                x0: rx0 as u32,
                y0: ry0 as u32,
                x1: rx1 as u32,
                y1: ry1 as u32,
                lo: rel(lo, -pad),
                hi: rel(hi, pad),
            })
        };
        let project = |&(id, lo, hi): &(u32, glam::Vec3, glam::Vec3)| -> Result<Option<Rect>, ()> {
            let lo = lo.as_dvec3() - pad;
            let hi = hi.as_dvec3() + pad;
            let lo_s = root.to_scene(lo, depth);
            let hi_s = root.to_scene(hi, depth);
            // The box's distance from the eye: a box that holds the eye or touches it has no
            // rectangle.
            let gap = (lo_s - eye_s).max(eye_s - hi_s).max(DVec3::ZERO).length();
            if !(gap > 0.0) {
                return Err(());
            }
            // The box in front of the plane at `zc` before the eye: its corners there and
            // where its edges cross the plane. The rest of it is off the screen or behind.
            let zc = gap * clip;
            // The corners in view space (along right, up, forward), from the low corner and
            // the three edge vectors.
            let v0 = lo_s - eye_s;
            let view = |v: DVec3| DVec3::new(v.dot(right), v.dot(up), v.dot(forward));
            let c0 = view(v0);
            let d = hi_s - lo_s;
            let ex = DVec3::new(right.x, up.x, forward.x) * d.x;
            let ey = DVec3::new(right.y, up.y, forward.y) * d.y;
            let ez = DVec3::new(right.z, up.z, forward.z) * d.z;
            let corners: [DVec3; 8] = std::array::from_fn(|i| {
                c0 + if i & 4 != 0 { ex } else { DVec3::ZERO }
                    + if i & 2 != 0 { ey } else { DVec3::ZERO }
                    + if i & 1 != 0 { ez } else { DVec3::ZERO }
            });
            let (mut x0, mut y0, mut x1, mut y1) = (
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            );
            if corners.iter().all(|c| c.z >= zc) {
                // Wholly in front: the rectangle of the corners' projections.
                for c in corners {
                    let (px, py) = rays.pixel_of_view(c);
                    x0 = x0.min(px);
                    y0 = y0.min(py);
                    x1 = x1.max(px);
                    y1 = y1.max(py);
                }
                return Ok(rect(id, [x0, y0, x1, y1], lo, hi));
            }
            let corner = |i: usize| {
                DVec3::new(
                    if i & 4 != 0 { hi_s.x } else { lo_s.x },
                    if i & 2 != 0 { hi_s.y } else { lo_s.y },
                    if i & 1 != 0 { hi_s.z } else { lo_s.z },
                )
            };
            let z = |p: DVec3| (p - eye_s).dot(forward);
            let mut any = false;
            let mut add = |p: DVec3| -> Result<(), ()> {
                let (px, py) = rays.project(p).ok_or(())?;
                x0 = x0.min(px);
                y0 = y0.min(py);
                x1 = x1.max(px);
                y1 = y1.max(py);
                any = true;
                Ok(())
            };
            for i in 0..8 {
                let a = corner(i);
                let za = z(a);
                if za >= zc {
                    add(a)?;
                }
                // The edges from this corner to those with one more bit set.
                for bit in [4, 2, 1] {
                    if i & bit == 0 {
                        let b = corner(i | bit);
                        let zb = z(b);
                        if (za < zc) != (zb < zc) {
                            add(a + (b - a) * ((zc - za) / (zb - za)))?;
                        }
                    }
                }
            }
            if !any {
                // Wholly behind the plane: off the screen or behind the eye.
                return Ok(None);
            }
            Ok(rect(id, [x0, y0, x1, y1], lo, hi))
        };
        // The finest set of boxes whose rectangles are not too many tests; a box that
        // reaches behind the eye does so in every coarser set too.
        let mut coarser = 0;
        let pixels = u64::from(w) * u64::from(h);
        let rects = loop {
            let boxes = tracer.surfaces().coarse_boxes(coarser)?;
            // Projecting a box costs about as much as tracing a few rays: a small image
            // takes a coarser set.
            if boxes.len() as u64 * PIXELS_PER_BOX > pixels
                && tracer.surfaces().coarse_boxes(coarser + 1).is_some()
            {
                coarser += 1;
                continue;
            }
            #[cfg(feature = "parallel")]
            let rects: Result<Vec<Option<Rect>>, ()> = {
                use rayon::prelude::*;
                boxes.par_iter().map(project).collect()
            };
            #[cfg(not(feature = "parallel"))]
            let rects: Result<Vec<Option<Rect>>, ()> = boxes.iter().map(project).collect();
            let rects: Vec<Rect> = rects.ok()?.into_iter().flatten().collect();
            let area: u64 = rects
                .iter()
                .map(|r| u64::from(r.x1 - r.x0 + 1) * u64::from(r.y1 - r.y0 + 1))
                .sum();
            if area <= MAX_TESTS_PER_PIXEL * u64::from(w) * u64::from(h) {
                break rects;
            }
            coarser += 1;
        };
        let mut bands = vec![Vec::new(); h.div_ceil(BAND) as usize];
        for (i, r) in (0u32..).zip(&rects) {
            for b in r.y0 / BAND..=r.y1 / BAND {
                bands[b as usize].push(i);
            }
        }
        Some(Self {
            rects,
            bands,
            scale: tracer.scale(),
        })
    }

    /// The starts of row `y`, one per pixel of `out` (the row's width long): where each
    /// pixel's ray may first hit and the boxes it meets first, or `+inf` where it hits
    /// nothing.
    pub(crate) fn row(&self, rays: &CameraRays, y: u32, out: &mut [PrimaryStart]) {
        // Nothing met yet: nothing to hit (the boxes fill in what they meet).
        out.fill(PrimaryStart {
            tmin: f32::INFINITY,
            boxes: [(NO_BOX, f32::INFINITY); START_BOXES],
            beyond: f32::INFINITY,
        });
        let Some(band) = self.bands.get((y / BAND) as usize) else {
            return;
        };
        let mut span = (u32::MAX, 0u32);
        for &i in band {
            let r = &self.rects[i as usize];
            if r.y0 <= y && y <= r.y1 {
                span = (span.0.min(r.x0), span.1.max(r.x1));
            }
        }
        if span.0 > span.1 {
            return;
        }
        // The inverse grid directions of the row's rays, as the traversal makes them, one
        // array per axis so the slab tests below run over several pixels at once.
        let len = (span.1 - span.0 + 1) as usize;
        let (mut ix, mut iy, mut iz) = (
            Vec::with_capacity(len),
            Vec::with_capacity(len),
            Vec::with_capacity(len),
        );
        for x in span.0..=span.1 {
            let inv = (rays.dir_f32(x, y) * self.scale).recip();
            ix.push(inv.x);
            iy.push(inv.y);
            iz.push(inv.z);
        }
        let mut near = vec![0.0f32; len];
        // No NaN can arise (no corner is at the eye's coordinate, and an infinite inverse
        // times a non-zero corner is infinite), so plain comparisons make min and max.
        let min = |a: f32, b: f32| if a < b { a } else { b };
        let max = |a: f32, b: f32| if a > b { a } else { b };
        for &i in band {
            let r = &self.rects[i as usize];
            if r.y0 > y || y > r.y1 {
                continue;
            }
            let (a, b) = ((r.x0 - span.0) as usize, (r.x1 - span.0) as usize + 1);
            let (lo, hi) = (r.lo, r.hi);
            for (((t, &ix), &iy), &iz) in near[a..b]
                .iter_mut()
                .zip(&ix[a..b])
                .zip(&iy[a..b])
                .zip(&iz[a..b])
            {
                let (x0, x1) = (lo.x * ix, hi.x * ix);
                let (y0, y1) = (lo.y * iy, hi.y * iy);
                let (z0, z1) = (lo.z * iz, hi.z * iz);
                let n = max(max(min(x0, x1), min(y0, y1)), min(z0, z1));
                let f = min(min(max(x0, x1), max(y0, y1)), max(z0, z1));
                // A margin for the f32 ray parameters of the traversal; +inf: missed.
                *t = if n <= f && f >= 0.0 {
                    max(n, 0.0) * (1.0 - 1e-4)
                } else {
                    f32::INFINITY
                };
            }
            for (v, &t) in out[r.x0 as usize..=r.x1 as usize]
                .iter_mut()
                .zip(&near[a..b])
            {
                if t < f32::INFINITY {
                    insert(v, r.id, t);
                }
            }
        }
    }
}

/// Files box `id`, met at `t`, among `v`'s first boxes (in order of entry); the entry of a
/// box that falls off the list lowers `beyond`.
#[inline]
fn insert(v: &mut PrimaryStart, id: u32, t: f32) {
    let last = v.boxes[START_BOXES - 1].1;
    if t >= last {
        v.beyond = v.beyond.min(t);
        return;
    }
    v.beyond = v.beyond.min(last);
    let mut k = START_BOXES - 1;
    while k > 0 && v.boxes[k - 1].1 > t {
        v.boxes[k] = v.boxes[k - 1];
        k -= 1;
    }
    v.boxes[k] = (id, t);
    v.tmin = v.boxes[0].1;
}
