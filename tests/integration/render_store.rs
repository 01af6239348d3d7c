//! Rendering a Zarr store chunk by chunk ([`PagedOccupancy`]): the flags
//! equal the in-memory grid's and the cloud never exceeds it, every ray kind
//! draws the in-memory picture pixel for pixel, only the chunks the rays
//! reach are decoded (so a store whose in-memory structure is refused by the
//! memory limit still renders), and running out of memory or reading a
//! damaged shard mid-render is an error, never an image.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::scratch::temp_dir;
use glam::{DVec3, IVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::camera::Camera;
use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
use voxkit::io::zarr::{self, ChunkReader};
use voxkit::render::{
    GridTransform, NormalMode, OccupancyGrid, PagedOccupancy, RayKind, RenderBricks, RenderOptions,
    render_grid,
};

/// Scattered voxels, short runs along every axis, a ball (full bricks),
/// voxels on chunk faces (x, y, z ≡ 63, 64 mod 64) and the far corner.
fn scene(rng: &mut ChaCha8Rng, dims: [usize; 3]) -> BrickGrid {
    let c = DVec3::from_array(dims.map(|d| d as f64)) * DVec3::new(0.3, 0.5, 0.5);
    let r2 = (dims.iter().min().copied().unwrap() as f64 * 0.3).powi(2);
    let mut g = BrickGrid::from_x_rows(dims, |v| {
        (0..8).fold(0u8, |r, i| {
            let p = (v + IVec3::new(i, 0, 0)).as_dvec3();
            r | u8::from((p - c).length_squared() <= r2) << i
        })
    });
    let d = IVec3::from_array(dims.map(|d| d as i32));
    let random = |rng: &mut ChaCha8Rng| {
        IVec3::new(
            rng.random_range(0..d.x),
            rng.random_range(0..d.y),
            rng.random_range(0..d.z),
        )
    };
    for _ in 0..400 {
        g.insert(random(rng));
    }
    for _ in 0..60 {
        let mut v = random(rng);
        let axis = rng.random_range(0..3);
        v[axis] = 64 * rng.random_range(0..=(d[axis] - 1) / 64) + rng.random_range(62..66);
        let step = IVec3::AXES[rng.random_range(0..3)];
        for _ in 0..rng.random_range(1..20) {
            if v.cmpge(IVec3::ZERO).all() && v.cmplt(d).all() {
                g.insert(v);
            }
            v += step;
        }
    }
    g.insert(d - 1);
    g
}

fn write_store(dir: &Path, grid: &BrickGrid, frame: &GridFrame) -> PathBuf {
    let path = dir.join("s.zarr");
    zarr::write(&path, grid, frame, true, 1).unwrap();
    path
}

fn open(path: &Path, limit: MemoryLimit) -> PagedOccupancy {
    let reader = ChunkReader::open(path, 0, limit)
        .unwrap()
        .expect("voxkit's own layout");
    PagedOccupancy::new(reader, limit).unwrap()
}

/// Every brick's flags equal the in-memory grid's, every cloud value is at
/// most the in-memory one, and the bounds are the grid's, on grids across a
/// shard face.
#[test]
fn paged_flags_equal_the_in_memory_grids_and_clouds_bound_them() {
    let dir = temp_dir("flags");
    for seed in 0..3u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let dims = [[600, 90, 130], [130, 70, 540], [200, 150, 77]][seed as usize];
        let grid = scene(&mut rng, dims);
        let frame = GridFrame::new(DVec3::ZERO, 1.0, dims);
        let path = write_store(&dir, &grid, &frame);
        let paged = open(&path, MemoryLimit::DEFAULT);
        let occ = OccupancyGrid::new(&grid, dims, MemoryLimit::DEFAULT).unwrap();
        assert_eq!(paged.bounds(), grid.bounds());
        let bd = IVec3::from_array(dims.map(|d| d.div_ceil(8) as i32));
        let mut tighter = 0u64;
        for z in 0..bd.z {
            for y in 0..bd.y {
                for x in 0..bd.x {
                    let b = IVec3::new(x, y, z);
                    let (p, m) = (paged.locate(b), occ.locate(b));
                    assert_eq!(paged.flags(p), occ.flags(m), "seed {seed}, brick {b}");
                    assert!(paged.cloud(p) <= occ.cloud(m), "seed {seed}, brick {b}");
                    tighter += u64::from(occ.cloud(m) - paged.cloud(p));
                }
            }
        }
        // The bound is a bound, not nothing: most bricks keep their value.
        assert!(
            tighter < (bd.x * bd.y * bd.z) as u64 * 8,
            "seed {seed}: {tighter}"
        );
        assert!(paged.health().is_ok());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every ray kind, with and without skipping, smooth and face normals,
/// from outside (perspective and orthographic) and from inside the grid:
/// the paged render equals the in-memory one in hits, colours and depths.
#[test]
fn paged_renders_equal_in_memory_renders() {
    let dir = temp_dir("renders");
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let dims = [560, 100, 120];
    let grid = scene(&mut rng, dims);
    let frame = GridFrame::new(DVec3::new(-3.0, 1.0, 2.0), 0.5, dims);
    let path = write_store(&dir, &grid, &frame);
    let occ = OccupancyGrid::new(&grid, dims, MemoryLimit::DEFAULT).unwrap();
    let xf = GridTransform::from_frame(&frame).unwrap();
    let centre = xf.grid_to_world(DVec3::new(280.0, 50.0, 60.0));
    let cams = [
        Camera::perspective(
            centre + DVec3::new(60.0, 90.0, 200.0),
            centre,
            DVec3::Y,
            40.0,
        ),
        Camera::orthographic(
            centre + DVec3::new(-300.0, 20.0, 5.0),
            centre,
            DVec3::Y,
            160.0,
        ),
        Camera::perspective(
            xf.grid_to_world(DVec3::new(20.0, 50.0, 60.0)),
            centre,
            DVec3::Y,
            70.0,
        ),
    ];
    for (ci, cam) in cams.iter().enumerate() {
        // A fresh store per camera: pages are built by the render itself.
        let paged = open(&path, MemoryLimit::DEFAULT);
        for ray in [
            RayKind::Adaptive,
            RayKind::Six,
            RayKind::TwentySix,
            RayKind::AmanatidesWoo,
        ] {
            for skip in [true, false] {
                for normals in [NormalMode::Smooth, NormalMode::Face] {
                    let opts = RenderOptions {
                        width: 96,
                        height: 64,
                        ray,
                        skip,
                        normals,
                        ..RenderOptions::default()
                    };
                    let (a, _) = render_grid(&paged, &xf, cam, &opts).unwrap();
                    let (b, _) = render_grid(&occ, &xf, cam, &opts).unwrap();
                    let what = format!("camera {ci}, {ray:?}, skip {skip}, {normals:?}");
                    assert!(b.hit.iter().any(|h| h.is_some()), "{what}: sees nothing");
                    assert_eq!(a.hit, b.hit, "{what}");
                    assert_eq!(a.color, b.color, "{what}");
                    assert_eq!(a.depth, b.depth, "{what}");
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A 2048³ store with a screen in front of a larger plate: looking at the
/// screen straight on, the rays never reach the plate, so its chunks are
/// never decoded. The in-memory structure of that store is refused by a
/// 32 MiB limit; the paged one renders within it.
#[test]
fn only_the_chunks_rays_reach_are_decoded() {
    let dir = temp_dir("reach");
    let dims = [2048, 2048, 2048];
    let mut grid = BrickGrid::new();
    for y in 960..1088 {
        for x in 960..1088 {
            grid.insert(IVec3::new(x, y, 1000));
        }
    }
    for y in 512..1536 {
        for x in 512..1536 {
            grid.insert(IVec3::new(x, y, 1800));
        }
    }
    let frame = GridFrame::new(DVec3::ZERO, 1.0, dims);
    let path = write_store(&dir, &grid, &frame);
    let limit = MemoryLimit::new(32 << 20);
    assert!(matches!(
        OccupancyGrid::new(&grid, dims, limit),
        Err(voxkit::VoxkitError::Limits { .. })
    ));
    let paged = open(&path, limit);
    let stored = paged.stored_chunks() as u64;
    let xf = GridTransform::from_frame(&frame).unwrap();
    let cam = Camera::orthographic(
        DVec3::new(1024.0, 1024.0, -100.0),
        DVec3::new(1024.0, 1024.0, 1000.0),
        DVec3::Y,
        100.0,
    );
    let opts = RenderOptions {
        width: 64,
        height: 64,
        limit,
        ..RenderOptions::default()
    };
    let (img, _) = render_grid(&paged, &xf, &cam, &opts).unwrap();
    assert!(img.hit.iter().all(|h| h.is_some_and(|v| v.z == 1000)));
    // The screen spans 2×2 chunks, the plate 16×16. Finding the bounds
    // decoded the outermost layers (the plate's rim and back, the screen)
    // and dropped them: what stays is what the rays reached.
    assert_eq!(stored, 2 * 2 + 16 * 16);
    let decoded = paged.chunks_decoded();
    assert!(decoded <= 4 * 4, "{decoded} of {stored} chunks decoded");
    assert!(paged.heap_bytes() < 32 << 20);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Past the memory limit while rendering, or a shard rewritten under the
/// reader: the render is an error (and stays one), never an image.
#[test]
fn running_out_of_memory_or_data_mid_render_is_an_error() {
    let dir = temp_dir("fail");
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let dims = [300, 200, 200];
    let grid = scene(&mut rng, dims);
    let frame = GridFrame::new(DVec3::ZERO, 1.0, dims);
    let path = write_store(&dir, &grid, &frame);
    let xf = GridTransform::from_frame(&frame).unwrap();
    let cam = Camera::perspective(
        DVec3::new(150.0, 300.0, 500.0),
        DVec3::splat(100.0),
        DVec3::Y,
        45.0,
    );
    let opts = RenderOptions {
        width: 64,
        height: 48,
        ..RenderOptions::default()
    };
    // Enough for the tables and the bounds, not for the pages.
    let tight = MemoryLimit::new(open(&path, MemoryLimit::DEFAULT).heap_bytes() + 4096);
    let paged = open(&path, tight);
    for _ in 0..2 {
        let err = render_grid(&paged, &xf, &cam, &opts).unwrap_err();
        assert!(matches!(err, voxkit::VoxkitError::Limits { .. }), "{err}");
    }
    // A shard cut short after its index was read.
    let paged = open(&path, MemoryLimit::DEFAULT);
    let shard = path.join("0/c/0/0/0");
    let len = std::fs::metadata(&shard).unwrap().len();
    let f = std::fs::OpenOptions::new()
        .write(true)
        .open(&shard)
        .unwrap();
    f.set_len(len / 2).unwrap();
    let err = render_grid(&paged, &xf, &cam, &opts).unwrap_err();
    assert!(err.to_string().contains("damaged shard"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn voxkit(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args(args)
        .output()
        .expect("voxkit runs")
}

/// `voxkit render` on a store draws the binvox file's picture, byte for
/// byte, says what it read, and refuses a limit the rays outgrow in one
/// line with exit code 2 and no file.
#[test]
fn cli_renders_a_store_as_its_binvox_twin() {
    let dir = temp_dir("cli");
    let mesh = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/meshes/obj/spot.obj");
    let mesh = mesh.to_str().unwrap();
    let p = |n: &str| dir.join(n).to_str().unwrap().to_string();
    for out in ["s.zarr", "s.binvox"] {
        let o = voxkit(&["voxelize", mesh, "-r", "160", "-o", &p(out)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    for ray in ["adaptive", "aw"] {
        let mut pngs = Vec::new();
        for input in ["s.zarr", "s.binvox"] {
            let png = p(&format!("{input}-{ray}.png"));
            let o = voxkit(&[
                "render",
                &p(input),
                "-o",
                &png,
                "--size",
                "160x120",
                "--ray",
                ray,
                "--normals",
                "smooth",
                "--json",
            ]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            if input == "s.zarr" {
                let decoded = j["chunks_decoded"].as_u64().unwrap();
                assert!(
                    decoded >= 1 && decoded <= j["stored_chunks"].as_u64().unwrap(),
                    "{j}"
                );
                assert!(j["pages_built"].as_u64().unwrap() >= 1, "{j}");
            }
            pngs.push(std::fs::read(&png).unwrap());
        }
        assert!(pngs[0] == pngs[1], "{ray}: the store's picture differs");
    }
    // Spot at 600: a few MiB of pages for the rays, past a 1 MiB limit.
    let o = voxkit(&["voxelize", mesh, "-r", "600", "-o", &p("big.zarr")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let png = p("small.png");
    let o = voxkit(&[
        "render",
        &p("big.zarr"),
        "-o",
        &png,
        "--size",
        "64x64",
        "--max-memory",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("memory limit"), "{err}");
    assert!(!Path::new(&png).exists());
    let _ = std::fs::remove_dir_all(&dir);
}
