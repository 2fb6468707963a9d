//! Leaf attributes: material mapping from MTL (including `Tr`), textures, binary PLY, padding and the builder.

use crate::common;
use common::{bake_at, rng};
use glam::{DVec3, UVec3, Vec3};
use rand::Rng;
use svo::{BakeOptions, Mesh, bake_mesh};

fn random_mesh(seed: u64, n: usize, size: f64) -> Mesh {
    let mut r = rng(seed);
    let mut m = Mesh::default();
    for i in 0..n as u32 {
        let c = DVec3::new(r.random(), r.random(), r.random());
        for _ in 0..3 {
            m.positions.push(
                c + DVec3::new(
                    r.random_range(-size..size),
                    r.random_range(-size..size),
                    r.random_range(-size..size),
                ),
            );
        }
        m.triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    m
}

fn write(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn mtl_materials_map_as_documented() {
    let d = tempfile::tempdir().unwrap();
    // A 2x1 texture: left red, right blue.
    let img = image::RgbaImage::from_fn(2, 1, |x, _| {
        if x == 0 {
            image::Rgba([255, 0, 0, 255])
        } else {
            image::Rgba([0, 0, 255, 255])
        }
    });
    img.save(d.path().join("tex.png")).unwrap();
    write(
        d.path(),
        "m.mtl",
        "newmtl glass\nKd 1 1 1\nTr 0.75\nNi 1.33\nillum 2\n\
         newmtl mirror\nKd 0.5 0.5 0.5\nKs 0.9 0.8 0.7\nillum 3\n\
         newmtl dissolve\nKd 0 1 0\nd 0.25\n\
         newmtl textured\nKd 1 1 1\nmap_Kd tex.png\n",
    );
    let obj = write(
        d.path(),
        "m.obj",
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0.25 0.5\nvt 0.75 0.5\n\
         usemtl glass\nf 1 2 3\nusemtl mirror\nf 2 4 3\nusemtl dissolve\nf 1 2 4\nusemtl textured\nf 1/1 2/2 3/1\n",
    );
    let mesh = Mesh::load(&obj).unwrap();
    let mat = |t: usize| mesh.material_of(t).clone();
    assert!(
        (mat(0).refractivity - 0.75).abs() < 1e-6,
        "Tr 0.75 -> refractivity 0.75"
    );
    assert!((mat(0).ior - 1.33).abs() < 1e-6);
    assert_eq!(mat(0).reflectivity, 0.0, "illum 2 has no mirror");
    assert!((mat(1).reflectivity - 0.9).abs() < 1e-6, "illum 3: max Ks");
    assert!(
        (mat(2).refractivity - 0.75).abs() < 1e-6,
        "d 0.25 -> refractivity 0.75"
    );
    assert_eq!(mat(2).colour[..3], [0.0, 1.0, 0.0]);
    let tex = &mesh.textures[mat(3).texture.unwrap()];
    assert_eq!((tex.width, tex.height), (2, 1));
    // u = 0.25 samples the red texel, 0.75 the blue one.
    assert_eq!(
        tex.sample_linear(glam::Vec2::new(0.25, 0.5))[..3],
        [1.0, 0.0, 0.0]
    );
    assert_eq!(
        tex.sample_linear(glam::Vec2::new(0.75, 0.5))[..3],
        [0.0, 0.0, 1.0]
    );
    // Baked: colour, reflectivity and refractivity vary, so they are per leaf.
    let (tree, _) = bake_at(&mesh, 3);
    let a = &tree.attributes;
    assert!(
        a.colour.is_per_leaf()
            && a.reflectivity.is_per_leaf()
            && a.refractivity.is_per_leaf()
            && a.ior.is_per_leaf()
    );
}

#[test]
fn single_material_channels_are_constants() {
    let mesh = random_mesh(5, 50, 0.1);
    let (tree, stats) = bake_at(&mesh, 5);
    let a = &tree.attributes;
    assert!(a.normal.is_per_leaf() && a.contour.is_per_leaf());
    assert!(
        matches!(a.colour, svo::Channel::Constant(_)) && matches!(a.ior, svo::Channel::Constant(_))
    );
    assert_eq!(
        stats.payload_bytes,
        tree.nodes.len() * 8 + tree.leaf_count as usize * 8
    );
    let sel = "normal".parse::<svo::ChannelSelection>().unwrap();
    let (tree, _) = bake_mesh(
        &mesh,
        &BakeOptions {
            depth: 5,
            channels: sel,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        matches!(tree.attributes.contour, svo::Channel::Absent)
            && matches!(tree.attributes.colour, svo::Channel::Absent)
    );
}

#[test]
fn binary_ply_reads_like_ascii() {
    let d = tempfile::tempdir().unwrap();
    let verts = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let faces: [[i32; 3]; 2] = [[0, 1, 2], [0, 1, 3]];
    let head = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";
    let mut bytes = head.as_bytes().to_vec();
    for v in verts {
        for c in v {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in faces {
        bytes.push(3);
        for i in f {
            bytes.extend_from_slice(&i.to_le_bytes());
        }
    }
    std::fs::write(d.path().join("b.ply"), &bytes).unwrap();
    let ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n";
    write(d.path(), "a.ply", ascii);
    let a = Mesh::load(d.path().join("a.ply")).unwrap();
    let b = Mesh::load(d.path().join("b.ply")).unwrap();
    assert_eq!(a.positions, b.positions);
    assert_eq!(a.triangles, b.triangles);
}

#[test]
fn padding_shifts_cells_and_grows_the_root() {
    let mesh = random_mesh(8, 40, 0.1);
    let (plain, _) = bake_at(&mesh, 5);
    let (padded, _) = bake_mesh(
        &mesh,
        &BakeOptions {
            depth: 5,
            pad: 2,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(padded.root.side > plain.root.side);
    let min = padded.leaves().fold(UVec3::MAX, |a, l| a.min(l.cell));
    let max = padded.leaves().fold(UVec3::ZERO, |a, l| a.max(l.cell));
    assert!(
        min.min_element() >= 2 && max.max_element() <= 29,
        "{min} {max}"
    );
}

#[test]
fn builder_from_fn_equals_from_cells() {
    let root = svo::RootCube {
        origin: DVec3::ZERO,
        side: 1.0,
    };
    let inside = |c: UVec3| {
        (c.as_vec3() - Vec3::splat(7.5)).length() < 6.0 && !(c.x + c.y + c.z).is_multiple_of(3)
    };
    let voxel = |c: UVec3| svo::octree::Voxel {
        colour: [c.x as f32 / 16.0, 0.5, 0.5, 1.0],
        ..Default::default()
    };
    let a = svo::Octree::from_fn(root, 4, |_, _| true, |c| inside(c).then(|| voxel(c))).unwrap();
    let cells: Vec<_> = (0..16u32 * 16 * 16)
        .map(|i| UVec3::new(i / 256, (i / 16) % 16, i % 16))
        .filter(|&c| inside(c))
        .collect();
    // Reverse order and a duplicate: the builder sorts and keeps the last.
    let mut list: Vec<_> = cells.iter().rev().map(|&c| (c, voxel(c))).collect();
    list.push((cells[0], voxel(cells[0])));
    let b = svo::Octree::from_cells(root, 4, list).unwrap();
    assert_eq!(a, b);
    a.validate().unwrap();
    for &c in &cells {
        assert!(a.leaf_at(c).is_some());
    }
    assert!(matches!(
        svo::Octree::from_cells(root, 4, [(UVec3::new(16, 0, 0), voxel(UVec3::ZERO))]),
        Err(svo::octree::OctreeError::CellOutOfRange { .. })
    ));
    assert!(svo::Octree::from_cells(root, 0, []).is_err());
}
