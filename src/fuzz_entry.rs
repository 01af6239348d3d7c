//! The entry points of the fuzz targets in `fuzz/` (cargo-fuzz, libFuzzer),
//! kept in the library so that the targets and the regression test
//! (`tests/integration/fuzz_regressions.rs`, which replays every file under
//! `fuzz/regressions/<target>/`) run the same code. Not a public API.
//!
//! Each function takes the raw fuzz input and returns what the reader
//! returned: `Ok` for input it accepted, a typed error otherwise. A panic,
//! a hang or an allocation beyond libFuzzer's `-malloc_limit_mb` is a bug.
//! Where a cheap independent check exists (a written file reads back with
//! the same voxels), a failing check panics, so the fuzzer reports it.

use crate::error::{Result, VoxkitError};
use crate::grid::{BrickGrid, GridFrame, MemoryLimit};

/// The memory limit every reader gets under fuzzing: small, so that a
/// header asking for more is refused before anything is allocated, and
/// well under libFuzzer's 1 GiB allocation limit.
pub const LIMIT: MemoryLimit = MemoryLimit::new(256 << 20);

/// The names of the fuzz targets, each a function of this module and a
/// directory under `fuzz/regressions/`.
pub const TARGETS: &[&str] = &["obj", "binvox", "vox", "npy", "nrrd"];

/// Runs the entry point of `target` (one of [`TARGETS`]) on `data`.
pub fn run(target: &str, data: &[u8]) -> Result<()> {
    match target {
        "obj" => obj(data),
        "binvox" => binvox(data),
        "vox" => vox(data),
        "npy" => npy(data),
        "nrrd" => nrrd(data),
        _ => Err(VoxkitError::invalid(format!("no fuzz target {target:?}"))),
    }
}

/// OBJ text (bytes that are not UTF-8 are an error, as in `obj::load`).
pub fn obj(data: &[u8]) -> Result<()> {
    let text = std::str::from_utf8(data).map_err(|_| VoxkitError::invalid("not UTF-8"))?;
    let mesh = crate::mesh::obj::parse_str(text, "fuzz.obj")?;
    check_mesh(&mesh);
    Ok(())
}

/// A loaded mesh's indices must point at its positions.
fn check_mesh(mesh: &crate::mesh::Mesh) {
    let n = mesh.positions.len();
    for t in &mesh.triangles {
        assert!(t.iter().all(|&i| (i as usize) < n), "triangle index out of range");
    }
    for l in &mesh.polylines {
        assert!(l.iter().all(|&i| (i as usize) < n), "polyline index out of range");
    }
    let _ = mesh.bounds();
}

/// Writes what a voxel reader returned with `write` and reads it back with
/// `read`: the voxel count must survive the round trip. A write that is
/// refused (a limit) is fine.
fn round_trip(
    grid: &BrickGrid,
    frame: &GridFrame,
    write: impl Fn(&mut Vec<u8>, &BrickGrid, &GridFrame) -> Result<()>,
    read: impl Fn(&[u8]) -> Result<(BrickGrid, GridFrame)>,
) {
    let mut bytes = Vec::new();
    if write(&mut bytes, grid, frame).is_err() {
        return;
    }
    let (again, _) = read(&bytes).expect("a file we wrote must read back");
    assert_eq!(again.count(), grid.count(), "voxel count changed in a round trip");
}

/// `.binvox` bytes.
pub fn binvox(data: &[u8]) -> Result<()> {
    use crate::io::binvox;
    let (grid, frame) = binvox::read(data, LIMIT)?;
    round_trip(
        &grid,
        &frame,
        |w, g, f| binvox::write(w, g, f, LIMIT),
        |b| binvox::read(b, LIMIT),
    );
    Ok(())
}

/// MagicaVoxel `.vox` bytes, with colours.
pub fn vox(data: &[u8]) -> Result<()> {
    use crate::io::vox;
    let (grid, frame, _colors) = vox::read_colored(data, LIMIT)?;
    round_trip(&grid, &frame, |w, g, f| vox::write(w, g, f), |b| vox::read(b, LIMIT));
    Ok(())
}

/// `.npy` bytes as a voxel grid.
pub fn npy(data: &[u8]) -> Result<()> {
    use crate::io::npy;
    let (grid, frame) = npy::read(data, LIMIT)?;
    round_trip(
        &grid,
        &frame,
        |w, g, f| npy::write(w, g, f, LIMIT),
        |b| npy::read(b, LIMIT),
    );
    Ok(())
}

/// `.nrrd` bytes as a voxel grid.
pub fn nrrd(data: &[u8]) -> Result<()> {
    use crate::io::nrrd;
    let (grid, frame) = nrrd::read(data, LIMIT)?;
    round_trip(
        &grid,
        &frame,
        |w, g, f| nrrd::write(w, g, f, LIMIT),
        |b| nrrd::read(b, LIMIT),
    );
    Ok(())
}
