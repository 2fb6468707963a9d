//! Version 4's DAG layout: a tree written as a graph of distinct subtrees reads back as the
//! same tree (its nodes and every leaf channel), converts back to the tree layout's bytes, is
//! smaller where subtrees repeat, and reads to a depth as the tree layout's file does; trees
//! the layout cannot hold are refused before anything is written.

use glam::{DVec3, UVec3};
use svo::io::{
    BuildInfo, from_bytes, read_dag_file, read_file, read_file_to_depth, to_bytes, write_dag_file,
    write_dag_to, write_file,
};
use svo::{BakeOptions, Mesh, Octree, RootCube, Voxel, bake_mesh};

/// The frame of scene `s` (its camera, lights, sky and shading) on `surfaces`.
fn frame_on<S: svo::render::Surfaces>(
    s: &svo::render::RenderScene,
    surfaces: S,
    trace: svo::render::TraceOptions,
) -> svo::render::Frame {
    let t = svo::render::Tracer::new(surfaces, &s.lights, s.sky.clone(), s.phong, trace);
    svo::render::render(&t, &s.camera).unwrap()
}

fn dag_bytes(tree: &Octree) -> Vec<u8> {
    let mut v = Vec::new();
    write_dag_to(tree, &BuildInfo::new(), &mut v).unwrap();
    v
}

fn version_and_layout(bytes: &[u8]) -> (u32, u8) {
    let v = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
    // The layout byte follows the root cube (32 bytes) and the depth in version 4's header.
    (v, bytes[16 + 32 + 1])
}

/// Seeded random trees of depths 2 to 9 with per-leaf colours (empty, one cell, sparse,
/// dense, and a lattice whose subtrees all repeat), and a bake with every channel: each reads
/// back from its DAG file as the same tree, and the tree read back writes the tree layout's
/// bytes again; its graph finds the tree's box of occupied cells.
#[test]
fn a_dag_file_reads_back_as_the_same_tree() {
    let root = RootCube {
        origin: DVec3::new(-1.0, 2.0, 0.5),
        side: 3.0,
    };
    let mut rnd = svo_tests::seeds::xorshift(0xda91);
    let mut trees = Vec::new();
    for case in 0..40u32 {
        let depth = 2 + (case % 8) as u8;
        let side = 1u32 << depth;
        let n = match case % 10 {
            0 => 0,
            1 => 1,
            2 => 3000,
            _ => 1 + rnd() % 300,
        };
        let cells: Vec<(UVec3, Voxel)> = (0..n)
            .map(|_| {
                let c = UVec3::new(rnd() as u32, rnd() as u32, rnd() as u32) % side;
                let v = Voxel {
                    colour: [(rnd() % 256) as f32 / 255.0, 0.5, 0.25, 1.0],
                    ..Voxel::default()
                };
                (c, v)
            })
            .collect();
        trees.push(Octree::from_cells(root, depth, cells).unwrap());
    }
    let lattice = (0..4096u32)
        .map(|i| UVec3::new(i % 16, i / 16 % 16, i / 256))
        .filter(|c| c.x % 2 == 0 && c.y % 3 == 0)
        .map(|c| (c, Voxel::glass()));
    trees.push(Octree::from_cells(root, 4, lattice).unwrap());
    let torus = Mesh::load(svo_tests::repo_root().join("fixtures/torus.obj")).unwrap();
    let opts = BakeOptions {
        depth: 7,
        ..Default::default()
    };
    trees.push(bake_mesh(&torus, &opts).unwrap().0);
    for (i, tree) in trees.iter().enumerate() {
        let bytes = dag_bytes(tree);
        assert_eq!(version_and_layout(&bytes), (4, 1), "tree {i}");
        let back = from_bytes(&bytes).unwrap().0;
        assert_eq!(&back, tree, "tree {i}");
        assert_eq!(
            to_bytes(&back, &BuildInfo::new()),
            to_bytes(tree, &BuildInfo::new())
        );
        // The same bytes again from the tree read back: the layout is the tree's alone.
        assert_eq!(dag_bytes(&back), bytes, "tree {i}");
        // The graph finds the tree's box of occupied cells.
        let graph = svo::dag::DagTree::from_tree(tree).unwrap();
        assert_eq!(graph.occupied_cells(), tree.occupied_cells(), "tree {i}");
        assert_eq!(graph.occupied_bounds(), tree.occupied_bounds(), "tree {i}");
    }
    // Subtrees that repeat are stored once: the lattice's file is a fraction of the tree's.
    let lattice = &trees[40];
    assert!(5 * dag_bytes(lattice).len() < to_bytes(lattice, &BuildInfo::new()).len());
}

