//! The GPU checked against the CPU reference (lavapipe without a GPU): the headless image
//! equals the CPU image for the same scene, camera and settings within a tight tolerance,
//! with the same hit/miss mask; and the ray-batch entry point returns the same leaves as
//! `svo::trace::cast` on seeded random rays, axis-parallel rays with `+0.0`/`-0.0`,
//! rays through lattice corners and edges, and rays starting inside.
//!
//! Without an adapter the harness reports the tests ignored, except under CI (`CI` set), where
//! a missing adapter is a failure: CI installs lavapipe (`mesa-vulkan-drivers`).

use svo_tests::harness::{Need, Test};
use svo_tests::trial;

use crate::common;
use glam::{DVec3, Vec3};
use rand::{Rng, SeedableRng};
use std::path::Path;
use svo::dag::DagTree;
use svo::octree::{Octree, RootCube, Voxel};
use svo::render::{
    DagSurfaces, Frame, NO_LEAF, OctreeSurfaces, RenderScene, SceneSetup, ShadowMode, TraceOptions,
    Tracer, render,
};
use svo::trace::{GridRay, HitMode, MAX_STEPS, cast};
use svo_view::gpu_context::GpuContext;
use svo_view::gpu_render::{GpuLayout, GpuRenderer, MAX_ARENA_CHUNKS, arena_bindings};
use svo_view::gpu_types::{GpuRay, ShaderVariant, tree_uniforms};
use svo_view::headless::render_scene;

/// The shared device, taken in turn ([`common::gpu_context`]).
fn gpu() -> Option<std::sync::MutexGuard<'static, GpuContext>> {
    common::gpu_context().ok()
}

/// How many of `n` leaves or rays may differ between the GPU and the CPU: none on lavapipe,
/// where the shader's `f32` arithmetic is the CPU's bit for bit (every comparison here finds 0
/// differences there); on other adapters `n / per`, since WGSL lets a driver fuse a multiply
/// and an add, which can move a ray that ties on a cell boundary by an ulp into the
/// neighbouring leaf.
fn allowed(ctx: &GpuContext, n: usize, per: usize) -> usize {
    if ctx.adapter_name().contains("llvmpipe") {
        0
    } else {
        n / per
    }
}

/// The torus fixture's material made glass: 20% opacity, IOR 1.5, a little specular.
const GLASS_MTL: &str = "newmtl copper\nKd 0.85 0.92 1.0\nKs 0.1 0.1 0.1\nNi 1.5\nd 0.2\nillum 7\n";

fn torus(mtl: Option<&str>, depth: u8) -> Octree {
    torus_with(mtl, depth, None)
}

fn torus_with(mtl: Option<&str>, depth: u8, solid: Option<svo::bake::SolidMode>) -> Octree {
    let opts = svo::BakeOptions {
        depth,
        solid,
        ..svo::BakeOptions::default()
    };
    torus_baked(mtl, &opts)
}

/// The torus fixture (with material `mtl`) baked with `opts`.
fn torus_baked(mtl: Option<&str>, opts: &svo::BakeOptions) -> Octree {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    let obj = match mtl {
        None => fixtures.join("torus.obj"),
        Some(m) => {
            // The torus with another material: a copy in a temporary folder.
            let dir = tempfile::tempdir().unwrap().keep();
            let src = std::fs::read_to_string(fixtures.join("torus.obj")).unwrap();
            std::fs::write(dir.join("torus.obj"), src).unwrap();
            std::fs::write(dir.join("torus.mtl"), m).unwrap();
            dir.join("torus.obj")
        }
    };
    let mesh = svo::Mesh::load(&obj).unwrap();
    svo::bake_mesh(&mesh, opts).unwrap().0
}

/// The torus (with material `mtl`) baked at `depth` with its inner nodes' attributes: the
/// same nodes and leaves as without them.
fn torus_with_levels(mtl: Option<&str>, depth: u8) -> Octree {
    let opts = svo::BakeOptions {
        depth,
        node_attributes: true,
        ..svo::BakeOptions::default()
    };
    let tree = torus_baked(mtl, &opts);
    let plain = torus(mtl, depth);
    // The nodes in level order, the same shape.
    assert!(svo_tests::node_order::same_shape(&tree, &plain));
    assert_eq!(tree.attributes, plain.attributes);
    tree
}

/// A level of detail (rays stop at inner nodes as wide as their cones; secondary and shadow
/// rays keep the cone's width) renders the same on the GPU as on the CPU: the copper torus
/// with contours and shadows at three and six pixels, in cube mode at four, and the glass
/// torus (refraction through the nodes' IOR) at four. Inner nodes are hit, and fewer steps are
/// taken than at `--lod 0`.
fn a_level_of_detail_renders_the_same() {
    let glass = GLASS_MTL;
    let exact = same_image(torus_with_levels(None, 7), TraceOptions::default(), 0.5);
    let Some(exact) = exact else {
        return;
    };
    // A pixel of this view is about one and a half leaves wide.
    let cases = [
        (None, 3.0, HitMode::Contour, 0.5),
        (None, 6.0, HitMode::Contour, 0.5),
        (None, 4.0, HitMode::Cube, 0.5),
        (Some(glass), 4.0, HitMode::Contour, 2.0),
    ];
    for (mtl, lod, mode, max_rmse) in cases {
        let tree = torus_with_levels(mtl, 7);
        let trace = TraceOptions {
            lod,
            mode,
            ..TraceOptions::default()
        };
        let v = ShaderVariant::for_scene(&tree, &trace, 1);
        assert!(v.lod && v.node_channels[0] != 0, "{v:?}");
        let s = scene(tree.clone());
        let nodes = cpu_frame(&s, &trace)
            .leaf
            .iter()
            .filter(|&&id| id != NO_LEAF && id & svo::render::NODE_ID != 0)
            .count();
        assert!(nodes > 100, "lod {lod}: {nodes} pixels on inner nodes");
        let st = same_image(tree, trace, max_rmse).unwrap();
        if mtl.is_none() && mode == HitMode::Contour {
            assert!(st.primary_steps < exact.primary_steps, "lod {lod}: {st:?}");
        }
    }
    // The 64-ary view has none: a level of detail is refused there, with one line.
    let ctx = gpu().unwrap();
    let tree = torus_with_levels(None, 6);
    let trace = TraceOptions {
        lod: 2.0,
        ..TraceOptions::default()
    };
    let wide = GpuLayout {
        wide_view: true,
        ..GpuLayout::default()
    };
    let v = ShaderVariant::for_scene(&tree, &trace, 1);
    let e = GpuRenderer::with_options(&ctx, &tree, v, 16, 16, &wide).err();
    assert!(
        e.is_some_and(|e| e.to_string().contains("level of detail")),
        "the wide view took a level of detail"
    );
    drop(ctx);
    // Without the inner nodes' attributes there is no level of detail to compile.
    let plain = ShaderVariant::for_scene(
        &torus(None, 7),
        &TraceOptions {
            lod: 2.0,
            ..TraceOptions::default()
        },
        1,
    );
    assert!(!plain.lod && plain.node_channels == [0; 6]);
}

