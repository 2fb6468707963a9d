//! Numerical stability of the tracer on extreme inputs: a mesh far from the origin
//! (georeferenced, 1e6-1e7) and at micro and mega scales renders the same image as at the
//! origin (measured: 80-83 dB PSNR, the same pixels hit; the test asks for 70 dB); empty, one-level and very deep trees render without trouble; a camera inside the
//! model and one looking straight along an axis (zero direction components everywhere) work.
#![cfg(all(feature = "obj", feature = "image-io", feature = "reference"))]

use glam::{DVec3, UVec3, Vec3};
use svo::octree::{Octree, Voxel};
use svo::render::{
    Camera, Frame, OctreeSurfaces, Phong, PointLight, Sky, TraceOptions, Tracer, render,
};
use svo::trace::HitMode;
use svo::{BakeOptions, Mesh, RootCube, bake_mesh};

fn torus() -> Mesh {
    let p = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/torus.obj");
    Mesh::load(std::path::Path::new(p)).unwrap()
}

/// Renders `tree` from a camera placed relative to the model's bounds (so transformed
/// copies of a scene get the transformed camera), with a light placed the same way.
fn shoot(tree: &Octree, mode: HitMode) -> Frame {
    shoot_lit(tree, mode, true)
}

/// [`shoot`], with the light or without any.
fn shoot_lit(tree: &Octree, mode: HitMode, lit: bool) -> Frame {
    let (lo, hi) = tree.occupied_bounds();
    let cam = Camera::framing(lo, hi, 64, 48, 40.0);
    let size = (hi - lo).length();
    let light = PointLight {
        position: cam.eye + DVec3::new(0.3, 1.0, 0.2) * size,
        colour: Vec3::ONE,
        intensity: (2.0 * size * size) as f32,
    };
    let lights = if lit { &[light][..] } else { &[] };
    let t = Tracer::new(
        OctreeSurfaces::new(tree, mode),
        lights,
        Sky::default(),
        Phong::default(),
        TraceOptions {
            mode,
            ..TraceOptions::default()
        },
    );
    render(&t, &cam).unwrap()
}

fn transformed(m: &Mesh, scale: f64, offset: DVec3) -> Mesh {
    let mut m = m.clone();
    for p in &mut m.positions {
        *p = *p * scale + offset;
    }
    m
}

fn bake(m: &Mesh, depth: u8) -> Octree {
    let opts = BakeOptions {
        depth,
        ..BakeOptions::default()
    };
    bake_mesh(m, &opts).unwrap().0
}

#[test]
fn far_from_the_origin_and_at_extreme_scales_the_image_is_the_same() {
    let base = torus();
    let reference = shoot(&bake(&base, 6), HitMode::Contour);
    assert!(reference.stats.primary_hits > 300);
    for (scale, offset) in [
        (1.0, DVec3::new(3.2e6, 5.1e6, 120.0)),
        (1.0, DVec3::new(-7.5e6, 2.5e6, -4.0e6)),
        (1e-6, DVec3::ZERO),
        (1e6, DVec3::ZERO),
        (1e-3, DVec3::new(4.0e6, 0.0, 4.0e6)),
    ] {
        let f = shoot(
            &bake(&transformed(&base, scale, offset), 6),
            HitMode::Contour,
        );
        assert_eq!(f.stats.capped, 0);
        let d = svo::render::compare(&f, &reference).unwrap();
        assert!(
            d.psnr_db > 70.0 && d.hit_mismatch == 0.0,
            "scale {scale} offset {offset}: PSNR {} dB, hit/miss {}",
            d.psnr_db,
            d.hit_mismatch
        );
        assert!(f.colour.iter().all(|c| c.is_finite()) && f.depth.iter().all(|t| !t.is_nan()));
    }
}

