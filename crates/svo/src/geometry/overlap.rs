//! Triangle/cell overlap tests in grid space, for closed cells.
//!
//! The complete separating axis test for a triangle and a box has 13 axes: the 3 box
//! normals (done exactly by [`crate::geometry::child_classify`] or [`aabb_overlaps`]), the triangle's
//! plane normal ([`plane_overlaps`], thesis Algorithm 2) and the 9 cross products of the
//! triangle's edges with the box axes ([`edges_overlap`], thesis Algorithm 3 in its 2D
//! projections). [`vertex_inside`] is the thesis's shortcut: a vertex inside the cell proves
//! overlap without the other tests.
//!
//! ## Exactness in floating point
//! The box-normal and vertex tests are comparisons of exact values. The plane and edge
//! tests compute dot products, whose rounding could turn a touching contact into a reported
//! separation. Each of them therefore only reports a separation when it exceeds a rigorous
//! bound on the rounding error (a small multiple of machine epsilon times the magnitudes
//! involved): [`plane_overlaps`] and [`edges_overlap`] alone are *conservative* (a cell that
//! the triangle touches is never rejected; one within about `1e-13` relative of touching may
//! be accepted). [`triangle_box_overlap`] is exact: where an axis's answer lies within its
//! bound it decides the cell exactly, in integers
//! ([`crate::geometry::exact_contact`]). Degenerate triangles (zero area: segments and
//! points) are handled by the same code: their normal is (nearly) zero, so the plane test
//! never separates, and the edge axes plus box normals are then the complete test for a
//! segment.

use crate::geometry::exact_contact::{PLANE_AXIS, touches_exactly};
use crate::geometry::triangle_setup::{GridTriangle, edge_axis};
use glam::DVec3;

/// Relative tolerance on the plane and edge-axis separations: 256 machine epsilons, well
/// above the few roundings each dot product makes.
pub(crate) const TOLERANCE: f64 = 256.0 * f64::EPSILON;

#[inline]
fn l1(d: DVec3) -> f64 {
    d.x.abs() + d.y.abs() + d.z.abs()
}

/// Whether the triangle's bounding box overlaps the closed cell `[m, m + s]` (the three
/// box-normal axes).
#[inline]
pub fn aabb_overlaps(t: &GridTriangle, m: DVec3, s: f64) -> bool {
    let hi = m + DVec3::splat(s);
    t.lo().cmple(hi).all() && t.hi().cmpge(m).all()
}

/// Whether any vertex lies in the closed cell `[m, m + s]` (proves overlap).
#[inline]
pub fn vertex_inside(t: &GridTriangle, m: DVec3, s: f64) -> bool {
    let hi = m + DVec3::splat(s);
    t.v.iter().any(|v| v.cmpge(m).all() && v.cmple(hi).all())
}

/// The rounding bound of the plane test for cells whose corners are at most `reach` (L1)
/// from the triangle's first vertex: `|n|_1 <= 3 n_scale`, and the normal and the
/// distances each carry a few roundings of that size times `reach`. The voxelizer's
/// batched plane tests (all children of a node, all cells of a scatter node) pass a
/// `reach` that covers every cell they test.
#[inline]
pub(crate) fn plane_tolerance(t: &GridTriangle, reach: f64) -> f64 {
    TOLERANCE * 3.0 * t.n_scale * reach
}

/// What a floating-point test with rounding bound `tol` says about the interval
/// `[lo, hi]` (computed) containing 0: `Some(true)` if it surely does, `Some(false)` if it
/// surely does not, `None` if rounding could decide either way.
#[inline]
pub(crate) fn verdict(lo: f64, hi: f64, tol: f64) -> Option<bool> {
    if lo > tol || hi < -tol {
        Some(false)
    } else if lo <= -tol && hi >= tol {
        Some(true)
    } else {
        None
    }
}

/// [`verdict`] for one edge axis: the triangle's projection `[lo, hi]` against the cell's,
/// `pc` plus or minus `rad`, with rounding bound `tol`. The axis separates iff
/// `lo - pc > rad` or `pc - hi > rad`: the interval `[lo - pc - rad, hi - pc + rad]` holds 0
/// iff it does not.
#[inline]
pub(crate) fn edge_axis_verdict(lo: f64, hi: f64, pc: f64, rad: f64, tol: f64) -> Option<bool> {
    verdict(lo - pc - rad, hi - pc + rad, tol)
}

/// The plane test's computed interval `[base + neg, base + pos]` of signed distances (times
/// the normal's length) of the cell `[m, m + s]`, and its rounding bound.
#[inline]
fn plane_interval(t: &GridTriangle, m: DVec3, s: f64) -> (f64, f64, f64) {
    let n = t.n;
    let d = m - t.v[0];
    let base = n.dot(d);
    let pos = s * (n.x.max(0.0) + n.y.max(0.0) + n.z.max(0.0));
    let neg = s * (n.x.min(0.0) + n.y.min(0.0) + n.z.min(0.0));
    (base + neg, base + pos, plane_tolerance(t, l1(d) + 3.0 * s))
}

/// Thesis Algorithm 2: whether the triangle's plane meets the closed cell `[m, m + s]`
/// (the cell's two corners along the normal are not strictly on one side). Conservative.
#[inline]
pub fn plane_overlaps(t: &GridTriangle, m: DVec3, s: f64) -> bool {
    let (lo, hi, tol) = plane_interval(t, m, s);
    lo <= tol && hi >= -tol
}

