//! Generalized winding numbers of a triangle soup with rigorous error bounds:
//! a Barnes–Hut tree (Barill et al. 2018, "Fast winding numbers for soups and
//! clouds") whose far-field terms carry an upper bound of their error, so a
//! caller can tell when an approximate value already decides `w ≥ ½`.
//!
//! Every node stores its area vector `N = Σ ½ (b−a)×(c−a)`, the total of its
//! triangles' absolute areas `A`, its area-weighted centroid `p` and the
//! radius `r` of the ball around `p` holding all its vertices. Seen from a
//! point `q` at distance `g > 0` from the node (`g ≥ d − r`, `d = |p − q|`),
//! the dipole term is `N·(p−q) / (4π d³)`; replacing the kernel
//! `(x−q)/|x−q|³` at `x` by its value at `p` errs by at most `2r/g³` per unit
//! area (the kernel's Jacobian has norm `2/|x|³`), so the term is off by at
//! most `A·2r / (4π g³)`. Leaves are summed exactly (van Oosterom–Strackee
//! solid angles in `f64`).
//!
//! Over a box, [`WindingTree::bound`] adds the box's half-diagonal times a
//! bound of `|∇w|`: off the soup, `∇w` is the Biot–Savart field of the
//! soup's rim (its boundary chain; interior edges cancel), at most
//! `Σ |e| / (4π dist²)` over rim edges ([`RimTree`]). A closed soup has no
//! rim, so its winding number is constant off it. `None` when a triangle may
//! meet the box, where `w` jumps and no bound holds.

use glam::DVec3;

use crate::voxelize::caps::boundary_edges;
use crate::voxelize::surface::{SurfaceTriangle, VOXEL_ONE};

const FOUR_PI: f64 = 4.0 * std::f64::consts::PI;
/// Triangles per leaf.
const LEAF: usize = 8;
/// Slack added to every bound for `f64` rounding of the exact sums (far
/// above their error for meshes below 2^22 voxels, far below any margin).
pub const ROUNDING_SLACK: f64 = 1e-9;

/// The signed solid angle of triangle `(a, b, c)` seen from the origin
/// (van Oosterom–Strackee); positive when the origin is behind the
/// triangle's right-hand normal. Its magnitude is below 2π.
///
/// ```
/// use glam::DVec3;
/// use voxkit::voxelize::winding::solid_angle;
/// // An octant's triangle covers 1/8 of the sphere seen from the origin.
/// let w = solid_angle(DVec3::X, DVec3::Y, DVec3::Z);
/// assert!((w - 4.0 * std::f64::consts::PI / 8.0).abs() < 1e-12);
/// ```
#[inline]
pub fn solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * num.atan2(den)
}

/// Largest error (radians) of [`fast_atan2`], with margin over the largest
/// error found by a dense sweep (`fast_atan2_error_is_bounded`).
pub const FAST_ATAN2_ERROR: f64 = 2e-5;

/// `atan2(y, x)` by octant reduction and a degree-11 odd polynomial for
/// `atan` on `[0, 1]`: several times faster than libm, within
/// [`FAST_ATAN2_ERROR`].
#[inline]
pub fn fast_atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (mn, mx) = (ax.min(ay), ax.max(ay));
    if mx == 0.0 {
        return 0.0;
    }
    let a = mn / mx;
    let s = a * a;
    let mut r = a
        * (0.999_977_26
            + s * (-0.332_623_47
                + s * (0.193_543_46
                    + s * (-0.116_432_87 + s * (0.052_653_32 + s * -0.011_721_20)))));
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 { -r } else { r }
}

/// [`solid_angle`] with [`fast_atan2`]: off by at most `2 · FAST_ATAN2_ERROR`.
#[inline]
fn solid_angle_fast(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * fast_atan2(num, den)
}

/// A value and an upper bound of its error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    /// The approximate winding number.
    pub value: f64,
    /// `|true − value| ≤ error` (over the whole region for [`WindingTree::bound`]).
    pub error: f64,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    centre: DVec3,
    radius: f64,
    normal: DVec3,
    abs_area: f64,
    start: u32,
    end: u32,
    /// Children (0 for a leaf: the root is never a child).
    left: u32,
    right: u32,
}

