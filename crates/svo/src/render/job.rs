//! File to image: load an `.svo`, set up the camera, lights and tracer, render (once, or
//! repeatedly for a benchmark) and write the colour image or an AOV atomically. This is
//! everything `svo-view --cpu` does; its `main` only parses arguments and prints the
//! [`RenderReport`].

use crate::import::load_mesh;
use crate::io::chunked::ChunkedFile;
use crate::io::read::read_file;
use crate::io::write::FormatError;
use crate::mesh::scene_info::SceneInfo;
use crate::mesh::triangle_mesh::MeshError;
use crate::mesh::triangle_mesh::Texture;
use crate::octree::tree::Octree;
use crate::render::aov::{self, Aov};
use crate::render::camera::{Camera, CameraError};
use crate::render::chunked_surfaces::{ChunkTree, ChunkedSurfaces};
use crate::render::exact_surfaces::exact_surfaces;
use crate::render::frame::{Frame, RenderStats, render_timed};
use crate::render::image_compare::{self, ImageDiff};
use crate::render::image_write::{ImageWriteError, write_float, write_png};
use crate::render::mesh_reference::MeshSurfaces;
use crate::render::primary_cast::cast_timed;
use crate::render::shading::{Phong, PointLight};
use crate::render::sky::{CubeMap, Sky};
use crate::render::surfaces::OctreeSurfaces;
use crate::render::whitted::{MAX_BOUNCES, TraceOptions, Tracer};
use crate::thread_pool::{ThreadsError, with_threads};
use crate::trace::leaf_hit::HitMode;
use glam::{DVec3, Vec3};
use std::fmt;
use std::path::PathBuf;
use thiserror::Error;

