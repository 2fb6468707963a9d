//! One part of a planned bake ([`crate::bake::parts::plan`]): its subtrees baked exactly as the
//! whole bake bakes them, and the part file that carries them to the merge.
//!
//! A part file (`.svopart`) is, in order: the magic `\x89SVOPRT\n`, a `u32` version, the
//! header's length (`u32`) and its XXH3-64 (`u64`), the header (bincode, as the `.svo` header:
//! the plan's hash, the part's index, per subtree its Morton code, child mask, node and leaf
//! counts, per channel how it is stored, and per array its offset, length and XXH3-64), then
//! the arrays, each at a multiple of 8 bytes: the subtrees' nodes in the order the merged file
//! places them (the highest code first; pointers counted from the subtree's first node, leaf
//! bases from the part's first leaf), then each per-leaf channel's values for the part's
//! leaves in Morton order. A part of a bake with inner-node attributes stores its nodes level
//! by level instead, with their values ([`crate::bake::parts::part_levels`]): for each level
//! below its subtrees' roots the records, then on the levels that keep values each inner-node
//! channel's, each an array of its own. The merge checks every array's hash as it copies it.

use crate::attributes::leaf_attributes::{AttributeInputs, LeafValues};
use crate::attributes::surface_sums::{BakeSums, SurfaceSums};
use crate::bake::bake_mesh::{BakeError, prepare};
use crate::bake::parts::bins::{bin_path, read_bin};
use crate::bake::parts::part_levels::{PartLevels, node_kinds, part_levels};
use crate::bake::parts::plan::{BakePlan, PartsError, config, hash_file, part_path, read_plan};
use crate::geometry::triangle_setup::{setup_triangles_in_order, spatial_order};
use crate::io::atomic_write::write_atomic;
use crate::mesh::triangle_mesh::Mesh;
use crate::octree::layout::Chunk;
use crate::octree::tree::{LeafAttributes, Node, StoredChannel};
use crate::voxelize::build::{Baked, Subtree, voxelize_subtrees};
use serde::{Deserialize, Serialize};
use std::io::{Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

const PART_MAGIC: [u8; 8] = *b"\x89SVOPRT\n";
const PART_VERSION: u32 = 2;
/// Magic, version, header length, header hash.
pub(crate) const PART_PREAMBLE: u64 = 24;

/// One subtree of a part, as its header lists it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct PartSubtree {
    /// Morton code of its node at the plan's level.
    pub code: u64,
    /// Which children the node has.
    pub mask: u8,
    /// Nodes below the node (the node itself is its parent's record).
    pub nodes: u64,
    /// Leaves.
    pub leaves: u64,
}

/// How a part stores a channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum PartStorage {
    /// One value for every leaf of the tree.
    Constant(u32),
    /// One value per leaf, in an array; `uniform` when the part has leaves and they all
    /// hold that value (the merge stores a constant when every part agrees).
    PerLeaf {
        /// Bytes per value.
        size: u8,
        /// The value every leaf of the part holds, if one does.
        uniform: Option<u32>,
    },
}

/// Where an array lies in a part file, and its hash.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct PartArray {
    /// Byte offset in the file (a multiple of 8).
    pub offset: u64,
    /// Length in bytes.
    pub len: u64,
    /// XXH3-64 of its bytes.
    pub hash: u64,
}

/// What a part measured.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct PartStats {
    /// Seconds baking (from the mesh in memory to the values, before writing); not stored,
    /// so that a part baked twice is the same file.
    #[serde(skip)]
    pub bake_s: f64,
    /// Overlap tests run in the part's subtrees (the splits above them are not counted).
    pub overlap_tests: u64,
    /// Leaf/triangle contacts.
    pub leaf_triangle_pairs: u64,
    /// Leaves no triangle touches (inexact strategies).
    pub false_positives: u64,
}

