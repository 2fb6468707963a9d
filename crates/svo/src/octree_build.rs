//! The voxelizer: a top-down, depth-first octree build over per-node triangle lists.
//!
//! At every node the triangles are classified into children by their bounding boxes
//! (thesis Algorithm 1, [`crate::child_classify`]) and then filtered by the tests that the
//! [`Strategy`] puts at that level ([`crate::overlap`]). Leaves keep the list of triangles
//! that touch them, which the attribute and contour passes use.
//!
//! The top levels build their children in parallel (rayon, feature `parallel`); the subtrees'
//! places in the final arrays are planned in child order and each is copied there in
//! parallel, so the output is identical whatever the thread count. Below those levels a task
//! recurses sequentially, reusing one scratch list per level, so memory stays proportional to
//! the triangles on the current path plus the output. In the default strategy the last three
//! levels are built by scattering triangles into cells instead of recursing (`docs/algorithms.md`).

use crate::child_classify::{child_cell, child_offset, classify_children};
use crate::octree::Node;
use crate::octree_layout::{Chunk, LeafStore};
use crate::overlap::{edge_interval, edges_overlap, plane_tolerance, vertex_inside};
use crate::strategy::Strategy;
use crate::triangle_setup::GridTriangle;
use glam::DVec3;
use std::sync::atomic::{AtomicU64, Ordering};

/// Levels (from the root) whose children may be built in parallel.
const PARALLEL_LEVELS: u8 = 3;
/// A node needs at least this many triangles for its children to be built in parallel.
const PARALLEL_MIN_TRIANGLES: usize = 64;
/// Progress is counted in units of the volume of a node at this level.
const PROGRESS_LEVEL: u8 = 3;

/// Leaves as the voxelizer makes them: integer cells and the triangles touching each.
#[derive(Debug, Default, Clone)]
pub struct LeafTriangles {
    /// Integer cell coordinates per leaf.
    pub cells: Vec<[u32; 3]>,
    /// Per leaf, the end of its triangle list in `tris` (the start is the previous end).
    pub ends: Vec<u64>,
    /// Triangle indices, leaf after leaf.
    pub tris: Vec<u32>,
}

impl LeafTriangles {
    /// The triangles touching leaf `i`.
    pub fn triangles(&self, i: usize) -> &[u32] {
        let start = if i == 0 { 0 } else { self.ends[i - 1] as usize };
        &self.tris[start..self.ends[i] as usize]
    }
}

impl LeafStore for LeafTriangles {
    fn len(&self) -> usize {
        self.cells.len()
    }
}

/// The voxelizer's output: the node layout and the leaves with their triangles.
#[derive(Debug, Default)]
pub struct Voxelized {
    /// Packed nodes, root first.
    pub nodes: Vec<Node>,
    /// Leaves in leaf-array order.
    pub leaves: LeafTriangles,
    /// Triangle/cell overlap tests run (all levels), for the reports.
    pub tests: u64,
}

/// Per-task reusable buffers: one set of child lists per level, and the scatter pairs.
struct Scratch {
    lists: Vec<[Vec<u32>; 8]>,
    pairs: Vec<(u16, u32)>,
}

struct Ctx<'a> {
    tris: &'a [GridTriangle],
    depth: u8,
    strategy: Strategy,
    progress: &'a (dyn Fn(f64) + Sync),
    done: AtomicU64,
    total: u64,
    progress_level: u8,
}

impl Ctx<'_> {
    fn advance(&self, units: u64) {
        let d = self.done.fetch_add(units, Ordering::Relaxed) + units;
        (self.progress)(d as f64 / self.total as f64);
    }

    /// Progress units that a node at `level` stands for.
    fn units(&self, level: u8) -> u64 {
        if level > self.progress_level {
            0
        } else {
            8u64.pow(u32::from(self.progress_level - level))
        }
    }

    /// Whether triangle `t` survives into the child cell `[m, m + s]` at `level`, given
    /// whether a vertex lies in it and whether its plane meets it (both computed for all
    /// children at once by [`split`]).
    #[inline]
    fn keep(
        &self,
        t: &GridTriangle,
        m: DVec3,
        s: f64,
        level: u8,
        vertex: bool,
        plane: bool,
    ) -> bool {
        let leaf = level == self.depth;
        match self.strategy {
            Strategy::AabbPlane => plane,
            Strategy::AabbPlaneSat => vertex || (plane && edges_overlap(t, m, s)),
            Strategy::SatLeaf => !leaf || vertex || edges_overlap(t, m, s),
            Strategy::PlaneSatLeaf => {
                if leaf {
                    vertex || (plane && edges_overlap(t, m, s))
                } else {
                    plane
                }
            }
            // Measured fastest: pruning with the edge axes at every level pays for itself.
            Strategy::Exact => vertex || (plane && edges_overlap(t, m, s)),
        }
    }
}