/// A Barnes–Hut tree over a triangle soup in voxel units (grid space).
#[derive(Clone, Debug)]
pub struct WindingTree {
    nodes: Vec<Node>,
    tris: Vec<[DVec3; 3]>,
    fixed: Vec<SurfaceTriangle>,
    /// Built on first use: only the bounds need it.
    rim: std::sync::OnceLock<RimTree>,
}

impl WindingTree {
    /// Builds the tree over fixed-point triangles ([`VOXEL_ONE`] per voxel).
    ///
    /// ```
    /// use glam::DVec3;
    /// use voxkit::voxelize::winding::WindingTree;
    /// // A closed tetrahedron around the origin.
    /// let v = [[256, 256, 256], [256, -256, -256], [-256, 256, -256], [-256, -256, 256]];
    /// let t = WindingTree::new(&[[v[0], v[1], v[2]], [v[0], v[3], v[1]], [v[0], v[2], v[3]], [v[1], v[3], v[2]]]);
    /// let inside = t.point(DVec3::ZERO, 1e-6).unwrap();
    /// assert!((inside.value.abs() - 1.0).abs() <= inside.error + 1e-9);
    /// ```
    pub fn new(triangles: &[SurfaceTriangle]) -> Self {
        let one = VOXEL_ONE as f64;
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let tri_f: Vec<[DVec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / one))
            .collect();
        let centroids: Vec<DVec3> = tri_f.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let mut nodes = Vec::new();
        if !triangles.is_empty() {
            build(&mut nodes, &mut order, 0, &tri_f, &centroids);
        }
        let tris = order.iter().map(|&i| tri_f[i as usize]).collect();
        let fixed = order.iter().map(|&i| triangles[i as usize]).collect();
        WindingTree {
            nodes,
            tris,
            fixed,
            rim: std::sync::OnceLock::new(),
        }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// Whether the tree holds no triangle (its winding number is 0 everywhere).
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// The winding number over the closed box `[lo, hi]` (grid space): a value
    /// at the box centre whose error bound covers every point of the box, or
    /// `None` when a triangle may meet the box (the winding number may jump
    /// there). The variation over the box is bounded by the
    /// half-diagonal times [`RimTree::gradient_bound`] of the soup's rim.
    /// `beta` is the far-field opening ratio (see [`WindingTree::point`]).
    pub fn bound(&self, lo: DVec3, hi: DVec3, beta: f64) -> Option<Estimate> {
        if self.meets_box(lo, hi) {
            return None;
        }
        let q = (lo + hi) * 0.5;
        let mut e = self.walk(q, beta, None)?;
        let rho = (hi - lo).length() * 0.5;
        if rho > 0.0 {
            e.error += rho * self.rim().gradient_bound(lo, hi);
        }
        Some(e)
    }

    /// An upper bound of `|∇w|` over the closed box `[lo, hi]` (off the
    /// soup): [`RimTree::gradient_bound`] of the soup's rim.
    pub fn gradient_bound(&self, lo: DVec3, hi: DVec3) -> f64 {
        self.rim().gradient_bound(lo, hi)
    }

    /// An upper bound of the second derivatives of `w` over the closed box
    /// (off the soup): [`RimTree::hessian_bound`] of the soup's rim.
    pub fn hessian_bound(&self, lo: DVec3, hi: DVec3) -> f64 {
        self.rim().hessian_bound(lo, hi)
    }

    fn rim(&self) -> &RimTree {
        self.rim.get_or_init(|| RimTree::new(&self.fixed))
    }

