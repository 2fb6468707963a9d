//! The reader against files whose header and node array were edited on purpose, with the
//! checksum fixed so that the checks behind it must catch the edit: hostile node words,
//! cycles, backward pointers, references past the end, reserved bits, and headers that lie
//! about their counts or depth. A refused file is an error, never a panic or an allocation
//! the file does not justify.

use crate::io::BuildInfo;
use crate::io::header::bincode_config;
use crate::io::read::{from_bytes, read_header};
use crate::io::write::to_bytes;
use crate::octree::format_check::Check;
use crate::octree::{Octree, RootCube, Voxel};
use glam::{DVec3, UVec3};

/// A depth-4 tree of 40 cells on a diagonal band, with per-leaf colours.
fn small_tree() -> Octree {
    let root = RootCube {
        origin: DVec3::ZERO,
        side: 1.0,
    };
    let cells = (0..40u32).map(|i| {
        let c = UVec3::new(i % 16, (i * 7) % 16, (i * 3) % 16);
        let v = Voxel {
            colour: [i as f32 / 40.0, 0.5, 0.25, 1.0],
            ..Voxel::default()
        };
        (c, v)
    });
    Octree::from_cells(root, 4, cells).unwrap()
}

fn info() -> BuildInfo {
    BuildInfo {
        generator: "test".into(),
        ..BuildInfo::default()
    }
}

/// The check a file fails (`None` if it is read).
fn check_of(b: &[u8]) -> Option<Check> {
    from_bytes(b).err().and_then(|e| e.check())
}

fn rechecksum(b: &mut [u8]) {
    let n = b.len() - 8;
    let s = xxhash_rust::xxh3::xxh3_64(&b[..n]);
    b[n..].copy_from_slice(&s.to_le_bytes());
}

/// A seeded generator of bytes and ranges (xorshift).
struct Rng(Box<dyn FnMut() -> u64>);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(Box::new(svo_tests::seeds::xorshift(seed)))
    }
    fn below(&mut self, n: usize) -> usize {
        ((self.0)() % n as u64) as usize
    }
    fn in_range(&mut self, r: std::ops::Range<usize>) -> usize {
        r.start + self.below(r.end - r.start)
    }
}

#[test]
fn hostile_contents_with_valid_checksum_never_panic() {
    // Corrupt the payload and fix the checksum, so the structural validation must catch it.
    let tree = small_tree();
    let bytes = to_bytes(&tree, &info());
    let header = read_header(&bytes).unwrap().header;
    let nodes_at = header.nodes.offset as usize;
    let mut r = Rng::new(4);
    let mut rejected = 0;
    for _ in 0..5000 {
        let mut b = bytes.clone();
        let region = if r.below(2) == 0 {
            nodes_at..nodes_at + header.nodes.len as usize
        } else {
            16..b.len() - 8
        };
        for _ in 0..r.in_range(1..4) {
            let i = r.in_range(region.clone());
            b[i] = r.below(256) as u8;
        }
        rechecksum(&mut b);
        match from_bytes(&b) {
            Ok((t, _)) => t.validate().unwrap(),
            Err(_) => rejected += 1,
        }
    }
    assert!(rejected > 2000, "only {rejected} rejected");
}

