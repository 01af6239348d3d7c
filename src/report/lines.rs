//! The report's lines section: every line algorithm's speed beside its
//! exact error (from [`super::line_report`]), and the Amanatides–Woo
//! traversal in `f32` and `f64` against the exact tripod line on long rays.

use glam::DVec3;
use rand::{Rng, SeedableRng};

use super::document::PlotDir;
use super::plot::{Chart, Series};
use super::{LineAlgorithm, LineReportConfig, LineRow};
use crate::error::Result;
use crate::fixed;
use crate::grid::Voxel;
use crate::line::amanatides_woo::{aw_line, aw_line_f32};
use crate::line::{Segment, Tripod6};

/// A-W against the exact tripod line, for rays of one length.
#[derive(Clone, Debug, PartialEq)]
pub struct LongRayRow {
    /// Target length in 6-connected voxels (rays are sized to about this).
    pub target_voxels: u64,
    /// Rays measured.
    pub rays: usize,
    /// Mean voxels of the exact tripod lines.
    pub mean_voxels: f64,
    /// Per precision (`[f64, f32]`): the measures against the tripod line.
    pub precision: [Divergence; 2],
}

/// How one traversal's voxels differ from the exact line's, over a set of rays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Divergence {
    /// Share of rays whose voxel sequence differs from the tripod line's.
    pub differing_rays: f64,
    /// Mean (over all rays) of the voxels in one line but not the other
    /// (symmetric difference of the two voxel sets).
    pub mean_voxels_differing: f64,
    /// Median over the differing rays of the first differing position, as a
    /// share of the line (0 = at the start voxel, 1 = at the end); `None`
    /// when no ray differs.
    pub first_divergence: Option<f64>,
}

/// Random rays of about `target` 6-connected voxels from a start in
/// `[-1000, 1000)³`, endpoints on the `2^-20` lattice (exact in `f64`; the
/// `f32` traversal gets them rounded to `f32`, as an `f32` caster would).
fn long_rays(n: usize, target: u64, seed: u64) -> Result<Vec<Segment>> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ target);
    let snap = |x: f64| (x * fixed::ONE as f64).round() / fixed::ONE as f64;
    (0..n)
        .map(|_| {
            let a = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-1000.0..1000.0)));
            let z: f64 = rng.random_range(-1.0..1.0);
            let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let r = (1.0 - z * z).sqrt();
            let d = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            // A 6-connected line takes about |d|₁ voxels per unit length.
            let b = a + d * (target as f64 / d.abs().element_sum());
            Segment::from_f64(a.to_array().map(snap), b.to_array().map(snap))
        })
        .collect()
}

/// Symmetric-difference size of two voxel lists (as sets) and the first
/// position where the sequences differ (`None` if equal).
fn compare(exact: &[Voxel], other: &[Voxel]) -> (u64, Option<usize>) {
    let first = exact
        .iter()
        .zip(other)
        .position(|(a, b)| a != b)
        .or((exact.len() != other.len()).then(|| exact.len().min(other.len())));
    if first.is_none() {
        return (0, None);
    }
    let key = |v: &Voxel| (v.x, v.y, v.z);
    let mut a = exact.to_vec();
    let mut b = other.to_vec();
    a.sort_unstable_by_key(key);
    b.sort_unstable_by_key(key);
    let (mut i, mut j, mut diff) = (0, 0, 0u64);
    while i < a.len() && j < b.len() {
        match key(&a[i]).cmp(&key(&b[j])) {
            std::cmp::Ordering::Less => (diff, i) = (diff + 1, i + 1),
            std::cmp::Ordering::Greater => (diff, j) = (diff + 1, j + 1),
            std::cmp::Ordering::Equal => (i, j) = (i + 1, j + 1),
        }
    }
    diff += (a.len() - i + b.len() - j) as u64;
    (diff, first)
}

