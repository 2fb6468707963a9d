//! The 2015 thesis's scene from its committed scene file (`examples/scenes/pool.toml`): the
//! Stanford bunny submerged in a pool of water. Bakes it (`svo::bake::bake_file`, as
//! `svo-bake` does), then renders the three camera views stored in the file (water, bunny, parallel)
//! on the CPU, as `svo-view --cpu --view NAME` does.
//!
//! `cargo run --release -p svo-examples --example pool_scene -- [OUT_DIR [WIDTHxHEIGHT]]`
//! (default `docs/images` at 640x400). The bunny comes from `../shared/models`.

use std::path::PathBuf;
use svo::bake::{BakeJob, bake_file as bake};
use svo::render::{RenderJob, render_file as render};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "docs/images".into()));
    let size = args.next().unwrap_or_else(|| "640x400".into());
    let (width, height) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .ok_or_else(|| anyhow::anyhow!("size {size:?} is not WIDTHxHEIGHT"))?;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let svo_path = out.join("pool.svo");
    let job = BakeJob {
        input: root.join("examples/scenes/pool.toml"),
        output: svo_path.clone(),
        options: Default::default(),
        threads: None,
        given: Default::default(),
        memory: None,
    };
    let report = bake(&job)?;
    print!("{report}");
    for view in ["water", "bunny", "parallel"] {
        let job = RenderJob {
            input: svo_path.clone(),
            output: Some(out.join(format!("pool_{view}.png"))),
            width,
            height,
            view: Some(view.into()),
            ..RenderJob::default()
        };
        print!("{}", render(&job)?);
    }
    std::fs::remove_file(&svo_path)?;
    Ok(())
}
