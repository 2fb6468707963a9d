//! Atomic file output: write to a temporary file beside the target, flush it to disk, then
//! rename it over the target. A failure or a kill at any moment leaves the old file or none,
//! never a partial one (a killed process may leave a `.NAME.*.tmp` file beside it; the next
//! write of the same file removes it once its own file is in place).
//!
//! Replacing a file frees the old one, and freeing a few MB of cached pages and blocks costs
//! about as much as writing them (0.6-0.8 ms of a 2.5-3.2 ms write of the depth-8 bunny's
//! 2.4 MB on this project's ext4 VM, `docs/performance.md`). On Linux the old file is
//! therefore held open across the rename (`O_PATH`: no access, and an open that cannot block,
//! whatever kind of file it is) and let go on a short-lived thread; if the process ends
//! first, the kernel lets go of it at exit. Nothing is left behind either way.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `path` atomically with what `write` produces.
pub(crate) fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let dir = parent_dir(path);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if name.is_empty() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "output path has no file name",
        ));
    }
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // A temporary file is private (0600); the output is an ordinary file, readable as any
    // file the user creates (0666 less the umask).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let tmp = builder.tempfile_in(dir)?;
    {
        let mut w = BufWriter::with_capacity(1 << 20, tmp.as_file());
        write(&mut w)?;
        w.flush()?;
    }
    tmp.as_file().sync_all()?;
    let replaced = hold_replaced(path);
    tmp.persist(path).map_err(|e| e.error)?;
    if let Some(old) = replaced {
        // If no thread can be started, the closure, and with it the handle, is dropped here.
        let _ = std::thread::Builder::new()
            .name("svo-unlink".into())
            .spawn(move || drop(old));
    }
    remove_stale(path);
    Ok(())
}

/// The folder `path` is written in (`.` for a bare file name).
pub(crate) fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Removes what killed writes of `path` left beside it: `.NAME.` + six random characters +
/// `.tmp`, as [`write_atomic`] names its temporary files. Returns what it removed.
pub(crate) fn remove_stale(path: &Path) -> Vec<PathBuf> {
    let prefix = format!(
        ".{}.",
        path.file_name().unwrap_or_default().to_string_lossy()
    );
    let Ok(entries) = std::fs::read_dir(parent_dir(path)) else {
        return Vec::new();
    };
    let mut removed = Vec::new();
    for e in entries.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        if name.len() == prefix.len() + 6 + 4
            && name.starts_with(&prefix)
            && name.ends_with(".tmp")
            && std::fs::remove_file(e.path()).is_ok()
        {
            removed.push(e.path());
        }
    }
    removed
}

/// Files below this size are freed faster than a thread starts.
#[cfg(target_os = "linux")]
const HOLD_MIN_BYTES: u64 = 1 << 20;

/// A handle on the regular file of at least [`HOLD_MIN_BYTES`] that `path` names, if any, so
/// that replacing it does not free it on the caller's time.
#[cfg(target_os = "linux")]
fn hold_replaced(path: &Path) -> Option<rustix::fd::OwnedFd> {
    use rustix::fs::{Mode, OFlags};
    let meta = std::fs::symlink_metadata(path).ok()?;
    if !meta.is_file() || meta.len() < HOLD_MIN_BYTES {
        return None;
    }
    // Whatever `path` names by now (it may have changed since the check) is only held, never
    // read: `O_PATH` opens no FIFO or device, and `O_NOFOLLOW` holds a symlink itself.
    rustix::fs::open(
        path,
        OFlags::PATH | OFlags::CLOEXEC | OFlags::NOFOLLOW,
        Mode::empty(),
    )
    .ok()
}

#[cfg(not(target_os = "linux"))]
fn hold_replaced(_: &Path) -> Option<()> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replacing_a_large_file_leaves_only_the_new_one() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("big.bin");
        let old = vec![7u8; 3 << 20];
        std::fs::write(&out, &old).unwrap();
        write_atomic(&out, |w: &mut dyn Write| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"new");
        // The old file is gone from the directory at once (only a handle held it), and no
        // temporary file is left.
        let names: Vec<_> = std::fs::read_dir(d.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["big.bin"]);
        // Replacing it again, now that it is small, takes the plain path.
        write_atomic(&out, |w: &mut dyn Write| w.write_all(&old)).unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), old);
    }

    #[test]
    fn a_killed_writes_leftover_goes_with_the_next_write_of_the_same_file() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("out.svo");
        // A killed write of out.svo's, and one of another file whose name starts alike.
        let stale = d.path().join(".out.svo.AbC123.tmp");
        let other = d.path().join(".out.svo.bak.AbC123.tmp");
        for f in [&stale, &other] {
            std::fs::write(f, b"partial").unwrap();
        }
        write_atomic(&out, |w: &mut dyn Write| w.write_all(b"new")).unwrap();
        assert!(!stale.exists() && other.exists());
        assert_eq!(std::fs::read(&out).unwrap(), b"new");
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_in_the_way_is_replaced_without_blocking() {
        // Opening a FIFO for reading would wait for a writer; the size check and `O_PATH`
        // keep the write from ever opening it so.
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("pipe");
        // `mkfifo` is POSIX (coreutils on Linux): every Unix has it.
        let status = std::process::Command::new("mkfifo").arg(&out).status();
        assert!(
            status.as_ref().is_ok_and(std::process::ExitStatus::success),
            "mkfifo failed: {status:?}"
        );
        write_atomic(&out, |w: &mut dyn Write| w.write_all(b"abc")).unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"abc");
    }

    #[test]
    fn output_has_ordinary_permissions() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("x.bin");
        write_atomic(&out, |w: &mut dyn Write| w.write_all(b"abc")).unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"abc");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // The same mode a plainly created file gets under this process's umask.
            let plain = d.path().join("plain");
            std::fs::write(&plain, b"").unwrap();
            let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode(&out), mode(&plain));
        }
    }
}
