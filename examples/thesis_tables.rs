//! Reproduces the thesis's two build-time tables (strategies x depths 1-8 on the Stanford
//! bunny) beside the thesis's own figures, with the leaves each strategy makes, its false
//! positives and negatives against the exact set, and bytes per leaf. Prints Markdown.
//!
//! `cargo run --release -p svo-examples --example thesis_tables -- [mesh] [runs] [max_depth]`
// Tables are indexed by strategy and depth together.
#![allow(clippy::needless_range_loop)]

use std::collections::HashSet;
use std::time::Instant;
use svo::format_header::BuildInfo;
use svo::{BakeOptions, Strategy, bake_mesh};

/// The thesis's table (seconds), rows in `Strategy::ALL` order minus `exact`.
const THESIS: [(&str, [f64; 8]); 5] = [
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

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .unwrap_or_else(|| "../shared/models/stanford/stanford-bunny.obj".into());
    let runs: usize = args.next().map_or(Ok(5), |s| s.parse())?;
    let max_depth: u8 = args.next().map_or(Ok(8), |s| s.parse())?;
    let mesh = svo::import::load_mesh(std::path::Path::new(&path))?;
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let threads = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    println!(
        "Mesh `{path}` ({} triangles); {cpu}, {threads} threads; median of {runs} runs per cell;",
        mesh.triangles.len()
    );
    println!(
        "time = full bake in memory (voxelize + attributes + contours), loading and writing excluded.\n"
    );

    let depths: Vec<u8> = (1..=max_depth).collect();
    let mut time = vec![vec![0.0; depths.len()]; Strategy::ALL.len()];
    let mut leaves = vec![vec![0usize; depths.len()]; Strategy::ALL.len()];
    let mut fp = vec![vec![0usize; depths.len()]; Strategy::ALL.len()];
    let mut fnn = vec![vec![0usize; depths.len()]; Strategy::ALL.len()];
    let mut bpl = vec![vec![0.0; depths.len()]; Strategy::ALL.len()];
    for (di, &depth) in depths.iter().enumerate() {
        let exact: HashSet<[u32; 3]> = {
            let (t, _) = bake_mesh(
                &mesh,
                &BakeOptions {
                    depth,
                    ..Default::default()
                },
                &|_, _| {},
            )?;
            t.leaves().map(|l| l.cell.to_array()).collect()
        };
        for (si, &strategy) in Strategy::ALL.iter().enumerate() {
            let opts = BakeOptions {
                depth,
                strategy,
                ..Default::default()
            };
            let mut ts = Vec::new();
            let mut tree = None;
            for _ in 0..runs {
                let t0 = Instant::now();
                let (t, _) = bake_mesh(&mesh, &opts, &|_, _| {})?;
                ts.push(t0.elapsed().as_secs_f64());
                tree = Some(t);
            }
            let tree = tree.expect("at least one run");
            let cells: HashSet<[u32; 3]> = tree.leaves().map(|l| l.cell.to_array()).collect();
            time[si][di] = median(ts);
            leaves[si][di] = cells.len();
            fp[si][di] = cells.difference(&exact).count();
            fnn[si][di] = exact.difference(&cells).count();
            let bytes = svo::format_write::to_bytes(&tree, &BuildInfo::default()).len();
            bpl[si][di] = bytes as f64 / cells.len().max(1) as f64;
        }
    }
    let header = |title: &str| {
        print!("| {title} |");
        for d in &depths {
            print!(" {d} |");
        }
        print!("\n|---|");
        for _ in &depths {
            print!("---:|");
        }
        println!();
    };
    let rows = [(0usize, 0usize), (1, 1), (2, 2), (3, 3), (4, 4)];
    println!("### Build time: thesis (s) / ours (ms) / speed-up\n");
    header("strategy (thesis row)");
    for &(si, ti) in &rows {
        let s = Strategy::ALL[si];
        print!("| `{s}` ({}) |", THESIS[ti].0);
        for di in 0..depths.len() {
            let th = THESIS[ti].1[di];
            print!(
                " {th} s / {:.2} ms / {:.0}x |",
                time[si][di] * 1e3,
                th / time[si][di]
            );
        }
        println!();
    }
    println!(
        "\nThe last row compares our default `exact` with the thesis's fastest variant, SAT at the leaves plus the vertex-inside shortcut (its second table).\n"
    );
    println!("### Leaves, and false positives / negatives against the exact set\n");
    header("strategy");
    for (si, s) in Strategy::ALL.iter().enumerate() {
        print!("| `{s}` |");
        for di in 0..depths.len() {
            print!(" {} (+{} / -{}) |", leaves[si][di], fp[si][di], fnn[si][di]);
        }
        println!();
    }
    println!("\n### File bytes per leaf (`.svo`, all channels; constants in the header)\n");
    header("strategy");
    for (si, s) in Strategy::ALL.iter().enumerate() {
        print!("| `{s}` |");
        for di in 0..depths.len() {
            print!(" {:.2} |", bpl[si][di]);
        }
        println!();
    }
    Ok(())
}
