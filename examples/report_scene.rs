//! The 2019 report's scene (glass panes in a solid frame, void holes, a semi-solid centre
//! cube, three coloured point lights), built through the programmatic API
//! (`svo_examples::report2019`), saved as an `.svo` file with its lights and camera, and ray
//! traced on the CPU at the report's settings (512 x 512, four reflections and four
//! refractions).
//!
//! `cargo run --release -p svo-examples --example report_scene -- report.svo report.png`
//! (the committed `examples/scenes/report2019.svo` and `docs/images/report_scene.png` are
//! its output; a test checks the file is what the library builds today).

use std::path::PathBuf;
use svo::io::BuildInfo;
use svo::render::{OctreeSurfaces, Phong, ShadowMode, Sky, TraceOptions, Tracer, render};
use svo::trace::HitMode;
use svo_examples::report2019::report_scene;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let svo_path = PathBuf::from(args.next().unwrap_or_else(|| "report.svo".into()));
    let png_path = PathBuf::from(args.next().unwrap_or_else(|| "report.png".into()));
    let scene = report_scene(6, 512, 512)?;
    println!(
        "{} leaves, {} nodes; {} lights",
        scene.tree.leaf_count,
        scene.tree.nodes.len(),
        scene.lights.len()
    );
    // The lights and the camera go into the file, so `svo-view report.svo` shows this view.
    let build = BuildInfo {
        generator: "report_scene example".into(),
        strategy: "builder".into(),
        scene: scene.scene_info(),
        ..BuildInfo::default()
    };
    svo::io::write_file(&scene.tree, &build, &svo_path)?;
    let dark = Sky {
        zenith: glam::Vec3::splat(0.02),
        horizon: glam::Vec3::splat(0.05),
        ground: glam::Vec3::splat(0.01),
        ..Sky::default()
    };
    let tracer = Tracer::new(
        OctreeSurfaces::new(&scene.tree, HitMode::Cube),
        &scene.lights,
        dark,
        Phong::default(),
        TraceOptions {
            max_reflections: 4,
            max_refractions: 4,
            shadows: ShadowMode::Transmittance,
            ..TraceOptions::default()
        },
    );
    let frame = render(&tracer, &scene.camera)?;
    let rgb = svo::render::colour_rgb8(&frame);
    svo::render::write_png(&png_path, frame.width, frame.height, &rgb)?;
    println!(
        "{} -> {} ({:.0} ms)",
        svo_path.display(),
        png_path.display(),
        frame.elapsed.as_secs_f64() * 1e3
    );
    Ok(())
}
