//! Reading `.svo` files: every field is validated before use (magic, version, lengths,
//! checksum, header, array bounds, channel sizes, then the tree's structure with
//! [`crate::octree::validate`]), and the arrays are copied out, not decoded per element.
//! A corrupt, truncated or hostile file gives a [`FormatError`], never a panic, a hang or an
//! allocation larger than the file.

#[cfg(feature = "trace")]
use crate::dag::DagTree;
use crate::dag::levels::{DagLevels, MAX_DAG_LEAVES, TreeSize, max_block_len};
use crate::geometry::grid::RootCube;
use crate::io::header::{
    ArrayRef, BuildInfo, ChannelEntry, ChunkRecord, Chunking, Header, HeaderV1, HeaderV3, HeaderV4,
    Levels, MAGIC, MAX_HEADER_LEN, NodeStorage, PREAMBLE_LEN, Storage, VERSION, bincode_config,
};
use crate::io::packed::{self, PackedRaw};
pub(crate) use crate::io::write::FormatError;
use crate::io::write::block_hash;
use crate::octree::format_check::{
    CHUNKED_VERSION, Check, DAG_LAYOUT, LEVELS_VERSION, MAX_CHUNK_LEVEL,
};
use crate::octree::level_order::{check_level_order, depth_first};
use crate::octree::stitch::{self, Piece, Stub, moved};
use crate::octree::tree::{Channel, ChannelKind, LeafAttributes, Node, Octree};
use crate::octree::validate::{
    InfoBits, MAX_LEAVES, check_chunk, check_leaf_order, check_node_words, check_renumbered,
    check_root_and_counts, check_shape_and_node_order, check_tree, check_values,
};
use glam::DVec3;
use std::path::Path;

fn corrupt(check: Check, detail: impl Into<String>) -> FormatError {
    FormatError::Corrupt {
        check,
        detail: detail.into(),
    }
}

fn truncated(check: Check, detail: impl Into<String>) -> FormatError {
    FormatError::Truncated {
        check,
        detail: detail.into(),
    }
}

/// Reads and validates a `.svo` file: the tree and what accompanies it.
pub fn read_file(path: impl AsRef<Path>) -> Result<(Octree, BuildInfo), FormatError> {
    read_file_with_header(path.as_ref()).map(|r| (r.tree, r.preamble.header.build))
}

/// What checks 1 to 6 read: the format version, the header's length in bytes and the header.
#[derive(Debug)]
pub(crate) struct Preamble {
    pub version: u32,
    pub header_len: usize,
    pub header: Header,
}

impl Preamble {
    /// Where the header ends: with its checksum in version 4.
    pub(crate) fn header_end(&self) -> u64 {
        header_end(self.version, self.header_len)
    }
}

/// Where a header of `hlen` bytes ends in a file of `version`, its checksum (version 4)
/// included.
fn header_end(version: u32, hlen: usize) -> u64 {
    (PREAMBLE_LEN + hlen) as u64 + if version >= LEVELS_VERSION { 8 } else { 0 }
}

/// Check 20 (version 4): the header checksum after the header of `bytes` (the preamble and
/// the header with its checksum, at least).
fn check_header_checksum(bytes: &[u8], version: u32, hlen: usize) -> Result<(), FormatError> {
    if version < LEVELS_VERSION {
        return Ok(());
    }
    let end = PREAMBLE_LEN + hlen;
    let stored = u64::from_le_bytes(bytes[end..end + 8].try_into().unwrap_or([0; 8]));
    let computed = xxhash_rust::xxh3::xxh3_64(&bytes[..end]);
    if stored != computed {
        return Err(corrupt(
            Check::HeaderChecksum,
            format!("the header's checksum is {stored:#018x}, its bytes hash to {computed:#018x}"),
        ));
    }
    Ok(())
}

/// Checks 1 to 6: the preamble, the checksum and the header's encoding.
pub(crate) fn read_header(bytes: &[u8]) -> Result<Preamble, FormatError> {
    let (version, hlen) = check_preamble(bytes, bytes.len() as u64)?;
    // 5. The checksum.
    let body = bytes.len() - 8;
    let stored = u64::from_le_bytes(bytes[body..].try_into().unwrap_or([0; 8]));
    let computed = xxhash_rust::xxh3::xxh3_64(&bytes[..body]);
    if stored != computed {
        return Err(FormatError::Checksum { stored, computed });
    }
    check_header_checksum(bytes, version, hlen)?;
    decode_header(&bytes[PREAMBLE_LEN..PREAMBLE_LEN + hlen], version)
}

/// Checks 1 to 4 on the first bytes of a file of `total` bytes (at least the preamble and
/// the header when the file has them): returns the version and the header's length.
fn check_preamble(bytes: &[u8], total: u64) -> Result<(u32, usize), FormatError> {
    // 1. The magic.
    if bytes.len() < 8 || bytes[..8] != MAGIC {
        return Err(if bytes.len() < 8 && MAGIC.starts_with(bytes) {
            truncated(
                Check::Magic,
                format!("{} bytes, the magic alone is 8", bytes.len()),
            )
        } else {
            FormatError::NotSvo
        });
    }
    // 2. The preamble and the checksum fit.
    if total < (PREAMBLE_LEN + 8) as u64 {
        return Err(truncated(
            Check::Size,
            format!("{total} bytes, less than the smallest file (24)"),
        ));
    }
    // 3. The version.
    let word =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let version = word(8);
    if version > VERSION {
        return Err(FormatError::NewerVersion {
            found: version,
            supported: VERSION,
        });
    }
    if version == 0 {
        return Err(corrupt(Check::Version, "format version 0"));
    }
    // 4. The header length.
    let hlen = word(12) as usize;
    if hlen > MAX_HEADER_LEN {
        return Err(corrupt(
            Check::HeaderLength,
            format!("header length {hlen} exceeds {MAX_HEADER_LEN}"),
        ));
    }
    if header_end(version, hlen) + 8 > total {
        return Err(truncated(
            Check::HeaderLength,
            format!(
                "a header of {hlen} bytes does not end before the checksum of a file of {total} bytes"
            ),
        ));
    }
    Ok((version, hlen))
}

/// Check 6: the header decodes in exactly its length.
fn decode_header(raw: &[u8], version: u32) -> Result<Preamble, FormatError> {
    let hlen = raw.len();
    let (header, used): (Header, usize) = match version {
        1 => bincode::serde::decode_from_slice::<HeaderV1, _>(raw, bincode_config())
            .map(|(h, n)| (h.into(), n)),
        3 => bincode::serde::decode_from_slice::<HeaderV3, _>(raw, bincode_config())
            .map(|(h, n)| (h.into(), n)),
        4 => bincode::serde::decode_from_slice::<HeaderV4, _>(raw, bincode_config())
            .map(|(h, n)| (h.into(), n)),
        _ => bincode::serde::decode_from_slice(raw, bincode_config()),
    }
    .map_err(|e| corrupt(Check::Header, format!("header: {e}")))?;
    if used != hlen {
        return Err(corrupt(
            Check::Header,
            format!("the header holds {used} bytes, its length says {hlen}"),
        ));
    }
    Ok(Preamble {
        version,
        header_len: hlen,
        header,
    })
}

/// Reads and validates a whole `.svo` file from `reader`.
pub fn read_from(mut reader: impl std::io::Read) -> Result<(Octree, BuildInfo), FormatError> {
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|cause| FormatError::Io {
            path: "<reader>".into(),
            cause,
        })?;
    from_bytes(&bytes)
}

/// Parses and validates the bytes of a `.svo` file: the checks of `docs/format.md` in their
/// order.
pub fn from_bytes(bytes: &[u8]) -> Result<(Octree, BuildInfo), FormatError> {
    read_with_header(bytes).map(|(tree, p)| (tree, p.header.build))
}

