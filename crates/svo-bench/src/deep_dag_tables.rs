//! Graphs deeper than a bake in memory reaches (`svo-bench --deep-dag`, its own page
//! `docs/benchmarks-deep-dag.md`): the mesh baked in parts within a memory budget at each
//! depth three ways, the tree layout's geometry, the DAG layout's geometry and the DAG
//! layout with normals on a level two above the leaves in 16 bits, each in a process of its
//! own (the time, the merge, the peak resident set, the file's bytes a leaf); then each
//! graph with normals rendered from its file by `svo-view`'s CPU and GPU paths, again a
//! process each (the time with the read, a frame, the peak resident set, the bytes on the
//! GPU, and the CPU image against the triangles').

use crate::machine::Machine;
use crate::parts_tables::{ChildBake, ChildLine, run_child};
use crate::report::{Report, f, ms};
use std::path::Path;
use std::time::Instant;
use svo_view::job::RenderJob;

/// What `--deep-dag` measures.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct DeepDagPlan {
    /// The depths baked.
    pub depths: Vec<u8>,
    /// The memory budget of every bake, bytes.
    pub budget: u64,
    /// The renders' size.
    pub size: (u32, u32),
}

impl DeepDagPlan {
    /// The full variant's depths (14 and 15 in 8 GiB at 1920x1080), or the quick one's.
    pub fn new(quick: bool) -> Self {
        if quick {
            Self {
                depths: vec![7, 8],
                budget: 32 << 20,
                size: (160, 90),
            }
        } else {
            Self {
                depths: vec![14, 15],
                budget: 8 << 30,
                size: (1920, 1080),
            }
        }
    }
}

/// The three bakes at each depth: (name, what the child bakes, given the depth).
fn bakes(depth: u8) -> [(&'static str, ChildBake); 3] {
    let geometry = ChildBake {
        channels: "none",
        ..ChildBake::default()
    };
    [
        ("tree, geometry", geometry),
        (
            "DAG, geometry",
            ChildBake {
                dag: true,
                ..geometry
            },
        ),
        (
            "DAG, normals on level d-2 in 16 bits",
            ChildBake {
                channels: "normal",
                dag: true,
                level: Some(depth - 2),
                normal_bits: 16,
            },
        ),
    ]
}

/// One bake in parts.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct DeepBakeRow {
    /// Tree depth.
    pub depth: u8,
    /// What was baked (layout and channels).
    pub bake: String,
    /// Leaves.
    pub leaves: u64,
    /// Wall seconds of the whole job (load, parts, merge).
    pub seconds: f64,
    /// The merge's seconds.
    pub merge: Option<f64>,
    /// Parts and their level.
    pub parts: Option<(u32, u8)>,
    /// The process's peak resident set, bytes.
    pub resident: Option<u64>,
    /// The file's bytes.
    pub file: u64,
    /// What went wrong, if the bake failed.
    pub error: Option<String>,
}

impl DeepBakeRow {
    /// Bits a leaf of the file.
    pub fn bits(&self) -> f64 {
        8.0 * self.file as f64 / self.leaves.max(1) as f64
    }
}

/// One render of a file in a process of its own.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct DeepRenderRow {
    /// Tree depth.
    pub depth: u8,
    /// `CPU` or the GPU adapter's name.
    pub path: String,
    /// Wall seconds of the job: the read, the upload and the shader where there is one, one
    /// frame.
    pub seconds: f64,
    /// The frame's milliseconds (the median of the timed frames).
    pub frame_ms: f64,
    /// The process's peak resident set, bytes.
    pub resident: Option<u64>,
    /// Bytes of the graph on the GPU.
    pub gpu_bytes: Option<u64>,
    /// PSNR (dB) of the CPU image against the triangles', same camera and lights.
    pub psnr_triangles: Option<f64>,
    /// What went wrong comparing with the triangles, if that failed.
    #[serde(default)]
    pub compare_error: Option<String>,
    /// What went wrong, if the render failed.
    pub error: Option<String>,
}

/// Everything `--deep-dag` measured.
#[derive(serde::Serialize, serde::Deserialize)]
pub struct DeepDag {
    /// Where.
    pub machine: Machine,
    /// The mesh as the page names it.
    pub mesh: String,
    /// What.
    pub plan: DeepDagPlan,
    /// The bakes.
    pub bakes: Vec<DeepBakeRow>,
    /// The renders.
    pub renders: Vec<DeepRenderRow>,
    /// Seconds of the whole run.
    pub seconds: f64,
}

/// The argument that makes the benchmark binary render one file as a child process:
/// `RENDER_CHILD_ARG cpu|gpu|compare FILE MESH WIDTH HEIGHT`. `compare` renders on the CPU
/// with the triangle reference beside.
pub const RENDER_CHILD_ARG: &str = "--deep-render-child";

