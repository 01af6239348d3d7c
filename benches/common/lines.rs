//! Inputs and measures shared by the line benches: the peer harness's
//! random segments in its corner-origin convention, converted to ours and
//! floored for `Bresenham3d`; the generation measure of each algorithm.

use line_drawing::{Bresenham3d, VoxelOrigin, WalkVoxels};
use voxkit::line::{Line26, Segment, Tripod6};

/// The peer harness's generator (/work/shared/peers/rust-lines).
struct SplitMix64(u64);
impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// `n` segments of length `len` inside `[0.5, g − 0.5)³` (grid units with
/// corner-origin voxels, as the peer), fixed seed.
pub fn segments(n: usize, len: f64, g: f64, seed: u64) -> Vec<([f64; 3], [f64; 3])> {
    let mut rng = SplitMix64(seed);
    let (lo, hi) = (0.5, g - 0.5);
    let inside = |p: &[f64; 3]| p.iter().all(|&c| c >= lo && c < hi);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let a = [0; 3].map(|_| lo + (hi - lo) * rng.unit());
        let z = 2.0 * rng.unit() - 1.0;
        let phi = std::f64::consts::TAU * rng.unit();
        let r = (1.0 - z * z).sqrt();
        let d = [r * phi.cos(), r * phi.sin(), z];
        let b = [a[0] + len * d[0], a[1] + len * d[1], a[2] + len * d[2]];
        if inside(&a) && inside(&b) {
            out.push((a, b));
        }
    }
    out
}

/// Our centred convention: corner-origin coordinate `p` is grid `p − 0.5`.
pub fn ours(s: &[([f64; 3], [f64; 3])]) -> Vec<Segment> {
    s.iter()
        .map(|(a, b)| Segment::from_f64(a.map(|c| c - 0.5), b.map(|c| c - 0.5)).unwrap())
        .collect()
}

/// Integer endpoints.
pub type IPair = ((i32, i32, i32), (i32, i32, i32));

/// Corner-origin endpoints floored to integer voxels (as `Bresenham3d` takes them).
pub fn floored(s: &[([f64; 3], [f64; 3])]) -> Vec<IPair> {
    let f = |p: [f64; 3]| {
        (
            p[0].floor() as i32,
            p[1].floor() as i32,
            p[2].floor() as i32,
        )
    };
    s.iter().map(|(a, b)| (f(*a), f(*b))).collect()
}

/// The generation measure: every voxel of every line handed to a consumer
/// that XORs its coordinates.
#[inline(always)]
pub fn xor26(segs: &[Segment]) -> i32 {
    segs.iter()
        .map(|s| Line26::new(s).fold(0i32, |acc, v| acc ^ v.x ^ v.y ^ v.z))
        .fold(0, |a, b| a ^ b)
}

/// [`xor26`] for the tripod.
#[inline(always)]
pub fn xor6(segs: &[Segment]) -> i32 {
    segs.iter()
        .map(|s| Tripod6::new(s).fold(0i32, |acc, v| acc ^ v.x ^ v.y ^ v.z))
        .fold(0, |a, b| a ^ b)
}

/// [`xor26`] for the peer's `Bresenham3d` on integer endpoints.
#[inline(always)]
pub fn xor_bresenham(ints: &[IPair]) -> i32 {
    ints.iter()
        .map(|&(a, b)| Bresenham3d::new(a, b).fold(0, |acc, v| acc ^ v.0 ^ v.1 ^ v.2))
        .fold(0, |a, b| a ^ b)
}

/// The peer's corner-origin voxel walk of a raw segment.
#[inline(always)]
pub fn walk_voxels(a: &[f64; 3], b: &[f64; 3]) -> WalkVoxels<f64, i32> {
    WalkVoxels::<f64, i32>::new((a[0], a[1], a[2]), (b[0], b[1], b[2]), &VoxelOrigin::Corner)
}

/// [`xor26`] for the peer's `WalkVoxels`.
#[inline(always)]
pub fn xor_walk_voxels(raw: &[([f64; 3], [f64; 3])]) -> i32 {
    raw.iter()
        .map(|(a, b)| walk_voxels(a, b).fold(0, |acc, v| acc ^ v.0 ^ v.1 ^ v.2))
        .fold(0, |a, b| a ^ b)
}

/// Marks the peer's voxels (corner-origin integer coordinates) in a `g³`
/// grid's cells (x fastest), as the peer's user would.
#[inline(always)]
pub fn mark(cells: &mut [u8], g: usize, voxels: impl Iterator<Item = (i32, i32, i32)>) {
    for (x, y, z) in voxels {
        cells[x as usize + g * (y as usize + g * z as usize)] = 1;
    }
}

/// The voxels the peer's `Bresenham3d` and `WalkVoxels` hand on for the
/// floored and the raw segments.
pub fn peer_voxels(ints: &[IPair], raw: &[([f64; 3], [f64; 3])]) -> (u64, u64) {
    let bresenham = ints
        .iter()
        .map(|&(a, b)| Bresenham3d::new(a, b).count() as u64);
    let walk = raw.iter().map(|(a, b)| walk_voxels(a, b).count() as u64);
    (bresenham.sum(), walk.sum())
}
