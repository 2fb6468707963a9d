//! Ray casting throughput, one thread, primary rays of a framing camera (480x270): the octree
//! with cube and contour hits, and the dense-grid DDA, on the committed torus always and on
//! the Stanford bunny when `../shared/models` is present. Throughput is reported in rays.
#![allow(missing_docs)]

mod common;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use svo::render::Camera;
use svo::trace::{DenseGrid, GridRay, HitMode, MAX_STEPS, cast, leaf_hit, traverse_dda};
use svo::{BakeOptions, bake_mesh};

fn bench(c: &mut Criterion) {
    let meshes = common::bench_meshes();
    let mut g = c.benchmark_group("cast");
    g.sample_size(10);
    for (name, path) in &meshes {
        let mesh = svo::Mesh::load(path).unwrap();
        for depth in [8u8, 10] {
            let opts = BakeOptions {
                depth,
                ..Default::default()
            };
            let tree = bake_mesh(&mesh, &opts).unwrap().0;
            let (lo, hi) = tree.occupied_bounds();
            let cam = Camera::framing(lo, hi, 480, 270, 40.0);
            let r = cam.rays().unwrap();
            let eye = tree.root.to_grid(cam.eye, depth).as_vec3();
            let scale = ((1u64 << depth) as f64 / tree.root.side) as f32;
            let rays: Vec<GridRay> = (0..270)
                .flat_map(|y| (0..480).map(move |x| (x, y)))
                .map(|(x, y)| GridRay {
                    origin: eye,
                    dir: r.dir_f32(x, y) * scale,
                })
                .collect();
            // The work timed: first hits, counted.
            let hits = |ray: &GridRay, mode: HitMode| {
                cast(&tree, ray, 0.0, f32::INFINITY, mode, None, MAX_STEPS)
                    .hit
                    .is_some()
            };
            g.throughput(Throughput::Elements(rays.len() as u64));
            for mode in [HitMode::Cube, HitMode::Contour] {
                g.bench_function(format!("{name}/d{depth}/octree-{}", mode.name()), |b| {
                    b.iter(|| rays.iter().filter(|ray| hits(ray, mode)).count())
                });
            }
            if std::env::var_os("SVO_BENCH_SPLIT").is_some() {
                // Diagnostics: rays that miss the root (setup cost only), and the hit rays
                // alone.
                let away: Vec<GridRay> = rays
                    .iter()
                    .map(|r| GridRay {
                        origin: r.origin,
                        dir: -r.dir,
                    })
                    .collect();
                let (hit, missed): (Vec<GridRay>, Vec<GridRay>) =
                    rays.iter().partition(|ray| hits(ray, HitMode::Cube));
                for (label, set) in [("away", &away), ("hits", &hit), ("misses", &missed)] {
                    g.throughput(Throughput::Elements(set.len() as u64));
                    g.bench_function(format!("{name}/d{depth}/split-{label}"), |b| {
                        b.iter(|| set.iter().filter(|ray| hits(ray, HitMode::Cube)).count())
                    });
                }
                g.throughput(Throughput::Elements(rays.len() as u64));
            }
            if depth <= 8 {
                let grid = DenseGrid::new(&tree).unwrap();
                g.bench_function(format!("{name}/d{depth}/dda-cube"), |b| {
                    b.iter(|| {
                        rays.iter()
                            .filter(|ray| {
                                traverse_dda(
                                    &grid,
                                    &tree,
                                    ray,
                                    0.0,
                                    f32::INFINITY,
                                    MAX_STEPS,
                                    |e| leaf_hit(&tree, ray, e, HitMode::Cube),
                                )
                                .hit
                                .is_some()
                            })
                            .count()
                    })
                });
            }
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
