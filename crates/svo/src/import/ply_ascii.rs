//! A fast reading of ASCII PLY payloads that gives exactly what `ply-rs-bw` gives, or
//! declines.
//!
//! `ply-rs-bw` matches every data line against a PEG grammar and collects its tokens before
//! parsing them: most of the 70 ms that `bun_zipper.ply` took to load. This reader scans the
//! bytes of the payload once, with the crate's own header (read by the crate) saying what
//! each token is, and parses each token with the same `str::parse` for the declared type
//! that the crate calls. It takes only the plain case: an ASCII payload of a `vertex` and a
//! `face` element, every line matching the crate's grammar, every token parsing, every
//! position numeric, every face list an integer list within the vertex range. Anything
//! else (another element, a line the grammar rejects, a missing token, an index out of
//! range) makes it decline, and the file is read by the crate, which gives the mesh or the
//! error it always gave. `ply_reader_tests.rs` holds the two equal on `bun_zipper.ply` and
//! on random clean and corrupted files.

use crate::mesh::triangle_mesh::Mesh;
use glam::DVec3;
use ply_rs_bw::ply::{ElementDef, Encoding, Header, PropertyType, ScalarType};

/// The mesh of an ASCII PLY whose header is `header` and whose payload starts at `data`,
/// or `None` where this reader declines (see the module docs).
pub(crate) fn read_ascii_mesh(header: &Header, data: &[u8]) -> Option<Mesh> {
    if header.encoding != Encoding::Ascii {
        return None;
    }
    let mut lines = Lines::new(data);
    let (mut positions, mut lists) = (None, None);
    for (name, def) in &header.elements {
        match name.as_str() {
            "vertex" => positions = Some(vertices(def, &mut lines)?),
            "face" => lists = Some(faces(def, &mut lines)?),
            _ => return None,
        }
    }
    let positions = positions?;
    let (indices, counts) = lists.unwrap_or_default();
    let nv = positions.len() as u64;
    if indices.iter().any(|&i| u64::from(i) >= nv) {
        return None;
    }
    let mut mesh = Mesh {
        positions,
        ..Mesh::default()
    };
    let mut at = 0;
    for n in counts {
        let face = &indices[at..at + n];
        at += n;
        for k in 1..n.saturating_sub(1) {
            mesh.triangles.push([face[0], face[k], face[k + 1]]);
        }
    }
    Some(mesh)
}

/// The vertex element: `x`, `y` and `z` as the importer widens them (the last of a repeated
/// name wins, as in the crate's reading); declines where one is missing or is a list.
fn vertices(def: &ElementDef, lines: &mut Lines<'_>) -> Option<Vec<DVec3>> {
    let mut out = Vec::with_capacity(def.count.min(lines.rest.len() / 2));
    for _ in 0..def.count {
        let mut tokens = lines.next()?;
        let mut xyz = [None; 3];
        for (name, p) in &def.properties {
            let axis = match name.as_str() {
                "x" => Some(0),
                "y" => Some(1),
                "z" => Some(2),
                _ => None,
            };
            match &p.data_type {
                PropertyType::Scalar(t) => {
                    let v = scalar(t, tokens.next()?)?;
                    if let Some(a) = axis {
                        xyz[a] = Some(v);
                    }
                }
                PropertyType::List(_, t) => {
                    if axis.is_some() {
                        return None;
                    }
                    skip_list(t, &mut tokens)?;
                }
            }
        }
        out.push(DVec3::new(xyz[0]?, xyz[1]?, xyz[2]?));
    }
    Some(out)
}

