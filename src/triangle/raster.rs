//! Triangle rasterization with edge functions (Pineda 1988), evaluated
//! incrementally in exact integer arithmetic.
//!
//! # Conventions
//! - **Screen space**: x to the right, y **down** (row 0 is the top row).
//!   Pixel `(x, y)` is sampled at its **centre** `(x + ½, y + ½)`.
//! - **Sub-pixel fixed point**: a vertex coordinate `v` (pixels) is stored as
//!   the integer `round(v · 2^SUB_BITS)` with [`SUB_BITS`] = 8 (1/256 pixel).
//!   Pixel centres are exact in this lattice (`x · 256 + 128`).
//! - **Range**: vertex coordinates must satisfy `|v| ≤ 2^20` pixels
//!   ([`MAX_PIXEL_COORD`]); framebuffers are at most `2^15` pixels a side. Then
//!   coordinate differences fit in 29 bits, each product in 58 bits and an edge
//!   value in 60 bits: all edge arithmetic is exact in `i64`.
//! - **Fill rule: top-left.** A pixel is covered when its centre is strictly
//!   inside the triangle, or lies on a *top* edge (horizontal, interior below
//!   it) or a *left* edge (interior to its right). Orientation is normalised
//!   first, so either winding gives the same pixels; two triangles sharing an
//!   edge never both cover a pixel on it, and a complete fan around a vertex
//!   covers a pixel centred on that vertex exactly once.
//! - **Degenerate triangles** (zero area: collinear, two or three equal
//!   vertices) cover no pixel. This is what the tiling guarantee needs: a
//!   zero-area triangle in a mesh adds no area, so it must add no pixels.
//!
//! # Cost
//! Setup is O(1); the walk visits the bounding box (clipped to the
//! framebuffer once) with one add per edge per pixel and one per edge per row.

use crate::error::{Result, VoxkitError};

/// Fraction bits of a sub-pixel fixed-point coordinate.
pub const SUB_BITS: u32 = 8;
/// One pixel in fixed point.
pub const SUB_ONE: i64 = 1 << SUB_BITS;
/// Half a pixel in fixed point (the offset of a pixel centre).
pub const SUB_HALF: i64 = SUB_ONE / 2;
/// Largest supported magnitude of a vertex coordinate, in pixels (2^20).
pub const MAX_PIXEL_COORD: i64 = 1 << 20;
/// Largest supported magnitude of a fixed-point vertex coordinate.
pub const MAX_FIXED_COORD: i64 = MAX_PIXEL_COORD << SUB_BITS;

/// Converts a pixel coordinate to sub-pixel fixed point (nearest, ties away
/// from zero), rejecting NaN, infinities and `|v| > 2^20`.
///
/// ```
/// use voxkit::triangle::{to_subpixel, SUB_ONE};
/// assert_eq!(to_subpixel(1.5).unwrap(), SUB_ONE + SUB_ONE / 2);
/// assert!(to_subpixel(f32::NAN).is_err());
/// assert!(to_subpixel(3e6).is_err());
/// ```
pub fn to_subpixel(v: f32) -> Result<i64> {
    let v = v as f64;
    if !v.is_finite() || v.abs() > MAX_PIXEL_COORD as f64 {
        return Err(VoxkitError::invalid(format!(
            "pixel coordinate {v} is not finite or outside ±2^20"
        )));
    }
    Ok((v * SUB_ONE as f64).round() as i64)
}

/// A triangle with sub-pixel fixed-point vertices (`[x, y]` each), any
/// winding, inside the supported range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FixedTriangle {
    v: [[i64; 2]; 3],
}

impl FixedTriangle {
    /// From fixed-point vertices; each coordinate must satisfy
    /// `|c| ≤ MAX_FIXED_COORD`.
    pub fn from_fixed(v: [[i64; 2]; 3]) -> Result<Self> {
        if v.iter().flatten().any(|c| c.abs() > MAX_FIXED_COORD) {
            return Err(VoxkitError::invalid(format!(
                "fixed-point vertex {v:?} outside ±2^{}",
                20 + SUB_BITS
            )));
        }
        Ok(FixedTriangle { v })
    }