/// A bake's DAG file on disk (without channels, and with all): read whole it is the tree, and
/// read to each depth it is the coarser tree the tree layout's file gives; its level sizes
/// are the tree's, counted on the graph; it is smaller than the tree's.
#[test]
fn a_dag_file_reads_to_a_depth_as_the_tree_layout_does() {
    let mesh = Mesh::sphere(DVec3::splat(0.5), 0.4, 24);
    for channels in [svo::ChannelSelection::NONE, svo::ChannelSelection::ALL] {
        let opts = BakeOptions {
            depth: 6,
            channels,
            ..Default::default()
        };
        let tree = bake_mesh(&mesh, &opts).unwrap().0;
        let dir = tempfile::tempdir().unwrap();
        let (tree_path, dag_path) = (dir.path().join("tree.svo"), dir.path().join("dag.svo"));
        let tree_len = write_file(&tree, &BuildInfo::new(), &tree_path).unwrap();
        let dag_len = write_dag_file(&tree, &BuildInfo::new(), &dag_path).unwrap();
        assert!(dag_len < tree_len, "{dag_len} against {tree_len}");
        assert_eq!(read_file(&dag_path).unwrap().0, tree);
        for k in 1..=7 {
            assert_eq!(
                read_file_to_depth(&dag_path, k).unwrap().0,
                read_file_to_depth(&tree_path, k).unwrap().0,
                "depth {k}"
            );
        }
        let sizes = svo::io::read_level_sizes(&dag_path).unwrap().unwrap();
        let mut want = vec![0u64; 7];
        for d in 0..=6u8 {
            let top = read_file_to_depth(&tree_path, d.max(1)).unwrap().0;
            want[usize::from(d)] = if d == 0 { 1 } else { u64::from(top.leaf_count) };
        }
        assert_eq!(sizes.counts, want);
        assert_eq!(
            (sizes.leaf_bytes, sizes.node_bytes),
            (tree.attributes.per_leaf_bytes() as u64, 0)
        );
    }
}

/// What the layout cannot hold is refused before a byte is written: a tree of depth 1 (its
/// lowest nodes are bricks of two levels) and a tree with inner-node attributes (shared
/// subtrees keep no values of their own).
#[test]
fn the_dag_layout_refuses_what_it_cannot_hold() {
    let root = RootCube {
        origin: DVec3::ZERO,
        side: 1.0,
    };
    let flat = Octree::from_cells(root, 1, [(UVec3::ONE, Voxel::glass())]).unwrap();
    let mut out = Vec::new();
    let e = write_dag_to(&flat, &BuildInfo::new(), &mut out).unwrap_err();
    assert!(e.to_string().contains("depth 2 or more"), "{e}");
    assert!(out.is_empty());
    let mesh = Mesh::sphere(DVec3::splat(0.5), 0.4, 12);
    let opts = BakeOptions {
        depth: 4,
        node_attributes: true,
        ..Default::default()
    };
    let lod = bake_mesh(&mesh, &opts).unwrap().0;
    let e = write_dag_to(&lod, &BuildInfo::new(), &mut out).unwrap_err();
    assert!(e.to_string().contains("inner-node attributes"), "{e}");
    assert!(out.is_empty());
}