/// A part file's header.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct PartHeader {
    /// The hash of the plan file it belongs to.
    pub plan_hash: u64,
    /// Its index in the plan.
    pub index: u32,
    /// Its subtrees, the highest code first (the order of their nodes).
    pub subtrees: Vec<PartSubtree>,
    /// Per channel kind present (increasing), how it is stored.
    pub channels: Vec<(u8, PartStorage)>,
    /// The node array, then each per-leaf channel's array in kind order.
    pub arrays: Vec<PartArray>,
    /// What the bake measured.
    pub stats: PartStats,
    /// With inner-node attributes: the levels below the subtrees' roots, whose arrays come
    /// first (instead of the node array), and the roots' values.
    pub levels: Option<PartLevels>,
}

impl PartHeader {
    /// Leaves in the part.
    pub(crate) fn leaves(&self) -> u64 {
        self.subtrees.iter().map(|s| s.leaves).sum()
    }
}

/// A part baked in memory, ready to be written.
pub(crate) struct PartData {
    header: PartHeader,
    /// The subtrees' nodes in the merged file's order (without inner-node attributes).
    nodes: Vec<Node>,
    /// The levels' arrays (with inner-node attributes).
    level_arrays: Vec<Vec<u8>>,
    attributes: LeafAttributes,
    /// Whether the file gets the per-leaf channels' arrays ([`BakePlan::leaf_arrays`]).
    leaf_arrays: bool,
}

/// Bakes the parts `indices` of `plan` from its mesh, one after another, handing each to
/// `each` as it is done (so only one is held at a time). The mesh must be the plan's (its
/// hash is the caller's to check); its root cube must come out as the plan's. The triangles
/// are binned to the parts in one pass, and each part sets up only its own, freed before
/// the next part. Returns the number of degenerate triangles of the mesh (kept, as the bake
/// keeps them).
pub(crate) fn bake_parts(
    mesh: &Mesh,
    plan: &BakePlan,
    plan_hash: u64,
    indices: impl IntoIterator<Item = u32>,
    each: &mut dyn FnMut(u32, PartData) -> Result<(), PartsError>,
) -> Result<usize, PartsError> {
    bake_parts_from(mesh, false, plan, plan_hash, indices, each)
}

/// [`bake_parts`] from the whole mesh, or (`binned`) from the parts' own triangles
/// ([`crate::bake::parts::bins`]), whose bounds are not the mesh's: the plan's root cube is taken.
fn bake_parts_from(
    mesh: &Mesh,
    binned: bool,
    plan: &BakePlan,
    plan_hash: u64,
    indices: impl IntoIterator<Item = u32>,
    each: &mut dyn FnMut(u32, PartData) -> Result<(), PartsError>,
) -> Result<usize, PartsError> {
    let opts = plan.options()?;
    let root = if binned {
        // The checks `prepare` makes of the mesh (a part may have no triangles at all).
        if !mesh.triangles.is_empty() {
            mesh.validated_bounds().map_err(BakeError::from)?;
        }
        plan.root()
    } else {
        let (root, _) = prepare(mesh, &opts)?;
        if root != plan.root() {
            return Err(PartsError::Unsupported(format!(
                "the mesh's root cube {root:?} is not the plan's {:?}",
                plan.root()
            )));
        }
        root
    };
    let indices: Vec<u32> = indices.into_iter().collect();
    // Each part sets up only the triangles that may touch its subtrees (about 240 bytes
    // each), in the whole bake's spatial order, and frees them before the next part: each
    // subtree gets the same triangles in the same order, so the same bytes, and the setups
    // held at once are one part's. The lists come from one pass over the triangles.
    if let Some(index) = indices.iter().find(|&&i| i >= plan.part_count()) {
        return Err(PartsError::Unsupported(format!(
            "part {index}: the plan has {} parts",
            plan.part_count()
        )));
    }
    let order = spatial_order(mesh, &root);
    let lists = touched_lists(mesh, plan, order.iter().copied(), &indices);
    drop(order);
    let degenerate = count_degenerate(mesh, &root, opts.depth);
    for (&index, list) in indices.iter().zip(&lists) {
        let part = {
            let tris = setup_triangles_in_order(mesh, &root, opts.depth, list);
            let inputs = AttributeInputs::new(mesh, &tris, list, opts.channels);
            bake_one(&inputs, plan, &opts, plan_hash, index)?
        };
        each(index, part)?;
    }
    Ok(degenerate)
}

