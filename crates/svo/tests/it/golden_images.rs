//! Golden images: small renders committed under `fixtures/golden/`, compared with a
//! tolerance (every channel within 2 of 255, and at most 0.1% of pixels beyond that, for
//! libm differences between machines). On failure the render and a diff image are written
//! to `target/golden-diff/` and the test names them.
//!
//! To accept new images after an intended change: `SVO_BLESS=1 cargo test -p svo --test
//! golden_images`, then look at the images before committing them. Only the value `1`
//! blesses, and never under CI (the test fails there instead).
//!
//! The goldens only say that an image did not change. Each render is also checked on its own
//! terms: the torus against the triangle mesh traced through a BVH (every pixel the mesh
//! covers is covered, depths within the leaf size of the mesh's), the voxel scene against a
//! brute-force first hit over every occupied cell of its definition.
#![cfg(all(feature = "obj", feature = "image-io", feature = "reference"))]

use glam::{DVec3, UVec3, Vec3};
use std::path::{Path, PathBuf};
use svo::octree::{Octree, Voxel};
use svo::render::{
    Camera, Frame, MeshSurfaces, NO_LEAF, OctreeSurfaces, Phong, PointLight, ShadowMode, Sky,
    Surfaces, TraceOptions, Tracer, render,
};
use svo::trace::HitMode;
use svo::{BakeOptions, RootCube};

fn root_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn torus_mesh() -> svo::Mesh {
    svo::Mesh::load(root_dir().join("fixtures/torus.obj")).unwrap()
}

fn torus(depth: u8) -> Octree {
    let opts = BakeOptions {
        depth,
        ..BakeOptions::default()
    };
    svo::bake_mesh(&torus_mesh(), &opts).unwrap().0
}

/// The voxel scene's cells: what [`report_scene`] builds its tree from.
fn report_cells() -> Vec<UVec3> {
    let mut cells = Vec::new();
    for x in 0..32 {
        for y in 0..32 {
            for z in 0..32 {
                let c = UVec3::new(x, y, z);
                if report_voxel(c).is_some() {
                    cells.push(c);
                }
            }
        }
    }
    cells
}

/// A small version of the 2019 report's scene: a solid frame with glass panes (holes in
/// their middles), the front left open, a semi-solid cube in the centre, on a mirror floor.
fn report_scene() -> Octree {
    let root = RootCube {
        origin: DVec3::splat(-1.0),
        side: 2.0,
    };
    Octree::from_fn(root, 5, |_, _| true, report_voxel).unwrap()
}

/// The report scene's voxel at cell `c` of its 32^3 grid over `[-1, 1]^3`.
fn report_voxel(c: UVec3) -> Option<Voxel> {
    let n = 32u32;
    {
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
    }
}

fn camera(tree: &Octree, eye_dir: DVec3, zoom: f64) -> Camera {
    let (lo, hi) = tree.occupied_bounds();
    let mut cam = Camera::framing(lo, hi, 96, 72, 40.0);
    let centre = (lo + hi) * 0.5;
    cam.eye = centre + eye_dir * (cam.eye - centre).length() / zoom;
    cam
}

fn render_scene(tree: &Octree, mode: HitMode, eye_dir: DVec3, zoom: f64, bounces: u8) -> Frame {
    let cam = camera(tree, eye_dir, zoom);
    render_with(OctreeSurfaces::new(tree, mode), tree, &cam, mode, bounces)
}

