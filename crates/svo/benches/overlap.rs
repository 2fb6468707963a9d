//! Cost of each overlap test on seeded random triangles and cells (ns per test).
#![allow(missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use std::hint::black_box;
use svo::voxelize::{
    GridTriangle, edges_overlap, plane_overlaps, triangle_box_overlap, vertex_inside,
};

fn cases() -> Vec<(GridTriangle, DVec3)> {
    let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    (0..4096)
        .map(|_| {
            let p = |r: &mut rand_chacha::ChaCha8Rng| {
                DVec3::new(
                    r.random_range(-1.0..3.0),
                    r.random_range(-1.0..3.0),
                    r.random_range(-1.0..3.0),
                )
            };
            let a = p(&mut r);
            let t = GridTriangle::new(a, a + (p(&mut r) - a) * 0.5, a + (p(&mut r) - a) * 0.5);
            (
                t,
                DVec3::new(
                    f64::from(r.random_range(0..2)),
                    f64::from(r.random_range(0..2)),
                    f64::from(r.random_range(0..2)),
                ),
            )
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let cs = cases();
    let mut g = c.benchmark_group("overlap_4096");
    g.bench_function("vertex_inside", |b| {
        b.iter(|| {
            cs.iter()
                .filter(|(t, m)| vertex_inside(black_box(t), *m, 1.0))
                .count()
        })
    });
    g.bench_function("plane", |b| {
        b.iter(|| {
            cs.iter()
                .filter(|(t, m)| plane_overlaps(black_box(t), *m, 1.0))
                .count()
        })
    });
    g.bench_function("edges_sat", |b| {
        b.iter(|| {
            cs.iter()
                .filter(|(t, m)| edges_overlap(black_box(t), *m, 1.0))
                .count()
        })
    });
    g.bench_function("full_13_axis", |b| {
        b.iter(|| {
            cs.iter()
                .filter(|(t, m)| triangle_box_overlap(black_box(t), *m, 1.0))
                .count()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
