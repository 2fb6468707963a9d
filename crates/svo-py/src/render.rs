//! `Octree.render` and `Octree.render_aovs`: the library's Whitted tracer (reflections,
//! refractions, shadows through glass) on the CPU with the GIL released, set up as
//! `svo-view --cpu` sets it up, so the same arguments give the same image.

use crate::errors::threads_error;
use crate::octree::PyOctree;
use glam::DVec3;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use svo::render::{
    Frame, LightSpec, OctreeSurfaces, SceneSetup, ShadowMode, TraceOptions, Tracer, render,
};

/// What a render asks for, as `render` and `render_aovs` take it.
pub(crate) struct RenderArgs {
    pub(crate) width: i64,
    pub(crate) height: i64,
    pub(crate) eye: Option<[f64; 3]>,
    pub(crate) target: Option<[f64; 3]>,
    pub(crate) up: Option<[f64; 3]>,
    pub(crate) fov: f64,
    pub(crate) view: Option<String>,
    pub(crate) lights: Option<Vec<[f64; 3]>>,
    pub(crate) mode: String,
    pub(crate) shadows: String,
    pub(crate) reflections: u8,
    pub(crate) refractions: u8,
    pub(crate) lod: f32,
    pub(crate) threads: Option<usize>,
}

/// A `ValueError` with `e`'s message.
fn value_error(e: impl ToString) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Renders `tree` as `args` say, the GIL released.
pub(crate) fn frame(py: Python<'_>, tree: &PyOctree, args: RenderArgs) -> PyResult<Frame> {
    let side = |v: i64, what: &str| {
        u32::try_from(v).map_err(|_| value_error(format!("{what} {v} is not a pixel count")))
    };
    let mode = crate::rays::hit_mode(&args.mode)?;
    if !(args.lod.is_finite() && args.lod >= 0.0) {
        return Err(value_error(format!(
            "lod {} must be 0 (the exact walk) or a positive number of pixels",
            args.lod
        )));
    }
    let setup = SceneSetup {
        width: side(args.width, "width")?,
        height: side(args.height, "height")?,
        eye: args.eye.map(DVec3::from_array),
        target: args.target.map(DVec3::from_array),
        up: args.up.map(DVec3::from_array),
        fov_deg: args.fov,
        lights: args
            .lights
            .unwrap_or_default()
            .into_iter()
            .map(|p| LightSpec {
                position: DVec3::from_array(p),
                colour: None,
                intensity: None,
            })
            .collect(),
        view: args.view,
        ..SceneSetup::default()
    };
    let options = TraceOptions {
        mode,
        max_reflections: args.reflections,
        max_refractions: args.refractions,
        shadows: args.shadows.parse::<ShadowMode>().map_err(value_error)?,
        lod: args.lod,
        ..TraceOptions::default()
    };
    let t = &tree.tree;
    let (lo, hi) = t.occupied_bounds();
    let stage = setup
        .stage(t.depth, lo, hi, &tree.build.scene)
        .map_err(value_error)?;
    py.detach(|| {
        svo::with_threads(args.threads, |_| {
            let surfaces = OctreeSurfaces::new(t, options.mode);
            let tracer = Tracer::new(surfaces, &stage.lights, stage.sky, stage.phong, options);
            render(&tracer, &stage.camera)
        })
    })
    .map_err(threads_error)?
    .map_err(value_error)
}
