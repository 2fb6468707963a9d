//! The Python package side by side, in one sitting: `docs/bench/python_package.py` (kept
//! loaded, fed one command at a time over its pipes) times `svo.bake` and `Octree.cast` from
//! Python, open3d's and trimesh's voxelizers (each set compared with the exact one) and
//! Embree on the same rays; between its runs this module times the same bake and cast from
//! Rust (`bake_mesh`, `Octree::cast_many`) on the same mesh and rays, and checks that both
//! sides hit the same leaf with every ray.

use crate::external::{PYTHON_PACKAGE, scripts};
use crate::report::{Report, f, median, ms};
use serde_json::Value;
use std::io::{BufRead, BufReader, Lines, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::Instant;
use svo::mesh::Mesh;
use svo::trace::HitMode;
use svo::{BakeOptions, Ray, bake_mesh};

/// The deepest grid trimesh's voxelizer is run at: on the bunny at depth 10 its subdivision
/// to half a cell held 24 GB and was killed on the 24 GiB VM.
const TRIMESH_MAX_DEPTH: u8 = 8;

/// trimesh's runs (after the rounds of `svo.bake` and open3d; their median is its time).
const TRIMESH_RUNS: usize = 3;

/// One call made from Python and from Rust, alternating.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CallRow {
    /// What was called.
    pub what: String,
    /// Rounds (the same number of calls from each side a round).
    pub rounds: usize,
    /// Median milliseconds from Python.
    pub python_ms: f64,
    /// Median milliseconds from Rust.
    pub rust_ms: f64,
    /// What it made (leaves, hits).
    pub result: String,
}

/// Another voxelizer's set against the exact one.
#[derive(Clone, Debug, serde::Serialize)]
pub struct VoxelizerRow {
    /// The tool.
    pub tool: String,
    /// Depth (grid `2^depth`).
    pub depth: u8,
    /// Median milliseconds, or why it did not run.
    pub ms: Result<f64, String>,
    /// Its voxels, the exact cells it missed and the cells it added.
    pub voxels: usize,
    /// Exact cells absent from its set.
    pub missed: usize,
    /// Cells of its set that no triangle touches.
    pub extra: usize,
    /// `svo.bake`'s median milliseconds at the same depth.
    pub svo_ms: f64,
    /// Where the tool ran in alternation with `svo.bake`: the rounds' ratios of its time to
    /// `svo.bake`'s, median, lowest and highest.
    pub ratios: Option<(f64, f64, f64)>,
}

impl VoxelizerRow {
    /// A row from the tool's time and the counts of its compared run `v`.
    fn new(tool: &str, depth: u8, ms: Result<f64, String>, v: &Value, svo_ms: f64) -> Self {
        let count = |k: &str| v.get(k).and_then(Value::as_u64).unwrap_or(0) as usize;
        Self {
            tool: tool.to_string(),
            depth,
            ms,
            voxels: count("voxels"),
            missed: count("missed"),
            extra: count("extra"),
            svo_ms,
            ratios: None,
        }
    }

    /// The row with the rounds' ratios to `svo.bake` (none if there were no rounds).
    fn with_ratios(mut self, ratios: &[f64]) -> Self {
        let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        self.ratios = (!ratios.is_empty()).then(|| (median(ratios), lo, hi));
        self
    }

    /// Its time over `svo.bake`'s: the median of the rounds' ratios where it alternated,
    /// else the ratio of the medians.
    pub fn ratio(&self) -> Option<f64> {
        let t = self.ms.as_ref().ok()?;
        Some(self.ratios.map_or(t / self.svo_ms, |r| r.0))
    }
}

/// Embree's closest hits on the same rays.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EmbreeRow {
    /// Milliseconds (one run, one thread).
    pub ms: f64,
    /// Rays that hit.
    pub hits: u64,
    /// The fraction of rays on which Embree and `Octree.cast` agree (hit or miss).
    pub agree: f64,
    /// The median distance between their hits, in cells of the tree.
    pub median_t_cells: f64,
}

