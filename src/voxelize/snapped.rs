//! Thin and thick surfaces for vertices snapped to the voxel lattice, by
//! Kahan–Kelsen indexing (the "thin route" of DESIGN.md for snapped input).
//!
//! # Method
//! The voxel set is the one [`voxelize_surface`](super::surface::voxelize_surface)
//! builds — for every family of lattice lines of the mode and every lattice
//! point `(i, j)` of the closed projected triangle, the voxel at depth
//! `T = floor(t + 1/2)` — but enumerated differently. With every vertex a
//! multiple of [`VOXEL_ONE`], a family's unimodular map sends the triangle to
//! one with *integer* `(u, v, t)` vertices, so its projection is a lattice
//! triangle. Each `(triangle, family)` pair with non-zero projected area
//! becomes a [`TriangleIndex`]; one [`MeshIndex`] takes the prefix sum of
//! their point counts, and the global range of `(pair, point)` indices is cut
//! into even chunks, so threads get equal numbers of points however unequal
//! the triangles are (one huge triangle is split among all threads).
//!
//! # Exactness
//! For a pair with integer family vertices `P0 = (u0, v0, t0)`, `P1`, `P2`
//! and normal `(a, b, c) = (P1 − P0) × (P2 − P0)` oriented so that `c > 0`,
//! the line through `(i, j)` meets the plane at
//! `t = t0 − (a·(i − u0) + b·(j − v0)) / c`, hence
//! `T = t0 + floor((c − 2a·(i − u0) − 2b·(j − v0)) / (2c))`: the same rational
//! the crossing kernel rounds, in integers. Per point that is two multiplies,
//! and one floor division done as a multiplication by a precomputed `f64`
//! reciprocal with an exact one-step correction while the numerator stays
//! below 2^50; pairs that could exceed it (spans of tens of thousands of
//! voxels) take an `i128` path. Pairs whose projection has zero area are not
//! indexed, as the kernel skips them.
//!
//! Triangles are indexed in batches of [`BATCH_TRIANGLES`], which bounds the
//! set-up's memory; each batch is split evenly on its own.
//!
//! # Storage and determinism
//! Each chunk collects its voxels in bricks keyed by brick coordinate (a
//! hash table behind a small direct-mapped cache); the chunks' bricks are
//! then sorted by key and OR-merged. The result is the same set, in the same
//! order (z, then y, then x brick), for any number of threads.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use rayon::prelude::*;

use super::slab::{BRICK, BrickBits};
use super::surface::{LineFamily, SurfaceMode, SurfaceTriangle, VOXEL_FRAC_BITS, VOXEL_ONE};
use crate::error::{Result, VoxkitError};
use crate::grid::Voxel;
use crate::triangle::{MeshIndex, TriangleIndex};

/// Largest vertex coordinate (in voxels) [`voxelize_snapped`] takes: twice
/// the largest grid side, so that family coordinates stay below 2^25 and the
/// plane coefficients below 2^52.
pub const MAX_SNAPPED_COORD: i64 = 1 << 23;

/// Triangles indexed at a time: bounds the set-up's memory
/// ([`BYTES_PER_PAIR`] per pair) while leaving each batch enough points to
/// split evenly across threads.
pub const BATCH_TRIANGLES: usize = 1 << 13;

/// Points per chunk at least: below this a chunk's set-up (a brick table)
/// outweighs its work.
const MIN_CHUNK: u64 = 1 << 14;

/// Numerators of the depth division below this take the `f64` reciprocal
/// path (see [`div_floor_recip`]).
const RECIP_SAFE: i128 = 1 << 50;

/// What a lattice point of one `(triangle, family)` pair needs for its depth
/// and voxel.
#[derive(Clone, Copy, Debug)]
struct Plane {
    family: LineFamily,
    /// The triangle's index in its batch.
    tri: u32,
    /// Vertex 0 of the pair, in family lattice coordinates.
    u0: i64,
    v0: i64,
    t0: i64,
    /// `2a`, `2b` and the divisor `2c > 0` of the depth formula.
    a2: i64,
    b2: i64,
    c2: i64,
    /// `1 / (2c)`, rounded.
    recip: f64,
    /// Whether numerators can reach [`RECIP_SAFE`]: then `i128`.
    wide: bool,
}

