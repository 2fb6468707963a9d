//! `svo-view --headless`: a render job on the GPU without a window. The scene (tree,
//! camera, lights, sky) is set up by the same [`crate::job::prepare`] as the CPU path, the
//! frame is traced by [`crate::gpu_render::GpuRenderer`], and the image or AOV is written by
//! the CPU path's writer, so `--headless` and `--cpu` give the same files and the same
//! [`FrameReport`]. A tree larger than the adapter is shown from the deepest prefix of its
//! levels that fits ([`crate::fit`]). A DAG file is rendered on its graph (the walk of the
//! shader's feature `dag`), its tree never made, where the graph fits the adapter. With `vs_cpu` the CPU reference renders the same frame and the two are
//! compared.

use crate::fit::{fit_scene, level_sizes, open_fitting, said_of_file};
use crate::gpu_context::{GpuContext, GpuError};
use crate::gpu_render::{GpuLayout, GpuRenderer, adapter_capacity, arena_bytes};
use crate::gpu_tree::GpuTree;
use crate::gpu_types::{MAX_LIGHTS, ShaderVariant, uniforms};
use crate::job::{JobError, RenderJob, write_output};
use crate::report::{CameraReport, FrameReport, FrameTiming, GpuRun, VsCpu};
use crate::timing::render_timed;
use svo::render::{
    Camera, DagSurfaces, OctreeSurfaces, Phong, PointLight, RenderScene, SetupError, Sky, Stage,
    Surfaces, Tracer, compare,
};
use svo::trace::HitMode;
use thiserror::Error;

/// Errors of a headless job.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum HeadlessError {
    /// Setting up the scene, or writing the image, failed.
    #[error(transparent)]
    Job(#[from] JobError),
    /// The GPU failed or refused.
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// What a headless job does besides the render job itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HeadlessOptions {
    /// Also render the frame with the CPU reference tracer and compare.
    pub vs_cpu: bool,
    /// Compile every shader path in and read every channel per leaf
    /// ([`ShaderVariant::everything`]), to measure what the scene's variant saves.
    pub everything: bool,
    /// How the work is laid out on the device: the walk (the chunk limit is the adapter's).
    pub layout: GpuLayout,
}

/// Refuses what the GPU path does not do (yet): the exact hit mode, a cube-map sky, more
/// than [`MAX_LIGHTS`] lights.
pub fn check_gpu_support(
    trace: &svo::render::TraceOptions,
    cube_map: bool,
    lights: usize,
) -> Result<(), GpuError> {
    if trace.mode == HitMode::Exact {
        return Err(GpuError::Unsupported(
            "hit mode exact (the leaves' triangles) is CPU only: use --cpu, or --hit cube|contour"
                .into(),
        ));
    }
    if cube_map {
        return Err(GpuError::Unsupported(
            "a cube-map sky is CPU only so far: use --cpu, or leave out --sky".into(),
        ));
    }
    if lights > MAX_LIGHTS {
        return Err(GpuError::Unsupported(format!(
            "{lights} lights; the GPU path takes at most {MAX_LIGHTS}"
        )));
    }
    Ok(())
}

/// A frame rendered on the GPU.
pub struct GpuFrame {
    /// The image and its AOVs and counters, as the CPU renderer makes them.
    pub frame: svo::render::Frame,
    /// Seconds per timed frame.
    pub times: Vec<f64>,
    /// The shader variant used.
    pub variant: ShaderVariant,
    /// Bytes of tree data uploaded.
    pub tree_bytes: u64,
    /// Whether the traversal walked the 64-ary view.
    pub wide_view: bool,
    /// Whether the traversal walked a graph (a DAG file's).
    pub dag: bool,
}

/// Renders `scene` on `ctx` with `trace`'s settings: one untimed frame (pipeline compilation
/// on some drivers), then `frames` timed ones (one when `None`), and reads the last back.
/// `opts.everything` compiles every shader path in ([`ShaderVariant::everything`]);
/// `opts.layout` lays the work out (`vs_cpu` is not used here).
pub fn render_scene(
    ctx: &GpuContext,
    scene: &RenderScene,
    trace: &svo::render::TraceOptions,
    opts: &HeadlessOptions,
    frames: Option<u32>,
) -> Result<GpuFrame, HeadlessError> {
    let stage = Staged::of(scene);
    render_on(ctx, (&scene.tree).into(), &stage, trace, opts, frames)
}

