//! File to file: load a mesh, a scene or an `.svo`, bake, and write `.svo`, `.binvox` or
//! `.vox` atomically, timing each phase. This is everything `svo-bake` does with an input;
//! its `main` parses arguments, draws the progress bar and prints the
//! [`BakeReport`].

use crate::memory::peak_resident;
use crate::report::{BakeReport, PartsReport};
use std::path::{Path, PathBuf};
use std::time::Instant;
use svo::bake::parts::{MergeFormat, PartsError, bake_within};
use svo::bake::{BakeError, BakeOptions, BakeStats, Phase, bake_mesh_with_progress};
use svo::dag::DagValues;
use svo::io::{BuildInfo, ExportError, read_file, write_binvox, write_file};
use svo::mesh::{MeshFormat, SceneInfo};
use svo::{FormatError, Mesh, MeshError, Octree, ThreadsError};
use thiserror::Error;

/// Errors of a bake job.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum JobError {
    /// Loading the mesh failed.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// Baking failed.
    #[error("{err}{hint}", err = .0, hint = bake_hint(.0))]
    Bake(BakeError),
    /// Reading or writing `.svo` failed.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// Exporting failed.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// The bake in parts failed.
    #[error("{err}{hint}", err = .0, hint = parts_hint(.0))]
    Parts(PartsError),
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
    #[error(transparent)]
    Scene(#[from] svo::scene::SceneError),
    /// The output's node layout cannot hold this job's tree, or this kind of job does not
    /// make it.
    #[error("--layout dag: {0}")]
    Layout(String),
}

// The bake's and the parts' errors are shown with a hint (below), not as sources: their
// messages are the variants' own.
impl From<BakeError> for JobError {
    fn from(e: BakeError) -> Self {
        Self::Bake(e)
    }
}

impl From<PartsError> for JobError {
    fn from(e: PartsError) -> Self {
        Self::Parts(e)
    }
}

/// What the command's flags can do about a bake's error: the text to add to its message.
pub fn bake_hint(e: &BakeError) -> &'static str {
    match e {
        BakeError::TooLarge { .. } => "; lower --depth, or pass --force to try anyway",
        BakeError::TooManyLeaves { .. } => " (--depth)",
        BakeError::OpenMesh { .. } => {
            "; --solid needs a closed mesh (use --solid vote for meshes with holes)"
        }
        BakeError::ContourWithoutNormal => " (add `normal` to --channels, or drop `contour`)",
        _ => "",
    }
}

/// What the command's flags can do about an error of a bake in parts: the text to add to its
/// message.
pub fn parts_hint(e: &PartsError) -> String {
    match e {
        PartsError::Bake(b) => bake_hint(b).to_string(),
        PartsError::BudgetTooSmall { .. } => "; raise --memory".into(),
        PartsError::TooManyParts { .. } | PartsError::NoDiskSpace { .. } => {
            "; lower --depth".into()
        }
        PartsError::MissingPart { index, .. } => format!(" (run `svo-bake part PLAN {index}`)"),
        _ => String::new(),
    }
}

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
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

