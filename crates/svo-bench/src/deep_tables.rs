//! Deep trees: bake time and peak heap per leaf at depths 1 to 20 for the three shapes of
//! `crates/svo/tests/it/deep_trees.rs` (a small triangle, a thin sliver, a bundle of long thin
//! triangles), so the claim that time and memory follow the leaves made, and nothing else,
//! is a measured figure.

use crate::peak_memory;
use crate::report::{Report, f, median, ms};
use glam::DVec3;
use std::time::Instant;
use svo::{BakeOptions, Mesh, bake_mesh};

/// One shape at one depth.
#[derive(serde::Serialize)]
pub struct DeepRow {
    /// The shape's name.
    pub shape: &'static str,
    /// Tree depth.
    pub depth: u8,
    /// Leaves made.
    pub leaves: usize,
    /// Inner nodes.
    pub nodes: usize,
    /// Median bake time, seconds.
    pub seconds: f64,
    /// Peak heap of the bake beyond what was live before it, bytes.
    pub peak: Option<u64>,
}

/// `tris` plus a point-sized triangle at each of `(0, 0, 0)` and `(1, 1, 1)`, so the root is
/// the unit cube (as in the test).
fn anchored(tris: &[[DVec3; 3]]) -> Mesh {
    let mut positions = vec![DVec3::ZERO; 3];
    positions.extend([DVec3::ONE; 3]);
    let mut triangles = vec![[0, 1, 2], [3, 4, 5]];
    for t in tris {
        let b = positions.len() as u32;
        positions.extend_from_slice(t);
        triangles.push([b, b + 1, b + 2]);
    }
    Mesh::from_triangles(positions, triangles)
}

/// The three shapes.
fn shapes() -> Vec<(&'static str, Mesh)> {
    let a = DVec3::new(0.37, 0.41, 0.53);
    let s = 1.0 / 4096.0;
    let small = anchored(&[[a, a + DVec3::new(s, 0.0, 0.0), a + DVec3::new(0.0, s, s)]]);
    // A sliver 1/64 of the root long and 1e-12 wide.
    let b = DVec3::new(0.3125, 0.41, 0.53);
    let sliver = anchored(&[[
        b,
        b + DVec3::new(1.0 / 64.0, 0.0, 0.0),
        b + DVec3::new(0.5 / 64.0, 1e-12, 0.0),
    ]]);
    // Eight needles 1/64 of the way across the root, 1e-9 wide.
    let fan: Vec<[DVec3; 3]> = (0..8)
        .map(|k| {
            let t = f64::from(k) / 8.0;
            let a = DVec3::new(0.05 + 0.1 * t, 0.1, 0.2 + 0.05 * t);
            let b = a + (DVec3::new(0.9 - 0.1 * t, 0.85, 0.7 - 0.3 * t) - a) / 64.0;
            [a, b, a + DVec3::new(0.0, 1e-9, 0.0)]
        })
        .collect();
    vec![
        ("small triangle", small),
        ("sliver", sliver),
        ("needles", anchored(&fan)),
    ]
}

/// Bakes each shape at depths `1..=max_depth`, `runs(depth)` times each.
pub fn measure(max_depth: u8, runs: fn(u8) -> usize, log: &dyn Fn(&str)) -> Vec<DeepRow> {
    let mut rows = Vec::new();
    for (shape, mesh) in shapes() {
        log(&format!("deep trees: {shape}"));
        for depth in 1..=max_depth {
            let opts = BakeOptions {
                depth,
                ..Default::default()
            };
            let mut times = Vec::new();
            let mut peak = None;
            let mut size = (0, 0);
            for run in 0..runs(depth).max(1) {
                let t0 = Instant::now();
                let (res, p) = peak_memory::measure(|| bake_mesh(&mesh, &opts));
                times.push(t0.elapsed().as_secs_f64());
                let Ok((tree, _)) = res else {
                    break;
                };
                if run == 0 {
                    peak = p;
                    size = (tree.leaf_count as usize, tree.nodes.len());
                }
            }
            rows.push(DeepRow {
                shape,
                depth,
                leaves: size.0,
                nodes: size.1,
                seconds: median(&times),
                peak,
            });
        }
    }
    rows
}

/// The section's table.
pub fn write(r: &mut Report, rows: &[DeepRow], runs_note: &str) {
    r.para(&format!(
        "The three shapes of `crates/svo/tests/it/deep_trees.rs` (root: the unit cube): a \
         triangle with legs of 2^-12, a sliver 1/64 long and 1e-12 wide, and eight needles \
         1/64 long and 1e-9 wide; the whole bake (`bake_mesh`: voxelize, attributes, \
         contours), {runs_note}; peak heap is the most bytes live at once beyond those live \
         before the bake. Per leaf, time and memory settle to constants once the leaves \
         outnumber the fixed costs (thread start, the paths from the root)."
    ));
    let header = [
        "shape",
        "depth",
        "leaves",
        "nodes",
        "bake",
        "ns / leaf",
        "peak heap",
        "bytes / leaf",
    ];
    let t: Vec<Vec<String>> = rows
        .iter()
        .map(|row| {
            let per = |x: f64| {
                if row.leaves > 0 {
                    f(x / row.leaves as f64, 0)
                } else {
                    String::new()
                }
            };
            vec![
                row.shape.to_string(),
                row.depth.to_string(),
                row.leaves.to_string(),
                row.nodes.to_string(),
                ms(row.seconds),
                per(row.seconds * 1e9),
                row.peak
                    .map_or(String::new(), |b| format!("{:.1} KiB", b as f64 / 1024.0)),
                row.peak.map_or(String::new(), |b| per(b as f64)),
            ]
        })
        .collect();
    r.table(&header, &t);
}