/// What a frame is rendered with besides the tree: a [`RenderScene`]'s or a [`Stage`]'s.
#[derive(Clone, Copy)]
struct Staged<'a> {
    camera: &'a Camera,
    lights: &'a [PointLight],
    sky: &'a Sky,
    phong: Phong,
}

impl<'a> Staged<'a> {
    fn of(s: &'a RenderScene) -> Self {
        Self {
            camera: &s.camera,
            lights: &s.lights,
            sky: &s.sky,
            phong: s.phong,
        }
    }

    fn of_stage(s: &'a Stage) -> Self {
        Self {
            camera: &s.camera,
            lights: &s.lights,
            sky: &s.sky,
            phong: s.phong,
        }
    }
}

/// [`render_scene`] of `tree` (a tree or a graph) with `stage`.
fn render_on(
    ctx: &GpuContext,
    tree: GpuTree<'_>,
    stage: &Staged<'_>,
    trace: &svo::render::TraceOptions,
    opts: &HeadlessOptions,
    frames: Option<u32>,
) -> Result<GpuFrame, HeadlessError> {
    let Staged {
        camera,
        lights,
        sky,
        phong,
    } = *stage;
    check_gpu_support(trace, sky.cube_map.is_some(), lights.len())?;
    let mut variant = ShaderVariant::for_scene(tree, trace, lights.len());
    if opts.everything {
        variant = variant.everything();
    }
    let renderer = GpuRenderer::with_options(
        ctx,
        tree,
        variant,
        camera.width,
        camera.height,
        &opts.layout,
    )?;
    let u = uniforms(tree, camera, lights, sky, &phong, trace).map_err(JobError::from)?;
    renderer.render(ctx, &u)?;
    let mut times = Vec::new();
    for _ in 0..frames.unwrap_or(1) {
        times.push(renderer.render(ctx, &u)?.as_secs_f64());
    }
    let frame = renderer.read_frame(
        ctx,
        std::time::Duration::from_secs_f64(FrameTiming::median(&times)),
    )?;
    Ok(GpuFrame {
        frame,
        times,
        variant,
        tree_bytes: renderer.tree_bytes,
        wide_view: renderer.wide_view(),
        dag: tree.is_dag(),
    })
}

/// Renders `job` on the GPU (see the module docs).
pub fn run(job: &RenderJob, opts: &HeadlessOptions) -> Result<FrameReport, HeadlessError> {
    let start = std::time::Instant::now();
    // Before loading anything (the lights are counted again once the scene is made).
    check_gpu_support(&job.trace, job.sky_cube_map.is_some(), job.lights.len())?;
    if job.reference.is_some() || job.compare {
        return Err(GpuError::Unsupported(
            "the triangle reference is CPU only: use --cpu with --reference".into(),
        )
        .into());
    }
    // Checks the settings (bench frames, bounces, bias, output path) before loading.
    job.setup()?;
    let graph = renders_as_graph(job, opts)?;
    // The file's level table, if it has one, is read before the adapter is opened: a file
    // that cannot be read fails first.
    let sizes = if graph {
        None
    } else {
        level_sizes(job, &opts.layout)?
    };
    let ctx = GpuContext::new()?;
    let limit = adapter_capacity(&ctx, &opts.layout);
    if graph {
        let (dag, build) =
            svo::io::read_dag_file(&job.input).map_err(|e| JobError::from(SetupError::from(e)))?;
        let (lo, hi) = dag.occupied_bounds();
        let stage = job
            .setup()?
            .stage(dag.depth(), lo, hi, &build.scene)
            .map_err(JobError::from)?;
        let variant = ShaderVariant::for_scene(&dag, &job.trace, stage.lights.len());
        if arena_bytes(&dag, &variant) <= limit {
            let staged = Staged::of_stage(&stage);
            let r = render_on(
                &ctx,
                (&dag).into(),
                &staged,
                &job.trace,
                opts,
                job.bench_frames,
            )?;
            let vs_cpu = if opts.vs_cpu {
                Some(vs_cpu(
                    job,
                    DagSurfaces::new(&dag, job.trace.mode),
                    &staged,
                    &r.frame,
                )?)
            } else {
                None
            };
            let size = (dag.depth(), dag.leaf_count());
            return finish(job, &ctx, &r, vs_cpu, &stage.camera, size, None, start);
        }
        // The graph does not fit either: the tree's top levels that do, as for a tree.
    }
    let sizes = if graph {
        level_sizes(job, &opts.layout)?
    } else {
        sizes
    };
    let (mut scene, read) = open_fitting(job, sizes, limit)?;
    let shown = said_of_file(fit_scene(&ctx, &mut scene, &job.trace, &opts.layout)?, read);
    let r = render_scene(&ctx, &scene, &job.trace, opts, job.bench_frames)?;
    let vs_cpu = if opts.vs_cpu {
        let s = OctreeSurfaces::new(&scene.tree, job.trace.mode);
        Some(vs_cpu(job, s, &Staged::of(&scene), &r.frame)?)
    } else {
        None
    };
    let size = (scene.tree.depth, u64::from(scene.tree.leaf_count));
    finish(job, &ctx, &r, vs_cpu, &scene.camera, size, shown, start)
}

