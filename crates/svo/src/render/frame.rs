//! Rendering an image: one primary ray per pixel through a [`Tracer`], in parallel over
//! bands of rows (rayon, with the `parallel` feature), each band's primary rays first decided
//! together by the prepass ([`crate::render::primary_prepass`]). Every pixel depends only on its own rays, so
//! the image is the same whatever the thread count.
//!
//! Besides the colour, a render keeps the per-pixel outputs (AOVs) of the primary ray: the
//! hit distance (scene units along the unit view ray, `+inf` on a miss), the shading
//! normal, the leaf index and the traversal steps (the cost heat map).

use crate::render::camera::{Camera, CameraError, CameraRays};
use crate::render::primary_prepass::{BAND, PrimaryBand, PrimaryScratch, PrimaryView};
use crate::render::surfaces::Surfaces;
use crate::render::whitted::{PrimaryStart, Sample, SampleStats, Tracer};
use crate::trace::cone::Cone;
use crate::trace::packet::LANES;
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
    /// ray and per other ray, and the capped count.
    pub fn summary(&self) -> String {
        let others = self.secondary_rays + self.shadow_rays;
        format!(
            "rays: {} primary ({:.1}% hit), {} secondary, {} shadow; {:.1} steps per primary ray (max {}), {:.1} per other ray; {} capped",
            self.primary_rays,
            100.0 * self.primary_hits as f64 / self.primary_rays.max(1) as f64,
            self.secondary_rays,
            self.shadow_rays,
            self.primary_steps as f64 / self.primary_rays.max(1) as f64,
            self.max_primary_steps,
            self.steps.saturating_sub(self.primary_steps) as f64 / others.max(1) as f64,
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
    /// Primary hit leaf index, [`NO_LEAF`] on a miss; an inner node hit with a level of
    /// detail is its index with [`crate::render::NODE_ID`] set.
    pub leaf: Vec<u32>,
    /// Primary ray traversal steps.
    pub cost: Vec<u32>,
    /// Counters.
    pub stats: RenderStats,
    /// Wall time of the render.
    pub elapsed: Duration,
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

/// A band of rows' slices of a frame's buffers, and its counters.
struct BandOut<'a> {
    colour: &'a mut [Vec3],
    depth: &'a mut [f32],
    normal: &'a mut [Vec3],
    leaf: &'a mut [u32],
    cost: &'a mut [u32],
    stats: RenderStats,
}

impl BandOut<'_> {
    /// Pixel `i`, whose ray the prepass proved to hit nothing after `tests` leaf tests: the
    /// sky, without casting it.
    #[inline]
    fn miss(&mut self, i: usize, sky: Vec3, tests: u32) {
        self.colour[i] = sky;
        self.depth[i] = f32::INFINITY;
        self.normal[i] = Vec3::ZERO;
        self.leaf[i] = NO_LEAF;
        self.cost[i] = tests;
        let st = &mut self.stats;
        st.primary_rays += 1;
        st.primary_steps += u64::from(tests);
        st.steps += u64::from(tests);
        st.max_primary_steps = st.max_primary_steps.max(tests);
    }

    /// Pixel `i`, traced.
    #[inline]
    fn sample(&mut self, i: usize, s: &Sample) {
        self.colour[i] = s.colour;
        self.depth[i] = s.hit.map_or(f32::INFINITY, |h| h.t);
        self.normal[i] = s.normal;
        self.leaf[i] = s.hit.map_or(NO_LEAF, |h| h.id);
        self.cost[i] = s.primary_steps;
        self.stats.add(&s.stats, s.primary_steps, s.hit.is_some());
    }
}

/// What every band of one frame shares: the tracer, the camera's rays, the eye in grid
/// coordinates and the prepass's view.
struct Bands<'a, S: Surfaces> {
    tracer: &'a Tracer<S>,
    rays: &'a CameraRays,
    eye: Vec3,
    width: u32,
    view: Option<PrimaryView>,
    /// The primary rays' footprint.
    cone: Cone,
}