/// A tree larger than the adapter's bindings (here: bindings made small) is shown from the
/// deepest prefix of its levels that fits, never from the leaf parents' level (which keeps no
/// values), and that prefix renders on the GPU as on the CPU; a tree that fits is left alone.
fn a_tree_too_large_for_the_adapter_shows_its_top_levels() {
    let Some(ctx) = gpu() else {
        return;
    };
    let tree = torus_with_levels(None, 7);
    let trace = TraceOptions::default();
    let whole =
        svo_view::gpu_render::arena_bytes(&tree, &ShaderVariant::for_scene(&tree, &trace, 1));
    let mut s = scene(tree.clone());
    assert_eq!(
        svo_view::fit::fit_scene(&ctx, &mut s, &trace, &GpuLayout::default()).unwrap(),
        None
    );
    // Four bindings of a sixteenth of the tree's bytes each hold a quarter of it.
    let small = GpuLayout {
        chunk_limit: Some(whole / 16),
        ..GpuLayout::default()
    };
    let p = svo_view::fit::fit_scene(&ctx, &mut s, &trace, &small)
        .unwrap()
        .expect("the tree does not fit");
    assert!(p.depth < 6 && p.of == 7 && p.needed == whole, "{p:?}");
    assert!(
        p.to_string()
            .starts_with(&format!("showing the top {} of 7 levels", p.depth))
    );
    assert_eq!(s.tree.depth, p.depth);
    assert_eq!(s.tree, tree.top_levels(p.depth).unwrap());
    let v = ShaderVariant::for_scene(&s.tree, &trace, s.lights.len());
    assert!(svo_view::gpu_render::arena_bytes(&s.tree, &v) <= p.limit);
    let r = GpuRenderer::with_options(&ctx, &s.tree, v, 96, 72, &small).unwrap();
    let g = render_with(&ctx, &s, &trace, &r);
    let c = cpu_frame(&s, &trace);
    assert_eq!(g.leaf, c.leaf);
    assert!(c.stats.primary_hits > 0);
    assert!(svo::render::compare(&g, &c).unwrap().rmse <= 0.5);
}

/// A version-4 file's header tells how much of it an adapter holds before any level is read
/// (what `--headless` reads of a file too large): with and without a level of detail, for a
/// limit of each prefix's arena the depth chosen is the deepest prefix within it (never the
/// leaf parents' level, which keeps no values), and the estimate of the whole is its arena;
/// a version-2 file has no level table. Needs no adapter.
fn the_header_says_which_prefix_of_a_file_fits() {
    let tree = torus_with_levels(None, 7);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("levels.svo");
    svo::io::write_file(&tree, &svo::io::BuildInfo::new(), &path).unwrap();
    let sizes = svo::io::read_level_sizes(&path).unwrap().unwrap();
    assert_eq!(sizes.counts.len(), 8);
    assert_eq!(sizes.counts[7], u64::from(tree.leaf_count));
    for lod in [0.0, 1.0] {
        let trace = TraceOptions {
            lod,
            ..TraceOptions::default()
        };
        let arena = |t: &Octree| {
            svo_view::gpu_render::arena_bytes(t, &ShaderVariant::for_scene(t, &trace, 1))
        };
        let whole = arena(&tree);
        let fits = |limit| svo_view::fit::prefix_depth(&sizes, limit, lod > 0.0);
        assert_eq!(fits(whole), None);
        let tops: Vec<u64> = (1..7u8)
            .map(|k| arena(&svo::io::read_file_to_depth(&path, k).unwrap().0))
            .collect();
        for k in 1..7u8 {
            let limit = tops[usize::from(k) - 1];
            let (got, estimate) = fits(limit).unwrap();
            // The deepest prefix but the leaf parents' whose arena is within the limit.
            let want = (1..6u8)
                .rev()
                .find(|&j| tops[usize::from(j) - 1] <= limit)
                .unwrap_or(1);
            assert_eq!(got, want, "lod {lod}, prefix of {k} levels");
            assert_eq!(estimate, whole, "lod {lod}");
        }
    }
    let plain = dir.path().join("plain.svo");
    svo::io::write_file(&torus(None, 5), &svo::io::BuildInfo::new(), &plain).unwrap();
    assert_eq!(svo::io::read_level_sizes(&plain).unwrap(), None);
}

/// A version-4 file larger than the adapter is read only as deep as its header says fits:
/// `--headless` renders the top levels it read and says what of the file it shows, the same
/// image as the CPU's of that prefix.
fn a_file_too_large_for_the_adapter_is_read_only_as_deep_as_fits() {
    let Some(ctx) = gpu() else {
        return;
    };
    drop(ctx);
    let tree = torus_with_levels(None, 7);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("levels.svo");
    svo::io::write_file(&tree, &svo::io::BuildInfo::new(), &path).unwrap();
    let trace = TraceOptions {
        lod: 1.0,
        ..TraceOptions::default()
    };
    let whole =
        svo_view::gpu_render::arena_bytes(&tree, &ShaderVariant::for_scene(&tree, &trace, 1));
    let job = svo_view::job::RenderJob {
        input: path.clone(),
        output: Some(dir.path().join("top.png")),
        width: 96,
        height: 72,
        trace,
        ..Default::default()
    };
    let opts = svo_view::headless::HeadlessOptions {
        vs_cpu: true,
        layout: GpuLayout {
            chunk_limit: Some(whole / 16),
            ..GpuLayout::default()
        },
        ..Default::default()
    };
    let r = svo_view::headless::run(&job, &opts).unwrap();
    let gpu = r.gpu.unwrap();
    let p = gpu.shown.expect("the file does not fit");
    assert!(p.depth < 6 && p.of == 7 && p.needed == whole, "{p:?}");
    assert_eq!(r.depth, p.depth);
    let top = svo::io::read_file_to_depth(&path, p.depth).unwrap().0;
    assert_eq!(r.leaves, u64::from(top.leaf_count));
    let v = gpu.vs_cpu.unwrap();
    assert!(v.diff.rmse <= 0.5 && v.leaf_mismatch == 0.0, "{v:?}");
}

/// The scene of `tree` at 96x72 with the default camera and light.
fn scene(tree: Octree) -> RenderScene {
    let setup = SceneSetup {
        width: 96,
        height: 72,
        ..SceneSetup::default()
    };
    RenderScene::new(tree, &Default::default(), &setup).unwrap()
}

