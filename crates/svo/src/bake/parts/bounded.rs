//! A bake in bounded memory on one machine: the plan's parts baked one after another into
//! part files beside the output, then merged.
//! Only the mesh, the lists that bin its triangles to the parts (one pass) and one part with
//! the setup of its own triangles are in memory at a time; the number of parts comes from
//! the memory budget, the bake's estimate and the parts' triangle counts.

use crate::bake::bake_mesh::{BakeOptions, Phase, estimate_bake};
use crate::bake::estimate::{BYTES_PER_LEAF, BYTES_PER_TRIANGLE, NODE_BYTES_PER_LEAF};
use crate::bake::parts::merge::{MergeFormat, MergeReport, dag_values, merge_with};
use crate::bake::parts::part::{bake_parts, is_complete_part, touched_counts, write_part};
use crate::bake::parts::plan::{
    BakePlan, MAX_PARTS, PART_LEAVES, PartsError, least_parts, makes_node_attributes, plan_bake,
    plan_to_bytes,
};
use crate::dag::DagValues;
use crate::io::atomic_write::{parent_dir, remove_stale};
use crate::io::header::BuildInfo;
use crate::mesh::triangle_mesh::Mesh;
use std::path::{Path, PathBuf};

/// What a bake within a memory budget did.
#[derive(Clone, Debug, PartialEq)]
pub struct PartsReport {
    /// The plan its parts were baked from.
    pub plan: BakePlan,
    /// Seconds each part took to bake (writing its file included), in part order.
    pub part_seconds: Vec<f64>,
    /// Bytes of all part files together.
    pub part_bytes: u64,
    /// The merge.
    pub merge: MergeReport,
    /// Degenerate triangles of the mesh (kept, as the bake in memory keeps them).
    pub degenerate_triangles: usize,
    /// The parts a killed earlier run of the same bake had finished, taken as they were.
    pub resumed_parts: Vec<u32>,
    /// Part folders of earlier bakes into the same output with another plan, removed.
    pub removed_folders: Vec<PathBuf>,
    /// Part folders of bakes into other outputs found beside it, left alone (another bake
    /// may be running into them; [`remove_leftovers`] removes an output's).
    pub other_folders: Vec<PathBuf>,
}

