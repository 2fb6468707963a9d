//! The voxelizer: a top-down, depth-first octree build over per-node triangle lists.
//!
//! At every node the triangles are classified into children by their bounding boxes
//! (thesis Algorithm 1, [`crate::geometry::child_classify`]) and then filtered by the tests that the
//! [`Strategy`] puts at that level ([`crate::geometry::overlap`]). What a leaf becomes depends on the
//! caller: [`voxelize`] keeps each leaf's list of triangles; [`voxelize_with_attributes`]
//! (the bake) computes the leaf's attributes and contour from its triangles' parts the moment
//! it is made and keeps no list.
//!
//! The top levels split long triangle lists in parallel pieces (joined in order) and build
//! their children in parallel (rayon, feature `parallel`); the subtrees' places in the final
//! arrays are planned in child order and each is copied there in parallel, so the output is
//! identical whatever the thread count. Below those levels a task
//! recurses sequentially, reusing one scratch list per level, so memory stays proportional to
//! the triangles on the current path plus the output. In the default strategy the last five
//! levels are built in one go per 32^3 block instead of recursing ([`crate::voxelize::scatter`],
//! `docs/algorithms.md`).

use crate::attributes::leaf_attributes::{AttributeInputs, LeafValues};
use crate::attributes::surface_sums::{BakeSums, NodeValue, SurfaceSums};
use crate::geometry::child_classify::{child_cell, child_offset, classify_children};
use crate::geometry::grid::closed_cells;
use crate::geometry::overlap::{
    decide, edges_overlap, plane_tolerance, triangle_box_overlap, verdict,
};
use crate::geometry::triangle_setup::GridTriangle;
use crate::octree::layout::{Chunk, LeafStore, Record, Sums, children_sums};
use crate::octree::tree::Node;
use crate::voxelize::scatter::{
    SCATTER_LEVELS, ScatterScratch, clip_contacts, scatter_pairs, scatter_sliced,
};
use crate::voxelize::strategy::Strategy;
use glam::DVec3;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Levels (from the root) whose children may be built in parallel.
const PARALLEL_LEVELS: u8 = 3;
/// A node needs at least this many triangles for its children to be built in parallel.
const PARALLEL_MIN_TRIANGLES: usize = 64;
/// Triangles per parallel piece of a top-level split ([`split_parallel`]); lists shorter
/// than two pieces are split on one thread.
#[cfg(feature = "parallel")]
const SPLIT_CHUNK: usize = 8192;
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
    type Sums = ();
    type NodeValue = ();
    fn len(&self) -> usize {
        self.cells.len()
    }
}

/// The bake's leaves: their values, and with `S = SurfaceSums` the sums and values of the
/// inner nodes too (`S = ()`: none, and nothing spent on them).
#[derive(Debug, Default)]
pub(crate) struct Baked<S> {
    /// The leaves' values.
    pub values: LeafValues,
    sums: std::marker::PhantomData<S>,
}

impl<S: BakeSums> LeafStore for Baked<S> {
    type Sums = S;
    type NodeValue = S::Value;
    fn len(&self) -> usize {
        self.values.len()
    }
}

/// What the voxelizer makes of leaves: how a leaf is stored from a triangle list (the
/// recursion's last level), how the bottom levels are scattered, and how parts are joined.
trait LeafSink: LeafStore + Sized {
    /// Appends the leaf at `cell` touched by the triangles of `list`; returns its sums.
    fn push_list(
        &mut self,
        ctx: &Ctx<'_>,
        cell: [u32; 3],
        list: &[u32],
        scratch: &mut Scratch,
    ) -> Self::Sums;
    /// The value of a node whose children's sums added up to `sums` (which it completes).
    fn node_value(ctx: &Ctx<'_>, sums: &mut Self::Sums) -> Self::NodeValue;
    /// Builds the subtree of a node of the bottom levels ([`crate::voxelize::scatter`]).
    fn scatter(
        ctx: &Ctx<'_>,
        level: u8,
        cell: [u32; 3],
        list: &[u32],
        chunk: &mut Chunk<Self>,
        scratch: &mut ScatterScratch,
        tests: &mut u64,
    ) -> Option<Record<Self>>;
    /// The leaves of `parts`, one after the other (each array reserved once at its full
    /// length, so no element is copied twice).
    fn concat(parts: Vec<Self>) -> Self;
}

impl LeafSink for LeafTriangles {
    fn push_list(&mut self, _: &Ctx<'_>, cell: [u32; 3], list: &[u32], _: &mut Scratch) {
        self.cells.push(cell);
        self.tris.extend_from_slice(list);
        self.ends.push(self.tris.len() as u64);
    }

