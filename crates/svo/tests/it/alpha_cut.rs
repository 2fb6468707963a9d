//! Alpha cut-outs (`Mesh::cut_alpha_masks`, glTF `alphaMode: MASK`): the kept surface is
//! exactly the triangle's points over kept texels, held to a point-by-point check on random
//! triangles and textures and, on a quad whose texels are squares of the grid, to the leaves
//! of a mesh made of the kept squares by hand. glTF `BLEND` becomes coverage.

use glam::{DVec2, DVec3, Vec2};
use std::collections::BTreeSet;
use svo::mesh::Texture;
use svo::{BakeOptions, Material, Mesh, MeshError, Octree};

/// A texture of `w x h` texels whose alpha is 255 where `kept(x, y)`, else 0.
fn mask_texture(w: u32, h: u32, kept: impl Fn(u32, u32) -> bool) -> Texture {
    let rgba = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| [200, 100, 50, if kept(x, y) { 255 } else { 0 }])
        .collect();
    Texture {
        width: w,
        height: h,
        rgba,
    }
}

/// The unit square in `z = 0` as two triangles, its texture coordinates equal to its `x, y`,
/// with one textured material.
fn textured_quad(texture: Texture) -> Mesh {
    let corners = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    Mesh {
        positions: corners.map(|[x, y]| DVec3::new(x, y, 0.0)).to_vec(),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        uvs: corners.map(|[x, y]| Vec2::new(x as f32, y as f32)).to_vec(),
        triangle_uvs: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![0, 0],
        materials: vec![Material {
            texture: Some(0),
            ..Material::default()
        }],
        textures: vec![texture],
        ..Mesh::default()
    }
}

/// `mesh` baked at `depth`, every channel.
fn bake(mesh: &Mesh, depth: u8) -> Octree {
    let opts = BakeOptions {
        depth,
        ..BakeOptions::default()
    };
    svo::bake_mesh(mesh, &opts).unwrap().0
}

/// The leaves' cells of `mesh` baked at `depth`.
fn leaf_cells(mesh: &Mesh, depth: u8) -> BTreeSet<[u32; 3]> {
    bake(mesh, depth)
        .leaves()
        .map(|l| l.cell.to_array())
        .collect()
}

/// The 3D area of `mesh`'s triangles.
fn area(mesh: &Mesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| mesh.positions[i as usize]);
            0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
        })
        .sum()
}

#[test]
fn checker_quad_has_holes_where_its_texels_are_cut() {
    // Texels (0, 0) and (1, 1) kept: the quad's quarters x, y < 1/2 and x, y > 1/2 (v = 0 is
    // the texture's top row, and here y = v).
    let mut mesh = textured_quad(mask_texture(2, 2, |x, y| x == y));
    mesh.cut_alpha_masks(&[(0, 0.5)]).unwrap();
    mesh.validate().unwrap();
    assert!((area(&mesh) - 0.5).abs() < 1e-12, "{}", area(&mesh));
    let tree = bake(&mesh, 4);
    // Every leaf touches a kept quarter (closed squares)...
    let eps = 1e-12;
    for leaf in tree.leaves() {
        let low = leaf.min.x <= 0.5 + eps && leaf.min.y <= 0.5 + eps;
        let high = leaf.max.x >= 0.5 - eps && leaf.max.y >= 0.5 - eps;
        assert!(low || high, "leaf {:?} lies in a cut quarter", leaf.cell);
    }
    // ...and the kept quarters are covered, the cut ones empty.
    for (x, y, kept) in [
        (0.25, 0.25, true),
        (0.75, 0.75, true),
        (0.75, 0.25, false),
        (0.25, 0.75, false),
    ] {
        for (dx, dy) in [
            (0.0, 0.0),
            (0.1, 0.1),
            (-0.1, 0.1),
            (0.1, -0.1),
            (-0.1, -0.1),
        ] {
            let p = DVec3::new(x + dx, y + dy, 0.0);
            assert_eq!(tree.leaf_at_point(p).is_some(), kept, "{p}");
        }
    }
}

