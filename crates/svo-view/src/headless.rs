//! `svo-view --headless`: a render job on the GPU without a window. The scene (tree,
//! camera, lights, sky) is set up by the same [`svo::render::prepare`] as the CPU
//! path, the frame is traced by [`crate::gpu_render::GpuRenderer`], and the image or AOV is
//! written by the CPU path's writer, so `--headless` and `--cpu` give the same files.
//! With `vs_cpu` the CPU reference renders the same frame and the two are compared.

use crate::gpu_context::{GpuContext, GpuError};
use crate::gpu_render::{GpuLayout, GpuRenderer};
use crate::gpu_types::{MAX_LIGHTS, ShaderVariant, uniforms};
use serde::Serialize;
use std::fmt;
use svo::render::{
    FrameTiming, ImageDiff, JobScene, OctreeSurfaces, RenderJob, RenderJobError, RenderStats,
    Tracer, compare, prepare, render_timed, write_output,
};
use svo::trace::HitMode;
use thiserror::Error;

/// Errors of a headless job.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum HeadlessError {
    /// Setting up the scene, or writing the image, failed.
    #[error(transparent)]
    Job(#[from] RenderJobError),
    /// The GPU failed or refused.
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// The GPU frame compared with the CPU reference's.
#[derive(Clone, Debug, Serialize)]
pub struct VsCpu {
    /// Image difference (GPU vs CPU).
    pub diff: ImageDiff,
    /// Pixels whose primary leaf differs.
    pub leaf_mismatch: f64,
    /// Median CPU ms per frame.
    pub cpu_ms: f64,
    /// CPU threads.
    pub cpu_threads: usize,
}

/// What a headless job did.
#[derive(Clone, Debug, Serialize)]
pub struct HeadlessReport {
    /// The adapter: name, backend, type.
    pub adapter: String,
    /// The shader paths compiled in.
    pub variant: String,
    /// Image size.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tree depth.
    pub depth: u8,
    /// Leaves.
    pub leaves: u32,
    /// Bytes of tree data on the GPU.
    pub tree_bytes: u64,
    /// Hit mode.
    pub hit: &'static str,
    /// Time per frame (submission to completion) and throughput.
    #[serde(flatten)]
    pub timing: FrameTiming,
    /// Milliseconds of the job before the timed frames: loading, the adapter, the upload,
    /// the pipeline and the untimed first frame (which also compiles the shader on some
    /// drivers).
    pub startup_ms: f64,
    /// Counters of the last frame.
    pub stats: RenderStats,
    /// The file written.
    pub output: Option<String>,
    /// The comparison with the CPU reference.
    pub vs_cpu: Option<VsCpu>,
}

impl fmt::Display for HeadlessReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.stats;
        writeln!(f, "adapter: {}", self.adapter)?;
        writeln!(
            f,
            "{}x{} depth {} ({} leaves, {} bytes on the GPU), hit {}; shader: {}",
            self.width,
            self.height,
            self.depth,
            self.leaves,
            self.tree_bytes,
            self.hit,
            self.variant
        )?;
        writeln!(f, "{}", s.summary())?;
        if let Some(o) = &self.output {
            writeln!(f, "wrote {o}")?;
        }
        if let Some(c) = &self.vs_cpu {
            writeln!(
                f,
                "vs CPU reference: RMSE {:.3} (8-bit sRGB), PSNR {:.2} dB, max diff {}, hit/miss differs on {:.4}% of pixels, leaf on {:.4}%; CPU {:.2} ms per frame ({} threads)",
                c.diff.rmse,
                c.diff.psnr_db,
                c.diff.max_abs,
                100.0 * c.diff.hit_mismatch,
                100.0 * c.leaf_mismatch,
                c.cpu_ms,
                c.cpu_threads
            )?;
        }
        write!(
            f,
            "{} frame(s): median {:.3} ms/frame (min {:.3}), primary {:.1} Mrays/s, all {:.1} Mrays/s; first frame after {:.0} ms",
            self.timing.frames,
            self.timing.median_ms,
            self.timing.min_ms,
            self.timing.primary_mrays_per_s,
            self.timing.mrays_per_s,
            self.startup_ms
        )
    }
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
}

/// Renders `scene` on `ctx` with `trace`'s settings: one untimed frame (pipeline compilation
/// on some drivers), then `frames` timed ones (one when `None`), and reads the last back.
/// `opts.everything` compiles every shader path in ([`ShaderVariant::everything`]);
/// `opts.layout` lays the work out (`vs_cpu` is not used here).
pub fn render_scene(
    ctx: &GpuContext,
    scene: &JobScene,
    trace: &svo::render::TraceOptions,
    opts: &HeadlessOptions,
    frames: Option<u32>,
) -> Result<GpuFrame, HeadlessError> {
    let JobScene {
        tree,
        camera,
        lights,
        sky,
        phong,
        ..
    } = scene;
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
    let u = uniforms(tree, camera, lights, sky, phong, trace).map_err(RenderJobError::from)?;
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
    })
}

/// Renders `job` on the GPU (see the module docs).
pub fn run(job: &RenderJob, opts: &HeadlessOptions) -> Result<HeadlessReport, HeadlessError> {
    let vs_cpu = opts.vs_cpu;
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
    let scene = prepare(job)?;
    let ctx = GpuContext::new()?;
    let r = render_scene(&ctx, &scene, &job.trace, opts, job.bench_frames)?;
    let (frame, times, variant, tree_bytes) = (r.frame, r.times, r.variant, r.tree_bytes);
    let startup_ms = (start.elapsed().as_secs_f64() - times.iter().sum::<f64>()) * 1e3;
    let s = frame.stats;
    let cost_scale = s.max_primary_steps.max(1);
    let vs = if vs_cpu {
        let tracer = Tracer::new(
            OctreeSurfaces::new(&scene.tree, job.trace.mode),
            &scene.lights,
            scene.sky.clone(),
            scene.phong,
            job.trace,
        );
        let (cpu, cpu_times) =
            render_timed(&tracer, &scene.camera, job.bench_frames).map_err(RenderJobError::from)?;
        let diff = compare(&frame, &cpu)
            .ok_or_else(|| RenderJobError::Invalid("the two renders differ in size".into()))?;
        let leaf_mismatch = frame
            .leaf
            .iter()
            .zip(&cpu.leaf)
            .filter(|(a, b)| a != b)
            .count() as f64
            / frame.leaf.len().max(1) as f64;
        Some(VsCpu {
            diff,
            leaf_mismatch,
            cpu_ms: FrameTiming::median(&cpu_times) * 1e3,
            cpu_threads: rayon_threads(),
        })
    } else {
        None
    };
    let output = match &job.output {
        Some(out) => {
            write_output(&frame, job.aov, out, cost_scale).map_err(RenderJobError::from)?;
            Some(out.display().to_string())
        }
        None => None,
    };
    Ok(HeadlessReport {
        adapter: ctx.adapter_name(),
        variant: format!(
            "{}; stacks: ancestors {}, pending rays {}{}",
            variant.describe(),
            scene.tree.depth,
            variant.ray_stack,
            if r.wide_view {
                "; walks the 64-ary view"
            } else {
                ""
            }
        ),
        width: scene.camera.width,
        height: scene.camera.height,
        depth: scene.tree.depth,
        leaves: scene.tree.leaf_count,
        tree_bytes,
        hit: job.trace.mode.name(),
        timing: FrameTiming::new(&times, &s),
        startup_ms,
        stats: s,
        output,
        vs_cpu: vs,
    })
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}