    /// From pixel coordinates, rounded to 1/256 pixel (see [`to_subpixel`]).
    ///
    /// ```
    /// use voxkit::triangle::FixedTriangle;
    /// let t = FixedTriangle::from_pixels([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]]).unwrap();
    /// assert_eq!(t.area2(), 16 * 256 * 256);
    /// ```
    pub fn from_pixels(v: [[f32; 2]; 3]) -> Result<Self> {
        let mut f = [[0i64; 2]; 3];
        for (dst, src) in f.iter_mut().zip(v) {
            *dst = [to_subpixel(src[0])?, to_subpixel(src[1])?];
        }
        Ok(FixedTriangle { v: f })
    }

    /// The fixed-point vertices.
    #[inline]
    pub fn vertices(&self) -> [[i64; 2]; 3] {
        self.v
    }

    /// Twice the signed area in fixed-point units squared:
    /// `(v1 − v0) × (v2 − v0)`. Positive when the vertices run clockwise on
    /// screen (y down), zero for degenerate triangles.
    #[inline]
    pub fn area2(&self) -> i64 {
        let [a, b, c] = self.v;
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    }
}

/// An inclusive pixel rectangle `[x0, x1] × [y0, y1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// Last column (inclusive).
    pub x1: u32,
    /// Last row (inclusive).
    pub y1: u32,
}

/// `floor(a / b)` for `b > 0`.
#[inline]
pub(crate) fn floor_div(a: i64, b: i64) -> i64 {
    a.div_euclid(b)
}

/// `ceil(a / b)` for `b > 0`.
#[inline]
pub(crate) fn ceil_div(a: i64, b: i64) -> i64 {
    -(-a).div_euclid(b)
}

/// Pixel columns whose centre lies in `[lo, hi]` (fixed point), clipped to
/// `0..n`; `None` if empty.
#[inline]
pub(crate) fn centre_range(lo: i64, hi: i64, n: u32) -> Option<(u32, u32)> {
    let a = ceil_div(lo - SUB_HALF, SUB_ONE).max(0);
    let b = floor_div(hi - SUB_HALF, SUB_ONE).min(n as i64 - 1);
    (a <= b).then_some((a as u32, b as u32))
}

/// One edge function in the form used by the walk: the value at a pixel
/// centre is `c + dx·x + dy·y` (x, y pixel indices), already oriented so
/// the interior is positive, and `bias` is 0 for top-left edges and −1 for
/// the others (a pixel is inside this edge iff `value + bias ≥ 0`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeEq {
    /// Change per pixel step in x.
    pub dx: i64,
    /// Change per pixel step in y.
    pub dy: i64,
    /// Value at the centre of pixel (0, 0).
    pub c: i64,
    /// Fill-rule bias: 0 on top-left edges, −1 otherwise.
    pub bias: i64,
}

impl EdgeEq {
    /// The (unbiased) value at the centre of pixel `(x, y)`.
    #[inline]
    pub fn at(&self, x: i64, y: i64) -> i64 {
        self.c + self.dx * x + self.dy * y
    }
}

/// Per-triangle setup: three oriented edge functions, `|area2|` and the
/// bounding box clipped to the framebuffer. Edge `i` is the one opposite
/// vertex `i`, so its value at a pixel divided by [`TriangleSetup::area2`]
/// is the barycentric weight of vertex `i` there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TriangleSetup {
    /// Edge functions, edge `i` opposite vertex `i`.
    pub edges: [EdgeEq; 3],
    /// `|area2|` of the triangle (> 0).
    pub area2: i64,
    /// Pixels whose centres lie in the triangle's bounding box, clipped.
    pub bbox: PixelRect,
}

