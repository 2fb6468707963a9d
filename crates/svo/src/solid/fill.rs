//! Solid voxelization: the cells inside a mesh, added to its surface tree as interior
//! leaves.
//!
//! A cell that no triangle touches lies wholly inside or wholly outside, so its centre
//! decides. Centres are tested a column at a time: the line through a column of centres
//! (along x, y or z) crosses the triangles whose projection contains the column's point,
//! and between the 1st and 2nd, 3rd and 4th, ... crossing it is inside.
//!
//! - **Exact counting.** Whether a column's point lies in a triangle's projection is decided
//!   with exact orientation predicates (`robust::orient2d`); a point exactly on an edge or a
//!   vertex is treated as moved by `(e, e^2)` for an infinitesimal `e` (simulation of
//!   simplicity), which is antisymmetric in the edge's direction, so two triangles sharing an
//!   edge always agree and the perturbed line crosses a closed surface an even number of
//!   times. Triangles standing on edge in the projection contain no perturbed point.
//! - **Safe crossing positions.** A crossing lies on a triangle, and a cell that no triangle
//!   touches is at least half a cell from it along its column, so the crossing's position
//!   (barycentric weights from the same predicates) only needs to be good to far less than
//!   half a cell; cells within half a cell of a crossing are surface leaves already.
//! - **Modes.** [`SolidMode::Closed`] counts along z columns and is exact for closed meshes
//!   (checked first with [`crate::mesh::closed::open_edges`]). [`SolidMode::Vote`] is for meshes
//!   with holes (the Stanford bunny): it counts along x, y and z; a column with an odd number
//!   of crossings abstains, and a cell is inside when more of the remaining columns through it
//!   say inside than outside. On a closed mesh it gives the same cells as `Closed`.
//!
//! Interior leaves carry the material of the triangle where their run enters the mesh, the
//! normal word [`crate::octree::tree::NO_NORMAL`] and a full contour.

use crate::geometry::grid::RootCube;
use crate::mesh::triangle_mesh::Mesh;
use crate::octree::builder::{layout_sorted, morton};
use crate::octree::encoding::{encode_colour, ior_encode, unorm8};
use crate::octree::tree::{Channel, LeafAttributes, NO_NORMAL, Octree};
use crate::solid::mode::SolidMode;
use glam::{DVec3, UVec3};
use robust::{Coord, orient2d};

/// Estimated bytes of memory per interior cell while it is merged into the tree (key and
/// source, then the node share and the per-leaf channels).
pub(crate) const BYTES_PER_CELL: f64 = 48.0;

/// One crossing of a column with a triangle.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    /// `u * side + v`: the column (see [`axes`]).
    key: u64,
    /// Grid coordinate along the column.
    at: f64,
    /// Material index of the triangle.
    material: u32,
}

/// A run of cell centres inside the mesh along one column: cells `lo..=hi`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Run {
    key: u64,
    lo: u32,
    hi: u32,
    material: u32,
}

/// The runs and abstaining columns along one axis.
#[derive(Debug, Default)]
struct AxisRuns {
    /// Sorted by `(key, lo)`, disjoint within a column.
    runs: Vec<Run>,
    /// Columns with an odd number of crossings, sorted.
    odd: Vec<u64>,
    /// For grids of at most [`DENSE_COLUMNS`] columns, where each column's runs start
    /// (`side^2 + 1` entries, the last one `runs.len()`) and one bit per column for `odd`:
    /// a vote is then two loads instead of two binary searches.
    dense: Option<(Vec<u32>, Vec<u64>)>,
}

/// The largest column count (`4^depth`) that gets a dense column index: 2^24 columns (depth
/// 12) take 64 MiB.
const DENSE_COLUMNS: u64 = 1 << 24;

/// What a column says about a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Vote {
    In(u32),
    Out,
    Abstain,
}

/// The two axes across `axis` (the column's coordinates), in cyclic order.
#[inline]
fn axes(axis: usize) -> (usize, usize) {
    ((axis + 1) % 3, (axis + 2) % 3)
}

/// The sign (-1, 1) of point `c` against the directed edge `a -> b`, with ties broken by the
/// perturbation `c + (e, e^2)`; and the predicate's value (zero on the edge's line).
#[inline]
fn side(a: Coord<f64>, b: Coord<f64>, c: Coord<f64>) -> (i8, f64) {
    let d = orient2d(a, b, c);
    let s = if d > 0.0 {
        1
    } else if d < 0.0 {
        -1
    } else if b.y != a.y {
        // d/de of cross(b - a, (e, e^2)) = -(b.y - a.y).
        if b.y > a.y { -1 } else { 1 }
    } else if b.x > a.x {
        1
    } else {
        -1
    };
    (s, d)
}

