//! The 2015 thesis's scene from its committed scene file (`examples/scenes/pool.toml`): the
//! Stanford bunny submerged in a pool of water. Loads the scene, bakes it at the file's depth,
//! then renders the three camera views stored in the file (water, bunny, parallel) on the CPU
//! tracer, as `svo-bake examples/scenes/pool.toml -o pool.svo` and
//! `svo-view pool.svo --cpu --view NAME` do.
//!
//! `cargo run --release -p svo-examples --example pool_scene -- [OUT_DIR [WIDTHxHEIGHT]]`
//! (default `docs/images` at 640x400). The bunny comes from `../shared/models`.

use std::path::PathBuf;
use svo::render::{
    OctreeSurfaces, RenderScene, SceneSetup, TraceOptions, Tracer, colour_rgb8, render, write_png,
};
use svo::{BakeOptions, bake_mesh};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "docs/images".into()));
    let size = args.next().unwrap_or_else(|| "640x400".into());
    let (width, height) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .ok_or_else(|| anyhow::anyhow!("size {size:?} is not WIDTHxHEIGHT"))?;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let scene = svo::scene::load_scene(&root.join("examples/scenes/pool.toml"))?;
    let opts = BakeOptions {
        depth: scene.depth.unwrap_or(8),
        ..BakeOptions::default()
    };
    let (tree, stats) = bake_mesh(&scene.mesh, &opts)?;
    println!(
        "pool: {} triangles, depth {}, {} leaves in {:.0} ms",
        stats.triangles,
        stats.depth,
        stats.leaves,
        (stats.voxelize_s + stats.attributes_s + stats.contours_s) * 1e3
    );
    for view in ["water", "bunny", "parallel"] {
        let setup = SceneSetup {
            width,
            height,
            view: Some(view.into()),
            ..SceneSetup::default()
        };
        let s = RenderScene::new(tree.clone(), &scene.info, &setup)?;
        let trace = TraceOptions::default();
        let tracer = Tracer::new(
            OctreeSurfaces::new(&s.tree, trace.mode),
            &s.lights,
            s.sky.clone(),
            s.phong,
            trace,
        );
        let frame = render(&tracer, &s.camera)?;
        let path = out.join(format!("pool_{view}.png"));
        write_png(&path, width, height, &colour_rgb8(&frame))?;
        println!(
            "{view}: {} in {:.0} ms",
            path.display(),
            frame.elapsed.as_secs_f64() * 1e3
        );
    }
    Ok(())
}