impl<S: Surfaces> Bands<'_, S> {
    /// One band of rows starting at row `y0`: its primary rays decided together, then each
    /// pixel shaded into `out` (whose buffers hold the band's pixels).
    fn render(&self, scratch: &mut PrimaryScratch, y0: u32, mut out: BandOut<'_>) -> RenderStats {
        let rows = (out.colour.len() / self.width as usize) as u32;
        let decided = self
            .view
            .as_ref()
            .map(|v| PrimaryBand::decided_by(v, self.tracer.surfaces(), y0, rows, scratch));
        let start = |i: usize| {
            decided
                .as_ref()
                .map_or(PrimaryStart::From(0.0), |b| b.start(i))
        };
        if self.tracer.packs() {
            self.packed(y0, rows, &start, &mut out);
        } else {
            self.single(y0, rows, &start, &mut out);
        }
        out.stats
    }

    /// The band's pixels `(index in the band, x, y)`, row by row.
    fn pixels(&self, y0: u32, rows: u32) -> impl Iterator<Item = (usize, u32, u32)> + use<'_, S> {
        let w = self.width;
        (0..rows)
            .flat_map(move |r| (0..w).map(move |x| (x, y0 + r)))
            .enumerate()
            .map(|(i, (x, y))| (i, x, y))
    }

    /// Four neighbouring pixels at a time, their rays after the primary ones walked together.
    fn packed(
        &self,
        y0: u32,
        rows: u32,
        start: &impl Fn(usize) -> PrimaryStart,
        out: &mut BandOut<'_>,
    ) {
        let tracer = self.tracer;
        let mut group = [(0usize, Vec3::ZERO, PrimaryStart::From(0.0)); LANES];
        let mut n = 0;
        for p in self.pixels(y0, rows).map(Some).chain([None]) {
            if let Some((i, x, y)) = p {
                let start = start(i);
                let dir = self.rays.dir_f32(x, y);
                if let PrimaryStart::Miss { tests } = start {
                    out.miss(i, tracer.miss_colour(dir), tests);
                    continue;
                }
                group[n] = (i, dir, start);
                n += 1;
                if n < LANES {
                    continue;
                }
            } else if n == 0 {
                break;
            }
            let samples = tracer.trace_primary4(
                self.eye,
                &group.map(|g| g.1),
                &group.map(|g| g.2),
                n,
                self.cone,
            );
            for (s, &(i, ..)) in samples.iter().zip(&group).take(n) {
                out.sample(i, s);
            }
            n = 0;
        }
    }

    /// One pixel at a time.
    fn single(
        &self,
        y0: u32,
        rows: u32,
        start: &impl Fn(usize) -> PrimaryStart,
        out: &mut BandOut<'_>,
    ) {
        for (i, x, y) in self.pixels(y0, rows) {
            let start = start(i);
            // The grid direction of a unit scene direction is the same unit vector (the
            // mapping is a uniform scale); the tracer scales it so `t` is in scene units.
            let dir = self.rays.dir_f32(x, y);
            if let PrimaryStart::Miss { tests } = start {
                // The prepass proved the ray hits nothing: the sky, without casting it.
                out.miss(i, self.tracer.miss_colour(dir), tests);
                continue;
            }
            out.sample(
                i,
                &self.tracer.trace_primary(self.eye, dir, start, self.cone),
            );
        }
    }
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
    let cone = tracer.primary_cone(camera);
    let bands = Bands {
        tracer,
        rays: &rays,
        eye: tracer.to_grid(camera.eye),
        width: w,
        view: PrimaryView::new(tracer, &rays, cone),
        cone,
    };
    let band = |scratch: &mut PrimaryScratch,
                y0: u32,
                colour: &mut [Vec3],
                depth: &mut [f32],
                normal: &mut [Vec3],
                leaf: &mut [u32],
                cost: &mut [u32]| {
        let out = BandOut {
            colour,
            depth,
            normal,
            leaf,
            cost,
            stats: RenderStats::default(),
        };
        bands.render(scratch, y0, out)
    };
    let chunk = w as usize * BAND as usize;
    #[cfg(feature = "parallel")]
    let stats = {
        use rayon::prelude::*;
        f.colour
            .par_chunks_mut(chunk)
            .zip(f.depth.par_chunks_mut(chunk))
            .zip(f.normal.par_chunks_mut(chunk))
            .zip(f.leaf.par_chunks_mut(chunk))
            .zip(f.cost.par_chunks_mut(chunk))
            .enumerate()
            .map_init(Default::default, |scratch, (b, ((((c, d), n), l), k))| {
                band(scratch, b as u32 * BAND, c, d, n, l, k)
            })
            .reduce(RenderStats::default, |mut a, b| {
                a.merge(&b);
                a
            })
    };
    #[cfg(not(feature = "parallel"))]
    let stats = {
        let mut st = RenderStats::default();
        let mut scratch = Default::default();
        for ((((b, c), d), n), (l, k)) in f
            .colour
            .chunks_mut(chunk)
            .enumerate()
            .zip(f.depth.chunks_mut(chunk))
            .zip(f.normal.chunks_mut(chunk))
            .zip(f.leaf.chunks_mut(chunk).zip(f.cost.chunks_mut(chunk)))
        {
            st.merge(&band(&mut scratch, b as u32 * BAND, c, d, n, l, k));
        }
        st
    };
    f.stats = stats;
    f.elapsed = start.elapsed();
    Ok(())
}