/// Whether the job renders a DAG file as its graph on the GPU (its tree never made): a DAG
/// file, whole, on the octree walk (the 64-ary view is made from a tree).
fn renders_as_graph(job: &RenderJob, opts: &HeadlessOptions) -> Result<bool, JobError> {
    if job.max_depth.is_some() || opts.layout.wide_view {
        return Ok(false);
    }
    Ok(svo::io::is_dag_file(&job.input).map_err(SetupError::from)?)
}

/// Writes the frame `r` of a tree of `size` (depth, leaves) and makes the report.
#[allow(clippy::too_many_arguments)]
fn finish(
    job: &RenderJob,
    ctx: &GpuContext,
    r: &GpuFrame,
    vs_cpu: Option<VsCpu>,
    camera: &Camera,
    size: (u8, u64),
    shown: Option<crate::fit::Prefix>,
    start: std::time::Instant,
) -> Result<FrameReport, HeadlessError> {
    let startup_ms = (start.elapsed().as_secs_f64() - r.times.iter().sum::<f64>()) * 1e3;
    let s = r.frame.stats;
    let output = match &job.output {
        Some(out) => {
            write_output(&r.frame, job.aov, out, s.max_primary_steps.max(1))
                .map_err(JobError::from)?;
            Some(out.display().to_string())
        }
        None => None,
    };
    let (depth, leaves) = size;
    Ok(FrameReport {
        width: camera.width,
        height: camera.height,
        depth,
        leaves,
        hit: job.trace.mode.name(),
        timing: FrameTiming::new(&r.times, &s),
        stats: s,
        output,
        camera: CameraReport::of(camera),
        cpu: None,
        gpu: Some(GpuRun {
            adapter: ctx.adapter_name(),
            variant: format!(
                "{}; stacks: ancestors {}, pending rays {}{}",
                r.variant.describe(),
                depth,
                r.variant.ray_stack,
                if r.wide_view {
                    "; walks the 64-ary view"
                } else if r.dag {
                    "; walks the graph"
                } else {
                    ""
                }
            ),
            tree_bytes: r.tree_bytes,
            startup_ms,
            vs_cpu,
            shown,
        }),
    })
}

/// The CPU reference's frame of `surfaces` seen as `stage` says, timed as `job` asks,
/// against the GPU's `frame`.
fn vs_cpu<S: Surfaces>(
    job: &RenderJob,
    surfaces: S,
    stage: &Staged<'_>,
    frame: &svo::render::Frame,
) -> Result<VsCpu, JobError> {
    let tracer = Tracer::new(
        surfaces,
        stage.lights,
        stage.sky.clone(),
        stage.phong,
        job.trace,
    );
    let (cpu, cpu_times) = render_timed(&tracer, stage.camera, job.bench_frames)?;
    let diff = compare(frame, &cpu)
        .ok_or_else(|| JobError::Invalid("the two renders differ in size".into()))?;
    let leaf_mismatch = frame
        .leaf
        .iter()
        .zip(&cpu.leaf)
        .filter(|(a, b)| a != b)
        .count() as f64
        / frame.leaf.len().max(1) as f64;
    Ok(VsCpu {
        diff,
        leaf_mismatch,
        cpu_ms: FrameTiming::median(&cpu_times) * 1e3,
        cpu_threads: rayon_threads(),
    })
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}
