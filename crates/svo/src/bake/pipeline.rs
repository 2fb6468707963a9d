//! File to file: load a mesh (or an `.svo`), bake, and write `.svo`, `.binvox` or `.vox`
//! atomically, timing each phase. This is everything `svo-bake` does; its `main` only parses
//! arguments, draws the progress bar and prints the [`BakeReport`].

use crate::bake::bake_mesh::{BakeError, BakeOptions, BakeStats, Phase, bake_for_file};
use crate::import::load_mesh;
use crate::io::binvox::{ExportError, write_binvox};
use crate::io::header::BuildInfo;
use crate::io::read::read_file;
use crate::io::write::{FormatError, write_file};
use crate::mesh::MeshFormat;
use crate::mesh::format::is_scene_file;
use crate::mesh::scene_info::SceneInfo;
use crate::mesh::triangle_mesh::MeshError;
use crate::octree::tree::Octree;
use crate::thread_pool::{ThreadsError, with_threads};
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;
use thiserror::Error;

/// Errors of the bake pipeline.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum PipelineError {
    /// Loading the mesh failed.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// Baking failed.
    #[error(transparent)]
    Bake(#[from] BakeError),
    /// Reading or writing `.svo` failed.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// Exporting failed.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// The output's extension is not a format we write.
    #[error("unsupported output format for {0} (expected .svo, .binvox or .vox)")]
    UnknownOutput(String),
    /// The output's folder does not exist.
    #[error("cannot write {path}: folder {dir} does not exist")]
    NoOutputDir {
        /// The output.
        path: String,
        /// Its folder.
        dir: String,
    },
    /// The thread pool could not be made.
    #[error(transparent)]
    Threads(#[from] ThreadsError),
    /// The scene file could not be loaded.
    #[cfg(feature = "scene")]
    #[error(transparent)]
    Scene(#[from] crate::scene::file::SceneError),
    /// A scene file without svo's `scene` feature.
    #[error("{0}: scene files need svo's `scene` cargo feature")]
    SceneUnavailable(String),
}

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
#[non_exhaustive]
pub enum OutputFormat {
    /// The `.svo` octree file.
    Svo,
    /// Dense binvox.
    Binvox,
    /// MagicaVoxel.
    Vox,
}

impl OutputFormat {
    /// The format named by a path's extension.
    pub fn from_path(path: &Path) -> Option<Self> {
        match path
            .extension()?
            .to_string_lossy()
            .to_ascii_lowercase()
            .as_str()
        {
            "svo" => Some(Self::Svo),
            "binvox" => Some(Self::Binvox),
            "vox" => Some(Self::Vox),
            _ => None,
        }
    }
}

/// One bake, file to file.
#[derive(Clone, Debug)]
pub struct BakeJob {
    /// The mesh (`.obj`, `.obj.gz`, `.ply`, `.gltf`, `.glb`), scene (`.toml`), or `.svo` to
    /// convert.
    pub input: PathBuf,
    /// The output (`.svo`, `.binvox`, `.vox`).
    pub output: PathBuf,
    /// Bake settings (ignored for `.svo` input).
    pub options: BakeOptions,
    /// Worker threads: a pool of this many, or with `None` the caller's pool (rayon's global
    /// one: all cores unless `RAYON_NUM_THREADS` says otherwise).
    pub threads: Option<usize>,
    /// Which of `options` the user set: a scene file's own depth and solid fill are used
    /// where the user did not.
    pub given: GivenOptions,
}

/// Which bake options were given explicitly (on the command line), so a scene file's own
/// values do not override them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GivenOptions {
    /// `options.depth`.
    pub depth: bool,
    /// `options.solid`.
    pub solid: bool,
}

/// What a bake did, for the summary and `--json`.
#[derive(Clone, Debug)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
pub struct BakeReport {
    /// Input path.
    pub input: String,
    /// Output path.
    pub output: String,
    /// Output format.
    pub format: OutputFormat,
    /// Threads used.
    pub threads: usize,
    /// Seconds loading the input.
    pub load_s: f64,
    /// Seconds writing the output.
    pub write_s: f64,
    /// Seconds in total.
    pub total_s: f64,
    /// Output file size.
    pub file_bytes: u64,
    /// Leaves in the tree.
    pub leaves: usize,
    /// Nodes in the tree.
    pub nodes: usize,
    /// Tree depth.
    pub depth: u8,
    /// Bake statistics (absent when converting an `.svo`).
    pub bake: Option<BakeStats>,
}

/// Runs a bake job (what `svo-bake` does): loads the input, bakes it (or reads an `.svo`),
/// and writes the output atomically.
pub fn bake_file(job: &BakeJob) -> Result<BakeReport, PipelineError> {
    bake_file_with_progress(job, &|_, _| {})
}

/// [`bake_file`], calling `progress(phase, fraction)` as the bake goes (from worker threads).
pub fn bake_file_with_progress(
    job: &BakeJob,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<BakeReport, PipelineError> {
    let format = OutputFormat::from_path(&job.output)
        .ok_or_else(|| PipelineError::UnknownOutput(job.output.display().to_string()))?;
    if let Some(dir) = job.output.parent().filter(|d| !d.as_os_str().is_empty())
        && !dir.is_dir()
    {
        return Err(PipelineError::NoOutputDir {
            path: job.output.display().to_string(),
            dir: dir.display().to_string(),
        });
    }
    let is_svo = job
        .input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svo"));
    let is_scene = is_scene_file(&job.input);
    if is_scene && cfg!(not(feature = "scene")) {
        return Err(PipelineError::SceneUnavailable(
            job.input.display().to_string(),
        ));
    }
    if !is_svo && !is_scene && MeshFormat::from_path(&job.input).is_none() {
        return Err(MeshError::UnknownFormat {
            path: job.input.display().to_string(),
            extension: job
                .input
                .extension()
                .map(|e| e.to_string_lossy().into_owned())
                .unwrap_or_default(),
        }
        .into());
    }
    with_threads(job.threads, |threads| {
        run_inner(job, format, is_svo, is_scene, threads, progress)
    })?
}

fn run_inner(
    job: &BakeJob,
    format: OutputFormat,
    is_svo: bool,
    is_scene: bool,
    threads: usize,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<BakeReport, PipelineError> {
    let t_all = Instant::now();
    let t = Instant::now();
    let (tree, build, stats, load_s): (Octree, BuildInfo, Option<BakeStats>, f64) = if is_svo {
        let (tree, build) = read_file(&job.input)?;
        (tree, build, None, t.elapsed().as_secs_f64())
    } else {
        let (mesh, scene, options) = load_input(job, is_scene)?;
        let load_s = t.elapsed().as_secs_f64();
        let (tree, stats) = bake_for_file(&mesh, &options, progress)?;
        let build = BuildInfo {
            strategy: options.strategy.name().to_string(),
            source_triangles: mesh.triangles.len() as u64,
            scene,
            ..BuildInfo::new()
        };
        (tree, build, Some(stats), load_s)
    };
    let t = Instant::now();
    let file_bytes = match format {
        OutputFormat::Svo => write_file(&tree, &build, &job.output)?,
        OutputFormat::Binvox => write_binvox(&tree, &job.output)?,
        #[cfg(feature = "vox")]
        OutputFormat::Vox => crate::io::vox::write_vox(&tree, &job.output)?,
        #[cfg(not(feature = "vox"))]
        OutputFormat::Vox => {
            return Err(PipelineError::UnknownOutput(
                "vox support not compiled in".into(),
            ));
        }
    };
    let (leaves, nodes, depth) = (tree.leaf_count as usize, tree.nodes.len(), tree.depth);
    crate::bake::bake_mesh::drop_in_background(tree);
    Ok(BakeReport {
        input: job.input.display().to_string(),
        output: job.output.display().to_string(),
        format,
        threads,
        load_s,
        write_s: t.elapsed().as_secs_f64(),
        total_s: t_all.elapsed().as_secs_f64(),
        file_bytes,
        leaves,
        nodes,
        depth,
        bake: stats,
    })
}

/// The mesh to bake, the scene's lights and views, and the options with a scene file's own
/// values where the user gave none. `is_scene`: the input is a scene file (which [`run`]
/// refuses without the `scene` feature).
fn load_input(
    job: &BakeJob,
    is_scene: bool,
) -> Result<(crate::Mesh, SceneInfo, BakeOptions), PipelineError> {
    #[cfg(feature = "scene")]
    if is_scene {
        let s = crate::scene::file::load_scene(&job.input)?;
        let mut options = job.options.clone();
        if !job.given.depth
            && let Some(d) = s.depth
        {
            options.depth = d;
        }
        if !job.given.solid && s.solid.is_some() {
            options.solid = s.solid;
        }
        return Ok((s.mesh, s.info, options));
    }
    #[cfg(not(feature = "scene"))]
    let _ = is_scene;
    let mesh = load_mesh(&job.input)?;
    let scene = mesh.scene.clone();
    Ok((mesh, scene, job.options.clone()))
}

fn ms(s: f64) -> String {
    if s < 10.0 {
        format!("{:.1} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

impl fmt::Display for BakeReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} -> {} ({:?}, depth {}, {} threads)",
            self.input, self.output, self.format, self.depth, self.threads
        )?;
        let per_leaf = if self.leaves > 0 {
            self.file_bytes as f64 / self.leaves as f64
        } else {
            0.0
        };
        if let Some(b) = &self.bake {
            writeln!(
                f,
                "  triangles   {} ({} degenerate, kept)",
                b.triangles, b.degenerate_triangles
            )?;
            writeln!(
                f,
                "  tree        {} nodes, {} leaves (estimated {:.0}), {} triangle/leaf pairs",
                self.nodes, self.leaves, b.estimated_leaves, b.leaf_triangle_pairs
            )?;
            if let Some(mode) = &b.solid {
                writeln!(
                    f,
                    "  solid       {} interior leaves ({mode} fill; {} surface leaves)",
                    b.interior_leaves,
                    self.leaves - b.interior_leaves.min(self.leaves)
                )?;
            }
            let strategy = if b.exact {
                "exact: every touched cell, no false positive".to_string()
            } else {
                format!(
                    "inexact: {} false positives ({:.2}% of the leaves; `exact` avoids them)",
                    b.false_positives,
                    100.0 * b.false_positives as f64 / self.leaves.max(1) as f64
                )
            };
            writeln!(f, "  accuracy    strategy {} ({strategy})", b.strategy)?;
            writeln!(
                f,
                "  error       cell {:.4e} units; as cubes the surface is off by up to {:.4e} units (a cell diagonal)",
                b.cell_size,
                b.cell_size * 3f64.sqrt()
            )?;
            if let Some(c) = &b.contour_thickness {
                writeln!(
                    f,
                    "  contours    thickness mean {:.3} cells, p95 {:.3}, max {:.3}: as contours the surface lies \
                     within a slab of {:.4e} units (mean; p95 {:.4e})",
                    c.mean,
                    c.p95,
                    c.max,
                    c.mean * b.cell_size,
                    c.p95 * b.cell_size
                )?;
            }
            let ch: Vec<String> = b.channels.iter().map(|(k, s)| format!("{k}:{s}")).collect();
            writeln!(
                f,
                "  channels    {}",
                if ch.is_empty() {
                    "none".to_string()
                } else {
                    ch.join(" ")
                }
            )?;
            writeln!(
                f,
                "  time        load {}, voxelize {}, attributes {}, contours {}{}, write {}, total {}",
                ms(self.load_s),
                ms(b.voxelize_s),
                ms(b.attributes_s),
                ms(b.contours_s),
                if b.solid.is_some() {
                    format!(", solid fill {}", ms(b.solid_s))
                } else {
                    String::new()
                },
                ms(self.write_s),
                ms(self.total_s)
            )?;
        } else {
            writeln!(
                f,
                "  tree        {} nodes, {} leaves (converted)",
                self.nodes, self.leaves
            )?;
            writeln!(
                f,
                "  time        read {}, write {}",
                ms(self.load_s),
                ms(self.write_s)
            )?;
        }
        write!(
            f,
            "  output      {} bytes, {:.2} bytes per leaf",
            self.file_bytes, per_leaf
        )
    }
}