/// The child's work ([`RENDER_CHILD_ARG`]'s arguments after it): renders `svo-view`'s
/// default view of the file and prints one line of JSON: the job's seconds, the process's
/// peak resident set and the frame's report. Returns the exit code.
pub fn render_child_main(args: &[String]) -> i32 {
    let (Some(how), Some(file), Some(mesh), Some(width), Some(height)) = (
        args.first().map(String::as_str),
        args.get(1),
        args.get(2),
        args.get(3).and_then(|w| w.parse::<u32>().ok()),
        args.get(4).and_then(|h| h.parse::<u32>().ok()),
    ) else {
        eprintln!("{RENDER_CHILD_ARG} cpu|gpu|compare FILE MESH WIDTH HEIGHT");
        return 2;
    };
    let compare = how == "compare";
    let job = RenderJob {
        input: file.into(),
        width,
        height,
        reference: compare.then(|| mesh.into()),
        compare,
        ..RenderJob::default()
    };
    let t = Instant::now();
    let report = match how {
        "cpu" | "compare" => svo_view::cpu_render::render_file(&job).map_err(anyhow::Error::from),
        "gpu" => svo_view::headless::run(&job, &svo_view::headless::HeadlessOptions::default())
            .map_err(anyhow::Error::from),
        _ => Err(anyhow::anyhow!("{how}: expected cpu, gpu or compare")),
    };
    let seconds = t.elapsed().as_secs_f64();
    match report.and_then(|r| Ok(serde_json::to_value(r)?)) {
        Ok(r) => {
            let line = serde_json::json!({
                "seconds": seconds,
                "peak_resident": svo_bake::memory::peak_resident(),
                "report": r,
            });
            println!("{line}");
            0
        }
        Err(e) => {
            println!("{e:#}");
            1
        }
    }
}

/// Renders `file` in a child process ([`RENDER_CHILD_ARG`]) and returns its JSON line.
fn render_child(
    how: &str,
    file: &Path,
    mesh: &Path,
    (w, h): (u32, u32),
) -> Result<serde_json::Value, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let o = std::process::Command::new(exe)
        .arg(RENDER_CHILD_ARG)
        .arg(how)
        .arg(file)
        .arg(mesh)
        .arg(w.to_string())
        .arg(h.to_string())
        .output()
        .map_err(|e| e.to_string())?;
    let text = String::from_utf8_lossy(&o.stdout);
    let last = text.lines().last().unwrap_or_default().trim().to_string();
    if !o.status.success() {
        let err = String::from_utf8_lossy(&o.stderr);
        return Err(format!("{last} {}", err.trim()).trim().to_string());
    }
    serde_json::from_str(&last).map_err(|e| format!("{e}: {last}"))
}

/// The row of one bake's child line.
fn bake_row(depth: u8, bake: &str, c: &ChildLine, file: u64) -> DeepBakeRow {
    let num = |k: &str| c.get(k).and_then(|v| v.first()).copied();
    DeepBakeRow {
        depth,
        bake: bake.to_string(),
        leaves: num("leaves").unwrap_or(0.0) as u64,
        seconds: num("seconds").unwrap_or(0.0),
        merge: num("merge_seconds"),
        parts: num("parts")
            .zip(num("level"))
            .map(|(n, l)| (n as u32, l as u8)),
        resident: num("peak_resident").map(|v| v as u64),
        file,
        error: None,
    }
}

/// Bakes `mesh` as `plan` asks into `dir` and renders each graph with normals (each file
/// removed once measured); `log` says what runs.
pub fn measure(
    mesh: &Path,
    plan: &DeepDagPlan,
    dir: &Path,
    log: &dyn Fn(&str),
) -> (Vec<DeepBakeRow>, Vec<DeepRenderRow>) {
    let (mut bakes_out, mut renders) = (Vec::new(), Vec::new());
    for &depth in &plan.depths {
        for (k, (name, bake)) in bakes(depth).into_iter().enumerate() {
            log(&format!("deep DAG: depth {depth}, {name}"));
            let out = dir.join(format!("deep{depth}-{k}.svo"));
            let row = match run_child(mesh, &out, depth, Some(plan.budget), &bake) {
                Ok(c) => bake_row(
                    depth,
                    name,
                    &c,
                    std::fs::metadata(&out).map_or(0, |m| m.len()),
                ),
                Err(e) => DeepBakeRow {
                    depth,
                    bake: name.to_string(),
                    leaves: 0,
                    seconds: 0.0,
                    merge: None,
                    parts: None,
                    resident: None,
                    file: 0,
                    error: Some(e),
                },
            };
            let rendered = row.error.is_none() && bake.channels == "normal";
            bakes_out.push(row);
            if rendered {
                renders.extend(render_rows(depth, &out, mesh, plan.size, log));
            }
            let _ = std::fs::remove_file(&out);
        }
    }
    (bakes_out, renders)
}

