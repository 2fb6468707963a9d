//! Side-by-side baselines from other tools, run when they are installed: open3d's voxelizer
//! and Embree's single-ray throughput, through the Python scripts in `docs/bench/`. Where a
//! tool is missing the report says so instead of quoting an old figure.

use std::io::{BufRead, BufReader, Lines, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use svo::render::Camera;

/// The folder of the baseline scripts (`docs/bench` of this repository).
pub fn scripts() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/bench")
}

/// A baseline tool run through Python: its name, the modules it needs and how to install
/// them.
pub struct Baseline {
    /// The tool's name in the report.
    pub name: &'static str,
    /// The Python modules its script imports.
    pub modules: &'static [&'static str],
    /// The command that installs them.
    pub install: &'static str,
}

/// open3d's voxelizer (`docs/bench/open3d_voxelize.py`).
pub const OPEN3D: Baseline = Baseline {
    name: "open3d",
    modules: &["open3d", "numpy"],
    install: "pip install open3d",
};

/// Embree through embreex (`docs/bench/embree_primary.py`).
pub const EMBREE: Baseline = Baseline {
    name: "Embree",
    modules: &["embreex", "trimesh", "numpy"],
    install: "pip install embreex trimesh",
};

/// This repository's Python package, for the report's Python section
/// (`docs/bench/python_package.py`).
pub const PYTHON_PACKAGE: Baseline = Baseline {
    name: "the Python package",
    modules: &["svo", "numpy"],
    install: "pip install ./crates/svo-py open3d trimesh embreex",
};

impl Baseline {
    /// Whether its modules import here.
    pub fn available(&self) -> bool {
        python_has(self.modules)
    }
}

/// Whether `python3` can import every module named.
fn python_has(modules: &[&str]) -> bool {
    Command::new("python3")
        .args(["-c", &format!("import {}", modules.join(", "))])
        .output()
        .is_ok_and(|o| o.status.success())
}

fn run(args: &[&str]) -> anyhow::Result<String> {
    let o = Command::new("python3").args(args).output()?;
    if !o.status.success() {
        anyhow::bail!(
            "python3 {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&o.stderr).trim()
        );
    }
    Ok(String::from_utf8_lossy(&o.stdout).into_owned())
}

/// The number before `unit` in `line` (`"median 258.1 ms"` -> 258.1 for `" ms"`).
fn number_before(line: &str, unit: &str) -> Option<f64> {
    let end = line.find(unit)?;
    line[..end].rsplit(' ').next()?.parse().ok()
}

/// open3d's voxel set at `depth`: median ms of 5 runs and the voxel count.
#[derive(Clone, Copy, Debug)]
pub struct Open3d {
    /// Depth (grid `2^depth`).
    pub depth: u8,
    /// Median seconds.
    pub seconds: f64,
    /// Voxels.
    pub voxels: usize,
}

/// The mesh as open3d can read it: a gzipped mesh is unpacked into `dir` (open3d reads no
/// `.gz`).
fn open3d_input(mesh: &Path, dir: &Path) -> anyhow::Result<PathBuf> {
    if mesh.extension().is_none_or(|e| e != "gz") {
        return Ok(mesh.to_path_buf());
    }
    let o = Command::new("gzip").arg("-dc").arg(mesh).output()?;
    if !o.status.success() {
        anyhow::bail!("gzip -dc {} failed", mesh.display());
    }
    let stem = mesh
        .file_stem()
        .map_or_else(|| "mesh.obj".into(), std::ffi::OsStr::to_os_string);
    let out = dir.join(stem);
    std::fs::write(&out, o.stdout)?;
    Ok(out)
}

/// `open3d_voxelize.py --serve` on one mesh: open3d stays loaded and measures one depth
/// when asked, so that the caller's own runs sit between its runs in one sitting.
pub struct Open3dServer {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Lines<BufReader<ChildStdout>>,
    /// The script's first line ("PATH: N triangles, open3d X, T threads").
    pub head: String,
}

