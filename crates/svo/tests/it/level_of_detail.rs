//! Rays with a footprint: a walk that may stop at an inner node as wide as the ray's cone.
//!
//! A node's contour encloses its subtree's surface (and its cube its leaves), so a ray that
//! meets some leaf's surface meets the node's slab no later: the walk with a footprint hits
//! no later than the exact walk, never misses what it hits, and stops only at nodes no wider
//! than the cone where it stops. Renders with a footprint come close to the exact image with
//! fewer steps, walk the same with and without packets, and start their secondary rays off a
//! node without meeting it again.
#![cfg(all(feature = "image-io", feature = "reference"))]

use crate::common::rng;
use glam::{DVec3, Vec3};
use rand::Rng;
use svo::render::{
    Camera, NODE_ID, OctreeSurfaces, Phong, PointLight, Query, Sky, Surfaces, TraceOptions, Tracer,
    compare, render,
};
use svo::trace::{Cone, GridRay, LeafEntry, MAX_STEPS, traverse, traverse_cone};
use svo::{BakeOptions, HitMode, Material, Mesh, Octree, bake_mesh};

/// A sphere and a smaller, red, shinier one beside it: per-leaf normals, contours, colours
/// and reflectivity, with inner-node attributes.
fn scene(depth: u8) -> Octree {
    let mut m = Mesh::sphere(DVec3::new(0.3, 0.5, 0.5), 0.25, 24);
    let mut t = Mesh::sphere(DVec3::new(0.75, 0.45, 0.55), 0.2, 12);
    t.materials = vec![Material {
        colour: [0.9, 0.1, 0.2, 1.0],
        reflectivity: 0.4,
        ..Default::default()
    }];
    t.triangle_materials = vec![0; t.triangles.len()];
    m.append(t);
    let opts = BakeOptions {
        depth,
        node_attributes: true,
        ..Default::default()
    };
    bake_mesh(&m, &opts).unwrap().0
}

/// A seeded ray from outside the tree toward a point inside its occupied box, in grid
/// units; every eighth axis-parallel, some with `-0.0` components.
fn ray(r: &mut impl Rng, tree: &Octree) -> GridRay {
    let n = (1u32 << tree.depth) as f32;
    let target = Vec3::new(
        r.random_range(0.2..0.95),
        r.random_range(0.2..0.8),
        r.random_range(0.2..0.8),
    ) * n;
    if r.random_range(0..8) == 0 {
        let axis = r.random_range(0..3);
        let sign = if r.random() { 1.0 } else { -1.0 };
        let mut dir = Vec3::splat(if r.random() { 0.0 } else { -0.0 });
        dir[axis] = sign;
        return GridRay {
            origin: target - dir * 2.0 * n,
            dir,
        };
    }
    let dir = Vec3::new(
        r.random_range(-1.0..1.0),
        r.random_range(-1.0..1.0),
        r.random_range(-1.0..1.0),
    )
    .normalize_or(Vec3::X);
    GridRay {
        origin: target - dir * 2.0 * n,
        dir,
    }
}

/// The exact and the footprint walk of many seeded rays, under random cones: the footprint
/// hit comes no later than the exact one (up to the rounding of the scaled contour planes),
/// it hits wherever the exact walk does, and a node it stops at is no wider than the cone
/// where the ray meets it, at least 4 cells wide and a power of two.
#[test]
fn a_walk_with_a_footprint_hits_no_later_than_the_exact_walk() {
    let tree = scene(7);
    for mode in [HitMode::Contour, HitMode::Cube] {
        let s = OctreeSurfaces::new(&tree, mode);
        assert!(s.level_of_detail());
        let mut r = rng(58_001);
        let (mut node_hits, mut hits) = (0, 0);
        for i in 0..20_000 {
            let ray = ray(&mut r, &tree);
            let cone = Cone {
                width: r.random_range(0.0..12.0),
                spread: if i % 2 == 0 {
                    r.random_range(0.0..0.05)
                } else {
                    0.0
                },
            };
            let exact = s.closest(&ray, &Query::all(MAX_STEPS));
            let coarse = s.closest(
                &ray,
                &Query {
                    cone,
                    ..Query::all(MAX_STEPS)
                },
            );
            assert!(!exact.capped && !coarse.capped);
            let Some(e) = exact.hit else {
                continue;
            };
            hits += 1;
            let c = coarse.hit.unwrap_or_else(|| {
                panic!(
                    "{mode:?} ray {ray:?} cone {cone:?} hits {e:?} exactly, not with its footprint"
                )
            });
            assert!(
                c.t <= e.t + 1e-4 * (1.0 + e.t.abs()),
                "{mode:?} ray {ray:?} cone {cone:?}: footprint hit at {} after the exact hit at {}",
                c.t,
                e.t
            );
            if c.id & NODE_ID != 0 {
                node_hits += 1;
                assert!(c.side >= 4 && c.side.is_power_of_two(), "{c:?}");
                assert!(c.side as f32 <= cone.width_at(c.t), "{c:?} {cone:?}");
            } else {
                assert_eq!(c.side, 1);
            }
        }
        assert!(hits > 5_000, "{mode:?}: {hits} hits");
        assert!(
            node_hits > hits / 4,
            "{mode:?}: {node_hits} of {hits} hits on inner nodes"
        );
    }
}

