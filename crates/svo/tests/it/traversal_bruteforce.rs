//! The octree traversal against an exact reference: every ray against every cell of the
//! list the tree was built from, its cube or contour slab decoded by the test itself, with
//! the entry parameter computed in rationals (`tests/src/ray_reference.rs`), on seeded random
//! trees and rays: axis-parallel rays with `+0.0` and `-0.0` components, rays through lattice
//! corners and edges, rays along cell faces, rays starting inside the root and inside leaves,
//! directions scaled by `2^-69` to `2^60`, and a sparse deep tree.
//!
//! The margin that the tracer's `f32` arithmetic allows, and what each ray must satisfy, are
//! stated in `tests/src/ray_check.rs`: no cell entered by more than the margin is missed, the
//! hit is no later than the first such entry, and its point lies in its cell's region within
//! the margin; rays whose arithmetic is exact get no cube margin at all.
#![cfg(feature = "trace")]

use crate::common;

use common::ray_check::{Worst, check_hit};
use common::ray_reference::{
    ExactRay, Interval, Q, RefCell, contains, index_of, interval, tree_of, with_words,
};
use glam::{UVec3, Vec3};
use num_bigint::Sign;
use rand::Rng;
use std::collections::HashMap;
use svo::dag::DagTree;
use svo::octree::Octree;
use svo::trace::{GridRay, HitMode, LeafEntry, MAX_STEPS, cast, traverse};

/// Checks one ray's cast against the reference; returns whether it hit.
fn check_ray(
    tree: &Octree,
    cells: &[RefCell],
    index: &HashMap<UVec3, usize>,
    ray: &GridRay,
    tmin: f32,
    mode: HitMode,
    worst: &mut Worst,
) -> bool {
    let res = cast(tree, ray, tmin, f32::INFINITY, mode, None, MAX_STEPS);
    assert!(!res.capped, "capped: {ray:?}");
    if let Some(h) = res.hit {
        assert_eq!(tree.leaf_at(h.cell), Some(h.leaf), "cell and leaf disagree");
    }
    let n = (1u32 << tree.depth) as f32;
    check_hit(
        cells,
        index,
        ray,
        tmin,
        n,
        mode,
        res.hit.map(|h| (h.t, h.cell)),
        worst,
    )
}

/// A tree of `cells` without normals or contours.
fn plain_tree(depth: u8, cells: &[UVec3]) -> Octree {
    let root = svo::RootCube {
        origin: glam::DVec3::ZERO,
        side: f64::from(1u32 << depth),
    };
    Octree::from_cells(
        root,
        depth,
        cells.iter().map(|&c| (c, svo::octree::Voxel::default())),
    )
    .unwrap()
}

/// Random cells at `depth` with random words, their tree and their indices; `None` when the
/// draw is empty.
fn random_scene(
    rng: &mut impl Rng,
    depth: u8,
    density: f64,
) -> Option<(Vec<RefCell>, Octree, HashMap<UVec3, usize>)> {
    let cells = random_cells(rng, depth, density);
    if cells.is_empty() {
        return None;
    }
    let cells = with_words(rng, &cells);
    let (tree, index) = (tree_of(depth, &cells), index_of(&cells));
    Some((cells, tree, index))
}

fn random_cells(rng: &mut impl Rng, depth: u8, density: f64) -> Vec<UVec3> {
    let side = 1u32 << depth;
    let mut cells = Vec::new();
    for x in 0..side {
        for y in 0..side {
            for z in 0..side {
                if rng.random_bool(density) {
                    cells.push(UVec3::new(x, y, z));
                }
            }
        }
    }
    cells
}

fn signed_zero(rng: &mut impl Rng) -> f32 {
    if rng.random_bool(0.5) { 0.0 } else { -0.0 }
}

/// A point inside the root of `n` cells a side.
fn inside(rng: &mut impl Rng, n: f32) -> Vec3 {
    Vec3::new(
        rng.random_range(0.0..n),
        rng.random_range(0.0..n),
        rng.random_range(0.0..n),
    )
}

/// A unit direction, uniform over the sphere.
fn unit(rng: &mut impl Rng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.length() > 0.1 && v.length() < 1.0 {
            break v.normalize();
        }
    }
}

/// A lattice point of the root of `n` cells or up to two cells outside it.
fn lattice(rng: &mut impl Rng, n: f32) -> Vec3 {
    let k = n as i32;
    Vec3::new(
        rng.random_range(-2..=k + 2) as f32,
        rng.random_range(-2..=k + 2) as f32,
        rng.random_range(-2..=k + 2) as f32,
    )
}

