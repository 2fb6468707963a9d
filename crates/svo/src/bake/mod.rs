//! Baking: a mesh to an octree with its attributes and contours ([`bake_mesh`]), checked
//! first (valid mesh, depth, a memory estimate against a limit, a closed mesh for a closed
//! solid bake), with timings and statistics ([`BakeStats`]); the voxelization alone
//! ([`voxelize_mesh`]: the leaf cells and the triangles touching each); and a file to a file
//! ([`bake_file`], with the `io` feature: a mesh or scene file to `.svo`, `.binvox` or
//! `.vox`, or an `.svo` converted), which is what `svo-bake` runs.
//!
//! Depends on every folder below it: [`crate::mesh`], the importers, [`crate::voxelize`],
//! the attributes, the solid fill, [`crate::octree`], and for [`bake_file`] [`crate::io`]
//! and [`crate::scene`].

pub(crate) mod bake_mesh;
#[cfg(feature = "io")]
pub(crate) mod bins;
#[cfg(feature = "io")]
pub(crate) mod bounded;
pub(crate) mod estimate;
#[cfg(feature = "io")]
pub(crate) mod merge;
#[cfg(feature = "io")]
pub(crate) mod part;
#[cfg(feature = "io")]
pub(crate) mod pipeline;
#[cfg(feature = "io")]
pub(crate) mod plan;

pub use crate::attributes::{ChannelSelection, ContourStats};
pub use crate::solid::SolidMode;
pub use crate::voxelize::Strategy;
pub use crate::voxelize::build::LeafTriangles;
pub use bake_mesh::{
    BakeError, BakeOptions, BakeStats, Phase, available_memory, bake_mesh, bake_mesh_with_progress,
    estimate_bake, voxelize_mesh,
};
#[cfg(feature = "io")]
pub use bins::{BinsReport, bin_path, read_bin, write_bins};
#[cfg(feature = "io")]
pub use bounded::{PartsReport, bake_planned, peak_resident, plan_for_budget};
pub use estimate::Estimate;
#[cfg(feature = "io")]
pub use merge::{MergeFormat, MergeReport, merge_parts};
#[cfg(feature = "io")]
pub use part::{
    PartData, PartHeader, PartReport, bake_part_file, bake_parts, read_part_header, write_part,
};
#[cfg(feature = "io")]
pub use pipeline::{
    BakeJob, BakeReport, GivenOptions, OutputFormat, PipelineError, bake_file,
    bake_file_with_progress,
};
#[cfg(feature = "io")]
pub use plan::{
    BakePlan, PartsError, hash_file, part_path, plan_bake, plan_file, read_plan, write_plan,
};
