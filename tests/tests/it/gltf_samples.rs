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
        ("GlassBrokenWindow.glb", Expect::Transmissive, 24.8),
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

/// The 3D area of `mesh`'s triangles of material `m`.
fn material_area(mesh: &svo::Mesh, m: usize) -> f64 {
    (0..mesh.triangles.len())
        .filter(|&t| mesh.triangle_materials[t] as usize == m)
        .map(|t| {
            let p = mesh.triangles[t].map(|i| mesh.positions[i as usize]);
            0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
        })
        .sum()
}

/// `TransmissionTest`'s six alpha-masked spheres lose the area of their cut texels: on each
/// masked material the cut's area equals a Monte Carlo estimate over the uncut triangles
/// (64 points a triangle, each kept where its sampled alpha reaches the cutoff, 0.5) within
/// 1% of the material's area, the import's cut is `Mesh::cut_alpha_masks` of the file read
/// as opaque, and the other materials keep every triangle.
fn transmission_test_masks_cut_the_area_of_their_clear_texels() {
    let path = svo_tests::model("gltf/TransmissionTest.glb").unwrap();
    let bytes = std::fs::read(&path).unwrap();
    // The file with its masks turned off: `"alphaMode":"MASK",` blanked (JSON whitespace).
    let key = b"\"alphaMode\":\"MASK\",";
    let mut opaque_bytes = bytes.clone();
    let mut masked_count = 0;
    for i in 0..bytes.len() - key.len() {
        if &bytes[i..i + key.len()] == key {
            opaque_bytes[i..i + key.len()].fill(b' ');
            masked_count += 1;
        }
    }
    assert_eq!(masked_count, 6);
    let cut = svo::Mesh::load(&path).unwrap();
    let opaque = svo::Mesh::from_bytes(&opaque_bytes, svo::MeshFormat::Gltf).unwrap();
    let masked: Vec<usize> = (0..opaque.materials.len())
        .filter(|&m| opaque.materials[m].name.contains("Mask"))
        .collect();
    assert_eq!(masked.len(), 6);
    let mut by_hand = opaque.clone();
    let masks: Vec<(u32, f32)> = masked.iter().map(|&m| (m as u32, 0.5)).collect();
    by_hand.cut_alpha_masks(&masks).unwrap();
    assert_eq!(by_hand.triangles.len(), cut.triangles.len());
    let mut r = svo_tests::seeds::unit_f64(0x7a5c);
    for m in 0..opaque.materials.len() {
        let (before, after) = (material_area(&opaque, m), material_area(&cut, m));
        assert_eq!(after, material_area(&by_hand, m), "material {m}");
        if !masked.contains(&m) {
            assert_eq!(after, before, "material {m} is not masked");
            continue;
        }
        let mat = &opaque.materials[m];
        let tex = &opaque.textures[mat.texture.unwrap()];
        let mut expected = 0.0;
        for t in (0..opaque.triangles.len()).filter(|&t| opaque.triangle_materials[t] as usize == m)
        {
            let p = opaque.triangles[t].map(|i| opaque.positions[i as usize]);
            let uv = opaque.triangle_uvs[t].map(|i| opaque.uvs[i as usize].as_dvec2());
            let a = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
            let kept = (0..64)
                .filter(|_| {
                    let (mut b1, mut b2) = (r(), r());
                    if b1 + b2 > 1.0 {
                        (b1, b2) = (1.0 - b1, 1.0 - b2);
                    }
                    let q = uv[0] * (1.0 - b1 - b2) + uv[1] * b1 + uv[2] * b2;
                    mat.colour[3] * tex.sample_linear(q.as_vec2())[3] >= 0.5
                })
                .count();
            expected += a * kept as f64 / 64.0;
        }
        eprintln!(
            "{} (material {m}): area {before:.4} -> {after:.4}, estimate {expected:.4}",
            mat.name
        );
        assert!(
            (after - expected).abs() < 0.01 * before,
            "material {m}: cut area {after}, estimate {expected}"
        );
        assert!(
            after > 0.05 * before && after < 0.95 * before,
            "material {m}"
        );
    }
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![
        trial!(
            gltf_samples_bake_with_their_materials_and_render_like_their_triangles,
            Need::model("gltf/Box.glb")
        ),
        trial!(
            transmission_test_masks_cut_the_area_of_their_clear_texels,
            Need::model("gltf/TransmissionTest.glb")
        ),
    ]
}