/// Errors of a render job.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum RenderJobError {
    /// Reading the `.svo` failed.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// The camera settings are invalid.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// Writing the image failed.
    #[error(transparent)]
    Image(#[from] ImageWriteError),
    /// Loading a mesh failed.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A setting is invalid.
    #[error("{0}")]
    Invalid(String),
    /// The thread pool could not be made.
    #[error(transparent)]
    Threads(#[from] ThreadsError),
    /// Loading a scene file as the reference failed.
    #[cfg(feature = "scene")]
    #[error(transparent)]
    Scene(#[from] crate::scene::file::SceneError),
}

/// The triangles of `--reference` or `--mesh`: a mesh file, or every object of a scene file
/// (`.toml`, with the `scene` feature), which is what `svo-bake` voxelizes from it.
fn load_reference(path: &std::path::Path) -> Result<crate::Mesh, RenderJobError> {
    #[cfg(feature = "scene")]
    if crate::mesh::format::is_scene_file(path) {
        return Ok(crate::scene::file::load_scene(path)?.mesh);
    }
    Ok(load_mesh(path)?)
}

/// The deepest tree the renderers trace. Traversal runs in `f32` grid coordinates, whose cell
/// planes are exact integers up to depth 24: there every ray hits each leaf it enters by more
/// than the rounding of its plane parameters (`tests/deep_precision.rs`); from depth 25 the
/// planes round and from depth 26 half the rays go wrong, so such trees are refused rather
/// than rendered wrong.
pub const MAX_TRACE_DEPTH: u8 = 24;

/// The most frames a benchmark renders.
pub const MAX_BENCH_FRAMES: u32 = 10_000;

/// A point light as given on the command line: position, optional colour and intensity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSpec {
    /// Position (scene units).
    pub position: DVec3,
    /// Linear RGB colour (default white).
    pub colour: Option<Vec3>,
    /// Intensity (default: the squared distance to the scene's centre, so the light gives
    /// about 1 at the model).
    pub intensity: Option<f32>,
}

/// What to render and how.
#[derive(Clone, Debug)]
pub struct RenderJob {
    /// The `.svo` file.
    pub input: PathBuf,
    /// The image to write (`.png`; `.pfm` or `.exr` for the depth AOV); `None` renders
    /// without writing (benchmarks).
    pub output: Option<PathBuf>,
    /// Image size.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Camera eye; default: frame the model.
    pub eye: Option<DVec3>,
    /// Camera target; default: the model's centre.
    pub target: Option<DVec3>,
    /// Up; default `+y`.
    pub up: Option<DVec3>,
    /// Vertical field of view in degrees.
    pub fov_deg: f64,
    /// Tracer settings.
    pub trace: TraceOptions,
    /// Lights; default: the file's lights, else one white light above and behind the
    /// camera's right shoulder.
    pub lights: Vec<LightSpec>,
    /// A camera view stored in the file, by name or index; default: the file's first view
    /// unless `eye` is given, else framing the model.
    pub view: Option<String>,
    /// What to write.
    pub aov: Aov,
    /// Render this many timed frames (after one untimed warm-up) and report the median.
    pub bench_frames: Option<u32>,
    /// With `bench_frames`: cast the primary rays alone (the first hit and its distance per
    /// pixel, no shading, no image: [`crate::render::cast_primary`]), as a ray-casting library
    /// returns them.
    pub cast: bool,
    /// Worker threads: a pool of this many, or with `None` the caller's pool (rayon's global
    /// one: all cores unless `RAYON_NUM_THREADS` says otherwise).
    pub threads: Option<usize>,
    /// A triangle mesh to render instead (the reference), or beside the octree with
    /// `compare`.
    pub reference: Option<PathBuf>,
    /// Render both the octree and `reference` and measure the difference.
    pub compare: bool,
    /// The mesh the tree was baked from, for the exact hit mode (default: `reference`).
    pub mesh: Option<PathBuf>,
    /// A folder with a cube-map sky: `px, nx, py, ny, pz, nz` as `.png` or `.jpg`.
    pub sky_cube_map: Option<PathBuf>,
}

impl Default for RenderJob {
    fn default() -> Self {
        Self {
            input: PathBuf::new(),
            output: None,
            width: 1280,
            height: 720,
            eye: None,
            target: None,
            up: None,
            fov_deg: 40.0,
            trace: TraceOptions::default(),
            lights: Vec::new(),
            view: None,
            aov: Aov::Colour,
            bench_frames: None,
            cast: false,
            threads: None,
            reference: None,
            compare: false,
            mesh: None,
            sky_cube_map: None,
        }
    }
}

/// What a render job did.
#[derive(Clone, Debug)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
pub struct RenderReport {
    /// Image size.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tree depth.
    pub depth: u8,
    /// Leaves.
    pub leaves: u64,
    /// Hit mode name.
    pub hit: &'static str,
    /// Threads used.
    pub threads: usize,
    /// Time per frame and throughput.
    #[cfg_attr(feature = "io", serde(flatten))]
    pub timing: FrameTiming,
    /// Counters of the last frame.
    pub stats: RenderStats,
    /// The scale of the cost heat map (steps at the hottest colour).
    pub cost_scale: u32,
    /// The file written.
    pub output: Option<String>,
    /// The comparison with the triangle reference, with `--compare`.
    pub compare: Option<CompareReport>,
    /// The camera used (scene units), so another renderer can reproduce the view.
    pub camera: CameraReport,
}

/// The camera of a render.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
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

/// An SVO render measured against the triangle reference.
#[derive(Clone, Debug)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
pub struct CompareReport {
    /// Image error.
    pub diff: ImageDiff,
    /// Median ms per frame of the SVO render.
    pub svo_ms: f64,
    /// Median ms per frame of the reference render.
    pub reference_ms: f64,
    /// Where the reference image went.
    pub reference_output: Option<String>,
}

impl fmt::Display for RenderReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.stats;
        writeln!(
            f,
            "{}x{} depth {} ({} leaves), hit {}, {} threads",
            self.width, self.height, self.depth, self.leaves, self.hit, self.threads
        )?;
        let c = &self.camera;
        let v = |a: [f64; 3]| format!("{:.6},{:.6},{:.6}", a[0], a[1], a[2]);
        writeln!(
            f,
            "camera: --eye {} --target {} --up {} --fov {}",
            v(c.eye),
            v(c.target),
            v(c.up),
            c.fov_deg
        )?;
        let all = s.primary_rays + s.secondary_rays + s.shadow_rays;
        writeln!(f, "{}", s.summary())?;
        if let Some(o) = &self.output {
            writeln!(f, "wrote {o}")?;
        }
        if let Some(c) = &self.compare {
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
            if let Some(r) = &c.reference_output {
                writeln!(f, "wrote {r} and the diff image beside it")?;
            }
        }
        write!(
            f,
            "{} frame(s): median {:.2} ms/frame (min {:.2}), {} rays/frame, primary {:.1} Mrays/s, all {:.1} Mrays/s",
            self.timing.frames,
            self.timing.median_ms,
            self.timing.min_ms,
            all,
            self.timing.primary_mrays_per_s,
            self.timing.mrays_per_s
        )
    }
}