/// Splits `list` (triangles overlapping the node at `level` with min corner `m`, side `s`)
/// into the 8 children's lists. Returns the number of tests run.
fn split(ctx: &Ctx<'_>, level: u8, m: DVec3, s: f64, list: &[u32], out: &mut [Vec<u32>; 8]) -> u64 {
    for l in out.iter_mut() {
        l.clear();
    }
    let h = 0.5 * s;
    let c = m + DVec3::splat(h);
    let hi = m + DVec3::splat(s);
    let mut tests = 0u64;
    for &ti in list {
        let t = &ctx.tris[ti as usize];
        let mut mask = classify_children(t.lo, t.hi, c);
        // Children holding a vertex (closed cells): each vertex inside the node is in the
        // children its own point-box classification names.
        let mut vmask = 0u8;
        for v in &t.v {
            if v.cmpge(m).all() && v.cmple(hi).all() {
                vmask |= classify_children(*v, *v, c);
            }
        }
        // Plane test for every child from one dot product: a child's min corner is
        // `m + h o`, so its signed distance differs from the node's by `h (n . o)`. The
        // tolerance bounds the rounding for all children (see `overlap::plane_overlaps`).
        let n = t.n;
        let d = m - t.v[0];
        let base = n.dot(d);
        let hn = n * h;
        let pos = hn.x.max(0.0) + hn.y.max(0.0) + hn.z.max(0.0);
        let neg = hn.x.min(0.0) + hn.y.min(0.0) + hn.z.min(0.0);
        // Child corners are within `3h` of the node's, and a child spans `3h` more.
        let tol = plane_tolerance(t, d.x.abs() + d.y.abs() + d.z.abs() + 6.0 * h);
        while mask != 0 {
            let i = mask.trailing_zeros() as u8;
            mask &= mask - 1;
            let o = child_offset(i);
            let (ox, oy, oz) = (f64::from(o[0]), f64::from(o[1]), f64::from(o[2]));
            let dist = base + hn.x * ox + hn.y * oy + hn.z * oz;
            let plane = dist + neg <= tol && dist + pos >= -tol;
            let cm = m + DVec3::new(ox, oy, oz) * h;
            tests += 1;
            if ctx.keep(t, cm, h, level + 1, vmask >> i & 1 == 1, plane) {
                out[i as usize].push(ti);
            }
        }
    }
    tests
}

/// Levels above the leaves below which the default strategy scatters triangles into cells
/// instead of recursing (see [`scatter`]).
const SCATTER_LEVELS: u8 = 3;

