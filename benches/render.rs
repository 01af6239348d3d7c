//! The discrete ray caster: ms per 1024×1024 frame for every ray kind, with
//! and without empty-space skipping, on the Stanford bunny voxelized thin at
//! 256³ and 512³, default three-quarter camera, all cores. Before timing,
//! each case prints (to stderr) its differing pixels against the 6-ray
//! image, voxels visited and jumps, so the error stands beside the time.
//!
//! The CT head in MIP, compositing and iso follows (adaptive, skipping).
//!
//! `cargo bench --bench render -- --warm-up-time 1`, then
//! `python3 scripts/criterion_table.py render_bunny256 render_bunny512 render_ct_head`.
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

fn render(c: &mut Criterion) {
    bench_bunny(c, 256);
    bench_bunny(c, 512);
    bench_ct_head(c);
}

criterion_group!(benches, render);
criterion_main!(benches);
