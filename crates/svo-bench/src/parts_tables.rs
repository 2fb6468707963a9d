//! Bakes in parts against the bake in memory: the whole `svo-bake` job (load, bake, write)
//! on real meshes at deep levels, once in memory where it fits and once within a memory
//! budget in parts (`BakeJob::memory`), with the time a leaf, the peak heap beside the
//! budget, the spread of the parts' times, and whether the two files are the same bytes.

use crate::peak_memory;
use crate::report::{Report, f, ms};
use std::path::Path;
use std::time::Instant;
use svo::BakeOptions;
use svo::bake::{BakeJob, GivenOptions, bake_file};

/// One bake.
pub struct PartsRow {
    /// The mesh, as the report names it.
    pub mesh: String,
    /// Tree depth.
    pub depth: u8,
    /// The budget, bytes; `None` for the bake in memory.
    pub budget: Option<u64>,
    /// Leaves.
    pub leaves: usize,
    /// Wall seconds of the whole job.
    pub seconds: f64,
    /// Peak heap beyond what was live before, bytes.
    pub peak: Option<u64>,
    /// Parts and their level.
    pub parts: Option<(u32, u8)>,
    /// The parts' times, seconds (min, median, max).
    pub spread: Option<(f64, f64, f64)>,
    /// The merge's seconds.
    pub merge: Option<f64>,
    /// For a bake in parts beside one in memory: whether the files are the same bytes.
    pub same: Option<bool>,
    /// What went wrong, if the bake failed.
    pub error: Option<String>,
}

/// XXH3-64 of a file's bytes.
fn hash(path: &Path) -> Option<u64> {
    svo::bake::hash_file(path).ok()
}

/// Bakes `mesh` at each `(depth, in memory too, budget)` into files in `dir` (each removed
/// once measured).
pub fn measure(
    name: &str,
    mesh: &Path,
    cases: &[(u8, bool, u64)],
    dir: &Path,
    log: &dyn Fn(&str),
) -> Vec<PartsRow> {
    let mut rows = Vec::new();
    for &(depth, in_memory, budget) in cases {
        let whole = dir.join(format!("whole{depth}.svo"));
        let mut whole_hash = None;
        let mut jobs = Vec::new();
        if in_memory {
            jobs.push(None);
        }
        jobs.push(Some(budget));
        for memory in jobs {
            log(&format!(
                "parts: {name} depth {depth} {}",
                memory.map_or("in memory".to_string(), |b| format!(
                    "within {:.1} GiB",
                    b as f64 / (1u64 << 30) as f64
                ))
            ));
            let out = if memory.is_some() {
                dir.join(format!("parts{depth}.svo"))
            } else {
                whole.clone()
            };
            let job = BakeJob {
                input: mesh.to_path_buf(),
                output: out.clone(),
                options: BakeOptions {
                    depth,
                    ..BakeOptions::default()
                },
                threads: None,
                given: GivenOptions {
                    depth: true,
                    solid: false,
                },
                memory,
            };
            let t = Instant::now();
            let (res, peak) = peak_memory::measure(|| bake_file(&job));
            let seconds = t.elapsed().as_secs_f64();
            let mut row = PartsRow {
                mesh: name.to_string(),
                depth,
                budget: memory,
                leaves: 0,
                seconds,
                peak,
                parts: None,
                spread: None,
                merge: None,
                same: None,
                error: None,
            };
            match res {
                Ok(rep) => {
                    row.leaves = rep.leaves;
                    if let Some(p) = &rep.parts {
                        let mut t = p.part_seconds.clone();
                        t.sort_by(f64::total_cmp);
                        row.parts = Some((p.parts, p.level));
                        row.spread = t
                            .first()
                            .zip(t.last())
                            .map(|(&lo, &hi)| (lo, t[t.len() / 2], hi));
                        row.merge = Some(p.merge.seconds);
                    }
                    if memory.is_none() {
                        whole_hash = hash(&out);
                    } else if whole_hash.is_some() {
                        row.same = Some(hash(&out) == whole_hash);
                    }
                }
                Err(e) => row.error = Some(format!("{e:#}")),
            }
            if memory.is_some() {
                let _ = std::fs::remove_file(&out);
            }
            rows.push(row);
        }
        let _ = std::fs::remove_file(&whole);
    }
    rows
}

/// The section's table.
pub fn write(r: &mut Report, rows: &[PartsRow]) {
    r.para(
        "The whole `svo-bake` job (`bake_file`: load, bake, write the `.svo`) on all threads, \
         once each: in memory, and within a memory budget in parts (`--memory`: each part \
         baked into a file beside the output, then merged; `docs/bake-in-parts.md`). Peak heap \
         is the most bytes live at once beyond those live before the job (the process's \
         resident set is a little more); ns a leaf is the job's wall time over its leaves. \
         Where both ran, the two files were compared byte for byte.",
    );
    let header = [
        "mesh",
        "depth",
        "bake",
        "leaves",
        "time",
        "ns / leaf",
        "peak heap",
        "parts (level)",
        "parts' times (min / median / max)",
        "merge",
        "same bytes",
    ];
    let gib = |b: u64| format!("{:.2} GiB", b as f64 / (1u64 << 30) as f64);
    let t: Vec<Vec<String>> = rows
        .iter()
        .map(|row| {
            let bake = row
                .budget
                .map_or("in memory".to_string(), |b| format!("within {}", gib(b)));
            if let Some(e) = &row.error {
                return vec![
                    row.mesh.clone(),
                    row.depth.to_string(),
                    bake,
                    format!("failed: {e}"),
                ];
            }
            vec![
                row.mesh.clone(),
                row.depth.to_string(),
                bake,
                format!("{:.1} M", row.leaves as f64 / 1e6),
                ms(row.seconds),
                if row.leaves > 0 {
                    f(row.seconds * 1e9 / row.leaves as f64, 0)
                } else {
                    String::new()
                },
                row.peak.map_or(String::new(), gib),
                row.parts
                    .map_or(String::new(), |(n, l)| format!("{n} ({l})")),
                row.spread.map_or(String::new(), |(a, b, c)| {
                    format!("{} / {} / {}", ms(a), ms(b), ms(c))
                }),
                row.merge.map_or(String::new(), ms),
                row.same
                    .map_or(String::new(), |s| if s { "yes" } else { "NO" }.to_string()),
            ]
        })
        .collect();
    r.table(&header, &t);
}