    fn node_value(_: &Ctx<'_>, _: &mut ()) {}

    fn scatter(
        ctx: &Ctx<'_>,
        level: u8,
        cell: [u32; 3],
        list: &[u32],
        chunk: &mut Chunk<Self>,
        scratch: &mut ScatterScratch,
        tests: &mut u64,
    ) -> Option<Record<Self>> {
        scatter_pairs(ctx, level, cell, list, chunk, scratch, tests)
    }

    fn concat(mut parts: Vec<Self>) -> Self {
        let sum = |f: fn(&Self) -> usize| parts.iter().map(f).sum::<usize>();
        let mut cells = Vec::with_capacity(sum(|p| p.cells.len()));
        let mut ends = Vec::with_capacity(sum(|p| p.ends.len()));
        let mut tris = Vec::with_capacity(sum(|p| p.tris.len()));
        // Each array of a part is freed as it is copied (at most one array is held twice).
        for p in &mut parts {
            cells.extend_from_slice(&std::mem::take(&mut p.cells));
        }
        for p in &mut parts {
            let off = tris.len() as u64;
            ends.extend(std::mem::take(&mut p.ends).iter().map(|e| e + off));
            tris.extend_from_slice(&std::mem::take(&mut p.tris));
        }
        Self { cells, ends, tris }
    }
}

impl<S: BakeSums> LeafSink for Baked<S> {
    fn push_list(
        &mut self,
        ctx: &Ctx<'_>,
        cell: [u32; 3],
        list: &[u32],
        scratch: &mut Scratch,
    ) -> S {
        let t0 = Instant::now();
        let values = &mut self.values;
        let inputs = ctx
            .attributes
            .expect("the bake's voxelizer has attribute inputs");
        let m = DVec3::new(f64::from(cell[0]), f64::from(cell[1]), f64::from(cell[2]));
        if !ctx.strategy.is_exact()
            && !list
                .iter()
                .any(|&t| triangle_box_overlap(&ctx.tris[t as usize], m, 1.0))
        {
            values.false_positives += 1;
        }
        let (contacts, pts) = scratch.scatter.contact_buffers();
        clip_contacts(ctx.tris, cell, list, contacts, pts);
        let sums = inputs.push_leaf(values, m, contacts, 0, pts);
        let t1 = Instant::now();
        if inputs.wants_contour() {
            values.fit_contours(contacts, pts);
        }
        values.t_attributes += t1 - t0;
        values.t_contours += t1.elapsed();
        S::of_leaf(sums)
    }

    fn node_value(ctx: &Ctx<'_>, sums: &mut S) -> S::Value {
        let inputs = ctx
            .attributes
            .expect("the bake's voxelizer has attribute inputs");
        S::value(inputs, sums)
    }

    fn scatter(
        ctx: &Ctx<'_>,
        level: u8,
        cell: [u32; 3],
        list: &[u32],
        chunk: &mut Chunk<Self>,
        scratch: &mut ScatterScratch,
        tests: &mut u64,
    ) -> Option<Record<Self>> {
        scatter_sliced(ctx, level, cell, list, chunk, scratch, tests)
    }