/// Bakes `mesh` (read from `mesh_path`, which the plan names) into `output` within `budget`
/// bytes of memory: enough parts that each one's estimated peak fits in the budget beside the
/// mesh and the lists that bin its triangles to the parts, each baked in this
/// process into a file in a folder beside `output` (`.svo-parts.NAME.HASH`, the plan's hash),
/// then merged; the folder is removed at the end. A run killed before then leaves it: the
/// next run of the same bake takes the parts it finished, checked whole, and bakes the rest;
/// one with another plan removes it. The same bytes as the bake in memory written in `format`
/// ([`MergeFormat::Dag`]: as [`crate::io::write_dag_to`] writes it); `build` is what the file
/// records of the bake (`opts.max_memory` is not used). `progress` receives [`Phase::Part`] as each part ends and [`Phase::Merge`] around
/// the merge.
#[allow(clippy::too_many_arguments)]
pub fn bake_within(
    mesh: &Mesh,
    mesh_path: &Path,
    opts: &BakeOptions,
    budget: u64,
    build: &BuildInfo,
    output: &Path,
    format: MergeFormat,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<PartsReport, PartsError> {
    // The budget is the limit now: the whole bake's estimate is not held against it.
    let opts = BakeOptions {
        max_memory: None,
        ..opts.clone()
    };
    // What the merge would refuse, refused before the first part.
    let dag = dag_values(format, opts.depth, makes_node_attributes(&opts))?;
    let plan = plan_for_budget(mesh, mesh_path, &opts, (budget, dag), build)?;
    let p = bake_planned(mesh, &plan, output, format, progress)?;
    Ok(PartsReport {
        plan,
        part_seconds: p.part_seconds,
        part_bytes: p.part_bytes,
        merge: p.merge,
        degenerate_triangles: p.degenerate,
        resumed_parts: p.resumed,
        removed_folders: p.removed,
        other_folders: p.others,
    })
}

/// The plan of `mesh`'s bake for a memory budget: enough parts that each one's peak for the
/// most leaves it can make, with the setup of its own triangles, fits in `budget` bytes beside
/// the mesh and the lists that bin its triangles to the parts, and that none can make more
/// than 2^31 leaves (`dag`: the parts are for a DAG, as [`plan_bake`] takes it).
pub(crate) fn plan_for_budget(
    mesh: &Mesh,
    mesh_path: &Path,
    opts: &BakeOptions,
    (budget, dag): (u64, Option<DagValues>),
    build: &BuildInfo,
) -> Result<BakePlan, PartsError> {
    let est = estimate_bake(mesh, opts)?;
    // The mesh (24 bytes a vertex, 12 a triangle), its spatial order and the parts' lists
    // (a triangle in about two parts' lists: 12 bytes).
    let fixed = mesh.positions.len() as f64 * 24.0 + mesh.triangles.len() as f64 * 24.0;
    let room = budget as f64 - fixed;
    const GIB: f64 = (1u64 << 30) as f64;
    if room < budget as f64 / 4.0 {
        return Err(PartsError::BudgetTooSmall {
            mesh_gib: fixed / GIB,
            budget_gib: budget as f64 / GIB,
        });
    }
    // Enough parts for the budget, and at least what a plan needs.
    let least = least_parts(est.max_leaves);
    if least > f64::from(MAX_PARTS) {
        return Err(PartsError::TooManyParts {
            depth: opts.depth,
            leaves: est.max_leaves,
        });
    }
    // The inner nodes' values and their level order, beside the records.
    let per_leaf = BYTES_PER_LEAF
        + if opts.node_attributes {
            NODE_BYTES_PER_LEAF
        } else {
            0.0
        };
    let mut parts = (est.max_leaves * per_leaf / room)
        .max(least)
        .ceil()
        .max(1.0) as u32;
    let mut fewer: Option<(f64, BakePlan)> = None;
    loop {
        let plan = plan_bake(
            mesh,
            mesh_path,
            0,
            opts,
            (parts.min(MAX_PARTS), dag),
            build.clone(),
        )?;
        let largest = plan
            .parts
            .iter()
            .zip(touched_counts(mesh, &plan))
            .map(|(p, t)| p.max_leaves * per_leaf + t as f64 * BYTES_PER_TRIANGLE)
            .fold(0.0, f64::max);
        let fits = largest <= room && plan.largest_part_leaves() <= PART_LEAVES;
        if fits || parts >= MAX_PARTS {
            return Ok(plan);
        }
        // A subtree larger than a part's share cannot be split: more parts stop helping.
        if let Some((before, plan)) = fewer.take_if(|(before, _)| largest >= 0.95 * *before) {
            let _ = before;
            return Ok(plan);
        }
        fewer = Some((largest, plan));
        parts = parts.saturating_mul(2);
    }
}

/// Refuses a bake whose part files and output (both on disk before the part files are
/// removed) would not fit in the space free in `dir`, by the plan's estimate of the leaves:
/// the nodes (about 3 bytes a leaf), the normals and contours, and the material channels
/// where the mesh has more than one material or a texture (else they are constants in the
/// header); the parts without their leaves' channels where the plan keeps none. A DAG's
/// file, its shared subtrees unknown before the merge, is not counted (the merge reports a
/// full disk as it writes, and the parts stay for the next run). Where the free space is
/// unknown, nothing is refused.
fn check_disk(mesh: &Mesh, plan: &BakePlan, dir: &Path, dag: bool) -> Result<(), PartsError> {
    use crate::octree::ChannelKind;
    let varied = mesh.materials.len() > 1 || !mesh.textures.is_empty();
    let channels: f64 = plan
        .channels
        .split(',')
        .filter_map(|c| c.parse::<ChannelKind>().ok())
        .filter(|k| varied || matches!(k, ChannelKind::Normal | ChannelKind::Contour))
        .map(|k| k.element_size() as f64)
        .sum();
    let parts = 3.0 + if plan.leaf_arrays { channels } else { 0.0 };
    let file = if dag { 0.0 } else { 3.0 + channels };
    let need = plan.estimated_leaves * (parts + file);
    #[cfg(unix)]
    let free = rustix::fs::statvfs(dir)
        .ok()
        .map(|s| s.f_bavail as f64 * s.f_frsize as f64);
    #[cfg(not(unix))]
    let free: Option<f64> = None;
    match free {
        Some(free) if need > free => {
            const GB: f64 = 1e9;
            Err(PartsError::NoDiskSpace {
                depth: plan.depth,
                leaves: plan.estimated_leaves,
                need_gb: need / GB,
                free_gb: free / GB,
                dir: dir.display().to_string(),
            })
        }
        _ => Ok(()),
    }
}

/// What [`bake_planned`] did.
pub(crate) struct Planned {
    pub(crate) merge: MergeReport,
    pub(crate) part_seconds: Vec<f64>,
    pub(crate) part_bytes: u64,
    pub(crate) degenerate: usize,
    pub(crate) resumed: Vec<u32>,
    pub(crate) removed: Vec<PathBuf>,
    pub(crate) others: Vec<PathBuf>,
}

/// The name every part folder of a bake into `output` starts with: `.svo-parts.NAME.`, beside
/// it.
fn folder_prefix(output: &Path) -> String {
    let name = output
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    format!(".svo-parts.{name}.")
}

/// The folder `output`'s parts of the plan with hash `plan_hash` are baked into:
/// `.svo-parts.NAME.HASH` beside it, so that a later run of the same bake (the same mesh,
/// options and parts) finds the parts a killed one finished.
fn parts_folder(dir: &Path, output: &Path, plan_hash: u64) -> PathBuf {
    dir.join(format!("{}{plan_hash:016x}", folder_prefix(output)))
}

/// Removes what interrupted bakes into `output` left beside it: the part folders of bakes
/// within a memory budget (`.svo-parts.NAME.*`) and unfinished outputs (`.NAME.XXXXXX.tmp`, which
/// an atomic write renames over `output` only once whole). For a program that stops a bake on
/// a signal; returns what it removed.
pub fn remove_leftovers(output: &Path) -> Vec<PathBuf> {
    let prefix = folder_prefix(output);
    let mut removed = remove_stale(output);
    let Ok(entries) = std::fs::read_dir(parent_dir(output)) else {
        return removed;
    };
    for e in entries.flatten() {
        let path = e.path();
        // A part may be renamed into the folder while it goes: try again.
        if e.file_name().to_string_lossy().starts_with(&prefix)
            && (0..8).any(|_| std::fs::remove_dir_all(&path).is_ok() || !path.exists())
        {
            removed.push(path);
        }
    }
    removed
}

/// Removes a folder when dropped (the part files, once merged or after an error).
struct RemoveOnDrop(PathBuf);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Prepares `output`'s part folder for `plan`: removes the folders of other bakes into
/// `output` (an earlier run with other options or another mesh) and, inside its own, every
/// file that is not a complete, undamaged part of this plan. Returns the folder, the parts
/// it already holds, the folders removed and the part folders of other outputs found beside
/// it (reported, not touched: another bake may be running into them).
fn prepare_folder(output: &Path, plan: &BakePlan, hash: u64) -> Result<Folder, PartsError> {
    let dir = parent_dir(output);
    let folder = parts_folder(dir, output, hash);
    let mine = folder_prefix(output);
    let (mut removed, mut others) = (Vec::new(), Vec::new());
    for e in std::fs::read_dir(dir)
        .map_err(|e| PartsError::io(dir, e))?
        .flatten()
    {
        let (name, path) = (e.file_name().to_string_lossy().into_owned(), e.path());
        if path == folder || !name.starts_with(".svo-parts.") {
            continue;
        }
        if name.starts_with(&mine) {
            std::fs::remove_dir_all(&path).map_err(|e| PartsError::io(&path, e))?;
            removed.push(path);
        } else {
            others.push(path);
        }
    }
    std::fs::create_dir_all(&folder).map_err(|e| PartsError::io(&folder, e))?;
    let count = plan.part_count();
    let mut resumed = Vec::new();
    for e in std::fs::read_dir(&folder)
        .map_err(|e| PartsError::io(&folder, e))?
        .flatten()
    {
        let (name, path) = (e.file_name().to_string_lossy().into_owned(), e.path());
        let index = name
            .strip_suffix(".svopart")
            .and_then(|n| n.parse::<u32>().ok())
            .filter(|&i| i < count && name == part_name(i));
        match index {
            Some(i) if is_complete_part(&path, hash, i) => resumed.push(i),
            _ => std::fs::remove_file(&path).map_err(|e| PartsError::io(&path, e))?,
        }
    }
    resumed.sort_unstable();
    others.sort();
    Ok(Folder {
        path: folder,
        resumed,
        removed,
        others,
    })
}

/// A bake's part folder, ready ([`prepare_folder`]).
struct Folder {
    path: PathBuf,
    resumed: Vec<u32>,
    removed: Vec<PathBuf>,
    others: Vec<PathBuf>,
}

/// Part `i`'s file name inside the part folder.
fn part_name(i: u32) -> String {
    format!("{i:05}.svopart")
}

/// Bakes `plan` in this process into `output`: each part into a file in the part folder
/// beside `output` ([`parts_folder`]; the parts a killed run of the same bake finished are
/// kept and not baked again), then the merge; the folder is removed at the end, whatever
/// happens, except when the process is killed. `progress` receives [`Phase::Part`] as each
/// part ends and [`Phase::Merge`] around the merge.
pub(crate) fn bake_planned(
    mesh: &Mesh,
    plan: &BakePlan,
    output: &Path,
    format: MergeFormat,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<Planned, PartsError> {
    let dag = matches!(format, MergeFormat::Dag | MergeFormat::DagWith(_));
    check_disk(mesh, plan, parent_dir(output), dag)?;
    let hash = xxhash_rust::xxh3::xxh3_64(&plan_to_bytes(plan));
    let Folder {
        path,
        resumed,
        removed,
        others,
    } = prepare_folder(output, plan, hash)?;
    let guard = RemoveOnDrop(path);
    let path_of = |i: u32| guard.0.join(part_name(i));
    let count = plan.part_count();
    let mut seconds = Vec::with_capacity(count as usize);
    let mut bytes: u64 = resumed
        .iter()
        .filter_map(|&i| std::fs::metadata(path_of(i)).ok())
        .map(|m| m.len())
        .sum();
    let mut done = resumed.len() as u32;
    let mut t = std::time::Instant::now();
    progress(Phase::Part, f64::from(done) / f64::from(count));
    let todo = (0..count).filter(|i| resumed.binary_search(i).is_err());
    let degenerate = bake_parts(mesh, plan, hash, todo, &mut |i, part| {
        bytes += write_part(&part, &path_of(i))?;
        drop(part);
        seconds.push(t.elapsed().as_secs_f64());
        t = std::time::Instant::now();
        done += 1;
        progress(Phase::Part, f64::from(done) / f64::from(count));
        Ok(())
    })?;
    progress(Phase::Merge, 0.0);
    let merge = merge_with(plan, hash, &path_of, output, format)?;
    progress(Phase::Merge, 1.0);
    Ok(Planned {
        merge,
        part_seconds: seconds,
        part_bytes: bytes,
        degenerate,
        resumed,
        removed,
        others,
    })
}
