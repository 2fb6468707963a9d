//! Scene setup: what every renderer of a tree needs besides the tree, with the defaults a
//! viewer expects filled in. A camera framing the occupied cells (or a view stored with the
//! tree, or one given), point lights (the stored ones, or one white light above the camera's
//! right shoulder, or the ones given), the sky and the Phong factors. The CPU tracer and the
//! GPU port start from the same [`RenderScene`], so their images show the same scene.

use crate::mesh::scene_info::{SceneInfo, StoredCamera};
use crate::octree::tree::Octree;
use crate::render::camera::{Camera, CameraError};
use crate::render::shading::{Phong, PointLight};
use crate::render::sky::{CubeMap, Sky};
use glam::{DVec3, Vec3};
use std::sync::Arc;
use thiserror::Error;

/// The deepest tree the renderers trace. Traversal runs in `f32` grid coordinates, whose cell
/// planes are exact integers up to depth 24: there every ray hits each leaf it enters by more
/// than the rounding of its plane parameters (`tests/it/deep_precision.rs`); from depth 25 the
/// planes round and from depth 26 half the rays go wrong, so such trees are refused rather
/// than rendered wrong.
pub const MAX_TRACE_DEPTH: u8 = 24;

/// Errors of a scene's setup.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SetupError {
    /// Reading the `.svo` failed.
    #[cfg(feature = "io")]
    #[error(transparent)]
    Format(#[from] crate::io::FormatError),
    /// The camera settings make no image.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// The tree is deeper than the tracers resolve.
    #[error(
        "the tree has depth {0}, and the tracer works in 32-bit floats, which resolve cells only up to depth {MAX_TRACE_DEPTH} (docs/stability.md); bake at depth {MAX_TRACE_DEPTH} or less to render"
    )]
    TooDeep(u8),
    /// The asked-for stored view does not exist.
    #[error("{}", no_view(name, stored))]
    NoView {
        /// The name asked for.
        name: String,
        /// The stored views' names.
        stored: Vec<String>,
    },
}

/// The message of [`SetupError::NoView`].
fn no_view(name: &str, stored: &[String]) -> String {
    if stored.is_empty() {
        format!("no view {name:?}: the file stores no camera views")
    } else {
        format!("no view {name:?}; the file has {}", stored.join(", "))
    }
}

/// A point light as given by a user: position, optional colour and intensity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSpec {
    /// Position (scene units).
    pub position: DVec3,
    /// Linear RGB colour (default white).
    pub colour: Option<Vec3>,
    /// Intensity (default: the squared distance to the scene's centre, so the light gives
    /// about 1 at the model).
    pub intensity: Option<f32>,
}

/// How to frame and light a tree: the image size and what the user gave; what is left out
/// gets the defaults below.
#[derive(Clone, Debug)]
pub struct SceneSetup {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Camera eye; default: frame the model.
    pub eye: Option<DVec3>,
    /// Camera target; default: the model's centre.
    pub target: Option<DVec3>,
    /// Up; default `+y`.
    pub up: Option<DVec3>,
    /// Vertical field of view in degrees.
    pub fov_deg: f64,
    /// Lights; default: the stored lights, else one white light above and behind the
    /// camera's right shoulder.
    pub lights: Vec<LightSpec>,
    /// A camera view stored with the tree, by name or index; default: the first stored view
    /// unless `eye` is given, else framing the model.
    pub view: Option<String>,
    /// A cube-map sky; default: the procedural gradient.
    pub cube_map: Option<Arc<CubeMap>>,
    /// Read only the file's top this many levels, as a coarser tree whose leaves are the
    /// nodes of that level ([`crate::io::read_file_to_depth`]: a version-4 file's prefix);
    /// default: every level.
    pub max_depth: Option<u8>,
}

impl Default for SceneSetup {
    fn default() -> Self {
        Self {
            width: 1280,
            height: 720,
            eye: None,
            target: None,
            up: None,
            fov_deg: 40.0,
            lights: Vec::new(),
            view: None,
            cube_map: None,
            max_depth: None,
        }
    }
}

/// Everything a renderer needs around a tree: camera, lights, sky, shading factors, and the
/// stored views at the setup's image size (a viewer steps through them).
#[derive(Clone, Debug)]
pub struct Stage {
    /// The camera.
    pub camera: Camera,
    /// Point lights (scene units).
    pub lights: Vec<PointLight>,
    /// The sky.
    pub sky: Sky,
    /// Phong factors.
    pub phong: Phong,
    /// The stored camera views, by name.
    pub views: Vec<(String, Camera)>,
}

/// A tree ready to render: the tree and its [`Stage`].
#[derive(Clone, Debug)]
pub struct RenderScene {
    /// The tree.
    pub tree: Octree,
    /// The camera.
    pub camera: Camera,
    /// Point lights (scene units).
    pub lights: Vec<PointLight>,
    /// The sky.
    pub sky: Sky,
    /// Phong factors.
    pub phong: Phong,
    /// The stored camera views, by name, at the setup's image size.
    pub views: Vec<(String, Camera)>,
}

