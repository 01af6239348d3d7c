//! Clipping a line to a box of voxels, exactly and in O(1).
//!
//! Every exact line here is monotone in the local (mirrored) frame, so its
//! voxels inside a box form one contiguous run. Clipping finds the first and
//! last voxel of that run from the decision-variable formulas and starts the
//! stepping state there: the line is *not* redrawn from a clipped endpoint
//! (that would change it).

use crate::grid::{Dims, Voxel};

use super::segment::Frame;

/// An inclusive box of voxels `lo..=hi` in world grid coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridBox {
    /// Smallest voxel of the box.
    pub lo: Voxel,
    /// Largest voxel of the box (inclusive).
    pub hi: Voxel,
}

impl GridBox {
    /// The box of a grid with extents `dims`: `(0,0,0)..=dims − 1`.
    pub fn from_dims(dims: Dims) -> Self {
        GridBox {
            lo: Voxel::ZERO,
            hi: Voxel::new(dims[0] as i32 - 1, dims[1] as i32 - 1, dims[2] as i32 - 1),
        }
    }

    /// Whether `v` lies in the box.
    pub fn contains(&self, v: Voxel) -> bool {
        v.cmpge(self.lo).all() && v.cmple(self.hi).all()
    }

    /// The box in a segment's local frame: `(L, H)` per local axis.
    pub(crate) fn local(&self, f: &Frame) -> ([i64; 3], [i64; 3]) {
        let lo = [self.lo.x as i64, self.lo.y as i64, self.lo.z as i64];
        let hi = [self.hi.x as i64, self.hi.y as i64, self.hi.z as i64];
        let mut l = [0; 3];
        let mut h = [0; 3];
        for k in 0..3 {
            let w = f.perm[k];
            let (a, b) = (f.sign[k] * (lo[w] - f.v0[w]), f.sign[k] * (hi[w] - f.v0[w]));
            l[k] = a.min(b);
            h[k] = a.max(b);
        }
        (l, h)
    }
}

/// Whether the (shifted) line reaches the plane at distance `ri` along local
/// axis `i` strictly before the plane at distance `rj` along `j`.
fn before(f: &Frame, i: usize, ri: i128, j: usize, rj: i128) -> bool {
    let val = f.d[j] as i128 * ri - f.d[i] as i128 * rj;
    val < 0 || (val == 0 && f.pneg[i][j])
}

/// The tripod voxel right after the line crosses into coordinate `n` along
/// axis `k` (which must cross there within the segment).
fn voxel_after_crossing(f: &Frame, k: usize, n: i64) -> [i64; 3] {
    let s = crate::fixed::ONE as i128;
    let rk = f.r(k, n - 1);
    let mut c = [0i64; 3];
    c[k] = n;
    #[allow(clippy::needless_range_loop)] // j indexes c and several frame arrays
    for j in 0..3 {
        if j == k {
            continue;
        }
        // Count planes n_j = 0, 1, ... of axis j crossed before rk:
        // D_k·r_j(n_j) − D_j·r_k + p < 0  ⟺  n_j < Q / (D_k·S).
        let q = f.d[j] as i128 * rk - f.d[k] as i128 * (s / 2 - f.a[j] as i128)
            + i128::from(f.pneg[j][k]);
        let den = f.d[k] as i128 * s;
        let cnt = -((-q).div_euclid(den)); // ceil(q / den)
        c[j] = cnt.clamp(0, f.end[j] as i128) as i64;
    }
    c
}

/// First in-box voxel of the tripod line (local) and the number of in-box
/// voxels, or `None` if the line misses the box.
pub(crate) fn tripod_range(f: &Frame, b: &GridBox) -> Option<([i64; 3], u64)> {
    let (l, h) = b.local(f);
    for k in 0..3 {
        if l[k] > f.end[k] || h[k] < 0 {
            return None;
        }
    }
    // Entry: the last axis to cross into the box.
    let mut entry = [0i64; 3];
    let mut last: Option<usize> = None;
    for k in 0..3 {
        if l[k] > 0 {
            last = match last {
                None => Some(k),
                Some(q) if before(f, q, f.r(q, l[q] - 1), k, f.r(k, l[k] - 1)) => Some(k),
                keep => keep,
            };
        }
    }
    if let Some(k) = last {
        entry = voxel_after_crossing(f, k, l[k]);
    }
    if (0..3).any(|k| entry[k] > h[k] || entry[k] < l[k]) {
        return None;
    }
    // Exit: the first axis to cross out of the box.
    let mut first: Option<usize> = None;
    for k in 0..3 {
        if h[k] < f.end[k] {
            first = match first {
                None => Some(k),
                Some(q) if before(f, k, f.r(k, h[k]), q, f.r(q, h[q])) => Some(k),
                keep => keep,
            };
        }
    }
    let last_index: u64 = match first {
        Some(k) => voxel_after_crossing(f, k, h[k] + 1).iter().sum::<i64>() as u64 - 1,
        None => f.tripod_steps(),
    };
    let start_index: u64 = entry.iter().sum::<i64>() as u64;
    if start_index > last_index {
        return None;
    }
    Some((entry, last_index - start_index + 1))
}