fn ray(origin: Vec3, dir: Vec3) -> (GridRay, f32) {
    (GridRay { origin, dir }, 0.0)
}

/// A ray of one of the families the module doc lists, with its `tmin`.
fn random_ray(rng: &mut impl Rng, n: f32) -> (GridRay, f32) {
    match rng.random_range(0..8) {
        // From outside towards a point inside.
        0 => {
            let target = inside(rng, n);
            let o = Vec3::splat(n * 0.5) + unit(rng) * n * 1.5;
            ray(o, target - o)
        }
        1 => from_inside(rng, n),
        2 => axis_parallel(rng, n),
        // Along a face: two non-zero components, the origin on a lattice plane.
        3 => {
            let axis = rng.random_range(0..3);
            let mut d = unit(rng);
            d[axis] = signed_zero(rng);
            let mut o = inside(rng, n);
            o[axis] = rng.random_range(0..=n as u32) as f32;
            ray(o, d)
        }
        4 => through_lattice(rng, n),
        // Exact diagonals through the root's corners.
        5 => {
            let mut s = || if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let d = Vec3::new(s(), s(), s());
            ray(Vec3::splat(n * 0.5) - d * n, d)
        }
        // A ray from outside towards a point inside with its direction scaled by a power
        // of two (exactly): the tracer's precision must not depend on the direction's length.
        7 => {
            let target = inside(rng, n);
            let o = Vec3::splat(n * 0.5) + unit(rng) * n * 1.5;
            let k = [-69, -40, -20, 20, 60][rng.random_range(0..5)];
            ray(o, (target - o) * 2f32.powi(k))
        }
        // Tiny (denormal-ish) components.
        _ => {
            let mut d = unit(rng);
            d[rng.random_range(0..3)] = if rng.random_bool(0.5) { 1e-30 } else { -1e-30 };
            ray(inside(rng, n), d)
        }
    }
}

/// From inside, any direction, sometimes starting later along the ray.
fn from_inside(rng: &mut impl Rng, n: f32) -> (GridRay, f32) {
    let tmin = if rng.random_bool(0.3) {
        rng.random_range(0.0..n)
    } else {
        0.0
    };
    let origin = inside(rng, n);
    (
        GridRay {
            origin,
            dir: unit(rng),
        },
        tmin,
    )
}

/// Axis-parallel: one non-zero component, the others signed zeros, the origin often exactly
/// on a cell face or edge.
fn axis_parallel(rng: &mut impl Rng, n: f32) -> (GridRay, f32) {
    let axis = rng.random_range(0..3);
    let mut d = Vec3::new(signed_zero(rng), signed_zero(rng), signed_zero(rng));
    d[axis] = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let mut o = inside(rng, n);
    o[axis] = if d[axis] > 0.0 { -1.0 } else { n + 1.0 };
    for k in 0..3 {
        if k != axis && rng.random_bool(0.5) {
            o[k] = o[k].floor();
        }
    }
    ray(o, d)
}

/// Through lattice corners and edges: integer origin, small integer direction.
fn through_lattice(rng: &mut impl Rng, n: f32) -> (GridRay, f32) {
    let mut d = Vec3::new(
        rng.random_range(-2..=2) as f32,
        rng.random_range(-2..=2) as f32,
        rng.random_range(-2..=2) as f32,
    );
    if d == Vec3::ZERO {
        d.x = 1.0;
    }
    for k in 0..3 {
        if d[k] == 0.0 {
            d[k] = signed_zero(rng);
        }
    }
    ray(lattice(rng, n), d)
}

#[test]
fn traversal_equals_the_exact_reference_on_random_trees() {
    let mut rng = common::rng(0x7ACE);
    let mut rays = 0;
    let mut hits = [0usize; 2];
    let mut worst = Worst::default();
    for depth in 1..=5u8 {
        for &density in &[0.02, 0.15, 0.5, 0.95] {
            let Some((cells, tree, index)) = random_scene(&mut rng, depth, density) else {
                continue;
            };
            let n = (1u32 << depth) as f32;
            for (mi, mode) in [HitMode::Cube, HitMode::Contour].into_iter().enumerate() {
                let count = if depth == 5 { 300 } else { 600 };
                for _ in 0..count {
                    let (ray, tmin) = random_ray(&mut rng, n);
                    hits[mi] += usize::from(check_ray(
                        &tree, &cells, &index, &ray, tmin, mode, &mut worst,
                    ));
                    rays += 1;
                }
            }
        }
    }
    eprintln!(
        "{rays} rays, hits {hits:?}; worst hit point outside its cell: cube {:.2} u L, contour {:.2} u L; {} exact rays held to no margin",
        worst.ratio[0], worst.ratio[1], worst.exact
    );
    // The families must exercise both outcomes and the exact rays.
    assert!(
        hits[0] > rays / 8 && hits[1] > rays / 10 && worst.exact > 500,
        "hits {hits:?} of {rays}, {} exact",
        worst.exact
    );
}

