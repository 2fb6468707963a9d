//! The geometry-only OBJ reader (`obj_geometry.rs`) against tobj, the reader it
//! stands in for: on every file it accepts it must give exactly tobj's mesh (the same
//! positions in the same order, the same triangles and materials). Checked on the shared
//! meshes, on hand-made cases of every construct it handles, and on seeded random files
//! that mix valid and invalid lines.

use crate::import::obj::obj_from_bytes_tobj;
use crate::import::obj_geometry;
use crate::mesh::Mesh;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(svo_tests::seeds::seed(seed))
}

/// Whether two meshes are the same to the bit.
fn same(a: &Mesh, b: &Mesh) -> Result<(), String> {
    let bits = |m: &Mesh| -> Vec<[u64; 3]> {
        m.positions
            .iter()
            .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
            .collect()
    };
    if bits(a) != bits(b) {
        return Err(format!(
            "positions differ ({} and {})",
            a.positions.len(),
            b.positions.len()
        ));
    }
    if a.triangles != b.triangles {
        return Err(format!(
            "triangles differ ({} and {})",
            a.triangles.len(),
            b.triangles.len()
        ));
    }
    if a.triangle_materials != b.triangle_materials || a.materials != b.materials {
        return Err("materials differ".into());
    }
    if a.uvs != b.uvs || a.triangle_uvs != b.triangle_uvs || a.textures.len() != b.textures.len() {
        return Err("texture coordinates differ".into());
    }
    Ok(())
}

/// Checks the reader on `text`: where it gives a mesh, tobj must give the same one. Returns
/// whether the reader took the file.
fn check(text: &[u8]) -> bool {
    let Some(fast) = obj_geometry::parse(text) else {
        return false;
    };
    let reference = obj_from_bytes_tobj(text, Path::new("case.obj")).unwrap_or_else(|e| {
        panic!(
            "the reader took a file tobj rejects ({e}):\n{}",
            String::from_utf8_lossy(text)
        )
    });
    if let Err(why) = same(&fast, &reference) {
        panic!("{why}:\n{}", String::from_utf8_lossy(text));
    }
    true
}

#[test]
fn hand_made_cases() {
    // (file, whether the reader must take it)
    let cases: &[(&str, bool)] = &[
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", true),
        // Relative indices, a quad and a pentagon (fans), unused and reordered vertices.
        (
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 9 9 9\nf -3 -2 -4\nf 1 2 3 4\nf 5 4 3 2 1\n",
            true,
        ),
        // Texture and normal indices, checked against what was read.
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0 0\nvn 0 0 1\nf 1/1/1 2/2/1 3//1\nf 3/-1 2/-2 1\n",
            true,
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/2 2/1 3/1\n", false),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2 3\n", false),
        // Models: positions are numbered per model in the order of first use.
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1\no a\nf 3 2 1\ng b\nf 1 2 4\no\ng c\nf 4 3 1\n",
            true,
        ),
        // A group line before any face, and one after only skipped faces.
        (
            "g first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\no x\nf 1 2 3\nf 2 3 1\ng\nf 3\ng y\nf 3 1 2\n",
            true,
        ),
        // Whitespace: tabs, CR LF, vertical tab and form feed, leading blanks, blank lines.
        (
            " v\t0 0 0\r\nv 1\x0b0 0\r\n\r\n\x0cv 0 1 0\n\t f 1 2 3 \r\n",
            true,
        ),
        // Comments and lines tobj ignores.
        (
            "# header\nv 0 0 0\nv 1 0 0\nv 0 1 0\ns 1\nvp 0.5\np 1\ncstype bezier\n#f 9 9 9\nf 1 2 3\n",
            true,
        ),
        // Number forms that the standard parser reads (and so does tobj).
        (
            "v 1e2 -2.5E-3 +.5\nv 5. -0 inf\nv nan 1 2\nf 1 2 3\nf +1 +2 +3\n",
            true,
        ),
        // What the reader leaves to tobj.
        ("mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", false),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n", false),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n", false),
        ("v 0 0 0 2\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", false),
        ("v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", false),
        ("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", false),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", false),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", false),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n", false),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n", false),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n", false),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 # note\n", false),
        ("v 0 0 0 # note\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", false),
        ("v 0 0 x\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", false),
        ("# caf\u{e9}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", false),
        // Empty, and no faces: an empty mesh either way.
        ("", true),
        ("v 1 2 3\n", true),
    ];
    for (text, takes) in cases {
        assert_eq!(check(text.as_bytes()), *takes, "{text:?}");
    }
}

/// A random number token: mostly plain decimals, sometimes other forms the standard parser
/// takes or rejects.
fn number(r: &mut ChaCha8Rng, noisy: bool) -> String {
    if noisy && r.random_bool(0.03) {
        let odd = [
            "nan", "inf", "-inf", "1e", ".", "0x1", "1,5", "--1", "+.5", "5.", "1E+3", "",
        ];
        return odd[r.random_range(0..odd.len())].to_string();
    }
    let v: f64 = r.random_range(-10.0..10.0);
    match r.random_range(0..4) {
        0 => format!("{v}"),
        1 => format!("{v:.6}"),
        2 => format!("{v:e}"),
        _ => format!("{}", r.random_range(-5i32..5)),
    }
}

