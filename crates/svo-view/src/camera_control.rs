//! The window's camera: orbit (drag to turn around a target, wheel to zoom, pan with the
//! other buttons) and fly (mouse look, keys to move), both turning into an
//! [`svo::render::Camera`] for each frame. Pure state and arithmetic, tested without a
//! window.

use glam::DVec3;
use svo::render::Camera;

/// Radians per pixel of mouse movement.
const TURN_PER_PIXEL: f64 = 0.005;
/// The steepest pitch, short of straight up or down (where "up" would be undefined).
const MAX_PITCH: f64 = 1.55;

/// How the mouse and keys move the camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraMode {
    /// Around a target point.
    Orbit,
    /// Free flight: the eye moves, the view turns.
    Fly,
}

/// The camera state between frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraControl {
    /// Orbit or fly.
    pub mode: CameraMode,
    /// The point looked at (orbit) or the eye (fly) is derived from these.
    target: DVec3,
    /// Distance from the eye to the target.
    distance: f64,
    /// Angle around the up axis.
    yaw: f64,
    /// Angle above the horizontal plane.
    pitch: f64,
    /// World up (unit).
    up: DVec3,
    /// Two unit vectors spanning the horizontal plane.
    a: DVec3,
    b: DVec3,
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    /// Fly speed, scene units per second (the model's size per second by default).
    pub speed: f64,
    start: (DVec3, f64, f64, f64),
}

impl CameraControl {
    /// The control that reproduces `camera`, for a model of about `size` scene units.
    pub fn from_camera(camera: &Camera, size: f64) -> Self {
        let up = camera.up.normalize_or(DVec3::Y);
        let a = up.any_orthonormal_vector();
        let b = up.cross(a);
        let v = camera.eye - camera.target;
        let distance = v.length().max(1e-12);
        let d = v / distance;
        let pitch = d
            .dot(up)
            .clamp(-1.0, 1.0)
            .asin()
            .clamp(-MAX_PITCH, MAX_PITCH);
        let yaw = d.dot(b).atan2(d.dot(a));
        Self {
            mode: CameraMode::Orbit,
            target: camera.target,
            distance,
            yaw,
            pitch,
            up,
            a,
            b,
            fov_deg: camera.fov_deg,
            speed: size.max(1e-9),
            start: (camera.target, distance, yaw, pitch),
        }
    }