impl Plane {
    /// The pair's plane, or `None` when the projection has zero area.
    fn new(p: &[[i64; 3]; 3], family: LineFamily, tri: u32) -> Option<Plane> {
        let w = p.map(|q| q.map(i128::from));
        let e1 = [0, 1, 2].map(|k| w[1][k] - w[0][k]);
        let e2 = [0, 1, 2].map(|k| w[2][k] - w[0][k]);
        let mut a = e1[1] * e2[2] - e1[2] * e2[1];
        let mut b = e1[2] * e2[0] - e1[0] * e2[2];
        let mut c = e1[0] * e2[1] - e1[1] * e2[0];
        if c == 0 {
            return None;
        }
        if c < 0 {
            (a, b, c) = (-a, -b, -c);
        }
        // Every lattice point of the closed projection lies in the vertices'
        // bounding box, so |i − u0| and |j − v0| are at most the box's sides.
        let du = (0..3).map(|k| (w[k][0] - w[0][0]).abs()).max().unwrap_or(0);
        let dv = (0..3).map(|k| (w[k][1] - w[0][1]).abs()).max().unwrap_or(0);
        let bound = c + 2 * a.abs() * du + 2 * b.abs() * dv;
        // Family coordinates are within ±2^24 (vertices within
        // ±MAX_SNAPPED_COORD, the diagonal maps add two of them), so the
        // doubled coefficients (below 2^53) fit i64; only their products with
        // the offsets may not.
        Some(Plane {
            family,
            tri,
            u0: p[0][0],
            v0: p[0][1],
            t0: p[0][2],
            a2: (2 * a) as i64,
            b2: (2 * b) as i64,
            c2: (2 * c) as i64,
            recip: 1.0 / (2 * c) as f64,
            wide: bound >= RECIP_SAFE,
        })
    }

    /// The crossing voxel of the family's line through lattice point `(i, j)`
    /// (unclamped).
    #[inline(always)]
    fn voxel(&self, i: i64, j: i64) -> Voxel {
        let (di, dj) = (i - self.u0, j - self.v0);
        let dt = if self.wide {
            self.depth_wide(di, dj)
        } else {
            let n = (self.c2 >> 1) - self.a2 * di - self.b2 * dj;
            div_floor_recip(n, self.c2, self.recip)
        };
        self.family.to_voxel(i, j, self.t0 + dt)
    }

    /// The depth offset in `i128` (pairs spanning tens of thousands of voxels).
    #[cold]
    #[inline(never)]
    fn depth_wide(&self, di: i64, dj: i64) -> i64 {
        let n = i128::from(self.c2 >> 1)
            - i128::from(self.a2) * i128::from(di)
            - i128::from(self.b2) * i128::from(dj);
        n.div_euclid(i128::from(self.c2)) as i64
    }
}

/// A snapped triangle in `family`'s coordinates, in lattice units.
#[inline]
fn project(tri: &SurfaceTriangle, family: LineFamily) -> [[i64; 3]; 3] {
    tri.map(|q| family.to_family(q).map(|c| c >> VOXEL_FRAC_BITS))
}

/// Bytes per `(triangle, family)` pair of the Kahan–Kelsen set-up (its
/// [`TriangleIndex`] and depth plane), for memory estimates.
pub const BYTES_PER_PAIR: u64 = 480;

/// `floor(n / d)` for `0 < d` and `|n| < 2^50`, `d < 2^51`, given `recip =
/// 1/d` rounded: the product carries two roundings of relative size 2^-53,
/// so it is within 1/4 of `n/d` (below 2^50 in magnitude) and its truncation
/// within one of the floor; the remainder's sign fixes it exactly.
#[inline(always)]
fn div_floor_recip(n: i64, d: i64, recip: f64) -> i64 {
    debug_assert!(d > 0 && n.unsigned_abs() < 1 << 50);
    let q = (n as f64 * recip) as i64;
    let r = n - q * d;
    if r < 0 {
        q - 1
    } else if r >= d {
        q + 1
    } else {
        q
    }
}

