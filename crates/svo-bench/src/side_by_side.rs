//! Our bake against open3d's voxelizer in one sitting: rounds that alternate open3d's runs
//! (the script kept loaded, [`Open3dServer`]) with ours, so that both tools see the
//! same state of a shared machine. On the 2-core VM the same command's median moves by 1.5x
//! within minutes; figures taken minutes apart can disagree by that much, figures taken in
//! alternation cannot.

use crate::external::Open3dServer;
use crate::report::median;
use std::path::Path;
use std::time::Instant;
use svo::io::{BuildInfo, write_file};
use svo::mesh::Mesh;
use svo::{BakeOptions, bake_mesh};

/// What to measure at one depth.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// Tree depth (grid `2^depth`).
    pub depth: u8,
    /// Rounds (open3d, then ours, in each).
    pub rounds: usize,
    /// Runs per tool in a round (each round's figure is their median).
    pub runs: usize,
}

/// One round's medians, in seconds.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Round {
    /// open3d's voxel set.
    pub open3d: f64,
    /// Our whole in-memory bake.
    pub bake: f64,
    /// Our bake and the `.svo` file written after it (atomically, with its `fsync`), as
    /// `svo-bake` does.
    pub with_file: f64,
}

/// One depth of one mesh, measured in alternation.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SideBySide {
    /// The mesh's label.
    pub label: String,
    /// Tree depth.
    pub depth: u8,
    /// Runs per tool in a round.
    pub runs: usize,
    /// The rounds, in order.
    pub rounds: Vec<Round>,
    /// open3d's voxel count.
    pub open3d_voxels: usize,
    /// Our leaf count.
    pub leaves: usize,
}

impl SideBySide {
    /// The median over the rounds of `f`.
    fn over_rounds(&self, f: fn(&Round) -> f64) -> f64 {
        median(&self.rounds.iter().map(f).collect::<Vec<_>>())
    }

    /// open3d's median over the rounds' medians.
    pub fn open3d_s(&self) -> f64 {
        self.over_rounds(|r| r.open3d)
    }

    /// Our median over the rounds' medians.
    pub fn svo_s(&self) -> f64 {
        self.over_rounds(|r| r.bake)
    }

    /// Our median over the rounds' medians of the bake with the file.
    pub fn with_file_s(&self) -> f64 {
        self.over_rounds(|r| r.with_file)
    }

    /// The rounds' ratios open3d / ours (the in-memory bake): median, lowest, highest.
    pub fn ratios(&self) -> (f64, f64, f64) {
        self.spread(|r| r.open3d / r.bake)
    }

    /// The rounds' ratios open3d / ours with the file written: median, lowest, highest.
    pub fn ratios_with_file(&self) -> (f64, f64, f64) {
        self.spread(|r| r.open3d / r.with_file)
    }

    /// Median, lowest and highest over the rounds of `f`.
    fn spread(&self, f: fn(&Round) -> f64) -> (f64, f64, f64) {
        let r: Vec<f64> = self.rounds.iter().map(f).collect();
        let lo = r.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = r.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (median(&r), lo, hi)
    }
}

/// Measures `mesh` (already loaded as `loaded`) at each planned depth, open3d and ours in
/// alternation. Returns open3d's first line (its version) and one row per depth.
pub fn measure(
    label: &str,
    mesh: &Path,
    loaded: &Mesh,
    plans: &[Plan],
    dir: &Path,
    log: &dyn Fn(&str),
) -> anyhow::Result<(String, Vec<SideBySide>)> {
    let mut server = Open3dServer::start(mesh, dir)?;
    let out = dir.join("side_by_side.svo");
    let mut rows = Vec::new();
    for p in plans {
        log(&format!(
            "open3d side by side: {label} depth {}, {} rounds",
            p.depth, p.rounds
        ));
        let opts = BakeOptions {
            depth: p.depth,
            ..Default::default()
        };
        let mut row = SideBySide {
            label: label.to_string(),
            depth: p.depth,
            runs: p.runs,
            rounds: Vec::with_capacity(p.rounds),
            open3d_voxels: 0,
            leaves: 0,
        };
        // One untimed run of each first: neither tool's first run in a process (page faults
        // of fresh buffers, cold caches) is what the rounds compare.
        server.measure(p.depth, 1)?;
        bake_mesh(loaded, &opts)?;
        for _ in 0..p.rounds {
            let o = server.measure(p.depth, p.runs as u32)?;
            row.open3d_voxels = o.voxels;
            let (mut times, mut with_file) = (Vec::new(), Vec::new());
            for _ in 0..p.runs {
                let t = Instant::now();
                let (tree, _) = bake_mesh(loaded, &opts)?;
                times.push(t.elapsed().as_secs_f64());
                write_file(&tree, &BuildInfo::default(), &out)?;
                with_file.push(t.elapsed().as_secs_f64());
                row.leaves = tree.leaf_count as usize;
            }
            row.rounds.push(Round {
                open3d: o.seconds,
                bake: median(&times),
                with_file: median(&with_file),
            });
        }
        rows.push(row);
    }
    let head = std::mem::take(&mut server.head);
    Ok((version_of(&head), rows))
}

/// "PATH: N triangles, open3d X, T threads" -> "open3d X".
fn version_of(head: &str) -> String {
    head.split(", ")
        .find(|p| p.starts_with("open3d"))
        .unwrap_or("open3d")
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_are_taken_per_round() {
        let row = SideBySide {
            label: "bunny".into(),
            depth: 8,
            runs: 5,
            rounds: [(0.30, 0.05, 0.06), (0.24, 0.06, 0.06), (0.28, 0.04, 0.07)]
                .map(|(open3d, bake, with_file)| Round {
                    open3d,
                    bake,
                    with_file,
                })
                .to_vec(),
            open3d_voxels: 1,
            leaves: 1,
        };
        assert!((row.open3d_s() - 0.28).abs() < 1e-12);
        assert!((row.svo_s() - 0.05).abs() < 1e-12);
        let (mid, lo, hi) = row.ratios();
        assert!((mid - 6.0).abs() < 1e-9 && (lo - 4.0).abs() < 1e-9 && (hi - 7.0).abs() < 1e-9);
        assert!((row.with_file_s() - 0.06).abs() < 1e-12);
        let (mid, lo, hi) = row.ratios_with_file();
        assert!((mid - 4.0).abs() < 1e-9 && (lo - 4.0).abs() < 1e-9 && (hi - 5.0).abs() < 1e-9);
        assert_eq!(
            version_of("/x/bunny.obj: 69451 triangles, open3d 0.20.0, ? threads"),
            "open3d 0.20.0"
        );
    }
}
