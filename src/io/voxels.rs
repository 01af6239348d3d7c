//! Voxel files by extension: [`write_voxels`] / [`read_voxels`] dispatch to
//! [`super::binvox`], [`super::vox`], [`super::npy`] and [`super::nrrd`].
//!
//! Writers take a sparse [`BrickGrid`] plus its [`GridFrame`]; every set voxel
//! must lie in `0..frame.dims`. No writer builds the whole dense grid or a
//! mask per tile: binvox, npy and NRRD stream one brick layer at a time
//! ([`BrickGrid::brick_layers`]), .vox one 256³ model at a time
//! ([`BrickGrid::brick_groups`]), a tile becoming runs, rows or voxels
//! directly. Readers return a [`BrickGrid`] with every full brick as a tile
//! (so a solid read back is as small as the solid written) and the frame the
//! file records (see each format for what it can record).

use std::path::Path;

use crate::error::{Result, VoxkitError};
use crate::grid::brick::{BRICK_EDGE, FULL_BRICK, mask_voxels};
use crate::grid::{BrickGrid, Dims, GridFrame, MemoryLimit};

/// A voxel file format, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VoxelFormat {
    /// `.binvox` ([`super::binvox`]).
    Binvox,
    /// MagicaVoxel `.vox` ([`super::vox`]).
    Vox,
    /// NumPy `.npy` ([`super::npy`]).
    Npy,
    /// `.nrrd` ([`super::nrrd`]).
    Nrrd,
    /// An OME-Zarr store, a directory `.zarr` ([`super::zarr`]).
    Zarr,
}

impl VoxelFormat {
    /// The format for `path`'s extension (case-insensitive), or
    /// [`VoxkitError::Unsupported`].
    pub fn from_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        Ok(match ext.as_str() {
            "binvox" => VoxelFormat::Binvox,
            "vox" => VoxelFormat::Vox,
            "npy" => VoxelFormat::Npy,
            "nrrd" => VoxelFormat::Nrrd,
            "zarr" => VoxelFormat::Zarr,
            _ => {
                return Err(VoxkitError::Unsupported(format!(
                    "{}: unknown voxel format (expected .binvox, .vox, .npy, .nrrd or .zarr)",
                    path.display()
                )));
            }
        })
    }
}

/// Writes `grid` in `frame` to `path`, the format chosen by extension,
/// atomically (see [`super::atomic_write`]); an existing file is replaced
/// only if `overwrite`. Dense buffers are capped by [`MemoryLimit::DEFAULT`].
///
/// ```
/// use glam::{DVec3, IVec3};
/// use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
/// use voxkit::io::{read_voxels, write_voxels};
/// let dir = std::env::temp_dir().join(format!("voxkit-doc-vox-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let grid: BrickGrid = [IVec3::new(1, 2, 3), IVec3::new(0, 0, 0)].into_iter().collect();
/// let frame = GridFrame::new(DVec3::new(-1.0, 0.5, 2.0), 0.25, [4, 5, 6]);
/// for ext in ["binvox", "vox", "npy", "nrrd", "zarr"] {
///     let path = dir.join(format!("g.{ext}"));
///     write_voxels(&path, &grid, &frame, true).unwrap();
///     let (back, _frame) = read_voxels(&path, MemoryLimit::DEFAULT).unwrap();
///     assert_eq!(back, grid);
/// }
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn write_voxels(
    path: &Path,
    grid: &BrickGrid,
    frame: &GridFrame,
    overwrite: bool,
) -> Result<()> {
    write_voxels_limited(path, grid, frame, overwrite, MemoryLimit::DEFAULT)
}

/// As [`write_voxels`] with an explicit cap on the writer's buffers.
pub fn write_voxels_limited(
    path: &Path,
    grid: &BrickGrid,
    frame: &GridFrame,
    overwrite: bool,
    limit: MemoryLimit,
) -> Result<()> {
    let format = VoxelFormat::from_path(path)?;
    check_frame(frame)?;
    grid.check_inside(frame.dims)?;
    if format == VoxelFormat::Zarr {
        return super::zarr::write(path, grid, frame, overwrite, 1).map(|_| ());
    }
    super::atomic_write(path, overwrite, |w| match format {
        VoxelFormat::Binvox => super::binvox::write(w, grid, frame, limit),
        VoxelFormat::Vox => super::vox::write(w, grid, frame),
        VoxelFormat::Npy => super::npy::write(w, grid, frame, limit),
        VoxelFormat::Nrrd => super::nrrd::write(w, grid, frame, limit),
        // A store is a directory, written above.
        VoxelFormat::Zarr => Err(VoxkitError::Unsupported(
            "a zarr store is not one file".into(),
        )),
    })
}

/// Reads a voxel file (format by extension). `limit` caps what the reader
/// allocates (checked from the header, before allocating). Errors name the
/// file. What a reader skipped while reading (a .vox file's hidden layers,
/// say) is dropped: [`read_voxels_warned`] returns it.
pub fn read_voxels(path: &Path, limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
    read_voxels_warned(path, limit).map(|(grid, frame, _)| (grid, frame))
}

