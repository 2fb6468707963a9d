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
    read_file_with_header(path.as_ref()).map(|r| (r.tree, r.preamble.header.build))
}

/// What checks 1 to 6 read: the format version, the header's length in bytes and the header.
pub(crate) struct Preamble {
    pub version: u32,
    pub header_len: usize,
    pub header: Header,
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
    if (PREAMBLE_LEN + hlen + 8) as u64 > total {
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

/// Checks 7 to 12 on a decoded header, for a file of `len` bytes whose header ends at
/// `header_end`: returns the padding gaps (`from..to`) that check 13 reads.
fn check_layout(h: &Header, header_end: u64, len: u64) -> Result<Vec<(u64, u64)>, FormatError> {
    let data_end = len - 8;
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
    Ok(gaps)
}

/// [`from_bytes`], also returning what the preamble and the header hold.
pub(crate) fn read_with_header(bytes: &[u8]) -> Result<(Octree, Preamble), FormatError> {
    let p = read_header(bytes)?;
    let h = &p.header;
    let gaps = check_layout(h, (PREAMBLE_LEN + p.header_len) as u64, bytes.len() as u64)?;
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
    let tree = arrays_into_tree(h, &mut |r, dst| {
        dst.copy_from_slice(&bytes[r.offset as usize..(r.offset + r.len) as usize]);
        Ok(())
    })?;
    finish_tree(tree, p)
}

/// Fills an array's bytes (`dst`, `r.len` of them) from the file: the arrays are asked for in
/// the file's order.
type Fetch<'a> = dyn FnMut(ArrayRef, &mut [u8]) -> Result<(), FormatError> + 'a;

/// An array of `r.len / size_of::<T>()` values filled by `fetch`.
fn array<T: bytemuck::Pod>(r: ArrayRef, fetch: &mut Fetch<'_>) -> Result<Vec<T>, FormatError> {
    let mut v = vec![T::zeroed(); r.len as usize / size_of::<T>()];
    fetch(r, bytemuck::cast_slice_mut(&mut v))?;
    Ok(v)
}

/// The tree of a header whose layout passed checks 7 to 12, its arrays filled by
/// `fetch(r, dst)` in the file's order (the nodes, then the per-leaf channels by kind).
fn arrays_into_tree(h: &Header, fetch: &mut Fetch<'_>) -> Result<Octree, FormatError> {
    let nodes: Vec<Node> = array(h.nodes, fetch)?;
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
    Ok(Octree {
        root: RootCube {
            origin: DVec3::from_array(h.root_origin),
            side: h.root_side,
        },
        depth: h.depth,
        // Check 9 bounds the count by 2^31.
        leaf_count: h.leaf_count as u32,
        nodes,
        attributes,
    })
}

/// Checks 14 to 18 (the node words, the tree's shape, the node and leaf order, the values),
/// then the nodes' bounds.
fn finish_tree(mut tree: Octree, p: Preamble) -> Result<(Octree, Preamble), FormatError> {
    check_tree(&tree, p.version, InfoBits::Zero)
        .map_err(|(check, detail)| corrupt(check, detail))?;
    tree.refresh_bounds();
    Ok((tree, p))
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
    let io = |cause| FormatError::Io {
        path: path.display().to_string(),
        cause,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let len = f.metadata().map_err(io)?.len();
    read_stream(std::io::BufReader::with_capacity(1 << 20, f), len).map_err(|e| match e {
        FormatError::Io { cause, .. } => io(cause),
        e => e,
    })
}

/// [`read_file_with_header`] from `r`, which holds `len` bytes.
fn read_stream(r: impl std::io::Read, len: u64) -> Result<FileRead, FormatError> {
    use std::io::Read;
    let io = |cause| FormatError::Io {
        path: "<reader>".into(),
        cause,
    };
    // The preamble and the header (at most their largest size, and never past the end).
    let mut prefix = vec![0u8; len.min((PREAMBLE_LEN + MAX_HEADER_LEN + 8) as u64) as usize];
    let mut r = r;
    r.read_exact(&mut prefix).map_err(io)?;
    let (version, hlen) = check_preamble(&prefix, len)?;
    // From here every byte before the checksum is hashed as it is consumed, from the start.
    let mut src = Hashed {
        inner: std::io::Cursor::new(prefix).chain(r),
        hash: xxhash_rust::xxh3::Xxh3::new(),
        at: 0,
        body: len - 8,
    };
    let mut header = vec![0u8; PREAMBLE_LEN + hlen];
    src.read_exact(&mut header).map_err(io)?;
    let parsed = decode_header(&header[PREAMBLE_LEN..], version).and_then(|p| {
        check_layout(&p.header, (PREAMBLE_LEN + hlen) as u64, len).map(|gaps| (p, gaps))
    });
    let (p, gaps) = match parsed {
        Ok(v) => v,
        // A file that fails both the checksum and a later check fails at the checksum.
        Err(e) => {
            src.skip_to(len - 8).map_err(io)?;
            src.checksum()?;
            return Err(e);
        }
    };
    let mut padding: Option<(u64, u64)> = None;
    let mut gaps = gaps.into_iter();
    let tree = arrays_into_tree(&p.header, &mut |r, dst| {
        // The padding before the array: zeros (check 13, reported after the checksum).
        if let Some((from, to)) = gaps.next() {
            let mut pad = [0u8; 8];
            let n = (to - from) as usize;
            src.read_exact(&mut pad[..n.min(8)]).map_err(io)?;
            if padding.is_none() && pad.iter().any(|&b| b != 0) {
                padding = Some((from, to));
            }
        }
        debug_assert_eq!(src.at, r.offset);
        src.read_exact(dst).map_err(io)
    })?;
    // The padding after the last array, then the checksum.
    for (from, to) in gaps {
        let mut pad = [0u8; 8];
        src.read_exact(&mut pad[..((to - from) as usize).min(8)])
            .map_err(io)?;
        if padding.is_none() && pad.iter().any(|&b| b != 0) {
            padding = Some((from, to));
        }
    }
    let checksum = src.checksum()?;
    if let Some((from, to)) = padding {
        return Err(corrupt(
            Check::Padding,
            format!("a padding byte in {from}..{to} is not zero"),
        ));
    }
    let (tree, preamble) = finish_tree(tree, p)?;
    Ok(FileRead {
        tree,
        preamble,
        checksum,
        len,
    })
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
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a reader made of a file: the tree, or the check it failed (`None` for an I/O error).
    fn outcome(r: Result<Octree, FormatError>) -> Result<Octree, Option<Check>> {
        r.map_err(|e| e.check())
    }

    fn streamed(bytes: &[u8]) -> Result<Octree, FormatError> {
        read_stream(std::io::Cursor::new(bytes), bytes.len() as u64).map(|r| r.tree)
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
        let mut rnd = crate::test_rng::xorshift(0x51f0_7e11);
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