    /// Whether some triangle may meet the closed box `[lo, hi]` (separating
    /// axes in `f64` on a box grown by a hair: never a false "no").
    pub fn meets_box(&self, lo: DVec3, hi: DVec3) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack = [0u32; 96];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = &self.nodes[stack[top] as usize];
            if !boxes_meet(n.lo, n.hi, lo, hi) {
                continue;
            }
            if n.left != 0 {
                stack[top] = n.left;
                stack[top + 1] = n.right;
                top += 2;
                continue;
            }
            for t in &self.tris[n.start as usize..n.end as usize] {
                if triangle_meets_box(t, lo, hi) {
                    return true;
                }
            }
        }
        false
    }

    /// The winding number at a point: `None` only when the point lies on a
    /// triangle (closed, exact fixed-point test), where it is undefined. A
    /// node is taken as one dipole when its distance exceeds `beta` times
    /// its radius (Barnes–Hut's opening criterion; larger is more precise and
    /// slower, `f64::INFINITY` sums every triangle exactly with libm's
    /// arctangent); the error bound is rigorous for any `beta`.
    pub fn point(&self, q: DVec3, beta: f64) -> Option<Estimate> {
        let qf = q.to_array().map(|c| (c * VOXEL_ONE as f64).round() as i64);
        let exact = (q * VOXEL_ONE as f64).to_array() == qf.map(|c| c as f64);
        self.walk(q, beta, exact.then_some(qf))
    }

    /// The winding number at a point by summing every triangle (no
    /// approximation; `None` on a triangle as for [`WindingTree::point`]).
    pub fn point_exact(&self, q: DVec3) -> Option<Estimate> {
        self.point(q, f64::INFINITY)
    }

    fn walk(&self, q: DVec3, beta: f64, fixed_point: Option<[i64; 3]>) -> Option<Estimate> {
        let mut est = Estimate::default();
        if self.nodes.is_empty() {
            return Some(est);
        }
        let mut stack = [0u32; 96];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = &self.nodes[stack[top] as usize];
            // Open unless d − r > β r, tested on squares (no root for the
            // nodes that are opened, most of them near the point).
            let to = n.centre - q;
            let d2 = to.length_squared();
            let reach = (beta + 1.0) * n.radius;
            if d2 > reach * reach {
                let d = d2.sqrt();
                let gap = d - n.radius;
                est.value += n.normal.dot(to) / (FOUR_PI * d2 * d);
                est.error += n.abs_area * 2.0 * n.radius / (FOUR_PI * gap * gap * gap);
                continue;
            }
            if n.left != 0 {
                stack[top] = n.left;
                stack[top + 1] = n.right;
                top += 2;
                continue;
            }
            for i in n.start as usize..n.end as usize {
                let t = &self.tris[i];
                if let Some(p) = fixed_point
                    && on_triangle(&self.fixed[i], p)
                {
                    return None;
                }
                // Exact sums (beta ∞) use libm; the others the fast
                // arctangent, its error added to the bound.
                if beta.is_finite() {
                    est.value += solid_angle_fast(t[0] - q, t[1] - q, t[2] - q) / FOUR_PI;
                    est.error += 2.0 * FAST_ATAN2_ERROR / FOUR_PI;
                } else {
                    est.value += solid_angle(t[0] - q, t[1] - q, t[2] - q) / FOUR_PI;
                }
                est.error += ROUNDING_SLACK / self.tris.len() as f64;
            }
        }
        Some(est)
    }
}

/// The rim of a triangle soup (its boundary chain, [`boundary_edges`]) as a
/// tree of segments, for bounds of the winding number's gradient: off the
/// soup, `∇w` is the Biot–Savart field of the rim alone (interior edges
/// cancel), so `|∇w(q)| ≤ Σ_e |e| / (4π dist(q, e)²)`.
#[derive(Clone, Debug, Default)]
pub struct RimTree {
    nodes: Vec<RimNode>,
    segments: Vec<[DVec3; 2]>,
}

#[derive(Clone, Copy, Debug)]
struct RimNode {
    lo: DVec3,
    hi: DVec3,
    length: f64,
    start: u32,
    end: u32,
    left: u32,
    right: u32,
}

