//! Traversal precision in deep trees: the traversal works in `f32` grid coordinates, whose
//! spacing near the far side of a depth-`d` root is `2^(d - 24)` cells. For depths 12 to 30,
//! clusters of leaves near the root's middle and its far corner are hit by rays starting a
//! few to a few hundred cells away; each hit (leaf and entry parameter) is compared with an
//! `f64` slab test of the same `f32` ray against every leaf. Prints, per depth, the rays that
//! hit another leaf than the first one the ray enters and the worst entry error
//! (`cargo test --test deep_precision -- --nocapture`) and asserts what `docs/stability.md`
//! states: up to depth 24 every ray keeps the traversal's contract. A plane parameter is
//! `(p - o) * (1 / d)` in `f32`, the exact parameter of a plane moved by up to `3u |p - o|`
//! (`u = 2^-24`; `tests/src/ray_check.rs`), so a leaf counts as entered when the ray enters
//! its cube shrunk by `3.25u` times its planes' largest distance from the origin: such a
//! leaf must be hit, and no leaf later than its entry; a hit leaf must be met by its cube
//! grown by the same margin, at its own entry parameter within `1e-3` cells plus the `f32`
//! rounding of its magnitude and of the origin. A leaf that the ray only clips within the
//! margin may be passed over (its stretch inside is below the `f32` spacing of the
//! parameters). From depth 25 the cells' own planes are no longer `f32` integers, and rays go
//! wrong (printed, not asserted; such trees are refused by the renderers).
//!
//! Deep origins round to coarse `f32` steps (a sixteenth of a cell at depth 20, a whole cell
//! at 24), so a ray often *starts on* a leaf's face and moves away from it; that touches the
//! leaf without entering it, and the traversal rightly goes on to the leaf the ray enters.

#![cfg(feature = "trace")]

use crate::common;

use common::ray_check::U;
use glam::{DVec3, UVec3};
use rand::Rng;
use svo::RootCube;
use svo::octree::{Octree, Voxel};
use svo::trace::{GridRay, HitMode, MAX_STEPS, cast};

/// Where the `f64` ray `o + t d` is inside cell `c`'s cube moved inwards by `inset` cells on
/// every face (outwards when negative): the parameters `(t0, t1)`, from 0 on.
fn span(c: UVec3, inset: f64, o: DVec3, d: DVec3) -> (f64, f64) {
    let lo = c.as_dvec3() + DVec3::splat(inset);
    let hi = c.as_dvec3() + DVec3::splat(1.0 - inset);
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < lo[a] || o[a] > hi[a] {
                t0 = f64::INFINITY;
            }
            continue;
        }
        let (p, q) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
        t0 = t0.max(p.min(q));
        t1 = t1.min(p.max(q));
    }
    (t0, t1)
}

/// The rounding margin of cell `c`'s plane parameters for a ray from `o`, in cells: `3.25u`
/// times the largest distance from `o` to one of its planes along an axis.
fn margin(c: UVec3, o: DVec3) -> f64 {
    let lo = c.as_dvec3();
    let far = (lo - o)
        .abs()
        .max((lo + DVec3::ONE - o).abs())
        .max_element();
    3.25 * U * far
}

/// The first leaf the `f64` ray `o + t d` enters and where, with `shrink` (each cell's cube
/// shrunk by its margin) or without: the first entry of a stretch of positive length (a ray
/// that starts on a cell's face and moves away, or grazes an edge, touches the cell without
/// entering it).
fn first_entered(cells: &[UVec3], o: DVec3, d: DVec3, shrink: bool) -> Option<(UVec3, f64)> {
    let mut best: Option<(UVec3, f64)> = None;
    for &c in cells {
        let inset = if shrink { margin(c, o) } else { 0.0 };
        let (t0, t1) = span(c, inset, o, d);
        if t0 < t1 && best.is_none_or(|b| t0 < b.1) {
            best = Some((c, t0));
        }
    }
    best
}