/// Runs a render job.
pub fn render_file(job: &RenderJob) -> Result<RenderReport, RenderJobError> {
    with_threads(job.threads, |threads| run_inner(job, threads))?
}

/// What every renderer of a job needs, with the job's defaults filled in: the tree, the
/// camera (framing the occupied cells unless given), the lights (one white light above the
/// camera's right shoulder unless given), the sky and the Phong factors. The CPU path
/// ([`render_file`]) and the GPU viewer both start here, so their images show the same scene.
#[derive(Clone, Debug)]
pub struct JobScene {
    /// The loaded, validated tree.
    pub tree: Octree,
    /// The camera.
    pub camera: Camera,
    /// Point lights (scene units).
    pub lights: Vec<PointLight>,
    /// The sky.
    pub sky: Sky,
    /// Phong factors.
    pub phong: Phong,
    /// The camera views stored with the tree, by name, at the job's image size (the window
    /// steps through them).
    pub views: Vec<(String, Camera)>,
}

/// Checks `job`'s settings and output path, loads its file and sets up its scene.
pub fn prepare(job: &RenderJob) -> Result<JobScene, RenderJobError> {
    if job.trace.max_reflections > MAX_BOUNCES || job.trace.max_refractions > MAX_BOUNCES {
        return Err(RenderJobError::Invalid(format!(
            "at most {MAX_BOUNCES} bounces"
        )));
    }
    if job
        .bench_frames
        .is_some_and(|n| n == 0 || n > MAX_BENCH_FRAMES)
    {
        return Err(RenderJobError::Invalid(format!(
            "--bench takes 1..={MAX_BENCH_FRAMES} frames"
        )));
    }
    if job.cast && (job.bench_frames.is_none() || job.output.is_some() || job.reference.is_some()) {
        return Err(RenderJobError::Invalid(
            "--cast times the primary rays alone: it goes with --bench, without -o or --reference"
                .into(),
        ));
    }
    if !(job.trace.bias_cells.is_finite() && job.trace.bias_cells >= 0.0) {
        return Err(RenderJobError::Invalid(
            "the bias must be a non-negative number".into(),
        ));
    }
    if let Some(out) = &job.output {
        check_output(out, job.aov)?;
    }
    let (tree, build) = read_file(&job.input)?;
    scene_with(tree, &build.scene, job)
}

/// The scene of `job` around a tree already in memory: the camera, lights and sky with the
/// job's defaults filled in (the settings are not checked; [`prepare`] does that).
pub fn scene(tree: Octree, job: &RenderJob) -> Result<JobScene, RenderJobError> {
    scene_with(tree, &SceneInfo::default(), job)
}

/// [`scene`] with the lights and camera views stored beside the tree: the job's own lights
/// and camera win; else `job.view` (which must exist) or the first stored view, and the
/// stored lights.
pub fn scene_with(
    tree: Octree,
    stored: &SceneInfo,
    job: &RenderJob,
) -> Result<JobScene, RenderJobError> {
    let (lo, hi) = tree.occupied_bounds();
    let (camera, lights, sky, views) = scene_around(tree.depth, lo, hi, stored, job)?;
    Ok(JobScene {
        tree,
        camera,
        lights,
        sky,
        phong: Phong::default(),
        views,
    })
}

