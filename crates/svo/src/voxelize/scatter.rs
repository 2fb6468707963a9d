//! The default strategy's bottom levels: triangles scattered into the cells of a small
//! block instead of recursing.
//!
//! A node at most `2^SCATTER_LEVELS` cells across is built in one go: every triangle of
//! its list names the cells it touches, the `(cell, triangle)` contacts are sorted by the
//! cells' Morton order, and the subtree is emitted bottom-up ((`emit_sorted`)). Two ways to
//! name the cells, with the same result:
//!
//! * [`scatter_pairs`] (the voxelizer alone): the cells of the triangle's bounding box that
//!   its plane crosses, per column along the normal's dominant axis, each decided by the
//!   complete overlap test with the plane and edge intervals prepared once per triangle
//!   ([`CellTest`]).
//! * [`scatter_sliced`] (the bake, attributes included): the triangle is sliced through the
//!   block ([`crate::geometry::grid_slice`]), which yields its part in every cell at once; those parts
//!   are the leaves' area weights and contour points (a bake without channels slices too,
//!   faster than testing each candidate, and keeps no weights). A part whose centroid is well inside
//!   its cell proves the contact; the other parts (including those slicing gives the cells
//!   that the triangle touches only on their boundary or misses by a hair) are decided by
//!   [`CellTest`], so the cells are those of [`scatter_pairs`] (tested against the brute
//!   force and against [`scatter_pairs`] on random, grid-aligned and real meshes).

use crate::attributes::leaf_attributes::Contact;
use crate::attributes::surface_sums::BakeSums;
use crate::geometry::child_classify::child_cell;
use crate::geometry::clip::clip_to_unit_cube;
use crate::geometry::exact_contact::{PLANE_AXIS, touches_exactly};
use crate::geometry::grid::{closed_cells, floor_i64};
use crate::geometry::grid_slice::{Slicer, digest_part, dominant_axis, polygon_area, well_inside};
use crate::geometry::overlap::{
    edge_axis_verdict, edge_interval, plane_tolerance, verdict, vertex_inside,
};
use crate::geometry::triangle_setup::{GridTriangle, spread3};
use crate::octree::layout::{Chunk, LeafStore, Record, Sums};
use crate::voxelize::build::{Baked, Ctx, LeafTriangles};
use glam::{DVec3, Vec3};
use std::time::Instant;

/// Levels above the leaves below which the default strategy scatters triangles into cells
/// instead of recursing.
pub(crate) const SCATTER_LEVELS: u8 = 5;

/// How far inside its cell (relative to the coordinates' magnitude) a part's vertex must be
/// to prove the contact without the exact test: far above the rounding of the slicing (a
/// few ulps per cut, nine cuts at most).
const SLICE_MARGIN: f64 = 1e-10;

/// `1 / n` for the point counts of a part (at most `CAP`, 12, in `grid_slice`; the table
/// covers twice that).
const RECIP: [f64; 32] = {
    let mut t = [0.0; 32];
    let mut i = 1;
    while i < 32 {
        t[i] = 1.0 / i as f64;
        i += 1;
    }
    t
};

/// Per-task buffers of the scatter, reused from node to node.
#[derive(Default)]
pub(crate) struct ScatterScratch {
    pairs: Vec<(u16, u32)>,
    contacts: Vec<Contact>,
    pts: Vec<Vec3>,
    sort_tmp: Vec<Contact>,
    counts: Vec<u32>,
    verify: Vec<usize>,
    slicer: Slicer,
}

impl ScatterScratch {
    /// The contact and point buffers, for a leaf made outside the scatter (the recursion's
    /// last level in the inexact strategies, [`clip_contacts`]).
    pub(crate) fn contact_buffers(&mut self) -> (&mut Vec<Contact>, &mut Vec<Vec3>) {
        (&mut self.contacts, &mut self.pts)
    }
}

/// The complete overlap test of one triangle against the unit cells of a block, with the
/// box axes (the triangle's closed cell range), the plane distance and the edge intervals
/// prepared once (the same bounds as [`crate::geometry::overlap::triangle_box_overlap`], with one plane
/// tolerance for the whole block).
pub(crate) struct CellTest<'a> {
    t: &'a GridTriangle,
    node_min: DVec3,
    /// Per axis, the local cells that the triangle's closed bounds reach (cell `i` meets
    /// `[lo, hi]` iff `i <= hi` and `i + 1 >= lo`).
    bounds: [(i64, i64); 3],
    pbase: f64,
    pos: f64,
    neg: f64,
    ptol: f64,
    axes: [(f64, f64, usize, usize, f64, f64, f64); 9],
}

