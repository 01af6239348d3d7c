//! 2D lines between integer points: the midpoint 8-connected line, the
//! 4-connected line, and the 8→4 alternation of Cohen-Or & Kaufman (Fig. 8).
//!
//! A pixel is the closed unit square centred on an integer point. Every line
//! here starts at pixel `p0` and ends at pixel `p1`, and every pixel it
//! emits is touched by the segment `p0–p1`.
//!
//! # Frame
//! Each line is computed in a canonical octant: the axes are mirrored so the
//! direction is non-negative and swapped so the *major* axis `u` (the one
//! with the larger extent `A`; x when `|dx| = |dy|`) comes first; the minor
//! axis `v` has extent `B ≤ A`. With `f(u, v) = B·u − A·v` (zero on the
//! line, positive below it), all decision variables are `2·f` at some point,
//! exact integers (`i128`).
//!
//! # The three lines
//! - **8-line** ([`line8`], midpoint / Bresenham): `e8 = 2 f(u + 1, v + ½)`,
//!   the line's side of the midpoint between the two candidate pixels of the
//!   next column. `e8 < 0`: step `u`; otherwise step `u` and `v`. `A + 1`
//!   pixels (`max(|dx|, |dy|) + 1`), 8-connected; each is the pixel of its
//!   column nearest the line.
//! - **4-line** ([`line4`]): `e4 = 2 f(u + ½, v + ½)`, the line's side of the
//!   corner the current pixel shares with its `u`- and `v`-neighbours ahead.
//!   `e4 < 0`: the line leaves through the `u` face; otherwise through the
//!   `v` face. `A + B + 1` pixels (`|dx| + |dy| + 1`), 4-connected, and with
//!   *containment*: the union of the closed squares covers the segment.
//! - **8→4 alternation** ([`alternating_line`], Fig. 8): an 8-line that,
//!   at the first pixel a caller's predicate flags, converts its decision
//!   variable and continues as a 4-line to the end.
//!
//! # Why alternate
//! An 8-connected ray is fast (one step per column) but passes diagonally
//! between two pixels that share only a corner, so it can slip through an
//! 8-connected gap of an object (an 8-tunnel) or miss a silhouette pixel; a
//! 4-connected ray cannot (containment) but takes `A + B` steps instead of
//! `A`. The seed marks the pixels near an object with a *proximity flag*:
//! the ray runs as an 8-line through empty space and "slows down" to a
//! 4-line at the first nonempty pixel (object or flag), keeping the speed far
//! from objects and containment near them. The switch is exact because both
//! variables sample the same `f` half a pixel apart along `u`
//! (seed eqs. 5–8): `e8 = e4 + B` (doubled), so `e4 = e8 − B` at the switch
//! pixel; after it the 4-loop runs `(A − u) + (B − v)` steps. The pixels
//! after the switch are exactly the 4-line's pixels from that pixel on.
//! Seed errata applied: the 4-loop's `u` branch needs `e4 += 2B`; the
//! printed `B_i` is `B`; the loop count is `(A − u) + (B − v)`.
//!
//! # Ties and reversal
//! - 8-line: `e8 = 0` (the line passes exactly through the midpoint) steps
//!   diagonally, i.e. rounds toward the direction of travel.
//! - 4-line: `e4 = 0` (the line passes exactly through the corner) steps
//!   along the minor axis `v` first.
//!
//! Both are consistent but depend on the direction: `p1 → p0` emits the same
//! pixel set as `p0 → p1` reversed exactly when the segment passes through no
//! such midpoint (8-line) or pixel corner (4-line).
//!
//! # Range
//! Coordinates must satisfy `|c| ≤ 2^61` ([`MAX_COORD_2D`]), so extents,
//! counts and decision variables never overflow and counts fit `u64`;
//! beyond it the constructors return [`VoxkitError::Invalid`].
//!
//! ```
//! use glam::I64Vec2;
//! use voxkit::line::line2d::{line4, line8};
//! let (a, b) = (I64Vec2::new(0, 0), I64Vec2::new(3, 1));
//! let eight: Vec<_> = line8(a, b).unwrap().map(|p| p.to_array()).collect();
//! assert_eq!(eight, [[0, 0], [1, 0], [2, 1], [3, 1]]);
//! let four: Vec<_> = line4(a, b).unwrap().map(|p| p.to_array()).collect();
//! assert_eq!(four, [[0, 0], [1, 0], [1, 1], [2, 1], [3, 1]]);
//! ```