/// The default strategy's bottom levels: for a node of at most `2^SCATTER_LEVELS` cells per
/// axis, every triangle enumerates the cells of its bounding box inside the node that its
/// plane crosses (per column along the normal's dominant axis) and runs on each the complete
/// test of [`crate::overlap::triangle_box_overlap`], with the plane distance and edge
/// intervals prepared once per triangle; the `(cell, triangle)` pairs are sorted by the
/// cells' Morton order and the subtree is emitted bottom-up. Same cells and lists as the
/// recursion, with far less per-node overhead.
fn scatter(
    ctx: &Ctx<'_>,
    level: u8,
    cell: [u32; 3],
    list: &[u32],
    chunk: &mut Chunk<LeafTriangles>,
    pairs: &mut Vec<(u16, u32)>,
    tests: &mut u64,
) -> Option<Node> {
    let k = ctx.depth - level;
    let n = 1i64 << k;
    let base = [i64::from(cell[0]), i64::from(cell[1]), i64::from(cell[2])];
    pairs.clear();
    let node_min = DVec3::new(base[0] as f64, base[1] as f64, base[2] as f64);
    for &ti in list {
        let t = &ctx.tris[ti as usize];
        // Closed cells: cell i meets [lo, hi] iff i <= hi and i + 1 >= lo.
        let range = |a: usize| -> (i64, i64) {
            let f = floor_i64(t.lo[a]);
            let ceil_minus_1 = if f as f64 == t.lo[a] { f - 1 } else { f };
            let lo = (ceil_minus_1 - base[a]).max(0);
            let hi = (floor_i64(t.hi[a]) - base[a]).min(n - 1);
            (lo, hi)
        };
        let ((x0, x1), (y0, y1), (z0, z1)) = (range(0), range(1), range(2));
        if x0 > x1 || y0 > y1 || z0 > z1 {
            continue;
        }
        // Plane: signed distance of a cell's min corner is `base + n . (x, y, z)`; one
        // tolerance covers every cell of the node (as in `overlap::plane_overlaps`).
        let nn = t.n;
        let d0 = node_min - t.v[0];
        let pbase = nn.dot(d0);
        let pos = nn.x.max(0.0) + nn.y.max(0.0) + nn.z.max(0.0);
        let neg = nn.x.min(0.0) + nn.y.min(0.0) + nn.z.min(0.0);
        // Cell corners are within `3n` of the node's, and a cell spans 3 more.
        let ptol = plane_tolerance(
            t,
            d0.x.abs() + d0.y.abs() + d0.z.abs() + 3.0 * n as f64 + 3.0,
        );
        // Edge axes: the triangle's interval on each, and the cell's radius on it plus the
        // rounding bound (as in `overlap::edges_overlap`).
        let mut axes = [(0.0, 0.0, 0usize, 0usize, 0.0, 0.0, 0.0); 9];
        for (i, axis) in axes.iter_mut().enumerate() {
            let (a1, a2, i1, i2, lo, hi, w) = edge_interval(t, i / 3, i % 3);
            *axis = (a1, a2, i1, i2, lo, hi, (0.5 + t.edge_tol) * w);
        }
        let test = |x: i64, y: i64, z: i64| -> bool {
            let m = node_min + DVec3::new(x as f64, y as f64, z as f64);
            vertex_inside(t, m, 1.0) || {
                let dist = pbase + nn.x * x as f64 + nn.y * y as f64 + nn.z * z as f64;
                dist + neg <= ptol && dist + pos >= -ptol && {
                    let c = m + DVec3::splat(0.5);
                    axes.iter().all(|&(a1, a2, i1, i2, lo, hi, rad)| {
                        let pc = a1 * c[i1] + a2 * c[i2];
                        lo <= pc + rad && hi >= pc - rad
                    })
                }
            }
        };
        let ranges = [(x0, x1), (y0, y1), (z0, z1)];
        // Columns along the normal's dominant axis `w`: only the cells that the plane
        // crosses in a column can touch the triangle, so the others are skipped. The range
        // is widened by a margin far above its rounding error; near-degenerate triangles,
        // whose plane is rounding noise, test their whole box.
        let na = nn.abs();
        let w = if na.x >= na.y && na.x >= na.z {
            0
        } else if na.y >= na.z {
            1
        } else {
            2
        };
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
                        // Cell i meets [lo, hi] iff i <= hi and i + 1 >= lo.
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
                    if test(p[0], p[1], p[2]) {
                        pairs.push((morton_local(p[0] as u32, p[1] as u32, p[2] as u32, k), ti));
                    }
                }
            }
        }
    }
    // Triangles stay in list order within a cell: a stable sort by cell.
    pairs.sort_by_key(|p| p.0);
    if level <= ctx.progress_level {
        ctx.advance(ctx.units(level));
    }
    emit_sorted(pairs, k, 0, cell, chunk)
}

/// `floor` as an integer without a libm call (baseline x86-64 has no rounding
/// instruction); `x` is a finite grid coordinate far below `2^62`.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t - i64::from((t as f64) > x)
}

/// Interleaves the low `k` bits of local cell coordinates into a Morton index (x highest).
#[inline]
fn morton_local(x: u32, y: u32, z: u32, k: u8) -> u16 {
    let mut m = 0u32;
    for b in (0..u32::from(k)).rev() {
        m = m << 3 | ((x >> b) & 1) << 2 | ((y >> b) & 1) << 1 | ((z >> b) & 1);
    }
    m as u16
}