impl<'a> CellTest<'a> {
    /// Prepares the test of `t` against the cells of the block of side `n` at `node_min`.
    pub(crate) fn new(t: &'a GridTriangle, node_min: DVec3, n: f64) -> Self {
        let nn = t.n;
        let d0 = node_min - t.v[0];
        let mut axes = [(0.0, 0.0, 0usize, 0usize, 0.0, 0.0, 0.0); 9];
        for (i, axis) in axes.iter_mut().enumerate() {
            let (a1, a2, i1, i2, lo, hi, w) = edge_interval(t, i / 3, i % 3);
            *axis = (a1, a2, i1, i2, lo, hi, w);
        }
        let (t_lo, t_hi) = (t.lo(), t.hi());
        let bounds = [0, 1, 2].map(|a| {
            let (first, last) = closed_cells(t_lo[a], t_hi[a]);
            // The block's corner is an integer well inside `i64`.
            let base = node_min[a] as i64;
            (first - base, last - base)
        });
        Self {
            t,
            node_min,
            bounds,
            pbase: nn.dot(d0),
            pos: nn.x.max(0.0) + nn.y.max(0.0) + nn.z.max(0.0),
            neg: nn.x.min(0.0) + nn.y.min(0.0) + nn.z.min(0.0),
            // Cell corners are within `3n` of the node's, and a cell spans 3 more.
            ptol: plane_tolerance(t, d0.x.abs() + d0.y.abs() + d0.z.abs() + 3.0 * n + 3.0),
            axes,
        }
    }

    /// Whether the triangle touches the closed unit cell at local coordinates `(x, y, z)`.
    /// (The box's own axes matter to a caller that asks about cells beyond the triangle's
    /// bounds: the slicing's tolerance can give a cell across a face a part when a vertex
    /// lies a hair beyond that face, and neither the plane nor the edge axes reject it.)
    #[inline]
    pub(crate) fn touches(&self, x: i64, y: i64, z: i64) -> bool {
        let inside = |a: usize, c: i64| self.bounds[a].0 <= c && c <= self.bounds[a].1;
        if !(inside(0, x) && inside(1, y) && inside(2, z)) {
            return false;
        }
        let t = self.t;
        let m = self.node_min + DVec3::new(x as f64, y as f64, z as f64);
        if vertex_inside(t, m, 1.0) {
            return true;
        }
        let nn = t.n;
        let dist = self.pbase + nn.x * x as f64 + nn.y * y as f64 + nn.z * z as f64;
        let plane = verdict(dist + self.neg, dist + self.pos, self.ptol);
        if plane == Some(false) {
            return false;
        }
        // The edge axes as in `overlap::edges_doubt`, with the intervals prepared once; the
        // axes left in doubt are decided exactly.
        let c = m + DVec3::splat(0.5);
        let mut doubt = if plane == Some(true) { 0 } else { PLANE_AXIS };
        for (i, &(a1, a2, i1, i2, lo, hi, w)) in self.axes.iter().enumerate() {
            let pc = a1 * c[i1] + a2 * c[i2];
            match edge_axis_verdict(lo, hi, pc, 0.5 * w, t.edge_tol * w) {
                Some(false) => return false,
                Some(true) => {}
                None => doubt |= 1 << (1 + i),
            }
        }
        doubt == 0 || touches_exactly(&t.v, m, 1.0, doubt)
    }
}

