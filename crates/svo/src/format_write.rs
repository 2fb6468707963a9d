//! Writing `.svo` files (see [`crate::format_header`] and `docs/format.md`).

use crate::atomic_write::write_atomic;
use crate::format_header::{
    ArrayRef, BuildInfo, ChannelEntry, Header, MAGIC, PREAMBLE_LEN, Storage, VERSION,
    bincode_config,
};
use crate::octree::{Channel, Octree};
use std::path::Path;
use thiserror::Error;

/// Errors of reading and writing `.svo` files.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FormatError {
    /// The file could not be read or written.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's error.
        cause: std::io::Error,
    },
    /// The file does not start with the `.svo` magic bytes.
    #[error("not an .svo file (bad magic bytes)")]
    NotSvo,
    /// The file is from a newer format version.
    #[error(
        "file format version {found} is newer than this reader supports (version {supported}); upgrade svo"
    )]
    NewerVersion {
        /// The file's version.
        found: u32,
        /// What this library reads.
        supported: u32,
    },
    /// The file ends before its declared contents.
    #[error("truncated file: {0}")]
    Truncated(String),
    /// The checksum does not match the contents.
    #[error(
        "checksum mismatch: the file is corrupt (stored {stored:#018x}, computed {computed:#018x})"
    )]
    Checksum {
        /// Stored value.
        stored: u64,
        /// Computed value.
        computed: u64,
    },
    /// The contents are inconsistent.
    #[error("corrupt file: {0}")]
    Corrupt(String),
}

/// Serializes an octree into the bytes of a `.svo` file.
pub fn to_bytes(tree: &Octree, build: &BuildInfo) -> Vec<u8> {
    let a = &tree.attributes;
    let mut arrays: Vec<(Option<u8>, &[u8])> = vec![(None, bytemuck::cast_slice(&tree.nodes))];
    let mut entries: Vec<ChannelEntry> = Vec::new();
    fn add<'a, T: bytemuck::Pod + Into<u32>>(
        kind: u8,
        c: &'a Channel<T>,
        entries: &mut Vec<ChannelEntry>,
        arrays: &mut Vec<(Option<u8>, &'a [u8])>,
    ) {
        match c {
            Channel::Absent => {}
            Channel::Constant(v) => entries.push(ChannelEntry {
                kind,
                storage: Storage::Constant((*v).into()),
            }),
            Channel::PerLeaf(v) => {
                entries.push(ChannelEntry {
                    kind,
                    storage: Storage::PerLeaf(ArrayRef::default()),
                });
                arrays.push((Some(kind), bytemuck::cast_slice(v)));
            }
        }
    }
    add(0, &a.normal, &mut entries, &mut arrays);
    add(1, &a.contour, &mut entries, &mut arrays);
    add(2, &a.colour, &mut entries, &mut arrays);
    add(3, &a.reflectivity, &mut entries, &mut arrays);
    add(4, &a.refractivity, &mut entries, &mut arrays);
    add(5, &a.ior, &mut entries, &mut arrays);

    let mut header = Header {
        root_origin: tree.root.origin.to_array(),
        root_side: tree.root.side,
        depth: tree.depth,
        node_count: tree.nodes.len() as u64,
        leaf_count: u64::from(tree.leaf_count),
        nodes: ArrayRef::default(),
        channels: entries,
        build: build.clone(),
    };
    // Fixed-width integers: the header's size does not depend on the offsets in it.
    let hlen = bincode::serde::encode_to_vec(&header, bincode_config())
        .map(|v| v.len())
        .unwrap_or(0);
    let pad8 = |x: usize| x.div_ceil(8) * 8;
    let mut offset = pad8(PREAMBLE_LEN + hlen);
    for (kind, bytes) in &arrays {
        let r = ArrayRef {
            offset: offset as u64,
            len: bytes.len() as u64,
        };
        match kind {
            None => header.nodes = r,
            Some(k) => {
                if let Some(e) = header.channels.iter_mut().find(|e| e.kind == *k) {
                    e.storage = Storage::PerLeaf(r);
                }
            }
        }
        offset = pad8(offset + bytes.len());
    }
    let hbytes = bincode::serde::encode_to_vec(&header, bincode_config()).unwrap_or_default();
    debug_assert_eq!(hbytes.len(), hlen);
    let mut out = Vec::with_capacity(offset + 8);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(hbytes.len() as u32).to_le_bytes());
    out.extend_from_slice(&hbytes);
    out.resize(pad8(out.len()), 0);
    for (_, bytes) in &arrays {
        append_le(&mut out, bytes);
        out.resize(pad8(out.len()), 0);
    }
    let sum = xxhash_rust::xxh3::xxh3_64(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

/// Appends raw array bytes in little-endian order (a plain copy on little-endian machines).
fn append_le(out: &mut Vec<u8>, bytes: &[u8]) {
    out.extend_from_slice(bytes);
    #[cfg(target_endian = "big")]
    compile_error!("svo's file writer assumes a little-endian target");
}

/// Writes an octree to `path` atomically.
pub fn write_file(tree: &Octree, build: &BuildInfo, path: &Path) -> Result<u64, FormatError> {
    let bytes = to_bytes(tree, build);
    write_atomic(path, |w| w.write_all(&bytes)).map_err(|cause| FormatError::Io {
        path: path.display().to_string(),
        cause,
    })?;
    Ok(bytes.len() as u64)
}
