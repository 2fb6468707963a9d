//! Bakes in parts against the bake in memory: the whole `svo-bake` job (load, bake, write)
//! on real meshes at deep levels, once in memory where it fits and once within a memory
//! budget in parts (`BakeJob::memory`), with the time a leaf, the peak resident set and the
//! peak heap beside the budget, the spread of the parts' times, and whether the two files are
//! the same bytes. Each bake runs in a child process of its own (this binary again, with
//! [`CHILD_ARG`]), so that the resident set's high-water mark is the bake's alone.

use crate::peak_memory;
use crate::report::{Report, f, ms};
use std::path::Path;
use std::time::Instant;
use svo::BakeOptions;
use svo::dag::DagValues;
use svo_bake::job::{BakeJob, GivenOptions, NodeLayout, bake_file};

/// One bake.
#[derive(serde::Serialize)]
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
    /// The child process's peak resident set (Linux `VmHWM`), bytes.
    pub resident: Option<u64>,
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

/// XXH3-64 of a file's bytes, read a buffer at a time (the files run to gigabytes).
fn hash(path: &Path) -> Option<u64> {
    use std::io::Read;
    let mut file = std::fs::File::open(path).ok()?;
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        match file.read(&mut buf).ok()? {
            0 => return Some(h.digest()),
            n => h.update(&buf[..n]),
        }
    }
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
            let mut row = PartsRow {
                mesh: name.to_string(),
                depth,
                budget: memory,
                leaves: 0,
                seconds: 0.0,
                peak: None,
                resident: None,
                parts: None,
                spread: None,
                merge: None,
                same: None,
                error: None,
            };
            match run_child(mesh, &out, depth, memory, &ChildBake::default()) {
                Ok(c) => {
                    let num = |k: &str| c.get(k).and_then(|v| v.first()).copied();
                    row.seconds = num("seconds").unwrap_or(0.0);
                    row.leaves = num("leaves").unwrap_or(0.0) as usize;
                    row.peak = num("peak_heap").map(|v| v as u64);
                    row.resident = num("peak_resident").map(|v| v as u64);
                    if let (Some(n), Some(l)) = (num("parts"), num("level")) {
                        row.parts = Some((n as u32, l as u8));
                        let mut t = c.get("part_seconds").cloned().unwrap_or_default();
                        t.sort_by(f64::total_cmp);
                        row.spread = t
                            .first()
                            .zip(t.last())
                            .map(|(&lo, &hi)| (lo, t[t.len() / 2], hi));
                        row.merge = num("merge_seconds");
                    }
                    if memory.is_none() {
                        whole_hash = hash(&out);
                    } else if whole_hash.is_some() {
                        row.same = Some(hash(&out) == whole_hash);
                    }
                }
                Err(e) => row.error = Some(e),
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

/// The argument that makes the benchmark binary run one bake as a child process:
/// `CHILD_ARG MESH OUTPUT DEPTH BUDGET [CHANNELS LAYOUT LEVEL NORMAL_BITS]` (budget in bytes,
/// 0 for the bake in memory; the rest as [`ChildBake`], the default bake without them).
pub const CHILD_ARG: &str = "--parts-bake-child";

/// What a child bake makes besides its depth and budget: `svo-bake`'s `--channels`,
/// `--layout`, `--attribute-depth` and `--normal-bits`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChildBake {
    /// The channels, as `--channels` takes them (`all`, `none`, `normal`, ...).
    pub channels: &'static str,
    /// The DAG layout instead of the tree.
    pub dag: bool,
    /// With the DAG layout: the level whose nodes keep the values (`None`: the leaves).
    pub level: Option<u8>,
    /// With the DAG layout: bits a normal.
    pub normal_bits: u8,
}

impl Default for ChildBake {
    fn default() -> Self {
        Self {
            channels: "all",
            dag: false,
            level: None,
            normal_bits: 32,
        }
    }
}

/// What a child bake printed: one line of `key=value[,value...]` pairs.
pub type ChildLine = std::collections::BTreeMap<String, Vec<f64>>;

