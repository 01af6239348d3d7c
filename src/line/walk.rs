//! Walking a line through a [`DenseGrid`] with a visitor that can stop early.
//!
//! The segment is clipped to the grid box once ([`super::clip`]); the stepping
//! state is started at the first in-grid voxel in O(1) (the line is not
//! redrawn), and the loop moves a linear index by the grid's precomputed
//! neighbour offsets: no bounds check and no 3D→1D recomputation per voxel.
//! The walk visits exactly the iterator's in-grid voxels, in order.

use std::ops::ControlFlow;

use crate::grid::{DenseGrid, Voxel};
use crate::metric::Connectivity;

use super::clip::{GridBox, tripod_range};
use super::line18::Cursor18;
use super::line26::{AnyMid, Compact26, Cursor26, Mid26State, Plan26};
use super::segment::{DecisionInt, Frame, Segment};
use super::tripod6::{AnyTripod, Tripod6, TripodState};

/// Where a walk ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WalkOutcome {
    /// The visitor returned `Break` at this voxel.
    Stopped {
        /// Linear index of the voxel in the grid.
        index: usize,
        /// The voxel.
        voxel: Voxel,
    },
    /// The walk visited every in-grid voxel of the line.
    Completed {
        /// Number of voxels visited.
        visited: u64,
    },
}

impl WalkOutcome {
    /// The voxel where the walk stopped, if it did.
    pub fn stopped_at(&self) -> Option<Voxel> {
        match self {
            WalkOutcome::Stopped { voxel, .. } => Some(*voxel),
            WalkOutcome::Completed { .. } => None,
        }
    }
}

/// Linear-index offsets of the three local axes and of the eight local move
/// masks, for a segment's frame in a grid.
pub(crate) struct Offsets {
    /// Offsets of local axes m, u, v (zero-padded: no bounds check for the
    /// tripod's 2-bit step index).
    pub axis: [isize; 4],
    pub mask: [isize; 8],
}

impl Offsets {
    pub(crate) fn new(table: &[isize; 27], f: &Frame) -> Self {
        let steps = f.world_steps();
        let axis = steps.map(|s| table[crate::grid::neighbour_slot(s.x, s.y, s.z)]);
        let mask = std::array::from_fn(|m| {
            (0..3)
                .filter(|k| m >> k & 1 == 1)
                .map(|k| axis[k])
                .sum::<isize>()
        });
        Offsets {
            axis: [axis[0], axis[1], axis[2], 0],
            mask,
        }
    }
}

/// Runs `n ≥ 1` tripod voxels from `idx`. `Err(i)` = stopped at index `i`.
#[inline(always)]
fn run_tripod<T: DecisionInt, F: FnMut(usize) -> ControlFlow<()>>(
    mut s: TripodState<T>,
    mut idx: usize,
    n: u64,
    off: &[isize; 4],
    visit: &mut F,
) -> Result<u64, usize> {
    if visit(idx).is_break() {
        return Err(idx);
    }
    for _ in 1..n {
        let k = s.step();
        idx = idx.wrapping_add_signed(off[k]);
        if visit(idx).is_break() {
            return Err(idx);
        }
    }
    Ok(n)
}

#[inline(always)]
fn run_mid<T: DecisionInt, F: FnMut(usize) -> ControlFlow<()>>(
    s: &mut Mid26State<T>,
    idx: &mut usize,
    n: u64,
    off: &[isize; 8],
    visit: &mut F,
) -> Result<(), usize> {
    for _ in 0..n {
        let m = s.step();
        *idx = idx.wrapping_add_signed(off[m]);
        if visit(*idx).is_break() {
            return Err(*idx);
        }
    }
    Ok(())
}

fn walk_tripod<F: FnMut(usize) -> ControlFlow<()>>(
    dims: crate::grid::Dims,
    off: &Offsets,
    f: &Frame,
    start_index: impl Fn(Voxel) -> usize,
    visit: &mut F,
) -> Result<u64, usize> {
    let Some((c, n)) = tripod_range(f, &GridBox::from_dims(dims)) else {
        return Ok(0);
    };
    let idx = start_index(f.voxel_world(c));
    match AnyTripod::at(f, c) {
        AnyTripod::Narrow(s) => run_tripod(s, idx, n, &off.axis, visit),
        AnyTripod::Wide(s) => run_tripod(s, idx, n, &off.axis, visit),
    }
}