/// A random face vertex token for a file with `v`, `vt`, `vn` elements so far.
fn vertex(r: &mut ChaCha8Rng, counts: [usize; 3], noisy: bool) -> String {
    let index = |r: &mut ChaCha8Rng, n: usize| -> String {
        let n = n as i64;
        if noisy && r.random_bool(0.05) {
            let odd = ["0", "x", "", "-0", "99999999999999999999"];
            return odd[r.random_range(0..odd.len())].to_string();
        }
        if n == 0 || (noisy && r.random_bool(0.05)) {
            return r.random_range(-3i64..n + 3).to_string();
        }
        if r.random_bool(0.2) {
            (-r.random_range(1..=n)).to_string()
        } else {
            r.random_range(1..=n).to_string()
        }
    };
    let v = index(r, counts[0]);
    // A clean file names only elements it has.
    let parts = if noisy || (counts[1] > 0 && counts[2] > 0) {
        5
    } else {
        2
    };
    match r.random_range(0..parts) {
        0 | 1 => v,
        2 => format!("{v}/{}", index(r, counts[1])),
        3 => format!("{v}//{}", index(r, counts[2])),
        _ => format!("{v}/{}/{}", index(r, counts[1]), index(r, counts[2])),
    }
}

/// A random OBJ file; `noisy` ones hold lines tobj rejects or the reader declines.
fn random_file(r: &mut ChaCha8Rng, noisy: bool) -> String {
    let mut s = String::new();
    let mut counts = [0usize; 3];
    let spaces = [" ", "  ", "\t", " \t"];
    let ends = ["\n", "\r\n", " \n"];
    for _ in 0..r.random_range(0..60) {
        let sp = spaces[r.random_range(0..spaces.len())];
        let line = match r.random_range(0..100) {
            0..=34 => {
                counts[0] += 1;
                let extra = if noisy && r.random_bool(0.05) {
                    format!("{sp}{}", number(r, noisy))
                } else {
                    String::new()
                };
                format!(
                    "v{sp}{}{sp}{}{sp}{}{extra}",
                    number(r, noisy),
                    number(r, noisy),
                    number(r, noisy)
                )
            }
            35..=42 => {
                counts[1] += 1;
                format!("vt{sp}{}{sp}{}", number(r, noisy), number(r, noisy))
            }
            43..=48 => {
                counts[2] += 1;
                format!(
                    "vn{sp}{}{sp}{}{sp}{}",
                    number(r, noisy),
                    number(r, noisy),
                    number(r, noisy)
                )
            }
            49..=84 if noisy || counts[0] > 0 => {
                let n = if r.random_bool(0.1) {
                    r.random_range(if noisy { 0 } else { 1 }..3)
                } else {
                    r.random_range(3..7)
                };
                let mut f = String::from("f");
                for _ in 0..n {
                    f.push_str(sp);
                    f.push_str(&vertex(r, counts, noisy));
                }
                f
            }
            49..=89 => ["o part", "g part", "g", "o", "s 1"][r.random_range(0..5)].to_string(),
            90..=94 => "# a comment".to_string(),
            95..=96 => String::new(),
            _ if noisy => ["l 1 2", "usemtl m", "mtllib m.mtl", "p 1", "# caf\u{e9}"]
                [r.random_range(0..5)]
            .to_string(),
            _ => "vp 0.5".to_string(),
        };
        s.push_str(&line);
        s.push_str(ends[r.random_range(0..ends.len())]);
    }
    s
}

#[test]
fn random_files_read_the_same() {
    let mut r = rng(0x0b1_7e57);
    let (mut clean_taken, mut noisy_taken) = (0, 0);
    let runs = 3000;
    for i in 0..runs {
        let noisy = i % 2 == 1;
        let text = random_file(&mut r, noisy);
        let taken = check(text.as_bytes());
        if noisy {
            noisy_taken += usize::from(taken);
        } else {
            clean_taken += usize::from(taken);
        }
    }
    // The comparison means something only if the reader takes most clean files (those it
    // declines have texture or normal indices pointing ahead) and some noisy ones.
    assert!(
        clean_taken > runs / 2 * 6 / 10,
        "clean files taken: {clean_taken}"
    );
    assert!(
        noisy_taken > runs / 2 / 50,
        "noisy files taken: {noisy_taken}"
    );
}

#[test]
fn large_files_split_into_pieces_read_the_same() {
    // Long enough to be parsed in several pieces in parallel: relative indices, models and
    // skipped faces that cross the pieces' boundaries.
    let mut r = rng(0x51ce);
    let mut s = String::new();
    let mut n = 0i64;
    while s.len() < 3 << 20 {
        for _ in 0..r.random_range(1..6) {
            s.push_str(&format!(
                "v {} {} {}\n",
                r.random_range(-1.0..1.0f64),
                r.random_range(-1.0..1.0f64),
                r.random_range(-1.0..1.0f64)
            ));
            n += 1;
        }
        match r.random_range(0..20) {
            0 => s.push_str("o next\n"),
            1 => s.push_str(&format!("f {}\n", r.random_range(1..=n))),
            _ => {
                let k = r.random_range(3..6);
                s.push('f');
                for _ in 0..k {
                    if r.random_bool(0.3) {
                        s.push_str(&format!(" -{}", r.random_range(1..=n.min(40))));
                    } else {
                        s.push_str(&format!(" {}", r.random_range(1..=n)));
                    }
                }
                s.push('\n');
            }
        }
    }
    assert!(check(s.as_bytes()));
}
