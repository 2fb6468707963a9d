//! A bake in bounded memory on one machine: the plan's parts baked one after another into
//! part files beside the output, then merged.
//! Only the mesh, the lists that bin its triangles to the parts (one pass) and one part with
//! the setup of its own triangles are in memory at a time; the number of parts comes from
//! the memory budget, the bake's estimate and the parts' triangle counts.

use crate::bake::bake_mesh::{BakeOptions, Phase, estimate_bake};
use crate::bake::estimate::{BYTES_PER_LEAF, BYTES_PER_TRIANGLE};
use crate::bake::parts::merge::{MergeFormat, MergeReport, merge_with};
use crate::bake::parts::part::{bake_parts, touched_counts, write_part};
use crate::bake::parts::plan::{
    BakePlan, MAX_PARTS, PartsError, least_parts, plan_bake, plan_to_bytes,
};
use crate::io::header::BuildInfo;
use crate::mesh::triangle_mesh::Mesh;
use std::path::Path;

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
}

/// Bakes `mesh` (read from `mesh_path`, which the plan names) into `output` within `budget`
/// bytes of memory: enough parts that each one's estimated peak fits in the budget beside the
/// mesh and the lists that bin its triangles to the parts, each baked in this
/// process into a file in a temporary folder beside `output` and removed at the end, then
/// merged. The same bytes as the bake in memory; `build` is what the file records of the
/// bake (`opts.max_memory` is not used). `progress` receives [`Phase::Part`] as each part ends and [`Phase::Merge`] around
/// the merge.
pub fn bake_within(
    mesh: &Mesh,
    mesh_path: &Path,
    opts: &BakeOptions,
    budget: u64,
    build: &BuildInfo,
    output: &Path,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<PartsReport, PartsError> {
    // The budget is the limit now: the whole bake's estimate is not held against it.
    let opts = BakeOptions {
        max_memory: None,
        ..opts.clone()
    };
    let plan = plan_for_budget(mesh, mesh_path, &opts, budget, build)?;
    let (merge, part_seconds, part_bytes, degenerate_triangles) =
        bake_planned(mesh, &plan, output, progress)?;
    Ok(PartsReport {
        plan,
        part_seconds,
        part_bytes,
        merge,
        degenerate_triangles,
    })
}

/// The plan of `mesh`'s bake for a memory budget: enough parts that each one's estimated
/// peak (its leaves and the setup of its own triangles) fits in `budget` bytes beside the
/// mesh and the lists that bin its triangles to the parts, and that each holds about 2^30
/// leaves at most.
pub(crate) fn plan_for_budget(
    mesh: &Mesh,
    mesh_path: &Path,
    opts: &BakeOptions,
    budget: u64,
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
    let least = least_parts(est.leaves);
    if least > f64::from(MAX_PARTS) {
        return Err(PartsError::TooManyParts {
            depth: opts.depth,
            leaves: est.leaves,
        });
    }
    let mut parts = (est.leaves * BYTES_PER_LEAF / room)
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
            parts.min(MAX_PARTS),
            build.clone(),
        )?;
        let largest = plan
            .parts
            .iter()
            .zip(touched_counts(mesh, &plan))
            .map(|(p, t)| p.estimated_leaves * BYTES_PER_LEAF + t as f64 * BYTES_PER_TRIANGLE)
            .fold(0.0, f64::max);
        if largest <= room || parts >= MAX_PARTS {
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
/// header). Where the free space is unknown, nothing is refused.
fn check_disk(mesh: &Mesh, plan: &BakePlan, dir: &Path) -> Result<(), PartsError> {
    use crate::octree::ChannelKind;
    let varied = mesh.materials.len() > 1 || !mesh.textures.is_empty();
    let channels: f64 = plan
        .channels
        .split(',')
        .filter_map(|c| c.parse::<ChannelKind>().ok())
        .filter(|k| varied || matches!(k, ChannelKind::Normal | ChannelKind::Contour))
        .map(|k| k.element_size() as f64)
        .sum();
    let need = 2.0 * plan.estimated_leaves * (3.0 + channels);
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

/// Bakes `plan` in this process into `output`: each part into a file in a temporary folder
/// beside `output` (removed at the end, whatever happens), then the merge. `progress`
/// receives [`Phase::Part`] as each part ends and [`Phase::Merge`] around the merge.
/// Returns the merge's report, each part's seconds, the part files' bytes and the number of
/// degenerate triangles.
pub(crate) fn bake_planned(
    mesh: &Mesh,
    plan: &BakePlan,
    output: &Path,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<(MergeReport, Vec<f64>, u64, usize), PartsError> {
    let dir = match output.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    check_disk(mesh, plan, dir)?;
    let tmp = tempfile::Builder::new()
        .prefix(".svo-parts.")
        .tempdir_in(dir)
        .map_err(|e| PartsError::io(dir, e))?;
    let hash = xxhash_rust::xxh3::xxh3_64(&plan_to_bytes(plan));
    let path_of = |i: u32| tmp.path().join(format!("{i:05}.svopart"));
    let count = plan.part_count();
    let mut seconds = Vec::with_capacity(count as usize);
    let mut bytes = 0;
    let mut t = std::time::Instant::now();
    progress(Phase::Part, 0.0);
    let degenerate = bake_parts(mesh, plan, hash, 0..count, &mut |i, part| {
        bytes += write_part(&part, &path_of(i))?;
        drop(part);
        seconds.push(t.elapsed().as_secs_f64());
        t = std::time::Instant::now();
        progress(Phase::Part, f64::from(i + 1) / f64::from(count));
        Ok(())
    })?;
    progress(Phase::Merge, 0.0);
    let merged = merge_with(plan, hash, &path_of, output, MergeFormat::Auto)?;
    progress(Phase::Merge, 1.0);
    Ok((merged, seconds, bytes, degenerate))
}