#[test]
fn deep_sparse_tree() {
    let mut rng = common::rng(0xDEE9);
    let depth = 16u8;
    let side = 1u32 << depth;
    // Clusters of cells around random centres, plus scattered ones.
    let mut cells = Vec::new();
    for _ in 0..12 {
        let c = UVec3::new(
            rng.random_range(4..side - 4),
            rng.random_range(4..side - 4),
            rng.random_range(4..side - 4),
        );
        for _ in 0..40 {
            cells.push(
                c + UVec3::new(
                    rng.random_range(0..4),
                    rng.random_range(0..4),
                    rng.random_range(0..4),
                ) - UVec3::splat(2),
            );
        }
    }
    cells.sort_by_key(UVec3::to_array);
    cells.dedup();
    let cells = with_words(&mut rng, &cells);
    let tree = tree_of(depth, &cells);
    let index = index_of(&cells);
    let centres: Vec<Vec3> = cells.iter().map(|c| c.lo.as_vec3() + 0.5).collect();
    let mut worst = Worst::default();
    for mode in [HitMode::Cube, HitMode::Contour] {
        let mut hit = 0;
        for i in 0..2000 {
            // Aim at a cluster so rays hit; from far outside or from inside the root.
            let target = centres[rng.random_range(0..centres.len())]
                + Vec3::new(
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                );
            let o = if i % 2 == 0 {
                Vec3::new(
                    rng.random_range(0.0..side as f32),
                    rng.random_range(0.0..side as f32),
                    rng.random_range(0.0..side as f32),
                )
            } else {
                target
                    + Vec3::new(
                        rng.random_range(-50.0..50.0),
                        rng.random_range(-50.0..50.0),
                        rng.random_range(-50.0..50.0),
                    )
            };
            let mut d = target - o;
            if i % 7 == 0 {
                // Axis-parallel towards the target.
                let k = d.abs().max_position();
                let keep = d[k];
                d = Vec3::new(
                    signed_zero(&mut rng),
                    signed_zero(&mut rng),
                    signed_zero(&mut rng),
                );
                d[k] = keep;
            }
            hit += usize::from(check_ray(
                &tree,
                &cells,
                &index,
                &GridRay { origin: o, dir: d },
                0.0,
                mode,
                &mut worst,
            ));
        }
        assert!(hit > 200, "{mode:?}: only {hit} hits");
    }
    eprintln!(
        "depth 16: worst hit point outside its cell: cube {:.2} u L, contour {:.2} u L",
        worst.ratio[0], worst.ratio[1]
    );
}

/// The exact per-axis entry and exit parameters of the cube at `lo` for an exact ray, and the
/// axes they come from: `(t0, t1)` per axis, `None` for minus or plus infinity (a zero
/// component: the ray runs along the axis's planes; on its entry plane it enters at 0, on
/// its exit plane it leaves at 0).
fn axis_params(er: &ExactRay, lo: UVec3) -> [(Option<Q>, Option<Q>); 3] {
    std::array::from_fn(|k| {
        let (a, b) = (Q::int(i64::from(lo[k])), Q::int(i64::from(lo[k]) + 1));
        let (p_in, p_out) = if er.neg[k] { (b, a) } else { (a, b) };
        if er.d[k].sign() == Sign::NoSign {
            (
                (er.o[k] == p_in).then(|| Q::int(0)),
                (er.o[k] == p_out).then(|| Q::int(0)),
            )
        } else {
            (
                Some(p_in.sub(&er.o[k]).div(&er.d[k])),
                Some(p_out.sub(&er.o[k]).div(&er.d[k])),
            )
        }
    })
}

