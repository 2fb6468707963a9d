//! A fast reader for geometry-only OBJ files: the common case of scanned meshes (the Stanford
//! bunny and dragon), which are nothing but `v` and `f` lines.
//!
//! tobj reads such a file at about 55 MB/s here (the 33 MB dragon in 0.6 s, more than its
//! whole depth-10 voxelization): it allocates a `String` per line and remaps every face
//! index of a model through a hash map. This reader walks the bytes with a cursor, in pieces
//! on all threads, parses coordinates with the standard library's parser (as tobj does) and
//! face indices to exactly what it gives, and renumbers positions through a plain array.
//!
//! It gives exactly the [`Mesh`] that the tobj path gives (the same positions in the same
//! order, the same triangles), or nothing: a file with anything it does not mirror to the
//! letter (materials, `l` lines, a `v` line with a weight or a colour, a face index out of
//! range or pointing ahead, a texture or normal index it cannot check, non-ASCII bytes, any
//! token tobj would reject) makes it return `None`, and the caller hands the file to tobj,
//! which then reads it or reports the error. `obj_reader_tests.rs` checks the agreement on
//! the shared meshes and on seeded random files.
//!
//! What tobj does that this mirrors: positions per model (a model ends at an `o` or `g` line
//! that follows a face) in the order the model's triangles first use them, faces of 1 or 2
//! vertices skipped, polygons split into a fan from their first vertex, negative indices
//! relative to the vertices read so far, every other line kind ignored.

use crate::mesh::triangle_mesh::{Material, Mesh};
use glam::DVec3;
use std::str::FromStr;

/// The ASCII bytes that `char::is_whitespace` accepts (tobj splits lines with
/// `str::split_whitespace`, which includes the vertical tab that `u8::is_ascii_whitespace`
/// leaves out).
#[inline]
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | 0x0B | 0x0C | b'\r')
}

/// Whitespace-separated tokens, line by line, read from a cursor (the text is ASCII, so
/// every byte offset is a character boundary).
struct Tokens<'a> {
    s: &'a str,
    i: usize,
}

impl<'a> Tokens<'a> {
    /// The next token of the current line, if it has one more.
    #[inline]
    fn next(&mut self) -> Option<&'a str> {
        let b = self.s.as_bytes();
        let mut i = self.i;
        while i < b.len() && b[i] != b'\n' && is_space(b[i]) {
            i += 1;
        }
        let start = i;
        while i < b.len() && !is_space(b[i]) {
            i += 1;
        }
        self.i = i;
        (i > start).then(|| &self.s[start..i])
    }

    /// Moves to the start of the next line; `false` at the end of the text.
    #[inline]
    fn next_line(&mut self) -> bool {
        match self.s.as_bytes()[self.i..].iter().position(|&c| c == b'\n') {
            Some(p) => {
                self.i += p + 1;
                true
            }
            None => false,
        }
    }
}

/// A token parsed as tobj parses it.
#[inline]
fn number<T: FromStr>(t: &str) -> Option<T> {
    t.parse().ok()
}

/// Resolves an OBJ index as tobj does (1-based, or negative from the end of the `count`
/// elements read so far) and accepts it only if it names one of those elements.
#[inline]
fn resolve(x: isize, count: usize) -> Option<usize> {
    let r = if x < 0 {
        count.checked_add_signed(x)?
    } else {
        (x as usize).checked_sub(1)?
    };
    (r < count).then_some(r)
}

/// Counts of the elements read so far, for relative indices and checks.
#[derive(Clone, Copy, Default)]
struct Counts {
    v: usize,
    vt: usize,
    vn: usize,
}

impl Counts {
    fn add(self, o: Counts) -> Counts {
        Counts {
            v: self.v + o.v,
            vt: self.vt + o.vt,
            vn: self.vn + o.vn,
        }
    }
}

/// An index token parsed as `isize::from_str` parses it (an optional sign, then decimal
/// digits, no overflow), without its generic machinery: face indices are most of a mesh file
/// (the 33 MB dragon: 212 against 270 ms through `str::parse` on one thread, 130 against
/// 160 ms on two; medians of 9, alternating builds).
#[inline]
fn index(t: &[u8]) -> Option<isize> {
    let (neg, digits) = match t.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, t),
    };
    if digits.is_empty() {
        return None;
    }
    let mut v: isize = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        let d = isize::from(d - b'0');
        v = v.checked_mul(10)?;
        v = if neg {
            v.checked_sub(d)?
        } else {
            v.checked_add(d)?
        };
    }
    Some(v)
}