impl RimTree {
    /// The rim of `triangles` (fixed point, [`VOXEL_ONE`] per voxel).
    pub fn new(triangles: &[SurfaceTriangle]) -> Self {
        let one = VOXEL_ONE as f64;
        let to = |p: [i64; 3]| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / one;
        let mut segments: Vec<[DVec3; 2]> = boundary_edges(triangles.iter().copied())
            .into_iter()
            .map(|(a, b)| [to(a), to(b)])
            .collect();
        let mut nodes = Vec::new();
        if !segments.is_empty() {
            build_rim(&mut nodes, &mut segments, 0);
        }
        RimTree { nodes, segments }
    }

    /// An upper bound of `|∇w|` over the closed box `[lo, hi]`; infinite when
    /// a rim segment's bounding box meets the box.
    pub fn gradient_bound(&self, lo: DVec3, hi: DVec3) -> f64 {
        self.sum_over_distance(lo, hi, 2) / FOUR_PI
    }

    /// An upper bound of every second derivative `|∂²w/∂xᵢ∂xⱼ|` over the
    /// closed box: the Biot–Savart kernel's Jacobian has norm `2/r³`, so
    /// `Σ_e 2|e| / (4π dist³)`. Infinite when a rim segment meets the box.
    pub fn hessian_bound(&self, lo: DVec3, hi: DVec3) -> f64 {
        2.0 * self.sum_over_distance(lo, hi, 3) / FOUR_PI
    }

    /// `Σ_e |e| / dist(box, e)^power` with lower bounds of the distances.
    fn sum_over_distance(&self, lo: DVec3, hi: DVec3, power: i32) -> f64 {
        if self.nodes.is_empty() {
            return 0.0;
        }
        let mut sum = 0.0;
        let mut stack = [0u32; 96];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = &self.nodes[stack[top] as usize];
            let g = box_distance(n.lo, n.hi, lo, hi);
            // A far node: its whole length at its box's distance.
            if g > 0.0 && g * g >= (n.hi - n.lo).length_squared() {
                sum += n.length / g.powi(power);
                continue;
            }
            if n.left != 0 {
                stack[top] = n.left;
                stack[top + 1] = n.right;
                top += 2;
                continue;
            }
            for s in &self.segments[n.start as usize..n.end as usize] {
                let g = box_distance(s[0].min(s[1]), s[0].max(s[1]), lo, hi);
                if g <= 0.0 {
                    return f64::INFINITY;
                }
                sum += (s[1] - s[0]).length() / g.powi(power);
            }
        }
        sum
    }
}

fn build_rim(nodes: &mut Vec<RimNode>, segs: &mut [[DVec3; 2]], start: usize) -> u32 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut length = 0.0;
    for s in segs.iter() {
        lo = lo.min(s[0]).min(s[1]);
        hi = hi.max(s[0]).max(s[1]);
        length += (s[1] - s[0]).length();
    }
    let me = nodes.len();
    nodes.push(RimNode {
        lo,
        hi,
        length,
        start: start as u32,
        end: (start + segs.len()) as u32,
        left: 0,
        right: 0,
    });
    if segs.len() > LEAF {
        let axis = longest_axis(hi - lo);
        let mid = segs.len() / 2;
        segs.select_nth_unstable_by(mid, |a, b| {
            (a[0] + a[1])[axis].total_cmp(&(b[0] + b[1])[axis])
        });
        let (left, right) = segs.split_at_mut(mid);
        let l = build_rim(nodes, left, start);
        let r = build_rim(nodes, right, start + mid);
        nodes[me].left = l;
        nodes[me].right = r;
    }
    me as u32
}

