//! The `.svo` conformance corpus (`fixtures/format/conformance/`, written by
//! `cargo run -p svo-examples --example format_corpus`): valid files covering every channel
//! kind and storage, both versions, an empty tree, a single leaf, the deepest depth, a solid
//! tree with interior leaves and stored lights and views; and invalid files, each failing one
//! numbered check of `docs/format.md`, named by it.
//!
//! The files are encoded here from `docs/format.md` ([`Parts::encode`]), not by svo's writer:
//! for every valid tree that svo can write, the test `tests/tests/it/format_conformance.rs`
//! requires svo's writer to give the same bytes, so the canonical layout is stated and
//! followed twice.

use glam::{DVec3, UVec3, Vec3};
use svo::io::BuildInfo;
use svo::mesh::{Mesh, SceneInfo, StoredCamera, StoredLight};
use svo::{BakeOptions, Channel, Octree, RootCube, SolidMode, Voxel, bake_mesh};

/// A stored channel: one value for every leaf, or an array of elements (little-endian bytes).
#[derive(Clone, Debug)]
pub enum Stored {
    /// `Constant(u32)`: variant 0.
    Constant(u32),
    /// `PerLeaf { offset, len }`: variant 1, with the array's bytes.
    PerLeaf(Vec<u8>),
    /// `Packed { level, bits, offset, len }`: variant 2 (the DAG layout's values on a level),
    /// with the bit stream's bytes.
    Packed {
        /// The level whose nodes hold the values.
        level: u8,
        /// The bits of a value.
        bits: u8,
        /// The bit stream.
        bytes: Vec<u8>,
    },
}

/// A file's contents, field by field as `docs/format.md` lists them, before encoding.
#[derive(Clone, Debug)]
pub struct Parts {
    /// Format version (1, 2 or 3).
    pub version: u32,
    /// Version 3: the chunk level and the chunk table (`code`, `nodes`, `leaves`); `nodes` is
    /// then the chunks' node arrays one after another.
    pub chunks: Option<(u8, Vec<[u64; 3]>)>,
    /// Root cube minimum corner.
    pub origin: [f64; 3],
    /// Root cube side.
    pub side: f64,
    /// Levels below the root.
    pub depth: u8,
    /// `node_count` as stored.
    pub node_count: u64,
    /// `leaf_count` as stored.
    pub leaf_count: u64,
    /// The node array: `(info, first)` words.
    pub nodes: Vec<[u32; 2]>,
    /// The channels by kind code.
    pub channels: Vec<(u8, Stored)>,
    /// `build.generator`.
    pub generator: String,
    /// `build.strategy`.
    pub strategy: String,
    /// `build.source_triangles`.
    pub source_triangles: u64,
    /// Lights and cameras (version 2).
    pub scene: SceneInfo,
    /// Version 4: the inner nodes' channels by kind, a per-node array holding one value for
    /// every node in the (canonical) order of `nodes`; only levels `0 .. depth - 2` are stored.
    pub node_channels: Vec<(u8, Stored)>,
    /// Version 4: the `layout` byte.
    pub layout: u8,
    /// Version 4: whether the nodes are put in level order (else stored in `nodes`' order,
    /// which makes a file that breaks it).
    pub level_order: bool,
}

fn channel_bytes<T: Copy>(
    kind: u8,
    c: &Channel<T>,
    le: impl Fn(T) -> Vec<u8>,
    out: &mut Vec<(u8, Stored)>,
) where
    u32: From<T>,
{
    match c {
        Channel::Absent => {}
        Channel::Constant(v) => out.push((kind, Stored::Constant(u32::from(*v)))),
        Channel::PerLeaf(v) => out.push((
            kind,
            Stored::PerLeaf(v.iter().flat_map(|&x| le(x)).collect()),
        )),
    }
}

fn pad8(x: usize) -> usize {
    x.div_ceil(8) * 8
}

impl Parts {
    /// The parts of a tree and its build information, as a version-2 file stores them.
    pub fn of(tree: &Octree, build: &BuildInfo) -> Self {
        let a = &tree.attributes;
        let mut channels = Vec::new();
        channel_bytes(
            0,
            &a.normal,
            |v: u32| v.to_le_bytes().to_vec(),
            &mut channels,
        );
        channel_bytes(
            1,
            &a.contour,
            |v: u32| v.to_le_bytes().to_vec(),
            &mut channels,
        );
        channel_bytes(
            2,
            &a.colour,
            |v: u32| v.to_le_bytes().to_vec(),
            &mut channels,
        );
        channel_bytes(3, &a.reflectivity, |v: u8| vec![v], &mut channels);
        channel_bytes(4, &a.refractivity, |v: u8| vec![v], &mut channels);
        channel_bytes(5, &a.ior, |v: u16| v.to_le_bytes().to_vec(), &mut channels);
        Self {
            version: 2,
            chunks: None,
            origin: tree.root.origin.to_array(),
            side: tree.root.side,
            depth: tree.depth,
            node_count: tree.nodes.len() as u64,
            leaf_count: u64::from(tree.leaf_count),
            nodes: tree
                .nodes
                .iter()
                .map(|n| [u32::from(n.child_mask()), n.first])
                .collect(),
            channels,
            generator: build.generator.clone(),
            strategy: build.strategy.clone(),
            source_triangles: build.source_triangles,
            scene: build.scene.clone(),
            node_channels: Vec::new(),
            layout: 0,
            level_order: true,
        }
    }

    /// The parts of a tree with its inner nodes' channels, as a version-4 file stores them.
    pub fn levels_of(tree: &Octree, build: &BuildInfo) -> Self {
        let mut p = Self::of(tree, build);
        let a = &tree.node_attributes;
        let mut channels = Vec::new();
        let le4 = |v: u32| v.to_le_bytes().to_vec();
        channel_bytes(0, &a.normal, le4, &mut channels);
        channel_bytes(1, &a.contour, le4, &mut channels);
        channel_bytes(2, &a.colour, le4, &mut channels);
        channel_bytes(3, &a.reflectivity, |v: u8| vec![v], &mut channels);
        channel_bytes(4, &a.refractivity, |v: u8| vec![v], &mut channels);
        channel_bytes(5, &a.ior, |v: u16| v.to_le_bytes().to_vec(), &mut channels);
        p.version = 4;
        p.node_channels = channels;
        p
    }

    /// The same tree as a file of the DAG layout stores it (section 12; without inner-node
    /// channels).
    pub fn as_dag(&self) -> Self {
        let mut p = self.clone();
        p.version = 4;
        p.layout = 1;
        p.node_channels.clear();
        p.node_count = dag_blocks(&p.nodes, p.depth).1.iter().sum();
        p
    }

    /// Section 11: the nodes' indices in `nodes` in level order (each level's children blocks
    /// in the order of their parents), and the nodes on each level.
    fn levels(&self) -> (Vec<usize>, Vec<u64>) {
        let mut order = vec![0usize];
        let mut counts = vec![0u64; usize::from(self.depth)];
        let (mut level, mut level_end) = (0usize, 1usize);
        let mut i = 0;
        while i < order.len() {
            if i == level_end {
                level += 1;
                level_end = order.len();
            }
            counts[level] += 1;
            let [info, first] = self.nodes[order[i]];
            if (first as i32) >= 0 && info & 0xFF != 0 {
                let k = (info & 0xFF).count_ones() as usize;
                order.extend(first as usize..first as usize + k);
            }
            i += 1;
        }
        (order, counts)
    }

    /// Version 4's blocks: for each level, its records then (levels `0 .. depth - 2`) each
    /// per-node channel's values.
    fn blocks(&self) -> (Vec<Vec<Vec<u8>>>, Vec<u64>) {
        if self.layout == 1 {
            let (blocks, counts) = dag_blocks(&self.nodes, self.depth);
            return (blocks.into_iter().map(|b| vec![b]).collect(), counts);
        }
        let (order, counts) = self.levels();
        let mut at_of = vec![0u32; self.nodes.len()];
        for (new, &old) in order.iter().enumerate() {
            at_of[old] = new as u32;
        }
        let mut blocks = Vec::new();
        let mut start = 0usize;
        for (l, &n) in counts.iter().enumerate() {
            let range = start..start + n as usize;
            let mut records = Vec::new();
            for new in range.clone() {
                let old = if self.level_order { order[new] } else { new };
                let [info, first] = self.nodes[old];
                let first = if self.level_order && (first as i32) >= 0 && info & 0xFF != 0 {
                    at_of[first as usize]
                } else {
                    first
                };
                records.extend(info.to_le_bytes());
                records.extend(first.to_le_bytes());
            }
            let mut block = vec![records];
            if l + 2 <= usize::from(self.depth) {
                for (kind, s) in &self.node_channels {
                    if let Stored::PerLeaf(values) = s {
                        let size = [4usize, 4, 4, 1, 1, 2][usize::from(*kind)];
                        let mut v = Vec::new();
                        for new in range.clone() {
                            let old = order[new];
                            v.extend(&values[old * size..(old + 1) * size]);
                        }
                        block.push(v);
                    }
                }
            }
            blocks.push(block);
            start = range.end;
        }
        (blocks, counts)
    }

    /// The version-4 header with the levels at `levels` (`nodes`, `offset`, `len`, `hash`)
    /// and the per-leaf arrays at `refs`.
    fn header_v4(&self, levels: &[[u64; 4]], refs: &[(u64, u64)]) -> Vec<u8> {
        let mut h = Vec::new();
        let u64s = |h: &mut Vec<u8>, v: u64| h.extend(v.to_le_bytes());
        self.origin
            .iter()
            .chain([&self.side])
            .for_each(|x| h.extend(x.to_le_bytes()));
        h.push(self.depth);
        h.push(self.layout);
        u64s(&mut h, self.node_count);
        u64s(&mut h, self.leaf_count);
        u64s(&mut h, levels.len() as u64);
        for e in levels {
            e.iter().for_each(|&x| u64s(&mut h, x));
        }
        u64s(&mut h, self.node_channels.len() as u64);
        for (kind, s) in &self.node_channels {
            h.push(*kind);
            match s {
                Stored::Constant(v) => {
                    h.extend(0u32.to_le_bytes());
                    h.extend(v.to_le_bytes());
                }
                Stored::PerLeaf(_) | Stored::Packed { .. } => h.extend(1u32.to_le_bytes()),
            }
        }
        self.channels_and_tail(&mut h, refs, 0);
        h
    }

