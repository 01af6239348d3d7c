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
//! - Header lines after the magic that start with `#` are comments and
//!   skipped (some writers put a generator note there); blank lines and
//!   `\r\n` line ends are accepted too.
//! - Coordinates are written with Rust's shortest round-trip formatting, so
//!   `translate` reads back bit-exactly.

use std::io::Write;

use glam::DVec3;
use rayon::prelude::*;

use super::voxels::check_sparse_budget;
use crate::error::{Result, VoxkitError};
use crate::grid::brick::BrickMask;
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
    // The writer's own memory: the brick order (4 bytes per stored mask),
    // a brick layer per thread (up to (d/8)² bricks of 24 bytes), never a
    // mask per tile, and per thread the runs of two layers (found and being
    // encoded, 16 bytes a run).
    let (d_wide, batch) = (d as u128, layer_batch() as u128);
    let layer = d_wide.div_ceil(8).pow(2);
    let runs = layer_runs_bound(grid, d);
    limit.check(
        "binvox writer",
        4 * grid.mask_count() as u128 + 24 * layer * batch + 2 * 16 * runs * batch,
        1,
    )?;
    write!(
        w,
        "#binvox 1\ndim {d} {d} {d}\ntranslate {} {} {}\nscale {}\ndata\n",
        o.x,
        o.y,
        o.z,
        d as f64 * frame.voxel_size
    )?;
    write_runs(w, grid, d as u64)
}

/// An upper bound of the runs of set voxels that [`layer_runs`] finds in
/// any one x layer of bricks: at most ⌈d/2⌉ on each of its 8·d lines along
/// y (a checkerboard's, 64·d² bytes), and at most 4 per brick line, 256
/// per stored mask and 64 per tile, of the layer's bricks (a surface's
/// layer has a few thousand bricks).
fn layer_runs_bound(grid: &BrickGrid, d: usize) -> u128 {
    let mut per_layer = vec![0u128; d.div_ceil(8)];
    let masks = grid.bricks().take(grid.mask_count()).map(|(k, _)| (k, 256));
    for (k, most) in masks.chain(grid.tiles().map(|k| (k, 64))) {
        if let Some(n) = usize::try_from(k.x).ok().and_then(|x| per_layer.get_mut(x)) {
            *n += most;
        }
    }
    let worst = 8 * d as u128 * (d as u128).div_ceil(2);
    per_layer.into_iter().max().unwrap_or(0).min(worst)
}

/// Bit `ly` of the result is bit `8 ly` of `column` (the y column of a
/// brick word at `lx = 0`): the eight bits are gathered by one multiply
/// (the shifted copies land on distinct bits of the top byte, no carries).
#[inline]
fn column_bits(column: u64) -> u8 {
    (column.wrapping_mul(0x0102_0408_1020_4080) >> 56) as u8
}

/// The data section: runs over the `d³` voxels in binvox order (x, then z,
/// then y fastest), computed from the bricks alone: one x layer of bricks
/// at a time ([`BrickGrid::brick_layers`]), its runs of set voxels found by
/// [`layer_runs`] (a batch of layers in parallel, while the batch before
/// is encoded), then encoded in order with the zero runs between them. The
/// cost grows with the occupied bricks and the number of runs, not with
/// `d³` (a 1024³ box is 10^9 voxels, a surface in it a few million), and
/// nothing is sorted per voxel. The bytes depend only on the voxels, so
/// they are the same for any number of threads.
fn write_runs(w: &mut dyn Write, grid: &BrickGrid, d: u64) -> Result<()> {
    let mut rle = Rle::default();
    let mut out = Vec::with_capacity(1 << 16);
    let mut pos = 0u64; // next voxel index to encode
    // A layer per thread at a time (their runs take 16 bytes per run of
    // set voxels, two per y line crossing a solid).
    let batch = layer_batch();
    let mut layers = grid.brick_layers(0);
    // Each thread's runs: the batch being found and the one being encoded
    // meanwhile, kept from batch to batch (fresh vectors would fault their
    // pages in again for every layer).
    let (mut found, mut encoding) = (vec![Vec::new(); batch], vec![Vec::new(); batch]);
    let mut held = 0; // layers in `encoding`
    loop {
        let slabs: Vec<_> = layers.by_ref().take(batch).collect();
        let n = slabs.len();
        if n == 0 && held == 0 {
            break;
        }
        let scan = |found: &mut [Vec<(u64, u64)>]| {
            slabs
                .into_par_iter()
                .zip(found)
                .for_each(|((bx, slab), runs)| layer_runs(bx, slab, d, runs))
        };
        let encode = || {
            for &(s, e) in encoding[..held].iter().flatten() {
                rle.push_run(0, s - pos, &mut out);
                rle.push_run(1, e - s, &mut out);
                pos = e;
            }
        };
        rayon::join(|| scan(&mut found[..n]), encode);
        w.write_all(&out)?;
        out.clear();
        std::mem::swap(&mut found, &mut encoding);
        held = n;
    }
    rle.push_run(0, d * d * d - pos, &mut out);
    rle.finish(&mut out);
    w.write_all(&out)?;
    Ok(())
}

