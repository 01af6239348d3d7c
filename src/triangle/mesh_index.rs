//! One global index over the lattice points of many lattice triangles.
//!
//! A prefix sum over the per-triangle counts maps a global index to
//! `(triangle, local index)` by binary search; each triangle's
//! [`TriangleIndex`] then enumerates its part in `O(1)` per point. Work is split
//! in even chunks of the *global* range, so threads get equal numbers of points
//! whatever the sizes of the triangles (the paper's parallel setting).
//!
//! A lattice point shared by several triangles (a common edge or vertex) is
//! visited once per triangle: the enumeration is of `(triangle, point)` pairs.

use std::ops::{ControlFlow, Range};

use rayon::prelude::*;

use super::index::{LatticePoint, TriangleIndex, even_chunks};
use crate::{Result, VoxkitError};

/// Global indexing of the `(triangle, lattice point)` pairs of a set of lattice
/// triangles.
///
/// ```
/// use voxkit::triangle::MeshIndex;
/// let m = MeshIndex::new(&[[[0, 0], [2, 0], [0, 2]], [[5, 5], [5, 5], [6, 6]]]).unwrap();
/// assert_eq!(m.len(), 6 + 2);
/// assert_eq!(m.locate(6), Some((1, 0)));
/// let mut n = 0;
/// m.for_each_in_range(3..8, |_tri, _p| n += 1);
/// assert_eq!(n, 5);
/// ```
#[derive(Clone, Debug)]
pub struct MeshIndex {
    tris: Vec<TriangleIndex>,
    /// `starts[t]` = global index of triangle `t`'s first point; `starts[n] = len`.
    starts: Vec<u64>,
}

impl MeshIndex {
    /// Indexes every triangle (`O(bits)` each) and builds the prefix sum.
    ///
    /// # Errors
    /// [`VoxkitError::Invalid`] for a vertex outside ±2^30 (naming the triangle),
    /// or if the total count exceeds `u64::MAX`.
    pub fn new(triangles: &[[LatticePoint; 3]]) -> Result<MeshIndex> {
        let tris = triangles
            .iter()
            .enumerate()
            .map(|(t, v)| {
                TriangleIndex::new(*v)
                    .map_err(|e| VoxkitError::invalid(format!("triangle {t}: {e}")))
            })
            .collect::<Result<Vec<_>>>()?;
        Self::from_indices(tris)
    }

    /// Builds the prefix sum over already indexed triangles.
    ///
    /// # Errors
    /// [`VoxkitError::Invalid`] if the total count exceeds `u64::MAX`.
    pub fn from_indices(tris: Vec<TriangleIndex>) -> Result<MeshIndex> {
        let mut starts = Vec::with_capacity(tris.len() + 1);
        let mut acc = 0u64;
        starts.push(0);
        for t in &tris {
            acc = acc.checked_add(t.len()).ok_or_else(|| {
                VoxkitError::invalid("total lattice point count exceeds u64::MAX")
            })?;
            starts.push(acc);
        }
        Ok(MeshIndex { tris, starts })
    }

    /// Total number of `(triangle, point)` pairs.
    #[allow(clippy::len_without_is_empty)]
    pub fn len(&self) -> u64 {
        *self.starts.last().expect("starts has n + 1 entries")
    }

    /// The per-triangle indices.
    pub fn triangles(&self) -> &[TriangleIndex] {
        &self.tris
    }

    /// Global index of triangle `t`'s first point (`t ≤ number of triangles`).
    pub fn start_of(&self, t: usize) -> u64 {
        self.starts[t]
    }

    /// `(triangle, local index)` of global index `g`, or `None` if `g ≥ len()`.
    /// `O(log triangles)`.
    pub fn locate(&self, g: u64) -> Option<(usize, u64)> {
        if g >= self.len() {
            return None;
        }
        // Last triangle whose start ≤ g (every triangle has ≥ 1 point).
        let t = self.starts.partition_point(|&s| s <= g) - 1;
        Some((t, g - self.starts[t]))
    }