/// On a quad whose texels are squares of the octree's grid, the cut's leaves are those of
/// the kept texels' squares made by hand (the arithmetic is exact there: every texel edge
/// falls on a dyadic coordinate).
#[test]
fn cut_quads_voxelize_as_their_kept_texels() {
    let mut next = svo_tests::seeds::xorshift(0xa1fa);
    for case in 0..7 {
        let (w, h) = ([8, 4, 16][case % 3], [8, 16, 2][case % 3]);
        let bits: Vec<bool> = if case == 6 {
            // Stripes: every row keeps the same runs, so each is one piece a triangle.
            (0..w * h).map(|i| i % w % 3 != 0).collect()
        } else {
            (0..w * h).map(|_| !next().is_multiple_of(3)).collect()
        };
        let kept = |x: u32, y: u32| bits[(y * w + x) as usize];
        let mut cut = textured_quad(mask_texture(w, h, kept));
        cut.cut_alpha_masks(&[(0, 0.5)]).unwrap();
        let mut by_hand = Mesh::default();
        for y in 0..h {
            for x in 0..w {
                if !kept(x, y) {
                    continue;
                }
                let (x0, x1) = (f64::from(x) / f64::from(w), f64::from(x + 1) / f64::from(w));
                let (y0, y1) = (f64::from(y) / f64::from(h), f64::from(y + 1) / f64::from(h));
                let n = by_hand.positions.len() as u32;
                by_hand.positions.extend([
                    DVec3::new(x0, y0, 0.0),
                    DVec3::new(x1, y0, 0.0),
                    DVec3::new(x1, y1, 0.0),
                    DVec3::new(x0, y1, 0.0),
                ]);
                by_hand
                    .triangles
                    .extend([[n, n + 1, n + 2], [n, n + 2, n + 3]]);
            }
        }
        if by_hand.triangles.is_empty() {
            continue;
        }
        assert!((area(&cut) - area(&by_hand)).abs() < 1e-12, "case {case}");
        if case == 6 {
            // Three stripes, each at most a pentagon (three triangles) in each triangle.
            assert!(
                cut.triangles.len() <= 18,
                "{} triangles",
                cut.triangles.len()
            );
        }
        for depth in [4, 6] {
            assert_eq!(
                leaf_cells(&cut, depth),
                leaf_cells(&by_hand, depth),
                "case {case}, depth {depth}"
            );
        }
    }
}

/// Whether `q` lies in the triangle `p` (in its plane), with a tolerance of `eps` in
/// barycentric coordinates.
fn inside(p: [DVec3; 3], q: DVec3, eps: f64) -> bool {
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    let nn = n.length_squared();
    if nn == 0.0 {
        return false;
    }
    let b1 = (q - p[0]).cross(p[2] - p[0]).dot(n) / nn;
    let b2 = (p[1] - p[0]).cross(q - p[0]).dot(n) / nn;
    b1 >= -eps && b2 >= -eps && b1 + b2 <= 1.0 + eps
}

