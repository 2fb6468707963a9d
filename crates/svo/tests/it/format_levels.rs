//! Version-4 files: a tree with inner-node attributes round-trips through them (in memory and
//! on disk), and the top levels of such a file read alone are the coarser tree the full tree
//! holds: its nodes above, the nodes of the last level read as leaves with their node values.
//! A prefix read checks what it reads (header and level checksums) and reads nothing after.

use glam::{DVec3, UVec3};
use svo::io::{BuildInfo, from_bytes, read_file, read_file_to_depth, to_bytes, write_file};
use svo::octree::Check;
use svo::{BakeOptions, Mesh, Octree, bake_mesh};

use svo_tests::node_order::{is_level_order, same_shape};

fn bake(mesh: &Mesh, depth: u8, node_attributes: bool) -> Octree {
    let opts = BakeOptions {
        depth,
        node_attributes,
        ..Default::default()
    };
    bake_mesh(mesh, &opts).unwrap().0
}

/// A sphere and a torus side by side, two materials: per-leaf normals, contours and colours.
fn scene() -> Mesh {
    let mut m = Mesh::sphere(DVec3::new(0.3, 0.5, 0.5), 0.25, 24);
    let mut t = Mesh::sphere(DVec3::new(0.75, 0.45, 0.55), 0.2, 12);
    t.materials = vec![svo::Material {
        colour: [0.9, 0.1, 0.2, 1.0],
        ..Default::default()
    }];
    t.triangle_materials = vec![0; t.triangles.len()];
    m.append(t);
    m
}

fn version(bytes: &[u8]) -> u32 {
    u32::from_le_bytes(bytes[8..12].try_into().unwrap())
}

/// The nodes of `tree` on `level`, in depth-first order, with their cells at that level.
fn nodes_on_level(tree: &Octree, level: u8) -> Vec<(usize, UVec3)> {
    let mut out = Vec::new();
    let mut stack = vec![(0usize, 0u8, UVec3::ZERO)];
    while let Some((i, l, cell)) = stack.pop() {
        let node = tree.nodes[i];
        if l == level {
            out.push((i, cell));
            continue;
        }
        for c in (0..8u8).rev() {
            if let Some(rank) = node.child_rank(c) {
                let o = UVec3::new(
                    u32::from(c >> 2 & 1),
                    u32::from(c >> 1 & 1),
                    u32::from(c & 1),
                );
                stack.push(((node.first + rank) as usize, l + 1, cell * 2 + o));
            }
        }
    }
    out
}

#[test]
fn trees_with_inner_node_attributes_round_trip_through_version_4() {
    let mesh = scene();
    let dir = tempfile::tempdir().unwrap();
    for depth in [1u8, 2, 3, 6] {
        let tree = bake(&mesh, depth, true);
        let bytes = to_bytes(&tree, &BuildInfo::new());
        assert_eq!(version(&bytes), 4, "depth {depth}");
        assert_eq!(from_bytes(&bytes).unwrap().0, tree, "depth {depth}");
        let path = dir.path().join(format!("d{depth}.svo"));
        write_file(&tree, &BuildInfo::new(), &path).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), bytes);
        assert_eq!(read_file(&path).unwrap().0, tree, "depth {depth} from disk");
        // The same tree without them is written as version 2, with the same leaves.
        let plain = bake(&mesh, depth, false);
        let plain_bytes = to_bytes(&plain, &BuildInfo::new());
        assert_eq!(version(&plain_bytes), 2);
        let back = from_bytes(&plain_bytes).unwrap().0;
        assert_eq!(back.attributes, tree.attributes);
        assert!(same_shape(&back, &tree), "depth {depth}");
        // In memory the tree with them keeps its file's level order, the other depth-first.
        assert!(is_level_order(&tree), "depth {depth}");
        assert_eq!(is_level_order(&back), depth <= 2, "depth {depth}");
    }
}

#[test]
fn a_version_4_files_top_levels_are_the_coarser_tree() {
    let depth = 7;
    let tree = bake(&scene(), depth, true);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.svo");
    write_file(&tree, &BuildInfo::new(), &path).unwrap();
    let plain_path = dir.path().join("plain.svo");
    let plain = bake(&scene(), depth, false);
    write_file(&plain, &BuildInfo::new(), &plain_path).unwrap();
    for k in 0..=depth + 2 {
        let (top, _) = read_file_to_depth(&path, k).unwrap();
        let want_depth = k.clamp(1, depth);
        assert_eq!(top.depth, want_depth, "k {k}");
        top.validate().unwrap();
        if want_depth == depth {
            assert_eq!(top, tree);
            continue;
        }
        // The leaves are the full tree's nodes on level k, with their cells and node values.
        let level = nodes_on_level(&tree, want_depth);
        let leaves: Vec<_> = top.leaves().collect();
        assert_eq!(leaves.len(), level.len(), "k {k}");
        let kept = want_depth + 2 <= depth;
        for (leaf, &(i, cell)) in leaves.iter().zip(&level) {
            assert_eq!(leaf.cell, cell, "k {k}");
            let (got, node) = (
                top.attributes.get(leaf.index as usize),
                tree.node_attributes.get(i),
            );
            if kept {
                assert_eq!(got, node, "k {k}, node {i}");
            } else {
                // Level depth - 1 is the leaf parents', which keep no values: cubes.
                assert_eq!(top.attributes, Default::default());
            }
        }
        // The nodes above keep theirs (the new leaf parents' are 0, as a tree's are).
        for (l, inner) in (0..want_depth.saturating_sub(1)).map(|l| (l, nodes_on_level(&top, l))) {
            let full = nodes_on_level(&tree, l);
            for (&(a, _), &(b, _)) in inner.iter().zip(&full) {
                if kept {
                    assert_eq!(
                        top.node_attributes.get(a),
                        tree.node_attributes.get(b),
                        "level {l}"
                    );
                }
            }
        }
        // A version-2 file of the same tree cut in memory has the same nodes and cells.
        let (cut, _) = read_file_to_depth(&plain_path, k).unwrap();
        assert!(same_shape(&cut, &top), "k {k}");
        assert_eq!(is_level_order(&top), kept || want_depth <= 2, "k {k}");
        assert_eq!(cut.attributes, Default::default());
    }
}

