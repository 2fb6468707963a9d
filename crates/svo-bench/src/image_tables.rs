//! Images against run time: for a view and a baked tree, the shaded render in each hit mode
//! (cube, contour, exact triangles) timed beside its error against the triangle reference of
//! the same camera, lights and shading; primary-ray throughput; and the octree walk against
//! the dense-grid DDA on the same rays.

use crate::report::median;
use crate::views::View;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;
use svo::Octree;
use svo::mesh::Mesh;
use svo::render::{
    Camera, CameraRays, Frame, MeshSurfaces, OctreeSurfaces, Phong, PointLight, RenderScene,
    ShadowMode, Sky, Surfaces, TraceOptions, Tracer, exact_surfaces,
};
use svo::trace::{DenseGrid, GridRay, HitMode, MAX_STEPS, cast, leaf_hit, traverse_dda};
use svo_view::gpu_context::GpuContext;
use svo_view::headless::render_scene;
use svo_view::timing::{cast_timed, render_timed};

/// One render measured against the reference.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ImageRow {
    /// The view.
    pub view: View,
    /// Tree depth.
    pub depth: u8,
    /// `cube`, `contour`, `exact` or `triangles`.
    pub mode: &'static str,
    /// Median seconds per frame.
    pub seconds: f64,
    /// RMSE on 8-bit sRGB against the reference.
    pub rmse: f64,
    /// PSNR, dB.
    pub psnr: f64,
    /// Share of pixels that hit in one image and miss in the other.
    pub mismatch: f64,
    /// Primary-hit distance error against the reference, cells: mean and 95th percentile.
    pub depth_err: (f64, f64),
    /// Traversal steps per primary ray.
    pub steps: f64,
    /// Rays that reached the step cap.
    pub capped: u64,
    /// Rays per frame (primary, secondary and shadow).
    pub rays: u64,
    /// Median seconds per frame on the GPU, and the GPU image's PSNR against the CPU image.
    pub gpu: Option<(f64, f64)>,
}

/// The frames of one view at one depth kept for the report's pictures.
pub struct ViewFrames {
    /// The contour render.
    pub contour: Frame,
    /// The triangle reference.
    pub reference: Frame,
}

/// The tracer of the report's renders: `s` under one point light, the default sky and Phong
/// factors, with `o`.
pub(crate) fn tracer<S: Surfaces>(s: S, light: PointLight, o: TraceOptions) -> Tracer<S> {
    Tracer::new(s, &[light], Sky::default(), Phong::default(), o)
}

/// `runs` timed frames of `t` through `cam` after a warm-up: the last frame and the median
/// seconds.
pub(crate) fn timed<S: Surfaces>(
    t: &Tracer<S>,
    cam: &Camera,
    runs: u32,
) -> anyhow::Result<(Frame, f64)> {
    let (f, times) = render_timed(t, cam, Some(runs))?;
    Ok((f, median(&times)))
}

/// Primary-hit distance error in cells over the pixels where both hit: mean and p95.
fn depth_error(a: &Frame, r: &Frame, cells_per_unit: f64) -> (f64, f64) {
    let mut e: Vec<f64> = a
        .depth
        .iter()
        .zip(&r.depth)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| f64::from((x - y).abs()) * cells_per_unit)
        .collect();
    if e.is_empty() {
        return (0.0, 0.0);
    }
    e.sort_by(f64::total_cmp);
    let mean = e.iter().sum::<f64>() / e.len() as f64;
    (mean, e[((e.len() - 1) as f64 * 0.95) as usize])
}

fn row(
    view: View,
    depth: u8,
    mode: &'static str,
    f: &Frame,
    seconds: f64,
    reference: &Frame,
    cells_per_unit: f64,
) -> ImageRow {
    let d = svo::render::compare(f, reference).expect("frames of one camera");
    let s = &f.stats;
    ImageRow {
        view,
        depth,
        mode,
        seconds,
        rmse: d.rmse,
        psnr: d.psnr_db,
        mismatch: d.hit_mismatch,
        depth_err: depth_error(f, reference, cells_per_unit),
        steps: s.primary_steps as f64 / s.primary_rays.max(1) as f64,
        capped: s.capped,
        rays: s.primary_rays + s.secondary_rays + s.shadow_rays,
        gpu: None,
    }
}