    /// Version 4's file (section 11).
    fn encode_v4(&self) -> Vec<u8> {
        let (blocks, counts) = self.blocks();
        let leaf_arrays: Vec<Vec<u8>> = self
            .channels
            .iter()
            .filter_map(|(_, s)| match s {
                Stored::PerLeaf(b) | Stored::Packed { bytes: b, .. } => Some(b.clone()),
                Stored::Constant(_) => None,
            })
            .collect();
        let hlen = self
            .header_v4(
                &vec![[0; 4]; counts.len()],
                &vec![(0, 0); leaf_arrays.len()],
            )
            .len();
        let mut at = pad8(16 + hlen + 8);
        let mut levels = Vec::new();
        for (block, &n) in blocks.iter().zip(&counts) {
            let offset = at;
            let mut hasher = xxhash_rust::xxh3::Xxh3::new();
            let mut end = at;
            for (i, a) in block.iter().enumerate() {
                if i > 0 {
                    hasher.update(&vec![0u8; at - end]);
                }
                hasher.update(a);
                end = at + a.len();
                at = pad8(end);
            }
            levels.push([n, offset as u64, (end - offset) as u64, hasher.digest()]);
        }
        let refs: Vec<(u64, u64)> = leaf_arrays
            .iter()
            .map(|a| {
                let r = (at as u64, a.len() as u64);
                at = pad8(at + a.len());
                r
            })
            .collect();
        let header = self.header_v4(&levels, &refs);
        let mut out = Vec::new();
        out.extend(MAGIC);
        out.extend(self.version.to_le_bytes());
        out.extend((header.len() as u32).to_le_bytes());
        out.extend(&header);
        let sum = xxhash_rust::xxh3::xxh3_64(&out);
        out.extend(sum.to_le_bytes());
        for a in blocks.iter().flatten().chain(&leaf_arrays) {
            out.resize(pad8(out.len()), 0);
            out.extend(a);
        }
        out.resize(pad8(out.len()), 0);
        seal(&mut out);
        out
    }

    /// The same tree as version 3 with its chunks at `level` (section 10): each subtree under a
    /// node at `level` placed again as a tree of its own, in its own canonical order, its
    /// leaves numbered from 0.
    pub fn chunked(&self, level: u8) -> Self {
        let mut table = Vec::new();
        let mut nodes = Vec::new();
        // (node, level, code), children pushed last first so that they pop in child order.
        let mut stack = vec![(0usize, 0u8, 0u64)];
        while let Some((i, l, code)) = stack.pop() {
            let [info, first] = self.nodes[i];
            let mask = info & 0xFF;
            if mask == 0 {
                continue;
            }
            if l == level {
                let chunk = own_tree(&self.nodes, i, self.depth - level);
                let leaves = leaf_parents(&chunk).iter().map(|p| u64::from(p.2)).sum();
                table.push([code, chunk.len() as u64, leaves]);
                nodes.extend(chunk);
                continue;
            }
            let bits: Vec<u32> = (0..8).filter(|b| mask >> b & 1 == 1).collect();
            for (slot, b) in bits.iter().enumerate().rev() {
                stack.push((first as usize + slot, l + 1, code << 3 | u64::from(*b)));
            }
        }
        let mut p = self.clone();
        p.version = 3;
        p.node_count = nodes.len() as u64;
        p.nodes = nodes;
        p.chunks = Some((level, table));
        p
    }

    /// The arrays in file order: in version 3 the chunk table, the nodes, then the per-leaf
    /// channels by kind.
    fn arrays(&self) -> Vec<Vec<u8>> {
        let nodes = self
            .nodes
            .iter()
            .flat_map(|w| w.iter().flat_map(|x| x.to_le_bytes()))
            .collect();
        let mut out = Vec::new();
        if let Some((_, table)) = &self.chunks {
            out.push(
                table
                    .iter()
                    .flat_map(|r| r.iter().flat_map(|x| x.to_le_bytes()))
                    .collect(),
            );
        }
        out.push(nodes);
        for (_, s) in &self.channels {
            if let Stored::PerLeaf(b) | Stored::Packed { bytes: b, .. } = s {
                out.push(b.clone());
            }
        }
        out
    }

    /// The header with the arrays at `refs` (`(offset, len)` in file order).
    pub fn header(&self, refs: &[(u64, u64)]) -> Vec<u8> {
        let mut h = Vec::new();
        let u64s = |h: &mut Vec<u8>, v: u64| h.extend(v.to_le_bytes());
        let f64s = |h: &mut Vec<u8>, v: &[f64]| v.iter().for_each(|x| h.extend(x.to_le_bytes()));
        f64s(&mut h, &self.origin);
        f64s(&mut h, &[self.side]);
        h.push(self.depth);
        if let Some((level, table)) = &self.chunks {
            h.push(*level);
            u64s(&mut h, table.len() as u64);
        }
        u64s(&mut h, self.node_count);
        u64s(&mut h, self.leaf_count);
        let mut next = 0;
        if self.chunks.is_some() {
            u64s(&mut h, refs[0].0);
            u64s(&mut h, refs[0].1);
            next = 1;
        }
        u64s(&mut h, refs[next].0);
        u64s(&mut h, refs[next].1);
        self.channels_and_tail(&mut h, refs, next + 1);
        h
    }

    /// The header from `channels` to `cameras`, the per-leaf arrays at `refs[next..]`.
    fn channels_and_tail(&self, h: &mut Vec<u8>, refs: &[(u64, u64)], mut next: usize) {
        let u64s = |h: &mut Vec<u8>, v: u64| h.extend(v.to_le_bytes());
        let f64s = |h: &mut Vec<u8>, v: &[f64]| v.iter().for_each(|x| h.extend(x.to_le_bytes()));
        let string = |h: &mut Vec<u8>, s: &str| {
            h.extend((s.len() as u64).to_le_bytes());
            h.extend(s.as_bytes());
        };
        u64s(h, self.channels.len() as u64);
        for (kind, s) in &self.channels {
            h.push(*kind);
            match s {
                Stored::Constant(v) => {
                    h.extend(0u32.to_le_bytes());
                    h.extend(v.to_le_bytes());
                }
                Stored::PerLeaf(_) => {
                    h.extend(1u32.to_le_bytes());
                    u64s(h, refs[next].0);
                    u64s(h, refs[next].1);
                    next += 1;
                }
                Stored::Packed { level, bits, .. } => {
                    h.extend(2u32.to_le_bytes());
                    h.push(*level);
                    h.push(*bits);
                    u64s(h, refs[next].0);
                    u64s(h, refs[next].1);
                    next += 1;
                }
            }
        }
        string(h, &self.generator);
        string(h, &self.strategy);
        u64s(h, self.source_triangles);
        if self.version >= 2 {
            u64s(h, self.scene.lights.len() as u64);
            for l in &self.scene.lights {
                f64s(h, &l.position);
                l.colour.iter().for_each(|c| h.extend(c.to_le_bytes()));
                h.extend(l.intensity.to_le_bytes());
            }
            u64s(h, self.scene.cameras.len() as u64);
            for c in &self.scene.cameras {
                string(h, &c.name);
                f64s(h, &c.eye);
                f64s(h, &c.target);
                f64s(h, &c.up);
                f64s(h, &[c.fov_deg]);
            }
        }
    }

    /// The canonical file: preamble, header, zero padding to 8, each array at the next
    /// multiple of 8 with zero padding after it, and the XXH3-64 checksum of everything
    /// before it.
    pub fn encode(&self) -> Vec<u8> {
        if self.version == 4 {
            return self.encode_v4();
        }
        let arrays = self.arrays();
        // The header's length does not depend on the offsets in it (fixed-width integers).
        let hlen = self.header(&vec![(0, 0); arrays.len()]).len();
        let mut at = pad8(16 + hlen);
        let refs: Vec<(u64, u64)> = arrays
            .iter()
            .map(|a| {
                let r = (at as u64, a.len() as u64);
                at = pad8(at + a.len());
                r
            })
            .collect();
        let header = self.header(&refs);
        let mut out = Vec::new();
        out.extend(MAGIC);
        out.extend(self.version.to_le_bytes());
        out.extend((header.len() as u32).to_le_bytes());
        out.extend(&header);
        for a in &arrays {
            out.resize(pad8(out.len()), 0);
            out.extend(a);
        }
        out.resize(pad8(out.len()), 0);
        seal(&mut out);
        out
    }
}

/// The magic bytes.
pub const MAGIC: [u8; 8] = *b"\x89SVO\r\n\x1a\n";

/// Appends the checksum: XXH3-64 (seed 0) of every byte, little-endian.
pub fn seal(bytes: &mut Vec<u8>) {
    let sum = xxhash_rust::xxh3::xxh3_64(bytes);
    bytes.extend(sum.to_le_bytes());
}

/// Version 4: recomputes the header checksum after the header, then the file's checksum.
pub fn reseal_v4(bytes: &mut Vec<u8>) {
    let h = header_len(bytes);
    let sum = xxhash_rust::xxh3::xxh3_64(&bytes[..16 + h]);
    bytes[16 + h..16 + h + 8].copy_from_slice(&sum.to_le_bytes());
    reseal(bytes);
}

/// Replaces the last 8 bytes with the checksum of the bytes before them.
pub fn reseal(bytes: &mut Vec<u8>) {
    bytes.truncate(bytes.len() - 8);
    seal(bytes);
}

/// One file of the corpus.
pub struct Entry {
    /// File name, `valid-...` or `check-NN-...`.
    pub name: String,
    /// The bytes.
    pub bytes: Vec<u8>,
    /// The check it fails (`None`: valid).
    pub check: Option<u8>,
    /// What it holds or breaks.
    pub what: String,
}

fn root() -> RootCube {
    RootCube {
        origin: DVec3::new(-1.0, -0.5, 0.25),
        side: 2.0,
    }
}

/// A depth-3 tree of 12 cells whose every attribute varies, with contours.
fn varied_tree() -> Octree {
    let cells = (0..12u32).map(|i| {
        let c = UVec3::new(i % 4 * 2, i / 4 * 2 + 1, (i * 3) % 8);
        let t = i as f32 / 11.0;
        let v = Voxel {
            colour: [t, 1.0 - t, 0.5, 0.25 + 0.5 * t],
            reflectivity: t,
            refractivity: 1.0 - t,
            ior: 1.0 + 2.0 * t,
            normal: Some(Vec3::new(t - 0.5, 0.3, -0.7 + t)),
        };
        (c, v)
    });
    let mut tree = Octree::from_cells(root(), 3, cells).expect("a valid tree");
    let contours = (0..tree.leaf_count)
        .map(|i| (i * 1000) | ((40_000 + i * 2000) << 16))
        .collect();
    tree.attributes.contour = Channel::PerLeaf(contours);
    tree
}

/// A depth-2 tree of 5 cells, every channel a constant (a contour too).
fn constant_tree() -> Octree {
    let v = Voxel {
        normal: Some(Vec3::new(0.0, 1.0, 0.0)),
        ..Voxel::glass()
    };
    let cells =
        [[0, 0, 0], [1, 2, 3], [3, 3, 3], [2, 0, 1], [0, 3, 1]].map(|c| (UVec3::from_array(c), v));
    let mut tree = Octree::from_cells(root(), 2, cells).expect("a valid tree");
    tree.attributes.contour = Channel::Constant(0x9000_7000);
    tree
}