/// Checks 7 to 12 on a decoded header, for a file of `len` bytes whose header ends at
/// `header_end`: returns the padding gaps (`from..to`) that check 13 reads.
fn check_layout(h: &Header, header_end: u64, len: u64) -> Result<Vec<(u64, u64)>, FormatError> {
    let data_end = len - 8;
    // 7. Depth; 8. root cube; 9. counts.
    let origin = DVec3::from_array(h.root_origin);
    match h.chunks {
        None if is_dag(h) => check_dag_counts(h, origin),
        None => check_root_and_counts(h.depth, origin, h.root_side, h.node_count, h.leaf_count),
        Some(c) => check_chunked_counts(h, c, origin),
    }
    .map_err(|(check, detail)| corrupt(check, detail))?;
    // 10. Channels: known kinds, increasing; constants that fit; a contour only with a normal.
    let mut last_kind: i16 = -1;
    for e in &h.channels {
        if i16::from(e.kind) <= last_kind || e.kind > 5 {
            return Err(corrupt(
                Check::Channels,
                format!("channel code {} unknown, repeated or out of order", e.kind),
            ));
        }
        last_kind = i16::from(e.kind);
        if let Storage::Constant(v) = e.storage {
            constant_fits(e.kind, v, "")?;
        }
        if let Storage::Packed { level, bits, .. } = e.storage {
            check_packed(h, e.kind, level, bits)?;
        }
    }
    // Every channel with values per leaf or per node keeps them on one level.
    let mut levels_used = h.channels.iter().filter_map(|e| match e.storage {
        Storage::Constant(_) => None,
        Storage::PerLeaf(_) => Some(h.depth),
        Storage::Packed { level, .. } => Some(level),
    });
    if let Some(first) = levels_used.next()
        && let Some(other) = levels_used.find(|&l| l != first)
    {
        return Err(corrupt(
            Check::Channels,
            format!("channels on levels {first} and {other}: every channel's values on one level"),
        ));
    }
    if h.channels.iter().any(|e| e.kind == 1) && !h.channels.iter().any(|e| e.kind == 0) {
        return Err(corrupt(
            Check::Channels,
            "a contour channel without a normal channel",
        ));
    }
    // Version 4: the inner nodes' channels, none or the leaves' kinds.
    if let Some(l) = &h.levels {
        check_node_channel_list(h, l)?;
    }
    // 11. The scene.
    h.build
        .scene
        .validate()
        .map_err(|e| corrupt(Check::Scene, format!("scene: {e}")))?;
    // 21. The level table.
    if let Some(l) = &h.levels {
        check_level_table(h, l)?;
    }
    // 12. The arrays where the canonical layout puts them: the nodes, then the per-leaf
    // channels by kind, each at the next multiple of 8, and the checksum after the last.
    let node_bytes = h
        .node_count
        .checked_mul(8)
        .ok_or_else(|| corrupt(Check::ArrayLayout, "the node count overflows"))?;
    // Check 9 bounds the chunk count by the node count and the leaf count by eight a node,
    // which keeps neither array's size below 2^64.
    let overflows = |what: &str| corrupt(Check::ArrayLayout, format!("the {what} overflows"));
    let mut refs: Vec<(ArrayRef, u64)> = Vec::new();
    if let Some(c) = h.chunks {
        let table = c
            .count
            .checked_mul(size_of::<ChunkRecord>() as u64)
            .ok_or_else(|| overflows("chunk table's size"))?;
        refs.push((c.table, table));
    }
    if h.levels.is_none() {
        refs.push((h.nodes, node_bytes));
    }
    for e in &h.channels {
        match e.storage {
            Storage::PerLeaf(r) => {
                let size = ChannelKind::ALL[usize::from(e.kind)].element_size() as u64;
                let bytes = h
                    .leaf_count
                    .checked_mul(size)
                    .ok_or_else(|| overflows("channel array's size"))?;
                refs.push((r, bytes));
            }
            // Its length is checked against the graph's count on its level (check 17).
            Storage::Packed { array, .. } => refs.push((array, array.len)),
            Storage::Constant(_) => {}
        }
    }
    let pad8 = |x: u64| x.div_ceil(8) * 8;
    let mut at = pad8(header_end);
    let mut gaps = vec![(header_end, at)];
    // Version 4: the levels' blocks first, each its arrays one after another.
    if let Some(levels) = &h.levels {
        for (l, entry) in levels.table.iter().enumerate() {
            let lens = level_lens(h, l).ok_or_else(|| {
                if is_dag(h) {
                    corrupt(
                        Check::ArrayLayout,
                        format!(
                            "level {l}'s block of {} bytes does not fit its {} nodes",
                            entry.block.len, entry.nodes
                        ),
                    )
                } else {
                    overflows("level block's size")
                }
            })?;
            let (mut end, mut next) = (at, at);
            for &len in &lens {
                end = next.saturating_add(len);
                next = pad8(end);
            }
            let want = ArrayRef {
                offset: at,
                len: end - at,
            };
            if entry.block != want {
                return Err(corrupt(
                    Check::ArrayLayout,
                    format!(
                        "level {l}'s block at {} of {} bytes, where the layout needs one at {} \
                         of {}",
                        entry.block.offset, entry.block.len, want.offset, want.len
                    ),
                ));
            }
            for &len in &lens {
                let end = at.saturating_add(len);
                if end > data_end {
                    return Err(truncated(
                        Check::ArrayLayout,
                        format!(
                            "level {l}'s block at {at}..{end} runs past the data end {data_end}"
                        ),
                    ));
                }
                at = pad8(end);
                gaps.push((end, at));
            }
        }
    }
    for (r, want) in &refs {
        if r.len != *want || r.offset != at {
            return Err(corrupt(
                Check::ArrayLayout,
                format!(
                    "an array at {} of {} bytes, where the layout needs one at {at} of {want}",
                    r.offset, r.len
                ),
            ));
        }
        let end = at.saturating_add(r.len);
        if end > data_end {
            return Err(truncated(
                Check::ArrayLayout,
                format!("the array at {at}..{end} runs past the data end {data_end}"),
            ));
        }
        at = pad8(end);
        gaps.push((end, at));
    }
    if at != data_end {
        return Err(if at > data_end {
            truncated(
                Check::ArrayLayout,
                format!("the padding after the last array runs past the data end {data_end}"),
            )
        } else {
            corrupt(
                Check::ArrayLayout,
                format!(
                    "{} bytes between the last array and the checksum",
                    data_end - at
                ),
            )
        });
    }
    Ok(gaps)
}

/// The lengths of the arrays of level `l`'s block in a version-4 file of header `h`: the nodes'
/// records, then on levels above `depth - 1` one array for each per-node channel (`None` if
/// one overflows).
pub(crate) fn level_lens(h: &Header, l: usize) -> Option<Vec<u64>> {
    let levels = h.levels.as_ref()?;
    let nodes = levels.table.get(l)?.nodes;
    if levels.layout == DAG_LAYOUT {
        // The bricks' level: 8 bytes a brick; a level above: a mask byte and up to 8
        // references a node, each as wide as the next level's count needs (check 21 made the
        // layout's depth at least 2, so a node level has one below it).
        let len = levels.table[l].block.len;
        let fits = if l + 2 == usize::from(h.depth) {
            Some(len) == nodes.checked_mul(8)
        } else {
            let below = levels.table.get(l + 1).map_or(0, |e| e.nodes);
            len >= nodes && max_block_len(nodes, below).is_some_and(|n| len <= n)
        };
        return fits.then(|| vec![len]);
    }
    let mut lens = vec![nodes.checked_mul(8)?];
    if l + 2 <= usize::from(h.depth) {
        for e in &levels.node_channels {
            if e.storage == NodeStorage::PerNode {
                let size = ChannelKind::ALL[usize::from(e.kind)].element_size() as u64;
                lens.push(nodes.checked_mul(size)?);
            }
        }
    }
    Some(lens)
}

/// Check 10 on a version-4 header's inner-node channels: none, or one for each of the leaves'
/// channels, of the same kinds in the same order, each constant fitting its element.
fn check_node_channel_list(h: &Header, l: &Levels) -> Result<(), FormatError> {
    if l.node_channels.is_empty() {
        return Ok(());
    }
    let kinds: Vec<u8> = h.channels.iter().map(|e| e.kind).collect();
    let node_kinds: Vec<u8> = l.node_channels.iter().map(|e| e.kind).collect();
    if kinds != node_kinds {
        return Err(corrupt(
            Check::Channels,
            format!("inner-node channels {node_kinds:?}, where the leaves have {kinds:?}"),
        ));
    }
    for e in &l.node_channels {
        if let NodeStorage::Constant(v) = e.storage {
            constant_fits(e.kind, v, "inner-node ")?;
        }
    }
    Ok(())
}

/// Check 10 on a channel stored on a level: the DAG layout only, a level from 1 to the depth,
/// bits its element's (a normal's: even, 4 to 32), and a contour only on the leaves'.
fn check_packed(h: &Header, kind: u8, level: u8, bits: u8) -> Result<(), FormatError> {
    let name = ChannelKind::ALL[usize::from(kind)].name();
    let fail = |detail: String| Err(corrupt(Check::Channels, detail));
    if !is_dag(h) {
        return fail(format!(
            "the {name} channel is stored on a level, which only the DAG layout allows"
        ));
    }
    if level == 0 || level > h.depth {
        return fail(format!(
            "the {name} channel on level {level}: levels 1 to the depth {}",
            h.depth
        ));
    }
    if !packed::bits_allowed(kind, bits) {
        return fail(format!(
            "the {name} channel in {bits} bits: its element's {} (a normal: an even number from 4 to 32)",
            packed::element_bits(kind)
        ));
    }
    if kind == 1 && level != h.depth {
        return fail(format!(
            "a contour channel on level {level}: a contour is measured in its leaf's cell"
        ));
    }
    Ok(())
}

/// Check 10 on a constant `v` of channel `kind` (known): it fits the channel's element.
fn constant_fits(kind: u8, v: u32, what: &str) -> Result<(), FormatError> {
    let size = ChannelKind::ALL[usize::from(kind)].element_size();
    if size < 4 && v >> (8 * size) != 0 {
        return Err(corrupt(
            Check::Channels,
            format!("the {what}constant {v} of channel {kind} does not fit {size} byte(s)"),
        ));
    }
    Ok(())
}

/// Check 21: the layout is the tree (0), and the level table has an entry for each level, one
/// node (the root) on level 0, at most 8 nodes for each node of the level above, and
/// `node_count` nodes in all.
fn check_level_table(h: &Header, l: &Levels) -> Result<(), FormatError> {
    let fail = |m: String| Err(corrupt(Check::Levels, m));
    if l.layout > DAG_LAYOUT {
        return fail(format!(
            "layout {} (only 0, the tree, and 1, the DAG, are defined)",
            l.layout
        ));
    }
    let dag = l.layout == DAG_LAYOUT;
    if dag && h.depth < 2 {
        return fail(format!(
            "the DAG layout at depth {}: its bricks need two levels",
            h.depth
        ));
    }
    if dag && !l.node_channels.is_empty() {
        return fail("inner-node channels in the DAG layout".into());
    }
    let want = usize::from(h.depth) - usize::from(dag);
    if l.table.len() != want {
        return fail(format!(
            "{} levels in the table for a tree of depth {} (layout {}: {want})",
            l.table.len(),
            h.depth,
            l.layout
        ));
    }
    if l.table[0].nodes != 1 {
        return fail(format!("{} nodes on level 0, not 1", l.table[0].nodes));
    }
    let mut sum = 1u64;
    for i in 1..l.table.len() {
        let (above, n) = (l.table[i - 1].nodes, l.table[i].nodes);
        if n > above.saturating_mul(8) {
            return fail(format!(
                "{n} nodes on level {i}, more than 8 for each of the {above} above"
            ));
        }
        sum = sum.saturating_add(n);
    }
    if sum != h.node_count {
        return fail(format!(
            "the levels hold {sum} nodes, the header says {}",
            h.node_count
        ));
    }
    Ok(())
}

/// Whether a header is version 4's with the DAG layout.
fn is_dag(h: &Header) -> bool {
    h.levels.as_ref().is_some_and(|l| l.layout == DAG_LAYOUT)
}