/// The same frame on the GPU: median seconds of `runs` frames after an untimed one, and the
/// PSNR of its image against the CPU's.
fn gpu_frame(
    ctx: &GpuContext,
    tree: &Octree,
    cam: &Camera,
    light: PointLight,
    mode: HitMode,
    runs: u32,
    cpu: &Frame,
) -> anyhow::Result<(f64, f64)> {
    let scene = RenderScene {
        tree: tree.clone(),
        camera: *cam,
        lights: vec![light],
        sky: Sky::default(),
        phong: Phong::default(),
        views: Vec::new(),
    };
    let opts = TraceOptions {
        mode,
        ..TraceOptions::default()
    };
    let g = render_scene(ctx, &scene, &opts, &Default::default(), Some(runs))?;
    let d = svo::render::compare(&g.frame, cpu).expect("frames of one camera");
    Ok((median(&g.times), d.psnr_db))
}

/// Renders `view` of `tree` (baked from `mesh`) in every hit mode and as triangles, `runs`
/// timed frames each after a warm-up; cube and contour also on `gpu` when given.
pub fn measure_view(
    view: View,
    tree: &Octree,
    mesh: &Mesh,
    (width, height): (u32, u32),
    runs: u32,
    gpu: Option<&GpuContext>,
) -> anyhow::Result<(Vec<ImageRow>, ViewFrames)> {
    let (lo, hi) = mesh.bounds().ok_or_else(|| anyhow::anyhow!("empty mesh"))?;
    let cam = view.camera(lo, hi, width, height);
    let light = view.light(lo, hi, &cam);
    let opts = TraceOptions::default();
    let depth = tree.depth;
    let cells_per_unit = f64::from(1u32 << depth) / tree.root.side;
    let reference_tracer = tracer(
        MeshSurfaces::new(mesh.clone(), tree.root, depth),
        light,
        opts,
    );
    let (reference, ref_s) = timed(&reference_tracer, &cam, runs)?;
    let mut rows = Vec::new();
    let mut contour = None;
    for mode in [HitMode::Cube, HitMode::Contour] {
        let (f, s) = timed(
            &tracer(OctreeSurfaces::new(tree, mode), light, opts),
            &cam,
            runs,
        )?;
        let mut r = row(view, depth, mode.name(), &f, s, &reference, cells_per_unit);
        if let Some(ctx) = gpu {
            r.gpu = Some(gpu_frame(ctx, tree, &cam, light, mode, runs, &f)?);
        }
        rows.push(r);
        if mode == HitMode::Contour {
            contour = Some(f);
        }
    }
    let exact = exact_surfaces(tree, mesh).map_err(anyhow::Error::msg)?;
    let (f, s) = timed(&tracer(exact, light, opts), &cam, runs)?;
    rows.push(row(view, depth, "exact", &f, s, &reference, cells_per_unit));
    rows.push(row(
        view,
        depth,
        "triangles",
        &reference,
        ref_s,
        &reference,
        cells_per_unit,
    ));
    Ok((
        rows,
        ViewFrames {
            contour: contour.expect("the contour mode ran"),
            reference,
        },
    ))
}

/// Primary-ray throughput of one configuration.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Throughput {
    /// Depth.
    pub depth: u8,
    /// Hit mode, or `triangles`.
    pub mode: &'static str,
    /// Whether the frame was the first hits alone ([`svo::render::cast_primary`]: what a ray-casting
    /// library returns) rather than a shaded image with its AOVs.
    pub cast: bool,
    /// Median seconds per frame.
    pub seconds: f64,
    /// Millions of primary rays per second.
    pub mrays: f64,
    /// Share of rays that hit.
    pub hit: f64,
}