/// Calls `f` with the local coordinates of every cell of the block (side `n = 2^k` cells at
/// integer corner `base`) that `t` touches: the cells of its bounding box, per column along
/// the normal's dominant axis only those the plane crosses, each decided by [`CellTest`].
fn touched_cells(
    t: &GridTriangle,
    base: [i64; 3],
    n: i64,
    tests: &mut u64,
    f: &mut impl FnMut([i64; 3]),
) {
    let node_min = DVec3::new(base[0] as f64, base[1] as f64, base[2] as f64);
    let test = CellTest::new(t, node_min, n as f64);
    // The cells of the triangle's closed bounds (the test's box axes) within the block.
    let ranges = test
        .bounds
        .map(|(first, last)| (first.max(0), last.min(n - 1)));
    if ranges.iter().any(|r| r.0 > r.1) {
        return;
    }
    // Columns along the normal's dominant axis `w`: only the cells that the plane crosses
    // in a column can touch the triangle, so the others are skipped. The range is widened
    // by a margin far above its rounding error; near-degenerate triangles, whose plane is
    // rounding noise, test their whole box.
    let nn = t.n;
    let na = nn.abs();
    let w = dominant_axis(nn);
    let (u, v) = ((w + 1) % 3, (w + 2) % 3);
    let prune = na[w] > 1e-6 * t.n_scale && na[w].is_finite();
    // The plane's w-coordinate is `w_at(u, v) = wc - su u - sv v`; over a column
    // `[u, u + 1] x [v, v + 1]` it spans that value plus the corner offsets below.
    let (su, sv) = (nn[u] / nn[w], nn[v] / nn[w]);
    let wc = nn.dot(t.v[0]) / nn[w];
    let (off_lo, off_hi) = (
        (-su).min(0.0) + (-sv).min(0.0),
        (-su).max(0.0) + (-sv).max(0.0),
    );
    for cu in ranges[u].0..=ranges[u].1 {
        for cv in ranges[v].0..=ranges[v].1 {
            let (mut w0, mut w1) = ranges[w];
            if prune {
                let at = wc - su * (base[u] + cu) as f64 - sv * (base[v] + cv) as f64;
                let (lo, hi) = (at + off_lo, at + off_hi);
                let margin = 1e-7 * (1.0 + lo.abs().max(hi.abs()));
                if lo.is_finite() && hi.is_finite() {
                    w0 = w0.max(floor_i64(lo - margin) - base[w]);
                    w1 = w1.min(floor_i64(hi + margin) - base[w]);
                }
            }
            for cw in w0..=w1 {
                let mut p = [0i64; 3];
                p[u] = cu;
                p[v] = cv;
                p[w] = cw;
                *tests += 1;
                if test.touches(p[0], p[1], p[2]) {
                    f(p);
                }
            }
        }
    }
}

/// The block of the node at `level` with integer min corner `cell`: its side in cells
/// (`2^k`), `k`, and its corner as integers.
fn block(ctx: &Ctx<'_>, level: u8, cell: [u32; 3]) -> (i64, u8, [i64; 3]) {
    let k = ctx.depth - level;
    (
        1i64 << k,
        k,
        [i64::from(cell[0]), i64::from(cell[1]), i64::from(cell[2])],
    )
}

/// The voxelizer's bottom levels with triangle lists as leaves (see the module docs).
pub(crate) fn scatter_pairs(
    ctx: &Ctx<'_>,
    level: u8,
    cell: [u32; 3],
    list: &[u32],
    chunk: &mut Chunk<LeafTriangles>,
    scratch: &mut ScatterScratch,
    tests: &mut u64,
) -> Option<Record<LeafTriangles>> {
    let (n, k, base) = block(ctx, level, cell);
    let pairs = &mut scratch.pairs;
    pairs.clear();
    for &ti in list {
        touched_cells(&ctx.tris[ti as usize], base, n, tests, &mut |p| {
            pairs.push((morton_local(p[0] as u32, p[1] as u32, p[2] as u32, k), ti));
        });
    }
    // Triangles stay in list order within a cell: a stable sort by cell.
    pairs.sort_by_key(|p| p.0);
    ctx.node_done(level);
    emit_sorted(
        pairs,
        |p| p.0,
        k,
        0,
        cell,
        chunk,
        &mut |leaves: &mut LeafTriangles, c, run: &[(u16, u32)], _| {
            leaves.cells.push(c);
            leaves.tris.extend(run.iter().map(|p| p.1));
            leaves.ends.push(leaves.tris.len() as u64);
        },
        &|_| (),
    )
}

/// One block of the bake's bottom levels: `n` cells a side (`k` bits a local coordinate)
/// from grid cell `base`.
struct Block {
    n: i64,
    k: u8,
    base: [i64; 3],
    node_min: DVec3,
}