fn cpu_frame(s: &RenderScene, trace: &TraceOptions) -> Frame {
    frame_on(s, OctreeSurfaces::new(&s.tree, trace.mode), trace)
}

/// The CPU's frame of scene `s` (its camera, lights, sky and shading) on `surfaces`.
fn frame_on<S: svo::render::Surfaces>(s: &RenderScene, surfaces: S, trace: &TraceOptions) -> Frame {
    let t = Tracer::new(surfaces, &s.lights, s.sky.clone(), s.phong, *trace);
    render(&t, &s.camera).unwrap()
}

/// A hash of a cell, for scattering cells over a tree.
fn cell_hash(c: glam::UVec3) -> u32 {
    c.x.wrapping_mul(73_856_093) ^ c.y.wrapping_mul(19_349_663) ^ c.z.wrapping_mul(83_492_791)
}

/// Renders `tree` on both and checks the images: the same hit/miss mask, nearly the same
/// leaves, an RMSE (8-bit sRGB) of at most `max_rmse`, and depths within 1e-4 relative
/// where the leaves agree. Returns the GPU frame's counters for further checks.
fn same_image(
    tree: Octree,
    trace: TraceOptions,
    max_rmse: f64,
) -> Option<svo::render::RenderStats> {
    let ctx = gpu()?;
    let s = scene(tree);
    let g = render_scene(&ctx, &s, &trace, &Default::default(), None).unwrap();
    let c = cpu_frame(&s, &trace);
    let diff = svo::render::compare(&g.frame, &c).unwrap();
    let n = c.leaf.len();
    let leaf_diff = g
        .frame
        .leaf
        .iter()
        .zip(&c.leaf)
        .filter(|(a, b)| a != b)
        .count();
    eprintln!(
        "{}: RMSE {:.3}, max {}, hit/miss {:.4}, leaves differ on {leaf_diff} of {n}",
        g.variant.describe(),
        diff.rmse,
        diff.max_abs,
        diff.hit_mismatch
    );
    assert_eq!(diff.hit_mismatch, 0.0, "hit/miss masks differ");
    assert!(
        leaf_diff <= allowed(&ctx, n, 200),
        "{leaf_diff} of {n} leaves differ"
    );
    assert!(diff.rmse <= max_rmse, "RMSE {} > {max_rmse}", diff.rmse);
    for i in 0..n {
        if g.frame.leaf[i] == c.leaf[i] && c.leaf[i] != NO_LEAF {
            let (a, b) = (g.frame.depth[i], c.depth[i]);
            assert!(
                (a - b).abs() <= 1e-4 * b.abs().max(1e-3),
                "pixel {i}: depth {a} vs {b}"
            );
        }
    }
    assert!(c.stats.primary_hits > 0, "the scene is not in view");
    assert_eq!(g.frame.stats.primary_hits, c.stats.primary_hits);
    assert_eq!(g.frame.stats.capped, 0);
    Some(g.frame.stats)
}

fn reflective_torus_contour_with_shadows() {
    // The fixture's copper: reflection, one light, product shadows.
    let Some(st) = same_image(torus(None, 6), TraceOptions::default(), 0.5) else {
        return;
    };
    assert!(st.secondary_rays > 0 && st.shadow_rays > 0, "{st:?}");
}

fn glass_torus_cube_refraction() {
    let glass = GLASS_MTL;
    let trace = TraceOptions {
        mode: HitMode::Cube,
        shadows: ShadowMode::MaxRefractivity,
        ..TraceOptions::default()
    };
    // Refraction chains through cube faces amplify rounding: a looser bound.
    let Some(st) = same_image(torus(Some(glass), 5), trace, 2.0) else {
        return;
    };
    assert!(st.secondary_rays > st.primary_hits, "{st:?}");
}

/// The path limit of the 2015 thesis's tracer (one bounce a path: the primary ray's
/// reflection and refraction, nothing after them) on the glass torus: the same image as the
/// CPU, at most two secondary rays per primary hit, fewer than without the limit.
fn path_bounce_limit_of_one_renders_the_same() {
    let glass = GLASS_MTL;
    let trace = TraceOptions {
        max_path_bounces: 1,
        ..TraceOptions::default()
    };
    let Some(one) = same_image(torus(Some(glass), 5), trace, 2.0) else {
        return;
    };
    assert!(
        one.secondary_rays > one.primary_hits && one.secondary_rays <= 2 * one.primary_hits,
        "{one:?}"
    );
    let all = same_image(torus(Some(glass), 5), TraceOptions::default(), 2.0).unwrap();
    assert!(all.secondary_rays > one.secondary_rays, "{all:?}");
}

/// Scenes that take every path of the shader: glass (contours and cubes, the glass tori at
/// `glass_depth`; shadow rays traced between the hit and its rays), a mirror, a solid
/// bake's interior leaves and a volumetric medium (depth 6 and 5).
fn scenes_of_every_path(glass_depth: u8) -> Vec<(&'static str, Octree, TraceOptions)> {
    let glass = GLASS_MTL;
    let cube = TraceOptions {
        mode: HitMode::Cube,
        ..TraceOptions::default()
    };
    let opaque_shadows = TraceOptions {
        shadows: ShadowMode::Opaque,
        ..TraceOptions::default()
    };
    vec![
        (
            "glass torus",
            torus(Some(glass), glass_depth),
            TraceOptions::default(),
        ),
        ("glass torus, cubes", torus(Some(glass), glass_depth), cube),
        ("copper torus", torus(None, 6), TraceOptions::default()),
        (
            "solid glass torus",
            torus_with(Some(glass), 6, Some(svo::bake::SolidMode::Closed)),
            TraceOptions::default(),
        ),
        ("glass block", glass_block_on_a_floor(), opaque_shadows),
    ]
}

/// [`scenes_of_every_path`] at depth 6, and glass at depths 5 and 7 and a mirror at 2 and 3
/// (opaque shadows).
fn every_path_and_depth() -> Vec<(&'static str, Octree, TraceOptions)> {
    let opaque_shadows = TraceOptions {
        shadows: ShadowMode::Opaque,
        ..TraceOptions::default()
    };
    let mut cases = scenes_of_every_path(6);
    for depth in [5, 7] {
        let name = ["glass torus, depth 5", "glass torus, depth 7"][usize::from(depth == 7)];
        cases.push((name, torus(Some(GLASS_MTL), depth), TraceOptions::default()));
    }
    cases.push(("copper torus, depth 2", torus(None, 2), opaque_shadows));
    cases.push(("copper torus, depth 3", torus(None, 3), opaque_shadows));
    cases
}

