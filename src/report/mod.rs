//! Speed against error: the measurements `voxkit demo` prints (this file)
//! and the full report `voxkit report` writes ([`document`], one submodule
//! per area: [`lines`], [`triangles`], [`voxelize`], [`render`]; the
//! machine in [`machine`], timing rules in [`timing`], plots in [`plot`]).
//!
//! Every line algorithm is timed on the same seeded random segments, walking
//! a dense grid and writing each voxel, and judged by the exact oracles of
//! [`crate::topology`] on the same segments: how many listed voxels the
//! continuous segment does not touch, how many lines cover their segment
//! (containment), how many are N-connected, and — for the floating-point
//! Amanatides–Woo line — how many differ from the exact tripod line.
//! Timings are wall-clock on whatever machine runs them: they are a report,
//! never a test.

use std::ops::ControlFlow;
use std::time::Instant;

use glam::DVec3;
use rand::{Rng, SeedableRng};

use crate::Connectivity;
use crate::error::Result;
use crate::fixed;
use crate::grid::{DenseGrid, MemoryLimit, Voxel};
use crate::line::amanatides_woo::{aw_line, aw_walk_mut};
use crate::line::{
    Line18, Line26, OCCUPIED, Segment, Tripod6, WalkOutcome, adaptive_walk, set_proximity_flags,
    walk, walk_mut,
};
use crate::topology::{covers_segment, first_untouched, is_connected_path};

pub mod document;
pub mod lines;
pub mod machine;
pub mod plot;
pub mod render;
pub mod timing;
pub mod triangles;
pub mod voxelize;

/// The line algorithms of the engine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineAlgorithm {
    /// 26-connected midpoint line.
    Line26,
    /// 18-connected line.
    Line18,
    /// Tripod 6-connected line (exact, containment).
    Tripod6,
    /// Amanatides–Woo in `f64`.
    AmanatidesWoo,
    /// Adaptive 26↔6 ray over a grid with proximity flags.
    Adaptive,
}

impl LineAlgorithm {
    /// All algorithms, in table order.
    pub const ALL: [LineAlgorithm; 5] = [
        LineAlgorithm::Line26,
        LineAlgorithm::Line18,
        LineAlgorithm::Tripod6,
        LineAlgorithm::AmanatidesWoo,
        LineAlgorithm::Adaptive,
    ];

    /// Short name used in tables and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LineAlgorithm::Line26 => "26-line",
            LineAlgorithm::Line18 => "18-line",
            LineAlgorithm::Tripod6 => "tripod 6-line",
            LineAlgorithm::AmanatidesWoo => "Amanatides-Woo",
            LineAlgorithm::Adaptive => "adaptive 26/6",
        }
    }
}

/// One row of the line report.
#[derive(Clone, Debug, PartialEq)]
pub struct LineRow {
    /// The algorithm.
    pub algorithm: LineAlgorithm,
    /// Mean voxels per line.
    pub voxels_per_line: f64,
    /// Voxels written (or read, for the adaptive ray) per second.
    pub voxels_per_second: f64,
    /// Share of listed voxels that the continuous segment does not touch.
    pub untouched: f64,
    /// Share of lines whose voxels cover their whole segment.
    pub containment: f64,
    /// Share of lines that are paths of the algorithm's connectivity.
    pub connected: f64,
    /// Largest Euclidean distance from a listed voxel's centre to the
    /// continuous segment, in voxels (√3/2 ≈ 0.866 for a voxel the segment
    /// only touches at a corner; more means a voxel the segment misses).
    pub max_distance: f64,
    /// Relative spread `(max − min) / median` of the timed passes.
    pub time_spread: f64,
    /// For A–W: share of lines whose voxels differ from the exact tripod
    /// line; for the adaptive ray: share of rays whose first occupied voxel
    /// differs from the tripod line's. Zero for the exact lines.
    pub mismatch: f64,
}

/// Settings of [`line_report`].
#[derive(Clone, Copy, Debug)]
pub struct LineReportConfig {
    /// Segments timed.
    pub segments: usize,
    /// Segments judged by the exact oracles (the first ones of the timed set).
    pub judged: usize,
    /// Segment length in voxels.
    pub length: f64,
    /// Grid side.
    pub grid: usize,
    /// Random seed.
    pub seed: u64,
    /// Timed passes over all segments (after one warm-up pass); the
    /// median is reported.
    pub reps: usize,
}

impl Default for LineReportConfig {
    fn default() -> Self {
        LineReportConfig {
            segments: 20_000,
            judged: 2_000,
            length: 64.0,
            grid: 256,
            seed: 42,
            reps: 3,
        }
    }
}