/// The triangles of `mesh` whose setup has a zero normal (kept, as the bake keeps them),
/// counted without holding their setups.
fn count_degenerate(mesh: &Mesh, root: &crate::geometry::grid::RootCube, depth: u8) -> usize {
    let degenerate = |t: &[u32; 3]| {
        let g = |k: usize| root.to_grid(mesh.positions[t[k] as usize], depth);
        crate::geometry::triangle_setup::GridTriangle::new(g(0), g(1), g(2)).n == glam::DVec3::ZERO
    };
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        mesh.triangles
            .par_iter()
            .with_min_len(4096)
            .filter(|t| degenerate(t))
            .count()
    }
    #[cfg(not(feature = "parallel"))]
    mesh.triangles.iter().filter(|t| degenerate(t)).count()
}

/// The nodes at `level` that mesh triangle `t`'s closed bounds reach, as inclusive ranges of
/// their coordinates per axis (one node more on the low side: a bound on a node's low face
/// touches the node below), or `None` when in doubt (a triangle across more than 512 such
/// nodes, or one whose bounds are not finite): a triangle that the whole bake's splits hand
/// to a node lies in that box.
fn touched_nodes(
    mesh: &Mesh,
    root: &crate::geometry::grid::RootCube,
    depth: u8,
    level: u8,
    t: u32,
) -> Option<[(u64, u64); 3]> {
    let tri = mesh.triangles.get(t as usize)?;
    let mut g = [glam::DVec3::ZERO; 3];
    for (k, &i) in tri.iter().enumerate() {
        g[k] = root.to_grid(*mesh.positions.get(i as usize)?, depth);
    }
    let (lo, hi) = (g[0].min(g[1]).min(g[2]), g[0].max(g[1]).max(g[2]));
    let side = f64::from(1u32 << (depth - level));
    let last = (1u64 << level) - 1;
    let span = |a: f64, b: f64| {
        let first = ((a / side).floor() - 1.0).clamp(0.0, last as f64) as u64;
        let end = (b / side).floor().clamp(0.0, last as f64) as u64;
        (first, end)
    };
    let box_ = [span(lo.x, hi.x), span(lo.y, hi.y), span(lo.z, hi.z)];
    let count: u64 = box_.iter().map(|(a, b)| b - a + 1).product();
    (count <= 512 && lo.is_finite() && hi.is_finite()).then_some(box_)
}

/// Calls `touch(part, t)` for each triangle `t` of `order` (triangles of `mesh`, its plan's
/// mesh) and each part of `plan` whose range holds a node its bounds reach
/// ([`touched_nodes`]; a triangle in doubt reaches every part): the triangles that part sets
/// up. One pass.
fn for_each_touch(
    mesh: &Mesh,
    plan: &BakePlan,
    order: impl Iterator<Item = u32>,
    mut touch: impl FnMut(usize, u32),
) {
    let root = plan.root();
    let count = plan.parts.len();
    let part_of = |code: u64| plan.parts.partition_point(|p| p.end <= code);
    let mut seen = Vec::new();
    for t in order {
        let Some([x, y, z]) = touched_nodes(mesh, &root, plan.depth, plan.level, t) else {
            (0..count).for_each(|p| touch(p, t));
            continue;
        };
        seen.clear();
        for i in x.0..=x.1 {
            for j in y.0..=y.1 {
                for k in z.0..=z.1 {
                    let p = part_of(crate::bake::parts::plan::morton([i, j, k], plan.level));
                    if p < count {
                        seen.push(p);
                    }
                }
            }
        }
        seen.sort_unstable();
        seen.dedup();
        for &p in &seen {
            touch(p, t);
        }
    }
}