/// A DAG file read as a graph (`read_dag_file`, the tree it stands for never made) is the
/// graph of its tree with the tree's leaf channels, and rays walk it as they walk the tree: the
/// same leaves, one after another, for rays across the bake from every side; a file of the
/// tree layout reads as the same graph.
#[test]
fn a_dag_file_reads_as_the_graph_rays_walk() {
    use glam::Vec3;
    use svo::dag::DagTree;
    use svo::trace::{GridRay, MAX_STEPS, traverse};
    let torus = Mesh::load(svo_tests::repo_root().join("fixtures/torus.obj")).unwrap();
    let opts = BakeOptions {
        depth: 7,
        ..Default::default()
    };
    let tree = bake_mesh(&torus, &opts).unwrap().0;
    let dir = tempfile::tempdir().unwrap();
    let (tree_path, dag_path) = (dir.path().join("tree.svo"), dir.path().join("dag.svo"));
    write_file(&tree, &BuildInfo::new(), &tree_path).unwrap();
    write_dag_file(&tree, &BuildInfo::new(), &dag_path).unwrap();
    let (dag, _) = read_dag_file(&dag_path).unwrap();
    let (again, _) = read_dag_file(&tree_path).unwrap();
    let made = DagTree::from_tree(&tree).unwrap();
    assert_eq!(dag.level_counts(), made.level_counts());
    assert_eq!(again.level_counts(), made.level_counts());
    assert_eq!(dag.attributes(), &tree.attributes);
    assert_eq!(again.attributes(), &tree.attributes);
    assert_eq!(
        (dag.depth(), dag.root(), dag.leaf_count()),
        (7, tree.root, u64::from(tree.leaf_count))
    );
    let mut rnd = svo_tests::seeds::xorshift(0xda9a1c);
    let mut unit = || (rnd() % 20_001) as f32 / 10_000.0 - 1.0;
    let mut met = 0;
    for _ in 0..2000 {
        let origin = Vec3::splat(64.0) + Vec3::new(unit(), unit(), unit()) * 120.0;
        let to = Vec3::splat(64.0) + Vec3::new(unit(), unit(), unit()) * 40.0;
        let ray = GridRay {
            origin,
            dir: (to - origin).normalize_or(Vec3::X),
        };
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let ta = dag.traverse(&ray, 0.0, f32::INFINITY, MAX_STEPS, |e| {
            a.push((e.leaf, e.cell, e.t_enter.to_bits()));
            None::<()>
        });
        let tb = traverse(&tree, &ray, 0.0, f32::INFINITY, MAX_STEPS, |e| {
            b.push((e.leaf, e.cell, e.t_enter.to_bits()));
            None::<()>
        });
        assert_eq!(a, b, "{ray:?}");
        assert!(!ta.capped && !tb.capped);
        met += a.len();
    }
    assert!(met > 2000, "{met} leaves met");
}