fn walk_26<F: FnMut(usize) -> ControlFlow<()>>(
    dims: crate::grid::Dims,
    off: &Offsets,
    f: &Frame,
    start_index: impl Fn(Voxel) -> usize,
    visit: &mut F,
) -> Result<u64, usize> {
    let plan = Plan26::new(f);
    let Some((p0, p1)) = plan.range(f, &GridBox::from_dims(dims)) else {
        return Ok(0);
    };
    let total = p1 - p0 + 1;
    let mut cur = Cursor26::at(f, plan, p0);
    let mut idx = start_index(f.voxel_world(plan.voxel_at(f, p0)));
    if visit(idx).is_break() {
        return Err(idx);
    }
    let mut left = total - 1;
    while left > 0 && cur.pre_i < plan.pre.len {
        idx = idx.wrapping_add_signed(off.mask[cur.advance()]);
        left -= 1;
        if visit(idx).is_break() {
            return Err(idx);
        }
    }
    let n = left.min(cur.mid_left);
    if n > 0 {
        match &mut cur.mid {
            AnyMid::Narrow(s) => {
                #[cfg(target_arch = "x86_64")]
                if let Some(i) = lanes_mid(dims, off, s, idx, n, visit) {
                    idx = i?;
                } else {
                    run_mid(s, &mut idx, n, &off.mask, visit)?;
                }
                #[cfg(not(target_arch = "x86_64"))]
                run_mid(s, &mut idx, n, &off.mask, visit)?;
            }
            AnyMid::Wide(s) => run_mid(s, &mut idx, n, &off.mask, visit)?,
        }
        cur.mid_left -= n;
        left -= n;
    }
    while left > 0 {
        idx = idx.wrapping_add_signed(off.mask[cur.advance()]);
        left -= 1;
        if visit(idx).is_break() {
            return Err(idx);
        }
    }
    Ok(total)
}

/// The 26-line's middle in AVX2 lanes ([`super::lanes`]): `n` columns after
/// `idx`, if the lanes apply (AVX2, at least 8 columns, a major span under
/// 256 voxels, a grid of fewer than 2^31 cells); the result is the last index
/// or where the visitor stopped. `None`: run it scalar.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn lanes_mid<F: FnMut(usize) -> ControlFlow<()>>(
    dims: crate::grid::Dims,
    off: &Offsets,
    s: &Mid26State<i64>,
    idx: usize,
    n: u64,
    visit: &mut F,
) -> Option<Result<usize, usize>> {
    use super::lanes::{
        avx2::{MidColumns, available},
        mid_indices,
    };
    use super::line26::LANES_MIN_COLUMNS;
    if n < LANES_MIN_COLUMNS || !i32_indices(dims) || !available() {
        return None;
    }
    let cols = MidColumns::new([s.eu, s.ev], [s.dm, s.du, s.dv])?;
    let axis = [off.axis[0], off.axis[1], off.axis[2]];
    // SAFETY: AVX2 is available, and every visited index is an in-grid cell
    // of a grid with fewer than 2^31 cells (clipping, as for the scalar walk).
    Some(unsafe { mid_indices(&cols, idx, axis, n, visit) })
}

/// Last 26-line position whose tripod index (sum of local coordinates) is
/// `≤ ts`, the index of the tripod voxel `c` where the line enters the box.
/// O(1): the 26-line has one voxel per column and is a subsequence of the
/// tripod path, so in the middle it is column `c_m`'s voxel or the one before;
/// near the ends at most a prefix or suffix (≤ 6 voxels) is scanned.
fn last_position_at_most(f: &Frame, plan: &Plan26, c: [i64; 3], ts: i64) -> u64 {
    if ts == 0 {
        return 0;
    }
    let sum_at = |p: u64| plan.voxel_at(f, p).iter().sum::<i64>();
    let pre = plan.pre.len as u64;
    let (cm, m) = (c[0], f.end[0]);
    if (2..m).contains(&cm) {
        // Column c_m's voxel; the one of column c_m − 1 precedes `c` on the
        // tripod path (smaller m).
        let p = pre + (cm - 1) as u64;
        return if sum_at(p) <= ts { p } else { p - 1 };
    }
    // Column ≤ 1: within the prefix (position 0 has index 0); column ≥ M:
    // within the suffix (its first voxel, column M − 1, precedes `c`).
    let (lo, hi) = if cm <= 1 {
        (0, pre)
    } else {
        (pre + plan.mid, plan.count() - 1)
    };
    (lo..=hi)
        .rev()
        .find(|&p| sum_at(p) <= ts)
        .expect("a 26-line voxel precedes the entry voxel")
}