/// Brick layers encoded at a time: one per thread.
fn layer_batch() -> usize {
    rayon::current_num_threads().max(1)
}

/// Into `runs`: the runs `s..e` of set voxels (as binvox indices, rising,
/// each as long as it can be) of the x layer of bricks `bx`: walked one z
/// row at a time, each brick giving the 8 voxels of its y column at that
/// `(x, z)` by a shift and a gather (a tile's column is one run of 8,
/// going on from the last brick's), its runs joined to the open one where
/// they touch.
fn layer_runs(bx: i32, mut slab: Vec<(Voxel, &BrickMask)>, d: u64, runs: &mut Vec<(u64, u64)>) {
    slab.sort_unstable_by_key(|(k, _)| (k.z, k.y));
    runs.clear();
    // The open run `s..e` (`s == e`: none).
    let (mut s, mut e) = (0u64, 0u64);
    // Bit `x + 8·y` of a brick word holds (x, y): the column at x.
    const COLUMN: u64 = 0x0101_0101_0101_0101;
    for lx in 0..8 {
        let x = bx as u64 * 8 + lx;
        for row in slab.chunk_by(|a, b| a.0.z == b.0.z) {
            for lz in 0..8 {
                let z = row[0].0.z as u64 * 8 + lz;
                let line = (x * d + z) * d;
                for (k, m) in row {
                    let mut ys = column_bits(m[lz as usize] >> lx & COLUMN);
                    while ys != 0 {
                        let y0 = ys.trailing_zeros();
                        let len = (!(ys >> y0)).trailing_zeros();
                        ys &= !((((1u16 << len) - 1) << y0) as u8);
                        let at = line + k.y as u64 * 8 + u64::from(y0);
                        if at != e || e == s {
                            if e > s {
                                runs.push((s, e));
                            }
                            s = at;
                            e = at;
                        }
                        e += u64::from(len);
                    }
                }
            }
        }
    }
    if e > s {
        runs.push((s, e));
    }
}

/// Run-length encoder state: the open run.
#[derive(Default)]
struct Rle {
    value: u8,
    count: u8,
}

impl Rle {
    /// Appends `len` voxels of value `v`, continuing the open run. The same
    /// bytes as a voxel-at-a-time encoder (runs greedily filled to 255), but
    /// a long run costs one store per 255 voxels.
    fn push_run(&mut self, v: u8, mut len: u64, out: &mut Vec<u8>) {
        if len == 0 {
            return;
        }
        if self.count > 0 && self.value == v {
            let take = len.min(255 - self.count as u64);
            self.count += take as u8;
            len -= take;
            if len == 0 {
                return;
            }
        }
        // The open run is full or of the other value: close it.
        if self.count > 0 {
            out.extend_from_slice(&[self.value, self.count]);
        }
        let full = (len - 1) / 255; // keep the last (partial or full) run open
        let at = out.len();
        out.resize(at + 2 * full as usize, 255);
        out[at..].chunks_exact_mut(2).for_each(|pair| pair[0] = v);
        self.value = v;
        self.count = (len - 255 * full) as u8;
    }

    fn finish(&mut self, out: &mut Vec<u8>) {
        if self.count > 0 {
            out.extend_from_slice(&[self.value, self.count]);
            self.count = 0;
        }
    }
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
        if line.starts_with('#') {
            continue; // a comment line, as some writers emit after the magic
        }
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
    // Runs arrive x layer by x layer: the bricks of one x layer of bricks
    // are gathered in `layer` and moved into `grid` when x leaves it, full
    // ones as tiles, so reading a solid never holds its interior as masks.
    let mut grid = BrickGrid::new();
    let mut layer = BrickGrid::new();
    let mut layer_x = 0i32;
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
        // The run's pieces along y columns.
        let mut i = index;
        while value == 1 && i < index + count {
            let (x, z, y) = (i / plane, (i % plane) / col, i % col);
            let n = (col - y).min(index + count - i);
            let (x, z) = (x as i32, z as i32);
            if x >> 3 != layer_x {
                grid.union_with(&layer);
                layer = BrickGrid::new();
                layer_x = x >> 3;
            }
            set_column(&mut layer, x, z, y as i32, (y + n) as i32);
            i += n;
        }
        index += count;
    }
    grid.union_with(&layer);
    if index != total {
        return Err(bad(&format!(
            "data covers {index} of {total} voxels (truncated?)"
        )));
    }
    let hmax = *dims.iter().max().expect("three dims") as f64;
    Ok((grid, GridFrame::new(translate, scale / hmax, dims)))
}

