//! `svo-bench`: regenerates `docs/benchmarks.md` and its plots. All the work is in the
//! library ([`svo_bench::run`]); this file parses arguments.

use clap::Parser;
use std::path::PathBuf;

/// Counts heap bytes so the report can give each bake's peak memory.
#[global_allocator]
static ALLOC: svo_bench::peak_memory::CountingAlloc = svo_bench::peak_memory::CountingAlloc;

/// Regenerate the benchmark report (error against run time) on this machine.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// The quick variant for CI: shallow depths, tiny images, one run, no external tools.
    #[arg(long)]
    quick: bool,
    /// Folder for benchmarks.md and bench/*.png (default: docs, or target/bench-quick with --quick).
    #[arg(long)]
    out: Option<PathBuf>,
    /// The benchmark mesh [default: stanford/stanford-bunny.obj in the shared models folder,
    /// `$SVO_MODELS` or ../shared/models].
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// A large mesh for the pipeline table, skipped when absent [default:
    /// stanford/dragon_vrip.obj.gz in the shared models folder].
    #[arg(long)]
    large_mesh: Option<PathBuf>,
    /// Do not run open3d and Embree even where installed.
    #[arg(long)]
    no_external: bool,
    /// Do not use the GPU even where an adapter exists.
    #[arg(long)]
    no_gpu: bool,
    /// Time a software GPU adapter (lavapipe) too; the quick variant always uses one.
    #[arg(long)]
    software_gpu: bool,
    /// Instead of the report: bake the mesh in parts at depths 14 and 15 (7 and 8 with
    /// --quick) as the tree, its graph and the graph with normals, render the graphs, and
    /// write benchmarks-deep-dag.md (about 20 minutes and 30 GB of disk on 2 cores).
    #[arg(long)]
    deep_dag: bool,
    /// With --deep-dag: write its page again from the benchmarks-deep-dag.json of an earlier
    /// run in the output folder, measuring nothing.
    #[arg(long, requires = "deep_dag")]
    from_json: bool,
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some(svo_bench::parts_tables::CHILD_ARG) {
        std::process::exit(svo_bench::parts_tables::child_main(&args[2..]));
    }
    if args.get(1).map(String::as_str) == Some(svo_bench::deep_dag_tables::RENDER_CHILD_ARG) {
        std::process::exit(svo_bench::deep_dag_tables::render_child_main(&args[2..]));
    }
    let a = Args::parse();
    let opts = svo_bench::Options {
        quick: a.quick,
        out: a.out.unwrap_or_else(|| {
            PathBuf::from(if a.quick {
                "target/bench-quick"
            } else {
                "docs"
            })
        }),
        mesh: a
            .mesh
            .unwrap_or_else(|| svo_tests::models_dir().join("stanford/stanford-bunny.obj")),
        large_mesh: Some(
            a.large_mesh
                .unwrap_or_else(|| svo_tests::models_dir().join("stanford/dragon_vrip.obj.gz")),
        ),
        no_external: a.no_external,
        no_gpu: a.no_gpu,
        software_gpu: a.software_gpu,
        from_json: a.from_json,
    };
    let run = if a.deep_dag {
        svo_bench::run_deep_dag
    } else {
        svo_bench::run
    };
    if let Err(e) = run(&opts) {
        eprintln!("svo-bench: error: {e:#}");
        std::process::exit(1);
    }
}