/// Everything the section shows.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PythonTables {
    /// The versions the script reported.
    pub versions: Value,
    /// Calls from Python against Rust.
    pub calls: Vec<CallRow>,
    /// Voxelizers against the exact set.
    pub voxelizers: Vec<VoxelizerRow>,
    /// Embree, where it ran.
    pub embree: Result<EmbreeRow, String>,
    /// The rays cast.
    pub rays: usize,
    /// The tree's depth they were cast through.
    pub cast_depth: u8,
}

/// The script, kept loaded.
struct Server {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Lines<BufReader<ChildStdout>>,
}

impl Server {
    fn start(mesh: &Path, rays: &Path) -> anyhow::Result<(Self, Value)> {
        let mut child = Command::new("python3")
            .arg(scripts().join("python_package.py"))
            .arg(mesh)
            .arg(rays)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            anyhow::bail!("python_package.py started without its pipes");
        };
        let mut server = Self {
            child,
            stdin: Some(stdin),
            lines: BufReader::new(stdout).lines(),
        };
        let head = server.read()?;
        Ok((server, head))
    }

    fn read(&mut self) -> anyhow::Result<Value> {
        let line = match self.lines.next() {
            Some(line) => line?,
            None => anyhow::bail!("python_package.py ended early"),
        };
        Ok(serde_json::from_str(&line)?)
    }

    /// Sends `command` and returns its answer, or the error the script reported.
    fn ask(&mut self, command: &str) -> anyhow::Result<Value> {
        let stdin = self
            .stdin
            .as_mut()
            .ok_or_else(|| anyhow::anyhow!("python_package.py is closed"))?;
        writeln!(stdin, "{command}")?;
        stdin.flush()?;
        let v = self.read()?;
        if let Some(e) = v.get("error") {
            anyhow::bail!("python_package.py {command}: {e}");
        }
        Ok(v)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        drop(self.stdin.take());
        let _ = self.child.wait();
    }
}

/// A number field of an answer.
fn num(v: &Value, key: &str) -> anyhow::Result<f64> {
    v.get(key)
        .and_then(Value::as_f64)
        .ok_or_else(|| anyhow::anyhow!("no {key} in {v}"))
}

/// Milliseconds `f` takes.
fn time_ms<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let t = Instant::now();
    let out = f();
    (t.elapsed().as_secs_f64() * 1e3, out)
}

/// The median milliseconds of `runs` calls of `f`.
fn round_median(runs: usize, f: &mut dyn FnMut() -> anyhow::Result<f64>) -> anyhow::Result<f64> {
    let times = (0..runs)
        .map(|_| f())
        .collect::<anyhow::Result<Vec<f64>>>()?;
    Ok(median(&times))
}

/// The rays the script wrote: little-endian `f64` rows of origin and direction.
fn read_rays(path: &Path) -> anyhow::Result<Vec<Ray>> {
    let bytes = std::fs::read(path)?;
    let v: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or_default()))
        .collect();
    Ok(v.chunks_exact(6)
        .map(|r| {
            Ray::new(
                glam::DVec3::new(r[0], r[1], r[2]),
                glam::DVec3::new(r[3], r[4], r[5]),
            )
        })
        .collect())
}

/// Whether `python3` imports the package and NumPy.
pub fn available() -> bool {
    PYTHON_PACKAGE.available()
}

