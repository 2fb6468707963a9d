//! [`BakeReport`]: what a bake did, for the summary `svo-bake` prints and its `--json`.

use crate::job::OutputFormat;
use serde::Serialize;
use std::fmt;
use svo::bake::BakeStats;
use svo::bake::parts::MergeReport;

/// What a bake in parts did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PartsReport {
    /// The memory budget, bytes.
    pub budget: u64,
    /// Whether the bake chose parts itself because the whole bake would not fit.
    pub automatic: bool,
    /// Parts.
    pub parts: u32,
    /// The level of the octree the parts split at.
    pub level: u8,
    /// Seconds each part took to bake (writing its file included), in part order.
    pub part_seconds: Vec<f64>,
    /// Bytes of all part files together.
    pub part_bytes: u64,
    /// Parts an interrupted earlier run of the same bake had finished, taken as they were.
    pub resumed_parts: u32,
    /// Part folders of earlier bakes into the same output with other settings, removed.
    pub removed_folders: Vec<String>,
    /// Part folders of bakes into other outputs beside this one, left alone.
    pub other_folders: Vec<String>,
    /// The merge.
    pub merge: MergeReport,
    /// The process's peak resident set at the end (Linux `VmHWM`), bytes, if known.
    pub peak_resident: Option<u64>,
}

/// What a bake did, for the summary and `--json`.
#[derive(Clone, Debug, Serialize)]
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

/// Seconds as milliseconds below 10 s, else as seconds.
fn ms(s: f64) -> String {
    if s < 10.0 {
        format!("{:.1} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

const GIB: f64 = (1u64 << 30) as f64;

impl BakeReport {
    /// The triangles, the tree and, for a solid bake, its interior.
    fn write_tree(&self, f: &mut fmt::Formatter<'_>, b: &BakeStats) -> fmt::Result {
        writeln!(
            f,
            "  triangles   {} ({} degenerate, kept)",
            b.triangles, b.degenerate_triangles
        )?;
        writeln!(
            f,
            "  tree        {} nodes, {} leaves (estimated {:.0}, at most {:.0}), {} triangle/leaf pairs",
            self.nodes, self.leaves, b.estimated_leaves, b.max_leaves, b.leaf_triangle_pairs
        )?;
        if let Some(mode) = &b.solid {
            writeln!(
                f,
                "  solid       {} interior leaves ({mode} fill; {} surface leaves)",
                b.interior_leaves,
                self.leaves - b.interior_leaves.min(self.leaves)
            )?;
        }
        Ok(())
    }

    /// The accuracy the bake buys: the strategy, the cell, the contours.
    fn write_accuracy(&self, f: &mut fmt::Formatter<'_>, b: &BakeStats) -> fmt::Result {
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
        Ok(())
    }

    /// The channels stored and where the time went.
    fn write_channels_and_time(&self, f: &mut fmt::Formatter<'_>, b: &BakeStats) -> fmt::Result {
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
            "  time        load {}, voxelize {}, attributes {}, contours {}{}{}, write {}, total {}",
            ms(self.load_s),
            ms(b.voxelize_s),
            ms(b.attributes_s),
            ms(b.contours_s),
            if b.node_attributes_s > 0.0 {
                format!(", inner nodes {}", ms(b.node_attributes_s))
            } else {
                String::new()
            },
            if b.solid.is_some() {
                format!(", solid fill {}", ms(b.solid_s))
            } else {
                String::new()
            },
            ms(self.write_s),
            ms(self.total_s)
        )
    }

    /// The parts of a bake in parts: their times, files and the merge.
    fn write_parts(f: &mut fmt::Formatter<'_>, p: &PartsReport) -> fmt::Result {
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
        if p.resumed_parts > 0 {
            writeln!(
                f,
                "  resumed     {} of the {} parts from an interrupted run of this bake (checked whole)",
                p.resumed_parts, p.parts
            )?;
        }
        for d in &p.removed_folders {
            writeln!(
                f,
                "  removed     {d} (the parts of an earlier bake into this output)"
            )?;
        }
        for d in &p.other_folders {
            writeln!(
                f,
                "  left alone  {d} (the parts of a bake into another output: removed when that output is baked again or its bake is stopped)"
            )?;
        }
        Ok(())
    }
}

impl fmt::Display for BakeReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} -> {} ({:?}, depth {}, {} threads)",
            self.input, self.output, self.format, self.depth, self.threads
        )?;
        match &self.bake {
            Some(b) => {
                self.write_tree(f, b)?;
                self.write_accuracy(f, b)?;
                self.write_channels_and_time(f, b)?;
            }
            None => {
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
        }
        if let Some(p) = &self.parts {
            Self::write_parts(f, p)?;
        }
        let per_leaf = if self.leaves > 0 {
            self.file_bytes as f64 / self.leaves as f64
        } else {
            0.0
        };
        write!(
            f,
            "  output      {} bytes, {:.2} bytes per leaf",
            self.file_bytes, per_leaf
        )
    }
}