/// Random segments of `length` voxels with sub-voxel endpoints inside a
/// `grid`³ box, on the 2^-20 lattice so the fixed-point oracles see exactly
/// the segment the floating-point algorithm sees.
pub fn random_segments(n: usize, length: f64, grid: usize, seed: u64) -> Result<Vec<Segment>> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let hi = grid as f64 - 1.0;
    let snap = |x: f64| (x * fixed::ONE as f64).round() / fixed::ONE as f64;
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let a = DVec3::new(
            rng.random_range(0.0..hi),
            rng.random_range(0.0..hi),
            rng.random_range(0.0..hi),
        );
        let z: f64 = rng.random_range(-1.0..1.0);
        let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let r = (1.0 - z * z).sqrt();
        let b = a + length * DVec3::new(r * phi.cos(), r * phi.sin(), z);
        if b.min_element() >= 0.0 && b.max_element() <= hi {
            out.push(Segment::from_f64(
                a.to_array().map(snap),
                b.to_array().map(snap),
            )?);
        }
    }
    Ok(out)
}

pub(crate) fn endpoints_f64(s: &Segment) -> (DVec3, DVec3) {
    let p = |q: [i64; 3]| {
        DVec3::new(
            fixed::to_f64(q[0]),
            fixed::to_f64(q[1]),
            fixed::to_f64(q[2]),
        )
    };
    (p(s.a()), p(s.b()))
}

fn voxels_of(algorithm: LineAlgorithm, s: &Segment) -> Result<Vec<Voxel>> {
    Ok(match algorithm {
        LineAlgorithm::Line26 | LineAlgorithm::Adaptive => Line26::new(s).collect(),
        LineAlgorithm::Line18 => Line18::new(s).collect(),
        LineAlgorithm::Tripod6 => Tripod6::new(s).collect(),
        LineAlgorithm::AmanatidesWoo => {
            let (a, b) = endpoints_f64(s);
            aw_line(a, b)?.collect()
        }
    })
}

fn connectivity_of(algorithm: LineAlgorithm) -> Connectivity {
    match algorithm {
        LineAlgorithm::Line26 | LineAlgorithm::Adaptive => Connectivity::TwentySix,
        LineAlgorithm::Line18 => Connectivity::Eighteen,
        LineAlgorithm::Tripod6 | LineAlgorithm::AmanatidesWoo => Connectivity::Six,
    }
}

