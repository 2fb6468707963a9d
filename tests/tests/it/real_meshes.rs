//! The shared real meshes: baked at low depths they equal the exact oracle cell for cell
//! ([`svo_tests::bake_check`]), and the importers' own readers take them and read them
//! exactly as the crates they stand in for (tobj, ply-rs-bw).

use svo::Mesh;
use svo_tests::bake_check::check;
use svo_tests::harness::{Need, Test};
use svo_tests::trial;

fn real_meshes_at_low_depth_equal_the_oracle() {
    for (rel, depth) in [
        ("stanford/stanford-bunny.obj", 5),
        ("classic/teapot.obj", 5),
        ("classic/spot.obj", 4),
    ] {
        let mesh = Mesh::load(svo_tests::models_dir().join(rel)).unwrap();
        let cells = check(&mesh, depth, rel, true);
        assert!(cells > 100, "{rel}: {cells} cells");
    }
}

/// Our OBJ reader takes each of these geometry-only files and reads it exactly as tobj does.
fn shared_obj_files_read_as_tobj_reads_them() {
    for file in [
        "stanford/stanford-bunny.obj",
        "stanford/dragon_vrip_res2.obj.gz",
        "classic/spot.obj",
        "classic/teapot.obj",
    ] {
        let raw = std::fs::read(svo_tests::models_dir().join(file)).unwrap();
        let bytes = if file.ends_with(".gz") {
            use std::io::Read;
            let mut out = Vec::new();
            flate2::read::GzDecoder::new(&raw[..])
                .read_to_end(&mut out)
                .unwrap();
            out
        } else {
            raw
        };
        assert!(
            svo::fuzz_import::same_as_tobj(&bytes),
            "{file}: the reader declined"
        );
    }
}

/// The PLY importer's ASCII scan takes the bunny and reads it exactly as ply-rs-bw does.
fn bun_zipper_reads_as_ply_rs_reads_it() {
    let bytes = std::fs::read(svo_tests::models_dir().join("stanford/bun_zipper.ply")).unwrap();
    svo::fuzz_import::same_as_ply_crate(&bytes);
    assert!(
        svo::fuzz_import::ply_ascii_scan_takes(&bytes),
        "the ASCII scan declined"
    );
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    let (bunny, teapot, spot) = (
        Need::model("stanford/stanford-bunny.obj"),
        Need::model("classic/teapot.obj"),
        Need::model("classic/spot.obj"),
    );
    vec![
        trial!(
            real_meshes_at_low_depth_equal_the_oracle,
            bunny.clone(),
            teapot.clone(),
            spot.clone()
        ),
        trial!(
            shared_obj_files_read_as_tobj_reads_them,
            bunny,
            teapot,
            spot,
            Need::model("stanford/dragon_vrip_res2.obj.gz")
        ),
        trial!(
            bun_zipper_reads_as_ply_rs_reads_it,
            Need::model("stanford/bun_zipper.ply")
        ),
    ]
}