impl Block {
    /// The contact key (local Morton code) of the block's cell `p`.
    #[inline]
    fn key(&self, p: [i64; 3]) -> u16 {
        morton_local(p[0] as u32, p[1] as u32, p[2] as u32, self.k)
    }
}

/// The bake's bottom levels: the same cells as [`scatter_pairs`], each leaf emitted with its
/// attributes computed from the triangles' parts in it (see the module docs).
pub(crate) fn scatter_sliced<S: BakeSums>(
    ctx: &Ctx<'_>,
    level: u8,
    cell: [u32; 3],
    list: &[u32],
    chunk: &mut Chunk<Baked<S>>,
    scratch: &mut ScatterScratch,
    tests: &mut u64,
) -> Option<Record<Baked<S>>> {
    let inputs = ctx
        .attributes
        .expect("the bake's voxelizer has attribute inputs");
    let geometry = inputs.needs_geometry();
    let t0 = Instant::now();
    let (n, k, base) = block(ctx, level, cell);
    let b = Block {
        n,
        k,
        base,
        node_min: DVec3::new(base[0] as f64, base[1] as f64, base[2] as f64),
    };
    scratch.contacts.clear();
    scratch.pts.clear();
    for &ti in list {
        let t = &ctx.tris[ti as usize];
        // Exactly degenerate triangles, and those whose slicing fails, take the cell tests.
        // Without geometry the slicing still finds the cells (faster than testing each
        // candidate); its parts' areas are then not wanted.
        let unit = if geometry {
            inputs.unit_normal(ti)
        } else {
            DVec3::ZERO
        };
        let sliced = t.n != DVec3::ZERO && slice_triangle(&b, t, ti, unit, scratch, tests);
        if !sliced {
            cell_tested(
                &b,
                t,
                ti,
                geometry,
                &mut scratch.contacts,
                &mut scratch.pts,
                tests,
            );
        }
    }
    let ScatterScratch {
        contacts,
        pts,
        sort_tmp,
        counts,
        ..
    } = scratch;
    // Triangles stay in list order within a cell: a stable sort by cell.
    sort_by_cell(contacts, sort_tmp, counts, 3 * u32::from(k));
    let contacts = &*contacts;
    ctx.node_done(level);
    let t1 = Instant::now();
    let node = emit_sorted(
        contacts,
        |c| c.key,
        k,
        0,
        cell,
        chunk,
        &mut |leaves: &mut Baked<S>, c, run: &[Contact], start| {
            let cell = DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]));
            S::of_leaf(inputs.push_leaf(&mut leaves.values, cell, run, start as u32, pts))
        },
        &|sums| S::value(inputs, sums),
    );
    let t2 = Instant::now();
    let values = &mut chunk.leaves.values;
    if inputs.wants_contour() {
        values.fit_contours(contacts, pts);
    }
    let t3 = Instant::now();
    values.t_voxelize += t1 - t0;
    values.t_attributes += t2 - t1;
    values.t_contours += t3 - t2;
    node
}