/// Emits the subtree of sorted `(morton, triangle)` pairs of a node `k` levels above the
/// leaves (`k - depth_below` at this call), with min corner `cell`.
fn emit_sorted(
    pairs: &[(u16, u32)],
    k: u8,
    done: u8,
    cell: [u32; 3],
    chunk: &mut Chunk<LeafTriangles>,
) -> Option<Node> {
    if pairs.is_empty() {
        return None;
    }
    let below = k - done; // levels from this node to the leaves
    let shift = 3 * u32::from(below - 1);
    let child = |m: u16| ((u32::from(m) >> shift) & 7) as u8;
    let half = 1u32 << (below - 1);
    let mut mask = 0u8;
    if below == 1 {
        let base = chunk.leaves.len();
        let mut start = 0;
        while start < pairs.len() {
            let m = pairs[start].0;
            let end = start + pairs[start..].partition_point(|p| p.0 == m);
            let i = child(m);
            mask |= 1 << i;
            chunk.leaves.cells.push(child_cell(cell, i, 1));
            chunk
                .leaves
                .tris
                .extend(pairs[start..end].iter().map(|p| p.1));
            chunk.leaves.ends.push(chunk.leaves.tris.len() as u64);
            start = end;
        }
        return Some(Chunk::<LeafTriangles>::leaf_parent(mask, base));
    }
    let mut records = [Node::default(); 8];
    let mut count = 0;
    let mut start = 0;
    while start < pairs.len() {
        let i = child(pairs[start].0);
        let end = start + pairs[start..].partition_point(|p| child(p.0) == i);
        let c = child_cell(cell, i, half);
        if let Some(r) = emit_sorted(&pairs[start..end], k, done + 1, c, chunk) {
            mask |= 1 << i;
            records[count] = r;
            count += 1;
        }
        start = end;
    }
    (mask != 0).then(|| chunk.push_children(mask, &records[..count]))
}

/// Builds the subtree of the node at `level` with integer min corner `cell` (in units of
/// leaf cells) sequentially into `chunk`, returning its record, or `None` if it holds no leaf.
fn build_seq(
    ctx: &Ctx<'_>,
    level: u8,
    cell: [u32; 3],
    list: &[u32],
    chunk: &mut Chunk<LeafTriangles>,
    scratch: &mut Scratch,
    tests: &mut u64,
) -> Option<Node> {
    if ctx.strategy == Strategy::Exact && ctx.depth - level <= SCATTER_LEVELS {
        return scatter(ctx, level, cell, list, chunk, &mut scratch.pairs, tests);
    }
    let scratch_lists = &mut scratch.lists;
    let s = f64::from(1u32 << (ctx.depth - level));
    let m = DVec3::new(f64::from(cell[0]), f64::from(cell[1]), f64::from(cell[2]));
    let mut lists = std::mem::take(&mut scratch_lists[usize::from(level)]);
    *tests += split(ctx, level, m, s, list, &mut lists);
    let half = 1u32 << (ctx.depth - level - 1);
    let mut mask = 0u8;
    let record;
    if level + 1 == ctx.depth {
        let base = chunk.leaves.len();
        for (i, l) in lists.iter().enumerate() {
            if l.is_empty() {
                continue;
            }
            mask |= 1 << i;
            chunk.leaves.cells.push(child_cell(cell, i as u8, 1));
            chunk.leaves.tris.extend_from_slice(l);
            chunk.leaves.ends.push(chunk.leaves.tris.len() as u64);
        }
        record = (mask != 0).then(|| Chunk::<LeafTriangles>::leaf_parent(mask, base));
    } else {
        let mut records = [Node::default(); 8];
        let mut k = 0;
        for (i, l) in lists.iter().enumerate() {
            let cu = ctx.units(level + 1);
            if l.is_empty() {
                if cu > 0 {
                    ctx.advance(cu);
                }
                continue;
            }
            let child = child_cell(cell, i as u8, half);
            if let Some(r) = build_seq(ctx, level + 1, child, l, chunk, scratch, tests) {
                mask |= 1 << i;
                records[k] = r;
                k += 1;
            }
        }
        record = (mask != 0).then(|| chunk.push_children(mask, &records[..k]));
    }
    scratch.lists[usize::from(level)] = lists;
    if level == ctx.progress_level {
        ctx.advance(1);
    }
    record
}

