//! The 2019 report's voxel box (`svo_examples::report2019`, built through the library's
//! programmatic builder) has the report's regions, and renders with its three lights.

use glam::{UVec3, Vec3};
use std::collections::BTreeMap;
use svo::render::{OctreeSurfaces, Phong, ShadowMode, Sky, TraceOptions, Tracer, render};
use svo::trace::HitMode;
use svo_examples::report2019::{ReportMaterial, report_material, report_scene};
use svo_tests::harness::Test;
use svo_tests::trial;

fn report_box_has_the_reports_regions() {
    let depth = 5;
    let n = 32u32;
    let scene = report_scene(depth, 64, 64).unwrap();
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for leaf in scene.tree.leaves() {
        let v = scene.tree.attributes.get(leaf.index as usize);
        let kind = match (v.refractivity, v.reflectivity) {
            (Some(t), _) if t > 0.7 => "glass",
            (Some(t), _) if t > 0.1 => "semi-solid",
            _ => "solid",
        };
        *counts.entry(kind).or_default() += 1;
        assert_eq!(
            report_material(leaf.cell, n).map(|m| m == ReportMaterial::Glass),
            Some(kind == "glass"),
            "{:?}",
            leaf.cell
        );
    }
    // The centre cube: radius 12.5% of 16 cells is 2 cells each way, 4^3 cells.
    assert_eq!(counts["semi-solid"], 64);
    // The frame: on each face a ring 2 cells wide (|u| > 87.5%), the box's edges included.
    // Faces: 6 x (32^2 - 28^2) ring cells, minus the edges counted twice (12 edges of 32
    // cells, each on 2 faces) plus the corners counted three times once more (8).
    let ring = 6 * (32 * 32 - 28 * 28);
    assert_eq!(counts["solid"], ring - 12 * 32 + 8);
    // Glass: five faces (none at the front) of 28^2 pane cells minus a 8^2 hole each
    // (|u| <= 25%: 4 cells each way), minus the pane cells on the box's edges (none: the
    // panes are inside the rings).
    assert_eq!(counts["glass"], 5 * (28 * 28 - 8 * 8));
    // The front face's middle is open and the back face's middle is a hole.
    for c in [
        UVec3::new(16, 16, n - 1),
        UVec3::new(16, 16, 0),
        UVec3::new(5, 16, n - 1),
    ] {
        assert!(scene.tree.leaf_at(c).is_none(), "{c:?}");
    }
    assert!(scene.tree.leaf_at(UVec3::new(5, 16, 0)).is_some());
}

fn report_scene_renders_with_its_three_lights() {
    let scene = report_scene(5, 96, 96).unwrap();
    let black = Sky {
        zenith: Vec3::ZERO,
        horizon: Vec3::ZERO,
        ground: Vec3::ZERO,
        ..Sky::default()
    };
    let opts = TraceOptions {
        max_reflections: 4,
        max_refractions: 4,
        shadows: ShadowMode::Transmittance,
        ..TraceOptions::default()
    };
    let phong = Phong {
        ambient: 0.0,
        ..Phong::default()
    };
    let tracer = Tracer::new(
        OctreeSurfaces::new(&scene.tree, HitMode::Cube),
        &scene.lights,
        black.clone(),
        phong,
        opts,
    );
    let frame = render(&tracer, &scene.camera).unwrap();
    // The centre pixel's ray passes the open front and meets the semi-solid cube's front
    // face at z = 0.125 (scene units; the root is [-1, 1]^3).
    let (w, h) = (scene.camera.width, scene.camera.height);
    let i = (h / 2 * w + w / 2) as usize;
    let dir = scene.camera.rays().unwrap().dir(w / 2, h / 2);
    let hit = scene.camera.eye + dir * f64::from(frame.depth[i]);
    assert!((hit.z - 0.125).abs() < 1e-3, "centre ray met {hit}");
    assert!(
        hit.x.abs() < 0.125 && hit.y.abs() < 0.125,
        "centre ray met {hit}"
    );
    // With no ambient light and a black sky, every colour comes from the lights: each one
    // alone lights part of the image in its own colour, and all three together are the sum.
    let total: Vec3 = frame.colour.iter().sum();
    let mut sum_alone = Vec3::ZERO;
    for (i, light) in scene.lights.iter().enumerate() {
        let t = Tracer::new(
            OctreeSurfaces::new(&scene.tree, HitMode::Cube),
            std::slice::from_ref(light),
            black.clone(),
            phong,
            opts,
        );
        let f = render(&t, &scene.camera).unwrap();
        let s: Vec3 = f.colour.iter().sum();
        assert!(s.max_element() > 0.5, "light {i} lights nothing: {s}");
        // The light's own colour dominates what it lights (the box is white).
        let dominant = light.colour.max_position();
        assert_eq!(s.max_position(), dominant, "light {i}: {s}");
        sum_alone += s;
    }
    assert!(
        (total - sum_alone).abs().max_element() <= 1e-3 * total.max_element(),
        "{total} vs {sum_alone}"
    );
}

/// The committed `examples/scenes/report2019.svo` (written by `examples/report_scene.rs`) is
/// exactly what the library builds today, and renders from its stored view and lights.
fn committed_report_scene_file_is_current_and_renders_its_view() {
    let path = svo_tests::repo_root().join("examples/scenes/report2019.svo");
    let committed = std::fs::read(&path).unwrap();
    let scene = report_scene(6, 512, 512).unwrap();
    let build = svo::io::BuildInfo {
        generator: "report_scene example".into(),
        strategy: "builder".into(),
        scene: scene.scene_info(),
        ..Default::default()
    };
    assert!(
        svo::io::to_bytes(&scene.tree, &build) == committed,
        "examples/scenes/report2019.svo is stale: rerun `cargo run --release -p svo-examples \
         --example report_scene -- examples/scenes/report2019.svo docs/images/report_scene.png`"
    );
    let setup = svo::render::SceneSetup {
        width: 64,
        height: 64,
        ..Default::default()
    };
    let s = svo::render::RenderScene::open(&path, &setup).unwrap();
    assert_eq!(s.camera.eye, scene.camera.eye);
    assert_eq!(s.camera.fov_deg, scene.camera.fov_deg);
    assert_eq!(s.lights, scene.lights);
    let t = Tracer::new(
        OctreeSurfaces::new(&s.tree, HitMode::Cube),
        &s.lights,
        s.sky.clone(),
        s.phong,
        TraceOptions::default(),
    );
    let f = render(&t, &s.camera).unwrap();
    assert!(f.stats.primary_hits > 64 * 64 / 3, "{:?}", f.stats);
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![
        trial!(report_box_has_the_reports_regions),
        trial!(report_scene_renders_with_its_three_lights),
        trial!(committed_report_scene_file_is_current_and_renders_its_view),
    ]
}