impl RenderScene {
    /// The scene of `tree` with the lights and views `stored` beside it: the setup's own
    /// lights and camera win; else its `view` (which must exist) or the first stored view,
    /// and the stored lights.
    pub fn new(tree: Octree, stored: &SceneInfo, setup: &SceneSetup) -> Result<Self, SetupError> {
        let (lo, hi) = tree.occupied_bounds();
        let stage = setup.stage(tree.depth, lo, hi, stored)?;
        Ok(Self::from_parts(tree, stage))
    }

    /// The scene of `tree` on `stage`.
    pub fn from_parts(tree: Octree, stage: Stage) -> Self {
        let Stage {
            camera,
            lights,
            sky,
            phong,
            views,
        } = stage;
        Self {
            tree,
            camera,
            lights,
            sky,
            phong,
            views,
        }
    }

    /// The tree and its stage.
    pub fn into_parts(self) -> (Octree, Stage) {
        let Self {
            tree,
            camera,
            lights,
            sky,
            phong,
            views,
        } = self;
        let stage = Stage {
            camera,
            lights,
            sky,
            phong,
            views,
        };
        (tree, stage)
    }

    /// Reads the `.svo` file at `path` (checked) and sets up its scene with the lights and
    /// views stored in it.
    #[cfg(feature = "io")]
    pub fn open(path: &std::path::Path, setup: &SceneSetup) -> Result<Self, SetupError> {
        let (tree, build) = match setup.max_depth {
            Some(k) => crate::io::read::read_file_to_depth(path, k)?,
            None => crate::io::read::read_file(path)?,
        };
        Self::new(tree, &build.scene, setup)
    }
}

impl SceneSetup {
    /// The stage of a tree of `depth` whose leaves lie in `lo..hi` (scene units), with the
    /// lights and views `stored` beside it (see [`RenderScene::new`]).
    pub fn stage(
        &self,
        depth: u8,
        lo: DVec3,
        hi: DVec3,
        stored: &SceneInfo,
    ) -> Result<Stage, SetupError> {
        if depth > MAX_TRACE_DEPTH {
            return Err(SetupError::TooDeep(depth));
        }
        let framing = Camera::framing(lo, hi, self.width, self.height, self.fov_deg);
        // A stored view at the setup's image size.
        let as_camera = |v: &StoredCamera| Camera {
            eye: DVec3::from_array(v.eye),
            target: DVec3::from_array(v.target),
            up: DVec3::from_array(v.up),
            fov_deg: v.fov_deg,
            ..framing
        };
        let view = match &self.view {
            Some(name) => Some(stored.camera(name).ok_or_else(|| SetupError::NoView {
                name: name.clone(),
                stored: stored.cameras.iter().map(|c| c.name.clone()).collect(),
            })?),
            None if self.eye.is_none() => stored.cameras.first(),
            None => None,
        };
        let mut camera = match view {
            Some(v) => as_camera(v),
            None => Camera {
                eye: self.eye.unwrap_or(framing.eye),
                target: self.target.unwrap_or(framing.target),
                up: self.up.unwrap_or(DVec3::Y),
                ..framing
            },
        };
        if view.is_none() && self.eye.is_some() && self.target.is_none() {
            camera.target = (lo + hi) * 0.5;
        }
        let lights = self.lights_for(&camera, (lo + hi) * 0.5, stored)?;
        let sky = Sky {
            up: camera.up.normalize().as_vec3(),
            cube_map: self.cube_map.clone(),
            ..Sky::default()
        };
        let views = stored
            .cameras
            .iter()
            .map(|v| (v.name.clone(), as_camera(v)))
            .collect();
        Ok(Stage {
            camera,
            lights,
            sky,
            phong: Phong::default(),
            views,
        })
    }

    /// The lights seen from `camera` around a scene centred on `centre`: the setup's, else
    /// the stored ones, else one white light above the camera's right shoulder.
    fn lights_for(
        &self,
        camera: &Camera,
        centre: DVec3,
        stored: &SceneInfo,
    ) -> Result<Vec<PointLight>, SetupError> {
        let rays = camera.rays()?;
        if self.lights.is_empty() && !stored.lights.is_empty() {
            return Ok(stored
                .lights
                .iter()
                .map(|l| PointLight {
                    position: DVec3::from_array(l.position),
                    colour: Vec3::from_array(l.colour),
                    intensity: l.intensity,
                })
                .collect());
        }
        if self.lights.is_empty() {
            let dist = (camera.eye - camera.target).length();
            let pos = camera.eye + (rays.up() * 0.8 + rays.right() * 0.5) * dist;
            return Ok(vec![PointLight {
                position: pos,
                colour: Vec3::ONE,
                intensity: (pos - centre).length_squared() as f32,
            }]);
        }
        Ok(self
            .lights
            .iter()
            .map(|l| PointLight {
                position: l.position,
                colour: l.colour.unwrap_or(Vec3::ONE),
                intensity: l
                    .intensity
                    .unwrap_or((l.position - centre).length_squared() as f32),
            })
            .collect())
    }
}
