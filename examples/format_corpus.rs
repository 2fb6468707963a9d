//! Writes the `.svo` conformance corpus and its manifest to `fixtures/format/conformance/`
//! (or the folder given): `cargo run -p svo-examples --example format_corpus`.
//! The test `format_conformance` (`tests/tests/it/`) checks that the committed files are
//! what this writes.

use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let dir = std::env::args_os().nth(1).map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/format/conformance"),
        PathBuf::from,
    );
    std::fs::create_dir_all(&dir)?;
    for old in std::fs::read_dir(&dir)? {
        let old = old?.path();
        if old.extension().is_some_and(|e| e == "svo") {
            std::fs::remove_file(old)?;
        }
    }
    let corpus = svo_tests::conformance::corpus();
    for e in &corpus {
        std::fs::write(dir.join(&e.name), &e.bytes)?;
    }
    std::fs::write(
        dir.join("manifest.tsv"),
        svo_tests::conformance::manifest(&corpus),
    )?;
    println!("{} files in {}", corpus.len(), dir.display());
    Ok(())
}