/// The CPU's and the GPU's renders of one file (the CPU twice: alone for its time and
/// memory, then beside the triangles for its error).
fn render_rows(
    depth: u8,
    file: &Path,
    mesh: &Path,
    size: (u32, u32),
    log: &dyn Fn(&str),
) -> Vec<DeepRenderRow> {
    let mut rows = Vec::new();
    for how in ["cpu", "gpu"] {
        log(&format!("deep DAG: depth {depth}, rendered on the {how}"));
        let mut row = DeepRenderRow {
            depth,
            path: "CPU".into(),
            seconds: 0.0,
            frame_ms: 0.0,
            resident: None,
            gpu_bytes: None,
            psnr_triangles: None,
            compare_error: None,
            error: None,
        };
        match render_child(how, file, mesh, size) {
            Ok(v) => {
                let r = &v["report"];
                row.seconds = v["seconds"].as_f64().unwrap_or(0.0);
                row.resident = v["peak_resident"].as_u64();
                row.frame_ms = r["median_ms"].as_f64().unwrap_or(0.0);
                if let Some(a) = r["adapter"].as_str() {
                    row.path = a.to_string();
                    row.gpu_bytes = r["tree_bytes"].as_u64();
                }
            }
            Err(e) => {
                if how == "gpu" {
                    row.path = "GPU".into();
                }
                row.error = Some(e);
            }
        }
        if how == "cpu" && row.error.is_none() {
            log(&format!(
                "deep DAG: depth {depth}, the CPU beside the triangles"
            ));
            match render_child("compare", file, mesh, size) {
                Ok(v) => row.psnr_triangles = v["report"]["compare"]["diff"]["psnr_db"].as_f64(),
                Err(e) => row.compare_error = Some(e),
            }
        }
        rows.push(row);
    }
    rows
}

/// Bytes in GB (10^9), or MB below one GB.
fn gb(b: u64) -> String {
    if b >= 1_000_000_000 {
        format!("{:.2} GB", b as f64 / 1e9)
    } else {
        format!("{:.1} MB", b as f64 / 1e6)
    }
}

