//! `svo-bake`: bake a triangle mesh into a sparse voxel octree file.
//!
//! ```text
//! svo-bake bunny.obj --depth 8 -o bunny.svo
//! svo-bake bunny.obj --depth 14 --memory 8GiB -o bunny.svo
//! svo-bake bunny.svo -o bunny.binvox
//! svo-bake plan bunny.obj --depth 14 --parts 16 -o job.svoplan
//! svo-bake part job.svoplan 3
//! svo-bake merge job.svoplan -o bunny.svo
//! ```
//! The bake job is the `svo_bake` library's ([`svo_bake::job::bake_file`]) and the bake in
//! parts `svo`'s ([`svo::bake::parts`]); this file parses arguments, draws the progress bar
//! and prints the summaries.
#![forbid(unsafe_code)]

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Mutex;
use svo::bake::parts::{MergeFormat, bake_part_file, merge_parts, part_path, plan_file};
use svo::bake::{BakeOptions, ChannelSelection, Phase, SolidMode, Strategy};
use svo::dag::DagValues;
use svo_bake::job::{
    BakeJob, GivenOptions, NodeLayout, bake_file_with_progress, options_for_values, parts_hint,
};
use svo_bake::memory::available_memory;

/// mimalloc keeps the bake's freed buffers for its next allocations; the system allocator
/// returns large ones to the kernel, and touching them again costs a page fault per page
/// (feature `mimalloc`, on by default; `docs/performance.md`).
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOC: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Bake a triangle mesh (OBJ, OBJ.GZ, PLY, glTF, GLB) or a scene file (.toml) into a sparse
/// voxel octree (.svo), or export/convert to .binvox or .vox (MagicaVoxel). With `plan`,
/// `part` and `merge`, bake in parts that a batch system (Slurm, Kubernetes) runs anywhere
/// the files are shared.
#[derive(Parser, Debug)]
#[command(
    version,
    about,
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
)]
struct Args {
    #[command(subcommand)]
    command: Option<Command>,
    /// Input mesh (.obj, .obj.gz, .ply, .gltf, .glb), scene file (.toml; see
    /// docs/scenes.md) or .svo to convert.
    #[arg(required = true)]
    input: Option<PathBuf>,
    /// Output file: .svo, .binvox (depth <= 10) or .vox (depth <= 8). Default: input name with .svo.
    #[arg(short, long)]
    output: Option<PathBuf>,
    #[command(flatten)]
    settings: Settings,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// No progress bar and no summary (errors are still printed).
    #[arg(short, long)]
    quiet: bool,
    /// Fill the inside: `--solid` (or `--solid closed`) for closed meshes (an open mesh is
    /// refused, with its count of open edges); `--solid vote` for meshes with holes (parity
    /// along x, y and z columns, the majority deciding).
    #[arg(long, num_args = 0..=1, default_missing_value = "closed", value_name = "MODE",
)]
    solid: Option<SolidMode>,
    /// Bake within this much memory (e.g. 8GiB, 512MiB): in parts baked one after another
    /// into files beside the output, then merged into it; the same file as a bake in
    /// memory. Without it, a bake that could need more than the available memory (for the
    /// most leaves it can make) does this by itself within that memory.
    #[arg(long, value_parser = parse_size, value_name = "SIZE")]
    memory: Option<u64>,
    /// Bake in memory even when it could need more than the available memory.
    #[arg(long)]
    force: bool,
    /// How an .svo output stores its nodes: `tree` (each node its child mask and a pointer
    /// to its children) or `dag` (identical subtrees stored once, the two lowest levels as
    /// 64-bit bricks; format version 4, without inner-node attributes). With an .svo input,
    /// converts it either way.
    #[arg(long, default_value = "tree", value_name = "LAYOUT")]
    layout: LayoutArg,
    #[command(flatten)]
    values: ValuesArgs,
}