/// For each of the parts `wanted` of `plan`, the triangles of `order` that the part sets up,
/// in that order ([`for_each_touch`]).
pub(crate) fn touched_lists(
    mesh: &Mesh,
    plan: &BakePlan,
    order: impl Iterator<Item = u32>,
    wanted: &[u32],
) -> Vec<Vec<u32>> {
    let mut slot = vec![None; plan.parts.len()];
    for (k, &i) in wanted.iter().enumerate() {
        if let Some(s) = slot.get_mut(i as usize) {
            *s = Some(k);
        }
    }
    let mut lists = vec![Vec::new(); wanted.len()];
    for_each_touch(mesh, plan, order, |p, t| {
        if let Some(k) = slot[p] {
            lists[k].push(t);
        }
    });
    lists
}

/// Per part of `plan`, how many triangles of `mesh` the part sets up.
pub(crate) fn touched_counts(mesh: &Mesh, plan: &BakePlan) -> Vec<u64> {
    let mut counts = vec![0u64; plan.parts.len()];
    for_each_touch(mesh, plan, 0..mesh.triangles.len() as u32, |p, _| {
        counts[p] += 1
    });
    counts
}

fn bake_one(
    inputs: &AttributeInputs<'_>,
    plan: &BakePlan,
    opts: &crate::bake::BakeOptions,
    plan_hash: u64,
    index: u32,
) -> Result<PartData, PartsError> {
    let Some(range) = plan.parts.get(index as usize) else {
        return Err(PartsError::Unsupported(format!(
            "part {index}: the plan has {} parts (0 to {})",
            plan.parts.len(),
            plan.parts.len().saturating_sub(1)
        )));
    };
    let t0 = Instant::now();
    let codes = range.start..range.end;
    // The subtrees' header list, leaf channels and statistics, with their nodes: level by
    // level with the inner nodes' values, or in the merged file's depth-first order.
    let (listed, (attributes, channels, mut stats), levels, nodes, level_arrays) = if plan
        .node_attributes
    {
        let (mut subtrees, tests) =
            voxelize_subtrees::<SurfaceSums>(inputs, opts.depth, opts.strategy, plan.level, codes);
        let leaf_off = leaf_offsets(&subtrees, index)?;
        let listed = listed(&subtrees);
        let leaves = leaves_of(inputs, &mut subtrees, tests);
        let (levels, level_arrays) = part_levels(
            &subtrees,
            &leaf_off,
            &leaves.0,
            &node_kinds(&leaves.1),
            opts.depth - plan.level - 1,
            inputs.node_rule(),
        );
        (listed, leaves, Some(levels), Vec::new(), level_arrays)
    } else {
        let (mut subtrees, tests) =
            voxelize_subtrees::<()>(inputs, opts.depth, opts.strategy, plan.level, codes);
        let leaf_off = leaf_offsets(&subtrees, index)?;
        // Nodes in the merged file's order (the highest code first).
        let mut nodes = Vec::with_capacity(subtrees.iter().map(|s| s.nodes.len() - 1).sum());
        for (s, &off) in subtrees.iter().zip(&leaf_off).rev() {
            for &n in &s.nodes[1..] {
                // Inner pointers from the subtree's first node below its root (index 1).
                let n = if n.is_leaf_parent() {
                    Chunk::<Baked<()>>::relocate(n, 0, off)
                } else if n.child_mask() != 0 {
                    Node {
                        info: n.info,
                        first: n.first - 1,
                    }
                } else {
                    n
                };
                nodes.push(n);
            }
        }
        let listed = listed(&subtrees);
        let leaves = leaves_of(inputs, &mut subtrees, tests);
        (listed, leaves, None, nodes, Vec::new())
    };
    stats.bake_s = t0.elapsed().as_secs_f64();
    Ok(PartData {
        header: PartHeader {
            plan_hash,
            index,
            subtrees: listed,
            channels,
            arrays: Vec::new(),
            stats,
            levels,
        },
        nodes,
        level_arrays,
        attributes,
        leaf_arrays: plan.leaf_arrays,
    })
}