/// Primary rays only (no bounces, no shadows) of the framed view, `runs` frames after a
/// warm-up; with the triangle reference for the same rays.
pub fn throughput(
    tree: &Octree,
    mesh: &Mesh,
    (width, height): (u32, u32),
    runs: u32,
) -> anyhow::Result<Vec<Throughput>> {
    let (lo, hi) = mesh.bounds().ok_or_else(|| anyhow::anyhow!("empty mesh"))?;
    let cam = View::Framed.camera(lo, hi, width, height);
    let light = View::Framed.light(lo, hi, &cam);
    let opts = TraceOptions {
        max_reflections: 0,
        max_refractions: 0,
        shadows: ShadowMode::None,
        ..TraceOptions::default()
    };
    let n = f64::from(width) * f64::from(height);
    let mut out = Vec::new();
    let mut push = |mode: &'static str, cast: bool, hits: u64, s: f64| {
        out.push(Throughput {
            depth: tree.depth,
            mode,
            cast,
            seconds: s,
            mrays: n / s / 1e6,
            hit: hits as f64 / n,
        });
    };
    for mode in [HitMode::Cube, HitMode::Contour] {
        let o = TraceOptions { mode, ..opts };
        let t = tracer(OctreeSurfaces::new(tree, mode), light, o);
        let (f, s) = timed(&t, &cam, runs)?;
        push(mode.name(), false, f.stats.primary_hits, s);
        let (st, times) = cast_timed(&t, &cam, Some(runs))?;
        push(mode.name(), true, st.primary_hits, median(&times));
    }
    let reference = tracer(
        MeshSurfaces::new(mesh.clone(), tree.root, tree.depth),
        light,
        opts,
    );
    let (f, s) = timed(&reference, &cam, runs)?;
    push("triangles", false, f.stats.primary_hits, s);
    let (st, times) = cast_timed(&reference, &cam, Some(runs))?;
    push("triangles", true, st.primary_hits, median(&times));
    Ok(out)
}

/// General rays: the first hits of primary rays traced from the eye without the prepass,
/// so that every ray goes through the general traversal as reflection, refraction and shadow
/// rays do (`svo-view --cpu --bench --cast --no-prepass --threads 1`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct GeneralRays {
    /// Camera: `framed` or `close-up`.
    pub camera: &'static str,
    /// Depth.
    pub depth: u8,
    /// Hit mode.
    pub mode: &'static str,
    /// Median seconds per frame, one thread.
    pub seconds: f64,
    /// Millions of rays per second, one thread.
    pub mrays: f64,
    /// Traversal steps per ray.
    pub steps: f64,
    /// Share of rays that hit.
    pub hit: f64,
}

