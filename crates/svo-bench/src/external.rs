//! Side-by-side baselines from other tools, run when they are installed: open3d's voxelizer
//! and Embree's single-ray throughput, through the Python scripts in `docs/bench/`. Where a
//! tool is missing the report says so instead of quoting an old figure.

use std::path::{Path, PathBuf};
use std::process::Command;
use svo::camera::Camera;

/// The folder of the baseline scripts (`docs/bench` of this repository).
pub fn scripts() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/bench")
}

/// Whether `python3` can import every module named.
pub fn python_has(modules: &[&str]) -> bool {
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

/// Runs `open3d_voxelize.py` on `mesh` at `depths` (a gzipped mesh is unpacked into `dir`
/// first: open3d reads no `.gz`); also returns open3d's version line.
pub fn open3d(mesh: &Path, depths: &[u8], dir: &Path) -> anyhow::Result<(String, Vec<Open3d>)> {
    let script = scripts().join("open3d_voxelize.py");
    let mesh = if mesh.extension().is_some_and(|e| e == "gz") {
        let o = Command::new("gzip").arg("-dc").arg(mesh).output()?;
        if !o.status.success() {
            anyhow::bail!("gzip -dc {} failed", mesh.display());
        }
        let stem = mesh
            .file_stem()
            .map_or_else(|| "mesh.obj".into(), std::ffi::OsStr::to_os_string);
        let out = dir.join(stem);
        std::fs::write(&out, o.stdout)?;
        out
    } else {
        mesh.to_path_buf()
    };
    let mut args = vec![
        script.to_string_lossy().into_owned(),
        mesh.to_string_lossy().into_owned(),
    ];
    args.extend(depths.iter().map(u8::to_string));
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = run(&a)?;
    let mut lines = out.lines();
    let head = lines.next().unwrap_or_default().to_string();
    let rows = lines
        .filter_map(|l| {
            let depth = l.strip_prefix("depth ")?.split(' ').next()?.parse().ok()?;
            let ms = number_before(l, " ms")?;
            let voxels = number_before(l, " voxels")? as usize;
            Some(Open3d {
                depth,
                seconds: ms / 1e3,
                voxels,
            })
        })
        .collect();
    Ok((head, rows))
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
    }
}
