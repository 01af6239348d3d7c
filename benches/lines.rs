//! Voxels/s of every line algorithm against `line_drawing` on the same
//! random 64-voxel float segments (SplitMix64 generator of the peer harness
//! /work/shared/peers/rust-lines), in three settings: generation only, writes
//! into a cache-resident 64³ u8 grid, writes into a 512³ u8 grid (plus a
//! store-only baseline writing a precomputed index list of the same voxels);
//! and generation against line length (16, 64, 200 voxels).

use std::hint::black_box;
use std::ops::ControlFlow;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use line_drawing::Bresenham3d;
use voxkit::Connectivity;
use voxkit::grid::{DenseGrid, MemoryLimit};
use voxkit::line::amanatides_woo::{aw_line, aw_walk_mut};
use voxkit::line::{
    Line18, Line26, OCCUPIED, Segment, Tripod6, WalkOutcome, adaptive_walk, walk_mut,
};

#[path = "common/lines.rs"]
mod common;
use common::{
    floored, mark, ours, peer_voxels, segments, walk_voxels, xor_bresenham, xor_walk_voxels, xor6,
    xor26,
};

fn bench_size(c: &mut Criterion, g: usize, name: &str) {
    // 64³: 2000 segments (cache-resident grid). 512³: 20000 segments spread
    // over 128 MiB, so writes miss the caches as a real traversal would.
    let n = if g == 64 { 2000 } else { 20000 };
    let raw = segments(n, 64.0, g as f64, 42);
    let segs = ours(&raw);
    let ints = floored(&raw);
    let int_segs: Vec<Segment> = ints
        .iter()
        .map(|&(a, b)| {
            let v = |p: (i32, i32, i32)| glam::IVec3::new(p.0, p.1, p.2);
            Segment::from_voxels(v(a), v(b)).unwrap()
        })
        .collect();
    let total26i: u64 = int_segs.iter().map(|s| Line26::new(s).len() as u64).sum();
    let total26: u64 = segs.iter().map(|s| Line26::new(s).len() as u64).sum();
    let total6: u64 = segs.iter().map(|s| Tripod6::new(s).len() as u64).sum();
    let total18: u64 = segs.iter().map(|s| Line18::new(s).count() as u64).sum();
    let (totalb, totalw) = peer_voxels(&ints, &raw);

    if g == 64 {
        let mut grp = c.benchmark_group("generate");
        grp.throughput(Throughput::Elements(total26));
        grp.bench_function("line26", |bn| bn.iter(|| xor26(black_box(&segs))));
        // Set-up alone (construct, read the length): the fixed cost per line.
        grp.throughput(Throughput::Elements(segs.len() as u64));
        grp.bench_function("line26_setup_per_line", |bn| {
            bn.iter(|| {
                black_box(&segs)
                    .iter()
                    .map(|s| Line26::new(s).len())
                    .fold(0, |a, b| a ^ b)
            })
        });
        grp.throughput(Throughput::Elements(total26i));
        grp.bench_function("line26_integer_endpoints", |bn| {
            bn.iter(|| xor26(black_box(&int_segs)))
        });
        grp.throughput(Throughput::Elements(totalb));
        grp.bench_function("bresenham3d", |bn| {
            bn.iter(|| xor_bresenham(black_box(&ints)))
        });
        grp.throughput(Throughput::Elements(total6));
        grp.bench_function("tripod6", |bn| bn.iter(|| xor6(black_box(&segs))));
        grp.throughput(Throughput::Elements(total18));
        grp.bench_function("line18", |bn| {
            bn.iter(|| {
                black_box(&segs)
                    .iter()
                    .map(|s| Line18::new(s).fold(0i32, |acc, v| acc ^ v.x ^ v.y ^ v.z))
                    .fold(0, |a, b| a ^ b)
            })
        });
        grp.throughput(Throughput::Elements(totalw));
        grp.bench_function("walkvoxels_f64", |bn| {
            bn.iter(|| xor_walk_voxels(black_box(&raw)))
        });
        grp.throughput(Throughput::Elements(total6));
        grp.bench_function("amanatides_woo", |bn| {
            bn.iter(|| {
                black_box(&segs)
                    .iter()
                    .map(|s| {
                        let p = |q: [i64; 3]| {
                            glam::DVec3::new(
                                voxkit::fixed::to_f64(q[0]),
                                voxkit::fixed::to_f64(q[1]),
                                voxkit::fixed::to_f64(q[2]),
                            )
                        };
                        aw_line(p(s.a()), p(s.b()))
                            .unwrap()
                            .fold(0i32, |acc, v| acc ^ v.x ^ v.y ^ v.z)
                    })
                    .fold(0, |a, b| a ^ b)
            })
        });
        grp.finish();
    }

    let mut grid = DenseGrid::new([g, g, g], 0u8, MemoryLimit::DEFAULT).unwrap();
    let mut grp = c.benchmark_group(name);
    grp.sample_size(10);
    for (label, conn, total) in [
        ("line26", Connectivity::TwentySix, total26),
        ("line18", Connectivity::Eighteen, total18),
        ("tripod6", Connectivity::Six, total6),
    ] {
        grp.throughput(Throughput::Elements(total));
        grp.bench_function(label, |bn| {
            bn.iter(|| {
                for s in black_box(&segs) {
                    walk_mut(&mut grid, s, conn, |c| {
                        *c = 1;
                        ControlFlow::Continue(())
                    });
                }
            })
        });
        // store-only baseline: the same voxels as a precomputed index list
        let mut idx = Vec::with_capacity(total as usize);
        for s in &segs {
            walk_mut(&mut grid, s, conn, |_| ControlFlow::Continue(()));
            let it: Box<dyn Iterator<Item = glam::IVec3>> = match conn {
                Connectivity::Six => Box::new(Tripod6::new(s)),
                Connectivity::Eighteen => Box::new(Line18::new(s)),
                Connectivity::TwentySix => Box::new(Line26::new(s)),
            };
            idx.extend(it.map(|v| grid.linear_index(v).unwrap()));
        }
        grp.bench_function(format!("store_only_{label}"), |bn| {
            bn.iter(|| {
                let cells = grid.as_mut_slice();
                for &i in black_box(&idx) {
                    cells[i] = 1;
                }
            })
        });
    }
    // The adaptive ray with no proximity flags runs 26-connected; count the
    // voxels it actually visits.
    let total_adaptive: u64 = segs
        .iter()
        .map(
            |s| match adaptive_walk(&grid, s, |_| ControlFlow::Continue(())) {
                WalkOutcome::Completed { visited } => visited,
                WalkOutcome::Stopped { .. } => unreachable!("the visitor never stops"),
            },
        )
        .sum();
    grp.throughput(Throughput::Elements(total_adaptive));
    grp.bench_function("adaptive_no_flags_read", |bn| {
        bn.iter(|| {
            let mut n = 0u64;
            for s in black_box(&segs) {
                adaptive_walk(&grid, s, |c| {
                    n += u64::from(*c & OCCUPIED);
                    ControlFlow::Continue(())
                });
            }
            n
        })
    });
    let aw_ends: Vec<(glam::DVec3, glam::DVec3)> = raw
        .iter()
        .map(|(a, b)| {
            let p = |q: &[f64; 3]| glam::DVec3::new(q[0] - 0.5, q[1] - 0.5, q[2] - 0.5);
            (p(a), p(b))
        })
        .collect();
    grp.throughput(Throughput::Elements(total6));
    grp.bench_function("amanatides_woo", |bn| {
        bn.iter(|| {
            for &(a, b) in black_box(&aw_ends) {
                aw_walk_mut(&mut grid, a, b, |c| {
                    *c = 1;
                    ControlFlow::Continue(())
                })
                .unwrap();
            }
        })
    });
    grp.throughput(Throughput::Elements(total26i));
    grp.bench_function("line26_integer_endpoints", |bn| {
        bn.iter(|| {
            for s in black_box(&int_segs) {
                walk_mut(&mut grid, s, Connectivity::TwentySix, |c| {
                    *c = 1;
                    ControlFlow::Continue(())
                });
            }
        })
    });
    grp.throughput(Throughput::Elements(totalb));
    grp.bench_function("bresenham3d", |bn| {
        bn.iter(|| {
            let cells = grid.as_mut_slice();
            for &(a, b) in black_box(&ints) {
                mark(cells, g, Bresenham3d::new(a, b));
            }
        })
    });
    grp.throughput(Throughput::Elements(totalw));
    grp.bench_function("walkvoxels_f64", |bn| {
        bn.iter(|| {
            let cells = grid.as_mut_slice();
            for (a, b) in black_box(&raw) {
                mark(cells, g, walk_voxels(a, b));
            }
        })
    });
    grp.finish();
}