/// A hasher for packed brick keys: one multiply, enough for keys that are
/// already well spread coordinates.
#[derive(Default)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ u64::from(b)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    fn write_u64(&mut self, k: u64) {
        self.0 = (k ^ (k >> 29)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

/// Bits per brick coordinate in a packed key: grids have at most 2^22
/// voxels, 2^19 bricks, per axis.
const KEY_BITS: u32 = 21;

/// Packs brick coordinates (non-negative) so that key order is z, y, x.
#[inline(always)]
fn brick_key(bx: u32, by: u32, bz: u32) -> u64 {
    (u64::from(bz) << (2 * KEY_BITS)) | (u64::from(by) << KEY_BITS) | u64::from(bx)
}

/// Entries of [`ChunkBricks`]'s brick cache (a power of two).
const CACHE: usize = 16;

/// The bricks one chunk writes, in first-touch order.
struct ChunkBricks {
    dims: [i32; 3],
    slots: HashMap<u64, u32, BuildHasherDefault<KeyHasher>>,
    bricks: Vec<(u64, BrickBits)>,
    /// Recently used bricks, direct-mapped by brick coordinates: the index's
    /// order alternates between a point and its mirror in the triangle, so
    /// consecutive voxels often toggle between a few bricks, and a hash
    /// lookup per toggle cost more than the rest of the point.
    /// `(key, slot)`; key `u64::MAX` = empty.
    cache: [(u64, u32); CACHE],
}

impl ChunkBricks {
    fn new(dims: [i32; 3]) -> Self {
        ChunkBricks {
            dims,
            slots: HashMap::default(),
            bricks: Vec::new(),
            cache: [(u64::MAX, 0); CACHE],
        }
    }

    /// Sets voxel `v` after clamping each coordinate into `0..dims`, exactly
    /// as [`SlabBricks::set`](super::slab::SlabBricks::set) does (crossings on
    /// the grid's max faces are clamped, not dropped).
    #[inline(always)]
    fn set(&mut self, v: Voxel) {
        let x = v.x.clamp(0, self.dims[0] - 1) as u32;
        let y = v.y.clamp(0, self.dims[1] - 1) as u32;
        let z = v.z.clamp(0, self.dims[2] - 1) as u32;
        let (bx, by, bz) = (x >> 3, y >> 3, z >> 3);
        let key = brick_key(bx, by, bz);
        // Face-adjacent bricks land in different cache entries.
        let line = (bx
            .wrapping_add(by.wrapping_mul(3))
            .wrapping_add(bz.wrapping_mul(5))) as usize
            & (CACHE - 1);
        let mut slot = self.cache[line].1;
        if self.cache[line].0 != key {
            slot = self.slot_of(key);
            self.cache[line] = (key, slot);
        }
        let bits = &mut self.bricks[slot as usize].1;
        bits[(z & 7) as usize] |= 1u64 << ((x & 7) | ((y & 7) << 3));
    }

    /// The arena slot of brick `key`, allocating it on first touch.
    #[inline(never)]
    fn slot_of(&mut self, key: u64) -> u32 {
        let next = self.bricks.len() as u32;
        let slot = *self.slots.entry(key).or_insert(next);
        if slot == next {
            self.bricks.push((key, [0; 8]));
        }
        slot
    }
}

/// Surface voxelization of triangles whose vertices are all multiples of
/// [`VOXEL_ONE`] (snapped to voxel centres), by Kahan–Kelsen enumeration of
/// the projected lattice triangles (see the [module docs](self)). The voxel
/// set equals [`voxelize_surface`](super::surface::voxelize_surface)'s for
/// the same triangles, `dims` and `mode`, including the clamping of
/// crossings outside `0..dims` into the grid. Returns the occupied bricks
/// (min corner, bits), each exactly once, sorted by z, y, x brick; the result
/// does not depend on the number of threads.
///
/// # Errors
/// [`VoxkitError::Invalid`] if a vertex is not a multiple of [`VOXEL_ONE`]
/// or has a coordinate beyond ±[`MAX_SNAPPED_COORD`] voxels, or if `dims` is
/// not within `1..=2^22` per axis.
///
/// ```
/// use voxkit::voxelize::snapped::voxelize_snapped;
/// use voxkit::voxelize::surface::{SurfaceMode, VOXEL_ONE, voxelize_surface};
/// let o = VOXEL_ONE;
/// let tri = [[0, 0, 0], [4 * o, 0, 2 * o], [0, 3 * o, 3 * o]];
/// let kk = voxelize_snapped(&[tri], [8, 8, 8], SurfaceMode::Thin).unwrap();
/// let mut lines = voxelize_surface(&[tri], [8, 8, 8], SurfaceMode::Thin);
/// lines.sort_by_key(|(c, _)| [c[2], c[1], c[0]]);
/// assert_eq!(kk, lines);
/// ```
pub fn voxelize_snapped(
    triangles: &[SurfaceTriangle],
    dims: [i32; 3],
    mode: SurfaceMode,
) -> Result<Vec<([i32; 3], BrickBits)>> {
    voxelize_snapped_chunked(triangles, dims, mode, MIN_CHUNK, BATCH_TRIANGLES)
}

/// [`voxelize_snapped`] with chunks of at least `min_chunk` points and
/// batches of `batch` triangles (tests use small ones to split small inputs
/// among many chunks and batches).
fn voxelize_snapped_chunked(
    triangles: &[SurfaceTriangle],
    dims: [i32; 3],
    mode: SurfaceMode,
    min_chunk: u64,
    batch: usize,
) -> Result<Vec<([i32; 3], BrickBits)>> {
    if dims.iter().any(|&d| !(1..=1 << 22).contains(&d)) {
        return Err(VoxkitError::invalid(format!(
            "grid dimensions {dims:?} outside 1..=2^22"
        )));
    }
    let limit = MAX_SNAPPED_COORD * VOXEL_ONE;
    if let Some(t) = triangles.iter().position(|t| {
        t.iter()
            .flatten()
            .any(|&c| c & (VOXEL_ONE - 1) != 0 || !(-limit..=limit).contains(&c))
    }) {
        return Err(VoxkitError::invalid(format!(
            "triangle {t}: vertices must be voxel centres within ±2^23 voxels"
        )));
    }
    let families = mode.families();
    let mut chunks = Vec::new();
    let size = batch.max(1);
    for (b, tris) in triangles.chunks(size).enumerate() {
        let (mesh, planes) = index_batch(tris, b * size, families)?;
        let planes = &planes;
        chunks.extend(mesh.map_chunks_par(
            min_chunk,
            |_| ChunkBricks::new(dims),
            |bricks, pair, [i, j]| bricks.set(planes[pair].voxel(i, j)),
        ));
    }
    Ok(merge_chunks(chunks))
}

/// The [`MeshIndex`] of the `(triangle, family)` pairs of `batch` (whose
/// first triangle is number `first` of the input) with non-zero projected
/// area, and their planes in the same order.
fn index_batch(
    batch: &[SurfaceTriangle],
    first: usize,
    families: &[LineFamily],
) -> Result<(MeshIndex, Vec<Plane>)> {
    // In parallel: the planes first, then the indexing's O(bits)
    // precomputation (the route's fixed cost per pair), each collected once
    // at its exact size.
    let planes: Vec<Plane> = batch
        .par_iter()
        .enumerate()
        .flat_map_iter(|(t, tri)| {
            families
                .iter()
                .filter_map(move |&family| Plane::new(&project(tri, family), family, t as u32))
        })
        .collect();
    let indices = planes
        .par_iter()
        .map(|pl| {
            let p = project(&batch[pl.tri as usize], pl.family);
            TriangleIndex::new(p.map(|q| [q[0], q[1]])).map_err(|e| {
                VoxkitError::invalid(format!("triangle {}: {e}", first + pl.tri as usize))
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((MeshIndex::from_indices(indices)?, planes))
}

/// Sorts the chunks' bricks by key and ORs duplicates: the union, in key
/// order, whatever the chunking.
fn merge_chunks(chunks: Vec<ChunkBricks>) -> Vec<([i32; 3], BrickBits)> {
    // Sort 16-byte references rather than the 72-byte bricks themselves.
    let mut order: Vec<(u64, u32, u32)> = chunks
        .iter()
        .enumerate()
        .flat_map(|(c, ch)| {
            ch.bricks
                .iter()
                .enumerate()
                .map(move |(s, b)| (b.0, c as u32, s as u32))
        })
        .collect();
    order.par_sort_unstable();
    let mut out: Vec<([i32; 3], BrickBits)> = Vec::with_capacity(order.len());
    let mut last_key = u64::MAX;
    let mask = (1u64 << KEY_BITS) - 1;
    for (key, c, s) in order {
        let bits = &chunks[c as usize].bricks[s as usize].1;
        if key == last_key {
            let merged = &mut out.last_mut().expect("a brick with this key was pushed").1;
            for (m, b) in merged.iter_mut().zip(bits) {
                *m |= b;
            }
        } else {
            let corner = [key & mask, (key >> KEY_BITS) & mask, key >> (2 * KEY_BITS)]
                .map(|c| c as i32 * BRICK);
            out.push((corner, *bits));
            last_key = key;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Mesh, fit_frame};
    use crate::voxelize::pipeline::quantize_mesh;
    use crate::voxelize::shapes::{IndexedMesh, random_rotation};
    use crate::voxelize::surface::voxelize_surface;
    use glam::DVec3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const MODES: [SurfaceMode; 2] = [SurfaceMode::Thin, SurfaceMode::Thick];

    /// The crossing kernel's bricks in the KK route's order.
    fn by_lines(
        tris: &[SurfaceTriangle],
        dims: [i32; 3],
        mode: SurfaceMode,
    ) -> Vec<([i32; 3], BrickBits)> {
        let mut b = voxelize_surface(tris, dims, mode);
        b.sort_by_key(|(c, _)| [c[2], c[1], c[0]]);
        b
    }

    fn count(b: &[([i32; 3], BrickBits)]) -> u64 {
        b.iter()
            .map(|(_, m)| m.iter().map(|w| u64::from(w.count_ones())).sum::<u64>())
            .sum()
    }

    fn assert_same(tris: &[SurfaceTriangle], dims: [i32; 3], what: &str) {
        for mode in MODES {
            let want = by_lines(tris, dims, mode);
            for (min_chunk, batch) in [(1, 5), (97, 64), (MIN_CHUNK, BATCH_TRIANGLES)] {
                let got = voxelize_snapped_chunked(tris, dims, mode, min_chunk, batch).unwrap();
                assert_eq!(
                    count(&got),
                    count(&want),
                    "{what} {mode:?} chunk {min_chunk}"
                );
                assert_eq!(got, want, "{what} {mode:?} chunk {min_chunk}");
            }
        }
    }

    /// A snapped vertex with coordinates in `lo..=hi` voxels per axis.
    fn vertex(rng: &mut ChaCha8Rng, lo: [i64; 3], hi: [i64; 3]) -> [i64; 3] {
        std::array::from_fn(|a| rng.random_range(lo[a]..=hi[a]) * VOXEL_ONE)
    }

    /// Triangles of very different sizes: one spanning most of the grid,
    /// mid-sized ones, many tiny ones (some degenerate in a family or
    /// entirely), and some reaching past the grid's faces.
    fn soup(rng: &mut ChaCha8Rng, dims: [i32; 3], n: usize) -> Vec<SurfaceTriangle> {
        let d = dims.map(i64::from);
        let mut tris = vec![[
            vertex(rng, [0; 3], [d[0] / 4, d[1] / 4, d[2] - 1]),
            vertex(rng, [d[0] * 3 / 4, 0, 0], [d[0] - 1, d[1] / 4, d[2] - 1]),
            vertex(rng, [0, d[1] * 3 / 4, 0], [d[0] / 4, d[1] - 1, d[2] - 1]),
        ]];
        for k in 0..n {
            let size = [1, 2, 3, 12][k % 4];
            let c = vertex(rng, [-1; 3], d);
            let mut t = [c; 3];
            for v in &mut t[1..] {
                *v = std::array::from_fn(|a| c[a] + rng.random_range(-size..=size) * VOXEL_ONE);
            }
            tris.push(t);
        }
        tris
    }

    #[test]
    fn set_up_bytes_per_pair_covers_the_structs() {
        let bytes = std::mem::size_of::<TriangleIndex>() + std::mem::size_of::<Plane>();
        assert!(bytes as u64 <= BYTES_PER_PAIR, "{bytes}");
    }

    #[test]
    fn recip_division_is_exact() {
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        for _ in 0..200_000 {
            let bits = rng.random_range(0..51);
            let d = rng.random_range(1..=(1i64 << bits));
            let n = rng.random_range(-(1i64 << 50) + 1..(1i64 << 50));
            let m = (n / d) * d;
            for n in [n, m, m + 1, m - 1] {
                if n.unsigned_abs() < 1 << 50 {
                    assert_eq!(
                        div_floor_recip(n, d, 1.0 / d as f64),
                        n.div_euclid(d),
                        "{n}/{d}"
                    );
                }
            }
        }
    }

    #[test]
    fn equals_line_kernel_on_random_snapped_soups() {
        let mut rng = ChaCha8Rng::seed_from_u64(32);
        for case in 0..24 {
            let dims = [
                rng.random_range(1..70),
                rng.random_range(1..70),
                rng.random_range(1..70),
            ];
            let tris = soup(&mut rng, dims, 40 + case * 10);
            assert_same(&tris, dims, &format!("case {case} dims {dims:?}"));
        }
    }

    #[test]
    fn equals_line_kernel_on_snapped_closed_meshes() {
        let mut rng = ChaCha8Rng::seed_from_u64(33);
        let shapes = [
            IndexedMesh::uv_sphere(DVec3::ZERO, 1.0, 11, 17),
            IndexedMesh::torus(DVec3::ZERO, 1.0, 0.35, 23, 9),
            IndexedMesh::cuboid(DVec3::splat(-1.0), DVec3::new(1.0, 0.5, 0.7)),
        ];
        for (k, shape) in shapes.iter().enumerate() {
            for r in [7, 24, 61] {
                let rot = random_rotation([rng.random(), rng.random(), rng.random()]);
                let m = shape.transformed(rot, DVec3::new(rng.random(), rng.random(), 0.3));
                let mesh = Mesh::from_parts("shape", m.vertices, m.faces, vec![]).unwrap();
                let frame = fit_frame(mesh.bounds(), r).unwrap();
                let q = quantize_mesh(&mesh, &frame, true);
                let dims = frame.dims.map(|d| d as i32);
                assert_same(&q.triangles, dims, &format!("shape {k} r {r}"));
            }
        }
    }

    #[test]
    fn equals_line_kernel_on_snapped_real_meshes() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/meshes/obj");
        for (name, r) in [
            ("stanford-bunny.obj", 200),
            ("spot.obj", 160),
            ("teapot.obj", 96),
        ] {
            let mesh = Mesh::load(&dir.join(name)).unwrap();
            let frame = fit_frame(mesh.bounds(), r).unwrap();
            let q = quantize_mesh(&mesh, &frame, true);
            let dims = frame.dims.map(|d| d as i32);
            for mode in MODES {
                let want = by_lines(&q.triangles, dims, mode);
                let got = voxelize_snapped(&q.triangles, dims, mode).unwrap();
                assert!(count(&want) > 10_000, "{name}");
                assert_eq!(got, want, "{name} r {r} {mode:?}");
            }
        }
    }

    #[test]
    fn independent_of_thread_count() {
        let mut rng = ChaCha8Rng::seed_from_u64(34);
        let dims = [90, 80, 70];
        let tris = soup(&mut rng, dims, 3000);
        for mode in MODES {
            let want = by_lines(&tris, dims, mode);
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                for (min_chunk, batch) in [(64, 500), (MIN_CHUNK, BATCH_TRIANGLES)] {
                    let got = pool
                        .install(|| voxelize_snapped_chunked(&tris, dims, mode, min_chunk, batch))
                        .unwrap();
                    assert_eq!(got, want, "{mode:?} {threads} threads, chunk {min_chunk}");
                }
            }
            // The default pool, with the default chunks.
            assert_eq!(
                voxelize_snapped(&tris, dims, mode).unwrap(),
                want,
                "{mode:?}"
            );
        }
    }

    #[test]
    fn crossings_on_and_beyond_the_max_faces_are_clamped() {
        let o = VOXEL_ONE;
        let dims = [10, 9, 8];
        // In the plane x = 10 (one past the last layer), in the last layer
        // x = 9, and a tilted one poking out through the top corner.
        let tris = [
            [[10 * o, 0, 0], [10 * o, 8 * o, 0], [10 * o, 0, 7 * o]],
            [[9 * o, 2 * o, o], [9 * o, 8 * o, 7 * o], [9 * o, 0, 7 * o]],
            [
                [5 * o, 5 * o, 5 * o],
                [11 * o, 9 * o, 8 * o],
                [9 * o, 11 * o, 9 * o],
            ],
        ];
        assert_same(&tris, dims, "max faces");
        let got = voxelize_snapped(&tris[..1], dims, SurfaceMode::Thin).unwrap();
        // Every crossing of the first triangle lands in layer x = 9.
        assert!(count(&got) > 0);
        for (c, m) in &got {
            for (z, w) in m.iter().enumerate() {
                for b in 0..64 {
                    if w >> b & 1 != 0 {
                        let v = [c[0] + (b & 7), c[1] + (b >> 3), c[2] + z as i32];
                        assert_eq!(v[0], 9, "{v:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn wide_triangles_take_the_i128_path_and_agree() {
        use crate::voxelize::surface::triangle_crossings;
        let o = VOXEL_ONE;
        // Nearly containing the z direction: few lattice points in the z
        // family's projection, but spans of 10^5 voxels make the depth
        // numerators pass 2^50. Compared per pair, unclamped.
        let s = 100_000;
        let family = LineFamily::Axis(2);
        for (k, t) in [
            [[0, 0, 0], [s * o, (s + 1) * o, 0], [o, 0, s * o]],
            [
                [7 * o, -3 * o, 5 * o],
                [(7 - s) * o, (-4 - s) * o, 9 * o],
                [8 * o, -3 * o, (5 - s) * o],
            ],
        ]
        .iter()
        .enumerate()
        {
            let p = project(t, family);
            let plane = Plane::new(&p, family, 0).unwrap();
            assert!(plane.wide, "case {k} should take the i128 path");
            let index = TriangleIndex::new(p.map(|q| [q[0], q[1]])).unwrap();
            let mut got: Vec<[i32; 3]> = index
                .iter()
                .map(|[i, j]| plane.voxel(i, j).to_array())
                .collect();
            let mut want = Vec::new();
            triangle_crossings(t, family, &mut |v| want.push(v.to_array()));
            got.sort();
            want.sort();
            assert!(got.len() > 1000, "case {k}: {} points", got.len());
            assert_eq!(got, want, "case {k}");
        }
    }

    #[test]
    fn unsnapped_and_out_of_range_input_is_refused() {
        let o = VOXEL_ONE;
        let off = [[0, 0, 0], [o, 0, 1], [0, o, 0]];
        assert!(matches!(
            voxelize_snapped(&[off], [4, 4, 4], SurfaceMode::Thin),
            Err(VoxkitError::Invalid(_))
        ));
        let far = [[0, 0, 0], [(MAX_SNAPPED_COORD + 1) * o, 0, 0], [0, o, 0]];
        assert!(voxelize_snapped(&[far], [4, 4, 4], SurfaceMode::Thick).is_err());
        assert!(voxelize_snapped(&[], [0, 4, 4], SurfaceMode::Thin).is_err());
        assert!(
            voxelize_snapped(&[], [4, 4, 4], SurfaceMode::Thin)
                .unwrap()
                .is_empty()
        );
    }
}