    fn concat(parts: Vec<Self>) -> Self {
        Self {
            values: LeafValues::concat(parts.into_iter().map(|p| p.values).collect()),
            sums: std::marker::PhantomData,
        }
    }
}

/// Per-task reusable buffers: one set of child lists per level, and the scatter's buffers
/// (whose contact buffers also serve leaves made by the recursion).
struct Scratch {
    lists: Vec<[Vec<u32>; 8]>,
    scatter: ScatterScratch,
}

/// Where a triangle's bounds sit in the tree, for [`split`]'s shortcut: the lowest cell of
/// its closed bounds (`[a, b]` per axis: the cells `i` with `i <= hi` and `i + 1 >= lo`)
/// and `limit`, the number of levels from the root at which `a` and `b` fall in the same
/// child. At the levels `0..limit` the bounds lie strictly inside one child (they do not
/// reach its faces: a bound on a face would put a cell of the neighbour in `[a, b]`), which
/// is the child that the bounds classification ([`classify_children`]) names; the triangle
/// then lies in that child.
#[derive(Clone, Copy, Debug, Default)]
struct Home {
    a: [u32; 3],
    limit: u8,
}

impl Home {
    /// The home of a triangle with bounds `t_lo..t_hi` in a tree of `depth` levels (`limit`
    /// 0, no shortcut, for bounds that leave the root or are not finite).
    fn of(t_lo: DVec3, t_hi: DVec3, depth: u8) -> Self {
        let n = 1u64 << depth;
        let mut a = [0u32; 3];
        let mut diff = 0u64;
        for (axis, a) in a.iter_mut().enumerate() {
            let (lo, hi) = (t_lo[axis], t_hi[axis]);
            // `lo > 0` and `hi < n` (false for NaN): the closed range stays in the root.
            if !(lo > 0.0 && hi < n as f64 && lo <= hi) {
                return Self::default();
            }
            // Both in `0..n`: `lo > 0` and `hi < n`.
            let (first, last) = closed_cells(lo, hi);
            *a = first as u32;
            diff |= (first ^ last) as u64;
        }
        // `a` and `b` share the bits above their highest difference: the children at
        // levels `0..depth - bits` agree.
        let bits = 64 - diff.leading_zeros() as u8;
        Self {
            a,
            limit: depth - bits,
        }
    }

