//! Rendering an image: one primary ray per pixel through a [`Tracer`], in parallel over
//! rows (rayon, with the `parallel` feature). Every pixel depends only on its own rays, so
//! the image is the same whatever the thread count.
//!
//! Besides the colour, a render keeps the per-pixel outputs (AOVs) of the primary ray: the
//! hit distance (scene units along the unit view ray, `+inf` on a miss), the shading
//! normal, the leaf index and the traversal steps (the cost heat map).

use crate::camera::{Camera, CameraError};
use crate::surfaces::Surfaces;
use crate::whitted::{SampleStats, Tracer};
use glam::Vec3;
use std::time::{Duration, Instant};

/// The leaf AOV value of a pixel whose primary ray misses.
pub const NO_LEAF: u32 = u32::MAX;

/// Counters over a whole image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
pub struct RenderStats {
    /// Primary rays (one per pixel).
    pub primary_rays: u64,
    /// Primary rays that hit a leaf.
    pub primary_hits: u64,
    /// Reflection and refraction rays.
    pub secondary_rays: u64,
    /// Shadow rays.
    pub shadow_rays: u64,
    /// Traversal steps of all rays.
    pub steps: u64,
    /// Traversal steps of the primary rays.
    pub primary_steps: u64,
    /// Largest primary-ray step count of a pixel.
    pub max_primary_steps: u32,
    /// Rays stopped by the step cap.
    pub capped: u64,
}

impl RenderStats {
    /// One line for reports: rays by kind, the share of primary hits, steps per primary
    /// ray and the capped count.
    pub fn summary(&self) -> String {
        format!(
            "rays: {} primary ({:.1}% hit), {} secondary, {} shadow; {:.1} steps per primary ray (max {}); {} capped",
            self.primary_rays,
            100.0 * self.primary_hits as f64 / self.primary_rays.max(1) as f64,
            self.secondary_rays,
            self.shadow_rays,
            self.primary_steps as f64 / self.primary_rays.max(1) as f64,
            self.max_primary_steps,
            self.capped
        )
    }

    fn add(&mut self, s: &SampleStats, primary_steps: u32, hit: bool) {
        self.primary_rays += 1;
        self.primary_hits += u64::from(hit);
        self.secondary_rays += u64::from(s.rays.saturating_sub(1));
        self.shadow_rays += u64::from(s.shadow_rays);
        self.steps += u64::from(s.steps);
        self.primary_steps += u64::from(primary_steps);
        self.max_primary_steps = self.max_primary_steps.max(primary_steps);
        self.capped += u64::from(s.capped);
    }

    fn merge(&mut self, o: &Self) {
        self.primary_rays += o.primary_rays;
        self.primary_hits += o.primary_hits;
        self.secondary_rays += o.secondary_rays;
        self.shadow_rays += o.shadow_rays;
        self.steps += o.steps;
        self.primary_steps += o.primary_steps;
        self.max_primary_steps = self.max_primary_steps.max(o.max_primary_steps);
        self.capped += o.capped;
    }
}

/// A rendered image with its AOVs, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB.
    pub colour: Vec<Vec3>,
    /// Primary hit distance in scene units, `+inf` on a miss.
    pub depth: Vec<f32>,
    /// Primary hit shading normal (zero on a miss).
    pub normal: Vec<Vec3>,
    /// Primary hit leaf index, [`NO_LEAF`] on a miss.
    pub leaf: Vec<u32>,
    /// Primary ray traversal steps.
    pub cost: Vec<u32>,
    /// Counters.
    pub stats: RenderStats,
    /// Wall time of the render.
    pub elapsed: Duration,
}

/// The primary-ray prepass: per pixel, a lower bound of the first hit's parameter
/// (`+inf` where nothing can be hit). Each coarse box around the surfaces is projected; its
/// pixel rectangle (grown by a pixel) gets the box's distance from the eye, a lower bound of
/// where any ray through it meets it, so a ray's first hit, which lies in some box whose
/// rectangle holds the ray's pixel, is never before its bound. `None` (no prepass) when the
/// eye is in a box or a box reaches behind it, or when the rectangles would cost more than
/// they save.
fn primary_starts<S: Surfaces>(
    tracer: &Tracer<S>,
    camera: &Camera,
    rays: &crate::camera::CameraRays,
) -> Option<Vec<f32>> {
    let boxes = tracer.surfaces().coarse_boxes()?;
    let (w, h) = (i64::from(camera.width), i64::from(camera.height));
    let eye = camera.eye;
    let mut rects = Vec::with_capacity(boxes.len());
    let mut area = 0i64;
    for (lo_g, hi_g) in boxes {
        let lo = tracer.to_scene(lo_g);
        let hi = tracer.to_scene(hi_g);
        let gap = (lo - eye).max(eye - hi).max(glam::DVec3::ZERO);
        let dist = gap.length();
        if !(dist > 0.0) {
            return None;
        }
        let (mut x0, mut y0, mut x1, mut y1) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for i in 0..8 {
            let c = glam::DVec3::new(
                if i & 4 != 0 { hi.x } else { lo.x },
                if i & 2 != 0 { hi.y } else { lo.y },
                if i & 1 != 0 { hi.z } else { lo.z },
            );
            let (px, py) = rays.project(c)?;
            x0 = x0.min(px);
            y0 = y0.min(py);
            x1 = x1.max(px);
            y1 = y1.max(py);
        }
        let rx0 = ((x0.floor() as i64) - 1).max(0);
        let ry0 = ((y0.floor() as i64) - 1).max(0);
        let rx1 = ((x1.ceil() as i64) + 1).min(w - 1);
        let ry1 = ((y1.ceil() as i64) + 1).min(h - 1);
        if rx0 > rx1 || ry0 > ry1 {
            continue;
        }
        area += (rx1 - rx0 + 1) * (ry1 - ry0 + 1);
        // A margin for the f32 ray parameters of the traversal.
        rects.push((rx0, ry0, rx1, ry1, (dist * (1.0 - 1e-4)) as f32));
    }
    // Filling a pixel costs about a hundredth of tracing one: 32 layers still pay.
    if area > 32 * w * h {
        return None;
    }
    let mut starts = vec![f32::INFINITY; (w * h) as usize];
    for (rx0, ry0, rx1, ry1, t) in rects {
        for y in ry0..=ry1 {
            let row = &mut starts[(y * w) as usize..][..w as usize];
            for v in &mut row[rx0 as usize..=rx1 as usize] {
                *v = v.min(t);
            }
        }
    }
    Some(starts)
}

