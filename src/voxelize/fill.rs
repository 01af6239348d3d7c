//! The interior fill: signed crossings along x-lattice lines, one layer of
//! 8³ bricks at a time, written as whole-brick tiles and partial masks.
//!
//! For the x-line through `(y, z) = (j, k)` every triangle whose projection
//! onto the `(y, z)` plane contains the point `(j, k) + (ε, ε²)` (ε → 0⁺;
//! symbolic perturbation, decided by exact integer edge functions: a line
//! through a shared edge or vertex meets exactly one of the triangles around
//! it) is crossed at the exact rational depth `x*`. The crossing counts for
//! the centres `i ≥ x*` (a centre exactly on the surface takes the side
//! beyond), with weight `−sign(n_x)`. So the running sum along the line is
//! the winding number of a closed chain exactly: `1` inside a closed
//! outward-oriented mesh, `0` outside, `2` inside two overlapping copies.
//! With [`LineValue::Parity`] the running value is the crossing count mod 2.
//!
//! Per layer the crossings of all triangles meeting it are sorted by
//! `(y, z, x)`; each run of a line with value ≥ 1 sets one byte per brick it
//! covers (a brick row is one byte of its mask); bricks that come out full
//! are tiles. Bricks whose threshold is not the default (near the holes of a
//! mesh, see [`crate::voxelize::solid`]) are recomputed voxel by voxel from
//! the same runs. Memory: the crossings of one layer per thread, plus the
//! output.

use glam::IVec3;
use rayon::prelude::*;

use crate::grid::brick::BrickMask;
use crate::grid::{BrickGrid, Voxel};
use crate::voxelize::surface::{SurfaceTriangle, VOXEL_ONE};

/// What a line's running value is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineValue {
    /// Signed crossing count (the winding number of a closed chain).
    Winding,
    /// Crossing count mod 2 (orientation ignored).
    Parity,
}

/// How a brick decides inside from the line value `m` at a voxel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BrickRule {
    /// Inside iff `m + offset ≥ ½` for every voxel of the brick (`±∞`: all
    /// inside or all outside).
    Uniform(f64),
    /// Decided voxel by voxel by a [`BrickRefiner`] that sees the line values.
    Refine,
}

/// Decides a brick from its voxels' line values (`m[lx + 8 ly + 64 lz]`,
/// `None` outside the grid): returns the inside mask and the number of
/// ambiguous voxels found.
pub trait BrickRefiner: Sync {
    /// The brick `key`'s mask.
    fn refine(&self, key: Voxel, m: &[Option<i32>; 512]) -> (BrickMask, u64);
}

/// A refiner for fills without [`BrickRule::Refine`] bricks.
pub struct NoRefiner;

impl BrickRefiner for NoRefiner {
    fn refine(&self, _: Voxel, _: &[Option<i32>; 512]) -> (BrickMask, u64) {
        ([0; 8], 0)
    }
}

/// Interior voxels and counts of one fill.
#[derive(Debug, Default)]
pub struct FillOutput {
    /// Partial bricks (brick coordinates, masks).
    pub keys: Vec<Voxel>,
    /// Their masks.
    pub masks: Vec<BrickMask>,
    /// Whole bricks.
    pub tiles: Vec<Voxel>,
    /// Crossings found.
    pub crossings: u64,
    /// Voxels (in per-voxel bricks, not on `surface`) with `|w − ½| < band`.
    pub ambiguous: u64,
}

/// A closed chain of triangles as the fill reads it: a soup's triangles,
/// then the caps that close it, each read reversed (`[a, c, b]`). Kept as
/// the two slices it comes from: on a mesh of a million triangles a copy
/// of both was ~100 MB of fresh pages.
#[derive(Clone, Copy, Debug, Default)]
pub struct Chain<'a> {
    /// Triangles taken as they are.
    pub triangles: &'a [SurfaceTriangle],
    /// Triangles taken reversed.
    pub reversed: &'a [SurfaceTriangle],
}

impl Chain<'_> {
    /// Triangles in the chain.
    pub fn len(&self) -> usize {
        self.triangles.len() + self.reversed.len()
    }

    /// Whether the chain has no triangle.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Triangle `i` (of [`Chain::len`]), oriented.
    #[inline]
    pub fn get(&self, i: usize) -> SurfaceTriangle {
        match self.triangles.get(i) {
            Some(t) => *t,
            None => {
                let t = self.reversed[i - self.triangles.len()];
                [t[0], t[2], t[1]]
            }
        }
    }
}

impl<'a> From<&'a [SurfaceTriangle]> for Chain<'a> {
    fn from(triangles: &'a [SurfaceTriangle]) -> Self {
        Chain {
            triangles,
            reversed: &[],
        }
    }
}