use glam::I64Vec2;

use crate::error::{Result, VoxkitError};

/// A pixel: integer coordinates of the centre of a closed unit square.
pub type Pixel = I64Vec2;

/// Largest supported coordinate magnitude of a 2D line endpoint.
pub const MAX_COORD_2D: i64 = 1 << 61;

/// The canonical octant of a line: mirror signs, axis swap and extents.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Octant {
    origin: Pixel,
    /// Whether the major axis `u` is world y.
    swap: bool,
    /// World step of one unit along `u` and along `v`.
    du: Pixel,
    dv: Pixel,
    /// Major extent `A` and minor extent `B` (`A ≥ B ≥ 0`).
    a: i64,
    b: i64,
}

impl Octant {
    fn new(p0: Pixel, p1: Pixel) -> Result<Self> {
        for p in [p0, p1] {
            if p.x.abs() > MAX_COORD_2D || p.y.abs() > MAX_COORD_2D {
                return Err(VoxkitError::invalid(format!(
                    "2D line endpoint {p} is outside the supported range ±2^61"
                )));
            }
        }
        let d = p1 - p0;
        let (sx, sy) = (if d.x < 0 { -1 } else { 1 }, if d.y < 0 { -1 } else { 1 });
        let (ax, ay) = (d.x.abs(), d.y.abs());
        let swap = ay > ax;
        let (ex, ey) = (Pixel::new(sx, 0), Pixel::new(0, sy));
        Ok(if swap {
            Octant {
                origin: p0,
                swap,
                du: ey,
                dv: ex,
                a: ay,
                b: ax,
            }
        } else {
            Octant {
                origin: p0,
                swap,
                du: ex,
                dv: ey,
                a: ax,
                b: ay,
            }
        })
    }

    #[inline(always)]
    fn voxel_world(self, u: i64, v: i64) -> Pixel {
        self.origin + self.du * u + self.dv * v
    }
}

/// Converts a remaining count to an exact `size_hint` (exact on 64-bit
/// targets, where every count in range fits `usize`).
fn hint(n: u64) -> (usize, Option<usize>) {
    match usize::try_from(n) {
        Ok(n) => (n, Some(n)),
        Err(_) => (usize::MAX, None),
    }
}

/// The `Copy` stepping state of a midpoint 8-connected line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Line8Stepper {
    oct: Octant,
    u: i64,
    v: i64,
    /// `2 f(u + 1, v + ½)`.
    e: i128,
}

impl Line8Stepper {
    /// The 8-line from `p0` to `p1`, at `p0`.
    pub fn new(p0: Pixel, p1: Pixel) -> Result<Self> {
        let oct = Octant::new(p0, p1)?;
        // 2 f(1, ½) = 2B − A.
        let e = 2 * oct.b as i128 - oct.a as i128;
        Ok(Line8Stepper { oct, u: 0, v: 0, e })
    }

    /// The current pixel.
    #[inline]
    pub fn pixel(&self) -> Pixel {
        self.oct.voxel_world(self.u, self.v)
    }

    /// Steps left to the end pixel: `A − u`.
    #[inline]
    pub fn remaining_steps(&self) -> u64 {
        (self.oct.a - self.u) as u64
    }

    /// Moves to the next pixel; `false` (and stays) at the end.
    #[inline]
    pub fn step(&mut self) -> bool {
        if self.u == self.oct.a {
            return false;
        }
        let (a, b) = (self.oct.a as i128, self.oct.b as i128);
        self.u += 1;
        if self.e < 0 {
            self.e += 2 * b;
        } else {
            self.v += 1;
            self.e += 2 * (b - a);
        }
        true
    }

    /// Continues as a 4-line from the current pixel (seed Fig. 8's
    /// `alternate:`): `e4 = e8 − B`.
    pub fn into_four(self) -> Line4Stepper {
        Line4Stepper {
            oct: self.oct,
            u: self.u,
            v: self.v,
            e: self.e - self.oct.b as i128,
        }
    }
}

/// The `Copy` stepping state of a 4-connected line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Line4Stepper {
    oct: Octant,
    u: i64,
    v: i64,
    /// `2 f(u + ½, v + ½)`.
    e: i128,
}