/// The crossings of the columns along `axis` with triangle `t` (grid space).
fn triangle_crossings(
    t: &[DVec3; 3],
    material: u32,
    axis: usize,
    side_n: u64,
    out: &mut Vec<Crossing>,
) {
    let (u, v) = axes(axis);
    let p = t.map(|q| Coord { x: q[u], y: q[v] });
    let area = orient2d(p[0], p[1], p[2]);
    if area == 0.0 {
        return; // on edge in this projection: no perturbed point inside
    }
    let want: i8 = if area > 0.0 { 1 } else { -1 };
    let last = side_n as f64 - 1.0;
    let lo_y = p[0].y.min(p[1].y).min(p[2].y);
    let hi_y = p[0].y.max(p[1].y).max(p[2].y);
    // One row more on each side than rounding could need; the exact test decides.
    let j0 = ((lo_y - 0.5).ceil() - 1.0).max(0.0);
    let j1 = ((hi_y - 0.5).floor() + 1.0).min(last);
    if !(j0 <= j1) {
        return;
    }
    let (lo_a, hi_a) = (
        t[0][axis].min(t[1][axis]).min(t[2][axis]),
        t[0][axis].max(t[1][axis]).max(t[2][axis]),
    );
    for j in j0 as u64..=j1 as u64 {
        let y = j as f64 + 0.5;
        // The row's x interval on the triangle, from the edges spanning it.
        let (mut x_lo, mut x_hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..3 {
            let (a, b) = (p[k], p[(k + 1) % 3]);
            if y < a.y.min(b.y) - 1.0 || y > a.y.max(b.y) + 1.0 {
                continue;
            }
            let x = if a.y == b.y {
                x_lo = x_lo.min(a.x.min(b.x));
                x_hi = x_hi.max(a.x.max(b.x));
                continue;
            } else {
                let s = ((y - a.y) / (b.y - a.y)).clamp(0.0, 1.0);
                a.x + s * (b.x - a.x)
            };
            x_lo = x_lo.min(x);
            x_hi = x_hi.max(x);
        }
        if !(x_lo <= x_hi) {
            continue;
        }
        let i0 = ((x_lo - 0.5).ceil() - 1.0).max(0.0);
        let i1 = ((x_hi - 0.5).floor() + 1.0).min(last);
        if !(i0 <= i1) {
            continue;
        }
        for i in i0 as u64..=i1 as u64 {
            let c = Coord {
                x: i as f64 + 0.5,
                y,
            };
            let (s0, w0) = side(p[1], p[2], c);
            if s0 != want {
                continue;
            }
            let (s1, w1) = side(p[2], p[0], c);
            let (s2, w2) = side(p[0], p[1], c);
            if s1 != want || s2 != want {
                continue;
            }
            // Barycentric weights all have the triangle's sign (or are zero), so the sum
            // is not zero and the position stays within the triangle's extent.
            let at = (w0 * t[0][axis] + w1 * t[1][axis] + w2 * t[2][axis]) / (w0 + w1 + w2);
            out.push(Crossing {
                key: i * side_n + j,
                at: if at.is_finite() {
                    at.clamp(lo_a, hi_a)
                } else {
                    lo_a
                },
                material,
            });
        }
    }
}

/// The inside runs along `axis`.
fn axis_runs(tris: &[[DVec3; 3]], materials: &[u32], axis: usize, depth: u8) -> AxisRuns {
    let side_n = 1u64 << depth;
    #[cfg(feature = "parallel")]
    let mut crossings: Vec<Crossing> = {
        use rayon::prelude::*;
        tris.par_chunks(4096)
            .zip(materials.par_chunks(4096))
            .flat_map_iter(|(ts, ms)| {
                let mut out = Vec::new();
                for (t, &m) in ts.iter().zip(ms) {
                    triangle_crossings(t, m, axis, side_n, &mut out);
                }
                out
            })
            .collect()
    };
    #[cfg(not(feature = "parallel"))]
    let mut crossings: Vec<Crossing> = {
        let mut out = Vec::new();
        for (t, &m) in tris.iter().zip(materials) {
            triangle_crossings(t, m, axis, side_n, &mut out);
        }
        out
    };
    let by_column = |a: &Crossing, b: &Crossing| a.key.cmp(&b.key).then(a.at.total_cmp(&b.at));
    #[cfg(feature = "parallel")]
    {
        use rayon::slice::ParallelSliceMut;
        crossings.par_sort_unstable_by(by_column);
    }
    #[cfg(not(feature = "parallel"))]
    crossings.sort_unstable_by(by_column);

    let mut out = AxisRuns::default();
    let mut start = 0;
    while start < crossings.len() {
        let key = crossings[start].key;
        let end = start + crossings[start..].partition_point(|c| c.key == key);
        let col = &crossings[start..end];
        if col.len() % 2 == 1 {
            out.odd.push(key);
        } else {
            for pair in col.chunks_exact(2) {
                let lo = (pair[0].at - 0.5).ceil().max(0.0);
                let hi = (pair[1].at - 0.5).floor().min((side_n - 1) as f64);
                if lo <= hi {
                    out.runs.push(Run {
                        key,
                        lo: lo as u32,
                        hi: hi as u32,
                        material: pair[0].material,
                    });
                }
            }
        }
        start = end;
    }
    let columns = 1u64 << (2 * u32::from(depth));
    if columns <= DENSE_COLUMNS && out.runs.len() < u32::MAX as usize {
        let mut starts = vec![0u32; columns as usize + 1];
        for r in &out.runs {
            starts[r.key as usize + 1] += 1;
        }
        for k in 0..columns as usize {
            starts[k + 1] += starts[k];
        }
        let mut odd = vec![0u64; (columns as usize).div_ceil(64)];
        for &k in &out.odd {
            odd[(k / 64) as usize] |= 1 << (k % 64);
        }
        out.dense = Some((starts, odd));
    }
    out
}

impl AxisRuns {
    /// What the column along `axis` through `cell` says.
    fn vote(&self, axis: usize, cell: UVec3, depth: u8) -> Vote {
        let (u, v) = axes(axis);
        let key = (u64::from(cell[u]) << depth) + u64::from(cell[v]);
        let c = cell[axis];
        if let Some((starts, odd)) = &self.dense {
            if odd[(key / 64) as usize] >> (key % 64) & 1 == 1 {
                return Vote::Abstain;
            }
            let (a, b) = (
                starts[key as usize] as usize,
                starts[key as usize + 1] as usize,
            );
            return match self.runs[a..b].iter().find(|r| r.hi >= c) {
                Some(r) if r.lo <= c => Vote::In(r.material),
                _ => Vote::Out,
            };
        }
        if self.odd.binary_search(&key).is_ok() {
            return Vote::Abstain;
        }
        let i = self.runs.partition_point(|r| (r.key, r.hi) < (key, c));
        match self.runs.get(i) {
            Some(r) if r.key == key && r.lo <= c => Vote::In(r.material),
            _ => Vote::Out,
        }
    }

    /// Cells of the runs (surface cells included), with their run's material.
    fn cells(&self, axis: usize, depth: u8) -> impl Iterator<Item = (UVec3, u32)> + '_ {
        let (u, v) = axes(axis);
        let mask = (1u64 << depth) - 1;
        self.runs.iter().flat_map(move |r| {
            (r.lo..=r.hi).map(move |k| {
                let mut c = UVec3::ZERO;
                c[axis] = k;
                c[u] = (r.key >> depth) as u32;
                c[v] = (r.key & mask) as u32;
                (c, r.material)
            })
        })
    }

    fn cell_count(&self) -> u64 {
        self.runs.iter().map(|r| u64::from(r.hi - r.lo) + 1).sum()
    }
}