#[test]
fn deep_trees_hit_the_right_leaf_at_the_right_distance() {
    let mut rng = common::rng(0xDEE9_0002);
    println!(
        "depth | rays | hits | not the first leaf entered | contract broken | worst |t - t_entry| (cells) | f32 spacing at the far side"
    );
    for depth in [12u8, 16, 20, 22, 24, 26, 28, 30] {
        let side = 1u64 << depth;
        // Two clusters: around the middle, and in the far corner, where f32 is coarsest.
        let mut cells = Vec::new();
        for centre in [side / 2, side - 6] {
            for _ in 0..30 {
                let c = |r: &mut rand_chacha::ChaCha8Rng| {
                    (centre as i64 + r.random_range(-4..4)).clamp(0, side as i64 - 1) as u32
                };
                cells.push(UVec3::new(c(&mut rng), c(&mut rng), c(&mut rng)));
            }
        }
        cells.sort_by_key(UVec3::to_array);
        cells.dedup();
        let root = RootCube {
            origin: DVec3::ZERO,
            side: side as f64,
        };
        let tree =
            Octree::from_cells(root, depth, cells.iter().map(|&c| (c, Voxel::default()))).unwrap();
        let (mut hits, mut broken, mut other, mut worst) = (0usize, 0usize, 0usize, 0.0f64);
        let mut worst_allowed_excess = f64::NEG_INFINITY;
        // The spacing of f32 coordinates at the root's far side.
        let spacing = side as f64 / f64::from(1u32 << 24);
        let rays = 3000;
        for _ in 0..rays {
            let target = cells[rng.random_range(0..cells.len())].as_dvec3()
                + DVec3::new(rng.random(), rng.random(), rng.random());
            let dist = 10f64.powf(rng.random_range(0.5..2.5));
            let dir = DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            // The ray as the tracer has it: f32 origin and direction.
            let ray = GridRay {
                origin: (target - dir * dist).as_vec3(),
                dir: dir.as_vec3(),
            };
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
            let first = first_entered(&cells, o, d, false);
            let must = first_entered(&cells, o, d, true);
            let got = cast(
                &tree,
                &ray,
                0.0,
                f32::INFINITY,
                HitMode::Cube,
                None,
                MAX_STEPS,
            )
            .hit;
            let scale = d.length();
            // f32 rounding of a parameter of this size, plus the planes' spacing.
            let allowed = |t: f64| 1e-3 + (t * scale) * 2.0 * f64::from(f32::EPSILON) + spacing;
            match got {
                Some(h) => {
                    hits += 1;
                    let t = f64::from(h.t);
                    // Met by the hit leaf's cube grown by its margin, no later than the entry
                    // of a leaf that must be hit.
                    let (g0, g1) = span(h.cell, -margin(h.cell, o), o, d);
                    let late = must.is_some_and(|(_, t_in)| t > t_in + allowed(t_in) / scale);
                    if g0 > g1 || late {
                        broken += 1;
                    }
                    if first.is_none_or(|(c, _)| c != h.cell) {
                        other += 1;
                    }
                    // Its entry parameter: the hit leaf's own.
                    let (t0, _) = span(h.cell, 0.0, o, d);
                    let err = (t - t0).abs() * scale;
                    worst = worst.max(err);
                    worst_allowed_excess = worst_allowed_excess.max(err - allowed(t0));
                }
                None => {
                    if must.is_some() {
                        broken += 1;
                    }
                    if first.is_some() {
                        other += 1;
                    }
                }
            }
        }
        let shown = spacing.max(f64::from(f32::EPSILON));
        println!("{depth} | {rays} | {hits} | {other} | {broken} | {worst:.3e} | {shown:.3e}");
        if depth <= 24 {
            assert!(hits > rays / 2, "depth {depth}: only {hits} hits");
            assert_eq!(
                broken, 0,
                "depth {depth}: rays missed a leaf they enter beyond the rounding margin"
            );
            // Passing over a leaf clipped within the margin is rare.
            assert!(
                other <= 2,
                "depth {depth}: {other} rays passed over a clipped leaf"
            );
            assert!(
                worst_allowed_excess <= 0.0,
                "depth {depth}: entry error {worst:.3e} cells beyond the rounding bound"
            );
        }
    }
}