/// Checks 7 to 9 of a header of the DAG layout: the depth and root cube as in every version,
/// a node, and at most [`MAX_DAG_LEAVES`] leaves (a graph's leaves are not bounded by its
/// nodes).
fn check_dag_counts(h: &Header, origin: DVec3) -> Result<(), (Check, String)> {
    check_root_and_counts(h.depth, origin, h.root_side, h.node_count, 0)?;
    if h.leaf_count > MAX_DAG_LEAVES {
        return Err((
            Check::Counts,
            format!("{} leaves: more than 2^48", h.leaf_count),
        ));
    }
    Ok(())
}

/// The graph the blocks of a file of the DAG layout hold (`docs/format.md`, section 12),
/// whose tree the reader will make: checks 14 to 16 on its levels, 17 on its leaves, and the
/// tree's size against what one tree in memory holds.
fn dag_within_limits(
    h: &Header,
    levels: &Levels,
    blocks: &[Vec<Vec<u8>>],
) -> Result<DagLevels, FormatError> {
    let (dag, size) = dag_levels(h, levels, blocks)?;
    if size.leaves > MAX_LEAVES || size.nodes > MAX_LEAVES {
        return Err(FormatError::DagTooLarge {
            leaves: size.leaves,
            nodes: size.nodes,
        });
    }
    Ok(dag)
}

/// The channels stored on a level, unpacked into `attributes` (one value for each node of
/// that level of `graph`'s tree): checks 17 and 18 on each. Returns the level, if a channel
/// has one.
fn unpack_packed(
    attributes: &mut LeafAttributes,
    packed: &[PackedRaw],
    graph: &DagLevels,
) -> Result<Option<u8>, FormatError> {
    let Some(first) = packed.first() else {
        return Ok(None);
    };
    let counts = graph.tree_counts();
    for p in packed {
        let count = counts.get(usize::from(p.level)).copied().unwrap_or(0);
        let one = packed::unpack_channel(p, count).map_err(|(c, d)| corrupt(c, d))?;
        take_channel(attributes, one, p.kind);
    }
    Ok(Some(first.level))
}

/// Each leaf given its ancestor's values on `level`, where the channels hold one value for
/// each node of that level (a tree's nodes in canonical order).
fn spread_values(tree: &mut Octree, level: u8) {
    if level == tree.depth {
        return;
    }
    fn one<T: Copy>(c: &mut Channel<T>, nodes: &[Node], depth: u8, level: u8) {
        if let Channel::PerLeaf(v) = c {
            *v = packed::spread(v, nodes, depth, level);
        }
    }
    let (n, d) = (&tree.nodes, tree.depth);
    let a = &mut tree.attributes;
    one(&mut a.normal, n, d, level);
    one(&mut a.contour, n, d, level);
    one(&mut a.colour, n, d, level);
    one(&mut a.reflectivity, n, d, level);
    one(&mut a.refractivity, n, d, level);
    one(&mut a.ior, n, d, level);
}

/// The graph the blocks of a file of the DAG layout hold, and the size of its tree: checks 14
/// to 16 on its levels and 17 on its leaves.
fn dag_levels(
    h: &Header,
    levels: &Levels,
    blocks: &[Vec<Vec<u8>>],
) -> Result<(DagLevels, TreeSize), FormatError> {
    let arrays: Vec<&[u8]> = blocks.iter().map(|b| b[0].as_slice()).collect();
    let counts: Vec<u64> = levels.table.iter().map(|e| e.nodes).collect();
    let dag = DagLevels::from_blocks(h.depth, &arrays, &counts)
        .map_err(|(check, detail)| corrupt(check, detail))?;
    let size = dag.tree_size();
    if size.leaves != h.leaf_count {
        return Err(corrupt(
            Check::LeafOrder,
            format!(
                "the graph stands for {} leaves, the header says {}",
                size.leaves, h.leaf_count
            ),
        ));
    }
    Ok((dag, size))
}

/// Checks 7 to 9 of a version-3 header: the depth, the chunk level below it, the root cube,
/// at most 8 leaves a node, and no more chunks than nodes or cells at the chunk level.
fn check_chunked_counts(h: &Header, c: Chunking, origin: DVec3) -> Result<(), (Check, String)> {
    // The depth and root cube as in every version; the counts below instead.
    check_root_and_counts(h.depth, origin, h.root_side, 1, 0)?;
    if c.level >= h.depth || c.level > MAX_CHUNK_LEVEL {
        return Err((
            Check::Depth,
            format!(
                "chunk level {} is not above depth {} or past {MAX_CHUNK_LEVEL}",
                c.level, h.depth
            ),
        ));
    }
    let cells = 1u64 << (3 * u32::from(c.level));
    if h.leaf_count > h.node_count.saturating_mul(8) || c.count > h.node_count || c.count > cells {
        return Err((
            Check::Counts,
            format!(
                "{} leaves, {} nodes, {} chunks: more than 8 leaves a node, more chunks than \
                 nodes, or more than the {cells} cells at level {}",
                h.leaf_count, h.node_count, c.count, c.level
            ),
        ));
    }
    Ok(())
}

/// Whether the tree of a version-3 header fits one tree in memory: at most 2^31 leaves, and
/// at most 2^31 nodes with the levels above the chunks (bounded by the chunk count, the
/// table unread).
fn check_fits(h: &Header) -> Result<(), FormatError> {
    let Some(c) = h.chunks else { return Ok(()) };
    let top: u64 = (0..u32::from(c.level))
        .map(|l| (1u64 << (3 * l)).min(c.count))
        .sum();
    let nodes = h.node_count.saturating_add(top);
    if h.leaf_count > MAX_LEAVES || nodes > MAX_LEAVES {
        return Err(FormatError::TooLarge {
            leaves: h.leaf_count,
            nodes,
            chunks: c.count,
        });
    }
    Ok(())
}

/// [`from_bytes`], also returning what the preamble and the header hold.
pub(crate) fn read_with_header(bytes: &[u8]) -> Result<(Octree, Preamble), FormatError> {
    let p = read_header(bytes)?;
    let h = &p.header;
    let gaps = check_layout(h, p.header_end(), bytes.len() as u64)?;
    // 13. Zero padding.
    if let Some(&(from, to)) = gaps
        .iter()
        .find(|&&(from, to)| bytes[from as usize..to as usize].iter().any(|&b| b != 0))
    {
        return Err(padding_error((from, to)));
    }
    let tree = arrays_into_tree(h, &mut |r, dst| {
        dst.copy_from_slice(&bytes[r.offset as usize..(r.offset + r.len) as usize]);
        Ok(())
    })?;
    finish_tree(tree, p)
}

/// Fills an array's bytes (`dst`, `r.len` of them) from the file: the arrays are asked for in
/// the file's order.
pub(crate) type Fetch<'a> = dyn FnMut(ArrayRef, &mut [u8]) -> Result<(), FormatError> + 'a;

/// An array of `r.len / size_of::<T>()` values filled by `fetch`.
fn array<T: bytemuck::Pod>(r: ArrayRef, fetch: &mut Fetch<'_>) -> Result<Vec<T>, FormatError> {
    let mut v = vec![T::zeroed(); r.len as usize / size_of::<T>()];
    fetch(r, bytemuck::cast_slice_mut(&mut v))?;
    Ok(v)
}

/// The tree of a header whose layout passed checks 7 to 12, its arrays filled by
/// `fetch(r, dst)` in the file's order (the nodes, then the per-leaf channels by kind).
fn arrays_into_tree(h: &Header, fetch: &mut Fetch<'_>) -> Result<Raw, FormatError> {
    let table: Option<Vec<ChunkRecord>> = match h.chunks {
        Some(c) => Some(array(c.table, fetch)?),
        None => None,
    };
    check_fits(h)?;
    let (nodes, blocks): (Vec<Node>, _) = match &h.levels {
        None => (array(h.nodes, fetch)?, Vec::new()),
        Some(levels) => (Vec::new(), read_blocks(h, levels.table.len(), fetch)?),
    };
    let mut attributes = LeafAttributes::default();
    let mut packed = Vec::new();
    for e in &h.channels {
        if let Storage::Packed { level, bits, array } = e.storage {
            let mut bytes = vec![0u8; array.len as usize];
            fetch(array, &mut bytes)?;
            packed.push(PackedRaw {
                kind: e.kind,
                level,
                bits,
                bytes,
            });
        } else {
            let one = read_channels(std::slice::from_ref(e), fetch)?;
            take_channel(&mut attributes, one, e.kind);
        }
    }
    let tree = Octree {
        root: RootCube {
            origin: DVec3::from_array(h.root_origin),
            side: h.root_side,
        },
        depth: h.depth,
        // Check 9 (versions 1, 2 and 4's tree layout) and `check_fits` (version 3) bound the
        // count by 2^31; the DAG layout's is checked against its graph before it is used.
        leaf_count: h.leaf_count.min(MAX_LEAVES) as u32,
        nodes,
        attributes,
        node_attributes: Default::default(),
    };
    Ok(Raw {
        tree,
        table,
        blocks,
        packed,
    })
}

/// The arrays of the first `count` levels' blocks of a version-4 file of header `h`, where
/// check 12 found them, filled by `fetch(r, dst)` in the file's order.
fn read_blocks(
    h: &Header,
    count: usize,
    fetch: &mut Fetch<'_>,
) -> Result<Vec<Vec<Vec<u8>>>, FormatError> {
    let Some(levels) = &h.levels else {
        return Ok(Vec::new());
    };
    let mut blocks = Vec::with_capacity(count);
    for (l, entry) in levels.table.iter().enumerate().take(count) {
        let mut at = entry.block.offset;
        let mut block = Vec::new();
        for len in level_lens(h, l).unwrap_or_default() {
            let mut v = vec![0u8; len as usize];
            fetch(ArrayRef { offset: at, len }, &mut v)?;
            at = (at + len).div_ceil(8) * 8;
            block.push(v);
        }
        blocks.push(block);
    }
    Ok(blocks)
}

