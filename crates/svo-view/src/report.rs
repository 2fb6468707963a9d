//! [`FrameReport`]: what a render did, on the CPU (`--cpu`) or the GPU (`--headless`), as
//! text (its `Display`) and as JSON (`--json`).

use serde::Serialize;
use std::fmt;
use svo::render::{Camera, ImageDiff, RenderStats};

/// The timing of a benchmark's frames, with the throughput it gives.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FrameTiming {
    /// Frames timed.
    pub frames: u32,
    /// Median milliseconds per frame.
    pub median_ms: f64,
    /// Fastest frame, ms.
    pub min_ms: f64,
    /// All rays (primary, secondary, shadow) per second at the median, millions.
    pub mrays_per_s: f64,
    /// Primary rays per second at the median, millions.
    pub primary_mrays_per_s: f64,
}

impl FrameTiming {
    /// The timing of frames that took `times` seconds each (not empty) and cast the rays
    /// `stats` counts per frame.
    pub fn new(times: &[f64], stats: &RenderStats) -> Self {
        let med = Self::median(times);
        let all = (stats.primary_rays + stats.secondary_rays + stats.shadow_rays) as f64;
        Self {
            frames: times.len() as u32,
            median_ms: med * 1e3,
            min_ms: times.iter().copied().fold(f64::INFINITY, f64::min) * 1e3,
            mrays_per_s: all / med / 1e6,
            primary_mrays_per_s: stats.primary_rays as f64 / med / 1e6,
        }
    }

    /// The frame time a timing reports for frames of `times` seconds: their median (the
    /// upper one of an even count); `times` must not be empty.
    pub fn median(times: &[f64]) -> f64 {
        let mut s = times.to_vec();
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    }
}

/// The camera of a render, so another renderer can reproduce the view.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct CameraReport {
    /// Eye.
    pub eye: [f64; 3],
    /// Target.
    pub target: [f64; 3],
    /// Up.
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
}

impl CameraReport {
    /// The report of `camera`.
    pub fn of(camera: &Camera) -> Self {
        Self {
            eye: camera.eye.to_array(),
            target: camera.target.to_array(),
            up: camera.up.to_array(),
            fov_deg: camera.fov_deg,
        }
    }
}

/// An SVO render measured against the triangle reference (`--compare`).
#[derive(Clone, Debug, Serialize)]
pub struct CompareReport {
    /// Image error.
    pub diff: ImageDiff,
    /// Median ms per frame of the SVO render.
    pub svo_ms: f64,
    /// Median ms per frame of the reference render.
    pub reference_ms: f64,
    /// Where the reference image went.
    pub reference_output: Option<String>,
    /// Where the difference image (a PNG of the colour difference) went.
    pub diff_output: Option<String>,
}

/// The GPU frame compared with the CPU reference's (`--vs-cpu`).
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

/// What the CPU tracer's run adds to a report.
#[derive(Clone, Debug, Serialize)]
pub struct CpuRun {
    /// Threads used.
    pub threads: usize,
    /// The scale of the cost heat map (steps at the hottest colour).
    pub cost_scale: u32,
    /// The comparison with the triangle reference.
    pub compare: Option<CompareReport>,
    /// The level of detail asked for, in pixels (0: none).
    pub lod: f32,
    /// Whether it applied: the tree's inner nodes carry attributes.
    pub lod_applied: bool,
}

impl CpuRun {
    /// The head line's words on the level of detail, if one was asked for.
    fn lod_words(&self) -> String {
        match (self.lod > 0.0, self.lod_applied) {
            (false, _) => String::new(),
            (true, true) => format!(", lod {} px", self.lod),
            (true, false) => format!(
                ", lod {} px not applied (the tree's inner nodes carry no attributes: bake with --lod filtered)",
                self.lod
            ),
        }
    }
}

/// What the GPU's run adds to a report.
#[derive(Clone, Debug, Serialize)]
pub struct GpuRun {
    /// The adapter: name, backend, type.
    pub adapter: String,
    /// The shader paths compiled in, the stacks' sizes and the walk.
    pub variant: String,
    /// Bytes of tree data on the GPU.
    pub tree_bytes: u64,
    /// Milliseconds of the job before the timed frames: loading, the adapter, the upload,
    /// the pipeline and the untimed first frame (which also compiles the shader on some
    /// drivers).
    pub startup_ms: f64,
    /// The comparison with the CPU reference.
    pub vs_cpu: Option<VsCpu>,
    /// What of a tree larger than the adapter was shown: the deepest prefix of its levels
    /// that fits.
    pub shown: Option<crate::fit::Prefix>,
}

