//! Rendering an image: one primary ray per pixel through a [`Tracer`], in parallel over
//! tiles (rayon, with the `parallel` feature). Every pixel depends only on its own rays, so
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

/// Tile side in pixels.
const TILE: u32 = 16;

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

struct Tile {
    colour: Vec<Vec3>,
    depth: Vec<f32>,
    normal: Vec<Vec3>,
    leaf: Vec<u32>,
    cost: Vec<u32>,
    stats: RenderStats,
}

/// Renders `camera`'s view through `tracer`.
pub fn render<S: Surfaces>(tracer: &Tracer<S>, camera: &Camera) -> Result<Frame, CameraError> {
    let rays = camera.rays()?;
    let start = Instant::now();
    let (w, h) = (camera.width, camera.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let eye = tracer.to_grid(camera.eye);
    let do_tile = |ti: u32| -> Tile {
        let (tx, ty) = (ti % tiles_x, ti / tiles_x);
        let x0 = tx * TILE;
        let y0 = ty * TILE;
        let x1 = (x0 + TILE).min(w);
        let y1 = (y0 + TILE).min(h);
        let n = ((x1 - x0) * (y1 - y0)) as usize;
        let mut t = Tile {
            colour: Vec::with_capacity(n),
            depth: Vec::with_capacity(n),
            normal: Vec::with_capacity(n),
            leaf: Vec::with_capacity(n),
            cost: Vec::with_capacity(n),
            stats: RenderStats::default(),
        };
        for y in y0..y1 {
            for x in x0..x1 {
                // The grid direction of a unit scene direction is the same unit vector (the
                // mapping is a uniform scale); the tracer scales it so `t` is in scene units.
                let d = rays.dir(x, y).as_vec3();
                let s = tracer.trace(eye, d);
                t.colour.push(s.colour);
                t.depth.push(s.hit.map_or(f32::INFINITY, |h| h.t));
                t.normal.push(s.normal);
                t.leaf.push(s.hit.map_or(NO_LEAF, |h| h.id));
                t.cost.push(s.primary_steps);
                t.stats.add(&s.stats, s.primary_steps, s.hit.is_some());
            }
        }
        t
    };
    let count = tiles_x * tiles_y;
    #[cfg(feature = "parallel")]
    let tiles: Vec<Tile> = {
        use rayon::prelude::*;
        (0..count).into_par_iter().map(do_tile).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let tiles: Vec<Tile> = (0..count).map(do_tile).collect();

    let px = (w as usize) * (h as usize);
    let mut f = Frame {
        width: w,
        height: h,
        colour: vec![Vec3::ZERO; px],
        depth: vec![f32::INFINITY; px],
        normal: vec![Vec3::ZERO; px],
        leaf: vec![NO_LEAF; px],
        cost: vec![0; px],
        stats: RenderStats::default(),
        elapsed: Duration::ZERO,
    };
    for (ti, t) in tiles.iter().enumerate() {
        let ti = ti as u32;
        let (x0, y0) = ((ti % tiles_x) * TILE, (ti / tiles_x) * TILE);
        let tw = ((x0 + TILE).min(w) - x0) as usize;
        for (k, ((((c, d), n), l), s)) in t
            .colour
            .iter()
            .zip(&t.depth)
            .zip(&t.normal)
            .zip(&t.leaf)
            .zip(&t.cost)
            .enumerate()
        {
            let (x, y) = (x0 as usize + k % tw, y0 as usize + k / tw);
            let i = y * w as usize + x;
            f.colour[i] = *c;
            f.depth[i] = *d;
            f.normal[i] = *n;
            f.leaf[i] = *l;
            f.cost[i] = *s;
        }
        f.stats.merge(&t.stats);
    }
    f.elapsed = start.elapsed();
    Ok(f)
}
