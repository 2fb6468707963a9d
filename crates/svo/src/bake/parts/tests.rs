//! A bake in parts (plan, parts, merge) writes the same bytes as the bake in memory, whatever
//! the number of parts; a part baked twice is the same file; the merge refuses a missing
//! part, a part of another plan, a part given the wrong index, a truncated part and a
//! damaged one, and leaves no output when it does; a bake within a memory budget writes the
//! bake in memory's bytes.

use super::bins::{bin_path, read_bin};
use super::merge::{MergeFormat, merge_parts};
use super::part::{PartData, bake_parts, write_part};
use super::plan::{PartsError, hash_file, part_path, plan_bake, plan_file, read_plan, write_plan};
use super::{bake_part_file, bake_within};
use crate::bake::{BakeOptions, bake_mesh};
use crate::io::BuildInfo;
use rand::{Rng, SeedableRng};
use std::path::{Path, PathBuf};

/// What `svo-bake` records of a mesh file's bake.
fn build_of(mesh: &crate::Mesh, opts: &BakeOptions) -> BuildInfo {
    BuildInfo {
        strategy: opts.strategy.name().to_string(),
        source_triangles: mesh.triangles.len() as u64,
        scene: mesh.scene.clone(),
        ..BuildInfo::new()
    }
}

/// The in-memory bake's file bytes.
fn in_memory(mesh: &Path, opts: &BakeOptions, _dir: &Path) -> Vec<u8> {
    let mesh = crate::Mesh::load(mesh).unwrap();
    let (tree, _) = bake_mesh(&mesh, opts).unwrap();
    let mut bytes = Vec::new();
    crate::io::write_to(&tree, &build_of(&mesh, opts), &mut bytes).unwrap();
    bytes
}

/// Plans `parts` parts, bakes each into its file and returns the plan's path.
fn plan_and_bake(mesh_path: &Path, opts: &BakeOptions, parts: u32, dir: &Path) -> PathBuf {
    plan_and_bake_for(mesh_path, opts, parts, dir, None)
}

/// [`plan_and_bake`] for a merge into a DAG that keeps the values `dag`.
fn plan_and_bake_for(
    mesh_path: &Path,
    opts: &BakeOptions,
    parts: u32,
    dir: &Path,
    dag: Option<crate::dag::DagValues>,
) -> PathBuf {
    let mesh = crate::Mesh::load(mesh_path).unwrap();
    let build = build_of(&mesh, opts);
    let hash = hash_file(mesh_path).unwrap();
    let plan = plan_bake(&mesh, mesh_path, hash, opts, (parts, dag), build).unwrap();
    let plan_path = dir.join(format!("job{parts}.svoplan"));
    let plan_hash = write_plan(&plan, &plan_path).unwrap();
    // Each part alone, as `svo-bake part` bakes it (setting up only the triangles that may
    // reach its subtrees), except the first plan's, baked in one call as `--memory` does.
    let mut write =
        |i: u32, part: PartData| write_part(&part, &part_path(&plan_path, i)).map(|_| ());
    if parts == 1 {
        bake_parts(&mesh, &plan, plan_hash, 0..parts, &mut write).unwrap();
    } else {
        for i in 0..parts {
            bake_parts(&mesh, &plan, plan_hash, [i], &mut write).unwrap();
        }
    }
    plan_path
}

fn merged(plan: &Path, dir: &Path) -> Result<Vec<u8>, PartsError> {
    merged_as(plan, dir, MergeFormat::Auto)
}

fn merged_as(plan: &Path, dir: &Path, format: MergeFormat) -> Result<Vec<u8>, PartsError> {
    let out = dir.join("merged.svo");
    let _ = std::fs::remove_file(&out);
    merge_parts(plan, &out, format)?;
    Ok(std::fs::read(out).unwrap())
}

/// The merge into version 3 (chunks at the plan's level) is what the library's chunked writer
/// makes of the in-memory bake's tree, and reads back as that tree.
fn check_chunked(plan: &Path, whole: &[u8], dir: &Path) {
    let got = merged_as(plan, dir, MergeFormat::Chunked).unwrap();
    let (tree, build) = crate::io::from_bytes(whole).unwrap();
    let level = read_plan(plan).unwrap().0.level;
    let mut want = Vec::new();
    crate::io::write_chunked_to(&tree, &build, level, &mut want).unwrap();
    assert_eq!(u32::from_le_bytes(got[8..12].try_into().unwrap()), 3);
    assert!(got == want, "{} bytes against {}", got.len(), want.len());
    assert_eq!(crate::io::from_bytes(&got).unwrap().0, tree);
}

