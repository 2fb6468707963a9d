//! `svo-view`: the viewer for `.svo` files. For now it validates a file and prints its
//! header and statistics (`--info`); CPU and GPU rendering come with their own issues.
#![forbid(unsafe_code)]

use anyhow::Context;
use clap::Parser;
use std::path::PathBuf;

/// Inspect a sparse voxel octree (.svo) file.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// The .svo file.
    file: PathBuf,
    /// Print the header and statistics (the only mode so far).
    #[arg(long)]
    info: bool,
}

fn main() {
    if let Err(e) = real_main() {
        eprintln!("svo-view: error: {e:#}");
        std::process::exit(1);
    }
}

fn real_main() -> anyhow::Result<()> {
    let args = Args::parse();
    let bytes = std::fs::read(&args.file)
        .with_context(|| format!("cannot read {}", args.file.display()))?;
    let (tree, build) = svo::format_read::from_bytes(&bytes)
        .with_context(|| format!("loading {}", args.file.display()))?;
    if !args.info {
        anyhow::bail!("rendering is not available yet; use --info to inspect the file");
    }
    println!(
        "{}\n{}",
        args.file.display(),
        svo::describe::describe(&tree, &build, bytes.len() as u64)
    );
    Ok(())
}