/// The traversal through the tree's 64-ary view (`GpuLayout::wide_view`) against the
/// octree's walk: the same frames bit for bit (colour, depth, normal, leaf) and the same rays
/// of each kind, on glass (contours and cubes, shadow rays traced between the hit and its
/// rays), a mirror, a solid bake's interior leaves and a volumetric medium, at even depths and
/// at odd ones (whose view has a root of 2x2x2 cells, down to depth 1), with the scene's
/// shader and with every shader path compiled in. Its steps count cells, so they differ; at
/// depth 6 and deeper they are fewer.
fn the_wide_view_renders_the_same() {
    let Some(ctx) = gpu() else {
        return;
    };
    let opaque_shadows = TraceOptions {
        shadows: ShadowMode::Opaque,
        ..TraceOptions::default()
    };
    let mut cases = every_path_and_depth();
    cases.push(("copper torus, depth 1", torus(None, 1), opaque_shadows));
    let mut walked = 0;
    for (name, tree, trace) in cases {
        let s = scene(tree);
        for full in [false, true] {
            let mut variant = ShaderVariant::for_scene(&s.tree, &trace, s.lights.len());
            if full {
                variant = variant.everything();
            }
            let frame = |wide_view: bool| {
                let layout = GpuLayout {
                    wide_view,
                    ..GpuLayout::default()
                };
                let r = GpuRenderer::with_options(
                    &ctx,
                    &s.tree,
                    variant,
                    s.camera.width,
                    s.camera.height,
                    &layout,
                )
                .unwrap();
                assert_eq!(r.wide_view(), wide_view, "{name}");
                render_with(&ctx, &s, &trace, &r)
            };
            let (a, b) = (frame(false), frame(true));
            walked += 1;
            let what = format!("{name}, full shader {full}");
            assert!(a.stats.primary_hits > 0, "{what}");
            assert_eq!(a.colour, b.colour, "{what}");
            assert_eq!(a.depth, b.depth, "{what}");
            assert_eq!(a.normal, b.normal, "{what}");
            assert_eq!(a.leaf, b.leaf, "{what}");
            let rays = |f: &Frame| {
                let st = &f.stats;
                (
                    st.primary_rays,
                    st.primary_hits,
                    st.secondary_rays,
                    st.shadow_rays,
                    st.capped,
                )
            };
            assert_eq!(rays(&a), rays(&b), "{what}");
            if s.tree.depth >= 6 {
                // A tree this deep has empty 4x4x4 regions to cross in fewer steps (at depth 2
                // the octree steps over an empty 2x2x2 block where the view walks its cells).
                assert!(
                    b.stats.steps < a.stats.steps,
                    "{what}: {:?} {:?}",
                    a.stats,
                    b.stats
                );
            }
        }
    }
    assert!(walked >= 20, "{walked}");
}

/// A tree's graph (`svo::dag::DagTree`, what a DAG file reads as) renders on the GPU the
/// frames its tree renders, bit for bit (colour, depth, normal, leaf, steps a pixel, and the
/// rays of each kind), on every shading path (glass with contours and cubes, a mirror, a
/// solid bake's interior leaves, a volumetric medium), at depths 2 (the root a brick) to 7,
/// with the scene's shader and with every path compiled in; and the CPU walks the graph to the
/// same leaves.
fn a_graph_renders_the_frames_of_its_tree() {
    let Some(ctx) = gpu() else {
        return;
    };
    let mut walked = 0;
    for (name, tree, trace) in every_path_and_depth() {
        let s = scene(tree);
        let dag = DagTree::from_tree(&s.tree).unwrap();
        for full in [false, true] {
            let mut variant = ShaderVariant::for_scene(&s.tree, &trace, s.lights.len());
            if full {
                variant = variant.everything();
            }
            assert_eq!(
                ShaderVariant::for_scene(&dag, &trace, s.lights.len()).everything(),
                variant.everything()
            );
            let (w, h) = (s.camera.width, s.camera.height);
            let a = render_with(
                &ctx,
                &s,
                &trace,
                &GpuRenderer::new(&ctx, &s.tree, variant, w, h).unwrap(),
            );
            let r = GpuRenderer::new(&ctx, &dag, variant, w, h).unwrap();
            let u =
                svo_view::gpu_types::uniforms(&dag, &s.camera, &s.lights, &s.sky, &s.phong, &trace)
                    .unwrap();
            r.render(&ctx, &u).unwrap();
            let b = r.read_frame(&ctx, std::time::Duration::ZERO).unwrap();
            walked += 1;
            let what = format!("{name}, full shader {full}");
            assert!(a.stats.primary_hits > 0, "{what}");
            assert_eq!(a.colour, b.colour, "{what}");
            assert_eq!(a.depth, b.depth, "{what}");
            assert_eq!(a.normal, b.normal, "{what}");
            assert_eq!(a.leaf, b.leaf, "{what}");
            assert_eq!(a.cost, b.cost, "{what}");
            assert_eq!(a.stats, b.stats, "{what}");
            if !full {
                // The CPU's walk of the graph meets the GPU's leaves.
                let c = frame_on(&s, DagSurfaces::new(&dag, trace.mode), &trace);
                let differ = c.leaf.iter().zip(&b.leaf).filter(|(x, y)| x != y).count();
                assert!(
                    differ <= allowed(&ctx, c.leaf.len(), 200),
                    "{what}: {differ} leaves differ"
                );
            }
        }
    }
    assert!(walked >= 14, "{walked}");
    // The 64-ary view is made from a tree: a graph is refused there, with one line.
    let dag = DagTree::from_tree(&torus(None, 4)).unwrap();
    let wide = GpuLayout {
        wide_view: true,
        ..GpuLayout::default()
    };
    let v = ShaderVariant::for_scene(&dag, &TraceOptions::default(), 1);
    let e = GpuRenderer::with_options(&ctx, &dag, v, 8, 8, &wide).err();
    assert!(
        e.is_some_and(|e| e.to_string().contains("64-ary")),
        "the wide view took a graph"
    );
}