/// Each subtree's first leaf in the part (subtrees in code order), refusing a part of more
/// leaves than a part holds.
fn leaf_offsets<S: BakeSums>(
    subtrees: &[Subtree<S>],
    index: u32,
) -> Result<Vec<usize>, PartsError> {
    let mut leaf_off = Vec::with_capacity(subtrees.len());
    let mut total = 0usize;
    for s in subtrees {
        leaf_off.push(total);
        total += s.leaves.len();
    }
    if total > i32::MAX as usize + 1 {
        return Err(PartsError::Unsupported(format!(
            "part {index} has {total} leaves, more than a part holds (2^31): plan more parts"
        )));
    }
    Ok(leaf_off)
}

/// The header's list of subtrees (in code order), the highest code first.
fn listed<S: BakeSums>(subtrees: &[Subtree<S>]) -> Vec<PartSubtree> {
    subtrees
        .iter()
        .rev()
        .map(|s| PartSubtree {
            code: s.code,
            mask: s.nodes[0].child_mask(),
            nodes: (s.nodes.len() - 1) as u64,
            leaves: s.leaves.len() as u64,
        })
        .collect()
}

/// The part's leaf channels (taken from its subtrees, in code order), how it stores each, and
/// its statistics (`tests` overlap tests).
fn leaves_of<S: BakeSums>(
    inputs: &AttributeInputs<'_>,
    subtrees: &mut [Subtree<S>],
    tests: u64,
) -> (LeafAttributes, Vec<(u8, PartStorage)>, PartStats) {
    let values = LeafValues::concat(
        subtrees
            .iter_mut()
            .map(|s| std::mem::take(&mut s.leaves))
            .collect(),
    );
    let stats = PartStats {
        bake_s: 0.0,
        overlap_tests: tests,
        leaf_triangle_pairs: values.pairs,
        false_positives: values.false_positives,
    };
    let (attributes, _) = inputs.finish_uncompacted(values, Duration::ZERO);
    let channels = attributes
        .stored()
        .into_iter()
        .map(|(kind, c)| match c {
            StoredChannel::Constant(v) => (kind, PartStorage::Constant(v)),
            StoredChannel::PerLeaf { bytes, size } => {
                // The value every leaf holds, if one does (bytes equal: values equal).
                let mut values = bytes.chunks_exact(size);
                let uniform = values.next().filter(|f| values.all(|x| x == *f)).map(|f| {
                    let mut word = [0u8; 4];
                    word[..size].copy_from_slice(f);
                    u32::from_le_bytes(word)
                });
                (
                    kind,
                    PartStorage::PerLeaf {
                        size: size as u8,
                        uniform,
                    },
                )
            }
        })
        .collect();
    (attributes, channels, stats)
}

/// What `svo-bake part` did.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
pub struct PartReport {
    /// The part's index.
    pub index: u32,
    /// Parts in the plan.
    pub count: u32,
    /// The part file.
    pub path: String,
    /// Its bytes.
    pub bytes: u64,
    /// Subtrees baked.
    pub subtrees: usize,
    /// Leaves.
    pub leaves: u64,
    /// Seconds loading the mesh (and hashing it).
    pub load_s: f64,
    /// Seconds baking.
    pub bake_s: f64,
    /// Seconds writing.
    pub write_s: f64,
}

/// Bakes part `index` of the plan at `plan_path` into its file ([`part_path`]), what
/// `svo-bake part` does: reads the plan, checks that the mesh's bytes still hash to the
/// plan's, bakes and writes the part atomically, on `threads` worker threads (`None`: the
/// caller's pool). Run twice, it writes the same bytes.
pub fn bake_part_file(
    plan_path: &Path,
    index: u32,
    threads: Option<usize>,
) -> Result<PartReport, PartsError> {
    crate::thread_pool::with_threads(threads, |_| part_file_inner(plan_path, index))?
}

