//! File input and output. Every writer goes through [`atomic_write`]: the
//! bytes land in a temporary file beside the target, which is renamed over
//! the target only once complete, so a failure never leaves a partial file.

pub mod binvox;
pub mod image;
mod nifti;
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
    // The staged file removes its temporary on every way out but the
    // rename: an error, and also a panic unwinding through `fill` (batch
    // mode catches those per mesh and goes on, so nothing may be left).
    let mut staged = stage_file(path, fill)?;
    staged.file.sync_all().map_err(io_err)?;
    let tmp = staged.tmp.0.take().unwrap_or_default();
    if let Err(e) = fs::rename(&tmp, path) {
        staged.tmp.0 = Some(tmp);
        return Err(io_err(e));
    }
    Ok(())
}

/// A file written in full under a temporary name beside its target, not
/// yet synced nor renamed ([`stage_file`]); [`commit_staged`] makes a batch
/// of them durable with one filesystem sync and renames each into place.
/// Dropped uncommitted, its temporary file is deleted.
pub(crate) struct StagedFile {
    path: PathBuf,
    file: fs::File,
    tmp: RemoveOnDrop,
}

/// Writes `fill`'s bytes to a temporary file beside `path` (replacing
/// `path` later, at [`commit_staged`]).
pub(crate) fn stage_file<F>(path: &Path, fill: F) -> Result<StagedFile>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    let tmp = temp_path(path);
    let file = fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(|e| VoxkitError::Io {
            path: tmp.clone(),
            source: e,
        })?;
    let cleanup = RemoveOnDrop(Some(tmp.clone()));
    let mut w = BufWriter::new(file);
    fill(&mut w)?;
    let file = w.into_inner().map_err(|e| VoxkitError::Io {
        path: tmp,
        source: e.into_error(),
    })?;
    Ok(StagedFile {
        path: path.to_path_buf(),
        file,
        tmp: cleanup,
    })
}

/// Makes staged files durable and puts them in place: one `syncfs` of the
/// filesystem holding the first of them (Linux; elsewhere one `fsync` per
/// file), then each renamed over its target. As with [`atomic_write`], a
/// reader sees each target whole, old or new. The batch is meant for the
/// files of one store (one filesystem): `atomic_write`'s fsync per file
/// costs a journal commit and a device flush each, which for the hundreds
/// of small shards a tile or a store writes was most of the write time
/// (docs/scale-out.md).
pub(crate) fn commit_staged(files: Vec<StagedFile>) -> Result<()> {
    sync_staged(&files)?;
    for mut f in files {
        let tmp = f.tmp.0.take().unwrap_or_default();
        if let Err(source) = fs::rename(&tmp, &f.path) {
            f.tmp.0 = Some(tmp);
            return Err(VoxkitError::Io {
                path: f.path.clone(),
                source,
            });
        }
    }
    Ok(())
}

/// One `syncfs` of the filesystem holding the first staged file.
#[cfg(target_os = "linux")]
fn sync_staged(files: &[StagedFile]) -> Result<()> {
    use std::os::fd::AsRawFd;
    let Some(first) = files.first() else {
        return Ok(());
    };
    // SAFETY: the descriptor belongs to `first.file`, open for the whole
    // call; syncfs only reads it.
    if unsafe { libc::syncfs(first.file.as_raw_fd()) } != 0 {
        return Err(VoxkitError::Io {
            path: first.path.clone(),
            source: std::io::Error::last_os_error(),
        });
    }
    Ok(())
}

/// One `fsync` per staged file (no `syncfs` here).
#[cfg(not(target_os = "linux"))]
fn sync_staged(files: &[StagedFile]) -> Result<()> {
    for f in files {
        f.file.sync_all().map_err(|source| VoxkitError::Io {
            path: f.path.clone(),
            source,
        })?;
    }
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

    /// Staged files appear only at the commit (one sync, then renames),
    /// replace their targets whole, and leave no temporary file; a staged
    /// file dropped uncommitted leaves nothing and keeps the old target.
    #[test]
    fn staged_files_appear_at_the_commit_and_leave_nothing_else() {
        let dir = std::env::temp_dir().join(format!("voxkit-staged-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.bin"), dir.join("b.bin"));
        fs::write(&b, b"old").unwrap();
        let staged = vec![
            stage_file(&a, |w| Ok(w.write_all(b"first")?)).unwrap(),
            stage_file(&b, |w| Ok(w.write_all(&[7u8; 100_000])?)).unwrap(),
        ];
        assert!(!a.exists() && fs::read(&b).unwrap() == b"old");
        commit_staged(staged).unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"first");
        assert_eq!(fs::read(&b).unwrap(), vec![7u8; 100_000]);
        let dropped = stage_file(&a, |w| Ok(w.write_all(b"never")?)).unwrap();
        drop(dropped);
        commit_staged(Vec::new()).unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"first");
        let mut names: Vec<_> = fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(names, ["a.bin", "b.bin"]);
        fs::remove_dir_all(&dir).unwrap();
    }
}
