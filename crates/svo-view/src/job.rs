//! A render job as `svo-view` takes it: the file, the settings its flags give, and what to
//! write. [`prepare`] checks the settings and the output path before anything is loaded,
//! then sets the scene up with [`svo::render::RenderScene::open`]; the CPU path
//! ([`crate::cpu_render`]), the GPU path ([`crate::headless`]) and the window start there,
//! so they show the same scene.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use svo::mesh::Texture;
use svo::render::{
    Aov, CubeMap, Frame, ImageWriteError, LightSpec, MAX_BOUNCES, RenderScene, SceneSetup,
    SetupError, TraceOptions, write_float, write_png,
};
use thiserror::Error;

/// The most frames a benchmark renders.
pub const MAX_BENCH_FRAMES: u32 = 10_000;

/// Errors of a render job.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum JobError {
    /// Reading the file or setting its scene up failed.
    #[error("{err}{hint}", err = .0, hint = setup_hint(.0))]
    Setup(SetupError),
    /// The camera settings make no image.
    #[error(transparent)]
    Camera(#[from] svo::render::CameraError),
    /// Writing the image failed.
    #[error(transparent)]
    Image(#[from] ImageWriteError),
    /// Loading a mesh failed.
    #[error(transparent)]
    Mesh(#[from] svo::MeshError),
    /// Loading a scene file as the reference failed.
    #[error(transparent)]
    Scene(#[from] svo::scene::SceneError),
    /// The leaves' triangles, or the chunks of a file past one tree in memory, cannot be
    /// traced.
    #[error(transparent)]
    Surfaces(#[from] svo::render::SurfacesError),
    /// The thread pool could not be made.
    #[error(transparent)]
    Threads(#[from] svo::ThreadsError),
    /// A setting is invalid (the message names the flag).
    #[error("{0}")]
    Invalid(String),
}

// The setup's error is shown with a hint (below), not as a source: its message is the
// variant's own.
impl From<SetupError> for JobError {
    fn from(e: SetupError) -> Self {
        Self::Setup(e)
    }
}

/// What the command can do about a setup's error: the text to add to its message.
fn setup_hint(e: &SetupError) -> &'static str {
    match e {
        SetupError::Format(svo::FormatError::TooLarge { .. }) => {
            " (`svo-view --info` describes the file, and `svo-view --cpu` renders it)"
        }
        _ => "",
    }
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
    pub eye: Option<glam::DVec3>,
    /// Camera target; default: the model's centre.
    pub target: Option<glam::DVec3>,
    /// Up; default `+y`.
    pub up: Option<glam::DVec3>,
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
    /// pixel, no shading, no image: [`svo::render::cast_primary`]), as a ray-casting library
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
    /// Read only the file's top this many levels ([`svo::io::read_file_to_depth`]).
    pub max_depth: Option<u8>,
}

impl Default for RenderJob {
    fn default() -> Self {
        let setup = SceneSetup::default();
        Self {
            input: PathBuf::new(),
            output: None,
            width: setup.width,
            height: setup.height,
            eye: None,
            target: None,
            up: None,
            fov_deg: setup.fov_deg,
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
            max_depth: None,
        }
    }
}

impl RenderJob {
    /// The scene setup the job's settings give (the cube map loaded from its folder).
    pub fn setup(&self) -> Result<SceneSetup, JobError> {
        Ok(SceneSetup {
            width: self.width,
            height: self.height,
            eye: self.eye,
            target: self.target,
            up: self.up,
            fov_deg: self.fov_deg,
            lights: self.lights.clone(),
            view: self.view.clone(),
            cube_map: self
                .sky_cube_map
                .as_deref()
                .map(load_cube_map)
                .transpose()?
                .map(Arc::new),
            max_depth: self.max_depth,
        })
    }

    /// Checks the settings the flags give, before anything is loaded.
    pub fn check(&self) -> Result<(), JobError> {
        let bounces = self.trace.max_reflections.max(self.trace.max_refractions);
        if bounces > MAX_BOUNCES {
            return Err(JobError::Invalid(format!("at most {MAX_BOUNCES} bounces")));
        }
        if self
            .bench_frames
            .is_some_and(|n| n == 0 || n > MAX_BENCH_FRAMES)
        {
            return Err(JobError::Invalid(format!(
                "--bench takes 1..={MAX_BENCH_FRAMES} frames"
            )));
        }
        if self.cast
            && (self.bench_frames.is_none() || self.output.is_some() || self.reference.is_some())
        {
            return Err(JobError::Invalid(
                "--cast times the primary rays alone: it goes with --bench, without -o or --reference"
                    .into(),
            ));
        }
        if !(self.trace.lod.is_finite() && self.trace.lod >= 0.0) {
            return Err(JobError::Invalid(
                "--lod must be a non-negative number of pixels".into(),
            ));
        }
        if !(self.trace.bias_cells.is_finite() && self.trace.bias_cells >= 0.0) {
            return Err(JobError::Invalid(
                "the bias must be a non-negative number".into(),
            ));
        }
        if let Some(out) = &self.output {
            check_output(out, self.aov)?;
        }
        Ok(())
    }
}

/// Checks `job`'s settings and output path, loads its file and sets up its scene.
pub fn prepare(job: &RenderJob) -> Result<RenderScene, JobError> {
    job.check()?;
    Ok(RenderScene::open(&job.input, &job.setup()?)?)
}

/// The triangles of `--reference` or `--mesh`: a mesh file, or every object of a scene file
/// (`.toml`), which is what `svo-bake` voxelizes from it.
pub fn load_reference(path: &Path) -> Result<svo::Mesh, JobError> {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
    {
        return Ok(svo::scene::load_scene(path)?.mesh);
    }
    Ok(svo::Mesh::load(path)?)
}

/// Loads the six faces `px, nx, py, ny, pz, nz` (`.png`, `.jpg` or `.jpeg`) of a cube map
/// from folder `dir`; they must be square and of one size.
pub fn load_cube_map(dir: &Path) -> Result<CubeMap, JobError> {
    let mut faces = Vec::with_capacity(6);
    let mut side = None;
    for name in ["px", "nx", "py", "ny", "pz", "nz"] {
        let path = ["png", "jpg", "jpeg"]
            .iter()
            .map(|e| dir.join(format!("{name}.{e}")))
            .find(|p| p.is_file())
            .ok_or_else(|| {
                JobError::Invalid(format!(
                    "cube map {}: no {name}.png or {name}.jpg (faces px, nx, py, ny, pz, nz)",
                    dir.display()
                ))
            })?;
        let img = image::open(&path)
            .map_err(|e| JobError::Invalid(format!("cube map face {}: {e}", path.display())))?
            .to_rgba8();
        let (w, h) = img.dimensions();
        if w != h || side.is_some_and(|s| s != w) || w == 0 {
            return Err(JobError::Invalid(format!(
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
        .map_err(|_| JobError::Invalid("cube map needs six faces".into()))?;
    Ok(CubeMap { faces })
}

/// Checks that `out` has the extension AOV `a` is written as and that its folder exists.
pub fn check_output(out: &Path, a: Aov) -> Result<(), JobError> {
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let (ok, what, exts) = match a {
        Aov::Depth => (ext == "pfm" || ext == "exr", "depth", ".pfm or .exr"),
        _ => (ext == "png", "colour and AOV", ".png"),
    };
    if !ok {
        return Err(JobError::Invalid(format!(
            "{}: {what} images are written as {exts}",
            out.display()
        )));
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty())
        && !dir.is_dir()
    {
        return Err(JobError::Invalid(format!(
            "cannot write {}: folder {} does not exist",
            out.display(),
            dir.display()
        )));
    }
    Ok(())
}

/// Writes `f`'s colour or AOV `a` to `out` atomically (`cost_scale`: the steps at the
/// hottest colour of the cost heat map).
pub fn write_output(f: &Frame, a: Aov, out: &Path, cost_scale: u32) -> Result<(), ImageWriteError> {
    let (w, h) = (f.width, f.height);
    match a.rgb8(f, cost_scale) {
        Some(rgb) => write_png(out, w, h, &rgb),
        None => write_float(out, w, h, &f.depth),
    }
}

/// `dir/name.ext` -> `dir/name.<tag>.ext`.
pub fn sibling(out: &Path, tag: &str) -> PathBuf {
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

/// Where `--compare` writes its difference image beside `out`: always a PNG of the colour
/// difference, `dir/name.diff.png`, whatever the AOV and the output's extension.
pub fn diff_path(out: &Path) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    out.with_file_name(format!("{stem}.diff.png"))
}
