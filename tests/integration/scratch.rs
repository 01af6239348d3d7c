//! Scratch folders for the tests that write files.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh, empty folder under the system's temporary directory, removed
/// with everything in it when dropped (also when the test fails and
/// unwinds). Derefs to its [`Path`].
pub struct Scratch {
    path: PathBuf,
}

/// A new [`Scratch`] folder named after `tag`. Every call gets its own
/// folder: the tests of this binary run in parallel threads of one
/// process, so the process id alone would let two tests with the same tag
/// share (and delete) each other's files.
pub fn temp_dir(tag: &str) -> Scratch {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let path = std::env::temp_dir().join(format!("voxkit-test-{tag}-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&path);
    std::fs::create_dir_all(&path).expect("a scratch folder");
    Scratch { path }
}

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

#[test]
fn scratch_folders_are_distinct_and_removed() {
    let (a, b) = (temp_dir("same"), temp_dir("same"));
    assert_ne!(&*a, &*b);
    std::fs::write(a.join("f"), b"x").unwrap();
    let kept = a.to_path_buf();
    assert!(kept.join("f").exists() && b.is_dir());
    drop(a);
    assert!(!kept.exists());
}
