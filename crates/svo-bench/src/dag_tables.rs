//! The tree's geometry as a DAG (`svo::dag::Dag`): distinct nodes, pointers and bits a leaf
//! beside the tree's, the sizes of both layouts' files (geometry alone and with every
//! channel), and the time to build the graph and write its file beside the bake's; and the
//! normals kept on a level above the leaves, in fewer bits, against the image they give.

use std::time::Instant;
use svo::dag::Dag;
use svo::io::{BuildInfo, write_dag_to, write_dag_to_with, write_to};
use svo::mesh::Mesh;
use svo::octree::LeafAttributes;
use svo::{BakeOptions, bake_mesh};

/// One mesh at one depth.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DagRow {
    /// The mesh's file name.
    pub mesh: String,
    /// Tree depth.
    pub depth: u8,
    /// Leaves.
    pub leaves: u64,
    /// The tree's nodes.
    pub tree_nodes: u64,
    /// The graph's distinct nodes.
    pub dag_nodes: u64,
    /// The graph's pointers.
    pub pointers: u64,
    /// The graph's distinct nodes two levels above the leaves: its 4x4x4 bricks.
    pub bricks: u64,
    /// Nodes above the bricks and their pointers.
    pub above_bricks: (u64, u64),
    /// Seconds of the bake (geometry and every channel), one run.
    pub bake_s: f64,
    /// Seconds building the graph from the tree, one run.
    pub dag_s: f64,
    /// Bytes of the tree-layout file with every channel, and of its geometry alone.
    pub tree_file: (u64, u64),
    /// Bytes of the DAG-layout file with every channel, and of its geometry alone.
    pub dag_file: (u64, u64),
    /// Seconds writing the DAG-layout file of the geometry (the graph built again, its
    /// levels encoded, hashed and streamed to nowhere), one run.
    pub dag_write_s: f64,
}

impl DagRow {
    /// Bits a leaf of the tree's node array (8 bytes a node).
    pub fn tree_bits(&self) -> f64 {
        64.0 * self.tree_nodes as f64 / self.leaves.max(1) as f64
    }

    /// Bits a leaf of the graph at 4 bytes a node (its mask) and 4 a pointer.
    pub fn dag_bits(&self) -> f64 {
        32.0 * (self.dag_nodes + self.pointers) as f64 / self.leaves.max(1) as f64
    }

    /// [`Self::dag_bits`] with a 4-byte count of leaves a node above the leaf parents (what
    /// keeps the leaves' values in one array in Morton order).
    pub fn dag_counted_bits(&self) -> f64 {
        let (n, _) = self.above_bricks;
        self.dag_bits() + 32.0 * (n + self.bricks) as f64 / self.leaves.max(1) as f64
    }

    /// Bits a leaf of a file of `bytes`.
    pub fn file_bits(&self, bytes: u64) -> f64 {
        8.0 * bytes as f64 / self.leaves.max(1) as f64
    }
}

/// Bakes `mesh` (named `name`) at each of `depths` (geometry and every channel, as the
/// default bake) and builds each tree's graph.
pub fn measure(
    mesh: &Mesh,
    name: &str,
    depths: impl IntoIterator<Item = u8>,
) -> anyhow::Result<Vec<DagRow>> {
    let mut rows = Vec::new();
    for depth in depths {
        let opts = BakeOptions {
            depth,
            ..Default::default()
        };
        let t = Instant::now();
        let mut tree = bake_mesh(mesh, &opts)?.0;
        let bake_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let dag = Dag::from_tree(&tree);
        let dag_s = t.elapsed().as_secs_f64();
        let counts = dag.level_counts();
        let pointers = dag.level_pointer_counts();
        let k = counts.len().saturating_sub(2);
        let build = BuildInfo::new();
        let sink = &mut std::io::sink();
        let tree_all = write_to(&tree, &build, sink)?;
        let dag_all = write_dag_to(&tree, &build, sink)?;
        tree.attributes = LeafAttributes::default();
        let tree_geometry = write_to(&tree, &build, sink)?;
        let t = Instant::now();
        let dag_geometry = write_dag_to(&tree, &build, sink)?;
        let dag_write_s = t.elapsed().as_secs_f64();
        rows.push(DagRow {
            mesh: name.to_string(),
            depth,
            leaves: dag.leaf_count(),
            tree_nodes: tree.nodes.len() as u64,
            dag_nodes: dag.node_count(),
            pointers: dag.pointer_count(),
            bricks: counts.get(k).copied().unwrap_or(0),
            above_bricks: (counts[..k].iter().sum(), pointers[..k].iter().sum()),
            bake_s,
            dag_s,
            tree_file: (tree_all, tree_geometry),
            dag_file: (dag_all, dag_geometry),
            dag_write_s,
        });
    }
    Ok(rows)
}