    /// The unit vector from the target to the eye.
    fn back(&self) -> DVec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        (self.a * cy + self.b * sy) * cp + self.up * sp
    }

    /// The eye.
    pub fn eye(&self) -> DVec3 {
        self.target + self.back() * self.distance
    }

    /// The point looked at.
    pub fn target(&self) -> DVec3 {
        self.target
    }

    /// The camera for a `width` x `height` frame.
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        Camera {
            eye: self.eye(),
            target: self.target,
            up: self.up,
            fov_deg: self.fov_deg,
            width,
            height,
        }
    }

    /// Mouse drag with the turning button by `(dx, dy)` pixels: orbit around the target, or
    /// (fly) turn the view about the eye.
    pub fn turn(&mut self, dx: f64, dy: f64) {
        let eye = self.eye();
        self.yaw -= dx * TURN_PER_PIXEL;
        match self.mode {
            CameraMode::Orbit => {
                self.pitch = (self.pitch + dy * TURN_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
            }
            CameraMode::Fly => {
                // Looking up moves the target up: the pitch of `back` goes down.
                self.pitch = (self.pitch + dy * TURN_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
                self.target = eye - self.back() * self.distance;
            }
        }
    }

    /// Mouse drag with the panning button by `(dx, dy)` pixels in a frame `height` pixels
    /// high: the target (and eye) follow the pointer in the view plane.
    pub fn pan(&mut self, dx: f64, dy: f64, height: u32) {
        let back = self.back();
        let right = self.up.cross(back).normalize_or(self.a);
        let view_up = back.cross(right);
        let per_px = 2.0 * self.distance * (self.fov_deg.to_radians() * 0.5).tan()
            / f64::from(height.max(1));
        self.target += (-right * dx + view_up * dy) * per_px;
    }

    /// Wheel by `steps` notches (positive: closer): orbit moves the eye towards the target,
    /// fly moves it forward.
    pub fn zoom(&mut self, steps: f64) {
        match self.mode {
            CameraMode::Orbit => self.distance = (self.distance * 0.9f64.powf(steps)).max(1e-9),
            CameraMode::Fly => {
                let step = self.speed * 0.1 * steps;
                self.target -= self.back() * step;
            }
        }
    }

    /// Fly keys held for `dt` seconds: `forward`, `right` and `up` in -1..=1.
    pub fn fly(&mut self, forward: f64, right: f64, up: f64, dt: f64) {
        let back = self.back();
        let r = self.up.cross(back).normalize_or(self.a);
        let step = self.speed * dt;
        self.target += (-back * forward + r * right + self.up * up) * step;
    }

    /// Switches between orbit and fly; the view does not jump.
    pub fn toggle_mode(&mut self) {
        self.mode = match self.mode {
            CameraMode::Orbit => CameraMode::Fly,
            CameraMode::Fly => CameraMode::Orbit,
        };
    }

    /// Back to the starting view.
    pub fn reset(&mut self) {
        (self.target, self.distance, self.yaw, self.pitch) = self.start;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            eye: DVec3::new(1.0, 2.0, 5.0),
            target: DVec3::new(0.0, 0.5, 0.0),
            up: DVec3::Y,
            fov_deg: 40.0,
            width: 64,
            height: 48,
        }
    }

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-9
    }

    #[test]
    fn reproduces_the_starting_camera() {
        let c = CameraControl::from_camera(&cam(), 2.0);
        let back = c.camera(64, 48);
        assert!(close(back.eye, cam().eye), "{:?}", back.eye);
        assert!(close(back.target, cam().target));
        assert!(back.rays().is_ok());
    }

    #[test]
    fn orbit_keeps_the_distance_and_the_target() {
        let mut c = CameraControl::from_camera(&cam(), 2.0);
        let d0 = (c.eye() - c.target()).length();
        c.turn(120.0, -40.0);
        assert!(((c.eye() - c.target()).length() - d0).abs() < 1e-9);
        assert!(close(c.target(), cam().target));
        assert!(!close(c.eye(), cam().eye));
        // Dragging far up stops short of the pole: the camera stays valid.
        c.turn(0.0, 10_000.0);
        assert!(c.camera(64, 48).rays().is_ok());
        c.reset();
        assert!(close(c.eye(), cam().eye));
    }

    #[test]
    fn zoom_and_pan() {
        let mut c = CameraControl::from_camera(&cam(), 2.0);
        let d0 = (c.eye() - c.target()).length();
        c.zoom(1.0);
        assert!(((c.eye() - c.target()).length() - 0.9 * d0).abs() < 1e-9);
        let t0 = c.target();
        let e0 = c.eye();
        c.pan(10.0, 0.0, 48);
        // Panning moves eye and target together, sideways.
        assert!(close(c.eye() - e0, c.target() - t0));
        assert!((c.target() - t0).dot(DVec3::Y).abs() < 1e-9);
        assert!((c.target() - t0).length() > 0.0);
    }

    #[test]
    fn fly_moves_along_the_view_and_turns_about_the_eye() {
        let mut c = CameraControl::from_camera(&cam(), 2.0);
        c.toggle_mode();
        assert_eq!(c.mode, CameraMode::Fly);
        let e0 = c.eye();
        let view = (c.target() - c.eye()).normalize();
        c.fly(1.0, 0.0, 0.0, 0.5);
        assert!(close(c.eye() - e0, view * 1.0), "moved {}", c.eye() - e0);
        let e1 = c.eye();
        c.turn(50.0, 20.0);
        assert!(close(c.eye(), e1), "turning in fly mode keeps the eye");
        c.toggle_mode();
        assert_eq!(c.mode, CameraMode::Orbit);
        assert!(close(c.eye(), e1), "switching modes keeps the view");
    }
}
