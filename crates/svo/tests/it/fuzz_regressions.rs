//! The fuzz targets' checks (`tests/src/fuzz_cases.rs`) on every input kept in
//! `fixtures/fuzz/<target>/`: the seeds the fuzzer starts from and every input that once
//! crashed a target. Runs on stable in every test run; the fuzzing itself needs nightly and
//! `cargo fuzz` (see `docs/stability.md`).

#![cfg(all(feature = "io", feature = "obj", feature = "ply", feature = "gltf"))]

use crate::common;

use common::fuzz_cases;
use std::path::Path;

/// Runs `check` on every file of `fixtures/fuzz/<target>`, returning how many there were.
fn run(target: &str, check: fn(&[u8])) -> usize {
    run_in(&format!("fuzz/{target}"), check)
}

/// Runs `check` on every file of `fixtures/<folder>`, returning how many there were.
fn run_in(folder: &str, check: fn(&[u8])) -> usize {
    let target = folder;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(folder);
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    paths.sort();
    for p in &paths {
        let data = std::fs::read(p).unwrap();
        let r = std::panic::catch_unwind(|| check(&data));
        assert!(r.is_ok(), "{target}: {} fails its check", p.display());
    }
    paths.len()
}

#[test]
fn svo_reader_inputs() {
    assert!(run("svo_read", fuzz_cases::svo_read) >= 2);
    // The format's conformance corpus, which the fuzzer also starts from (`.ci/run`).
    assert!(run_in("format/conformance", fuzz_cases::svo_read) >= 60);
}

#[test]
fn mesh_import_inputs() {
    assert!(run("mesh_import", fuzz_cases::mesh_import) >= 4);
}

#[test]
fn bake_inputs() {
    assert!(run("bake", fuzz_cases::bake) >= 2);
}

/// The seeds are real inputs (so the fuzzer starts from the formats' happy paths): each
/// mesh seed imports, each `.svo` seed but the truncated one reads.
#[test]
fn seeds_are_valid_inputs() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/fuzz");
    let read = |p: &str| std::fs::read(dir.join(p)).unwrap();
    for (file, format) in [
        ("mesh_import/seed-obj", svo::MeshFormat::Obj),
        ("mesh_import/seed-obj-gz", svo::MeshFormat::ObjGz),
        ("mesh_import/seed-ply", svo::MeshFormat::Ply),
        ("mesh_import/seed-ply-ascii", svo::MeshFormat::Ply),
        ("mesh_import/seed-gltf", svo::MeshFormat::Gltf),
    ] {
        let bytes = read(file);
        let mesh =
            svo::Mesh::from_bytes(&bytes[1..], format).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert!(!mesh.triangles.is_empty(), "{file}");
    }
    assert!(svo::io::from_bytes(&read("svo_read/seed-depth3.svo")).is_ok());
    assert!(svo::io::from_bytes(&read("svo_read/seed-truncated")).is_err());
}
