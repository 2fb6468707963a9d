//! The `.svo` conformance corpus (`fixtures/format/conformance/`, `docs/format.md`): the
//! committed files are what the generator (`svo_tests::conformance`, an encoder written
//! from the document) makes; svo's reader accepts exactly the valid ones and rejects each
//! invalid one at the check its manifest names, with the check's number and name in the
//! message; and svo's writer, given a valid tree back, writes the same bytes as the
//! document's encoder (the canonical layout). A second reader, written from the document
//! alone (`svo_tests::spec_reader`), gives every file the same outcome and check.

use std::collections::BTreeMap;
use svo::dag::DagValues;
use svo::io::{FormatError, from_bytes, to_bytes, write_chunked_to, write_dag_to_with};
use svo::octree::Check;
use svo_tests::conformance::{corpus, manifest};
use svo_tests::harness::Test;
use svo_tests::spec_reader;
use svo_tests::trial;

fn corpus_dir() -> std::path::PathBuf {
    svo_tests::repo_root().join("fixtures/format/conformance")
}

fn committed_corpus_is_what_the_generator_makes() {
    let dir = corpus_dir();
    let made = corpus();
    let mut committed: BTreeMap<String, Vec<u8>> = BTreeMap::new();
    for f in std::fs::read_dir(&dir).expect("the corpus folder") {
        let p = f.expect("an entry").path();
        if p.extension().is_some_and(|e| e == "svo") {
            let name = p
                .file_name()
                .expect("a name")
                .to_string_lossy()
                .into_owned();
            committed.insert(name, std::fs::read(&p).expect("readable"));
        }
    }
    let regenerate = "regenerate with `cargo run -p svo-examples --example format_corpus`";
    assert_eq!(
        committed.keys().cloned().collect::<Vec<_>>(),
        {
            let mut names: Vec<String> = made.iter().map(|e| e.name.clone()).collect();
            names.sort();
            names
        },
        "the corpus's files differ from the generator's; {regenerate}"
    );
    for e in &made {
        assert!(
            committed[&e.name] == e.bytes,
            "{} differs; {regenerate}",
            e.name
        );
    }
    let text = std::fs::read_to_string(dir.join("manifest.tsv")).expect("the manifest");
    assert_eq!(text, manifest(&made), "manifest.tsv differs; {regenerate}");
}

fn the_reader_accepts_exactly_the_valid_files_and_names_each_failed_check() {
    let dir = corpus_dir();
    let text = std::fs::read_to_string(dir.join("manifest.tsv")).expect("the manifest");
    let mut per_check = BTreeMap::new();
    let (mut valid, mut chunked, mut levels, mut dags) = (0, 0, 0, 0);
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = line.split('\t').collect();
        let bytes = std::fs::read(dir.join(f[0])).expect("a corpus file");
        // The reader written from the document alone agrees with the manifest.
        let want = (f[1] == "invalid").then(|| f[2].parse::<u8>().expect("a number"));
        assert_eq!(
            spec_reader::check(&bytes).err(),
            want,
            "{}: the document's reader",
            f[0]
        );
        match (f[1], from_bytes(&bytes)) {
            ("valid", Ok((tree, build))) => {
                valid += 1;
                // The canonical writer: the same bytes back (version 2, and version 3 at the
                // file's chunk level; the library writes no version 1).
                if bytes[8] == 2 {
                    assert!(
                        to_bytes(&tree, &build) == bytes,
                        "{}: written differently",
                        f[0]
                    );
                }
                // Version 4, which svo writes for a tree with inner-node attributes.
                if bytes[8] == 4 && tree.node_attributes != Default::default() {
                    assert!(
                        to_bytes(&tree, &build) == bytes,
                        "{}: written differently",
                        f[0]
                    );
                    levels += 1;
                }
                // The DAG layout (its layout byte follows the root cube and the depth).
                // Values on a level above the leaves come from inner-node attributes, which a
                // tree read back does not keep: those files are not written again; normals
                // in fewer bits on the leaves' level are.
                let values = match f[0] {
                    "valid-dag-values-leaves.svo" => Some(DagValues {
                        level: None,
                        normal_bits: 10,
                        colour_bits: 32,
                    }),
                    name if name.starts_with("valid-dag-values-") => None,
                    _ => Some(DagValues::default()),
                };
                if bytes[8] == 4
                    && bytes[16 + 33] == 1
                    && let Some(values) = values
                {
                    let mut out = Vec::new();
                    write_dag_to_with(&tree, &build, &values, &mut out).expect("written");
                    assert!(out == bytes, "{}: written differently", f[0]);
                    dags += 1;
                }
                if bytes[8] == 3 {
                    // The chunk level follows the depth (docs/format.md, section 3).
                    let mut out = Vec::new();
                    write_chunked_to(&tree, &build, bytes[16 + 33], &mut out).expect("written");
                    assert!(out == bytes, "{}: written differently", f[0]);
                    chunked += 1;
                }
            }
            ("valid", Err(e)) => panic!("{}: refused: {e}", f[0]),
            ("invalid", Ok(_)) => panic!("{}: accepted, but it breaks check {}", f[0], f[2]),
            ("invalid", Err(e)) => {
                let want = Check::from_number(f[2].parse().expect("a number")).expect("a check");
                assert_eq!(want.name(), f[3], "{}", f[0]);
                assert_eq!(e.check(), Some(want), "{}: {e}", f[0]);
                let msg = e.to_string();
                assert!(
                    msg.starts_with(&format!("check {} ({}): ", want.number(), want.name())),
                    "{}: {msg}",
                    f[0]
                );
                if matches!(e, FormatError::Truncated { .. }) {
                    assert!(msg.contains("truncated"), "{msg}");
                }
                *per_check.entry(want.number()).or_insert(0) += 1;
            }
            (o, _) => panic!("{}: unknown outcome {o}", f[0]),
        }
    }
    assert_eq!((valid, chunked, levels, dags), (33, 5, 4, 6));
    // Every check has at least one file that fails it.
    let numbers: Vec<u8> = per_check.keys().copied().collect();
    assert_eq!(numbers, (1..=22).collect::<Vec<u8>>());
}