/// Measures the section on `mesh` (loaded from `path`): bakes at `depths` (`rounds(depth)`
/// rounds of `runs(depth)` runs of each call), `rays` rays cast through the depth-`cast_depth` tree (`cast_rounds` rounds).
pub fn measure(
    path: &Path,
    mesh: &Mesh,
    depths: &[u8],
    (rounds, runs): (impl Fn(u8) -> usize, impl Fn(u8) -> usize),
    (rays, cast_depth, cast_rounds): (usize, u8, usize),
    dir: &Path,
    lg: &dyn Fn(&str),
) -> anyhow::Result<PythonTables> {
    let rays_path = dir.join("rays.bin");
    let (mut py, head) = Server::start(path, &rays_path)?;
    let versions = head.get("versions").cloned().unwrap_or(Value::Null);
    lg(&format!("the Python package: {versions}"));
    let options = |depth| BakeOptions {
        depth,
        ..BakeOptions::default()
    };
    let mut calls = Vec::new();
    let mut voxelizers = Vec::new();
    for &depth in depths {
        // One untimed call of each first; open3d's also compares its set with the exact one.
        py.ask(&format!("bake {depth}"))?;
        let (_, first) = time_ms(|| bake_mesh(mesh, &options(depth)));
        let leaves = first?.0.leaf_count;
        let open3d_first = py.ask(&format!("open3d {depth} 1"));
        let (mut p, mut r, mut o) = (Vec::new(), Vec::new(), Vec::new());
        let runs = runs(depth);
        for _ in 0..rounds(depth) {
            p.push(round_median(runs, &mut || {
                num(&py.ask(&format!("bake {depth}"))?, "ms")
            })?);
            r.push(round_median(runs, &mut || {
                let (t, tree) = time_ms(|| bake_mesh(mesh, &options(depth)));
                drop(tree?);
                Ok(t)
            })?);
            if open3d_first.is_ok() {
                o.push(round_median(runs, &mut || {
                    num(&py.ask(&format!("open3d {depth} 0"))?, "ms")
                })?);
            }
        }
        let svo_ms = median(&p);
        calls.push(CallRow {
            what: format!("`svo.bake(mesh, depth={depth})`"),
            rounds: p.len(),
            python_ms: svo_ms,
            rust_ms: median(&r),
            result: format!("{leaves} leaves"),
        });
        let ratios: Vec<f64> = o.iter().zip(&p).map(|(o, p)| o / p).collect();
        voxelizers.push(match open3d_first {
            Ok(v) => {
                VoxelizerRow::new("open3d", depth, Ok(median(&o)), &v, svo_ms).with_ratios(&ratios)
            }
            Err(e) => {
                VoxelizerRow::new("open3d", depth, Err(format!("{e:#}")), &Value::Null, svo_ms)
            }
        });
        // trimesh's subdivision of the bunny to half a cell at depth 10 passes 24 GiB; at
        // 8 it takes seconds a run and hundreds of times svo.bake's time, so it runs apart.
        if depth <= TRIMESH_MAX_DEPTH {
            let mut times = Vec::new();
            let mut last = Value::Null;
            let mut failed = None;
            for _ in 0..TRIMESH_RUNS {
                match py.ask(&format!("trimesh {depth}")) {
                    Ok(v) => {
                        times.push(num(&v, "ms")?);
                        last = v;
                    }
                    Err(e) => {
                        failed = Some(format!("{e:#}"));
                        break;
                    }
                }
            }
            let ms = failed.map_or_else(|| Ok(median(&times)), Err);
            voxelizers.push(VoxelizerRow::new("trimesh", depth, ms, &last, svo_ms));
        }
        lg(&format!("the Python package: depth {depth} done"));
    }
    py.ask(&format!("rays {rays}"))?;
    let ray_list = read_rays(&rays_path)?;
    let tree = bake_mesh(mesh, &options(cast_depth))?.0;
    py.ask(&format!("cast {cast_depth}"))?;
    // The untimed first cast gives each ray's leaf, which the Python side's must equal.
    let rust_leaves: Vec<i64> = tree
        .cast_many(&ray_list, HitMode::Contour)
        .iter()
        .map(|h| h.map_or(-1, |h| i64::from(h.leaf)))
        .collect();
    let rust_hits = rust_leaves.iter().filter(|&&l| l >= 0).count();
    let (mut p, mut r) = (Vec::new(), Vec::new());
    let mut py_hits = 0.0;
    for _ in 0..cast_rounds {
        let v = py.ask(&format!("cast {cast_depth}"))?;
        p.push(num(&v, "ms")?);
        py_hits = num(&v, "hits")?;
        let (t, hits) = time_ms(|| tree.cast_many(&ray_list, HitMode::Contour));
        drop(hits);
        r.push(t);
    }
    anyhow::ensure!(
        py_hits as usize == rust_hits,
        "Octree.cast hit {py_hits} rays, Octree::cast_many {rust_hits}"
    );
    // Every ray's leaf, from Python and from Rust.
    let py_leaves: Vec<i64> = std::fs::read(rays_path.with_extension("bin.leaf"))?
        .chunks_exact(8)
        .map(|c| i64::from_le_bytes(c.try_into().unwrap_or_default()))
        .collect();
    anyhow::ensure!(
        py_leaves == rust_leaves,
        "Octree.cast and Octree::cast_many hit different leaves"
    );
    calls.push(CallRow {
        what: format!(
            "`Octree.cast`, {} M rays, depth {cast_depth}",
            f(rays as f64 / 1e6, 1)
        ),
        rounds: p.len(),
        python_ms: median(&p),
        rust_ms: median(&r),
        result: format!("{rust_hits} hits"),
    });
    let embree = py
        .ask("embree")
        .and_then(|v| {
            Ok(EmbreeRow {
                ms: num(&v, "ms")?,
                hits: num(&v, "hits")? as u64,
                agree: num(&v, "agree")?,
                median_t_cells: num(&v, "median_t_cells")?,
            })
        })
        .map_err(|e| format!("{e:#}"));
    Ok(PythonTables {
        versions,
        calls,
        voxelizers,
        embree,
        rays,
        cast_depth,
    })
}