fn part_file_inner(plan_path: &Path, index: u32) -> Result<PartReport, PartsError> {
    let (plan, plan_hash) = read_plan(plan_path)?;
    if index >= plan.part_count() {
        return Err(PartsError::Unsupported(format!(
            "part {index}: the plan has {} parts (0 to {})",
            plan.part_count(),
            plan.part_count() - 1
        )));
    }
    let t = Instant::now();
    // The part's own triangles where the plan wrote them, else the whole mesh.
    let bin = bin_path(plan_path, index);
    let binned = bin.exists();
    let mesh = if binned {
        read_bin(&bin, plan_hash, index)?
    } else {
        let mesh_path = Path::new(&plan.mesh);
        let found = hash_file(mesh_path)?;
        if found != plan.mesh_hash {
            return Err(PartsError::MeshChanged {
                path: plan.mesh.clone(),
                found,
                planned: plan.mesh_hash,
            });
        }
        crate::import::load_mesh(mesh_path)?
    };
    let load_s = t.elapsed().as_secs_f64();
    let path = part_path(plan_path, index);
    let mut report = None;
    bake_parts_from(&mesh, binned, &plan, plan_hash, [index], &mut |i, part| {
        let t = Instant::now();
        let bytes = write_part(&part, &path)?;
        report = Some(PartReport {
            index: i,
            count: plan.part_count(),
            path: path.display().to_string(),
            bytes,
            subtrees: part.header.subtrees.len(),
            leaves: part.header.leaves(),
            load_s,
            bake_s: part.header.stats.bake_s,
            write_s: t.elapsed().as_secs_f64(),
        });
        Ok(())
    })?;
    report.ok_or_else(|| PartsError::Unsupported(format!("part {index} was not baked")))
}

/// The part's arrays as bytes: the nodes (bits 8-31 of `info` zero) or the levels' arrays,
/// then each per-leaf channel in kind order (where the plan keeps them).
fn arrays(part: &PartData) -> Vec<&[u8]> {
    let mut out: Vec<&[u8]> = if part.header.levels.is_some() {
        part.level_arrays.iter().map(Vec::as_slice).collect()
    } else {
        vec![bytemuck::cast_slice(&part.nodes)]
    };
    if part.leaf_arrays {
        for (_, c) in part.attributes.stored() {
            if let StoredChannel::PerLeaf { bytes, .. } = c {
                out.push(bytes);
            }
        }
    }
    out
}

/// Writes a part file atomically; returns its size in bytes.
pub(crate) fn write_part(part: &PartData, path: &Path) -> Result<u64, PartsError> {
    let arrays = arrays(part);
    let mut header = part.header.clone();
    header.arrays = arrays
        .iter()
        .map(|a| PartArray {
            offset: 0,
            len: a.len() as u64,
            hash: xxhash_rust::xxh3::xxh3_64(a),
        })
        .collect();
    let encode = |h: &PartHeader| {
        bincode::serde::encode_to_vec(h, config())
            .map_err(|e| PartsError::io(path, std::io::Error::other(e)))
    };
    let hlen = encode(&header)?.len() as u64;
    let pad8 = |x: u64| x.div_ceil(8) * 8;
    let mut at = pad8(PART_PREAMBLE + hlen);
    for a in &mut header.arrays {
        a.offset = at;
        at = pad8(at + a.len);
    }
    let hbytes = encode(&header)?;
    let mut written = 0u64;
    write_atomic(path, |w| {
        fn put(w: &mut dyn Write, written: &mut u64, b: &[u8]) -> std::io::Result<()> {
            w.write_all(b)?;
            *written += b.len() as u64;
            Ok(())
        }
        let n = &mut written;
        put(w, n, &PART_MAGIC)?;
        put(w, n, &PART_VERSION.to_le_bytes())?;
        put(w, n, &(hbytes.len() as u32).to_le_bytes())?;
        put(w, n, &xxhash_rust::xxh3::xxh3_64(&hbytes).to_le_bytes())?;
        put(w, n, &hbytes)?;
        for a in &arrays {
            let pad = (pad8(*n) - *n) as usize;
            put(w, n, &[0u8; 8][..pad])?;
            put(w, n, a)?;
        }
        let pad = (pad8(*n) - *n) as usize;
        put(w, n, &[0u8; 8][..pad])
    })
    .map_err(|e| PartsError::io(path, e))?;
    Ok(written)
}