/// The axis whose parameter is `better` than every earlier one's (so ties go to the first
/// axis), with its parameter; `None` where no axis has one.
fn extreme(params: [Option<&Q>; 3], better: fn(&Q, &Q) -> bool) -> Option<(Q, usize)> {
    let mut best: Option<(Q, usize)> = None;
    for (k, p) in params.into_iter().enumerate() {
        if let Some(p) = p
            && best.as_ref().is_none_or(|(b, _)| better(p, b))
        {
            best = Some((p.clone(), k));
        }
    }
    best
}

/// A ray of integer origin (up to two cells outside a root of `n` cells) and small integer
/// direction (zeros signed at random), with a `tmin` and `tmax` sometimes inside the root.
fn exact_ray(rng: &mut impl Rng, n: i32) -> ([f32; 3], [f32; 3], f32, f32) {
    let mut o = [0.0f32; 3];
    let mut d = [0.0f32; 3];
    for k in 0..3 {
        o[k] = rng.random_range(-2..=n + 2) as f32;
        d[k] = rng.random_range(-2..=2) as f32;
        if d[k] == 0.0 {
            d[k] = signed_zero(rng);
        }
    }
    if d.iter().all(|v| *v == 0.0) {
        d[rng.random_range(0..3)] = 1.0;
    }
    let tmin = if rng.random_bool(0.3) {
        rng.random_range(0..n) as f32
    } else {
        0.0
    };
    let tmax = if rng.random_bool(0.3) {
        tmin + rng.random_range(0..=n) as f32
    } else {
        f32::INFINITY
    };
    (o, d, tmin, tmax)
}

/// Checks a handed-over entry's parameters and faces against the exact ray's: it enters at
/// the latest axis entry (or `tmin` when it starts inside), by that axis's face, and leaves
/// at the earliest axis exit (or `tmax`), by that axis's face; ties go to the first axis.
fn check_entry_and_exit(er: &ExactRay, e: &LeafEntry, qmax: Option<&Q>, what: &str) {
    let (t_in, t_out) = (Q::of(f64::from(e.t_enter)), Q::of(f64::from(e.t_exit)));
    let p = axis_params(er, e.cell);
    // Entry: the latest t0, ties to the first axis.
    let t0 = extreme(p.each_ref().map(|(a, _)| a.as_ref()), |a, b| a > b);
    let starts_inside = t0.as_ref().is_none_or(|(a, _)| *a < er.tmin);
    let enter = if starts_inside {
        er.tmin.clone()
    } else {
        t0.clone().unwrap().0
    };
    assert!(
        t_in == enter,
        "{what}: enters at {}, not {}",
        e.t_enter,
        enter.approx()
    );
    let mut want_in = Vec3::ZERO;
    if !starts_inside {
        let k = t0.unwrap().1;
        want_in[k] = if er.neg[k] { 1.0 } else { -1.0 };
    }
    assert_eq!(e.entry_normal, want_in, "{what}: entry face");
    // Exit: the earliest t1, ties to the first axis.
    let (exit, k) = extreme(p.each_ref().map(|(_, b)| b.as_ref()), |a, b| a < b)
        .expect("a non-zero component bounds the cell");
    let exit = qmax.map_or(exit.clone(), |m| exit.min(m.clone()));
    assert!(
        t_out == exit,
        "{what}: leaves at {}, not {}",
        e.t_exit,
        exit.approx()
    );
    let mut want_out = Vec3::ZERO;
    want_out[k] = if er.neg[k] { -1.0 } else { 1.0 };
    assert_eq!(e.exit_normal, want_out, "{what}: exit face");
}