fn the_version_1_3_and_4_files_hold_the_same_trees_as_their_version_2_twins() {
    let dir = corpus_dir();
    let read = |name: &str| {
        from_bytes(&std::fs::read(dir.join(name)).expect("a corpus file")).expect("valid")
    };
    let v2 = read("valid-per-leaf.svo");
    assert_eq!(read("valid-version-1.svo"), v2);
    assert_eq!(read("valid-chunked.svo"), v2);
    assert_eq!(read("valid-chunked-leaf-parents.svo"), v2);
    assert_eq!(read("valid-chunked-level-0.svo"), read("valid-bake.svo"));
    assert_eq!(read("valid-chunked-empty.svo"), read("valid-empty.svo"));
    assert_eq!(
        read("valid-chunked-depth-30.svo"),
        read("valid-depth-30.svo")
    );
    assert_eq!(read("valid-levels-no-node-channels.svo"), v2);
    // Values on a level: the same geometry as the tree's DAG file, each leaf its ancestor's
    // values.
    let (on_level, _) = read("valid-dag-values-level.svo");
    assert_eq!(on_level.nodes, read("valid-dag-bake.svo").0.nodes);
    assert!(on_level.attributes.normal.is_per_leaf());
    assert_eq!(read("valid-levels-empty.svo"), read("valid-empty.svo"));
    assert_eq!(
        read("valid-levels-depth-30.svo"),
        read("valid-depth-30.svo")
    );
    // With inner-node channels: the same shape and leaves (the nodes kept level by level).
    let (levels, _) = read("valid-levels.svo");
    assert_same_shape(&levels, &v2.0);
    assert!(levels.node_attributes.normal.is_per_leaf());
    let (bake, _) = read("valid-levels-bake.svo");
    assert_same_shape(&bake, &read("valid-bake.svo").0);
}

/// The same leaves in the same cells, the same channels and as many nodes, whatever the
/// nodes' order.
fn assert_same_shape(a: &svo::Octree, b: &svo::Octree) {
    assert_eq!(a.attributes, b.attributes);
    assert!(svo_tests::node_order::same_shape(a, b));
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![
        trial!(committed_corpus_is_what_the_generator_makes),
        trial!(the_reader_accepts_exactly_the_valid_files_and_names_each_failed_check),
        trial!(the_version_1_3_and_4_files_hold_the_same_trees_as_their_version_2_twins),
    ]
}
