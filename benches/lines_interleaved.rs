//! The ratios of `benches/lines.rs` measured in interleaved rounds: each
//! round times every case once, in turn, on the same segments, so a slow
//! phase of the machine (this VM's run-to-run swings reach 30%) hits ours and
//! the peer alike. Prints, per setting, every case's best and median time per
//! line and each target ratio as the median over rounds of the ratio within a
//! round, with its range.
//!
//! `cargo bench --bench lines_interleaved` (31 rounds after one warm-up
//! round; `ROUNDS=n` to change).

use std::cell::RefCell;
use std::hint::black_box;
use std::ops::ControlFlow;
use std::time::Instant;

use line_drawing::Bresenham3d;
use voxkit::Connectivity;
use voxkit::grid::{DenseGrid, MemoryLimit};
use voxkit::line::{Line18, Line26, Segment, Tripod6, walk_mut};

#[path = "common/lines.rs"]
mod common;
use common::{
    floored, mark, ours, peer_voxels, segments, walk_voxels, xor_bresenham, xor_walk_voxels, xor6,
    xor26,
};

/// A named measure with the voxels it hands on: runs over every segment
/// once, returns a value to keep.
type Case<'a> = (&'a str, u64, Box<dyn FnMut() -> i64 + 'a>);

/// Runs the cases in turn for `rounds` rounds; returns each case's times per
/// line (ns), one per round.
fn rounds(cases: &mut [Case], rounds: usize, reps: usize, lines: usize) -> Vec<Vec<f64>> {
    let mut times = vec![Vec::with_capacity(rounds); cases.len()];
    // Round 0 warms up (first touches of the grid's pages) and is dropped.
    for round in 0..=rounds {
        for (k, (_, _, run)) in cases.iter_mut().enumerate() {
            let t = Instant::now();
            for _ in 0..reps {
                black_box(run());
            }
            if round > 0 {
                times[k].push(t.elapsed().as_secs_f64() * 1e9 / (reps * lines) as f64);
            }
        }
    }
    times
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

/// Prints each case's time per line and voxel rate, and the ratios: `rate`
/// pairs `(label, a, b)` compare voxel rates (a over b), `time` pairs compare
/// times of the same voxels (a over b), each as the median over rounds of the
/// ratio within a round, with its range.
fn report(
    setting: &str,
    cases: &[Case],
    times: &[Vec<f64>],
    lines: usize,
    rate: &[(&str, usize, usize)],
    time: &[(&str, usize, usize)],
) {
    let n_rounds = times[0].len();
    println!("\n{setting}: best / median of {n_rounds} rounds");
    for ((name, voxels, _), t) in cases.iter().zip(times) {
        let best = t.iter().copied().fold(f64::INFINITY, f64::min);
        let med = median(t);
        let per_line = *voxels as f64 / lines as f64;
        println!(
            "  {name:<20} {best:>7.1} / {med:>7.1} ns per line  {:>7.1} M voxels/s (median)",
            per_line / med * 1e3
        );
    }
    let per_voxel = |k: usize, r: usize| times[k][r] / cases[k].1 as f64;
    let show = |label: &str, r: Vec<f64>| {
        let (lo, hi) = r
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
        println!("  {label:<34} {:.2}x [{lo:.2}-{hi:.2}]", median(&r));
    };
    for &(label, a, b) in rate {
        show(
            label,
            (0..n_rounds)
                .map(|r| per_voxel(b, r) / per_voxel(a, r))
                .collect(),
        );
    }
    for &(label, a, b) in time {
        show(
            label,
            (0..n_rounds).map(|r| times[a][r] / times[b][r]).collect(),
        );
    }
}

/// Writes a precomputed index list (the store-only baseline).
fn store(cells: &mut [u8], idx: &[usize]) -> i64 {
    for &i in black_box(idx) {
        cells[i] = 1;
    }
    0
}

/// Voxels of every segment's line.
fn voxels<I: Iterator>(segs: &[Segment], line: impl Fn(&Segment) -> I) -> u64 {
    segs.iter().map(|s| line(s).count() as u64).sum()
}

fn main() {
    let n_rounds: usize = std::env::var("ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(31);

    // Generation only: 2,000 segments inside 64³, as `generate` in lines.rs.
    let raw = segments(2000, 64.0, 64.0, 42);
    let segs = ours(&raw);
    let ints = floored(&raw);
    let v26 = voxels(&segs, Line26::new);
    let v6 = voxels(&segs, Tripod6::new);
    let (vb, vw) = peer_voxels(&ints, &raw);
    let mut gen_cases: Vec<Case> = vec![
        (
            "line26",
            v26,
            Box::new(|| i64::from(xor26(black_box(&segs)))),
        ),
        (
            "bresenham3d",
            vb,
            Box::new(|| i64::from(xor_bresenham(black_box(&ints)))),
        ),
        (
            "tripod6",
            v6,
            Box::new(|| i64::from(xor6(black_box(&segs)))),
        ),
        (
            "walkvoxels_f64",
            vw,
            Box::new(|| i64::from(xor_walk_voxels(black_box(&raw)))),
        ),
    ];
    let t = rounds(&mut gen_cases, n_rounds, 50, segs.len());
    let rate = [
        ("26-line / Bresenham3d (rate)", 0, 1),
        ("tripod / WalkVoxels (rate)", 2, 3),
    ];
    report("generate", &gen_cases, &t, segs.len(), &rate, &[]);
    drop(gen_cases);

    for g in [64usize, 512] {
        let n = if g == 64 { 2000 } else { 20000 };
        let reps = if g == 64 { 30 } else { 3 };
        let raw = segments(n, 64.0, g as f64, 42);
        let segs = ours(&raw);
        let ints = floored(&raw);
        let grid = RefCell::new(DenseGrid::new([g, g, g], 0u8, MemoryLimit::DEFAULT).unwrap());
        let indices = |line: &dyn Fn(&Segment) -> Vec<glam::IVec3>| -> Vec<usize> {
            let grid = grid.borrow();
            segs.iter()
                .flat_map(line)
                .map(|v| grid.linear_index(v).unwrap())
                .collect()
        };
        let idx26 = indices(&|s| Line26::new(s).collect());
        let idx6 = indices(&|s| Tripod6::new(s).collect());
        let idx18 = indices(&|s| Line18::new(s).collect());
        let (vb, vw) = peer_voxels(&ints, &raw);
        let walk = |conn: Connectivity| {
            let (grid, segs) = (&grid, &segs);
            move || {
                let mut grid = grid.borrow_mut();
                for s in black_box(segs) {
                    walk_mut(&mut grid, s, conn, |c| {
                        *c = 1;
                        ControlFlow::Continue(())
                    });
                }
                0
            }
        };
        let mut cases: Vec<Case> = vec![
            (
                "line26",
                idx26.len() as u64,
                Box::new(walk(Connectivity::TwentySix)),
            ),
            (
                "bresenham3d",
                vb,
                Box::new(|| {
                    let mut grid = grid.borrow_mut();
                    let cells = grid.as_mut_slice();
                    for &(a, b) in black_box(&ints) {
                        mark(cells, g, Bresenham3d::new(a, b));
                    }
                    0
                }),
            ),
            (
                "tripod6",
                idx6.len() as u64,
                Box::new(walk(Connectivity::Six)),
            ),
            (
                "walkvoxels_f64",
                vw,
                Box::new(|| {
                    let mut grid = grid.borrow_mut();
                    let cells = grid.as_mut_slice();
                    for (a, b) in black_box(&raw) {
                        mark(cells, g, walk_voxels(a, b));
                    }
                    0
                }),
            ),
            (
                "line18",
                idx18.len() as u64,
                Box::new(walk(Connectivity::Eighteen)),
            ),
            (
                "store_only_line26",
                idx26.len() as u64,
                Box::new(|| store(grid.borrow_mut().as_mut_slice(), &idx26)),
            ),
            (
                "store_only_tripod6",
                idx6.len() as u64,
                Box::new(|| store(grid.borrow_mut().as_mut_slice(), &idx6)),
            ),
            (
                "store_only_line18",
                idx18.len() as u64,
                Box::new(|| store(grid.borrow_mut().as_mut_slice(), &idx18)),
            ),
        ];
        let t = rounds(&mut cases, n_rounds, reps, n);
        let time = [
            ("26-line / store-only (time)", 0, 5),
            ("tripod / store-only (time)", 2, 6),
            ("18-line / store-only (time)", 4, 7),
        ];
        let name = if g == 64 { "grid64" } else { "grid512" };
        report(name, &cases, &t, n, &rate, &time);
    }
}
