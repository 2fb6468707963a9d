//! The Python package, tested as its users get it: a fresh virtual environment, the README's
//! one `pip install` command (built in this test build's profile, so that the libraries the
//! workspace's test build made are reused), the README's Python example run as written, and
//! the pytest suite (`tests/python/`), which holds the package to `svo-bake` and `svo-view`
//! (the test build's, or built here where it made none) and to brute-force references.
//!
//! Needs `python3` with `venv` and access to the Python package registry (for maturin,
//! NumPy, pytest, trimesh and Pillow): without them the harness reports the test ignored,
//! except under CI, where it fails.

use std::path::{Path, PathBuf};
use std::process::Command;
use svo_tests::harness::Need;
use svo_tests::trial;

fn main() -> std::process::ExitCode {
    svo_tests::harness::main(vec![trial!(
        the_package_installs_runs_the_readme_example_and_passes_pytest,
        python_need()
    )])
}

/// `python3` with the `venv` module.
fn python_need() -> Need {
    Need::new("python3 with venv (apt-get install python3-venv)", || {
        let ok = Command::new("python3")
            .args(["-c", "import venv, ensurepip"])
            .status()
            .map_err(|e| format!("python3: {e}"))?;
        if ok.success() {
            Ok(())
        } else {
            Err("python3 lacks the venv or ensurepip module".into())
        }
    })
}

/// Runs `cmd`, panicking with its output if it fails.
fn run(cmd: &mut Command) {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?} failed ({}):\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The folder of this test build's binaries (`target/debug` or `target/release`) and the
/// cargo profile that fills it.
fn build_dir() -> (PathBuf, &'static str) {
    let exe = std::env::current_exe().unwrap();
    // target/<profile>/deps/it-<hash>
    let dir = exe.parent().and_then(Path::parent).unwrap().to_path_buf();
    let profile = if dir.ends_with("release") {
        "release"
    } else {
        "dev"
    };
    (dir, profile)
}

/// The README's first ```python block.
fn readme_example(repo: &Path) -> String {
    let readme = std::fs::read_to_string(repo.join("README.md")).unwrap();
    let start = readme
        .find("```python\n")
        .expect("the README has a Python example")
        + 10;
    let len = readme[start..].find("```").unwrap();
    readme[start..start + len].to_string()
}

fn the_package_installs_runs_the_readme_example_and_passes_pytest() {
    let repo = svo_tests::repo_root();
    let (bin, profile) = build_dir();
    // The workspace's test build makes both programs; a test of this package alone builds
    // them (a build of its own would replace the test build's, whose features may differ).
    if !(bin.join("svo-bake").is_file() && bin.join("svo-view").is_file()) {
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        run(Command::new(&cargo)
            .current_dir(&repo)
            .args(["build", "-q", "--locked", "--profile", profile])
            .args(["-p", "svo-bake", "-p", "svo-view"]));
    }
    let tmp = tempfile::tempdir().unwrap();
    let venv = tmp.path().join("venv");
    run(Command::new("python3").arg("-m").arg("venv").arg(&venv));
    let py = venv.join("bin/python");
    // The README's command, from the repository's root.
    run(Command::new(&py)
        .current_dir(&repo)
        .args(["-m", "pip", "install", "-q", "--disable-pip-version-check"])
        .arg("./crates/svo-py[test]")
        .env("MATURIN_PEP517_ARGS", format!("--profile {profile}")));
    // The README's example, as written, where `fixtures/torus.obj` is.
    let work = tmp.path().join("example");
    std::fs::create_dir(&work).unwrap();
    std::os::unix::fs::symlink(repo.join("fixtures"), work.join("fixtures")).unwrap();
    std::fs::write(work.join("example.py"), readme_example(&repo)).unwrap();
    run(Command::new(&py).current_dir(&work).arg("example.py"));
    // The suite, held to the programs of this build.
    run(Command::new(&py)
        .current_dir(repo.join("crates/svo-py/tests/python"))
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .env("SVO_BAKE", bin.join("svo-bake"))
        .env("SVO_VIEW", bin.join("svo-view")));
}
