//! Slicing a triangle through the cells of a small block of the grid.
//!
//! The voxelizer's bottom levels ([`crate::voxelize::scatter`]) need, for every cell a triangle
//! touches, the part of the triangle inside the cell: its area weighs the leaf's attributes
//! and its vertices bound the contour. Clipping the triangle against each cell's six faces
//! costs six plane passes per cell; slicing it costs about one: the triangle is clipped to
//! the block once, cut into slabs by the block's x planes, each slab into columns by the y
//! planes and each column into cells by the z planes, every cut sending the polygon's two
//! sides on at once (Sutherland-Hodgman with both outputs).
//!
//! The pieces are only approximately the exact intersections (the cut points are rounded,
//! though their coordinate on the cutting axis is set exactly). So that no touched cell is
//! lost to rounding, a vertex within `eps` of a cutting plane goes to both sides, where it
//! is (a vertex is never moved: moving one onto a plane bends the polygon's edges, and a
//! later cut along another axis then finds them further off than `eps`), and each edge
//! whose ends lie strictly on opposite sides adds its crossing to both: every cell the
//! triangle touches, or misses by at most `eps`, gets a piece, which may reach `eps` past
//! the cell. The caller decides membership from the pieces with care: a piece whose centroid
//! lies well inside its cell proves the contact ([`well_inside`]; the centroid is within
//! rounding of a point of the triangle); any other piece is decided by the exact overlap
//! test.

use glam::{DVec3, Vec3};

/// The most vertices a polygon may have while slicing. A triangle intersected with a box
/// has at most 9; rounding in degenerate cases could add a few, so there is room for more,
/// and a polygon that would exceed it makes [`slice_triangle`] report failure.
const CAP: usize = 12;

/// A convex polygon of at most 12 vertices.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Poly {
    v: [DVec3; 2 * CAP],
    n: usize,
    overflow: bool,
}

impl Default for Poly {
    fn default() -> Self {
        Self {
            v: [DVec3::ZERO; 2 * CAP],
            n: 0,
            overflow: false,
        }
    }
}

impl Poly {
    /// The vertices.
    pub(crate) fn points(&self) -> &[DVec3] {
        &self.v[..self.n]
    }

    #[inline]
    fn push(&mut self, p: DVec3) {
        if self.n < CAP {
            self.v[self.n] = p;
            self.n += 1;
        } else {
            self.overflow = true;
        }
    }

    /// The polygon's area (zero below three vertices).
    pub(crate) fn area(&self) -> f64 {
        polygon_area(self.points())
    }
}

/// What the voxelizer takes from a part, in one pass over its points: appends them to
/// `out` relative to the cell corner `m` in `f32`, and returns their sum and twice the area
/// of the part's projection on the plane normal to axis `W` (the `W` component of its fan's
/// vector area, the sums in [`polygon_area`]'s order). The part lies in its triangle's plane,
/// so its area is that projection's over the unit normal's `W` component (best taken on the
/// normal's dominant axis, [`dominant_axis`]): two products per point instead of a cross
/// product's six.
#[inline]
pub(crate) fn digest_part<const W: usize>(
    part: &Poly,
    m: DVec3,
    out: &mut Vec<Vec3>,
) -> (DVec3, f64) {
    let (u, v) = ((W + 1) % 3, (W + 2) % 3);
    let p = part.points();
    out.reserve(p.len());
    let (mut sum, mut fan) = (DVec3::ZERO, 0.0);
    let (p0, mut prev) = (p.first().copied().unwrap_or_default(), (0.0, 0.0));
    for (i, &q) in p.iter().enumerate() {
        sum += q;
        out.push((q - m).as_vec3());
        if i > 0 {
            let d = (q[u] - p0[u], q[v] - p0[v]);
            if i > 1 {
                fan += prev.0 * d.1 - prev.1 * d.0;
            }
            prev = d;
        }
    }
    (sum, fan)
}