/// The cameras of [`general_rays`]: the framed view and a close-up (the framed camera moved
/// to 0.6 of its distance from the target, about a third of the pixels on the model).
pub fn general_cameras(
    mesh: &Mesh,
    (width, height): (u32, u32),
) -> anyhow::Result<[(&'static str, Camera); 2]> {
    let (lo, hi) = mesh.bounds().ok_or_else(|| anyhow::anyhow!("empty mesh"))?;
    let framed = View::Framed.camera(lo, hi, width, height);
    let close = Camera {
        eye: framed.target + (framed.eye - framed.target) * 0.6,
        ..framed
    };
    Ok([("framed", framed), ("close-up", close)])
}

/// [`GeneralRays`] for both [`general_cameras`], cube and contour hits, on one thread.
pub fn general_rays(
    tree: &Octree,
    mesh: &Mesh,
    size: (u32, u32),
    runs: u32,
) -> anyhow::Result<Vec<GeneralRays>> {
    let (lo, hi) = mesh.bounds().ok_or_else(|| anyhow::anyhow!("empty mesh"))?;
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let mut out = Vec::new();
    for (name, cam) in general_cameras(mesh, size)? {
        let light = View::Framed.light(lo, hi, &cam);
        for mode in [HitMode::Cube, HitMode::Contour] {
            let o = TraceOptions {
                mode,
                max_reflections: 0,
                max_refractions: 0,
                shadows: ShadowMode::None,
                prepass: false,
                ..TraceOptions::default()
            };
            let t = tracer(OctreeSurfaces::new(tree, mode), light, o);
            let (st, times) = one.install(|| cast_timed(&t, &cam, Some(runs)))?;
            let s = median(&times);
            let n = st.primary_rays.max(1) as f64;
            out.push(GeneralRays {
                camera: name,
                depth: tree.depth,
                mode: mode.name(),
                seconds: s,
                mrays: n / s / 1e6,
                steps: st.primary_steps as f64 / n,
                hit: st.primary_hits as f64 / n,
            });
        }
    }
    Ok(out)
}

/// The octree walk against the dense-grid DDA on the same primary rays (framed view, cube
/// hits, no shading).
#[derive(Clone, Debug, serde::Serialize)]
pub struct DdaRow {
    /// Depth.
    pub depth: u8,
    /// Octree median seconds per frame.
    pub octree: f64,
    /// DDA median seconds per frame.
    pub dda: f64,
    /// Pixels whose hit differs.
    pub differ: usize,
    /// Bytes of the dense grid.
    pub grid_bytes: usize,
}

fn primary_only(
    rays: &CameraRays,
    (w, h): (u32, u32),
    eye: Vec3,
    scale: f32,
    runs: u32,
    cast: &(dyn Fn(&GridRay) -> Option<f32> + Sync),
) -> (Vec<Option<f32>>, f64) {
    let once = || -> Vec<Option<f32>> {
        (0..h)
            .into_par_iter()
            .flat_map_iter(|y| {
                (0..w).map(move |x| {
                    cast(&GridRay {
                        origin: eye,
                        dir: rays.dir_f32(x, y) * scale,
                    })
                })
            })
            .collect()
    };
    let mut out = once();
    let mut times = Vec::new();
    for _ in 0..runs.max(1) {
        let t0 = Instant::now();
        out = once();
        times.push(t0.elapsed().as_secs_f64());
    }
    (out, median(&times))
}

/// Measures the octree against the DDA on `tree` (depth at most
/// [`svo::trace::MAX_DDA_DEPTH`]).
pub fn dda(tree: &Octree, mesh: &Mesh, size: (u32, u32), runs: u32) -> anyhow::Result<DdaRow> {
    let (lo, hi) = mesh.bounds().ok_or_else(|| anyhow::anyhow!("empty mesh"))?;
    let cam = View::Framed.camera(lo, hi, size.0, size.1);
    let rays = cam.rays()?;
    let grid = DenseGrid::new(tree)?;
    let depth = tree.depth;
    let eye = tree.root.to_grid(cam.eye, depth).as_vec3();
    let scale = (f64::from(1u32 << depth) / tree.root.side) as f32;
    let oct = |r: &GridRay| {
        cast(tree, r, 0.0, f32::INFINITY, HitMode::Cube, None, MAX_STEPS)
            .hit
            .map(|h| h.t)
    };
    let walk = |r: &GridRay| {
        traverse_dda(&grid, tree, r, 0.0, f32::INFINITY, MAX_STEPS, |e| {
            leaf_hit(tree, r, e, HitMode::Cube)
        })
        .hit
        .map(|h| h.t)
    };
    let (a, ta) = primary_only(&rays, size, eye, scale, runs, &oct);
    let (b, tb) = primary_only(&rays, size, eye, scale, runs, &walk);
    Ok(DdaRow {
        depth,
        octree: ta,
        dda: tb,
        differ: a.iter().zip(&b).filter(|(x, y)| x != y).count(),
        grid_bytes: grid.bytes(),
    })
}
