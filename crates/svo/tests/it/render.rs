//! The Whitted tracer on scenes with known answers: a lit wall (ambient, diffuse, specular
//! and inverse-square falloff), shadows through glass panes in each shadow mode, a mirror, a
//! glass slab at normal incidence (Fresnel), images independent of the thread count, and the
//! exact hit mode against the triangle reference.
#![cfg(all(feature = "image-io", feature = "reference"))]

use crate::common;

use glam::{DVec3, UVec3, Vec3};
use rand::Rng;
use svo::render::{
    Camera, MeshSurfaces, OctreeSurfaces, Phong, PointLight, Query, ShadowMode, Sky, Surfaces,
    TraceOptions, Tracer, exact_surfaces, render,
};
use svo::{HitMode, Octree, RootCube, Voxel};

/// An sRGB byte as linear light (IEC 61966-2-1), as the stored colours are decoded.
fn srgb_to_linear(byte: u8) -> f32 {
    let c = f32::from(byte) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A 16^3 grid over `[0, 16]^3` scene units, so scene and grid coordinates coincide.
fn grid16(cells: impl IntoIterator<Item = (UVec3, Voxel)>) -> Octree {
    let root = RootCube {
        origin: DVec3::ZERO,
        side: 16.0,
    };
    Octree::from_cells(root, 4, cells).unwrap()
}

fn grey(c: f32) -> Voxel {
    Voxel {
        colour: [c, c, c, 1.0],
        reflectivity: 0.0,
        refractivity: 0.0,
        ior: 1.5,
        normal: None,
    }
}

/// A white mirror cell of `reflectivity`.
fn mirror(reflectivity: f32) -> Voxel {
    Voxel {
        colour: [1.0, 1.0, 1.0, 1.0],
        reflectivity,
        ..grey(1.0)
    }
}

/// Black sky, so only the scene contributes.
fn black_sky() -> Sky {
    Sky {
        zenith: Vec3::ZERO,
        horizon: Vec3::ZERO,
        ground: Vec3::ZERO,
        up: Vec3::Y,
        cube_map: None,
    }
}

fn opts(shadows: ShadowMode) -> TraceOptions {
    TraceOptions {
        mode: HitMode::Cube,
        shadows,
        ..TraceOptions::default()
    }
}

/// The colour of one ray from `from` towards `to` (scene = grid units here).
fn shade<S: Surfaces>(t: &Tracer<S>, from: Vec3, to: Vec3) -> Vec3 {
    t.trace(from, (to - from).normalize()).colour
}

#[test]
fn lit_wall_matches_phong_with_inverse_square_falloff() {
    // A wall: the layer z = 0 (cells z in [0, 1]), albedo 0.5 (sRGB byte 188 -> linear).
    let wall = grid16((0..16).flat_map(|x| (0..16).map(move |y| (UVec3::new(x, y, 0), grey(0.5)))));
    let stored = wall.attributes.get(0).colour.unwrap()[0];
    assert_eq!(stored, 188);
    let albedo = srgb_to_linear(stored);
    let phong = Phong::default();
    let light = PointLight {
        position: DVec3::new(8.5, 8.5, 5.0),
        colour: Vec3::new(1.0, 0.5, 0.25),
        intensity: 9.0,
    };
    let t = Tracer::new(
        OctreeSurfaces::new(&wall, HitMode::Cube),
        &[light],
        black_sky(),
        phong,
        opts(ShadowMode::Opaque),
    );
    // Viewed head-on from (8.5, 8.5, 9): the hit is (8.5, 8.5, 1), the light 4 units away
    // straight above the surface: N.L = 1, R.V = 1.
    let c = shade(&t, Vec3::new(8.5, 8.5, 9.0), Vec3::new(8.5, 8.5, 1.0));
    let falloff = 9.0 / 16.0;
    let want = Vec3::splat(albedo * phong.ambient)
        + light.colour * falloff * (albedo * phong.diffuse + phong.specular);
    assert!((c - want).length() < 1e-5, "{c} vs {want}");

    // At 60 degrees from the normal the diffuse term halves and the distance grows.
    let p = Vec3::new(8.5, 8.5, 1.0);
    let lp = p + Vec3::new(0.0, (60f32).to_radians().sin(), (60f32).to_radians().cos()) * 3.0;
    let light2 = PointLight {
        position: lp.as_dvec3(),
        colour: Vec3::ONE,
        intensity: 9.0,
    };
    let t2 = Tracer::new(
        OctreeSurfaces::new(&wall, HitMode::Cube),
        &[light2],
        black_sky(),
        Phong {
            specular: 0.0,
            ..phong
        },
        opts(ShadowMode::Opaque),
    );
    let c2 = shade(&t2, Vec3::new(8.5, 8.5, 9.0), p);
    let want2 = albedo * phong.ambient + 1.0 * albedo * phong.diffuse * 0.5;
    assert!((c2 - Vec3::splat(want2)).length() < 1e-4, "{c2} vs {want2}");
}

/// A pane of clear glass that lets half the light through.
fn glass_pane() -> Voxel {
    Voxel {
        colour: [1.0, 1.0, 1.0, 1.0],
        reflectivity: 0.0,
        refractivity: 0.5,
        ior: 1.0,
        normal: None,
    }
}

#[test]
fn shadows_through_two_glass_panes_in_each_mode() {
    // Floor y = 0 everywhere; two panes at y = 5 and y = 10 over x in 0..8, each letting
    // half the light through.
    let pane = glass_pane();
    let mut cells: Vec<(UVec3, Voxel)> = Vec::new();
    for x in 0..16 {
        for z in 0..16 {
            cells.push((UVec3::new(x, 0, z), grey(0.5)));
            if x < 8 {
                cells.push((UVec3::new(x, 5, z), pane));
                cells.push((UVec3::new(x, 10, z), pane));
            }
        }
    }
    let scene = grid16(cells);
    let light = PointLight {
        position: DVec3::new(4.5, 15.5, 8.5),
        colour: Vec3::ONE,
        intensity: 200.0,
    };
    // Seen from the open side, under the panes, grazing the floor at (4.5, 1, 8.5).
    let eye = Vec3::new(15.5, 3.0, 8.5);
    let at = Vec3::new(4.5, 1.0, 8.5);
    let radiance = |mode| {
        let t = Tracer::new(
            OctreeSurfaces::new(&scene, HitMode::Cube),
            &[light],
            black_sky(),
            Phong::default(),
            opts(mode),
        );
        shade(&t, eye, at)
    };
    let albedo = srgb_to_linear(188);
    let ambient = Vec3::splat(albedo * Phong::default().ambient);
    let lit = radiance(ShadowMode::None) - ambient;
    assert!(lit.x > 0.05, "the floor must be lit: {lit}");
    for (mode, vis) in [
        (ShadowMode::Opaque, 0.0),
        (ShadowMode::MaxRefractivity, 0.5),
        (ShadowMode::Transmittance, 0.25),
    ] {
        let got = radiance(mode) - ambient;
        assert!(
            (got - lit * vis).length() < 2e-3,
            "{mode:?}: {got} vs {}",
            lit * vis
        );
    }
}

#[test]
fn mirror_reflects_the_lit_wall() {
    // A mirror floor (y = 0) and a lit grey wall (x = 15); black sky.
    let mirror = mirror(1.0);
    let mut cells = Vec::new();
    for a in 0..16 {
        for b in 0..16 {
            cells.push((UVec3::new(a, 0, b), mirror));
            cells.push((UVec3::new(15, a, b), grey(0.5)));
        }
    }
    let scene = grid16(cells);
    let light = PointLight {
        position: DVec3::new(10.0, 8.0, 8.0),
        colour: Vec3::ONE,
        intensity: 25.0,
    };
    let t = Tracer::new(
        OctreeSurfaces::new(&scene, HitMode::Cube),
        &[light],
        black_sky(),
        Phong::default(),
        opts(ShadowMode::Opaque),
    );
    // Looking down at 45 degrees onto the mirror at (8.3, 1, 8.5): the reflected ray starts
    // `bias` cells above the surface and goes up to the wall, so it is the same ray as a
    // direct view from that point.
    let bias = TraceOptions::default().bias_cells;
    let via_mirror = shade(&t, Vec3::new(1.3, 8.0, 8.5), Vec3::new(8.3, 1.0, 8.5));
    let from = Vec3::new(8.3, 1.0 + bias, 8.5);
    let direct = shade(&t, from, from + Vec3::new(1.0, 1.0, 0.0));
    assert!(direct.x > 0.01);
    assert!(
        (via_mirror - direct).length() < 1e-4,
        "{via_mirror} vs {direct}"
    );
}

/// A glass slab two cells thick (y = 4 and 5) whose leaves carry outward normals, under a
/// white sky with a black ground.
fn glass_slab_under_white_sky() -> (Octree, Sky) {
    let glass = |n: Vec3| Voxel {
        colour: [1.0, 1.0, 1.0, 1.0],
        reflectivity: 0.0,
        refractivity: 1.0,
        ior: 1.5,
        normal: Some(n),
    };
    let scene = grid16((0..16).flat_map(|x| {
        (0..16).flat_map(move |z| {
            [
                (UVec3::new(x, 4, z), glass(Vec3::NEG_Y)),
                (UVec3::new(x, 5, z), glass(Vec3::Y)),
            ]
        })
    }));
    let sky = Sky {
        zenith: Vec3::ONE,
        horizon: Vec3::ONE,
        ground: Vec3::ZERO,
        up: Vec3::Y,
        cube_map: None,
    };
    (scene, sky)
}

#[test]
fn glass_slab_at_normal_incidence_transmits_per_fresnel() {
    // A glass slab two cells thick whose leaves carry outward normals: looking straight up
    // through it at a white sky, each of the two boundaries transmits 1 - 0.04 (Fresnel at
    // normal incidence, IOR 1.5), entering then leaving the medium.
    let (scene, sky) = glass_slab_under_white_sky();
    let t = Tracer::new(
        OctreeSurfaces::new(&scene, HitMode::Cube),
        &[],
        sky.clone(),
        Phong::default(),
        TraceOptions {
            max_reflections: 0,
            max_refractions: 4,
            ..opts(ShadowMode::None)
        },
    );
    let up = shade(&t, Vec3::new(8.5, 1.0, 8.5), Vec3::new(8.5, 15.0, 8.5));
    let r0 = 0.04f32;
    assert!(
        (up - Vec3::splat((1.0 - r0) * (1.0 - r0))).length() < 1e-4,
        "{up}"
    );
    // With one refraction allowed, the second boundary is never crossed: black.
    let t1 = Tracer::new(
        OctreeSurfaces::new(&scene, HitMode::Cube),
        &[],
        sky,
        Phong::default(),
        TraceOptions {
            max_reflections: 0,
            max_refractions: 1,
            ..opts(ShadowMode::None)
        },
    );
    assert_eq!(
        shade(&t1, Vec3::new(8.5, 1.0, 8.5), Vec3::new(8.5, 15.0, 8.5)),
        Vec3::ZERO
    );
}

/// The path limit (`max_path_bounces`) on the same two-cell glass slab, now also reflective
/// and with both limits generous: with 1 (the 2015 thesis's tracer) the ray entering the
/// glass is the last refraction, so looking up through the slab is black and a primary ray
/// spawns exactly two rays; with 2 it crosses both boundaries, `(1 - r0)^2` of the white sky
/// as at normal incidence, and the reflection inside the glass stops at the first boundary
/// (five rays); a limit that the two others make unreachable changes nothing, bit for bit.
#[test]
fn path_bounce_limit_cuts_the_ray_tree() {
    let (scene, sky) = glass_slab_under_white_sky();
    let up = |path: u8| {
        let t = Tracer::new(
            OctreeSurfaces::new(&scene, HitMode::Cube),
            &[],
            sky.clone(),
            Phong::default(),
            TraceOptions {
                max_reflections: 3,
                max_refractions: 4,
                max_path_bounces: path,
                ..opts(ShadowMode::None)
            },
        );
        t.trace(Vec3::new(8.5, 1.0, 8.5), Vec3::Y)
    };
    let one = up(1);
    assert_eq!(one.colour, Vec3::ZERO);
    assert_eq!(one.stats.rays, 3, "primary, reflection, refraction");
    let two = up(2);
    let r0 = 0.04f32;
    assert!(
        (two.colour - Vec3::splat((1.0 - r0) * (1.0 - r0))).length() < 1e-4,
        "{}",
        two.colour
    );
    assert_eq!(two.stats.rays, 5);
    let all = up(u8::MAX);
    assert!(all.stats.rays > 5, "{:?}", all.stats);
    assert!(
        all.colour.x > two.colour.x,
        "light reflected inside the glass"
    );
    let reachable = up(7);
    assert_eq!(reachable.colour, all.colour);
    assert_eq!(reachable.stats, all.stats);
}

/// Nested media: a glass slab inside a water slab, looked through at normal incidence. Each
/// boundary transmits `1 - ((n1 - n2) / (n1 + n2))^2` with the IORs on its two sides, so the
/// inner boundaries are water/glass (1.33/1.5), not air/glass as they would be if media did
/// not nest; both orders of crossing are checked, and a reflection inside the glass keeps
/// the glass's medium.
#[test]
fn nested_media_refract_with_the_surrounding_medium() {
    let slab = |ior: f32, n: Vec3| Voxel {
        colour: [1.0, 1.0, 1.0, 1.0],
        reflectivity: 0.0,
        refractivity: 1.0,
        ior,
        normal: Some(n),
    };
    let (water, glass) = (1.33f32, 1.5f32);
    // Water from y = 3 to 12, glass from y = 6 to 9 (surface leaves with outward normals).
    let scene = grid16((0..16).flat_map(|x| {
        (0..16).flat_map(move |z| {
            [
                (UVec3::new(x, 3, z), slab(water, Vec3::NEG_Y)),
                (UVec3::new(x, 6, z), slab(glass, Vec3::NEG_Y)),
                (UVec3::new(x, 8, z), slab(glass, Vec3::Y)),
                (UVec3::new(x, 11, z), slab(water, Vec3::Y)),
            ]
        })
    }));
    let sky = Sky {
        zenith: Vec3::ONE,
        horizon: Vec3::ONE,
        ground: Vec3::ONE,
        up: Vec3::Y,
        cube_map: None,
    };
    let t = Tracer::new(
        OctreeSurfaces::new(&scene, HitMode::Cube),
        &[],
        sky,
        Phong::default(),
        TraceOptions {
            max_reflections: 0,
            max_refractions: 8,
            ..opts(ShadowMode::None)
        },
    );
    let tr = |a: f32, b: f32| 1.0 - ((a - b) / (a + b)).powi(2);
    // The IORs go through the file's 1/16384 steps.
    let q = |n: f32| 1.0 + ((n - 1.0) * 16384.0).round() / 16384.0;
    let (w, g) = (q(water), q(glass));
    let want = tr(1.0, w) * tr(w, g) * tr(g, w) * tr(w, 1.0);
    let unnested = tr(1.0, w) * tr(1.0, g) * tr(g, 1.0) * tr(w, 1.0);
    assert!(
        (want - unnested).abs() > 1e-3,
        "the scene cannot tell nesting apart"
    );
    for (from, to) in [(1.0, 15.0), (15.0, 1.0)] {
        let c = shade(&t, Vec3::new(8.5, from, 8.5), Vec3::new(8.5, to, 8.5));
        assert!(
            (c - Vec3::splat(want)).abs().max_element() < 1e-5,
            "from y = {from}: {c}, want {want} (unnested {unnested})"
        );
    }
}

fn torus_mesh() -> svo::Mesh {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/torus.obj");
    svo::Mesh::load(std::path::Path::new(path)).unwrap()
}

fn torus_tree(depth: u8) -> Octree {
    let mesh = torus_mesh();
    let opts = svo::BakeOptions {
        depth,
        ..svo::BakeOptions::default()
    };
    svo::bake_mesh(&mesh, &opts).unwrap().0
}

#[test]
fn exact_hits_equal_the_triangle_reference() {
    // Every triangle that touches a leaf is in its list, so the exact mode must find the
    // same first hit as the BVH over all triangles, on every ray. The reference computes its
    // parameter in `f32`, which at grazing angles is off by up to thousandths of a cell;
    // where the two differ by more than 1e-4, the exact mode is held to the first hit over
    // all triangles computed in `f64`.
    let mesh = torus_mesh();
    let tree = torus_tree(5);
    let exact = exact_surfaces(&tree, &mesh).unwrap();
    let grid: Vec<[DVec3; 3]> = mesh
        .triangles
        .iter()
        .map(|t| {
            t.map(|i| {
                tree.root
                    .to_grid(mesh.positions[i as usize], tree.depth)
                    .as_vec3()
                    .as_dvec3()
            })
        })
        .collect();
    let tris = MeshSurfaces::new(mesh, tree.root, tree.depth);
    let mut rng = common::rng(0xE8AC7);
    let n = 32.0f32;
    let (mut hits, mut grazing) = (0, 0);
    for _ in 0..20_000 {
        let ray = ray_into(&mut rng, n, 8.0);
        let a = exact.closest(&ray, &Query::all(1 << 16));
        let b = tris.closest(&ray, &Query::all(1 << 16));
        match (a.hit, b.hit) {
            (None, None) => {}
            (Some(x), Some(y)) => {
                hits += 1;
                if (x.t - y.t).abs() >= 1e-4 {
                    grazing += 1;
                    let truth = first_hit_f64(&grid, &ray).expect("the reference hit");
                    assert!(
                        (f64::from(x.t) - truth).abs() < 1e-4,
                        "{ray:?}: exact {} vs reference {} and f64 {truth}",
                        x.t,
                        y.t
                    );
                }
            }
            (x, y) => panic!("{ray:?}: exact {x:?} vs reference {y:?}"),
        }
    }
    println!("{hits} hits, {grazing} beyond 1e-4 of the f32 reference");
    assert!(hits > 3000, "{hits}");
}

/// The first hit of `ray` (from `t = 0`) over all `tris`, two-sided, edges inclusive, in `f64`.
fn first_hit_f64(tris: &[[DVec3; 3]], ray: &svo::trace::GridRay) -> Option<f64> {
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let hit = |[a, b, c]: &[DVec3; 3]| {
        let (e1, e2) = (*b - *a, *c - *a);
        let p = d.cross(e2);
        let inv = 1.0 / e1.dot(p);
        let s = o - *a;
        let q = s.cross(e1);
        let (u, v, t) = (s.dot(p) * inv, d.dot(q) * inv, e2.dot(q) * inv);
        (inv.is_finite() && u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= 0.0).then_some(t)
    };
    tris.iter().filter_map(hit).min_by(f64::total_cmp)
}

#[test]
fn images_do_not_depend_on_the_thread_count() {
    let tree = torus_tree(6);
    let (lo, hi) = tree.occupied_bounds();
    let cam = Camera::framing(lo, hi, 96, 64, 40.0);
    let light = PointLight {
        position: cam.eye + DVec3::new(0.0, 10.0, 0.0),
        colour: Vec3::ONE,
        intensity: 100.0,
    };
    let frame = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let t = Tracer::new(
                OctreeSurfaces::new(&tree, HitMode::Contour),
                &[light],
                Sky::default(),
                Phong::default(),
                TraceOptions::default(),
            );
            let mut f = render(&t, &cam).unwrap();
            f.elapsed = std::time::Duration::ZERO;
            f
        })
    };
    let one = frame(1);
    assert!(one.stats.primary_hits > 500);
    assert_eq!(one, frame(2));
    assert_eq!(one, frame(3));
}

