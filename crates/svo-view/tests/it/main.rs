//! The viewer's integration tests, one binary: the shaders checked on the CPU through naga,
//! the GPU against the CPU reference (lavapipe without a GPU; without an adapter they print a
//! notice and pass, except under CI), the command line's headless, CPU and `--info` paths,
//! and the window under Xvfb (feature `window`).

mod common;
mod gpu_layout;
mod gpu_vs_cpu;
mod headless_cli;
mod info;
mod render_cli;
mod window_xvfb;