/// The position index of one face vertex (`v`, `v/vt`, `v//vn` or `v/vt/vn`), or `None` for
/// a token tobj rejects or one whose indices this reader cannot vouch for. `checked`: the
/// face is exported (three or more vertices), so its indices must be valid; otherwise only
/// the syntax matters.
fn face_vertex(t: &str, counts: &Counts, checked: bool) -> Option<usize> {
    let t = t.as_bytes();
    let mut v = None;
    let (mut part, mut start) = (0, 0);
    for end in (0..=t.len()).filter(|&i| i == t.len() || t[i] == b'/') {
        if part == 3 {
            return None; // more than three parts: tobj rejects the face
        }
        let text = &t[start..end];
        if !text.is_empty() {
            let x = index(text)?;
            if checked {
                // A texture or normal index is checked by tobj against the final lists,
                // and only if the file has any; here it must name one read already.
                let count = [counts.v, counts.vt, counts.vn][part];
                let r = resolve(x, count)?;
                if part == 0 {
                    v = Some(r);
                }
            }
        }
        part += 1;
        start = end + 1;
    }
    if checked { v } else { Some(0) }
}

/// The size of the pieces the file is parsed in, in parallel (each ends at a line end).
const CHUNK: usize = 1 << 18;

/// The file cut into pieces of about [`CHUNK`] bytes at line ends.
fn chunks(file: &str) -> Vec<&str> {
    let b = file.as_bytes();
    let mut out = Vec::with_capacity(b.len() / CHUNK + 1);
    let mut start = 0;
    while start < b.len() {
        let mut end = (start + CHUNK).min(b.len());
        while end < b.len() && b[end - 1] != b'\n' {
            end += 1;
        }
        out.push(&file[start..end]);
        start = end;
    }
    out
}

/// `f` over the pieces, in parallel with the `parallel` feature, results in order.
fn map_pieces<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        (0..n).into_par_iter().map(f).collect()
    }
    #[cfg(not(feature = "parallel"))]
    (0..n).map(f).collect()
}

/// The elements a piece defines (lines whose first token is `v`, `vt` or `vn`).
fn count(piece: &str) -> Counts {
    let mut c = Counts::default();
    let mut t = Tokens { s: piece, i: 0 };
    loop {
        match t.next() {
            Some("v") => c.v += 1,
            Some("vt") => c.vt += 1,
            Some("vn") => c.vn += 1,
            _ => {}
        }
        if !t.next_line() {
            return c;
        }
    }
}

/// What a piece holds: its positions, its triangles (fans of its faces, as indices into the
/// whole file's positions) and where its `o` and `g` lines fall in its triangle list.
#[derive(Default)]
struct Piece {
    pos: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
    groups: Vec<usize>,
}

/// Parses one piece, given the counts of the elements before it.
fn parse_piece(piece: &str, mut counts: Counts) -> Option<Piece> {
    let mut out = Piece::default();
    let mut face: Vec<u32> = Vec::new();
    let mut words_of_face: Vec<&str> = Vec::new();
    let mut words = Tokens { s: piece, i: 0 };
    loop {
        match words.next().unwrap_or_default() {
            "v" => {
                let x = number(words.next()?)?;
                let y = number(words.next()?)?;
                let z = number(words.next()?)?;
                if words.next().is_some() {
                    return None; // a weight or a colour
                }
                out.pos.push(DVec3::new(x, y, z));
                counts.v += 1;
            }
            // tobj needs the first 2 (3) values to be numbers and ignores the rest.
            "vt" => {
                for _ in 0..2 {
                    number::<f64>(words.next()?)?;
                }
                counts.vt += 1;
            }
            "vn" => {
                for _ in 0..3 {
                    number::<f64>(words.next()?)?;
                }
                counts.vn += 1;
            }
            "f" => {
                words_of_face.clear();
                while let Some(w) = words.next() {
                    words_of_face.push(w);
                }
                if words_of_face.is_empty() {
                    return None; // tobj: an invalid polygon
                }
                let checked = words_of_face.len() >= 3;
                face.clear();
                for w in &words_of_face {
                    face.push(u32::try_from(face_vertex(w, &counts, checked)?).ok()?);
                }
                // A face of 1 or 2 vertices is skipped (a point or a line). tobj counts it as
                // a face of the model, so that a group line after it starts a new model, but
                // a model with no triangles has used no positions: that changes nothing here.
                if checked {
                    for i in 1..face.len() - 1 {
                        out.tris.push([face[0], face[i], face[i + 1]]);
                    }
                }
            }
            "o" | "g" => out.groups.push(out.tris.len()),
            "l" | "mtllib" | "usemtl" => return None,
            _ => {}
        }
        if !words.next_line() {
            return Some(out);
        }
    }
}