/// A subtree built by parallel tasks: a sequential chunk, or a node of the top levels
/// whose children were built independently. Assembled once at the end ([`assemble`]), so
/// the output is copied once, not once per parallel level.
enum Part {
    Seq(Chunk<LeafTriangles>, Option<Node>),
    Par(Vec<(u8, Part)>),
}

/// One piece of the final node and leaf arrays: a sequential chunk, or the children block
/// of a node of the parallel levels, with where it goes.
enum Job {
    Chunk {
        chunk: Chunk<LeafTriangles>,
        node_off: usize,
        leaf_off: usize,
        tri_off: usize,
    },
    Block {
        records: Vec<Node>,
    },
}

/// A job with its destination slices: nodes, cells, list ends, triangle references.
type Task<'a> = (
    Job,
    &'a mut [Node],
    &'a mut [[u32; 3]],
    &'a mut [u64],
    &'a mut [u32],
);

/// Plans the post-order placement of a part: pushes its jobs with their final offsets and
/// returns its root record relocated there. `off` is (nodes, leaves, triangle references).
fn plan(part: Part, jobs: &mut Vec<Job>, off: &mut (usize, usize, usize)) -> Option<Node> {
    match part {
        Part::Seq(chunk, rec) => {
            let rec = rec?;
            let (node_off, leaf_off, tri_off) = *off;
            off.0 += chunk.nodes.len();
            off.1 += chunk.leaves.cells.len();
            off.2 += chunk.leaves.tris.len();
            jobs.push(Job::Chunk {
                chunk,
                node_off,
                leaf_off,
                tri_off,
            });
            Some(Chunk::<LeafTriangles>::relocate(
                rec,
                node_off as u32,
                leaf_off,
            ))
        }
        Part::Par(children) => {
            let mut records = Vec::with_capacity(8);
            let mut mask = 0u8;
            for (i, p) in children {
                if let Some(r) = plan(p, jobs, off) {
                    mask |= 1 << i;
                    records.push(r);
                }
            }
            if mask == 0 {
                return None;
            }
            // Children blocks hold their records in reverse until the final reversal.
            let start = off.0;
            off.0 += records.len();
            records.reverse();
            jobs.push(Job::Block { records });
            Some(Node {
                info: u32::from(mask),
                first: start as u32,
            })
        }
    }
}

/// Copies the parts into one chunk: offsets are planned first, then every piece is copied
/// (and relocated) into its own slice of the final arrays in parallel.
fn assemble(part: Part) -> (Chunk<LeafTriangles>, Option<Node>) {
    let mut jobs = Vec::new();
    let mut off = (0, 0, 0);
    let root = plan(part, &mut jobs, &mut off);
    let mut out = Chunk::<LeafTriangles>::new();
    out.nodes = vec![Node::default(); off.0];
    out.leaves.cells = vec![[0; 3]; off.1];
    out.leaves.ends = vec![0; off.1];
    out.leaves.tris = vec![0; off.2];
    {
        // Split the arrays into the jobs' disjoint slices, in order.
        let (mut nodes, mut cells, mut ends, mut tris) = (
            &mut out.nodes[..],
            &mut out.leaves.cells[..],
            &mut out.leaves.ends[..],
            &mut out.leaves.tris[..],
        );
        let mut tasks = Vec::with_capacity(jobs.len());
        for job in jobs {
            let (n, l, t) = match &job {
                Job::Chunk { chunk, .. } => (
                    chunk.nodes.len(),
                    chunk.leaves.cells.len(),
                    chunk.leaves.tris.len(),
                ),
                Job::Block { records } => (records.len(), 0, 0),
            };
            let (dn, rn) = std::mem::take(&mut nodes).split_at_mut(n);
            let (dc, rc) = std::mem::take(&mut cells).split_at_mut(l);
            let (de, re) = std::mem::take(&mut ends).split_at_mut(l);
            let (dt, rt) = std::mem::take(&mut tris).split_at_mut(t);
            (nodes, cells, ends, tris) = (rn, rc, re, rt);
            tasks.push((job, dn, dc, de, dt));
        }
        let copy = |(job, dn, dc, de, dt): Task<'_>| match job {
            Job::Chunk {
                chunk,
                node_off,
                leaf_off,
                tri_off,
            } => {
                for (d, s) in dn.iter_mut().zip(&chunk.nodes) {
                    *d = Chunk::<LeafTriangles>::relocate(*s, node_off as u32, leaf_off);
                }
                dc.copy_from_slice(&chunk.leaves.cells);
                for (d, s) in de.iter_mut().zip(&chunk.leaves.ends) {
                    *d = s + tri_off as u64;
                }
                dt.copy_from_slice(&chunk.leaves.tris);
            }
            Job::Block { records } => dn.copy_from_slice(&records),
        };
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            tasks.into_par_iter().for_each(copy);
        }
        #[cfg(not(feature = "parallel"))]
        tasks.into_iter().for_each(copy);
    }
    (out, root)
}

