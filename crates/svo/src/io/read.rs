//! Reading `.svo` files: every field is validated before use (magic, version, lengths,
//! checksum, header, array bounds, channel sizes, then the tree's structure with
//! [`crate::octree::validate`]), and the arrays are copied out, not decoded per element.
//! A corrupt, truncated or hostile file gives a [`FormatError`], never a panic, a hang or an
//! allocation larger than the file.

use crate::geometry::grid::RootCube;
use crate::io::header::{
    ArrayRef, BuildInfo, Header, HeaderV1, MAGIC, MAX_HEADER_LEN, PREAMBLE_LEN, Storage, VERSION,
    bincode_config,
};
pub use crate::io::write::FormatError;
use crate::octree::format_check::Check;
use crate::octree::tree::{Channel, ChannelKind, LeafAttributes, Node, Octree};
use crate::octree::validate::{InfoBits, check_root_and_counts, check_tree};
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
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|cause| FormatError::Io {
        path: path.display().to_string(),
        cause,
    })?;
    from_bytes(&bytes)
}

/// What checks 1 to 6 read: the format version, the header's length in bytes and the header.
pub(crate) struct Preamble {
    pub version: u32,
    pub header_len: usize,
    pub header: Header,
}

/// Checks 1 to 6: the preamble, the checksum and the header's encoding.
pub(crate) fn read_header(bytes: &[u8]) -> Result<Preamble, FormatError> {
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
    if bytes.len() < PREAMBLE_LEN + 8 {
        return Err(truncated(
            Check::Size,
            format!("{} bytes, less than the smallest file (24)", bytes.len()),
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
    if PREAMBLE_LEN + hlen + 8 > bytes.len() {
        return Err(truncated(
            Check::HeaderLength,
            format!(
                "a header of {hlen} bytes does not end before the checksum of a file of {} bytes",
                bytes.len()
            ),
        ));
    }
    // 5. The checksum.
    let body = bytes.len() - 8;
    let stored = u64::from_le_bytes(bytes[body..].try_into().unwrap_or([0; 8]));
    let computed = xxhash_rust::xxh3::xxh3_64(&bytes[..body]);
    if stored != computed {
        return Err(FormatError::Checksum { stored, computed });
    }
    // 6. The header decodes in exactly its length.
    let raw = &bytes[PREAMBLE_LEN..PREAMBLE_LEN + hlen];
    let (header, used): (Header, usize) = if version == 1 {
        bincode::serde::decode_from_slice::<HeaderV1, _>(raw, bincode_config())
            .map(|(h, n)| (h.into(), n))
    } else {
        bincode::serde::decode_from_slice(raw, bincode_config())
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

/// [`from_bytes`], also returning what the preamble and the header hold.
pub(crate) fn read_with_header(bytes: &[u8]) -> Result<(Octree, Preamble), FormatError> {
    let p = read_header(bytes)?;
    let h = &p.header;
    let header_end = (PREAMBLE_LEN + p.header_len) as u64;
    let data_end = (bytes.len() - 8) as u64;

    // 7. Depth; 8. root cube; 9. counts.
    let origin = DVec3::from_array(h.root_origin);
    check_root_and_counts(h.depth, origin, h.root_side, h.node_count, h.leaf_count)
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
        let size = ChannelKind::ALL[usize::from(e.kind)].element_size();
        if let Storage::Constant(v) = e.storage
            && size < 4
            && v >> (8 * size) != 0
        {
            return Err(corrupt(
                Check::Channels,
                format!(
                    "the constant {v} of channel {} does not fit {size} byte(s)",
                    e.kind
                ),
            ));
        }
    }
    if h.channels.iter().any(|e| e.kind == 1) && !h.channels.iter().any(|e| e.kind == 0) {
        return Err(corrupt(
            Check::Channels,
            "a contour channel without a normal channel",
        ));
    }
    // 11. The scene.
    h.build
        .scene
        .validate()
        .map_err(|e| corrupt(Check::Scene, format!("scene: {e}")))?;
    // 12. The arrays where the canonical layout puts them: the nodes, then the per-leaf
    // channels by kind, each at the next multiple of 8, and the checksum after the last.
    let node_bytes = h
        .node_count
        .checked_mul(8)
        .ok_or_else(|| corrupt(Check::ArrayLayout, "the node count overflows"))?;
    let mut refs: Vec<(ArrayRef, u64)> = vec![(h.nodes, node_bytes)];
    for e in &h.channels {
        if let Storage::PerLeaf(r) = e.storage {
            let size = ChannelKind::ALL[usize::from(e.kind)].element_size() as u64;
            refs.push((r, h.leaf_count * size));
        }
    }
    let pad8 = |x: u64| x.div_ceil(8) * 8;
    let mut at = pad8(header_end);
    let mut gaps = vec![(header_end, at)];
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
        let end = at + r.len;
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
    // 13. Zero padding.
    if let Some(&(from, to)) = gaps
        .iter()
        .find(|&&(from, to)| bytes[from as usize..to as usize].iter().any(|&b| b != 0))
    {
        return Err(corrupt(
            Check::Padding,
            format!("a padding byte in {from}..{to} is not zero"),
        ));
    }
    let slice = |r: ArrayRef| &bytes[r.offset as usize..(r.offset + r.len) as usize];
    let nodes: Vec<Node> = bytemuck::pod_collect_to_vec(slice(h.nodes));
    let mut attributes = LeafAttributes::default();
    for e in &h.channels {
        // Constants fit their element (check 10).
        match (e.kind, e.storage) {
            (0, Storage::Constant(v)) => attributes.normal = Channel::Constant(v),
            (1, Storage::Constant(v)) => attributes.contour = Channel::Constant(v),
            (2, Storage::Constant(v)) => attributes.colour = Channel::Constant(v),
            (3, Storage::Constant(v)) => attributes.reflectivity = Channel::Constant(v as u8),
            (4, Storage::Constant(v)) => attributes.refractivity = Channel::Constant(v as u8),
            (5, Storage::Constant(v)) => attributes.ior = Channel::Constant(v as u16),
            (0, Storage::PerLeaf(r)) => {
                attributes.normal = Channel::PerLeaf(bytemuck::pod_collect_to_vec(slice(r)))
            }
            (1, Storage::PerLeaf(r)) => {
                attributes.contour = Channel::PerLeaf(bytemuck::pod_collect_to_vec(slice(r)))
            }
            (2, Storage::PerLeaf(r)) => {
                attributes.colour = Channel::PerLeaf(bytemuck::pod_collect_to_vec(slice(r)))
            }
            (3, Storage::PerLeaf(r)) => {
                attributes.reflectivity = Channel::PerLeaf(slice(r).to_vec())
            }
            (4, Storage::PerLeaf(r)) => {
                attributes.refractivity = Channel::PerLeaf(slice(r).to_vec())
            }
            (5, Storage::PerLeaf(r)) => {
                attributes.ior = Channel::PerLeaf(bytemuck::pod_collect_to_vec(slice(r)))
            }
            _ => return Err(corrupt(Check::Channels, "unknown channel")),
        }
    }
    let mut tree = Octree {
        root: RootCube {
            origin,
            side: h.root_side,
        },
        depth: h.depth,
        // Check 9 bounds the count by 2^31.
        leaf_count: h.leaf_count as u32,
        nodes,
        attributes,
    };
    // 14 to 18: the node words, the tree's shape, the node and leaf order, the values.
    check_tree(&tree, p.version, InfoBits::Zero)
        .map_err(|(check, detail)| corrupt(check, detail))?;
    tree.refresh_bounds();
    Ok((tree, p))
}

impl Octree {
    /// Reads and validates a `.svo` file (its [`BuildInfo`] is dropped; [`read_file`] keeps
    /// it).
    pub fn load(path: impl AsRef<Path>) -> Result<Octree, FormatError> {
        read_file(path).map(|(tree, _)| tree)
    }
}