/// The merge into the DAG layout (the parts reduced into one graph as they are read) is what
/// the library's DAG writer makes of the in-memory bake's tree, and reads back as that tree.
fn check_dag(plan: &Path, whole: &[u8], dir: &Path) {
    let got = merged_as(plan, dir, MergeFormat::Dag).unwrap();
    let (tree, build) = crate::io::from_bytes(whole).unwrap();
    let mut want = Vec::new();
    crate::io::write_dag_to(&tree, &build, &mut want).unwrap();
    assert!(got == want, "{} bytes against {}", got.len(), want.len());
    assert_eq!(crate::io::from_bytes(&got).unwrap().0, tree);
}

fn meshes() -> Vec<PathBuf> {
    let mut v = vec![svo_tests::repo_root().join("fixtures/torus.obj")];
    v.extend(svo_tests::model("stanford/bun_zipper.ply"));
    v
}

/// At depths 6 to 9 (parts' levels 1 to 4), in 1 to 16 parts, with every channel, with
/// none and with an inexact strategy: the merged file is the in-memory bake's, byte for byte,
/// in each of the tree layout, chunks and the DAG layout.
#[test]
fn parts_merge_into_the_bytes_of_the_whole_bake() {
    let dir = tempfile::tempdir().unwrap();
    let mut checked = 0;
    for mesh in meshes() {
        for depth in [6u8, 7, 9] {
            for (k, opts) in [
                BakeOptions::default(),
                BakeOptions {
                    channels: "none".parse().unwrap(),
                    ..BakeOptions::default()
                },
                BakeOptions {
                    strategy: "aabb-plane".parse().unwrap(),
                    channels: "normal,colour".parse().unwrap(),
                    pad: 2,
                    ..BakeOptions::default()
                },
            ]
            .into_iter()
            .enumerate()
            {
                if k > 0 && depth == 9 {
                    continue;
                }
                let opts = BakeOptions { depth, ..opts };
                let whole = in_memory(&mesh, &opts, dir.path());
                for parts in [1u32, 3, 16] {
                    let plan = plan_and_bake(&mesh, &opts, parts, dir.path());
                    let got = merged(&plan, dir.path()).unwrap();
                    assert!(
                        got == whole,
                        "{} depth {depth} options {k}, {parts} parts: {} bytes against {}",
                        mesh.display(),
                        got.len(),
                        whole.len()
                    );
                    check_chunked(&plan, &whole, dir.path());
                    check_dag(&plan, &whole, dir.path());
                    checked += 1;
                }
            }
        }
    }
    // Alpha-masked and blended textured materials (cut by the importer, per-leaf optics).
    if let Some(vase) = svo_tests::model("gltf/GlassVaseFlowers.glb") {
        let opts = BakeOptions {
            depth: 6,
            ..BakeOptions::default()
        };
        let whole = in_memory(&vase, &opts, dir.path());
        for parts in [1u32, 3] {
            let plan = plan_and_bake(&vase, &opts, parts, dir.path());
            assert!(
                merged(&plan, dir.path()).unwrap() == whole,
                "vase, {parts} parts"
            );
        }
    }
    assert!(checked >= 15);
}

/// A lattice coordinate in `[0, 64]` (sixteenths of the root's side of 4): half of them on a
/// boundary of the parts' nodes at level 3 (multiples of 8), a quarter on one of level 4.
fn lattice_coordinate(rng: &mut impl Rng) -> u32 {
    match rng.random_range(0..4) {
        0 | 1 => 8 * rng.random_range(0..=8),
        2 => 4 * rng.random_range(0..=16),
        _ => rng.random_range(0..=64),
    }
}

