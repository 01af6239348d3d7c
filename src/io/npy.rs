//! NumPy `.npy`: a dense `uint8` array of 0/1 with **shape `[nx, ny, nz]`**
//! in C order, so `a[x, y, z]` is voxel `(x, y, z)` (z fastest in the file;
//! the same indexing as trimesh's `VoxelGrid.matrix` and `binvox_rw`'s
//! `data`). Written by streaming 8-voxel x-slabs after a version 1.0 header
//! (so a 1024³ grid needs a few MiB, not a dense GiB), read with
//! `ndarray-npy`.
//!
//! The format records no frame: the reader returns origin 0, voxel size 1 and
//! dims = shape, with every full brick as a tile. The reader also accepts `bool` arrays; it checks the shape in
//! the header against the [`MemoryLimit`] before reading the data.

use std::io::Write;

use ndarray::Array3;
use ndarray_npy::ReadNpyExt;

use super::voxels::for_each_slab;

use crate::error::{Result, VoxkitError};
use crate::grid::{BrickGrid, GridFrame, MemoryLimit};

/// Writes `grid` (voxels inside `frame.dims`, checked by the caller) as a
/// dense `[nx, ny, nz]` u8 array, streamed in x-slabs of 8 (the slab buffer
/// is checked against `limit`).
pub fn write(
    w: &mut dyn Write,
    grid: &BrickGrid,
    frame: &GridFrame,
    limit: MemoryLimit,
) -> Result<()> {
    let [nx, ny, nz] = frame.dims;
    w.write_all(&header(&[nx, ny, nz]))?;
    // x slowest, then y, z fastest (C order of shape [nx, ny, nz]).
    for_each_slab(grid, frame.dims, [0, 1, 2], limit, |slab| {
        w.write_all(slab)?;
        Ok(())
    })
}

/// An npy version 1.0 header for a C-order `uint8` array of `shape`: magic,
/// version, little-endian header length, then the dict padded with spaces
/// and a newline so that the data starts at a multiple of 64 bytes.
fn header(shape: &[usize]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut dict = format!("{{'descr': '|u1', 'fortran_order': False, 'shape': {tuple}, }}");
    let unpadded = 10 + dict.len() + 1;
    dict.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    dict.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
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
    let (nx, ny, nz) = a.dim();
    // Brick by brick, full bricks as tiles.
    let grid = BrickGrid::from_x_rows([nx, ny, nz], |v| {
        let (x, y, z) = (v.x as usize, v.y as usize, v.z as usize);
        (0..(nx - x).min(8)).fold(0u8, |r, i| r | u8::from(a[[x + i, y, z]] != 0) << i)
    });
    Ok((grid, GridFrame::new(glam::DVec3::ZERO, 1.0, [nx, ny, nz])))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Voxel;
    use rand::{Rng, SeedableRng};

    #[test]
    fn streamed_file_reads_back_with_ndarray_npy() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for dims in [[1, 1, 1], [5, 9, 17], [20, 3, 8], [17, 16, 9]] {
            let mut grid = BrickGrid::new();
            let mut dense = Array3::<u8>::zeros((dims[0], dims[1], dims[2]));
            for _ in 0..dims.iter().product::<usize>() / 3 + 1 {
                let v = [0, 1, 2].map(|a| rng.random_range(0..dims[a]));
                grid.insert(Voxel::new(v[0] as i32, v[1] as i32, v[2] as i32));
                dense[v] = 1;
            }
            let frame = GridFrame::new(glam::DVec3::ZERO, 1.0, dims);
            let mut bytes = Vec::new();
            write(&mut bytes, &grid, &frame, MemoryLimit::default()).unwrap();
            // The data starts on a 64-byte boundary, as the format asks.
            let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
            assert_eq!((10 + header_len) % 64, 0);
            assert_eq!(
                bytes.len(),
                10 + header_len + dims.iter().product::<usize>()
            );
            assert_eq!(
                Array3::<u8>::read_npy(&bytes[..]).unwrap(),
                dense,
                "{dims:?}"
            );
        }
    }
}