/// The channels `channels` lists, their per-leaf arrays filled by `fetch(r, dst)` in their
/// order. Constants fit their element (check 10).
pub(crate) fn read_channels(
    channels: &[ChannelEntry],
    fetch: &mut Fetch<'_>,
) -> Result<LeafAttributes, FormatError> {
    let mut attributes = LeafAttributes::default();
    for e in channels {
        match (e.kind, e.storage) {
            (0, Storage::Constant(v)) => attributes.normal = Channel::Constant(v),
            (1, Storage::Constant(v)) => attributes.contour = Channel::Constant(v),
            (2, Storage::Constant(v)) => attributes.colour = Channel::Constant(v),
            (3, Storage::Constant(v)) => attributes.reflectivity = Channel::Constant(v as u8),
            (4, Storage::Constant(v)) => attributes.refractivity = Channel::Constant(v as u8),
            (5, Storage::Constant(v)) => attributes.ior = Channel::Constant(v as u16),
            (0, Storage::PerLeaf(r)) => attributes.normal = Channel::PerLeaf(array(r, fetch)?),
            (1, Storage::PerLeaf(r)) => attributes.contour = Channel::PerLeaf(array(r, fetch)?),
            (2, Storage::PerLeaf(r)) => attributes.colour = Channel::PerLeaf(array(r, fetch)?),
            (3, Storage::PerLeaf(r)) => {
                attributes.reflectivity = Channel::PerLeaf(array(r, fetch)?)
            }
            (4, Storage::PerLeaf(r)) => {
                attributes.refractivity = Channel::PerLeaf(array(r, fetch)?)
            }
            (5, Storage::PerLeaf(r)) => attributes.ior = Channel::PerLeaf(array(r, fetch)?),
            _ => return Err(corrupt(Check::Channels, "unknown channel")),
        }
    }
    Ok(attributes)
}

/// The arrays of a file as read: for version 3 the tree's nodes are the chunks' node arrays
/// one after another, with the chunk table beside them.
struct Raw {
    tree: Octree,
    table: Option<Vec<ChunkRecord>>,
    /// Version 4: each level's arrays, as read (the tree's nodes are then empty).
    blocks: Vec<Vec<Vec<u8>>>,
    /// The DAG layout: the channels stored on a level, unpacked once the graph is read.
    packed: Vec<PackedRaw>,
}

/// Checks 14 to 18 (the node words, the tree's shape, the node and leaf order, the values;
/// for version 3 first check 19, the chunk table, and 15 to 17 on each chunk, whose nodes
/// are then stitched into one tree), then the nodes' bounds.
fn finish_tree(raw: Raw, p: Preamble) -> Result<(Octree, Preamble), FormatError> {
    let Raw {
        mut tree,
        table,
        blocks,
        packed,
    } = raw;
    match (table, p.header.chunks, &p.header.levels) {
        (Some(table), Some(c), _) => {
            tree.nodes = unchunk(&tree, &table, c.level, &p.header)
                .map_err(|(check, detail)| corrupt(check, detail))?;
            check_values(&tree, p.version)
        }
        (_, _, Some(levels)) if levels.layout == DAG_LAYOUT => {
            check_level_hashes(levels, &blocks)?;
            let graph = dag_within_limits(&p.header, levels, &blocks)?;
            tree.nodes = graph.to_nodes();
            if let Some(level) = unpack_packed(&mut tree.attributes, &packed, &graph)? {
                spread_values(&mut tree, level);
            }
            check_renumbered(&tree, p.version)
        }
        (_, _, Some(levels)) => {
            check_level_hashes(levels, &blocks)?;
            let counts: Vec<u64> = levels.table.iter().map(|e| e.nodes).collect();
            let top = from_levels(
                tree.depth,
                &counts,
                &levels.node_channels,
                u64::from(tree.leaf_count),
                &blocks,
                counts.len(),
            )?;
            tree.nodes = top.nodes;
            tree.node_attributes = top.node_attributes;
            check_renumbered(&tree, p.version)
        }
        _ => check_tree(&tree, p.version, InfoBits::Zero),
    }
    .map_err(|(check, detail)| corrupt(check, detail))?;
    tree.refresh_checked_bounds();
    Ok((tree, p))
}

/// Check 22: each of `blocks` (the first levels' arrays, as read) hashes to its level's entry.
fn check_level_hashes(levels: &Levels, blocks: &[Vec<Vec<u8>>]) -> Result<(), FormatError> {
    for (l, (block, entry)) in blocks.iter().zip(&levels.table).enumerate() {
        let computed = block_hash(block);
        if computed != entry.hash {
            return Err(corrupt(
                Check::LevelChecksums,
                format!(
                    "level {l}'s block hashes to {computed:#018x}, its entry says {:#018x}",
                    entry.hash
                ),
            ));
        }
    }
    Ok(())
}

/// The top of a tree stored level by level.
pub(crate) struct TopLevels {
    /// The nodes of the levels walked, in the canonical order: level order where the tree
    /// keeps inner-node channels, else depth-first.
    pub nodes: Vec<Node>,
    /// The inner nodes' channels (a leaf parent's values, which files do not store, are 0).
    pub node_attributes: LeafAttributes,
    /// Where the levels walked stop short of the tree's depth: the leaves' channels of the
    /// coarser tree, the next level's node channels (none where that level keeps none).
    pub leaf_attributes: LeafAttributes,
}

/// Checks 14 and 15 to 17 on the first `walked` levels' blocks of a tree of `depth` levels
/// stored level by level (`counts` nodes a level, inner-node channels `node_channels`), and
/// returns them as a tree in the canonical order. Where `walked < depth`, `blocks` also holds
/// level `walked`, whose nodes become the leaves of a tree of `walked` levels: each node of
/// level `walked - 1` then refers to its children as leaves, which take their node channels.
pub(crate) fn from_levels(
    depth: u8,
    counts: &[u64],
    node_channels: &[crate::io::header::NodeChannelEntry],
    leaf_count: u64,
    blocks: &[Vec<Vec<u8>>],
    walked: usize,
) -> Result<TopLevels, FormatError> {
    let fail = |(c, d): (Check, String)| corrupt(c, d);
    let mut bfs: Vec<Node> = Vec::new();
    for block in &blocks[..walked] {
        bfs.extend(bytemuck::pod_collect_to_vec::<u8, Node>(&block[0]));
    }
    // 14. The node words; 15 to 17, level by level.
    check_node_words(&bfs).map_err(fail)?;
    check_level_order(&bfs, counts, walked, depth, leaf_count).map_err(fail)?;
    let short = walked < usize::from(depth);
    if short {
        // The last level walked points to the next level's nodes: they become leaves.
        let above: u64 = counts[..walked - 1].iter().sum();
        let start = above + counts[walked - 1];
        for n in &mut bfs[above as usize..] {
            if n.child_mask() != 0 {
                n.first = (-((i64::from(n.first) - start as i64) + 1)) as i32 as u32;
            }
        }
    }
    // A level's values in level order (the leaf parents' stay 0), or the next level's as
    // leaves'.
    let mut node_attributes = LeafAttributes::default();
    let mut leaf_attributes = LeafAttributes::default();
    let keeps = |l: usize| l + 2 <= usize::from(depth);
    let mut array = 1;
    for e in node_channels {
        let (node_one, leaf_one) = match e.storage {
            NodeStorage::Constant(v) => {
                let c = [ChannelEntry {
                    kind: e.kind,
                    storage: Storage::Constant(v),
                }];
                let one = read_channels(&c, &mut |_, _| Ok(()))?;
                (one.clone(), one)
            }
            NodeStorage::PerNode => {
                let size = ChannelKind::ALL[usize::from(e.kind)].element_size();
                let mut all = vec![0u8; bfs.len() * size];
                let mut i = 0usize;
                for (l, block) in blocks[..walked].iter().enumerate() {
                    let n = block[0].len() / 8;
                    if keeps(l) && l + 1 < walked {
                        // Check 12 held: one value a node of the level.
                        let len = (n * size).min(block[array].len());
                        all[i * size..i * size + len].copy_from_slice(&block[array][..len]);
                    }
                    i += n;
                }
                let leaves: &[u8] = match blocks.get(walked) {
                    Some(b) if short && keeps(walked) => &b[array],
                    _ => &[],
                };
                array += 1;
                (values(e.kind, &all)?, values(e.kind, leaves)?)
            }
        };
        take_channel(&mut node_attributes, node_one, e.kind);
        take_channel(&mut leaf_attributes, leaf_one, e.kind);
    }
    if short && !keeps(walked) {
        // The next level is the leaf parents', which keep no values: a coarser tree of cubes.
        node_attributes = LeafAttributes::default();
        leaf_attributes = LeafAttributes::default();
    }
    // A tree without inner-node channels keeps the depth-first order.
    let nodes = if node_attributes.stored().is_empty() {
        depth_first(&bfs).0
    } else {
        bfs
    };
    Ok(TopLevels {
        nodes,
        node_attributes,
        leaf_attributes,
    })
}

/// Channel `kind` with the values `bytes` holds, one per node or leaf.
fn values(kind: u8, bytes: &[u8]) -> Result<LeafAttributes, FormatError> {
    let r = ArrayRef {
        offset: 0,
        len: bytes.len() as u64,
    };
    let entry = [ChannelEntry {
        kind,
        storage: Storage::PerLeaf(r),
    }];
    read_channels(&entry, &mut |_, dst| {
        dst.copy_from_slice(bytes);
        Ok(())
    })
}

/// A failed check of chunk `i`, its message naming the chunk.
pub(crate) fn in_chunk(i: usize, code: u64) -> impl Fn((Check, String)) -> (Check, String) {
    move |(check, detail)| (check, format!("chunk {i} (code {code}): {detail}"))
}

/// Where each chunk of `table` starts: its first node in the node array and its first leaf.
pub(crate) fn chunk_starts(table: &[ChunkRecord]) -> Vec<(u64, u64)> {
    let (mut node, mut leaf) = (0u64, 0u64);
    table
        .iter()
        .map(|r| {
            let start = (node, leaf);
            node += r.nodes;
            leaf += r.leaves;
            start
        })
        .collect()
}