/// A random soup of up to 14 triangles on the 1/16 lattice of `[0, 4]^3` scaled by `scale`
/// (a power of two, so the lattice stays exact), written as an OBJ file: the root is pinned
/// to that cube by a triangle at each of two opposite corners, and the other triangles have
/// their vertices, edges and faces on the boundaries between parts, some degenerate (a
/// vertex repeated, or three on a line) and some lying in one boundary plane.
fn lattice_soup(rng: &mut impl Rng, scale: f64, path: &Path) {
    let mut tris: Vec<[[u32; 3]; 3]> = vec![
        [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
        [[64, 64, 64], [63, 64, 64], [64, 63, 64]],
    ];
    for _ in 0..rng.random_range(1..=12) {
        let mut t = [0; 3].map(|_| [0; 3].map(|_| lattice_coordinate(rng)));
        match rng.random_range(0..8) {
            0 => t[2] = t[rng.random_range(0..2)],
            1 => {
                // On a line through the first two vertices: the first mirrored through the
                // second where that stays on the lattice, else the second repeated.
                let (a, b) = (t[0], t[1]);
                let inside = (0..3).all(|k| a[k] <= 2 * b[k] && 2 * b[k] - a[k] <= 64);
                t[2] = if inside {
                    [0, 1, 2].map(|k| 2 * b[k] - a[k])
                } else {
                    b
                };
            }
            2 | 3 => {
                let (axis, plane) = (rng.random_range(0..3), 8 * rng.random_range(0..=8));
                for v in &mut t {
                    v[axis] = plane;
                }
            }
            _ => {}
        }
        tris.push(t);
    }
    let mut obj = String::new();
    for t in &tris {
        for v in t {
            let c = v.map(|c| f64::from(c) / 16.0 * scale);
            obj += &format!("v {:e} {:e} {:e}\n", c[0], c[1], c[2]);
        }
    }
    for k in 0..tris.len() {
        obj += &format!("f {} {} {}\n", 3 * k + 1, 3 * k + 2, 3 * k + 3);
    }
    std::fs::write(path, obj).unwrap();
}

/// Seeded random lattice soups whose triangles lie on the parts' boundaries (faces, edges and
/// corners of the nodes the parts are made of; degenerate and in-plane triangles among them;
/// coordinates scaled by 1, 2^-70 and 2^70), at depths 6 to 9 in 2 to 16 parts: the parts
/// baked from their bins merge into the in-memory bake's bytes, and into its chunked and DAG
/// files.
#[test]
fn lattice_soups_on_part_boundaries_merge_into_the_whole_bake() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(svo_tests::seeds::seed(0x9A27_5EED));
    let mut empty_parts = 0;
    for round in 0..30 {
        let scale = [1.0, 1.0, 1.0, 2f64.powi(-70), 2f64.powi(70)][round % 5];
        let mesh_path = dir.path().join("soup.obj");
        lattice_soup(&mut rng, scale, &mesh_path);
        let opts = BakeOptions {
            depth: rng.random_range(6..=9),
            channels: ["all", "none", "normal"][rng.random_range(0..3)]
                .parse()
                .unwrap(),
            ..BakeOptions::default()
        };
        let parts = [2, 3, 5, 8, 16][rng.random_range(0..5)];
        let whole = in_memory(&mesh_path, &opts, dir.path());
        let plan = dir.path().join("soup.svoplan");
        let (p, _) = plan_file(&mesh_path, &opts, parts, MergeFormat::Auto, &plan, true).unwrap();
        let plan_hash = read_plan(&plan).unwrap().1;
        for i in 0..parts {
            let bin = read_bin(&bin_path(&plan, i), plan_hash, i).unwrap();
            empty_parts += usize::from(bin.triangles.is_empty());
            bake_part_file(&plan, i, None).unwrap();
        }
        let got = merged(&plan, dir.path()).unwrap();
        assert!(
            got == whole,
            "round {round}: depth {}, {parts} parts at level {}, scale {scale:e}: the merged \
             parts ({} bytes) differ from the in-memory bake ({} bytes)",
            opts.depth,
            p.level,
            got.len(),
            whole.len()
        );
        check_chunked(&plan, &whole, dir.path());
        check_dag(&plan, &whole, dir.path());
    }
    // The soups leave some parts without a triangle, whose merge must still hold.
    assert!(empty_parts > 0);
}

/// A part baked again is the same file, byte for byte, alone or with the others.
#[test]
fn a_part_baked_twice_is_the_same_file() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = svo_tests::repo_root().join("fixtures/torus.obj");
    let opts = BakeOptions {
        depth: 7,
        ..BakeOptions::default()
    };
    let plan = plan_and_bake(&mesh, &opts, 4, dir.path());
    let first: Vec<Vec<u8>> = (0..4)
        .map(|i| std::fs::read(part_path(&plan, i)).unwrap())
        .collect();
    plan_and_bake(&mesh, &opts, 4, dir.path());
    for (i, f) in first.iter().enumerate() {
        assert!(
            &std::fs::read(part_path(&plan, i as u32)).unwrap() == f,
            "part {i} differs"
        );
    }
    // Baked all in one call (as `--memory` does, every triangle set up), the same files.
    let (p, plan_hash) = read_plan(&plan).unwrap();
    let loaded = crate::Mesh::load(&mesh).unwrap();
    bake_parts(&loaded, &p, plan_hash, 0..4, &mut |i, part| {
        write_part(&part, &part_path(&plan, i)).map(|_| ())
    })
    .unwrap();
    for (i, f) in first.iter().enumerate() {
        assert!(
            &std::fs::read(part_path(&plan, i as u32)).unwrap() == f,
            "part {i} differs"
        );
    }
}

