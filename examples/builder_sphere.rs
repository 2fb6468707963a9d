//! Builds an octree programmatically (no mesh): a glass sphere shell around a solid red
//! core, with pruning so only the nodes near the surfaces are visited. Then queries cells
//! and writes the `.svo` file.
//!
//! `cargo run -p svo-examples --example builder_sphere -- sphere.svo`

use glam::{DVec3, UVec3, Vec3};
use svo::RootCube;
use svo::io::BuildInfo;
use svo::octree::{Octree, Voxel};

fn main() -> anyhow::Result<()> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "sphere.svo".into());
    let depth = 7u8;
    let n = f64::from(1u32 << depth);
    let c = DVec3::splat(n / 2.0);
    let (shell_r, core_r) = (n * 0.45, n * 0.2);
    // Distance from the centre to the nearest and farthest points of a node's cube.
    let span = |min: UVec3, size: u32| {
        let lo = min.as_dvec3();
        let hi = lo + DVec3::splat(f64::from(size));
        let near = c.clamp(lo, hi).distance(c);
        let far = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 4 != 0 { hi.x } else { lo.x },
                    if i & 2 != 0 { hi.y } else { lo.y },
                    if i & 1 != 0 { hi.z } else { lo.z },
                )
                .distance(c)
            })
            .fold(0.0, f64::max);
        (near, far)
    };
    let tree = Octree::from_fn(
        RootCube {
            origin: DVec3::splat(-1.0),
            side: 2.0,
        },
        depth,
        // a node may hold a voxel if it reaches the shell or the core
        |min, size| {
            let (near, far) = span(min, size);
            (near <= shell_r && far >= shell_r - 1.0) || near <= core_r
        },
        |cell| {
            let p = cell.as_dvec3() + DVec3::splat(0.5);
            let d = p.distance(c);
            let normal = Some((p - c).normalize().as_vec3());
            if (d - shell_r).abs() < 0.75 {
                Some(Voxel {
                    normal,
                    ..Voxel::glass()
                })
            } else if d < core_r {
                Some(Voxel {
                    normal,
                    ..Voxel::solid([0.8, 0.1, 0.1, 1.0])
                })
            } else {
                None
            }
        },
    )?;
    println!(
        "{} leaves, {} nodes, {} bytes of arrays",
        tree.leaf_count,
        tree.nodes.len(),
        tree.payload_bytes()
    );
    let centre = UVec3::splat(1 << (depth - 1));
    let i = tree.leaf_at(centre).expect("the core is solid");
    let v = tree.attributes.get(i as usize);
    println!(
        "cell {centre}: colour {:?}, refractivity {:?}",
        v.colour, v.refractivity
    );
    assert!(v.normal.is_some_and(|n: Vec3| n.is_normalized()));
    let build = BuildInfo {
        generator: "builder_sphere example".into(),
        strategy: "builder".into(),
        source_triangles: 0,
        ..Default::default()
    };
    let bytes = svo::io::write_file(&tree, &build, std::path::Path::new(&out))?;
    println!("wrote {out} ({bytes} bytes)");
    Ok(())
}
