//! The `svo-bake` library: the bake as the command runs it, file to file. The bake itself
//! (voxelization, attributes, the bake in parts) is `svo`'s; this crate adds what exists
//! because the command does:
//!
//! - [`job`]: a bake job ([`job::BakeJob`]: input, output, options, threads, memory) and
//!   [`job::bake_file`], which loads a mesh, scene or `.svo`, bakes it (in memory, or in parts
//!   within a memory budget, also by itself when the bake in memory would not fit) and writes
//!   `.svo`, `.binvox` or `.vox` atomically;
//! - [`report`]: what a bake did ([`report::BakeReport`]), as text and JSON;
//! - [`memory`]: what the machine's memory allows (Linux `/proc`).
#![forbid(unsafe_code)]

pub mod job;
pub mod memory;
pub mod report;