fn build(
    nodes: &mut Vec<Node>,
    order: &mut [u32],
    start: usize,
    tris: &[[DVec3; 3]],
    centroids: &[DVec3],
) -> u32 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let (mut normal, mut abs_area, mut weighted) = (DVec3::ZERO, 0.0, DVec3::ZERO);
    for &i in order.iter() {
        let t = &tris[i as usize];
        for p in t {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let n = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]);
        let a = n.length();
        normal += n;
        abs_area += a;
        weighted += a * centroids[i as usize];
    }
    let centre = if abs_area > 0.0 {
        weighted / abs_area
    } else {
        (lo + hi) * 0.5
    };
    let mut radius: f64 = 0.0;
    for &i in order.iter() {
        for p in &tris[i as usize] {
            radius = radius.max((*p - centre).length());
        }
    }
    let me = nodes.len();
    nodes.push(Node {
        lo,
        hi,
        centre,
        radius: radius * (1.0 + 1e-12),
        normal,
        abs_area,
        start: start as u32,
        end: (start + order.len()) as u32,
        left: 0,
        right: 0,
    });
    if order.len() > LEAF {
        let axis = longest_axis(hi - lo);
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
        });
        let (left, right) = order.split_at_mut(mid);
        let l = build(nodes, left, start, tris, centroids);
        let r = build(nodes, right, start + mid, tris, centroids);
        nodes[me].left = l;
        nodes[me].right = r;
    }
    me as u32
}

/// Triangle–box overlap by the 13 separating axes (Akenine-Möller), on the
/// box grown by `1e-7` so that rounding can only answer "meets".
fn triangle_meets_box(t: &[DVec3; 3], lo: DVec3, hi: DVec3) -> bool {
    let pad = DVec3::splat(1e-7);
    let c = (lo + hi) * 0.5;
    let h = (hi - lo) * 0.5 + pad;
    let v = t.map(|p| p - c);
    // Box axes.
    for a in 0..3 {
        let (mn, mx) = (
            v[0][a].min(v[1][a]).min(v[2][a]),
            v[0][a].max(v[1][a]).max(v[2][a]),
        );
        if mn > h[a] || mx < -h[a] {
            return false;
        }
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    // Triangle normal.
    let n = e[0].cross(e[1]);
    let r = h.dot(n.abs());
    let s = n.dot(v[0]);
    if s > r || s < -r {
        return false;
    }
    // Edge × box-axis cross products.
    for edge in e {
        for a in 0..3 {
            let mut axis = DVec3::ZERO;
            axis[a] = 1.0;
            let l = axis.cross(edge);
            if l == DVec3::ZERO {
                continue;
            }
            let p = v.map(|q| q.dot(l));
            let r = h.dot(l.abs());
            let (mn, mx) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
            if mn > r || mx < -r {
                return false;
            }
        }
    }
    true
}

/// The axis of the largest extent (the split axis of both trees).
fn longest_axis(ext: DVec3) -> usize {
    if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    }
}

#[inline]
fn boxes_meet(alo: DVec3, ahi: DVec3, blo: DVec3, bhi: DVec3) -> bool {
    alo.cmple(bhi).all() && blo.cmple(ahi).all()
}

#[inline]
fn box_distance(alo: DVec3, ahi: DVec3, blo: DVec3, bhi: DVec3) -> f64 {
    let gap = (blo - ahi).max(alo - bhi).max(DVec3::ZERO);
    gap.length()
}