/// Runs one bake in a child process (this binary with [`CHILD_ARG`]) and returns what it
/// printed.
pub fn run_child(
    mesh: &Path,
    out: &Path,
    depth: u8,
    memory: Option<u64>,
    bake: &ChildBake,
) -> Result<ChildLine, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let o = std::process::Command::new(exe)
        .arg(CHILD_ARG)
        .arg(mesh)
        .arg(out)
        .arg(depth.to_string())
        .arg(memory.unwrap_or(0).to_string())
        .arg(bake.channels)
        .arg(if bake.dag { "dag" } else { "tree" })
        .arg(bake.level.unwrap_or(0).to_string())
        .arg(bake.normal_bits.to_string())
        .output()
        .map_err(|e| e.to_string())?;
    let text = String::from_utf8_lossy(&o.stdout);
    if !o.status.success() {
        return Err(format!(
            "{}{}",
            text.trim(),
            String::from_utf8_lossy(&o.stderr).trim()
        ));
    }
    let line = text.lines().last().unwrap_or_default();
    Ok(line
        .split_whitespace()
        .filter_map(|kv| kv.split_once('='))
        .map(|(k, v)| {
            let values = v.split(',').filter_map(|x| x.parse().ok()).collect();
            (k.to_string(), values)
        })
        .collect())
}

/// The child's bake from [`CHILD_ARG`]'s arguments after it, `None` where they do not parse.
fn child_job(args: &[String]) -> Option<BakeJob> {
    let (mesh, out) = (args.first()?, args.get(1)?);
    let depth = args.get(2)?.parse::<u8>().ok()?;
    let budget = args.get(3)?.parse::<u64>().ok()?;
    let channels: svo::ChannelSelection = args.get(4).map_or("all", String::as_str).parse().ok()?;
    let dag = match args.get(5).map_or("tree", String::as_str) {
        "tree" => false,
        "dag" => true,
        _ => return None,
    };
    let level = args.get(6).map_or(Some(0), |l| l.parse::<u8>().ok())?;
    let normal_bits = args.get(7).map_or(Some(32), |b| b.parse::<u8>().ok())?;
    Some(BakeJob {
        input: mesh.into(),
        output: out.into(),
        options: BakeOptions {
            depth,
            channels,
            ..BakeOptions::default()
        },
        threads: None,
        given: GivenOptions {
            depth: true,
            solid: false,
        },
        memory: (budget > 0).then_some(budget),
        layout: if dag {
            NodeLayout::Dag
        } else {
            NodeLayout::Tree
        },
        values: DagValues {
            level: (level > 0).then_some(level),
            normal_bits,
            ..DagValues::default()
        },
    })
}

/// The child's work ([`CHILD_ARG`]'s arguments after it): bakes, and prints on one line
/// the job's seconds, leaves, parts, level, each part's seconds, the merge's seconds, the
/// peak heap beyond what was live before the job and the process's peak resident set.
/// Returns the exit code.
pub fn child_main(args: &[String]) -> i32 {
    let Some(job) = child_job(args) else {
        eprintln!("{CHILD_ARG} MESH OUTPUT DEPTH BUDGET [CHANNELS tree|dag LEVEL NORMAL_BITS]");
        return 2;
    };
    let t = Instant::now();
    let (res, peak) = peak_memory::measure(|| bake_file(&job));
    let seconds = t.elapsed().as_secs_f64();
    match res {
        Ok(rep) => {
            let mut line = format!("seconds={seconds} leaves={}", rep.leaves);
            if let Some(p) = &rep.parts {
                let times: Vec<String> = p.part_seconds.iter().map(f64::to_string).collect();
                line += &format!(
                    " parts={} level={} part_seconds={} merge_seconds={}",
                    p.parts,
                    p.level,
                    times.join(","),
                    p.merge.seconds
                );
            }
            if let Some(p) = peak {
                line += &format!(" peak_heap={p}");
            }
            if let Some(r) = svo_bake::memory::peak_resident() {
                line += &format!(" peak_resident={r}");
            }
            println!("{line}");
            0
        }
        Err(e) => {
            println!("{e:#}");
            1
        }
    }
}

/// The section's table.
pub fn write(r: &mut Report, rows: &[PartsRow]) {
    r.para(
        "The whole `svo-bake` job (`bake_file`: load, bake, write the `.svo`) on all threads, \
         once each: in memory, and within a memory budget in parts (`--memory`: each part \
         baked into a file beside the output, then merged; `docs/bake-in-parts.md`), each in a \
         process of its own. Peak resident is that process's resident-set high-water mark \
         (Linux `VmHWM`: the mesh, the bake, the allocator's cached pages, code); peak heap is \
         the most bytes live at once beyond those live before the job; ns a leaf is the job's \
         wall time over its leaves. Where both ran, the two files were compared byte for byte.",
    );
    let header = [
        "mesh",
        "depth",
        "bake",
        "leaves",
        "time",
        "ns / leaf",
        "peak resident",
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
                row.resident.map_or(String::new(), gib),
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
