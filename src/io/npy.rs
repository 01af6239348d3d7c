//! NumPy `.npy`: a dense `uint8` array of 0/1 with **shape `[nx, ny, nz]`**
//! in C order, so `a[x, y, z]` is voxel `(x, y, z)` (z fastest in the file;
//! the same indexing as trimesh's `VoxelGrid.matrix` and `binvox_rw`'s
//! `data`). Written and read with `ndarray-npy`.
//!
//! The format records no frame: the reader returns origin 0, voxel size 1 and
//! dims = shape. The reader also accepts `bool` arrays; it checks the shape in
//! the header against the [`MemoryLimit`] before reading the data.

use std::io::Write;

use ndarray::Array3;
use ndarray_npy::{ReadNpyExt, WriteNpyExt};

use crate::error::{Result, VoxkitError};
use crate::grid::{BrickGrid, GridFrame, MemoryLimit, Voxel};

/// Writes `grid` (voxels inside `frame.dims`, checked by the caller) as a
/// dense `[nx, ny, nz]` u8 array; the array is checked against `limit`
/// before it is allocated.
pub fn write(
    w: &mut dyn Write,
    grid: &BrickGrid,
    frame: &GridFrame,
    limit: MemoryLimit,
) -> Result<()> {
    let [nx, ny, nz] = frame.dims;
    limit.check(
        &format!("npy array {nx}x{ny}x{nz}"),
        nx as u128 * ny as u128 * nz as u128,
        1,
    )?;
    let mut a = Array3::<u8>::zeros((nx, ny, nz));
    for v in grid.iter_unordered() {
        a[[v.x as usize, v.y as usize, v.z as usize]] = 1;
    }
    a.write_npy(w).map_err(|e| match e {
        ndarray_npy::WriteNpyError::Io(e) => VoxkitError::from(e),
        other => VoxkitError::invalid(format!("npy: {other}")),
    })
}

/// The `shape` tuple of an npy header, without reading the data.
fn header_shape(bytes: &[u8]) -> Result<Vec<u128>> {
    let bad = |m: &str| VoxkitError::invalid(format!("npy: {m}"));
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(bad("missing \\x93NUMPY magic"));
    }
    let (len, start): (usize, usize) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(bad(&format!("unsupported version {v}"))),
    };
    let header = bytes
        .get(start..start.saturating_add(len))
        .ok_or_else(|| bad("truncated header"))?;
    let header = String::from_utf8_lossy(header);
    let at = header
        .find("'shape'")
        .ok_or_else(|| bad("header has no shape"))?;
    let rest = &header[at..];
    let (open, close) = (
        rest.find('(').ok_or_else(|| bad("bad shape"))?,
        rest.find(')').ok_or_else(|| bad("bad shape"))?,
    );
    if close < open {
        return Err(bad("bad shape"));
    }
    rest[open + 1..close]
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<u128>().map_err(|_| bad("bad shape")))
        .collect()
}

/// Reads a 3D `uint8` (or `bool`) npy array; nonzero cells are set voxels.
pub fn read(bytes: &[u8], limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
    let shape = header_shape(bytes)?;
    if shape.len() != 3 {
        return Err(VoxkitError::invalid(format!(
            "npy: array has {} dimensions, 3 are needed",
            shape.len()
        )));
    }
    if shape.iter().any(|&d| d == 0 || d > i32::MAX as u128) {
        return Err(VoxkitError::invalid(format!(
            "npy: shape {shape:?} has an empty or too large axis"
        )));
    }
    limit.check("npy array", shape.iter().product(), 1)?;
    let a: Array3<u8> = match Array3::<u8>::read_npy(bytes) {
        Ok(a) => a,
        Err(e8) => match Array3::<bool>::read_npy(bytes) {
            Ok(b) => b.mapv(u8::from),
            Err(_) => return Err(VoxkitError::invalid(format!("npy: {e8}"))),
        },
    };
    let mut grid = BrickGrid::new();
    for ((x, y, z), &c) in a.indexed_iter() {
        if c != 0 {
            grid.insert(Voxel::new(x as i32, y as i32, z as i32));
        }
    }
    let (nx, ny, nz) = a.dim();
    Ok((grid, GridFrame::new(glam::DVec3::ZERO, 1.0, [nx, ny, nz])))
}