/// Where a DAG file keeps its leaves' values, for a bake and for `merge`.
#[derive(clap::Args, Debug, Clone, Copy)]
struct ValuesArgs {
    /// With `--layout dag`: keep the leaves' values (normals, colours, materials) on this
    /// level of the tree, each node's the area-weighted surface in its cell, which the leaves
    /// below take (1 to depth - 2; the depth, each leaf its own, is the default). The
    /// contour, measured in its own leaf's cell, is left out. For `merge`, the plan must
    /// have been made with `--layout dag --attribute-depth`, or `--lod filtered
    /// --no-contours`.
    #[arg(long, value_name = "LEVEL")]
    attribute_depth: Option<u8>,
    /// With `--layout dag`: keep each normal in this many bits (an even number from 4 to
    /// 32, half of them a component of its octahedral encoding).
    #[arg(long, value_name = "BITS", default_value_t = 32)]
    normal_bits: u8,
    /// With `--layout dag`: keep each colour in 32 bits (as it is), 16 (R5G6B5) or 4 (blocks
    /// of 16 colours: two R5G6B5 ends and a 2-bit choice a colour).
    #[arg(long, value_name = "BITS", default_value_t = 32)]
    colour_bits: u8,
}

impl ValuesArgs {
    /// The library's settings, refused unless the output is a DAG.
    fn for_layout(self, layout: LayoutArg) -> anyhow::Result<DagValues> {
        let values = DagValues {
            level: self.attribute_depth,
            normal_bits: self.normal_bits,
            colour_bits: self.colour_bits,
        };
        if layout != LayoutArg::Dag && values != DagValues::default() {
            anyhow::bail!(
                "--attribute-depth, --normal-bits and --colour-bits are for --layout dag"
            );
        }
        Ok(values)
    }
}

/// What `--layout` asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum LayoutArg {
    /// The tree.
    Tree,
    /// The DAG.
    Dag,
}

/// The bake settings that `plan` shares with a bake.
#[derive(clap::Args, Debug)]
struct Settings {
    /// Octree depth: the grid has 2^depth cells per axis [default: 8, or the scene file's].
    #[arg(short, long, value_parser = clap::value_parser!(u8).range(0..=255))]
    depth: Option<u8>,
    /// Overlap test strategy: exact (default), aabb-plane, aabb-plane-sat, sat-leaf, plane-sat-leaf.
    #[arg(long, default_value = "exact")]
    strategy: Strategy,
    /// Do not compute contours.
    #[arg(long)]
    no_contours: bool,
    /// Attribute channels to store, comma-separated: normal, contour, colour, reflectivity,
    /// refractivity, ior, all, none. Channels constant over the scene go in the header.
    #[arg(long, default_value = "all")]
    channels: String,
    /// At least this many empty cells on every side of the mesh (its bounds then sit mid-cell).
    #[arg(long, default_value_t = 0)]
    pad: u32,
    /// Level of detail: `filtered` gives the inner nodes (above the leaf parents) the filtered
    /// surface of their cells, written as format version 4 (levels first, so a file's top
    /// levels read alone), in memory or in parts; `none` writes no inner-node channels.
    #[arg(long, default_value = "none", value_name = "MODE")]
    lod: Lod,
}

/// What `--lod` asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Lod {
    /// No inner-node channels.
    None,
    /// The inner nodes' filtered surface (normal, contour, colour, materials).
    Filtered,
}