/// Values on a level above the leaves (`svo::dag::DagValues`): a bake with its inner nodes'
/// attributes (normals and colours) written with its values on levels 2 to `depth - 2` and
/// on the leaves', normals in 32, 16 and 10 bits, reads back as the tree whose every leaf
/// holds its ancestor's values on that level (the normal kept in those bits), and as a graph
/// that rays walk to the same values (the same image, shadows included); what cannot be kept
/// so is refused.
#[test]
fn values_on_a_level_read_back_as_each_leafs_ancestors() {
    use svo::dag::{DagTree, DagValues};
    use svo::octree::{Channel, ChannelKind};
    use svo::render::{DagSurfaces, OctreeSurfaces, RenderScene, SceneSetup};
    let mut mesh = Mesh::sphere(DVec3::splat(0.5), 0.4, 24);
    // Two materials, so that colours vary.
    mesh.materials = vec![
        svo::mesh::Material::default(),
        svo::mesh::Material {
            colour: [0.9, 0.2, 0.1, 1.0],
            ..svo::mesh::Material::default()
        },
    ];
    mesh.triangle_materials = (0..mesh.triangles.len()).map(|i| (i % 2) as u32).collect();
    let depth = 7u8;
    let channels = svo::ChannelSelection::NONE
        .with(ChannelKind::Normal)
        .with(ChannelKind::Colour);
    let opts = BakeOptions {
        depth,
        node_attributes: true,
        channels,
        ..BakeOptions::default()
    };
    let tree = bake_mesh(&mesh, &opts).unwrap().0;
    assert!(tree.attributes.colour.is_per_leaf());
    // The same leaves without the inner nodes' attributes, for values on the leaves' level.
    let per_leaf = bake_mesh(
        &mesh,
        &BakeOptions {
            node_attributes: false,
            ..opts.clone()
        },
    )
    .unwrap()
    .0;
    assert_eq!(per_leaf.attributes, tree.attributes);
    let dir = tempfile::tempdir().unwrap();
    let leaves: Vec<UVec3> = tree.leaves().map(|l| l.cell).collect();
    let morton = |c: UVec3, levels: u8| {
        (0..levels).rev().fold(0u64, |code, l| {
            code << 3
                | u64::from(c.x >> l & 1) << 2
                | u64::from(c.y >> l & 1) << 1
                | u64::from(c.z >> l & 1)
        })
    };
    for level in [2u8, 4, 5, depth] {
        for (bits, colour_bits) in [(32u8, 32u8), (16, 16), (10, 4)] {
            let values = DagValues {
                level: Some(level),
                normal_bits: bits,
                colour_bits,
            };
            let path = dir.path().join(format!("v{level}-{bits}.svo"));
            let tree = if level == depth { &per_leaf } else { &tree };
            svo::io::write_dag_file_with(tree, &BuildInfo::new(), &values, &path).unwrap();
            // The values each leaf should get: its ancestor's on the level, in Morton order
            // among that level's nodes (the inner nodes' attributes), the normal kept in
            // `bits` bits.
            let up = |c: UVec3| c >> u32::from(depth - level);
            let mut ancestors: Vec<u64> = leaves.iter().map(|&c| morton(up(c), level)).collect();
            ancestors.sort_unstable();
            ancestors.dedup();
            let kept = DagTree::from_tree_with(tree, &values).unwrap();
            let (read, _) = read_file(&path).unwrap();
            assert_eq!(read.nodes.len(), tree.nodes.len());
            for (i, &c) in leaves.iter().enumerate() {
                // `leaves` follows the tree's depth-first leaf order, which the read tree's
                // leaf arrays follow too.
                let k = if level == depth {
                    i
                } else {
                    ancestors.binary_search(&morton(up(c), level)).unwrap()
                };
                assert_eq!(
                    read.attributes.normal.get(i),
                    kept.attributes().normal.get(k),
                    "level {level}, {bits} bits, leaf {i}"
                );
                assert_eq!(
                    read.attributes.colour.get(i),
                    kept.attributes().colour.get(k)
                );
            }
            // `svo-view --info` says where they are kept.
            let text = svo::io::describe_file(&path).unwrap();
            let says = format!("level {level}'s nodes, {bits} bits each");
            assert_eq!(text.contains(&says), level < depth || bits < 32, "{text}");
            // On the graph, rays find the same values as on the tree read back.
            let (dag, _) = read_dag_file(&path).unwrap();
            assert_eq!(dag.values_level(), level);
            assert_eq!(dag.attributes(), kept.attributes());
            let setup = SceneSetup {
                width: 64,
                height: 48,
                ..SceneSetup::default()
            };
            // With shadows: a shadow ray skips the leaf it starts on, not the leaves that
            // share its ancestor's values.
            let trace = svo::render::TraceOptions {
                mode: svo::trace::HitMode::Cube,
                ..Default::default()
            };
            let s = RenderScene::new(read.clone(), &Default::default(), &setup).unwrap();
            let a = frame_on(&s, OctreeSurfaces::new(&s.tree, trace.mode), trace);
            assert!(a.stats.primary_hits > 100);
            // The graph's walks with packets and the prepass, and one ray at a time.
            for fast in [true, false] {
                let trace = svo::render::TraceOptions {
                    packets: fast,
                    prepass: fast,
                    ..trace
                };
                let b = frame_on(&s, DagSurfaces::new(&dag, trace.mode), trace);
                assert_eq!(a.colour, b.colour, "level {level}, {bits} bits, {fast}");
            }
            let normals = match &dag.attributes().normal {
                Channel::PerLeaf(v) => v.len(),
                _ => 0,
            };
            assert_eq!(
                normals,
                if level == depth {
                    leaves.len()
                } else {
                    ancestors.len()
                }
            );
        }
    }
    // Refused: a contour above the leaves, the leaf parents' level, odd bits; and values
    // above the leaves from a tree without inner-node attributes.
    let with_contours = bake_mesh(
        &mesh,
        &BakeOptions {
            depth: 5,
            node_attributes: true,
            ..BakeOptions::default()
        },
    )
    .unwrap()
    .0;
    let refuse = |t: &Octree, level: u8, bits: u8, says: &str| {
        let v = DagValues {
            level: Some(level),
            normal_bits: bits,
            colour_bits: 32,
        };
        let e = svo::io::write_dag_to_with(t, &BuildInfo::new(), &v, &mut Vec::new()).unwrap_err();
        assert!(e.to_string().contains(says), "{e}");
    };
    refuse(&with_contours, 3, 32, "contour");
    refuse(&tree, depth - 1, 32, "levels that hold values are 1 to 5");
    refuse(&tree, 3, 11, "11 bits a normal");
    let v = DagValues {
        level: Some(3),
        colour_bits: 8,
        ..DagValues::default()
    };
    let e = svo::io::write_dag_to_with(&tree, &BuildInfo::new(), &v, &mut Vec::new()).unwrap_err();
    assert!(e.to_string().contains("8 bits a colour"), "{e}");
    refuse(&per_leaf, 3, 32, "inner nodes' attributes");
}