/// The axis of `n`'s largest component (by magnitude; the first of equals).
#[inline]
pub(crate) fn dominant_axis(n: DVec3) -> usize {
    let a = n.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

/// Twice the vector area of a planar polygon, summed over the fan from its first vertex
/// (zero below three vertices).
#[inline]
fn fan_vector(p: &[DVec3]) -> DVec3 {
    let mut s = DVec3::ZERO;
    for i in 1..p.len().saturating_sub(1) {
        s += (p[i] - p[0]).cross(p[i + 1] - p[0]);
    }
    s
}

/// The area of a planar convex polygon.
pub(crate) fn polygon_area(p: &[DVec3]) -> f64 {
    0.5 * fan_vector(p).length()
}

/// Cuts `src` by the plane `p[axis] = c` into its closed lower and upper sides. A vertex
/// within `eps` of the plane goes to both sides, unmoved; each edge whose ends lie strictly
/// on opposite sides of the plane adds its intersection, with the coordinate on `axis` set
/// to exactly `c`, to both (also where one end is within `eps`: an edge nearly along the
/// plane crosses it far from that end, and the side that end is truly on reaches that far
/// along the other axes).
///
/// Each side gets at most one point per vertex and one per edge, so no push is checked
/// against the capacity (`2 * CAP`); a side longer than `CAP` is cut back and flagged as
/// overflowed, so that every polygon fed to a cut has at most `CAP` vertices.
#[inline]
fn cut<const AXIS: usize>(src: &Poly, c: f64, eps: f64, lo: &mut Poly, hi: &mut Poly) {
    let axis = AXIS;
    let n = src.n;
    let v = &src.v[..n];
    let (mut nl, mut nh) = (0, 0);
    let mut dp = v.first().map_or(0.0, |p| p[axis] - c);
    for (i, &p) in v.iter().enumerate() {
        let j = if i + 1 == n { 0 } else { i + 1 };
        let dq = v[j][axis] - c;
        if dp < -eps {
            lo.v[nl] = p;
            nl += 1;
        } else if dp > eps {
            hi.v[nh] = p;
            nh += 1;
        } else {
            lo.v[nl] = p;
            hi.v[nh] = p;
            nl += 1;
            nh += 1;
        }
        if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
            let q = v[j];
            let mut x = p + (q - p) * (dp / (dp - dq));
            x[axis] = c;
            lo.v[nl] = x;
            hi.v[nh] = x;
            nl += 1;
            nh += 1;
        }
        dp = dq;
    }
    lo.overflow = src.overflow || nl > CAP;
    hi.overflow = src.overflow || nh > CAP;
    lo.n = nl.min(CAP);
    hi.n = nh.min(CAP);
}

/// Calls `f(i, slab)` for every unit slab `[i, i + 1]` along `axis` (within `0..n`) that
/// the polygon reaches or comes within `eps` of, with its part there (see [`cut`]). So a
/// cell that the triangle touches only with a face, an edge or a corner, or misses by no
/// more than rounding, gets a part (on its boundary; the caller decides it with the exact
/// test), and points made later by cuts on other axes lie within the polygon's extent, so
/// they cannot come near another slab unseen.
#[inline]
fn slabs<const AXIS: usize>(
    poly: &Poly,
    n: u32,
    eps: f64,
    buf: &mut [Poly; 3],
    f: &mut impl FnMut(u32, &Poly),
) {
    let axis = AXIS;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in poly.points() {
        // `f64::min`/`max` without their NaN handling (the points are finite).
        let x = p[axis];
        lo = if x < lo { x } else { lo };
        hi = if x > hi { x } else { hi };
    }
    // Closed slabs (a polygon reaching down to a plane also reaches the slab below it),
    // as `grid::closed_cells` counts them, in floating point: the local coordinates are
    // small, so the integers are exact, and the one-slab case is decided before any
    // conversion to an integer.
    let last = f64::from(n - 1);
    let (lo, hi) = (lo - eps, hi + eps);
    let fl = floor_small(lo);
    let first = if fl == lo { fl - 1.0 } else { fl };
    let a = first.max(0.0).min(last);
    let b = floor_small(hi).max(a).min(last);
    if a == b {
        f(a as u32, poly);
        return;
    }
    let (a, b) = (a as i64, b as i64);
    // Ping-pong between two buffers for what is left above each cut.
    let [below, x, y] = buf;
    let (mut rest, mut above) = (x, y);
    cut::<AXIS>(poly, (a + 1) as f64, eps, below, rest);
    if below.n > 0 {
        f(a as u32, below);
    }
    for i in a + 1..b {
        if rest.n == 0 {
            return;
        }
        cut::<AXIS>(rest, (i + 1) as f64, eps, below, above);
        if below.n > 0 {
            f(i as u32, below);
        }
        std::mem::swap(&mut rest, &mut above);
    }
    if rest.n > 0 {
        f(b as u32, rest);
    }
}

