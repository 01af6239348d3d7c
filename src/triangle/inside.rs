//! Batched point-in-triangle tests (the qTriangle cross-product form):
//! a point `p` is in the closed triangle iff the three edge functions
//! `(v_{i+1} − v_i) × (p − v_i)` are all `≥ 0`, once the vertices are put in
//! positive (clockwise on a y-down screen) order.
//!
//! The batch kernels take structure-of-arrays slices (`xs`, `ys`), process
//! fixed chunks of [`CHUNK`] points with no branch and no early exit in the
//! inner loop (the three tests are combined with `&`), and so compile to
//! packed SIMD compares (`cmpleps` / `pcmpgtd` on SSE2, their `v`-prefixed
//! forms on AVX). The tail is handled by the scalar test, which is the same
//! arithmetic, so batched and scalar results are identical.
//!
//! Two number types:
//! - [`InsideF32`]: `f32` arithmetic exactly as the seed writes it (rounded
//!   products, so points within rounding of an edge may go either way, but
//!   the batched and scalar answers agree bit for bit). NaN points are
//!   outside.
//! - [`InsideI32`]: exact `i32` arithmetic. Vertices must satisfy
//!   `|v| ≤ 2^14 − 1` ([`INSIDE_I32_MAX`]); points may be any `i32` (they are
//!   clamped to `±2^14`, which cannot change their answer because a clamped
//!   point stays outside the box holding the vertices). Then every product
//!   is below 2^30 and every edge value fits in `i32`.
//!
//! Zero-area triangles are rejected: with the closed test every point of
//! their supporting line would pass.

use crate::error::{Result, VoxkitError};

/// Points per chunk in the batched kernels.
pub const CHUNK: usize = 16;

/// Largest vertex coordinate magnitude accepted by [`InsideI32`].
pub const INSIDE_I32_MAX: i32 = (1 << 14) - 1;

/// Exact sign of the doubled area of an `f32` triangle (each `f32` product
/// is exact in `f64`, and the final subtraction keeps the sign).
fn area_sign_f32(v: &[[f32; 2]; 3]) -> f64 {
    let d = |i: usize, k: usize| v[i][k] as f64 - v[0][k] as f64;
    // The differences of two f32 are exact in f64 as well.
    d(1, 0) * d(2, 1) - d(1, 1) * d(2, 0)
}

fn check_lengths(xs: usize, ys: usize, out: Option<usize>) -> Result<()> {
    if xs != ys || out.is_some_and(|o| o != xs) {
        return Err(VoxkitError::invalid(format!(
            "point slices differ in length: xs {xs}, ys {ys}, out {out:?}"
        )));
    }
    Ok(())
}

/// A triangle prepared for `f32` point tests.
///
/// ```
/// use voxkit::triangle::InsideF32;
/// let t = InsideF32::new([[0.0, 0.0], [0.0, 4.0], [4.0, 0.0]]).unwrap();
/// assert!(t.contains(1.0, 1.0));
/// assert!(t.contains(0.0, 2.0)); // closed: edges count
/// assert!(!t.contains(3.0, 3.0));
/// let (xs, ys) = ([1.0, 3.0, 0.5], [1.0, 3.0, 0.5]);
/// assert_eq!(t.count(&xs, &ys).unwrap(), 2);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InsideF32 {
    /// Vertex x, y (positive order).
    vx: [f32; 3],
    vy: [f32; 3],
    /// Edge directions `v_{i+1} − v_i`.
    ex: [f32; 3],
    ey: [f32; 3],
}