/// The camera, lights, sky and stored views of [`scene_with`] for a tree of `depth` whose
/// leaves lie in `lo..hi`.
#[allow(clippy::type_complexity)]
fn scene_around(
    depth: u8,
    lo: DVec3,
    hi: DVec3,
    stored: &SceneInfo,
    job: &RenderJob,
) -> Result<(Camera, Vec<PointLight>, Sky, Vec<(String, Camera)>), RenderJobError> {
    if depth > MAX_TRACE_DEPTH {
        return Err(RenderJobError::Invalid(format!(
            "the tree has depth {depth}, and the tracer works in 32-bit floats, which resolve \
             cells only up to depth {MAX_TRACE_DEPTH} (docs/stability.md); bake at depth \
             {MAX_TRACE_DEPTH} or less to render"
        )));
    }
    let framing = Camera::framing(lo, hi, job.width, job.height, job.fov_deg);
    // A stored view at the job's image size.
    let as_camera = |v: &crate::mesh::scene_info::StoredCamera| Camera {
        eye: DVec3::from_array(v.eye),
        target: DVec3::from_array(v.target),
        up: DVec3::from_array(v.up),
        fov_deg: v.fov_deg,
        ..framing
    };
    let view = match &job.view {
        Some(name) => Some(stored.camera(name).ok_or_else(|| {
            let names: Vec<&str> = stored.cameras.iter().map(|c| c.name.as_str()).collect();
            RenderJobError::Invalid(if names.is_empty() {
                format!("no view {name:?}: the file stores no camera views")
            } else {
                format!("no view {name:?}; the file has {}", names.join(", "))
            })
        })?),
        None if job.eye.is_none() => stored.cameras.first(),
        None => None,
    };
    let mut camera = match view {
        Some(v) => as_camera(v),
        None => Camera {
            eye: job.eye.unwrap_or(framing.eye),
            target: job.target.unwrap_or(framing.target),
            up: job.up.unwrap_or(DVec3::Y),
            ..framing
        },
    };
    if view.is_none() && job.eye.is_some() && job.target.is_none() {
        camera.target = (lo + hi) * 0.5;
    }
    let rays = camera.rays()?;
    let centre = (lo + hi) * 0.5;
    let dist = (camera.eye - camera.target).length();
    let lights: Vec<PointLight> = if job.lights.is_empty() && !stored.lights.is_empty() {
        stored
            .lights
            .iter()
            .map(|l| PointLight {
                position: DVec3::from_array(l.position),
                colour: Vec3::from_array(l.colour),
                intensity: l.intensity,
            })
            .collect()
    } else if job.lights.is_empty() {
        let pos = camera.eye + (rays.up() * 0.8 + rays.right() * 0.5) * dist;
        vec![PointLight {
            position: pos,
            colour: Vec3::ONE,
            intensity: (pos - centre).length_squared() as f32,
        }]
    } else {
        job.lights
            .iter()
            .map(|l| PointLight {
                position: l.position,
                colour: l.colour.unwrap_or(Vec3::ONE),
                intensity: l
                    .intensity
                    .unwrap_or((l.position - centre).length_squared() as f32),
            })
            .collect()
    };
    let cube_map = job
        .sky_cube_map
        .as_deref()
        .map(load_cube_map)
        .transpose()?
        .map(std::sync::Arc::new);
    let sky = Sky {
        up: camera.up.normalize().as_vec3(),
        cube_map,
        ..Sky::default()
    };
    let views = stored
        .cameras
        .iter()
        .map(|v| (v.name.clone(), as_camera(v)))
        .collect();
    Ok((camera, lights, sky, views))
}

