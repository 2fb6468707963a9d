//! The test harness of the integration tests that need something of the machine (the shared
//! meshes, a GPU adapter, Xvfb, Slurm): each test names what it needs, the harness checks
//! each need once before running anything, and a test whose need is unmet is reported by the
//! runner as ignored, its reason printed, instead of passing without testing. Under CI
//! ([`crate::under_ci`]) nothing may be skipped: such a test runs and fails naming the need.
//!
//! Built on libtest-mimic, so the output, filters and flags are `cargo test`'s. A test binary
//! using it sets `harness = false` and lists its tests with [`trial!`](crate::trial); a test
//! function left out of the list is dead code, which the lints reject.

use libtest_mimic::{Arguments, Failed, Trial};
use std::collections::HashMap;
use std::process::ExitCode;
use std::sync::Arc;

/// Something a test needs from the machine, and how to check for it.
#[derive(Clone)]
pub struct Need {
    what: String,
    check: Arc<dyn Fn() -> Result<(), String> + Send + Sync>,
}

impl Need {
    /// A need checked by `check` (`Err` says why it is unmet); `what` names it in the report
    /// and is the key under which its check runs once.
    pub fn new(
        what: impl Into<String>,
        check: impl Fn() -> Result<(), String> + Send + Sync + 'static,
    ) -> Self {
        Self {
            what: what.into(),
            check: Arc::new(check),
        }
    }

    /// The shared mesh `rel` inside [`crate::models_dir`].
    pub fn model(rel: &'static str) -> Self {
        Self::new(format!("the shared mesh {rel}"), move || {
            let p = crate::models_dir().join(rel);
            if p.is_file() {
                Ok(())
            } else {
                Err(format!(
                    "{} is missing (set SVO_MODELS to the models folder)",
                    p.display()
                ))
            }
        })
    }

    /// The thesis's pool scene's bunny, where `examples/scenes/pool.toml` looks for it.
    pub fn pool_scene() -> Self {
        Self::new("the pool scene's bunny", || {
            crate::pool_scene_bunny().map(|_| ()).ok_or_else(|| {
                "stanford/bun_zipper.ply is in neither $SVO_MODELS nor ../shared/models".into()
            })
        })
    }

    /// An executable named `name` on `PATH`.
    pub fn tool(name: &'static str, install: &'static str) -> Self {
        Self::new(format!("{name} ({install})"), move || {
            crate::find_tool(name)
                .map(|_| ())
                .ok_or_else(|| format!("{name} is not on PATH"))
        })
    }
}

/// One test: its name, its body (a panic fails it) and what it needs.
pub struct Test {
    name: String,
    run: Box<dyn FnOnce() + Send>,
    needs: Vec<Need>,
}

impl Test {
    /// A test named `name` running `run`, needing `needs`.
    pub fn new(
        name: impl Into<String>,
        run: impl FnOnce() + Send + 'static,
        needs: &[Need],
    ) -> Self {
        Self {
            name: name.into(),
            run: Box::new(run),
            needs: needs.to_vec(),
        }
    }
}

/// A [`harness::Test`](Test) of the function `f` (named by its module path inside the test
/// binary) needing the [`Need`]s after it.
#[macro_export]
macro_rules! trial {
    ($f:path $(, $need:expr)* $(,)?) => {
        $crate::harness::Test::new(
            $crate::harness::test_name(module_path!(), stringify!($f)),
            $f,
            &[$($need),*],
        )
    };
}

/// `crate::module` and `f` -> `module::f` (the name libtest would give).
pub fn test_name(module: &str, f: &str) -> String {
    match module.split_once("::") {
        Some((_, m)) => format!("{m}::{f}"),
        None => f.to_string(),
    }
}

/// Runs `tests` as `cargo test` runs a test binary: each need checked once, tests with an
/// unmet need ignored (their reasons on stderr) or, under CI, failed.
pub fn main(tests: Vec<Test>) -> ExitCode {
    let args = Arguments::from_args();
    let ci = crate::under_ci();
    let mut checked: HashMap<String, Result<(), String>> = HashMap::new();
    let trials = tests
        .into_iter()
        .map(|t| {
            let unmet: Vec<String> = t
                .needs
                .iter()
                .filter_map(|n| {
                    let r = checked.entry(n.what.clone()).or_insert_with(|| (n.check)());
                    r.as_ref().err().map(|why| format!("{}: {why}", n.what))
                })
                .collect();
            let shown = args
                .filter
                .as_ref()
                .is_none_or(|f| t.name.contains(f.as_str()));
            trial(t, &unmet, ci, shown && !args.list)
        })
        .collect();
    libtest_mimic::run(&args, trials).exit_code()
}

/// The libtest-mimic trial of `t`, whose needs in `unmet` are not there (`say`: print why
/// it is ignored).
fn trial(t: Test, unmet: &[String], ci: bool, say: bool) -> Trial {
    let Test { name, run, .. } = t;
    if unmet.is_empty() {
        return Trial::test(name, move || {
            run();
            Ok(())
        });
    }
    let why = unmet.join("; ");
    if ci {
        return Trial::test(name, move || Err(Failed::from(format!("CI needs {why}"))));
    }
    if say {
        eprintln!("ignored {name}: needs {why}");
    }
    Trial::test(name, move || Err(Failed::from(format!("needs {why}")))).with_ignored_flag(true)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    /// `#[test]` in a binary without libtest is compiled out: a test written that way would
    /// never run. Every test of these binaries goes through [`super::main`].
    #[test]
    fn the_harness_binaries_have_no_libtest_tests() {
        fn walk(dir: &Path, files: &mut Vec<std::path::PathBuf>) {
            for e in std::fs::read_dir(dir).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    walk(&p, files);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    files.push(p);
                }
            }
        }
        let root = crate::repo_root();
        let mut files = Vec::new();
        for d in [
            "crates/svo-view/tests/it",
            "crates/svo-bake/tests/it",
            "tests/tests/it",
        ] {
            walk(&root.join(d), &mut files);
        }
        assert!(files.len() > 10, "{files:?}");
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap();
            assert!(
                !text.lines().any(|l| l.trim_start().starts_with("#[test]")),
                "{}: #[test] in a harness = false binary never runs; list it in trials()",
                f.display()
            );
        }
    }
}
