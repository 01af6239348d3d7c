//! `.binvox` (Patrick Min's format, as read by `binvox_rw` and trimesh).
//!
//! ```text
//! #binvox 1
//! dim D D D
//! translate ox oy oz
//! scale s
//! data
//! <(value, count) byte pairs, count 1..=255>
//! ```
//! Voxel order: y fastest, then z, then x: `index = x·(D·D) + z·D + y`.
//!
//! - **Padding**: binvox readers expect a cubic grid, so the writer pads to
//!   `D = max(dims)` on every axis (the extra voxels are empty);
//!   `translate = frame.origin`, `scale = D · h`. Reading back gives dims
//!   `[D, D, D]`, the same origin, and `h = scale / D` (equal to the written
//!   `h` up to one rounding).
//! - The reader accepts non-cubic `dim a b c` as well, taking the three
//!   numbers as the extents of the data order (x, z, y) as `binvox_rw` does.
//! - Coordinates are written with Rust's shortest round-trip formatting, so
//!   `translate` reads back bit-exactly.

use std::io::Write;

use glam::DVec3;

use super::voxels::{check_sparse_budget, for_each_slab};
use crate::error::{Result, VoxkitError};
use crate::grid::{BrickGrid, GridFrame, MemoryLimit, Voxel};

/// Writes `grid` (voxels inside `frame.dims`, checked by the caller) as binvox.
pub fn write(
    w: &mut dyn Write,
    grid: &BrickGrid,
    frame: &GridFrame,
    limit: MemoryLimit,
) -> Result<()> {
    let d = *frame.dims.iter().max().expect("three dims");
    let o = frame.origin;
    write!(
        w,
        "#binvox 1\ndim {d} {d} {d}\ntranslate {} {} {}\nscale {}\ndata\n",
        o.x,
        o.y,
        o.z,
        d as f64 * frame.voxel_size
    )?;
    let mut rle = Rle::default();
    let mut out = Vec::with_capacity(1 << 16);
    // x slowest, z, y fastest.
    for_each_slab(grid, [d, d, d], [0, 2, 1], limit, |slab| {
        rle.push_slice(slab, &mut out);
        w.write_all(&out)?;
        out.clear();
        Ok(())
    })?;
    rle.finish(&mut out);
    w.write_all(&out)?;
    Ok(())
}

/// Run-length encoder state across slabs.
#[derive(Default)]
struct Rle {
    value: u8,
    count: u8,
}

impl Rle {
    /// Encodes `bytes` (each 0 or 1), continuing the current run. Runs are
    /// found eight bytes at a time, so a mostly empty grid costs about one
    /// word compare per eight voxels instead of one branch per voxel.
    fn push_slice(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let mut i = 0;
        while i < bytes.len() {
            let v = bytes[i];
            let run = run_length(&bytes[i..], v);
            let mut left = run;
            while left > 0 {
                if self.count > 0 && (v != self.value || self.count == 255) {
                    out.extend_from_slice(&[self.value, self.count]);
                    self.count = 0;
                }
                self.value = v;
                let take = left.min(255 - self.count as usize);
                self.count += take as u8;
                left -= take;
            }
            i += run;
        }
    }

    fn finish(&mut self, out: &mut Vec<u8>) {
        if self.count > 0 {
            out.extend_from_slice(&[self.value, self.count]);
            self.count = 0;
        }
    }
}

/// Length of the run of `v` at the start of `bytes` (at least 1 when
/// `bytes[0] == v`).
#[inline]
fn run_length(bytes: &[u8], v: u8) -> usize {
    let pattern = u64::from_ne_bytes([v; 8]);
    let mut n = 0;
    let mut chunks = bytes.chunks_exact(8);
    for chunk in &mut chunks {
        let word = u64::from_le_bytes(chunk.try_into().expect("chunk of 8"));
        let diff = word ^ pattern;
        if diff != 0 {
            return n + (diff.trailing_zeros() / 8) as usize;
        }
        n += 8;
    }
    n + chunks.remainder().iter().take_while(|&&b| b == v).count()
}

