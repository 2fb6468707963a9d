//! The whole bake (voxelize, attributes, contours) per strategy and depth, and at depth 8
//! with the inner nodes' attributes (`/lod`): on the committed torus fixture always, and on
//! the Stanford bunny when `../shared/models` is present.
#![allow(missing_docs)]

mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use svo::{BakeOptions, Strategy, bake_mesh};

fn bench(c: &mut Criterion) {
    let meshes = common::bench_meshes();
    let mut g = c.benchmark_group("bake");
    g.sample_size(10);
    for (name, path) in &meshes {
        let mesh = svo::Mesh::load(path).unwrap();
        for depth in [6u8, 8] {
            for strategy in [Strategy::Exact, Strategy::PlaneSatLeaf] {
                let opts = BakeOptions {
                    depth,
                    strategy,
                    ..Default::default()
                };
                g.bench_function(format!("{name}/d{depth}/{strategy}"), |b| {
                    b.iter(|| bake_mesh(&mesh, &opts).unwrap())
                });
            }
        }
        let opts = BakeOptions {
            depth: 8,
            node_attributes: true,
            ..Default::default()
        };
        g.bench_function(format!("{name}/d8/exact/lod"), |b| {
            b.iter(|| bake_mesh(&mesh, &opts).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