impl InsideF32 {
    /// Prepares a triangle (any winding). Errors on non-finite vertices and
    /// on zero area.
    pub fn new(v: [[f32; 2]; 3]) -> Result<Self> {
        if v.iter().flatten().any(|c| !c.is_finite()) {
            return Err(VoxkitError::invalid(format!(
                "triangle {v:?} has a non-finite vertex"
            )));
        }
        let s = area_sign_f32(&v);
        if s == 0.0 {
            return Err(VoxkitError::invalid(format!(
                "triangle {v:?} has zero area"
            )));
        }
        let v = if s > 0.0 { v } else { [v[0], v[2], v[1]] };
        let vx = v.map(|p| p[0]);
        let vy = v.map(|p| p[1]);
        let ex = [vx[1] - vx[0], vx[2] - vx[1], vx[0] - vx[2]];
        let ey = [vy[1] - vy[0], vy[2] - vy[1], vy[0] - vy[2]];
        Ok(InsideF32 { vx, vy, ex, ey })
    }

    /// Scalar test: is `(x, y)` in the closed triangle?
    #[inline(always)]
    pub fn contains(&self, x: f32, y: f32) -> bool {
        let e0 = self.ex[0] * (y - self.vy[0]) - self.ey[0] * (x - self.vx[0]);
        let e1 = self.ex[1] * (y - self.vy[1]) - self.ey[1] * (x - self.vx[1]);
        let e2 = self.ex[2] * (y - self.vy[2]) - self.ey[2] * (x - self.vx[2]);
        (e0 >= 0.0) & (e1 >= 0.0) & (e2 >= 0.0)
    }

    /// Writes `1` (inside) or `0` to `out[i]` for each point
    /// `(xs[i], ys[i])`; returns the number inside. Slices must have equal
    /// lengths.
    pub fn mask(&self, xs: &[f32], ys: &[f32], out: &mut [u8]) -> Result<usize> {
        check_lengths(xs.len(), ys.len(), Some(out.len()))?;
        Ok(mask_f32(self, xs, ys, out))
    }

    /// The number of points `(xs[i], ys[i])` inside.
    pub fn count(&self, xs: &[f32], ys: &[f32]) -> Result<usize> {
        check_lengths(xs.len(), ys.len(), None)?;
        Ok(count_f32(self, xs, ys))
    }

    /// Reference loop: the scalar test per point (for tests and benches).
    pub fn count_scalar(&self, xs: &[f32], ys: &[f32]) -> Result<usize> {
        check_lengths(xs.len(), ys.len(), None)?;
        Ok(xs
            .iter()
            .zip(ys)
            .filter(|&(&x, &y)| self.contains(x, y))
            .count())
    }
}

/// The `f32` mask kernel (kept out of line so it can be found in a
/// disassembly).
#[inline(never)]
fn mask_f32(t: &InsideF32, xs: &[f32], ys: &[f32], out: &mut [u8]) -> usize {
    let mut total = 0usize;
    let mut cx = xs.chunks_exact(CHUNK);
    let mut cy = ys.chunks_exact(CHUNK);
    let mut co = out.chunks_exact_mut(CHUNK);
    for ((x, y), o) in (&mut cx).zip(&mut cy).zip(&mut co) {
        let x: &[f32; CHUNK] = x.try_into().expect("chunk");
        let y: &[f32; CHUNK] = y.try_into().expect("chunk");
        let o: &mut [u8; CHUNK] = o.try_into().expect("chunk");
        let mut n = 0u8;
        for i in 0..CHUNK {
            let m = t.contains(x[i], y[i]) as u8;
            o[i] = m;
            n += m;
        }
        total += n as usize;
    }
    for ((&x, &y), o) in cx
        .remainder()
        .iter()
        .zip(cy.remainder())
        .zip(co.into_remainder())
    {
        *o = t.contains(x, y) as u8;
        total += *o as usize;
    }
    total
}