/// Check 19: the chunk table against the chunk level and the header's counts.
fn check_table(table: &[ChunkRecord], level: u8, h: &Header) -> Result<(), (Check, String)> {
    let cells = 1u64 << (3 * u32::from(level));
    let (mut nodes, mut leaves) = (0u64, 0u64);
    for (i, r) in table.iter().enumerate() {
        let bad = |what: String| Err(in_chunk(i, r.code)((Check::Chunks, what)));
        if r.code >= cells || (i > 0 && r.code <= table[i - 1].code) {
            return bad(format!(
                "codes must increase and stay below {cells} (the cells at level {level})"
            ));
        }
        if r.nodes == 0 || r.nodes > MAX_LEAVES {
            return bad(format!("{} nodes, not 1 to 2^31", r.nodes));
        }
        if r.leaves == 0 || r.leaves > MAX_LEAVES || r.leaves > 8 * r.nodes {
            return bad(format!(
                "{} leaves, not 1 to 2^31 and at most 8 for each of its {} nodes",
                r.leaves, r.nodes
            ));
        }
        nodes += r.nodes;
        leaves += r.leaves;
    }
    if nodes != h.node_count || leaves != h.leaf_count {
        return Err((
            Check::Chunks,
            format!(
                "the chunks hold {nodes} nodes and {leaves} leaves, the header says {} and {}",
                h.node_count, h.leaf_count
            ),
        ));
    }
    Ok(())
}

/// Checks 19, 14 and 15 to 17 (each on every chunk) of a version-3 tree whose node array is
/// its chunks' (`raw.nodes`), and returns its nodes in one canonical node array.
fn unchunk(
    raw: &Octree,
    table: &[ChunkRecord],
    level: u8,
    h: &Header,
) -> Result<Vec<Node>, (Check, String)> {
    check_table(table, level, h)?;
    check_node_words(&raw.nodes)?;
    // 15 and 16 on every chunk, then 17 on every chunk.
    let starts = chunk_starts(table);
    let slice = |i: usize| {
        let from = starts[i].0 as usize;
        &raw.nodes[from..from + table[i].nodes as usize]
    };
    let mut leaf_order = Vec::with_capacity(table.len());
    for (i, r) in table.iter().enumerate() {
        leaf_order.push(
            check_shape_and_node_order(slice(i), h.depth - level, false, r.leaves)
                .map_err(in_chunk(i, r.code))?,
        );
    }
    for (i, r) in table.iter().enumerate() {
        if !leaf_order[i] {
            check_leaf_order(slice(i), r.leaves).map_err(in_chunk(i, r.code))?;
        }
    }
    // One canonical node array: the levels above the chunks, each chunk's nodes moved.
    let stubs: Vec<Stub> = table
        .iter()
        .map(|r| Stub {
            code: r.code,
            below: r.nodes - 1,
        })
        .collect();
    let mut out = Vec::with_capacity(stitch::node_count(&stubs, level) as usize);
    let overflow = || (Check::Chunks, "the tree's pointers overflow".to_string());
    stitch::stitch(&stubs, level, &mut |piece| {
        let mut put = |index: usize, from: usize, to: usize, at: u64| {
            for &n in &slice(index)[from..to] {
                out.push(moved(n, at as i64 - 1, starts[index].1 as i64).ok_or_else(overflow)?);
            }
            Ok(())
        };
        match piece {
            Piece::Top(n) => {
                out.push(n);
                Ok(())
            }
            Piece::Root { index, at } => put(index, 0, 1, at),
            Piece::Below { index, at } => put(index, 1, table[index].nodes as usize, at),
        }
    })?;
    Ok(out)
}

/// What [`read_file_with_header`] read: the tree, the preamble and header, the stored
/// checksum and the file's length.
pub(crate) struct FileRead {
    pub tree: Octree,
    pub preamble: Preamble,
    pub checksum: u64,
    pub len: u64,
}

/// Reads and validates a `.svo` file in one pass from disk: the same checks in the same
/// order as [`from_bytes`], but each array is read straight into the tree's own array and
/// hashed as it passes, so no copy of the file is held beside the tree.
pub(crate) fn read_file_with_header(path: &Path) -> Result<FileRead, FormatError> {
    read_path(path, &mut |raw, p| finish_tree(raw, p)).map(|(tree, preamble, checksum, len)| {
        FileRead {
            tree,
            preamble,
            checksum,
            len,
        }
    })
}

/// A file of the DAG layout read whole with every check, its graph kept: the tree's level
/// sizes counted on the graph (the root's level first, the leaves last), the file's leaves'
/// channels (in a tree without nodes), the header, the checksum and the file's length.
pub(crate) fn read_dag_sizes(path: &Path) -> Result<(Vec<u64>, FileRead), FormatError> {
    read_path(path, &mut |raw, p| {
        let (graph, _, tree, _) = dag_of_raw(raw, &p)?;
        Ok(((graph.tree_counts(), tree), p))
    })
    .map(|((counts, tree), preamble, checksum, len)| {
        (
            counts,
            FileRead {
                tree,
                preamble,
                checksum,
                len,
            },
        )
    })
}

/// What [`read_stream`]'s caller makes of the arrays read and the header.
type Finish<'a, X> = dyn FnMut(Raw, Preamble) -> Result<(X, Preamble), FormatError> + 'a;