/// Reads a binvox file from memory. Errors: bad or missing header lines,
/// zero-length runs, values other than 0/1, data shorter or longer than the
/// grid, and grids over `limit` (checked from the header).
pub fn read(bytes: &[u8], limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
    let bad = |m: &str| VoxkitError::invalid(format!("binvox: {m}"));
    let mut pos = 0;
    let mut next_line = || -> Result<&str> {
        let rest = &bytes[pos..];
        let end = rest
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| bad("truncated header"))?;
        pos += end + 1;
        std::str::from_utf8(&rest[..end])
            .map(str::trim)
            .map_err(|_| bad("header is not text"))
    };
    let magic = next_line()?;
    if !magic.starts_with("#binvox") {
        return Err(bad("missing '#binvox' magic"));
    }
    let (mut dim, mut translate, mut scale) = (None, None, None);
    loop {
        let line = next_line()?;
        let mut words = line.split_whitespace();
        let key = words.next();
        let nums: Vec<&str> = words.collect();
        let parse_f = |s: &&str| s.parse::<f64>().ok().filter(|v| v.is_finite());
        match key {
            Some("data") => break,
            Some("dim") => {
                let v: Option<Vec<usize>> = nums.iter().map(|s| s.parse().ok()).collect();
                match v.as_deref() {
                    Some(&[a, b, c]) if a > 0 && b > 0 && c > 0 => dim = Some([a, b, c]),
                    _ => return Err(bad(&format!("bad dim line {line:?}"))),
                }
            }
            Some("translate") => {
                let v: Option<Vec<f64>> = nums.iter().map(parse_f).collect();
                match v.as_deref() {
                    Some(&[x, y, z]) => translate = Some(DVec3::new(x, y, z)),
                    _ => return Err(bad(&format!("bad translate line {line:?}"))),
                }
            }
            Some("scale") => match nums.first().and_then(parse_f) {
                Some(s) if s > 0.0 && nums.len() == 1 => scale = Some(s),
                _ => return Err(bad(&format!("bad scale line {line:?}"))),
            },
            None => {}
            Some(other) => return Err(bad(&format!("unknown header field {other:?}"))),
        }
    }
    let [d0, d1, d2] = dim.ok_or_else(|| bad("no dim line"))?;
    let translate = translate.unwrap_or(DVec3::ZERO);
    let scale = scale.unwrap_or(1.0);
    if [d0, d1, d2].iter().any(|&d| d > i32::MAX as usize) {
        return Err(bad("dimensions too large"));
    }
    // Header order is the data order (x, z, y).
    let dims = [d0, d2, d1];
    check_sparse_budget(dims, limit, "binvox grid")?;
    let total = d0 as u128 * d1 as u128 * d2 as u128;
    let (plane, col) = (d1 as u128 * d2 as u128, d2 as u128);
    let data = &bytes[pos..];
    if !data.len().is_multiple_of(2) {
        return Err(bad("data ends in the middle of a run (truncated?)"));
    }
    let mut grid = BrickGrid::new();
    let mut index: u128 = 0;
    for (k, pair) in data.chunks_exact(2).enumerate() {
        let (value, count) = (pair[0], pair[1] as u128);
        if count == 0 || value > 1 {
            return Err(bad(&format!(
                "bad run {k}: value {value}, count {count} (value must be 0/1, count 1..=255)"
            )));
        }
        if index + count > total {
            return Err(bad(&format!(
                "data covers more than the {total} voxels of the grid"
            )));
        }
        if value == 1 {
            for i in index..index + count {
                let x = i / plane;
                let z = (i % plane) / col;
                let y = i % col;
                grid.insert(Voxel::new(x as i32, y as i32, z as i32));
            }
        }
        index += count;
    }
    if index != total {
        return Err(bad(&format!(
            "data covers {index} of {total} voxels (truncated?)"
        )));
    }
    let hmax = *dims.iter().max().expect("three dims") as f64;
    Ok((grid, GridFrame::new(translate, scale / hmax, dims)))
}

#[cfg(test)]
mod rle_tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The plain one-byte-at-a-time encoder the word-wise one replaces.
    fn reference(chunks: &[Vec<u8>]) -> Vec<u8> {
        let mut out = Vec::new();
        let (mut value, mut count) = (0u8, 0u8);
        for &b in chunks.iter().flatten() {
            if count > 0 && (b != value || count == 255) {
                out.extend_from_slice(&[value, count]);
                count = 0;
            }
            value = b;
            count += 1;
        }
        if count > 0 {
            out.extend_from_slice(&[value, count]);
        }
        out
    }

    #[test]
    fn word_wise_runs_match_the_bytewise_encoder() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        for case in 0..300 {
            // Slabs of random length made of runs of random length, so runs
            // cross slab boundaries, word boundaries and the 255 limit.
            let chunks: Vec<Vec<u8>> = (0..rng.random_range(1..5))
                .map(|_| {
                    let mut v = Vec::new();
                    let len = rng.random_range(0..2000);
                    while v.len() < len {
                        let run = if case % 2 == 0 {
                            rng.random_range(1..20)
                        } else {
                            rng.random_range(1..700)
                        };
                        let b = rng.random_range(0..2u8);
                        v.extend(std::iter::repeat_n(b, run));
                    }
                    v.truncate(len);
                    v
                })
                .collect();
            let mut rle = Rle::default();
            let mut out = Vec::new();
            for c in &chunks {
                rle.push_slice(c, &mut out);
            }
            rle.finish(&mut out);
            assert_eq!(out, reference(&chunks), "case {case}");
        }
    }
}
