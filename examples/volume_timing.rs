//! Frame times of the scalar-volume ray caster: a 1024×1024 MIP of a 512³
//! `float32` volume of 12 random Gaussian blobs (sigma 12–40 voxels), per
//! ray kind, with and without skipping.
//!
//! `cargo run --release --example volume_timing [-- SIZE IMAGE FRAMES MODE KINDS LO]`
//! (defaults 512, 1024, 3, mip, all, the default window; MODE: mip,
//! composite or iso; KINDS: a comma-separated subset of 6, 26, adaptive,
//! aw; LO: the window's low end instead of the 1% percentile). Prints one
//! line per kind and skip setting: the median frame time over FRAMES after
//! a warm-up frame, voxels visited and jumps per ray, and the pixels whose
//! colour differs from the 6-ray's without skipping (bit for bit, and by
//! more than half a step of 8-bit grey).

use std::time::Instant;

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use voxkit::camera::{Camera, SceneAxes, ViewPreset};
use voxkit::grid::{MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
use voxkit::render::{
    RayKind, RenderImage, RenderOptions, VolumeMode, VolumeOptions, VolumeScene, differing_values,
    render_volume,
};

/// As the `voxkit` binary: large buffers on transparent huge pages.
#[global_allocator]
static ALLOC: voxkit::alloc::HugePageAlloc = voxkit::alloc::HugePageAlloc;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, d: usize| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(d);
    let (n, size, frames) = (arg(0, 512), arg(1, 1024) as u32, arg(2, 3));
    let mode_name = args.get(3).map_or("mip", String::as_str);

    let t = Instant::now();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(512);
    // Separable blobs: per blob, amplitude and 1-D Gaussian tables per axis.
    let blobs: Vec<(f32, [Vec<f32>; 3])> = (0..12)
        .map(|_| {
            let sigma: f64 = rng.random_range(12.0..40.0);
            let amp: f32 = rng.random_range(0.5..1.0);
            let tables = std::array::from_fn(|_| {
                let c: f64 = rng.random_range(0.0..n as f64);
                (0..n)
                    .map(|i| (-((i as f64 - c).powi(2)) / (2.0 * sigma * sigma)).exp() as f32)
                    .collect()
            });
            (amp, tables)
        })
        .collect();
    let mut data = vec![0f32; n * n * n];
    data.par_chunks_mut(n * n)
        .enumerate()
        .for_each(|(z, slab)| {
            for y in 0..n {
                let w: Vec<f32> = blobs.iter().map(|(a, t)| a * t[1][y] * t[2][z]).collect();
                for x in 0..n {
                    slab[x + n * y] = blobs.iter().zip(&w).map(|((_, t), w)| w * t[0][x]).sum();
                }
            }
        });
    let vol = ScalarVolume::new(
        [n; 3],
        VolumeData::F32(data),
        VolumeFrame::from_spacing(DVec3::ZERO, DVec3::ONE),
    )
    .unwrap();
    let gen_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let mut window = VolumeOptions::default_window(&vol);
    if let Some(lo) = args.get(5).and_then(|s| s.parse::<f32>().ok()) {
        window.0 = lo;
    }
    let window_ms = t.elapsed().as_secs_f64() * 1e3;
    let mode = match mode_name {
        "composite" => VolumeMode::Composite,
        "iso" => VolumeMode::Iso(window.0 + 0.5 * (window.1 - window.0)),
        _ => VolumeMode::Mip,
    };
    let vopts = VolumeOptions {
        window,
        ..VolumeOptions::new(&vol, mode)
    };
    let t = Instant::now();
    let scene = VolumeScene::new(&vol, MemoryLimit::new(8 << 30)).unwrap();
    let scene_ms = t.elapsed().as_secs_f64() * 1e3;
    drop(vol);
    println!(
        "{n}^3 f32, {size}x{size} {mode:?}, window {window:?}; generate {gen_ms:.0} ms, \
         percentiles {window_ms:.0} ms, scene {scene_ms:.0} ms ({} MiB), {} threads",
        scene.heap_bytes() >> 20,
        rayon::current_num_threads()
    );

    let (dir, up) = SceneAxes::Z_UP.view(ViewPreset::Iso);
    let (lo, hi) = scene
        .transform()
        .world_bounds(DVec3::splat(-0.5), DVec3::splat(n as f64 - 0.5));
    let cam = Camera::framing(lo, hi, dir, up, Some(40.0), size, size).unwrap();
    let mut reference = None;
    let kinds = args.get(4).map_or("6,26,adaptive,aw", String::as_str);
    for kind in RayKind::ALL {
        if !kinds.split(',').any(|k| k == kind.name()) {
            continue;
        }
        for skip in [false, true] {
            let opts = RenderOptions {
                width: size,
                height: size,
                ray: kind,
                skip,
                limit: MemoryLimit::new(8 << 30),
                ..RenderOptions::default()
            };
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..frames + 1 {
                let (img, stats) = render_volume(&scene, &cam, &opts, &vopts).unwrap();
                times.push(stats.render_ms);
                last = Some((img, stats));
            }
            times.remove(0); // warm-up
            times.sort_by(f64::total_cmp);
            let (img, stats) = last.unwrap();
            let rays = stats.rays as f64;
            let diff = reference.as_ref().map_or(0, |r| differing_values(r, &img));
            let visible = reference.as_ref().map_or(0, |r: &RenderImage| {
                r.color
                    .iter()
                    .zip(&img.color)
                    .filter(|(a, b)| (0..4).any(|k| (a[k] - b[k]).abs() > 0.5 / 255.0))
                    .count()
            });
            println!(
                "ray {:>8} skip {:<5} {:>8.1} ms/frame (min {:.1})  visited/ray {:>6.1}  jumps/ray {:>5.2}  hits {:>7}  differ from 6: {} ({} visibly)",
                kind.name(),
                skip,
                times[times.len() / 2],
                times[0],
                stats.voxels_visited as f64 / rays,
                stats.bricks_skipped as f64 / rays,
                stats.hits,
                diff,
                visible
            );
            if reference.is_none() {
                reference = Some(img);
            }
        }
    }
}