/// Renders `camera`'s view through `tracer` into a new frame.
pub fn render<S: Surfaces>(tracer: &Tracer<S>, camera: &Camera) -> Result<Frame, CameraError> {
    let mut f = Frame {
        width: 0,
        height: 0,
        colour: Vec::new(),
        depth: Vec::new(),
        normal: Vec::new(),
        leaf: Vec::new(),
        cost: Vec::new(),
        stats: RenderStats::default(),
        elapsed: Duration::ZERO,
    };
    render_into(tracer, camera, &mut f)?;
    Ok(f)
}

/// Renders once, or, with `frames`, once untimed and then that many timed frames into the
/// same buffers (at least one): the last frame and the time of each counted frame, seconds.
pub fn render_timed<S: Surfaces>(
    tracer: &Tracer<S>,
    camera: &Camera,
    frames: Option<u32>,
) -> Result<(Frame, Vec<f64>), CameraError> {
    let mut frame = render(tracer, camera)?;
    let mut times = Vec::new();
    match frames {
        Some(n) => {
            for _ in 0..n.max(1) {
                render_into(tracer, camera, &mut frame)?;
                times.push(frame.elapsed.as_secs_f64());
            }
        }
        None => times.push(frame.elapsed.as_secs_f64()),
    }
    Ok((frame, times))
}

/// Renders into `f`, reusing its buffers (a benchmark loop then allocates nothing per
/// frame). Rows are rendered in parallel, each written in place.
pub fn render_into<S: Surfaces>(
    tracer: &Tracer<S>,
    camera: &Camera,
    f: &mut Frame,
) -> Result<(), CameraError> {
    let rays = camera.rays()?;
    let start = Instant::now();
    let (w, h) = (camera.width, camera.height);
    let px = (w as usize) * (h as usize);
    f.width = w;
    f.height = h;
    f.colour.resize(px, Vec3::ZERO);
    f.depth.resize(px, f32::INFINITY);
    f.normal.resize(px, Vec3::ZERO);
    f.leaf.resize(px, NO_LEAF);
    f.cost.resize(px, 0);
    let eye = tracer.to_grid(camera.eye);
    let starts = if tracer.options().prepass {
        primary_starts(tracer, camera, &rays)
    } else {
        None
    };
    let starts = starts.as_deref();
    let row = |y: u32,
               colour: &mut [Vec3],
               depth: &mut [f32],
               normal: &mut [Vec3],
               leaf: &mut [u32],
               cost: &mut [u32]|
     -> RenderStats {
        let mut stats = RenderStats::default();
        for x in 0..w {
            // The grid direction of a unit scene direction is the same unit vector (the
            // mapping is a uniform scale); the tracer scales it so `t` is in scene units.
            let tmin = starts.map_or(0.0, |m| m[y as usize * w as usize + x as usize]);
            let s = tracer.trace_from(eye, rays.dir_f32(x, y), tmin);
            let i = x as usize;
            colour[i] = s.colour;
            depth[i] = s.hit.map_or(f32::INFINITY, |h| h.t);
            normal[i] = s.normal;
            leaf[i] = s.hit.map_or(NO_LEAF, |h| h.id);
            cost[i] = s.primary_steps;
            stats.add(&s.stats, s.primary_steps, s.hit.is_some());
        }
        stats
    };
    let wu = w as usize;
    #[cfg(feature = "parallel")]
    let stats = {
        use rayon::prelude::*;
        f.colour
            .par_chunks_mut(wu)
            .zip(f.depth.par_chunks_mut(wu))
            .zip(f.normal.par_chunks_mut(wu))
            .zip(f.leaf.par_chunks_mut(wu))
            .zip(f.cost.par_chunks_mut(wu))
            .enumerate()
            .map(|(y, ((((c, d), n), l), k))| row(y as u32, c, d, n, l, k))
            .reduce(RenderStats::default, |mut a, b| {
                a.merge(&b);
                a
            })
    };
    #[cfg(not(feature = "parallel"))]
    let stats = {
        let mut st = RenderStats::default();
        for ((((y, c), d), n), (l, k)) in f
            .colour
            .chunks_mut(wu)
            .enumerate()
            .zip(f.depth.chunks_mut(wu))
            .zip(f.normal.chunks_mut(wu))
            .zip(f.leaf.chunks_mut(wu).zip(f.cost.chunks_mut(wu)))
        {
            st.merge(&row(y as u32, c, d, n, l, k));
        }
        st
    };
    f.stats = stats;
    f.elapsed = start.elapsed();
    Ok(())
}