/// Generation against line length: the fixed cost per line (set-up) and the
/// cost per voxel, for the 26-line against `Bresenham3d` and the tripod
/// against `WalkVoxels` (the same random segments, 2,000 per length).
fn by_length(c: &mut Criterion) {
    let mut grp = c.benchmark_group("length");
    for len in [16usize, 64, 200] {
        let g = (len * 3 / 2).max(32) as f64;
        let raw = segments(2000, len as f64, g, 43);
        let segs = ours(&raw);
        let ints = floored(&raw);
        let total26: u64 = segs.iter().map(|s| Line26::new(s).len() as u64).sum();
        let total6: u64 = segs.iter().map(|s| Tripod6::new(s).len() as u64).sum();
        let (totalb, totalw) = peer_voxels(&ints, &raw);
        grp.throughput(Throughput::Elements(total26));
        grp.bench_function(format!("line26/{len}"), |bn| {
            bn.iter(|| xor26(black_box(&segs)))
        });
        grp.throughput(Throughput::Elements(totalb));
        grp.bench_function(format!("bresenham3d/{len}"), |bn| {
            bn.iter(|| xor_bresenham(black_box(&ints)))
        });
        grp.throughput(Throughput::Elements(total6));
        grp.bench_function(format!("tripod6/{len}"), |bn| {
            bn.iter(|| xor6(black_box(&segs)))
        });
        grp.throughput(Throughput::Elements(totalw));
        grp.bench_function(format!("walkvoxels_f64/{len}"), |bn| {
            bn.iter(|| xor_walk_voxels(black_box(&raw)))
        });
    }
    grp.finish();
}

fn lines(c: &mut Criterion) {
    bench_size(c, 64, "grid64");
    bench_size(c, 512, "grid512");
    by_length(c);
}

criterion_group!(benches, lines);
criterion_main!(benches);
