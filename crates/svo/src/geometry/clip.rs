//! Clipping a triangle to a leaf cell (Sutherland-Hodgman against the cell's six faces), for
//! the clipped-area weights of the attributes and the points that contours must enclose.

use glam::DVec3;

/// A convex polygon with at most 9 vertices (a triangle clipped by 6 planes).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Polygon {
    /// Vertices; only the first `len` are valid.
    pub v: [DVec3; 9],
    /// Number of vertices.
    pub len: usize,
}

impl Polygon {
    /// The valid vertices.
    pub(crate) fn points(&self) -> &[DVec3] {
        &self.v[..self.len]
    }

    /// The polygon's area.
    pub(crate) fn area(&self) -> f64 {
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
}

/// Clips the convex polygon `src` against one face plane of the unit cube (`upper`: the
/// plane `p[axis] = 1`, else `p[axis] = 0`) into `dst`, keeping the closed inside; returns
/// the number of vertices written.
#[inline]
fn clip_plane(src: &[DVec3], dst: &mut [DVec3; 9], axis: usize, upper: bool) -> usize {
    let dist = |p: DVec3| if upper { 1.0 - p[axis] } else { p[axis] };
    let mut n = 0;
    let mut push = |p: DVec3| {
        if n < 9 {
            dst[n] = p;
            n += 1;
        }
    };
    let len = src.len();
    for i in 0..len {
        let p = src[i];
        let q = src[if i + 1 == len { 0 } else { i + 1 }];
        let (dp, dq) = (dist(p), dist(q));
        if dp >= 0.0 {
            push(p);
            if dq < 0.0 && dp > 0.0 {
                push(p + (q - p) * (dp / (dp - dq)));
            }
        } else if dq > 0.0 {
            push(p + (q - p) * (dp / (dp - dq)));
        }
    }
    n
}

/// Clips the triangle `v` (in cell-local coordinates) to the closed unit cube `[0, 1]^3`.
/// An empty result (`len == 0`) means the triangle misses the cube, or touches it only in a
/// way that rounding lost. Only the faces that the triangle's bounds cross are clipped
/// against, so a triangle inside the cell costs six comparisons.
pub(crate) fn clip_to_unit_cube(v: [DVec3; 3]) -> Polygon {
    let lo = v[0].min(v[1]).min(v[2]);
    let hi = v[0].max(v[1]).max(v[2]);
    let mut out = Polygon {
        v: [DVec3::ZERO; 9],
        len: 3,
    };
    out.v[..3].copy_from_slice(&v);
    if lo.cmpge(DVec3::ZERO).all() && hi.cmple(DVec3::ONE).all() {
        return out;
    }
    let mut tmp = [DVec3::ZERO; 9];
    let (mut src, mut dst) = (&mut out.v, &mut tmp);
    let mut n = 3;
    let mut swapped = false;
    for axis in 0..3 {
        for upper in [false, true] {
            let crosses = if upper {
                hi[axis] > 1.0
            } else {
                lo[axis] < 0.0
            };
            if crosses && n > 0 {
                n = clip_plane(&src[..n], dst, axis, upper);
                std::mem::swap(&mut src, &mut dst);
                swapped = !swapped;
            }
        }
    }
    // Pin the clipped coordinates onto the cube (the interpolation may round just outside).
    for p in &mut src[..n] {
        *p = p.clamp(DVec3::ZERO, DVec3::ONE);
    }
    if swapped {
        let pts = *src;
        out.v = pts;
    }
    out.len = n;
    out
}