/// `floor(x)` for `|x| < 2^51`, in floating point: adding and subtracting `1.5 * 2^52`
/// rounds `x` to an integer (exactly, in that range), which is then stepped down if it
/// rounded up. (Baseline x86-64 has no rounding instruction, and a round trip through an
/// integer register is a long chain of conversions.)
#[inline]
fn floor_small(x: f64) -> f64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    let r = (x + MAGIC) - MAGIC;
    if r > x { r - 1.0 } else { r }
}

/// Reusable polygon buffers for [`Slicer::slice`]: three per axis.
#[derive(Default)]
pub(crate) struct Slicer {
    clip: [Poly; 3],
    bufs: [[Poly; 3]; 3],
}

impl Slicer {
    /// Slices the triangle `v` (coordinates local to a block of `n^3` unit cells,
    /// `[0, n]^3`) into its parts per cell, calling `f(cell, part)` for each; a cell the
    /// triangle only touches, or misses by at most `eps`, gets a part on or near its boundary
    /// (points within `eps` of a cutting plane go to both sides, unmoved). Returns `false` when the triangle, clipped to the block, is empty (it
    /// misses the block, or touches it only where rounding lost the contact) or has an area
    /// of at most `eps` (it only grazes the block), or a polygon overflowed; the caller then
    /// falls back to testing cells one by one.
    pub(crate) fn slice(
        &mut self,
        v: [DVec3; 3],
        n: u32,
        eps: f64,
        f: &mut impl FnMut([u32; 3], &Poly),
    ) -> bool {
        let [poly, a, b] = &mut self.clip;
        poly.n = 0;
        poly.overflow = false;
        for p in v {
            poly.push(p);
        }
        // Clip to the block, against the faces that the triangle's bounds cross.
        let lo = v[0].min(v[1]).min(v[2]);
        let hi = v[0].max(v[1]).max(v[2]);
        let side = f64::from(n);
        clip_axis::<0>(poly, lo.x, hi.x, side, eps, a, b);
        clip_axis::<1>(poly, lo.y, hi.y, side, eps, a, b);
        clip_axis::<2>(poly, lo.z, hi.z, side, eps, a, b);
        if poly.n == 0 || poly.overflow {
            return false;
        }
        if lo.cmplt(DVec3::ZERO).any() || hi.cmpgt(DVec3::splat(side)).any() {
            // Pin the clipped coordinates into the block (interpolation may round just
            // outside).
            for p in &mut poly.v[..poly.n] {
                *p = p.clamp(DVec3::ZERO, DVec3::splat(side));
            }
            // A triangle that only grazes the block (what is left is a point, a segment or
            // a sliver on its faces) is left to the cell tests, which judge such contacts
            // with their own tolerance.
            if poly.area() <= eps {
                return false;
            }
        }
        // Slabs along x, columns along y, cells along z. (Putting the triangle normal's
        // dominant axis last, where a column holds the fewest cells, was measured slower on
        // the bunny: 117 against 113 ms for a depth-8 bake on one thread.)
        let mut overflow = false;
        let [bx, by, bz] = &mut self.bufs;
        slabs::<0>(poly, n, eps, bx, &mut |x, slab| {
            slabs::<1>(slab, n, eps, by, &mut |y, column| {
                slabs::<2>(column, n, eps, bz, &mut |z, part| {
                    overflow |= part.overflow;
                    f([x, y, z], part);
                });
            });
        });
        !overflow
    }
}

