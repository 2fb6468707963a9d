//! A human-readable description of an octree and its file header, for `svo-view --info`.

use crate::io::header::BuildInfo;
use crate::octree::tree::{Channel, Octree};
use std::fmt::Write;

fn channel<T: Copy>(name: &str, c: &Channel<T>, show: impl Fn(T) -> String, out: &mut String) {
    let _ = match c {
        Channel::Absent => writeln!(out, "  {name:<13} absent"),
        Channel::Constant(v) => writeln!(out, "  {name:<13} constant {}", show(*v)),
        Channel::PerLeaf(v) => writeln!(out, "  {name:<13} per leaf ({} values)", v.len()),
    };
}

/// Describes the tree: root, depth, counts per level, channels, sizes.
pub fn describe(tree: &Octree, build: &BuildInfo, file_bytes: u64) -> String {
    let mut out = String::new();
    let o = tree.root.origin;
    let _ = writeln!(
        out,
        "generator      {} (strategy {}, {} source triangles)",
        build.generator, build.strategy, build.source_triangles
    );
    let _ = writeln!(
        out,
        "root           origin ({}, {}, {}), side {}",
        o.x, o.y, o.z, tree.root.side
    );
    let _ = writeln!(
        out,
        "depth          {} (grid {}^3, cell {:.6e})",
        tree.depth,
        1u64 << tree.depth,
        tree.root.cell_size(tree.depth)
    );
    let _ = writeln!(out, "nodes          {}", tree.nodes.len());
    let _ = writeln!(out, "leaves         {}", tree.leaf_count);
    if let Channel::PerLeaf(v) = &tree.attributes.normal {
        let interior = v
            .iter()
            .filter(|&&w| w == crate::octree::tree::NO_NORMAL)
            .count();
        if interior > 0 {
            let _ = writeln!(
                out,
                "solid          {interior} interior leaves, {} surface leaves",
                v.len() - interior
            );
        }
    }
    for l in &build.scene.lights {
        let [x, y, z] = l.position;
        let [r, g, b] = l.colour;
        let _ = writeln!(
            out,
            "light          ({x}, {y}, {z}) colour ({r}, {g}, {b}) intensity {}",
            l.intensity
        );
    }
    for c in &build.scene.cameras {
        let _ = writeln!(
            out,
            "view           {:?}: eye {:?} target {:?} up {:?} fov {}",
            c.name, c.eye, c.target, c.up, c.fov_deg
        );
    }
    // Nodes per level, walking the packed layout breadth-first.
    let mut level = vec![0u32];
    let mut counts = Vec::new();
    while !level.is_empty() && counts.len() < usize::from(tree.depth) {
        counts.push(level.len());
        let mut next = Vec::new();
        for &i in &level {
            let n = tree.nodes[i as usize];
            if !n.is_leaf_parent() && n.child_mask() != 0 {
                next.extend(n.first..n.first + n.child_mask().count_ones());
            }
        }
        level = next;
    }
    let _ = writeln!(out, "nodes/level    {counts:?}");
    let _ = writeln!(out, "channels");
    let a = &tree.attributes;
    channel(
        "normal",
        &a.normal,
        |v| format!("{:?}", crate::octree::normal_encoding::decode(v)),
        &mut out,
    );
    channel(
        "contour",
        &a.contour,
        |v| format!("{:?}", crate::octree::contour::unpack(v)),
        &mut out,
    );
    channel(
        "colour",
        &a.colour,
        |v| format!("RGBA8 sRGB {:?}", v.to_le_bytes()),
        &mut out,
    );
    channel(
        "reflectivity",
        &a.reflectivity,
        |v| format!("{:.3}", f32::from(v) / 255.0),
        &mut out,
    );
    channel(
        "refractivity",
        &a.refractivity,
        |v| format!("{:.3}", f32::from(v) / 255.0),
        &mut out,
    );
    channel(
        "ior",
        &a.ior,
        |v| format!("{:.4}", crate::octree::encoding::ior_decode(v)),
        &mut out,
    );
    let per_leaf = if tree.leaf_count > 0 {
        file_bytes as f64 / f64::from(tree.leaf_count)
    } else {
        0.0
    };
    let _ = write!(
        out,
        "file           {file_bytes} bytes, {per_leaf:.2} bytes per leaf"
    );
    out
}