/// A graph whose leaves take their values from a level above (the inner nodes' normals,
/// `DagValues`), on the GPU as on the CPU: the copper torus at depth 7 (reflections, product
/// shadows) with values on levels 5 (the bricks'), 6 (the leaf parents') and 4, normals in 16
/// and 32 bits, colours in 4, 16 and 32: the same hit mask, the same leaves (values' indices)
/// and the same pixels (nearly, on a hardware GPU) as the CPU's render of the graph, which is
/// the image of the tree the file reads as; the leaves' indices are fewer than the leaves.
fn a_graph_with_values_above_its_leaves_renders_the_same() {
    let Some(ctx) = gpu() else {
        return;
    };
    let mut tree = torus_with_levels(None, 7);
    tree.attributes.contour = svo::octree::Channel::Absent;
    tree.node_attributes.contour = svo::octree::Channel::Absent;
    let s = scene(tree.clone());
    let trace = TraceOptions {
        mode: HitMode::Cube,
        ..TraceOptions::default()
    };
    for (level, normal_bits, colour_bits) in [(5u8, 16u8, 4u8), (4, 32, 32), (7, 16, 16)] {
        let values = svo::dag::DagValues {
            level: Some(level),
            normal_bits,
            colour_bits,
        };
        let dag = DagTree::from_tree_with(&tree, &values).unwrap();
        let variant = ShaderVariant::for_scene(&dag, &trace, s.lights.len());
        let (w, h) = (s.camera.width, s.camera.height);
        let r = GpuRenderer::new(&ctx, &dag, variant, w, h).unwrap();
        let u = svo_view::gpu_types::uniforms(&dag, &s.camera, &s.lights, &s.sky, &s.phong, &trace)
            .unwrap();
        r.render(&ctx, &u).unwrap();
        let g = r.read_frame(&ctx, std::time::Duration::ZERO).unwrap();
        let c = frame_on(&s, DagSurfaces::new(&dag, trace.mode), &trace);
        let diff = svo::render::compare(&g, &c).unwrap();
        let what = format!("level {level}, {normal_bits} bits");
        assert_eq!(diff.hit_mismatch, 0.0, "{what}");
        let differ = g.leaf.iter().zip(&c.leaf).filter(|(a, b)| a != b).count();
        assert!(
            differ <= allowed(&ctx, c.leaf.len(), 200),
            "{what}: {differ} leaves differ"
        );
        assert!(diff.rmse <= 0.5, "{what}: RMSE {}", diff.rmse);
        // Shadow and secondary rays skip the leaf they start on, not the leaves that share
        // its ancestor's values: the pixels are the CPU's, and the CPU's those of the tree
        // whose leaves hold their ancestors' values (the file's tree).
        let (gc, cc) = (svo::render::colour_rgb8(&g), svo::render::colour_rgb8(&c));
        let px = gc
            .chunks(3)
            .zip(cc.chunks(3))
            .filter(|(a, b)| a != b)
            .count();
        assert!(
            px <= allowed(&ctx, c.colour.len(), 200),
            "{what}: {px} pixels differ"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.svo");
        svo::io::write_dag_file_with(&tree, &svo::io::BuildInfo::new(), &values, &path).unwrap();
        let (read, _) = svo::io::read_file(&path).unwrap();
        let on_tree = frame_on(&s, OctreeSurfaces::new(&read, trace.mode), &trace);
        assert!(
            on_tree.colour == c.colour,
            "{what}: the tree's image differs"
        );
        let most = c
            .leaf
            .iter()
            .filter(|&&l| l != NO_LEAF)
            .max()
            .copied()
            .unwrap();
        if level < 7 {
            assert!(
                u64::from(most) * 8 < dag.leaf_count(),
                "{what}: index {most}"
            );
        }
    }
}

/// The 2015 thesis's own scene (`examples/scenes/pool.toml`: the Stanford bunny from
/// `../shared/models` in a pool of water) at depth 7, its three views with its settings
/// (contours, no shadow rays, one bounce a path): the GPU against the CPU (the same hit/miss
/// mask, nearly the same leaves and colours), and the GPU's two walks against each other,
/// bit for bit.
fn the_thesis_pool_views() {
    let Some(path) = svo_tests::pool_scene() else {
        return;
    };
    let Some(ctx) = gpu() else {
        return;
    };
    let pool = svo::scene::load_scene(&path).unwrap();
    let opts = svo::BakeOptions {
        depth: 7,
        ..svo::BakeOptions::default()
    };
    let (tree, _) = svo::bake_mesh(&pool.mesh, &opts).unwrap();
    let trace = TraceOptions {
        max_reflections: 1,
        max_refractions: 1,
        max_path_bounces: 1,
        shadows: ShadowMode::None,
        ..TraceOptions::default()
    };
    for view in ["water", "bunny", "parallel"] {
        let setup = SceneSetup {
            width: 120,
            height: 75,
            view: Some(view.into()),
            ..SceneSetup::default()
        };
        let s = RenderScene::new(tree.clone(), &pool.info, &setup).unwrap();
        let c = cpu_frame(&s, &trace);
        let gpu_frame = |wide_view: bool| {
            let variant = ShaderVariant::for_scene(&s.tree, &trace, s.lights.len());
            let layout = GpuLayout {
                wide_view,
                ..GpuLayout::default()
            };
            let r = GpuRenderer::with_options(&ctx, &s.tree, variant, 120, 75, &layout).unwrap();
            render_with(&ctx, &s, &trace, &r)
        };
        let g = gpu_frame(false);
        let diff = svo::render::compare(&g, &c).unwrap();
        let leaf_diff = g.leaf.iter().zip(&c.leaf).filter(|(a, b)| a != b).count();
        eprintln!(
            "{view}: RMSE {:.3} against the CPU, leaves differ on {leaf_diff}; {} secondary rays",
            diff.rmse, g.stats.secondary_rays
        );
        assert_eq!(diff.hit_mismatch, 0.0, "{view}");
        assert!(
            leaf_diff <= allowed(&ctx, c.leaf.len(), 200),
            "{view}: {leaf_diff} leaves differ"
        );
        assert!(diff.rmse <= 1.0, "{view}: RMSE {}", diff.rmse);
        assert_eq!(g.stats.secondary_rays, c.stats.secondary_rays, "{view}");
        assert!(g.stats.secondary_rays <= 2 * g.stats.primary_hits, "{view}");
        let wide = gpu_frame(true);
        assert_eq!(g.colour, wide.colour, "{view} through the view");
        assert_eq!(g.depth, wide.depth, "{view} through the view");
        assert_eq!(g.normal, wide.normal, "{view} through the view");
        assert_eq!(g.leaf, wide.leaf, "{view} through the view");
    }
}

fn solid_glass_torus_passes_through_its_interior_leaves() {
    // A solid bake: the interior leaves (normal word NO_NORMAL) are passed through on both
    // tracers, so refracted rays meet the far side of the surface, not the next cell.
    let glass = "newmtl copper\nKd 0.85 0.92 1.0\nKs 0.1 0.1 0.1\nNi 1.5\nd 0.3\nillum 7\n";
    let tree = torus_with(Some(glass), 6, Some(svo::bake::SolidMode::Closed));
    assert!(tree.attributes.has_interior());
    let trace = TraceOptions {
        shadows: ShadowMode::Transmittance,
        ..TraceOptions::default()
    };
    let variant = ShaderVariant::for_scene(&tree, &trace, 1);
    assert!(variant.interior && variant.describe().contains("interior"));
    let Some(st) = same_image(tree, trace, 1.0) else {
        return;
    };
    assert!(st.secondary_rays > st.primary_hits, "{st:?}");
}

/// The 2019 report's kind of scene: a glass block without normals (a volumetric medium)
/// standing on an opaque floor.
fn glass_block_on_a_floor() -> Octree {
    let root = RootCube {
        origin: DVec3::ZERO,
        side: 1.0,
    };
    Octree::from_fn(
        root,
        5,
        |_, _| true,
        |c| {
            if c.y == 0 {
                Some(Voxel::solid([0.7, 0.5, 0.3, 1.0]))
            } else if (10..22).contains(&c.x) && (1..12).contains(&c.y) && (10..22).contains(&c.z) {
                Some(Voxel::glass())
            } else {
                None
            }
        },
    )
    .unwrap()
}

fn volumetric_glass_block_on_a_floor() {
    // Opaque-shadowed.
    let trace = TraceOptions {
        shadows: ShadowMode::Opaque,
        ..TraceOptions::default()
    };
    let Some(st) = same_image(glass_block_on_a_floor(), trace, 1.0) else {
        return;
    };
    assert!(st.secondary_rays > 0, "{st:?}");
}

/// The 2019 report's voxel box (glass panes and semi-solid cube as volumetric media, a
/// solid frame, void holes): the same image on both.
fn report_scene_2019() {
    let tree = svo_examples::report2019::report_scene(5, 64, 64)
        .unwrap()
        .tree;
    let trace = TraceOptions {
        mode: HitMode::Cube,
        shadows: ShadowMode::Transmittance,
        ..TraceOptions::default()
    };
    let Some(st) = same_image(tree, trace, 1.0) else {
        return;
    };
    assert!(st.secondary_rays > st.primary_hits, "{st:?}");
}

/// A glass box inside a water box (surface leaves with outward normals): refraction from
/// water into glass and back uses both media's IORs (nested media), on both tracers.
fn glass_inside_water_nested_media() {
    let root = RootCube {
        origin: DVec3::ZERO,
        side: 1.0,
    };
    // The outward normal of a cell on the surface of the box [lo, hi) (sum of the faces it
    // lies on), or None inside or outside it.
    let shell = |c: glam::UVec3, lo: u32, hi: u32| -> Option<Vec3> {
        let inside = |v: u32| (lo..hi).contains(&v);
        if !(inside(c.x) && inside(c.y) && inside(c.z)) {
            return None;
        }
        let axis = |v: u32| {
            if v == lo {
                -1.0
            } else if v == hi - 1 {
                1.0
            } else {
                0.0
            }
        };
        let n = Vec3::new(axis(c.x), axis(c.y), axis(c.z));
        (n != Vec3::ZERO).then(|| n.normalize())
    };
    let tree = Octree::from_fn(
        root,
        5,
        |_, _| true,
        |c| {
            let medium = |n: Vec3, ior: f32, colour: [f32; 4]| Voxel {
                colour,
                reflectivity: 0.05,
                refractivity: 0.9,
                ior,
                normal: Some(n),
            };
            shell(c, 12, 20)
                .map(|n| medium(n, 1.5, [0.9, 1.0, 0.9, 1.0]))
                .or_else(|| shell(c, 4, 28).map(|n| medium(n, 1.33, [0.8, 0.9, 1.0, 1.0])))
        },
    )
    .unwrap();
    let trace = TraceOptions {
        mode: HitMode::Cube,
        shadows: ShadowMode::None,
        ..TraceOptions::default()
    };
    let Some(st) = same_image(tree, trace, 2.0) else {
        return;
    };
    assert!(st.secondary_rays > st.primary_hits, "{st:?}");
}

/// Seeded rays over a root of `n` cells: from outside towards inside, from inside,
/// axis-parallel with `+0.0`/`-0.0` along lattice planes and edges, and diagonal through
/// lattice corners with a `tmin` past their start.
fn batch(n: u32, seed: u64) -> Vec<(Vec3, Vec3, f32)> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let nf = n as f32;
    let mut rays = Vec::new();
    let point = |rng: &mut rand_chacha::ChaCha8Rng, lo: f32, hi: f32| {
        Vec3::new(
            rng.random_range(lo..hi),
            rng.random_range(lo..hi),
            rng.random_range(lo..hi),
        )
    };
    let lattice = |rng: &mut rand_chacha::ChaCha8Rng| {
        Vec3::new(
            rng.random_range(0..=n) as f32,
            rng.random_range(0..=n) as f32,
            rng.random_range(0..=n) as f32,
        )
    };
    for _ in 0..4000 {
        let o = point(&mut rng, -0.6 * nf, 1.6 * nf);
        let t = point(&mut rng, 0.0, nf);
        rays.push((o, t - o, 0.0));
    }
    for _ in 0..2000 {
        let o = point(&mut rng, 0.0, nf);
        let d = point(&mut rng, -1.0, 1.0);
        rays.push((o, d, 0.0));
    }
    for i in 0..2000 {
        let axis = i % 3;
        let mut d = Vec3::splat(if i % 2 == 0 { 0.0 } else { -0.0 });
        d[axis] = if i % 4 < 2 { 1.0 } else { -1.0 };
        let mut o = lattice(&mut rng);
        if i % 5 == 0 {
            o[(axis + 1) % 3] += 0.5;
        }
        o[axis] = if d[axis] > 0.0 { -3.0 } else { nf + 3.0 };
        rays.push((o, d, 0.0));
    }
    for _ in 0..2000 {
        let c = lattice(&mut rng);
        let mut d = Vec3::ONE;
        for k in 0..3 {
            if rng.random_bool(0.5) {
                d[k] = -1.0;
            }
        }
        rays.push((c - d * (nf + 8.0), d, rng.random_range(0.0..nf)));
    }
    rays
}

