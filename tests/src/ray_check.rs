//! The check of one traversal result against the exact reference ([`crate::ray_reference`])
//! with the margin that the tracer's `f32` arithmetic allows, shared by the octree and the
//! dense-grid tests.
//!
//! The traversal works in `f32`, so it is exact only up to a margin that follows from its
//! arithmetic. A plane parameter is `(p - o) * (1 / d)`, three roundings, so it is the exact
//! parameter of a plane moved by at most `3u |p - o|` (`u = 2^-24`), and raising a tiny
//! direction component to `TINY` moves a point by less than `2^-30` of its distance. Planes
//! are shared by neighbouring cells, so the traversal is exact for a grid whose faces are each
//! moved by at most `3.25 u L` cells, where `L` is the largest distance, along one axis, from
//! the origin to a plane of the root. The contour test in `leaf_hit` adds the rounding of the
//! decoded normal (whose error multiplies only the short vector from the cell centre to the
//! entry point), of the two dot products over `o - c` and `t d` (each up to `sqrt(3) L`) and
//! of the plane offsets: at most `24 u L + 80 u` cells along the normal. With `delta` that
//! margin, each ray must satisfy, exactly:
//! - if it enters some cell's region shrunk by `delta` (a parameter interval of positive
//!   length) it hits, no later than the first such entry `T_in`;
//! - the hit cell is in the list, and the point at the hit `t` (the `f32` value, exact) lies
//!   in that cell's region grown by `delta`, at or after `tmin`.
//!
//! Rays whose arithmetic is exact (integer origin, direction components `0`, `+-1`, `+-2`,
//! `tmin = 0`) get no cube margin at all: they must hit at exactly `T_in`, or where they
//! start, or where they only touch the root, at a point of the hit cell's closed cube.

use crate::ray_reference::{ExactRay, Q, RefCell, contains, first_entry, octahedral};
use glam::UVec3;
use std::collections::HashMap;
use svo::trace::{GridRay, HitMode};

/// `f32`'s unit roundoff.
pub const U: f64 = 1.0 / 16_777_216.0;

/// The margin for `ray` from `tmin` whose `L` is `l` (module doc); 0 for none.
pub fn margin(ray: &GridRay, tmin: f32, l: f64, mode: HitMode) -> f64 {
    let exact = tmin == 0.0
        && ray.origin.to_array().iter().all(|v| v.fract() == 0.0)
        && ray
            .dir
            .to_array()
            .iter()
            .all(|v| [0.0, 1.0, 2.0].contains(&v.abs()));
    match mode {
        HitMode::Cube if exact => 0.0,
        HitMode::Cube => 3.25 * U * l,
        _ => U * (24.0 * l + 80.0),
    }
}

/// What the rays measured: per mode, the worst distance of a hit point outside its cell's
/// exact region, in units of `u L`, and how many exact rays were held to no margin.
#[derive(Default)]
pub struct Worst {
    /// Per mode (cube, contour), the worst distance outside, in units of `u L`.
    pub ratio: [f64; 2],
    /// Rays held to no margin.
    pub exact: usize,
}

/// How far `p` lies outside `cell`'s region (0 inside), in cells: the cube's faces and the
/// slab's planes along the unit normal, from the exact differences.
pub fn outside(p: &[Q; 3], cell: &RefCell, contour: bool) -> f64 {
    let mut worst = 0.0f64;
    for (pk, lo) in p.iter().zip(cell.lo.to_array()) {
        let (lo, hi) = (Q::int(i64::from(lo)), Q::int(i64::from(lo) + 1));
        worst = worst.max(lo.sub(pk).approx()).max(pk.sub(&hi).approx());
    }
    if contour {
        let m = octahedral(cell.words.0);
        let l2 = m.iter().map(|v| (*v as f64).powi(2)).sum::<f64>().sqrt();
        // The slab at zero margin, measured by how much margin `contains` needs: bisect.
        let (mut a, mut b) = (0.0f64, 1.0f64);
        if !contains(p, cell, true, &Q::of(0.0)) {
            for _ in 0..40 {
                let mid = 0.5 * (a + b);
                if contains(p, cell, true, &Q::of(mid)) {
                    b = mid;
                } else {
                    a = mid;
                }
            }
            // The slab moves by `g |m|_1` in `m`'s units, `g |m|_1 / |m|_2` along the normal.
            let l1: f64 = m.iter().map(|v| v.abs() as f64).sum();
            worst = worst.max(b * l1 / l2);
        }
    }
    worst
}

/// Checks the hit `(t, cell)` (or the miss) that a traversal gave `ray` from `tmin` in a root
/// of `n` cells against the reference; returns whether it hit.
#[allow(clippy::too_many_arguments)]
pub fn check_hit(
    cells: &[RefCell],
    index: &HashMap<UVec3, usize>,
    ray: &GridRay,
    tmin: f32,
    n: f32,
    mode: HitMode,
    hit: Option<(f32, UVec3)>,
    worst: &mut Worst,
) -> bool {
    let contour = mode == HitMode::Contour;
    let l = delta_scale(ray, n);
    let delta = margin(ray, tmin, l, mode);
    let grow = Q::of(delta);
    let er = ExactRay::new(ray.origin.to_array(), ray.dir.to_array(), tmin);
    let first = first_entry(&er, cells, contour, &grow);
    let Some((t32, cell)) = hit else {
        let entered = first.map(|(t, i)| (t.approx(), cells[i].lo));
        assert!(
            entered.is_none(),
            "{mode:?}: missed a cell entered at (t, cell) {entered:?}: {ray:?} tmin {tmin}, margin {delta}"
        );
        return false;
    };
    let t = Q::of(f64::from(t32));
    let i = *index
        .get(&cell)
        .unwrap_or_else(|| panic!("{mode:?}: hit cell {cell} is not in the list: {ray:?}"));
    assert!(t >= er.tmin, "{mode:?}: hit at {t32} before tmin {tmin}");
    if let Some((t_in, j)) = &first {
        assert!(
            t <= *t_in,
            "{mode:?}: hit {cell} at {t32}, but cell {} is entered at {}: {ray:?} tmin {tmin}, margin {delta}",
            cells[*j].lo,
            t_in.approx()
        );
    }
    let p = er.at(&t);
    assert!(
        contains(&p, &cells[i], contour, &grow),
        "{mode:?}: the point at t = {t32} is {} cells outside cell {cell}'s region (margin {delta}): {ray:?} tmin {tmin}",
        outside(&p, &cells[i], contour),
    );
    if delta == 0.0 {
        // Exact arithmetic: at the first entry, or a touch where the ray starts or where it
        // only touches the root.
        let at_entry = first.as_ref().is_some_and(|(a, _)| t == *a);
        assert!(
            at_entry || t == er.tmin || first.is_none(),
            "{mode:?}: exact ray hit {cell} at {t32}, first entry {:?}: {ray:?}",
            first.map(|(a, _)| a.approx())
        );
        worst.exact += 1;
    } else {
        let k = usize::from(contour);
        worst.ratio[k] = worst.ratio[k].max(outside(&p, &cells[i], contour) / (U * l));
    }
    true
}

/// `L` of the module doc.
pub fn delta_scale(ray: &GridRay, n: f32) -> f64 {
    (0..3)
        .map(|k| {
            let o = f64::from(ray.origin[k]);
            o.abs().max((f64::from(n) - o).abs())
        })
        .fold(0.0, f64::max)
}