/// Random triangles with random texture coordinates (repeating, negative) over random
/// masks: at random points of each triangle away from texel edges, a point lies in the cut
/// mesh exactly when its texel is kept; the pieces lie inside the triangle and keep its
/// orientation.
#[test]
fn cut_keeps_exactly_the_points_over_kept_texels() {
    let mut r = svo_tests::seeds::unit_f64(0xc0ffee);
    let mut next = svo_tests::seeds::xorshift(0xbeef);
    let (mut kept_points, mut cut_points, mut split) = (0, 0, 0);
    for case in 0..300 {
        let (w, h) = (1 + (next() % 7) as u32, 1 + (next() % 7) as u32);
        let bits: Vec<bool> = (0..w * h).map(|_| next().is_multiple_of(2)).collect();
        let kept = |x: i64, y: i64| {
            bits[(y.rem_euclid(i64::from(h)) * i64::from(w) + x.rem_euclid(i64::from(w))) as usize]
        };
        let p: [DVec3; 3] = std::array::from_fn(|_| DVec3::new(r(), r(), r()) * 4.0 - 2.0);
        let uv: [Vec2; 3] =
            std::array::from_fn(|_| Vec2::new((r() * 4.0 - 1.5) as f32, (r() * 4.0 - 1.5) as f32));
        let mut mesh = Mesh {
            positions: p.to_vec(),
            triangles: vec![[0, 1, 2]],
            uvs: uv.to_vec(),
            triangle_uvs: vec![[0, 1, 2]],
            triangle_materials: vec![0],
            materials: vec![Material {
                texture: Some(0),
                ..Material::default()
            }],
            textures: vec![mask_texture(w, h, |x, y| kept(i64::from(x), i64::from(y)))],
            ..Mesh::default()
        };
        let normal = (p[1] - p[0]).cross(p[2] - p[0]);
        mesh.cut_alpha_masks(&[(0, 0.5)]).unwrap();
        if mesh.triangles.len() > 1 {
            split += 1;
        }
        let pieces: Vec<[DVec3; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.map(|i| mesh.positions[i as usize]))
            .collect();
        for piece in &pieces {
            for &v in piece {
                assert!(
                    inside(p, v, 1e-9),
                    "case {case}: a piece leaves its triangle"
                );
            }
            let n = (piece[1] - piece[0]).cross(piece[2] - piece[0]);
            assert!(n.dot(normal) >= 0.0, "case {case}: a piece turned over");
        }
        let uvd = uv.map(Vec2::as_dvec2);
        for _ in 0..200 {
            let (mut b1, mut b2) = (r(), r());
            if b1 + b2 > 1.0 {
                (b1, b2) = (1.0 - b1, 1.0 - b2);
            }
            let t = uvd[0] * (1.0 - b1 - b2) + uvd[1] * b1 + uvd[2] * b2;
            let texel = t * DVec2::new(f64::from(w), f64::from(h));
            let edge = |x: f64| (x - x.round()).abs() < 1e-3;
            if edge(texel.x) || edge(texel.y) || b1.min(b2).min(1.0 - b1 - b2) < 1e-6 {
                continue;
            }
            let q = p[0] * (1.0 - b1 - b2) + p[1] * b1 + p[2] * b2;
            let want = kept(texel.x.floor() as i64, texel.y.floor() as i64);
            let got = pieces.iter().any(|&piece| inside(piece, q, 1e-9));
            assert_eq!(got, want, "case {case}: texel {texel}");
            if want {
                kept_points += 1;
            } else {
                cut_points += 1;
            }
        }
    }
    eprintln!("{kept_points} kept and {cut_points} cut points, {split} of 300 triangles split");
    assert!(kept_points > 10_000 && cut_points > 10_000 && split > 150);
}

#[test]
fn cut_follows_the_samplers_texel_for_constant_coordinates() {
    // Every corner at a texel corner (1/2, 1/2) of a 2 x 2 texture: the sampler picks texel
    // (1, 1), so the cut keeps the triangle exactly when that texel is kept.
    for kept_texel in 0..4u32 {
        let tex = mask_texture(2, 2, |x, y| y * 2 + x == kept_texel);
        let mut mesh = textured_quad(tex);
        mesh.uvs = vec![Vec2::splat(0.5); 4];
        mesh.cut_alpha_masks(&[(0, 0.5)]).unwrap();
        let sampled = mesh.textures[0].sample_linear(Vec2::splat(0.5))[3] >= 0.5;
        assert_eq!(sampled, kept_texel == 3);
        assert_eq!(mesh.triangles.len(), if sampled { 2 } else { 0 });
    }
}

#[test]
fn materials_alpha_and_cutoff_decide() {
    // Alpha 255 x colour alpha 0.4 is under a cutoff of 0.5: everything goes; with 0.3 it
    // stays whole, with the same triangles.
    let base = {
        let mut m = textured_quad(mask_texture(4, 4, |_, _| true));
        m.materials[0].colour[3] = 0.4;
        m
    };
    let mut all_cut = base.clone();
    all_cut.cut_alpha_masks(&[(0, 0.5)]).unwrap();
    assert!(all_cut.triangles.is_empty());
    let mut whole = base.clone();
    whole.cut_alpha_masks(&[(0, 0.3)]).unwrap();
    assert_eq!(whole.triangles, base.triangles);
    assert_eq!(whole.positions, base.positions);
    // A material not listed is left alone.
    let mut other = textured_quad(mask_texture(2, 2, |x, y| x == y));
    other.cut_alpha_masks(&[(1, 0.5)]).unwrap();
    assert_eq!(other.triangles.len(), 2);
}