/// Measures every line algorithm: speed of the grid walk and the exact error
/// measures of [`LineRow`]. The adaptive ray runs over a grid holding a
/// solid ball of occupied voxels with proximity flags of radius 2, reading
/// cells until its first occupied voxel (the ray caster's use); its
/// other measures are those of its voxels with no flags (the 26-line).
pub fn line_report(cfg: &LineReportConfig) -> Result<Vec<LineRow>> {
    let segs = random_segments(cfg.segments, cfg.length, cfg.grid, cfg.seed)?;
    let g = cfg.grid;
    let mut grid = DenseGrid::new([g, g, g], 0u8, MemoryLimit::DEFAULT)?;
    // The scene for the adaptive ray: a ball of radius g/6 at the centre.
    let mut scene = DenseGrid::new([g, g, g], 0u8, MemoryLimit::DEFAULT)?;
    let c = (g as f64 - 1.0) / 2.0;
    let radius = g as f64 / 6.0;
    for z in 0..g {
        for y in 0..g {
            for x in 0..g {
                let d = DVec3::new(x as f64 - c, y as f64 - c, z as f64 - c).length();
                if d <= radius {
                    *scene
                        .get_mut(Voxel::new(x as i32, y as i32, z as i32))
                        .expect("in grid") = OCCUPIED;
                }
            }
        }
    }
    set_proximity_flags(&mut scene, 2);
    let judged = &segs[..cfg.judged.min(segs.len())];

    let mut rows = Vec::new();
    for algorithm in LineAlgorithm::ALL {
        // Speed: a warm-up pass, then the median of `reps` timed passes.
        let mut passes = Vec::new();
        let mut visited = 0u64;
        for pass in 0..=cfg.reps.max(1) {
            visited = 0;
            let t0 = Instant::now();
            for s in &segs {
                let outcome = match algorithm {
                    LineAlgorithm::Line26 => walk_mut(&mut grid, s, Connectivity::TwentySix, write),
                    LineAlgorithm::Line18 => walk_mut(&mut grid, s, Connectivity::Eighteen, write),
                    LineAlgorithm::Tripod6 => walk_mut(&mut grid, s, Connectivity::Six, write),
                    LineAlgorithm::AmanatidesWoo => {
                        let (a, b) = endpoints_f64(s);
                        aw_walk_mut(&mut grid, a, b, write)
                            .map(|o| WalkOutcome::Completed { visited: o.visited })?
                    }
                    LineAlgorithm::Adaptive => {
                        let mut n = 0u64;
                        adaptive_walk(&scene, s, |&cell| {
                            n += 1;
                            if cell & OCCUPIED != 0 {
                                ControlFlow::Break(())
                            } else {
                                ControlFlow::Continue(())
                            }
                        });
                        WalkOutcome::Completed { visited: n }
                    }
                };
                if let WalkOutcome::Completed { visited: n } = outcome {
                    visited += n;
                }
            }
            if pass > 0 {
                passes.push(t0.elapsed().as_secs_f64());
            }
        }
        let spread = passes.iter().copied().fold(0.0, f64::max)
            - passes.iter().copied().fold(f64::INFINITY, f64::min);
        let seconds = timing::median(&mut passes);

        // Error measures with the exact oracles.
        let conn = connectivity_of(algorithm);
        let (mut voxels, mut untouched, mut contained, mut connected, mut mismatched) =
            (0u64, 0u64, 0u64, 0u64, 0u64);
        let mut max_distance = 0.0f64;
        for s in judged {
            let path = voxels_of(algorithm, s)?;
            voxels += path.len() as u64;
            let (a, b) = endpoints_f64(s);
            for v in &path {
                let d = crate::voxelize::measure::point_segment_distance(v.as_dvec3(), a, b);
                max_distance = max_distance.max(d);
            }
            untouched += path
                .iter()
                .filter(|&&v| first_untouched(s.a(), s.b(), &[v]).is_some())
                .count() as u64;
            contained += u64::from(covers_segment(s.a(), s.b(), &path));
            connected += u64::from(is_connected_path(&path, conn));
            mismatched += u64::from(match algorithm {
                LineAlgorithm::AmanatidesWoo => path != Tripod6::new(s).collect::<Vec<_>>(),
                LineAlgorithm::Adaptive => {
                    first_hit(&scene, s, None) != first_hit(&scene, s, Some(Connectivity::Six))
                }
                _ => false,
            });
        }
        let n = judged.len().max(1) as f64;
        rows.push(LineRow {
            algorithm,
            voxels_per_line: voxels as f64 / n,
            voxels_per_second: visited as f64 / seconds,
            untouched: untouched as f64 / voxels.max(1) as f64,
            containment: contained as f64 / n,
            connected: connected as f64 / n,
            mismatch: mismatched as f64 / n,
            max_distance,
            time_spread: spread / seconds,
        });
    }
    Ok(rows)
}

#[inline(always)]
fn write(c: &mut u8) -> ControlFlow<()> {
    *c = 1;
    ControlFlow::Continue(())
}

/// First occupied voxel along `s`: by the adaptive ray (`conn = None`) or by
/// a plain walk of connectivity `conn`.
fn first_hit(scene: &DenseGrid<u8>, s: &Segment, conn: Option<Connectivity>) -> Option<Voxel> {
    let stop = |&c: &u8| {
        if c & OCCUPIED != 0 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    };
    match conn {
        None => adaptive_walk(scene, s, stop).stopped_at(),
        Some(conn) => walk(scene, s, conn, stop).stopped_at(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The report's own judgements on a small run: the exact lines are
    /// connected and touch every voxel; the tripod line has containment; the
    /// adaptive ray finds the tripod's first hit.
    #[test]
    fn small_report_has_the_guaranteed_properties() {
        let cfg = LineReportConfig {
            segments: 200,
            judged: 200,
            length: 20.0,
            grid: 48,
            seed: 3,
            reps: 1,
        };
        let rows = line_report(&cfg).unwrap();
        assert_eq!(rows.len(), LineAlgorithm::ALL.len());
        for r in &rows {
            assert_eq!(r.connected, 1.0, "{r:?}");
            assert!(r.voxels_per_second > 0.0);
            if r.algorithm != LineAlgorithm::AmanatidesWoo {
                assert_eq!(r.untouched, 0.0, "{r:?}");
                // A touched voxel's centre is within half its diagonal.
                assert!(r.max_distance <= 0.75f64.sqrt() + 1e-9, "{r:?}");
            }
            assert!(r.max_distance > 0.0 && r.max_distance.is_finite());
        }
        let tripod = rows
            .iter()
            .find(|r| r.algorithm == LineAlgorithm::Tripod6)
            .unwrap();
        assert_eq!(tripod.containment, 1.0);
        let adaptive = rows
            .iter()
            .find(|r| r.algorithm == LineAlgorithm::Adaptive)
            .unwrap();
        assert_eq!(adaptive.mismatch, 0.0);
    }
}
