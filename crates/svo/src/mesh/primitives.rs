//! Closed triangle meshes of simple shapes, for scene files, tests and users: boxes, spheres (an
//! octahedron whose faces are split into `n^2` triangles, pushed onto the sphere) and
//! rectangles. Triangles face outwards (counter-clockwise seen from outside); vertices shared
//! between faces are computed by the same expression, so they match exactly and the closed
//! shapes are closed ([`Mesh::open_edges`] is 0).

use crate::mesh::triangle_mesh::Mesh;
use glam::DVec3;

impl Mesh {
    /// An axis-aligned box from `lo` to `hi`: 8 vertices, 12 triangles.
    pub fn cuboid(lo: DVec3, hi: DVec3) -> Mesh {
        let p = |i: u32| {
            DVec3::new(
                if i & 4 != 0 { hi.x } else { lo.x },
                if i & 2 != 0 { hi.y } else { lo.y },
                if i & 1 != 0 { hi.z } else { lo.z },
            )
        };
        let quads = [
            [0, 1, 3, 2], // x = lo
            [4, 6, 7, 5], // x = hi
            [0, 4, 5, 1], // y = lo
            [2, 3, 7, 6], // y = hi
            [0, 2, 6, 4], // z = lo
            [1, 5, 7, 3], // z = hi
        ];
        let triangles = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        Mesh::from_triangles((0..8).map(p).collect(), triangles)
    }

    /// A sphere: the octahedron's 8 faces split into `n^2` triangles each (`n >= 1`; `n = 1` is
    /// the octahedron), vertices pushed to `radius` from `centre`.
    pub fn sphere(centre: DVec3, radius: f64, n: u32) -> Mesh {
        let n = n.max(1);
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for s in 0..8u32 {
            let sg = DVec3::new(
                if s & 4 != 0 { -1.0 } else { 1.0 },
                if s & 2 != 0 { -1.0 } else { 1.0 },
                if s & 1 != 0 { -1.0 } else { 1.0 },
            );
            // Mirrored octants reverse the winding.
            let flip = sg.x * sg.y * sg.z < 0.0;
            let base = positions.len() as u32;
            // Row a (0..=n), position b (0..=a) of the face's triangular grid.
            let idx = |a: u32, b: u32| base + a * (a + 1) / 2 + b;
            for a in 0..=n {
                for b in 0..=a {
                    let d =
                        DVec3::new(f64::from(n - a), f64::from(a - b), f64::from(b)).normalize();
                    positions.push(centre + d * sg * radius);
                }
            }
            let mut push = |mut t: [u32; 3]| {
                if flip {
                    t.swap(1, 2);
                }
                triangles.push(t);
            };
            for a in 0..n {
                for b in 0..=a {
                    push([idx(a, b), idx(a + 1, b), idx(a + 1, b + 1)]);
                    if b < a {
                        push([idx(a, b), idx(a + 1, b + 1), idx(a, b + 1)]);
                    }
                }
            }
        }
        Mesh::from_triangles(positions, triangles)
    }

    /// A rectangle (two triangles, open) centred at `centre`, facing `normal`, `size[0]` by
    /// `size[1]`: the first side runs along `normal x a`, where `a` is the axis least aligned
    /// with `normal` (so a rectangle facing `+y` spans x by z).
    pub fn rectangle(centre: DVec3, normal: DVec3, size: [f64; 2]) -> Mesh {
        let n = normal.normalize_or(DVec3::Y);
        let a = if n.x.abs() <= n.y.abs() && n.x.abs() <= n.z.abs() {
            DVec3::X
        } else if n.y.abs() <= n.z.abs() {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let v = n.cross(a).normalize() * (size[1] / 2.0);
        let u = v.cross(n).normalize() * (size[0] / 2.0);
        let positions = vec![
            centre - u - v,
            centre + u - v,
            centre + u + v,
            centre - u + v,
        ];
        Mesh::from_triangles(positions, vec![[0, 1, 2], [0, 2, 3]])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::closed::open_edges;

    /// The volume enclosed by outward triangles (divergence theorem).
    fn volume(m: &Mesh) -> f64 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn closed_outward_and_the_right_size() {
        let b = Mesh::cuboid(DVec3::new(1.0, 2.0, 3.0), DVec3::new(2.0, 4.0, 6.0));
        assert_eq!(open_edges(&b), 0);
        assert!((volume(&b) - 6.0).abs() < 1e-12);
        for n in [1, 2, 5, 16] {
            let s = Mesh::sphere(DVec3::new(0.5, -1.0, 2.0), 2.0, n);
            assert_eq!(open_edges(&s), 0, "n = {n}");
            assert_eq!(s.triangles.len() as u32, 8 * n * n);
            let v = volume(&s);
            let ball = 4.0 / 3.0 * std::f64::consts::PI * 8.0;
            assert!(v > 0.0 && v <= ball, "n = {n}: {v}");
            if n == 16 {
                assert!(v > 0.98 * ball, "{v}");
            }
        }
        let r = Mesh::rectangle(DVec3::new(0.0, 1.0, 0.0), DVec3::Y, [4.0, 2.0]);
        assert_eq!(open_edges(&r), 4);
        let (lo, hi) = r.bounds().unwrap();
        assert_eq!(
            (lo, hi),
            (DVec3::new(-2.0, 1.0, -1.0), DVec3::new(2.0, 1.0, 1.0))
        );
        let [a, b, c] = r.triangles[0].map(|i| r.positions[i as usize]);
        assert!(
            (b - a)
                .cross(c - a)
                .normalize()
                .abs_diff_eq(DVec3::Y, 1e-12)
        );
    }
}