/// The GPU's first hits of `rays` against `svo::trace::cast`: the same leaf for all but
/// one in a thousand (on lavapipe: all), and where the leaf agrees the same steps, `t` and
/// step-cap flag. Returns how many rays the cap stopped.
fn check_batch(
    ctx: &GpuContext,
    tree: &Octree,
    mode: HitMode,
    rays: &[(Vec3, Vec3, f32)],
    max_steps: u32,
) -> usize {
    let trace = TraceOptions {
        mode,
        max_steps,
        ..TraceOptions::default()
    };
    let variant = ShaderVariant::for_scene(tree, &trace, 0);
    let r = GpuRenderer::new(ctx, tree, variant, 1, 1).unwrap();
    let gpu_rays: Vec<GpuRay> = rays
        .iter()
        .map(|(o, d, tmin)| GpuRay {
            origin: o.to_array(),
            tmin: *tmin,
            dir: d.to_array(),
            tmax: f32::INFINITY,
        })
        .collect();
    let hits = r
        .cast(ctx, &tree_uniforms(tree, &trace), &gpu_rays)
        .unwrap();
    let mut differ = 0;
    let mut hit_count = 0;
    let mut capped = 0;
    for ((o, d, tmin), g) in rays.iter().zip(&hits) {
        let ray = GridRay {
            origin: *o,
            dir: *d,
        };
        let c = cast(tree, &ray, *tmin, f32::INFINITY, mode, None, max_steps);
        let cl = c.hit.map_or(NO_LEAF, |h| h.leaf);
        hit_count += usize::from(cl != NO_LEAF);
        if cl != g.leaf {
            differ += 1;
            eprintln!(
                "{mode:?}: ray {o} {d} tmin {tmin}: CPU {:?}, GPU {g:?}",
                c.hit
            );
        } else {
            if let Some(h) = c.hit {
                assert!(
                    (h.t - g.t).abs() <= 1e-4 * h.t.abs().max(1.0),
                    "t {} vs {}",
                    h.t,
                    g.t
                );
            }
            assert_eq!(c.steps, g.steps, "steps of ray {o} {d}");
            assert_eq!(c.capped, g.capped != 0, "cap of ray {o} {d}");
        }
        capped += usize::from(g.capped != 0);
    }
    eprintln!(
        "{mode:?}: {} rays, {hit_count} hits, {differ} differ",
        rays.len()
    );
    // Through the tree's graph (a DAG file's form): the same hits, steps and caps as the
    // tree's node array on the GPU, bit for bit.
    if tree.depth >= 2 {
        let dag = DagTree::from_tree(tree).unwrap();
        let r = GpuRenderer::new(ctx, &dag, ShaderVariant::for_scene(&dag, &trace, 0), 1, 1);
        let on_graph = r
            .unwrap()
            .cast(ctx, &tree_uniforms(&dag, &trace), &gpu_rays)
            .unwrap();
        for ((o, d, _), (g, v)) in rays.iter().zip(hits.iter().zip(&on_graph)) {
            assert_eq!(
                (g.leaf, g.t.to_bits(), g.steps, g.capped),
                (v.leaf, v.t.to_bits(), v.steps, v.capped),
                "ray {o} {d} through the graph"
            );
        }
    }
    if max_steps == MAX_STEPS {
        assert!(hit_count > rays.len() / 10, "too few hits to mean anything");
        // Through the 64-ary view (at odd depths its root has 2x2x2 cells): the same hits as
        // the octree's walk on the GPU, bit for bit (its steps count cells, and the cap does
        // not bind here).
        let layout = GpuLayout {
            wide_view: true,
            ..GpuLayout::default()
        };
        let w = GpuRenderer::with_options(ctx, tree, variant, 1, 1, &layout).unwrap();
        assert!(w.wide_view(), "depth {}", tree.depth);
        let wide = w
            .cast(ctx, &tree_uniforms(tree, &trace), &gpu_rays)
            .unwrap();
        for ((o, d, _), (g, v)) in rays.iter().zip(hits.iter().zip(&wide)) {
            assert_eq!(
                (g.leaf, g.t.to_bits(), g.capped),
                (v.leaf, v.t.to_bits(), v.capped),
                "ray {o} {d} through the view"
            );
        }
    }
    assert!(
        differ <= allowed(ctx, rays.len(), 1000),
        "{differ} of {} rays differ",
        rays.len()
    );
    capped
}