fn run_inner(job: &RenderJob, threads: usize) -> Result<RenderReport, RenderJobError> {
    let JobScene {
        tree,
        camera,
        lights,
        sky,
        phong,
        ..
    } = match prepare(job) {
        Err(RenderJobError::Format(FormatError::TooLarge { .. })) => {
            return run_chunked(job, threads);
        }
        r => r?,
    };
    let exact_mesh = if job.trace.mode == HitMode::Exact {
        let path = job
            .mesh
            .as_ref()
            .or(job.reference.as_ref())
            .ok_or_else(|| {
                RenderJobError::Invalid(
                "hit mode exact needs the mesh the tree was baked from: give --mesh or --reference"
                    .into(),
            )
            })?;
        Some(load_reference(path)?)
    } else {
        None
    };
    let reference = job
        .reference
        .as_ref()
        .map(|p| load_reference(p))
        .transpose()?;
    if job.compare && reference.is_none() {
        return Err(RenderJobError::Invalid(
            "--compare needs --reference MESH".into(),
        ));
    }
    let frames = job.bench_frames;
    if job.cast {
        let (stats, times) = match &exact_mesh {
            Some(mesh) => {
                let s = exact_surfaces(&tree, mesh).map_err(RenderJobError::Invalid)?;
                cast_timed(
                    &Tracer::new(s, &lights, sky, phong, job.trace),
                    &camera,
                    frames,
                )?
            }
            None => {
                let s = OctreeSurfaces::new(&tree, job.trace.mode);
                cast_timed(
                    &Tracer::new(s, &lights, sky, phong, job.trace),
                    &camera,
                    frames,
                )?
            }
        };
        return Ok(RenderReport {
            width: camera.width,
            height: camera.height,
            depth: tree.depth,
            leaves: u64::from(tree.leaf_count),
            hit: job.trace.mode.name(),
            threads,
            timing: FrameTiming::new(&times, &stats),
            stats,
            cost_scale: 1,
            output: None,
            compare: None,
            camera: CameraReport::of(&camera),
        });
    }
    // The octree image (unless only the reference is wanted).
    let svo = if reference.is_none() || job.compare {
        Some(match &exact_mesh {
            Some(mesh) => {
                let s = exact_surfaces(&tree, mesh).map_err(RenderJobError::Invalid)?;
                render_timed(
                    &Tracer::new(s, &lights, sky.clone(), phong, job.trace),
                    &camera,
                    frames,
                )?
            }
            None => {
                let s = OctreeSurfaces::new(&tree, job.trace.mode);
                render_timed(
                    &Tracer::new(s, &lights, sky.clone(), phong, job.trace),
                    &camera,
                    frames,
                )?
            }
        })
    } else {
        None
    };
    let refr = match reference {
        Some(mesh) => {
            let s = MeshSurfaces::new(mesh, tree.root, tree.depth);
            Some(render_timed(
                &Tracer::new(s, &lights, sky.clone(), phong, job.trace),
                &camera,
                frames,
            )?)
        }
        None => None,
    };
    let mut compare = None;
    let (frame, times) = match (svo, refr) {
        (Some(s), Some(r)) => {
            let diff = image_compare::compare(&s.0, &r.0)
                .ok_or_else(|| RenderJobError::Invalid("the two renders differ in size".into()))?;
            compare = Some(CompareReport {
                diff,
                svo_ms: FrameTiming::median(&s.1) * 1e3,
                reference_ms: FrameTiming::median(&r.1) * 1e3,
                reference_output: None,
            });
            if let Some(out) = &job.output {
                let ref_out = sibling(out, "reference");
                write_output(&r.0, job.aov, &ref_out, r.0.stats.max_primary_steps.max(1))?;
                let diff_out = sibling(out, "diff");
                write_png(
                    &diff_out,
                    s.0.width,
                    s.0.height,
                    &image_compare::diff_rgb8(&s.0, &r.0, 4.0),
                )?;
                if let Some(c) = compare.as_mut() {
                    c.reference_output = Some(ref_out.display().to_string());
                }
            }
            s
        }
        (Some(s), None) => s,
        (None, Some(r)) => r,
        (None, None) => unreachable!("one of the two renders always runs"),
    };
    let s = frame.stats;
    let cost_scale = s.max_primary_steps.max(1);
    let output = match &job.output {
        Some(out) => {
            write_output(&frame, job.aov, out, cost_scale)?;
            Some(out.display().to_string())
        }
        None => None,
    };
    Ok(RenderReport {
        width: camera.width,
        height: camera.height,
        depth: tree.depth,
        leaves: u64::from(tree.leaf_count),
        hit: if job.reference.is_some() && !job.compare {
            "triangles"
        } else {
            job.trace.mode.name()
        },
        threads,
        timing: FrameTiming::new(&times, &s),
        stats: s,
        cost_scale,
        output,
        compare,
        camera: CameraReport::of(&camera),
    })
}