fn walk_18<F: FnMut(usize) -> ControlFlow<()>>(
    dims: crate::grid::Dims,
    off: &Offsets,
    f: &Frame,
    start_index: impl Fn(Voxel) -> usize,
    visit: &mut F,
) -> Result<u64, usize> {
    // The 18-line is a subsequence of the tripod path, whose in-grid voxels
    // are the tripod indices (sum of local coordinates) ts..=te.
    let Some((c, n)) = tripod_range(f, &GridBox::from_dims(dims)) else {
        return Ok(0);
    };
    let plan = Plan26::new(f);
    let m = &off.mask;
    if c == [0; 3] && n == f.tripod_steps() + 1 {
        // The whole line is in the grid: count down the 26-line's moves, no
        // per-voxel test.
        let idx = start_index(f.voxel_world([0; 3]));
        if visit(idx).is_break() {
            return Err(idx);
        }
        let mut cur = Cursor18::at(f, plan, 0);
        let r = cur.drive(f, plan.count() - 1, (idx, 1u64), |(idx, k), mask, split| {
            if split != 0 {
                let i = idx.wrapping_add_signed(m[split]);
                if visit(i).is_break() {
                    return ControlFlow::Break((i, k));
                }
            }
            let i = idx.wrapping_add_signed(m[mask]);
            if visit(i).is_break() {
                return ControlFlow::Break((i, k));
            }
            ControlFlow::Continue((i, k + 1 + u64::from(split != 0)))
        });
        return match r {
            ControlFlow::Continue((_, k)) => Ok(k),
            ControlFlow::Break((i, _)) => Err(i),
        };
    }
    // Clipped: start at the last 26-line voxel before the entry and keep the
    // voxels with tripod index in ts..=te.
    let ts: i64 = c.iter().sum();
    let te = ts + n as i64 - 1;
    let p = last_position_at_most(f, &plan, c, ts);
    let v = plan.voxel_at(f, p);
    let t0: i64 = v.iter().sum();
    let idx = start_index(f.voxel_world(v));
    let mut visited = 0u64;
    if t0 >= ts {
        visited += 1;
        if visit(idx).is_break() {
            return Err(idx);
        }
    }
    // `stopped`: the visitor's Break index; a Break with none = past te.
    let mut stopped = None;
    let mut one = |i: usize, t: i64| -> ControlFlow<()> {
        if t > te {
            return ControlFlow::Break(());
        }
        if t >= ts {
            visited += 1;
            if visit(i).is_break() {
                stopped = Some(i);
                return ControlFlow::Break(());
            }
        }
        ControlFlow::Continue(())
    };
    let mut cur = Cursor18::at(f, plan, p);
    let _ = cur.drive(
        f,
        plan.count() - 1 - p,
        (idx, t0),
        |(idx, t), mask, split| {
            if split != 0 && one(idx.wrapping_add_signed(m[split]), t + 2).is_break() {
                return ControlFlow::Break((idx, t));
            }
            let i = idx.wrapping_add_signed(m[mask]);
            let t = t + mask.count_ones() as i64;
            if one(i, t).is_break() {
                return ControlFlow::Break((i, t));
            }
            ControlFlow::Continue((i, t))
        },
    );
    match stopped {
        Some(i) => Err(i),
        None => Ok(visited),
    }
}

/// What a walk needs from a grid, copied out so that no borrow of the grid
/// is alive while cells are visited.
#[derive(Clone, Copy)]
pub(crate) struct GridShape {
    pub dims: crate::grid::Dims,
    pub table: [isize; 27],
}

impl GridShape {
    pub(crate) fn of<T>(grid: &DenseGrid<T>) -> Self {
        GridShape {
            dims: grid.dims(),
            table: *grid.neighbour_offsets(),
        }
    }

    /// Linear index of `v` in wrapping arithmetic: exact for in-grid voxels,
    /// and affine in `v`, so offsets applied to an out-of-grid start voxel
    /// reach the exact index of an in-grid one.
    pub(crate) fn index(&self, v: Voxel) -> usize {
        let [nx, ny, _] = self.dims;
        (v.x as isize as usize).wrapping_add(nx.wrapping_mul(
            (v.y as isize as usize).wrapping_add(ny.wrapping_mul(v.z as isize as usize)),
        ))
    }
}

/// Linear-index offsets of local axes with world unit `steps`, in a grid
/// whose world x, y, z steps are `stride`.
#[inline]
pub(crate) fn axis_offsets(steps: [Voxel; 3], stride: [isize; 3]) -> [isize; 3] {
    steps.map(|s| (0..3).map(|w| s[w] as isize * stride[w]).sum())
}

/// Linear-index offsets of the eight local move masks (bit k: axis k).
#[inline]
pub(crate) fn mask_offsets(axis: [isize; 3]) -> [isize; 8] {
    std::array::from_fn(|m| (0..3).filter(|k| m >> k & 1 == 1).map(|k| axis[k]).sum())
}

/// Whether a grid of `dims` has fewer than 2^31 cells: the AVX2 lanes
/// compute its linear indices in `i32`.
#[inline]
fn i32_indices(dims: crate::grid::Dims) -> bool {
    dims.iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .is_some_and(|c| c < 1 << 31)
}

/// Whether `v` lies in the box `0..dims`.
#[inline]
pub(crate) fn in_box(v: Voxel, dims: crate::grid::Dims) -> bool {
    (0..3).all(|k| v[k] >= 0 && (v[k] as u64) < dims[k] as u64)
}