#[test]
fn cycles_backward_pointers_and_overflows_are_rejected() {
    let tree = small_tree();
    let bytes = to_bytes(&tree, &info());
    let h = read_header(&bytes).unwrap().header;
    let at = h.nodes.offset as usize;
    let set_node = |b: &mut Vec<u8>, i: usize, info: u32, first: u32| {
        b[at + 8 * i..at + 8 * i + 4].copy_from_slice(&info.to_le_bytes());
        b[at + 8 * i + 4..at + 8 * i + 8].copy_from_slice(&first.to_le_bytes());
    };
    // Root pointing to itself (a cycle).
    let mut b = bytes.clone();
    set_node(&mut b, 0, tree.nodes[0].info, 0);
    rechecksum(&mut b);
    assert_eq!(check_of(&b), Some(Check::NodeOrder));
    // Child block past the end (as an `i32`, a leaf reference above the leaf level), and
    // just past the node array.
    let mut b = bytes.clone();
    set_node(&mut b, 0, tree.nodes[0].info, u32::MAX - 2);
    rechecksum(&mut b);
    assert_eq!(check_of(&b), Some(Check::TreeShape));
    let mut b = bytes.clone();
    set_node(&mut b, 0, tree.nodes[0].info, tree.nodes.len() as u32 - 1);
    rechecksum(&mut b);
    assert_eq!(check_of(&b), Some(Check::NodeOrder));
    // Reserved bits.
    let mut b = bytes.clone();
    set_node(&mut b, 0, tree.nodes[0].info | 0x100, tree.nodes[0].first);
    rechecksum(&mut b);
    assert_eq!(check_of(&b), Some(Check::NodeWords));
}

#[test]
fn header_lies_about_counts() {
    // Re-encode the header with inconsistent counts: the reader must refuse, not allocate.
    let tree = small_tree();
    let bytes = to_bytes(&tree, &info());
    let mut h = read_header(&bytes).unwrap().header;
    for lie in 0..3 {
        let mut hh = h.clone();
        match lie {
            0 => hh.leaf_count = u64::MAX,
            1 => hh.node_count = 1 << 60,
            _ => hh.nodes.len += 8,
        }
        let enc = bincode::serde::encode_to_vec(&hh, bincode_config()).unwrap();
        let mut b = bytes.clone();
        b.splice(16..16 + enc.len(), enc.iter().copied());
        rechecksum(&mut b);
        assert!(from_bytes(&b).is_err(), "lie {lie} accepted");
    }
    h.depth = 0;
    let enc = bincode::serde::encode_to_vec(&h, bincode_config()).unwrap();
    let mut b = bytes.clone();
    b.splice(16..16 + enc.len(), enc.iter().copied());
    rechecksum(&mut b);
    assert_eq!(check_of(&b), Some(Check::Depth));
}

#[test]
fn a_chunked_header_whose_array_sizes_overflow_is_refused() {
    // A version-3 header may claim up to 2^64 - 1 nodes; check 9 bounds the leaves by eight
    // a node and the chunks by the cells at the chunk level, which leaves the sizes of the
    // per-leaf arrays and of the chunk table free to pass 2^64 bytes. Check 12 must refuse
    // both as corrupt (a size that overflows), with overflow checks on or off.
    let tree = small_tree();
    let mut bytes = Vec::new();
    crate::io::write_chunked_to(&tree, &info(), 1, &mut bytes).unwrap();
    let h = read_header(&bytes).unwrap().header;
    let c = h.chunks.expect("a chunked header");
    assert!(
        h.channels
            .iter()
            .any(|e| matches!(e.storage, crate::io::header::Storage::PerLeaf(_))),
        "the tree needs a per-leaf channel"
    );
    for lie in 0..2 {
        let mut hh = h.clone();
        // The most nodes whose array size fits 64 bits.
        hh.node_count = u64::MAX / 8;
        let mut cc = c;
        match lie {
            // 2^62 leaves of four-byte colours: 2^64 bytes.
            0 => hh.leaf_count = 1 << 62,
            // 2^60 chunks at level 21 (8^21 = 2^63 cells) of 24-byte records.
            _ => {
                hh.depth = 22;
                cc.level = 21;
                cc.count = 1 << 60;
            }
        }
        let v3 = crate::io::header::HeaderV3::of(&hh, cc);
        let enc = bincode::serde::encode_to_vec(&v3, bincode_config()).unwrap();
        let mut b = bytes.clone();
        b.splice(16..16 + enc.len(), enc.iter().copied());
        rechecksum(&mut b);
        let e = from_bytes(&b).unwrap_err();
        assert_eq!(e.check(), Some(Check::ArrayLayout), "lie {lie}: {e}");
        let what = ["channel array's size", "chunk table's size"][lie];
        assert!(
            e.to_string().contains(&format!("the {what} overflows")),
            "lie {lie}: {e}"
        );
    }
}