impl Settings {
    fn options(&self) -> anyhow::Result<BakeOptions> {
        let mut channels: ChannelSelection = self.channels.parse().map_err(anyhow::Error::msg)?;
        if self.no_contours {
            channels = channels.without(svo::ChannelKind::Contour);
        }
        Ok(BakeOptions {
            depth: self.depth.unwrap_or(8),
            strategy: self.strategy,
            channels,
            pad: self.pad,
            node_attributes: self.lod == Lod::Filtered,
            ..BakeOptions::default()
        })
    }
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Plan a bake in parts: writes the plan (the mesh's path and hash, the options, each
    /// part's subtrees) that `part` and `merge` read. Part I's file will be
    /// NAME.IIIII.svopart beside the plan NAME.svoplan.
    Plan {
        /// The mesh (.obj, .obj.gz, .ply, .gltf, .glb).
        mesh: PathBuf,
        /// Number of parts (1 to 65536).
        #[arg(long)]
        parts: u32,
        /// The plan file to write (.svoplan).
        #[arg(short, long)]
        output: PathBuf,
        /// Also write each part's triangles to NAME.IIIII.svobin beside the plan, which the
        /// part then loads instead of the whole mesh (the same bytes).
        #[arg(long)]
        bins: bool,
        #[command(flatten)]
        settings: Settings,
        /// The layout the parts will be merged into: `tree`, or `dag` (with
        /// `--attribute-depth`, the parts are baked with the inner nodes' attributes,
        /// without contours, and keep no leaf channels: `merge --layout dag
        /// --attribute-depth` is then the one merge of them).
        #[arg(long, default_value = "tree", value_name = "LAYOUT")]
        layout: LayoutArg,
        #[command(flatten)]
        values: ValuesArgs,
    },
    /// Bake part INDEX of a plan into its file beside the plan (stateless: run it on any
    /// machine that sees the plan and the mesh; run twice, the same bytes).
    Part {
        /// The plan file.
        plan: PathBuf,
        /// The part, 0 to parts - 1.
        index: u32,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Print the summary as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Merge a plan's parts into the .svo file, streamed; refuses a missing part, a part of
    /// another plan, and a truncated or damaged part, leaving no output.
    Merge {
        /// The plan file.
        plan: PathBuf,
        /// The .svo file to write.
        #[arg(short, long)]
        output: PathBuf,
        /// Write format version 3 (the subtrees at the plan's level stored as chunks) even
        /// when version 2 holds the tree; past 2^31 leaves or nodes it is written anyway.
        #[arg(long, conflicts_with = "layout")]
        chunked: bool,
        /// How the file stores its nodes: `tree`, or `dag` (the parts reduced into one graph
        /// of distinct subtrees as they are read; format version 4, without inner-node
        /// attributes).
        #[arg(long, default_value = "tree", value_name = "LAYOUT")]
        layout: LayoutArg,
        #[command(flatten)]
        values: ValuesArgs,
        /// Print the summary as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
}

/// A size in bytes: a number with an optional unit (B, KiB, MiB, GiB, TiB, or K, M, G, T
/// for the same powers of 1024).
fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let value: f64 = num
        .parse()
        .map_err(|_| format!("{s:?} is not a size (e.g. 8GiB, 512MiB)"))?;
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kib" | "kb" => 10,
        "m" | "mib" | "mb" => 20,
        "g" | "gib" | "gb" => 30,
        "t" | "tib" | "tb" => 40,
        u => {
            return Err(format!(
                "unknown size unit {u:?} (use KiB, MiB, GiB or TiB)"
            ));
        }
    };
    let bytes = value * (1u64 << shift) as f64;
    if !(1.0..1.8e19).contains(&bytes) {
        return Err(format!("{s:?} is not a usable size"));
    }
    Ok(bytes as u64)
}

/// `println!` that returns the error instead of panicking, so that a closed pipe
/// (`svo-bake ... | head`) ends the program quietly.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($t)*)?;
    }};
}

fn main() {
    if let Err(e) = real_main() {
        // The reader of stdout went away (`| head`): nothing is wrong with the work.
        if e.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
        {
            return;
        }
        // Stopped by a signal: that thread says so and exits (the error is its doing).
        if STOPPING.load(std::sync::atomic::Ordering::SeqCst) {
            loop {
                std::thread::park();
            }
        }
        eprintln!("svo-bake: error: {e:#}");
        std::process::exit(1);
    }
}

/// Set once a signal stops the program.
static STOPPING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// On SIGINT (Ctrl-C) or SIGTERM (what Slurm sends at a time limit or on preemption): removes
/// what the run left beside `output` (a bake's part files, an unfinished output; the
/// previous output stays as it was), says so in one line and exits with 128 + the signal.
#[cfg(unix)]
fn stop_on_signals(output: &std::path::Path) -> anyhow::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])
        .context("cannot watch for SIGINT and SIGTERM")?;
    let output = output.to_path_buf();
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            STOPPING.store(true, std::sync::atomic::Ordering::SeqCst);
            let removed = svo::bake::parts::remove_leftovers(&output);
            let name = if sig == SIGINT { "SIGINT" } else { "SIGTERM" };
            eprintln!(
                "svo-bake: error: stopped by {name}: removed what it had begun beside {} ({} part folder(s) and unfinished file(s)); that file is as it was, unless the bake had already put its new one in place",
                output.display(),
                removed.len()
            );
            std::process::exit(128 + sig);
        }
    });
    Ok(())
}