#[test]
fn solid_glass_block_without_normals_is_one_medium() {
    // A block of glass cells four thick with no stored normals (a builder scene, as in the
    // 2019 report): a ray through it crosses two boundaries, not one per cell.
    let glass = Voxel {
        colour: [1.0, 1.0, 1.0, 1.0],
        reflectivity: 0.0,
        refractivity: 1.0,
        ior: 1.5,
        normal: None,
    };
    let scene = grid16((0..16).flat_map(|x| {
        (0..16).flat_map(move |z| (4..8).map(move |y| (UVec3::new(x, y, z), glass)))
    }));
    let sky = Sky {
        zenith: Vec3::ONE,
        horizon: Vec3::ONE,
        ground: Vec3::ZERO,
        up: Vec3::Y,
        cube_map: None,
    };
    let t = Tracer::new(
        OctreeSurfaces::new(&scene, HitMode::Cube),
        &[],
        sky,
        Phong::default(),
        TraceOptions {
            max_reflections: 0,
            max_refractions: 2,
            ..opts(ShadowMode::None)
        },
    );
    let up = shade(&t, Vec3::new(8.5, 1.0, 8.5), Vec3::new(8.5, 15.0, 8.5));
    assert!((up - Vec3::splat(0.96 * 0.96)).length() < 1e-4, "{up}");
    // Tilted: Snell bends the ray inside, and it leaves parallel to how it came in, so it
    // sees the same sky.
    let tilted = shade(&t, Vec3::new(4.5, 1.0, 8.5), Vec3::new(6.5, 4.0, 8.5));
    assert!(tilted.x > 0.85 && tilted.x < 0.93, "{tilted}");
}

