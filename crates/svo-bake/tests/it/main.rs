//! The baker's integration tests, one binary: the command line (bakes, exports, conversions,
//! bakes in parts and within a memory budget, bad input) and the bake in parts on a Slurm
//! cluster of one node.

mod cli;
mod slurm;

fn main() -> std::process::ExitCode {
    let mut tests = cli::trials();
    tests.extend(slurm::trials());
    svo_tests::harness::main(tests)
}
