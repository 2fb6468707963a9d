//! A pinhole camera: eye, target, up and a vertical field of view, with pixel centres at
//! half-integer positions; and the default camera that frames a set of bounds.

use crate::trace::cone::Cone;
use glam::DVec3;
use thiserror::Error;

/// The largest image side the renderers accept.
pub(crate) const MAX_IMAGE_SIDE: u32 = 16384;

/// The most pixels an image may have (a frame keeps 36 bytes a pixel: 2.4 GB here).
pub(crate) const MAX_IMAGE_PIXELS: u64 = 1 << 26;

/// Errors of camera settings.
#[derive(Debug, Error, PartialEq)]
#[non_exhaustive]
pub enum CameraError {
    /// Width or height is zero or above 16384, or the image has more than `2^26` pixels.
    #[error(
        "image size {0}x{1} is outside 1..={MAX_IMAGE_SIDE} per side or above {MAX_IMAGE_PIXELS} pixels"
    )]
    Size(u32, u32),
    /// The field of view is not in `(0, 180)` degrees.
    #[error("field of view {0} degrees is outside (0, 180)")]
    Fov(f64),
    /// Eye, target or up is not finite.
    #[error("camera eye, target and up must be finite")]
    NotFinite,
    /// Eye and target coincide, or up is parallel to the view direction.
    #[error("camera eye equals target, or up is parallel to the view direction")]
    Degenerate,
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (scene units).
    pub eye: DVec3,
    /// Point looked at.
    pub target: DVec3,
    /// Up direction (need not be orthogonal to the view direction).
    pub up: DVec3,
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// A camera's orthonormal basis and scale, ready to make rays.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half: f64,
    aspect: f64,
    width: u32,
    height: u32,
    /// `forward`, `right`, `up` in `f32`.
    basis: [glam::Vec3; 3],
    /// `2 / width`, `2 / height`.
    px_scale: glam::Vec2,
    /// `tan(fov / 2) * aspect`, `tan(fov / 2)`.
    half_extent: glam::Vec2,
}

impl Camera {
    /// A camera looking at the centre of the box `[lo, hi]` from the front-right, above
    /// (towards `+z`, `+x` and `+y`, `+y` up), far enough that the box's bounding sphere
    /// fits the vertical and horizontal field of view.
    pub fn framing(lo: DVec3, hi: DVec3, width: u32, height: u32, fov_deg: f64) -> Self {
        let centre = (lo + hi) * 0.5;
        // Scale-free: a box of any size frames the same; only a point gets a radius, relative
        // to its distance from the origin.
        let half = (hi - lo).length() * 0.5;
        let radius = if half > 0.0 {
            half
        } else {
            (centre.abs().max_element() * 1e-9).max(f64::MIN_POSITIVE)
        };
        let half_v = (fov_deg.to_radians() * 0.5).clamp(1e-3, 1.5);
        let aspect = f64::from(width.max(1)) / f64::from(height.max(1));
        let half_h = (half_v.tan() * aspect).atan();
        let dist = radius / half_v.min(half_h).sin() * 1.02;
        let dir = DVec3::new(0.35, 0.3, 1.0).normalize();
        Self {
            eye: centre + dir * dist,
            target: centre,
            up: DVec3::Y,
            fov_deg,
            width,
            height,
        }
    }

    /// Checks the settings and prepares the ray generator.
    pub fn rays(&self) -> Result<CameraRays, CameraError> {
        if self.width == 0
            || self.height == 0
            || self.width > MAX_IMAGE_SIDE
            || self.height > MAX_IMAGE_SIDE
            || u64::from(self.width) * u64::from(self.height) > MAX_IMAGE_PIXELS
        {
            return Err(CameraError::Size(self.width, self.height));
        }
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return Err(CameraError::Fov(self.fov_deg));
        }
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return Err(CameraError::NotFinite);
        }
        let forward = (self.target - self.eye).normalize_or_zero();
        let up = self.up.normalize_or_zero();
        let cross = forward.cross(up);
        // Parallel within rounding counts as parallel.
        let right = if cross.length() > 1e-9 {
            cross.normalize()
        } else {
            DVec3::ZERO
        };
        if forward == DVec3::ZERO || right == DVec3::ZERO {
            return Err(CameraError::Degenerate);
        }
        let up = right.cross(forward);
        let tan_half = (self.fov_deg.to_radians() * 0.5).tan();
        let aspect = f64::from(self.width) / f64::from(self.height);
        Ok(CameraRays {
            eye: self.eye,
            forward,
            right,
            up,
            tan_half,
            aspect,
            width: self.width,
            height: self.height,
            basis: [forward.as_vec3(), right.as_vec3(), up.as_vec3()],
            px_scale: glam::Vec2::new(2.0 / self.width as f32, 2.0 / self.height as f32),
            half_extent: glam::DVec2::new(tan_half * aspect, tan_half).as_vec2(),
        })
    }
}

impl Camera {
    /// The footprint of the primary rays for a level of detail of `lod` pixels: no width at
    /// the eye, and the angle of a pixel at the image's centre (`2 tan(fov / 2) / height`)
    /// times `lod` as its spread. [`Cone::EXACT`] when `lod` is not positive.
    pub fn pixel_cone(&self, lod: f32) -> Cone {
        if !(lod > 0.0) {
            return Cone::EXACT;
        }
        let tan_half = (self.fov_deg.to_radians() * 0.5).tan();
        let pixel = 2.0 * tan_half / f64::from(self.height.max(1));
        Cone {
            width: 0.0,
            spread: (pixel * f64::from(lod)) as f32,
        }
    }
}

impl CameraRays {
    /// The eye.
    pub fn eye(&self) -> DVec3 {
        self.eye
    }