/// The section: the calls from Python against Rust, the voxelizers against the exact set,
/// Embree on the same rays.
pub fn write(r: &mut Report, t: &PythonTables) {
    let v = |k: &str| {
        t.versions
            .get(k)
            .and_then(Value::as_str)
            .unwrap_or("?")
            .to_string()
    };
    r.para(&format!(
        "`docs/bench/python_package.py` (Python {}, NumPy {}; open3d {}, trimesh {}, embreex \
         {}), kept loaded and fed one command at a time; between its calls this program makes \
         the same call from Rust on the same mesh (and, for the rays, the same rays, read from \
         the file the script wrote): each round makes the same number of calls from each side \
         (3 at depth 8, else 1) and gives the median of each side's; every ray hits the same \
         leaf from both sides (checked). Medians over the rounds; the package is a \
         release build (`pip install ./crates/svo-py`), the GIL released for the calls, both \
         sides on all cores and on mimalloc (this program links it as `svo-bake` does, the \
         package for its own allocations).",
        v("python"),
        v("numpy"),
        v("open3d"),
        v("trimesh"),
        v("embreex")
    ));
    let rows: Vec<Vec<String>> = t
        .calls
        .iter()
        .map(|c| {
            vec![
                c.what.clone(),
                c.rounds.to_string(),
                ms(c.python_ms / 1e3),
                ms(c.rust_ms / 1e3),
                format!("{}x", f(c.python_ms / c.rust_ms, 3)),
                c.result.clone(),
            ]
        })
        .collect();
    r.table(
        &[
            "call",
            "rounds",
            "from Python",
            "from Rust",
            "Python / Rust",
            "result",
        ],
        &rows,
    );
    r.para(
        "Other voxelizers from Python on the same root cube and grid as `svo.bake` (each set \
         compared cell by cell with the exact one: *missed* are cells a triangle touches that \
         the set lacks, *extra* cells no triangle touches): open3d's \
         `VoxelGrid.create_from_triangle_mesh_within_bounds` (the voxel set only, vertices \
         read as 32-bit floats) and trimesh's `voxelize_subdivide` (the mesh subdivided until \
         its edges are shorter than a cell, then the cells of its vertices: it misses the \
         cells that a triangle only crosses between them; at depth 10 its subdivision of the \
         bunny held 24 GB and was killed on this 24 GiB machine, so it runs at depth 8 only). \
         open3d runs as often as each bake in every round of the `svo.bake` rows above, after \
         them, so that both see the same state of the machine: its time is the median over the \
         rounds, and its ratio the median of the rounds' ratios to `svo.bake` (lowest and \
         highest in brackets). trimesh runs 3 times after the rounds (median; the ratio of \
         the medians). Each set is compared once, in an untimed run. CudaVox 1.7.0 (the Python bindings of a fork of cuda_voxelizer, with \
         an OpenMP path for CPUs) installs from PyPI but was compiled against NumPy 1 and \
         does not import beside NumPy 2 (`_ARRAY_API not found`), so it has no row.",
    );
    let rows: Vec<Vec<String>> = t
        .voxelizers
        .iter()
        .map(|x| match (&x.ms, x.ratio()) {
            (Ok(t), Some(ratio)) => vec![
                x.tool.clone(),
                format!("{}^3", 1u64 << x.depth),
                ms(t / 1e3),
                match x.ratios {
                    Some((_, lo, hi)) => {
                        format!("{}x ({}-{})", f(ratio, 2), f(lo, 1), f(hi, 1))
                    }
                    None => format!("{}x", f(ratio, 0)),
                },
                x.voxels.to_string(),
                x.missed.to_string(),
                x.extra.to_string(),
            ],
            (e, _) => vec![
                x.tool.clone(),
                format!("{}^3", 1u64 << x.depth),
                format!("failed: {}", e.as_ref().err().map_or("", String::as_str)),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
            ],
        })
        .collect();
    r.table(
        &[
            "voxelizer",
            "grid",
            "time",
            "time / svo.bake",
            "voxels",
            "missed",
            "extra",
        ],
        &rows,
    );
    match &t.embree {
        Ok(e) => r.para(&format!(
            "The same {} rays through Embree (embreex, closest hits on the mesh's triangles, \
             one thread, BVH built beforehand): {}, {} hits; it and `Octree.cast` (depth {}, \
             contours) agree on hit or miss for {}% of the rays, and where both hit their \
             distances differ by a median of {:.1e} cells.",
            t.rays,
            ms(e.ms / 1e3),
            e.hits,
            t.cast_depth,
            f(e.agree * 100.0, 2),
            e.median_t_cells
        )),
        Err(e) => r.para(&format!("Embree on the same rays did not run: {e}.")),
    }
}