#[test]
fn primary_prepass_changes_nothing_but_the_steps() {
    let tree = torus_tree(7);
    let (lo, hi) = tree.occupied_bounds();
    let base = Camera::framing(lo, hi, 120, 90, 40.0);
    let c = (lo + hi) * 0.5;
    // The centre of a leaf: every box around it holds the eye.
    let leaf = tree.leaves().next().unwrap().cell.as_dvec3() + 0.5;
    let in_leaf = tree.root.to_scene(leaf, tree.depth);
    let cams = [
        base,
        // Close up (nodes cover much of the screen), from below, from inside the tube (the
        // nodes around the eye reach behind it), and from inside a leaf.
        Camera {
            eye: c + (base.eye - c) * 0.35,
            ..base
        },
        Camera {
            eye: c + DVec3::new(0.2, -1.0, 0.4) * (hi - lo).length(),
            ..base
        },
        Camera {
            eye: c + DVec3::new((hi.x - lo.x) * 0.375, 0.0, 0.0),
            target: c + DVec3::new((hi.x - lo.x) * 0.375, 0.0, 1.0),
            ..base
        },
        Camera {
            eye: in_leaf,
            target: c,
            ..base
        },
    ];
    for mode in [HitMode::Cube, HitMode::Contour] {
        for (k, cam) in cams.iter().enumerate() {
            let (a, b) = with_and_without_prepass(&tree, mode, cam, &format!("camera {k}"));
            assert!(b.stats.primary_hits > 0);
            // The prepass decided the rays (the node holding the eye, and the leaf, are
            // opened for every pixel) and saved steps.
            assert!(
                a.stats.primary_steps < b.stats.primary_steps,
                "{k}: {} vs {}",
                a.stats.primary_steps,
                b.stats.primary_steps
            );
        }
    }
}

