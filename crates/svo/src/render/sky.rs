//! The sky: what rays that leave the scene see. A procedural gradient from the ground
//! through the horizon to the zenith, or a cube map ([`CubeMap`]) when one is given.

use crate::mesh::triangle_mesh::Texture;
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// Six square images around the scene, in the OpenGL order and orientation: `+x, -x, +y,
/// -y, +z, -z`, each read with its top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct CubeMap {
    /// The faces.
    pub faces: [Texture; 6],
}

impl CubeMap {
    /// The linear RGB colour seen in direction `d` (nearest texel).
    pub fn colour(&self, d: Vec3) -> Vec3 {
        let a = d.abs();
        // Face, then the face coordinates (sc, tc) over the major axis (OpenGL's table).
        let (face, sc, tc, ma) = if a.x >= a.y && a.x >= a.z {
            if d.x >= 0.0 {
                (0, -d.z, -d.y, a.x)
            } else {
                (1, d.z, -d.y, a.x)
            }
        } else if a.y >= a.z {
            if d.y >= 0.0 {
                (2, d.x, d.z, a.y)
            } else {
                (3, d.x, -d.z, a.y)
            }
        } else if d.z >= 0.0 {
            (4, d.x, -d.y, a.z)
        } else {
            (5, -d.x, -d.y, a.z)
        };
        if !(ma > 0.0) {
            return Vec3::ZERO;
        }
        let uv = Vec2::new(sc / ma, tc / ma) * 0.5 + 0.5;
        // Clamp inside the face: repeat wrapping would fetch the opposite edge.
        let uv = uv.clamp(Vec2::ZERO, Vec2::splat(0.999_999));
        let c = self.faces[face].sample_linear(uv);
        Vec3::new(c[0], c[1], c[2])
    }
}

/// The background seen by rays that leave the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Sky {
    /// Colour at the zenith (linear RGB).
    pub zenith: Vec3,
    /// Colour at the horizon.
    pub horizon: Vec3,
    /// Colour straight down.
    pub ground: Vec3,
    /// The up direction (unit).
    pub up: Vec3,
    /// A cube map that replaces the gradient.
    pub cube_map: Option<Arc<CubeMap>>,
}

impl Default for Sky {
    fn default() -> Self {
        Self {
            zenith: Vec3::new(0.18, 0.32, 0.62),
            horizon: Vec3::new(0.75, 0.82, 0.9),
            ground: Vec3::new(0.25, 0.23, 0.21),
            up: Vec3::Y,
            cube_map: None,
        }
    }
}

impl Sky {
    /// The colour in unit direction `d`: a gradient from the horizon to the zenith above,
    /// and to the ground below.
    #[inline]
    pub fn colour(&self, d: Vec3) -> Vec3 {
        if let Some(c) = &self.cube_map {
            return c.colour(d);
        }
        let h = d.dot(self.up).clamp(-1.0, 1.0);
        if h >= 0.0 {
            self.horizon.lerp(self.zenith, h.sqrt())
        } else {
            self.horizon.lerp(self.ground, (-h).sqrt())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_ends() {
        let s = Sky::default();
        assert_eq!(s.colour(Vec3::Y), s.zenith);
        assert_eq!(s.colour(Vec3::NEG_Y), s.ground);
        assert_eq!(s.colour(Vec3::X), s.horizon);
    }

    #[test]
    fn cube_map_faces_and_orientation() {
        // Each face a distinct colour, its top-left texel marked: directions pick the face
        // OpenGL picks, and the marked corner is where OpenGL puts it.
        let face = |k: u8| Texture {
            width: 2,
            height: 2,
            rgba: vec![
                [255, 255, 255, 255],
                [k * 40, 0, 0, 255],
                [k * 40, 0, 0, 255],
                [k * 40, 0, 0, 255],
            ],
        };
        let cm = CubeMap {
            faces: std::array::from_fn(|k| face(k as u8)),
        };
        let r = |k: u8| crate::mesh::triangle_mesh::srgb_to_linear(k * 40);
        for (d, k) in [
            (Vec3::X, 0u8),
            (Vec3::NEG_X, 1),
            (Vec3::Y, 2),
            (Vec3::NEG_Y, 3),
            (Vec3::Z, 4),
            (Vec3::NEG_Z, 5),
        ] {
            // Straight on: the face's centre, the bottom-right texel of a 2x2 face.
            assert_eq!(cm.colour(d), Vec3::new(r(k), 0.0, 0.0), "{d}");
        }
        // +z face: sc = x, tc = -y, so up-left (-x, +y) is the top-left texel (white).
        assert_eq!(cm.colour(Vec3::new(-0.5, 0.5, 1.0).normalize()), Vec3::ONE);
        // -z face: sc = -x, so up-right (+x, +y) is its top-left.
        assert_eq!(cm.colour(Vec3::new(0.5, 0.5, -1.0).normalize()), Vec3::ONE);
        // +y face: sc = x, tc = z: (-x, -z) is the top-left.
        assert_eq!(cm.colour(Vec3::new(-0.5, 1.0, -0.5).normalize()), Vec3::ONE);
        // Other corners of +z are the face colour.
        assert_eq!(
            cm.colour(Vec3::new(0.5, -0.5, 1.0).normalize()),
            Vec3::new(r(4), 0.0, 0.0)
        );
        let sky = Sky {
            cube_map: Some(Arc::new(cm)),
            ..Sky::default()
        };
        assert_eq!(
            sky.colour(Vec3::new(0.5, -0.5, 1.0).normalize()),
            Vec3::new(r(4), 0.0, 0.0)
        );
    }
}