/// Fills the interior of the closed chain `chain` inside `[0, dims)`.
/// `rules` (sorted by brick key `(bz, by, bx)`, bricks in the grid) override
/// the default rule `m ≥ 1` (Winding) or `m odd` (Parity); `refiner` decides
/// the [`BrickRule::Refine`] bricks. `Uniform` bricks count voxels off
/// `surface` with `|m + offset − ½| < band` as ambiguous.
#[allow(clippy::too_many_arguments)]
pub fn fill_interior(
    chain: Chain<'_>,
    dims: [usize; 3],
    value: LineValue,
    rules: &[(Voxel, BrickRule)],
    refiner: &dyn BrickRefiner,
    surface: &BrickGrid,
    band: f64,
) -> FillOutput {
    let layers = dims[2].div_ceil(8);
    // Triangles by the brick layers their z-range meets.
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); layers];
    for i in 0..chain.len() {
        let t = chain.get(i);
        let zmin = t.iter().map(|p| p[2]).min().unwrap_or(0);
        let zmax = t.iter().map(|p| p[2]).max().unwrap_or(0);
        let k0 = ceil_div(zmin, VOXEL_ONE).max(0);
        let k1 = zmax.div_euclid(VOXEL_ONE).min(dims[2] as i64 - 1);
        if k0 > k1 {
            continue;
        }
        for b in (k0 / 8)..=(k1 / 8) {
            buckets[b as usize].push(i as u32);
        }
    }
    let parts: Vec<FillOutput> = (0..layers)
        .into_par_iter()
        .map_init(Vec::new, |scratch, bz| {
            let lo = rules.partition_point(|(k, _)| k.z < bz as i32);
            let hi = rules.partition_point(|(k, _)| k.z <= bz as i32);
            fill_layer(
                chain,
                &buckets[bz],
                bz,
                dims,
                value,
                &rules[lo..hi],
                refiner,
                surface,
                band,
                scratch,
            )
        })
        .collect();
    // Sized once: growing by doubling copied (and faulted in) the masks
    // several times over on one thread.
    let mut out = FillOutput {
        keys: Vec::with_capacity(parts.iter().map(|p| p.keys.len()).sum()),
        masks: Vec::with_capacity(parts.iter().map(|p| p.masks.len()).sum()),
        tiles: Vec::with_capacity(parts.iter().map(|p| p.tiles.len()).sum()),
        ..FillOutput::default()
    };
    for p in parts {
        out.keys.extend(p.keys);
        out.masks.extend(p.masks);
        out.tiles.extend(p.tiles);
        out.crossings += p.crossings;
        out.ambiguous += p.ambiguous;
    }
    out
}

#[inline]
fn ceil_div(a: i64, b: i64) -> i64 {
    -((-a).div_euclid(b))
}

/// A crossing: key `line << 32 | f` (line = `8 y + (z mod 8)`, `f` the first
/// centre at or beyond it), weight.
type Crossing = (u64, i32);

