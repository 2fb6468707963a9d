//! `svo-view --info` on a file the library writes, and its errors on bad files.

use std::process::Command;
use svo_tests::harness::Test;
use svo_tests::trial;

fn view(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_svo-view"))
        .args(args)
        .output()
        .expect("run svo-view")
}

fn info_describes_a_file_and_errors_are_one_line() {
    let d = tempfile::tempdir().unwrap();
    let root = svo::RootCube {
        origin: glam::DVec3::ZERO,
        side: 2.0,
    };
    let cells = (0..20u32).map(|i| {
        (
            glam::UVec3::new(i % 4, i / 4 % 4, i / 16),
            svo::octree::Voxel::glass(),
        )
    });
    let tree = svo::Octree::from_cells(root, 2, cells).unwrap();
    let path = d.path().join("t.svo");
    let build = svo::io::BuildInfo {
        generator: "test".into(),
        strategy: "builder".into(),
        source_triangles: 0,
        ..Default::default()
    };
    svo::io::write_file(&tree, &build, &path).unwrap();

    let o = view(&[path.to_str().unwrap(), "--info"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    for want in [
        "leaves         20",
        "depth          2",
        "refractivity  constant 0.800",
        "ior           constant 1.5000",
        "bytes per leaf",
    ] {
        assert!(out.contains(want), "missing {want:?} in\n{out}");
    }
    // The same tree in chunks (format version 3): the same tree, and its chunks.
    let chunked = d.path().join("c.svo");
    let mut bytes = Vec::new();
    svo::io::write_chunked_to(&tree, &build, 1, &mut bytes).unwrap();
    std::fs::write(&chunked, &bytes).unwrap();
    let o = view(&[chunked.to_str().unwrap(), "--info"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    for want in [
        "format         version 3",
        "chunks         4 at level 1",
        "leaves         20",
    ] {
        assert!(text.contains(want), "missing {want:?} in\n{text}");
    }
    // The same tree as a DAG (format version 4, layout 1): the root is its one brick.
    let dag = d.path().join("g.svo");
    svo::io::write_dag_file(&tree, &build, &dag).unwrap();
    let o = view(&[dag.to_str().unwrap(), "--info"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    for want in [
        "format         version 4",
        "layout         DAG",
        "level 0        1 distinct bricks",
        "leaves         20",
    ] {
        assert!(text.contains(want), "missing {want:?} in\n{text}");
    }
    // A truncated file and a missing file: one line each, non-zero exit.
    let bytes = std::fs::read(&path).unwrap();
    let bad = d.path().join("bad.svo");
    std::fs::write(&bad, &bytes[..bytes.len() / 2]).unwrap();
    for p in [bad, d.path().join("missing.svo")] {
        let o = view(&[p.to_str().unwrap(), "--info"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success()
                && err.starts_with("svo-view: error: ")
                && err.trim_end().lines().count() == 1,
            "{err}"
        );
        assert!(!err.contains("panicked"));
    }
}

fn a_closed_stdout_ends_quietly() {
    // `svo-view file --info | head -1`: the reader has gone before the report is written.
    let d = tempfile::tempdir().unwrap();
    let tree = svo::Octree::from_cells(
        svo::RootCube {
            origin: glam::DVec3::ZERO,
            side: 1.0,
        },
        1,
        [(glam::UVec3::ZERO, svo::octree::Voxel::default())],
    )
    .unwrap();
    let path = d.path().join("one.svo");
    svo::io::write_file(&tree, &svo::io::BuildInfo::default(), &path).unwrap();
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let o = Command::new(env!("CARGO_BIN_EXE_svo-view"))
        .args([path.to_str().unwrap(), "--info"])
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && err.is_empty(),
        "{:?}: {err}",
        o.status
    );
}

/// The conformance corpus (`fixtures/format/conformance/`): for every invalid file `--info`
/// names the check it fails, by number and name, on one line; for a valid file it prints the
/// header's fields: version, header length, where each array is, the checksum.
fn info_names_the_failed_check_and_prints_the_header() {
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/format/conformance");
    let manifest = std::fs::read_to_string(dir.join("manifest.tsv")).unwrap();
    let mut invalid = 0;
    for line in manifest.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = line.split('\t').collect();
        let o = view(&[dir.join(f[0]).to_str().unwrap(), "--info"]);
        if f[1] == "invalid" {
            invalid += 1;
            let err = String::from_utf8_lossy(&o.stderr);
            let want = format!("check {} ({}): ", f[2], f[3]);
            assert!(
                !o.status.success() && err.contains(&want) && err.trim_end().lines().count() == 1,
                "{}: {err}",
                f[0]
            );
        } else {
            assert!(
                o.status.success(),
                "{}: {}",
                f[0],
                String::from_utf8_lossy(&o.stderr)
            );
        }
    }
    assert!(invalid >= 18, "{invalid} invalid files");
    let o = view(&[dir.join("valid-bake.svo").to_str().unwrap(), "--info"]);
    let out = String::from_utf8_lossy(&o.stdout);
    for want in [
        "format         version 2, header 211 bytes at 16, checksum 0x",
        "arrays         nodes at 232 (1576 bytes)",
        "               normal at 1808 (2656 bytes)",
        "               contour at 4464 (2656 bytes)",
        "               ior constant 0x2000",
        "generator      svo conformance (strategy exact, 256 source triangles)",
    ] {
        assert!(out.contains(want), "missing {want:?} in\n{out}");
    }
    let o = view(&[dir.join("valid-scene.svo").to_str().unwrap(), "--info"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("light          (2, 3, -1.5)") && out.contains("view           \"front\""),
        "{out}"
    );
    let o = view(&[dir.join("valid-version-1.svo").to_str().unwrap(), "--info"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("format         version 1,"));
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![
        trial!(info_describes_a_file_and_errors_are_one_line),
        trial!(a_closed_stdout_ends_quietly),
        trial!(info_names_the_failed_check_and_prints_the_header),
    ]
}
