//! The discrete ray caster: ms per 1024×1024 frame for every ray kind, with
//! and without empty-space skipping, on the Stanford bunny voxelized thin at
//! 256³ and 512³, default three-quarter camera, all cores. Before timing,
//! each case prints (to stderr) its differing pixels against the 6-ray
//! image, voxels visited and jumps, so the error stands beside the time.
//!
//! The CT head in MIP, compositing and iso follows (adaptive, skipping), then
//! a 512³ float32 volume in the three modes beside the memory floor timed in
//! the same run (`VOXKIT_BENCH_VOLUME_N` sets another size).
//!
//! `cargo bench --bench render -- --warm-up-time 1`, then
//! `python3 scripts/criterion_table.py render_bunny256 render_bunny512 render_ct_head render_volume512`.
//! VTK's frame on the same inputs: `scripts/compare_render.py`.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use voxkit::camera::SceneAxes;
use voxkit::mesh::Mesh;
use voxkit::render::{
    GridTransform, OccupancyGrid, RayKind, RenderOptions, default_camera, render_grid,
};
use voxkit::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, voxelize_mesh};

fn bench_bunny(c: &mut Criterion, res: u32) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/meshes/obj/stanford-bunny.obj");
    let mesh = Mesh::load(&path).expect("bundled mesh loads");
    let v =
        voxelize_mesh(&mesh, &VoxelizeOptions::new(res, VoxelizeMode::Thin)).expect("voxelizes");
    let occ = OccupancyGrid::new(&v.grid, v.frame.dims, Default::default()).expect("fits");
    let xf = GridTransform::from_frame(&v.frame).expect("frame");
    let cam = default_camera(&occ, &xf, &SceneAxes::Y_UP, 1024, 1024).expect("camera");
    let base = RenderOptions::default();
    let six = render_grid(
        &occ,
        &xf,
        &cam,
        &RenderOptions {
            ray: RayKind::Six,
            ..base
        },
    )
    .expect("renders")
    .0;
    let mut g = c.benchmark_group(format!("render_bunny{res}"));
    g.sample_size(10);
    g.throughput(Throughput::Elements(1024 * 1024));
    for skip in [true, false] {
        for kind in RayKind::ALL {
            let opts = RenderOptions {
                ray: kind,
                skip,
                ..base
            };
            let (img, stats) = render_grid(&occ, &xf, &cam, &opts).expect("renders");
            eprintln!(
                "render_bunny{res} {} skip={skip}: differing pixels {}, voxels visited {}, jumps {}, structures {} bytes",
                kind.name(),
                img.differing_hits(&six),
                stats.voxels_visited,
                stats.bricks_skipped,
                occ.heap_bytes()
            );
            // A no-skip A–W frame of the 512³ bunny takes about two seconds.
            g.measurement_time(Duration::from_secs(if skip { 4 } else { 12 }));
            let id = format!("{}{}", kind.name(), if skip { "" } else { "-noskip" });
            g.bench_with_input(BenchmarkId::new(id, res), &opts, |b, opts| {
                b.iter(|| black_box(render_grid(&occ, &xf, &cam, opts).expect("renders").1.hits))
            });
        }
    }
    g.finish();
}

/// The CT head (64×64×93 int16, spacing 3.2×3.2×1.5) in MIP, compositing
/// and iso (at 1000, bone), adaptive rays with skipping; differing pixels
/// against the 6-ray image printed beside.
fn bench_ct_head(c: &mut Criterion) {
    use voxkit::render::{VolumeMode, VolumeOptions, VolumeScene, differing_values, render_volume};
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/volumes/headsq_quarter/headsq_quarter.nhdr");
    let vol = voxkit::io::volume::read_volume(&path, Default::default()).expect("bundled volume");
    let scene = VolumeScene::new(&vol, Default::default()).expect("fits");
    let xf = *scene.transform();
    let d = vol.dims.map(|x| x as f64);
    let (lo, hi) = xf.world_bounds(glam::DVec3::splat(-0.5), glam::DVec3::from_array(d) - 0.5);
    let (dir, up) = SceneAxes::Z_UP.view(voxkit::camera::ViewPreset::Iso);
    let cam =
        voxkit::camera::Camera::framing(lo, hi, dir, up, Some(35.0), 1024, 1024).expect("camera");
    let opts = RenderOptions::default();
    let mut g = c.benchmark_group("render_ct_head");
    g.sample_size(10);
    g.throughput(Throughput::Elements(1024 * 1024));
    g.measurement_time(Duration::from_secs(6));
    for (name, mode) in [
        ("mip", VolumeMode::Mip),
        ("composite", VolumeMode::Composite),
        ("iso", VolumeMode::Iso(1000.0)),
    ] {
        let vopts = VolumeOptions::new(&vol, mode);
        let six = RenderOptions {
            ray: RayKind::Six,
            ..opts
        };
        let reference = render_volume(&scene, &cam, &six, &vopts)
            .expect("renders")
            .0;
        let (img, stats) = render_volume(&scene, &cam, &opts, &vopts).expect("renders");
        eprintln!(
            "render_ct_head {name} adaptive: differing pixels {}, voxels visited {}, jumps {}, structures {} bytes",
            differing_values(&img, &reference),
            stats.voxels_visited,
            stats.bricks_skipped,
            scene.heap_bytes()
        );
        g.bench_with_input(BenchmarkId::new(name, "adaptive"), &vopts, |b, vopts| {
            b.iter(|| {
                black_box(
                    render_volume(&scene, &cam, &opts, vopts)
                        .expect("renders")
                        .1
                        .hits,
                )
            })
        });
    }
    g.finish();
}

