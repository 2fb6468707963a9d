//! End-to-end tests on real meshes and scenes, one binary: determinism across threads and
//! runs, the format's conformance corpus against the reader and a reader written from
//! `docs/format.md` alone, the glTF sample models, the 2019 report's scene and the seed
//! documents' scenes.

mod determinism;
mod format_conformance;
mod gltf_samples;
mod real_meshes;
mod report_scene;
mod seed_scenes;

fn main() -> std::process::ExitCode {
    let mut tests = determinism::trials();
    tests.extend(format_conformance::trials());
    tests.extend(gltf_samples::trials());
    tests.extend(real_meshes::trials());
    tests.extend(report_scene::trials());
    tests.extend(seed_scenes::trials());
    svo_tests::harness::main(tests)
}
