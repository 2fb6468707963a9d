//! Images: a Whitted ray tracer over the octree (reflections, refractions, shadows through
//! glass), with a camera, point lights, Phong shading, Fresnel, a sky, and per-pixel outputs
//! (depth, normal, leaf, traversal cost); the triangle reference it is measured against
//! ([`MeshSurfaces`]); image comparison (RMSE, PSNR) and image files (PNG, PFM, OpenEXR);
//! and the scene setup every renderer of a tree starts from ([`RenderScene`]: camera, lights
//! and sky with a viewer's defaults).
//!
//! ```
//! use glam::{DVec3, UVec3};
//! use svo::render::{Camera, OctreeSurfaces, Tracer, render};
//! use svo::{HitMode, Octree, RootCube, Voxel};
//! let root = RootCube { origin: DVec3::ZERO, side: 1.0 };
//! let tree = Octree::from_cells(root, 3, [(UVec3::splat(4), Voxel::default())])?;
//! let tracer = Tracer::new(OctreeSurfaces::new(&tree, HitMode::Cube), &[], Default::default(),
//!                          Default::default(), Default::default());
//! let camera = Camera::framing(root.origin, root.origin + 1.0, 64, 48, 40.0);
//! let frame = render(&tracer, &camera)?;
//! assert_eq!((frame.width, frame.height), (64, 48));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The tracer is generic over [`Surfaces`]: the octree ([`OctreeSurfaces`], its leaves hit as
//! cubes, contour slabs or, with [`exact_surfaces`], the mesh's triangles) and the triangle
//! reference render through the same camera, lights and shading, so their difference is the
//! voxels' error. Primary rays are decided a band of rows at a time by projecting the octree
//! front to back (`TraceOptions::prepass`), with the traversal's own plane tests: the same
//! image as tracing each ray from the eye.
//!
//! Depends on [`crate::trace`] (the traversal), [`crate::octree`], [`crate::mesh`], and for
//! files [`crate::io`]. Built with the `trace` feature; image files need `image-io`, the
//! triangle reference `reference`.

pub(crate) mod aov;
pub(crate) mod camera;
pub(crate) mod chunked_surfaces;
pub(crate) mod dag_surfaces;
pub(crate) mod exact_surfaces;
pub(crate) mod frame;
pub(crate) mod image_compare;
#[cfg(feature = "image-io")]
pub(crate) mod image_write;
pub(crate) mod leaf_values;
#[cfg(feature = "reference")]
pub(crate) mod mesh_reference;
pub(crate) mod primary_cast;
pub(crate) mod primary_prepass;
pub(crate) mod setup;
pub(crate) mod shading;
pub(crate) mod sky;
pub(crate) mod surfaces;
pub(crate) mod surfaces_error;
pub(crate) mod whitted;

pub use aov::{Aov, colour_rgb8, cost_rgb8};
pub use camera::{Camera, CameraError, CameraRays};
pub use chunked_surfaces::{ChunkTree, ChunkedSurfaces};
pub use dag_surfaces::DagSurfaces;
pub use exact_surfaces::{ExactLeaves, exact_surfaces};
pub use frame::{Frame, NO_LEAF, RenderStats, render, render_into};
pub use image_compare::{ImageDiff, compare};
#[cfg(feature = "image-io")]
pub use image_write::{ImageWriteError, read_pfm, write_float, write_png};
#[cfg(feature = "reference")]
pub use mesh_reference::MeshSurfaces;
pub use primary_cast::{Hits, cast_primary};
pub use setup::{LightSpec, MAX_TRACE_DEPTH, RenderScene, SceneSetup, SetupError, Stage};
pub use shading::{Phong, PointLight};
pub use sky::{CubeMap, Sky};
pub use surfaces::{
    LeafShape, Medium, NODE_ID, OctreeSurfaces, Query, Skip, SurfaceHit, SurfaceMaterial, Surfaces,
    Traced, Walked,
};
pub use surfaces_error::SurfacesError;
pub use whitted::{
    FresnelMode, MAX_BOUNCES, Sample, SampleStats, ShadowMode, TraceOptions, Tracer,
};
