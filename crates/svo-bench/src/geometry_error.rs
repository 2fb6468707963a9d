//! Geometric error of the rendered voxel surface: points sampled uniformly on the mesh (by
//! area, seeded), and from each a ray along the triangle's normal, from both sides, starting
//! [`OFFSET_CELLS`] cells off the surface. Each ray is cast against the octree in a hit mode
//! and against the triangles (the `obvhs` reference) in the same grid; the error is the
//! difference of the two hit distances, in cells and in scene units. Rays where one hits and
//! the other does not are counted apart (they are holes or bulges, not distances).

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use svo::mesh::Mesh;
use svo::render::{Query, Surfaces};
use svo::trace::{GridRay, MAX_STEPS};

/// How far off the surface the rays start, in cells.
pub const OFFSET_CELLS: f32 = 2.0;

/// A point on the mesh and its unit normal (scene space).
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// The point.
    pub p: DVec3,
    /// The triangle's unit normal.
    pub n: DVec3,
}

/// `count` points on `mesh`, uniform by area, from a fixed seed; degenerate triangles are
/// never chosen.
pub fn sample(mesh: &Mesh, count: usize, seed: u64) -> Vec<Sample> {
    let mut cdf = Vec::with_capacity(mesh.triangles.len());
    let mut total = 0.0;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        total += 0.5 * (b - a).cross(c - a).length();
        cdf.push(total);
    }
    if !(total > 0.0) {
        return Vec::new();
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            let u = rng.random::<f64>() * total;
            let i = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
            let [a, b, c] = mesh.triangles[i].map(|k| mesh.positions[k as usize]);
            let (r1, r2) = (rng.random::<f64>().sqrt(), rng.random::<f64>());
            let p = a * (1.0 - r1) + b * (r1 * (1.0 - r2)) + c * (r1 * r2);
            Sample {
                p,
                n: (b - a).cross(c - a).normalize(),
            }
        })
        .collect()
}

/// The grid rays of the samples, two per sample (from either side), in the grid of `depth`.
pub fn rays(samples: &[Sample], root: &svo::RootCube, depth: u8) -> Vec<GridRay> {
    let cell = root.cell_size(depth);
    samples
        .iter()
        .flat_map(|s| {
            [1.0, -1.0].map(|side| {
                let o = s.p + s.n * (side * f64::from(OFFSET_CELLS) * cell);
                GridRay {
                    origin: root.to_grid(o, depth).as_vec3(),
                    dir: (-s.n * side).as_vec3().normalize(),
                }
            })
        })
        .collect()
}

/// The first hit distance (cells) of every ray within twice the offset.
pub fn distances<S: Surfaces>(surfaces: &S, rays: &[GridRay]) -> Vec<Option<f32>> {
    let q = Query {
        tmax: 3.0 * OFFSET_CELLS,
        ..Query::all(MAX_STEPS)
    };
    rays.par_iter()
        .map(|r| surfaces.closest(r, &q).hit.map(|h| h.t))
        .collect()
}

/// Error statistics of one hit mode at one depth.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct GeometryError {
    /// Mean of `|t - t_ref|`, cells.
    pub mean: f64,
    /// 95th percentile, cells.
    pub p95: f64,
    /// Maximum, cells.
    pub max: f64,
    /// Share of rays where exactly one of the two hits.
    pub mismatch: f64,
    /// Rays compared.
    pub rays: usize,
}

/// Compares hit distances against the reference's.
pub fn compare(got: &[Option<f32>], reference: &[Option<f32>]) -> GeometryError {
    let mut e = Vec::with_capacity(got.len());
    let mut mismatch = 0usize;
    for (a, b) in got.iter().zip(reference) {
        match (a, b) {
            (Some(a), Some(b)) => e.push(f64::from((a - b).abs())),
            (None, None) => {}
            _ => mismatch += 1,
        }
    }
    if e.is_empty() {
        return GeometryError {
            mismatch: mismatch as f64 / got.len().max(1) as f64,
            rays: got.len(),
            ..Default::default()
        };
    }
    e.sort_by(f64::total_cmp);
    GeometryError {
        mean: e.iter().sum::<f64>() / e.len() as f64,
        p95: e[((e.len() - 1) as f64 * 0.95) as usize],
        max: e[e.len() - 1],
        mismatch: mismatch as f64 / got.len().max(1) as f64,
        rays: got.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_lie_on_the_mesh_and_repeat() {
        let mesh = Mesh::from_triangles(
            vec![
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                DVec3::new(5.0, 5.0, 5.0),
                DVec3::new(5.0, 5.0, 5.0),
                DVec3::new(5.0, 5.0, 5.0),
            ],
            vec![[0, 1, 2], [3, 4, 5]],
        );
        let a = sample(&mesh, 500, 7);
        let b = sample(&mesh, 500, 7);
        assert_eq!(a.len(), 500);
        for (s, t) in a.iter().zip(&b) {
            assert_eq!(s.p, t.p);
            // Only the first (non-degenerate) triangle: z = 0, x, y >= 0, x + y <= 1.
            assert!(s.p.z == 0.0 && s.p.x >= 0.0 && s.p.y >= 0.0 && s.p.x + s.p.y <= 1.0 + 1e-12);
            assert_eq!(s.n, DVec3::Z);
        }
    }

    #[test]
    fn compare_counts_mismatches_apart() {
        let e = compare(
            &[Some(1.0), Some(2.5), None, Some(1.0)],
            &[Some(1.5), Some(2.0), Some(1.0), None],
        );
        assert_eq!(e.rays, 4);
        assert!((e.mean - 0.5).abs() < 1e-12 && (e.max - 0.5).abs() < 1e-12);
        assert!((e.mismatch - 0.5).abs() < 1e-12);
    }
}