/// Whether the fixed-point point `p` lies on the closed triangle `t` (exact).
fn on_triangle(t: &SurfaceTriangle, p: [i64; 3]) -> bool {
    let d = |a: [i64; 3], b: [i64; 3]| [0, 1, 2].map(|k| (b[k] - a[k]) as i128);
    let cross = |u: [i128; 3], v: [i128; 3]| {
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    let dot = |u: [i128; 3], v: [i128; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let n = cross(d(t[0], t[1]), d(t[0], t[2]));
    if dot(n, d(t[0], p)) != 0 {
        return false;
    }
    // Coplanar: inside iff p is on the inner side of (or on) every edge.
    (0..3).all(|i| {
        let (a, b) = (t[i], t[(i + 1) % 3]);
        dot(cross(d(a, b), d(a, p)), n) >= 0
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn sphere_soup(n: usize, seed: u64) -> Vec<SurfaceTriangle> {
        // Random small triangles on a sphere of radius 20 voxels, plus noise.
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let c = DVec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
                .normalize()
                    * 20.0;
                std::array::from_fn(|_| {
                    let p = c + DVec3::new(
                        rng.random_range(-2.0..2.0),
                        rng.random_range(-2.0..2.0),
                        rng.random_range(-2.0..2.0),
                    );
                    p.to_array().map(|x| (x * VOXEL_ONE as f64).round() as i64)
                })
            })
            .collect()
    }

    fn brute(tris: &[SurfaceTriangle], q: DVec3) -> f64 {
        let one = VOXEL_ONE as f64;
        tris.iter()
            .map(|t| {
                let p = t.map(|v| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64) / one - q);
                solid_angle(p[0], p[1], p[2])
            })
            .sum::<f64>()
            / FOUR_PI
    }

    #[test]
    fn point_estimates_hold_their_error_bounds() {
        let tris = sphere_soup(3000, 7);
        let tree = WindingTree::new(&tris);
        let mut rng = rand::rngs::StdRng::seed_from_u64(1);
        for _ in 0..300 {
            let q = DVec3::new(
                rng.random_range(-40.0..40.0),
                rng.random_range(-40.0..40.0),
                rng.random_range(-40.0..40.0),
            );
            let truth = brute(&tris, q);
            for tol in [f64::INFINITY, 8.0, 2.0] {
                let e = tree.point(q, tol).expect("off the soup");
                assert!(
                    (e.value - truth).abs() <= e.error + 1e-9,
                    "{q} tol {tol}: {} vs {truth} ± {}",
                    e.value,
                    e.error
                );
            }
        }
    }

    #[test]
    fn box_bounds_cover_every_point_inside() {
        let tris = sphere_soup(2000, 3);
        let tree = WindingTree::new(&tris);
        let mut rng = rand::rngs::StdRng::seed_from_u64(2);
        let mut checked = 0;
        for _ in 0..200 {
            let lo = DVec3::new(
                rng.random_range(-60.0..50.0),
                rng.random_range(-60.0..50.0),
                rng.random_range(-60.0..50.0),
            );
            let hi = lo + DVec3::splat(rng.random_range(0.5..8.0));
            let Some(e) = tree.bound(lo, hi, 2.0) else {
                continue;
            };
            checked += 1;
            for _ in 0..5 {
                let t = DVec3::new(rng.random(), rng.random(), rng.random());
                let q = lo + (hi - lo) * t;
                let truth = brute(&tris, q);
                assert!((e.value - truth).abs() <= e.error + 1e-9);
            }
        }
        assert!(checked > 50, "only {checked} boxes bounded");
    }

    #[test]
    fn fast_atan2_error_is_bounded() {
        let mut worst: f64 = 0.0;
        let n = 200_000;
        for i in 0..=n {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            for r in [1e-300, 1e-3, 1.0, 7.5e8] {
                let (y, x) = (r * t.sin(), r * t.cos());
                worst = worst.max((fast_atan2(y, x) - y.atan2(x)).abs());
            }
        }
        for (y, x) in [(0.0, 1.0), (0.0, -1.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 0.0)] {
            let want: f64 = if x == 0.0 && y == 0.0 {
                0.0
            } else {
                f64::atan2(y, x)
            };
            worst = worst.max((fast_atan2(y, x) - want).abs());
        }
        assert!(worst * 2.0 <= FAST_ATAN2_ERROR, "worst {worst}");
    }

    #[test]
    fn points_on_a_triangle_are_refused() {
        let t: SurfaceTriangle = [[0, 0, 0], [1024, 0, 0], [0, 1024, 0]];
        let tree = WindingTree::new(&[t]);
        assert!(tree.point(DVec3::new(1.0, 1.0, 0.0), 0.0).is_none());
        assert!(tree.point(DVec3::new(4.0, 0.0, 0.0), 0.0).is_none()); // a vertex
        assert!(tree.point(DVec3::new(1.0, 1.0, 1.0), 0.0).is_some());
        assert!(tree.point(DVec3::new(3.0, 3.0, 0.0), 0.0).is_some()); // coplanar, outside
    }
}
