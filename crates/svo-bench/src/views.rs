//! The camera views of the image tables: the default framing, and the nearest equivalents of
//! the thesis's three test views (its figures 1.2-1.4) on the bunny alone: "water" (every
//! ray hits a refracting, reflecting surface: a water bunny filling the screen, until the
//! pool scene exists), "bunny" (every ray hits the bunny from the side), and "parallel" (the
//! camera inside the hollow bunny looking along it: rays graze many leaves, the thesis's
//! worst case for contours). Positions are fractions of the mesh's bounds, so any mesh gets
//! the same views; the fractions were chosen on the Stanford bunny.

use glam::{DVec3, Vec3};
use svo::mesh::{Material, Mesh};
use svo::render::{Camera, PointLight};

/// A view of the image tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum View {
    /// `svo-view`'s default framing (the whole model, 12.6% of the rays hit the bunny).
    Framed,
    /// The thesis's water view: the model made of water, filling the screen.
    Water,
    /// The thesis's bunny view: the model's side filling the screen.
    Bunny,
    /// The thesis's parallel view: inside the hollow model, along it.
    Parallel,
}

impl View {
    /// Every view, in report order.
    pub const ALL: [Self; 4] = [Self::Framed, Self::Water, Self::Bunny, Self::Parallel];

    /// The short name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Framed => "framed",
            Self::Water => "water",
            Self::Bunny => "bunny",
            Self::Parallel => "parallel",
        }
    }

    /// What it shows, for the report.
    pub fn what(self) -> &'static str {
        match self {
            Self::Framed => {
                "the default framing of `svo-view` (the model's bounding sphere fits a 40-degree \
                 field of view), opaque"
            }
            Self::Water => {
                "the thesis's water view (its figure 1.2) as far as the bunny alone allows: the \
                 bunny made of water (IOR 1.33, 10% mirror, 85% transmission), its side filling \
                 the screen, so every primary ray spawns reflection and refraction rays"
            }
            Self::Bunny => {
                "the thesis's bunny view (figure 1.3): the opaque bunny's side filling the screen"
            }
            Self::Parallel => {
                "the thesis's parallel view (figure 1.4): the camera inside the hollow bunny \
                 looking along it, lit from the eye; rays graze the inner wall through many \
                 leaves"
            }
        }
    }

    /// Whether the view renders the water material.
    pub fn water(self) -> bool {
        self == Self::Water
    }

    /// The camera for a model with bounds `[lo, hi]`.
    pub fn camera(self, lo: DVec3, hi: DVec3, width: u32, height: u32) -> Camera {
        let at = |f: DVec3| lo + (hi - lo) * f;
        let (eye, target, fov_deg) = match self {
            Self::Framed => return Camera::framing(lo, hi, width, height, 40.0),
            Self::Water | Self::Bunny => (
                at(DVec3::new(0.576, 0.402, 3.0)),
                at(DVec3::new(0.576, 0.402, 0.5)),
                9.0,
            ),
            Self::Parallel => (
                at(DVec3::new(0.865, 0.305, 0.513)),
                at(DVec3::new(0.223, 0.434, 0.513)),
                60.0,
            ),
        };
        Camera {
            eye,
            target,
            up: DVec3::Y,
            fov_deg,
            width,
            height,
        }
    }

    /// The one point light: above and to the right of the camera, with the intensity that
    /// makes it 1 at the model's centre; at the eye inside the model.
    pub fn light(self, lo: DVec3, hi: DVec3, cam: &Camera) -> PointLight {
        let centre = (lo + hi) * 0.5;
        let position = if self == Self::Parallel {
            cam.eye
        } else {
            let fwd = (cam.target - cam.eye).normalize();
            let right = fwd.cross(cam.up).normalize();
            let up = right.cross(fwd);
            let dist = (cam.eye - cam.target).length();
            cam.eye + (up * 0.8 + right * 0.5) * dist
        };
        let reach = if self == Self::Parallel {
            (hi - lo).length() * 0.5
        } else {
            (position - centre).length()
        };
        PointLight {
            position,
            colour: Vec3::ONE,
            intensity: (reach * reach) as f32,
        }
    }
}

/// `mesh` with every triangle made of water.
pub fn water(mesh: &Mesh) -> Mesh {
    let mut m = mesh.clone();
    m.materials = vec![Material {
        name: "water".into(),
        colour: [0.85, 0.93, 1.0, 1.0],
        texture: None,
        reflectivity: 0.1,
        refractivity: 0.85,
        ior: 1.33,
        alpha_blend: false,
    }];
    m.triangle_materials.clear();
    m.textures.clear();
    m.triangle_uvs.clear();
    m
}
