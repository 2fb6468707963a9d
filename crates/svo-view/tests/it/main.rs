//! The viewer's integration tests, one binary: the shaders checked on the CPU through naga,
//! the GPU against the CPU reference (lavapipe without a GPU; without an adapter the harness
//! reports them ignored, except under CI, where they fail), the command line's headless, CPU
//! and `--info` paths, and the window under Xvfb (feature `window`).

mod common;
mod gpu_layout;
mod gpu_vs_cpu;
mod headless_cli;
mod info;
mod render_cli;
mod window_xvfb;

fn main() -> std::process::ExitCode {
    let mut tests = Vec::new();
    tests.extend(gpu_layout::trials());
    tests.extend(gpu_vs_cpu::trials());
    tests.extend(headless_cli::trials());
    tests.extend(info::trials());
    tests.extend(render_cli::trials());
    #[cfg(feature = "window")]
    tests.extend(window_xvfb::trials());
    svo_tests::harness::main(tests)
}
