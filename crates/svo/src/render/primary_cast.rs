//! Primary hits alone: per pixel, the first surface the camera ray meets and its distance,
//! without shading, secondary rays or the other AOVs. This is what picking needs, and what a
//! ray-casting library returns for a batch of camera rays (Embree's `rtcIntersect` gives the
//! hit primitive and distance), so it is the figure to set beside such libraries.
//!
//! It casts exactly the primary rays of [`crate::render::frame`] (the same directions, the same
//! prepass, the same first hits): its leaves and distances equal a render's leaf and depth
//! AOVs.

use crate::render::camera::{Camera, CameraError};
use crate::render::frame::NO_LEAF;
use crate::render::primary_prepass::{BAND, PrimaryBand, PrimaryScratch, PrimaryView};
use crate::render::surfaces::{FirstHit, Query, Surfaces};
use crate::render::whitted::{PrimaryStart, Tracer};
use crate::trace::grid_ray::GridRay;
use crate::trace::packet::LANES;
use std::time::{Duration, Instant};

/// The primary hits of a view, row-major from the top-left pixel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hits {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The leaf (or triangle) hit, [`NO_LEAF`] on a miss; an inner node hit with a level of
    /// detail is its index with [`crate::render::NODE_ID`] set.
    pub leaf: Vec<u32>,
    /// Hit distance in scene units along the unit ray, `+inf` on a miss.
    pub depth: Vec<f32>,
    /// Rays that hit.
    pub hits: u64,
    /// Traversal steps of all rays.
    pub steps: u64,
    /// Rays stopped by the step cap.
    pub capped: u64,
    /// The most steps of one ray.
    pub max_steps: u32,
    /// Wall time of the cast.
    pub elapsed: Duration,
}

/// Casts `camera`'s primary rays through `tracer`'s surfaces into `out` (reusing its
/// buffers), rows in parallel.
pub fn cast_primary<S: Surfaces>(
    tracer: &Tracer<S>,
    camera: &Camera,
    out: &mut Hits,
) -> Result<(), CameraError> {
    let rays = camera.rays()?;
    let start = Instant::now();
    let (w, h) = (camera.width, camera.height);
    let px = (w as usize) * (h as usize);
    out.width = w;
    out.height = h;
    out.leaf.resize(px, NO_LEAF);
    out.depth.resize(px, f32::INFINITY);
    let cone = tracer.primary_cone(camera);
    let view = PrimaryView::new(tracer, &rays, cone);
    let eye = tracer.to_grid(camera.eye);
    let scale = tracer.scale();
    let max_steps = tracer.options().max_steps;
    let band =
        |scratch: &mut PrimaryScratch, y0: u32, leaf: &mut [u32], depth: &mut [f32]| -> [u64; 4] {
            let mut counts = [0u64; 4];
            let px = leaf.len();
            let rows = (px / w as usize) as u32;
            let decided = view
                .as_ref()
                .map(|v| PrimaryBand::decided_by(v, tracer.surfaces(), y0, rows, scratch));
            let mut record = |i: usize, r: FirstHit| {
                leaf[i] = r.hit.map_or(NO_LEAF, |h| h.0);
                depth[i] = r.hit.map_or(f32::INFINITY, |h| h.1);
                counts[0] += u64::from(r.hit.is_some());
                counts[1] += u64::from(r.steps);
                counts[2] += u64::from(r.capped);
                counts[3] = counts[3].max(u64::from(r.steps));
            };
            let ray_of = |i: usize| {
                let (x, y) = ((i % w as usize) as u32, y0 + (i / w as usize) as u32);
                GridRay {
                    origin: eye,
                    dir: rays.dir_f32(x, y) * scale,
                }
            };
            if decided.is_none() && tracer.options().packets {
                // Every ray from the eye: neighbouring pixels in packets.
                let q = Query {
                    cone,
                    ..Query::all(max_steps)
                };
                for i in (0..px).step_by(LANES) {
                    let n = (px - i).min(LANES);
                    let packet = std::array::from_fn(|l| ray_of(i + l.min(n - 1)));
                    let hits = tracer.surfaces().first_hits(&packet, n, &q);
                    for (l, h) in hits.into_iter().take(n).enumerate() {
                        record(i + l, h);
                    }
                }
                return counts;
            }
            for i in 0..px {
                let start = decided
                    .as_ref()
                    .map_or(PrimaryStart::From(0.0), |b| b.start(i));
                let r = FirstHit::decided(&start).unwrap_or_else(|| {
                    // Left to the traversal, from the start's lower bound.
                    let tmin = match start {
                        PrimaryStart::From(t) => t,
                        _ => 0.0,
                    };
                    let q = Query {
                        tmin,
                        cone,
                        ..Query::all(max_steps)
                    };
                    tracer.surfaces().first_hit(&ray_of(i), &q, &start)
                });
                record(i, r);
            }
            counts
        };
    let chunk = w as usize * BAND as usize;
    let add = |a: [u64; 4], b: [u64; 4]| [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3].max(b[3])];
    #[cfg(feature = "parallel")]
    let counts = {
        use rayon::prelude::*;
        out.leaf
            .par_chunks_mut(chunk)
            .zip(out.depth.par_chunks_mut(chunk))
            .enumerate()
            .map_init(Default::default, |scratch, (b, (l, d))| {
                band(scratch, b as u32 * BAND, l, d)
            })
            .reduce(|| [0; 4], add)
    };
    #[cfg(not(feature = "parallel"))]
    let counts = {
        let mut scratch = Default::default();
        out.leaf
            .chunks_mut(chunk)
            .zip(out.depth.chunks_mut(chunk))
            .enumerate()
            .map(|(b, (l, d))| band(&mut scratch, b as u32 * BAND, l, d))
            .fold([0; 4], add)
    };
    out.hits = counts[0];
    out.steps = counts[1];
    out.capped = counts[2];
    out.max_steps = counts[3] as u32;
    out.elapsed = start.elapsed();
    Ok(())
}
