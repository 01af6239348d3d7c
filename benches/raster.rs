//! Rasterization benches: point-in-triangle tests/s (batched SoA kernels
//! against the scalar loop, f32 and i32) and fill rate (pixels/s) for the
//! edge-function and scanline rasterizers on small and large triangles.
//! Fixed seeds; every result is consumed.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::triangle::{
    FixedTriangle, Framebuffer, InsideF32, InsideI32, fill_triangle_edge, fill_triangle_scanline,
};

const POINTS: usize = 1 << 16;

fn point_in_triangle(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let xs: Vec<f32> = (0..POINTS).map(|_| rng.random_range(0.0..100.0)).collect();
    let ys: Vec<f32> = (0..POINTS).map(|_| rng.random_range(0.0..100.0)).collect();
    let xi: Vec<i32> = xs.iter().map(|&x| x as i32).collect();
    let yi: Vec<i32> = ys.iter().map(|&y| y as i32).collect();
    let tf = InsideF32::new([[10.0, 5.0], [90.0, 30.0], [35.0, 95.0]]).unwrap();
    let ti = InsideI32::new([[10, 5], [90, 30], [35, 95]]).unwrap();
    let mut mask = vec![0u8; POINTS];
    let mut g = c.benchmark_group("point_in_triangle");
    g.throughput(Throughput::Elements(POINTS as u64));
    g.bench_function("f32_scalar", |b| {
        b.iter(|| tf.count_scalar(black_box(&xs), black_box(&ys)).unwrap())
    });
    g.bench_function("f32_batched_count", |b| {
        b.iter(|| tf.count(black_box(&xs), black_box(&ys)).unwrap())
    });
    g.bench_function("f32_batched_mask", |b| {
        b.iter(|| {
            let n = tf.mask(black_box(&xs), black_box(&ys), &mut mask).unwrap();
            black_box(&mask);
            n
        })
    });
    g.bench_function("i32_scalar", |b| {
        b.iter(|| ti.count_scalar(black_box(&xi), black_box(&yi)).unwrap())
    });
    g.bench_function("i32_batched_count", |b| {
        b.iter(|| ti.count(black_box(&xi), black_box(&yi)).unwrap())
    });
    g.bench_function("i32_batched_mask", |b| {
        b.iter(|| {
            let n = ti.mask(black_box(&xi), black_box(&yi), &mut mask).unwrap();
            black_box(&mask);
            n
        })
    });
    g.finish();
}

/// Random triangles with vertices in a `size`-pixel box inside a 1024²
/// framebuffer, and their total pixel count (for the throughput).
fn triangles(seed: u64, size: f32, n: usize) -> (Vec<FixedTriangle>, u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut fb = Framebuffer::new(1024, 1024, 0u8).unwrap();
    let tris: Vec<FixedTriangle> = (0..n)
        .map(|_| {
            let (ox, oy) = (
                rng.random_range(0.0..1024.0 - size),
                rng.random_range(0.0..1024.0 - size),
            );
            let mut p = || {
                [
                    ox + rng.random_range(0.0..size),
                    oy + rng.random_range(0.0..size),
                ]
            };
            FixedTriangle::from_pixels([p(), p(), p()]).unwrap()
        })
        .collect();
    let pixels = tris
        .iter()
        .map(|t| fill_triangle_edge(&mut fb, t, 1) as u64)
        .sum();
    (tris, pixels)
}

fn fill_rate(c: &mut Criterion) {
    let mut fb = Framebuffer::new(1024, 1024, 0u32).unwrap();
    for (name, size, n) in [("small_8px", 8.0, 4096), ("large_600px", 600.0, 16)] {
        let (tris, pixels) = triangles(7, size, n);
        let mut g = c.benchmark_group(format!("fill_{name}"));
        g.throughput(Throughput::Elements(pixels));
        g.bench_function("edge_functions", |b| {
            b.iter(|| {
                let mut n = 0;
                for (i, t) in tris.iter().enumerate() {
                    n += fill_triangle_edge(&mut fb, black_box(t), i as u32);
                }
                black_box(fb.pixels()[0]);
                n
            })
        });
        g.bench_function("scanline", |b| {
            b.iter(|| {
                let mut n = 0;
                for (i, t) in tris.iter().enumerate() {
                    n += fill_triangle_scanline(&mut fb, black_box(t), i as u32);
                }
                black_box(fb.pixels()[0]);
                n
            })
        });
        g.finish();
    }
}

criterion_group!(benches, point_in_triangle, fill_rate);
criterion_main!(benches);
