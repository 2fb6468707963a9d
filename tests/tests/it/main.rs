//! End-to-end tests on real meshes and scenes, one binary: determinism across threads and
//! runs, the format's conformance corpus against the reader and a reader written from
//! `docs/format.md` alone, the glTF sample models, the 2019 report's scene and the seed
//! documents' scenes.

mod determinism;
mod format_conformance;
mod gltf_samples;
mod report_scene;
mod seed_scenes;
