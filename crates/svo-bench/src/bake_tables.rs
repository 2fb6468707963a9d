//! The bake against the thesis: every strategy at every depth on one mesh, with the median
//! in-memory bake time, leaves, false positives and negatives against the exact set, file
//! bytes per leaf and peak memory; and the whole `svo-bake` pipeline per phase on real files.

use crate::peak_memory;
use crate::report::{Report, f, median, ms};
use std::path::Path;
use std::time::Instant;
use svo::io::BuildInfo;
use svo::mesh::Mesh;
use svo::{BakeOptions, Strategy, bake_mesh};
use svo_bake::job::BakeJob;
use svo_bake::report::BakeReport;

/// The thesis's build times (seconds, depths 1-8), rows in [`Strategy::ALL`] order; the
/// last is its second table (SAT at the leaves plus the vertex-inside shortcut), beside our
/// default `exact`.
pub const THESIS: [(&str, [f64; 8]); 5] = [
    (
        "AABB + Plane",
        [3.071, 1.216, 1.185, 1.249, 1.647, 3.335, 17.35, 54.17],
    ),
    (
        "AABB + Plane + SAT",
        [23.81, 36.13, 45.40, 54.40, 66.21, 95.46, 197.3, 472.2],
    ),
    (
        "SAT (leaf level)",
        [36.25, 14.83, 9.539, 9.960, 13.85, 78.06, 191.2, 427.7],
    ),
    (
        "Plane + SAT (leaf level)",
        [34.60, 14.13, 8.870, 9.593, 14.52, 80.69, 204.7, 493.1],
    ),
    (
        "SAT (leaf) + vertex inside",
        [1.813, 1.038, 0.859, 1.394, 2.216, 11.71, 61.2, 256.6],
    ),
];

/// One strategy at one depth.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BakeCell {
    /// Median seconds of the in-memory bake.
    pub seconds: f64,
    /// Every run's seconds.
    pub runs: Vec<f64>,
    /// Leaves made.
    pub leaves: usize,
    /// Cells no triangle touches (against the exact set).
    pub false_pos: usize,
    /// Touched cells missing.
    pub false_neg: usize,
    /// `.svo` file bytes per leaf.
    pub bytes_per_leaf: f64,
    /// Peak heap bytes of the first run beyond those live before it.
    pub peak_bytes: Option<u64>,
}

/// Strategies x depths.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BakeTables {
    /// Depths measured (from 1).
    pub depths: Vec<u8>,
    /// `cells[strategy][depth index]`, strategies in [`Strategy::ALL`] order.
    pub cells: Vec<Vec<BakeCell>>,
}

impl BakeTables {
    /// The exact default's cell at `depth`.
    pub fn exact(&self, depth: u8) -> Option<&BakeCell> {
        let di = self.depths.iter().position(|&d| d == depth)?;
        let si = Strategy::ALL.iter().position(|&s| s == Strategy::Exact)?;
        self.cells.get(si)?.get(di)
    }
}

fn sorted_cells(tree: &svo::Octree) -> Vec<[u32; 3]> {
    let mut v: Vec<[u32; 3]> = tree.leaves().map(|l| l.cell.to_array()).collect();
    v.sort_unstable();
    v
}