/// Measures A–W in `f64` and in `f32` against the exact tripod line on `rays`
/// random rays of each target length.
pub fn long_ray_report(lengths: &[u64], rays: usize, seed: u64) -> Result<Vec<LongRayRow>> {
    let mut rows = Vec::new();
    for &target in lengths {
        let segs = long_rays(rays, target, seed)?;
        let mut total_voxels = 0u64;
        let mut diffs = [0u64; 2];
        let mut differing = [0usize; 2];
        let mut firsts: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
        for s in &segs {
            let exact: Vec<Voxel> = Tripod6::new(s).collect();
            total_voxels += exact.len() as u64;
            let (a, b) = super::endpoints_f64(s);
            let lines: [Vec<Voxel>; 2] = [
                aw_line(a, b)?.collect(),
                aw_line_f32(a.as_vec3(), b.as_vec3())?.collect(),
            ];
            for (p, line) in lines.iter().enumerate() {
                let (d, first) = compare(&exact, line);
                diffs[p] += d;
                if let Some(f) = first {
                    differing[p] += 1;
                    firsts[p].push(f as f64 / exact.len().max(1) as f64);
                }
            }
        }
        let n = segs.len().max(1) as f64;
        let precision = std::array::from_fn(|p| Divergence {
            differing_rays: differing[p] as f64 / n,
            mean_voxels_differing: diffs[p] as f64 / n,
            first_divergence: (!firsts[p].is_empty())
                .then(|| super::timing::median(&mut firsts[p].clone())),
        });
        rows.push(LongRayRow {
            target_voxels: target,
            rays: segs.len(),
            mean_voxels: total_voxels as f64 / n,
            precision,
        });
    }
    Ok(rows)
}