/// The exact cone (and cones that are not positive, or NaN) walk to the leaves: the same
/// entries, front to back, with the same steps as the exact traversal.
#[test]
fn an_exact_cone_is_the_exact_walk() {
    let tree = scene(6);
    let mut r = rng(58_002);
    let entries = |ray: &GridRay, cone: Option<Cone>| {
        let mut seen: Vec<LeafEntry> = Vec::new();
        let visit = |e: &LeafEntry| {
            seen.push(*e);
            None::<()>
        };
        let t = match cone {
            None => traverse(&tree, ray, 0.0, f32::INFINITY, MAX_STEPS, visit),
            Some(c) => traverse_cone(&tree, ray, c, 0.0, f32::INFINITY, MAX_STEPS, visit),
        };
        (seen, t.steps)
    };
    for _ in 0..2_000 {
        let ray = ray(&mut r, &tree);
        let want = entries(&ray, None);
        assert!(want.0.iter().all(|e| e.side == 1));
        for cone in [
            Cone::EXACT,
            Cone {
                width: -3.0,
                spread: -1.0,
            },
            Cone {
                width: f32::NAN,
                spread: f32::NAN,
            },
        ] {
            assert_eq!(entries(&ray, Some(cone)), want, "{cone:?}");
        }
    }
    // A wide cone hands over inner nodes in place of their leaves, fewer entries in all.
    // Along x through the middle of a leaf in the middle of the list.
    let leaves: Vec<_> = tree.leaves().collect();
    let c = leaves[leaves.len() / 2].cell.as_vec3();
    let ray = GridRay {
        origin: Vec3::new(-10.0, c.y + 0.5, c.z + 0.5),
        dir: Vec3::X,
    };
    let wide = entries(
        &ray,
        Some(Cone {
            width: 16.0,
            spread: 0.0,
        }),
    );
    let exact = entries(&ray, None);
    assert!(wide.0.iter().any(|e| e.side == 16), "{:?}", wide.0);
    assert!(wide.0.len() < exact.0.len() && wide.1 < exact.1);
}

fn tracer<'a>(
    tree: &'a Octree,
    cam: &Camera,
    lod: f32,
    prepass: bool,
    packets: bool,
) -> Tracer<OctreeSurfaces<'a>> {
    let light = PointLight {
        position: cam.eye + DVec3::new(0.0, 1.0, 0.5),
        colour: Vec3::ONE,
        intensity: 2.0,
    };
    Tracer::new(
        OctreeSurfaces::new(tree, HitMode::Contour),
        &[light],
        Sky::default(),
        Phong::default(),
        TraceOptions {
            lod,
            packets,
            prepass,
            ..Default::default()
        },
    )
}

/// A render at a level of detail of one to four pixels: close to the exact image (the
/// secondary and shadow rays start off the nodes they leave without meeting them again:
/// no dark specks), with fewer steps per primary ray, and the same image with or without
/// the primary prepass and packets (the prepass finds the nodes where the walk stops).
#[test]
fn renders_with_a_footprint_are_close_to_the_exact_image_with_fewer_steps() {
    let tree = scene(9);
    let (lo, hi) = tree.occupied_bounds();
    let cam = Camera::framing(lo, hi, 128, 96, 40.0);
    let mut exact = render(&tracer(&tree, &cam, 0.0, false, true), &cam).unwrap();
    exact.elapsed = Default::default();
    assert!(
        exact.stats.primary_hits > 1_500,
        "{} hits",
        exact.stats.primary_hits
    );
    let steps = |f: &svo::render::Frame| f.stats.primary_steps as f64 / f.stats.primary_rays as f64;
    for (lod, min_psnr, max_steps) in [(1.0, 36.0, 0.9), (4.0, 30.0, 0.7)] {
        let mut f = render(&tracer(&tree, &cam, lod, false, true), &cam).unwrap();
        f.elapsed = Default::default();
        let d = compare(&exact, &f).unwrap();
        assert!(
            d.psnr_db >= min_psnr,
            "lod {lod}: PSNR {:.2} dB against the exact image",
            d.psnr_db
        );
        assert!(
            steps(&f) < max_steps * steps(&exact),
            "lod {lod}: {:.2} steps per primary ray, exact {:.2}",
            steps(&f),
            steps(&exact)
        );
        assert!(f.leaf.iter().any(|&id| id != u32::MAX && id & NODE_ID != 0));
        let mut single = render(&tracer(&tree, &cam, lod, false, false), &cam).unwrap();
        single.elapsed = Default::default();
        assert_eq!(f, single, "lod {lod}: packets change the image");
        for packets in [false, true] {
            let g = render(&tracer(&tree, &cam, lod, true, packets), &cam).unwrap();
            assert!(g.stats.primary_steps < f.stats.primary_steps);
            let differ = (0..f.colour.len())
                .filter(|&i| {
                    (g.colour[i], g.depth[i], g.normal[i], g.leaf[i])
                        != (f.colour[i], f.depth[i], f.normal[i], f.leaf[i])
                })
                .collect::<Vec<_>>();
            assert!(
                differ.is_empty(),
                "lod {lod}, packets {packets}: the prepass changes {} pixels, the first {:?}",
                differ.len(),
                differ
                    .first()
                    .map(|&i| (i, g.leaf[i], f.leaf[i], g.depth[i], f.depth[i]))
            );
        }
    }
}
