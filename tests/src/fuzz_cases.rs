//! What the fuzz targets check, as plain functions: `fuzz/fuzz_targets/*.rs` call them on
//! the fuzzer's inputs, and svo's test `fuzz_regressions` on the inputs kept in
//! `fixtures/fuzz/` (every crash the fuzzer found, and seeds). Each panics when a property
//! fails. The checks use the integer reference ([`crate::exact_sat`]) and the exact
//! voxelization oracle for any `f64` input ([`crate::oracle`]).

use crate::{exact_sat, oracle};
use glam::DVec3;
use svo::io::{from_bytes, to_bytes};
use svo::{BakeOptions, Mesh, MeshFormat, Strategy, bake_mesh};

/// The `.svo` reader on arbitrary bytes: an error or a valid tree, never a panic, a hang or
/// a huge allocation; a tree it accepts writes back to bytes that read as the same tree, and
/// a version-2 file it accepts writes back byte for byte (only canonical files are valid).
/// Each input is read twice: as it is, and with its last 8 bytes replaced by the right
/// checksum, so that mutations reach the checks behind the checksum (header, arrays, tree
/// structure) instead of all failing at it.
pub fn svo_read(data: &[u8]) {
    read_one(data);
    if data.len() >= 8 {
        let mut fixed = data.to_vec();
        let n = fixed.len() - 8;
        let sum = xxhash_rust::xxh3::xxh3_64(&fixed[..n]);
        fixed[n..].copy_from_slice(&sum.to_le_bytes());
        read_one(&fixed);
    }
}

fn read_one(data: &[u8]) {
    if let Ok((tree, info)) = from_bytes(data) {
        let again = to_bytes(&tree, &info);
        let (back, _) = from_bytes(&again).expect("a tree we accepted must write back readably");
        assert_eq!(back.nodes, tree.nodes);
        assert_eq!(back.leaf_count, tree.leaf_count);
        // The reader accepts only canonical files (docs/format.md): a version-2 file it
        // accepts is what the writer writes for its tree, byte for byte.
        if data[8] == 2 {
            assert!(again == data, "an accepted version-2 file is not canonical");
        }
    }
}

/// The mesh importers: the first byte picks OBJ, gzipped OBJ, PLY or glTF/GLB, the rest is
/// the file. An error or a valid mesh, never a panic; and where our own OBJ reader takes the
/// file, exactly tobj's mesh, as the PLY read through our ASCII scan is exactly the one read
/// through `ply-rs-bw` alone.
pub fn mesh_import(data: &[u8]) {
    let Some((&which, bytes)) = data.split_first() else {
        return;
    };
    let format = match which % 4 {
        0 => MeshFormat::Obj,
        1 => MeshFormat::ObjGz,
        2 => MeshFormat::Ply,
        _ => MeshFormat::Gltf,
    };
    // The importers' own readers against the crates they stand in for: the library's
    // differential checks, built for the fuzz targets only (its unit tests run them on the
    // kept inputs).
    #[cfg(fuzzing)]
    match format {
        MeshFormat::Obj => {
            svo::fuzz_import::same_as_tobj(bytes);
        }
        MeshFormat::Ply => svo::fuzz_import::same_as_ply_crate(bytes),
        _ => {}
    }
    match Mesh::from_bytes(bytes, format) {
        Ok(mesh) => mesh.validate().expect("an imported mesh is valid"),
        // The glTF importer turns a panic inside the gltf crates into this error; each
        // one the fuzzer finds gets a check of its own (`precheck` in `import/gltf.rs`).
        // (Only for glTF: another format's error may quote the input, which may hold
        // these words.)
        Err(e) => assert!(
            format != MeshFormat::Gltf || !e.to_string().contains("the glTF library failed"),
            "a panic in the gltf crates: {e}"
        ),
    }
}

/// Triangles per fuzzed mesh: lattice meshes are checked against the brute force, which
/// visits every cell near each triangle, so they stay fewer.
const MAX_TRIANGLES: usize = 24;
const MAX_LATTICE_TRIANGLES: usize = 10;