/// The merge refuses a missing, foreign, misplaced, truncated or damaged part with an error
/// that names it, and writes no output, with and without the inner nodes' attributes.
#[test]
fn the_merge_refuses_bad_parts_and_writes_nothing() {
    refuses_bad_parts(false, MergeFormat::Auto);
    refuses_bad_parts(true, MergeFormat::Auto);
    refuses_bad_parts(false, MergeFormat::Dag);
}

fn refuses_bad_parts(node_attributes: bool, format: MergeFormat) {
    let dir = tempfile::tempdir().unwrap();
    let mesh = svo_tests::repo_root().join("fixtures/torus.obj");
    let opts = BakeOptions {
        depth: 7,
        node_attributes,
        ..BakeOptions::default()
    };
    let plan = plan_and_bake(&mesh, &opts, 4, dir.path());
    let other_dir = dir.path().join("other");
    std::fs::create_dir(&other_dir).unwrap();
    let other = plan_and_bake(
        &mesh,
        &BakeOptions {
            depth: 6,
            ..opts.clone()
        },
        4,
        &other_dir,
    );
    let (p, _) = read_plan(&plan).unwrap();
    // The part with the most leaves, so that every array has bytes to damage.
    let big = (0..4)
        .max_by_key(|&i| std::fs::metadata(part_path(&plan, i)).unwrap().len())
        .unwrap();
    let good = std::fs::read(part_path(&plan, big)).unwrap();
    let out = dir.path().join("merged.svo");
    let check_with = |format: MergeFormat, what: &str, want: &str| {
        let e = merge_parts(&plan, &out, format)
            .expect_err(what)
            .to_string();
        assert!(e.contains(want), "{what}: {e}");
        assert!(!out.exists(), "{what}: an output was left");
        let leftovers: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(Result::ok)
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "{what}: {leftovers:?}");
    };
    let check = |what: &str, want: &str| check_with(format, what, want);
    let put = |bytes: &[u8]| std::fs::write(part_path(&plan, big), bytes).unwrap();

    std::fs::remove_file(part_path(&plan, big)).unwrap();
    check("missing", "is missing");
    std::fs::copy(part_path(&other, big), part_path(&plan, big)).unwrap();
    check("foreign", "another plan");
    let next = (big + 1) % 4;
    std::fs::copy(part_path(&plan, next), part_path(&plan, big)).unwrap();
    check("wrong index", &format!("not part {big}"));
    for cut in [10, 30, good.len() / 2, good.len() - 3] {
        put(&good[..cut]);
        check(&format!("truncated at {cut}"), "truncated");
    }
    // A flipped byte in the header, in the node array and in the last channel array.
    let header_end = 24 + u32::from_le_bytes(good[12..16].try_into().unwrap()) as usize;
    for at in [30, header_end + 8, good.len() - 9] {
        let mut bad = good.clone();
        bad[at] ^= 0x10;
        put(&bad);
        check(&format!("byte {at} flipped"), "corrupt");
    }
    put(&good);
    assert!(merge_parts(&plan, &out, format).is_ok());
    assert_eq!(p.parts.len(), 4);
    if node_attributes {
        // The DAG layout keeps no inner-node attributes.
        std::fs::remove_file(&out).unwrap();
        check_with(MergeFormat::Dag, "DAG layout", "no inner-node attributes");
    }
}

/// A bake within a memory budget far below the bake in memory's needs goes into several
/// parts and writes the in-memory bake's bytes: version 2, version 4 with the inner nodes'
/// attributes, and version 4's DAG layout.
#[test]
fn a_bake_within_a_small_budget_writes_the_bytes_of_the_bake_in_memory() {
    let dir = tempfile::tempdir().unwrap();
    let mesh_path = svo_tests::repo_root().join("fixtures/torus.obj");
    // Values on level 5 (below the parts' level): parts without per-leaf arrays.
    let on_level = crate::dag::DagValues {
        level: Some(5),
        normal_bits: 16,
        colour_bits: 32,
    };
    for (node_attributes, format, version) in [
        (false, MergeFormat::Auto, 2),
        (true, MergeFormat::Auto, 4),
        (false, MergeFormat::Dag, 4),
        (true, MergeFormat::DagWith(on_level), 4),
    ] {
        let opts = BakeOptions {
            depth: 9,
            node_attributes,
            channels: if node_attributes && format != MergeFormat::Auto {
                "normal,colour".parse().unwrap()
            } else {
                BakeOptions::default().channels
            },
            ..BakeOptions::default()
        };
        let mut whole = in_memory(&mesh_path, &opts, dir.path());
        if let MergeFormat::Dag | MergeFormat::DagWith(_) = format {
            let values = match format {
                MergeFormat::DagWith(v) => v,
                _ => crate::dag::DagValues::default(),
            };
            let mesh = crate::Mesh::load(&mesh_path).unwrap();
            let tree = bake_mesh(&mesh, &opts).unwrap().0;
            whole.clear();
            crate::io::write_dag_to_with(&tree, &build_of(&mesh, &opts), &values, &mut whole)
                .unwrap();
        }
        let out = dir.path().join("limited.svo");
        let mesh = crate::Mesh::load(&mesh_path).unwrap();
        let report = bake_within(
            &mesh,
            &mesh_path,
            &opts,
            16 << 20,
            &build_of(&mesh, &opts),
            &out,
            format,
            &|_, _| {},
        )
        .unwrap();
        assert!(report.plan.part_count() > 1, "{report:?}");
        assert_eq!(report.part_seconds.len() as u32, report.plan.part_count());
        assert_eq!(report.merge.version, version);
        assert_eq!(
            report.plan.leaf_arrays,
            format != MergeFormat::DagWith(on_level)
        );
        assert!(std::fs::read(&out).unwrap() == whole);
    }
}