/// Writes the page.
pub fn write(r: &mut Report, m: &DeepDag, quick: bool) {
    r.heading(1, "Benchmarks: deep graphs");
    r.para(&format!(
        "**Generated by `cargo run --release -p svo-bench -- --deep-dag{}`; do not edit by \
         hand.** Machine: {}. Mesh: `{}`. The whole run took {:.0} s. The main report is \
         [benchmarks.md](benchmarks.md).",
        if quick { " --quick" } else { "" },
        m.machine.line(),
        m.mesh,
        m.seconds
    ));
    if quick {
        r.para(
            "This is the **quick** variant (shallow depths, tiny images): it checks that the \
             generator works, its figures are not the report's.",
        );
    }
    r.heading(
        2,
        "Bakes in parts: the tree, its graph, and the graph with normals",
    );
    r.para(&format!(
        "Each bake is `svo-bake`'s whole job (`svo_bake::job::bake_file`: load, the parts one \
         after another, the merge, the file written) within `--memory {}MiB`, once, in a process \
         of its own, on every thread: `--channels none` in the tree layout and in the DAG \
         layout (`--layout dag`: identical subtrees stored once, the two lowest levels as \
         4x4x4 bricks, `docs/format.md` section 12), and `--channels normal --layout dag \
         --attribute-depth d-2 --normal-bits 16` (each leaf takes the normal of its ancestor \
         two levels up, from the inner nodes' attributes, in 16 bits). Peak resident is the \
         process's resident-set high-water mark (Linux `VmHWM`); \"x the tree\" is the time \
         against the tree layout's bake of the same depth. Published figures for lossless \
         geometry: Kampe, Sintorn and Assarsson 2013 (sparse voxel DAGs), Epic Citadel at \
         128K^3, about 0.4 bits a voxel; Villanueva, Marton and Gobbetti 2017 (symmetry-aware \
         DAGs), 0.123 bits a voxel at 64K^3 and 0.048 at 256K^3.",
        m.plan.budget >> 20
    ));
    let header = [
        "depth",
        "bake",
        "leaves",
        "time",
        "x the tree",
        "merge",
        "parts (level)",
        "peak resident",
        "file",
        "bits a leaf",
    ];
    let rows: Vec<Vec<String>> = m
        .bakes
        .iter()
        .map(|b| {
            if let Some(e) = &b.error {
                return vec![b.depth.to_string(), b.bake.clone(), format!("failed: {e}")];
            }
            let tree = m
                .bakes
                .iter()
                .find(|t| t.depth == b.depth && t.error.is_none() && t.bake.starts_with("tree"))
                .map(|t| t.seconds);
            vec![
                b.depth.to_string(),
                b.bake.clone(),
                format!("{:.1} M", b.leaves as f64 / 1e6),
                format!("{:.1} s", b.seconds),
                tree.map_or(String::new(), |t| format!("{}x", f(b.seconds / t, 2))),
                b.merge.map_or(String::new(), |s| format!("{s:.1} s")),
                b.parts.map_or(String::new(), |(n, l)| format!("{n} ({l})")),
                b.resident.map_or(String::new(), gb),
                gb(b.file),
                f(b.bits(), 2),
            ]
        })
        .collect();
    r.table(&header, &rows);

    let (w, h) = m.plan.size;
    r.heading(2, "The graphs with normals, rendered from their files");
    r.para(&format!(
        "`svo-view`'s job (`svo_view::cpu_render::render_file`, and `svo_view::headless::run` \
         on the GPU adapter there is) on each file of the last column above: its default view \
         and settings (the model framed, one light, shadows) at {w}x{h}, one untimed frame's \
         job in a process of its own. Time is the job's wall time (the read and the checks, \
         the graph expanded for the walk, on the GPU the upload and the shader, one frame); \
         PSNR is the CPU's image against the triangles' through the same camera, lights and \
         shading (`svo-view --reference --compare`, a second run)."
    ));
    let header = [
        "depth",
        "path",
        "time",
        "frame",
        "peak resident",
        "on the GPU",
        "PSNR vs triangles",
    ];
    let rows: Vec<Vec<String>> = m
        .renders
        .iter()
        .map(|r| {
            if let Some(e) = &r.error {
                return vec![r.depth.to_string(), r.path.clone(), format!("failed: {e}")];
            }
            vec![
                r.depth.to_string(),
                r.path.clone(),
                format!("{:.1} s", r.seconds),
                ms(r.frame_ms / 1e3),
                r.resident.map_or(String::new(), gb),
                r.gpu_bytes.map_or(String::new(), gb),
                match (&r.psnr_triangles, &r.compare_error) {
                    (Some(p), _) => format!("{} dB", f(*p, 2)),
                    (None, Some(e)) => format!("failed: {e}"),
                    (None, None) => String::new(),
                },
            ]
        })
        .collect();
    r.table(&header, &rows);
    targets(r, m);
}

/// The depth the targets are set for.
const TARGET_DEPTH: u8 = 15;

/// The figures at [`TARGET_DEPTH`] against the targets set for them.
fn targets(r: &mut Report, m: &DeepDag) {
    let d = TARGET_DEPTH;
    if !m.plan.depths.contains(&d) {
        return;
    }
    let bake = |k: &str| {
        m.bakes
            .iter()
            .find(|b| b.depth == d && b.bake.starts_with(k) && b.error.is_none())
    };
    let cpu = m
        .renders
        .iter()
        .find(|r| r.depth == d && r.path == "CPU" && r.error.is_none());
    let met = |ok: bool| if ok { "met" } else { "not met" }.to_string();
    let mut rows = Vec::new();
    if let Some(g) = bake("DAG, geometry") {
        rows.push(vec![
            "geometry at most 1 bit a leaf".into(),
            format!("{} bits", f(g.bits(), 2)),
            met(g.bits() <= 1.0),
        ]);
        if let Some(t) = bake("tree") {
            let x = g.seconds / t.seconds.max(1e-9);
            rows.push(vec![
                "building the graph at most 1.5x the tree's bake, same budget".into(),
                format!("{}x", f(x, 2)),
                met(x <= 1.5),
            ]);
        }
    }
    if let Some(n) = bake("DAG, normals") {
        rows.push(vec![
            "with normals at most 3 bits a leaf".into(),
            format!("{} bits", f(n.bits(), 2)),
            met(n.bits() <= 3.0),
        ]);
    }
    if let Some(c) = cpu.and_then(|c| c.resident.map(|b| b as f64 / 1e9)) {
        rows.push(vec![
            "`svo-view --cpu` at full depth within 4 GB resident".into(),
            format!("{} GB", f(c, 2)),
            met(c <= 4.0),
        ]);
    }
    if rows.is_empty() {
        return;
    }
    r.heading(2, &format!("Targets at depth {d}"));
    r.table(&["target", "measured", ""], &rows);
}
