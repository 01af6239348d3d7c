//! Scanline enumeration of the lattice points of a closed lattice triangle:
//! the baseline the Kahan–Kelsen index is benchmarked against, and a second
//! oracle for it.
//!
//! Rows `y = y_min..=y_max`; on each row the span `x_lo..=x_hi` is the
//! intersection of the three closed half-planes, each bound being
//! `⌊ex·(y − py)/ey⌋` stepped exactly from row to row as quotient + remainder
//! (no division per row). Cost is `O(rows + points)`: on a skinny 45° triangle
//! it is dominated by the rows, which is what indexing avoids.
//!
//! Range: vertex coordinates within ±2^30 (then `|ex·(y − py)| ≤ 2^62`, i64).

use super::index::{COORD_LIMIT, LatticePoint, collinear_segment, orient};
use crate::{Result, VoxkitError};

/// Exact incremental `⌊num/den⌋` with `den > 0` and `num` growing by `dnum` per row.
#[derive(Clone, Copy, Debug)]
struct FloorStep {
    q: i64,
    r: i64,
    dq: i64,
    dr: i64,
    den: i64,
}

impl FloorStep {
    fn new(num: i64, dnum: i64, den: i64) -> Self {
        FloorStep {
            q: num.div_euclid(den),
            r: num.rem_euclid(den),
            dq: dnum.div_euclid(den),
            dr: dnum.rem_euclid(den),
            den,
        }
    }

    #[inline(always)]
    fn step(&mut self) {
        self.q += self.dq;
        self.r += self.dr;
        if self.r >= self.den {
            self.r -= self.den;
            self.q += 1;
        }
    }
}

/// One bounding edge: `x ≤ px + ⌊…⌋` (upper) or `x ≥ px − ⌊…⌋` (lower).
#[derive(Clone, Copy, Debug)]
struct Bound {
    px: i64,
    upper: bool,
    f: FloorStep,
}

impl Bound {
    #[inline(always)]
    fn value(&self) -> i64 {
        if self.upper {
            self.px + self.f.q
        } else {
            self.px - self.f.q
        }
    }
}

/// Scanline lattice enumerator of a closed triangle with integer vertices.
///
/// ```
/// use voxkit::triangle::ScanlineLattice;
/// let s = ScanlineLattice::new([[0, 0], [4, 0], [0, 4]]).unwrap();
/// assert_eq!(s.count(), 15);
/// let mut first = None;
/// s.for_each(|p| { first.get_or_insert(p); });
/// assert_eq!(first, Some([0, 0]));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct ScanlineLattice {
    kind: ScanKind,
}

#[derive(Clone, Copy, Debug)]
enum ScanKind {
    Segment {
        start: LatticePoint,
        step: LatticePoint,
        len: u64,
    },
    Rows {
        y0: i64,
        y1: i64,
        bounds: [Bound; 3],
        nb: usize,
    },
}

impl ScanlineLattice {
    /// Prepares the scan of the closed triangle `v`. Collinear vertices give the
    /// lattice points of the segment they span.
    ///
    /// # Errors
    /// [`VoxkitError::Invalid`] if a coordinate is outside ±2^30.
    pub fn new(v: [LatticePoint; 3]) -> Result<Self> {
        if v.iter().flatten().any(|c| c.abs() > COORD_LIMIT) {
            return Err(VoxkitError::invalid(
                "triangle vertex coordinate outside ±2^30",
            ));
        }
        let o = orient(&v);
        if o == 0 {
            let (start, step, len) = collinear_segment(&v);
            return Ok(ScanlineLattice {
                kind: ScanKind::Segment { start, step, len },
            });
        }
        // Counter-clockwise, so the interior is left of every edge:
        // ey·(x − px) ≤ ex·(y − py).
        let v = if o > 0 { v } else { [v[0], v[2], v[1]] };
        let y0 = v.iter().map(|p| p[1]).min().expect("3");
        let y1 = v.iter().map(|p| p[1]).max().expect("3");
        let mut bounds = [Bound {
            px: 0,
            upper: true,
            f: FloorStep::new(0, 0, 1),
        }; 3];
        let mut nb = 0;
        for e in 0..3 {
            let (p, q) = (v[e], v[(e + 1) % 3]);
            let (ex, ey) = (q[0] - p[0], q[1] - p[1]);
            if ey == 0 {
                continue; // a horizontal edge only bounds y, which the row range does
            }
            let num = ex * (y0 - p[1]);
            bounds[nb] = Bound {
                px: p[0],
                upper: ey > 0,
                f: FloorStep::new(num, ex, ey.abs()),
            };
            nb += 1;
        }
        Ok(ScanlineLattice {
            kind: ScanKind::Rows { y0, y1, bounds, nb },
        })
    }

    /// Visits every lattice point of the closed triangle, row by row (y
    /// ascending, x ascending within a row); collinear input along its segment.
    #[inline]
    pub fn for_each(&self, mut f: impl FnMut(LatticePoint)) {
        match self.kind {
            ScanKind::Segment { start, step, len } => {
                let mut p = start;
                for _ in 0..len {
                    f(p);
                    p = [p[0] + step[0], p[1] + step[1]];
                }
            }
            ScanKind::Rows {
                y0,
                y1,
                mut bounds,
                nb,
            } => {
                let bounds = &mut bounds[..nb];
                for y in y0..=y1 {
                    let mut lo = i64::MIN;
                    let mut hi = i64::MAX;
                    for b in bounds.iter_mut() {
                        let v = b.value();
                        if b.upper {
                            hi = hi.min(v);
                        } else {
                            lo = lo.max(v);
                        }
                        b.f.step();
                    }
                    for x in lo..=hi {
                        f([x, y]);
                    }
                }
            }
        }
    }

    /// Number of lattice points (`O(rows)`).
    pub fn count(&self) -> u64 {
        match self.kind {
            ScanKind::Segment { len, .. } => len,
            ScanKind::Rows {
                y0,
                y1,
                mut bounds,
                nb,
            } => {
                let bounds = &mut bounds[..nb];
                let mut n = 0u64;
                for _ in y0..=y1 {
                    let mut lo = i64::MIN;
                    let mut hi = i64::MAX;
                    for b in bounds.iter_mut() {
                        let v = b.value();
                        if b.upper {
                            hi = hi.min(v);
                        } else {
                            lo = lo.max(v);
                        }
                        b.f.step();
                    }
                    if hi >= lo {
                        n += (hi - lo + 1) as u64;
                    }
                }
                n
            }
        }
    }
}