/// Roots far larger and smaller than any scene (1e20, 3e21, 1e-20 and 1e-30 times the torus):
/// the grid-space direction of a normalized scene ray is then tiny (about `2^6 / 1e20` per
/// component at 1e20) or huge. The same pixels hit, at the same distance in the root's units
/// to `1e-5` (no lights: at these scales the `f32` light falloff itself over- or underflows).
#[test]
fn roots_1e20_across_and_1e_20_hit_the_same_pixels_at_the_same_depth() {
    let base = torus();
    let depth_of = |m: &Mesh| {
        let f = shoot_lit(&bake(m, 6), HitMode::Contour, false);
        assert_eq!(f.stats.capped, 0);
        f.depth
    };
    let reference = depth_of(&base);
    assert!(reference.iter().filter(|t| t.is_finite()).count() > 300);
    for scale in [1e20, 3e21, 1e-20, 1e-30] {
        let d = depth_of(&transformed(&base, scale, DVec3::ZERO));
        for (i, (a, b)) in d.iter().zip(&reference).enumerate() {
            assert_eq!(
                a.is_finite(),
                b.is_finite(),
                "scale {scale}: pixel {i} hit/miss"
            );
            if b.is_finite() {
                let a = f64::from(*a) / scale;
                assert!(
                    (a - f64::from(*b)).abs() <= 1e-5 * f64::from(*b),
                    "scale {scale}: pixel {i} at {a}, not {b}"
                );
            }
        }
    }
}

#[test]
fn empty_shallow_and_deep_trees() {
    let root = RootCube {
        origin: DVec3::ZERO,
        side: 1.0,
    };
    // No leaves: all sky.
    let empty = Octree::from_cells(root, 3, std::iter::empty()).unwrap();
    let cam = Camera {
        eye: DVec3::new(0.5, 0.5, 3.0),
        target: DVec3::splat(0.5),
        up: DVec3::Y,
        fov_deg: 60.0,
        width: 16,
        height: 16,
    };
    let t = Tracer::new(
        OctreeSurfaces::new(&empty, HitMode::Cube),
        &[],
        Sky::default(),
        Phong::default(),
        TraceOptions::default(),
    );
    let f = render(&t, &cam).unwrap();
    assert_eq!(f.stats.primary_hits, 0);
    // Depth 1 with one cell, and depth 24 with a few cells around the middle: both hit.
    for (depth, cells) in [
        (1u8, vec![UVec3::new(1, 1, 0)]),
        (
            24,
            (0..8u32)
                .map(|i| UVec3::splat(1 << 23) + UVec3::new(i & 1, i >> 1 & 1, i >> 2))
                .collect(),
        ),
    ] {
        let tree = Octree::from_cells(
            root,
            depth,
            cells.into_iter().map(|c| (c, Voxel::default())),
        )
        .unwrap();
        let (lo, hi) = tree.occupied_bounds();
        let cam = Camera::framing(lo, hi, 16, 16, 40.0);
        let t = Tracer::new(
            OctreeSurfaces::new(&tree, HitMode::Cube),
            &[],
            Sky::default(),
            Phong::default(),
            TraceOptions::default(),
        );
        let f = render(&t, &cam).unwrap();
        assert!(
            f.stats.primary_hits > 0 && f.stats.capped == 0,
            "depth {depth}: {:?}",
            f.stats
        );
        // The centre pixel looks at the middle of the cells: a hit.
        assert_ne!(f.leaf[8 * 16 + 8], svo::render::NO_LEAF, "depth {depth}");
    }
}

#[test]
fn camera_inside_the_model_and_axis_aligned_views() {
    let tree = bake(&torus(), 6);
    let (lo, hi) = tree.occupied_bounds();
    let c = (lo + hi) * 0.5;
    let r = (hi - lo).max_element() * 0.5;
    // Inside the tube of the torus (the ring lies in the y = 0 plane around the centre), and
    // looking straight along each axis from outside: every direction component of the
    // central rays is an exact zero.
    let inside = c + DVec3::new(r * 0.75, 0.0, 0.0);
    for (eye, target, up) in [
        (inside, inside + DVec3::Z, DVec3::Y),
        (c + DVec3::Z * 4.0 * r, c, DVec3::Y),
        (c - DVec3::X * 4.0 * r, c, DVec3::Y),
        (c + DVec3::Y * 4.0 * r, c, DVec3::Z),
    ] {
        let cam = Camera {
            eye,
            target,
            up,
            fov_deg: 50.0,
            width: 33,
            height: 33,
        };
        for mode in [HitMode::Cube, HitMode::Contour] {
            let t = Tracer::new(
                OctreeSurfaces::new(&tree, mode),
                &[],
                Sky::default(),
                Phong::default(),
                TraceOptions::default(),
            );
            let f = render(&t, &cam).unwrap();
            assert_eq!(f.stats.capped, 0);
            assert!(f.colour.iter().all(|c| c.is_finite()));
            assert!(f.stats.primary_hits > 0, "{eye} -> {target}: {:?}", f.stats);
            // Depths are positive where there is a hit.
            assert!(f.depth.iter().all(|&t| t >= 0.0));
        }
    }
}
