//! Shading formulas: reflection, refraction (Snell), Fresnel (exact for unpolarized light and
//! Schlick's approximation), Phong, and point lights with inverse-square falloff.

use glam::Vec3;

/// Mirror reflection of direction `d` about unit normal `n`.
#[inline]
pub(crate) fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of unit direction `d` through a surface with unit normal `n` facing against
/// `d`, from index `n1` into `n2` (Snell's law). `None` on total internal reflection.
#[inline]
pub(crate) fn refract(d: Vec3, n: Vec3, n1: f32, n2: f32) -> Option<Vec3> {
    let eta = n1 / n2;
    let cos_i = -d.dot(n);
    let k = cos2_transmitted(cos_i, eta);
    (k >= 0.0).then(|| (eta * d + (eta * cos_i - k.sqrt()) * n).normalize())
}

/// `cos^2` of the transmitted angle, `1 - eta^2 (1 - cos_i^2)`, summed as
/// `(1 - eta^2) + eta^2 cos_i^2` so that it does not cancel at grazing incidence: between
/// equal media it is `cos_i^2` to the last bit (the direct form lost 3% of `cos_t` at
/// `cos_i = 1e-3` in `f32`). Negative on total internal reflection.
#[inline]
pub(crate) fn cos2_transmitted(cos_i: f32, eta: f32) -> f32 {
    let e2 = eta * eta;
    (1.0 - e2) + e2 * (cos_i * cos_i)
}

/// The exact Fresnel reflectance of unpolarized light at a dielectric boundary, for the
/// cosine `cos_i` of the incidence angle, from index `n1` into `n2`; 1 on total internal
/// reflection.
pub(crate) fn fresnel_exact(cos_i: f32, n1: f32, n2: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let cos2_t = cos2_transmitted(cos_i, n1 / n2);
    if cos2_t <= 0.0 {
        return 1.0;
    }
    let cos_t = cos2_t.sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i);
    0.5 * (rs * rs + rp * rp)
}

/// Schlick's approximation of [`fresnel_exact`] (with the transmitted angle's cosine when
/// leaving the denser medium, and 1 on total internal reflection).
pub(crate) fn fresnel_schlick(cos_i: f32, n1: f32, n2: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let r0 = ((n1 - n2) / (n1 + n2)).powi(2);
    let c = if n1 > n2 {
        let cos2_t = cos2_transmitted(cos_i, n1 / n2);
        if cos2_t <= 0.0 {
            return 1.0;
        }
        cos2_t.sqrt()
    } else {
        cos_i
    };
    r0 + (1.0 - r0) * (1.0 - c).powi(5)
}

/// The critical angle (radians) for total internal reflection going from `n1` into a less
/// dense `n2`; `None` when `n1 <= n2`.
#[cfg(test)]
pub(crate) fn critical_angle(n1: f32, n2: f32) -> Option<f32> {
    (n1 > n2).then(|| (n2 / n1).asin())
}

/// A point light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    /// Position in scene units.
    pub position: glam::DVec3,
    /// Linear RGB colour.
    pub colour: Vec3,
    /// Intensity: the irradiance scale at distance 1 (scene units).
    pub intensity: f32,
}

impl PointLight {
    /// The light's radiance scale at distance `dist` (inverse-square falloff).
    #[inline]
    pub fn falloff(&self, dist: f32) -> Vec3 {
        self.colour * (self.intensity / (dist * dist).max(1e-12))
    }
}

/// Phong material parameters shared by all leaves (the per-leaf attributes supply colour,
/// reflectivity, refractivity and IOR).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phong {
    /// Ambient factor (times the albedo).
    pub ambient: f32,
    /// Diffuse factor (times the albedo).
    pub diffuse: f32,
    /// Specular factor.
    pub specular: f32,
    /// Specular exponent.
    pub shininess: f32,
}

impl Default for Phong {
    fn default() -> Self {
        Self {
            ambient: 0.08,
            diffuse: 0.9,
            specular: 0.25,
            shininess: 32.0,
        }
    }
}