/// The face element: each face's index list (`vertex_indices`, else `vertex_index`; the
/// last of a repeated name wins) appended to one buffer, with its length; declines where a
/// face has no integer list of either name or an index is negative.
fn faces(def: &ElementDef, lines: &mut Lines<'_>) -> Option<(Vec<u32>, Vec<usize>)> {
    let (mut indices, mut counts) = (Vec::new(), Vec::new());
    let mut other = Vec::new();
    for _ in 0..def.count {
        let mut tokens = lines.next()?;
        let start = indices.len();
        let (mut named, mut fallback) = (false, false);
        other.clear();
        for (name, p) in &def.properties {
            let wanted = match name.as_str() {
                "vertex_indices" => 1,
                "vertex_index" => 2,
                _ => 0,
            };
            match &p.data_type {
                PropertyType::List(_, t) if wanted != 0 => {
                    // The list as the importer keeps it: integers (a float list is no index
                    // list, even an empty one), none negative.
                    if matches!(t, ScalarType::Float | ScalarType::Double) {
                        return None;
                    }
                    let n: usize = tokens.next()?.parse().ok()?;
                    let dst = if wanted == 1 {
                        indices.truncate(start);
                        named = true;
                        &mut indices
                    } else {
                        other.clear();
                        fallback = true;
                        &mut other
                    };
                    for _ in 0..n {
                        let v = integer(t, tokens.next()?)?;
                        dst.push(u32::try_from(v).ok()?);
                    }
                }
                PropertyType::Scalar(_) if wanted != 0 => return None,
                PropertyType::Scalar(t) => {
                    scalar(t, tokens.next()?)?;
                }
                PropertyType::List(_, t) => skip_list(t, &mut tokens)?,
            }
        }
        if !named {
            if !fallback {
                return None;
            }
            indices.extend_from_slice(&other);
        }
        counts.push(indices.len() - start);
    }
    Some((indices, counts))
}

/// Parses and drops a list (its count as `usize`, as the crate reads every list count).
fn skip_list(t: &ScalarType, tokens: &mut std::slice::Iter<'_, &str>) -> Option<()> {
    let n: usize = tokens.next()?.parse().ok()?;
    for _ in 0..n {
        scalar(t, tokens.next()?)?;
    }
    Some(())
}

/// A token parsed as the declared scalar type, widened to `f64` (as the importer widens it).
fn scalar(t: &ScalarType, s: &str) -> Option<f64> {
    Some(match t {
        ScalarType::Float => f64::from(s.parse::<f32>().ok()?),
        ScalarType::Double => s.parse::<f64>().ok()?,
        _ => integer(t, s)? as f64,
    })
}

/// A token parsed as the declared type, which must be an integer type (a float list is
/// not an index list).
fn integer(t: &ScalarType, s: &str) -> Option<i64> {
    Some(match t {
        ScalarType::Char => i64::from(s.parse::<i8>().ok()?),
        ScalarType::UChar => i64::from(s.parse::<u8>().ok()?),
        ScalarType::Short => i64::from(s.parse::<i16>().ok()?),
        ScalarType::UShort => i64::from(s.parse::<u16>().ok()?),
        ScalarType::Int => i64::from(s.parse::<i32>().ok()?),
        ScalarType::UInt => i64::from(s.parse::<u32>().ok()?),
        ScalarType::Float | ScalarType::Double => return None,
    })
}

/// The payload's lines as the crate reads them (`read_line`: up to and including `\n`, the
/// last one possibly without), each checked against the crate's data-line grammar in the
/// same pass that finds its tokens.
struct Lines<'a> {
    /// What is left of the payload's valid UTF-8 prefix.
    rest: &'a str,
    /// Whether that prefix is the whole payload (where it is not, a line that runs into its
    /// end is one that `read_line` would have refused).
    complete: bool,
    /// The current line's tokens.
    tokens: Vec<&'a str>,
}

impl<'a> Lines<'a> {
    fn new(data: &'a [u8]) -> Self {
        let (rest, complete) = match std::str::from_utf8(data) {
            Ok(s) => (s, true),
            Err(e) => (
                std::str::from_utf8(&data[..e.valid_up_to()]).unwrap_or_default(),
                false,
            ),
        };
        Self {
            rest,
            complete,
            tokens: Vec::new(),
        }
    }