/// Parses a geometry-only OBJ, or returns `None` for anything it does not mirror exactly
/// (see the module docs). The file is parsed in pieces in parallel (a first pass counts
/// each piece's vertices, so that the second knows where its relative indices point); the
/// positions are then renumbered per model in the order of first use, as tobj numbers them.
pub(crate) fn parse(bytes: &[u8]) -> Option<Mesh> {
    if !bytes.is_ascii() {
        return None;
    }
    let file = std::str::from_utf8(bytes).ok()?;
    let pieces = chunks(file);
    let counts = map_pieces(pieces.len(), |i| count(pieces[i]));
    let before: Vec<Counts> = counts
        .iter()
        .scan(Counts::default(), |run, &c| {
            let b = *run;
            *run = run.add(c);
            Some(b)
        })
        .collect();
    let parsed = map_pieces(pieces.len(), |i| parse_piece(pieces[i], before[i]));
    let parsed: Vec<Piece> = parsed.into_iter().collect::<Option<_>>()?;
    let pos: Vec<DVec3> = parsed.iter().flat_map(|p| p.pos.iter().copied()).collect();

    // Per model: the output index of each position it has used (u32::MAX: not yet), and
    // the positions it set, to clear at its end. (tobj ends a model at an `o` or `g` line
    // that follows a face; after a model that used no positions, there is nothing to clear.)
    let mut mesh = Mesh::default();
    let triangles: usize = parsed.iter().map(|p| p.tris.len()).sum();
    mesh.triangles.reserve(triangles);
    let mut map = vec![u32::MAX; pos.len()];
    let mut touched: Vec<u32> = Vec::new();
    for piece in &parsed {
        let mut done = 0;
        // The group lines, then the end of the piece (which ends no model).
        let ends = piece.groups.iter().map(|&at| (at, true));
        for (at, group) in ends.chain(std::iter::once((piece.tris.len(), false))) {
            for t in &piece.tris[done..at] {
                let mut tri = [0u32; 3];
                for (slot, &g) in tri.iter_mut().zip(t) {
                    let m = &mut map[g as usize];
                    if *m == u32::MAX {
                        *m = u32::try_from(mesh.positions.len()).ok()?;
                        mesh.positions.push(pos[g as usize]);
                        touched.push(g);
                    }
                    *slot = *m;
                }
                mesh.triangles.push(tri);
            }
            done = at;
            if group {
                for g in touched.drain(..) {
                    map[g as usize] = u32::MAX;
                }
            }
        }
    }
    mesh.materials.push(Material::default());
    mesh.triangle_materials = vec![0; mesh.triangles.len()];
    Some(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indices_resolve_like_tobj() {
        assert_eq!(resolve(1, 3), Some(0));
        assert_eq!(resolve(3, 3), Some(2));
        assert_eq!(resolve(4, 3), None);
        assert_eq!(resolve(0, 3), None);
        assert_eq!(resolve(-1, 3), Some(2));
        assert_eq!(resolve(-3, 3), Some(0));
        assert_eq!(resolve(-4, 3), None);
        assert_eq!(resolve(isize::MIN, 3), None);
    }

    #[test]
    fn indices_parse_like_the_standard_library() {
        for t in [
            "0",
            "1",
            "-1",
            "+7",
            "-0",
            "12345678901234567890",
            "9223372036854775807",
            "-9223372036854775808",
            "9223372036854775808",
            "",
            "-",
            "+",
            "1a",
            " 1",
            "--1",
            "+-1",
            "\u{660}",
        ] {
            assert_eq!(index(t.as_bytes()), t.parse::<isize>().ok(), "{t:?}");
        }
    }

    #[test]
    fn face_vertices() {
        let c = Counts { v: 5, vt: 2, vn: 0 };
        assert_eq!(face_vertex("3", &c, true), Some(2));
        assert_eq!(face_vertex("-1/2", &c, true), Some(4));
        assert_eq!(face_vertex("3/3", &c, true), None);
        assert_eq!(face_vertex("3//1", &c, true), None);
        assert_eq!(face_vertex("//", &c, true), None);
        assert_eq!(face_vertex("1/1/1/1", &c, true), None);
        assert_eq!(face_vertex("x", &c, false), None);
        assert_eq!(face_vertex("9", &c, false), Some(0));
    }
}
