//! Voxel adjacency and the discrete distances of Cohen-Or & Kaufman
//! (eqs. 1–3): `d6` is the length of the shortest 6-path between two voxels,
//! `d26` of the shortest 26-path, `d18` of the shortest 18-path.
//!
//! ```
//! use glam::IVec3;
//! use voxkit::metric::{d6, d18, d26};
//! let (a, b) = (IVec3::ZERO, IVec3::new(2, 2, 2));
//! assert_eq!((d6(a, b), d18(a, b), d26(a, b)), (6, 3, 2));
//! ```

use crate::grid::Voxel;

/// Which neighbours count as adjacent: sharing a face (6), a face or an edge
/// (18), or a face, an edge or a corner (26).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Connectivity {
    /// Face neighbours.
    Six,
    /// Face and edge neighbours.
    Eighteen,
    /// Face, edge and corner neighbours.
    TwentySix,
}

impl Connectivity {
    /// The number N of an N-connectivity (6, 18 or 26).
    pub const fn neighbours(self) -> u32 {
        match self {
            Connectivity::Six => 6,
            Connectivity::Eighteen => 18,
            Connectivity::TwentySix => 26,
        }
    }

    /// The connectivity with N neighbours, if N is 6, 18 or 26.
    pub const fn from_neighbours(n: u32) -> Option<Self> {
        match n {
            6 => Some(Connectivity::Six),
            18 => Some(Connectivity::Eighteen),
            26 => Some(Connectivity::TwentySix),
            _ => None,
        }
    }

    /// The discrete distance that counts the steps of a shortest N-path.
    pub fn distance(self, a: Voxel, b: Voxel) -> u64 {
        match self {
            Connectivity::Six => d6(a, b),
            Connectivity::Eighteen => d18(a, b),
            Connectivity::TwentySix => d26(a, b),
        }
    }
}

/// Absolute coordinate differences, widened so that voxels anywhere in the
/// `i32` range never overflow.
#[inline]
fn abs_deltas(a: Voxel, b: Voxel) -> [u64; 3] {
    [
        (a.x as i64 - b.x as i64).unsigned_abs(),
        (a.y as i64 - b.y as i64).unsigned_abs(),
        (a.z as i64 - b.z as i64).unsigned_abs(),
    ]
}

/// `d6 = |Δx| + |Δy| + |Δz|` (eq. 1).
#[inline]
pub fn d6(a: Voxel, b: Voxel) -> u64 {
    abs_deltas(a, b).iter().sum()
}

/// `d26 = max(|Δx|, |Δy|, |Δz|)` (eq. 2).
#[inline]
pub fn d26(a: Voxel, b: Voxel) -> u64 {
    let [x, y, z] = abs_deltas(a, b);
    x.max(y).max(z)
}

/// `d18 = max(d26, ⌈d6 / 2⌉)` (eq. 3).
#[inline]
pub fn d18(a: Voxel, b: Voxel) -> u64 {
    d26(a, b).max(d6(a, b).div_ceil(2))
}

/// Whether `a` and `b` are distinct N-neighbours.
///
/// ```
/// use glam::IVec3;
/// use voxkit::metric::{adjacent, Connectivity};
/// let o = IVec3::ZERO;
/// assert!(adjacent(o, IVec3::new(1, 1, 0), Connectivity::Eighteen));
/// assert!(!adjacent(o, IVec3::new(1, 1, 1), Connectivity::Eighteen));
/// assert!(!adjacent(o, o, Connectivity::TwentySix));
/// ```
#[inline]
pub fn adjacent(a: Voxel, b: Voxel, conn: Connectivity) -> bool {
    let [x, y, z] = abs_deltas(a, b);
    if x > 1 || y > 1 || z > 1 {
        return false;
    }
    let moved = x + y + z;
    match conn {
        Connectivity::Six => moved == 1,
        Connectivity::Eighteen => moved == 1 || moved == 2,
        Connectivity::TwentySix => moved >= 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::IVec3;

    /// Shortest N-path lengths by breadth-first search agree with the formulas.
    #[test]
    fn metrics_match_bfs() {
        for conn in [
            Connectivity::Six,
            Connectivity::Eighteen,
            Connectivity::TwentySix,
        ] {
            let r = 3;
            let moves: Vec<IVec3> = (-1..=1)
                .flat_map(|z| {
                    (-1..=1).flat_map(move |y| (-1..=1).map(move |x| IVec3::new(x, y, z)))
                })
                .filter(|&m| adjacent(IVec3::ZERO, m, conn))
                .collect();
            let side = (2 * r + 1) as usize;
            let idx = |v: IVec3| {
                ((v.x + r) as usize) + side * (((v.y + r) as usize) + side * (v.z + r) as usize)
            };
            let mut dist = vec![u64::MAX; side * side * side];
            let mut queue = std::collections::VecDeque::from([IVec3::ZERO]);
            dist[idx(IVec3::ZERO)] = 0;
            while let Some(v) = queue.pop_front() {
                for &m in &moves {
                    let w = v + m;
                    if w.abs().max_element() <= r && dist[idx(w)] == u64::MAX {
                        dist[idx(w)] = dist[idx(v)] + 1;
                        queue.push_back(w);
                    }
                }
            }
            for z in -r..=r {
                for y in -r..=r {
                    for x in -r..=r {
                        let v = IVec3::new(x, y, z);
                        assert_eq!(dist[idx(v)], conn.distance(IVec3::ZERO, v), "{conn:?} {v}");
                    }
                }
            }
        }
    }

    #[test]
    fn extreme_coordinates_do_not_overflow() {
        let a = IVec3::splat(i32::MIN);
        let b = IVec3::splat(i32::MAX);
        assert_eq!(d26(a, b), u32::MAX as u64);
        assert_eq!(d6(a, b), 3 * u32::MAX as u64);
    }
}