/// Sets voxels `(x, y, z)` for `y` in `y0..y1`, a brick word at a time.
fn set_column(grid: &mut BrickGrid, x: i32, z: i32, y0: i32, y1: i32) {
    let mut y = y0;
    while y < y1 {
        let by = y >> 3;
        let stop = (8 * by + 8).min(y1);
        let mut m = [0u64; 8];
        for ly in (y & 7)..(stop - 8 * by) {
            m[(z & 7) as usize] |= 1u64 << ((x & 7) + 8 * ly);
        }
        grid.or_brick(Voxel::new(x >> 3, by, z >> 3), &m);
        y = stop;
    }
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
    fn column_bits_gathers_every_eighth_bit() {
        for b in 0..=255u8 {
            let column = (0..8).fold(0u64, |c, y| c | u64::from(b >> y & 1) << (8 * y));
            // Other bits of the word never leak in once masked to the column.
            assert_eq!(column_bits(column), b);
        }
    }

    /// The writer's memory check counts its run vectors: a checkerboard
    /// (a run per other voxel) asks for more than a lone voxel in the same
    /// box, and a limit between the two refuses the first before writing a
    /// byte of its data while the second is written.
    #[test]
    fn memory_check_counts_the_runs() {
        let d = 64usize;
        let frame = GridFrame::new(glam::DVec3::ZERO, 1.0, [d; 3]);
        let mut board = BrickGrid::new();
        for x in 0..d as i32 {
            for z in 0..d as i32 {
                for y in 0..d as i32 {
                    if (x + y + z) % 2 == 0 {
                        board.insert(Voxel::new(x, y, z));
                    }
                }
            }
        }
        let mut lone = BrickGrid::new();
        lone.insert(Voxel::new(5, 6, 7));
        // Two threads: bricks and brick order 4·512 + 2·24·64 bytes; the
        // board's runs 2 · 32 · 8·64·32 = 1 MiB, the lone voxel's 16 KiB.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        pool.install(|| {
            let limit = MemoryLimit::new(256 << 10);
            let mut out = Vec::new();
            let err = write(&mut out, &board, &frame, limit).unwrap_err();
            assert!(matches!(err, VoxkitError::Limits { .. }), "{err}");
            assert!(out.is_empty(), "nothing written");
            let mut out = Vec::new();
            write(&mut out, &lone, &frame, limit).unwrap();
            let (back, _) = read(&out, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(back, lone);
            // Under the default limit the board is written and reads back.
            let mut out = Vec::new();
            write(&mut out, &board, &frame, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(read(&out, MemoryLimit::DEFAULT).unwrap().0, board);
        });
    }

    #[test]
    fn sparse_runs_match_the_bytewise_encoder_of_the_dense_grid() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        for case in 0..200 {
            // Random boxes with clusters, lines and lone voxels, so runs
            // cross slab boundaries and the 255 limit, and slabs are empty.
            let d = rng.random_range(1..40u64);
            let mut grid = BrickGrid::new();
            let mut dense = vec![0u8; (d * d * d) as usize];
            let n = if case % 3 == 0 {
                0
            } else {
                rng.random_range(0..d * d * 2)
            };
            for _ in 0..n {
                let c = [0; 3].map(|_| rng.random_range(0..d) as i32);
                let len = if case % 2 == 0 {
                    1
                } else {
                    rng.random_range(1..d as i32 + 1)
                };
                for y in c[1]..(c[1] + len).min(d as i32) {
                    grid.insert(Voxel::new(c[0], y, c[2]));
                    dense[((c[0] as u64 * d + c[2] as u64) * d + y as u64) as usize] = 1;
                }
            }
            // Tiles: whole bricks inside the box, beside partial ones.
            let bricks_inside = (d / 8) as i32;
            for _ in 0..if case % 4 == 1 { n.min(12) } else { 0 } {
                if bricks_inside == 0 {
                    break;
                }
                let b = [0; 3].map(|_| rng.random_range(0..bricks_inside));
                grid.insert_tile(Voxel::from_array(b));
                for l in 0..512 {
                    let v = [b[0] * 8 + l % 8, b[1] * 8 + l / 8 % 8, b[2] * 8 + l / 64];
                    dense[((v[0] as u64 * d + v[2] as u64) * d + v[1] as u64) as usize] = 1;
                }
            }
            // Layers are encoded a batch per thread count: the bytes may
            // not depend on it.
            let threads = 1 + case % 3;
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut out = Vec::new();
            pool.install(|| write_runs(&mut out, &grid, d)).unwrap();
            assert_eq!(out, reference(&[dense]), "case {case}, {threads} threads");
            // And back: the same voxels, full bricks as tiles.
            let mut file = format!("#binvox 1\ndim {d} {d} {d}\ndata\n").into_bytes();
            file.extend_from_slice(&out);
            let (back, _) = read(&file, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(back, grid, "case {case}");
            assert!(
                back.bricks()
                    .all(|(k, m)| back.is_tile(k) || *m != [u64::MAX; 8])
            );
        }
    }
}