fn closed_torus() -> Mesh {
    let (rings, sides) = (16, 8);
    let mut m = Mesh::default();
    for i in 0..rings {
        for j in 0..sides {
            let (u, v) = (
                std::f64::consts::TAU * f64::from(i) / f64::from(rings),
                std::f64::consts::TAU * f64::from(j) / f64::from(sides),
            );
            let r = 1.0 + 0.4 * v.cos();
            m.positions
                .push(DVec3::new(r * u.cos(), 0.4 * v.sin(), r * u.sin()));
        }
    }
    let at = |i: u32, j: u32| (i % rings) * sides + (j % sides);
    for i in 0..rings {
        for j in 0..sides {
            m.triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            m.triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    m
}

fn baked(solid: bool) -> (Octree, BuildInfo) {
    let opts = BakeOptions {
        depth: 4,
        solid: solid.then_some(SolidMode::Closed),
        ..BakeOptions::default()
    };
    let (tree, _) = bake_mesh(&closed_torus(), &opts).expect("the torus bakes");
    let build = BuildInfo {
        generator: "svo conformance".into(),
        strategy: "exact".into(),
        source_triangles: 256,
        scene: SceneInfo::default(),
    };
    (tree, build)
}

fn build(scene: SceneInfo) -> BuildInfo {
    BuildInfo {
        generator: "svo conformance".into(),
        strategy: "builder".into(),
        source_triangles: 0,
        scene,
    }
}

fn scene() -> SceneInfo {
    SceneInfo {
        lights: vec![
            StoredLight {
                position: [2.0, 3.0, -1.5],
                colour: [1.0, 0.9, 0.8],
                intensity: 12.5,
            },
            StoredLight {
                position: [-4.0, 0.5, 0.0],
                colour: [0.0, 0.0, 0.5],
                intensity: 0.0,
            },
        ],
        cameras: vec![
            StoredCamera {
                name: "front".into(),
                eye: [0.0, 0.5, 4.0],
                target: [0.0, 0.5, 0.0],
                up: [0.0, 1.0, 0.0],
                fov_deg: 45.0,
            },
            StoredCamera {
                name: "".into(),
                eye: [3.0, 3.0, 3.0],
                target: [0.0, 0.0, 0.0],
                up: [0.0, 0.0, 1.0],
                fov_deg: 0.5,
            },
        ],
    }
}

/// Rebuilds the node array with the children blocks in breadth-first order: a valid tree in
/// another order than the canonical one.
/// Section 12: the levels of the DAG layout of the canonical tree `nodes` of `depth` levels
/// (2 or more), each level's bytes, and the nodes on each level. Each tree node is named by
/// what it holds (a leaf parent its mask; a node two levels above the leaves its 64-bit
/// brick; a node above those its mask and its children's names); the names of a level are
/// numbered in the order in which the level above, walked in its own order, first refers to
/// them.
fn dag_blocks(nodes: &[[u32; 2]], depth: u8) -> (Vec<Vec<u8>>, Vec<u64>) {
    let depth = usize::from(depth);
    let bricks_level = depth - 2;
    let children = |i: usize| -> Vec<usize> {
        let [info, first] = nodes[i];
        let k = (info & 0xFF).count_ones() as usize;
        if (first as i32) < 0 || k == 0 {
            Vec::new()
        } else {
            (first as usize..first as usize + k).collect()
        }
    };
    // The name of each tree node: (mask or brick, children's names) as text, bottom up.
    fn name(
        i: usize,
        level: usize,
        bricks_level: usize,
        nodes: &[[u32; 2]],
        children: &dyn Fn(usize) -> Vec<usize>,
        names: &mut Vec<Option<String>>,
    ) -> String {
        if let Some(n) = &names[i] {
            return n.clone();
        }
        let mask = nodes[i][0] & 0xFF;
        let n = if level == bricks_level {
            let mut brick = 0u64;
            let mut kids = children(i).into_iter();
            for a in 0..8 {
                if mask >> a & 1 == 1 {
                    let lp = kids.next().expect("a child for each bit");
                    brick |= u64::from(nodes[lp][0] & 0xFF) << (8 * a);
                }
            }
            format!("b{brick}")
        } else {
            let kids: Vec<String> = children(i)
                .into_iter()
                .map(|c| name(c, level + 1, bricks_level, nodes, children, names))
                .collect();
            format!("({mask}:{})", kids.join(","))
        };
        names[i] = Some(n.clone());
        n
    }
    let mut names = vec![None; nodes.len()];
    name(0, 0, bricks_level, nodes, &children, &mut names);
    // Level by level: the distinct names in first-reference order, and one tree node for each.
    let mut levels: Vec<Vec<(String, usize)>> =
        vec![vec![(names[0].clone().unwrap_or_default(), 0)]];
    for l in 1..=bricks_level {
        let mut order: Vec<(String, usize)> = Vec::new();
        for (_, i) in &levels[l - 1] {
            for c in children(*i) {
                let n = names[c].clone().unwrap_or_default();
                if !order.iter().any(|(m, _)| *m == n) {
                    order.push((n, c));
                }
            }
        }
        levels.push(order);
    }
    // The bytes: a level above the bricks holds, for each node, its mask (8 bits) and its
    // children's indices on the level below, each in as many bits as that level's count
    // needs, packed lowest bit first; the bricks' level the bricks.
    let index_in = |l: usize, n: &str| levels[l].iter().position(|(m, _)| m == n).unwrap_or(0);
    let mut blocks = Vec::new();
    for (l, level) in levels.iter().enumerate() {
        let mut bits: Vec<bool> = Vec::new();
        let mut bytes = Vec::new();
        let width = levels
            .get(l + 1)
            .map_or(1, |below| reference_bits(below.len() as u64));
        for (n, i) in level {
            if l == bricks_level {
                let brick: u64 = n[1..].parse().unwrap_or(0);
                bytes.extend(brick.to_le_bytes());
                continue;
            }
            push_bits(&mut bits, nodes[*i][0] & 0xFF, 8);
            for c in children(*i) {
                let k = index_in(l + 1, names[c].as_deref().unwrap_or_default());
                push_bits(&mut bits, k as u32, width);
            }
        }
        if l < bricks_level {
            bytes = pack_bits(&bits);
        }
        blocks.push(bytes);
    }
    let counts = levels.iter().map(|l| l.len() as u64).collect();
    (blocks, counts)
}

/// Section 12: the bits of a reference to a level of `count` nodes, the fewest (at least 1)
/// that hold `count - 1`.
pub fn reference_bits(count: u64) -> u32 {
    let mut w = 1;
    while w < 64 && count > 1u64 << w {
        w += 1;
    }
    w
}

/// Appends `value`'s `width` lowest bits, lowest first.
fn push_bits(bits: &mut Vec<bool>, value: u32, width: u32) {
    bits.extend((0..width).map(|i| value >> i & 1 == 1));
}

/// Bits into bytes, bit `i` in bit `i % 8` of byte `i / 8`, the last byte's high bits zero.
fn pack_bits(bits: &[bool]) -> Vec<u8> {
    bits.chunks(8)
        .map(|c| {
            c.iter()
                .enumerate()
                .fold(0u8, |b, (i, &x)| b | u8::from(x) << i)
        })
        .collect()
}

fn breadth_first_order(nodes: &[[u32; 2]], depth: u8) -> Vec<[u32; 2]> {
    let mut out = vec![nodes[0]];
    // (old index, new index, level)
    let mut queue = std::collections::VecDeque::from([(0usize, 0usize, 0u8)]);
    while let Some((old, new, level)) = queue.pop_front() {
        let [info, first] = nodes[old];
        let k = (info & 0xFF).count_ones() as usize;
        if k == 0 || level + 1 == depth {
            continue;
        }
        let start = out.len();
        out[new][1] = start as u32;
        for c in 0..k {
            out.push(nodes[first as usize + c]);
            queue.push_back((first as usize + c, start + c, level + 1));
        }
    }
    out
}

/// The leaf parents in depth-first child order, with their leaf bases and counts.
fn leaf_parents(nodes: &[[u32; 2]]) -> Vec<(usize, u32, u32)> {
    let mut out = Vec::new();
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        let [info, first] = nodes[i];
        let k = (info & 0xFF).count_ones();
        if (first as i32) < 0 {
            out.push((i, (-i64::from(first as i32) - 1) as u32, k));
        } else if k > 0 {
            stack.extend((first as usize..first as usize + k as usize).rev());
        }
    }
    out
}

/// The subtree under node `root` of `nodes` as a tree of its own of `levels` levels: its root
/// first, its children blocks placed in the canonical order (a block, then the children's
/// subtrees from the last child to the first), its leaves numbered from 0 depth-first.
fn own_tree(nodes: &[[u32; 2]], root: usize, levels: u8) -> Vec<[u32; 2]> {
    fn place(
        nodes: &[[u32; 2]],
        old: usize,
        new: usize,
        lv: u8,
        levels: u8,
        out: &mut Vec<[u32; 2]>,
    ) {
        let [info, first] = nodes[old];
        let k = (info & 0xFF).count_ones() as usize;
        if lv + 1 == levels {
            return;
        }
        let start = out.len();
        out[new][1] = start as u32;
        out.extend((0..k).map(|c| nodes[first as usize + c]));
        for c in (0..k).rev() {
            place(nodes, first as usize + c, start + c, lv + 1, levels, out);
        }
    }
    let mut out = vec![nodes[root]];
    place(nodes, root, 0, 0, levels, &mut out);
    // The leaves, depth-first from 0: walk the new array in child order.
    let mut seen = 0u32;
    let mut stack = vec![(0usize, 0u8)];
    while let Some((i, lv)) = stack.pop() {
        let [info, first] = out[i];
        let k = (info & 0xFF).count_ones();
        if lv + 1 == levels {
            out[i][1] = (-i64::from(seen) - 1) as i32 as u32;
            seen += k;
        } else {
            stack.extend(
                (first as usize..first as usize + k as usize)
                    .rev()
                    .map(|j| (j, lv + 1)),
            );
        }
    }
    out
}

/// The byte offset of a header field (version-2 layout; the fixed part is the same in both).
mod at {
    pub const DEPTH: usize = 16 + 32;
    pub const NODE_COUNT: usize = DEPTH + 1;
    pub const LEAF_COUNT: usize = NODE_COUNT + 8;
    pub const NODES_OFFSET: usize = LEAF_COUNT + 8;
    pub const NODES_LEN: usize = NODES_OFFSET + 8;
    pub const CHANNELS: usize = NODES_LEN + 8;
    /// The first channel entry.
    pub const FIRST_CHANNEL: usize = CHANNELS + 8;
}

fn put(bytes: &mut [u8], at: usize, v: &[u8]) {
    bytes[at..at + v.len()].copy_from_slice(v);
}

/// The little-endian `u64` at `at`.
fn u64_at(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"))
}

fn header_len(bytes: &[u8]) -> usize {
    u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize
}

/// The trees the corpus's files are made of, as their parts.
struct Trees {
    /// Every channel per leaf, depth 3.
    varied: Parts,
    /// Every channel a constant.
    constant: Parts,
    /// A baked torus.
    torus: Parts,
    /// The same torus filled.
    solid: Parts,
    /// `varied` without channels.
    none: Parts,
    /// The empty tree.
    empty: Parts,
    /// One leaf at depth 1.
    single: Parts,
    /// Depth 30, three leaves.
    deepest: Parts,
    /// `constant` with lights and views.
    with_scene: Parts,
    /// `varied` as version 1.
    v1: Parts,
    /// `varied` in chunks at level 1.
    chunked: Parts,
    /// `varied` in chunks at level 2 (each a leaf parent).
    leafy: Parts,
    /// `deepest` in chunks at level 21.
    deepest_chunked: Parts,
    /// `varied`'s bytes, the file most invalid ones break.
    base: Vec<u8>,
    /// `varied` as version 4, with made-up values for every inner-node channel per node.
    levels: Parts,
    /// The torus baked with its inner nodes' attributes, version 4.
    levels_bake: Parts,
}

impl Trees {
    fn new() -> Self {
        let varied = Parts::of(&varied_tree(), &build(SceneInfo::default()));
        let constant = Parts::of(&constant_tree(), &build(SceneInfo::default()));
        let (surface, surface_build) = baked(false);
        let (solid, solid_build) = baked(true);
        let torus = Parts::of(&surface, &surface_build);
        let solid = Parts::of(&solid, &solid_build);
        let mut none = varied.clone();
        none.channels.clear();
        let empty = Parts::of(
            &Octree::from_cells(root(), 3, []).expect("empty"),
            &build(SceneInfo::default()),
        );
        let single = Parts::of(
            &Octree::from_cells(root(), 1, [(UVec3::new(1, 0, 1), Voxel::water())])
                .expect("one leaf"),
            &build(SceneInfo::default()),
        );
        let deepest = Parts::of(
            &Octree::from_cells(
                root(),
                30,
                [
                    UVec3::ZERO,
                    UVec3::splat((1 << 30) - 1),
                    UVec3::new(5, (1 << 29) + 3, 12345),
                ]
                .map(|c| (c, Voxel::solid([0.2, 0.4, 0.6, 1.0]))),
            )
            .expect("depth 30"),
            &build(SceneInfo::default()),
        );
        let with_scene = Parts::of(&constant_tree(), &build(scene()));
        let mut v1 = varied.clone();
        v1.version = 1;
        let chunked = varied.chunked(1);
        let leafy = varied.chunked(2);
        let deepest_chunked = deepest.chunked(21);
        let base = varied.encode();
        let mut levels = varied.clone();
        levels.version = 4;
        levels.node_channels = node_values(&varied);
        let levels_bake = {
            let opts = BakeOptions {
                depth: 4,
                node_attributes: true,
                ..BakeOptions::default()
            };
            let (tree, _) = bake_mesh(&closed_torus(), &opts).expect("the torus bakes");
            Parts::levels_of(&tree, &baked(false).1)
        };
        Self {
            varied,
            constant,
            torus,
            solid,
            none,
            empty,
            single,
            deepest,
            with_scene,
            v1,
            chunked,
            leafy,
            deepest_chunked,
            base,
            levels,
            levels_bake,
        }
    }
}

/// Made-up inner-node values of every channel for each of `p`'s nodes (valid words: no
/// `0x8000` half, the near plane before the far one).
fn node_values(p: &Parts) -> Vec<(u8, Stored)> {
    let n = p.nodes.len() as u32;
    let words = |f: &dyn Fn(u32) -> Vec<u8>| Stored::PerLeaf((0..n).flat_map(f).collect());
    vec![
        (
            0,
            words(&|i| {
                ((i * 1000) | ((30_000 - i * 700) << 16))
                    .to_le_bytes()
                    .to_vec()
            }),
        ),
        (
            1,
            words(&|i| ((i * 100) | ((60_000 - i) << 16)).to_le_bytes().to_vec()),
        ),
        (2, words(&|i| (i * 0x0102_0304).to_le_bytes().to_vec())),
        (3, words(&|i| vec![(i * 7) as u8])),
        (4, words(&|i| vec![255 - (i * 5) as u8])),
        (5, words(&|i| ((i * 300) as u16).to_le_bytes().to_vec())),
    ]
}

/// The tree's nodes on each of levels `0 ..= depth` (the last: its leaves), from its node
/// array in canonical order (section 4).
fn tree_level_counts(nodes: &[[u32; 2]], depth: u8) -> Vec<u64> {
    let mut counts = vec![0u64; usize::from(depth) + 1];
    let mut level = vec![0usize];
    for l in 0..usize::from(depth) {
        counts[l] = level.len() as u64;
        let mut next = Vec::new();
        for &i in &level {
            let [info, first] = nodes[i];
            let k = (info & 0xFF).count_ones();
            if (first as i32) < 0 {
                counts[l + 1] += u64::from(k);
            } else if info & 0xFF != 0 {
                next.extend(first as usize..(first + k) as usize);
            }
        }
        if l + 1 < usize::from(depth) {
            level = next;
        }
    }
    counts
}

/// `count` made-up values of `bits` bits as section 12's bit stream: for a normal of fewer
/// than 32 bits, two components in `-m ..= m`; for colours in 4 bits, blocks of 16 (64 bits,
/// a last block of `r` values `32 + 2 r`) of varying bits; else the element's bits of a
/// varying word.
fn packed_values(kind: u8, bits: u8, count: u64) -> Vec<u8> {
    if kind == 2 && bits == 4 {
        let total = 64 * (count / 16)
            + if !count.is_multiple_of(16) {
                32 + 2 * (count % 16)
            } else {
                0
            };
        let bitv: Vec<bool> = (0..total).map(|i| (i * 7 + i / 5) % 3 == 0).collect();
        return pack_bits(&bitv);
    }
    let b = u32::from(bits);
    let value = |i: u64| -> u64 {
        if kind == 0 && b < 32 {
            let h = b / 2;
            let m = (1i64 << (h - 1)) - 1;
            let comp = |k: i64| ((i as i64 * k) % (2 * m + 1) - m) as u64 & ((1 << h) - 1);
            comp(37) | comp(11) << h
        } else if kind == 0 {
            // Valid normal words: no 0x8000 half.
            (i * 1000 % 30_000) | (30_000 - i * 700 % 30_000) << 16
        } else {
            (i.wrapping_mul(0x0102_0304)) & ((1u64 << b) - 1)
        }
    };
    let mut bitv = Vec::new();
    for i in 0..count {
        let v = value(i);
        bitv.extend((0..b).map(|k| v >> k & 1 == 1));
    }
    pack_bits(&bitv)
}

/// `p` (of the DAG layout) with the channel `kind` stored on `level` in `bits` bits (made-up
/// values, `extra` bytes more than its count needs), every other channel that is not a
/// constant left out, or kept per leaf with `keep_per_leaf`.
fn on_level(p: &Parts, kind: u8, level: u8, bits: u8, keep_per_leaf: bool) -> Parts {
    let mut q = p.clone();
    let count = tree_level_counts(&q.nodes, q.depth)[usize::from(level)];
    q.channels.retain(|(k, s)| {
        *k == kind
            || matches!(s, Stored::Constant(_) | Stored::Packed { .. })
            || (keep_per_leaf && (*k != 1 || kind == 0))
    });
    let packed = Stored::Packed {
        level,
        bits,
        bytes: packed_values(kind, bits, count),
    };
    match q.channels.iter_mut().find(|(k, _)| *k == kind) {
        Some(c) => c.1 = packed,
        None => {
            q.channels.push((kind, packed));
            q.channels.sort_by_key(|c| c.0);
        }
    }
    q
}

/// The corpus, in manifest order.
pub fn corpus() -> Vec<Entry> {
    let t = Trees::new();
    let mut out = valid_files(&t);
    let mut invalid = |check: u8, name: &str, what: &str, bytes: Vec<u8>| {
        out.push(Entry {
            name: format!("check-{check:02}-{name}.svo"),
            bytes,
            check: Some(check),
            what: what.into(),
        });
    };
    preamble(&t, &mut invalid);
    header_encoding(&t, &mut invalid);
    header_values(&t, &mut invalid);
    layout(&t, &mut invalid);
    tree(&t, &mut invalid);
    values(&t, &mut invalid);
    version_3_header(&t, &mut invalid);
    version_3_chunks(&t, &mut invalid);
    edge_rules(&t, &mut invalid);
    version_4(&t, &mut invalid);
    dag_layout(&t, &mut invalid);
    values_on_a_level(&t, &mut invalid);
    out
}

/// Invalid files of section 12's values on a level.
fn values_on_a_level(t: &Trees, invalid: &mut Invalid<'_>) {
    let torus = t.torus.as_dag();
    let depth = torus.depth;
    let good = on_level(&torus, 0, depth - 2, 16, false);
    invalid(
        10,
        "values-tree-layout",
        "a channel stored on a level (variant 2) in a version-2 file",
        on_level(&t.varied, 2, 2, 32, true).encode(),
    );
    invalid(
        10,
        "values-odd-bits",
        "the DAG layout: normals on a level in 15 bits (an odd number)",
        on_level(&torus, 0, depth - 2, 15, false).encode(),
    );
    invalid(
        10,
        "values-colour-bits",
        "the DAG layout: colours on a level in 8 bits (a colour takes 32, 16 or 4)",
        on_level(&torus, 2, depth - 2, 8, false).encode(),
    );
    invalid(
        10,
        "values-level-0",
        "the DAG layout: normals on level 0",
        on_level(&torus, 0, 0, 16, false).encode(),
    );
    invalid(
        10,
        "values-contour-above",
        "the DAG layout: contours on a level above the leaves",
        on_level(&good, 1, depth - 2, 32, false).encode(),
    );
    invalid(
        10,
        "values-two-levels",
        "the DAG layout: colours on a level, normals per leaf",
        on_level(&t.varied.as_dag(), 2, 2, 32, true).encode(),
    );
    invalid(
        17,
        "values-length",
        "the DAG layout: a channel on a level a byte longer than its level's values",
        from(&good, &|p| {
            if let Some((_, Stored::Packed { bytes, .. })) =
                p.channels.iter_mut().find(|c| c.0 == 0)
            {
                bytes.push(0);
            }
        }),
    );
    // Colours in 4 bits are blocks: a stream of 4 bits a value is too short for a level whose
    // count is not a multiple of 16.
    let varied = t.varied.as_dag();
    let count = tree_level_counts(&varied.nodes, varied.depth)[2];
    assert_ne!(count % 16, 0);
    invalid(
        17,
        "values-colour-blocks",
        "the DAG layout: colours on a level in 4 bits, the stream 4 bits a value instead of blocks",
        from(&on_level(&varied, 2, 2, 4, false), &|p| {
            if let Some((_, Stored::Packed { bytes, .. })) =
                p.channels.iter_mut().find(|c| c.0 == 2)
            {
                bytes.truncate((count * 4).div_ceil(8) as usize);
            }
        }),
    );
    // A level whose values end inside a byte, for a bit after the last one.
    // The constant tree's five leaves in 6 bits end inside a byte.
    let five = t.constant.as_dag();
    assert_eq!(five.leaf_count * 6 % 8, 6);
    invalid(
        18,
        "values-trailing-bit",
        "the DAG layout: a bit set after the last value of a channel on a level",
        from(&on_level(&five, 0, five.depth, 6, true), &|p| {
            if let Some((_, Stored::Packed { bytes, .. })) =
                p.channels.iter_mut().find(|c| c.0 == 0)
            {
                *bytes.last_mut().expect("values") |= 0x80;
            }
        }),
    );
    invalid(
        18,
        "values-lone-component",
        "the DAG layout: a normal in 16 bits whose x component alone is -128 (the interior value)",
        from(&good, &|p| {
            if let Some((_, Stored::Packed { bytes, .. })) =
                p.channels.iter_mut().find(|c| c.0 == 0)
            {
                bytes[0] = 0x80;
                bytes[1] = 0x00;
            }
        }),
    );
}

/// What adds an invalid file: the check it fails, its name, what is wrong, its bytes.
type Invalid<'a> = dyn FnMut(u8, &str, &str, Vec<u8>) + 'a;

/// `base` changed by `f`, with the right checksum.
fn sealed(base: &[u8], f: &dyn Fn(&mut Vec<u8>)) -> Vec<u8> {
    let mut b = base.to_vec();
    f(&mut b);
    reseal(&mut b);
    b
}

/// `p` changed by `f`, encoded.
fn from(p: &Parts, f: &dyn Fn(&mut Parts)) -> Vec<u8> {
    let mut p = p.clone();
    f(&mut p);
    p.encode()
}

/// The valid files.
fn valid_files(t: &Trees) -> Vec<Entry> {
    let mut out = Vec::new();
    let mut valid = |name: &str, what: &str, parts: &Parts| {
        out.push(Entry {
            name: format!("valid-{name}.svo"),
            bytes: parts.encode(),
            check: None,
            what: what.into(),
        });
    };
    let Trees {
        varied,
        constant,
        torus,
        solid,
        none,
        empty,
        single,
        deepest,
        with_scene,
        v1,
        chunked,
        leafy,
        deepest_chunked,
        levels,
        levels_bake,
        ..
    } = t;
    valid(
        "per-leaf",
        "every channel per leaf (normals, contours, colours, reflectivity, refractivity, IOR), depth 3, 12 leaves",
        varied,
    );
    valid(
        "constant",
        "every channel a constant, depth 2, 5 leaves",
        constant,
    );
    valid(
        "absent",
        "no channel at all: every leaf takes the defaults",
        none,
    );
    valid(
        "bake",
        "a torus of 256 triangles baked at depth 4: per-leaf normals and contours, constant colour and materials",
        torus,
    );
    valid(
        "solid",
        "the same torus filled: interior leaves (normal word 0x80008000, whole-cell contour)",
        solid,
    );
    valid(
        "empty",
        "an empty tree: one root node without children, no leaves",
        empty,
    );
    valid(
        "single-leaf",
        "depth 1, one leaf: the root refers to it",
        single,
    );
    valid(
        "depth-30",
        "the deepest tree: depth 30, three leaves at opposite corners",
        deepest,
    );
    valid("scene", "two lights and two camera views", with_scene);
    valid(
        "camera-up-subnormal-square",
        "the scene's first view with up (0, 1e-160, 0): up . up is subnormal, its reciprocal square root finite",
        &{
            let mut p = with_scene.clone();
            p.scene.cameras[0].up = [0.0, 1e-160, 0.0];
            p
        },
    );
    valid(
        "version-1",
        "version 1 (no lights or views in the header)",
        v1,
    );
    valid(
        "chunked",
        "version 3: the per-leaf tree in chunks at level 1 (each chunk a tree of its own, its leaves from 0)",
        chunked,
    );
    valid(
        "chunked-level-0",
        "version 3: the baked torus as one chunk at level 0, the whole tree",
        &torus.chunked(0),
    );
    valid(
        "chunked-leaf-parents",
        "version 3: chunks at level depth - 1, each one leaf parent",
        leafy,
    );
    valid(
        "chunked-empty",
        "version 3: the empty tree, no chunk and no node",
        &empty.chunked(1),
    );
    valid(
        "chunked-depth-30",
        "version 3: the depth-30 tree in chunks at level 21, the deepest chunk level",
        deepest_chunked,
    );
    let v4 = |p: &Parts| {
        let mut p = p.clone();
        p.version = 4;
        p
    };
    valid(
        "levels",
        "version 4: the per-leaf tree level by level, every inner-node channel per node (levels 0 and 1)",
        levels,
    );
    valid(
        "levels-bake",
        "version 4: the torus baked with its inner nodes' attributes: per-node normals and contours, constant colour and materials",
        levels_bake,
    );
    valid(
        "levels-constant",
        "version 4: every channel a constant, for the leaves and the inner nodes",
        &{
            let mut p = v4(constant);
            p.node_channels = p.channels.clone();
            p
        },
    );
    valid(
        "levels-no-node-channels",
        "version 4: the per-leaf tree level by level, no inner-node channels",
        &v4(varied),
    );
    valid(
        "levels-empty",
        "version 4: the empty tree, levels 1 and 2 without nodes",
        &v4(empty),
    );
    valid(
        "levels-single-leaf",
        "version 4: depth 1 with per-node channels: level 0 is the leaf parents', which keep no values",
        &{
            let mut p = v4(single);
            p.node_channels = p
                .channels
                .iter()
                .map(|(kind, _)| {
                    let size = [4, 4, 4, 1, 1, 2][usize::from(*kind)];
                    (*kind, Stored::PerLeaf(vec![0; size]))
                })
                .collect();
            p
        },
    );
    valid(
        "levels-depth-30",
        "version 4: the depth-30 tree, 30 levels",
        &v4(deepest),
    );
    valid(
        "dag",
        "version 4's DAG layout: the per-leaf tree of depth 3, the root's mask and brick references, then its bricks",
        &varied.as_dag(),
    );
    valid(
        "dag-bake",
        "version 4's DAG layout: the baked torus (depth 4: the root, its distinct children, their bricks), per-leaf channels",
        &torus.as_dag(),
    );
    valid(
        "dag-root-brick",
        "version 4's DAG layout at depth 2: the root is the one brick",
        &constant.as_dag(),
    );
    valid(
        "dag-empty",
        "version 4's DAG layout: the empty tree, the root's mask 0 and no bricks",
        &empty.as_dag(),
    );
    valid(
        "dag-depth-30",
        "version 4's DAG layout: the depth-30 tree, 28 levels of nodes above its bricks",
        &deepest.as_dag(),
    );
    let torus_dag = t.torus.as_dag();
    let d = torus_dag.depth;
    valid(
        "dag-values-level",
        "the DAG layout: the baked torus's normals on level depth - 2, 16 bits each (its other channels constants)",
        &on_level(&torus_dag, 0, d - 2, 16, false),
    );
    valid(
        "dag-values-leaves",
        "the DAG layout: the baked torus's normals on the leaves' level in 10 bits, its contours per leaf",
        &on_level(&torus_dag, 0, d, 10, true),
    );
    valid(
        "dag-values-colour",
        "the DAG layout: the varied tree's colours on level 2 (32 bits), its other channels left out",
        &on_level(&t.varied.as_dag(), 2, 2, 32, false),
    );
    valid(
        "dag-values-colour-16",
        "the DAG layout: the varied tree's colours on level 2 in 16 bits (R5G6B5), its other channels left out",
        &on_level(&t.varied.as_dag(), 2, 2, 16, false),
    );
    valid(
        "dag-values-colour-4",
        "the DAG layout: the varied tree's colours on level 2 in 4 bits (one block of fewer than 16), its other channels left out",
        &on_level(&t.varied.as_dag(), 2, 2, 4, false),
    );

    out
}

/// The invalid files of checks 1 to 5: the preamble and the checksum.
fn preamble(t: &Trees, invalid: &mut Invalid<'_>) {
    let Trees { base, .. } = t;
    let sealed = |f: &dyn Fn(&mut Vec<u8>)| sealed(&t.base, f);
    // 1-5: preamble and checksum.
    invalid(
        1,
        "magic",
        "the second magic byte is `s`",
        sealed(&|b| b[1] = b's'),
    );
    invalid(
        1,
        "magic-prefix",
        "the first 5 bytes of the magic alone",
        base[..5].to_vec(),
    );
    invalid(
        2,
        "size",
        "the first 20 bytes of a file",
        base[..20].to_vec(),
    );
    invalid(
        3,
        "version-newer",
        "version 5",
        sealed(&|b| put(b, 8, &5u32.to_le_bytes())),
    );
    invalid(
        3,
        "version-zero",
        "version 0",
        sealed(&|b| put(b, 8, &0u32.to_le_bytes())),
    );
    invalid(
        4,
        "header-length-limit",
        "a header length of 65,537",
        sealed(&|b| put(b, 12, &65_537u32.to_le_bytes())),
    );
    invalid(
        4,
        "header-length-past-checksum",
        "a header that would end inside the checksum",
        sealed(&|b| {
            let h = (b.len() - 16 - 8 + 1) as u32;
            put(b, 12, &h.to_le_bytes());
        }),
    );
    let mut flipped = base.clone();
    flipped[pad8(16 + header_len(base)) + 3] ^= 0x10;
    invalid(5, "checksum", "one bit of the node array flipped", flipped);
}

/// The invalid files of check 6: the header's encoding.
fn header_encoding(t: &Trees, invalid: &mut Invalid<'_>) {
    let Trees { varied, .. } = t;
    let sealed = |f: &dyn Fn(&mut Vec<u8>)| sealed(&t.base, f);
    // 6: the header's encoding.
    invalid(
        6,
        "storage-variant",
        "a channel's storage variant is 2",
        sealed(&|b| put(b, at::FIRST_CHANNEL + 1, &2u32.to_le_bytes())),
    );
    invalid(
        6,
        "header-length-long",
        "the header length counts one byte more than the header holds",
        sealed(&|b| {
            let h = header_len(b);
            b.insert(16 + h, 0);
            put(b, 12, &(h as u32 + 1).to_le_bytes());
        }),
    );
    invalid(6, "string-utf8", "the generator string is not UTF-8", {
        let mut p = varied.clone();
        p.generator = "svo \u{7f}".into();
        let mut b = p.encode();
        let h = header_len(&b);
        let at = b[16..16 + h]
            .windows(5)
            .position(|w| w == b"svo \x7f")
            .expect("generator")
            + 16;
        b[at + 4] = 0xff;
        reseal(&mut b);
        b
    });
}

/// The invalid files of checks 7 to 11: the header's values.
fn header_values(t: &Trees, invalid: &mut Invalid<'_>) {
    let Trees {
        varied,
        constant,
        with_scene,
        ..
    } = t;
    let sealed = |f: &dyn Fn(&mut Vec<u8>)| sealed(&t.base, f);
    // 7-11: header values.
    invalid(7, "depth-zero", "depth 0", sealed(&|b| b[at::DEPTH] = 0));
    invalid(7, "depth-31", "depth 31", sealed(&|b| b[at::DEPTH] = 31));
    invalid(
        8,
        "side-zero",
        "a root side of 0",
        from(varied, &|p| p.side = 0.0),
    );
    invalid(
        8,
        "origin-nan",
        "a NaN in the root origin",
        from(varied, &|p| p.origin[1] = f64::NAN),
    );
    invalid(
        8,
        "side-infinite",
        "an infinite root side",
        from(varied, &|p| p.side = f64::INFINITY),
    );
    invalid(
        8,
        "origin-plus-side-overflow",
        "a root origin of 1e308 and side of 1e308: each finite, their sum (the far corner) not",
        from(varied, &|p| {
            p.origin[2] = 1e308;
            p.side = 1e308;
        }),
    );
    invalid(
        9,
        "no-nodes",
        "a node count of 0",
        sealed(&|b| put(b, at::NODE_COUNT, &0u64.to_le_bytes())),
    );
    invalid(
        9,
        "leaves-per-node",
        "more than 8 leaves for each node (every channel constant, so no array grows)",
        from(constant, &|p| p.leaf_count = 8 * p.node_count + 1),
    );
    invalid(
        9,
        "leaves-2-31",
        "2^31 + 1 leaves",
        from(constant, &|p| p.leaf_count = (1 << 31) + 1),
    );
    invalid(
        10,
        "kind-unknown",
        "channel kind 6",
        from(constant, &|p| p.channels.push((6, Stored::Constant(0)))),
    );
    invalid(
        10,
        "kind-order",
        "the colour channel listed before the contour",
        from(constant, &|p| p.channels.swap(1, 2)),
    );
    invalid(
        10,
        "kind-repeated",
        "the IOR channel twice",
        from(constant, &|p| p.channels.push((5, Stored::Constant(1)))),
    );
    invalid(
        10,
        "constant-range",
        "a reflectivity constant of 256",
        from(constant, &|p| p.channels[3].1 = Stored::Constant(256)),
    );
    invalid(
        10,
        "contour-without-normal",
        "a contour channel and no normal channel",
        from(constant, &|p| {
            p.channels.remove(0);
        }),
    );
    invalid(
        11,
        "light-nan",
        "a light at a NaN position",
        from(with_scene, &|p| p.scene.lights[0].position[2] = f64::NAN),
    );
    invalid(
        11,
        "light-negative",
        "a light of negative intensity",
        from(with_scene, &|p| p.scene.lights[1].intensity = -1.0),
    );
    invalid(
        11,
        "camera-up",
        "a view whose up is along its view direction",
        from(with_scene, &|p| p.scene.cameras[0].up = [0.0, 0.0, -2.0]),
    );
    invalid(
        11,
        "camera-up-overflow",
        "a view whose up (0, 1e200, 0) has a square that overflows: w is 0",
        from(with_scene, &|p| p.scene.cameras[0].up = [0.0, 1e200, 0.0]),
    );
    invalid(
        11,
        "camera-up-underflow",
        "a view whose up (0, 1e-170, 0) has a square that underflows to 0: w is 0",
        from(with_scene, &|p| p.scene.cameras[0].up = [0.0, 1e-170, 0.0]),
    );
    invalid(
        11,
        "camera-eye",
        "a view whose eye is its target",
        from(with_scene, &|p| {
            p.scene.cameras[1].target = p.scene.cameras[1].eye
        }),
    );
    invalid(
        11,
        "camera-fov",
        "a field of view of 180 degrees",
        from(with_scene, &|p| p.scene.cameras[0].fov_deg = 180.0),
    );
    invalid(
        11,
        "camera-name",
        "a view name of 257 bytes",
        from(with_scene, &|p| p.scene.cameras[0].name = "v".repeat(257)),
    );
}

/// The invalid files of checks 12 and 13: where the arrays are.
fn layout(t: &Trees, invalid: &mut Invalid<'_>) {
    let Trees { varied, base, .. } = t;
    let sealed = |f: &dyn Fn(&mut Vec<u8>)| sealed(&t.base, f);
    // 12-13: layout.
    invalid(
        12,
        "gap",
        "8 zero bytes between the header and the node array",
        sealed(&|b| {
            let first = pad8(16 + header_len(b));
            b.splice(first..first, [0; 8]);
            for r in 0..7 {
                // every array moves by 8: the nodes and the six per-leaf channels
                let field = if r == 0 {
                    at::NODES_OFFSET
                } else {
                    at::FIRST_CHANNEL + 5 + (r - 1) * 21
                };
                let old = u64_at(b, field);
                put(b, field, &(old + 8).to_le_bytes());
            }
        }),
    );
    invalid(
        12,
        "trailing",
        "8 zero bytes between the last array and the checksum",
        sealed(&|b| {
            let end = b.len() - 8;
            b.splice(end..end, [0; 8]);
        }),
    );
    invalid(
        12,
        "node-length",
        "the node array's length is not 8 times the node count",
        sealed(&|b| put(b, at::NODE_COUNT, &(varied.node_count - 1).to_le_bytes())),
    );
    invalid(
        12,
        "order",
        "the normal and contour arrays swapped",
        sealed(&|b| {
            let (n, c) = (at::FIRST_CHANNEL + 5, at::FIRST_CHANNEL + 5 + 21);
            let no = b[n..n + 8].to_vec();
            let co = b[c..c + 8].to_vec();
            put(b, n, &co);
            put(b, c, &no);
        }),
    );
    invalid(
        12,
        "truncated",
        "the file cut in its last array, its checksum recomputed",
        {
            let mut b = base[..base.len() - 8 - 16].to_vec();
            seal(&mut b);
            b
        },
    );
    invalid(
        13,
        "padding-header",
        "a padding byte after the header is 1",
        {
            let h = header_len(base);
            assert!(
                pad8(16 + h) > 16 + h,
                "the per-leaf file's header needs padding"
            );
            sealed(&|b| b[16 + h] = 1)
        },
    );
    invalid(
        13,
        "padding-array",
        "a padding byte after the reflectivity array is 1",
        {
            let refl = at::FIRST_CHANNEL + 5 + 3 * 21;
            let off = u64_at(base, refl) as usize;
            sealed(&|b| b[off + 12] = 1)
        },
    );
}

/// The invalid files of checks 14 to 17: the tree.
fn tree(t: &Trees, invalid: &mut Invalid<'_>) {
    let Trees { varied, .. } = t;
    // 14-17: the tree.
    invalid(
        14,
        "reserved-bits",
        "bit 8 of the root's info set",
        from(varied, &|p| p.nodes[0][0] |= 0x100),
    );
    invalid(
        15,
        "childless",
        "a node other than the root without children",
        from(varied, &|p| {
            let (i, _, _) = leaf_parents(&p.nodes)[0];
            p.nodes[i][0] = 0;
        }),
    );
    invalid(
        15,
        "leaves-too-high",
        "the root refers to leaves in a depth-3 tree",
        from(varied, &|p| p.nodes[0][1] = (-1i32) as u32),
    );
    invalid(
        16,
        "breadth-first-order",
        "a valid tree with its children blocks in breadth-first order instead of the canonical order",
        from(varied, &|p| {
            p.nodes = breadth_first_order(&p.nodes, p.depth)
        }),
    );
    invalid(
        16,
        "cycle",
        "the root's children block starts at the root",
        from(varied, &|p| p.nodes[0][1] = 0),
    );
    invalid(
        16,
        "orphan",
        "an extra node that nothing refers to",
        from(varied, &|p| {
            p.nodes.push([1, (-1i32) as u32]);
            p.node_count += 1;
        }),
    );
    invalid(
        17,
        "leaf-order",
        "the first two leaf parents' leaves swapped, with their values, so every leaf keeps its data",
        from(varied, &|p| {
            let lp = leaf_parents(&p.nodes);
            let ((ia, ba, ka), (ib, bb, kb)) = (lp[0], lp[1]);
            assert!(bb == ba + ka, "the first two leaf parents are adjacent");
            // b's leaves first, then a's.
            p.nodes[ib][1] = (-(i64::from(ba)) - 1) as i32 as u32;
            p.nodes[ia][1] = (-(i64::from(ba + kb)) - 1) as i32 as u32;
            for (_, s) in &mut p.channels {
                if let Stored::PerLeaf(bytes) = s {
                    let size = bytes.len() / p.leaf_count as usize;
                    let (a0, b0, b1) = (
                        ba as usize * size,
                        bb as usize * size,
                        (bb + kb) as usize * size,
                    );
                    bytes[a0..b1].rotate_left(b0 - a0);
                }
            }
        }),
    );
    invalid(
        17,
        "leaf-count",
        "one leaf more than the tree refers to (and one more value in each array)",
        from(varied, &|p| {
            p.leaf_count += 1;
            for (_, s) in &mut p.channels {
                if let Stored::PerLeaf(bytes) = s {
                    let size = bytes.len() / (p.leaf_count as usize - 1);
                    let last = bytes[bytes.len() - size..].to_vec();
                    bytes.extend(last);
                }
            }
        }),
    );
}

/// The invalid files of check 18: the stored values.
fn values(t: &Trees, invalid: &mut Invalid<'_>) {
    let Trees {
        varied,
        constant,
        v1,
        ..
    } = t;
    // 18: values.
    let set_leaf = |p: &mut Parts, kind: u8, leaf: usize, v: u32| {
        for (k, s) in &mut p.channels {
            if *k == kind
                && let Stored::PerLeaf(bytes) = s
            {
                put(bytes, 4 * leaf, &v.to_le_bytes());
            }
        }
    };
    invalid(
        18,
        "normal-half",
        "a normal word with one half 0x8000",
        from(varied, &|p| set_leaf(p, 0, 3, 0x1234_8000)),
    );
    invalid(
        18,
        "interior-in-version-1",
        "the interior-leaf word 0x80008000 in a version-1 file",
        from(v1, &|p| set_leaf(p, 0, 3, 0x8000_8000)),
    );
    invalid(
        18,
        "contour-reversed",
        "a contour whose near plane is beyond its far plane",
        from(varied, &|p| set_leaf(p, 1, 5, 0x1000_2000)),
    );
    invalid(
        18,
        "interior-contour",
        "an interior leaf whose contour is not the whole cell",
        from(varied, &|p| {
            set_leaf(p, 0, 2, 0x8000_8000);
            set_leaf(p, 1, 2, 0xF000_0000);
        }),
    );
    invalid(
        18,
        "constant-normal-half",
        "a constant normal word with one half 0x8000",
        from(constant, &|p| {
            p.channels[0].1 = Stored::Constant(0x8000_0000)
        }),
    );
}

/// The invalid files of version 3 (section 10): its header and chunk table, broken in
/// the encoded bytes.
fn version_3_header(t: &Trees, invalid: &mut Invalid<'_>) {
    let Trees {
        chunked,
        deepest_chunked,
        ..
    } = t;
    // Version 3 (section 10): its header, chunk table and chunks.
    let chunk_sealed = |p: &Parts, f: &dyn Fn(&mut Vec<u8>)| sealed(&p.encode(), f);
    invalid(
        7,
        "chunk-level-depth",
        "version 3: a chunk level equal to the depth",
        chunk_sealed(chunked, &|b| b[at3::CHUNK_LEVEL] = 3),
    );
    invalid(
        7,
        "chunk-level-22",
        "version 3: chunk level 22 in a depth-30 tree (codes past 64 bits)",
        chunk_sealed(deepest_chunked, &|b| b[at3::CHUNK_LEVEL] = 22),
    );
    invalid(
        9,
        "chunk-count",
        "version 3: more chunks than the 8 cells at level 1 (and than nodes)",
        chunk_sealed(chunked, &|b| put(b, at3::CHUNK_COUNT, &9u64.to_le_bytes())),
    );
    invalid(
        12,
        "chunk-table-length",
        "version 3: the chunk table's length is not 24 times the chunk count",
        chunk_sealed(chunked, &|b| {
            let len = u64_at(b, at3::CHUNKS_LEN);
            put(b, at3::CHUNKS_LEN, &(len - 8).to_le_bytes());
        }),
    );
}

/// The invalid files of version 3 (section 10): its chunk records and chunks.
fn version_3_chunks(t: &Trees, invalid: &mut Invalid<'_>) {
    let Trees {
        constant,
        chunked,
        leafy,
        ..
    } = t;
    let table = |p: &Parts| p.chunks.clone().expect("chunks").1;
    assert!(
        table(chunked).len() >= 3,
        "the chunked file has chunks enough to break"
    );
    invalid(
        19,
        "chunk-order",
        "version 3: the first two chunk records swapped (codes decreasing)",
        from(chunked, &|p| {
            if let Some((_, t)) = &mut p.chunks {
                t.swap(0, 1);
            }
        }),
    );
    invalid(
        19,
        "chunk-code-range",
        "version 3: a chunk code of 8 at level 1",
        from(chunked, &|p| {
            if let Some((_, t)) = &mut p.chunks {
                let last = t.len() - 1;
                t[last][0] = 8;
            }
        }),
    );
    invalid(
        19,
        "chunk-no-nodes",
        "version 3: a chunk of no node, its nodes counted with the next chunk (the sums kept)",
        from(chunked, &|p| {
            if let Some((_, t)) = &mut p.chunks {
                t[1][1] += t[0][1];
                t[0][1] = 0;
            }
        }),
    );
    invalid(
        19,
        "chunk-leaf-sum",
        "version 3: the header counts one leaf more than the chunks (every channel constant)",
        from(&constant.chunked(1), &|p| p.leaf_count += 1),
    );
    invalid(
        15,
        "chunk-empty-root",
        "version 3: a chunk whose root has no children",
        from(leafy, &|p| p.nodes[1][0] = 0),
    );
    invalid(
        16,
        "chunk-global-first",
        "version 3: the second chunk's inner nodes point into the whole node array, not into the chunk's",
        from(chunked, &|p| {
            let t = table(p);
            let (start, n) = (t[0][1] as usize, t[1][1] as usize);
            for w in &mut p.nodes[start..start + n] {
                if (w[1] as i32) > 0 {
                    w[1] += start as u32;
                }
            }
        }),
    );
    invalid(
        17,
        "chunk-global-leaves",
        "version 3: the second chunk's leaves numbered as in the whole tree, not from 0",
        from(chunked, &|p| {
            let t = table(p);
            let (start, n, base) = (t[0][1] as usize, t[1][1] as usize, t[0][2] as i64);
            for w in &mut p.nodes[start..start + n] {
                if (w[1] as i32) < 0 {
                    w[1] = (i64::from(w[1] as i32) - base) as i32 as u32;
                }
            }
        }),
    );
}

/// The nodes of a valid tree in the order the walk of checks 15 and 16 visits them
/// (docs/format.md, section 9: a stack, the last child popped first).
fn walk_order(nodes: &[[u32; 2]], depth: u8) -> Vec<(usize, u8)> {
    let mut order = Vec::new();
    let mut stack = vec![(0usize, 0u8)];
    while let Some((i, level)) = stack.pop() {
        order.push((i, level));
        let [info, first] = nodes[i];
        let k = (info & 0xFF).count_ones() as usize;
        if k == 0 || level + 1 == depth {
            continue;
        }
        stack.extend((0..k).map(|j| (first as usize + j, level + 1)));
    }
    order
}

/// The invalid files of the rules for edge cases: arrays of length 0, the empty tree's root,
/// constants without leaves, products past 2^64, and files that break checks 15 and 16 both.
fn edge_rules(t: &Trees, invalid: &mut Invalid<'_>) {
    let Trees {
        varied,
        empty,
        chunked,
        ..
    } = t;
    invalid(
        10,
        "empty-constant-range",
        "the empty tree with a reflectivity constant of 256 (constants are checked without leaves too)",
        from(empty, &|p| p.channels = vec![(3, Stored::Constant(256))]),
    );
    invalid(
        18,
        "empty-constant-normal-half",
        "the empty tree with a constant normal word whose half is 0x8000",
        from(empty, &|p| {
            p.channels = vec![(0, Stored::Constant(0x8000_0000))]
        }),
    );
    invalid(
        16,
        "empty-root-first",
        "the empty tree with its childless root's first 1 instead of 0",
        from(empty, &|p| p.nodes[0][1] = 1),
    );
    invalid(
        12,
        "chunk-empty-misplaced",
        "version 3: the empty tree's chunk table, of length 0, 8 bytes after where the layout puts it",
        sealed(&empty.chunked(1).encode(), &|b| {
            let off = u64_at(b, at3::CHUNKS_OFFSET);
            put(b, at3::CHUNKS_OFFSET, &(off + 8).to_le_bytes());
        }),
    );
    invalid(
        12,
        "chunk-node-length-overflow",
        "version 3: a node count of 2^61 + 1, whose node array's length 8 * node_count passes 2^64",
        sealed(&chunked.encode(), &|b| {
            put(b, at3::NODE_COUNT, &((1u64 << 61) + 1).to_le_bytes())
        }),
    );
    // Version 3's order: check 14 on the whole node array, then 15 and 16 on every chunk,
    // then 17 on every chunk.
    invalid(
        14,
        "chunk-before-15",
        "version 3: the first chunk's root without children (check 15) and a reserved bit in the last node (14): 14 is named",
        from(chunked, &|p| {
            p.nodes[0][0] = 0;
            let last = p.nodes.len() - 1;
            p.nodes[last][0] |= 0x100;
        }),
    );
    invalid(
        16,
        "chunk-before-17",
        "version 3: the first chunk's first leaf parent numbers its leaves from 1 (check 17) and the second chunk's inner nodes point into the whole node array (16): 16 is named",
        from(chunked, &|p| {
            let t = p.chunks.clone().expect("chunks").1;
            let (start, n) = (t[0][1] as usize, t[1][1] as usize);
            assert_eq!(
                p.nodes[1][1] as i32, -1,
                "the first leaf parent's leaves start at 0"
            );
            p.nodes[1][1] = (-2i32) as u32;
            for w in &mut p.nodes[start..start + n] {
                if (w[1] as i32) > 0 {
                    w[1] += start as u32;
                }
            }
        }),
    );
    let order = walk_order(&varied.nodes, varied.depth);
    let leaf_parents: Vec<usize> = order
        .iter()
        .filter(|&&(_, l)| l + 1 == varied.depth)
        .map(|&(i, _)| i)
        .collect();
    let inner: Vec<usize> = order
        .iter()
        .filter(|&&(_, l)| l > 0 && l + 1 < varied.depth)
        .map(|&(i, _)| i)
        .collect();
    let (first_leafy, last_leafy) = (leaf_parents[0], leaf_parents[leaf_parents.len() - 1]);
    let (first_inner, last_inner) = (inner[0], inner[inner.len() - 1]);
    invalid(
        15,
        "and-16-same-node",
        "the first leaf parent the walk meets refers to nodes, at 0: it breaks check 15 and 16 at one node, and 15 is named",
        from(varied, &|p| p.nodes[first_leafy][1] = 0),
    );
    invalid(
        15,
        "before-16",
        "the walk meets a childless leaf parent (check 15) before an inner node whose children block is one node late (16)",
        from(varied, &|p| {
            p.nodes[first_leafy][0] = 0;
            p.nodes[last_inner][1] += 1;
        }),
    );
    invalid(
        16,
        "before-15",
        "the walk meets an inner node whose children block is one node late (check 16) before a childless leaf parent (15)",
        from(varied, &|p| {
            p.nodes[first_inner][1] += 1;
            p.nodes[last_leafy][0] = 0;
        }),
    );
}

/// The file offsets of version-3 header fields (docs/format.md, section 3).
mod at3 {
    pub const CHUNK_LEVEL: usize = super::at::DEPTH + 1;
    pub const CHUNK_COUNT: usize = CHUNK_LEVEL + 1;
    pub const NODE_COUNT: usize = CHUNK_COUNT + 8;
    pub const CHUNKS_OFFSET: usize = CHUNK_COUNT + 3 * 8;
    pub const CHUNKS_LEN: usize = CHUNKS_OFFSET + 8;
}

/// The manifest: one line a file, tab-separated: name, `valid` or `invalid`, the check's
/// number and name (`-` for valid files), what the file holds or breaks.
pub fn manifest(corpus: &[Entry]) -> String {
    let mut s = String::from("# file\toutcome\tcheck\tcheck name\twhat\n");
    for e in corpus {
        let (outcome, number, name) = match e.check {
            None => ("valid", "-".to_string(), "-"),
            Some(n) => (
                "invalid",
                n.to_string(),
                svo::octree::Check::from_number(n).map_or("?", |c| c.name()),
            ),
        };
        s.push_str(&format!(
            "{}\t{outcome}\t{number}\t{name}\t{}\n",
            e.name, e.what
        ));
    }
    s
}

/// Offsets in a version-4 file of `levels`' header (depth 3): the layout byte and level `l`'s
/// entry.
mod at4 {
    /// `layout`: after the root cube (32 bytes) and the depth.
    pub const LAYOUT: usize = 16 + 33;
    /// Level `l`'s entry: after `node_count`, `leaf_count` and the list's length.
    pub const fn level(l: usize) -> usize {
        16 + 34 + 16 + 8 + 32 * l
    }
}

/// The invalid version-4 files: checks 20 to 22, and the others where version 4 differs.
fn version_4(t: &Trees, invalid: &mut Invalid<'_>) {
    let base = t.levels.encode();
    let resealed = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = base.clone();
        f(&mut b);
        reseal_v4(&mut b);
        b
    };
    invalid(
        20,
        "header-checksum",
        "version 4: one bit of the header checksum flipped (the file's checksum right)",
        sealed(&base, &|b| {
            let h = header_len(b);
            b[16 + h] ^= 1;
        }),
    );
    invalid(
        21,
        "layout",
        "version 4: layout 2, which is reserved",
        resealed(&|b| b[at4::LAYOUT] = 2),
    );
    invalid(
        21,
        "level-0",
        "version 4: 2 nodes on level 0",
        resealed(&|b| put(b, at4::level(0), &2u64.to_le_bytes())),
    );
    invalid(
        21,
        "level-growth",
        "version 4: 9 nodes on level 1 under a root",
        resealed(&|b| put(b, at4::level(1), &9u64.to_le_bytes())),
    );
    invalid(
        21,
        "level-sum",
        "version 4: one node more on level 2 than the header's node count allows",
        resealed(&|b| {
            let n = u64_at(b, at4::level(2)) + 1;
            put(b, at4::level(2), &n.to_le_bytes());
        }),
    );
    invalid(
        12,
        "level-block",
        "version 4: level 1's block said to start 8 bytes later",
        resealed(&|b| {
            let o = u64_at(b, at4::level(1) + 8) + 8;
            put(b, at4::level(1) + 8, &o.to_le_bytes());
        }),
    );
    invalid(
        22,
        "level-checksum",
        "version 4: one bit of level 1's checksum flipped",
        resealed(&|b| b[at4::level(1) + 24] ^= 1),
    );
    invalid(
        22,
        "level-data",
        "version 4: one bit of level 1's normals flipped (the header and file checksums right)",
        resealed(&|b| {
            let o = u64_at(b, at4::level(1) + 8) as usize;
            let n = u64_at(b, at4::level(1)) as usize;
            b[pad8(o + 8 * n)] ^= 1;
        }),
    );
    invalid(
        16,
        "level-order",
        "version 4: the nodes in the canonical depth-first order instead of level order",
        from(&t.levels, &|p| p.level_order = false),
    );
    invalid(
        10,
        "node-channel-kinds",
        "version 4: inner-node channels without the IOR the leaves have",
        from(&t.levels, &|p| {
            p.node_channels.pop();
        }),
    );
    invalid(
        10,
        "node-constant",
        "version 4: an inner-node reflectivity constant of 256",
        from(&t.levels, &|p| p.node_channels[3].1 = Stored::Constant(256)),
    );
    invalid(
        18,
        "node-contour",
        "version 4: the root's contour has its near plane beyond its far plane",
        from(&t.levels, &|p| {
            if let Stored::PerLeaf(v) = &mut p.node_channels[1].1 {
                v[..4].copy_from_slice(&0x1000_2000u32.to_le_bytes());
            }
        }),
    );
    invalid(
        18,
        "node-interior-word",
        "version 4: a level-1 node's normal is the interior-leaf word 0x80008000",
        from(&t.levels, &|p| {
            if let Stored::PerLeaf(v) = &mut p.node_channels[0].1 {
                v[4..8].copy_from_slice(&0x8000_8000u32.to_le_bytes());
            }
        }),
    );
}

