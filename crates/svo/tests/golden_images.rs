//! Golden images: small renders committed under `fixtures/golden/`, compared with a
//! tolerance (every channel within 2 of 255, and at most 0.1% of pixels beyond that, for
//! libm differences between machines). On failure the render and a diff image are written
//! to `target/golden-diff/` and the test names them.
//!
//! To accept new images after an intended change: `SVO_BLESS=1 cargo test -p svo --test
//! golden_images`, then look at the images before committing them.
#![cfg(all(feature = "obj", feature = "image-io", feature = "reference"))]

use glam::{DVec3, UVec3, Vec3};
use std::path::{Path, PathBuf};
use svo::octree::{Octree, Voxel};
use svo::render::{
    Camera, Frame, OctreeSurfaces, Phong, PointLight, ShadowMode, Sky, TraceOptions, Tracer, render,
};
use svo::trace::HitMode;
use svo::{BakeOptions, RootCube};

fn root_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn torus(depth: u8) -> Octree {
    let mesh = svo::Mesh::load(root_dir().join("fixtures/torus.obj")).unwrap();
    let opts = BakeOptions {
        depth,
        ..BakeOptions::default()
    };
    svo::bake_mesh(&mesh, &opts).unwrap().0
}

/// A small version of the 2019 report's scene: a solid frame with glass panes (holes in
/// their middles), the front left open, a semi-solid cube in the centre, on a mirror floor.
fn report_scene() -> Octree {
    let n = 32u32;
    let root = RootCube {
        origin: DVec3::splat(-1.0),
        side: 2.0,
    };
    let f = |c: UVec3| -> Option<Voxel> {
        let p = (c.as_vec3() + 0.5) / n as f32 * 2.0 - 1.0;
        let a = p.abs();
        let outer = a.max_element() > 0.875;
        if outer {
            let edge = [a.x > 0.875, a.y > 0.875, a.z > 0.875]
                .iter()
                .filter(|&&b| b)
                .count();
            // Edges of the box: the solid frame.
            if edge >= 2 {
                return Some(Voxel::solid([0.6, 0.55, 0.5, 1.0]));
            }
            if p.y < -0.875 {
                return Some(Voxel {
                    reflectivity: 0.6,
                    ..Voxel::solid([0.3, 0.3, 0.35, 1.0])
                });
            }
            if p.z > 0.875 {
                return None;
            }
            // Glass panes with a hole in their middles.
            let (u, v) = if a.x > 0.875 {
                (p.y, p.z)
            } else if a.y > 0.875 {
                (p.x, p.z)
            } else {
                (p.x, p.y)
            };
            if u.abs() < 0.25 && v.abs() < 0.25 {
                return None;
            }
            return Some(Voxel::glass());
        }
        (a.max_element() < 0.25).then(|| Voxel::semi_solid([0.8, 0.2, 0.2, 1.0]))
    };
    Octree::from_fn(root, 5, |_, _| true, f).unwrap()
}

fn render_scene(tree: &Octree, mode: HitMode, eye_dir: DVec3, zoom: f64, bounces: u8) -> Frame {
    let (lo, hi) = tree.occupied_bounds();
    let mut cam = Camera::framing(lo, hi, 96, 72, 40.0);
    let centre = (lo + hi) * 0.5;
    cam.eye = centre + eye_dir * (cam.eye - centre).length() / zoom;
    let light = PointLight {
        position: centre + DVec3::new(0.6, 1.2, 0.9) * (hi - lo).length(),
        colour: Vec3::ONE,
        intensity: (1.5 * (hi - lo).length()).powi(2) as f32,
    };
    let t = Tracer::new(
        OctreeSurfaces::new(tree, mode),
        &[light],
        Sky::default(),
        Phong::default(),
        TraceOptions {
            mode,
            max_reflections: bounces,
            max_refractions: bounces,
            shadows: ShadowMode::Transmittance,
            ..TraceOptions::default()
        },
    );
    render(&t, &cam).unwrap()
}

fn check(name: &str, f: &Frame) {
    let rgb = svo::render::colour_rgb8(f);
    let path = root_dir()
        .join("fixtures/golden")
        .join(format!("{name}.png"));
    if std::env::var_os("SVO_BLESS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        image::save_buffer(&path, &rgb, f.width, f.height, image::ColorType::Rgb8).unwrap();
        eprintln!("blessed {}", path.display());
        return;
    }
    let golden = image::open(&path)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e} (run with SVO_BLESS=1 to create it)",
                path.display()
            )
        })
        .to_rgb8();
    assert_eq!(
        (golden.width(), golden.height()),
        (f.width, f.height),
        "{name}: size"
    );
    let g = golden.as_raw();
    let mut worst = 0u8;
    let mut beyond = 0usize;
    for (px_a, px_b) in rgb.chunks(3).zip(g.chunks(3)) {
        let d = px_a
            .iter()
            .zip(px_b)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap_or(0);
        worst = worst.max(d);
        beyond += usize::from(d > 2);
    }
    let pixels = (f.width * f.height) as usize;
    if beyond * 1000 > pixels {
        let out = root_dir().join("target/golden-diff");
        std::fs::create_dir_all(&out).unwrap();
        let actual = out.join(format!("{name}.actual.png"));
        let diff = out.join(format!("{name}.diff.png"));
        image::save_buffer(&actual, &rgb, f.width, f.height, image::ColorType::Rgb8).unwrap();
        let d: Vec<u8> = rgb
            .iter()
            .zip(g)
            .map(|(a, b)| a.abs_diff(*b).saturating_mul(8))
            .collect();
        image::save_buffer(&diff, &d, f.width, f.height, image::ColorType::Rgb8).unwrap();
        panic!(
            "{name}: {beyond} of {pixels} pixels differ by more than 2 (worst {worst}); wrote {} and {}",
            actual.display(),
            diff.display()
        );
    }
}

#[test]
fn golden_torus_contour() {
    let t = torus(6);
    check(
        "torus_contour",
        &render_scene(
            &t,
            HitMode::Contour,
            DVec3::new(0.35, 0.6, 1.0).normalize(),
            1.5,
            2,
        ),
    );
}

#[test]
fn golden_torus_cube() {
    let t = torus(6);
    check(
        "torus_cube",
        &render_scene(
            &t,
            HitMode::Cube,
            DVec3::new(0.35, 0.6, 1.0).normalize(),
            1.5,
            2,
        ),
    );
}

#[test]
fn golden_report_scene_with_reflections_and_refractions() {
    let t = report_scene();
    let f = render_scene(
        &t,
        HitMode::Cube,
        DVec3::new(0.3, 0.35, 1.0).normalize(),
        1.0,
        3,
    );
    assert!(f.stats.secondary_rays > 1000, "{:?}", f.stats);
    check("report_scene", &f);
}