#[cfg(not(unix))]
fn stop_on_signals(_: &std::path::Path) -> anyhow::Result<()> {
    Ok(())
}

fn real_main() -> anyhow::Result<()> {
    let args = Args::parse();
    let written = match &args.command {
        Some(Command::Plan { output, .. } | Command::Merge { output, .. }) => output.clone(),
        Some(Command::Part { plan, index, .. }) => part_path(plan, *index),
        None => args
            .output
            .clone()
            .or_else(|| args.input.as_deref().map(default_output))
            .unwrap_or_default(),
    };
    stop_on_signals(&written)?;
    match &args.command {
        Some(Command::Plan {
            mesh,
            parts,
            output,
            bins,
            settings,
            layout,
            values,
        }) => plan(
            mesh,
            *parts,
            output,
            *bins,
            settings,
            (*layout, values.for_layout(*layout)?),
        ),
        Some(Command::Part {
            plan,
            index,
            threads,
            json,
        }) => part(plan, *index, *threads, *json),
        Some(Command::Merge {
            plan,
            output,
            chunked,
            layout,
            values,
            json,
        }) => merge(
            plan,
            output,
            *chunked,
            *layout,
            values.for_layout(*layout)?,
            *json,
        ),
        None => bake(&args),
    }
}

/// A bake in parts' error with what the command's flags can do about it.
fn with_hint(e: &svo::bake::parts::PartsError) -> anyhow::Error {
    anyhow::anyhow!("{e}{}", parts_hint(e))
}

/// `svo-bake plan`.
fn plan(
    mesh: &std::path::Path,
    parts: u32,
    output: &std::path::Path,
    bins: bool,
    settings: &Settings,
    (layout, values): (LayoutArg, DagValues),
) -> anyhow::Result<()> {
    let mut opts = settings.options()?;
    let format = match layout {
        LayoutArg::Tree => MergeFormat::Auto,
        LayoutArg::Dag => {
            // As a bake sets them for these values.
            options_for_values(&mut opts, values);
            MergeFormat::DagWith(values)
        }
    };
    let (plan, binned) = plan_file(mesh, &opts, parts, format, output, bins)
        .map_err(|e| with_hint(&e))
        .with_context(|| format!("planning the bake of {}", mesh.display()))?;
    say!(
        "{}: {} parts of the subtrees at level {} (depth {}; about {:.3e} leaves in all, \
         the largest part at most {:.3e})",
        output.display(),
        plan.part_count(),
        plan.level,
        plan.depth,
        plan.estimated_leaves,
        plan.largest_part_leaves()
    );
    if let Some(b) = binned {
        say!(
            "{} bins of the parts' triangles ({} triangles in all, {} bytes), {} ...",
            b.files,
            b.triangles,
            b.bytes,
            b.first
        );
    }
    say!(
        "next: svo-bake part {} I (for I in 0..{}: writes {} ...), then svo-bake merge {} -o OUT.svo",
        output.display(),
        plan.part_count(),
        part_path(output, 0).display(),
        output.display()
    );
    Ok(())
}

/// `svo-bake part`.
fn part(
    plan: &std::path::Path,
    index: u32,
    threads: Option<usize>,
    json: bool,
) -> anyhow::Result<()> {
    let r = bake_part_file(plan, index, threads)
        .map_err(|e| with_hint(&e))
        .with_context(|| format!("baking part {index} of {}", plan.display()))?;
    if json {
        say!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        say!(
            "part {} of {}: {} subtrees, {} leaves, {} bytes -> {} (load {:.2} s, bake {:.2} s, write {:.2} s)",
            r.index,
            r.count,
            r.subtrees,
            r.leaves,
            r.bytes,
            r.path,
            r.load_s,
            r.bake_s,
            r.write_s
        );
    }
    Ok(())
}