fn dispatch<F: FnMut(usize) -> ControlFlow<()>>(
    shape: GridShape,
    seg: &Segment,
    conn: Connectivity,
    visit: &mut F,
) -> Result<u64, usize> {
    let dims = shape.dims;
    // The common case: a narrow line wholly in the grid, no clipping.
    let small = i32_indices(dims);
    let stride = [1, dims[0] as isize, (dims[0] * dims[1]) as isize];
    match conn {
        Connectivity::TwentySix => {
            if let Some(c) = Compact26::new(seg)
                && c.inside(dims)
            {
                return c.walk(shape.index(c.start()), stride, small, visit);
            }
        }
        Connectivity::Six => {
            if let Some((t, [v0, v1])) = Tripod6::narrow(seg)
                && in_box(v0, dims)
                && in_box(v1, dims)
            {
                return t.walk(shape.index(v0), stride, small, visit);
            }
        }
        Connectivity::Eighteen => {
            if let Some(r) =
                super::line18::walk_inside(seg, dims, stride, |v| shape.index(v), visit)
            {
                return r;
            }
        }
    }
    let f = Frame::new(seg);
    let off = Offsets::new(&shape.table, &f);
    let start = |v: Voxel| shape.index(v);
    match conn {
        Connectivity::Six => walk_tripod(dims, &off, &f, start, visit),
        Connectivity::TwentySix => walk_26(dims, &off, &f, start, visit),
        Connectivity::Eighteen => walk_18(dims, &off, &f, start, visit),
    }
}

fn outcome<T>(grid: &DenseGrid<T>, r: Result<u64, usize>) -> WalkOutcome {
    match r {
        Ok(visited) => WalkOutcome::Completed { visited },
        Err(index) => WalkOutcome::Stopped {
            index,
            voxel: grid.voxel_of_index(index),
        },
    }
}

/// Walks the `conn`-connected line of `seg` (26: [`super::Line26`],
/// 18: [`super::Line18`], 6: [`super::Tripod6`]) through `grid`, calling
/// `visit` on each in-grid cell in order until it returns `Break`.
///
/// ```
/// use std::ops::ControlFlow;
/// use voxkit::grid::{DenseGrid, MemoryLimit};
/// use voxkit::line::{walk_mut, Segment, WalkOutcome};
/// use voxkit::Connectivity;
/// let mut g = DenseGrid::new([8, 8, 8], 0u8, MemoryLimit::DEFAULT).unwrap();
/// let s = Segment::from_f64([-3.0, 1.0, 1.0], [20.0, 4.0, 2.0]).unwrap();
/// let out = walk_mut(&mut g, &s, Connectivity::Six, |c| {
///     *c += 1;
///     ControlFlow::Continue(())
/// });
/// assert!(matches!(out, WalkOutcome::Completed { visited } if visited >= 8));
/// ```
pub fn walk_mut<T>(
    grid: &mut DenseGrid<T>,
    seg: &Segment,
    conn: Connectivity,
    mut visit: impl FnMut(&mut T) -> ControlFlow<()>,
) -> WalkOutcome {
    let shape = GridShape::of(grid);
    let len = grid.len();
    let ptr = grid.as_mut_slice().as_mut_ptr();
    let visit = &mut visit;
    // `move`: the pointer itself, not a reference to it, in the closure, so
    // the loops keep it in a register across the visitor's stores.
    let mut by_index = move |i: usize| {
        debug_assert!(i < len, "walk left the grid: index {i} of {len}");
        // SAFETY: clipping guarantees that every visited voxel lies in the
        // grid box, so `i` is the linear index of an in-grid cell (`i < len`);
        // tested by `walk_matches_iterator_in_grid` (random segments partly
        // outside the grid, debug builds assert the bound). No other
        // reference to the cells exists while the walk runs.
        visit(unsafe { &mut *ptr.add(i) })
    };
    let r = dispatch(shape, seg, conn, &mut by_index);
    outcome(grid, r)
}

/// Read-only [`walk_mut`], for ray casting: `visit` sees each in-grid cell in
/// order and returns `Break` to stop (first hit).
pub fn walk<T>(
    grid: &DenseGrid<T>,
    seg: &Segment,
    conn: Connectivity,
    mut visit: impl FnMut(&T) -> ControlFlow<()>,
) -> WalkOutcome {
    let shape = GridShape::of(grid);
    let cells = grid.as_slice();
    let visit = &mut visit;
    let mut by_index = move |i: usize| {
        debug_assert!(i < cells.len());
        // SAFETY: as in `walk_mut`: every visited index is in-grid.
        visit(unsafe { cells.get_unchecked(i) })
    };
    let r = dispatch(shape, seg, conn, &mut by_index);
    outcome(grid, r)
}
