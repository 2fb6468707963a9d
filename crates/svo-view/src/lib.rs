//! The `svo-view` library: the viewer's jobs and its GPU side. The CPU reference tracer, the
//! file format and the scene setup live in `svo`; this crate adds the render jobs as the
//! command takes them and what needs wgpu.
//!
//! - [`job`]: a render job (the file, the flags' settings, what to write), its checks, and
//!   the output and cube-map files;
//! - [`cpu_render`]: `svo-view --cpu`, the job on the CPU reference tracer;
//! - [`report`]: what a render did ([`report::FrameReport`]), on the CPU or the GPU;
//! - [`timing`]: the benchmark loops;
//! - [`gpu_types`]: the structs shared with the WGSL shader and the shader variant
//!   (pipeline-overridable constants that leave out what a scene does not need);
//! - [`gpu_context`]: the adapter and device, and [`gpu_context::GpuError`];
//! - [`gpu_tree`]: what the GPU traces, a tree or its graph (a DAG file read as one);
//! - [`gpu_render`]: the tree's buffers, the compute pipeline, a frame and its read-back;
//! - [`fit`]: a tree larger than the adapter shown from the deepest prefix of its levels that
//!   fits;
//! - [`shader`]: the tracer's shader, WESL modules linked into WGSL for a walk, with the
//!   constants it shares with Rust generated from their values;
//! - [`wide_view`]: the tree's 64-ary view, which the GPU's traversal can walk instead of
//!   the octree;
//! - [`headless`]: `svo-view --headless`, a render job on the GPU, optionally compared with
//!   the CPU reference;
//! - [`camera_control`]: the window's orbit and fly camera;
//! - [`window_blit`]: showing a frame's pixel buffer on a surface;
//! - `window` (feature `window`, on by default): `svo-view FILE`, the interactive window
//!   (winit, egui overlay).
//!
//! The shader (`src/shaders/trace/*.wesl`) ports `svo`'s traversal, leaf hits and Whitted
//! loop; the golden tests (`tests/it/gpu_vs_cpu.rs`) hold the two to the same images.

pub mod camera_control;
pub mod cpu_render;
pub mod fit;
pub mod gpu_context;
pub mod gpu_render;
pub mod gpu_tree;
pub mod gpu_types;
pub mod headless;
pub mod job;
pub mod report;
pub mod shader;
pub mod timing;
pub mod wide_view;
#[cfg(feature = "window")]
pub mod window;
pub mod window_blit;