fn render_with<S: Surfaces>(
    surfaces: S,
    tree: &Octree,
    cam: &Camera,
    mode: HitMode,
    bounces: u8,
) -> Frame {
    let (lo, hi) = tree.occupied_bounds();
    let centre = (lo + hi) * 0.5;
    let light = PointLight {
        position: centre + DVec3::new(0.6, 1.2, 0.9) * (hi - lo).length(),
        colour: Vec3::ONE,
        intensity: (1.5 * (hi - lo).length()).powi(2) as f32,
    };
    let t = Tracer::new(
        surfaces,
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
    render(&t, cam).unwrap()
}

fn check(name: &str, f: &Frame) {
    let rgb = svo::render::colour_rgb8(f);
    let path = root_dir()
        .join("fixtures/golden")
        .join(format!("{name}.png"));
    if std::env::var_os("SVO_BLESS").is_some_and(|v| v == "1") {
        assert!(
            !svo_tests::under_ci(),
            "SVO_BLESS=1 under CI: goldens are blessed on a developer's machine, never by CI"
        );
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

/// The torus render against the mesh traced through a BVH with the same camera: every pixel
/// whose ray hits the mesh hits a leaf, and no later than the mesh (the leaves hold every
/// cell the surface touches, and a contour slab holds the surface inside its leaf); hits
/// more than `slack` leaf sizes before the mesh's, or on no mesh at all, are rays that pass
/// through a leaf beside the surface, along the silhouette: fewer than `stray` of them. Every
/// hit point lies in a leaf the surface touches: within a leaf's diagonal plus the longest
/// edge of a mesh vertex.
fn check_against_mesh(view: &TorusView, slack: f32, stray: usize) {
    let TorusView {
        tree,
        mode,
        cam,
        frame: f,
    } = view;
    let (mode, cam) = (*mode, cam);
    let mesh = MeshSurfaces::new(torus_mesh(), tree.root, tree.depth);
    let reference = render_with(mesh, tree, cam, mode, 0);
    let cell = tree.root.cell_size(tree.depth) as f32;
    let mut strays = 0;
    for (i, (&d, &r)) in f.depth.iter().zip(&reference.depth).enumerate() {
        match (d.is_finite(), r.is_finite()) {
            (false, true) => panic!("{mode:?}, pixel {i}: the mesh is hit at {r}, no leaf is"),
            (true, false) => strays += 1,
            (true, true) => {
                assert!(
                    d <= r + 1e-4 * cell * (1.0 + r),
                    "{mode:?}, pixel {i}: leaf at {d}, behind the mesh at {r}"
                );
                strays += usize::from(r - d > slack * cell);
            }
            (false, false) => {}
        }
    }
    assert!(
        strays < stray,
        "{mode:?}: {strays} pixels hit away from the surface"
    );
    let torus = torus_mesh();
    let longest = torus
        .triangles
        .iter()
        .flat_map(|t| (0..3).map(|k| (t[k], t[(k + 1) % 3])))
        .map(|(a, b)| torus.positions[a as usize].distance(torus.positions[b as usize]))
        .fold(0.0, f64::max);
    let reach = 3f64.sqrt() * f64::from(cell) + longest;
    let rays = cam.rays().unwrap();
    let (w, h) = (f.width as usize, f.height as usize);
    for (i, &d) in f.depth.iter().enumerate() {
        if d.is_finite() {
            let dir = pixel_dir(&rays, i % w, i / w, w, h);
            let p = rays.eye() + dir * f64::from(d);
            let near = torus
                .positions
                .iter()
                .map(|q| q.distance(p))
                .fold(f64::INFINITY, f64::min);
            assert!(
                near < reach,
                "{mode:?}, pixel {i}: hit {near} from the mesh"
            );
        }
    }
    let hits = reference.depth.iter().filter(|d| d.is_finite()).count();
    assert!(hits > 1500, "{hits} pixels see the torus");
    eprintln!("{mode:?}: {strays} strays of {hits}");
}

/// The torus at depth 6 seen from above and aside in `mode`: the tree, the camera and the
/// render.
struct TorusView {
    tree: Octree,
    mode: HitMode,
    cam: Camera,
    frame: Frame,
}

fn torus_view(mode: HitMode) -> TorusView {
    let tree = torus(6);
    let cam = camera(&tree, DVec3::new(0.35, 0.6, 1.0).normalize(), 1.5);
    let frame = render_with(OctreeSurfaces::new(&tree, mode), &tree, &cam, mode, 2);
    TorusView {
        tree,
        mode,
        cam,
        frame,
    }
}

#[test]
fn golden_torus_contour() {
    let view = torus_view(HitMode::Contour);
    check_against_mesh(&view, 1.0, 40);
    check("torus_contour", &view.frame);
}

#[test]
fn golden_torus_cube() {
    let view = torus_view(HitMode::Cube);
    // Cubes are entered up to a diagonal before the surface inside them, and a ray at a
    // grazing angle crosses several touched cubes before it meets the surface.
    check_against_mesh(&view, 1.8, 1_000);
    check("torus_cube", &view.frame);
}

/// The direction of pixel `(x, y)`'s ray through its centre, in `f64` (the renderer's own
/// rays are `f32`).
fn pixel_dir(rays: &svo::render::CameraRays, x: usize, y: usize, w: usize, h: usize) -> DVec3 {
    let he = rays.half_extent();
    let sx = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * he.x;
    let sy = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * he.y;
    (rays.forward() + rays.right() * sx + rays.up() * sy).normalize()
}

/// The first occupied cell along each pixel's ray, by slab tests against every occupied cell
/// of the scene's definition, against the render's primary hits: the same hit or miss away
/// from cell edges, and the same distance.
fn check_report_scene_hits(tree: &Octree, f: &Frame, cam: &Camera) {
    let rays = cam.rays().unwrap();
    let cells = report_cells();
    let (w, h) = (f.width as usize, f.height as usize);
    let (mut compared, mut differ) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let dir = pixel_dir(&rays, x, y, w, h);
            let (o, cell) = (rays.eye(), 2.0 / 32.0);
            // Entry distance into each cell (closed slabs), the nearest kept; and how close
            // the ray passes to the boundary of the cell it enters (a near-tie is not judged).
            let mut best = (f64::INFINITY, f64::INFINITY);
            for c in &cells {
                let lo = DVec3::splat(-1.0) + c.as_dvec3() * cell;
                let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
                for k in 0..3 {
                    let (a, b) = ((lo[k] - o[k]) / dir[k], (lo[k] + cell - o[k]) / dir[k]);
                    t0 = t0.max(a.min(b));
                    t1 = t1.min(a.max(b));
                }
                if t0 <= t1 && t0 < best.0 {
                    best = (t0, t1 - t0);
                }
            }
            let i = y * w + x;
            let hit = f.leaf[i] != NO_LEAF;
            if best.0.is_finite() && best.1 < 1e-3 * cell {
                continue; // the ray grazes the edge of its first cell
            }
            compared += 1;
            if hit != best.0.is_finite() {
                differ += 1;
                continue;
            }
            if hit {
                let d = f64::from(f.depth[i]);
                assert!(
                    (d - best.0).abs() < 1e-3 * cell * (1.0 + best.0),
                    "pixel ({x}, {y}): depth {d}, first cell at {}",
                    best.0
                );
            }
        }
    }
    // The camera rays here are computed apart from the renderer's (in f64, not f32): a ray
    // within rounding of a cell's edge may decide differently.
    eprintln!("report scene: {differ} of {compared} pixels differ from the brute force");
    assert!(
        differ * 500 < compared,
        "{differ} of {compared} pixels differ"
    );
    assert!(compared > w * h * 9 / 10);
    let hits = f.leaf.iter().filter(|&&l| l != NO_LEAF).count();
    assert!(hits > 1_000, "{hits} pixels hit");
    assert!(tree.leaf_count as usize == cells.len());
}

#[test]
fn golden_report_scene_with_reflections_and_refractions() {
    let t = report_scene();
    let dir = DVec3::new(0.3, 0.35, 1.0).normalize();
    let f = render_scene(&t, HitMode::Cube, dir, 1.0, 3);
    assert!(f.stats.secondary_rays > 1000, "{:?}", f.stats);
    check_report_scene_hits(&t, &f, &camera(&t, dir, 1.0));
    check("report_scene", &f);
}