/// [`read_voxels`], plus one line per thing the reader skipped while still
/// reading the grid (.vox: hidden layers and nodes, animation frames after
/// the first), for the caller to show (the command line prints each as
/// `warning: …` and lists them under `warnings` in `--json`).
pub fn read_voxels_warned(
    path: &Path,
    limit: MemoryLimit,
) -> Result<(BrickGrid, GridFrame, Vec<String>)> {
    let format = VoxelFormat::from_path(path)?;
    if format == VoxelFormat::Nrrd {
        // Through the volume reader, which opens detached data itself.
        return super::nrrd::read_path(path, limit).map(|(g, f)| (g, f, Vec::new()));
    }
    if format == VoxelFormat::Zarr {
        return super::zarr::read(path, limit).map(|(g, f)| (g, f, Vec::new()));
    }
    let io_err = |source| VoxkitError::Io {
        path: path.to_path_buf(),
        source,
    };
    let len = std::fs::metadata(path).map_err(io_err)?.len();
    limit.check(&format!("reading {}", path.display()), len as u128, 1)?;
    let bytes = std::fs::read(path).map_err(io_err)?;
    let plain = |r: Result<(BrickGrid, GridFrame)>| r.map(|(g, f)| (g, f, Vec::new()));
    let result = match format {
        VoxelFormat::Binvox => plain(super::binvox::read(&bytes, limit)),
        VoxelFormat::Vox => super::vox::read_warned(&bytes, limit),
        VoxelFormat::Npy => plain(super::npy::read(&bytes, limit)),
        VoxelFormat::Nrrd | VoxelFormat::Zarr => unreachable!("read above"),
    };
    result.map_err(|e| match e {
        VoxkitError::Invalid(m) => VoxkitError::Invalid(format!("{}: {m}", path.display())),
        VoxkitError::Unsupported(m) => VoxkitError::Unsupported(format!("{}: {m}", path.display())),
        other => other,
    })
}

/// A frame a writer can record: finite origin, finite positive voxel size,
/// positive extents that fit `i32`.
pub(crate) fn check_frame(frame: &GridFrame) -> Result<()> {
    if !(frame.origin.is_finite() && frame.voxel_size.is_finite() && frame.voxel_size > 0.0) {
        return Err(VoxkitError::invalid(format!(
            "grid frame needs a finite origin and a positive voxel size, got {} and {}",
            frame.origin, frame.voxel_size
        )));
    }
    if frame.dims.iter().any(|&d| d == 0 || d > i32::MAX as usize) {
        return Err(VoxkitError::invalid(format!(
            "grid dimensions {:?} must be in 1..=2^31-1",
            frame.dims
        )));
    }
    Ok(())
}

/// Streams the grid box `0..dims` as 0/1 bytes in the order
/// `order = [slow, mid, fast]` (axis numbers), in slabs of up to 8 layers
/// along `slow`: `emit` gets each slab's bytes (`layers * n_mid * n_fast`,
/// slow-major). Every voxel must lie inside `dims` (checked by the caller).
/// The slabs come from [`BrickGrid::brick_layers`]: one brick layer at a
/// time, a tile filling its 64 rows of 8 bytes, never a mask per tile.
pub(crate) fn for_each_slab(
    grid: &BrickGrid,
    dims: Dims,
    order: [usize; 3],
    limit: MemoryLimit,
    mut emit: impl FnMut(&[u8]) -> Result<()>,
) -> Result<()> {
    let [slow, mid, fast] = order;
    let (n_mid, n_fast) = (dims[mid], dims[fast]);
    let plane = n_mid * n_fast;
    limit.check("slab buffer", 8 * plane as u128, 1)?;
    let mut layers = grid.brick_layers(slow).peekable();
    let mut buf = vec![0u8; 8 * plane];
    let n_slabs = dims[slow].div_ceil(8);
    for s in 0..n_slabs {
        let layers_here = (dims[slow] - 8 * s).min(8);
        let slab = &mut buf[..layers_here * plane];
        slab.fill(0);
        let bricks = match layers.next_if(|(c, _)| *c as usize == s) {
            Some((_, bricks)) => bricks,
            None => Vec::new(),
        };
        for (k, m) in bricks {
            let base = k * BRICK_EDGE;
            if *m == FULL_BRICK {
                // Inside the grid, so all 8 layers, rows and columns are.
                for ls in 0..8 {
                    for lm in 0..8 {
                        let i =
                            ls * plane + (base[mid] as usize + lm) * n_fast + base[fast] as usize;
                        slab[i..i + 8].fill(1);
                    }
                }
                continue;
            }
            for l in mask_voxels(*m) {
                let v = base + l;
                let i = (v[slow] as usize - 8 * s) * plane
                    + v[mid] as usize * n_fast
                    + v[fast] as usize;
                slab[i] = 1;
            }
        }
        emit(slab)?;
    }
    Ok(())
}

/// A reader-side cap: a sparse result covering `dims` needs at most one
/// brick (~96 bytes with its map entry) per 8³ block of the box.
pub(crate) fn check_sparse_budget(dims: Dims, limit: MemoryLimit, what: &str) -> Result<()> {
    let bricks: u128 = dims.iter().map(|&d| (d as u128).div_ceil(8)).product();
    limit.check(what, bricks, 96)
}