/// The `f32` counting kernel.
#[inline(never)]
fn count_f32(t: &InsideF32, xs: &[f32], ys: &[f32]) -> usize {
    let mut acc = [0u32; CHUNK];
    let mut cx = xs.chunks_exact(CHUNK);
    let mut cy = ys.chunks_exact(CHUNK);
    for (x, y) in (&mut cx).zip(&mut cy) {
        let x: &[f32; CHUNK] = x.try_into().expect("chunk");
        let y: &[f32; CHUNK] = y.try_into().expect("chunk");
        for i in 0..CHUNK {
            acc[i] += t.contains(x[i], y[i]) as u32;
        }
    }
    let mut total: usize = acc.iter().map(|&a| a as usize).sum();
    for (&x, &y) in cx.remainder().iter().zip(cy.remainder()) {
        total += t.contains(x, y) as usize;
    }
    total
}

/// A triangle prepared for exact `i32` point tests (see the module doc for
/// the range).
///
/// ```
/// use voxkit::triangle::InsideI32;
/// let t = InsideI32::new([[0, 0], [4, 0], [0, 4]]).unwrap();
/// assert!(t.contains(2, 2)); // on the hypotenuse: closed test
/// assert!(!t.contains(3, 2));
/// assert!(!t.contains(i32::MAX, 0));
/// let mut m = [0u8; 3];
/// assert_eq!(t.mask(&[0, 1, 5], &[0, 1, 5], &mut m).unwrap(), 2);
/// assert_eq!(m, [1, 1, 0]);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InsideI32 {
    vx: [i32; 3],
    vy: [i32; 3],
    ex: [i32; 3],
    ey: [i32; 3],
}

/// Points are clamped to `±CLAMP_I32` before the exact test.
const CLAMP_I32: i32 = INSIDE_I32_MAX + 1;

impl InsideI32 {
    /// Prepares a triangle (any winding). Errors when a coordinate exceeds
    /// [`INSIDE_I32_MAX`] in magnitude or the area is zero.
    pub fn new(v: [[i32; 2]; 3]) -> Result<Self> {
        if v.iter().flatten().any(|c| c.abs() > INSIDE_I32_MAX) {
            return Err(VoxkitError::invalid(format!(
                "triangle {v:?} outside ±{INSIDE_I32_MAX}"
            )));
        }
        let d = |i: usize, k: usize| (v[i][k] - v[0][k]) as i64;
        let s = d(1, 0) * d(2, 1) - d(1, 1) * d(2, 0);
        if s == 0 {
            return Err(VoxkitError::invalid(format!(
                "triangle {v:?} has zero area"
            )));
        }
        let v = if s > 0 { v } else { [v[0], v[2], v[1]] };
        let vx = v.map(|p| p[0]);
        let vy = v.map(|p| p[1]);
        let ex = [vx[1] - vx[0], vx[2] - vx[1], vx[0] - vx[2]];
        let ey = [vy[1] - vy[0], vy[2] - vy[1], vy[0] - vy[2]];
        Ok(InsideI32 { vx, vy, ex, ey })
    }

    /// Scalar exact test: is `(x, y)` in the closed triangle?
    #[inline(always)]
    pub fn contains(&self, x: i32, y: i32) -> bool {
        let x = x.clamp(-CLAMP_I32, CLAMP_I32);
        let y = y.clamp(-CLAMP_I32, CLAMP_I32);
        // |edge| < 2^15, |p − v| < 2^15: each product < 2^30, so the
        // difference fits in i32 (no overflow possible).
        let e0 = self.ex[0] * (y - self.vy[0]) - self.ey[0] * (x - self.vx[0]);
        let e1 = self.ex[1] * (y - self.vy[1]) - self.ey[1] * (x - self.vx[1]);
        let e2 = self.ex[2] * (y - self.vy[2]) - self.ey[2] * (x - self.vx[2]);
        (e0 | e1 | e2) >= 0
    }

    /// Writes `1` (inside) or `0` to `out[i]`; returns the number inside.
    pub fn mask(&self, xs: &[i32], ys: &[i32], out: &mut [u8]) -> Result<usize> {
        check_lengths(xs.len(), ys.len(), Some(out.len()))?;
        Ok(mask_i32(self, xs, ys, out))
    }