/// Renders `cam`'s view of `tree` with and without the primary-ray prepass and checks that
/// the images and AOVs are the same bit for bit and that the prepass took no more steps.
fn with_and_without_prepass(
    tree: &Octree,
    mode: HitMode,
    cam: &Camera,
    what: &str,
) -> (svo::render::Frame, svo::render::Frame) {
    let tracer = |prepass: bool| {
        Tracer::new(
            OctreeSurfaces::new(tree, mode),
            &[PointLight {
                position: cam.eye + DVec3::Y,
                colour: Vec3::ONE,
                intensity: 1.0,
            }],
            Sky::default(),
            Phong::default(),
            TraceOptions {
                mode,
                prepass,
                ..TraceOptions::default()
            },
        )
    };
    let (a, b) = (
        render(&tracer(true), cam).unwrap(),
        render(&tracer(false), cam).unwrap(),
    );
    // Casting the primary rays alone finds the same hits, with the prepass and without.
    for prepass in [true, false] {
        let t = tracer(prepass);
        let mut hits = svo::render::Hits::default();
        svo::render::cast_primary(&t, cam, &mut hits).unwrap();
        assert_eq!(hits.leaf, a.leaf, "{what}: cast leaves, prepass {prepass}");
        assert!(
            hits.depth
                .iter()
                .zip(&a.depth)
                .all(|(x, y)| x.to_bits() == y.to_bits()),
            "{what}: cast depths, prepass {prepass}"
        );
        assert_eq!(hits.hits, a.stats.primary_hits);
        // Without the prepass the cast walks neighbouring pixels in packets, the render one
        // ray at a time: the same steps.
        let r = if prepass { &a } else { &b };
        assert_eq!(
            hits.steps, r.stats.primary_steps,
            "{what}: prepass {prepass}"
        );
        assert_eq!(hits.max_steps, r.stats.max_primary_steps, "{what}");
        assert_eq!(hits.capped, r.stats.capped, "{what}");
    }
    // The first pixel that differs, with what each render saw there.
    let differs = (0..a.colour.len()).find(|&i| {
        a.colour[i] != b.colour[i]
            || a.depth[i].to_bits() != b.depth[i].to_bits()
            || a.normal[i] != b.normal[i]
            || a.leaf[i] != b.leaf[i]
    });
    if let Some(i) = differs {
        panic!(
            "{mode:?}, {what}, {cam:?}: pixel ({}, {}) differs: with the prepass leaf {} at {}, \
             without leaf {} at {}",
            i % cam.width as usize,
            i / cam.width as usize,
            a.leaf[i],
            a.depth[i],
            b.leaf[i],
            b.depth[i]
        );
    }
    (a, b)
}

/// A seeded grid ray from a point within `margin` cells around a grid of `n` cells per axis
/// toward a point inside it.
fn ray_into(rng: &mut impl Rng, n: f32, margin: f32) -> svo::trace::GridRay {
    let o = Vec3::new(
        rng.random_range(-margin..n + margin),
        rng.random_range(-margin..n + margin),
        rng.random_range(-margin..n + margin),
    );
    let target = Vec3::new(
        rng.random_range(0.0..n),
        rng.random_range(0.0..n),
        rng.random_range(0.0..n),
    );
    svo::trace::GridRay {
        origin: o,
        dir: (target - o).normalize(),
    }
}

