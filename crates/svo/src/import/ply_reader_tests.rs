//! The PLY importer reads elements into its own small types; these tests hold it to what the
//! straightforward reading through the crate's `DefaultElement` (a map per vertex and face)
//! gives, on `bun_zipper.ply` and on seeded random ASCII and binary files with extra
//! properties, other elements, both index list names, odd types and broken data, and on
//! ASCII files whose data bytes are mutated into what the crate's line grammar may or may not
//! accept. The ASCII fast path (`ply_ascii`, which declines what it does not take) is
//! checked to be the one that read most of the clean ASCII files.

use crate::import::ply::ply_from_bytes;
use glam::DVec3;
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(svo_tests::seeds::seed(seed))
}

/// The reference: the whole file through `DefaultElement`, then the same mapping as the
/// importer (`x`, `y`, `z` of any scalar type; `vertex_indices`, else `vertex_index`), written
/// out here on purpose rather than shared, as the crate alone reads them.
fn reference(bytes: &[u8]) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), String> {
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut std::io::Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let scalar = |p: &Property| -> Option<f64> {
        Some(match *p {
            Property::Char(v) => f64::from(v),
            Property::UChar(v) => f64::from(v),
            Property::Short(v) => f64::from(v),
            Property::UShort(v) => f64::from(v),
            Property::Int(v) => f64::from(v),
            Property::UInt(v) => f64::from(v),
            Property::Float(v) => f64::from(v),
            Property::Double(v) => v,
            _ => return None,
        })
    };
    let list = |p: &Property| -> Option<Vec<i64>> {
        Some(match p {
            Property::ListChar(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListUChar(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListShort(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListUShort(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListInt(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Property::ListUInt(v) => v.iter().map(|&x| i64::from(x)).collect(),
            _ => return None,
        })
    };
    let vertices = ply.payload.get("vertex").ok_or("no vertex element")?;
    let mut pos = Vec::new();
    for v in vertices {
        let c = |k: &str| v.get(k).and_then(scalar);
        match (c("x"), c("y"), c("z")) {
            (Some(x), Some(y), Some(z)) => pos.push(DVec3::new(x, y, z)),
            _ => return Err("a vertex lacks x, y or z".into()),
        }
    }
    let mut tris = Vec::new();
    for face in ply.payload.get("face").into_iter().flatten() {
        let l = face
            .get("vertex_indices")
            .or_else(|| face.get("vertex_index"))
            .and_then(list)
            .ok_or("a face has no list")?;
        if l.iter().any(|&i| i < 0 || i as usize >= pos.len()) {
            return Err("an index out of range".into());
        }
        for k in 1..l.len().saturating_sub(1) {
            tris.push([l[0] as u32, l[k] as u32, l[k + 1] as u32]);
        }
    }
    Ok((pos, tris))
}

/// Whether the ASCII fast path takes the file (rather than declining to the crate).
fn fast_path_takes(bytes: &[u8]) -> bool {
    super::differential::ply_ascii_scan_takes(bytes)
}

/// The importer and the reference agree: the same mesh, or both refuse.
fn check(bytes: &[u8]) -> bool {
    let got = ply_from_bytes(bytes, Path::new("case.ply"));
    let want = reference(bytes);
    match (&got, &want) {
        (Ok(m), Ok((pos, tris))) => {
            let bits = |p: &[DVec3]| -> Vec<[u64; 3]> {
                p.iter()
                    .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                    .collect()
            };
            assert_eq!(bits(&m.positions), bits(pos));
            assert_eq!(&m.triangles, tris);
            true
        }
        (Err(_), Err(_)) => false,
        _ => panic!(
            "the importer gives {:?}, the reference {:?}:\n{}",
            got.map(|m| m.triangles.len()),
            want.map(|w| w.1.len()),
            String::from_utf8_lossy(bytes)
        ),
    }
}

/// A property type and how to write a value of it.
const SCALARS: [&str; 8] = [
    "char", "uchar", "short", "ushort", "int", "uint", "float", "double",
];

fn write_scalar(out: &mut Vec<u8>, ty: &str, v: f64, binary: bool) {
    if !binary {
        let text = match ty {
            "float" | "double" => format!("{v}"),
            _ => format!("{}", v as i64),
        };
        out.extend_from_slice(text.as_bytes());
        out.push(b' ');
        return;
    }
    match ty {
        "char" => out.extend_from_slice(&(v as i8).to_le_bytes()),
        "uchar" => out.extend_from_slice(&(v as u8).to_le_bytes()),
        "short" => out.extend_from_slice(&(v as i16).to_le_bytes()),
        "ushort" => out.extend_from_slice(&(v as u16).to_le_bytes()),
        "int" => out.extend_from_slice(&(v as i32).to_le_bytes()),
        "uint" => out.extend_from_slice(&(v as u32).to_le_bytes()),
        "float" => out.extend_from_slice(&(v as f32).to_le_bytes()),
        _ => out.extend_from_slice(&v.to_le_bytes()),
    }
}

/// A random PLY file, ASCII or binary at random (see [`random_ply_in`]).
fn random_ply(r: &mut ChaCha8Rng) -> Vec<u8> {
    let binary = r.random_bool(0.5);
    random_ply_in(r, binary)
}

/// A random PLY file in the encoding asked for: vertex properties (x, y, z among others,
/// some of odd types, lists, repeated names), possibly another element, faces under either
/// list name, and now and then a broken value or count.
fn random_ply_in(r: &mut ChaCha8Rng, binary: bool) -> Vec<u8> {
    let nv = r.random_range(1..12);
    let nf = r.random_range(0..10);
    // Vertex properties: (name, type, is a list).
    let mut props: Vec<(String, &str, bool)> = Vec::new();
    for name in ["x", "y", "z"] {
        let ty = if r.random_bool(0.7) {
            ["float", "double"][r.random_range(0..2)]
        } else {
            SCALARS[r.random_range(0..8)]
        };
        props.push((name.into(), ty, r.random_bool(0.02)));
    }
    for _ in 0..r.random_range(0..3) {
        let name = ["confidence", "intensity", "x", "red"][r.random_range(0..4)];
        props.insert(
            r.random_range(0..=props.len()),
            (
                name.into(),
                SCALARS[r.random_range(0..8)],
                r.random_bool(0.2),
            ),
        );
    }
    // One or two index lists on a face, under these names.
    let mut face_names = vec!["vertex_indices", "vertex_index", "indices"];
    face_names.swap(0, [0, 0, 0, 0, 0, 1, 1, 2][r.random_range(0..8)]);
    face_names.truncate(if r.random_bool(0.3) { 2 } else { 1 });
    let index_type = ["uchar", "int", "uint", "short", "float"][r.random_range(0..5)];
    let other = r.random_bool(0.3);
    let mut h = format!(
        "ply\nformat {} 1.0\ncomment random\nelement vertex {nv}\n",
        if binary {
            "binary_little_endian"
        } else {
            "ascii"
        }
    );
    for (name, ty, list) in &props {
        if *list {
            h.push_str(&format!("property list uchar {ty} {name}\n"));
        } else {
            h.push_str(&format!("property {ty} {name}\n"));
        }
    }
    if other {
        h.push_str("element edge 2\nproperty int vertex1\nproperty int vertex2\n");
    }
    h.push_str(&format!("element face {nf}\n"));
    for name in &face_names {
        h.push_str(&format!("property list uchar {index_type} {name}\n"));
    }
    h.push_str("end_header\n");
    let mut out = h.into_bytes();
    for _ in 0..nv {
        for (_, ty, list) in &props {
            if *list {
                write_scalar(&mut out, "uchar", 2.0, binary);
                for _ in 0..2 {
                    write_scalar(&mut out, ty, r.random_range(0.0..100.0), binary);
                }
            } else {
                write_scalar(&mut out, ty, r.random_range(-1.0..100.0), binary);
            }
        }
        if !binary {
            out.push(b'\n');
        }
    }
    if other {
        for _ in 0..2 {
            for _ in 0..2 {
                write_scalar(&mut out, "int", r.random_range(0.0..5.0), binary);
            }
            if !binary {
                out.push(b'\n');
            }
        }
    }
    for _ in 0..nf {
        for _ in &face_names {
            let n = r.random_range(0..6);
            write_scalar(&mut out, "uchar", f64::from(n), binary);
            for _ in 0..n {
                let i = if r.random_bool(0.05) {
                    r.random_range(-2.0..f64::from(nv) + 3.0)
                } else {
                    f64::from(r.random_range(0..nv))
                };
                write_scalar(&mut out, index_type, i, binary);
            }
        }
        if !binary {
            out.push(b'\n');
        }
    }
    if r.random_bool(0.1) {
        // Cut short.
        let keep = r.random_range(0..out.len());
        out.truncate(keep);
    }
    out
}

#[test]
fn random_files_read_the_same() {
    let mut r = rng(0x91_7e57);
    let mut read = 0;
    for _ in 0..1500 {
        read += usize::from(check(&random_ply(&mut r)));
    }
    // Most files are valid meshes: the agreement covers read meshes, not only errors.
    assert!(read > 500, "only {read} files read");
}

#[test]
fn the_fuzz_seed_takes_the_fast_path() {
    // Tabs, CRLF, signs, exponents, a list among the vertex properties, a short face and a
    // last line without a line break: all within the grammar.
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/fuzz/mesh_import/seed-ply-ascii");
    let bytes = std::fs::read(path).unwrap();
    assert!(check(&bytes[1..]));
    assert!(fast_path_takes(&bytes[1..]));
}

#[test]
fn the_fast_path_reads_most_clean_ascii_files() {
    let mut r = rng(0xa5c1_1e57);
    let (mut read, mut fast) = (0, 0);
    for _ in 0..1000 {
        let bytes = random_ply_in(&mut r, false);
        if check(&bytes) {
            read += 1;
            fast += usize::from(fast_path_takes(&bytes));
        }
    }
    // It declines only for other elements, list positions and the like.
    assert!(read > 300 && fast * 2 > read, "{fast} of {read} read files");
}

/// ASCII files whose data bytes are mutated into separators, line breaks, signs, points,
/// exponents, digits and letters: lines that the crate's grammar accepts or rejects by a
/// character. The importer must agree with the reference on every one.
#[test]
fn mutated_ascii_data_reads_the_same() {
    const BYTES: &[u8] = b"  \t\t\r\r\n\n--++..eeEE0123456789ax\x00\xc3";
    let mut r = rng(0x3a7e_d00d);
    let (mut read, mut fast) = (0, 0);
    for _ in 0..3000 {
        let mut bytes = random_ply_in(&mut r, false);
        let Some(start) = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .map(|i| i + 11)
        else {
            continue;
        };
        if start < bytes.len() {
            for _ in 0..r.random_range(1..4) {
                let at = r.random_range(start..bytes.len());
                let b = BYTES[r.random_range(0..BYTES.len())];
                match r.random_range(0..3) {
                    0 => bytes[at] = b,
                    1 => bytes.insert(at, b),
                    _ => {
                        bytes.remove(at);
                    }
                }
                if bytes.len() <= start {
                    break;
                }
            }
        }
        if check(&bytes) {
            read += 1;
            fast += usize::from(fast_path_takes(&bytes));
        }
    }
    // Many mutations leave a valid file (a digit for a digit, a space doubled).
    assert!(read > 300 && fast > 100, "{fast} fast of {read} read files");
}

/// Long files: element lengths at and around powers of two, CRLF and LF lines, a last line
/// without a line break, and now and then one bad token near the end (the file must then
/// fail, not read without it).
#[test]
fn long_files_read_the_same() {
    let mut r = rng(0x9_1ece);
    for (nv, nf) in [
        (8191, 8192),
        (8192, 8193),
        (8193, 16384),
        (16385, 3),
        (24577, 24576),
    ] {
        for variant in 0..3 {
            let crlf = variant == 1;
            let eol = if crlf { "\r\n" } else { "\n" };
            let mut text = format!(
                "ply\nformat ascii 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\n\
                 property float z\nproperty uchar red\nelement face {nf}\n\
                 property list uchar int vertex_indices\nend_header\n"
            );
            for i in 0..nv {
                let v = f64::from(i as u32) * 0.001;
                text.push_str(&format!("{v} {} -{v} {}{eol}", v * 2.0, i % 256));
            }
            for f in 0..nf {
                let a = (f * 7) % nv;
                text.push_str(&format!("3 {a} {} {}{eol}", (a + 1) % nv, (a + 2) % nv));
            }
            if variant == 2 {
                // A bad token in the faces' last piece.
                let at = text.len() - 3 - r.random_range(0..40);
                text.insert(at, 'x');
            }
            // The last line without its line break.
            text.truncate(text.len() - eol.len());
            let bytes = text.into_bytes();
            let read = check(&bytes);
            assert_eq!(read, variant != 2, "nv {nv}, nf {nf}, variant {variant}");
            assert_eq!(
                fast_path_takes(&bytes),
                read,
                "nv {nv}, nf {nf}, variant {variant}"
            );
        }
    }
}
