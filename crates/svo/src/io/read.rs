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
use crate::octree::tree::{Channel, ChannelKind, LeafAttributes, Node, Octree};
use glam::DVec3;
use std::path::Path;

fn corrupt(msg: impl Into<String>) -> FormatError {
    FormatError::Corrupt(msg.into())
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

/// Reads only the header (after checking magic, version and checksum).
pub(crate) fn read_header(bytes: &[u8]) -> Result<Header, FormatError> {
    if bytes.len() < 8 || bytes[..8] != MAGIC {
        return Err(if bytes.len() < 8 && MAGIC.starts_with(bytes) {
            FormatError::Truncated(format!("{} bytes, the magic alone is 8", bytes.len()))
        } else {
            FormatError::NotSvo
        });
    }
    if bytes.len() < PREAMBLE_LEN + 8 {
        return Err(FormatError::Truncated(format!(
            "{} bytes, less than the smallest file",
            bytes.len()
        )));
    }
    let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if version > VERSION {
        return Err(FormatError::NewerVersion {
            found: version,
            supported: VERSION,
        });
    }
    if version == 0 {
        return Err(corrupt("format version 0"));
    }
    let hlen = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
    if hlen > MAX_HEADER_LEN {
        return Err(corrupt(format!(
            "header length {hlen} exceeds {MAX_HEADER_LEN}"
        )));
    }
    if PREAMBLE_LEN + hlen + 8 > bytes.len() {
        return Err(FormatError::Truncated(format!(
            "header of {hlen} bytes does not fit in {} bytes",
            bytes.len()
        )));
    }
    let body = bytes.len() - 8;
    let stored = u64::from_le_bytes(bytes[body..].try_into().unwrap_or([0; 8]));
    let computed = xxhash_rust::xxh3::xxh3_64(&bytes[..body]);
    if stored != computed {
        return Err(FormatError::Checksum { stored, computed });
    }
    let raw = &bytes[PREAMBLE_LEN..PREAMBLE_LEN + hlen];
    let (header, used): (Header, usize) = if version == 1 {
        bincode::serde::decode_from_slice::<HeaderV1, _>(raw, bincode_config())
            .map(|(h, n)| (h.into(), n))
    } else {
        bincode::serde::decode_from_slice(raw, bincode_config())
    }
    .map_err(|e| corrupt(format!("header: {e}")))?;
    header
        .build
        .scene
        .validate()
        .map_err(|e| corrupt(format!("scene: {e}")))?;
    if used != hlen {
        return Err(corrupt(format!(
            "header holds {used} bytes, its length says {hlen}"
        )));
    }
    Ok(header)
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

/// Parses and validates the bytes of a `.svo` file.
pub fn from_bytes(bytes: &[u8]) -> Result<(Octree, BuildInfo), FormatError> {
    let h = read_header(bytes)?;
    let hlen = bytes.len().min(
        PREAMBLE_LEN + u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize,
    );
    let data_start = hlen.div_ceil(8) as u64 * 8;
    let data_end = (bytes.len() - 8) as u64;

    if !(1..=crate::MAX_DEPTH).contains(&h.depth) {
        return Err(corrupt(format!(
            "depth {} is outside 1..={}",
            h.depth,
            crate::MAX_DEPTH
        )));
    }
    let origin = DVec3::from_array(h.root_origin);
    if !origin.is_finite() || !h.root_side.is_finite() || h.root_side <= 0.0 {
        return Err(corrupt("root cube is not finite and positive"));
    }
    if h.node_count == 0 {
        return Err(corrupt("no root node"));
    }
    let leaf_count = u32::try_from(h.leaf_count).map_err(|_| corrupt("leaf count exceeds u32"))?;

    // Arrays: in bounds, 8-aligned, in increasing order without overlap, sized by the counts.
    let mut refs: Vec<(ArrayRef, u64)> = vec![(
        h.nodes,
        h.node_count
            .checked_mul(8)
            .ok_or_else(|| corrupt("node count overflows"))?,
    )];
    let mut last_kind: i16 = -1;
    for e in &h.channels {
        if i16::from(e.kind) <= last_kind || e.kind > 5 {
            return Err(corrupt(format!(
                "channel code {} unknown, repeated or out of order",
                e.kind
            )));
        }
        last_kind = i16::from(e.kind);
        if let Storage::PerLeaf(r) = e.storage {
            // Codes are positions in `ChannelKind::ALL` (checked `<= 5` above).
            let size = ChannelKind::ALL[usize::from(e.kind)].element_size() as u64;
            refs.push((r, h.leaf_count * size));
        }
    }
    let mut prev_end = data_start;
    for (r, want) in &refs {
        if r.len != *want {
            return Err(corrupt(format!(
                "array at {} has {} bytes, the counts need {want}",
                r.offset, r.len
            )));
        }
        let end = r
            .offset
            .checked_add(r.len)
            .ok_or_else(|| corrupt("array length overflows"))?;
        if r.offset % 8 != 0 || r.offset < prev_end || end > data_end {
            return Err(if end > data_end && r.offset >= prev_end {
                FormatError::Truncated(format!(
                    "array at {}..{end} runs past the data end {data_end}",
                    r.offset
                ))
            } else {
                corrupt(format!(
                    "array at {}..{end} is misaligned or overlaps",
                    r.offset
                ))
            });
        }
        prev_end = end;
    }
    let slice = |r: ArrayRef| &bytes[r.offset as usize..(r.offset + r.len) as usize];
    let nodes: Vec<Node> = bytemuck::pod_collect_to_vec(slice(h.nodes));
    let mut attributes = LeafAttributes::default();
    for e in &h.channels {
        match (e.kind, e.storage) {
            (0, Storage::Constant(v)) => attributes.normal = Channel::Constant(v),
            (1, Storage::Constant(v)) => attributes.contour = Channel::Constant(v),
            (2, Storage::Constant(v)) => attributes.colour = Channel::Constant(v),
            (3, Storage::Constant(v)) => attributes.reflectivity = Channel::Constant(byte(v)?),
            (4, Storage::Constant(v)) => attributes.refractivity = Channel::Constant(byte(v)?),
            (5, Storage::Constant(v)) => {
                attributes.ior = Channel::Constant(
                    u16::try_from(v).map_err(|_| corrupt("IOR constant out of range"))?,
                )
            }
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
            _ => return Err(corrupt("unknown channel")),
        }
    }
    let tree = Octree {
        root: RootCube {
            origin,
            side: h.root_side,
        },
        depth: h.depth,
        nodes,
        leaf_count,
        attributes,
    };
    crate::octree::validate::validate(&tree).map_err(FormatError::Corrupt)?;
    Ok((tree, h.build))
}

fn byte(v: u32) -> Result<u8, FormatError> {
    u8::try_from(v).map_err(|_| corrupt(format!("constant {v} does not fit a byte")))
}

impl Octree {
    /// Reads and validates a `.svo` file (its [`BuildInfo`] is dropped; [`read_file`] keeps
    /// it).
    pub fn load(path: impl AsRef<Path>) -> Result<Octree, FormatError> {
        read_file(path).map(|(tree, _)| tree)
    }
}