/// A shape whose parameter reads the entry's face normal: a cube hit only where the ray
/// came in through a face (an entry whose normal were left zero would never be hit).
struct FaceEntries;

impl svo::render::LeafShape for FaceEntries {
    fn hit(
        &self,
        _: &Octree,
        _: &svo::trace::GridRay,
        e: &svo::trace::LeafEntry,
    ) -> Option<(f32, Vec3)> {
        (e.entry_normal != Vec3::ZERO).then_some((e.t_enter, e.entry_normal))
    }
}

/// The prepass gives a shape that reads the face normals entries that have them (the
/// default of `LeafShape::hit_t_reads_normals`), and the built-in hit tests' parameters,
/// tested by the prepass on entries without normals, do not depend on them.
#[test]
fn prepass_entries_have_the_normals_a_shape_reads() {
    let tree = torus_tree(6);
    let (lo, hi) = tree.occupied_bounds();
    let cam = Camera::framing(lo, hi, 96, 72, 40.0);
    let c = (lo + hi) * 0.5;
    for cam in [
        cam,
        Camera {
            eye: c + (cam.eye - c) * 0.35,
            ..cam
        },
    ] {
        let tracer = |prepass: bool| {
            Tracer::new(
                OctreeSurfaces::with_shape(&tree, FaceEntries),
                &[],
                Sky::default(),
                Phong::default(),
                TraceOptions {
                    prepass,
                    ..TraceOptions::default()
                },
            )
        };
        let (a, b) = (
            render(&tracer(true), &cam).unwrap(),
            render(&tracer(false), &cam).unwrap(),
        );
        assert!(a.stats.primary_hits > 0);
        assert_eq!(a.leaf, b.leaf);
        assert_eq!(a.normal, b.normal);
        assert!(a.colour == b.colour);
    }
    // Every entry of every leaf a ray enters: the same parameter with the normals zero.
    let mut rng = common::rng(0x4E0_4A15);
    let mut entries = 0;
    for _ in 0..400 {
        let n = f32::from(1u16 << tree.depth);
        let ray = ray_into(&mut rng, n, 0.5 * n);
        svo::trace::traverse(&tree, &ray, 0.0, f32::INFINITY, 1 << 16, |e| {
            let bare = svo::trace::LeafEntry {
                entry_normal: Vec3::ZERO,
                exit_normal: Vec3::ZERO,
                ..*e
            };
            for mode in [HitMode::Cube, HitMode::Contour] {
                use svo::render::LeafShape;
                assert!(!mode.hit_t_reads_normals());
                let t = mode.leaf_hit_t(&tree, e.leaf);
                assert_eq!(
                    t(&ray, e).map(f32::to_bits),
                    t(&ray, &bare).map(f32::to_bits)
                );
            }
            entries += 1;
            None::<()>
        });
    }
    assert!(entries > 1000, "{entries}");
}

/// The prepass against tracing every ray from the eye on seeded random sparse trees and the
/// torus at several depths, from random eyes around and inside them and from eyes on the
/// lattice looking along an axis or a lattice diagonal (rays along cell faces and through
/// edges and corners): the same image every time.
#[test]
fn primary_prepass_changes_nothing_on_random_views() {
    let mut rng = common::rng(0x9E7A55);
    let mut ran = 0;
    let mut views = 0;
    let mut steps = [0u64; 2];
    for depth in [3u8, 5, 7] {
        let n = 1u32 << depth;
        // Clusters of cells, so boxes at every level are partly empty.
        let mut cells = Vec::new();
        for _ in 0..6 {
            let c = UVec3::new(
                rng.random_range(0..n),
                rng.random_range(0..n),
                rng.random_range(0..n),
            );
            for _ in 0..(n * 6) {
                let j = UVec3::new(
                    rng.random_range(0..=n / 4),
                    rng.random_range(0..=n / 4),
                    rng.random_range(0..=n / 4),
                );
                cells.push(((c + j).min(UVec3::splat(n - 1)), grey(0.7)));
            }
        }
        let root = RootCube {
            origin: DVec3::ZERO,
            side: f64::from(n),
        };
        let random = Octree::from_cells(root, depth, cells).unwrap();
        let torus = torus_tree(depth);
        for (name, tree, modes) in [
            ("random cells", &random, &[HitMode::Cube][..]),
            ("torus", &torus, &[HitMode::Cube, HitMode::Contour][..]),
        ] {
            let (lo, hi) = tree.occupied_bounds();
            let c = (lo + hi) * 0.5;
            let r = (hi - lo).length();
            // Scene units per cell.
            let cell = tree.root.side / f64::from(n);
            let lattice =
                |v: DVec3| tree.root.origin + (((v - tree.root.origin) / cell).round()) * cell;
            for k in 0..16 {
                // Image sizes with one word of pixel bits per row and with several, the
                // last partly used; heights that are and are not a multiple of the band.
                let (w, h) = [(64, 48), (131, 37), (200, 75), (7, 5)][k % 4];
                let base = Camera::framing(lo, hi, w, h, 40.0);
                let cam = match k % 4 {
                    // Around, at random distances, some close enough to be inside.
                    0 => {
                        let dir = DVec3::new(
                            rng.random_range(-1.0..1.0),
                            rng.random_range(-1.0..1.0),
                            rng.random_range(-1.0..1.0),
                        )
                        .normalize_or(DVec3::X);
                        Camera {
                            eye: c + dir * r * rng.random_range(0.3..1.5),
                            target: c,
                            fov_deg: rng.random_range(20.0..90.0),
                            ..base
                        }
                    }
                    // On the lattice, looking along an axis.
                    1 => {
                        let eye = lattice(c + DVec3::new(0.0, 0.0, r * 0.9));
                        Camera {
                            eye,
                            target: eye - DVec3::Z,
                            ..base
                        }
                    }
                    // On the lattice, looking along a lattice diagonal.
                    2 => {
                        let eye = lattice(c + DVec3::new(r, r, r) * 0.6);
                        Camera {
                            eye,
                            target: eye - DVec3::new(1.0, 1.0, 1.0),
                            up: DVec3::new(0.0, 1.0, 0.0),
                            ..base
                        }
                    }
                    // On a lattice point among the cells (on the corners of cells and of
                    // nodes), looking along an axis or a lattice diagonal.
                    _ => {
                        let j = DVec3::new(
                            rng.random_range(-0.3..0.3),
                            rng.random_range(-0.3..0.3),
                            rng.random_range(-0.3..0.3),
                        );
                        let eye = lattice(c + j * (hi - lo));
                        let look = [DVec3::X, DVec3::NEG_Y, DVec3::new(1.0, -1.0, 1.0)][k / 4 % 3];
                        Camera {
                            eye,
                            target: eye + look,
                            up: if look == DVec3::NEG_Y {
                                DVec3::Z
                            } else {
                                DVec3::Y
                            },
                            fov_deg: 70.0,
                            ..base
                        }
                    }
                };
                for &mode in modes {
                    let what = format!("{name} depth {depth} view {k}");
                    let (a, b) = with_and_without_prepass(tree, mode, &cam, &what);
                    views += 1;
                    ran += usize::from(a.stats.primary_steps < b.stats.primary_steps);
                    steps[0] += a.stats.primary_steps;
                    steps[1] += b.stats.primary_steps;
                }
            }
        }
    }
    // The prepass decides most rays (those that touch a cell go to the traversal) and saves
    // steps in all. Not on every view: its steps count the plane tests of every leaf whose
    // rectangle holds an open pixel, also leaves the ray then does not enter.
    assert!(
        ran * 2 > views && steps[0] < steps[1],
        "the prepass saved steps on {ran} of {views} views, {} against {} in all",
        steps[0],
        steps[1]
    );
}

