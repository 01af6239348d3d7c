//! NRRD (`NRRD0004`), raw `uchar` 0/1, x fastest (NRRD lists `sizes` fastest
//! axis first, so `sizes: nx ny nz` is exactly our dense layout).
//!
//! ```text
//! NRRD0004
//! # voxkit voxel grid
//! type: uchar
//! dimension: 3
//! space dimension: 3
//! sizes: nx ny nz
//! space directions: (h,0,0) (0,h,0) (0,0,h)
//! kinds: domain domain domain
//! encoding: raw
//! space origin: (cx,cy,cz)
//!
//! <nx·ny·nz bytes>
//! ```
//! **Origin convention**: NRRD's `space origin` is the position of the first
//! *sample*, and a voxel's sample sits at its centre, so `space origin` is
//! the centre of voxel (0,0,0): `frame.origin + h/2` on each axis. The reader
//! subtracts `h/2` again (exact up to one rounding per coordinate).
//!
//! The reader is the scalar-volume reader ([`super::volume`]: every
//! encoding it reads, `raw`, `gzip`, `bzip2`, `ascii`; detached data; 2-D
//! images as one voxel thick; size-1 extra axes squeezed; every sample type)
//! followed by a check that the voxels are axis-aligned cubes (our frames
//! have cubic voxels): any nonzero, non-NaN sample is a set voxel, and every
//! full brick becomes a tile. Without `space origin` voxel (0,0,0)'s min
//! corner is the world origin.

use std::io::{Read, Write};
use std::path::Path;

use glam::DVec3;

use super::volume::{read_volume, read_volume_bytes};
use super::voxels::for_each_slab;
use crate::error::{Result, VoxkitError};
use crate::grid::volume::ScalarVolume;
use crate::grid::{BrickGrid, GridFrame, MemoryLimit};

/// Writes `grid` (voxels inside `frame.dims`, checked by the caller) as NRRD,
/// streaming z-slabs.
pub fn write(
    w: &mut dyn Write,
    grid: &BrickGrid,
    frame: &GridFrame,
    limit: MemoryLimit,
) -> Result<()> {
    let [nx, ny, nz] = frame.dims;
    let h = frame.voxel_size;
    let c = frame.origin + DVec3::splat(h / 2.0);
    write!(
        w,
        "NRRD0004\n# voxkit voxel grid\ntype: uchar\ndimension: 3\nspace dimension: 3\n\
         sizes: {nx} {ny} {nz}\nspace directions: ({h},0,0) (0,{h},0) (0,0,{h})\n\
         kinds: domain domain domain\nencoding: raw\nspace origin: ({},{},{})\n\n",
        c.x, c.y, c.z
    )?;
    // z slowest, then y, x fastest.
    for_each_slab(grid, frame.dims, [2, 1, 0], limit, |slab| {
        w.write_all(slab)?;
        Ok(())
    })
}

/// Reads a NRRD voxel grid from memory (attached data; see the module docs).
pub fn read(bytes: &[u8], limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
    let vol = read_volume_bytes(Path::new("grid.nrrd"), bytes, &[], limit)?;
    to_grid(&vol, has_space_origin(bytes))
}

/// Reads a NRRD voxel grid from a file: attached data, or a detached header
/// (`.nrrd` or `.nhdr`) whose data files lie beside it. Errors name the file.
pub fn read_path(path: &Path, limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
    let vol = read_volume(path, limit)?;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| std::io::Read::take(f, 1 << 16).read_to_end(&mut head))
        .map_err(|source| VoxkitError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    to_grid(&vol, has_space_origin(&head)).map_err(|e| match e {
        VoxkitError::Unsupported(m) => VoxkitError::Unsupported(format!("{}: {m}", path.display())),
        other => other,
    })
}

/// The set samples of `vol` as a grid, if its voxels are axis-aligned cubes
/// (a voxel grid's frame). Without a `space origin` voxel (0,0,0)'s min
/// corner is the world origin.
fn to_grid(vol: &ScalarVolume, has_origin: bool) -> Result<(BrickGrid, GridFrame)> {
    let a = vol.frame.axes;
    let h = a.x_axis.x;
    let cubic = h > 0.0
        && a.x_axis == DVec3::new(h, 0.0, 0.0)
        && a.y_axis == DVec3::new(0.0, h, 0.0)
        && a.z_axis == DVec3::new(0.0, 0.0, h);
    if !cubic {
        return Err(VoxkitError::Unsupported(format!(
            "voxel axes {}, {}, {} are not axis-aligned cubes, which a voxel grid needs \
             (render the file as a scalar volume instead)",
            a.x_axis, a.y_axis, a.z_axis
        )));
    }
    let corner = if has_origin {
        vol.frame.origin - DVec3::splat(h / 2.0)
    } else {
        DVec3::ZERO
    };
    Ok((vol.to_brick_grid(), GridFrame::new(corner, h, vol.dims)))
}

/// Whether a NRRD header (the first bytes of the file) has a `space origin`.
fn has_space_origin(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(1 << 16)];
    let end = memchr::memmem::find(head, b"\n\n").unwrap_or(head.len());
    head[..end].split(|&b| b == b'\n').any(|l| {
        l.trim_ascii_start()
            .to_ascii_lowercase()
            .starts_with(b"space origin")
    })
}