/// A synthetic `n³` float32 volume like simulation output: 12 soft
/// Gaussian blobs inside a spherical shell whose radius is perturbed by
/// waves along each axis, over low-level noise (no brick is empty).
/// Separable terms are tabulated per axis, so a 512³ volume takes seconds.
fn blobs_in_shell(n: usize) -> voxkit::grid::ScalarVolume {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let nf = n as f32;
    let blobs: Vec<([f32; 3], f32, f32)> = (0..12)
        .map(|_| {
            let c = [0; 3].map(|_| rng.random_range(0.2 * nf..0.8 * nf));
            (
                c,
                rng.random_range(12.0..40.0) * nf / 512.0,
                rng.random_range(0.5..1.0),
            )
        })
        .collect();
    let gauss: Vec<[Vec<f32>; 3]> = blobs
        .iter()
        .map(|(c, s, _)| {
            [0, 1, 2].map(|k| {
                (0..n)
                    .map(|i| (-0.5 * ((i as f32 - c[k]) / s).powi(2)).exp())
                    .collect()
            })
        })
        .collect();
    let wave: [Vec<f32>; 3] = [3.0f32, 5.0, 7.0].map(|f| {
        (0..n)
            .map(|i| (std::f32::consts::TAU * f * i as f32 / nf).sin())
            .collect()
    });
    let mut data = vec![0f32; n * n * n];
    use rayon::prelude::*;
    data.par_chunks_mut(n * n)
        .enumerate()
        .for_each(|(z, slice)| {
            let mut h = (z as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
            for y in 0..n {
                for x in 0..n {
                    h ^= h << 13;
                    h ^= h >> 7;
                    h ^= h << 17;
                    let mut v = (h >> 40) as f32 / (1u64 << 24) as f32 * 0.05;
                    for ((_, _, a), g) in blobs.iter().zip(&gauss) {
                        v += a * g[0][x] * g[1][y] * g[2][z];
                    }
                    let p = [x, y, z].map(|i| i as f32 / nf - 0.5);
                    let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    let turb = 0.3 * (wave[0][x] + wave[1][y] + wave[2][z]);
                    v += (-0.5 * ((r - 0.42 - 0.05 * turb) / 0.015).powi(2)).exp();
                    slice[x + n * y] = v;
                }
            }
        });
    voxkit::grid::ScalarVolume::new(
        [n; 3],
        voxkit::grid::VolumeData::F32(data),
        voxkit::grid::VolumeFrame::default(),
    )
    .expect("valid volume")
}

/// A 512³ float32 volume (blobs in a turbulent shell) in MIP, compositing
/// and iso at 1024², default camera, adaptive rays with skipping, beside
/// the memory floor measured in the same run: one parallel pass reading
/// every stored sample ([`voxkit::render::VolumeBricks::max_pass`]). Each
/// frame's median over the floor's median is the figure that holds across
/// machines and days.
fn bench_volume_floor(c: &mut Criterion) {
    use voxkit::render::{VolumeMode, VolumeOptions, VolumeScene, render_volume};
    let n = std::env::var("VOXKIT_BENCH_VOLUME_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(512);
    let vol = blobs_in_shell(n);
    let vopts: Vec<(&str, VolumeOptions)> = [
        ("mip", VolumeMode::Mip),
        ("composite", VolumeMode::Composite),
        ("iso", VolumeMode::Iso(0.6)),
    ]
    .into_iter()
    .map(|(name, m)| (name, VolumeOptions::new(&vol, m)))
    .collect();
    let xf = voxkit::render::GridTransform::new(vol.frame.origin, vol.frame.axes).expect("frame");
    let d = vol.dims.map(|x| x as f64);
    let scene = VolumeScene::from_volume(vol, Default::default()).expect("fits");
    let (lo, hi) = xf.world_bounds(glam::DVec3::splat(-0.5), glam::DVec3::from_array(d) - 0.5);
    let (dir, up) = SceneAxes::Z_UP.view(voxkit::camera::ViewPreset::Iso);
    let cam =
        voxkit::camera::Camera::framing(lo, hi, dir, up, Some(35.0), 1024, 1024).expect("camera");
    let opts = RenderOptions::default();
    let mut g = c.benchmark_group(format!("render_volume{n}"));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(8));
    eprintln!(
        "render_volume{n}: bricks {} bytes (the volume's own {} bytes)",
        scene.heap_bytes(),
        n * n * n * 4
    );
    g.bench_function("floor", |b| b.iter(|| black_box(scene.bricks().max_pass())));
    for (name, vopts) in &vopts {
        g.bench_with_input(BenchmarkId::new(*name, "adaptive"), vopts, |b, vopts| {
            b.iter(|| {
                black_box(
                    render_volume(&scene, &cam, &opts, vopts)
                        .expect("renders")
                        .1
                        .hits,
                )
            })
        });
    }
    // Again after the frames: the two floors bracket them, showing the
    // machine's drift during the run.
    g.bench_function("floor-after", |b| {
        b.iter(|| black_box(scene.bricks().max_pass()))
    });
    g.finish();
}

fn render(c: &mut Criterion) {
    bench_bunny(c, 256);
    bench_bunny(c, 512);
    bench_ct_head(c);
    bench_volume_floor(c);
}

criterion_group!(benches, render);
criterion_main!(benches);