/// Cells in `a` but not `b`, and in `b` but not `a` (both sorted).
fn differences(a: &[[u32; 3]], b: &[[u32; 3]]) -> (usize, usize) {
    let (mut i, mut j, mut only_a, mut only_b) = (0, 0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => {
                only_a += 1;
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                only_b += 1;
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
    }
    (only_a + a.len() - i, only_b + b.len() - j)
}

/// Bakes `mesh` with every strategy at depths `1..=max_depth`, `runs(depth)` times each.
pub fn measure(
    mesh: &Mesh,
    max_depth: u8,
    runs: &dyn Fn(u8) -> usize,
    log: &dyn Fn(&str),
) -> anyhow::Result<BakeTables> {
    let depths: Vec<u8> = (1..=max_depth).collect();
    let mut cells = vec![Vec::new(); Strategy::ALL.len()];
    for &depth in &depths {
        log(&format!("bake tables: depth {depth}"));
        let exact = {
            let opts = BakeOptions {
                depth,
                ..Default::default()
            };
            sorted_cells(&bake_mesh(mesh, &opts)?.0)
        };
        for (si, &strategy) in Strategy::ALL.iter().enumerate() {
            let opts = BakeOptions {
                depth,
                strategy,
                ..Default::default()
            };
            let mut times = Vec::new();
            let mut tree = None;
            let mut peak = None;
            for r in 0..runs(depth).max(1) {
                let t0 = Instant::now();
                let (res, grew) = peak_memory::measure(|| bake_mesh(mesh, &opts));
                times.push(t0.elapsed().as_secs_f64());
                if r == 0 {
                    peak = grew;
                }
                tree = Some(res?.0);
            }
            let tree = tree.expect("at least one run");
            let got = sorted_cells(&tree);
            let (fp, fneg) = differences(&got, &exact);
            let bytes = svo::io::to_bytes(&tree, &BuildInfo::default()).len();
            cells[si].push(BakeCell {
                seconds: median(&times),
                runs: times,
                leaves: got.len(),
                false_pos: fp,
                false_neg: fneg,
                bytes_per_leaf: bytes as f64 / got.len().max(1) as f64,
                peak_bytes: peak,
            });
        }
    }
    Ok(BakeTables { depths, cells })
}

fn mib(b: Option<u64>) -> String {
    b.map_or_else(|| "n/a".into(), |b| f(b as f64 / f64::from(1u32 << 20), 1))
}

/// Writes the thesis comparison and the per-strategy tables.
pub fn write(r: &mut Report, t: &BakeTables, runs_note: &str, plot: Option<&str>) {
    let mut header: Vec<String> = vec!["strategy (thesis row)".into()];
    header.extend(t.depths.iter().map(u8::to_string));
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    r.heading(3, "Build time: thesis (s) / ours (ms) / speed-up");
    r.para(&format!(
        "Ours: the whole bake in memory (voxelization, clipped-area attributes, contours), \
         loading and writing excluded, {runs_note}. The thesis's figures are its octree build on \
         its own machine (2015), so the speed-up mixes algorithm, language and hardware; the leaf \
         counts below are the like-for-like part. Depths beyond 8 have no thesis figure."
    ));
    let mut rows = Vec::new();
    for (si, s) in Strategy::ALL.iter().enumerate() {
        let mut row = vec![format!("`{s}` ({})", THESIS[si].0)];
        for (di, &d) in t.depths.iter().enumerate() {
            let ours = t.cells[si][di].seconds;
            row.push(match THESIS[si].1.get(usize::from(d) - 1) {
                Some(&th) => format!("{th} s / {:.2} ms / {:.0}x", ours * 1e3, th / ours),
                None => format!("{:.2} ms", ours * 1e3),
            });
        }
        rows.push(row);
    }
    r.table(&header, &rows);
    r.para(
        "The last row sets our default `exact` beside the thesis's fastest variant (SAT at the \
         leaves plus the vertex-inside shortcut, its second table).",
    );
    if let Some(p) = plot {
        r.image("bake time against depth per strategy", p);
    }
    r.heading(
        3,
        "Leaves, and false positives / negatives against the exact set",
    );
    // One row per strategy, one cell per depth.
    let per_strategy = |cell: &dyn Fn(&BakeCell) -> String| -> Vec<Vec<String>> {
        Strategy::ALL
            .iter()
            .zip(&t.cells)
            .map(|(s, cells)| {
                let mut row = vec![format!("`{s}`")];
                row.extend(cells.iter().map(cell));
                row
            })
            .collect()
    };
    let mut h2 = header.clone();
    h2[0] = "strategy";
    r.table(
        &h2,
        &per_strategy(&|c| format!("{} (+{} / -{})", c.leaves, c.false_pos, c.false_neg)),
    );
    r.heading(
        3,
        "File bytes per leaf (`.svo`, all channels; constants in the header)",
    );
    r.table(&h2, &per_strategy(&|c| f(c.bytes_per_leaf, 2)));
    r.heading(
        3,
        "Peak heap memory of the bake (MiB live at once beyond what was live before it)",
    );
    r.table(&h2, &per_strategy(&|c| mib(c.peak_bytes)));
}

/// One `svo-bake` pipeline measurement.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PipelineRow {
    /// What was baked.
    pub label: String,
    /// Threads.
    pub threads: usize,
    /// The run with the median total time.
    pub report: BakeReport,
    /// Every run's total seconds.
    pub totals: Vec<f64>,
    /// Peak heap bytes of the first run (loading included) beyond those live before it.
    pub peak_bytes: Option<u64>,
}

