//! Level of detail against run time: a tree baked with its inner nodes' attributes, rendered
//! at several `--lod` levels (rays stop at nodes as wide as their pixel's cone times the
//! level), each timed beside its error against the triangles with one sample a pixel and
//! with 16 (the same camera at four times the width and height, averaged 4x4 in linear
//! light) in the views where prefiltering should pay.

use crate::views::{View, water};
use glam::{DVec3, Vec3};
use svo::mesh::Mesh;
use svo::render::{
    Camera, Frame, MeshSurfaces, OctreeSurfaces, PointLight, Surfaces, TraceOptions, Tracer,
    compare,
};
use svo::trace::HitMode;
use svo::{BakeOptions, Octree, bake_mesh};

/// The levels measured, in pixels (0: the exact walk).
pub const LODS: [f32; 5] = [0.0, 0.5, 1.0, 2.0, 4.0];

/// One view at one level.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LodRow {
    /// `close-up`, `framed`, `far` or `water`.
    pub view: &'static str,
    /// Tree depth.
    pub depth: u8,
    /// Level of detail, pixels.
    pub lod: f32,
    /// Median seconds per frame.
    pub seconds: f64,
    /// Traversal steps per primary ray.
    pub steps: f64,
    /// Traversal steps per ray after the primary ones (secondary and shadow).
    pub other_steps: f64,
    /// PSNR against the triangles, one sample a pixel, dB.
    pub psnr: f64,
    /// PSNR against the triangles, 16 samples a pixel, dB (the framed and far views, where
    /// a pixel covers many leaves).
    pub psnr16: Option<f64>,
    /// Share of pixels whose primary ray hits here and misses in the one-sample reference, or
    /// the other way round.
    pub mismatch: f64,
}

/// The views: the thesis's bunny view (a close-up), the default framing, the framing's eye
/// moved 1.6 times as far from the target (the bunny covers about 5% of the frame) and the
/// thesis's water view, each with its camera and light.
fn views(lo: DVec3, hi: DVec3, size: (u32, u32)) -> Vec<(&'static str, View, Camera, PointLight)> {
    let (w, h) = size;
    let framed = View::Framed.camera(lo, hi, w, h);
    let far = Camera {
        eye: framed.target + (framed.eye - framed.target) * 1.6,
        ..framed
    };
    let mut out = Vec::new();
    for (name, view, cam) in [
        ("close-up", View::Bunny, View::Bunny.camera(lo, hi, w, h)),
        ("framed", View::Framed, framed),
        ("far", View::Framed, far),
        ("water", View::Water, View::Water.camera(lo, hi, w, h)),
    ] {
        let light = view.light(lo, hi, &cam);
        out.push((name, view, cam, light));
    }
    out
}

/// The report's tracer ([`crate::image_tables::tracer`]) at level of detail `lod`.
fn tracer<S: Surfaces>(s: S, light: PointLight, lod: f32) -> Tracer<S> {
    let opts = TraceOptions {
        lod,
        ..TraceOptions::default()
    };
    crate::image_tables::tracer(s, light, opts)
}

/// The triangles through `cam` with 16 samples a pixel: `cam` at four times its width and
/// height, each 4x4 block averaged in linear light (its leaves from `one`, the one-sample
/// reference, for the hit mask).
fn reference16(
    mesh: &Mesh,
    tree: &Octree,
    cam: &Camera,
    light: PointLight,
    one: &Frame,
) -> anyhow::Result<Frame> {
    let big = Camera {
        width: cam.width * 4,
        height: cam.height * 4,
        ..*cam
    };
    let t = tracer(
        MeshSurfaces::new(mesh.clone(), tree.root, tree.depth),
        light,
        0.0,
    );
    let f = svo::render::render(&t, &big)?;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut out = one.clone();
    for y in 0..h {
        for x in 0..w {
            let mut sum = Vec3::ZERO;
            for dy in 0..4 {
                for dx in 0..4 {
                    sum += f.colour[(4 * y + dy) * 4 * w + 4 * x + dx];
                }
            }
            out.colour[y * w + x] = sum / 16.0;
        }
    }
    Ok(out)
}

/// Bakes `mesh` (and its water copy) at `depth` with the inner nodes' attributes and renders
/// each view at every level of [`LODS`], `runs` timed frames after a warm-up.
pub fn measure(mesh: &Mesh, depth: u8, size: (u32, u32), runs: u32) -> anyhow::Result<Vec<LodRow>> {
    let (lo, hi) = mesh.bounds().ok_or_else(|| anyhow::anyhow!("empty mesh"))?;
    let opts = BakeOptions {
        depth,
        node_attributes: true,
        ..Default::default()
    };
    let water_mesh = water(mesh);
    let tree = bake_mesh(mesh, &opts)?.0;
    let water_tree = bake_mesh(&water_mesh, &opts)?.0;
    let mut rows = Vec::new();
    for (name, view, cam, light) in views(lo, hi, size) {
        let (t, m) = if view.water() {
            (&water_tree, &water_mesh)
        } else {
            (&tree, mesh)
        };
        let reference = tracer(MeshSurfaces::new(m.clone(), t.root, t.depth), light, 0.0);
        let one = svo::render::render(&reference, &cam)?;
        // Where prefiltering can pay: a pixel there covers many leaves. The close-up's pixels
        // are about a leaf wide, and the water view's are too.
        let sixteen = if matches!(name, "framed" | "far") {
            Some(reference16(m, t, &cam, light, &one)?)
        } else {
            None
        };
        for lod in LODS {
            let tr = tracer(OctreeSurfaces::new(t, HitMode::Contour), light, lod);
            let (f, seconds) = crate::image_tables::timed(&tr, &cam, runs)?;
            let d1 = compare(&f, &one).ok_or_else(|| anyhow::anyhow!("frame sizes differ"))?;
            let psnr16 = match &sixteen {
                Some(r) => Some(
                    compare(&f, r)
                        .ok_or_else(|| anyhow::anyhow!("frame sizes differ"))?
                        .psnr_db,
                ),
                None => None,
            };
            let st = f.stats;
            let others = st.secondary_rays + st.shadow_rays;
            rows.push(LodRow {
                view: name,
                depth,
                lod,
                seconds,
                steps: st.primary_steps as f64 / st.primary_rays.max(1) as f64,
                other_steps: (st.steps - st.primary_steps) as f64 / others.max(1) as f64,
                psnr: d1.psnr_db,
                psnr16,
                mismatch: d1.hit_mismatch,
            });
        }
    }
    Ok(rows)
}
