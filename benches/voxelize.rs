//! Mesh voxelization, every mode at 256, 512 and 1024 on the Stanford bunny
//! (69,451 triangles) and at the same resolutions on Spot (5,856 triangles,
//! closed). The mesh is loaded once; each iteration is one `voxelize_mesh`
//! call (fitting, quantization, the mode's kernel, the brick grid), all cores
//! (rayon's default pool). Throughput is in output voxels.
//!
//! `voxelize_solid`: solid mode on the bunny as scanned and with its holes
//! closed, per inside test. `voxelize_solid_holed`: solid mode (winding
//! number) at `-r 128` on Spot and the closed bunny with 5, 20 and 40% of
//! their triangles deleted at random (seeded), the holed cases of
//! `scripts/compare_solid.py` (its deletions are drawn by numpy, these by
//! ChaCha8: the same kind of damage, not the same triangles).
//!
//! `cargo bench --bench voxelize -- --warm-up-time 1 --measurement-time 3`,
//! then `python3 scripts/criterion_table.py voxelize_bunny voxelize_spot voxelize_solid
//! voxelize_solid_holed`.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use voxkit::mesh::Mesh;
use voxkit::voxelize::caps::close_holes;
use voxkit::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, voxelize_mesh};
use voxkit::voxelize::solid::InsideTest;

const MODES: [VoxelizeMode; 4] = [
    VoxelizeMode::Thin,
    VoxelizeMode::Thick,
    VoxelizeMode::Conservative,
    VoxelizeMode::Solid,
];

fn bench_mesh(c: &mut Criterion, group: &str, file: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
    let mesh = Mesh::load(&path).expect("bundled mesh loads");
    let mut g = c.benchmark_group(group);
    // One 1024³ conservative or solid run takes about a second: few samples.
    g.sample_size(10);
    for res in [256u32, 512, 1024] {
        for mode in MODES {
            let opts = VoxelizeOptions::new(res, mode);
            let voxels = voxelize_mesh(&mesh, &opts).expect("voxelizes").stats.voxels;
            g.throughput(Throughput::Elements(voxels));
            g.measurement_time(Duration::from_secs(if res >= 1024 { 8 } else { 3 }));
            g.bench_with_input(BenchmarkId::new(mode.name(), res), &opts, |b, opts| {
                b.iter(|| black_box(voxelize_mesh(&mesh, opts).expect("voxelizes").stats.voxels))
            });
        }
    }
    g.finish();
}

/// Solid mode on the bunny as scanned (five holes in its base: the winding
/// number's refinement near them) and with the holes closed by fans (a
/// watertight 69,674-triangle scan: crossings only), by each inside test.
fn bench_solid(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/meshes/obj/stanford-bunny.obj");
    let open = Mesh::load(&path).expect("bundled mesh loads");
    let (positions, triangles) = close_holes(&open.positions, &open.triangles);
    let closed = Mesh::from_parts("bunny, holes closed", positions, triangles, vec![])
        .expect("closed bunny");
    let mut g = c.benchmark_group("voxelize_solid");
    g.sample_size(10);
    for res in [256u32, 512, 1024] {
        for (name, mesh, inside) in [
            ("bunny_winding", &open, InsideTest::Winding),
            ("closed_winding", &closed, InsideTest::Winding),
            ("closed_parity", &closed, InsideTest::Parity),
        ] {
            let mut opts = VoxelizeOptions::new(res, VoxelizeMode::Solid);
            opts.inside = inside;
            let voxels = voxelize_mesh(mesh, &opts).expect("voxelizes").stats.voxels;
            g.throughput(Throughput::Elements(voxels));
            g.measurement_time(Duration::from_secs(if res >= 1024 { 8 } else { 3 }));
            g.bench_with_input(BenchmarkId::new(name, res), &opts, |b, opts| {
                b.iter(|| black_box(voxelize_mesh(mesh, opts).expect("voxelizes").stats.voxels))
            });
        }
    }
    g.finish();
}

/// Solid mode at `-r 128` on closed meshes with a share of their triangles
/// deleted at random: holes everywhere, as in scans and careless exports.
fn bench_solid_holed(c: &mut Criterion) {
    use rand::{Rng, SeedableRng};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bunny = Mesh::load(&root.join("data/meshes/obj/stanford-bunny.obj")).expect("bunny");
    let (positions, triangles) = close_holes(&bunny.positions, &bunny.triangles);
    let bunny = Mesh::from_parts("bunny, holes closed", positions, triangles, vec![])
        .expect("closed bunny");
    let spot = Mesh::load(&root.join("data/meshes/obj/spot.obj")).expect("spot");
    let mut g = c.benchmark_group("voxelize_solid_holed");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(3));
    for (name, closed) in [("spot", &spot), ("bunny", &bunny)] {
        for pct in [5u32, 20, 40] {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(u64::from(pct));
            let mut holed = closed.clone();
            holed.triangles.retain(|_| rng.random_range(0..100) >= pct);
            let opts = VoxelizeOptions::new(128, VoxelizeMode::Solid);
            let voxels = voxelize_mesh(&holed, &opts)
                .expect("voxelizes")
                .stats
                .voxels;
            g.throughput(Throughput::Elements(voxels));
            g.bench_with_input(
                BenchmarkId::new(format!("{name}_{pct}pct"), 128),
                &opts,
                |b, opts| {
                    b.iter(|| {
                        black_box(voxelize_mesh(&holed, opts).expect("voxelizes").stats.voxels)
                    })
                },
            );
        }
    }
    g.finish();
}

fn voxelize(c: &mut Criterion) {
    bench_mesh(c, "voxelize_bunny", "data/meshes/obj/stanford-bunny.obj");
    bench_mesh(c, "voxelize_spot", "data/meshes/obj/spot.obj");
    bench_solid(c);
    bench_solid_holed(c);
}

criterion_group!(benches, voxelize);
criterion_main!(benches);