#[test]
fn the_writer_refuses_a_tree_the_reader_would_refuse() {
    // A node out of the canonical order, a contour without a normal: nothing is written, and
    // the error names the check.
    let tree = small_tree();
    // Bits 8-31 of the nodes (the derived bounds in memory) are written as zeros whatever
    // they hold, so they cannot make a file the reader refuses; `validate` refuses bits that
    // are not the bounds.
    let mut reserved = tree.clone();
    reserved.nodes[0].info ^= 0x100;
    let (mut a, mut b) = (Vec::new(), Vec::new());
    crate::io::write::write_to(&reserved, &info(), &mut a).unwrap();
    crate::io::write::write_to(&tree, &info(), &mut b).unwrap();
    assert_eq!(a, b);
    assert!(
        reserved
            .validate()
            .unwrap_err()
            .to_string()
            .starts_with("check 14 (node words)")
    );
    let mut moved = tree.clone();
    moved.nodes.push(crate::octree::Node {
        info: 1,
        first: u32::MAX,
    });
    let mut contour = tree.clone();
    contour.attributes.normal = crate::octree::Channel::Absent;
    contour.attributes.contour = crate::octree::Channel::Constant(0xFFFF_0000);
    for (t, want) in [
        (moved, "check 16 (node order)"),
        (contour, "check 10 (channels)"),
    ] {
        let mut out = Vec::new();
        let e = crate::io::write::write_to(&t, &info(), &mut out).unwrap_err();
        assert!(e.to_string().starts_with(want), "{e}");
        assert!(out.is_empty());
        assert!(t.validate().unwrap_err().to_string().starts_with(want));
    }
}

/// A file of the DAG layout whose levels were edited and whose level hashes, header checksum
/// and checksum were then fixed, so that the checks of the levels themselves must catch the
/// edit: every edit is refused at a check or reads as a valid tree, never a panic; and a
/// header that claims more leaves than the graph holds fails check 17.
/// Writes the version-4 header `h` (of the length `b`'s has, `hlen`) into `b`, then its
/// checksum and the file's.
fn reseal(b: &mut [u8], h: &crate::io::header::Header, hlen: usize) {
    let l = h.levels.as_ref().unwrap();
    let v4 = crate::io::header::HeaderV4::of(h, l);
    let hb = bincode::serde::encode_to_vec(v4, bincode_config()).unwrap();
    assert_eq!(hb.len(), hlen);
    b[16..16 + hlen].copy_from_slice(&hb);
    let s = xxhash_rust::xxh3::xxh3_64(&b[..16 + hlen]);
    b[16 + hlen..24 + hlen].copy_from_slice(&s.to_le_bytes());
    rechecksum(b);
}