/// Builds the subtree of a node, in parallel over children at the top levels.
fn build_node(ctx: &Ctx<'_>, level: u8, cell: [u32; 3], list: &[u32]) -> (Part, u64) {
    let parallel = cfg!(feature = "parallel")
        && level < PARALLEL_LEVELS
        && level + 2 < ctx.depth
        && list.len() >= PARALLEL_MIN_TRIANGLES;
    if !parallel {
        let mut chunk = Chunk::new();
        let mut scratch = Scratch {
            lists: vec![<[Vec<u32>; 8]>::default(); usize::from(ctx.depth)],
            pairs: Vec::new(),
        };
        let mut tests = 0;
        let rec = build_seq(ctx, level, cell, list, &mut chunk, &mut scratch, &mut tests);
        return (Part::Seq(chunk, rec), tests);
    }
    let s = f64::from(1u32 << (ctx.depth - level));
    let m = DVec3::new(f64::from(cell[0]), f64::from(cell[1]), f64::from(cell[2]));
    let mut lists = <[Vec<u32>; 8]>::default();
    let mut tests = split(ctx, level, m, s, list, &mut lists);
    let half = 1u32 << (ctx.depth - level - 1);
    for l in &lists {
        if l.is_empty() && ctx.units(level + 1) > 0 {
            ctx.advance(ctx.units(level + 1));
        }
    }
    let work = |i: usize| {
        let l = &lists[i];
        if l.is_empty() {
            return None;
        }
        let child = child_cell(cell, i as u8, half);
        Some(build_node(ctx, level + 1, child, l))
    };
    #[cfg(feature = "parallel")]
    let results: Vec<_> = {
        use rayon::prelude::*;
        (0..8).into_par_iter().map(work).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let results: Vec<_> = (0..8).map(work).collect();
    let mut children = Vec::with_capacity(8);
    for (i, r) in results.into_iter().enumerate() {
        if let Some((p, t)) = r {
            tests += t;
            children.push((i as u8, p));
        }
    }
    if level == ctx.progress_level {
        ctx.advance(1);
    }
    (Part::Par(children), tests)
}

/// Voxelizes grid-space triangles into an octree of `depth` levels (`1..=`[`crate::MAX_DEPTH`])
/// whose root is `[0, 2^depth]^3`. `progress` receives the fraction of the root's volume done.
pub fn voxelize(
    tris: &[GridTriangle],
    depth: u8,
    strategy: Strategy,
    progress: &(dyn Fn(f64) + Sync),
) -> Voxelized {
    assert!(
        (1..=crate::MAX_DEPTH).contains(&depth),
        "depth {depth} out of range"
    );
    let progress_level = PROGRESS_LEVEL.min(depth - 1);
    let ctx = Ctx {
        tris,
        depth,
        strategy,
        progress,
        done: AtomicU64::new(0),
        total: 8u64.pow(u32::from(progress_level)),
        progress_level,
    };
    // Only triangles whose bounds touch the root take part (all do for a mesh's own root).
    let side = f64::from(1u32 << depth);
    let all: Vec<u32> = (0..tris.len() as u32)
        .filter(|&i| {
            let t = &tris[i as usize];
            t.lo.cmple(DVec3::splat(side)).all() && t.hi.cmpge(DVec3::ZERO).all()
        })
        .collect();
    let (part, tests) = build_node(&ctx, 0, [0, 0, 0], &all);
    let (chunk, root) = match part {
        Part::Seq(chunk, root) => (chunk, root),
        par => assemble(par),
    };
    let (nodes, leaves) = chunk.finish(root);
    Voxelized {
        nodes,
        leaves,
        tests,
    }
}