#[allow(clippy::too_many_arguments)]
fn fill_layer(
    chain: Chain<'_>,
    members: &[u32],
    bz: usize,
    dims: [usize; 3],
    value: LineValue,
    rules: &[(Voxel, BrickRule)],
    refiner: &dyn BrickRefiner,
    surface: &BrickGrid,
    band: f64,
    crossings: &mut Vec<Crossing>,
) -> FillOutput {
    crossings.clear();
    let z0 = bz as i64 * 8;
    let z1 = (z0 + 8).min(dims[2] as i64);
    for &t in members {
        layer_crossings(&chain.get(t as usize), z0, z1, dims, value, crossings);
    }
    crossings.sort_unstable_by_key(|c| c.0);
    let mut out = FillOutput {
        crossings: crossings.len() as u64,
        ..FillOutput::default()
    };
    let nbx = dims[0].div_ceil(8);
    let nby = dims[1].div_ceil(8);
    let mut masks = vec![[0u64; 8]; nbx];
    let mut at = 0usize; // next crossing
    let mut rule_at = 0usize;
    for by in 0..nby {
        let first_line = (by * 64) as u64;
        // Skip bundles with neither crossings nor rules.
        let c_start = at;
        while at < crossings.len() && (crossings[at].0 >> 32) < first_line + 64 {
            at += 1;
        }
        let r_start = rule_at;
        while rule_at < rules.len() && rules[rule_at].0.y as usize == by {
            rule_at += 1;
        }
        let bundle = &crossings[c_start..at];
        let bundle_rules = &rules[r_start..rule_at];
        if bundle.is_empty() && bundle_rules.is_empty() {
            continue;
        }
        // Crossing ranges of the bundle's 64 lines.
        let mut ranges = [(0usize, 0usize); 64];
        let mut i = 0;
        while i < bundle.len() {
            let line = ((bundle[i].0 >> 32) - first_line) as usize;
            let s = i;
            while i < bundle.len() && ((bundle[i].0 >> 32) - first_line) as usize == line {
                i += 1;
            }
            ranges[line] = (s, i);
        }
        let (mut touched_lo, mut touched_hi) = (nbx, 0usize);
        for (line, &(s, e)) in ranges.iter().enumerate() {
            if s == e {
                continue;
            }
            let (ly, lz) = (line / 8, line % 8);
            for_runs(&bundle[s..e], value, dims[0], |x0, x1, m| {
                if inside_default(value, m) {
                    set_run(&mut masks, ly, lz, x0, x1);
                    touched_lo = touched_lo.min(x0 / 8);
                    touched_hi = touched_hi.max(x1.div_ceil(8));
                }
            });
        }
        let decide = |(key, rule): &(Voxel, BrickRule)| {
            let m = line_values(bundle, &ranges, *key, dims, value);
            match rule {
                BrickRule::Refine => refiner.refine(*key, &m),
                BrickRule::Uniform(offset) => {
                    let mut ambiguous = 0;
                    let mask = uniform_mask(*key, &m, *offset, surface, band, &mut ambiguous);
                    (mask, ambiguous)
                }
            }
        };
        // Refined bricks cost up to milliseconds each and crowd into the
        // few layers near the holes: a row with any is decided in parallel
        // (otherwise the layers alone were the units, and one thread was
        // left finishing the heaviest). Each brick's result is its own.
        let decided: Vec<(BrickMask, u64)> =
            if bundle_rules.iter().any(|(_, r)| *r == BrickRule::Refine) {
                bundle_rules.par_iter().map(decide).collect()
            } else {
                bundle_rules.iter().map(decide).collect()
            };
        for ((key, _), (mask, ambiguous)) in bundle_rules.iter().zip(decided) {
            let bx = key.x as usize;
            masks[bx] = mask;
            out.ambiguous += ambiguous;
            touched_lo = touched_lo.min(bx);
            touched_hi = touched_hi.max(bx + 1);
        }
        for (bx, m) in masks
            .iter_mut()
            .enumerate()
            .take(touched_hi)
            .skip(touched_lo)
        {
            let key = IVec3::new(bx as i32, by as i32, bz as i32);
            if m.iter().all(|&w| w == u64::MAX) {
                out.tiles.push(key);
            } else if m.iter().any(|&w| w != 0) {
                out.keys.push(key);
                out.masks.push(*m);
            }
            *m = [0; 8];
        }
    }
    out
}

#[inline]
fn inside_default(value: LineValue, m: i32) -> bool {
    match value {
        LineValue::Winding => m >= 1,
        LineValue::Parity => m & 1 == 1,
    }
}

/// Calls `f(x0, x1, m)` for each maximal run `[x0, x1)` (clipped to
/// `[0, nx)`, non-empty) of constant line value `m`, given the line's sorted
/// crossings.
#[inline]
fn for_runs(line: &[Crossing], value: LineValue, nx: usize, mut f: impl FnMut(usize, usize, i32)) {
    let mut m = 0i32;
    let mut x = 0usize;
    let mut i = 0;
    while i < line.len() {
        let fx = (line[i].0 & 0xffff_ffff) as usize;
        if fx > x {
            f(x, fx.min(nx), m);
            x = fx;
        }
        while i < line.len() && (line[i].0 & 0xffff_ffff) as usize == fx {
            m = match value {
                LineValue::Winding => m + line[i].1,
                LineValue::Parity => m ^ 1,
            };
            i += 1;
        }
    }
    if x < nx {
        f(x, nx, m);
    }
}

/// Sets bits `[x0, x1)` of row `(ly, lz)` across the bundle's bricks.
#[inline]
fn set_run(masks: &mut [BrickMask], ly: usize, lz: usize, x0: usize, x1: usize) {
    if x0 >= x1 {
        return;
    }
    let shift = 8 * ly;
    let (b0, b1) = (x0 / 8, (x1 - 1) / 8);
    let lo_bits = 0xffu64 << (x0 % 8) & 0xff;
    let hi_bits = 0xffu64 >> (7 - (x1 - 1) % 8);
    if b0 == b1 {
        masks[b0][lz] |= (lo_bits & hi_bits) << shift;
        return;
    }
    masks[b0][lz] |= lo_bits << shift;
    for m in &mut masks[b0 + 1..b1] {
        m[lz] |= 0xff << shift;
    }
    masks[b1][lz] |= hi_bits << shift;
}