/// [`render_file`] for a version-3 file past what one tree in memory holds: every chunk read
/// as a tree of its own (all in memory at once) and traced through [`ChunkedSurfaces`]. The
/// comparisons with the mesh and the exact hit mode are refused.
fn run_chunked(job: &RenderJob, threads: usize) -> Result<RenderReport, RenderJobError> {
    if job.reference.is_some() || job.mesh.is_some() || job.trace.mode == HitMode::Exact {
        return Err(RenderJobError::Invalid(
            "a tree stored in chunks past 2^31 leaves renders in the cube and contour hit \
             modes, without --reference or --mesh"
                .into(),
        ));
    }
    let (file, trees) = ChunkedFile::load(&job.input)?;
    let chunks: Vec<ChunkTree> = trees
        .into_iter()
        .enumerate()
        .map(|(i, tree)| ChunkTree {
            cell: file.chunk_cell(i),
            first_leaf: file.chunk_leaves(i).1,
            tree,
        })
        .collect();
    let (lo, hi) = chunks
        .iter()
        .map(|c| c.tree.occupied_bounds())
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
        .unwrap_or((file.root().origin, file.root().origin));
    let (camera, lights, sky, _) = scene_around(file.depth(), lo, hi, &file.build().scene, job)?;
    let s = ChunkedSurfaces::new(
        file.root(),
        file.depth(),
        file.level(),
        &chunks,
        job.trace.mode,
    )
    .map_err(RenderJobError::Invalid)?;
    let tracer = Tracer::new(s, &lights, sky, Phong::default(), job.trace);
    let report = |stats: RenderStats, times: &[f64], cost_scale, output| RenderReport {
        width: camera.width,
        height: camera.height,
        depth: file.depth(),
        leaves: file.leaf_count(),
        hit: job.trace.mode.name(),
        threads,
        timing: FrameTiming::new(times, &stats),
        stats,
        cost_scale,
        output,
        compare: None,
        camera: CameraReport::of(&camera),
    };
    if job.cast {
        let (stats, times) = cast_timed(&tracer, &camera, job.bench_frames)?;
        return Ok(report(stats, &times, 1, None));
    }
    let (frame, times) = render_timed(&tracer, &camera, job.bench_frames)?;
    let cost_scale = frame.stats.max_primary_steps.max(1);
    let output = match &job.output {
        Some(out) => {
            write_output(&frame, job.aov, out, cost_scale)?;
            Some(out.display().to_string())
        }
        None => None,
    };
    Ok(report(frame.stats, &times, cost_scale, output))
}

impl CameraReport {
    fn of(camera: &Camera) -> Self {
        Self {
            eye: camera.eye.to_array(),
            target: camera.target.to_array(),
            up: camera.up.to_array(),
            fov_deg: camera.fov_deg,
        }
    }
}

/// The timing of a benchmark's frames, with the throughput it gives.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
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

/// `dir/name.png` -> `dir/name.<tag>.png`.
fn sibling(out: &std::path::Path, tag: &str) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = out
        .extension()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    out.with_file_name(format!("{stem}.{tag}.{ext}"))
}

/// Loads the six faces `px, nx, py, ny, pz, nz` (`.png`, `.jpg` or `.jpeg`) of a cube map
/// from folder `dir`; they must be square and of one size.
pub fn load_cube_map(dir: &std::path::Path) -> Result<CubeMap, RenderJobError> {
    let mut faces = Vec::with_capacity(6);
    let mut side = None;
    for name in ["px", "nx", "py", "ny", "pz", "nz"] {
        let path = ["png", "jpg", "jpeg"]
            .iter()
            .map(|e| dir.join(format!("{name}.{e}")))
            .find(|p| p.is_file())
            .ok_or_else(|| {
                RenderJobError::Invalid(format!(
                    "cube map {}: no {name}.png or {name}.jpg (faces px, nx, py, ny, pz, nz)",
                    dir.display()
                ))
            })?;
        let img = image::open(&path)
            .map_err(|e| RenderJobError::Invalid(format!("cube map face {}: {e}", path.display())))?
            .to_rgba8();
        let (w, h) = img.dimensions();
        if w != h || side.is_some_and(|s| s != w) || w == 0 {
            return Err(RenderJobError::Invalid(format!(
                "cube map face {} is {w}x{h}; faces must be square and all the same size",
                path.display()
            )));
        }
        side = Some(w);
        faces.push(Texture {
            width: w,
            height: h,
            rgba: img.pixels().map(|p| p.0).collect(),
        });
    }
    let faces: [Texture; 6] = faces
        .try_into()
        .map_err(|_| RenderJobError::Invalid("cube map needs six faces".into()))?;
    Ok(CubeMap { faces })
}

