//! Contours (thesis section 1.4.4): two parallel planes with the leaf's normal that enclose
//! the surface inside the leaf. They are fitted to the triangles *clipped to the cell*, which
//! is tighter than the thesis's whole-triangle vertices.
//!
//! ## Encoding
//! For a unit normal `n`, the cell (side 1, centre `c`) spans `n . (p - c)` in `[-e, e]` with
//! `e = |n|_1 / 2`. A contour is the pair of fractions `t = (d + e) / (2e)` of that span for
//! the near and far plane, quantized to unorm16 (near in the low half), rounded outwards so the
//! planes always enclose the clipped surface. It is fitted against the *decoded* normal, so
//! the stored pair is conservative for exactly the normal a renderer reads.

use glam::{DVec3, Vec3};

/// The contour of the whole cell (near plane at 0, far at 1): what interior leaves of a solid
/// bake store.
pub(crate) const FULL: u32 = 0xFFFF_0000;

/// Packs the offsets `[dmin, dmax]` (along unit normal `n`, from the cell centre, in cells).
pub(crate) fn pack(dmin: f64, dmax: f64, n: Vec3) -> u32 {
    pack_with_thickness(dmin, dmax, n).0
}

/// [`pack`], with the packed contour's [`thickness`] (computed from the quantized offsets
/// without unpacking).
pub(crate) fn pack_with_thickness(dmin: f64, dmax: f64, n: Vec3) -> (u32, f32) {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    let e = 0.5 * f64::from(l1);
    if !(e > 0.0) || !(dmin <= dmax) {
        return (0xFFFF_0000, l1);
    }
    // The fraction of the cell's extent `[-e, e]` in unorm16 steps (one division).
    let scale = 65535.0 / (2.0 * e);
    let t = |d: f64| ((d + e) * scale).clamp(0.0, 65535.0);
    // One quantum of margin covers the f32 arithmetic of renderers.
    // floor and ceil of values in [0, 65535] by truncation (no libm call).
    let (a, b) = (t(dmin), t(dmax));
    let (fa, fb) = (a as u32, b as u32);
    let cb = fb + u32::from(f64::from(fb) < b);
    let lo = fa.saturating_sub(1);
    let hi = (cb + 1).min(65535);
    (lo | (hi << 16), (hi - lo) as f32 * (l1 / 65535.0))
}

/// Unpacks to the fractions `(near, far)` of the cell's extent along the normal.
pub(crate) fn unpack(c: u32) -> (f32, f32) {
    (
        f32::from((c & 0xFFFF) as u16) / 65535.0,
        f32::from((c >> 16) as u16) / 65535.0,
    )
}

/// The contour's plane offsets from the cell centre along `n`, in cells.
pub(crate) fn offsets(c: u32, n: Vec3) -> (f32, f32) {
    let e = 0.5 * (n.x.abs() + n.y.abs() + n.z.abs());
    let (a, b) = unpack(c);
    ((2.0 * a - 1.0) * e, (2.0 * b - 1.0) * e)
}

/// The thickness between the planes, in cells.
pub(crate) fn thickness(c: u32, n: Vec3) -> f32 {
    let (a, b) = offsets(c, n);
    b - a
}

/// Fits a contour: the extreme offsets of `points` (cell-local, the cell is `[0, 1]^3`)
/// along the decoded normal `n`. With no points the contour is the whole cell.
pub(crate) fn fit(points: &[DVec3], n: Vec3) -> u32 {
    if points.is_empty() {
        return 0xFFFF_0000;
    }
    let nd = n.as_dvec3();
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for p in points {
        let d = nd.dot(*p - DVec3::splat(0.5));
        lo = lo.min(d);
        hi = hi.max(d);
    }
    pack(lo, hi, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thickness_from_packing_equals_unpacked_thickness() {
        for (dmin, dmax, n) in [
            (-0.3, 0.1, Vec3::new(0.6, 0.0, 0.8)),
            (0.0, 0.0, Vec3::Z),
            (-0.8, 0.8, Vec3::new(0.577, 0.577, 0.578)),
            (0.2, 0.21, Vec3::new(-0.1, 0.99, 0.0)),
        ] {
            let (c, t) = pack_with_thickness(dmin, dmax, n);
            assert_eq!(c, pack(dmin, dmax, n));
            assert!(
                (t - thickness(c, n)).abs() < 1e-6,
                "{t} vs {}",
                thickness(c, n)
            );
            // Conservative: the packed slab encloses [dmin, dmax] (all within the cell).
            let (a, b) = offsets(c, n);
            assert!(f64::from(a) <= dmin && f64::from(b) >= dmax);
        }
    }
}