/// Two facing mirrors (a hall of mirrors): a ray between them bounces until the reflection
/// limit, exactly that many times for every limit up to `MAX_BOUNCES`, and the colour stays
/// finite; nothing loops or overflows the ray stack.
#[test]
fn facing_mirrors_stop_at_the_reflection_limit() {
    let mirror = mirror(0.9);
    let mut cells = Vec::new();
    for a in 0..16 {
        for b in 0..16 {
            cells.push((UVec3::new(0, a, b), mirror));
            cells.push((UVec3::new(15, a, b), mirror));
        }
    }
    let scene = grid16(cells);
    let light = PointLight {
        position: DVec3::new(8.0, 8.0, 8.0),
        colour: Vec3::ONE,
        intensity: 40.0,
    };
    for limit in [0u8, 1, 2, 7, svo::render::MAX_BOUNCES] {
        let o = TraceOptions {
            max_reflections: limit,
            ..opts(ShadowMode::Opaque)
        };
        let t = Tracer::new(
            OctreeSurfaces::new(&scene, HitMode::Cube),
            &[light],
            black_sky(),
            Phong::default(),
            o,
        );
        // Perpendicular to the mirrors, and at an angle (it still bounces between them).
        for dir in [Vec3::X, Vec3::new(1.0, 0.01, 0.005).normalize()] {
            let s = t.trace(Vec3::new(8.0, 8.0, 8.0), dir);
            assert!(s.colour.is_finite(), "limit {limit}: {}", s.colour);
            assert_eq!(
                s.stats.rays,
                1 + u32::from(limit),
                "limit {limit}, {dir}: primary plus one ray per reflection"
            );
            assert_eq!(s.stats.capped, 0);
        }
    }
    // The path limit cuts the same chain: one ray per bounce up to the smaller limit.
    for path in [0u8, 1, 5] {
        let t = Tracer::new(
            OctreeSurfaces::new(&scene, HitMode::Cube),
            &[light],
            black_sky(),
            Phong::default(),
            TraceOptions {
                max_reflections: svo::render::MAX_BOUNCES,
                max_path_bounces: path,
                ..opts(ShadowMode::Opaque)
            },
        );
        let s = t.trace(Vec3::new(8.0, 8.0, 8.0), Vec3::X);
        assert_eq!(s.stats.rays, 1 + u32::from(path), "path limit {path}");
    }
}

/// A light inside a closed box: with opaque shadows nothing outside is lit, and every
/// inner wall is; the shadow rays that start on a surface do not hit it.
#[test]
fn a_light_inside_closed_geometry_lights_only_the_inside() {
    let mut cells = Vec::new();
    for a in 4..12 {
        for b in 4..12 {
            for (x, y, z) in [
                (4, a, b),
                (11, a, b),
                (a, 4, b),
                (a, 11, b),
                (a, b, 4),
                (a, b, 11),
            ] {
                cells.push((UVec3::new(x, y, z), grey(0.5)));
            }
        }
    }
    // A floor outside the box.
    for a in 0..16 {
        for b in 0..16 {
            cells.push((UVec3::new(a, 0, b), grey(0.5)));
        }
    }
    cells.sort_by_key(|c| c.0.to_array());
    cells.dedup_by_key(|c| c.0);
    let scene = grid16(cells);
    let light = PointLight {
        position: DVec3::new(8.0, 8.0, 8.0),
        colour: Vec3::ONE,
        intensity: 10.0,
    };
    let phong = Phong {
        ambient: 0.0,
        ..Phong::default()
    };
    let t = Tracer::new(
        OctreeSurfaces::new(&scene, HitMode::Cube),
        &[light],
        black_sky(),
        phong,
        opts(ShadowMode::Opaque),
    );
    // Outside: the floor and the box's outer walls are dark.
    assert_eq!(
        shade(&t, Vec3::new(2.0, 6.0, 2.0), Vec3::new(2.0, 0.5, 2.5)),
        Vec3::ZERO
    );
    assert_eq!(
        shade(&t, Vec3::new(14.5, 8.0, 8.0), Vec3::new(11.5, 8.0, 8.0)),
        Vec3::ZERO
    );
    // Inside: from near the light, every wall is lit.
    let inside = Vec3::new(7.0, 7.5, 8.5);
    for to in [
        Vec3::new(4.5, 8.0, 8.0),
        Vec3::new(11.5, 8.0, 8.0),
        Vec3::new(8.0, 4.5, 8.0),
        Vec3::new(8.0, 11.5, 8.0),
        Vec3::new(8.0, 8.0, 4.5),
        Vec3::new(8.0, 8.0, 11.5),
    ] {
        let c = shade(&t, inside, to);
        assert!(c.x > 0.01 && c.is_finite(), "wall towards {to} is {c}");
    }
}

