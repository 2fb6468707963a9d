//! File to file: load a mesh (or an `.svo`), bake, and write `.svo`, `.binvox` or `.vox`
//! atomically, timing each phase. This is everything `svo-bake` does; its `main` only parses
//! arguments, draws the progress bar and prints the [`BakeReport`].

use crate::bake::bake_mesh::{BakeError, BakeOptions, BakeStats, Phase, bake_for_file};
use crate::bake::bounded::{PartsReport, bake_planned, peak_resident, plan_for_budget};
use crate::bake::plan::PartsError;
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
    /// The bake in parts failed.
    #[error(transparent)]
    Parts(#[from] PartsError),
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
    /// Bake in parts within this many bytes of memory (an `.svo` output only): the parts
    /// are baked one after another into files beside the output and merged into it, the
    /// same bytes as the bake in memory. `None`: in memory, unless `options.max_memory` is
    /// set and the estimate exceeds it, in which case the bake goes into parts within that.
    pub memory: Option<u64>,
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
    /// The bake in parts, when it was one.
    pub parts: Option<PartsReport>,
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
        let build = BuildInfo {
            strategy: options.strategy.name().to_string(),
            source_triangles: mesh.triangles.len() as u64,
            scene,
            ..BuildInfo::new()
        };
        let parts = |budget| {
            bake_in_parts(
                job,
                &mesh,
                &options,
                &build,
                budget,
                threads,
                (t_all, load_s),
                progress,
            )
        };
        if let Some(budget) = job.memory {
            if format != OutputFormat::Svo {
                return Err(PartsError::Unsupported(
                    "a bake within a memory budget writes .svo only".into(),
                )
                .into());
            }
            return parts((budget, false));
        }
        // A surface bake to `.svo` that the memory limit refuses (before it starts), or that
        // one tree in memory cannot hold, goes into parts within that limit (past 2^31 leaves
        // or nodes the file is version 3).
        let (tree, stats) = match bake_for_file(&mesh, &options, progress) {
            Err(BakeError::TooLarge { .. } | BakeError::TooManyLeaves { .. })
                if format == OutputFormat::Svo && options.solid.is_none() =>
            {
                let limit = options.max_memory.unwrap_or(u64::MAX);
                return parts((limit, true));
            }
            r => r?,
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
        parts: None,
    })
}

/// Bakes in parts within `budget` bytes into `job.output`.
#[allow(clippy::too_many_arguments)]
fn bake_in_parts(
    job: &BakeJob,
    mesh: &crate::Mesh,
    options: &BakeOptions,
    build: &BuildInfo,
    (budget, automatic): (u64, bool),
    threads: usize,
    (t_all, load_s): (Instant, f64),
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<BakeReport, PipelineError> {
    let opts = BakeOptions {
        max_memory: None,
        ..options.clone()
    };
    let plan = plan_for_budget(mesh, &job.input, &opts, budget, build)?;
    let t = Instant::now();
    let (merge, part_seconds, part_bytes, degenerate) =
        bake_planned(mesh, &plan, &job.output, progress)?;
    let bake_s = t.elapsed().as_secs_f64() - merge.seconds;
    let root = plan.root();
    let stats = BakeStats {
        triangles: mesh.triangles.len(),
        degenerate_triangles: degenerate,
        depth: plan.depth,
        strategy: plan.strategy.clone(),
        exact: opts.strategy.is_exact(),
        root_origin: plan.root_origin,
        root_side: plan.root_side,
        cell_size: root.cell_size(plan.depth),
        nodes: merge.nodes as usize,
        leaves: merge.leaves as usize,
        estimated_leaves: plan.estimated_leaves,
        overlap_tests: merge.overlap_tests,
        leaf_triangle_pairs: merge.leaf_triangle_pairs as usize,
        false_positives: merge.false_positives as usize,
        voxelize_s: bake_s,
        channels: merge.channels.clone(),
        payload_bytes: merge.bytes as usize,
        ..BakeStats::default()
    };
    Ok(BakeReport {
        input: job.input.display().to_string(),
        output: job.output.display().to_string(),
        format: OutputFormat::Svo,
        threads,
        load_s,
        write_s: merge.seconds,
        total_s: t_all.elapsed().as_secs_f64(),
        file_bytes: merge.bytes,
        leaves: merge.leaves as usize,
        nodes: merge.nodes as usize,
        depth: plan.depth,
        bake: Some(stats),
        parts: Some(PartsReport {
            budget,
            automatic,
            parts: plan.part_count(),
            level: plan.level,
            part_seconds,
            part_bytes,
            merge,
            peak_resident: peak_resident(),
        }),
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
        if let Some(p) = &self.parts {
            const GIB: f64 = (1u64 << 30) as f64;
            let mut t = p.part_seconds.clone();
            t.sort_by(f64::total_cmp);
            let (lo, mid, hi) = (
                t.first().copied().unwrap_or(0.0),
                t.get(t.len() / 2).copied().unwrap_or(0.0),
                t.last().copied().unwrap_or(0.0),
            );
            writeln!(
                f,
                "  parts       {} parts at level {}{} within {:.2} GiB: part times {} / {} / {} (min / median / max), \
                 {:.2} GiB of part files, merge {}; peak resident {}",
                p.parts,
                p.level,
                if p.automatic {
                    " (the bake in memory would not fit)"
                } else {
                    ""
                },
                p.budget as f64 / GIB,
                ms(lo),
                ms(mid),
                ms(hi),
                p.part_bytes as f64 / GIB,
                ms(p.merge.seconds),
                p.peak_resident.map_or("unknown".to_string(), |b| format!(
                    "{:.2} GiB",
                    b as f64 / GIB
                ))
            )?;
        }
        write!(
            f,
            "  output      {} bytes, {:.2} bytes per leaf",
            self.file_bytes, per_leaf
        )
    }
}
