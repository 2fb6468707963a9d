//! `svo-bake`: bake a triangle mesh into a sparse voxel octree file.
//!
//! ```text
//! svo-bake bunny.obj --depth 8 -o bunny.svo
//! svo-bake bunny.svo -o bunny.binvox
//! ```
//! All the work is in the `svo` library ([`svo::bake::bake_file`]); this file parses arguments,
//! draws the progress bar and prints the summary.
#![forbid(unsafe_code)]

use anyhow::Context;
use clap::Parser;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Mutex;
use svo::bake::{
    BakeJob, BakeOptions, ChannelSelection, GivenOptions, Phase, SolidMode, Strategy,
    available_memory, bake_file_with_progress,
};

/// mimalloc keeps the bake's freed buffers for its next allocations; the system allocator
/// returns large ones to the kernel, and touching them again costs a page fault per page
/// (feature `mimalloc`, on by default; `docs/performance.md`).
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOC: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Bake a triangle mesh (OBJ, OBJ.GZ, PLY, glTF, GLB) or a scene file (.toml) into a sparse
/// voxel octree (.svo), or export/convert to .binvox or .vox (MagicaVoxel).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Input mesh (.obj, .obj.gz, .ply, .gltf, .glb), scene file (.toml; see
    /// docs/scenes.md) or .svo to convert.
    input: PathBuf,
    /// Output file: .svo, .binvox (depth <= 10) or .vox (depth <= 8). Default: input name with .svo.
    #[arg(short, long)]
    output: Option<PathBuf>,
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
    /// Bake even when the memory estimate exceeds the available memory.
    #[arg(long)]
    force: bool,
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
        eprintln!("svo-bake: error: {e:#}");
        std::process::exit(1);
    }
}

fn real_main() -> anyhow::Result<()> {
    let args = Args::parse();
    let mut channels: ChannelSelection = args.channels.parse().map_err(anyhow::Error::msg)?;
    if args.no_contours {
        channels = channels.without(svo::ChannelKind::Contour);
    }
    let output = args.output.clone().unwrap_or_else(|| {
        let name = args
            .input
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let stem = name
            .trim_end_matches(".gz")
            .rsplit_once('.')
            .map_or(name.as_str(), |(s, _)| s)
            .to_string();
        args.input.with_file_name(format!("{stem}.svo"))
    });
    let job = BakeJob {
        input: args.input.clone(),
        output,
        options: BakeOptions {
            depth: args.depth.unwrap_or(8),
            strategy: args.strategy,
            channels,
            pad: args.pad,
            max_memory: if args.force { None } else { available_memory() },
            solid: args.solid,
        },
        threads: args.threads,
        given: GivenOptions {
            depth: args.depth.is_some(),
            solid: args.solid.is_some(),
        },
    };
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
    let last = Mutex::new(None);
    let progress = |phase: Phase, f: f64| {
        if let Ok(mut l) = last.lock()
            && *l != Some(phase)
        {
            *l = Some(phase);
            bar.set_message(match phase {
                Phase::Voxelize => "voxelize",
                Phase::Attributes => "attributes",
                Phase::Solid => "solid",
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