/// Clips `poly` to `0 <= p[AXIS] <= side` where its extent `lo..hi` on that axis passes a
/// bound (`a` and `b` are scratch).
#[inline]
fn clip_axis<const AXIS: usize>(
    poly: &mut Poly,
    lo: f64,
    hi: f64,
    side: f64,
    eps: f64,
    a: &mut Poly,
    b: &mut Poly,
) {
    if lo < 0.0 {
        cut::<AXIS>(poly, 0.0, eps, a, b);
        std::mem::swap(poly, b);
    }
    if hi > side {
        cut::<AXIS>(poly, side, eps, a, b);
        std::mem::swap(poly, a);
    }
}

/// [`Slicer::slice`] with buffers of its own.
#[cfg(test)]
pub(crate) fn slice_triangle(v: [DVec3; 3], n: u32, f: &mut impl FnMut([u32; 3], &Poly)) -> bool {
    Slicer::default().slice(v, n, 0.0, f)
}

/// Whether a point (cell-local coordinates `f`) is more than `eps` inside the cell on every
/// axis.
#[inline]
pub(crate) fn well_inside(f: DVec3, eps: f64) -> bool {
    f.cmpgt(DVec3::splat(eps)).all() && f.cmplt(DVec3::splat(1.0 - eps)).all()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri_area(v: [DVec3; 3]) -> f64 {
        0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length()
    }

    #[test]
    fn a_digest_repeats_the_area_and_points() {
        let mut slicer = Slicer::default();
        let v = [
            DVec3::new(0.3, 0.2, 0.1),
            DVec3::new(3.7, 1.1, 2.9),
            DVec3::new(1.2, 3.8, 0.4),
        ];
        let unit = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let w = dominant_axis(unit);
        let mut parts = 0;
        assert!(slicer.slice(v, 4, 1e-12, &mut |c, part| {
            let m = DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]));
            let mut out = vec![Vec3::ONE];
            let (sum, fan) = match w {
                0 => digest_part::<0>(part, m, &mut out),
                1 => digest_part::<1>(part, m, &mut out),
                _ => digest_part::<2>(part, m, &mut out),
            };
            // The projected area over the normal's component is the part's area (to
            // rounding), for every axis the normal has a component on.
            let area = part.area();
            let got = 0.5 * fan.abs() / unit[w].abs();
            assert!((got - area).abs() <= 1e-12 * area.max(1e-3), "{got} {area}");
            for k in 0..3 {
                let mut o = Vec::new();
                let f = match k {
                    0 => digest_part::<0>(part, m, &mut o).1,
                    1 => digest_part::<1>(part, m, &mut o).1,
                    _ => digest_part::<2>(part, m, &mut o).1,
                };
                let a = 0.5 * f.abs() / unit[k].abs();
                assert!(
                    (a - area).abs() <= 1e-9 * area.max(1e-3),
                    "axis {k}: {a} {area}"
                );
            }
            let want = part.points().iter().fold(DVec3::ZERO, |a, &p| a + p);
            assert_eq!(sum, want);
            let pts: Vec<Vec3> = part.points().iter().map(|&p| (p - m).as_vec3()).collect();
            assert_eq!(out[1..], pts[..]);
            parts += 1;
        }));
        assert!(parts > 10, "{parts}");
    }

    #[test]
    fn pieces_cover_the_triangle_and_stay_in_their_cells() {
        let mut rnd = svo_tests::seeds::unit_f64(0x9e37_79b9_7f4a_7c15);
        for _ in 0..2000 {
            let v = [0; 3].map(|_| DVec3::new(rnd() * 8.0, rnd() * 8.0, rnd() * 8.0));
            let mut sum = 0.0;
            let ok = slice_triangle(v, 8, &mut |c, p| {
                let m = DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]));
                for q in p.points() {
                    assert!(q.cmpge(m - 1e-12).all() && q.cmple(m + 1.0 + 1e-12).all());
                }
                sum += p.area();
            });
            assert!(ok);
            let a = tri_area(v);
            assert!((sum - a).abs() <= 1e-9 * a.max(1.0), "{sum} vs {a}");
        }
    }

    #[test]
    fn pieces_equal_clipping_to_each_cell() {
        let mut rnd = svo_tests::seeds::unit_f64(0x2545_f491_4f6c_dd1d);
        for _ in 0..500 {
            let v = [0; 3]
                .map(|_| DVec3::new(rnd() * 12.0 - 2.0, rnd() * 12.0 - 2.0, rnd() * 12.0 - 2.0));
            let mut got = std::collections::BTreeMap::new();
            slice_triangle(v, 8, &mut |c, p| {
                *got.entry(c).or_insert(0.0) += p.area();
            });
            for x in 0..8u32 {
                for y in 0..8u32 {
                    for z in 0..8u32 {
                        let m = DVec3::new(f64::from(x), f64::from(y), f64::from(z));
                        let want =
                            crate::geometry::clip::clip_to_unit_cube(v.map(|p| p - m)).area();
                        let g = got.get(&[x, y, z]).copied().unwrap_or(0.0);
                        assert!((g - want).abs() < 1e-9, "{:?}: {g} vs {want}", [x, y, z]);
                    }
                }
            }
        }
    }

    #[test]
    fn clipped_to_the_block() {
        // A triangle much larger than the block: the pieces cover the block's cross-section.
        let v = [
            DVec3::new(-100.0, -100.0, 2.5),
            DVec3::new(300.0, -100.0, 2.5),
            DVec3::new(-100.0, 300.0, 2.5),
        ];
        let mut sum = 0.0;
        let mut cells = 0;
        assert!(slice_triangle(v, 4, &mut |c, p| {
            assert_eq!(c[2], 2);
            sum += p.area();
            cells += 1;
        }));
        assert_eq!(cells, 16);
        assert!((sum - 16.0).abs() < 1e-9);
        // Missing the block entirely.
        let far = v.map(|p| p + DVec3::new(0.0, 0.0, 10.0));
        assert!(!slice_triangle(far, 4, &mut |_, _| panic!(
            "no piece expected"
        )));
    }

    #[test]
    fn an_overflow_flags_its_own_cut_only() {
        // Twelve vertices alternating across the plane x = 0.5: every edge crosses it, so
        // each side gets 6 vertices and 12 crossings, more than a polygon holds. A triangle
        // cut with the same buffers afterwards must not inherit the flag (it once did,
        // sending every later triangle of a task to the cell tests).
        let mut zigzag = Poly::default();
        for i in 0..CAP {
            let a = std::f64::consts::TAU * i as f64 / CAP as f64;
            let x = if i % 2 == 0 { 0.2 } else { 0.8 };
            zigzag.push(DVec3::new(x, 0.5 + 0.4 * a.cos(), 0.5 + 0.4 * a.sin()));
        }
        assert!(!zigzag.overflow);
        let (mut lo, mut hi) = (Poly::default(), Poly::default());
        cut::<0>(&zigzag, 0.5, 0.0, &mut lo, &mut hi);
        assert!(lo.overflow && hi.overflow);
        let mut tri = Poly::default();
        for p in [
            DVec3::new(0.1, 0.1, 0.1),
            DVec3::new(0.9, 0.1, 0.1),
            DVec3::new(0.1, 0.9, 0.1),
        ] {
            tri.push(p);
        }
        cut::<0>(&tri, 0.5, 0.0, &mut lo, &mut hi);
        assert!(!lo.overflow && !hi.overflow);
        assert_eq!((lo.n, hi.n), (4, 3));
    }

    /// The cut's rule at its boundaries, vertex by vertex: a vertex within `eps` of the plane
    /// (`|dp| <= eps`, exactly `eps` included) goes to both sides, unmoved; an edge
    /// adds its crossing when its ends lie strictly on opposite sides of the plane, within
    /// `eps` or not. Polygons with vertices exactly `eps` and `-eps` from the plane, in every
    /// order around the polygon, against the rule written out here.
    #[test]
    fn cut_decides_vertices_exactly_eps_from_the_plane() {
        let (c, eps) = (2.0, 2f64.powi(-10));
        let expected = |v: &[DVec3]| {
            let (mut lo, mut hi) = (Vec::new(), Vec::new());
            for (i, &p) in v.iter().enumerate() {
                let q = v[(i + 1) % v.len()];
                let (dp, dq) = (p.x - c, q.x - c);
                if dp.abs() <= eps {
                    lo.push(p);
                    hi.push(p);
                } else if dp < 0.0 {
                    lo.push(p);
                } else {
                    hi.push(p);
                }
                if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
                    let mut x = p + (q - p) * (dp / (dp - dq));
                    x.x = c;
                    lo.push(x);
                    hi.push(x);
                }
            }
            (lo, hi)
        };
        // Offsets from the plane: exactly -eps and +eps, beside clear ones on both sides.
        let offsets = [-eps, eps, -0.5, 0.5, -0.25, 0.75];
        let mut checked = 0;
        for a in offsets {
            for b in offsets {
                for d in offsets {
                    let v = [
                        DVec3::new(c + a, 0.1, 0.2),
                        DVec3::new(c + b, 0.9, 0.3),
                        DVec3::new(c + d, 0.4, 0.8),
                    ];
                    let mut poly = Poly::default();
                    v.iter().for_each(|&p| poly.push(p));
                    let (mut lo, mut hi) = (Poly::default(), Poly::default());
                    cut::<0>(&poly, c, eps, &mut lo, &mut hi);
                    let (want_lo, want_hi) = expected(&v);
                    assert_eq!(lo.points(), &want_lo[..], "below: offsets {a} {b} {d}");
                    assert_eq!(hi.points(), &want_hi[..], "above: offsets {a} {b} {d}");
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 216);
    }

    /// A triangle that grazes a cell near its corner `(1, 1, 1)`: slicing at `x = 1` leaves a
    /// vertex `1e-11` above `y = 1` whose edge runs nearly along that plane and reaches
    /// `z = 1` only `2.7e-9` further on. Taking the vertex for one on the plane, without the
    /// edge's crossing, lost that reach, and the cell `(0, 1, 1)` (which the exact test says
    /// the triangle touches) got no part. (A fuzzed bake, `fixtures/fuzz/bake`.)
    #[test]
    fn an_edge_nearly_along_a_plane_keeps_its_reach_past_a_vertex_within_eps() {
        let f = f64::from_bits;
        let v = [
            DVec3::new(0.021763392794279454, 0.0, f(0x401f_ffff_ff0e_c986)),
            DVec3::ZERO,
            DVec3::new(f(0x401f_ffff_fffe_eb87), 8.0, f(0x401f_ffff_ff0e_c986)),
        ];
        let mut cells = std::collections::BTreeSet::new();
        assert!(Slicer::default().slice(v, 8, 8e-10, &mut |c, _| {
            cells.insert(c);
        }));
        for c in [[0, 1, 1], [1, 2, 2], [3, 4, 4], [6, 7, 7]] {
            assert!(cells.contains(&c), "{c:?}");
        }
    }

    /// Seeded triangles whose vertices lie on, within `eps` of, or just past the block's grid
    /// planes, often with edges nearly along a plane: every cell the exact test says a
    /// triangle touches gets a part, wherever the slicer slices at all (when it does not, the
    /// caller tests the cells one by one).
    #[test]
    fn every_cell_a_triangle_touches_gets_a_part_near_the_planes() {
        use crate::geometry::overlap::triangle_box_overlap;
        use crate::geometry::triangle_setup::GridTriangle;
        let mut rnd = svo_tests::seeds::xorshift(0x511c_e5ed);
        let mut unit = move || (rnd() >> 11) as f64 / (1u64 << 53) as f64;
        let n = 4u32;
        let eps = 1e-10 * f64::from(n);
        let (mut cases, mut cells) = (0, 0);
        for case in 0..4000 {
            // A coordinate: a grid value, moved by nothing, by up to a few eps, or anywhere.
            let coord = |unit: &mut dyn FnMut() -> f64| {
                let g = (unit() * f64::from(n + 1)).floor();
                match (unit() * 5.0) as u32 {
                    0 => g,
                    1 => g + (unit() - 0.5) * 4.0 * eps,
                    2 => g + (unit() - 0.5) * 1e-12,
                    3 => g + (unit() - 0.5) * 1e-7,
                    _ => unit() * f64::from(n),
                }
            };
            let mut v = [DVec3::ZERO; 3];
            for p in &mut v {
                *p = DVec3::new(coord(&mut unit), coord(&mut unit), coord(&mut unit));
            }
            if case % 3 == 0 {
                // An edge nearly along a plane: the second vertex shares the first's
                // coordinate on one axis up to a few eps.
                let axis = case / 3 % 3;
                v[1][axis] = v[0][axis] + (unit() - 0.5) * 4.0 * eps;
            }
            let t = GridTriangle::new(v[0], v[1], v[2]);
            if t.n == DVec3::ZERO {
                continue;
            }
            let mut got = std::collections::BTreeSet::new();
            if !Slicer::default().slice(v, n, eps, &mut |c, _| {
                got.insert(c);
            }) {
                continue;
            }
            cases += 1;
            for x in 0..n {
                for y in 0..n {
                    for z in 0..n {
                        let m = DVec3::new(f64::from(x), f64::from(y), f64::from(z));
                        if triangle_box_overlap(&t, m, 1.0) {
                            cells += 1;
                            assert!(
                                got.contains(&[x, y, z]),
                                "case {case} {v:?}: {:?}",
                                [x, y, z]
                            );
                        }
                    }
                }
            }
        }
        assert!(cases > 2000 && cells > 10_000, "{cases} {cells}");
    }

    /// Closed slabs: a triangle whose lowest vertex lies exactly on a cutting plane (after
    /// the `eps` widening: `min - eps` an integer) touches the slab below it, and the cell there
    /// gets a part, with `eps` zero and positive, along every axis.
    #[test]
    fn a_vertex_on_a_plane_reaches_the_slab_below() {
        for eps in [0.0, 2f64.powi(-10)] {
            for axis in 0..3 {
                let along = |x: f64, a: f64, b: f64| {
                    let mut p = DVec3::new(a, b, a);
                    p[axis] = x;
                    p
                };
                let v = [
                    along(2.0 + eps, 0.5, 0.5),
                    along(3.5, 0.6, 0.7),
                    along(3.2, 1.5, 0.4),
                ];
                let mut cells = std::collections::BTreeSet::new();
                Slicer::default().slice(v, 4, eps, &mut |c, _| {
                    cells.insert(c);
                });
                let mut below = [0, 0, 0];
                below[axis] = 1;
                assert!(cells.contains(&below), "eps {eps}, axis {axis}: {cells:?}");
            }
        }
    }

    #[test]
    fn floor_small_is_floor() {
        let mut xs = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            2.5,
            -2.5,
            15.999_999_999_999_998,
        ];
        for k in -20..=20 {
            let k = f64::from(k);
            xs.extend([k, k.next_up(), k.next_down(), k + 1e-10, k - 1e-10, k + 0.5]);
        }
        xs.extend([2f64.powi(50) + 0.5, -(2f64.powi(50)) - 0.5, 1e-300, -1e-300]);
        for x in xs {
            assert_eq!(floor_small(x), x.floor(), "{x:e}");
        }
    }

    #[test]
    fn well_inside_means_off_every_face() {
        assert!(well_inside(DVec3::splat(0.5), 1e-9));
        assert!(!well_inside(DVec3::new(0.5, 0.0, 0.5), 1e-9));
        assert!(!well_inside(DVec3::new(0.5, 0.5, 1.0 - 1e-12), 1e-9));
    }

    #[test]
    fn touches_and_near_misses_give_boundary_parts() {
        // A vertical triangle whose edge runs along the cell edge x = 5, y = 4 (exactly, and
        // then a hair off it): the diagonal neighbours it touches along that edge get parts.
        for dy in [0.0, 1e-15, -1e-15] {
            let v = [
                DVec3::new(2.5, 8.0, 2.0),
                DVec3::new(7.5, 0.0, 2.0),
                DVec3::new(7.5, 0.0, 8.0),
            ]
            .map(|p| p + DVec3::new(0.0, dy, 0.0));
            let mut cells = std::collections::BTreeSet::new();
            assert!(Slicer::default().slice(v, 8, 1e-9, &mut |c, _| {
                cells.insert(c);
            }));
            for z in 2..=4 {
                assert!(cells.contains(&[4, 3, z]), "dy {dy}: [4, 3, {z}] missing");
                assert!(cells.contains(&[5, 4, z]), "dy {dy}: [5, 4, {z}] missing");
            }
        }
    }
}
