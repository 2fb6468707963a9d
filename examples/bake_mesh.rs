//! Bakes a mesh through the library API and walks the result: what `svo-bake` does, minus
//! the command line.
//!
//! `cargo run --release -p svo-examples --example bake_mesh -- fixtures/torus.obj 7`

use svo::{BakeOptions, bake_mesh};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "fixtures/torus.obj".into());
    let depth: u8 = args.next().map_or(Ok(7), |d| d.parse())?;
    let mesh = svo::Mesh::load(&path)?;
    let (tree, stats) = bake_mesh(
        &mesh,
        &BakeOptions {
            depth,
            ..Default::default()
        },
    )?;
    println!(
        "{path}: {} triangles -> {} leaves, {} nodes in {:.1} ms",
        stats.triangles,
        stats.leaves,
        stats.nodes,
        (stats.voxelize_s + stats.attributes_s + stats.contours_s) * 1e3
    );
    // The first few leaves with their cells, scene-space bounds and attributes.
    for leaf in tree.leaves().take(3) {
        let v = leaf.attributes;
        println!(
            "leaf {} cell {} bounds {:.3}..{:.3} normal {:?} contour {:?}",
            leaf.index, leaf.cell, leaf.min, leaf.max, v.normal, v.contour
        );
    }
    Ok(())
}
