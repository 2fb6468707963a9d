//! A bake in parts (`docs/bake-in-parts.md`): a tree too large for one process's memory,
//! or wanted from many machines, baked as the subtrees under one level of the octree,
//! grouped into parts that any process bakes alone, then merged into the `.svo` file the
//! bake in memory would write, byte for byte.
//!
//! - [`plan_file`] plans a mesh file's bake in a number of parts and writes the plan (the
//!   mesh's path and hash, the options, each part's subtrees), optionally with each part's
//!   triangles in a file of its own;
//! - [`bake_part_file`] bakes one part of a plan into its file ([`part_path`]), on any
//!   machine that sees the plan and the mesh; run twice, the same bytes;
//! - [`merge_parts`] streams the parts into the `.svo` file (version 2, or version 3's chunks
//!   past 2^31 leaves; or reduces them into one graph, version 4's DAG layout, with
//!   [`MergeFormat::Dag`]), refusing a missing, foreign, truncated or damaged part;
//! - [`bake_within`] does all three in one process within a memory budget.
//!
//! Inside: `plan.rs` (the cut at a level, the plan file), `bins.rs` (each part's triangles
//! in a file of its own), `part.rs` (a part's subtrees, built by the same recursion as the
//! whole bake, and the part file), `part_levels.rs` (a part's nodes level by level, with the
//! inner nodes' values), `merge.rs` (the streamed merge, through the writer's
//! layout), `merge_levels.rs` (the merge into version 4's levels), `merge_dag.rs` (the merge
//! into the DAG layout) and `bounded.rs` (parts one after another within a memory budget).

pub(crate) mod bins;
pub(crate) mod bounded;
pub(crate) mod merge;
pub(crate) mod merge_dag;
pub(crate) mod merge_levels;
pub(crate) mod part;
pub(crate) mod part_levels;
pub(crate) mod plan;
#[cfg(test)]
mod tests;

pub use bins::BinsReport;
pub use bounded::{PartsReport, bake_within, remove_leftovers};
pub use merge::{MergeFormat, MergeReport, merge_parts};
pub use part::{PartReport, bake_part_file};
pub use plan::{BakePlan, PartsError, part_path, plan_file};
