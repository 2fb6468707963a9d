//! # svo: exact sparse voxel octrees from triangle meshes
//!
//! Bake a mesh into a sparse voxel octree that holds exactly the cells its triangles touch,
//! with per-leaf normals, colours, materials and contours; save it in a compact, versioned,
//! validated file; and cast rays through it or render it with a Whitted ray tracer
//! (reflections, refractions, shadows), on the CPU here and on the GPU in `svo-view`.
//!
//! ```
//! use svo::prelude::*;
//! # let path = std::env::temp_dir().join(format!("svo-front-page-{}.obj", std::process::id()));
//! # std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")?;
//! let mesh = Mesh::load(&path)?; // .obj, .obj.gz, .ply, .gltf, .glb
//! let (tree, _stats) = bake_mesh(&mesh, &BakeOptions::default())?; // 256^3 cells, exact
//! tree.save(path.with_extension("svo"))?; // atomically; Octree::load validates
//! let hit = tree.cast(Ray::new(DVec3::new(0.2, 0.2, -1.0), DVec3::Z)).expect("a hit");
//! println!("t = {}, point = {}, normal = {}", hit.t, hit.point, hit.normal); // scene units
//! # assert!((hit.t - 1.0).abs() < 0.01 && hit.normal == -DVec3::Z);
//! # std::fs::remove_file(&path)?;
//! # std::fs::remove_file(path.with_extension("svo"))?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Where things are
//!
//! - [`Mesh`] ([`mesh`]): the triangles with their materials, loaded from a path, bytes or
//!   a reader; [`scene`]: TOML scene files (meshes, primitives, lights, views, CSG).
//! - [`bake_mesh`] ([`bake`]): mesh to [`Octree`], with [`BakeOptions`] (depth, [`Strategy`],
//!   channels, padding, solid fill) and [`BakeStats`]; [`bake::parts`] bakes in parts, on
//!   many machines or within a memory budget. [`voxelize`] has the exact triangle/cell tests
//!   the voxelizer is made of.
//! - [`Octree`] ([`octree`]): the packed nodes and leaf channels, queries in scene units
//!   ([`Octree::leaf_at_point`], [`Octree::leaves`]), and trees built from cells or a
//!   function ([`Octree::from_cells`], [`Octree::from_fn`]).
//! - [`io`]: the `.svo` file ([`Octree::save`], [`Octree::load`], bytes, readers and
//!   writers), `.binvox` and MagicaVoxel `.vox` exports.
//! - [`trace`]: rays in scene units ([`Octree::cast`], [`Octree::cast_many`]) and the
//!   traversal beneath them, with a callback per leaf.
//! - [`render`]: cameras, lights, the Whitted tracer, images and their comparison, and the
//!   scene setup every renderer of a tree starts from ([`render::RenderScene`]).
//!
//! ## Cargo features
//!
//! All on by default except `csg`: `obj`, `ply`, `gltf` (importers), `parallel` (rayon),
//! `io` (the file formats), `vox` (MagicaVoxel export), `trace` (rays and the CPU
//! renderer), `image-io` (image files), `reference` (the triangle renderer images are
//! measured against), `solid` (solid voxelization), `scene` (TOML scene files), and `csg`
//! (CSG in scene files through the Manifold kernel: C++, needs cmake and ninja). With
//! `default-features = false` the crate builds octrees in memory and nothing else.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unreachable_pub)]
#![cfg_attr(docsrs, feature(doc_cfg))]

mod attributes;
pub mod bake;
pub mod dag;
mod geometry;
mod import;
#[cfg(feature = "io")]
pub mod io;
pub mod mesh;
pub mod octree;
#[cfg(feature = "trace")]
pub mod render;
#[cfg(feature = "scene")]
pub mod scene;
mod solid;
#[cfg(feature = "io")]
mod thread_pool;
#[cfg(feature = "trace")]
pub mod trace;
pub mod voxelize;

pub mod prelude;

// The differential checks of the importers, for the fuzz targets (`cargo fuzz` builds with
// `--cfg fuzzing`) and this repository's tests on the shared meshes (the hidden
// `differential` feature); not part of the API.
#[cfg(all(
    any(fuzzing, feature = "differential"),
    any(feature = "obj", feature = "ply")
))]
#[doc(hidden)]
pub use import::differential as fuzz_import;

pub use bake::{BakeError, BakeOptions, BakeStats, ChannelSelection, SolidMode, bake_mesh};
#[cfg(feature = "io")]
pub use io::{BuildInfo, FormatError};
pub use mesh::{Material, Mesh, MeshError, MeshFormat};
pub use octree::{
    Channel, ChannelKind, Leaf, LeafAttributes, LeafValue, Node, Octree, OctreeError, RootCube,
    Voxel,
};
#[cfg(feature = "io")]
pub use thread_pool::{ThreadsError, with_threads};
#[cfg(feature = "trace")]
pub use trace::{Hit, HitMode, Ray};
pub use voxelize::Strategy;

// The README's example is compiled with the doc tests.
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
struct ReadmeExamples;

/// The deepest tree the library builds: cells are addressed by `u32` coordinates and grid
/// space must stay exact in `f64` far below a cell.
pub const MAX_DEPTH: u8 = 30;
