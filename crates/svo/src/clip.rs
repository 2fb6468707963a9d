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

/// Clips the convex polygon `a` against one face plane of the unit cube (`upper`: the
/// plane `p[axis] = 1`, else `p[axis] = 0`), keeping the closed inside.
fn clip_plane(a: &Polygon, axis: usize, upper: bool) -> Polygon {
    let dist = |p: DVec3| if upper { 1.0 - p[axis] } else { p[axis] };
    let mut b = Polygon {
        v: [DVec3::ZERO; 9],
        len: 0,
    };
    let push = |b: &mut Polygon, p: DVec3| {
        if b.len < 9 {
            b.v[b.len] = p;
            b.len += 1;
        }
    };
    for i in 0..a.len {
        let p = a.v[i];
        let q = a.v[if i + 1 == a.len { 0 } else { i + 1 }];
        let (dp, dq) = (dist(p), dist(q));
        if dp >= 0.0 {
            push(&mut b, p);
            if dq < 0.0 && dp > 0.0 {
                push(&mut b, p + (q - p) * (dp / (dp - dq)));
            }
        } else if dq > 0.0 {
            push(&mut b, p + (q - p) * (dp / (dp - dq)));
        }
    }
    b
}

/// Clips the triangle `v` (in cell-local coordinates) to the closed unit cube `[0, 1]^3`.
/// An empty result (`len == 0`) means the triangle misses the cube, or touches it only in a
/// way that rounding lost. Only the faces that the triangle's bounds cross are clipped
/// against, so a triangle inside the cell costs six comparisons.
pub fn clip_to_unit_cube(v: [DVec3; 3]) -> Polygon {
    let lo = v[0].min(v[1]).min(v[2]);
    let hi = v[0].max(v[1]).max(v[2]);
    let mut a = Polygon {
        v: [DVec3::ZERO; 9],
        len: 3,
    };
    a.v[..3].copy_from_slice(&v);
    if lo.cmpge(DVec3::ZERO).all() && hi.cmple(DVec3::ONE).all() {
        return a;
    }
    for axis in 0..3 {
        if lo[axis] < 0.0 {
            a = clip_plane(&a, axis, false);
        }
        if hi[axis] > 1.0 && a.len > 0 {
            a = clip_plane(&a, axis, true);
        }
        if a.len == 0 {
            return a;
        }
    }
    // Pin the clipped coordinates onto the cube (the interpolation may round just outside).
    for p in &mut a.v[..a.len] {
        *p = p.clamp(DVec3::ZERO, DVec3::ONE);
    }
    a
}