/// The scenes of [`packets_change_nothing`]: a tree, its lights, a view and its hit mode.
fn packet_scenes() -> Vec<(Octree, Vec<PointLight>, Camera, HitMode)> {
    let pane = glass_pane();
    let mut cells: Vec<(UVec3, Voxel)> = Vec::new();
    for x in 0..16 {
        for z in 0..16 {
            cells.push((
                UVec3::new(x, 0, z),
                if (x + z) % 7 == 0 {
                    mirror(0.6)
                } else {
                    grey(0.5)
                },
            ));
            if x < 8 && z % 5 != 0 {
                cells.push((UVec3::new(x, 5, z), pane));
                cells.push((UVec3::new(x, 10 + z % 3, z), pane));
            }
        }
    }
    let panes = grid16(cells);
    let glass = Voxel {
        colour: [0.9, 0.95, 1.0, 1.0],
        reflectivity: 0.1,
        refractivity: 0.8,
        ior: 1.5,
        normal: None,
    };
    let block = grid16((0..16).flat_map(|x| {
        (0..16).flat_map(move |z| (4..8).map(move |y| (UVec3::new(x, y, z), glass)))
    }));
    let torus = torus_tree(7);
    let (lo, hi) = torus.occupied_bounds();
    let c = (lo + hi) * 0.5;
    vec![
        (
            panes,
            vec![PointLight {
                position: DVec3::new(4.5, 15.5, 8.5),
                colour: Vec3::ONE,
                intensity: 200.0,
            }],
            Camera {
                eye: DVec3::new(15.5, 3.0, 8.5),
                target: DVec3::new(4.5, 1.0, 8.5),
                up: DVec3::Y,
                fov_deg: 70.0,
                width: 61,
                height: 47,
            },
            HitMode::Cube,
        ),
        (
            block,
            vec![PointLight {
                position: DVec3::new(8.5, 14.5, 8.5),
                colour: Vec3::ONE,
                intensity: 100.0,
            }],
            Camera {
                eye: DVec3::new(2.5, 1.0, 3.5),
                target: DVec3::new(9.5, 6.0, 10.5),
                up: DVec3::Y,
                fov_deg: 80.0,
                width: 45,
                height: 31,
            },
            HitMode::Cube,
        ),
        (
            torus,
            vec![
                PointLight {
                    position: c + (hi - lo) * DVec3::new(0.3, 1.5, 0.8),
                    colour: Vec3::ONE,
                    intensity: 2.0,
                },
                PointLight {
                    position: c,
                    colour: Vec3::new(1.0, 0.5, 0.2),
                    intensity: 0.5,
                },
            ],
            Camera::framing(lo, hi, 83, 29, 40.0),
            HitMode::Contour,
        ),
    ]
}

/// Panics at the first pixel where `a` and `b` differ in any bit of any output.
fn assert_same_pixels(a: &svo::render::Frame, b: &svo::render::Frame, what: &str) {
    let bits = |c: Vec3| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()];
    let differs = (0..a.colour.len()).find(|&i| {
        bits(a.colour[i]) != bits(b.colour[i])
            || bits(a.normal[i]) != bits(b.normal[i])
            || a.depth[i].to_bits() != b.depth[i].to_bits()
            || a.leaf[i] != b.leaf[i]
            || a.cost[i] != b.cost[i]
    });
    if let Some(i) = differs {
        panic!(
            "{what}: pixel {i} differs: colour {} / {}, leaf {} / {}",
            a.colour[i], b.colour[i], a.leaf[i], b.leaf[i]
        );
    }
}

/// A render traces four neighbouring pixels in lockstep and walks their rays after the
/// primary ones, and their shadow rays, as packets (and a cast without the prepass its
/// primary rays): the same image, AOVs and counters bit for bit as walking every ray alone.
/// Glass panes and mirrors over a floor in every shadow mode (shadow rays that pass through
/// surfaces and multiply, or stop), a glass block without normals (a medium), and the torus
/// at depth 7 with cube and contour hits, two lights (one inside the tube's ring); without
/// bounces, with one, and with svo-view's default limits; with and without the prepass, at
/// sizes whose rows do not split into fours.
#[test]
fn packets_change_nothing() {
    let (mut shadow_rays, mut secondary) = (0, 0);
    for (tree, lights, cam, first_mode) in packet_scenes() {
        let tree = &tree;
        for mode in [first_mode, HitMode::Cube] {
            for shadows in [
                ShadowMode::None,
                ShadowMode::Opaque,
                ShadowMode::MaxRefractivity,
                ShadowMode::Transmittance,
            ] {
                for (prepass, bounces) in [(true, 0), (false, 0), (true, 1), (false, 3)] {
                    let frame = |packets: bool| {
                        let t = Tracer::new(
                            OctreeSurfaces::new(tree, mode),
                            &lights,
                            Sky::default(),
                            Phong::default(),
                            TraceOptions {
                                mode,
                                shadows,
                                prepass,
                                packets,
                                max_reflections: bounces,
                                max_refractions: bounces,
                                max_path_bounces: if bounces == 1 { 1 } else { u8::MAX },
                                ..TraceOptions::default()
                            },
                        );
                        let mut hits = svo::render::Hits::default();
                        svo::render::cast_primary(&t, &cam, &mut hits).unwrap();
                        (render(&t, &cam).unwrap(), hits)
                    };
                    let ((a, ca), (b, cb)) = (frame(true), frame(false));
                    let what = format!("{mode:?} {shadows:?} prepass {prepass} bounces {bounces}");
                    assert_same_pixels(&a, &b, &what);
                    assert_eq!(a.stats, b.stats, "{what}");
                    assert_eq!((&ca.leaf, ca.steps), (&cb.leaf, cb.steps), "{what}");
                    shadow_rays += a.stats.shadow_rays;
                    secondary += a.stats.secondary_rays;
                }
            }
        }
    }
    assert!(
        shadow_rays > 10_000 && secondary > 10_000,
        "{shadow_rays} shadow and {secondary} secondary rays compared"
    );
}

