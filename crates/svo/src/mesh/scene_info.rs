//! What a scene adds to its octree: point lights and named camera views. They travel with
//! the tree in the `.svo` file (format version 2, only when present) and renderers use them
//! unless told otherwise.

use crate::mesh::triangle_mesh::MeshError;

/// A point light as stored.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "io", derive(serde::Serialize, serde::Deserialize))]
pub struct StoredLight {
    /// Position, scene units.
    pub position: [f64; 3],
    /// Linear RGB colour.
    pub colour: [f32; 3],
    /// Irradiance scale at distance 1 (scene units), as the renderer's point lights
    /// (`svo::render::PointLight`).
    pub intensity: f32,
}

/// A named camera view as stored.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "io", derive(serde::Serialize, serde::Deserialize))]
pub struct StoredCamera {
    /// The view's name (`--view` picks it).
    pub name: String,
    /// Eye, scene units.
    pub eye: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Up direction.
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
}

/// Lights and views of a scene (both may be empty).
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "io", derive(serde::Serialize, serde::Deserialize))]
pub struct SceneInfo {
    /// Point lights.
    pub lights: Vec<StoredLight>,
    /// Camera views, the first being the default.
    pub cameras: Vec<StoredCamera>,
}

impl SceneInfo {
    /// Whether there is nothing to store.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() && self.cameras.is_empty()
    }

    /// Checks every value a renderer relies on: finite positions, non-negative colours and
    /// intensities, views with distinct eye and target, an up direction not along the view,
    /// a field of view in `(0, 180)` degrees, names of at most 256 bytes.
    pub fn validate(&self) -> Result<(), MeshError> {
        self.check().map_err(MeshError::Scene)
    }

    /// [`Self::validate`]'s checks, the failure as its message.
    fn check(&self) -> Result<(), String> {
        let finite = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
        for (i, l) in self.lights.iter().enumerate() {
            if !finite(&l.position) {
                return Err(format!("light {i}: position is not finite"));
            }
            if !l.colour.iter().all(|c| c.is_finite() && *c >= 0.0) {
                return Err(format!("light {i}: colour is not finite and non-negative"));
            }
            if !(l.intensity.is_finite() && l.intensity >= 0.0) {
                return Err(format!(
                    "light {i}: intensity is not finite and non-negative"
                ));
            }
        }
        for (i, c) in self.cameras.iter().enumerate() {
            let what = format!("camera {i} ({:?})", c.name);
            if c.name.len() > 256 {
                return Err(format!("{what}: name longer than 256 bytes"));
            }
            if !(finite(&c.eye) && finite(&c.target) && finite(&c.up)) {
                return Err(format!("{what}: eye, target or up is not finite"));
            }
            let d = glam::DVec3::from_array(c.target) - glam::DVec3::from_array(c.eye);
            let up = glam::DVec3::from_array(c.up);
            if d.length_squared() == 0.0 || !d.length_squared().is_finite() {
                return Err(format!("{what}: eye and target coincide"));
            }
            let cross = d.normalize().cross(up.normalize_or_zero());
            if !(cross.length() > 1e-9) {
                return Err(format!("{what}: up is zero or along the view direction"));
            }
            if !(c.fov_deg > 0.0 && c.fov_deg < 180.0) {
                return Err(format!(
                    "{what}: field of view {} is outside (0, 180)",
                    c.fov_deg
                ));
            }
        }
        Ok(())
    }

    /// The camera named `name`, or with index `name` (`"0"`, `"1"`, ...).
    pub fn camera(&self, name: &str) -> Option<&StoredCamera> {
        self.cameras
            .iter()
            .find(|c| c.name == name)
            .or_else(|| name.parse::<usize>().ok().and_then(|i| self.cameras.get(i)))
    }
}
