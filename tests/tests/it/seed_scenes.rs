//! The thesis's scene from its committed scene file (`examples/scenes/pool.toml`): it loads,
//! bakes with its lights and three views stored, and each view shows what the thesis's
//! figure shows: the water view sees water in every pixel (and reflects and refracts), the
//! bunny view sees the bunny in every pixel, the parallel view (inside the hollow bunny) sees
//! only the bunny and costs more traversal steps per ray than the bunny view.

use svo::render::{NO_LEAF, OctreeSurfaces, RenderScene, SceneSetup, TraceOptions, Tracer, render};
use svo_tests::harness::{Need, Test};
use svo_tests::trial;

fn pool_scene_bakes_and_its_three_views_show_what_the_thesis_shows() {
    let Some(path) = svo_tests::pool_scene() else {
        return;
    };
    let scene = svo::scene::load_scene(&path).unwrap();
    assert_eq!(scene.depth, Some(8));
    let names: Vec<&str> = scene.info.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["water", "bunny", "parallel"]);
    assert_eq!(scene.info.lights.len(), 1);
    // Depth 6 keeps the test quick; the views are the file's.
    let opts = svo::BakeOptions {
        depth: 6,
        ..svo::BakeOptions::default()
    };
    let (tree, _) = svo::bake_mesh(&scene.mesh, &opts).unwrap();
    // The file round trip keeps the lights and views.
    let build = svo::io::BuildInfo {
        scene: scene.info.clone(),
        ..Default::default()
    };
    let bytes = svo::io::to_bytes(&tree, &build);
    let (tree, build) = svo::io::from_bytes(&bytes).unwrap();
    assert_eq!(build.scene, scene.info);

    let a = &tree.attributes;
    let is_water = |leaf: u32| a.refractivity.get(leaf as usize).is_some_and(|t| t > 200);
    // The clay bunny: red clearly above blue, opaque.
    let is_bunny = |leaf: u32| {
        let c = a.colour.get(leaf as usize).unwrap_or(0).to_le_bytes();
        u16::from(c[0]) > u16::from(c[2]) + 40 && a.refractivity.get(leaf as usize) == Some(0)
    };
    let mut steps = Vec::new();
    for view in ["water", "bunny", "parallel"] {
        let setup = SceneSetup {
            width: 64,
            height: 40,
            view: Some(view.into()),
            ..SceneSetup::default()
        };
        let trace = TraceOptions::default();
        let s = RenderScene::new(tree.clone(), &build.scene, &setup).unwrap();
        // Every stored view is offered (the window steps through them with V).
        let offered: Vec<&str> = s.views.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(offered, ["water", "bunny", "parallel"]);
        assert_eq!(s.views.iter().find(|(n, _)| n == view).unwrap().1, s.camera);
        let tracer = Tracer::new(
            OctreeSurfaces::new(&s.tree, trace.mode),
            &s.lights,
            s.sky.clone(),
            s.phong,
            trace,
        );
        let f = render(&tracer, &s.camera).unwrap();
        let n = f.leaf.len();
        assert!(
            f.leaf.iter().all(|&l| l != NO_LEAF),
            "{view}: a pixel sees the sky"
        );
        let share = |pred: &dyn Fn(u32) -> bool| {
            f.leaf.iter().filter(|&&l| pred(l)).count() as f64 / n as f64
        };
        match view {
            "water" => {
                assert!(
                    share(&is_water) > 0.97,
                    "{view}: water {}",
                    share(&is_water)
                );
                assert!(f.stats.secondary_rays >= 2 * n as u64, "{:?}", f.stats);
            }
            _ => assert!(
                share(&is_bunny) > 0.97,
                "{view}: bunny {}",
                share(&is_bunny)
            ),
        }
        steps.push(f.cost.iter().map(|&c| f64::from(c)).sum::<f64>() / n as f64);
    }
    assert!(
        steps[2] > steps[1],
        "steps per ray: bunny {}, parallel {}",
        steps[1],
        steps[2]
    );
}

/// Needs the `csg` feature (the Manifold kernel's C++ build).
#[cfg(feature = "csg")]
fn csg_scene_file_bakes_solid_with_its_bowl_hollowed_out() {
    let root = svo_tests::repo_root();
    let scene = svo::scene::load_scene(&root.join("examples/scenes/csg.toml")).unwrap();
    assert_eq!(scene.solid, Some(svo::bake::SolidMode::Closed));
    // The result and the floor are closed: the solid bake accepts them.
    assert_eq!(scene.mesh.open_edges(), 0);
    let opts = svo::BakeOptions {
        depth: 6,
        solid: scene.solid,
        ..svo::BakeOptions::default()
    };
    let (tree, stats) = svo::bake_mesh(&scene.mesh, &opts).unwrap();
    assert!(stats.interior_leaves > 1000, "{}", stats.interior_leaves);
    let cell = |p: glam::DVec3| {
        let g = tree.root.to_grid(p, tree.depth).floor();
        glam::UVec3::new(g.x as u32, g.y as u32, g.z as u32)
    };
    let filled = |p| tree.leaf_at(cell(p)).is_some();
    // Inside the rounded cube: filled; in the bowl and beyond the rounded corners: empty.
    assert!(filled(glam::DVec3::new(0.0, -0.3, 0.0)));
    assert!(filled(glam::DVec3::new(0.7, 0.2, 0.0)));
    assert!(!filled(glam::DVec3::new(0.0, 0.85, 0.0)));
    assert!(!filled(glam::DVec3::new(0.95, 0.95, 0.95)));
    // The floor under it.
    assert!(filled(glam::DVec3::new(2.0, -1.15, 2.0)));
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    #[allow(unused_mut)]
    let mut v = vec![trial!(
        pool_scene_bakes_and_its_three_views_show_what_the_thesis_shows,
        Need::pool_scene()
    )];
    #[cfg(feature = "csg")]
    v.push(trial!(
        csg_scene_file_bakes_solid_with_its_bowl_hollowed_out
    ));
    v
}