    /// The next line's tokens, or `None` at the end of the data or where the line is not
    /// what the grammar accepts: separators (spaces, tabs) and numbers, then one line break
    /// (`\r\n`, `\n`, or `\r` at the end of the data).
    fn next(&mut self) -> Option<std::slice::Iter<'_, &'a str>> {
        let text = self.rest;
        let b = text.as_bytes();
        if b.is_empty() {
            return None;
        }
        self.tokens.clear();
        let mut i = 0;
        let end = loop {
            while i < b.len() && matches!(b[i], b' ' | b'\t') {
                i += 1;
            }
            match b.get(i) {
                None if self.complete => break i,
                None => return None,
                Some(b'\n') => break i + 1,
                Some(b'\r') => match b.get(i + 1) {
                    Some(b'\n') => break i + 2,
                    None if self.complete => break i + 1,
                    _ => return None,
                },
                Some(_) => {
                    let start = i;
                    i = number_end(b, i)?;
                    if !matches!(b.get(i), None | Some(b' ' | b'\t' | b'\n' | b'\r')) {
                        return None;
                    }
                    self.tokens.push(&text[start..i]);
                }
            }
        };
        self.rest = &text[end..];
        Some(self.tokens.iter())
    }
}

/// Where a number as the crate's grammar writes one (`[-+]? [0-9]+ ('.' [0-9]+)?
/// ([eE] [-+]? [0-9]+)?`) that starts at `i` ends, or `None` where none starts there.
fn number_end(b: &[u8], mut i: usize) -> Option<usize> {
    let digits = |i: usize| b[i..].iter().take_while(|c| c.is_ascii_digit()).count();
    i += usize::from(matches!(b.get(i), Some(b'-' | b'+')));
    let n = digits(i);
    if n == 0 {
        return None;
    }
    i += n;
    if b.get(i) == Some(&b'.') {
        let n = digits(i + 1);
        if n == 0 {
            return None;
        }
        i += 1 + n;
    }
    if matches!(b.get(i), Some(b'e' | b'E')) {
        i += 1;
        i += usize::from(matches!(b.get(i), Some(b'-' | b'+')));
        let n = digits(i);
        if n == 0 {
            return None;
        }
        i += n;
    }
    Some(i)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn whole_number(t: &str) -> bool {
        number_end(t.as_bytes(), 0) == Some(t.len())
    }

    #[test]
    fn numbers_as_the_grammar_writes_them() {
        for ok in [
            "0", "-1", "+7", "12.5", "-0.25", "1e5", "1E-5", "2.5e+10", "007",
        ] {
            assert!(whole_number(ok), "{ok}");
        }
        for bad in [
            "", "-", "+", ".5", "5.", "1e", "1e+", "1.e5", "--1", "1.5.5", "nan", "inf", "0x10",
            "1,5", "1-2", "e5",
        ] {
            assert!(!whole_number(bad), "{bad}");
        }
    }

    #[test]
    fn lines_end_as_read_line_and_the_grammar_end_them() {
        let tokens = |data: &[u8]| -> Vec<Option<Vec<String>>> {
            let mut l = Lines::new(data);
            (0..8)
                .map(|_| l.next().map(|t| t.map(ToString::to_string).collect()))
                .collect()
        };
        let some = |v: &[&str]| Some(v.iter().map(ToString::to_string).collect::<Vec<_>>());
        let got = tokens(b"1 2\n \t3\t4 \r\n\n5\r");
        assert_eq!(
            got[..4],
            [
                some(&["1", "2"]),
                some(&["3", "4"]),
                some(&[]),
                some(&["5"])
            ]
        );
        assert_eq!(got[4], None);
        // Two carriage returns (the grammar takes one line break), a carriage return inside
        // a line, a number run into a letter, a point without digits.
        for bad in [&b"5\r\r\n"[..], b"6\r7\n", b"1 2x\n", b"1 .5\n", b"3.\n"] {
            assert_eq!(tokens(bad)[0], None, "{:?}", String::from_utf8_lossy(bad));
        }
        // A last line without a line break, and one that runs into bytes that are not UTF-8
        // (which `read_line` refuses).
        assert_eq!(tokens(b"7 8")[0], some(&["7", "8"]));
        assert_eq!(tokens(b"7 8 \xff\n")[0], None);
        assert_eq!(tokens(b"7 8\n\xff")[0], some(&["7", "8"]));
    }
}
