//! A human-readable description of a `.svo` file, for `svo-view --info`: everything its
//! header holds (version, lengths, where each array is, the checksum), the tree's counts per
//! level and its channels.

use crate::io::header::{NodeStorage, PREAMBLE_LEN, Storage};
use crate::io::read::{
    ChunksRead, FileRead, Preamble, check_chunks_file, read_dag_sizes, read_file_with_header,
};
use crate::io::write::FormatError;
use crate::octree::format_check::DAG_LAYOUT;
use crate::octree::tree::{Channel, ChannelKind, Octree};
use std::fmt::Write;
use std::path::Path;

fn channel<T: Copy>(name: &str, c: &Channel<T>, show: impl Fn(T) -> String, out: &mut String) {
    let _ = match c {
        Channel::Absent => writeln!(out, "  {name:<13} absent"),
        Channel::Constant(v) => writeln!(out, "  {name:<13} constant {}", show(*v)),
        Channel::PerLeaf(v) => writeln!(out, "  {name:<13} per leaf ({} values)", v.len()),
    };
}

/// Reads and validates the `.svo` file at `path` and describes it: the header's every field
/// (format version, header length, the arrays' offsets and lengths, the checksum, the build
/// information, lights and views), the counts per level and the channels. The file is read
/// in one pass ([`crate::io::read_file`]): no copy of it is held beside the tree. An invalid
/// file gives the reader's error, which names the check it failed. A version-3 file whose tree is larger than one tree in
/// memory holds ([`FormatError::TooLarge`]) is checked one chunk at a time instead (every
/// check but the values') and described from its header and chunk table; a file of the DAG
/// layout whose tree is too large to make ([`FormatError::DagTooLarge`]) is read with every
/// check and described from its graph.
pub fn describe_file(path: impl AsRef<Path>) -> Result<String, FormatError> {
    match read_file_with_header(path.as_ref()) {
        Ok(r) => Ok(describe_read(&r.tree, &r.preamble, r.checksum, r.len)),
        Err(FormatError::TooLarge { .. }) => {
            check_chunks_file(path.as_ref()).map(|r| describe_chunks(&r))
        }
        Err(FormatError::DagTooLarge { .. }) => {
            read_dag_sizes(path.as_ref()).map(|(counts, r)| describe_dag(&counts, &r))
        }
        Err(e) => Err(e),
    }
}

/// A graph whose tree is too large to make: its header, and the tree's counts per level as
/// the graph gives them.
fn describe_dag(counts: &[u64], r: &FileRead) -> String {
    let h = &r.preamble.header;
    let mut out = describe_header(&r.preamble, r.checksum);
    describe_root(&mut out, &h.build, r.tree.root, h.depth);
    let (levels, leaves) = counts.split_at(counts.len().saturating_sub(1));
    let nodes = levels.iter().fold(0u64, |a, &c| a.saturating_add(c));
    let _ = writeln!(
        out,
        "nodes          {nodes} in the tree the graph stands for"
    );
    let _ = writeln!(
        out,
        "leaves         {}",
        leaves.first().copied().unwrap_or(0)
    );
    let _ = writeln!(out, "nodes/level    {levels:?}");
    let _ = writeln!(
        out,
        "checked        every check; the tree is not made: it is larger than one tree in memory \
         holds (2^31 leaves and nodes)"
    );
    describe_channels(&mut out, &r.tree.attributes);
    describe_file_size(&mut out, r.len, h.leaf_count);
    out
}

fn describe_read(tree: &Octree, p: &Preamble, checksum: u64, len: u64) -> String {
    let mut out = describe_header(p, checksum);
    describe_tree(&mut out, tree, &p.header.build, len);
    out
}

