//! The library's integration tests, one binary: each module a subject, all of them held to
//! references that share no code with the library (`svo_tests`: the exact voxelization
//! oracle, the integer separating-axis test, the rational ray reference, the fuzz checks).
//! Seeded tests draw their seeds through `svo_tests::seeds`, so `SVO_TEST_SEED` moves them
//! all to new random cases for a soak.

mod alpha_cut;
mod attributes;
mod bake_sliced;
mod deep_precision;
mod deep_trees;
mod exact_oracle;
mod format_dag;
mod format_levels;
mod format_roundtrip;
mod fuzz_regressions;
mod gltf_scene;
mod golden_images;
mod level_of_detail;
mod node_attributes;
mod octree_bruteforce;
mod overlap_exact;
mod render;
mod render_extremes;
mod solid;
mod traversal_bruteforce;
mod traversal_dda;

/// What the modules share, from the support crate.
mod common {
    pub use svo_tests::exact_sat::*;
    pub use svo_tests::geometry::*;
    pub use svo_tests::{fuzz_cases, oracle, ray_check, ray_reference};
}