/// The file at `path` read in one pass (as [`read_file_with_header`]), its tree made by
/// `finish` from the arrays read and the header: what `finish` makes, the header, the
/// checksum and the file's length.
fn read_path<X>(
    path: &Path,
    finish: &mut Finish<'_, X>,
) -> Result<(X, Preamble, u64, u64), FormatError> {
    let io = |cause| FormatError::Io {
        path: path.display().to_string(),
        cause,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let len = f.metadata().map_err(io)?.len();
    read_stream(std::io::BufReader::with_capacity(1 << 20, f), len, finish).map_err(|e| match e {
        FormatError::Io { cause, .. } => io(cause),
        e => e,
    })
}

/// [`read_path`] from `r`, which holds `len` bytes.
fn read_stream<X>(
    r: impl std::io::Read,
    len: u64,
    finish: &mut Finish<'_, X>,
) -> Result<(X, Preamble, u64, u64), FormatError> {
    use std::io::Read;
    let io = |cause| FormatError::Io {
        path: "<reader>".into(),
        cause,
    };
    let (mut src, p, gaps) = open_stream(r, len)?;
    let mut padding: Option<(u64, u64)> = None;
    let mut gaps = gaps.into_iter();
    let tree = arrays_into_tree(&p.header, &mut |r, dst| {
        // The padding before the array.
        if let Some(gap) = gaps.next() {
            src.read_gap(gap, &mut padding).map_err(io)?;
        }
        debug_assert_eq!(src.at, r.offset);
        src.read_exact(dst).map_err(io)
    })?;
    // The padding after the last array, then the checksum.
    for gap in gaps {
        src.read_gap(gap, &mut padding).map_err(io)?;
    }
    let checksum = src.checksum()?;
    if let Some(gap) = padding {
        return Err(padding_error(gap));
    }
    let (x, preamble) = finish(tree, p)?;
    Ok((x, preamble, checksum, len))
}

/// Reads the file at `path` as a [`DagTree`] with every check of [`read_file`]: a file of the
/// DAG layout (`docs/format.md`, section 12) without making the tree it stands for, so in
/// memory about the size of its graph and its leaf channels; a file of another layout as its
/// tree, reduced to its graph. The leaves' channels are kept as the file stores them.
///
/// ```
/// use glam::{DVec3, UVec3};
/// use svo::io::{BuildInfo, read_dag_file, write_dag_file};
/// use svo::{Octree, RootCube, Voxel};
/// let root = RootCube { origin: DVec3::ZERO, side: 1.0 };
/// let cells = (0..64u32).map(|i| UVec3::new(i % 4, i / 4 % 4, i / 16) * 2);
/// let tree = Octree::from_cells(root, 3, cells.map(|c| (c, Voxel::glass())))?;
/// let path = std::env::temp_dir().join("svo-doc-read-dag.svo");
/// write_dag_file(&tree, &BuildInfo::new(), &path)?;
/// let (dag, _) = read_dag_file(&path)?;
/// // The root and one brick, which every child of the root shares.
/// assert_eq!((dag.leaf_count(), dag.level_counts()), (64, vec![1, 1]));
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[cfg(feature = "trace")]
pub fn read_dag_file(path: impl AsRef<Path>) -> Result<(DagTree, BuildInfo), FormatError> {
    let (dag, p, ..) = read_path(path.as_ref(), &mut |raw, p| {
        if !is_dag(&p.header) {
            let (mut tree, p) = finish_tree(raw, p)?;
            let attributes = std::mem::take(&mut tree.attributes);
            let mut dag = DagTree::from_tree(&tree)?;
            dag.attributes = attributes;
            return Ok((dag, p));
        }
        let (graph, size, tree, level) = dag_of_raw(raw, &p)?;
        let per_leaf = tree.attributes.per_leaf_bytes() > 0;
        let values = level.unwrap_or(tree.depth);
        let mut dag = DagTree::from_levels(tree.root, graph, size.leaves, values, per_leaf)?;
        dag.attributes = tree.attributes;
        Ok((dag, p))
    })?;
    Ok((dag, p.header.build))
}

/// Reads the top `max_depth` levels of a `.svo` file as a valid tree of that depth (at least
/// 1): the nodes on level `max_depth` become its leaves, with their inner-node channels as the
/// leaves' (none where the file has none, or where that level is the leaf parents', which
/// keep none). A file of `max_depth` levels or fewer is read whole, as [`read_file`] does.
///
/// A version-4 file is read as a prefix: the preamble and header, then the blocks of levels 0
/// to `max_depth` and nothing after them, in time and memory proportional to those levels.
/// What is read is checked (checks 1 to 4, 20, 6 to 12 and 21 from the header and the file's
/// length, then 13, 22 and 14 to 18 on the levels read); the whole-file checksum (check 5) is
/// not, since it needs every byte. A file of the DAG layout, whose levels are a graph's, is
/// read whole with every check and only the top levels of its tree are made from the graph,
/// so a graph past 2^31 leaves opens coarse. A version-3 file (chunks) is read in one pass holding one
/// chunk's nodes at a time, so a tree past 2^31 leaves opens coarse; a version-2 file is read
/// whole and cut in memory.
///
/// ```
/// use glam::{DVec3, UVec3};
/// use svo::io::{read_file_to_depth, write_file, BuildInfo};
/// use svo::{BakeOptions, Mesh, bake_mesh};
/// let sphere = Mesh::sphere(DVec3::splat(0.5), 0.4, 16);
/// let opts = BakeOptions { depth: 6, node_attributes: true, ..Default::default() };
/// let tree = bake_mesh(&sphere, &opts)?.0;
/// let path = std::env::temp_dir().join("svo-doc-read-to-depth.svo");
/// write_file(&tree, &BuildInfo::new(), &path)?; // version 4: levels first
/// let (top, _) = read_file_to_depth(&path, 3)?;
/// assert_eq!(top.depth, 3);
/// assert!(top.attributes.normal.is_per_leaf()); // the level-3 nodes' normals
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_file_to_depth(
    path: impl AsRef<Path>,
    max_depth: u8,
) -> Result<(Octree, BuildInfo), FormatError> {
    use std::io::Read;
    let path = path.as_ref();
    let io = |cause| FormatError::Io {
        path: path.display().to_string(),
        cause,
    };
    let max_depth = max_depth.max(1);
    let mut start = FileStart::open(path)?;
    if start.version == CHUNKED_VERSION {
        let p = start.header()?;
        return chunked_to_depth(path, &p.header, max_depth);
    }
    if start.version < LEVELS_VERSION {
        let (tree, build) = read_file(path)?;
        return Ok((cut_to_depth(&tree, max_depth)?, build));
    }
    let (p, levels, gaps) = start.levels_header()?;
    let h = &p.header;
    let levels = &levels;
    if max_depth >= h.depth {
        return read_file(path);
    }
    if levels.layout == DAG_LAYOUT {
        // A graph's levels are no tree's: the graph is read whole, and only the tree's top
        // levels made.
        drop(start);
        return dag_file_to_depth(path, max_depth);
    }
    // Everything up to the end of level `max_depth`'s block.
    let k = usize::from(max_depth);
    let last = levels.table[k].block;
    let end = last.offset + last.len;
    let mut bytes = std::mem::take(&mut start.prefix);
    if (bytes.len() as u64) < end {
        let have = bytes.len();
        bytes.resize(end as usize, 0);
        start.file.read_exact(&mut bytes[have..]).map_err(io)?;
    }
    bytes.truncate(end as usize);
    // 13. The padding read.
    if let Some(&gap) = gaps
        .iter()
        .filter(|g| g.1 <= end)
        .find(|&&(from, to)| bytes[from as usize..to as usize].iter().any(|&b| b != 0))
    {
        return Err(padding_error(gap));
    }
    let blocks = read_blocks(h, k + 1, &mut |r, dst| {
        dst.copy_from_slice(&bytes[r.offset as usize..(r.offset + r.len) as usize]);
        Ok(())
    })?;
    drop(bytes);
    check_level_hashes(levels, &blocks)?;
    let counts: Vec<u64> = levels.table.iter().map(|e| e.nodes).collect();
    let top = from_levels(
        h.depth,
        &counts,
        &levels.node_channels,
        h.leaf_count,
        &blocks,
        k,
    )?;
    let root = RootCube {
        origin: DVec3::from_array(h.root_origin),
        side: h.root_side,
    };
    let tree = top_tree(root, top, max_depth, counts[k], p.version)?;
    Ok((tree, p.header.build))
}

/// The graph a DAG-layout file's blocks hold (checks 22, 14 to 17), the size of its tree, and
/// the file's tree without nodes (its root cube and values, checks 17 and 18 applied): per
/// leaf, or one for each node of the level the file keeps them on (returned).
fn dag_of_raw(
    raw: Raw,
    p: &Preamble,
) -> Result<(DagLevels, TreeSize, Octree, Option<u8>), FormatError> {
    let Raw {
        mut tree,
        blocks,
        packed,
        ..
    } = raw;
    let Some(levels) = &p.header.levels else {
        return Err(corrupt(Check::Header, "a version-4 header without levels"));
    };
    check_level_hashes(levels, &blocks)?;
    let (graph, size) = dag_levels(&p.header, levels, &blocks)?;
    let level = unpack_packed(&mut tree.attributes, &packed, &graph)?;
    check_values(&tree, p.version).map_err(|(c, d)| corrupt(c, d))?;
    Ok((graph, size, tree, level))
}

/// The top `max_depth` levels (fewer than the file's) of the tree that the DAG-layout file at
/// `path` stands for: its graph read whole, only those levels of the tree made (their last
/// level's nodes the leaves, without channels: a graph's nodes keep none). Refused when they
/// pass 2^31 leaves or nodes.
fn dag_file_to_depth(path: &Path, max_depth: u8) -> Result<(Octree, BuildInfo), FormatError> {
    let k = usize::from(max_depth);
    let (tree, p, ..) = read_path(path, &mut |raw, p| {
        let (graph, _, file, _) = dag_of_raw(raw, &p)?;
        let counts = graph.tree_counts();
        let (nodes, leaves) = (counts[..k].iter().sum::<u64>(), counts[k]);
        if leaves > MAX_LEAVES || nodes > MAX_LEAVES {
            return Err(FormatError::DagTooLarge { leaves, nodes });
        }
        let mut tree = Octree {
            root: file.root,
            depth: max_depth,
            nodes: graph.to_nodes_to(k),
            leaf_count: leaves as u32,
            attributes: LeafAttributes::default(),
            node_attributes: LeafAttributes::default(),
        };
        check_renumbered(&tree, LEVELS_VERSION).map_err(|(c, d)| corrupt(c, d))?;
        tree.refresh_checked_bounds();
        Ok((tree, p))
    })?;
    Ok((tree, p.header.build))
}

/// The stretches of padding between a file's arrays, `(from, to)` byte offsets.
type Gaps = Vec<(u64, u64)>;

/// A file's first bytes, as the readers of its top levels and of its level table take them.
struct FileStart {
    /// The file, just past `prefix`.
    file: std::fs::File,
    /// Its length.
    len: u64,
    /// Its preamble and header, and what follows them up to a header's largest length.
    prefix: Vec<u8>,
    /// Its version (checks 1 to 4 made).
    version: u32,
    /// Its header's length.
    hlen: usize,
}

impl FileStart {
    /// Opens the file at `path` and reads its start (checks 1 to 4).
    fn open(path: &Path) -> Result<Self, FormatError> {
        use std::io::Read;
        let io = |cause| FormatError::Io {
            path: path.display().to_string(),
            cause,
        };
        let mut file = std::fs::File::open(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        let mut prefix = vec![0u8; len.min((PREAMBLE_LEN + MAX_HEADER_LEN + 16) as u64) as usize];
        file.read_exact(&mut prefix).map_err(io)?;
        let (version, hlen) = check_preamble(&prefix, len)?;
        Ok(Self {
            file,
            len,
            prefix,
            version,
            hlen,
        })
    }

    /// The header, decoded (check 6).
    fn header(&self) -> Result<Preamble, FormatError> {
        decode_header(
            &self.prefix[PREAMBLE_LEN..PREAMBLE_LEN + self.hlen],
            self.version,
        )
    }

    /// A version-4 header, checked (checks 20, 6 to 12 and 21 from the header and the file's
    /// length), with its levels and the padding's gaps.
    fn levels_header(&self) -> Result<(Preamble, Levels, Gaps), FormatError> {
        check_header_checksum(&self.prefix, self.version, self.hlen)?;
        let p = self.header()?;
        let gaps = check_layout(&p.header, p.header_end(), self.len)?;
        let Some(levels) = p.header.levels.clone() else {
            return Err(corrupt(Check::Header, "a version-4 header without levels"));
        };
        Ok((p, levels, gaps))
    }
}

/// The top `max_depth` levels of the version-3 file at `path`, as [`cut_to_depth`] makes them
/// of the whole tree (the leaves are the nodes of level `max_depth`, without values: version 3
/// stores none for inner nodes), in one pass over the file that holds one chunk's nodes at a
/// time (every check but the values', as [`ChunkedFile::open`](crate::io::ChunkedFile::open)),
/// and memory for the top levels: a tree past 2^31 leaves opens coarse. At its full depth the
/// file is read whole.
fn chunked_to_depth(
    path: &Path,
    header: &Header,
    max_depth: u8,
) -> Result<(Octree, BuildInfo), FormatError> {
    let (depth, Some(chunks)) = (header.depth, header.chunks) else {
        return Err(corrupt(Check::Header, "a version-3 header without chunks"));
    };
    if max_depth >= depth {
        return read_file(path);
    }
    let level = chunks.level;
    // The cells of level `max_depth`, as Morton keys in increasing order.
    let mut keys: Vec<(u128, ())> = Vec::new();
    let read = chunks_pass(path, false, &mut |_, rec, nodes| {
        if max_depth <= level {
            let key = u128::from(rec.code >> (3 * u32::from(level - max_depth)));
            if keys.last().map(|k| k.0) != Some(key) {
                keys.push((key, ()));
            }
        } else {
            cells_below(nodes, 0, u128::from(rec.code), max_depth - level, &mut keys);
        }
    })?
    .0;
    let h = &read.preamble.header;
    let (nodes, _) = crate::octree::builder::layout_sorted(&keys, max_depth);
    let mut tree = Octree {
        root: RootCube {
            origin: DVec3::from_array(h.root_origin),
            side: h.root_side,
        },
        depth: max_depth,
        nodes,
        // At most the file's leaves' parents (a tree past 2^31 leaves cut at 2^31 cells of a
        // level is refused by the check below).
        leaf_count: u32::try_from(keys.len()).unwrap_or(u32::MAX),
        attributes: LeafAttributes::default(),
        node_attributes: LeafAttributes::default(),
    };
    if keys.len() as u64 > MAX_LEAVES {
        return Err(corrupt(
            Check::Counts,
            format!(
                "its top {max_depth} levels have {} leaves, more than one tree holds (2^31)",
                keys.len()
            ),
        ));
    }
    tree.refresh_checked_bounds();
    Ok((tree, read.preamble.header.build))
}

/// Appends the Morton keys of the nodes `levels` below node `i` of a chunk's nodes (key
/// `key`), in increasing order.
fn cells_below(nodes: &[Node], i: usize, key: u128, levels: u8, out: &mut Vec<(u128, ())>) {
    if levels == 0 {
        out.push((key, ()));
        return;
    }
    let Some(&n) = nodes.get(i) else {
        return;
    };
    for c in 0..8u8 {
        let Some(rank) = n.child_rank(c) else {
            continue;
        };
        let child = key << 3 | u128::from(c);
        if levels == 1 {
            out.push((child, ()));
        } else if n.leaf_base().is_none() {
            cells_below(nodes, (n.first + rank) as usize, child, levels - 1, out);
        }
    }
}

/// What the levels of a version-4 file hold, from its header alone: enough to tell how large
/// a tree of its top `k` levels is before reading any of it.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct LevelSizes {
    /// Nodes on each level, the root's first (`depth` entries), then the leaves.
    pub counts: Vec<u64>,
    /// Bytes of a leaf's per-leaf channels.
    pub leaf_bytes: u64,
    /// Bytes of an inner node's per-node channels (on levels `0 .. depth - 2`).
    pub node_bytes: u64,
}

/// Whether the file at `path` is of the DAG layout (a version-4 file whose levels hold a
/// graph, `docs/format.md` section 12), read from its header (checks 1 to 4, 20, 6 to 12 and
/// 21): what [`read_dag_file`] reads without making the tree.
pub fn is_dag_file(path: impl AsRef<Path>) -> Result<bool, FormatError> {
    let start = FileStart::open(path.as_ref())?;
    if start.version < LEVELS_VERSION {
        return Ok(false);
    }
    let (_, levels, _) = start.levels_header()?;
    Ok(levels.layout == DAG_LAYOUT)
}

/// The level sizes of the version-4 file at `path`, read from its header (checks 1 to 4, 20,
/// 6 to 12 and 21, as [`read_file_to_depth`] makes them); `None` for a file of an older
/// version, which has no level table. A file of the DAG layout, whose levels hold a graph's
/// distinct nodes, is read whole with every check of [`read_file`] and its tree's levels
/// counted from the graph, without the tree being made.
pub fn read_level_sizes(path: impl AsRef<Path>) -> Result<Option<LevelSizes>, FormatError> {
    let start = FileStart::open(path.as_ref())?;
    if start.version < LEVELS_VERSION {
        return Ok(None);
    }
    let (p, levels, _) = start.levels_header()?;
    let counts = if levels.layout == DAG_LAYOUT {
        // The tree's levels, which the graph gives.
        drop(start);
        read_dag_sizes(path.as_ref())?.0
    } else {
        let mut counts: Vec<u64> = levels.table.iter().map(|e| e.nodes).collect();
        counts.push(p.header.leaf_count);
        counts
    };
    let h = &p.header;
    let size = |kind: u8| {
        ChannelKind::ALL
            .get(usize::from(kind))
            .map_or(0, |k| k.element_size() as u64)
    };
    Ok(Some(LevelSizes {
        counts,
        leaf_bytes: h
            .channels
            .iter()
            .filter(|c| matches!(c.storage, Storage::PerLeaf(_)))
            .map(|c| size(c.kind))
            .sum(),
        node_bytes: levels
            .node_channels
            .iter()
            .filter(|c| c.storage == NodeStorage::PerNode)
            .map(|c| size(c.kind))
            .sum(),
    }))
}

/// The tree of `top` (a tree's first `depth` levels in `root`, with `leaves` leaves, read from
/// a file of `version`), checked (its counts, channels and values: checks 14 to 17 held in
/// level order) and with its bounds.
fn top_tree(
    root: RootCube,
    top: TopLevels,
    depth: u8,
    leaves: u64,
    version: u32,
) -> Result<Octree, FormatError> {
    let mut tree = Octree {
        root,
        depth,
        nodes: top.nodes,
        // At most 8 a node of the level above, so within 2^31 with the file's node count.
        leaf_count: leaves as u32,
        attributes: top.leaf_attributes,
        node_attributes: top.node_attributes,
    };
    check_renumbered(&tree, version).map_err(|(c, d)| corrupt(c, d))?;
    tree.refresh_checked_bounds();
    Ok(tree)
}

/// The top `depth` levels of a tree in memory, as [`read_file_to_depth`] reads them from a
/// version-4 file.
fn cut_to_depth(tree: &Octree, depth: u8) -> Result<Octree, FormatError> {
    if depth >= tree.depth {
        return Ok(tree.clone());
    }
    let (plan, blocks) = crate::io::write::level_blocks(tree);
    let k = usize::from(depth);
    let top = from_levels(
        tree.depth,
        &plan.counts,
        &plan.node_channels,
        u64::from(tree.leaf_count),
        &blocks[..=k],
        k,
    )?;
    top_tree(tree.root, top, depth, plan.counts[k], LEVELS_VERSION)
}

/// What [`check_chunks_file`] read of a version-3 file without loading its tree.
#[derive(Debug)]
pub(crate) struct ChunksRead {
    pub preamble: Preamble,
    pub table: Vec<ChunkRecord>,
    pub checksum: u64,
    pub len: u64,
}

/// One chunk's arrays as [`read_chunks_file`] read them: its nodes and its channels.
pub(crate) struct ChunkArrays {
    pub nodes: Vec<Node>,
    pub attributes: LeafAttributes,
}

/// Checks a version-3 file one chunk at a time, holding one chunk's nodes at a time: checks 1
/// to 12, the padding (13), the chunk table (19), each chunk's node words, shape, node order
/// and leaf order (14 to 17), and the checksum over every byte. The channel arrays are hashed,
/// not read (check 18 is not made). A file that fails the checksum and another check fails at
/// the checksum; one whose padding fails and a later check fails at the padding.
pub(crate) fn check_chunks_file(path: &Path) -> Result<ChunksRead, FormatError> {
    chunks_pass(path, false, &mut |_, _, _| {}).map(|(read, _)| read)
}

/// [`check_chunks_file`] keeping every chunk's nodes and reading its stretch of each
/// channel array in the same pass: the file is read once. The checks of each chunk's nodes
/// (14 to 17) and values (18) are the caller's, chunk by chunk (they need not run in order).
pub(crate) fn read_chunks_file(path: &Path) -> Result<(ChunksRead, Vec<ChunkArrays>), FormatError> {
    chunks_pass(path, true, &mut |_, _, _| {})
}

/// One pass over a version-3 file as [`check_chunks_file`] makes it, keeping each chunk's
/// arrays (`keep`) or handing each chunk's checked nodes to `visit` (its index, record and
/// nodes) in turn: a caller's results are good only where the pass returns `Ok`.
fn chunks_pass(
    path: &Path,
    keep: bool,
    visit: &mut dyn FnMut(usize, &ChunkRecord, &[Node]),
) -> Result<(ChunksRead, Vec<ChunkArrays>), FormatError> {
    use std::io::Read;
    let io = |cause| FormatError::Io {
        path: path.display().to_string(),
        cause,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let len = f.metadata().map_err(io)?.len();
    let (mut src, p, gaps) = open_stream(std::io::BufReader::with_capacity(1 << 20, f), len)
        .map_err(|e| match e {
            FormatError::Io { cause, .. } => io(cause),
            e => e,
        })?;
    let version = p.version;
    let Some(c) = p.header.chunks else {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "a version-{version} file holds one tree, not chunks: read it whole (svo::io::read_file)"
            ),
        )));
    };
    // Gaps: before the table, before the nodes, then after each array.
    let mut gaps = gaps.into_iter();
    let mut padding = None;
    let mut gap = |src: &mut Hashed<_>, padding: &mut Option<(u64, u64)>| match gaps.next() {
        Some(g) => src.read_gap(g, padding).map_err(io),
        None => Ok(()),
    };
    gap(&mut src, &mut padding)?;
    let mut table = vec![ChunkRecord::default(); c.count as usize];
    src.read_exact(bytemuck::cast_slice_mut(&mut table))
        .map_err(io)?;
    gap(&mut src, &mut padding)?;
    let mut failure = check_table(&table, c.level, &p.header)
        .err()
        .map(|e| corrupt(e.0, e.1));
    // Each chunk's nodes (the table is sound, so they fill the node array exactly).
    let mut kept: Vec<ChunkArrays> = Vec::new();
    let mut scratch: Vec<Node> = Vec::new();
    if failure.is_none() {
        for (i, rec) in table.iter().enumerate() {
            // Kept chunks each get their own array; else one array serves every chunk.
            let mut nodes = std::mem::take(&mut scratch);
            nodes.clear();
            nodes.resize(rec.nodes as usize, Node::default());
            src.read_exact(bytemuck::cast_slice_mut(&mut nodes))
                .map_err(io)?;
            if keep {
                kept.push(ChunkArrays {
                    nodes,
                    attributes: LeafAttributes::default(),
                });
                continue;
            }
            if let Err(e) = check_chunk(&nodes, p.header.depth - c.level, rec.leaves) {
                let (check, detail) = in_chunk(i, rec.code)(e);
                failure = Some(corrupt(check, detail));
                break;
            }
            visit(i, rec, &nodes);
            scratch = nodes;
        }
    }
    // The channels: each per-leaf array's stretches, chunk after chunk, where the chunks
    // are kept (and the table sound); else only the padding between the arrays is read.
    src.skip_to(p.header.nodes.offset + p.header.nodes.len)
        .map_err(io)?;
    gap(&mut src, &mut padding)?;
    let starts = chunk_starts(&table);
    for e in &p.header.channels {
        // `kept` is empty unless the chunks are kept and the table is sound.
        for ((k, rec), start) in kept.iter_mut().zip(&table).zip(&starts) {
            let part = chunk_channel(e, start.1, rec.leaves);
            let one = read_channels(&[part], &mut |r, dst| {
                debug_assert_eq!(src.at, r.offset);
                src.read_exact(dst).map_err(io)
            })?;
            take_channel(&mut k.attributes, one, e.kind);
        }
        if let Storage::PerLeaf(r) = e.storage {
            src.skip_to(r.offset + r.len).map_err(io)?;
            gap(&mut src, &mut padding)?;
        }
    }
    src.skip_to(len - 8).map_err(io)?;
    let checksum = src.checksum()?;
    match padding.map(padding_error).or(failure) {
        Some(e) => Err(e),
        None => Ok((
            ChunksRead {
                preamble: p,
                table,
                checksum,
                len,
            },
            kept,
        )),
    }
}