    /// The number of points inside.
    pub fn count(&self, xs: &[i32], ys: &[i32]) -> Result<usize> {
        check_lengths(xs.len(), ys.len(), None)?;
        Ok(count_i32(self, xs, ys))
    }

    /// Reference loop: the scalar test per point.
    pub fn count_scalar(&self, xs: &[i32], ys: &[i32]) -> Result<usize> {
        check_lengths(xs.len(), ys.len(), None)?;
        Ok(xs
            .iter()
            .zip(ys)
            .filter(|&(&x, &y)| self.contains(x, y))
            .count())
    }
}

/// The `i32` mask kernel.
#[inline(never)]
fn mask_i32(t: &InsideI32, xs: &[i32], ys: &[i32], out: &mut [u8]) -> usize {
    let mut total = 0usize;
    let mut cx = xs.chunks_exact(CHUNK);
    let mut cy = ys.chunks_exact(CHUNK);
    let mut co = out.chunks_exact_mut(CHUNK);
    for ((x, y), o) in (&mut cx).zip(&mut cy).zip(&mut co) {
        let x: &[i32; CHUNK] = x.try_into().expect("chunk");
        let y: &[i32; CHUNK] = y.try_into().expect("chunk");
        let o: &mut [u8; CHUNK] = o.try_into().expect("chunk");
        let mut n = 0u8;
        for i in 0..CHUNK {
            let m = t.contains(x[i], y[i]) as u8;
            o[i] = m;
            n += m;
        }
        total += n as usize;
    }
    for ((&x, &y), o) in cx
        .remainder()
        .iter()
        .zip(cy.remainder())
        .zip(co.into_remainder())
    {
        *o = t.contains(x, y) as u8;
        total += *o as usize;
    }
    total
}

/// The `i32` counting kernel.
#[inline(never)]
fn count_i32(t: &InsideI32, xs: &[i32], ys: &[i32]) -> usize {
    let mut acc = [0u32; CHUNK];
    let mut cx = xs.chunks_exact(CHUNK);
    let mut cy = ys.chunks_exact(CHUNK);
    for (x, y) in (&mut cx).zip(&mut cy) {
        let x: &[i32; CHUNK] = x.try_into().expect("chunk");
        let y: &[i32; CHUNK] = y.try_into().expect("chunk");
        for i in 0..CHUNK {
            acc[i] += t.contains(x[i], y[i]) as u32;
        }
    }
    let mut total: usize = acc.iter().map(|&a| a as usize).sum();
    for (&x, &y) in cx.remainder().iter().zip(cy.remainder()) {
        total += t.contains(x, y) as usize;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_degenerate_and_out_of_range() {
        assert!(InsideF32::new([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]).is_err());
        assert!(InsideF32::new([[0.0, f32::NAN], [1.0, 1.0], [2.0, 0.0]]).is_err());
        assert!(InsideI32::new([[0, 0], [1, 1], [2, 2]]).is_err());
        assert!(InsideI32::new([[0, 0], [INSIDE_I32_MAX + 1, 1], [2, 0]]).is_err());
        let t = InsideI32::new([[0, 0], [1, 0], [0, 1]]).unwrap();
        assert!(t.mask(&[1, 2], &[1], &mut [0; 2]).is_err());
    }

    #[test]
    fn range_ends_exact() {
        let m = INSIDE_I32_MAX;
        let t = InsideI32::new([[-m, -m], [m, -m], [-m, m]]).unwrap();
        assert!(t.contains(-m, -m));
        assert!(t.contains(0, 0));
        assert!(t.contains(-1, 0)); // strictly inside
        assert!(t.contains(m, -m));
        assert!(!t.contains(m, -m + 1));
        assert!(!t.contains(i32::MIN, i32::MIN));
        assert!(!t.contains(i32::MAX, i32::MIN));
        // Hypotenuse x + y = 0 is on the boundary; (1, 0) is just outside.
        assert!(t.contains(5, -5));
        assert!(!t.contains(1, 0));
    }
}
