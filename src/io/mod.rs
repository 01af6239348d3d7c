//! File input and output. Every writer goes through [`atomic_write`]: the
//! bytes land in a temporary file beside the target, which is renamed over
//! the target only once complete, so a failure never leaves a partial file.

pub mod binvox;
pub mod image;
pub mod npy;
pub mod nrrd;
pub mod volume;
pub mod vox;
mod voxels;
pub mod zarr;

pub use voxels::{
    VoxelFormat, read_voxels, read_voxels_warned, write_voxels, write_voxels_limited,
};

use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{Result, VoxkitError};

/// Writes `path` atomically: `fill` writes the content into a temporary file
/// in the same directory, which is then flushed, synced and renamed onto
/// `path`. On any error the temporary file is removed and `path` is left as
/// it was. Unless `overwrite` is true, an existing `path` is an error
/// (checked before anything is written).
///
/// ```
/// let dir = std::env::temp_dir().join(format!("voxkit-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("hello.txt");
/// voxkit::io::atomic_write(&path, true, |w| Ok(w.write_all(b"hi")?)).unwrap();
/// assert_eq!(std::fs::read(&path).unwrap(), b"hi");
/// // A failing writer leaves the old content in place.
/// let err = voxkit::io::atomic_write(&path, true, |w| {
///     w.write_all(b"partial")?;
///     Err(voxkit::VoxkitError::invalid("stop"))
/// });
/// assert!(err.is_err());
/// assert_eq!(std::fs::read(&path).unwrap(), b"hi");
/// // Without `overwrite`, an existing file is refused.
/// assert!(voxkit::io::atomic_write(&path, false, |_| Ok(())).is_err());
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn atomic_write<F>(path: &Path, overwrite: bool, fill: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    let io_err = |source| VoxkitError::Io {
        path: path.to_path_buf(),
        source,
    };
    if !overwrite && path.exists() {
        return Err(VoxkitError::invalid(format!(
            "{} exists (use --force to overwrite)",
            path.display()
        )));
    }
    let tmp = temp_path(path);
    let file = fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(|e| VoxkitError::Io {
            path: tmp.clone(),
            source: e,
        })?;
    // Removes the temporary file on every way out but the rename: an error,
    // and also a panic unwinding through `fill` (batch mode catches those
    // per mesh and goes on, so nothing may be left behind).
    let mut cleanup = RemoveOnDrop(Some(tmp.clone()));
    let mut w = BufWriter::new(file);
    fill(&mut w)?;
    let file = w.into_inner().map_err(|e| io_err(e.into_error()))?;
    file.sync_all().map_err(io_err)?;
    fs::rename(&tmp, path).map_err(io_err)?;
    cleanup.0 = None;
    Ok(())
}

/// Deletes the file it holds when dropped (see [`atomic_write`]).
struct RemoveOnDrop(Option<PathBuf>);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        if let Some(path) = self.0.take() {
            let _ = fs::remove_file(path);
        }
    }
}

/// A temporary name beside `path`: same directory (so the rename is atomic),
/// hidden, unique per process and call.
pub(crate) fn temp_path(path: &Path) -> PathBuf {
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp_name = format!(".{name}.{}.{n}.tmp", std::process::id());
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.join(tmp_name),
        _ => PathBuf::from(tmp_name),
    }
}

/// Removes the temporary files of `output` (`.NAME.PID.N.tmp` beside it, as
/// [`atomic_write`] names them) whose writer process `dead` says
/// is gone.
pub(crate) fn remove_temp_files(output: &Path, dead: impl Fn(u32) -> bool) {
    let (Some(dir), Some(name)) = (output.parent(), output.file_name()) else {
        return;
    };
    let prefix = format!(".{}.", name.to_string_lossy());
    let Ok(listing) = std::fs::read_dir(if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    }) else {
        return;
    };
    for item in listing.flatten() {
        let file = item.file_name();
        let file = file.to_string_lossy();
        let Some(rest) = file
            .strip_prefix(&prefix)
            .and_then(|r| r.strip_suffix(".tmp"))
        else {
            continue;
        };
        let mut parts = rest.split('.');
        let (Some(pid), Some(n), None) = (parts.next(), parts.next(), parts.next()) else {
            continue;
        };
        if n.parse::<u64>().is_err() {
            continue;
        }
        if let Ok(pid) = pid.parse::<u32>()
            && dead(pid)
        {
            // A store (`.zarr`) is built in a temporary directory.
            let _ = if item.path().is_dir() {
                std::fs::remove_dir_all(item.path())
            } else {
                std::fs::remove_file(item.path())
            };
        }
    }
}

/// Whether process `pid` is gone (Linux: no `/proc/PID`); elsewhere no
/// process is known to be gone.
pub(crate) fn process_gone(pid: u32) -> bool {
    Path::new("/proc/self").exists()
        && pid != std::process::id()
        && !Path::new("/proc").join(pid.to_string()).exists()
}

impl From<std::io::Error> for VoxkitError {
    fn from(source: std::io::Error) -> Self {
        VoxkitError::Io {
            path: PathBuf::new(),
            source,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A panic inside the writer must not leave the temporary file.
    #[test]
    fn panicking_writer_leaves_no_temporary_file() {
        let dir = std::env::temp_dir().join(format!("voxkit-aw-panic-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("out.bin");
        let outcome = std::panic::catch_unwind(|| {
            atomic_write(&path, false, |w| {
                w.write_all(&[1u8; 1 << 16])?;
                panic!("writer failed");
            })
        });
        assert!(outcome.is_err());
        let left: Vec<_> = fs::read_dir(&dir).unwrap().collect();
        assert!(left.is_empty(), "left behind: {left:?}");
        fs::remove_dir_all(&dir).unwrap();
    }
}