impl Open3dServer {
    /// Starts the script on `mesh` (`dir` receives an unpacked copy of a gzipped mesh).
    pub fn start(mesh: &Path, dir: &Path) -> anyhow::Result<Self> {
        let input = open3d_input(mesh, dir)?;
        let mut child = Command::new("python3")
            .arg(scripts().join("open3d_voxelize.py"))
            .arg(&input)
            .arg("--serve")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            anyhow::bail!("open3d_voxelize.py started without its pipes");
        };
        let mut lines = BufReader::new(stdout).lines();
        let head = match lines.next() {
            Some(line) => line?,
            None => anyhow::bail!("open3d_voxelize.py --serve ended before its first line"),
        };
        Ok(Self {
            child,
            stdin: Some(stdin),
            lines,
            head,
        })
    }

    /// open3d's voxel set at `depth`: the median of `runs` runs.
    pub fn measure(&mut self, depth: u8, runs: u32) -> anyhow::Result<Open3d> {
        let stdin = self
            .stdin
            .as_mut()
            .ok_or_else(|| anyhow::anyhow!("open3d_voxelize.py is closed"))?;
        writeln!(stdin, "{depth} {runs}")?;
        stdin.flush()?;
        let line = match self.lines.next() {
            Some(line) => line?,
            None => anyhow::bail!("open3d_voxelize.py ended without measuring depth {depth}"),
        };
        parse_open3d(&line)
            .filter(|o| o.depth == depth)
            .ok_or_else(|| anyhow::anyhow!("unexpected line from open3d_voxelize.py: {line}"))
    }
}

impl Drop for Open3dServer {
    fn drop(&mut self) {
        // Closing its input ends the script's loop.
        drop(self.stdin.take());
        let _ = self.child.wait();
    }
}

/// One result line of `open3d_voxelize.py`.
fn parse_open3d(l: &str) -> Option<Open3d> {
    let depth = l.strip_prefix("depth ")?.split(' ').next()?.parse().ok()?;
    let ms = number_before(l, " ms")?;
    let voxels = number_before(l, " voxels")? as usize;
    Some(Open3d {
        depth,
        seconds: ms / 1e3,
        voxels,
    })
}

/// Runs `embree_primary.py` for the camera (one thread): median seconds per frame and Mrays/s.
pub fn embree(mesh: &Path, cam: &Camera, runs: u32, dir: &Path) -> anyhow::Result<(f64, f64)> {
    let json = format!(
        "{{\"width\": {}, \"height\": {}, \"camera\": {{\"eye\": [{}, {}, {}], \"target\": [{}, {}, {}], \"up\": [{}, {}, {}], \"fov_deg\": {}}}}}",
        cam.width,
        cam.height,
        cam.eye.x,
        cam.eye.y,
        cam.eye.z,
        cam.target.x,
        cam.target.y,
        cam.target.z,
        cam.up.x,
        cam.up.y,
        cam.up.z,
        cam.fov_deg
    );
    let path = dir.join("camera.json");
    std::fs::write(&path, json)?;
    let script = scripts().join("embree_primary.py");
    let out = run(&[
        &script.to_string_lossy(),
        &mesh.to_string_lossy(),
        &path.to_string_lossy(),
        &runs.to_string(),
    ])?;
    let line = out
        .lines()
        .find(|l| l.starts_with("embree:"))
        .ok_or_else(|| anyhow::anyhow!("unexpected output from embree_primary.py: {out}"))?;
    let ms = number_before(line, " ms over").ok_or_else(|| anyhow::anyhow!("no time in {line}"))?;
    let mrays =
        number_before(line, " Mrays/s").ok_or_else(|| anyhow::anyhow!("no rate in {line}"))?;
    Ok((ms / 1e3, mrays))
}

#[cfg(test)]
mod tests {
    #[test]
    fn numbers_are_read_before_their_unit() {
        let l = "depth 8 (256^3): median 258.1 ms, 224718 voxels";
        assert_eq!(super::number_before(l, " ms"), Some(258.1));
        assert_eq!(super::number_before(l, " voxels"), Some(224_718.0));
        assert_eq!(super::number_before(l, " Mrays/s"), None);
        let o = super::parse_open3d(l).expect("a result line");
        assert_eq!((o.depth, o.voxels), (8, 224_718));
        assert!((o.seconds - 0.2581).abs() < 1e-12);
        assert!(super::parse_open3d("/x/bunny.obj: 69451 triangles, open3d 0.20.0").is_none());
    }
}