/// What a render did: the image, the tree, the rays and their time, and what the CPU or the
/// GPU adds.
#[derive(Clone, Debug, Serialize)]
pub struct FrameReport {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tree depth.
    pub depth: u8,
    /// Leaves.
    pub leaves: u64,
    /// Hit mode name (`triangles` for the reference alone).
    pub hit: &'static str,
    /// Time per frame and throughput.
    #[serde(flatten)]
    pub timing: FrameTiming,
    /// Counters of the last frame.
    pub stats: RenderStats,
    /// The file written.
    pub output: Option<String>,
    /// The camera used (scene units).
    pub camera: CameraReport,
    /// The CPU tracer's run.
    #[serde(flatten)]
    pub cpu: Option<CpuRun>,
    /// The GPU's run.
    #[serde(flatten)]
    pub gpu: Option<GpuRun>,
}

impl FrameReport {
    /// The first line: the image, the tree, and who rendered it.
    fn write_head(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (w, h, d, n) = (self.width, self.height, self.depth, self.leaves);
        match (&self.cpu, &self.gpu) {
            (_, Some(g)) => {
                writeln!(f, "adapter: {}", g.adapter)?;
                if let Some(p) = &g.shown {
                    writeln!(f, "{p}")?;
                }
                writeln!(
                    f,
                    "{w}x{h} depth {d} ({n} leaves, {} bytes on the GPU), hit {}; shader: {}",
                    g.tree_bytes, self.hit, g.variant
                )
            }
            (Some(c), None) => {
                writeln!(
                    f,
                    "{w}x{h} depth {d} ({n} leaves), hit {}, {} threads{}",
                    self.hit,
                    c.threads,
                    c.lod_words()
                )?;
                let cam = &self.camera;
                let v = |a: [f64; 3]| format!("{:.6},{:.6},{:.6}", a[0], a[1], a[2]);
                writeln!(
                    f,
                    "camera: --eye {} --target {} --up {} --fov {}",
                    v(cam.eye),
                    v(cam.target),
                    v(cam.up),
                    cam.fov_deg
                )
            }
            (None, None) => writeln!(f, "{w}x{h} depth {d} ({n} leaves), hit {}", self.hit),
        }
    }

    /// The comparisons: with the triangle reference (CPU) or the CPU's image (GPU).
    fn write_comparisons(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(c) = self.cpu.as_ref().and_then(|c| c.compare.as_ref()) {
            writeln!(
                f,
                "vs triangle reference: RMSE {:.2} (8-bit sRGB), PSNR {:.2} dB, max diff {}, hit/miss differs on {:.3}% of pixels; SVO {:.2} ms, triangles {:.2} ms per frame",
                c.diff.rmse,
                c.diff.psnr_db,
                c.diff.max_abs,
                100.0 * c.diff.hit_mismatch,
                c.svo_ms,
                c.reference_ms
            )?;
            if let (Some(r), Some(d)) = (&c.reference_output, &c.diff_output) {
                writeln!(f, "wrote {r} and {d}")?;
            }
        }
        if let Some(c) = self.gpu.as_ref().and_then(|g| g.vs_cpu.as_ref()) {
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
        Ok(())
    }

    /// The last line: the frames' times and throughput.
    fn write_timing(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = &self.timing;
        if let Some(g) = &self.gpu {
            return write!(
                f,
                "{} frame(s): median {:.3} ms/frame (min {:.3}), primary {:.1} Mrays/s, all {:.1} Mrays/s; first frame after {:.0} ms",
                t.frames, t.median_ms, t.min_ms, t.primary_mrays_per_s, t.mrays_per_s, g.startup_ms
            );
        }
        let s = &self.stats;
        write!(
            f,
            "{} frame(s): median {:.2} ms/frame (min {:.2}), {} rays/frame, primary {:.1} Mrays/s, all {:.1} Mrays/s",
            t.frames,
            t.median_ms,
            t.min_ms,
            s.primary_rays + s.secondary_rays + s.shadow_rays,
            t.primary_mrays_per_s,
            t.mrays_per_s
        )
    }
}

impl fmt::Display for FrameReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write_head(f)?;
        writeln!(f, "{}", self.stats.summary())?;
        if let Some(o) = &self.output {
            writeln!(f, "wrote {o}")?;
        }
        self.write_comparisons(f)?;
        self.write_timing(f)
    }
}
