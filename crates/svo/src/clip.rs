//! Clipping a triangle to a leaf cell (Sutherland-Hodgman against the cell's six faces), for
//! the clipped-area weights of the attributes and the points that contours must enclose.

use glam::DVec3;

/// A convex polygon with at most 9 vertices (a triangle clipped by 6 planes).
#[derive(Clone, Copy, Debug)]
pub struct Polygon {
    /// Vertices; only the first `len` are valid.
    pub v: [DVec3; 9],
    /// Number of vertices.
    pub len: usize,
}

impl Polygon {
    /// The valid vertices.
    pub fn points(&self) -> &[DVec3] {
        &self.v[..self.len]
    }

    /// The polygon's area.
    pub fn area(&self) -> f64 {
        if self.len < 3 {
            return 0.0;
        }
        let p0 = self.v[0];
        let mut s = DVec3::ZERO;
        for i in 1..self.len - 1 {
            s += (self.v[i] - p0).cross(self.v[i + 1] - p0);
        }
        0.5 * s.length()
    }

    /// The mean of the vertices (a point inside the polygon).
    pub fn centre(&self) -> DVec3 {
        if self.len == 0 {
            return DVec3::ZERO;
        }
        self.points().iter().sum::<DVec3>() / self.len as f64
    }
}

/// Clips the triangle `v` (in cell-local coordinates) to the closed unit cube `[0, 1]^3`.
/// An empty result (`len == 0`) means the triangle misses the cube, or touches it only in a
/// way that rounding lost.
pub fn clip_to_unit_cube(v: [DVec3; 3]) -> Polygon {
    let mut a = Polygon {
        v: [DVec3::ZERO; 9],
        len: 3,
    };
    a.v[..3].copy_from_slice(&v);
    let mut b = Polygon {
        v: [DVec3::ZERO; 9],
        len: 0,
    };
    for axis in 0..3 {
        for upper in [false, true] {
            // signed distance, >= 0 inside
            let dist = |p: DVec3| if upper { 1.0 - p[axis] } else { p[axis] };
            b.len = 0;
            for i in 0..a.len {
                let p = a.v[i];
                let q = a.v[(i + 1) % a.len];
                let (dp, dq) = (dist(p), dist(q));
                if dp >= 0.0 {
                    if b.len < 9 {
                        b.v[b.len] = p;
                        b.len += 1;
                    }
                    if dq < 0.0 && dp > 0.0 && b.len < 9 {
                        b.v[b.len] = p + (q - p) * (dp / (dp - dq));
                        b.len += 1;
                    }
                } else if dq > 0.0 && b.len < 9 {
                    b.v[b.len] = p + (q - p) * (dp / (dp - dq));
                    b.len += 1;
                }
            }
            std::mem::swap(&mut a, &mut b);
            if a.len == 0 {
                return a;
            }
        }
    }
    // Pin the clipped coordinates onto the cube (the interpolation may round just outside).
    for p in &mut a.v[..a.len] {
        *p = p.clamp(DVec3::ZERO, DVec3::ONE);
    }
    a
}