/// The lines section's Markdown, with its plots written to `plots`.
pub fn section(
    cfg: &LineReportConfig,
    rows: &[LineRow],
    long: &[LongRayRow],
    plots: &PlotDir,
) -> Result<String> {
    let mut md = String::new();
    md.push_str(&format!(
        "{} random segments of {} voxels with sub-voxel endpoints (on the 2^-20 lattice) in a \
         {g}³ u8 grid, seed {}; every voxel written to the grid (the adaptive ray reads cells \
         until it hits a ball of radius {g}/6 with proximity flags, as the ray caster does). \
         Time: one warm-up pass, then the median of {} passes over all segments. Errors are \
         judged exactly on the first {} segments:\n\n",
        cfg.segments,
        cfg.length,
        cfg.seed,
        cfg.reps,
        cfg.judged,
        g = cfg.grid,
    ));
    md.push_str(
        "- **not covering**: lines whose voxels do not cover the whole continuous segment \
         (containment fails; only the 6-connected lines can have it).\n\
         - **max distance**: the largest Euclidean distance from a listed voxel's centre to the \
         continuous segment, in voxels; a voxel the segment touches is within √3/2 ≈ 0.866.\n\
         - **untouched**: listed voxels the segment does not touch at all.\n\
         - **connected**: lines that are paths of the algorithm's connectivity (26, 18 or 6).\n\
         - **mismatch**: A–W lines differing from the exact tripod line; adaptive rays whose \
         first hit differs from the tripod line's.\n\n",
    );
    md.push_str(
        "| algorithm | voxels/line | M voxels/s | ns/voxel | time spread | not covering | max distance | untouched | connected | mismatch |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        md.push_str(&format!(
            "| {} | {:.1} | {:.1} | {:.2} | {:.0}% | {:.2}% | {:.3} | {:.3}% | {:.1}% | {:.2}% |\n",
            r.algorithm.name(),
            r.voxels_per_line,
            r.voxels_per_second / 1e6,
            1e9 / r.voxels_per_second,
            100.0 * r.time_spread,
            100.0 * (1.0 - r.containment),
            r.max_distance,
            100.0 * r.untouched,
            100.0 * r.connected,
            100.0 * r.mismatch,
        ));
    }
    md.push('\n');
    let per_algorithm = |f: &dyn Fn(&LineRow) -> f64| -> Vec<Series> {
        rows.iter()
            .map(|r| Series::points(r.algorithm.name(), vec![(r.voxels_per_second / 1e6, f(r))]))
            .collect()
    };
    md.push_str(&plots.write(
        "lines_speed_containment.svg",
        &Chart {
            title: "Lines: speed against containment".into(),
            x_label: "M voxels/s (grid walk)".into(),
            y_label: "lines not covering their segment (%)".into(),
            log_x: false,
            log_y: false,
            series: per_algorithm(&|r| 100.0 * (1.0 - r.containment)),
            front: None,
        },
    )?);
    md.push_str(&plots.write(
        "lines_speed_distance.svg",
        &Chart {
            title: "Lines: speed against distance from the segment".into(),
            x_label: "M voxels/s (grid walk)".into(),
            y_label: "max voxel-centre distance to the segment (voxels)".into(),
            log_x: false,
            log_y: false,
            series: per_algorithm(&|r| r.max_distance),
            front: None,
        },
    )?);
    debug_assert!(
        rows.iter()
            .any(|r| r.algorithm == LineAlgorithm::AmanatidesWoo)
    );

    md.push_str(&format!(
        "\n### Amanatides–Woo in f32 and f64 against the exact tripod line, long rays\n\n\
         {} random rays per length from starts in [−1000, 1000)³, endpoints on the 2^-20 \
         lattice (exact in f64; rounded to f32 for the f32 traversal, as an f32 ray caster \
         would hold them). **differing rays**: rays whose voxel sequence is not the tripod \
         line's; **voxels differing**: mean size of the symmetric difference of the voxel sets \
         per ray; **first divergence**: median position of the first differing voxel, as a \
         share of the line (over the differing rays).\n\n\
         | voxels/ray | rays | f64 differing rays | f64 voxels differing | f64 first divergence | f32 differing rays | f32 voxels differing | f32 first divergence |\n\
         |---|---|---|---|---|---|---|---|\n",
        long.first().map_or(0, |r| r.rays)
    ));
    let first = |d: &Divergence| d.first_divergence.map_or("-".into(), |f| format!("{f:.3}"));
    for r in long {
        let [d64, d32] = &r.precision;
        md.push_str(&format!(
            "| {:.0} | {} | {:.1}% | {:.2} | {} | {:.1}% | {:.2} | {} |\n",
            r.mean_voxels,
            r.rays,
            100.0 * d64.differing_rays,
            d64.mean_voxels_differing,
            first(d64),
            100.0 * d32.differing_rays,
            d32.mean_voxels_differing,
            first(d32),
        ));
    }
    md.push('\n');
    let curve = |p: usize| -> Vec<(f64, f64)> {
        long.iter()
            .map(|r| (r.mean_voxels, 100.0 * r.precision[p].differing_rays))
            .collect()
    };
    md.push_str(&plots.write(
        "lines_aw_precision.svg",
        &Chart {
            title: "Amanatides–Woo against the exact tripod line".into(),
            x_label: "voxels per ray".into(),
            y_label: "rays differing from the tripod line (%)".into(),
            log_x: true,
            log_y: false,
            series: vec![
                Series::line("A–W f64", curve(0)),
                Series::line("A–W f32", curve(1)),
            ],
            front: None,
        },
    )?);
    Ok(md)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compare_counts_symmetric_difference() {
        let v = |x, y, z| Voxel::new(x, y, z);
        let a = [v(0, 0, 0), v(1, 0, 0), v(1, 1, 0)];
        let b = [v(0, 0, 0), v(0, 1, 0), v(1, 1, 0)];
        assert_eq!(compare(&a, &a), (0, None));
        assert_eq!(compare(&a, &b), (2, Some(1)));
        assert_eq!(compare(&a, &a[..2]), (1, Some(2)));
    }

    /// On short rays f64 A–W is exact on the lattice and the report says
    /// so; rays have about the asked length.
    #[test]
    fn short_rays_agree_in_f64() {
        let rows = long_ray_report(&[200], 20, 7).unwrap();
        let r = &rows[0];
        assert_eq!(r.rays, 20);
        assert!((r.mean_voxels - 200.0).abs() < 5.0, "{r:?}");
        assert_eq!(r.precision[0].differing_rays, 0.0);
        assert_eq!(r.precision[0].first_divergence, None);
        assert!(r.precision[1].mean_voxels_differing.is_finite());
    }
}