impl TriangleSetup {
    /// Sets `tri` up for a `width × height` framebuffer. `None` when the
    /// triangle is degenerate or its bounding box misses the framebuffer.
    pub fn new(tri: &FixedTriangle, width: u32, height: u32) -> Option<Self> {
        let area = tri.area2();
        if area == 0 {
            return None;
        }
        let s = area.signum();
        let v = tri.v;
        let (xs, ys) = (v.map(|p| p[0]), v.map(|p| p[1]));
        let (minx, maxx) = (*xs.iter().min()?, *xs.iter().max()?);
        let (miny, maxy) = (*ys.iter().min()?, *ys.iter().max()?);
        let (x0, x1) = centre_range(minx, maxx, width)?;
        let (y0, y1) = centre_range(miny, maxy, height)?;
        let mut edges = [EdgeEq {
            dx: 0,
            dy: 0,
            c: 0,
            bias: 0,
        }; 3];
        for (i, e) in edges.iter_mut().enumerate() {
            let a = v[(i + 1) % 3];
            let b = v[(i + 2) % 3];
            // E(p) = (b − a) × (p − a) = A·(px − ax) + B·(py − ay), times s.
            let ea = s * (a[1] - b[1]);
            let eb = s * (b[0] - a[0]);
            // Top-left: interior to the right (gradient x > 0) or a
            // horizontal edge with the interior below (y grows downwards).
            let top_left = ea > 0 || (ea == 0 && eb > 0);
            *e = EdgeEq {
                dx: ea * SUB_ONE,
                dy: eb * SUB_ONE,
                c: ea * (SUB_HALF - a[0]) + eb * (SUB_HALF - a[1]),
                bias: if top_left { 0 } else { -1 },
            };
        }
        Some(TriangleSetup {
            edges,
            area2: area.abs(),
            bbox: PixelRect { x0, y0, x1, y1 },
        })
    }

    /// Whether the centre of pixel `(x, y)` is covered (top-left rule).
    #[inline]
    pub fn covers(&self, x: i64, y: i64) -> bool {
        self.edges.iter().all(|e| e.at(x, y) + e.bias >= 0)
    }

    /// The unbiased edge values (barycentric weights × `area2`) at the
    /// centre of pixel `(x, y)`, any pixel.
    #[inline]
    pub fn weights_at(&self, x: i64, y: i64) -> [i64; 3] {
        self.edges.map(|e| e.at(x, y))
    }
}

/// A covered pixel and its three edge values (barycentric weights of the
/// vertices times [`TriangleSetup::area2`]; they sum to `area2`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fragment {
    /// Column.
    pub x: u32,
    /// Row.
    pub y: u32,
    /// Unbiased edge values, `w[i]` for vertex `i`.
    pub w: [i64; 3],
}

/// Walks the pixels of `setup` with incremental edge functions, calling
/// `visit` for each covered pixel in row-major order.
pub fn walk_fragments<F: FnMut(Fragment)>(setup: &TriangleSetup, mut visit: F) {
    let [e0, e1, e2] = setup.edges;
    let b = setup.bbox;
    // Row start values, biased so that "inside" is a sign test.
    let (x0, y0) = (b.x0 as i64, b.y0 as i64);
    let mut r = [
        e0.at(x0, y0) + e0.bias,
        e1.at(x0, y0) + e1.bias,
        e2.at(x0, y0) + e2.bias,
    ];
    for y in b.y0..=b.y1 {
        let mut w = r;
        for x in b.x0..=b.x1 {
            if (w[0] | w[1] | w[2]) >= 0 {
                visit(Fragment {
                    x,
                    y,
                    w: [w[0] - e0.bias, w[1] - e1.bias, w[2] - e2.bias],
                });
            }
            w[0] += e0.dx;
            w[1] += e1.dx;
            w[2] += e2.dx;
        }
        r[0] += e0.dy;
        r[1] += e1.dy;
        r[2] += e2.dy;
    }
}