/// The edge axis `e_j x unit_k` of triangle `t` as its two nonzero components `(a1, a2)`
/// on coordinates `(i1, i2)`, the triangle's projection interval `[lo, hi]` on it, and the
/// axis's L1 norm `a1.abs() + a2.abs()`. The edge's two vertices project alike, so the
/// interval comes from its first vertex and the vertex opposite the edge.
#[inline]
pub(crate) fn edge_interval(
    t: &GridTriangle,
    j: usize,
    k: usize,
) -> (f64, f64, usize, usize, f64, f64, f64) {
    let (a1, a2, i1, i2) = edge_axis(t.edge(j), k);
    let (p, q) = (t.v[j], t.v[if j == 0 { 2 } else { j - 1 }]);
    let (pa, pb) = (a1 * p[i1] + a2 * p[i2], a1 * q[i1] + a2 * q[i2]);
    (a1, a2, i1, i2, pa.min(pb), pa.max(pb), a1.abs() + a2.abs())
}

/// Thesis Algorithm 3: whether no axis `edge x box axis` separates the triangle from the
/// closed cell `[m, m + s]`: per axis, the triangle's projection interval against the
/// cell's centre plus or minus its radius. Conservative.
///
/// Rounding: the projections are dot products of coordinates of magnitude at most `M`
/// with the axis, so each computed value is within a few `eps * |axis|_1 * M` of the exact
/// one; separations smaller than [`GridTriangle::edge_tol`] times `|axis|_1` are not trusted.
#[inline]
pub fn edges_overlap(t: &GridTriangle, m: DVec3, s: f64) -> bool {
    edges_doubt(t, m, s).is_some()
}

/// [`edges_overlap`] with its certainty: `None` if an edge axis surely separates, else the
/// axes within their rounding bound of separating, as [`touches_exactly`]'s bits (`0`: none
/// can separate).
#[inline]
pub(crate) fn edges_doubt(t: &GridTriangle, m: DVec3, s: f64) -> Option<u16> {
    let h = 0.5 * s;
    let c = m + DVec3::splat(h);
    let mut doubt = 0u16;
    for j in 0..3 {
        for k in 0..3 {
            let (a1, a2, i1, i2, lo, hi, w) = edge_interval(t, j, k);
            let pc = a1 * c[i1] + a2 * c[i2];
            match edge_axis_verdict(lo, hi, pc, h * w, t.edge_tol * w) {
                Some(false) => return None,
                Some(true) => {}
                None => doubt |= 1 << (1 + 3 * j + k),
            }
        }
    }
    Some(doubt)
}

/// The complete 13-axis test: whether the triangle touches the closed cell `[m, m + s]`,
/// exactly (cells that the `f64` plane or edge tests leave within their rounding bound are
/// decided in integers).
#[inline]
pub fn triangle_box_overlap(t: &GridTriangle, m: DVec3, s: f64) -> bool {
    if !aabb_overlaps(t, m, s) {
        return false;
    }
    if vertex_inside(t, m, s) {
        return true;
    }
    let (lo, hi, tol) = plane_interval(t, m, s);
    let plane = verdict(lo, hi, tol);
    if plane == Some(false) {
        return false;
    }
    decide(t, m, s, plane == Some(true))
}

/// The rest of the exact test for a cell that the box axes and the plane (surely, when
/// `plane_sure`) do not separate: the edge axes, and the exact test of the axes in doubt.
#[inline]
pub(crate) fn decide(t: &GridTriangle, m: DVec3, s: f64, plane_sure: bool) -> bool {
    edges_doubt(t, m, s).is_some_and(|edges| {
        let doubt = edges | if plane_sure { 0 } else { PLANE_AXIS };
        doubt == 0 || touches_exactly(&t.v, m, s, doubt)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plane test's rounding bound against the error analysis of `docs/algorithms.md`
    /// ("Exactness in floating point"): the computed ends of the plane interval of a cell
    /// `[m, m + s]` lie within `9 u n_scale (|d|_1 + 3 s)` of the exact ones (`u = 2^-53`,
    /// `d = m - v0`), so a bound below that could let a rounded value decide a cell wrongly.
    /// The bound must cover it with room (16 u here; it is 1536 u). Cells from a hair off the
    /// first vertex to far from it (each component of `d` of its own magnitude, 1e-9 to 1e3),
    /// sides 1/8 to 1024.
    #[test]
    fn the_plane_bound_covers_the_rounding_error_analysis() {
        let mut rnd = svo_tests::seeds::unit_f64(0x0bad_5eed_1234_5678);
        let u = f64::EPSILON / 2.0;
        for i in 0..20_000 {
            let v = [0; 3].map(|_| DVec3::new(rnd(), rnd(), rnd()) * 2e3 - DVec3::splat(1e3));
            let t = GridTriangle::new(v[0], v[1], v[2]);
            let s = 2f64.powi(i % 14 - 3);
            let mut d = DVec3::ZERO;
            for k in 0..3 {
                d[k] = (rnd() - 0.5) * 10f64.powf(rnd() * 12.0 - 9.0);
            }
            let m = t.v[0] + d;
            let (_, _, tol) = plane_interval(&t, m, s);
            let dm = m - t.v[0];
            let need = 16.0 * u * t.n_scale * (dm.x.abs() + dm.y.abs() + dm.z.abs() + 3.0 * s);
            assert!(tol >= need, "bound {tol:e} below {need:e}: d {d}, s {s}");
        }
    }
}