/// A tree too large to load: its header, its chunks, and what was checked.
fn describe_chunks(r: &ChunksRead) -> String {
    let h = &r.preamble.header;
    let mut out = describe_header(&r.preamble, r.checksum);
    let root = crate::geometry::grid::RootCube {
        origin: glam::DVec3::from_array(h.root_origin),
        side: h.root_side,
    };
    describe_root(&mut out, &h.build, root, h.depth);
    let _ = writeln!(
        out,
        "nodes          {} in the chunks (the levels above them are not stored)",
        h.node_count
    );
    let _ = writeln!(out, "leaves         {}", h.leaf_count);
    let range = |f: fn(&crate::io::header::ChunkRecord) -> u64| {
        let lo = r.table.iter().map(f).min().unwrap_or(0);
        let hi = r.table.iter().map(f).max().unwrap_or(0);
        format!("{lo} to {hi}")
    };
    let _ = writeln!(
        out,
        "chunk sizes    {} nodes, {} leaves a chunk",
        range(|c| c.nodes),
        range(|c| c.leaves)
    );
    let _ = writeln!(
        out,
        "checked        checks 1 to 17 and 19, one chunk at a time; the values (check 18) not read: \
         the tree is larger than one tree in memory holds (2^31 leaves and nodes)"
    );
    describe_file_size(&mut out, r.len, h.leaf_count);
    out
}

/// The preamble's and header's lines of [`describe`]: version, lengths, where each array is.
fn describe_header(p: &Preamble, checksum: u64) -> String {
    let (version, hlen, header) = (p.version, p.header_len, &p.header);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "format         version {version}, header {hlen} bytes at {PREAMBLE_LEN}, checksum {checksum:#018x} (XXH3-64)",
    );
    if let Some(c) = header.chunks {
        let _ = writeln!(
            out,
            "chunks         {} at level {}, table at {} ({} bytes)",
            c.count, c.level, c.table.offset, c.table.len
        );
    }
    match &header.levels {
        None => {
            let _ = writeln!(
                out,
                "arrays         nodes at {} ({} bytes)",
                header.nodes.offset, header.nodes.len
            );
        }
        Some(levels) if levels.layout == DAG_LAYOUT => {
            let _ = writeln!(
                out,
                "layout         DAG: distinct subtrees once, the two lowest levels as 4x4x4 bricks"
            );
            let last = levels.table.len().saturating_sub(1);
            for (l, e) in levels.table.iter().enumerate() {
                let what = if l == last { "bricks" } else { "nodes" };
                let _ = writeln!(
                    out,
                    "level {l:<8} {} distinct {what}, block at {} ({} bytes), checksum {:#018x}",
                    e.nodes, e.block.offset, e.block.len, e.hash
                );
            }
            let _ = writeln!(out, "arrays");
        }
        Some(levels) => {
            for (l, e) in levels.table.iter().enumerate() {
                let _ = writeln!(
                    out,
                    "level {l:<8} {} nodes, block at {} ({} bytes), checksum {:#018x}",
                    e.nodes, e.block.offset, e.block.len, e.hash
                );
            }
            let kinds: Vec<String> = levels
                .node_channels
                .iter()
                .map(|e| {
                    let name = ChannelKind::ALL
                        .get(usize::from(e.kind))
                        .map_or("?", |k| k.name());
                    match e.storage {
                        NodeStorage::Constant(v) => format!("{name} constant {v:#x}"),
                        NodeStorage::PerNode => format!("{name} per node"),
                    }
                })
                .collect();
            let _ = writeln!(
                out,
                "inner nodes    {} (levels 0 to depth - 2)",
                if kinds.is_empty() {
                    "no channels".to_string()
                } else {
                    kinds.join(", ")
                }
            );
            let _ = writeln!(out, "arrays");
        }
    }
    for e in &header.channels {
        let name = ChannelKind::ALL
            .get(usize::from(e.kind))
            .map_or("?", |k| k.name());
        let _ = match e.storage {
            Storage::Constant(v) => writeln!(out, "               {name} constant {v:#x}"),
            Storage::PerLeaf(r) => {
                writeln!(
                    out,
                    "               {name} at {} ({} bytes)",
                    r.offset, r.len
                )
            }
            Storage::Packed { level, bits, array } => writeln!(
                out,
                "               {name} at {} ({} bytes): level {level}'s nodes, {bits} bits each{}",
                array.offset,
                array.len,
                if e.kind == 2 && bits == 4 {
                    " (blocks of 16)"
                } else {
                    ""
                }
            ),
        };
    }
    out
}