/// The voxelizer on small meshes: an even first byte makes a lattice mesh (coordinates on
/// the 1/16 lattice in `[0, 4]`, the root pinned to that cube) whose tree, in every
/// strategy, is compared with the exact `i128` brute force at depth 1-6 (at depth 6 the
/// bake's 32^3 blocks are below the root, so contacts across block faces are exercised);
/// an odd one reads
/// raw `f64` coordinates (any bits: NaN, infinities, huge, tiny, denormal) and bakes at
/// depth 1-6, which must give an error or a tree whose leaves are exactly the cells the
/// exact oracle finds touched (in the bake's own root), that survives the file format (and,
/// with the `solid` feature, a vote-filled tree that keeps every surface leaf).
pub fn bake(data: &[u8]) {
    let Some((&head, rest)) = data.split_first() else {
        return;
    };
    // The brute force visits every cell near each triangle: shallow trees keep a run fast.
    if head & 1 == 0 {
        lattice(1 + (head >> 1) % 6, rest);
    } else {
        raw(1 + (head >> 1) % 6, rest);
    }
}

fn lattice(depth: u8, bytes: &[u8]) {
    let mut tris: Vec<[exact_sat::I3; 3]> = vec![
        [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
        [[64, 64, 64], [63, 64, 64], [64, 63, 64]],
    ];
    for c in bytes.chunks_exact(9).take(MAX_LATTICE_TRIANGLES) {
        let p = |k: usize| [0, 1, 2].map(|a| i128::from(c[3 * k + a] % 65));
        tris.push([p(0), p(1), p(2)]);
    }
    let mut mesh = Mesh::default();
    for t in &tris {
        let b = mesh.positions.len() as u32;
        mesh.positions.extend(
            t.iter()
                .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / 16.0),
        );
        mesh.triangles.push([b, b + 1, b + 2]);
    }
    let expect = exact_sat::lattice_brute_force(&tris, depth);
    for strategy in Strategy::ALL {
        let opts = BakeOptions {
            depth,
            strategy,
            ..Default::default()
        };
        let (tree, _) = bake_mesh(&mesh, &opts).expect("a lattice mesh bakes");
        let cells: std::collections::BTreeSet<[u32; 3]> =
            tree.leaves().map(|l| l.cell.to_array()).collect();
        for c in expect.keys() {
            assert!(
                cells.contains(c),
                "{strategy} missed the touched cell {c:?}"
            );
        }
        if strategy.is_exact() {
            assert_eq!(
                cells.len(),
                expect.len(),
                "{strategy} kept an untouched cell"
            );
        }
    }
}

fn raw(depth: u8, bytes: &[u8]) {
    let vals: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect();
    let positions: Vec<DVec3> = vals
        .chunks_exact(3)
        .take(3 * MAX_TRIANGLES)
        .map(|v| DVec3::new(v[0], v[1], v[2]))
        .collect();
    let n = positions.len() as u32 / 3;
    let triangles = (0..n).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    let mesh = Mesh::from_triangles(positions, triangles);
    let opts = BakeOptions {
        depth,
        max_memory: Some(1 << 30),
        ..Default::default()
    };
    if let Ok((tree, _)) = bake_mesh(&mesh, &opts) {
        // Grid coordinates from their definition in the bake's root; cells from the oracle.
        let (origin, side) = (tree.root.origin, tree.root.side);
        let tris = oracle::grid_triangles(&mesh.positions, &mesh.triangles, origin, side, depth);
        let want: Vec<[u32; 3]> = oracle::touched_cells(&tris, depth)[usize::from(depth)]
            .keys()
            .copied()
            .collect();
        let mut got: Vec<[u32; 3]> = tree.leaves().map(|l| l.cell.to_array()).collect();
        got.sort_unstable();
        assert_eq!(
            got, want,
            "the bake's leaves are not the cells the oracle finds touched"
        );
        let bytes = to_bytes(&tree, &Default::default());
        from_bytes(&bytes).expect("a baked tree reads back");
        // The same mesh filled by voting (these meshes are rarely closed): a valid tree
        // that keeps every surface leaf.
        {
            let solid_opts = BakeOptions {
                solid: Some(svo::bake::SolidMode::Vote),
                ..opts
            };
            if let Ok((solid, _)) = bake_mesh(&mesh, &solid_opts) {
                solid.validate().expect("a solid tree is valid");
                for l in tree.leaves() {
                    let i = solid.leaf_at(l.cell).expect("a surface leaf is kept");
                    assert!(!solid.attributes.is_interior(i as usize));
                }
                let bytes = to_bytes(&solid, &Default::default());
                from_bytes(&bytes).expect("a solid tree reads back");
            }
        }
    }
}