/// Why a fill stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum FillLimit {
    /// The candidate cells (surface cells included) would take more memory than allowed.
    TooMany {
        /// Candidate cells.
        cells: f64,
        /// Estimated bytes.
        bytes: f64,
    },
}

/// What a fill added.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct FillStats {
    /// Interior leaves added.
    pub interior_leaves: u64,
    /// Columns with an odd number of crossings (each abstained).
    pub odd_columns: u64,
}

/// The interior cells of `mesh` in `root` at `depth` (cells no surface leaf of `surface`
/// holds), each with the index of its material, in no particular order.
pub(crate) fn interior_cells(
    mesh: &Mesh,
    root: &RootCube,
    depth: u8,
    mode: SolidMode,
    surface: &Octree,
    max_bytes: Option<u64>,
) -> Result<(Vec<(UVec3, u32)>, FillStats), FillLimit> {
    let tris: Vec<[DVec3; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| root.to_grid(mesh.positions[i as usize], depth)))
        .collect();
    let materials: Vec<u32> = (0..mesh.triangles.len())
        .map(|t| mesh.triangle_materials.get(t).copied().unwrap_or(0))
        .collect();
    let axes_used: &[usize] = match mode {
        SolidMode::Closed => &[2],
        SolidMode::Vote => &[0, 1, 2],
    };
    let runs: Vec<AxisRuns> = axes_used
        .iter()
        .map(|&a| axis_runs(&tris, &materials, a, depth))
        .collect();
    drop(tris);
    let candidates: u64 = runs.iter().map(AxisRuns::cell_count).sum();
    let bytes = candidates as f64 * BYTES_PER_CELL;
    if let Some(limit) = max_bytes
        && bytes > limit as f64
    {
        return Err(FillLimit::TooMany {
            cells: candidates as f64,
            bytes,
        });
    }
    let stats_odd = runs.iter().map(|r| r.odd.len() as u64).sum();
    let mut out = Vec::new();
    match mode {
        SolidMode::Closed => {
            out.extend(
                runs[0]
                    .cells(2, depth)
                    .filter(|(c, _)| surface.leaf_at(*c).is_none()),
            );
        }
        SolidMode::Vote => {
            for (n, axis_runs) in runs.iter().enumerate() {
                for (c, m) in axis_runs.cells(n, depth) {
                    let votes = [0, 1, 2].map(|a| {
                        if a == n {
                            Vote::In(m)
                        } else {
                            runs[a].vote(a, c, depth)
                        }
                    });
                    // Enumerated from the first axis that says inside.
                    if votes[..n].iter().any(|v| matches!(v, Vote::In(_))) {
                        continue;
                    }
                    let ins = votes.iter().filter(|v| matches!(v, Vote::In(_))).count();
                    let outs = votes.iter().filter(|v| **v == Vote::Out).count();
                    if ins > outs && surface.leaf_at(c).is_none() {
                        out.push((c, m));
                    }
                }
            }
        }
    }
    let stats = FillStats {
        interior_leaves: out.len() as u64,
        odd_columns: stats_odd,
    };
    Ok((out, stats))
}

