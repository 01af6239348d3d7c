//! Scanline triangle filling (after Petridis's polygon-filling notes and the
//! classic active-edge formulation), exact in integer arithmetic.
//!
//! The vertices are sorted by y; the *long* edge (top → bottom) bounds every
//! row on one side, the two *short* edges (top → mid, mid → bottom) on the
//! other. For each row whose centre `yc` satisfies `y_top ≤ yc < y_bottom`,
//! the crossing of each edge with the row is the exact rational
//! `x = ax + (yc − ay)·(bx − ax)/(by − ay)`, and the span is the pixel
//! centres `xc` with `x_left ≤ xc < x_right` (ceil / floor of exact
//! quotients, no floating point).
//!
//! This is the same top-left fill rule as the edge-function rasterizer
//! ([`super::raster`]), derived independently: left edges and top
//! horizontal edges are inclusive, right edges and bottom horizontal edges
//! exclusive. Horizontal edges never bound a row (they are the first or
//! last row's limit); collapsed vertices and collinear triangles yield
//! empty spans (`x_left = x_right`), a single point yields no row. Fixed
//! point and range as in [`super::raster`] (8 fraction bits, `|v| ≤ 2^20`
//! pixels): every intermediate fits in 60 bits.

use super::raster::{FixedTriangle, SUB_HALF, SUB_ONE, ceil_div};

/// The first pixel column whose centre `xc` satisfies `xc·den ≥ num`
/// (`den > 0`), i.e. `ceil((num/den − ½)/1)` in pixel units.
#[inline]
fn first_centre_at_or_after(num: i64, den: i64) -> i64 {
    ceil_div(num - SUB_HALF * den, SUB_ONE * den)
}

/// An edge from `a` to `b` with `a.y < b.y`, for crossing computations.
#[derive(Clone, Copy, Debug)]
struct ScanEdge {
    ax: i64,
    ay: i64,
    dx: i64,
    dy: i64,
}

impl ScanEdge {
    fn new(a: [i64; 2], b: [i64; 2]) -> Self {
        ScanEdge {
            ax: a[0],
            ay: a[1],
            dx: b[0] - a[0],
            dy: b[1] - a[1],
        }
    }

    /// First pixel column whose centre is at or right of the crossing with
    /// the row centred at fixed-point `yc`.
    #[inline]
    fn first_column(&self, yc: i64) -> i64 {
        let num = self.ax * self.dy + (yc - self.ay) * self.dx;
        first_centre_at_or_after(num, self.dy)
    }
}

/// Calls `visit(y, x_start, x_end)` (inclusive, clipped to the
/// `width × height` framebuffer) for each non-empty row span of `tri`, top
/// row first.
///
/// ```
/// use voxkit::triangle::{scanline_spans, FixedTriangle};
/// let t = FixedTriangle::from_pixels([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]]).unwrap();
/// let mut spans = Vec::new();
/// scanline_spans(&t, 8, 8, |y, a, b| spans.push((y, a, b)));
/// // Centres (x + ½, y + ½) with x + y + 1 < 4: the hypotenuse is a right
/// // edge, so centres on it (x + y = 3) are left to the neighbour.
/// assert_eq!(spans, vec![(0, 0, 2), (1, 0, 1), (2, 0, 0)]);
/// ```
pub fn scanline_spans<F: FnMut(u32, u32, u32)>(
    tri: &FixedTriangle,
    width: u32,
    height: u32,
    mut visit: F,
) {
    let mut v = tri.vertices();
    // Sort by y (then x, so that ties are deterministic).
    v.sort_by_key(|p| (p[1], p[0]));
    let [top, mid, bot] = v;
    if top[1] == bot[1] {
        return; // horizontal line or point: no row centre lies in [y, y).
    }
    let long = ScanEdge::new(top, bot);
    let upper = ScanEdge::new(top, mid);
    let lower = ScanEdge::new(mid, bot);
    // Is the long edge the left one? With d = bot − top (d.y > 0) and
    // m = mid − top, mid lies right of the long edge at y_mid iff
    // m.x·d.y > m.y·d.x, i.e. iff d × m < 0 (exact).
    let cross = (bot[0] - top[0]) * (mid[1] - top[1]) - (bot[1] - top[1]) * (mid[0] - top[0]);
    let long_is_left = cross < 0;
    // Rows whose centre lies in [y_top, y_bot).
    let ya = ceil_div(top[1] - SUB_HALF, SUB_ONE).max(0);
    let yb = (ceil_div(bot[1] - SUB_HALF, SUB_ONE) - 1).min(height as i64 - 1);
    for y in ya..=yb {
        let yc = y * SUB_ONE + SUB_HALF;
        let short = if yc < mid[1] { &upper } else { &lower };
        let (l, r) = if long_is_left {
            (&long, short)
        } else {
            (short, &long)
        };
        // Left inclusive: first centre ≥ x_left. Right exclusive: last
        // centre < x_right is one before the first centre ≥ x_right.
        let xa = l.first_column(yc).max(0);
        let xb = (r.first_column(yc) - 1).min(width as i64 - 1);
        if xa <= xb {
            visit(y as u32, xa as u32, xb as u32);
        }
    }
}

/// Fills `tri` with `value` span by span; returns the number of pixels
/// written. Same pixels as [`super::fill_triangle_edge`].
pub fn fill_triangle_scanline<P: Copy>(
    fb: &mut super::Framebuffer<P>,
    tri: &FixedTriangle,
    value: P,
) -> usize {
    let (w, h) = (fb.width(), fb.height());
    let mut count = 0;
    scanline_spans(tri, w, h, |y, a, b| {
        fb.row_mut(y)[a as usize..=b as usize].fill(value);
        count += (b - a + 1) as usize;
    });
    count
}