/// Normals kept on a level (`svo::dag::DagValues`): one mesh at one depth, one setting.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ValuesRow {
    /// The mesh's file name.
    pub mesh: String,
    /// Tree depth.
    pub depth: u8,
    /// Leaves.
    pub leaves: u64,
    /// The level whose nodes hold the normals (the depth: each leaf its own).
    pub level: u8,
    /// Bits a normal.
    pub bits: u8,
    /// The normals stored (one for each node of `level`).
    pub normals: u64,
    /// Bytes of the DAG file, geometry and normals.
    pub file: u64,
    /// PSNR (dB) of each view's image against the image with each leaf's own 32-bit normal.
    pub psnr_own: Vec<f64>,
    /// PSNR (dB) of each view's image against the triangles'.
    pub psnr_triangles: Vec<f64>,
}

impl ValuesRow {
    /// Bits a leaf of a file of `bytes`.
    pub fn file_bits(&self, bytes: u64) -> f64 {
        8.0 * bytes as f64 / self.leaves.max(1) as f64
    }
}

/// How the values tables render: cube hits, one light, no shadows or bounces (the values
/// alone make the difference).
fn values_trace() -> svo::render::TraceOptions {
    svo::render::TraceOptions {
        mode: svo::trace::HitMode::Cube,
        shadows: svo::render::ShadowMode::None,
        max_reflections: 0,
        max_refractions: 0,
        ..Default::default()
    }
}

/// Bakes `mesh` (named `name`) at each of `depths` with normals alone and its inner nodes'
/// attributes, and for each setting of (level below the depth, bits) writes the DAG file
/// with the normals so kept and renders `views` (cube hits, one light, no shadows or
/// bounces, `width` x `height`) on its graph, against the graph with each leaf's own normal
/// and against the triangles.
pub fn measure_values(
    mesh: &Mesh,
    name: &str,
    depths: impl IntoIterator<Item = u8>,
    settings: &[(u8, u8)],
    views: &[crate::views::View],
    (width, height): (u32, u32),
) -> anyhow::Result<Vec<ValuesRow>> {
    use svo::dag::{DagTree, DagValues};
    use svo::render::{DagSurfaces, MeshSurfaces, Phong, Sky, Tracer, compare, render};
    let (lo, hi) = mesh
        .bounds()
        .ok_or_else(|| anyhow::anyhow!("{name}: an empty mesh"))?;
    let trace = values_trace();
    let mut rows = Vec::new();
    for depth in depths {
        let opts = BakeOptions {
            depth,
            node_attributes: true,
            channels: svo::ChannelSelection::NONE.with(svo::octree::ChannelKind::Normal),
            ..Default::default()
        };
        let tree = bake_mesh(mesh, &opts)?.0;
        let build = BuildInfo::new();
        let sink = &mut std::io::sink();
        let own = DagTree::from_tree_with(&tree, &DagValues::default())?;
        let frame = |dag: &DagTree, view: crate::views::View| -> anyhow::Result<_> {
            let cam = view.camera(lo, hi, width, height);
            let light = view.light(lo, hi, &cam);
            let t = Tracer::new(
                DagSurfaces::new(dag, trace.mode),
                &[light],
                Sky::default(),
                Phong::default(),
                trace,
            );
            Ok(render(&t, &cam)?)
        };
        let mut references = Vec::new();
        for &view in views {
            let cam = view.camera(lo, hi, width, height);
            let light = view.light(lo, hi, &cam);
            let t = Tracer::new(
                MeshSurfaces::new(mesh.clone(), tree.root, tree.depth),
                &[light],
                Sky::default(),
                Phong::default(),
                trace,
            );
            references.push((frame(&own, view)?, render(&t, &cam)?));
        }
        for &(below, bits) in settings {
            let Some(level) = depth.checked_sub(below).filter(|&l| l >= 1) else {
                continue;
            };
            let values = DagValues {
                level: Some(level),
                normal_bits: bits,
                colour_bits: 32,
            };
            let file = write_dag_to_with(&tree, &build, &values, sink)?;
            let dag = DagTree::from_tree_with(&tree, &values)?;
            let (mut psnr_own, mut psnr_triangles) = (Vec::new(), Vec::new());
            for (&view, (own_frame, triangles)) in views.iter().zip(&references) {
                let f = frame(&dag, view)?;
                let db = |a, b| compare(a, b).map_or(f64::NAN, |d| d.psnr_db);
                psnr_own.push(db(&f, own_frame));
                psnr_triangles.push(db(&f, triangles));
            }
            let normals = match &dag.attributes().normal {
                svo::octree::Channel::PerLeaf(v) => v.len() as u64,
                _ => 0,
            };
            rows.push(ValuesRow {
                mesh: name.to_string(),
                depth,
                leaves: u64::from(tree.leaf_count),
                level,
                bits,
                normals,
                file,
                psnr_own,
                psnr_triangles,
            });
        }
    }
    Ok(rows)
}