fn batch_rays_hit_the_same_leaves() {
    let Some(ctx) = gpu() else {
        return;
    };
    // A random sparse tree of cubes (no contours), depth 5.
    let cubes = Octree::from_fn(
        RootCube {
            origin: DVec3::ZERO,
            side: 32.0,
        },
        5,
        |_, _| true,
        |c| {
            let h = cell_hash(c) % 100;
            (h < 6).then(Voxel::default)
        },
    )
    .unwrap();
    assert_eq!(
        check_batch(&ctx, &cubes, HitMode::Cube, &batch(32, 7), MAX_STEPS),
        0
    );
    // The torus with its contours, depth 6.
    let t = torus(None, 6);
    let rays = batch(64, 8);
    for mode in [HitMode::Cube, HitMode::Contour] {
        assert_eq!(check_batch(&ctx, &t, mode, &rays, MAX_STEPS), 0);
    }
}

/// The step cap stops the GPU's rays where it stops the CPU's (the shader's loops run
/// without wgpu's loop bounds, so the cap is what ends a long traversal): the torus's rays
/// with caps of 1 to 40 steps, some stopped and some not at each cap.
fn step_cap_stops_gpu_rays_where_it_stops_cpu_rays() {
    let Some(ctx) = gpu() else {
        return;
    };
    let t = torus(None, 6);
    let rays = batch(16, 9);
    for cap in [1, 2, 5, 12, 40] {
        let capped = check_batch(&ctx, &t, HitMode::Contour, &rays, cap);
        eprintln!("cap {cap}: {capped} of {} rays stopped", rays.len());
        assert!(capped > 0, "cap {cap} stopped no ray");
        assert!(capped < rays.len(), "cap {cap} stopped every ray");
    }
}

/// Deep trees (depths 16, 20, 21, 24): clusters of leaves in the middle and the far corner of
/// the root, where `f32` grid coordinates are coarsest, hit by rays from a few to a few
/// hundred cells away (as `crates/svo/tests/it/deep_precision.rs` does on the CPU against an
/// `f64` reference): the GPU finds the CPU's leaf with the same steps and `t`. At depths 29
/// and 30, the deepest (whose 64-ary views have 15 levels, a 2x2x2 root at the odd one), the
/// cluster sits near the root's low corner, where `f32` still resolves a cell.
fn deep_tree_batch_rays_hit_the_same_leaves() {
    let Some(ctx) = gpu() else {
        return;
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0xDEE9);
    for depth in [16u8, 20, 21, 24, 29, 30] {
        let side = 1u64 << depth;
        let mut cells = Vec::new();
        let centres = if depth <= 24 {
            vec![side / 2, side - 6]
        } else {
            vec![6]
        };
        for centre in centres {
            for _ in 0..30 {
                let mut c =
                    || (centre as i64 + rng.random_range(-4..4)).clamp(0, side as i64 - 1) as u32;
                cells.push(glam::UVec3::new(c(), c(), c()));
            }
        }
        cells.sort_by_key(glam::UVec3::to_array);
        cells.dedup();
        let root = RootCube {
            origin: DVec3::ZERO,
            side: side as f64,
        };
        let tree =
            Octree::from_cells(root, depth, cells.iter().map(|&c| (c, Voxel::default()))).unwrap();
        let rays: Vec<(Vec3, Vec3, f32)> = (0..2000)
            .map(|_| {
                let target = cells[rng.random_range(0..cells.len())].as_dvec3()
                    + DVec3::new(rng.random(), rng.random(), rng.random());
                let dist = 10f64.powf(rng.random_range(0.5..2.5));
                let dir = DVec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
                .normalize();
                ((target - dir * dist).as_vec3(), dir.as_vec3(), 0.0)
            })
            .collect();
        eprintln!("depth {depth}:");
        assert_eq!(check_batch(&ctx, &tree, HitMode::Cube, &rays, MAX_STEPS), 0);
    }
}

