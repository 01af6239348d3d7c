//! Mesh voxelization, every mode at 256, 512 and 1024 on the Stanford bunny
//! (69,451 triangles) and at the same resolutions on Spot (5,856 triangles,
//! closed). The mesh is loaded once; each iteration is one `voxelize_mesh`
//! call (fitting, quantization, the mode's kernel, the brick grid), all cores
//! (rayon's default pool). Throughput is in output voxels.
//!
//! `cargo bench --bench voxelize -- --warm-up-time 1 --measurement-time 3`,
//! then `python3 scripts/criterion_table.py voxelize_bunny voxelize_spot`.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use voxkit::mesh::Mesh;
use voxkit::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, voxelize_mesh};

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

fn voxelize(c: &mut Criterion) {
    bench_mesh(c, "voxelize_bunny", "data/meshes/obj/stanford-bunny.obj");
    bench_mesh(c, "voxelize_spot", "data/meshes/obj/spot.obj");
}

criterion_group!(benches, voxelize);
criterion_main!(benches);