/// Checks that `out` has the extension AOV `a` is written as and that its folder exists.
pub fn check_output(out: &std::path::Path, a: Aov) -> Result<(), RenderJobError> {
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let ok = match a {
        Aov::Depth => ext == "pfm" || ext == "exr",
        _ => ext == "png",
    };
    if !ok {
        return Err(RenderJobError::Invalid(format!(
            "{}: {} images are written as {}",
            out.display(),
            if a == Aov::Depth {
                "depth"
            } else {
                "colour and AOV"
            },
            if a == Aov::Depth {
                ".pfm or .exr"
            } else {
                ".png"
            }
        )));
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty())
        && !dir.is_dir()
    {
        return Err(RenderJobError::Invalid(format!(
            "cannot write {}: folder {} does not exist",
            out.display(),
            dir.display()
        )));
    }
    Ok(())
}

/// Writes `f`'s colour or AOV `a` to `out` atomically (`cost_scale`: the steps at the
/// hottest colour of the cost heat map).
pub fn write_output(
    f: &Frame,
    a: Aov,
    out: &std::path::Path,
    cost_scale: u32,
) -> Result<(), ImageWriteError> {
    let (w, h) = (f.width, f.height);
    match a {
        Aov::Depth => write_float(out, w, h, &f.depth),
        Aov::Colour => write_png(out, w, h, &aov::colour_rgb8(f)),
        Aov::Normal => write_png(out, w, h, &aov::normal_rgb8(f)),
        Aov::Leaf => write_png(out, w, h, &aov::leaf_rgb8(f)),
        Aov::Cost => write_png(out, w, h, &aov::cost_rgb8(f, cost_scale)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::xorshift;
    use glam::UVec3;

    /// The path for files past one tree in memory (every chunk a tree of its own) writes the
    /// image that reading the same version-3 file whole writes, byte for byte, and reports the
    /// same rays; the comparisons with a mesh are refused there in one line.
    #[test]
    fn a_file_in_chunks_renders_the_image_of_the_whole_tree() {
        let dir = tempfile::tempdir().unwrap();
        let mut rnd = xorshift(0x7e4d);
        let root = crate::geometry::grid::RootCube {
            origin: DVec3::new(0.0, -1.0, 2.0),
            side: 3.0,
        };
        let cells: Vec<_> = (0..2000)
            .map(|_| {
                let c = UVec3::new(
                    (rnd() % 64) as u32,
                    (rnd() % 16) as u32,
                    (rnd() % 64) as u32,
                );
                let t = (rnd() % 100) as f32 / 100.0;
                let v = crate::Voxel {
                    colour: [t, 0.4, 1.0 - t, 1.0],
                    reflectivity: if t > 0.7 { 0.6 } else { 0.0 },
                    normal: Some(Vec3::new(0.2, 1.0, t - 0.5)),
                    ..crate::Voxel::default()
                };
                (c, v)
            })
            .collect();
        let tree = Octree::from_cells(root, 6, cells).unwrap();
        let input = dir.path().join("c.svo");
        let mut bytes = Vec::new();
        crate::io::write_chunked_to(&tree, &crate::io::BuildInfo::new(), 3, &mut bytes).unwrap();
        std::fs::write(&input, bytes).unwrap();
        let job = |name: &str| RenderJob {
            input: input.clone(),
            output: Some(dir.path().join(name)),
            width: 80,
            height: 60,
            threads: Some(2),
            ..RenderJob::default()
        };
        let whole = render_file(&job("whole.png")).unwrap();
        let chunked = with_threads(Some(2), |threads| run_chunked(&job("chunks.png"), threads))
            .unwrap()
            .unwrap();
        assert!(whole.stats.primary_hits > 500, "{:?}", whole.stats);
        assert_eq!(chunked.stats.primary_hits, whole.stats.primary_hits);
        assert_eq!(chunked.leaves, whole.leaves);
        let read = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
        assert!(read("whole.png") == read("chunks.png"));
        let e = run_chunked(
            &RenderJob {
                reference: Some(input.clone()),
                ..job("no.png")
            },
            1,
        )
        .unwrap_err();
        assert!(e.to_string().contains("without --reference"), "{e}");
    }
}
