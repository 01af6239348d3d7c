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
//! The reader takes `raw` encoding only (`gzip` and detached data are
//! [`VoxkitError::Unsupported`]), types `uchar`/`uint8` (and the other 8-bit
//! spellings), and either `space directions` (which must be axis-aligned with
//! one positive spacing: our frames have cubic voxels) or `spacings`; any
//! nonzero byte is a set voxel, and every full brick becomes a tile.

use std::io::Write;

use glam::DVec3;

use super::voxels::for_each_slab;
use crate::error::{Result, VoxkitError};
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

fn bad(m: impl std::fmt::Display) -> VoxkitError {
    VoxkitError::invalid(format!("nrrd: {m}"))
}

/// Bit `i` set where byte `i` of `bytes` (at most 8) is nonzero.
#[inline]
fn nonzero_bits(bytes: &[u8]) -> u8 {
    if let Ok(eight) = <[u8; 8]>::try_from(bytes) {
        // Each byte's OR of its bits lands in its low bit, and one multiply
        // gathers the eight low bits into the top byte.
        let mut w = u64::from_le_bytes(eight);
        w |= w >> 4;
        w |= w >> 2;
        w |= w >> 1;
        return ((w & 0x0101_0101_0101_0101).wrapping_mul(0x0102_0408_1020_4080) >> 56) as u8;
    }
    bytes
        .iter()
        .enumerate()
        .fold(0, |r, (i, &b)| r | u8::from(b != 0) << i)
}

/// Parses `(a,b,c)` vectors.
fn vectors(s: &str) -> Result<Vec<[f64; 3]>> {
    let mut out = Vec::new();
    for part in s.split(')') {
        let part = part.trim();
        if part.is_empty() {
            continue;
        }
        let inner = part
            .strip_prefix('(')
            .ok_or_else(|| bad(format!("bad vector list {s:?}")))?;
        let v: Vec<f64> = inner
            .split(',')
            .map(|x| x.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
            .collect::<Option<_>>()
            .ok_or_else(|| bad(format!("bad vector {part:?})")))?;
        out.push(
            v.try_into()
                .map_err(|_| bad(format!("vector {part:?}) needs 3 components")))?,
        );
    }
    Ok(out)
}

/// Reads a NRRD file from memory (see the module docs for what is accepted).
pub fn read(bytes: &[u8], limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
    if !bytes.starts_with(b"NRRD000") {
        return Err(bad("missing NRRD000x magic"));
    }
    // The header ends at the first empty line.
    let mut pos = 0;
    let mut fields: Vec<(String, String)> = Vec::new();
    let mut first = true;
    loop {
        let rest = &bytes[pos..];
        let end = rest
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| bad("truncated header"))?;
        let line = std::str::from_utf8(&rest[..end])
            .map_err(|_| bad("header is not text"))?
            .trim_end_matches('\r');
        pos += end + 1;
        if first {
            first = false;
            continue;
        }
        if line.is_empty() {
            break;
        }
        if line.starts_with('#') || line.contains(":=") {
            continue; // comment or key/value pair
        }
        let (k, v) = line
            .split_once(": ")
            .ok_or_else(|| bad(format!("bad header line {line:?}")))?;
        fields.push((k.trim().to_ascii_lowercase(), v.trim().to_string()));
    }
    let get = |k: &str| fields.iter().find(|(f, _)| f == k).map(|(_, v)| v.as_str());
    match get("type") {
        Some(
            "uchar" | "unsigned char" | "uint8" | "uint8_t" | "signed char" | "int8" | "int8_t",
        ) => {}
        Some(t) => return Err(VoxkitError::Unsupported(format!("nrrd: type {t:?}"))),
        None => return Err(bad("no type field")),
    }
    if get("dimension") != Some("3") {
        return Err(bad("dimension must be 3"));
    }
    match get("encoding") {
        Some("raw") => {}
        Some(e) => return Err(VoxkitError::Unsupported(format!("nrrd: encoding {e:?}"))),
        None => return Err(bad("no encoding field")),
    }
    if get("data file").or(get("datafile")).is_some() {
        return Err(VoxkitError::Unsupported("nrrd: detached data".into()));
    }
    for skip in ["line skip", "lineskip", "byte skip", "byteskip"] {
        if get(skip).is_some_and(|v| v != "0") {
            return Err(VoxkitError::Unsupported(format!("nrrd: {skip}")));
        }
    }
    let sizes: Vec<usize> = get("sizes")
        .ok_or_else(|| bad("no sizes field"))?
        .split_whitespace()
        .map(|s| s.parse().ok())
        .collect::<Option<_>>()
        .filter(|v: &Vec<usize>| v.len() == 3 && v.iter().all(|&d| d > 0 && d <= i32::MAX as usize))
        .ok_or_else(|| bad("sizes must be three positive integers"))?;
    let dims = [sizes[0], sizes[1], sizes[2]];
    let n = dims.iter().map(|&d| d as u128).product::<u128>();
    limit.check("nrrd grid", n, 1)?;

    let h = if let Some(dirs) = get("space directions") {
        let d = vectors(dirs)?;
        let h = d.first().map(|v| v[0]).unwrap_or(0.0);
        let diagonal = d.len() == 3
            && h > 0.0
            && (0..3).all(|i| (0..3).all(|j| if i == j { d[i][j] == h } else { d[i][j] == 0.0 }));
        if !diagonal {
            return Err(VoxkitError::Unsupported(format!(
                "nrrd: space directions {dirs:?}: only axis-aligned cubic voxels are supported"
            )));
        }
        h
    } else if let Some(sp) = get("spacings") {
        let s: Vec<f64> = sp
            .split_whitespace()
            .map(|x| x.parse().ok())
            .collect::<Option<_>>()
            .ok_or_else(|| bad(format!("bad spacings {sp:?}")))?;
        if s.len() != 3 || !(s[0] > 0.0 && s[0].is_finite()) || s.iter().any(|&v| v != s[0]) {
            return Err(VoxkitError::Unsupported(format!(
                "nrrd: spacings {sp:?}: only cubic voxels are supported"
            )));
        }
        s[0]
    } else {
        1.0
    };
    let centre = match get("space origin") {
        Some(o) => {
            let v = vectors(o)?;
            let [c] = v[..] else {
                return Err(bad(format!("bad space origin {o:?}")));
            };
            DVec3::from_array(c)
        }
        None => DVec3::splat(h / 2.0),
    };
    let data = &bytes[pos..];
    if (data.len() as u128) < n {
        return Err(bad(format!(
            "data has {} bytes, {n} are needed (truncated?)",
            data.len()
        )));
    }
    if data.len() as u128 > n {
        return Err(bad(format!("data has {} bytes, {n} expected", data.len())));
    }
    // Brick by brick, full bricks as tiles.
    let (nx, ny) = (dims[0], dims[1]);
    let grid = BrickGrid::from_x_rows(dims, |v| {
        let i = v.x as usize + nx * (v.y as usize + ny * v.z as usize);
        nonzero_bits(&data[i..i + (nx - v.x as usize).min(8)])
    });
    Ok((
        grid,
        GridFrame::new(centre - DVec3::splat(h / 2.0), h, dims),
    ))
}