/// Slices triangle `ti` (unit normal `unit`) into the block's cells and pushes a contact
/// for each part whose centroid proves it or that the exact cell test confirms. Returns
/// false, with nothing pushed, when the slicing fails (the caller then takes the cell tests).
#[inline]
fn slice_triangle(
    b: &Block,
    t: &GridTriangle,
    ti: u32,
    unit: DVec3,
    scratch: &mut ScatterScratch,
    tests: &mut u64,
) -> bool {
    let ScatterScratch {
        contacts,
        pts,
        verify,
        slicer,
        ..
    } = scratch;
    let first = contacts.len();
    let local = t.v.map(|v| v - b.node_min);
    let reach = local
        .iter()
        .fold(b.n as f64, |a, v| a.max(v.abs().max_element()));
    let eps = SLICE_MARGIN * reach;
    // The parts' areas from their projections on the plane across the unit normal's
    // dominant axis `w`: `area = fan_w / (2 |u_w|)`, with `|u_w| >= 1 / sqrt(3)`.
    // (A triangle whose normal's length underflows has no unit normal; its parts
    // take their areas from the full fan, `polygon_area`.)
    let w = dominant_axis(unit);
    let half_over = if unit == DVec3::ZERO {
        None
    } else {
        Some(0.5 / unit[w].abs())
    };
    verify.clear();
    let sliced = slicer.slice(local, b.n as u32, eps, &mut |c, part| {
        let m = DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]));
        let start = pts.len() as u32;
        let (sum, fan) = match w {
            0 => digest_part::<0>(part, m, pts),
            1 => digest_part::<1>(part, m, pts),
            _ => digest_part::<2>(part, m, pts),
        };
        // A centroid well inside the cell is within rounding of a point of the
        // triangle: the contact is proven. Other parts take the exact test.
        // (The mean by a reciprocal from a table rather than a division: rounding
        // either way is far inside `eps`, and a part that misses the proof by it
        // only takes the exact test.)
        let centroid = sum * RECIP[part.points().len()];
        if !well_inside(centroid - m, eps) {
            verify.push(contacts.len());
        }
        let area = half_over.map_or_else(|| part.area(), |h| fan.abs() * h);
        contacts.push(Contact {
            key: b.key(c.map(i64::from)),
            tri: ti,
            area,
            start,
            len: part.points().len() as u32,
        });
    });
    if !sliced {
        contacts.truncate(first);
        return false;
    }
    if !verify.is_empty() {
        let test = CellTest::new(t, b.node_min, b.n as f64);
        let mut dead = 0;
        for &i in verify.iter() {
            let c = local_cell(contacts[i].key, b.k);
            *tests += 1;
            if !test.touches(c[0], c[1], c[2]) {
                contacts[i].len = u32::MAX;
                dead += 1;
            }
        }
        if dead > 0 {
            let mut w = first;
            for r in first..contacts.len() {
                if contacts[r].len != u32::MAX {
                    contacts[w] = contacts[r];
                    w += 1;
                }
            }
            contacts.truncate(w);
        }
    }
    true
}

/// The cells of the block that triangle `ti` touches, by the cell tests, each pushed as a
/// contact (with its part clipped to the cell when the attributes need `geometry`).
#[inline]
fn cell_tested(
    b: &Block,
    t: &GridTriangle,
    ti: u32,
    geometry: bool,
    contacts: &mut Vec<Contact>,
    pts: &mut Vec<Vec3>,
    tests: &mut u64,
) {
    touched_cells(t, b.base, b.n, tests, &mut |c| {
        if !geometry {
            contacts.push(Contact {
                key: b.key(c),
                tri: ti,
                ..Contact::default()
            });
            return;
        }
        let m = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        let p = clip_to_unit_cube(t.v.map(|v| v - b.node_min - m));
        if p.len == 0 {
            push_touch(contacts, pts, t, ti, b.node_min, c, b.key(c));
            return;
        }
        contacts.push(Contact {
            key: b.key(c),
            tri: ti,
            area: p.area(),
            start: pts.len() as u32,
            len: p.len as u32,
        });
        pts.extend(p.points().iter().map(|q| q.as_vec3()));
    });
}

/// Sorts `items` by their cell key (`bits` wide) and keeps the order of equal keys (the
/// triangles' order within a cell), with `tmp` and `counts` as scratch: a counting sort by
/// the low half of the key's bits, then one by the high half (a least-significant-digit
/// radix sort). Two passes of at most `2^8` buckets cost less than one of `2^15` for the
/// few thousand contacts of a block, whose keys spread over the whole range.
fn sort_by_cell(items: &mut [Contact], tmp: &mut Vec<Contact>, counts: &mut Vec<u32>, bits: u32) {
    if tmp.len() < items.len() {
        // Every slot is written before it is read, so the buffer is only grown, never
        // refilled with defaults.
        tmp.resize(items.len(), Contact::default());
    }
    let tmp = &mut tmp[..items.len()];
    let low = bits.div_ceil(2);
    counting_pass(items, tmp, counts, 0, low);
    counting_pass(tmp, items, counts, low, bits - low);
}

/// One stable counting pass of [`sort_by_cell`]: `src` into `dst` by the key bits
/// `shift..shift + width`.
fn counting_pass(
    src: &[Contact],
    dst: &mut [Contact],
    counts: &mut Vec<u32>,
    shift: u32,
    width: u32,
) {
    let digit = |c: &Contact| (usize::from(c.key) >> shift) & ((1 << width) - 1);
    counts.clear();
    counts.resize(1 << width, 0);
    for c in src {
        counts[digit(c)] += 1;
    }
    // Exclusive prefix sums, the running total in a register (`counts[i] += counts[i - 1]`
    // waits on the previous store at every step).
    let mut run = 0;
    for n in counts.iter_mut() {
        let here = *n;
        *n = run;
        run += here;
    }
    for c in src {
        let slot = &mut counts[digit(c)];
        dst[*slot as usize] = *c;
        *slot += 1;
    }
}