/// Runs the `svo-bake` pipeline (load, bake, atomic write with fsync) `runs` times.
pub fn pipeline(
    label: &str,
    input: &Path,
    depth: u8,
    threads: usize,
    runs: usize,
    dir: &Path,
) -> anyhow::Result<PipelineRow> {
    let job = BakeJob {
        input: input.to_path_buf(),
        output: dir.join("out.svo"),
        options: BakeOptions {
            depth,
            ..Default::default()
        },
        threads: Some(threads),
        given: Default::default(),
        memory: None,
        layout: Default::default(),
        values: Default::default(),
    };
    let mut reports = Vec::new();
    let mut peak = None;
    for i in 0..runs.max(1) {
        let (rep, grew) = peak_memory::measure(|| svo_bake::job::bake_file(&job));
        if i == 0 {
            peak = grew;
        }
        reports.push(rep?);
    }
    let totals: Vec<f64> = reports.iter().map(|r| r.total_s).collect();
    let m = median(&totals);
    let report = reports
        .into_iter()
        .find(|r| r.total_s == m)
        .expect("the median is one of the runs");
    Ok(PipelineRow {
        label: label.into(),
        threads,
        report,
        totals,
        peak_bytes: peak,
    })
}

/// Writes the per-phase table.
pub fn write_pipeline(r: &mut Report, rows: &[PipelineRow]) {
    let table: Vec<Vec<String>> = rows
        .iter()
        .map(|p| {
            let rep = &p.report;
            let b = rep.bake.clone().unwrap_or_default();
            let bake = b.voxelize_s + b.attributes_s + b.contours_s;
            vec![
                p.label.clone(),
                p.threads.to_string(),
                rep.depth.to_string(),
                format!("{} ({} tris)", rep.leaves, b.triangles),
                ms(rep.load_s),
                ms(b.voxelize_s),
                ms(b.attributes_s),
                ms(b.contours_s),
                ms(rep.write_s),
                format!("**{}**", ms(bake)),
                ms(rep.total_s),
                f(rep.file_bytes as f64 / rep.leaves.max(1) as f64, 2),
                mib(p.peak_bytes),
                p.totals.len().to_string(),
            ]
        })
        .collect();
    r.table(
        &[
            "input",
            "threads",
            "depth",
            "leaves",
            "load",
            "voxelize",
            "attributes",
            "contours",
            "write",
            "bake",
            "total",
            "bytes/leaf",
            "peak MiB",
            "runs",
        ],
        &table,
    );
}

#[cfg(test)]
mod tests {
    #[test]
    fn differences_count_both_sides() {
        let a = [[0, 0, 0], [0, 0, 2], [1, 0, 0]];
        let b = [[0, 0, 1], [0, 0, 2], [2, 0, 0], [3, 0, 0]];
        assert_eq!(super::differences(&a, &b), (2, 3));
        assert_eq!(super::differences(&a, &a), (0, 0));
        assert_eq!(super::differences(&[], &b), (0, 4));
    }
}