/// The torus cut into chunks at each level (written as a version-3 file and read back a
/// chunk at a time, each chunk a tree of its own) renders as the whole tree does: with
/// shadows and a reflective floor, in the cube and contour hit modes, the same leaf under
/// every pixel but where a ray grazes a chunk's boundary (the ray moved into a chunk's grid
/// rounds there), and colours within a PSNR of 60 dB.
#[test]
fn a_tree_in_chunks_renders_as_the_whole_tree() {
    use svo::io::{BuildInfo, ChunkedFile, write_chunked_to};
    use svo::render::{ChunkTree, ChunkedSurfaces, compare};
    let mut tree = torus_tree(6);
    let n = tree.leaf_count as usize;
    tree.attributes.reflectivity =
        svo::Channel::PerLeaf((0..n).map(|i| (i % 3 * 60) as u8).collect());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.svo");
    let (lo, hi) = tree.occupied_bounds();
    let camera = Camera::framing(lo, hi, 96, 72, 40.0);
    let lights = [PointLight {
        position: DVec3::new(2.0, 3.0, 2.5),
        colour: Vec3::ONE,
        intensity: 20.0,
    }];
    let mut checked = 0;
    for mode in [HitMode::Cube, HitMode::Contour] {
        let trace = TraceOptions {
            mode,
            ..opts(ShadowMode::Opaque)
        };
        let whole = Tracer::new(
            OctreeSurfaces::new(&tree, mode),
            &lights,
            Sky::default(),
            Phong::default(),
            trace,
        );
        let want = render(&whole, &camera).unwrap();
        let hits = want
            .leaf
            .iter()
            .filter(|&&l| l != svo::render::NO_LEAF)
            .count();
        assert!(hits > 500, "{hits}");
        for level in 0..tree.depth {
            let mut bytes = Vec::new();
            write_chunked_to(&tree, &BuildInfo::new(), level, &mut bytes).unwrap();
            std::fs::write(&path, bytes).unwrap();
            let file = ChunkedFile::open(&path).unwrap();
            let chunks: Vec<ChunkTree> = (0..file.len())
                .map(|i| ChunkTree {
                    cell: file.chunk_cell(i),
                    first_leaf: file.chunk_leaves(i).1,
                    tree: file.read_chunk(i).unwrap(),
                })
                .collect();
            let s = ChunkedSurfaces::new(file.root(), file.depth(), level, &chunks, mode).unwrap();
            let t = Tracer::new(s, &lights, Sky::default(), Phong::default(), trace);
            let got = render(&t, &camera).unwrap();
            let differ = got
                .leaf
                .iter()
                .zip(&want.leaf)
                .filter(|(a, b)| a != b)
                .count();
            let diff = compare(&got, &want).unwrap();
            eprintln!(
                "{mode:?} level {level}: {differ} of {hits} leaves differ, PSNR {} dB",
                diff.psnr_db
            );
            assert!(
                differ <= hits / 500 && diff.psnr_db > 60.0,
                "{mode:?} level {level}: {differ} of {hits} leaves differ, PSNR {} dB",
                diff.psnr_db
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 12);
}

/// A tree and its graph (`DagSurfaces`) render the same images and AOVs bit for bit, and take
/// the same steps as the tree's walks (with the prepass and packets, and without): the torus with contours and cubes from outside, close up and inside its tube,
/// with shadows; a mirror-and-glass scene of stored normals with reflections and refractions;
/// and glass cells without normals (one medium) seen through.
#[test]
fn a_graph_renders_what_its_tree_renders() {
    let torus = torus_tree(7);
    let (lo, hi) = torus.occupied_bounds();
    let base = Camera::framing(lo, hi, 96, 72, 40.0);
    let c = (lo + hi) * 0.5;
    let close = Camera {
        eye: c + (base.eye - c) * 0.35,
        ..base
    };
    let inside = Camera {
        eye: c + DVec3::new((hi.x - lo.x) * 0.375, 0.0, 0.0),
        target: c + DVec3::new((hi.x - lo.x) * 0.375, 0.0, 1.0),
        ..base
    };
    for mode in [HitMode::Contour, HitMode::Cube] {
        for (k, cam) in [base, close, inside].iter().enumerate() {
            let stats = same_on_graph(&torus, mode, cam, &Sky::default(), &format!("torus {k}"));
            assert!(stats.shadow_rays > 0, "{stats:?}");
        }
    }
    // Mirrors under a glass slab with normals; a block of glass cells without normals.
    let (_, sky) = glass_slab_under_white_sky();
    let glass = |n: Vec3| Voxel {
        normal: Some(n),
        ..glass_pane()
    };
    let mut cells: Vec<(UVec3, Voxel)> = (0..16u32)
        .flat_map(|x| (0..12u32).map(move |z| (x, z)))
        .flat_map(|(x, z)| {
            [
                (UVec3::new(x, 4, z), glass(Vec3::NEG_Y)),
                (UVec3::new(x, 5, z), glass(Vec3::Y)),
            ]
        })
        .collect();
    cells.extend((0..16).map(|x| (UVec3::new(x, 1, 7), mirror(0.8))));
    cells.extend((3..9).flat_map(|x| (9..12).map(move |y| (UVec3::new(x, y, 4), glass_pane()))));
    let slab = grid16(cells);
    let cam = Camera {
        eye: DVec3::new(8.0, 14.0, 22.0),
        target: DVec3::new(7.0, 5.0, 3.0),
        up: DVec3::Y,
        fov_deg: 50.0,
        width: 80,
        height: 60,
    };
    for mode in [HitMode::Contour, HitMode::Cube] {
        let stats = same_on_graph(&slab, mode, &cam, &sky, "glass and mirrors");
        assert!(stats.secondary_rays > 1000, "{stats:?}");
    }
}

/// `tree`'s image of `cam` and its graph's, each with and without the primary prepass and
/// the packets: the same colours, depths, normals and leaves bit for bit, and the graph's
/// walks as many steps as the tree's the same way.
fn same_on_graph(
    tree: &Octree,
    mode: HitMode,
    cam: &Camera,
    sky: &Sky,
    what: &str,
) -> svo::render::RenderStats {
    let dag = svo::dag::DagTree::from_tree(tree).unwrap();
    let light = [PointLight {
        position: cam.eye + DVec3::new(0.3, 1.0, 0.2),
        colour: Vec3::ONE,
        intensity: 1.0,
    }];
    let opts = |fast: bool| TraceOptions {
        mode,
        prepass: fast,
        packets: fast,
        ..TraceOptions::default()
    };
    // Each renderer with and without the prepass and the packets.
    let frames = |graph: bool| {
        [true, false].map(|fast| {
            let o = opts(fast);
            let light = &light;
            let f = if graph {
                let s = svo::render::DagSurfaces::new(&dag, mode);
                render(
                    &Tracer::new(s, light, sky.clone(), Phong::default(), o),
                    cam,
                )
            } else {
                let s = OctreeSurfaces::new(tree, mode);
                render(
                    &Tracer::new(s, light, sky.clone(), Phong::default(), o),
                    cam,
                )
            };
            f.unwrap()
        })
    };
    let (on_tree, on_graph) = (frames(false), frames(true));
    let graph = &on_graph[0];
    assert!(graph.stats.primary_hits > 0, "{what}");
    for (k, (t, g)) in on_tree.iter().zip(&on_graph).enumerate() {
        for t in [t, &on_tree[1 - k]] {
            assert_eq!(g.colour, t.colour, "{what}, {mode:?}");
            assert_eq!(g.normal, t.normal, "{what}, {mode:?}");
            assert_eq!(g.leaf, t.leaf, "{what}, {mode:?}");
            assert!(
                g.depth
                    .iter()
                    .zip(&t.depth)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{what}, {mode:?}"
            );
        }
        // The same walks: the same steps.
        assert_eq!(g.stats.steps, t.stats.steps, "{what}, {mode:?}, fast {k}");
        assert_eq!(g.stats.secondary_rays, t.stats.secondary_rays, "{what}");
    }
    graph.stats
}