/// Every leaf entry an exact ray's walk hands over (integer origin, components `0`, `+-1`,
/// `+-2`, integer `tmin`, so the `f32` arithmetic is exact), against the exact values: the
/// entry parameter `max(max t0, tmin)` and the exit `min t1`, bit for bit; the entry face
/// (the axis of the latest `t0`, ties to x then y, facing the ray; zero when the ray starts
/// inside, `max t0 < tmin`) and the exit face (the earliest `t1`, ties likewise, pointing
/// along the ray); entries front to back, each in the list and touched over its interval; and
/// every cell the ray enters (a parameter interval of positive length) handed over.
#[test]
fn every_entry_of_an_exact_ray_has_exact_parameters_and_faces() {
    let mut rng = common::rng(0xE7AC);
    let mut entries = 0usize;
    for depth in 1..=4u8 {
        for &density in &[0.1, 0.5, 0.9] {
            let Some((cells, tree, index)) = random_scene(&mut rng, depth, density) else {
                continue;
            };
            let n = 1i32 << depth;
            for _ in 0..800 {
                let (o, d, tmin, tmax) = exact_ray(&mut rng, n);
                let ray = GridRay {
                    origin: Vec3::from(o),
                    dir: Vec3::from(d),
                };
                let er = ExactRay::new(o, d, tmin);
                let qmax = tmax.is_finite().then(|| Q::of(f64::from(tmax)));
                let mut got: Vec<LeafEntry> = Vec::new();
                let walk = traverse(&tree, &ray, tmin, tmax, MAX_STEPS, |e| {
                    got.push(*e);
                    None::<()>
                });
                assert!(!walk.capped);
                for w in got.windows(2) {
                    assert!(w[0].t_enter <= w[1].t_enter, "not front to back: {ray:?}");
                }
                for e in &got {
                    let what = format!("{ray:?} tmin {tmin} tmax {tmax}: cell {}", e.cell);
                    assert!(e.t_enter <= tmax && e.t_exit <= tmax, "{what}: beyond tmax");
                    let i = *index
                        .get(&e.cell)
                        .unwrap_or_else(|| panic!("{what}: not in the list"));
                    assert_eq!(tree.leaf_at(e.cell), Some(e.leaf), "{what}");
                    // Touched where it is handed over; entered over the whole interval when
                    // that has positive length (a walk hands over cells it only touches
                    // where it starts).
                    let (t_in, t_out) = (Q::of(f64::from(e.t_enter)), Q::of(f64::from(e.t_exit)));
                    assert!(
                        contains(&er.at(&t_in), &cells[i], false, &Q::int(0)),
                        "{what}: not touched at {}",
                        e.t_enter
                    );
                    if t_in < t_out {
                        let iv = interval(&er, &cells[i], false, &Q::int(0))
                            .filter(Interval::entered)
                            .unwrap_or_else(|| panic!("{what}: handed over but not entered"));
                        let b = match (iv.b, &qmax) {
                            (Some(b), Some(m)) => Some(b.min(m.clone())),
                            (b, m) => b.or(m.clone()),
                        };
                        assert!(
                            iv.a == t_in && b.is_none_or(|b| b == t_out),
                            "{what}: interval"
                        );
                    }
                    check_entry_and_exit(&er, e, qmax.as_ref(), &what);
                    entries += 1;
                }
                // Every cell the ray enters is handed over, if it enters by `tmax` (at `tmax`
                // itself it is touched there, the range being closed).
                for c in &cells {
                    let entered = interval(&er, c, false, &Q::int(0))
                        .is_some_and(|iv| iv.entered() && qmax.as_ref().is_none_or(|m| iv.a <= *m));
                    if entered {
                        assert!(
                            got.iter().any(|e| e.cell == c.lo),
                            "{ray:?} tmin {tmin}: entered cell {} not handed over",
                            c.lo
                        );
                    }
                }
            }
        }
    }
    assert!(entries > 4_000, "{entries} entries checked");
}

#[test]
fn full_tree_every_axis_parallel_ray_hits_the_first_cell() {
    // A full 8^3 grid: an axis-parallel ray from outside through any cell centre or along
    // any lattice line hits at the root face, whatever the zero signs.
    let depth = 3u8;
    let n = 8u32;
    let cells: Vec<UVec3> = (0..n * n * n)
        .map(|i| UVec3::new(i / 64, i / 8 % 8, i % 8))
        .collect();
    let tree = plain_tree(depth, &cells);
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            for a in 0..=2 * n {
                for b in 0..=2 * n {
                    for zs in [0.0f32, -0.0] {
                        let mut o = Vec3::splat(0.0);
                        let mut d = Vec3::splat(zs);
                        d[axis] = sign;
                        o[axis] = if sign > 0.0 { -3.0 } else { n as f32 + 3.0 };
                        o[(axis + 1) % 3] = a as f32 * 0.5;
                        o[(axis + 2) % 3] = b as f32 * 0.5;
                        let r = cast(
                            &tree,
                            &GridRay { origin: o, dir: d },
                            0.0,
                            f32::INFINITY,
                            HitMode::Cube,
                            None,
                            MAX_STEPS,
                        );
                        // On the root's boundary a zero whose sign points outwards stands
                        // for a ray that leaves the root: it must miss. Every other ray hits.
                        let outward = |v: u32| {
                            (v == 0 && zs.is_sign_negative())
                                || (v == 2 * n && zs.is_sign_positive())
                        };
                        if outward(a) || outward(b) {
                            assert!(r.hit.is_none(), "hit {o} {d}");
                            continue;
                        }
                        let h = r.hit.unwrap_or_else(|| panic!("miss {o} {d}"));
                        assert_eq!(h.t, 3.0, "{o} {d}");
                        let mut want = Vec3::ZERO;
                        want[axis] = -sign;
                        assert_eq!(h.normal, want);
                    }
                }
            }
        }
    }
}