/// Colours kept on a level in fewer bits, for one setting.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ColourRow {
    /// The mesh's file name.
    pub mesh: String,
    /// Tree depth.
    pub depth: u8,
    /// Leaves.
    pub leaves: u64,
    /// The level whose nodes hold the values (the depth: each leaf its own).
    pub level: u8,
    /// Bits a colour (32, 16 or 4).
    pub bits: u8,
    /// The colours stored (one for each node of `level`).
    pub colours: u64,
    /// Bytes of the DAG file (geometry, normals in 32 bits and colours) and of the same file
    /// without its colour channel.
    pub file: (u64, u64),
    /// RMS error of the colours kept against the same level's colours in 32 bits, in 8-bit
    /// sRGB levels (per channel).
    pub rms: f64,
    /// PSNR (dB) of each view's image against the image with each leaf's own 32-bit colour
    /// and normal.
    pub psnr_own: Vec<f64>,
    /// PSNR (dB) of each view's image against the same level's values with 32-bit colours
    /// (the compression's error alone).
    pub psnr_level: Vec<f64>,
    /// PSNR (dB) of each view's image against the triangles'.
    pub psnr_triangles: Vec<f64>,
}

impl ColourRow {
    /// Bits a leaf of the colour channel (the file's bytes beyond the file without it).
    pub fn colour_bits(&self) -> f64 {
        8.0 * self.file.0.saturating_sub(self.file.1) as f64 / self.leaves.max(1) as f64
    }
}

/// The views of the colours table, for a mesh of bounds `lo`..`hi`: the default framing, and
/// its eye moved to 40% of the distance to the target (a pixel about a leaf wide at depth
/// 11), each with one light.
fn colour_views(
    lo: glam::DVec3,
    hi: glam::DVec3,
    (width, height): (u32, u32),
) -> Vec<(svo::render::Camera, svo::render::PointLight)> {
    use crate::views::View;
    let framed = View::Framed.camera(lo, hi, width, height);
    let close = svo::render::Camera {
        eye: framed.target + (framed.eye - framed.target) * 0.4,
        ..framed
    };
    [framed, close]
        .into_iter()
        .map(|c| (c, View::Framed.light(lo, hi, &c)))
        .collect()
}

