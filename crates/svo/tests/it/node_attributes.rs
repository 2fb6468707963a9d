//! Inner nodes' attributes (`BakeOptions::node_attributes`), held to a reference that clips
//! every triangle against every node's cell: each node's normal and colour are the
//! area-weighted means over the triangles' parts in its cell, its contour encloses those
//! parts, a plane's contours stay thin at every level, and the values do not depend on the
//! thread count.

use crate::common::{clipped_polygon, rng};
use glam::{DVec3, UVec3};
use rand::Rng;
use svo::octree::Channel;
use svo::{BakeOptions, Material, Mesh, Octree, bake_mesh, with_threads};

use svo_tests::node_order::{is_level_order, same_shape};

/// `n` random triangles of about `size` in the unit cube, in two materials (red and blue)
/// where `colours` is set.
fn random_mesh(seed: u64, n: usize, size: f64, colours: bool) -> Mesh {
    let mut r = rng(seed);
    let mut m = Mesh::default();
    for i in 0..n as u32 {
        let c = DVec3::new(r.random(), r.random(), r.random());
        for _ in 0..3 {
            let d = DVec3::new(
                r.random_range(-size..size),
                r.random_range(-size..size),
                r.random_range(-size..size),
            );
            m.positions.push(c + d);
        }
        m.triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        if colours {
            m.triangle_materials.push(i % 2);
        }
    }
    if colours {
        for (name, colour) in [
            ("red", [1.0, 0.0, 0.0, 1.0]),
            ("blue", [0.0, 0.2, 1.0, 1.0]),
        ] {
            m.materials.push(Material {
                name: name.into(),
                colour,
                ..Material::default()
            });
        }
    }
    m
}

fn bake(mesh: &Mesh, depth: u8) -> Octree {
    let opts = BakeOptions {
        depth,
        node_attributes: true,
        ..Default::default()
    };
    bake_mesh(mesh, &opts).unwrap().0
}

/// Every inner node above the leaf parents (which keep no values) with its minimum cell and
/// side, in cells of the tree's depth.
fn inner_nodes(tree: &Octree) -> Vec<(usize, UVec3, u32)> {
    let mut out = Vec::new();
    let mut stack = vec![(0usize, 0u8, UVec3::ZERO)];
    while let Some((i, level, min)) = stack.pop() {
        let node = tree.nodes[i];
        if node.child_mask() == 0 {
            continue;
        }
        let side = 1u32 << (tree.depth - level);
        if node.leaf_base().is_some() {
            continue;
        }
        out.push((i, min, side));
        for c in 0..8u8 {
            if let Some(rank) = node.child_rank(c) {
                let o = UVec3::new(
                    u32::from(c >> 2 & 1),
                    u32::from(c >> 1 & 1),
                    u32::from(c & 1),
                );
                stack.push((
                    (node.first + rank) as usize,
                    level + 1,
                    min + o * (side / 2),
                ));
            }
        }
    }
    out
}

/// The parts of the mesh's triangles in a node's cell, in the node's units (`[0, 1]^3`),
/// each with its triangle.
fn parts(mesh: &Mesh, tree: &Octree, min: UVec3, side: u32) -> Vec<(usize, Vec<DVec3>)> {
    let s = f64::from(side);
    mesh.triangles
        .iter()
        .enumerate()
        .filter_map(|(t, tri)| {
            let v = tri.map(|k| {
                (tree.root.to_grid(mesh.positions[k as usize], tree.depth) - min.as_dvec3()) / s
            });
            let p = clipped_polygon(v);
            (!p.is_empty()).then_some((t, p))
        })
        .collect()
}

fn area(p: &[DVec3]) -> f64 {
    let mut twice = DVec3::ZERO;
    for i in 1..p.len().saturating_sub(1) {
        twice += (p[i] - p[0]).cross(p[i + 1] - p[0]);
    }
    twice.length() / 2.0
}