#[test]
fn invalid_rays_miss_without_panicking() {
    let tree = plain_tree(2, &[UVec3::new(1, 1, 1)]);
    for (o, d) in [
        (Vec3::NAN, Vec3::X),
        (Vec3::ZERO, Vec3::ZERO),
        (Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0)),
        (Vec3::splat(f32::INFINITY), Vec3::ONE),
        (Vec3::splat(-1e30), Vec3::ONE),
        (Vec3::splat(1e30), Vec3::splat(1e-30)),
    ] {
        let r = cast(
            &tree,
            &GridRay { origin: o, dir: d },
            0.0,
            f32::INFINITY,
            HitMode::Cube,
            None,
            MAX_STEPS,
        );
        assert!(!r.capped);
        // A far but valid ray may hit; only non-finite input is guaranteed to miss.
        if !(o.is_finite() && d.is_finite() && d != Vec3::ZERO) {
            assert!(r.hit.is_none());
        }
    }
}

#[test]
fn step_cap_is_reported() {
    let cells: Vec<UVec3> = (0..16u32).map(|x| UVec3::new(x, 3, 3)).collect();
    let tree = plain_tree(4, &cells);
    let ray = GridRay {
        origin: Vec3::new(-1.0, 3.5, 3.5),
        dir: Vec3::X,
    };
    // Decline every leaf: the ray walks all 16 and some empty siblings.
    let all = traverse(&tree, &ray, 0.0, f32::INFINITY, MAX_STEPS, |_| None::<()>);
    assert!(!all.capped && all.hit.is_none() && all.steps >= 16);
    let capped = traverse(&tree, &ray, 0.0, f32::INFINITY, 5, |_| None::<()>);
    assert!(capped.capped && capped.steps == 6);
}

/// What a walk handed over, bit for bit, and its outcome.
type Walked = (Vec<[u32; 12]>, Option<u32>, u32, bool);

fn walk(tree: &Octree, ray: &GridRay, tmin: f32, tmax: f32, stop: Option<u32>) -> Walked {
    let mut seen = Vec::new();
    let t = traverse(tree, ray, tmin, tmax, MAX_STEPS, |e: &LeafEntry| {
        seen.push(entry_bits(e));
        (Some(e.leaf) == stop).then_some(e.leaf)
    });
    (seen, t.hit, t.steps, t.capped)
}

/// [`walk`] on a tree's graph.
fn walk_dag(dag: &DagTree, ray: &GridRay, tmin: f32, tmax: f32, stop: Option<u32>) -> Walked {
    let mut seen = Vec::new();
    let t = dag.traverse(ray, tmin, tmax, MAX_STEPS, |e: &LeafEntry| {
        seen.push(entry_bits(e));
        (Some(e.leaf) == stop).then_some(e.leaf)
    });
    (seen, t.hit, t.steps, t.capped)
}

/// An entry as its bits: the leaf, the cell, the parameters and both normals.
fn entry_bits(e: &LeafEntry) -> [u32; 12] {
    let n = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let [a, b, c] = n(e.entry_normal);
    let [d, f, g] = n(e.exit_normal);
    [
        e.leaf,
        e.cell.x,
        e.cell.y,
        e.cell.z,
        e.t_enter.to_bits(),
        e.t_exit.to_bits(),
        a,
        b,
        c,
        d,
        f,
        g,
    ]
}

/// A ray of this file's families for a tree of `depth` levels, with random `tmin` and `tmax`
/// (infinite for 70% of them). Past depth 8, small-tree rays scaled up to the deep tree: the
/// coordinates of families that are exact on small trees stay exact.
fn bounded_ray(rng: &mut impl Rng, depth: u8) -> (GridRay, f32, f32) {
    let n = (1u64 << depth) as f32;
    let (ray, tmin) = if depth > 8 {
        let (r, t) = random_ray(rng, 128.0);
        let s = if rng.random_bool(0.5) { 1.0 } else { n / 128.0 };
        (
            GridRay {
                origin: r.origin * s,
                dir: r.dir,
            },
            t * s,
        )
    } else {
        random_ray(rng, n)
    };
    let tmax = if rng.random_bool(0.3) {
        tmin + rng.random_range(0.0..n * 2.0)
    } else {
        f32::INFINITY
    };
    (ray, tmin, tmax)
}