/// Whether `path` holds the whole, undamaged part `index` of the plan whose hash is
/// `plan_hash`: its header checks out and every array's bytes have the hash it records.
pub(crate) fn is_complete_part(path: &Path, plan_hash: u64, index: u32) -> bool {
    use std::io::{Seek, SeekFrom};
    let Ok(h) = read_part_header(path) else {
        return false;
    };
    if h.plan_hash != plan_hash || h.index != index {
        return false;
    }
    let Ok(mut f) = std::fs::File::open(path) else {
        return false;
    };
    let mut buf = vec![0u8; 1 << 20];
    h.arrays.iter().all(|a| {
        let mut hasher = xxhash_rust::xxh3::Xxh3::new();
        let mut left = a.len;
        if f.seek(SeekFrom::Start(a.offset)).is_err() {
            return false;
        }
        while left > 0 {
            let n = usize::try_from(left.min(buf.len() as u64)).unwrap_or(buf.len());
            if f.read_exact(&mut buf[..n]).is_err() {
                return false;
            }
            hasher.update(&buf[..n]);
            left -= n as u64;
        }
        hasher.digest() == a.hash
    })
}

/// Reads and checks a part file's header: its magic, version and header hash, and that the
/// file is as long as its arrays say (a truncated part is refused here). The arrays' hashes
/// are checked as the merge copies them.
pub(crate) fn read_part_header(path: &Path) -> Result<PartHeader, PartsError> {
    let corrupt = |detail: String| PartsError::Corrupt {
        path: path.display().to_string(),
        detail,
    };
    let mut f = std::fs::File::open(path).map_err(|e| PartsError::io(path, e))?;
    let len = f.metadata().map_err(|e| PartsError::io(path, e))?.len();
    let mut pre = [0u8; PART_PREAMBLE as usize];
    if len < PART_PREAMBLE || f.read_exact(&mut pre).is_err() {
        return Err(corrupt("truncated part file (no header)".into()));
    }
    if pre[..8] != PART_MAGIC {
        return Err(corrupt("not an svo part file (bad magic bytes)".into()));
    }
    let word = |at: usize| u32::from_le_bytes([pre[at], pre[at + 1], pre[at + 2], pre[at + 3]]);
    if word(8) != PART_VERSION {
        return Err(corrupt(format!(
            "part version {} (this svo reads version {PART_VERSION})",
            word(8)
        )));
    }
    let hlen = u64::from(word(12));
    if PART_PREAMBLE + hlen > len {
        return Err(corrupt("truncated part file (in its header)".into()));
    }
    let mut hbytes = vec![0u8; hlen as usize];
    f.read_exact(&mut hbytes)
        .map_err(|e| PartsError::io(path, e))?;
    let stored = u64::from_le_bytes(pre[16..24].try_into().unwrap_or_default());
    if xxhash_rust::xxh3::xxh3_64(&hbytes) != stored {
        return Err(corrupt(
            "header checksum mismatch: the part file is corrupt".into(),
        ));
    }
    let (h, used): (PartHeader, usize) = bincode::serde::decode_from_slice(&hbytes, config())
        .map_err(|e| corrupt(format!("undecodable part header: {e}")))?;
    if used as u64 != hlen {
        return Err(corrupt("bytes left over after the part header".into()));
    }
    let end = h
        .arrays
        .last()
        .map_or(Some(PART_PREAMBLE + hlen), |a| a.offset.checked_add(a.len))
        .ok_or_else(|| corrupt("an array's end overflows".into()))?;
    let end = end.div_ceil(8) * 8;
    if len != end {
        return Err(corrupt(format!(
            "{} part file: {len} bytes where its arrays end at {end}",
            if len < end { "truncated" } else { "overlong" }
        )));
    }
    Ok(h)
}