/// Channel `e` of the chunk whose leaves are `first_leaf..first_leaf + leaves` of the whole
/// tree: its stretch of a per-leaf array, or the same constant.
pub(crate) fn chunk_channel(e: &ChannelEntry, first_leaf: u64, leaves: u64) -> ChannelEntry {
    let size = ChannelKind::ALL[usize::from(e.kind)].element_size() as u64;
    let storage = match e.storage {
        Storage::PerLeaf(r) => Storage::PerLeaf(ArrayRef {
            offset: r.offset + first_leaf * size,
            len: leaves * size,
        }),
        constant => constant,
    };
    ChannelEntry { storage, ..*e }
}

/// Puts channel `kind` of `from` into `into`.
fn take_channel(into: &mut LeafAttributes, from: LeafAttributes, kind: u8) {
    match kind {
        0 => into.normal = from.normal,
        1 => into.contour = from.contour,
        2 => into.colour = from.colour,
        3 => into.reflectivity = from.reflectivity,
        4 => into.refractivity = from.refractivity,
        _ => into.ior = from.ior,
    }
}

/// A file of `len` bytes in `r`, read up to its arrays: checks 1 to 4 on its first bytes, and
/// from there every byte hashed as it passes; then checks 6 to 12 on its header, of which a
/// file that also fails the checksum fails at the checksum (read to its end for that).
/// Returns the reader at the end of the header, the preamble, and the padding gaps.
#[allow(clippy::type_complexity)]
fn open_stream<R: std::io::Read>(
    mut r: R,
    len: u64,
) -> Result<(Hashed<impl std::io::Read>, Preamble, Vec<(u64, u64)>), FormatError> {
    use std::io::Read;
    let io = |cause| FormatError::Io {
        path: "<reader>".into(),
        cause,
    };
    // The preamble and the header (at most their largest size, and never past the end).
    let mut prefix = vec![0u8; len.min((PREAMBLE_LEN + MAX_HEADER_LEN + 8) as u64) as usize];
    r.read_exact(&mut prefix).map_err(io)?;
    let (version, hlen) = check_preamble(&prefix, len)?;
    // From here every byte before the checksum is hashed as it is consumed, from the start.
    let mut src = Hashed {
        inner: std::io::Cursor::new(prefix).chain(r),
        hash: xxhash_rust::xxh3::Xxh3::new(),
        at: 0,
        body: len - 8,
    };
    let end = header_end(version, hlen);
    let mut header = vec![0u8; end as usize];
    src.read_exact(&mut header).map_err(io)?;
    let parsed = check_header_checksum(&header, version, hlen)
        .and_then(|()| decode_header(&header[PREAMBLE_LEN..PREAMBLE_LEN + hlen], version))
        .and_then(|p| check_layout(&p.header, end, len).map(|gaps| (p, gaps)));
    match parsed {
        Ok((p, gaps)) => Ok((src, p, gaps)),
        // A file that fails both the checksum and a later check fails at the checksum.
        Err(e) => {
            src.skip_to(len - 8).map_err(io)?;
            src.checksum()?;
            Err(e)
        }
    }
}