/// The line values of a brick's voxels (`None` outside the grid).
fn line_values(
    bundle: &[Crossing],
    ranges: &[(usize, usize); 64],
    key: Voxel,
    dims: [usize; 3],
    value: LineValue,
) -> [Option<i32>; 512] {
    let mut out = [None; 512];
    let x_lo = key.x as usize * 8;
    let x_hi = (x_lo + 8).min(dims[0]);
    for (line, &(s, e)) in ranges.iter().enumerate() {
        let (ly, lz) = (line / 8, line % 8);
        let (y, z) = (key.y as usize * 8 + ly, key.z as usize * 8 + lz);
        if y >= dims[1] || z >= dims[2] {
            continue;
        }
        for_runs(&bundle[s..e], value, dims[0], |x0, x1, m| {
            for x in x0.max(x_lo)..x1.min(x_hi) {
                out[x - x_lo + 8 * ly + 64 * lz] = Some(m);
            }
        });
    }
    out
}

/// The mask of a brick with a uniform offset.
fn uniform_mask(
    key: Voxel,
    m: &[Option<i32>; 512],
    offset: f64,
    surface: &BrickGrid,
    band: f64,
    ambiguous: &mut u64,
) -> BrickMask {
    let mut mask = [0u64; 8];
    for (i, m) in m.iter().enumerate() {
        let Some(m) = *m else { continue };
        let w = m as f64 + offset;
        if w >= 0.5 {
            mask[i / 64] |= 1 << (i % 64);
        }
        if (w - 0.5).abs() < band {
            let v = key * 8 + IVec3::new((i % 8) as i32, (i / 8 % 8) as i32, (i / 64) as i32);
            if !surface.contains(v) {
                *ambiguous += 1;
            }
        }
    }
    mask
}