/// The package's targets: each call within 10% of Rust's, the bake at least 5x open3d at
/// depth 8 and 10x at depth 10 with no cell missed.
pub fn targets(t: &PythonTables) -> Vec<Vec<String>> {
    let met = |ok: bool| if ok { "met" } else { "**not met**" };
    let mut rows: Vec<Vec<String>> = t
        .calls
        .iter()
        .map(|c| {
            let ratio = c.python_ms / c.rust_ms;
            vec![
                format!(
                    "{} from Python within 10% of the same call from Rust",
                    c.what
                ),
                format!(
                    "{} against {} ({}x): {}",
                    ms(c.python_ms / 1e3),
                    ms(c.rust_ms / 1e3),
                    f(ratio, 3),
                    met(ratio <= 1.1)
                ),
            ]
        })
        .collect();
    for x in t.voxelizers.iter().filter(|x| x.tool == "open3d") {
        let want = if x.depth <= 8 { 5.0 } else { 10.0 };
        let (Ok(o3d), Some(ratio)) = (&x.ms, x.ratio()) else {
            continue;
        };
        rows.push(vec![
            format!(
                "`svo.bake` at depth {} at least {want}x open3d from Python, no cell missed",
                x.depth
            ),
            format!(
                "{} against {} (median ratio {}x{}), {} missed: {}",
                ms(x.svo_ms / 1e3),
                ms(o3d / 1e3),
                f(ratio, 2),
                x.ratios
                    .map(|(_, lo, hi)| format!(", rounds {}-{}x", f(lo, 1), f(hi, 1)))
                    .unwrap_or_default(),
                x.missed,
                met(ratio >= want && x.missed == 0)
            ),
        ]);
    }
    rows
}