#[test]
fn hostile_dag_levels_with_valid_hashes_are_refused() {
    use crate::io::write::write_dag_to;
    let tree = small_tree();
    let mut bytes = Vec::new();
    write_dag_to(&tree, &info(), &mut bytes).unwrap();
    assert_eq!(from_bytes(&bytes).unwrap().0, tree);
    let p = read_header(&bytes).unwrap();
    let levels = p.header.levels.clone().unwrap();
    let mut r = Rng::new(0xda9);
    let mut failed = std::collections::BTreeMap::new();
    for _ in 0..3000 {
        let mut b = bytes.clone();
        let l = r.below(levels.table.len());
        let e = levels.table[l].block;
        let (at, len) = (e.offset as usize, e.len as usize);
        for _ in 0..r.in_range(1..3) {
            let i = at + r.below(len);
            b[i] = match r.below(3) {
                0 => r.below(256) as u8,
                1 => b[i] ^ (1 << r.below(8)),
                _ => 0,
            };
        }
        let mut h = p.header.clone();
        h.levels.as_mut().unwrap().table[l].hash = xxhash_rust::xxh3::xxh3_64(&b[at..at + len]);
        reseal(&mut b, &h, p.header_len);
        match from_bytes(&b) {
            Ok((t, _)) => t.validate().unwrap(),
            Err(e) => *failed.entry(e.check()).or_insert(0) += 1,
        }
    }
    for c in [Check::NodeWords, Check::TreeShape, Check::NodeOrder] {
        assert!(failed.get(&Some(c)).is_some_and(|&n| n > 20), "{failed:?}");
    }
    // With constant channels (no array sized by the leaf count): one leaf more than the
    // graph holds.
    let root = RootCube {
        origin: DVec3::ZERO,
        side: 1.0,
    };
    let cells = (0..40u32).map(|i| UVec3::new(i % 16, (i * 7) % 16, (i * 3) % 16));
    let glass = Octree::from_cells(root, 4, cells.map(|c| (c, Voxel::glass()))).unwrap();
    let mut b = Vec::new();
    write_dag_to(&glass, &info(), &mut b).unwrap();
    let g = read_header(&b).unwrap();
    let mut h = g.header;
    h.leaf_count += 1;
    reseal(&mut b, &h, g.header_len);
    assert_eq!(check_of(&b), Some(Check::LeafOrder));
}

/// Values on a level (`docs/format.md`, section 12) edited with every checksum made right:
/// the packed values' bytes changed (read back, or refused at check 18), and the header's
/// level and bits (refused at check 10 or 17, or read back): never a panic, as a tree or as a
/// graph.
#[cfg(feature = "trace")]
#[test]
fn hostile_values_on_a_level_are_refused() {
    use crate::dag::DagValues;
    use crate::io::header::Storage;
    use crate::io::write::write_dag_to_with;
    let sphere = crate::Mesh::sphere(DVec3::splat(0.5), 0.4, 16);
    let opts = crate::BakeOptions {
        depth: 6,
        node_attributes: true,
        channels: crate::ChannelSelection::NONE.with(crate::octree::ChannelKind::Normal),
        ..Default::default()
    };
    let tree = crate::bake_mesh(&sphere, &opts).unwrap().0;
    let values = DagValues {
        level: Some(4),
        normal_bits: 10,
        colour_bits: 32,
    };
    let mut bytes = Vec::new();
    write_dag_to_with(&tree, &info(), &values, &mut bytes).unwrap();
    from_bytes(&bytes).unwrap();
    let p = read_header(&bytes).unwrap();
    let Storage::Packed { array, .. } = p.header.channels[0].storage else {
        panic!("normals on a level");
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("h.svo");
    let mut r = Rng::new(0x7a1);
    let mut failed = std::collections::BTreeMap::new();
    for round in 0..600 {
        let mut b = bytes.clone();
        if round % 2 == 0 {
            let (at, len) = (array.offset as usize, array.len as usize);
            for _ in 0..r.in_range(1..4) {
                let i = at + r.below(len);
                b[i] ^= 1 << r.below(8);
            }
            rechecksum(&mut b);
        } else {
            let mut h = p.header.clone();
            if let Storage::Packed { level, bits, .. } = &mut h.channels[0].storage {
                *level = r.below(9) as u8;
                *bits = r.below(40) as u8;
            }
            reseal(&mut b, &h, p.header_len);
        }
        match from_bytes(&b) {
            Ok((t, _)) => t.validate().unwrap(),
            Err(e) => *failed.entry(e.check()).or_insert(0) += 1,
        }
        std::fs::write(&path, &b).unwrap();
        let _ = crate::io::read_dag_file(&path);
    }
    for c in [Check::Channels, Check::LeafOrder, Check::Values] {
        assert!(failed.get(&Some(c)).is_some_and(|&n| n > 5), "{failed:?}");
    }
}