impl Line4Stepper {
    /// The 4-line from `p0` to `p1`, at `p0`.
    pub fn new(p0: Pixel, p1: Pixel) -> Result<Self> {
        let oct = Octant::new(p0, p1)?;
        // 2 f(½, ½) = B − A.
        let e = oct.b as i128 - oct.a as i128;
        Ok(Line4Stepper { oct, u: 0, v: 0, e })
    }

    /// The current pixel.
    #[inline]
    pub fn pixel(&self) -> Pixel {
        self.oct.voxel_world(self.u, self.v)
    }

    /// Steps left to the end pixel: `(A − u) + (B − v)`.
    #[inline]
    pub fn remaining_steps(&self) -> u64 {
        // Each part ≤ 2^62; their sum can exceed i64::MAX, not u64.
        (self.oct.a - self.u) as u64 + (self.oct.b - self.v) as u64
    }

    /// Moves to the next pixel; `false` (and stays) at the end.
    #[inline]
    pub fn step(&mut self) -> bool {
        if self.u == self.oct.a && self.v == self.oct.b {
            return false;
        }
        // With exact variables the 4-line never overshoots: on the last row
        // (v = B) e4 < 0 while u < A, on the last column e4 > 0 while v < B.
        if self.e < 0 {
            debug_assert!(self.u < self.oct.a);
            self.u += 1;
            self.e += 2 * self.oct.b as i128;
        } else {
            debug_assert!(self.v < self.oct.b);
            self.v += 1;
            self.e -= 2 * self.oct.a as i128;
        }
        true
    }
}

/// Iterator over the pixels of a midpoint 8-line, `p0` first, `p1` last,
/// `max(|dx|, |dy|) + 1` items.
#[derive(Clone, Copy, Debug)]
pub struct Line8 {
    state: Line8Stepper,
    pending: bool,
}

/// The midpoint 8-connected line from `p0` to `p1` (see the module docs).
///
/// ```
/// use glam::I64Vec2;
/// use voxkit::line::line2d::line8;
/// let line = line8(I64Vec2::new(5, 5), I64Vec2::new(2, 9)).unwrap();
/// assert_eq!(line.len(), 5);
/// ```
pub fn line8(p0: Pixel, p1: Pixel) -> Result<Line8> {
    Ok(Line8 {
        state: Line8Stepper::new(p0, p1)?,
        pending: true,
    })
}

impl Iterator for Line8 {
    type Item = Pixel;

    #[inline]
    fn next(&mut self) -> Option<Pixel> {
        if std::mem::take(&mut self.pending) {
            return Some(self.state.pixel());
        }
        self.state.step().then(|| self.state.pixel())
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        hint(self.state.remaining_steps() + self.pending as u64)
    }
}

impl ExactSizeIterator for Line8 {}
impl std::iter::FusedIterator for Line8 {}

/// Iterator over the pixels of a 4-connected line, `p0` first, `p1` last,
/// `|dx| + |dy| + 1` items.
#[derive(Clone, Copy, Debug)]
pub struct Line4 {
    state: Line4Stepper,
    pending: bool,
}

/// The 4-connected line from `p0` to `p1`, whose closed pixels cover the
/// segment (see the module docs).
///
/// ```
/// use glam::I64Vec2;
/// use voxkit::line::line2d::line4;
/// let line = line4(I64Vec2::new(5, 5), I64Vec2::new(2, 9)).unwrap();
/// assert_eq!(line.len(), 3 + 4 + 1);
/// ```
pub fn line4(p0: Pixel, p1: Pixel) -> Result<Line4> {
    Ok(Line4 {
        state: Line4Stepper::new(p0, p1)?,
        pending: true,
    })
}

impl Iterator for Line4 {
    type Item = Pixel;

    #[inline]
    fn next(&mut self) -> Option<Pixel> {
        if std::mem::take(&mut self.pending) {
            return Some(self.state.pixel());
        }
        self.state.step().then(|| self.state.pixel())
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        hint(self.state.remaining_steps() + self.pending as u64)
    }
}

impl ExactSizeIterator for Line4 {}
impl std::iter::FusedIterator for Line4 {}

/// The state of an alternating line: still an 8-line, or a 4-line since the
/// switch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlternatingStepper {
    /// Stepping as an 8-line.
    Eight(Line8Stepper),
    /// Stepping as a 4-line (after the switch).
    Four(Line4Stepper),
}

impl AlternatingStepper {
    /// The current pixel.
    pub fn pixel(&self) -> Pixel {
        match self {
            AlternatingStepper::Eight(s) => s.pixel(),
            AlternatingStepper::Four(s) => s.pixel(),
        }
    }