/// How an `.svo` output stores its nodes (`docs/format.md`, sections 4 and 12).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[non_exhaustive]
pub enum NodeLayout {
    /// The tree: each node its child mask and a pointer to its children (version 2, or 4
    /// with inner-node attributes).
    #[default]
    Tree,
    /// Identical subtrees stored once, the two lowest levels as 64-bit bricks (version 4's
    /// DAG layout; no inner-node attributes).
    Dag,
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
    /// set and the bake could need more than that, in which case the bake goes into parts
    /// within that.
    pub memory: Option<u64>,
    /// How an `.svo` output stores its nodes: the tree (the default) or the DAG, which a
    /// bake in memory and the conversion of an `.svo` make (a bake in parts writes the tree).
    pub layout: NodeLayout,
    /// With the DAG layout: where and how finely the leaves' values are kept (each leaf's
    /// own by default; on a level above, from the inner nodes' attributes, which a bake then
    /// makes; normals in fewer bits). A bake in memory or the conversion of an `.svo` with
    /// inner-node attributes.
    pub values: DagValues,
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

/// Whether `path` names a scene file (`.toml`) rather than a mesh.
fn is_scene_file(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

/// What kind of input a job reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Input {
    /// An `.svo` to convert.
    Svo,
    /// A scene file.
    Scene,
    /// A mesh file.
    Mesh,
}

/// Sets `options` for a DAG that keeps its leaves' values as `values` says: values above the
/// leaves are the inner nodes' attributes, and a contour (measured in its own leaf's cell)
/// cannot be kept there. Returns whether the values sit above the leaves.
pub fn options_for_values(options: &mut BakeOptions, values: DagValues) -> bool {
    let above = values.level_for(options.depth) < options.depth;
    if above {
        options.node_attributes = true;
        options.channels = options.channels.without(svo::octree::ChannelKind::Contour);
    }
    above
}

/// Runs a bake job (what `svo-bake` does): loads the input, bakes it (or reads an `.svo`),
/// and writes the output atomically.
pub fn bake_file(job: &BakeJob) -> Result<BakeReport, JobError> {
    bake_file_with_progress(job, &|_, _| {})
}

/// [`bake_file`], calling `progress(phase, fraction)` as the bake goes (from worker threads).
pub fn bake_file_with_progress(
    job: &BakeJob,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<BakeReport, JobError> {
    let format = OutputFormat::from_path(&job.output)
        .ok_or_else(|| JobError::UnknownOutput(job.output.display().to_string()))?;
    if let Some(dir) = job.output.parent().filter(|d| !d.as_os_str().is_empty())
        && !dir.is_dir()
    {
        return Err(JobError::NoOutputDir {
            path: job.output.display().to_string(),
            dir: dir.display().to_string(),
        });
    }
    let input = if job
        .input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svo"))
    {
        Input::Svo
    } else if is_scene_file(&job.input) {
        Input::Scene
    } else if MeshFormat::from_path(&job.input).is_some() {
        Input::Mesh
    } else {
        return Err(MeshError::UnknownFormat {
            path: job.input.display().to_string(),
            extension: job
                .input
                .extension()
                .map(|e| e.to_string_lossy().into_owned())
                .unwrap_or_default(),
        }
        .into());
    };
    svo::with_threads(job.threads, |threads| {
        run(job, format, input, threads, progress)
    })?
}

/// When the job started and the seconds its input took to load.
#[derive(Clone, Copy)]
struct Clock {
    start: Instant,
    load_s: f64,
}

fn run(
    job: &BakeJob,
    format: OutputFormat,
    input: Input,
    threads: usize,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<BakeReport, JobError> {
    let start = Instant::now();
    if input == Input::Svo {
        let (tree, build) = read_file(&job.input)?;
        let clock = Clock {
            start,
            load_s: start.elapsed().as_secs_f64(),
        };
        return write_tree(job, format, tree, &build, None, threads, clock);
    }
    let (mesh, scene, mut options) = load_input(job, input == Input::Scene)?;
    let dag = job.layout == NodeLayout::Dag;
    let mut values_above = false;
    if dag && job.values != DagValues::default() {
        job.values
            .check(options.depth)
            .map_err(|e| JobError::Layout(e.to_string()))?;
        values_above = options_for_values(&mut options, job.values);
    }
    let clock = Clock {
        start,
        load_s: start.elapsed().as_secs_f64(),
    };
    let build = BuildInfo {
        strategy: options.strategy.name().to_string(),
        source_triangles: mesh.triangles.len() as u64,
        scene,
        ..BuildInfo::new()
    };
    let parts = |budget, automatic| {
        bake_in_parts(
            job, &mesh, &options, &build, budget, automatic, threads, clock, progress,
        )
    };
    if dag && format != OutputFormat::Svo {
        return Err(JobError::Layout("a node layout is for .svo outputs".into()));
    }
    if dag && !values_above && options.node_attributes {
        return Err(JobError::Layout(
            "the DAG layout keeps no inner-node attributes: bake with --lod none, or write the \
             tree layout"
                .into(),
        ));
    }
    if dag && options.depth < 2 {
        return Err(JobError::Layout(
            "the DAG layout needs a tree of depth 2 or more (its lowest nodes are 4x4x4 bricks)"
                .into(),
        ));
    }
    if let Some(budget) = job.memory {
        if format != OutputFormat::Svo {
            return Err(PartsError::Unsupported(
                "a bake within a memory budget writes .svo only".into(),
            )
            .into());
        }
        return parts(budget, false);
    }
    // A surface bake to `.svo` that the memory limit refuses (before it starts), or that one
    // tree in memory cannot hold, goes into parts within that limit (past 2^31 leaves or
    // nodes the file is version 3).
    let (tree, stats) = match bake_mesh_with_progress(&mesh, &options, progress) {
        Err(BakeError::TooLarge { .. } | BakeError::TooManyLeaves { .. })
            if format == OutputFormat::Svo && options.solid.is_none() =>
        {
            return parts(options.max_memory.unwrap_or(u64::MAX), true);
        }
        r => r?,
    };
    write_tree(job, format, tree, &build, Some(stats), threads, clock)
}

/// Writes `tree` as the job's output and reports the job.
fn write_tree(
    job: &BakeJob,
    format: OutputFormat,
    tree: Octree,
    build: &BuildInfo,
    stats: Option<BakeStats>,
    threads: usize,
    clock: Clock,
) -> Result<BakeReport, JobError> {
    let t = Instant::now();
    let file_bytes = match format {
        OutputFormat::Svo if job.layout == NodeLayout::Dag => {
            svo::io::write_dag_file_with(&tree, build, &job.values, &job.output)?
        }
        OutputFormat::Svo => write_file(&tree, build, &job.output)?,
        OutputFormat::Binvox => write_binvox(&tree, &job.output)?,
        OutputFormat::Vox => svo::io::write_vox(&tree, &job.output)?,
    };
    let (leaves, nodes, depth) = (tree.leaf_count as usize, tree.nodes.len(), tree.depth);
    drop_in_background(tree);
    Ok(BakeReport {
        input: job.input.display().to_string(),
        output: job.output.display().to_string(),
        format,
        threads,
        load_s: clock.load_s,
        write_s: t.elapsed().as_secs_f64(),
        total_s: clock.start.elapsed().as_secs_f64(),
        file_bytes,
        leaves,
        nodes,
        depth,
        bake: stats,
        parts: None,
    })
}

/// Drops `value` on a short-lived thread: freeing hundreds of MB of pages costs tens of
/// milliseconds that the job need not wait for. If no thread can be started, the closure,
/// and with it the value, is dropped here by `spawn`'s error path.
fn drop_in_background<T: Send + 'static>(value: T) {
    let _ = std::thread::Builder::new()
        .name("svo-drop".into())
        .spawn(move || drop(value));
}

/// Bakes in parts within `budget` bytes into `job.output` (`automatic`: because the bake
/// in memory would not fit).
#[allow(clippy::too_many_arguments)]
fn bake_in_parts(
    job: &BakeJob,
    mesh: &Mesh,
    options: &BakeOptions,
    build: &BuildInfo,
    budget: u64,
    automatic: bool,
    threads: usize,
    clock: Clock,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<BakeReport, JobError> {
    let t = Instant::now();
    let r = bake_within(
        mesh,
        &job.input,
        options,
        budget,
        build,
        &job.output,
        if job.layout == NodeLayout::Dag {
            MergeFormat::DagWith(job.values)
        } else {
            MergeFormat::Auto
        },
        progress,
    )?;
    let bake_s = t.elapsed().as_secs_f64() - r.merge.seconds;
    let plan = &r.plan;
    let merge = &r.merge;
    let stats = BakeStats {
        triangles: mesh.triangles.len(),
        degenerate_triangles: r.degenerate_triangles,
        depth: plan.depth,
        strategy: plan.strategy.clone(),
        exact: options.strategy.is_exact(),
        root_origin: plan.root_origin,
        root_side: plan.root_side,
        cell_size: plan.root().cell_size(plan.depth),
        nodes: merge.nodes as usize,
        leaves: merge.leaves as usize,
        estimated_leaves: plan.estimated_leaves,
        max_leaves: plan.max_leaves,
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
        load_s: clock.load_s,
        write_s: merge.seconds,
        total_s: clock.start.elapsed().as_secs_f64(),
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
            part_seconds: r.part_seconds.clone(),
            part_bytes: r.part_bytes,
            resumed_parts: r.resumed_parts.len() as u32,
            removed_folders: paths(&r.removed_folders),
            other_folders: paths(&r.other_folders),
            merge: r.merge.clone(),
            peak_resident: peak_resident(),
        }),
    })
}

/// The mesh to bake, the scene's lights and views, and the options with a scene file's own
/// values where the user gave none.
fn load_input(job: &BakeJob, is_scene: bool) -> Result<(Mesh, SceneInfo, BakeOptions), JobError> {
    if is_scene {
        let s = svo::scene::load_scene(&job.input)?;
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
    let mesh = Mesh::load(&job.input)?;
    let scene = mesh.scene.clone();
    Ok((mesh, scene, job.options.clone()))
}

/// Paths as the report prints them.
fn paths(p: &[PathBuf]) -> Vec<String> {
    p.iter().map(|p| p.display().to_string()).collect()
}