/// Records a contact that slicing lost or rounding emptied (the triangle only touches the
/// cell): no area, and the triangle's vertices pulled onto the cell as its points, so the
/// contour still covers the contact.
fn push_touch(
    contacts: &mut Vec<Contact>,
    pts: &mut Vec<Vec3>,
    t: &GridTriangle,
    ti: u32,
    node_min: DVec3,
    c: [i64; 3],
    key: u16,
) {
    let m = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
    contacts.push(Contact {
        key,
        tri: ti,
        area: 0.0,
        start: pts.len() as u32,
        len: 3,
    });
    pts.extend(
        t.v.iter()
            .map(|&v| (v - node_min - m).clamp(DVec3::ZERO, DVec3::ONE).as_vec3()),
    );
}

/// The contacts of a leaf made by the recursion (the inexact strategies' last level): each
/// triangle clipped to the cell, in cell-local coordinates.
pub(crate) fn clip_contacts(
    tris: &[GridTriangle],
    cell: [u32; 3],
    list: &[u32],
    contacts: &mut Vec<Contact>,
    pts: &mut Vec<Vec3>,
) {
    let m = DVec3::new(f64::from(cell[0]), f64::from(cell[1]), f64::from(cell[2]));
    contacts.clear();
    pts.clear();
    for &ti in list {
        let t = &tris[ti as usize];
        let local = t.v.map(|v| v - m);
        let p = clip_to_unit_cube(local);
        let start = pts.len() as u32;
        let area = if p.len == 0 {
            let touch = local.map(|v| v.clamp(DVec3::ZERO, DVec3::ONE));
            pts.extend(touch.iter().map(|v| v.as_vec3()));
            polygon_area(&touch)
        } else {
            pts.extend(p.points().iter().map(|v| v.as_vec3()));
            p.area()
        };
        contacts.push(Contact {
            key: 0,
            tri: ti,
            area,
            start,
            len: pts.len() as u32 - start,
        });
    }
}

/// The local cell coordinates of a Morton key of `k` levels.
fn local_cell(key: u16, k: u8) -> [i64; 3] {
    let mut c = [0i64; 3];
    for b in 0..u32::from(k) {
        c[0] |= i64::from(key >> (3 * b + 2) & 1) << b;
        c[1] |= i64::from(key >> (3 * b + 1) & 1) << b;
        c[2] |= i64::from(key >> (3 * b) & 1) << b;
    }
    c
}

/// Interleaves the low `k` bits of local cell coordinates into a Morton index (x highest):
/// bit `b` of x goes to bit `3b + 2`, of y to `3b + 1`, of z to `3b` (the coordinates are
/// below `2^k`, `k <= SCATTER_LEVELS`, so the index fits 15 bits).
#[inline]
fn morton_local(x: u32, y: u32, z: u32, k: u8) -> u16 {
    debug_assert!(k <= SCATTER_LEVELS && (x | y | z) >> k == 0);
    // The bits of a coordinate below 32 spread three apart, by table.
    const SPREAD: [u16; 32] = {
        let mut t = [0u16; 32];
        let mut v = 0;
        while v < 32 {
            t[v] = spread3(v as u64) as u16;
            v += 1;
        }
        t
    };
    let s = |v: u32| SPREAD[(v & 31) as usize];
    s(x) << 2 | s(y) << 1 | s(z)
}

/// Emits the subtree of `items` sorted by their Morton `key`, for a node `k` levels above
/// the leaves (`k - done` at this call) with min corner `cell`. `leaf` appends one leaf
/// from its cell, its run of items and the run's start in the whole slice, and returns its
/// sums; `value` makes a node's value from its children's sums.
#[allow(clippy::too_many_arguments)]
fn emit_sorted<T, L: LeafStore>(
    items: &[T],
    key: impl Fn(&T) -> u16 + Copy,
    k: u8,
    done: u8,
    cell: [u32; 3],
    chunk: &mut Chunk<L>,
    leaf: &mut impl FnMut(&mut L, [u32; 3], &[T], usize) -> L::Sums,
    value: &impl Fn(&mut L::Sums) -> L::NodeValue,
) -> Option<Record<L>> {
    emit_at(items, 0, key, k, done, cell, chunk, leaf, value)
}

