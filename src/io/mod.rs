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
fn temp_path(path: &Path) -> PathBuf {
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