/// The covered pixels of a triangle as an iterator (the same stepping as
/// [`walk_fragments`], one pixel per `next`; the visitor is faster).
///
/// ```
/// use voxkit::triangle::{FixedTriangle, Fragments, TriangleSetup};
/// let t = FixedTriangle::from_pixels([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]]).unwrap();
/// let s = TriangleSetup::new(&t, 8, 8).unwrap();
/// let px: Vec<(u32, u32)> = Fragments::new(&s).map(|f| (f.x, f.y)).collect();
/// assert_eq!(px, [(0, 0), (1, 0), (0, 1)]);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Fragments {
    setup: TriangleSetup,
    x: u32,
    y: u32,
    row: [i64; 3],
    w: [i64; 3],
    done: bool,
}

impl Fragments {
    /// Starts at the top-left pixel of the clipped bounding box.
    pub fn new(setup: &TriangleSetup) -> Self {
        let (b, e) = (setup.bbox, setup.edges);
        let (x0, y0) = (b.x0 as i64, b.y0 as i64);
        let row = e.map(|e| e.at(x0, y0) + e.bias);
        Fragments {
            setup: *setup,
            x: b.x0,
            y: b.y0,
            row,
            w: row,
            done: false,
        }
    }
}

impl Iterator for Fragments {
    type Item = Fragment;

    fn next(&mut self) -> Option<Fragment> {
        let (b, e) = (self.setup.bbox, self.setup.edges);
        while !self.done {
            let (x, y, w) = (self.x, self.y, self.w);
            // Step to the next pixel of the box.
            if self.x < b.x1 {
                self.x += 1;
                for (w, e) in self.w.iter_mut().zip(&e) {
                    *w += e.dx;
                }
            } else if self.y < b.y1 {
                self.x = b.x0;
                self.y += 1;
                for (r, e) in self.row.iter_mut().zip(&e) {
                    *r += e.dy;
                }
                self.w = self.row;
            } else {
                self.done = true;
            }
            if (w[0] | w[1] | w[2]) >= 0 {
                return Some(Fragment {
                    x,
                    y,
                    w: [w[0] - e[0].bias, w[1] - e[1].bias, w[2] - e[2].bias],
                });
            }
        }
        None
    }
}

/// Calls `visit(y, x_start, x_end)` (inclusive) for each run of covered
/// pixels of `tri`, found by walking edge functions over the clipped
/// bounding box. Same pixels as [`super::scanline::scanline_spans`].
pub fn edge_spans<F: FnMut(u32, u32, u32)>(
    tri: &FixedTriangle,
    width: u32,
    height: u32,
    mut visit: F,
) {
    let Some(setup) = TriangleSetup::new(tri, width, height) else {
        return;
    };
    let mut run: Option<(u32, u32, u32)> = None;
    walk_fragments(&setup, |f| {
        run = match run {
            Some((y, a, b)) if y == f.y && b + 1 == f.x => Some((y, a, f.x)),
            Some((y, a, b)) => {
                visit(y, a, b);
                Some((f.y, f.x, f.x))
            }
            None => Some((f.y, f.x, f.x)),
        };
    });
    if let Some((y, a, b)) = run {
        visit(y, a, b);
    }
}

