//! The report's triangle section: Kahan–Kelsen indexed enumeration
//! ([`TriangleIndex::for_each_point`]) against row-by-row scanline
//! enumeration ([`ScanlineLattice`]) of a triangle's lattice points, on fat
//! triangles (time ∝ points for both) and skinny 45° ones (a handful of
//! points over a long diagonal: scanline pays per row, the index per point).
//! The same shapes as `benches/triangle.rs`.

use std::hint::black_box;

use rand::{Rng, SeedableRng};

use super::document::PlotDir;
use super::plot::{Chart, Series};
use super::timing::{Timing, time_batched};
use crate::error::Result;
use crate::triangle::{LatticePoint, ScanlineLattice, TriangleIndex};

/// Triangle shapes measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Roughly equilateral-ish, seeded jitter.
    Fat,
    /// 45° sliver with about a dozen points.
    Skinny,
}

impl Shape {
    /// Name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Shape::Fat => "fat",
            Shape::Skinny => "skinny 45°",
        }
    }
}

/// One triangle's timings.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleRow {
    /// Shape.
    pub shape: Shape,
    /// Longest extent of the bounding box (lattice units).
    pub extent: i64,
    /// Lattice points in the closed triangle.
    pub points: u64,
    /// Indexed enumeration, seconds per triangle.
    pub indexed: Timing,
    /// Scanline enumeration, seconds per triangle.
    pub scanline: Timing,
    /// Whether both enumerations listed the same number of points.
    pub same_count: bool,
}

/// A fat triangle of roughly `2r²` points with seeded jitter (the bench's).
fn fat(rng: &mut rand::rngs::StdRng, r: i64) -> [LatticePoint; 3] {
    let mut j = || rng.random_range(-r / 20..=r / 20);
    [
        [j(), j()],
        [2 * r + j(), r / 3 + j()],
        [r / 2 + j(), 2 * r + j()],
    ]
}

/// A skinny 45° triangle with long side about `n·√2` and `m + 2` points
/// (the bench's).
fn skinny(n: i64, m: i64) -> [LatticePoint; 3] {
    [[0, 0], [n, n + 1], [m, m]]
}

fn fold(acc: i64, p: LatticePoint) -> i64 {
    acc.wrapping_add(p[0] ^ p[1].rotate_left(7))
}

/// Times both enumerations on fat triangles of the given radii and skinny
/// ones of the given long sides; `reps` batches of about `batch_s` seconds.
pub fn triangle_report(
    fat_radii: &[i64],
    skinny_sides: &[i64],
    reps: usize,
    batch_s: f64,
) -> Result<Vec<TriangleRow>> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let cases = fat_radii
        .iter()
        .map(|&r| (Shape::Fat, fat(&mut rng, r)))
        .chain(skinny_sides.iter().map(|&n| (Shape::Skinny, skinny(n, 10))))
        .collect::<Vec<_>>();
    let mut rows = Vec::new();
    for (shape, v) in cases {
        let t = TriangleIndex::new(v)?;
        let s = ScanlineLattice::new(v)?;
        let indexed = time_batched(reps, batch_s, || {
            let mut acc = 0i64;
            black_box(&t).for_each_point(|p| acc = fold(acc, p));
            black_box(acc);
        });
        let scanline = time_batched(reps, batch_s, || {
            let mut acc = 0i64;
            black_box(&s).for_each(|p| acc = fold(acc, p));
            black_box(acc);
        });
        let xs = v.map(|p| p[0]);
        let ys = v.map(|p| p[1]);
        let extent = (xs.iter().max().unwrap_or(&0) - xs.iter().min().unwrap_or(&0))
            .max(ys.iter().max().unwrap_or(&0) - ys.iter().min().unwrap_or(&0));
        rows.push(TriangleRow {
            shape,
            extent,
            points: t.len(),
            indexed,
            scanline,
            same_count: t.len() == s.count(),
        });
    }
    Ok(rows)
}

/// The triangle section's Markdown, with its plot written to `plots`.
pub fn section(rows: &[TriangleRow], plots: &PlotDir) -> Result<String> {
    let reps = rows.first().map_or(0, |r| r.indexed.reps);
    let mut md = format!(
        "Every lattice point of one triangle handed to a consumer (the same shapes as \
         `benches/triangle.rs`): **indexed** is Kahan–Kelsen `TriangleIndex::for_each_point`, \
         **scanline** is `ScanlineLattice::for_each` (row by row). Time: a warm-up call sizes a \
         batch of ≈ the batch time, then the median of {reps} batches, per triangle. Both are \
         exact (no error to report); **same points** checks that both enumerate the same number \
         of points — the error column of this table.\n\n\
         | shape | extent | points | indexed µs/triangle | indexed ns/point | scanline µs/triangle | scanline ns/point | scanline / indexed | same points |\n\
         |---|---|---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        let per_point = |t: &Timing| 1e9 * t.median / r.points.max(1) as f64;
        md.push_str(&format!(
            "| {} | {} | {} | {:.3} | {:.2} | {:.3} | {:.2} | {:.2}× | {} |\n",
            r.shape.name(),
            r.extent,
            r.points,
            1e6 * r.indexed.median,
            per_point(&r.indexed),
            1e6 * r.scanline.median,
            per_point(&r.scanline),
            r.scanline.median / r.indexed.median,
            if r.same_count { "yes" } else { "**no**" },
        ));
    }
    md.push('\n');
    let series = |shape: Shape, name: &str, f: &dyn Fn(&TriangleRow) -> f64| {
        Series::line(
            format!("{} {name}", shape.name()),
            rows.iter()
                .filter(|r| r.shape == shape)
                .map(|r| (r.extent as f64, f(r)))
                .collect(),
        )
    };
    md.push_str(&plots.write(
        "triangles_time.svg",
        &Chart {
            title: "Triangle lattice points: indexed against scanline".into(),
            x_label: "bounding-box extent (lattice units)".into(),
            y_label: "µs per triangle".into(),
            log_x: true,
            log_y: true,
            series: vec![
                series(Shape::Fat, "indexed", &|r| 1e6 * r.indexed.median),
                series(Shape::Fat, "scanline", &|r| 1e6 * r.scanline.median),
                series(Shape::Skinny, "indexed", &|r| 1e6 * r.indexed.median),
                series(Shape::Skinny, "scanline", &|r| 1e6 * r.scanline.median),
            ],
            front: None,
        },
    )?);
    Ok(md)
}