/// The generator, root cube and depth lines of [`describe`].
fn describe_root(
    out: &mut String,
    build: &crate::io::BuildInfo,
    root: crate::geometry::grid::RootCube,
    depth: u8,
) {
    let o = root.origin;
    let _ = writeln!(
        out,
        "generator      {} (strategy {}, {} source triangles)",
        build.generator, build.strategy, build.source_triangles
    );
    let _ = writeln!(
        out,
        "root           origin ({}, {}, {}), side {}",
        o.x, o.y, o.z, root.side
    );
    let _ = writeln!(
        out,
        "depth          {depth} (grid {}^3, cell {:.6e})",
        1u64 << depth,
        root.cell_size(depth)
    );
}

/// The tree's part of [`describe`]: root, depth, counts per level, channels, sizes.
fn describe_tree(out: &mut String, tree: &Octree, build: &crate::io::BuildInfo, file_bytes: u64) {
    describe_root(out, build, tree.root, tree.depth);
    let _ = writeln!(out, "nodes          {}", tree.nodes.len());
    let _ = writeln!(out, "leaves         {}", tree.leaf_count);
    if let Channel::PerLeaf(v) = &tree.attributes.normal {
        let interior = v
            .iter()
            .filter(|&&w| w == crate::octree::tree::NO_NORMAL)
            .count();
        if interior > 0 {
            let _ = writeln!(
                out,
                "solid          {interior} interior leaves, {} surface leaves",
                v.len() - interior
            );
        }
    }
    for l in &build.scene.lights {
        let [x, y, z] = l.position;
        let [r, g, b] = l.colour;
        let _ = writeln!(
            out,
            "light          ({x}, {y}, {z}) colour ({r}, {g}, {b}) intensity {}",
            l.intensity
        );
    }
    for c in &build.scene.cameras {
        let _ = writeln!(
            out,
            "view           {:?}: eye {:?} target {:?} up {:?} fov {}",
            c.name, c.eye, c.target, c.up, c.fov_deg
        );
    }
    // Nodes per level, walking the packed layout breadth-first.
    let mut level = vec![0u32];
    let mut counts = Vec::new();
    while !level.is_empty() && counts.len() < usize::from(tree.depth) {
        counts.push(level.len());
        let mut next = Vec::new();
        for &i in &level {
            let n = tree.nodes[i as usize];
            if !n.is_leaf_parent() && n.child_mask() != 0 {
                next.extend(n.first..n.first + n.child_mask().count_ones());
            }
        }
        level = next;
    }
    let _ = writeln!(out, "nodes/level    {counts:?}");
    describe_channels(out, &tree.attributes);
    describe_file_size(out, file_bytes, u64::from(tree.leaf_count));
}

/// The last line of [`describe`]: the file's bytes, in all and a leaf.
fn describe_file_size(out: &mut String, bytes: u64, leaves: u64) {
    let per_leaf = if leaves > 0 {
        bytes as f64 / leaves as f64
    } else {
        0.0
    };
    let _ = write!(
        out,
        "file           {bytes} bytes, {per_leaf:.2} bytes per leaf"
    );
}

/// The channels' lines of [`describe`]: each channel absent, constant or per leaf.
fn describe_channels(out: &mut String, a: &crate::octree::tree::LeafAttributes) {
    let _ = writeln!(out, "channels");
    channel(
        "normal",
        &a.normal,
        |v| format!("{:?}", crate::octree::normal_encoding::decode(v)),
        out,
    );
    channel(
        "contour",
        &a.contour,
        |v| format!("{:?}", crate::octree::contour::unpack(v)),
        out,
    );
    channel(
        "colour",
        &a.colour,
        |v| format!("RGBA8 sRGB {:?}", v.to_le_bytes()),
        out,
    );
    channel(
        "reflectivity",
        &a.reflectivity,
        |v| format!("{:.3}", f32::from(v) / 255.0),
        out,
    );
    channel(
        "refractivity",
        &a.refractivity,
        |v| format!("{:.3}", f32::from(v) / 255.0),
        out,
    );
    channel(
        "ior",
        &a.ior,
        |v| format!("{:.4}", crate::octree::encoding::ior_decode(v)),
        out,
    );
}