#[test]
fn texture_repeated_millions_of_times_is_refused_and_the_mesh_kept() {
    let mut mesh = textured_quad(mask_texture(2, 2, |x, y| x == y));
    mesh.uvs[2] = Vec2::new(1e5, 1e5);
    let before = (mesh.triangles.clone(), mesh.positions.len());
    let e = mesh.cut_alpha_masks(&[(0, 0.5)]).unwrap_err();
    assert!(matches!(e, MeshError::AlphaCut(_)), "{e}");
    assert!(e.to_string().contains("texels"), "{e}");
    assert_eq!((mesh.triangles.clone(), mesh.positions.len()), before);
}

#[cfg(all(feature = "gltf", feature = "io"))]
/// A GLB of the textured unit quad with a 2 x 2 checker alpha PNG, its material given
/// `material` (alpha mode and cutoff).
fn checker_glb(material: serde_json::Value) -> Vec<u8> {
    use serde_json::json;
    let mut png = Vec::new();
    let img = image::RgbaImage::from_fn(2, 2, |x, y| {
        image::Rgba([255, 255, 255, if x == y { 255 } else { 0 }])
    });
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let mut bin = Vec::new();
    for [x, y] in [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
        for c in [x, y, 0.0] {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for [u, v] in [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
        bin.extend_from_slice(&u.to_le_bytes());
        bin.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let png_at = bin.len();
    bin.extend_from_slice(&png);
    let mut material = material;
    material["pbrMetallicRoughness"] = json!({"baseColorTexture": {"index": 0}});
    let j = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 12},
            {"buffer": 0, "byteOffset": png_at, "byteLength": png.len()}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "images": [{"bufferView": 3, "mimeType": "image/png"}],
        "textures": [{"source": 0}],
        "materials": [material],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1},
            "indices": 2, "material": 0}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    crate::gltf_scene::glb(&j, &bin)
}

#[cfg(all(feature = "gltf", feature = "io"))]
#[test]
fn gltf_alpha_modes_import_as_holes_coverage_or_nothing() {
    use serde_json::json;
    let load = |m| Mesh::from_bytes(&checker_glb(m), svo::MeshFormat::Gltf).unwrap();
    let masked = load(json!({"alphaMode": "MASK"}));
    assert!((area(&masked) - 0.5).abs() < 1e-9, "{}", area(&masked));
    assert!(!masked.materials[0].alpha_blend);
    // Baked, the cut quarters have no leaves, the kept ones do.
    let tree = bake(&masked, 4);
    for (x, y, kept) in [
        (0.25, 0.25, true),
        (0.75, 0.75, true),
        (0.75, 0.25, false),
        (0.25, 0.75, false),
    ] {
        let p = DVec3::new(x, y, 0.0);
        assert_eq!(tree.leaf_at_point(p).is_some(), kept, "{p}");
    }
    // A cutoff of 0 keeps every texel.
    let all = load(json!({"alphaMode": "MASK", "alphaCutoff": 0.0}));
    assert!((area(&all) - 1.0).abs() < 1e-9);
    let opaque = load(json!({}));
    assert!((area(&opaque) - 1.0).abs() < 1e-9);
    assert_eq!(opaque.triangles.len(), 2);
    let blend = load(json!({"alphaMode": "BLEND"}));
    assert_eq!(blend.triangles.len(), 2);
    let m = &blend.materials[0];
    assert!(m.alpha_blend && m.ior == 1.0);
    assert_eq!(m.optics_at(0.0), (0.0, 1.0));
    assert_eq!(m.optics_at(1.0), (0.0, 0.0));
    // Baked, the blended quad's leaves refract where the texels are clear: the channel is
    // per leaf, clear over the cut texels and opaque over the kept ones.
    let tree = bake(&blend, 3);
    assert!(tree.attributes.refractivity.is_per_leaf());
    for (x, y, clear) in [
        (0.2, 0.2, false),
        (0.8, 0.8, false),
        (0.8, 0.2, true),
        (0.2, 0.8, true),
    ] {
        let leaf = tree.leaf_at_point(DVec3::new(x, y, 0.0)).unwrap();
        let r = leaf.attributes.refractivity.unwrap();
        assert_eq!(r, if clear { 1.0 } else { 0.0 }, "({x}, {y})");
    }
}