/// The invalid files of version 4's DAG layout (section 12), most of them the baked torus's
/// graph (depth 4: level 0 the root, level 1 its distinct children, level 2 their bricks)
/// with its level checksums, header checksum and checksum made right after the edit.
fn dag_layout(t: &Trees, invalid: &mut Invalid<'_>) {
    let base = t.torus.as_dag().encode();
    // The word or brick `i` of level `l`, and its place in the file.
    let at = |b: &[u8], l: usize, i: usize, size: usize| {
        u64_at(b, at4::level(l) + 8) as usize + size * i
    };
    let edited = |bytes: &[u8], f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = bytes.to_vec();
        f(&mut b);
        for l in 0..usize::from(b[16 + 32]).saturating_sub(1) {
            let (o, len) = (
                u64_at(&b, at4::level(l) + 8) as usize,
                u64_at(&b, at4::level(l) + 16) as usize,
            );
            if o + len <= b.len() {
                let h = xxhash_rust::xxh3::xxh3_64(&b[o..o + len]);
                put(&mut b, at4::level(l) + 24, &h.to_le_bytes());
            }
        }
        reseal_v4(&mut b);
        b
    };
    // The field of `width` bits at bit `bit` of level `l`'s block.
    let field = |b: &[u8], l: usize, bit: usize, width: u32| {
        (0..width as usize).fold(0u32, |v, i| {
            let x = at(b, l, 0, 1) * 8 + bit + i;
            v | u32::from(b[x / 8] >> (x % 8) & 1) << i
        })
    };
    let set_field = |b: &mut Vec<u8>, l: usize, bit: usize, width: u32, v: u32| {
        let base = at(b, l, 0, 1) * 8;
        for i in 0..width as usize {
            let x = base + bit + i;
            b[x / 8] = b[x / 8] & !(1 << (x % 8)) | ((v >> i & 1) as u8) << (x % 8);
        }
    };
    let count = |b: &[u8], l: usize| u64_at(b, at4::level(l));
    // The torus's graph: the root, level 1's nodes (references to the bricks), the bricks.
    let (w0, w1) = (
        reference_bits(count(&base, 1)),
        reference_bits(count(&base, 2)),
    );
    let root_ref = |j: usize| 8 + j * w0 as usize;
    // The bits level 1's nodes take.
    let root_kids = field(&base, 0, 0, 8).count_ones() as usize;
    let constant = t.constant.as_dag().encode();
    invalid(
        9,
        "dag-leaves-2-48",
        "the DAG layout: the empty tree's header says 2^48 + 1 leaves",
        edited(&t.empty.as_dag().encode(), &|b| {
            put(b, 16 + 42, &((1u64 << 48) + 1).to_le_bytes())
        }),
    );
    invalid(
        21,
        "dag-depth-1",
        "the DAG layout at depth 1 (its bricks need two levels)",
        edited(&constant, &|b| b[16 + 32] = 1),
    );
    invalid(
        21,
        "dag-node-channels",
        "the DAG layout with inner-node channels in the header",
        from(&t.varied.as_dag(), &|p| p.node_channels = node_values(p)),
    );
    invalid(
        12,
        "dag-block-length",
        "the DAG layout: level 0's block said to be a byte longer than its one node can take (a mask byte and 8 references)",
        edited(&base, &|b| {
            let n = 1 + u64::from(w0) + 1;
            put(b, at4::level(0) + 16, &n.to_le_bytes());
        }),
    );
    // A node level whose block ends before the next multiple of 8 and could be a byte longer
    // (within check 12): that byte of padding counted in the block, 8 bits after the last node.
    let len = |b: &[u8], l: usize| u64_at(b, at4::level(l) + 16);
    let longer = (0..2)
        .find(|&l| {
            let w = [w0, w1][l];
            len(&base, l) % 8 != 0 && len(&base, l) < count(&base, l) * (1 + u64::from(w))
        })
        .expect("a node level with room for a byte more");
    invalid(
        14,
        "dag-trailing-byte",
        "the DAG layout: a level's block a zero byte longer than its nodes (8 bits after the last node)",
        edited(&base, &|b| {
            let n = len(b, longer) + 1;
            put(b, at4::level(longer) + 16, &n.to_le_bytes());
        }),
    );
    invalid(
        15,
        "dag-childless",
        "the DAG layout: the first node of level 1 has mask 0",
        edited(&base, &|b| set_field(b, 1, 0, 8, 0)),
    );
    invalid(
        15,
        "dag-empty-brick",
        "the DAG layout: brick 0 holds no leaf",
        edited(&base, &|b| {
            let o = at(b, 2, 0, 8);
            put(b, o, &0u64.to_le_bytes());
        }),
    );
    // A reference past the next level's nodes, on a level whose width holds one: the first
    // reference of the first node of such a level, in the torus's graph or the solid torus's.
    let (graph, l) = [&base, &t.solid.as_dag().encode()]
        .into_iter()
        .find_map(|g| {
            let levels = usize::from(g[16 + 32]) - 2;
            (0..levels)
                .find(|&l| 1u64 << reference_bits(count(g, l + 1)) > count(g, l + 1))
                .map(|l| (g.clone(), l))
        })
        .expect("a graph with a level whose references have room past its next level");
    invalid(
        16,
        "dag-pointer",
        "the DAG layout: a node's first child refers to an index past the next level's nodes",
        edited(&graph, &|b| {
            let below = count(b, l + 1);
            set_field(b, l, 8, reference_bits(below), below as u32);
        }),
    );
    invalid(
        16,
        "dag-first-reference",
        "the DAG layout: the root's first two children swapped (the second node of level 1 referred to before the first)",
        edited(&base, &|b| {
            let (x, y) = (field(b, 0, root_ref(0), w0), field(b, 0, root_ref(1), w0));
            set_field(b, 0, root_ref(0), w0, y);
            set_field(b, 0, root_ref(1), w0, x);
        }),
    );
    invalid(
        16,
        "dag-twice",
        "the DAG layout: brick 1 equal to brick 0",
        edited(&base, &|b| {
            let (o0, o1) = (at(b, 2, 0, 8), at(b, 2, 1, 8));
            let v = b[o0..o0 + 8].to_vec();
            put(b, o1, &v);
        }),
    );
    invalid(
        16,
        "dag-orphan",
        "the DAG layout: the root's last child made its previous one, so the last node of level 1 is referred to by none",
        edited(&base, &|b| {
            let k = root_kids;
            let w = field(b, 0, root_ref(k - 2), w0);
            set_field(b, 0, root_ref(k - 1), w0, w);
        }),
    );
    // One node more on level 1: a node past level 1's block, or (where the count passes a
    // power of two) the root's references a bit wider, past level 0's block; check 16 either way.
    invalid(
        16,
        "dag-count",
        "the DAG layout: the level table (and the node count) says level 1 holds one node more than its block",
        edited(&base, &|b| {
            let n = u64_at(b, at4::level(1)) + 1;
            put(b, at4::level(1), &n.to_le_bytes());
            let all = u64_at(b, 16 + 34) + 1;
            put(b, 16 + 34, &all.to_le_bytes());
        }),
    );
    invalid(
        17,
        "dag-leaf-count",
        "the DAG layout: the header says one leaf more than the root brick holds (every channel a constant)",
        edited(&constant, &|b| {
            let n = u64_at(b, 16 + 42) + 1;
            put(b, 16 + 42, &n.to_le_bytes());
        }),
    );
}