/// Fills `tri` with `value` using edge functions; returns the number of
/// pixels written.
///
/// ```
/// use voxkit::triangle::{fill_triangle_edge, FixedTriangle, Framebuffer};
/// let mut fb = Framebuffer::new(8, 8, 0u8).unwrap();
/// // Two triangles of the square [0, 4]²: 16 pixels, none twice.
/// let a = FixedTriangle::from_pixels([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]]).unwrap();
/// let b = FixedTriangle::from_pixels([[0.0, 0.0], [4.0, 4.0], [0.0, 4.0]]).unwrap();
/// assert_eq!(fill_triangle_edge(&mut fb, &a, 1) + fill_triangle_edge(&mut fb, &b, 1), 16);
/// ```
pub fn fill_triangle_edge<P: Copy>(
    fb: &mut super::Framebuffer<P>,
    tri: &FixedTriangle,
    value: P,
) -> usize {
    let Some(setup) = TriangleSetup::new(tri, fb.width(), fb.height()) else {
        return 0;
    };
    let [e0, e1, e2] = setup.edges;
    let b = setup.bbox;
    let (x0, y0) = (b.x0 as i64, b.y0 as i64);
    let mut r = [
        e0.at(x0, y0) + e0.bias,
        e1.at(x0, y0) + e1.bias,
        e2.at(x0, y0) + e2.bias,
    ];
    let mut count = 0;
    for y in b.y0..=b.y1 {
        let row = &mut fb.row_mut(y)[b.x0 as usize..=b.x1 as usize];
        let mut w = r;
        for px in row.iter_mut() {
            if (w[0] | w[1] | w[2]) >= 0 {
                *px = value;
                count += 1;
            }
            w[0] += e0.dx;
            w[1] += e1.dx;
            w[2] += e2.dx;
        }
        r[0] += e0.dy;
        r[1] += e1.dy;
        r[2] += e2.dy;
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(v: [[f32; 2]; 3]) -> FixedTriangle {
        FixedTriangle::from_pixels(v).unwrap()
    }

    fn pixels(t: &FixedTriangle, w: u32, h: u32) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        if let Some(s) = TriangleSetup::new(t, w, h) {
            walk_fragments(&s, |f| out.push((f.x, f.y)));
        }
        out
    }

    #[test]
    fn winding_does_not_matter() {
        let a = tri([[0.3, 0.2], [7.9, 2.5], [2.0, 6.5]]);
        let b = tri([[0.3, 0.2], [2.0, 6.5], [7.9, 2.5]]);
        assert_eq!(pixels(&a, 10, 10), pixels(&b, 10, 10));
        assert!(!pixels(&a, 10, 10).is_empty());
    }

    #[test]
    fn top_left_rule_on_axis_aligned_square_halves() {
        // Square [1,3]² split along a diagonal: pixel centres on x = 1 and
        // y = 1 (left, top) are in, x = 3 and y = 3 (right, bottom) are out.
        let a = tri([[1.0, 1.0], [3.0, 1.0], [3.0, 3.0]]);
        let b = tri([[1.0, 1.0], [3.0, 3.0], [1.0, 3.0]]);
        let mut all = pixels(&a, 8, 8);
        all.extend(pixels(&b, 8, 8));
        all.sort();
        assert_eq!(all, vec![(1, 1), (1, 2), (2, 1), (2, 2)]);
        // Centres at half-integers: a triangle whose edges pass through
        // centres, e.g. the diagonal through (1.5,1.5) and (2.5,2.5).
        let c = tri([[0.5, 0.5], [3.5, 0.5], [3.5, 3.5]]);
        let d = tri([[0.5, 0.5], [3.5, 3.5], [0.5, 3.5]]);
        let (pc, pd) = (pixels(&c, 8, 8), pixels(&d, 8, 8));
        assert!(pc.iter().all(|p| !pd.contains(p)));
        assert_eq!(pc.len() + pd.len(), 9);
    }

    #[test]
    fn degenerate_triangles_cover_nothing() {
        assert!(pixels(&tri([[1.5, 1.5], [1.5, 1.5], [1.5, 1.5]]), 4, 4).is_empty());
        assert!(pixels(&tri([[0.5, 0.5], [3.5, 3.5], [1.5, 1.5]]), 4, 4).is_empty());
        assert!(pixels(&tri([[0.5, 0.5], [3.5, 3.5], [3.5, 3.5]]), 4, 4).is_empty());
    }

    #[test]
    fn range_is_checked() {
        assert!(FixedTriangle::from_fixed([[MAX_FIXED_COORD, 0], [0, 0], [0, 1]]).is_ok());
        assert!(FixedTriangle::from_fixed([[MAX_FIXED_COORD + 1, 0], [0, 0], [0, 1]]).is_err());
        assert!(
            FixedTriangle::from_pixels([[f32::INFINITY, 0.0], [0.0, 0.0], [0.0, 1.0]]).is_err()
        );
    }
}