/// Seeded random trees for the walks' comparisons: slabs and clusters at depths `depths`,
/// random cells (sparse and dense) at depth up to 5, and sparse trees of depth 12, 20 and 30
/// whose shapes lie near the low faces, the far corner and in the middle (so that mirrored
/// axes meet boxes next to either face).
fn walk_trees(
    rng: &mut impl Rng,
    depths: std::ops::RangeInclusive<u8>,
    dense: f64,
) -> Vec<(u8, Octree)> {
    let mut trees = Vec::new();
    for depth in depths {
        for k in 0..3 {
            let cells = match k {
                0 => slabs_and_clusters(rng, depth),
                1 => random_cells(rng, depth.min(5), 0.03),
                _ => random_cells(rng, depth.min(5), dense),
            };
            if !cells.is_empty() {
                let d = if k == 0 { depth } else { depth.min(5) };
                trees.push((d, plain_tree(d, &cells)));
            }
        }
    }
    for depth in [12u8, 20, 30] {
        let far = (1u32 << depth) - 1;
        let mut cells = slabs_and_clusters(rng, 7);
        let n = cells.len();
        for i in 0..n {
            let c = cells[i];
            cells.push(UVec3::splat(far) - c);
            cells.push(c + UVec3::splat(far / 2));
        }
        trees.push((depth, plain_tree(depth, &cells)));
    }
    trees
}

/// A tree's graph (`svo::dag::DagTree`: identical subtrees once, 4x4x4 bricks at the bottom)
/// walks as the tree does: on seeded random trees (slabs, clusters, random cells, depths 2
/// to 8, a lattice whose every subtree repeats, and sparse trees of depth 12, 20 and 30),
/// every ray family of this file with random `tmin` and `tmax` (axis-parallel with `-0.0`,
/// through lattice corners and edges, from inside), walked to the end and stopped at a chosen
/// leaf, hands over the same leaves (the same indices into the tree's leaf arrays) with the
/// same entries bit for bit, in as many steps as the tree (the graph keeps the boxes of its
/// nodes' leaves too), and stops at the same leaf.
#[test]
fn the_dag_walk_hands_over_the_trees_entries() {
    let mut rng = common::rng(0xDA6_3A1C);
    let mut trees = walk_trees(&mut rng, 2..=8, 0.4);
    let lattice: Vec<UVec3> = random_cells(&mut rng, 6, 1.0)
        .into_iter()
        .filter(|c| c.x % 3 == 0 && (c.y + c.z) % 2 == 0)
        .collect();
    trees.push((6, plain_tree(6, &lattice)));
    let (mut rays, mut handed) = (0usize, 0usize);
    for (depth, tree) in &trees {
        let dag = DagTree::from_tree(tree).unwrap();
        assert_eq!(dag.leaf_count(), u64::from(tree.leaf_count));
        for _ in 0..300 {
            let (ray, tmin, tmax) = bounded_ray(&mut rng, *depth);
            let all = walk(tree, &ray, tmin, tmax, None);
            assert_eq!(
                walk_dag(&dag, &ray, tmin, tmax, None),
                all,
                "{ray:?} {tmin} {tmax}"
            );
            rays += 1;
            handed += all.0.len();
            if let Some(e) = all.0.get(rng.random_range(0..all.0.len().max(1))) {
                let stop = Some(e[0]);
                assert_eq!(
                    walk_dag(&dag, &ray, tmin, tmax, stop),
                    walk(tree, &ray, tmin, tmax, stop),
                    "{ray:?} stopped at {stop:?}"
                );
            }
        }
    }
    assert!(handed > rays, "{handed} leaves over {rays} rays");
}