/// Bakes `mesh` (named `name`, with colours) at `depth` with normals, colours and its inner
/// nodes' attributes, and for each of `levels` (levels above the leaves: 0 is each leaf its
/// own) and `bits` writes the DAG file with the colours so kept (normals in 32 bits on the
/// same level) and renders the framed and a close view (cube hits, one light, no shadows or
/// bounces, `size`) on its graph, against each leaf's own values, against the same level in
/// 32 bits and against the triangles.
pub fn measure_colours(
    mesh: &Mesh,
    name: &str,
    depth: u8,
    levels: &[u8],
    bits: &[u8],
    size: (u32, u32),
) -> anyhow::Result<Vec<ColourRow>> {
    use svo::dag::{DagTree, DagValues};
    use svo::octree::{Channel, ChannelKind};
    use svo::render::{DagSurfaces, MeshSurfaces, Phong, Sky, Tracer, compare, render};
    let (lo, hi) = mesh
        .bounds()
        .ok_or_else(|| anyhow::anyhow!("{name}: an empty mesh"))?;
    let trace = values_trace();
    let opts = BakeOptions {
        depth,
        node_attributes: true,
        channels: svo::ChannelSelection::NONE
            .with(ChannelKind::Normal)
            .with(ChannelKind::Colour),
        ..Default::default()
    };
    let tree = bake_mesh(mesh, &opts)?.0;
    if !tree.attributes.colour.is_per_leaf() {
        anyhow::bail!("{name}: the bake has one colour");
    }
    let mut plain = tree.clone();
    plain.attributes.colour = Channel::Absent;
    plain.node_attributes.colour = Channel::Absent;
    let build = BuildInfo::new();
    let sink = &mut std::io::sink();
    let views = colour_views(lo, hi, size);
    let frames = |dag: &DagTree| -> anyhow::Result<Vec<svo::render::Frame>> {
        views
            .iter()
            .map(|(cam, light)| {
                let t = Tracer::new(
                    DagSurfaces::new(dag, trace.mode),
                    &[*light],
                    Sky::default(),
                    Phong::default(),
                    trace,
                );
                Ok(render(&t, cam)?)
            })
            .collect()
    };
    let own = frames(&DagTree::from_tree_with(&tree, &DagValues::default())?)?;
    let mut triangles = Vec::new();
    for (cam, light) in &views {
        let t = Tracer::new(
            MeshSurfaces::new(mesh.clone(), tree.root, tree.depth),
            &[*light],
            Sky::default(),
            Phong::default(),
            trace,
        );
        triangles.push(render(&t, cam)?);
    }
    let db = |a: &[svo::render::Frame], b: &[svo::render::Frame]| -> Vec<f64> {
        a.iter()
            .zip(b)
            .map(|(x, y)| compare(x, y).map_or(f64::NAN, |d| d.psnr_db))
            .collect()
    };
    let rgb = |w: u32| [w & 0xFF, (w >> 8) & 0xFF, (w >> 16) & 0xFF];
    let mut rows = Vec::new();
    for &below in levels {
        let Some(level) = depth.checked_sub(below).filter(|&l| l >= 1) else {
            continue;
        };
        let at = |b: u8| DagValues {
            level: Some(level),
            colour_bits: b,
            ..DagValues::default()
        };
        let full = DagTree::from_tree_with(&tree, &at(32))?;
        // On the leaves' level, 32 bits are each leaf's own values, already rendered.
        let full_frames = if level == depth {
            own.clone()
        } else {
            frames(&full)?
        };
        let without = write_dag_to_with(&plain, &build, &at(32), sink)?;
        for &b in bits {
            let values = at(b);
            let file = write_dag_to_with(&tree, &build, &values, sink)?;
            // 32 bits: the graph and frames made above.
            let built = if b == 32 {
                None
            } else {
                Some(DagTree::from_tree_with(&tree, &values)?)
            };
            let dag = built.as_ref().unwrap_or(&full);
            let (kept, whole) = match (&dag.attributes().colour, &full.attributes().colour) {
                (Channel::PerLeaf(k), Channel::PerLeaf(w)) => (k, w),
                _ => anyhow::bail!("{name}: colours not kept per value"),
            };
            let sq: f64 = kept
                .iter()
                .zip(whole)
                .map(|(&k, &w)| {
                    let (k, w) = (rgb(k), rgb(w));
                    (0..3)
                        .map(|c| f64::from(k[c].abs_diff(w[c])).powi(2))
                        .sum::<f64>()
                })
                .sum();
            let f = match &built {
                Some(d) => frames(d)?,
                None => full_frames.clone(),
            };
            rows.push(ColourRow {
                mesh: name.to_string(),
                depth,
                leaves: u64::from(tree.leaf_count),
                level,
                bits: b,
                colours: kept.len() as u64,
                file: (file, without),
                rms: (sq / (3 * kept.len().max(1)) as f64).sqrt(),
                psnr_own: db(&f, &own),
                psnr_level: db(&f, &full_frames),
                psnr_triangles: db(&f, &triangles),
            });
        }
    }
    Ok(rows)
}