impl Phong {
    /// The diffuse plus specular response to one light: `n` the unit normal facing the
    /// viewer, `l` the unit direction to the light, `v` the unit direction to the viewer.
    #[inline]
    pub fn direct(&self, albedo: Vec3, n: Vec3, l: Vec3, v: Vec3) -> Vec3 {
        let ndl = n.dot(l);
        if ndl <= 0.0 {
            return Vec3::ZERO;
        }
        let r = reflect(-l, n);
        let spec = r.dot(v).max(0.0).powf(self.shininess);
        albedo * (self.diffuse * ndl) + Vec3::splat(self.specular * spec)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GLASS: f32 = 1.5;

    /// Every pair of indices a file can hold (decoded IOR 1 to 5, with the smallest step
    /// above 1) at incidences from normal to exactly grazing: reflectances are finite and in
    /// `[0, 1]`, equal media reflect nothing, refraction gives a unit vector exactly when
    /// Snell's law has a solution, and the transmitted ray bends towards the normal when
    /// entering the denser medium.
    #[test]
    fn fresnel_and_refraction_stay_finite_and_bounded_over_every_ior() {
        let iors = [1.0, 1.0 + 1.0 / 16384.0, 1.0003, 1.33, 1.5, 2.42, 4.0, 5.0];
        let cosines = [1.0, 0.999_999, 0.7, 0.3, 1e-3, 1e-7, 1e-30, 0.0];
        for &n1 in &iors {
            for &n2 in &iors {
                for &c in &cosines {
                    for (name, r) in [
                        ("exact", fresnel_exact(c, n1, n2)),
                        ("schlick", fresnel_schlick(c, n1, n2)),
                    ] {
                        assert!(
                            r.is_finite() && (0.0..=1.0).contains(&r),
                            "{name} fresnel({c}, {n1}, {n2}) = {r}"
                        );
                    }
                    if n1 == n2 && c > 1e-6 {
                        assert!(fresnel_exact(c, n1, n2) < 1e-6, "equal media reflect");
                    }
                    let sin_i = (1.0 - c * c).max(0.0).sqrt();
                    let d = Vec3::new(sin_i, -c, 0.0);
                    let n = Vec3::Y;
                    match refract(d, n, n1, n2) {
                        Some(t) => {
                            assert!(t.is_finite() && (t.length() - 1.0).abs() < 1e-5, "{t}");
                            assert!(t.y <= 0.0, "the refracted ray goes through: {t}");
                            if n2 > n1 && c > 1e-3 {
                                assert!(t.x.abs() <= sin_i + 1e-6, "bends towards the normal");
                            }
                        }
                        None => assert!(
                            n1 / n2 * sin_i > 1.0 - 1e-6,
                            "total internal reflection where Snell has a solution: {c} {n1} {n2}"
                        ),
                    }
                }
            }
        }
    }

    #[test]
    fn fresnel_at_normal_incidence_is_r0() {
        let r0 = ((1.0 - GLASS) / (1.0 + GLASS)).powi(2); // 0.04
        assert!((fresnel_exact(1.0, 1.0, GLASS) - r0).abs() < 1e-6);
        assert!((fresnel_schlick(1.0, 1.0, GLASS) - r0).abs() < 1e-6);
        assert!((r0 - 0.04).abs() < 1e-6);
        // Symmetric at normal incidence.
        assert!((fresnel_exact(1.0, GLASS, 1.0) - r0).abs() < 1e-6);
    }

    #[test]
    fn fresnel_at_grazing_incidence_is_one() {
        assert!((fresnel_exact(0.0, 1.0, GLASS) - 1.0).abs() < 1e-6);
        assert!((fresnel_schlick(0.0, 1.0, GLASS) - 1.0).abs() < 1e-6);
        // Brewster's angle: p-polarized reflectance vanishes, so R = Rs / 2.
        let theta_b = GLASS.atan();
        let cos_i = theta_b.cos();
        let cos_t = (1.0 - (theta_b.sin() / GLASS).powi(2)).sqrt();
        let rs = ((cos_i - GLASS * cos_t) / (cos_i + GLASS * cos_t)).powi(2);
        assert!((fresnel_exact(cos_i, 1.0, GLASS) - rs / 2.0).abs() < 1e-6);
    }

    #[test]
    fn total_internal_reflection_beyond_the_critical_angle() {
        let crit = critical_angle(GLASS, 1.0).unwrap();
        assert!((crit.to_degrees() - 41.810_31).abs() < 1e-3);
        assert!(critical_angle(1.0, GLASS).is_none());
        let n = Vec3::Y;
        for (deg, tir) in [(41.0f32, false), (42.0, true), (80.0, true)] {
            let a = deg.to_radians();
            let d = Vec3::new(a.sin(), -a.cos(), 0.0);
            assert_eq!(refract(d, n, GLASS, 1.0).is_none(), tir, "{deg}");
            assert_eq!(fresnel_exact(a.cos(), GLASS, 1.0) == 1.0, tir, "{deg}");
            assert_eq!(fresnel_schlick(a.cos(), GLASS, 1.0) == 1.0, tir, "{deg}");
        }
    }

    #[test]
    fn snell_law_holds() {
        let n = Vec3::Y;
        for deg in [0.0f32, 10.0, 30.0, 60.0, 89.0] {
            let a = deg.to_radians();
            let d = Vec3::new(a.sin(), -a.cos(), 0.0);
            let t = refract(d, n, 1.0, GLASS).unwrap();
            let sin_t = t.x / t.length();
            assert!((a.sin() - GLASS * sin_t).abs() < 1e-5, "{deg}");
            assert!(t.y < 0.0 && (t.length() - 1.0).abs() < 1e-6);
        }
        let d = Vec3::new(0.3, -0.7, 0.2).normalize();
        assert_eq!(refract(d, n, 1.3, 1.3).unwrap(), d);
        let r = reflect(d, n);
        assert!((r - Vec3::new(d.x, -d.y, d.z)).length() < 1e-6);
    }

    #[test]
    fn inverse_square_falloff() {
        let l = PointLight {
            position: glam::DVec3::ZERO,
            colour: Vec3::new(1.0, 0.5, 0.25),
            intensity: 8.0,
        };
        assert_eq!(l.falloff(1.0), Vec3::new(8.0, 4.0, 2.0));
        assert_eq!(l.falloff(2.0), Vec3::new(2.0, 1.0, 0.5));
        assert_eq!(l.falloff(4.0) * 16.0, l.falloff(1.0));
    }

    #[test]
    fn exact_fresnel_and_schlick_stay_close() {
        let mut worst = 0.0f32;
        for i in 0..=1000 {
            let c = i as f32 / 1000.0;
            worst =
                worst.max((fresnel_exact(c, 1.0, GLASS) - fresnel_schlick(c, 1.0, GLASS)).abs());
        }
        // Schlick's well-known worst error for glass is a few hundredths.
        assert!(worst < 0.05 && worst > 0.001, "{worst}");
    }
}