    /// Switches to 4-connected stepping at the current pixel (no-op if
    /// already switched).
    pub fn switch_to_four(&mut self) {
        if let AlternatingStepper::Eight(s) = *self {
            *self = AlternatingStepper::Four(s.into_four());
        }
    }

    /// Moves to the next pixel; `false` at the end.
    pub fn step(&mut self) -> bool {
        match self {
            AlternatingStepper::Eight(s) => s.step(),
            AlternatingStepper::Four(s) => s.step(),
        }
    }
}

/// Iterator over an 8→4 alternating line (seed Fig. 8): 8-connected steps
/// until `switch_here` returns `true` for the current pixel, 4-connected
/// steps from that pixel to the end.
pub struct AlternatingLine<F> {
    state: AlternatingStepper,
    pending: bool,
    switch_here: F,
}

/// The 8→4 alternating line from `p0` to `p1`: `switch_here(pixel)` is asked
/// at each pixel while the line is still 8-connected (in the seed: "is this
/// pixel nonempty?", an object pixel or a proximity flag); at the first
/// `true` the line continues from that pixel as a 4-line.
///
/// ```
/// use glam::I64Vec2;
/// use voxkit::line::line2d::alternating_line;
/// // Switch at (2, 1): 8-steps before, 4-steps after.
/// let p: Vec<_> = alternating_line(I64Vec2::ZERO, I64Vec2::new(4, 2), |p| p == I64Vec2::new(2, 1))
///     .unwrap()
///     .map(|p| p.to_array())
///     .collect();
/// assert_eq!(p, [[0, 0], [1, 1], [2, 1], [3, 1], [3, 2], [4, 2]]);
/// ```
pub fn alternating_line<F>(p0: Pixel, p1: Pixel, switch_here: F) -> Result<AlternatingLine<F>>
where
    F: FnMut(Pixel) -> bool,
{
    Ok(AlternatingLine {
        state: AlternatingStepper::Eight(Line8Stepper::new(p0, p1)?),
        pending: true,
        switch_here,
    })
}

impl<F> AlternatingLine<F> {
    /// The underlying stepping state.
    pub fn stepper(&self) -> &AlternatingStepper {
        &self.state
    }
}

impl<F: FnMut(Pixel) -> bool> Iterator for AlternatingLine<F> {
    type Item = Pixel;

    fn next(&mut self) -> Option<Pixel> {
        if std::mem::take(&mut self.pending) {
            return Some(self.state.pixel());
        }
        if let AlternatingStepper::Eight(s) = self.state
            && (self.switch_here)(s.pixel())
        {
            self.state.switch_to_four();
        }
        self.state.step().then(|| self.state.pixel())
    }

    /// Exact once switched; before, between the 8-line's and the 4-line's
    /// remaining counts.
    fn size_hint(&self) -> (usize, Option<usize>) {
        let p = self.pending as u64;
        match self.state {
            AlternatingStepper::Four(s) => hint(s.remaining_steps() + p),
            AlternatingStepper::Eight(s) => {
                let lo = hint(s.remaining_steps() + p).0;
                let hi = hint(s.into_four().remaining_steps() + p).1;
                (lo, hi)
            }
        }
    }
}

impl<F: FnMut(Pixel) -> bool> std::iter::FusedIterator for AlternatingLine<F> {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_line_is_eight_line_switched_at_start() {
        for (a, b) in [
            ((0, 0), (7, 3)),
            ((2, -1), (-4, 9)),
            ((0, 0), (0, 0)),
            ((1, 1), (-5, 1)),
        ] {
            let (a, b) = (Pixel::new(a.0, a.1), Pixel::new(b.0, b.1));
            assert_eq!(
                Line8Stepper::new(a, b).unwrap().into_four(),
                Line4Stepper::new(a, b).unwrap()
            );
        }
    }

    #[test]
    fn range_is_checked() {
        let far = Pixel::new(MAX_COORD_2D + 1, 0);
        assert!(line8(Pixel::ZERO, far).is_err());
        assert!(line4(far, Pixel::ZERO).is_err());
        let edge = Pixel::new(MAX_COORD_2D, -MAX_COORD_2D);
        let l = line4(-edge, edge).unwrap();
        assert_eq!(l.len() as u64, 4 * MAX_COORD_2D as u64 + 1);
    }
}