    /// The child (at the level where `bit` of the cell coordinates decides) holding the
    /// triangle; the same numbering as [`child_offset`].
    #[inline]
    fn child(self, bit: u8) -> u8 {
        let b = |v: u32| ((v >> bit) & 1) as u8;
        b(self.a[0]) << 2 | b(self.a[1]) << 1 | b(self.a[2])
    }
}

/// What every step of one voxelization reads.
pub(crate) struct Ctx<'a> {
    /// Grid-space triangles.
    pub tris: &'a [GridTriangle],
    /// Per triangle, where its bounds sit (for [`split`]).
    homes: Vec<Home>,
    /// Tree depth.
    pub depth: u8,
    strategy: Strategy,
    /// Attribute inputs, when leaves get their attributes as they are made.
    pub attributes: Option<&'a AttributeInputs<'a>>,
    progress: &'a (dyn Fn(f64) + Sync),
    done: AtomicU64,
    total: u64,
    progress_level: u8,
    /// Buffers that finished sequential tasks hand to later ones, so that a task does not
    /// grow (and fault in) its buffers from empty again.
    spare: Mutex<Vec<Scratch>>,
}

impl Ctx<'_> {
    /// Counts the progress of a whole node at `level` built in one go.
    pub(crate) fn node_done(&self, level: u8) {
        if level <= self.progress_level {
            self.advance(self.units(level));
        }
    }

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
    /// whether a vertex lies in it and what the plane test says (`Some(true)`: it surely meets
    /// the cell, `None`: within rounding; both computed for all children at once by
    /// [`split`]). Above the leaves a test may keep a triangle that only rounding lets
    /// through (its subtree then ends empty, or the leaves decide); at the leaves the exact
    /// strategies decide exactly.
    #[inline]
    fn keep(
        &self,
        t: &GridTriangle,
        m: DVec3,
        s: f64,
        level: u8,
        vertex: bool,
        plane_verdict: Option<bool>,
    ) -> bool {
        let leaf = level == self.depth;
        let plane = plane_verdict != Some(false);
        if leaf && self.strategy.is_exact() {
            return vertex || (plane && decide(t, m, s, plane_verdict == Some(true)));
        }
        // Here the exact strategies are above the leaves.
        match self.strategy {
            Strategy::AabbPlane | Strategy::PlaneSatLeaf => plane,
            Strategy::SatLeaf => !leaf || vertex || edges_overlap(t, m, s),
            // Measured fastest: pruning with the edge axes at every level pays for itself.
            Strategy::AabbPlaneSat | Strategy::Exact => vertex || (plane && edges_overlap(t, m, s)),
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
    // The bit of the cell coordinates that names the child at this level.
    let bit = ctx.depth - level - 1;
    for &ti in list {
        // Bounds in one child only (see [`Home`]): the triangle lies inside that child, so
        // it touches it and every strategy keeps it (a vertex is inside, and its plane
        // meets it); no test is run, and the triangle itself is not read. Most triangles of
        // the top levels take this path.
        let home = ctx.homes[ti as usize];
        if level < home.limit {
            out[usize::from(home.child(bit))].push(ti);
            continue;
        }
        let t = &ctx.tris[ti as usize];
        let mut mask = classify_children(t.lo(), t.hi(), c);
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
            let plane = verdict(dist + neg, dist + pos, tol);
            let cm = m + DVec3::new(ox, oy, oz) * h;
            tests += 1;
            if ctx.keep(t, cm, h, level + 1, vmask >> i & 1 == 1, plane) {
                out[i as usize].push(ti);
            }
        }
    }
    tests
}

/// [`split`] for the long lists of the top levels: chunks of the list split in parallel and
/// each child's lists joined in chunk order, so the lists are those of [`split`] (the root's
/// split of the dragon's 871k triangles would otherwise run on one thread while the others
/// wait).
fn split_parallel(
    ctx: &Ctx<'_>,
    level: u8,
    m: DVec3,
    s: f64,
    list: &[u32],
    out: &mut [Vec<u32>; 8],
) -> u64 {
    #[cfg(feature = "parallel")]
    if list.len() >= 2 * SPLIT_CHUNK {
        use rayon::prelude::*;
        let parts: Vec<([Vec<u32>; 8], u64)> = list
            .par_chunks(SPLIT_CHUNK)
            .map(|chunk| {
                let mut lists = <[Vec<u32>; 8]>::default();
                let tests = split(ctx, level, m, s, chunk, &mut lists);
                (lists, tests)
            })
            .collect();
        for (i, l) in out.iter_mut().enumerate() {
            l.clear();
            l.reserve(parts.iter().map(|p| p.0[i].len()).sum());
            for p in &parts {
                l.extend_from_slice(&p.0[i]);
            }
        }
        return parts.iter().map(|p| p.1).sum();
    }
    split(ctx, level, m, s, list, out)
}

/// Builds the subtree of the node at `level` with integer min corner `cell` (in units of
/// leaf cells) sequentially into `chunk`, returning its record, or `None` if it holds no leaf.
fn build_seq<L: LeafSink>(
    ctx: &Ctx<'_>,
    level: u8,
    cell: [u32; 3],
    list: &[u32],
    chunk: &mut Chunk<L>,
    scratch: &mut Scratch,
    tests: &mut u64,
) -> Option<Record<L>> {
    if ctx.strategy == Strategy::Exact && ctx.depth - level <= SCATTER_LEVELS {
        return L::scatter(ctx, level, cell, list, chunk, &mut scratch.scatter, tests);
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
        let mut sums = L::Sums::default();
        for (i, l) in lists.iter().enumerate() {
            if l.is_empty() {
                continue;
            }
            mask |= 1 << i;
            let leaf = chunk
                .leaves
                .push_list(ctx, child_cell(cell, i as u8, 1), l, scratch);
            sums.add(&leaf);
        }
        record = (mask != 0).then(|| {
            let value = L::node_value(ctx, &mut sums);
            (Chunk::<L>::leaf_parent(mask, base), sums, value)
        });
    } else {
        let mut records: [Record<L>; 8] = Default::default();
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
        record = (mask != 0).then(|| {
            let (node, mut sums) = chunk.push_children(mask, &records[..k]);
            let value = L::node_value(ctx, &mut sums);
            (node, sums, value)
        });
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
enum Part<L: LeafStore> {
    Seq(Chunk<L>, Option<Record<L>>),
    Par(Vec<(u8, Part<L>)>),
}

/// One piece of the final node array: a sequential chunk's nodes with the offsets of its
/// nodes and leaves, or the children block of a node of the parallel levels.
enum Job<V> {
    Chunk {
        nodes: Vec<Node>,
        values: Vec<V>,
        node_off: usize,
        leaf_off: usize,
    },
    Block {
        records: Vec<Node>,
        values: Vec<V>,
    },
}

/// Plans the post-order placement of a part: pushes its leaves to `leaves` (to be joined in
/// that order), its node jobs with their final offsets to `jobs`, and returns its root
/// record relocated there. `off` and `leaf_off` count the nodes and leaves placed so far.
fn plan<L: LeafSink>(
    ctx: &Ctx<'_>,
    part: Part<L>,
    jobs: &mut Vec<Job<L::NodeValue>>,
    off: &mut usize,
    leaf_off: &mut usize,
    leaves: &mut Vec<L>,
) -> Option<Record<L>> {
    match part {
        Part::Seq(chunk, rec) => {
            let (rec, sums, value) = rec?;
            let node_off = *off;
            let first_leaf = *leaf_off;
            *off += chunk.nodes.len();
            *leaf_off += chunk.leaves.len();
            leaves.push(chunk.leaves);
            jobs.push(Job::Chunk {
                nodes: chunk.nodes,
                values: chunk.values,
                node_off,
                leaf_off: first_leaf,
            });
            let rec = Chunk::<L>::relocate(rec, node_off as u32, first_leaf);
            Some((rec, sums, value))
        }
        Part::Par(children) => {
            let mut records = Vec::with_capacity(8);
            let mut mask = 0u8;
            for (i, p) in children {
                if let Some(r) = plan(ctx, p, jobs, off, leaf_off, leaves) {
                    mask |= 1 << i;
                    records.push(r);
                }
            }
            if mask == 0 {
                return None;
            }
            let mut sums = children_sums::<L>(&records);
            let value = L::node_value(ctx, &mut sums);
            // Children blocks hold their records in reverse until the final reversal.
            let start = *off;
            *off += records.len();
            jobs.push(Job::Block {
                records: records.iter().rev().map(|r| r.0).collect(),
                values: records.iter().rev().map(|r| r.2).collect(),
            });
            let node = Node {
                info: u32::from(mask),
                first: start as u32,
            };
            Some((node, sums, value))
        }
    }
}

/// Joins the parts into one chunk: the offsets are planned and the leaves joined in order
/// (the parts' arrays freed as they are copied), then every node piece is copied (and
/// relocated) into its own slice of the final array in parallel. The leaves are joined
/// before the node array is allocated, not beside its copy: side by side that measured within
/// the noise of this order, and it held both at once (12 MiB more at the peak of the bunny at
/// depth 10).
fn assemble<L: LeafSink>(ctx: &Ctx<'_>, part: Part<L>) -> (Chunk<L>, Option<Record<L>>) {
    let mut jobs = Vec::new();
    let (mut off, mut leaf_off) = (0, 0);
    let mut parts = Vec::new();
    let root = plan(ctx, part, &mut jobs, &mut off, &mut leaf_off, &mut parts);
    let leaves = L::concat(parts);
    let mut nodes = vec![Node::default(); off];
    let mut values = vec![L::NodeValue::default(); off];
    let (mut rest, mut rest_values) = (&mut nodes[..], &mut values[..]);
    let mut tasks = Vec::with_capacity(jobs.len());
    for job in jobs {
        let n = match &job {
            Job::Chunk { nodes, .. } => nodes.len(),
            Job::Block { records, .. } => records.len(),
        };
        let (dst, r) = std::mem::take(&mut rest).split_at_mut(n);
        let (dst_values, rv) = std::mem::take(&mut rest_values).split_at_mut(n);
        (rest, rest_values) = (r, rv);
        tasks.push((job, dst, dst_values));
    }
    type Task<'a, V> = (Job<V>, &'a mut [Node], &'a mut [V]);
    let copy = |(job, dst, dst_values): Task<'_, L::NodeValue>| match job {
        Job::Chunk {
            nodes,
            values,
            node_off,
            leaf_off,
        } => {
            for (d, s) in dst.iter_mut().zip(&nodes) {
                *d = Chunk::<L>::relocate(*s, node_off as u32, leaf_off);
            }
            dst_values.copy_from_slice(&values);
        }
        Job::Block { records, values } => {
            dst.copy_from_slice(&records);
            dst_values.copy_from_slice(&values);
        }
    };
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        tasks.into_par_iter().for_each(copy);
    }
    #[cfg(not(feature = "parallel"))]
    tasks.into_iter().for_each(copy);
    (
        Chunk {
            nodes,
            values,
            leaves,
        },
        root,
    )
}

/// Builds the subtree of a node, in parallel over children at the top levels.
fn build_node<L: LeafSink>(
    ctx: &Ctx<'_>,
    level: u8,
    cell: [u32; 3],
    list: &[u32],
) -> (Part<L>, u64) {
    let parallel = cfg!(feature = "parallel")
        && level < PARALLEL_LEVELS
        && level + 2 < ctx.depth
        && list.len() >= PARALLEL_MIN_TRIANGLES;
    if !parallel {
        let mut chunk = Chunk::new();
        let spare = ctx.spare.lock().ok().and_then(|mut s| s.pop());
        let mut scratch = spare.unwrap_or_else(|| Scratch {
            lists: vec![<[Vec<u32>; 8]>::default(); usize::from(ctx.depth)],
            scatter: ScatterScratch::default(),
        });
        let mut tests = 0;
        let rec = build_seq(ctx, level, cell, list, &mut chunk, &mut scratch, &mut tests);
        if let Ok(mut s) = ctx.spare.lock() {
            s.push(scratch);
        }
        return (Part::Seq(chunk, rec), tests);
    }
    let s = f64::from(1u32 << (ctx.depth - level));
    let m = DVec3::new(f64::from(cell[0]), f64::from(cell[1]), f64::from(cell[2]));
    let mut lists = <[Vec<u32>; 8]>::default();
    let mut tests = split_parallel(ctx, level, m, s, list, &mut lists);
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
        Some(build_node::<L>(ctx, level + 1, child, l))
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

/// The context of one voxelization, and the triangles that take part in it (those whose
/// bounds touch the root: all of them for a mesh's own root).
fn context<'a>(
    tris: &'a [GridTriangle],
    depth: u8,
    strategy: Strategy,
    attributes: Option<&'a AttributeInputs<'a>>,
    progress: &'a (dyn Fn(f64) + Sync),
) -> (Ctx<'a>, Vec<u32>) {
    assert!(
        (1..=crate::MAX_DEPTH).contains(&depth),
        "depth {depth} out of range"
    );
    let progress_level = PROGRESS_LEVEL.min(depth - 1);
    let side = f64::from(1u32 << depth);
    let home = |t: &GridTriangle| {
        let (lo, hi) = (t.lo(), t.hi());
        let inside = lo.cmple(DVec3::splat(side)).all() && hi.cmpge(DVec3::ZERO).all();
        (Home::of(lo, hi, depth), inside)
    };
    #[cfg(feature = "parallel")]
    let (homes, inside): (Vec<Home>, Vec<bool>) = {
        use rayon::prelude::*;
        tris.par_iter().map(home).unzip()
    };
    #[cfg(not(feature = "parallel"))]
    let (homes, inside): (Vec<Home>, Vec<bool>) = tris.iter().map(home).unzip();
    let all: Vec<u32> = (0..tris.len() as u32)
        .filter(|&i| inside[i as usize])
        .collect();
    let ctx = Ctx {
        tris,
        homes,
        depth,
        strategy,
        attributes,
        progress,
        done: AtomicU64::new(0),
        total: 8u64.pow(u32::from(progress_level)),
        progress_level,
        spare: Mutex::new(Vec::new()),
    };
    (ctx, all)
}

/// Runs the voxelizer with leaves of type `L`: the nodes, their values, the leaves and the
/// number of tests.
fn build<L: LeafSink>(
    tris: &[GridTriangle],
    depth: u8,
    strategy: Strategy,
    attributes: Option<&AttributeInputs<'_>>,
    progress: &(dyn Fn(f64) + Sync),
) -> (Vec<Node>, Vec<L::NodeValue>, L, u64) {
    let (ctx, all) = context(tris, depth, strategy, attributes, progress);
    let (part, tests) = build_node::<L>(&ctx, 0, [0, 0, 0], &all);
    let (chunk, root) = match part {
        Part::Seq(chunk, root) => (chunk, root),
        par => assemble(&ctx, par),
    };
    let (nodes, values, leaves) = chunk.finish(root);
    (nodes, values, leaves, tests)
}

#[cfg(feature = "io")]
/// The subtree of one node at the parts' level, as [`voxelize_subtrees`] makes it.
#[derive(Debug)]
pub(crate) struct Subtree<S: BakeSums> {
    /// The node's Morton code among the nodes of its level: its child index at each level
    /// from the root, three bits a level, the root's first (the order of the leaves).
    pub code: u64,
    /// The subtree's nodes in the file's order with the node first: the same records, in the
    /// same order, as the whole tree's bake holds below the node, indexed from the node.
    pub nodes: Vec<Node>,
    /// Each node's value (none with `S = ()`), at its node's index.
    pub values: Vec<S::Value>,
    /// The node's sums, as its record carries them to its parent.
    pub sums: S,
    /// Its leaves' values, in leaf order.
    pub leaves: LeafValues,
}

#[cfg(feature = "io")]
/// The lowest level whose subtrees [`voxelize_subtrees`] builds exactly as the whole tree's
/// bake does: above it, no node builds its bottom levels in one go
/// ([`crate::voxelize::scatter`]), so every node down to it is split as in the whole bake.
pub(crate) fn deepest_part_level(depth: u8) -> u8 {
    depth.saturating_sub(SCATTER_LEVELS)
}

#[cfg(feature = "io")]
/// Voxelizes like [`voxelize_with_attributes`], but only the subtrees of the nodes at `level`
/// whose Morton codes lie in `codes`: each holds the records and leaves that the whole bake
/// holds below that node, bit for bit (its triangle list is split down to it exactly as the
/// whole bake splits it, and it is built by the same code), for `level` at most
/// [`deepest_part_level`]. Empty subtrees are left out; the others come in code order. Also
/// returns the number of overlap tests run below `level`.
pub(crate) fn voxelize_subtrees<S: BakeSums>(
    inputs: &AttributeInputs<'_>,
    depth: u8,
    strategy: Strategy,
    level: u8,
    codes: std::ops::Range<u64>,
) -> (Vec<Subtree<S>>, u64) {
    assert!(
        level <= deepest_part_level(depth),
        "parts level {level} too deep for depth {depth}"
    );
    let (ctx, all) = context(inputs.triangles(), depth, strategy, Some(inputs), &|_| {});
    let mut lists = Vec::new();
    // The tests above `level` depend on which triangles the caller set up, so they are not
    // counted: a subtree's count is the same however its part was baked.
    lists_at(&ctx, 0, [0, 0, 0], 0, all, level, &codes, &mut lists);
    let build = |(code, cell, list): (u64, [u32; 3], Vec<u32>)| {
        let (part, tests) = build_node::<Baked<S>>(&ctx, level, cell, &list);
        drop(list);
        let (chunk, root) = match part {
            Part::Seq(chunk, root) => (chunk, root),
            par => assemble(&ctx, par),
        };
        let root = root?;
        let sums = root.1;
        let (nodes, values, Baked { values: leaves, .. }) = chunk.finish(Some(root));
        Some((
            Subtree {
                code,
                nodes,
                values,
                sums,
                leaves,
            },
            tests,
        ))
    };
    #[cfg(feature = "parallel")]
    let built: Vec<_> = {
        use rayon::prelude::*;
        lists.into_par_iter().map(build).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let built: Vec<_> = lists.into_iter().map(build).collect();
    let mut total = 0;
    let subtrees = built
        .into_iter()
        .flatten()
        .map(|(s, t)| {
            total += t;
            s
        })
        .collect();
    (subtrees, total)
}

#[cfg(feature = "io")]
/// Splits `list` (the triangles of the node at `level`, min corner `cell`, Morton code
/// `code`) down to `target`, as the whole bake splits it, and appends the non-empty lists of
/// the nodes there whose codes lie in `codes`.
#[allow(clippy::too_many_arguments)]
fn lists_at(
    ctx: &Ctx<'_>,
    level: u8,
    cell: [u32; 3],
    code: u64,
    list: Vec<u32>,
    target: u8,
    codes: &std::ops::Range<u64>,
    out: &mut Vec<(u64, [u32; 3], Vec<u32>)>,
) {
    let shift = 3 * u32::from(target - level);
    let (lo, hi) = (code << shift, (code + 1) << shift);
    if list.is_empty() || hi <= codes.start || codes.end <= lo {
        return;
    }
    if level == target {
        out.push((code, cell, list));
        return;
    }
    let s = f64::from(1u32 << (ctx.depth - level));
    let m = DVec3::new(f64::from(cell[0]), f64::from(cell[1]), f64::from(cell[2]));
    let mut lists = <[Vec<u32>; 8]>::default();
    split_parallel(ctx, level, m, s, &list, &mut lists);
    drop(list);
    let half = 1u32 << (ctx.depth - level - 1);
    for (i, l) in lists.into_iter().enumerate() {
        let child = child_cell(cell, i as u8, half);
        lists_at(
            ctx,
            level + 1,
            child,
            code << 3 | i as u64,
            l,
            target,
            codes,
            out,
        );
    }
}

/// Voxelizes grid-space triangles into an octree of `depth` levels (`1..=`[`crate::MAX_DEPTH`])
/// whose root is `[0, 2^depth]^3`, keeping each leaf's list of triangles (in leaf order).
/// `progress` receives the fraction of the root's volume done.
pub(crate) fn voxelize(
    tris: &[GridTriangle],
    depth: u8,
    strategy: Strategy,
    progress: &(dyn Fn(f64) + Sync),
) -> LeafTriangles {
    build::<LeafTriangles>(tris, depth, strategy, None, progress).2
}

/// Voxelizes like [`voxelize`] and computes each leaf's attributes as it is made (the
/// bake's path): no list of triangles per leaf is kept. The triangles are `inputs`'s.
/// With `nodes`, each record carries its subtree's [`SurfaceSums`] up the build and every
/// node gets its encoded attributes. Returns the nodes, their encoded attributes (none without
/// `nodes`), the leaves' values and the number of overlap tests run.
pub(crate) fn voxelize_with_attributes(
    inputs: &AttributeInputs<'_>,
    depth: u8,
    strategy: Strategy,
    nodes: bool,
    progress: &(dyn Fn(f64) + Sync),
) -> (Vec<Node>, Vec<NodeValue>, LeafValues, u64) {
    let tris = inputs.triangles();
    if nodes {
        let (nodes, values, leaves, tests) =
            build::<Baked<SurfaceSums>>(tris, depth, strategy, Some(inputs), progress);
        (nodes, values, leaves.values, tests)
    } else {
        let (nodes, _, leaves, tests) =
            build::<Baked<()>>(tris, depth, strategy, Some(inputs), progress);
        (nodes, Vec::new(), leaves.values, tests)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Home`'s shortcut holds exactly where the bounds lie strictly inside one child: on
    /// random triangles whose coordinates are often grid values (bounds on node faces) or
    /// within a hair of them.
    #[test]
    fn home_names_the_only_child_the_bounds_reach() {
        const D: u8 = 5;
        let side = f64::from(1u32 << D);
        let mut rnd = svo_tests::seeds::xorshift(0x2545_f491_4f6c_dd1d);
        // A coordinate near `base` from the random word `r`.
        let coord = |r: u64, base: f64| -> f64 {
            let k = (r >> 8) % 4;
            let v = match r % 5 {
                0 => base.floor(),
                1 => base.floor() + 0.5,
                2 => base.floor() + [1e-12, -1e-12, 1e-9, -1e-9][k as usize],
                _ => base + ((r >> 16) % 1000) as f64 / 1000.0 * 3.0 - 1.5,
            };
            v.clamp(0.0, side)
        };
        let (mut shortcuts, mut tight) = (0, 0);
        for _ in 0..20_000 {
            let c = [0, 1, 2].map(|_| (rnd() % 33) as f64);
            let v = [0, 1, 2]
                .map(|_| DVec3::new(coord(rnd(), c[0]), coord(rnd(), c[1]), coord(rnd(), c[2])));
            let t = GridTriangle::new(v[0], v[1], v[2]);
            let home = Home::of(t.lo(), t.hi(), D);
            for level in 0..D {
                let s = 1u32 << (D - level);
                let node = home.a.map(|x| x / s * s);
                let m = DVec3::new(f64::from(node[0]), f64::from(node[1]), f64::from(node[2]));
                let h = f64::from(s / 2);
                if level < home.limit {
                    shortcuts += 1;
                    let i = home.child(D - level - 1);
                    assert_eq!(
                        classify_children(t.lo(), t.hi(), m + DVec3::splat(h)),
                        1 << i
                    );
                    // Strictly inside the child: no other node at that level is reached.
                    let o = child_offset(i);
                    let cm = m + DVec3::new(f64::from(o[0]), f64::from(o[1]), f64::from(o[2])) * h;
                    assert!(t.lo().cmpgt(cm).all() && t.hi().cmplt(cm + DVec3::splat(h)).all());
                } else if level == home.limit && home.limit > 0 {
                    // The first level without the shortcut: the bounds reach two children
                    // of this node, or a child's face.
                    tight += 1;
                    let c = m + DVec3::splat(h);
                    let mask = classify_children(t.lo(), t.hi(), c);
                    let one = mask.is_power_of_two() && {
                        let o = child_offset(mask.trailing_zeros() as u8);
                        let cm =
                            m + DVec3::new(f64::from(o[0]), f64::from(o[1]), f64::from(o[2])) * h;
                        t.lo().cmpgt(cm).all() && t.hi().cmplt(cm + DVec3::splat(h)).all()
                    };
                    assert!(
                        !one,
                        "the shortcut stops too early for {t:?} at level {level}"
                    );
                }
            }
        }
        assert!(shortcuts > 10_000 && tight > 1_000, "{shortcuts} {tight}");
    }
}