fn srgb_to_linear(v: u8) -> f64 {
    let c = f64::from(v) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn nodes_carry_the_area_weighted_surface_of_their_cells() {
    let (mut normals, mut colours, mut points) = (0, 0, 0);
    for (seed, n, size, depth) in [(11u64, 40, 0.3, 5u8), (12, 300, 0.05, 6), (13, 8, 0.6, 4)] {
        let mesh = random_mesh(seed, n, size, true);
        let tree = bake(&mesh, depth);
        let a = &tree.node_attributes;
        for (i, min, side) in inner_nodes(&tree) {
            let v = a.get(i);
            let (nrm, (near, far)) = (v.normal.unwrap(), v.contour.unwrap());
            let parts = parts(&mesh, &tree, min, side);
            // The reference: area-weighted unit normals and linear colours of the parts.
            let (mut s, mut w, mut col) = (DVec3::ZERO, 0.0, [0.0f64; 3]);
            for (t, p) in &parts {
                let tri = mesh.triangles[*t].map(|k| mesh.positions[k as usize]);
                let unit = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize_or_zero();
                let a = area(p);
                s += unit * a;
                w += a;
                let c = mesh.materials[mesh.triangle_materials[*t] as usize].colour;
                for k in 0..3 {
                    col[k] += a * f64::from(c[k]);
                }
                // Every point of every part lies between the node's contour planes.
                for q in p {
                    let d = nrm.as_dvec3().dot(*q - DVec3::splat(0.5));
                    assert!(
                        d >= f64::from(near) - 1e-5 && d <= f64::from(far) + 1e-5,
                        "seed {seed}, node {i}: {d} outside [{near}, {far}]"
                    );
                    points += 1;
                }
            }
            // Where the normals do not nearly cancel, the node's is their mean's direction
            // (the octahedral encoding is good to about 1e-4 radians).
            if w > 0.0 && s.length() > 0.2 * w {
                let angle = s.normalize().angle_between(nrm.as_dvec3());
                assert!(
                    angle < 2e-3,
                    "seed {seed}, node {i}: normal off by {angle} rad"
                );
                normals += 1;
            }
            if w > 0.0 {
                let got = v.colour.unwrap();
                for k in 0..3 {
                    let want = col[k] / w;
                    let have = srgb_to_linear(got[k]);
                    // One sRGB step is at most about 0.013 in linear terms.
                    assert!(
                        (have - want).abs() < 0.015,
                        "seed {seed}, node {i}, channel {k}: {have} vs {want}"
                    );
                }
                colours += 1;
            }
        }
    }
    assert!(
        normals > 300 && colours > 300 && points > 5000,
        "{normals} {colours} {points}"
    );
}

#[test]
fn a_planes_node_contours_stay_thin_at_every_level() {
    // A tilted square: every node's children hold flat pieces of the same plane, so the
    // contours built from the children's stay a few quanta thick, not growing level by level.
    let mut m = Mesh::default();
    let (o, u, v) = (
        DVec3::new(0.1, 0.2, 0.15),
        DVec3::new(0.8, 0.3, 0.1),
        DVec3::new(-0.1, 0.35, 0.75),
    );
    m.positions = vec![o, o + u, o + u + v, o + v];
    m.triangles = vec![[0, 1, 2], [0, 2, 3]];
    let tree = bake(&m, 7);
    let a = &tree.node_attributes;
    let mut checked = 0;
    for (i, _, side) in inner_nodes(&tree) {
        let v = a.get(i);
        let (near, far) = v.contour.unwrap();
        // Node units: 1e-3 of a node at every level (a quantum is 1.5e-5 of its extent).
        assert!(
            far - near < 1e-3,
            "node {i} (side {side}): thickness {}",
            far - near
        );
        checked += 1;
    }
    assert!(checked > 200, "{checked}");
}

#[test]
fn node_attributes_do_not_depend_on_the_thread_count_nor_change_the_leaves() {
    let mesh = random_mesh(21, 2000, 0.08, true);
    let one = with_threads(Some(1), |_| bake(&mesh, 7)).unwrap();
    let three = with_threads(Some(3), |_| bake(&mesh, 7)).unwrap();
    assert_eq!(one, three);
    let plain = bake_mesh(
        &mesh,
        &BakeOptions {
            depth: 7,
            ..Default::default()
        },
    )
    .unwrap()
    .0;
    // The same shape, the nodes level by level where they carry values.
    assert!(same_shape(&plain, &one));
    assert!(is_level_order(&one) && !is_level_order(&plain));
    assert_eq!(plain.attributes, one.attributes);
    assert_eq!(
        plain.node_attributes,
        svo::octree::LeafAttributes::default()
    );
    assert!(one.node_attributes.normal.is_per_leaf() && one.node_attributes.colour.is_per_leaf());
    let per_node = |c: &Channel<u32>| match c {
        Channel::PerLeaf(v) => v.len(),
        _ => 0,
    };
    assert_eq!(per_node(&one.node_attributes.contour), one.nodes.len());
    // The tree checks out; in depth-first order with its values it does not.
    one.validate().unwrap();
    // (Constant values, so that only the order can fail.)
    fn constant<T: Copy + Default>(c: &Channel<T>) -> Channel<T> {
        match c {
            Channel::Absent => Channel::Absent,
            _ => Channel::Constant(T::default()),
        }
    }
    let a = &one.node_attributes;
    let constants = svo::octree::LeafAttributes {
        normal: constant(&a.normal),
        contour: constant(&a.contour),
        colour: constant(&a.colour),
        reflectivity: constant(&a.reflectivity),
        refractivity: constant(&a.refractivity),
        ior: constant(&a.ior),
    };
    Octree {
        node_attributes: constants.clone(),
        ..one.clone()
    }
    .validate()
    .unwrap();
    let depth_first = Octree {
        nodes: plain.nodes.clone(),
        node_attributes: constants,
        ..one.clone()
    };
    let err = depth_first.validate().unwrap_err().to_string();
    assert!(err.contains("check 16"), "{err}");
    // Nor does one with a node channel one value short.
    let mut short = one.clone();
    if let Channel::PerLeaf(v) = &mut short.node_attributes.normal {
        v.pop();
    }
    let err = short.validate().unwrap_err().to_string();
    assert!(err.contains("node channel normal"), "{err}");
    // The leaf parents keep no values, and one that has one is refused.
    let leaf_parent = one.nodes.iter().position(|n| n.is_leaf_parent()).unwrap();
    assert_eq!(one.node_attributes.normal.get(leaf_parent), Some(0));
    assert_eq!(one.node_attributes.contour.get(leaf_parent), Some(0));
    let mut stray = one.clone();
    if let Channel::PerLeaf(v) = &mut stray.node_attributes.contour {
        v[leaf_parent] = 0xFFFF_0000;
    }
    let err = stray.validate().unwrap_err().to_string();
    assert!(err.contains("a leaf parent"), "{err}");
    // The root's colour lies between the two materials'.
    let root = one.node_attributes.get(0).colour.unwrap();
    assert!(root[0] > 40 && root[2] > 40, "{root:?}");
}

#[test]
fn node_channels_follow_the_leaves_storage() {
    // One material: the leaves' colour and optics are constants, and so are the nodes'.
    let sphere = Mesh::sphere(DVec3::splat(0.5), 0.4, 24);
    let tree = bake(&sphere, 5);
    let (leaves, nodes) = (&tree.attributes, &tree.node_attributes);
    assert!(matches!(leaves.colour, Channel::Constant(_)));
    assert_eq!(nodes.colour, leaves.colour);
    assert_eq!(nodes.ior, leaves.ior);
    assert!(nodes.normal.is_per_leaf() && nodes.contour.is_per_leaf());
    // Without normals (and so contours), the nodes have none either.
    let opts = BakeOptions {
        depth: 5,
        node_attributes: true,
        channels: svo::ChannelSelection::ALL
            .without(svo::octree::ChannelKind::Normal)
            .without(svo::octree::ChannelKind::Contour),
        ..Default::default()
    };
    let tree = bake_mesh(&sphere, &opts).unwrap().0;
    assert_eq!(tree.node_attributes.normal, Channel::Absent);
    assert_eq!(tree.node_attributes.contour, Channel::Absent);
    assert_eq!(tree.node_attributes.colour, tree.attributes.colour);
}

/// Solid bakes add interior leaves after the build, so they make no node channels.
#[cfg(feature = "solid")]
#[test]
fn solid_bakes_make_no_node_channels() {
    let opts = BakeOptions {
        depth: 5,
        node_attributes: true,
        solid: Some(svo::SolidMode::Closed),
        ..Default::default()
    };
    let tree = bake_mesh(&Mesh::sphere(DVec3::splat(0.5), 0.4, 24), &opts)
        .unwrap()
        .0;
    assert!(tree.attributes.has_interior());
    assert_eq!(tree.node_attributes, svo::octree::LeafAttributes::default());
}