    /// `(triangle, point)` of global index `g`.
    pub fn point(&self, g: u64) -> Option<(usize, LatticePoint)> {
        self.locate(g)
            .map(|(t, i)| (t, self.tris[t].point_unchecked(i)))
    }

    /// Visits the pairs with global indices in `range` (clamped) in index order;
    /// `f` may stop early with [`ControlFlow::Break`].
    pub fn try_for_each_in_range<B>(
        &self,
        range: Range<u64>,
        mut f: impl FnMut(usize, LatticePoint) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let hi = range.end.min(self.len());
        let lo = range.start.min(hi);
        let Some((mut t, mut local)) = self.locate(lo) else {
            return ControlFlow::Continue(());
        };
        let mut g = lo;
        while g < hi {
            let tri = &self.tris[t];
            let end = (local + (hi - g)).min(tri.len());
            tri.try_for_each_in_range(local..end, |p| f(t, p))?;
            g += end - local;
            t += 1;
            local = 0;
        }
        ControlFlow::Continue(())
    }

    /// Visits the pairs with global indices in `range` (clamped) in index order.
    pub fn for_each_in_range(&self, range: Range<u64>, mut f: impl FnMut(usize, LatticePoint)) {
        let _ = self.try_for_each_in_range(range, |t, p| -> ControlFlow<()> {
            f(t, p);
            ControlFlow::Continue(())
        });
    }

    /// Visits the pairs with global indices in `range` (clamped), each once, in
    /// no promised order: triangles wholly inside the range are walked with
    /// [`TriangleIndex::for_each_point_unordered`] (scanline for fat ones),
    /// triangles cut by the range ends by index. Disjoint ranges still
    /// partition the pairs exactly.
    pub fn for_each_in_range_unordered(
        &self,
        range: Range<u64>,
        mut f: impl FnMut(usize, LatticePoint),
    ) {
        let hi = range.end.min(self.len());
        let lo = range.start.min(hi);
        let Some((mut t, mut local)) = self.locate(lo) else {
            return;
        };
        let mut g = lo;
        while g < hi {
            let tri = &self.tris[t];
            let end = (local + (hi - g)).min(tri.len());
            if local == 0 && end == tri.len() {
                tri.for_each_point_unordered(|p| f(t, p));
            } else {
                tri.for_each_in_range(local..end, |p| f(t, p));
            }
            g += end - local;
            t += 1;
            local = 0;
        }
    }

    /// Parallel [`for_each_in_range_unordered`](Self::for_each_in_range_unordered)
    /// over even chunks of the global range (at least `min_chunk` pairs each):
    /// the fastest way to visit every pair once when order does not matter.
    pub fn for_each_par_unordered(
        &self,
        min_chunk: u64,
        f: impl Fn(usize, LatticePoint) + Sync + Send,
    ) {
        even_chunks(self.len(), min_chunk)
            .into_par_iter()
            .for_each(|r| self.for_each_in_range_unordered(r, &f));
    }

    /// Visits every pair once, in parallel over even chunks of the global index
    /// range (at least `min_chunk` pairs each). Order is unspecified.
    pub fn for_each_par(&self, min_chunk: u64, f: impl Fn(usize, LatticePoint) + Sync + Send) {
        even_chunks(self.len(), min_chunk)
            .into_par_iter()
            .for_each(|r| self.for_each_in_range(r, &f));
    }

    /// Like [`for_each_par`](Self::for_each_par), with per-chunk state: `init`
    /// makes a state for each chunk (e.g. a local buffer), `f` visits with it,
    /// and the states are returned in chunk order.
    pub fn map_chunks_par<S: Send>(
        &self,
        min_chunk: u64,
        init: impl Fn(Range<u64>) -> S + Sync + Send,
        f: impl Fn(&mut S, usize, LatticePoint) + Sync + Send,
    ) -> Vec<S> {
        even_chunks(self.len(), min_chunk)
            .into_par_iter()
            .map(|r| {
                let mut s = init(r.clone());
                self.for_each_in_range(r, |t, p| f(&mut s, t, p));
                s
            })
            .collect()
    }
}
