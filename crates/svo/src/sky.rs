//! The sky: what rays that leave the scene see, a procedural gradient from the ground
//! through the horizon to the zenith.

use glam::Vec3;

/// The background seen by rays that leave the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sky {
    /// Colour at the zenith (linear RGB).
    pub zenith: Vec3,
    /// Colour at the horizon.
    pub horizon: Vec3,
    /// Colour straight down.
    pub ground: Vec3,
    /// The up direction (unit).
    pub up: Vec3,
}

impl Default for Sky {
    fn default() -> Self {
        Self {
            zenith: Vec3::new(0.18, 0.32, 0.62),
            horizon: Vec3::new(0.75, 0.82, 0.9),
            ground: Vec3::new(0.25, 0.23, 0.21),
            up: Vec3::Y,
        }
    }
}

impl Sky {
    /// The colour in unit direction `d`: a gradient from the horizon to the zenith above,
    /// and to the ground below.
    #[inline]
    pub fn colour(&self, d: Vec3) -> Vec3 {
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
}