/// Where a leaf of the merged tree comes from.
#[derive(Clone, Copy, Debug)]
enum Source {
    Surface(u32),
    Interior(u32),
}

/// The surface tree with `interior` cells (and their material indices) added as interior
/// leaves. Channels the surface tree leaves out stay out.
pub(crate) fn merge_interior(surface: &Octree, mesh: &Mesh, interior: &[(UVec3, u32)]) -> Octree {
    let depth = surface.depth;
    let mut cells: Vec<(u128, Source)> =
        Vec::with_capacity(surface.leaf_count as usize + interior.len());
    cells.extend(
        surface
            .leaves()
            .map(|l| (morton(l.cell, depth), Source::Surface(l.index))),
    );
    cells.extend(
        interior
            .iter()
            .map(|&(c, m)| (morton(c, depth), Source::Interior(m))),
    );
    #[cfg(feature = "parallel")]
    {
        use rayon::slice::ParallelSliceMut;
        cells.par_sort_unstable_by_key(|c| c.0);
    }
    #[cfg(not(feature = "parallel"))]
    cells.sort_unstable_by_key(|c| c.0);
    let (nodes, sources) = layout_sorted(&cells, depth);
    drop(cells);
    let single_material = mesh.materials.len() <= 1;
    let material = |m: u32| mesh.materials.get(m as usize).cloned().unwrap_or_default();
    let a = &surface.attributes;
    // A channel the surface stores as one constant keeps it for a one-material mesh (the
    // interior's material is the surface's).
    fn gather<T: Copy + PartialEq>(
        ch: &Channel<T>,
        sources: &[Source],
        keep_constant: bool,
        interior: impl Fn(u32) -> T,
    ) -> Channel<T> {
        match ch {
            Channel::Absent => Channel::Absent,
            Channel::Constant(v) if keep_constant => Channel::Constant(*v),
            _ => {
                let mut c = Channel::PerLeaf(
                    sources
                        .iter()
                        .map(|s| match *s {
                            Source::Surface(i) => ch.get(i as usize).unwrap_or_else(|| interior(0)),
                            Source::Interior(m) => interior(m),
                        })
                        .collect(),
                );
                c.compact();
                c
            }
        }
    }
    let attributes = LeafAttributes {
        normal: gather(&a.normal, &sources, false, |_| NO_NORMAL),
        contour: gather(&a.contour, &sources, false, |_| {
            crate::octree::contour::FULL
        }),
        colour: gather(&a.colour, &sources, single_material, |m| {
            encode_colour(material(m).colour)
        }),
        reflectivity: gather(&a.reflectivity, &sources, single_material, |m| {
            unorm8(material(m).optics_at(material(m).colour[3]).0)
        }),
        refractivity: gather(&a.refractivity, &sources, single_material, |m| {
            unorm8(material(m).optics_at(material(m).colour[3]).1)
        }),
        ior: gather(&a.ior, &sources, single_material, |m| {
            ior_encode(material(m).ior)
        }),
    };
    Octree {
        root: surface.root,
        depth,
        nodes,
        leaf_count: sources.len() as u32,
        attributes,
        node_attributes: Default::default(),
    }
}