/// A version-3 file (chunks) reads to any depth as its version-2 twin is cut, above, at and
/// below the chunks' level, in one pass holding one chunk at a time; a damaged chunk is
/// refused as the whole read refuses it.
#[test]
fn a_version_3_files_top_levels_are_the_coarser_tree() {
    let depth = 7;
    let plain = bake(&scene(), depth, false);
    let dir = tempfile::tempdir().unwrap();
    let plain_path = dir.path().join("plain.svo");
    write_file(&plain, &BuildInfo::new(), &plain_path).unwrap();
    for level in [1u8, 2, 4] {
        let path = dir.path().join(format!("chunks{level}.svo"));
        let mut bytes = Vec::new();
        svo::io::write_chunked_to(&plain, &BuildInfo::new(), level, &mut bytes).unwrap();
        std::fs::write(&path, &bytes).unwrap();
        for k in 0..=depth + 1 {
            let (got, _) = read_file_to_depth(&path, k).unwrap();
            let (want, _) = read_file_to_depth(&plain_path, k).unwrap();
            assert_eq!(got, want, "chunks at level {level}, k {k}");
            got.validate().unwrap();
        }
        // A flipped byte in the node array: the same refusal as reading the file whole.
        let at = bytes.len() / 3;
        let mut bad = bytes.clone();
        bad[at] ^= 0x40;
        std::fs::write(&path, &bad).unwrap();
        let whole = read_file(&path).unwrap_err().check();
        assert!(whole.is_some());
        assert_eq!(
            read_file_to_depth(&path, 3).unwrap_err().check(),
            whole,
            "level {level}"
        );
    }
}

/// What a prefix read checks: the header's and the levels' checksums, not the bytes after.
#[test]
fn a_prefix_read_checks_what_it_reads_and_nothing_after() {
    let depth = 6;
    let tree = bake(&scene(), depth, true);
    let bytes = to_bytes(&tree, &BuildInfo::new());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.svo");
    let fail = |b: &[u8], k: u8| {
        std::fs::write(&path, b).unwrap();
        read_file_to_depth(&path, k).err().and_then(|e| e.check())
    };
    let (top, _) = {
        std::fs::write(&path, &bytes).unwrap();
        read_file_to_depth(&path, 3).unwrap()
    };
    // A byte of the leaves' arrays flipped: the whole file fails its checksum; its top
    // levels still read, the same.
    let mut late = bytes.clone();
    let n = late.len();
    late[n - 16] ^= 1;
    assert_eq!(
        from_bytes(&late).unwrap_err().check(),
        Some(Check::Checksum)
    );
    std::fs::write(&path, &late).unwrap();
    assert_eq!(read_file_to_depth(&path, 3).unwrap().0, top);
    // A byte of level 2's block flipped: the level checksum catches it (and the whole-file
    // checksum in a full read).
    let h = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let level2 = first_byte_of_level(&bytes, 2);
    let mut mid = bytes.clone();
    mid[level2] ^= 0x10;
    assert_eq!(fail(&mid, 3), Some(Check::LevelChecksums));
    // Levels 0 and 1 alone do not reach it.
    std::fs::write(&path, &mid).unwrap();
    assert_eq!(read_file_to_depth(&path, 1).unwrap().0.depth, 1);
    assert_eq!(from_bytes(&mid).unwrap_err().check(), Some(Check::Checksum));
    // A header byte (the generator's) flipped: the header checksum.
    let mut head = bytes.clone();
    let g = head[16..16 + h]
        .windows(3)
        .position(|w| w == b"svo")
        .unwrap();
    head[16 + g] = b'S';
    assert_eq!(fail(&head, 3), Some(Check::HeaderChecksum));
}

/// The offset of level `l`'s block, as `svo::io::describe_file` prints the level table.
fn first_byte_of_level(bytes: &[u8], l: usize) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.svo");
    std::fs::write(&path, bytes).unwrap();
    let text = svo::io::describe_file(&path).unwrap();
    let line = text
        .lines()
        .find(|s| s.starts_with(&format!("level {l} ")))
        .unwrap();
    let at = line.split("block at ").nth(1).unwrap();
    at.split(' ').next().unwrap().parse().unwrap()
}