/// Cells that leave most of a node's cube empty, where the boxes of the nodes' leaves pay:
/// thin slabs over part of a face (floors, walls, a water surface), small clusters, and a few
/// scattered cells.
fn slabs_and_clusters(rng: &mut impl Rng, depth: u8) -> Vec<UVec3> {
    let side = 1u32 << depth;
    let mut cells = Vec::new();
    let span = |rng: &mut dyn rand::RngCore| {
        let a = rng.random_range(0..side);
        let b = rng.random_range(0..side);
        (a.min(b), a.max(b))
    };
    for _ in 0..rng.random_range(1..4) {
        let axis = rng.random_range(0..3);
        let at = rng.random_range(0..side);
        let ((u0, u1), (v0, v1)) = (span(rng), span(rng));
        for u in u0..=u1.min(u0 + 40) {
            for v in v0..=v1.min(v0 + 40) {
                let mut c = UVec3::ZERO;
                c[axis] = at;
                c[(axis + 1) % 3] = u;
                c[(axis + 2) % 3] = v;
                cells.push(c);
            }
        }
    }
    for _ in 0..rng.random_range(0..4) {
        let c = UVec3::new(
            rng.random_range(0..side),
            rng.random_range(0..side),
            rng.random_range(0..side),
        );
        for _ in 0..12 {
            let d = UVec3::new(
                rng.random_range(0..3),
                rng.random_range(0..3),
                rng.random_range(0..3),
            );
            cells.push((c + d).min(UVec3::splat(side - 1)));
        }
    }
    cells.sort_by_key(UVec3::to_array);
    cells.dedup();
    cells
}

/// The boxes of the nodes' leaves that the traversal tests before entering a child change its
/// steps and nothing else: on seeded random trees (slabs, clusters, random cells, depths 1 to
/// 8, and sparse trees of depth 12, 20 and 30 whose boxes are stored in coarse units), every
/// ray family of this file with random `tmin` and `tmax`, walked to the end and stopped at a
/// chosen leaf, hands over the same leaves with the same entries bit for bit as the walk of
/// the same tree with its bounds cleared, and stops at the same leaf, never with more steps
/// (but for the few that a ray with a finite `tmax` may take after a box turned it away).
/// Over all rays the boxes save at least a fifth of the steps.
#[test]
fn node_bounds_change_the_steps_and_nothing_else() {
    let mut rng = common::rng(0xB0_0B5);
    let (mut with, mut without, mut rays, mut handed) = (0u64, 0u64, 0usize, 0usize);
    let (mut boxed, mut more) = (0, 0);
    let trees = walk_trees(&mut rng, 1..=8, 0.3);
    for (depth, tree) in &trees {
        let mut bare = tree.clone();
        bare.clear_bounds();
        boxed += usize::from(&bare != tree);
        for _ in 0..300 {
            let (ray, tmin, tmax) = bounded_ray(&mut rng, *depth);
            let all = walk(&bare, &ray, tmin, tmax, None);
            assert_eq!(
                walk(tree, &ray, tmin, tmax, None).0,
                all.0,
                "{ray:?} {tmin} {tmax}"
            );
            let got = walk(tree, &ray, tmin, tmax, None);
            // A walk ends at the first existing child past `tmax`. Where a box turns the
            // ray away from a child whose walk would have ended there, the walk goes on over
            // the child's later siblings and its ancestors' (at most three a level), so a
            // finite `tmax` may cost those few steps; an infinite one never costs any.
            let extra = if tmax.is_finite() {
                3 * u32::from(*depth)
            } else {
                0
            };
            assert!(
                got.2 <= all.2 + extra,
                "{ray:?} tmax {tmax}: {} steps with the bounds, {} without",
                got.2,
                all.2
            );
            more += usize::from(got.2 > all.2);
            with += u64::from(got.2);
            without += u64::from(all.2);
            handed += all.0.len();
            if !all.0.is_empty() {
                let stop = all.0[rng.random_range(0..all.0.len())][0];
                let a = walk(tree, &ray, tmin, tmax, Some(stop));
                let b = walk(&bare, &ray, tmin, tmax, Some(stop));
                assert_eq!(
                    (&a.0, a.1, a.3),
                    (&b.0, b.1, b.3),
                    "{ray:?} stopped at {stop}"
                );
                assert!(a.2 <= b.2);
            }
            rays += 1;
        }
    }
    eprintln!(
        "{rays} rays, {handed} leaves handed over; {with} steps with the bounds, {without} without; {more} rays with more steps"
    );
    assert!(handed > rays, "{handed} leaves for {rays} rays");
    assert!(
        boxed * 4 > trees.len() * 3,
        "{boxed} of {} trees have boxes",
        trees.len()
    );
    assert!(
        with * 5 <= without * 4,
        "{with} steps with the bounds, {without} without"
    );
}