fn a_tree_split_over_bindings_renders_the_same() {
    // Arena chunks far below the adapter's limit force the split a large tree needs.
    let Some(ctx) = gpu() else {
        return;
    };
    let trace = TraceOptions::default();
    let s = scene(torus(None, 6));
    let variant = ShaderVariant::for_scene(&s.tree, &trace, s.lights.len());
    let whole = GpuRenderer::new(&ctx, &s.tree, variant, s.camera.width, s.camera.height).unwrap();
    assert_eq!(whole.arena_chunks(), 1);
    let bytes = whole.tree_bytes;
    let split = GpuRenderer::with_options(
        &ctx,
        &s.tree,
        variant,
        s.camera.width,
        s.camera.height,
        &GpuLayout {
            chunk_limit: Some(bytes / 3),
            ..GpuLayout::default()
        },
    )
    .unwrap();
    assert!(split.arena_chunks() >= 3, "{} chunks", split.arena_chunks());
    let g = render_with(&ctx, &s, &trace, &split);
    let c = cpu_frame(&s, &trace);
    let diff = svo::render::compare(&g, &c).unwrap();
    assert_eq!(diff.hit_mismatch, 0.0);
    assert!(diff.rmse <= 0.5, "RMSE {}", diff.rmse);
    let leaf_diff = g.leaf.iter().zip(&c.leaf).filter(|(a, b)| a != b).count();
    assert!(
        leaf_diff <= allowed(&ctx, c.leaf.len(), 200),
        "{leaf_diff} leaves differ"
    );
    // Over more than four bindings, where the adapter allows sixteen (lavapipe does): the
    // same frame as over three, for the tree and for its graph; else a clear error.
    let many = GpuLayout {
        chunk_limit: Some(bytes / 7),
        ..GpuLayout::default()
    };
    let (w, h) = (s.camera.width, s.camera.height);
    let split_many = GpuRenderer::with_options(&ctx, &s.tree, variant, w, h, &many);
    if arena_bindings(&ctx.limits) == MAX_ARENA_CHUNKS {
        let split_many = split_many.unwrap();
        assert!(
            split_many.arena_chunks() > 4,
            "{} chunks",
            split_many.arena_chunks()
        );
        let f = render_with(&ctx, &s, &trace, &split_many);
        assert_eq!((&f.colour, &f.leaf, &f.cost), (&g.colour, &g.leaf, &g.cost));
        let dag = DagTree::from_tree(&s.tree).unwrap();
        let on_graph = GpuRenderer::with_options(&ctx, &dag, variant, w, h, &many).unwrap();
        assert!(
            on_graph.arena_chunks() > 4,
            "{} chunks",
            on_graph.arena_chunks()
        );
        let u = svo_view::gpu_types::uniforms(&dag, &s.camera, &s.lights, &s.sky, &s.phong, &trace)
            .unwrap();
        on_graph.render(&ctx, &u).unwrap();
        let f = on_graph
            .read_frame(&ctx, std::time::Duration::ZERO)
            .unwrap();
        assert_eq!((&f.colour, &f.leaf, &f.cost), (&g.colour, &g.leaf, &g.cost));
    } else {
        let e = split_many.err().expect("refused");
        assert!(e.to_string().contains("bindings"), "{e}");
    }
    // Too small to fit in the bindings the adapter allows: a clear error, not a crash.
    let e = GpuRenderer::with_options(
        &ctx,
        &s.tree,
        variant,
        8,
        8,
        &GpuLayout {
            chunk_limit: Some(bytes / 40),
            ..GpuLayout::default()
        },
    )
    .err()
    .expect("refused");
    assert!(e.to_string().contains("bindings"), "{e}");
}

/// Renders `s` with `r` (built for `s` and `trace`).
fn render_with(ctx: &GpuContext, s: &RenderScene, trace: &TraceOptions, r: &GpuRenderer) -> Frame {
    let u = svo_view::gpu_types::uniforms(&s.tree, &s.camera, &s.lights, &s.sky, &s.phong, trace)
        .unwrap();
    r.render(ctx, &u).unwrap();
    r.read_frame(ctx, std::time::Duration::ZERO).unwrap()
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![
        trial!(reflective_torus_contour_with_shadows, common::gpu_need()),
        trial!(glass_torus_cube_refraction, common::gpu_need()),
        trial!(
            path_bounce_limit_of_one_renders_the_same,
            common::gpu_need()
        ),
        trial!(the_wide_view_renders_the_same, common::gpu_need()),
        trial!(a_graph_renders_the_frames_of_its_tree, common::gpu_need()),
        trial!(
            a_graph_with_values_above_its_leaves_renders_the_same,
            common::gpu_need()
        ),
        trial!(a_level_of_detail_renders_the_same, common::gpu_need()),
        trial!(
            a_tree_too_large_for_the_adapter_shows_its_top_levels,
            common::gpu_need()
        ),
        trial!(the_header_says_which_prefix_of_a_file_fits),
        trial!(
            a_file_too_large_for_the_adapter_is_read_only_as_deep_as_fits,
            common::gpu_need()
        ),
        trial!(
            the_thesis_pool_views,
            common::gpu_need(),
            Need::pool_scene()
        ),
        trial!(
            solid_glass_torus_passes_through_its_interior_leaves,
            common::gpu_need()
        ),
        trial!(volumetric_glass_block_on_a_floor, common::gpu_need()),
        trial!(report_scene_2019, common::gpu_need()),
        trial!(glass_inside_water_nested_media, common::gpu_need()),
        trial!(batch_rays_hit_the_same_leaves, common::gpu_need()),
        trial!(
            step_cap_stops_gpu_rays_where_it_stops_cpu_rays,
            common::gpu_need()
        ),
        trial!(deep_tree_batch_rays_hit_the_same_leaves, common::gpu_need()),
        trial!(
            a_tree_split_over_bindings_renders_the_same,
            common::gpu_need()
        ),
    ]
}