/// A mesh with everything a bin must carry: three materials (one textured, one mirror, one
/// glass), texture coordinates on some triangles, shared vertices, triangles spread over the
/// whole root and some crossing it; written as OBJ + MTL + PNG into `dir`.
fn textured_mesh(dir: &Path) -> PathBuf {
    textured_mesh_in(dir, "m", false)
}

/// [`textured_mesh`], with every vertex moved into one of two small boxes at opposite corners
/// of its bounds when `corners` (so that most of the root is empty).
fn textured_mesh_in(dir: &Path, name: &str, corners: bool) -> PathBuf {
    let img = image::RgbaImage::from_fn(4, 2, |x, y| {
        image::Rgba([60 * x as u8, 120 * y as u8, 200, 255])
    });
    img.save(dir.join("tex.png")).unwrap();
    // The corners' materials share one colour, so only the texture makes colours vary.
    let mirror = if corners { "1 1 1" } else { "0.5 0.5 0.5" };
    std::fs::write(
        dir.join(format!("{name}.mtl")),
        format!(
            "newmtl textured\nKd 1 1 1\nmap_Kd tex.png\n\
             newmtl mirror\nKd {mirror}\nKs 0.9 0.8 0.7\nillum 3\n\
             newmtl glass\nKd 1 1 1\nTr 0.75\nNi 1.33\nillum 2\n"
        ),
    )
    .unwrap();
    let mut obj = format!("mtllib {name}.mtl\n");
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let n = 300;
    for k in 0..n {
        let mut v = [next() * 4.0, next() * 4.0, next() * 4.0];
        if corners {
            let far = if k < n / 2 { 0.0 } else { 3.5 };
            v = v.map(|c| far + c / 8.0);
        }
        obj += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    for k in 0..16 {
        obj += &format!("vt {} {}\n", f64::from(k) / 16.0, f64::from(k % 4) / 4.0);
    }
    for t in 0..700u32 {
        let a = 1 + (t * 7) % n;
        // Mostly small triangles (near neighbours in the vertex list), some long ones.
        let (b, c) = if t % 11 == 0 {
            (1 + (t * 13 + 5) % n, 1 + (t * 29 + 11) % n)
        } else {
            (1 + (a % n), 1 + ((a + 1) % n))
        };
        match t % 3 {
            0 => {
                obj += "usemtl textured\n";
                obj += &format!(
                    "f {a}/{} {b}/{} {c}/{}\n",
                    1 + t % 16,
                    1 + (t + 3) % 16,
                    1 + (t + 7) % 16
                );
            }
            1 => obj += &format!("usemtl mirror\nf {a} {b} {c}\n"),
            _ => obj += &format!("usemtl glass\nf {a} {b} {c}\n"),
        }
    }
    let path = dir.join(format!("{name}.obj"));
    std::fs::write(&path, obj).unwrap();
    path
}

/// Parts baked from bins (each part's own triangles, written with the plan) are the files the
/// parts bake from the whole mesh, byte for byte, and merge into the in-memory bake's bytes,
/// on a mesh with textures, materials and texture coordinates and on the bunny; every bin
/// holds fewer triangles than the mesh. A bin that is damaged, truncated, of another plan or
/// of another part is refused with a message naming what is wrong.
#[test]
fn bins_bake_the_same_parts_and_bad_bins_are_refused() {
    let d = tempfile::tempdir().unwrap();
    // The corners' mesh leaves parts without a triangle at depth 6 in 8 parts (one node of
    // level 1 a part).
    let mut meshes = vec![
        (textured_mesh(d.path()), 7u8, 5u32),
        (textured_mesh_in(d.path(), "corners", true), 6, 8),
    ];
    if let Some(bunny) = svo_tests::model("stanford/bun_zipper.ply") {
        meshes.push((bunny, 8, 16));
    }
    for (mesh_path, depth, parts) in meshes {
        let opts = BakeOptions {
            depth,
            ..BakeOptions::default()
        };
        let whole = in_memory(&mesh_path, &opts, d.path());
        let plan = d.path().join("binned.svoplan");
        let (p, bins) =
            plan_file(&mesh_path, &opts, parts, MergeFormat::Auto, &plan, true).unwrap();
        let bins = bins.unwrap();
        assert_eq!((bins.files, p.part_count()), (parts, parts));
        let triangles = crate::Mesh::load(&mesh_path).unwrap().triangles.len();
        let mut from_bins = Vec::new();
        let mut empty = 0;
        for i in 0..parts {
            let plan_hash = read_plan(&plan).unwrap().1;
            let bin = read_bin(&bin_path(&plan, i), plan_hash, i).unwrap();
            empty += usize::from(bin.triangles.is_empty());
            // A part holds fewer triangles than the mesh (the corners' mesh: all of them in
            // the part around the first corner, whose neighbour reaches the second).
            assert!(
                bin.triangles.len() < triangles || mesh_path.ends_with("corners.obj"),
                "part {i}: {} triangles",
                bin.triangles.len()
            );
            bake_part_file(&plan, i, None).unwrap();
            from_bins.push(std::fs::read(part_path(&plan, i)).unwrap());
        }
        if mesh_path.ends_with("corners.obj") {
            assert!(empty > 0, "no part without triangles");
        }
        assert!(
            merged(&plan, d.path()).unwrap() == whole,
            "{}: the merged parts from bins differ from the in-memory bake",
            mesh_path.display()
        );
        // The same parts from the whole mesh (the plan again without bins removes them).
        plan_file(&mesh_path, &opts, parts, MergeFormat::Auto, &plan, false).unwrap();
        assert!(!bin_path(&plan, 0).exists());
        for (i, bytes) in from_bins.iter().enumerate() {
            bake_part_file(&plan, i as u32, None).unwrap();
            assert!(
                &std::fs::read(part_path(&plan, i as u32)).unwrap() == bytes,
                "part {i}"
            );
        }
        eprintln!(
            "{}: {} triangles, {} in the bins together ({} bytes)",
            mesh_path.display(),
            triangles,
            bins.triangles,
            bins.bytes
        );
    }

    // Bad bins.
    let mesh_path = textured_mesh(d.path());
    let opts = BakeOptions {
        depth: 6,
        ..BakeOptions::default()
    };
    let plan = d.path().join("bad.svoplan");
    plan_file(&mesh_path, &opts, 3, MergeFormat::Auto, &plan, true).unwrap();
    let other = d.path().join("other.svoplan");
    plan_file(&mesh_path, &opts, 4, MergeFormat::Auto, &other, true).unwrap();
    let bin = |p: &Path, i: u32| bin_path(p, i);
    let good = std::fs::read(bin(&plan, 2)).unwrap();
    let refused = |bytes: &[u8], what: &str| {
        std::fs::write(bin(&plan, 2), bytes).unwrap();
        let e = bake_part_file(&plan, 2, None).unwrap_err().to_string();
        assert!(e.contains(what), "{what}: {e}");
        assert!(e.contains("bad.00002.svobin"), "{e}");
    };
    let mut damaged = good.clone();
    let k = damaged.len() / 2;
    damaged[k] ^= 0x10;
    refused(&damaged, "checksum mismatch");
    refused(&good[..good.len() - 9], "truncated");
    refused(
        b"not a bin at all, but long enough to have a header",
        "bad magic",
    );
    refused(&std::fs::read(bin(&other, 2)).unwrap(), "another plan");
    refused(&std::fs::read(bin(&plan, 1)).unwrap(), "holds part 1");
    std::fs::write(bin(&plan, 2), &good).unwrap();
    bake_part_file(&plan, 2, None).unwrap();
}

/// A flat square (and two points that pin its bounds to a cube) as an OBJ file in `dir`: every
/// leaf has one normal.
fn flat_square(dir: &Path) -> PathBuf {
    let square = dir.join("square.obj");
    std::fs::write(
        &square,
        "v 0 0 0.3\nv 1 0 0.3\nv 1 1 0.3\nv 0 1 0.3\nv 0 0 0\nv 1 1 1\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    square
}

/// With the inner nodes' attributes, the merge writes version 4 with the in-memory bake's
/// bytes, whatever the number of parts (the levels above the parts' made from their roots),
/// on the torus, the bunny, a textured mesh with materials (per-node colours and optics), a
/// flat square (one normal for every leaf: the nodes' normals are then stored once) and a
/// mesh without channels (version 2). The merge refuses chunks for such a plan. (Bakes
/// within a budget: `a_bake_within_a_small_budget_writes_the_bytes_of_the_bake_in_memory`.)
#[test]
fn parts_with_inner_node_attributes_merge_into_the_bytes_of_the_whole_bake() {
    let dir = tempfile::tempdir().unwrap();
    let square = flat_square(dir.path());
    let mut cases: Vec<(PathBuf, u8, &str)> = Vec::new();
    for mesh in meshes() {
        cases.push((mesh.clone(), 7, "all"));
        cases.push((mesh.clone(), 9, "all"));
        cases.push((mesh, 6, "normal,colour"));
    }
    cases.push((textured_mesh(dir.path()), 7, "all"));
    cases.push((square, 7, "all"));
    cases.push((svo_tests::repo_root().join("fixtures/torus.obj"), 6, "none"));
    let mut versions = std::collections::BTreeSet::new();
    for (mesh, depth, channels) in &cases {
        let opts = BakeOptions {
            depth: *depth,
            channels: channels.parse().unwrap(),
            node_attributes: true,
            ..BakeOptions::default()
        };
        let whole = in_memory(mesh, &opts, dir.path());
        let version = u32::from_le_bytes(whole[8..12].try_into().unwrap());
        versions.insert(version);
        for parts in [1u32, 3, 16] {
            let plan = plan_and_bake(mesh, &opts, parts, dir.path());
            let got = merged(&plan, dir.path()).unwrap();
            assert!(
                got == whole,
                "{} depth {depth} channels {channels}, {parts} parts: {} bytes against {}",
                mesh.display(),
                got.len(),
                whole.len()
            );
            if version == 4 {
                let e = merged_as(&plan, dir.path(), MergeFormat::Chunked).unwrap_err();
                assert!(e.to_string().contains("inner-node attributes"), "{e}");
            }
        }
    }
    assert_eq!(versions, [2, 4].into());
    // The flat square's nodes store one normal, the torus's one per node.
    let nodes_normal = |mesh: &Path| {
        let opts = BakeOptions {
            depth: 7,
            node_attributes: true,
            ..BakeOptions::default()
        };
        let m = crate::Mesh::load(mesh).unwrap();
        let tree = bake_mesh(&m, &opts).unwrap().0;
        tree.node_attributes.normal.clone()
    };
    assert!(matches!(
        nodes_normal(&cases[cases.len() - 2].0),
        crate::octree::tree::Channel::Constant(_)
    ));
    assert!(matches!(
        nodes_normal(&cases[0].0),
        crate::octree::tree::Channel::PerLeaf(_)
    ));
}

/// The DAG merge with the leaves' values on a level (the parts baked with inner-node
/// attributes, without contours) or with normals and colours in fewer bits: the bytes the DAG writer
/// makes of the tree baked in memory, whatever the number of parts, for levels above, at and
/// below the parts' level, on the torus, the bunny, a textured mesh (per-node colours and
/// optics) and the flat square (one normal for every leaf). Parts planned for values on a
/// level keep no leaf channels and merge into the same file, and into no other. Values above
/// the leaves need the inner nodes' attributes, values on the leaves a plan without them; a
/// contour cannot sit on a level.
#[test]
fn parts_merge_into_a_dag_with_values_on_a_level() {
    use crate::dag::DagValues;
    let dir = tempfile::tempdir().unwrap();
    let square = flat_square(dir.path());
    let mut cases: Vec<(PathBuf, u8, &str)> = Vec::new();
    for mesh in meshes() {
        cases.push((mesh.clone(), 8, "normal"));
        cases.push((mesh, 6, "normal,colour"));
    }
    cases.push((
        textured_mesh(dir.path()),
        7,
        "normal,colour,reflectivity,ior",
    ));
    cases.push((square, 7, "normal"));
    let mut levels_seen = std::collections::BTreeSet::new();
    let mut checked = 0;
    for (mesh, depth, channels) in &cases {
        let m = crate::Mesh::load(mesh).unwrap();
        for node_attributes in [true, false] {
            let opts = BakeOptions {
                depth: *depth,
                channels: channels.parse().unwrap(),
                node_attributes,
                ..BakeOptions::default()
            };
            let tree = bake_mesh(&m, &opts).unwrap().0;
            let build = build_of(&m, &opts);
            for parts in [1u32, 3, 16] {
                let plan_path = plan_and_bake(mesh, &opts, parts, dir.path());
                let plan_level = read_plan(&plan_path).unwrap().0.level;
                let values: Vec<DagValues> = if node_attributes {
                    [1, plan_level, plan_level + 1, depth - 2]
                        .into_iter()
                        .filter(|&l| (1..=depth - 2).contains(&l))
                        .flat_map(|l| {
                            [(32, 32), (16, 16), (6, 4)].map(|(normal_bits, colour_bits)| {
                                DagValues {
                                    level: Some(l),
                                    normal_bits,
                                    colour_bits,
                                }
                            })
                        })
                        .collect()
                } else {
                    [(16, 4), (10, 16)]
                        .map(|(normal_bits, colour_bits)| DagValues {
                            level: None,
                            normal_bits,
                            colour_bits,
                        })
                        .to_vec()
                };
                for v in values {
                    let mut want = Vec::new();
                    crate::io::write_dag_to_with(&tree, &build, &v, &mut want).unwrap();
                    let got = merged_as(&plan_path, dir.path(), MergeFormat::DagWith(v)).unwrap();
                    assert!(
                        got == want,
                        "{} depth {depth} {channels}, {parts} parts, {v:?} (parts' level \
                         {plan_level}): {} bytes against {}",
                        mesh.display(),
                        got.len(),
                        want.len()
                    );
                    let level = v.level_for(*depth);
                    levels_seen.insert(level.cmp(&plan_level));
                    checked += 1;
                }
                // The wrong plan for the values asked.
                let other = if node_attributes {
                    DagValues {
                        level: None,
                        normal_bits: 16,
                        colour_bits: 32,
                    }
                } else {
                    DagValues {
                        level: Some(1),
                        normal_bits: 32,
                        colour_bits: 32,
                    }
                };
                let e = merged_as(&plan_path, dir.path(), MergeFormat::DagWith(other)).unwrap_err();
                assert!(
                    e.to_string().contains("inner-node attributes")
                        || e.to_string().contains("node attributes"),
                    "{e}"
                );
            }
        }
    }
    assert_eq!(
        levels_seen.len(),
        3,
        "levels above, at and below the parts'"
    );
    assert!(checked >= 60, "{checked}");
    // Parts planned for values on a level keep no per-leaf arrays: the same DAG, and no
    // other merge.
    let torus = svo_tests::repo_root().join("fixtures/torus.obj");
    let opts = BakeOptions {
        depth: 7,
        channels: "normal".parse().unwrap(),
        node_attributes: true,
        ..BakeOptions::default()
    };
    let v = DagValues {
        level: Some(4),
        normal_bits: 12,
        colour_bits: 32,
    };
    let size = |plan: &Path| -> u64 {
        (0..3)
            .map(|i| std::fs::metadata(part_path(plan, i)).unwrap().len())
            .sum()
    };
    // (Both plans are written to the same path: the second replaces the first's parts.)
    let full = plan_and_bake(&torus, &opts, 3, dir.path());
    let want = merged_as(&full, dir.path(), MergeFormat::DagWith(v)).unwrap();
    let full_bytes = size(&full);
    let lean = plan_and_bake_for(&torus, &opts, 3, dir.path(), Some(v));
    assert!(!read_plan(&lean).unwrap().0.leaf_arrays);
    assert!(
        size(&lean) < full_bytes,
        "{} against {full_bytes}",
        size(&lean)
    );
    assert!(merged_as(&lean, dir.path(), MergeFormat::DagWith(v)).unwrap() == want);
    for (format, says) in [
        (MergeFormat::Auto, "no per-leaf values"),
        (MergeFormat::Chunked, "no per-leaf values"),
        (MergeFormat::Dag, "inner-node attributes"),
    ] {
        let e = merged_as(&lean, dir.path(), format).unwrap_err();
        assert!(e.to_string().contains(says), "{e}");
    }
    // A contour cannot sit on a level: a plan with contours is refused.
    let opts = BakeOptions {
        depth: 6,
        node_attributes: true,
        ..BakeOptions::default()
    };
    let plan = plan_and_bake(&torus, &opts, 3, dir.path());
    let v = DagValues {
        level: Some(3),
        normal_bits: 32,
        colour_bits: 32,
    };
    let e = merged_as(&plan, dir.path(), MergeFormat::DagWith(v)).unwrap_err();
    assert!(e.to_string().contains("contour"), "{e}");
    assert!(!dir.path().join("merged.svo").exists());
}
