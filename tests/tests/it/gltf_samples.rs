//! The glTF samples in `../shared/models/gltf` bake with sensible materials (transmission as
//! refractivity, metal as reflectivity, textures as per-leaf colours) and render believably:
//! the octree's image against the triangle reference's, same camera, lights and shading,
//! within a PSNR floor and a hit/miss disagreement ceiling (figures printed; the floors sit
//! below what depth 6 gives, see docs/scenes.md).

use std::path::PathBuf;
use svo::render::{
    MeshSurfaces, OctreeSurfaces, RenderScene, SceneSetup, TraceOptions, Tracer, render,
};
use svo::trace::HitMode;
use svo_tests::harness::{Need, Test};
use svo_tests::trial;

/// The glTF samples' folder, when they are there.
fn gltf_dir() -> Option<PathBuf> {
    Some(svo_tests::model("gltf/Box.glb")?.with_file_name(""))
}

/// What each sample's leaves must show.
#[derive(Clone, Copy, Debug)]
enum Expect {
    Plain,
    Transmissive,
    Metallic,
    Textured,
}

fn gltf_samples_bake_with_their_materials_and_render_like_their_triangles() {
    let Some(dir) = gltf_dir() else { return };
    let samples = [
        ("Box.glb", Expect::Plain, 32.0),
        ("Box_glTF/Box.gltf", Expect::Plain, 32.0),
        ("MetalRoughSpheresNoTextures.glb", Expect::Metallic, 25.0),
        ("DamagedHelmet.glb", Expect::Textured, 18.0),
        ("TransmissionTest.glb", Expect::Transmissive, 23.0),
        ("TransmissionRoughnessTest.glb", Expect::Transmissive, 17.0),
        ("AttenuationTest.glb", Expect::Transmissive, 22.0),
        ("GlassBrokenWindow.glb", Expect::Transmissive, 25.0),
        ("GlassHurricaneCandleHolder.glb", Expect::Transmissive, 20.0),
        ("GlassVaseFlowers.glb", Expect::Transmissive, 17.0),
    ];
    let depth = 6;
    for (name, expect, min_psnr) in samples {
        let mesh = svo::Mesh::load(dir.join(name)).unwrap();
        let opts = svo::BakeOptions {
            depth,
            ..svo::BakeOptions::default()
        };
        let (tree, _) = svo::bake_mesh(&mesh, &opts).unwrap();
        let a = &tree.attributes;
        let n = tree.leaf_count as usize;
        let share = |f: &dyn Fn(usize) -> bool| (0..n).filter(|&i| f(i)).count() as f64 / n as f64;
        match expect {
            Expect::Plain => {}
            Expect::Transmissive => {
                let t = share(&|i| a.refractivity.get(i).is_some_and(|v| v > 128));
                assert!(t > 0.02, "{name}: {t} of the leaves refract");
            }
            Expect::Metallic => {
                let r = share(&|i| a.reflectivity.get(i).is_some_and(|v| v > 128));
                assert!(r > 0.05, "{name}: {r} of the leaves reflect");
            }
            Expect::Textured => {
                let mut colours: Vec<u32> = (0..n).filter_map(|i| a.colour.get(i)).collect();
                colours.sort_unstable();
                colours.dedup();
                assert!(
                    a.colour.is_per_leaf() && colours.len() > 500,
                    "{name}: {} colours",
                    colours.len()
                );
            }
        }
        let trace = TraceOptions {
            mode: HitMode::Contour,
            ..TraceOptions::default()
        };
        let setup = SceneSetup {
            width: 96,
            height: 72,
            ..SceneSetup::default()
        };
        let s = RenderScene::new(tree, &Default::default(), &setup).unwrap();
        let ours = render(
            &Tracer::new(
                OctreeSurfaces::new(&s.tree, HitMode::Contour),
                &s.lights,
                s.sky.clone(),
                s.phong,
                trace,
            ),
            &s.camera,
        )
        .unwrap();
        let reference = render(
            &Tracer::new(
                MeshSurfaces::new(mesh, s.tree.root, depth),
                &s.lights,
                s.sky.clone(),
                s.phong,
                trace,
            ),
            &s.camera,
        )
        .unwrap();
        let d = svo::render::compare(&ours, &reference).unwrap();
        eprintln!(
            "{name}: {} leaves, PSNR {:.1} dB, RMSE {:.2}, hit/miss differ on {:.2}%",
            n,
            d.psnr_db,
            d.rmse,
            100.0 * d.hit_mismatch
        );
        assert!(
            ours.stats.primary_hits > 200 && ours.stats.capped == 0,
            "{name}: {:?}",
            ours.stats
        );
        assert!(ours.colour.iter().all(|c| c.is_finite()), "{name}");
        assert!(
            d.psnr_db >= min_psnr,
            "{name}: PSNR {:.1} dB < {min_psnr}",
            d.psnr_db
        );
        assert!(
            d.hit_mismatch < 0.03,
            "{name}: hit/miss differ on {}",
            d.hit_mismatch
        );
    }
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![trial!(
        gltf_samples_bake_with_their_materials_and_render_like_their_triangles,
        Need::model("gltf/Box.glb")
    )]
}