/// `svo-bake merge`.
fn merge(
    plan: &std::path::Path,
    output: &std::path::Path,
    chunked: bool,
    layout: LayoutArg,
    values: DagValues,
    json: bool,
) -> anyhow::Result<()> {
    let format = match (chunked, layout) {
        (_, LayoutArg::Dag) => MergeFormat::DagWith(values),
        (true, LayoutArg::Tree) => MergeFormat::Chunked,
        (false, LayoutArg::Tree) => MergeFormat::Auto,
    };
    let r = merge_parts(plan, output, format)
        .map_err(|e| with_hint(&e))
        .with_context(|| format!("merging the parts of {}", plan.display()))?;
    if json {
        say!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        say!(
            "{}: {} parts merged, {} nodes, {} leaves, {} bytes (format version {}{}) in {:.2} s",
            output.display(),
            r.parts,
            r.nodes,
            r.leaves,
            r.bytes,
            r.version,
            if r.chunks > 0 {
                format!(", {} chunks", r.chunks)
            } else {
                String::new()
            },
            r.seconds
        );
    }
    Ok(())
}

/// The output a bake of `input` writes unless told: the input's name with `.svo`.
fn default_output(input: &std::path::Path) -> PathBuf {
    let name = input
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = name
        .trim_end_matches(".gz")
        .rsplit_once('.')
        .map_or(name.as_str(), |(s, _)| s)
        .to_string();
    input.with_file_name(format!("{stem}.svo"))
}

/// The progress bar of a bake: drawn on a terminal unless quiet or printing JSON.
fn progress_bar(args: &Args) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(
        Some(1000),
        if args.quiet || args.json || !std::io::stderr().is_terminal() {
            ProgressDrawTarget::hidden()
        } else {
            ProgressDrawTarget::stderr()
        },
    );
    bar.set_style(
        ProgressStyle::with_template("{msg:>10} [{bar:40}] {percent:>3}% {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// A bake: input to output.
fn bake(args: &Args) -> anyhow::Result<()> {
    let input = args.input.clone().context("no input file given")?;
    let is_svo = input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svo"));
    if is_svo && args.output.is_none() {
        anyhow::bail!(
            "{}: an .svo input needs -o (its default output, the same name, is the input itself)",
            input.display()
        );
    }
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&input));
    let job = BakeJob {
        input: input.clone(),
        output,
        options: BakeOptions {
            max_memory: if args.force { None } else { available_memory() },
            solid: args.solid,
            ..args.settings.options()?
        },
        threads: args.threads,
        given: GivenOptions {
            depth: args.settings.depth.is_some(),
            solid: args.solid.is_some(),
        },
        memory: args.memory,
        layout: match args.layout {
            LayoutArg::Tree => NodeLayout::Tree,
            LayoutArg::Dag => NodeLayout::Dag,
        },
        values: args.values.for_layout(args.layout)?,
    };
    let bar = progress_bar(args);
    let last = Mutex::new(None);
    let talk = !(args.quiet || args.json);
    let progress = |phase: Phase, f: f64| {
        if let Ok(mut l) = last.lock()
            && *l != Some(phase)
        {
            if phase == Phase::Part && talk {
                bar.suspend(|| {
                    eprintln!(
                        "svo-bake: baking in parts within the memory budget, one after another, then merging them"
                    );
                });
            }
            *l = Some(phase);
            bar.set_message(match phase {
                Phase::Voxelize => "voxelize",
                Phase::Attributes => "attributes",
                Phase::Solid => "solid",
                Phase::Part => "parts",
                Phase::Merge => "merge",
            });
        }
        bar.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64);
    };
    let report = bake_file_with_progress(&job, &progress)
        .with_context(|| format!("baking {}", job.input.display()))?;
    bar.finish_and_clear();
    if args.json {
        say!("{}", serde_json::to_string_pretty(&report)?);
    } else if !args.quiet {
        say!("{report}");
    }
    Ok(())
}
