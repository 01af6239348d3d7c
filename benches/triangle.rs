//! Kahan–Kelsen indexed enumeration against scanline enumeration, and the
//! latency of random access `point(i)` across triangle sizes.
//!
//! Targets: skinny 45° triangles ≥ 100× faster indexed than scanline (time ∝
//! points, not rows); fat triangles within 1.5× of scanline; `point(i)` flat
//! from 10^2 to 10^12 points. Fixed-seed inputs, results consumed.
//! `indexed` / `indexed_iter` walk the index order; `indexed_range_unordered`
//! visits the same index range in no particular order (whole skew lines as
//! row strips), which is what parallel enumeration by index ranges uses.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::triangle::{LatticePoint, MeshIndex, ScanlineLattice, TriangleIndex};

type Tri = [LatticePoint; 3];

/// A fat triangle of roughly `r²` points with generic (seeded) vertices.
fn fat(rng: &mut ChaCha8Rng, r: i64) -> Tri {
    let mut j = || rng.random_range(-r / 20..=r / 20);
    [
        [j(), j()],
        [2 * r + j(), r / 3 + j()],
        [r / 2 + j(), 2 * r + j()],
    ]
}

/// A skinny 45° triangle with long side about `n·√2` and about `m + 2`
/// points: `(ac)` runs along the diagonal with `m + 1` lattice points and
/// `b = (n, n + 1)` makes `|D| = m`.
fn skinny(n: i64, m: i64) -> Tri {
    [[0, 0], [n, n + 1], [m, m]]
}

fn fold(acc: i64, p: LatticePoint) -> i64 {
    acc.wrapping_add(p[0] ^ p[1].rotate_left(7))
}

fn enumeration(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let cases = [
        ("fat_1e4", fat(&mut rng, 70)),
        ("fat_1e6", fat(&mut rng, 700)),
        ("skinny45_1e6_3pts", skinny(1_000_000, 1)),
        ("skinny45_1e6_1e4pts", skinny(1_000_000, 10_000)),
    ];
    let mut g = c.benchmark_group("triangle_enumerate");
    for (name, v) in cases {
        let t = TriangleIndex::new(v).unwrap();
        let s = ScanlineLattice::new(v).unwrap();
        g.throughput(Throughput::Elements(t.len()));
        g.bench_with_input(BenchmarkId::new("indexed", name), &t, |bch, t| {
            bch.iter(|| {
                let mut acc = 0i64;
                black_box(t).for_each_point(|p| acc = fold(acc, p));
                acc
            })
        });
        g.bench_with_input(BenchmarkId::new("indexed_iter", name), &t, |bch, t| {
            bch.iter(|| black_box(t).iter().fold(0i64, fold))
        });
        g.bench_with_input(
            BenchmarkId::new("indexed_range_unordered", name),
            &t,
            |bch, t| {
                bch.iter(|| {
                    let mut acc = 0i64;
                    let t = black_box(t);
                    t.for_each_in_range_unordered(0..t.len(), |p| acc = fold(acc, p));
                    acc
                })
            },
        );
        g.bench_with_input(
            BenchmarkId::new("adaptive_unordered", name),
            &t,
            |bch, t| {
                bch.iter(|| {
                    let mut acc = 0i64;
                    black_box(t).for_each_point_unordered(|p| acc = fold(acc, p));
                    acc
                })
            },
        );
        g.bench_with_input(BenchmarkId::new("scanline", name), &s, |bch, s| {
            bch.iter(|| {
                let mut acc = 0i64;
                black_box(s).for_each(|p| acc = fold(acc, p));
                acc
            })
        });
    }
    g.finish();
}

fn random_access(c: &mut Criterion) {
    let mut g = c.benchmark_group("triangle_point_random_access");
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    const N: usize = 1024;
    for exp in [2u32, 4, 6, 8, 10, 12] {
        // Right-ish generic triangle with about 10^exp points.
        let r = (2.0 * 10f64.powi(exp as i32)).sqrt() as i64;
        let v = [[0, 0], [r + 1, 3], [5, r - 1]];
        let t = TriangleIndex::new(v).unwrap();
        let idx: Vec<u64> = (0..N).map(|_| rng.random_range(0..t.len())).collect();
        let pts: Vec<LatticePoint> = idx.iter().map(|&i| t.point(i).unwrap()).collect();
        g.throughput(Throughput::Elements(N as u64));
        g.bench_with_input(
            BenchmarkId::new("point", format!("1e{exp}")),
            &idx,
            |bch, idx| {
                bch.iter(|| {
                    idx.iter()
                        .fold(0i64, |a, &i| fold(a, black_box(&t).point_unchecked(i)))
                })
            },
        );
        g.bench_with_input(
            BenchmarkId::new("index_of", format!("1e{exp}")),
            &pts,
            |bch, pts| {
                bch.iter(|| {
                    pts.iter().fold(0u64, |a, &p| {
                        a.wrapping_add(black_box(&t).index_of(p).unwrap_or(0))
                    })
                })
            },
        );
    }
    g.finish();
}

fn mesh(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let tris: Vec<Tri> = (0..2000)
        .map(|_| {
            let o = [rng.random_range(-5000..5000), rng.random_range(-5000..5000)];
            let mut p = || {
                [
                    o[0] + rng.random_range(-40..40),
                    o[1] + rng.random_range(-40..40),
                ]
            };
            [p(), p(), p()]
        })
        .collect();
    let m = MeshIndex::new(&tris).unwrap();
    let mut g = c.benchmark_group("triangle_mesh");
    g.throughput(Throughput::Elements(m.len()));
    g.bench_function("sequential", |b| {
        b.iter(|| {
            let mut acc = 0i64;
            black_box(&m).for_each_in_range(0..m.len(), |t, p| acc = fold(acc + t as i64, p));
            acc
        })
    });
    g.bench_function("parallel", |b| {
        b.iter(|| {
            black_box(&m)
                .map_chunks_par(
                    1 << 12,
                    |_| 0i64,
                    |acc, t, p| *acc = fold(*acc + t as i64, p),
                )
                .into_iter()
                .fold(0i64, i64::wrapping_add)
        })
    });
    g.bench_function("parallel_unordered", |b| {
        b.iter(|| {
            let acc = std::sync::atomic::AtomicI64::new(0);
            black_box(&m).for_each_par_unordered(1 << 12, |t, p| {
                if fold(t as i64, p) == i64::MIN {
                    acc.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                }
            });
            acc.into_inner()
        })
    });
    g.finish();
}

criterion_group!(benches, enumeration, random_access, mesh);
criterion_main!(benches);