/// Check 13's failure for the padding gap `from..to`.
fn padding_error((from, to): (u64, u64)) -> FormatError {
    corrupt(
        Check::Padding,
        format!("a padding byte in {from}..{to} is not zero"),
    )
}

/// A reader that hashes the bytes before `body` as they are read (the checksum's input).
struct Hashed<R> {
    inner: R,
    hash: xxhash_rust::xxh3::Xxh3,
    at: u64,
    body: u64,
}

impl<R: std::io::Read> std::io::Read for Hashed<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        let hashed = (self.body.saturating_sub(self.at) as usize).min(n);
        self.hash.update(&buf[..hashed]);
        self.at += n as u64;
        Ok(n)
    }
}

impl<R: std::io::Read> Hashed<R> {
    /// Reads the padding gap `gap` (at most 8 bytes), noting it in `first_bad` if it is the
    /// first gap with a byte that is not zero (check 13, reported after the checksum).
    fn read_gap(
        &mut self,
        gap: (u64, u64),
        first_bad: &mut Option<(u64, u64)>,
    ) -> std::io::Result<()> {
        let mut pad = [0u8; 8];
        std::io::Read::read_exact(self, &mut pad[..((gap.1 - gap.0) as usize).min(8)])?;
        if first_bad.is_none() && pad.iter().any(|&b| b != 0) {
            *first_bad = Some(gap);
        }
        Ok(())
    }

    /// Reads (and hashes) up to offset `to`.
    fn skip_to(&mut self, to: u64) -> std::io::Result<()> {
        let mut buf = vec![0u8; 1 << 16];
        while self.at < to {
            let n = ((to - self.at) as usize).min(buf.len());
            std::io::Read::read_exact(self, &mut buf[..n])?;
        }
        Ok(())
    }

    /// Reads the stored checksum (the last 8 bytes) and compares it with the hash of
    /// everything before: check 5. Returns it.
    fn checksum(&mut self) -> Result<u64, FormatError> {
        let mut sum = [0u8; 8];
        std::io::Read::read_exact(self, &mut sum).map_err(|cause| FormatError::Io {
            path: "<reader>".into(),
            cause,
        })?;
        let stored = u64::from_le_bytes(sum);
        let computed = self.hash.digest();
        if stored != computed {
            return Err(FormatError::Checksum { stored, computed });
        }
        Ok(stored)
    }
}

impl Octree {
    /// Reads and validates a `.svo` file (its [`BuildInfo`] is dropped; [`read_file`] keeps
    /// it).
    pub fn load(path: impl AsRef<Path>) -> Result<Octree, FormatError> {
        read_file(path).map(|(tree, _)| tree)
    }

    /// Reads the top `max_depth` levels of a `.svo` file as a coarser tree: see
    /// [`read_file_to_depth`] (which also returns the [`BuildInfo`]).
    pub fn load_to_depth(path: impl AsRef<Path>, max_depth: u8) -> Result<Octree, FormatError> {
        read_file_to_depth(path, max_depth).map(|(tree, _)| tree)
    }

    /// The top `depth` levels (at least 1) of this tree as a coarser tree, as
    /// [`read_file_to_depth`] reads them from a file: the nodes on level `depth` become its
    /// leaves with their inner-node channels. A copy of the whole tree where `depth` is at
    /// least its own.
    pub fn top_levels(&self, depth: u8) -> Result<Octree, FormatError> {
        cut_to_depth(self, depth.max(1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a reader made of a file: the tree, or the check it failed (`None` for an I/O error).
    fn outcome(r: Result<Octree, FormatError>) -> Result<Octree, Option<Check>> {
        r.map_err(|e| e.check())
    }

    fn streamed(bytes: &[u8]) -> Result<Octree, FormatError> {
        read_stream(
            std::io::Cursor::new(bytes),
            bytes.len() as u64,
            &mut |raw, p| finish_tree(raw, p),
        )
        .map(|r| r.0)
    }

    /// The one-pass reader of files on disk and the reader of bytes agree on every file of the
    /// conformance corpus (each valid file read the same, each invalid one refused at the
    /// same check) and on seeded damage to the valid ones: flipped bytes (with the checksum
    /// left wrong, and fixed), cuts, and bytes appended.
    #[test]
    fn the_streaming_reader_agrees_with_the_bytes_reader() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/format/conformance");
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "svo"))
            .collect();
        files.sort();
        assert!(files.len() > 50, "{}", files.len());
        let mut rnd = svo_tests::seeds::xorshift(0x51f0_7e11);
        let (mut valid, mut refused, mut damaged) = (0, 0, 0);
        for f in &files {
            let bytes = std::fs::read(f).unwrap();
            let want = outcome(from_bytes(&bytes).map(|(t, _)| t));
            assert_eq!(outcome(streamed(&bytes)), want, "{}", f.display());
            let from_disk = read_file(f).map(|(t, _)| t);
            assert_eq!(outcome(from_disk), want, "{} from disk", f.display());
            if want.is_err() {
                refused += 1;
                continue;
            }
            valid += 1;
            for k in 0..40 {
                let mut b = bytes.clone();
                match k % 4 {
                    0 => {
                        let at = (rnd() as usize) % b.len();
                        b[at] ^= 1 << (rnd() % 8);
                    }
                    1 => {
                        let at = (rnd() as usize) % (b.len() - 8);
                        b[at] ^= 1 << (rnd() % 8);
                        let n = b.len() - 8;
                        let s = xxhash_rust::xxh3::xxh3_64(&b[..n]);
                        b[n..].copy_from_slice(&s.to_le_bytes());
                    }
                    2 => b.truncate((rnd() as usize) % b.len()),
                    _ => b.extend_from_slice(&[0; 8][..1 + (rnd() % 8) as usize]),
                }
                let want = outcome(from_bytes(&b).map(|(t, _)| t));
                assert_eq!(outcome(streamed(&b)), want, "{} damage {k}", f.display());
                damaged += 1;
            }
        }
        assert!(
            valid >= 5 && refused >= 40 && damaged >= 200,
            "{valid} {refused} {damaged}"
        );
    }
}
