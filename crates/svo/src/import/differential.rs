//! Our readers against the crates they stand in for, on any bytes: where our OBJ reader
//! takes a file, tobj must give the same mesh, and the PLY importer (our scan of plain ASCII
//! payloads) must give what ply-rs-bw alone gives. The checks panic on a difference. The
//! `mesh_import` fuzz target runs them (built with `--cfg fuzzing`, which makes this module
//! public as `svo::fuzz_import`), and the tests below run them on every input the fuzzer
//! kept (`fixtures/fuzz/mesh_import`).

use crate::mesh::Mesh;
use std::path::Path;

/// A mesh's positions as bit patterns, to compare two readings exactly.
fn position_bits(m: &Mesh) -> Vec<[u64; 3]> {
    m.positions
        .iter()
        .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .collect()
}

/// Our geometry-only OBJ reader stands in for tobj: on a file it takes, tobj must give the
/// same mesh (positions to the bit, in the same order; the same triangles and materials).
/// Returns whether our reader took the file.
#[cfg(feature = "obj")]
pub fn same_as_tobj(bytes: &[u8]) -> bool {
    let Some(fast) = super::obj_geometry::parse(bytes) else {
        return false;
    };
    let reference = super::obj::obj_from_bytes_tobj(bytes, Path::new("fuzz"))
        .expect("tobj reads what our reader takes");
    assert_eq!(
        position_bits(&fast),
        position_bits(&reference),
        "positions differ from tobj's"
    );
    assert_eq!(fast.triangles, reference.triangles, "triangles differ");
    assert_eq!(fast.triangle_materials, reference.triangle_materials);
    true
}

/// The PLY importer (which reads plain ASCII payloads by its own scan) and `ply-rs-bw` alone
/// give the same mesh, or both an error.
#[cfg(feature = "ply")]
pub fn same_as_ply_crate(bytes: &[u8]) {
    use super::ply::{ply_from_bytes, ply_from_bytes_crate};
    let got = ply_from_bytes(bytes, Path::new("fuzz"));
    let want = ply_from_bytes_crate(bytes, Path::new("fuzz"));
    match (got, want) {
        (Ok(a), Ok(b)) => {
            assert_eq!(
                position_bits(&a),
                position_bits(&b),
                "positions differ from ply-rs-bw's"
            );
            assert_eq!(a.triangles, b.triangles, "triangles differ");
        }
        (Err(_), Err(_)) => {}
        (a, b) => panic!(
            "the importer gives {:?}, ply-rs-bw alone {:?}",
            a.map(|m| m.triangles.len()),
            b.map(|m| m.triangles.len())
        ),
    }
}

/// Whether the PLY importer's own scan of plain ASCII payloads reads `bytes` (rather than
/// handing them to `ply-rs-bw`).
#[cfg(feature = "ply")]
pub fn ply_ascii_scan_takes(bytes: &[u8]) -> bool {
    use ply_rs_bw::parser::{Parser, Reader};
    use ply_rs_bw::ply::DefaultElement;
    let mut cursor = std::io::Cursor::new(bytes);
    let mut reader = Reader::new(&mut cursor);
    let Ok(header) = Parser::<DefaultElement>::new().read_header(&mut reader) else {
        return false;
    };
    let at = usize::try_from(reader.get_ref().position()).unwrap_or(usize::MAX);
    bytes
        .get(at..)
        .and_then(|rest| super::ply_ascii::read_ascii_mesh(&header, rest))
        .is_some()
}

#[cfg(test)]
mod tests {
    /// The kept inputs of the `mesh_import` target whose first byte picks `which` (0 OBJ,
    /// 2 PLY, as the target reads it), without that byte.
    fn kept(which: u8) -> Vec<Vec<u8>> {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../fixtures/fuzz/mesh_import");
        let mut out = Vec::new();
        for e in std::fs::read_dir(&dir).unwrap() {
            let data = std::fs::read(e.unwrap().path()).unwrap();
            if let Some((&first, bytes)) = data.split_first()
                && first % 4 == which
            {
                out.push(bytes.to_vec());
            }
        }
        out
    }

    #[cfg(feature = "obj")]
    #[test]
    fn kept_obj_inputs_read_as_tobj_reads_them() {
        let inputs = kept(0);
        assert!(!inputs.is_empty());
        for bytes in &inputs {
            super::same_as_tobj(bytes);
        }
    }

    #[cfg(feature = "ply")]
    #[test]
    fn kept_ply_inputs_read_as_the_crate_reads_them() {
        let inputs = kept(2);
        assert!(!inputs.is_empty());
        for bytes in &inputs {
            super::same_as_ply_crate(bytes);
        }
    }
}