/// Crossings of triangle `t` with the x-lines of rows `z ∈ [z0, z1)`.
fn layer_crossings(
    t: &SurfaceTriangle,
    z0: i64,
    z1: i64,
    dims: [usize; 3],
    value: LineValue,
    out: &mut Vec<Crossing>,
) {
    const ONE: i64 = VOXEL_ONE;
    let p = t.map(|v| [v[1], v[2]]);
    let d = t.map(|v| v[0]);
    let cross = |a: [i64; 2], b: [i64; 2], q: [i64; 2]| {
        (b[0] - a[0]) as i128 * (q[1] - a[1]) as i128
            - (b[1] - a[1]) as i128 * (q[0] - a[0]) as i128
    };
    let area = cross(p[0], p[1], p[2]);
    if area == 0 {
        return;
    }
    let s: i64 = if area > 0 { 1 } else { -1 };
    let weight = match value {
        LineValue::Winding => -s as i32,
        LineValue::Parity => 1,
    };
    let umin = p.iter().map(|q| q[0]).min().unwrap_or(0);
    let umax = p.iter().map(|q| q[0]).max().unwrap_or(0);
    let wmin = p.iter().map(|q| q[1]).min().unwrap_or(0);
    let wmax = p.iter().map(|q| q[1]).max().unwrap_or(0);
    let j_lo = ceil_div(umin, ONE).max(0);
    let j_hi = umax.div_euclid(ONE).min(dims[1] as i64 - 1);
    let k_lo = ceil_div(wmin, ONE).max(z0);
    let k_hi = wmax.div_euclid(ONE).min(z1 - 1);
    if j_lo > j_hi || k_lo > k_hi {
        return;
    }
    // Edge i: e(q) = s·((b−a) × (q−a)) > 0, or = 0 with a positive tie sign
    // (the ε-perturbed point's side): e + bias > 0 with bias ∈ {0, 1}.
    let mut edges = [(0i64, 0i64, [0i64; 2], 0i64); 3];
    for (i, edge) in edges.iter_mut().enumerate() {
        let (a, b) = (p[i], p[(i + 1) % 3]);
        let (du, dw) = (b[0] - a[0], b[1] - a[1]);
        let tie = if dw != 0 { -dw.signum() } else { du.signum() };
        *edge = (du, dw, a, i64::from(s * tie > 0));
    }
    // Depth numerator N(j, k) = x*·area = d0·area + l1 (d1−d0) + l2 (d2−d0),
    // l1 = cross(p2, p0, q), l2 = cross(p0, p1, q): linear in j.
    let (dd1, dd2) = ((d[1] - d[0]) as i128, (d[2] - d[0]) as i128);
    let (sa, den) = if area > 0 {
        (1i128, area * ONE as i128)
    } else {
        (-1i128, -area * ONE as i128)
    };
    let den_f = den as f64;
    // ∂N/∂j: cross(a, b, q) changes by −(b_w − a_w)·ONE per column.
    let dn = sa
        * ONE as i128
        * (-((p[0][1] - p[2][1]) as i128) * dd1 - ((p[1][1] - p[0][1]) as i128) * dd2);
    for k in k_lo..=k_hi {
        let qw = k * ONE;
        // j-interval where all three edge conditions hold. Everything fits
        // i64: coordinates are below 2^30 fixed units (2^22 voxels).
        let (mut lo, mut hi) = (j_lo, j_hi);
        for &(du, dw, a, bias) in &edges {
            // e(j) = s·(du·(qw − aw) − dw·(j·ONE − au)) = A·j + B
            let a_coef = -s * dw * ONE;
            let c = s * (du * (qw - a[1]) + dw * a[0]) + bias;
            if a_coef > 0 {
                lo = lo.max((-c).div_euclid(a_coef) + 1);
            } else if a_coef < 0 {
                hi = hi.min(-((-c).div_euclid(-a_coef)) - 1);
            } else if c <= 0 {
                hi = lo - 1;
            }
        }
        if lo > hi {
            continue;
        }
        let line_base = ((k - z0) as u64) & 7;
        let q = [lo * ONE, qw];
        let mut n =
            sa * (d[0] as i128 * area + cross(p[2], p[0], q) * dd1 + cross(p[0], p[1], q) * dd2);
        for j in lo..=hi {
            // First centre i with i·den ≥ N: ceil(N / den), estimated in f64
            // and corrected exactly.
            let mut f = (n as f64 / den_f).ceil() as i64;
            while (f as i128) * den < n {
                f += 1;
            }
            while ((f - 1) as i128) * den >= n {
                f -= 1;
            }
            n += dn;
            if f >= dims[0] as i64 {
                continue;
            }
            let line = (j as u64) * 8 + line_base;
            out.push((line << 32 | f.max(0) as u64, weight));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A [`Chain`] of a closed soup's triangles, some stored reversed,
    /// fills exactly as the copy that lists them all oriented.
    #[test]
    fn chain_reads_like_its_copy() {
        use crate::voxelize::shapes::IndexedMesh;
        use glam::DVec3;
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let dims = [40usize, 36, 33];
        let reverse = |t: &SurfaceTriangle| [t[0], t[2], t[1]];
        for _ in 0..6 {
            let c = DVec3::new(
                rng.random_range(13.0..27.0),
                rng.random_range(13.0..23.0),
                rng.random_range(13.0..20.0),
            );
            let mesh = IndexedMesh::uv_sphere(c, rng.random_range(4.0..11.0), 9, 13);
            let fixed = |v: DVec3| v.to_array().map(|x| (x * VOXEL_ONE as f64).round() as i64);
            let (mut own, mut rev) = (Vec::new(), Vec::new());
            for f in &mesh.faces {
                let t: SurfaceTriangle = f.map(|i| fixed(mesh.vertices[i as usize]));
                if rng.random_bool(0.4) {
                    rev.push(reverse(&t));
                } else {
                    own.push(t);
                }
            }
            let copy: Vec<SurfaceTriangle> =
                own.iter().copied().chain(rev.iter().map(reverse)).collect();
            let surface = BrickGrid::new();
            let fill = |chain: Chain<'_>| {
                let o = fill_interior(
                    chain,
                    dims,
                    LineValue::Winding,
                    &[],
                    &NoRefiner,
                    &surface,
                    0.0,
                );
                (o.keys, o.masks, o.tiles, o.crossings)
            };
            let chained = fill(Chain {
                triangles: &own,
                reversed: &rev,
            });
            let copied = fill((&copy[..]).into());
            assert!(
                copied.3 > 0 && !copied.1.is_empty(),
                "the sphere fills something"
            );
            assert_eq!(chained, copied);
        }
    }

    #[test]
    fn runs_set_the_right_bits() {
        let mut masks = vec![[0u64; 8]; 3];
        set_run(&mut masks, 2, 5, 3, 19);
        let bits: Vec<usize> = (0..24)
            .filter(|&x| masks[x / 8][5] >> (16 + x % 8) & 1 == 1)
            .collect();
        assert_eq!(bits, (3..19).collect::<Vec<_>>());
        assert!(
            masks
                .iter()
                .all(|m| m.iter().enumerate().all(|(z, w)| z == 5 || *w == 0))
        );
    }
}