    /// The image plane's half extent at distance 1 along the view direction: `tan(fov / 2)`
    /// times the aspect ratio, and `tan(fov / 2)`.
    pub fn half_extent(&self) -> glam::DVec2 {
        glam::DVec2::new(self.tan_half * self.aspect, self.tan_half)
    }

    /// The image size, width and height in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The unit view direction.
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// The unit up vector of the image plane.
    pub fn up(&self) -> DVec3 {
        self.up
    }

    /// The unit right vector of the image plane.
    pub fn right(&self) -> DVec3 {
        self.right
    }

    /// The continuous pixel coordinates `(x, y)` of scene point `p` (pixel centres at
    /// integers, as [`Self::dir`] numbers them), or `None` when `p` is not in front of the
    /// eye by a safe margin.
    pub fn project(&self, p: DVec3) -> Option<(f64, f64)> {
        let v = p - self.eye;
        let z = v.dot(self.forward);
        if !(z > 1e-9 * v.length()) || !(z > 0.0) {
            return None;
        }
        Some(self.pixel_of_view(DVec3::new(v.dot(self.right), v.dot(self.up), z)))
    }

    /// [`Self::project`] for a point given in view space relative to the eye (along right,
    /// up and the view direction; the last positive), without the margin check.
    pub fn pixel_of_view(&self, v: DVec3) -> (f64, f64) {
        let sx = v.x / (v.z * self.tan_half * self.aspect);
        let sy = v.y / (v.z * self.tan_half);
        (
            (sx + 1.0) * 0.5 * f64::from(self.width) - 0.5,
            (1.0 - sy) * 0.5 * f64::from(self.height) - 0.5,
        )
    }

    /// The `f32` values [`Self::dir_f32`] makes directions from: the basis (forward, right,
    /// up), `(2 / width, 2 / height)` and the image plane's half extent at distance 1, for a
    /// port (the GPU viewer's shader) that must make the same directions.
    pub fn f32_basis(&self) -> ([glam::Vec3; 3], glam::Vec2, glam::Vec2) {
        (self.basis, self.px_scale, self.half_extent)
    }

    /// [`Self::dir`] in `f32` (what the renderers use: a direction needs no more, and
    /// `f64` square roots and divisions per pixel cost a sixth of a primary ray).
    #[inline]
    pub fn dir_f32(&self, x: u32, y: u32) -> glam::Vec3 {
        let sx = ((x as f32 + 0.5) * self.px_scale.x - 1.0) * self.half_extent.x;
        let sy = (1.0 - (y as f32 + 0.5) * self.px_scale.y) * self.half_extent.y;
        (self.basis[0] + self.basis[1] * sx + self.basis[2] * sy).normalize()
    }

    /// The unit direction through the centre of pixel `(x, y)` (row 0 at the top).
    #[inline]
    pub fn dir(&self, x: u32, y: u32) -> DVec3 {
        let sx = (2.0 * (f64::from(x) + 0.5) / f64::from(self.width) - 1.0)
            * self.tan_half
            * self.aspect;
        let sy = (1.0 - 2.0 * (f64::from(y) + 0.5) / f64::from(self.height)) * self.tan_half;
        (self.forward + self.right * sx + self.up * sy).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_at_the_target_and_corners_are_symmetric() {
        let c = Camera {
            eye: DVec3::new(0.0, 0.0, 5.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            fov_deg: 90.0,
            width: 3,
            height: 3,
        };
        let r = c.rays().unwrap();
        assert!((r.dir(1, 1) - DVec3::NEG_Z).length() < 1e-12);
        let tl = r.dir(0, 0);
        let br = r.dir(2, 2);
        assert!(tl.x < 0.0 && tl.y > 0.0 && br.x > 0.0 && br.y < 0.0);
        assert!((tl.x + br.x).abs() < 1e-12 && (tl.y + br.y).abs() < 1e-12);
        // Pixel centres at half-integers: the top-left centre is 2/3 of the way to the edge.
        let edge = (45f64.to_radians()).tan();
        assert!((tl.x / -tl.z - (-2.0 / 3.0 * edge)).abs() < 1e-12);
        for (x, y) in [(0, 0), (1, 1), (2, 0)] {
            assert!((r.dir_f32(x, y).as_dvec3() - r.dir(x, y)).length() < 1e-6);
            // Projecting a point along a pixel's ray lands on that pixel's centre.
            let (px, py) = r.project(r.eye() + r.dir(x, y) * 3.0).unwrap();
            assert!((px - f64::from(x)).abs() < 1e-9 && (py - f64::from(y)).abs() < 1e-9);
        }
        assert!(r.project(r.eye() - r.forward()).is_none());
    }

    #[test]
    fn bad_settings_are_errors() {
        let ok = Camera::framing(DVec3::ZERO, DVec3::ONE, 8, 8, 40.0);
        assert!(ok.rays().is_ok());
        for (c, e) in [
            (Camera { width: 0, ..ok }, CameraError::Size(0, 8)),
            (
                Camera {
                    width: 16384,
                    height: 16384,
                    ..ok
                },
                CameraError::Size(16384, 16384),
            ),
            (
                Camera {
                    fov_deg: 180.0,
                    ..ok
                },
                CameraError::Fov(180.0),
            ),
            (
                Camera {
                    eye: DVec3::NAN,
                    ..ok
                },
                CameraError::NotFinite,
            ),
            (
                Camera {
                    target: ok.eye,
                    ..ok
                },
                CameraError::Degenerate,
            ),
            (
                Camera {
                    up: ok.target - ok.eye,
                    ..ok
                },
                CameraError::Degenerate,
            ),
        ] {
            assert_eq!(c.rays().unwrap_err(), e);
        }
    }
}