#[allow(clippy::too_many_arguments)]
fn emit_at<T, L: LeafStore>(
    items: &[T],
    offset: usize,
    key: impl Fn(&T) -> u16 + Copy,
    k: u8,
    done: u8,
    cell: [u32; 3],
    chunk: &mut Chunk<L>,
    leaf: &mut impl FnMut(&mut L, [u32; 3], &[T], usize) -> L::Sums,
    value: &impl Fn(&mut L::Sums) -> L::NodeValue,
) -> Option<Record<L>> {
    if items.is_empty() {
        return None;
    }
    let below = k - done; // levels from this node to the leaves
    let shift = 3 * u32::from(below - 1);
    let child = |m: u16| ((u32::from(m) >> shift) & 7) as u8;
    let half = 1u32 << (below - 1);
    let mut mask = 0u8;
    if below == 1 {
        let base = chunk.leaves.len();
        let mut sums = L::Sums::default();
        let mut start = 0;
        while start < items.len() {
            let m = key(&items[start]);
            // A leaf's run is short (about three contacts): a forward scan, not a search.
            let mut end = start + 1;
            while end < items.len() && key(&items[end]) == m {
                end += 1;
            }
            let i = child(m);
            mask |= 1 << i;
            let s = leaf(
                &mut chunk.leaves,
                child_cell(cell, i, 1),
                &items[start..end],
                offset + start,
            );
            sums.add(&s);
            start = end;
        }
        let v = value(&mut sums);
        return Some((Chunk::<L>::leaf_parent(mask, base), sums, v));
    }
    let mut records: [Record<L>; 8] = Default::default();
    let mut count = 0;
    let mut start = 0;
    while start < items.len() {
        let i = child(key(&items[start]));
        let end = start + items[start..].partition_point(|p| child(key(p)) == i);
        let c = child_cell(cell, i, half);
        if let Some(r) = emit_at(
            &items[start..end],
            offset + start,
            key,
            k,
            done + 1,
            c,
            chunk,
            leaf,
            value,
        ) {
            mask |= 1 << i;
            records[count] = r;
            count += 1;
        }
        start = end;
    }
    (mask != 0).then(|| {
        let (node, mut sums) = chunk.push_children(mask, &records[..count]);
        let v = value(&mut sums);
        (node, sums, v)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_keys_round_trip() {
        for k in 1..=SCATTER_LEVELS {
            let n = 1u32 << k;
            for x in 0..n {
                for y in 0..n {
                    for z in 0..n {
                        let key = morton_local(x, y, z, k);
                        assert_eq!(local_cell(key, k), [x, y, z].map(i64::from));
                    }
                }
            }
        }
    }

    #[test]
    fn the_cell_sort_is_a_stable_sort_by_key() {
        let mut rnd = svo_tests::seeds::unit_f64(0x5eed_c0de_2026_1124);
        let (mut tmp, mut counts) = (Vec::new(), Vec::new());
        for k in 1..=SCATTER_LEVELS {
            let bits = 3 * u32::from(k);
            for len in [0usize, 1, 2, 7, 100, 5000] {
                // Few distinct keys, so that equal keys are common and the order among them
                // shows.
                let distinct = 1 + (rnd() * 40.0) as u32;
                let keys: Vec<u16> = (0..distinct)
                    .map(|_| (rnd() * f64::from(1u32 << bits)) as u16)
                    .collect();
                let mut items: Vec<Contact> = (0..len)
                    .map(|i| Contact {
                        key: keys[(rnd() * f64::from(distinct)) as usize],
                        tri: i as u32,
                        ..Contact::default()
                    })
                    .collect();
                let mut want = items.clone();
                want.sort_by_key(|c| c.key);
                sort_by_cell(&mut items, &mut tmp, &mut counts, bits);
                let got: Vec<(u16, u32)> = items.iter().map(|c| (c.key, c.tri)).collect();
                let want: Vec<(u16, u32)> = want.iter().map(|c| (c.key, c.tri)).collect();
                assert_eq!(got, want, "k {k}, {len} contacts");
            }
        }
    }
}
