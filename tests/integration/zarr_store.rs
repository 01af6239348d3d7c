//! OME-Zarr stores: what voxkit writes decodes, through zarrs' own sharding
//! decoder, to the grid written; levels are max-pooled; metadata names the
//! frame; overwrites and repairs behave.

use std::path::Path;
use std::sync::Arc;

use crate::scratch::temp_dir;
use glam::{DVec3, IVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit};
use voxkit::io::zarr::{self, ShardBox};
use voxkit::io::{read_voxels, write_voxels};

/// A grid with scattered voxels, a solid ball (tiles) and the far corner.
fn sample_grid(rng: &mut ChaCha8Rng, dims: [usize; 3], n: usize) -> BrickGrid {
    let c = DVec3::from_array(dims.map(|d| d as f64)) * 0.4;
    let r2 = (dims.iter().min().copied().unwrap() as f64 * 0.3).powi(2);
    let mut g = BrickGrid::from_x_rows(dims, |v| {
        (0..8).fold(0u8, |r, i| {
            let p = (v + IVec3::new(i, 0, 0)).as_dvec3();
            r | u8::from((p - c).length_squared() <= r2) << i
        })
    });
    for _ in 0..n {
        g.insert(IVec3::new(
            rng.random_range(0..dims[0] as i32),
            rng.random_range(0..dims[1] as i32),
            rng.random_range(0..dims[2] as i32),
        ));
    }
    g.insert(IVec3::new(
        dims[0] as i32 - 1,
        dims[1] as i32 - 1,
        dims[2] as i32 - 1,
    ));
    g
}

/// The whole array of `level` decoded by zarrs (its sharding codec, not
/// voxkit's reader), as the set of nonzero voxels.
fn decode_with_zarrs(path: &Path, level: u32) -> (BrickGrid, Vec<u64>) {
    use zarrs::array::{Array, ArraySubset};
    let store = Arc::new(zarrs::filesystem::FilesystemStore::new(path).unwrap());
    let array = Array::open(store, &format!("/{level}")).unwrap();
    let shape = array.shape().to_vec();
    let subset = ArraySubset::new_with_shape(shape.clone());
    let data: Vec<u8> = array.retrieve_array_subset(&subset).unwrap();
    let mut g = BrickGrid::new();
    let (nz, ny, nx) = (shape[0] as usize, shape[1] as usize, shape[2] as usize);
    assert_eq!(data.len(), nx * ny * nz);
    for (i, &b) in data.iter().enumerate() {
        assert!(b <= 1, "uint8 0/1");
        if b == 1 {
            let (x, y, z) = (i % nx, i / nx % ny, i / nx / ny);
            g.insert(IVec3::new(x as i32, y as i32, z as i32));
        }
    }
    (g, shape)
}

/// Level `l` by brute force: voxel `v >> l` for every voxel `v`.
fn pooled(g: &BrickGrid, l: u32) -> BrickGrid {
    g.iter().map(|v| v >> l as i32).collect()
}

#[test]
fn stores_decode_in_zarrs_to_the_grid_written_with_every_level_pooled() {
    let dir = temp_dir("decode");
    let mut rng = ChaCha8Rng::seed_from_u64(0x2A77);
    // Across a shard boundary (513 in y), odd extents, one voxel.
    for dims in [[1, 1, 1], [70, 513, 9], [130, 66, 200]] {
        let grid = sample_grid(&mut rng, dims, 3_000);
        let frame = GridFrame::new(DVec3::new(-1.5, 0.25, 3.0), 0.125, dims);
        let path = dir.join("s.zarr");
        let levels = zarr::pyramid_levels(dims);
        zarr::write(&path, &grid, &frame, true, levels).unwrap();
        for l in 0..levels {
            let (g, shape) = decode_with_zarrs(&path, l);
            let lf = zarr::level_frame(&frame, l);
            assert_eq!(
                shape,
                vec![lf.dims[2] as u64, lf.dims[1] as u64, lf.dims[0] as u64]
            );
            assert_eq!(g, pooled(&grid, l), "{dims:?} level {l}");
            let (back, f) = zarr::read_level(&path, l, MemoryLimit::DEFAULT).unwrap();
            assert_eq!(back, g, "voxkit's reader, {dims:?} level {l}");
            assert_eq!(f, lf);
        }
        let (back, f) = read_voxels(&path, MemoryLimit::DEFAULT).unwrap();
        assert_eq!((back, f), (grid, frame));
    }
}

#[test]
fn metadata_is_ome_zarr_0_5_with_centres_and_the_voxkit_frame() {
    let dir = temp_dir("meta");
    let dims = [100, 40, 600];
    let frame = GridFrame::new(DVec3::new(1.0, -2.0, 0.5), 0.25, dims);
    let grid: BrickGrid = [IVec3::new(3, 4, 599)].into_iter().collect();
    let path = dir.join("m.zarr");
    let levels = zarr::pyramid_levels(dims);
    assert_eq!(levels, 5, "600 → 300 → 150 → 75 → 38");
    zarr::write(&path, &grid, &frame, false, levels).unwrap();
    let group: serde_json::Value =
        serde_json::from_slice(&std::fs::read(path.join("zarr.json")).unwrap()).unwrap();
    assert_eq!(group["zarr_format"], 3);
    assert_eq!(group["node_type"], "group");
    let ome = &group["attributes"]["ome"];
    assert_eq!(ome["version"], "0.5");
    let ms = &ome["multiscales"][0];
    let axes: Vec<&str> = ms["axes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["name"].as_str().unwrap())
        .collect();
    assert_eq!(axes, ["z", "y", "x"]);
    for l in 0..levels {
        let ds = &ms["datasets"][l as usize];
        assert_eq!(ds["path"], l.to_string());
        let h = 0.25 * f64::from(1u32 << l);
        let t = &ds["coordinateTransformations"];
        assert_eq!(t[0]["scale"], serde_json::json!([h, h, h]));
        let c = frame.origin + DVec3::splat(h / 2.0);
        assert_eq!(t[1]["translation"], serde_json::json!([c.z, c.y, c.x]));
    }
    let vk = &group["attributes"]["voxkit"];
    assert_eq!(vk["dims"], serde_json::json!(dims));
    assert_eq!(vk["origin"], serde_json::json!([1.0, -2.0, 0.5]));
    let array: serde_json::Value =
        serde_json::from_slice(&std::fs::read(path.join("0/zarr.json")).unwrap()).unwrap();
    assert_eq!(array["data_type"], "uint8");
    assert_eq!(array["shape"], serde_json::json!([600, 40, 100]));
    assert_eq!(array["dimension_names"], serde_json::json!(["z", "y", "x"]));
    assert_eq!(
        array["chunk_grid"]["configuration"]["chunk_shape"],
        serde_json::json!([512, 512, 512])
    );
    let shard = &array["codecs"][0];
    assert_eq!(shard["name"], "sharding_indexed");
    assert_eq!(
        shard["configuration"]["chunk_shape"],
        serde_json::json!([64, 64, 64])
    );
    let inner: Vec<&str> = shard["configuration"]["codecs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    assert_eq!(inner, ["bytes", "zstd"]);
    assert_eq!(
        shard["configuration"]["codecs"][1]["configuration"]["level"],
        3
    );
    let index: Vec<&str> = shard["configuration"]["index_codecs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    assert_eq!(index, ["bytes", "crc32c"]);
    // Only the shard holding the voxel exists: (z 599 → shard 1).
    assert!(path.join("0/c/1/0/0").is_file());
    assert!(!path.join("0/c/0/0/0").exists());
}

#[test]
fn overwrites_replace_stores_only() {
    let dir = temp_dir("over");
    let frame = GridFrame::new(DVec3::ZERO, 1.0, [10, 10, 10]);
    let a: BrickGrid = [IVec3::new(1, 2, 3)].into_iter().collect();
    let b: BrickGrid = [IVec3::new(9, 9, 9)].into_iter().collect();
    let path = dir.join("o.zarr");
    write_voxels(&path, &a, &frame, false).unwrap();
    assert!(
        write_voxels(&path, &b, &frame, false).is_err(),
        "no overwrite"
    );
    write_voxels(&path, &b, &frame, true).unwrap();
    assert_eq!(read_voxels(&path, MemoryLimit::DEFAULT).unwrap().0, b);
    // A directory that is not a store is never replaced.
    let other = dir.join("keep.zarr");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("precious.txt"), b"x").unwrap();
    let err = write_voxels(&other, &a, &frame, true).unwrap_err();
    assert!(err.to_string().contains("not a Zarr store"), "{err}");
    assert!(other.join("precious.txt").is_file());
    // Nothing temporary is left beside the stores.
    let left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
}

#[test]
fn rewriting_a_box_of_shards_repairs_torn_and_stale_shards() {
    let dir = temp_dir("repair");
    let mut rng = ChaCha8Rng::seed_from_u64(0x7EA2);
    let dims = [1100, 600, 70];
    let grid = sample_grid(&mut rng, dims, 20_000);
    let frame = GridFrame::new(DVec3::ZERO, 1.0, dims);
    let path = dir.join("r.zarr");
    zarr::write(&path, &grid, &frame, false, 1).unwrap();
    // Tear shard (0,0,0), and leave a stale shard in an empty place.
    let torn = path.join("0/c/0/0/0");
    let bytes = std::fs::read(&torn).unwrap();
    std::fs::write(&torn, &bytes[..bytes.len() / 3]).unwrap();
    assert!(
        zarr::read(&path, MemoryLimit::DEFAULT).is_err(),
        "torn shard read"
    );
    let all = ShardBox {
        min: IVec3::ZERO,
        max: IVec3::new(3, 2, 1),
    };
    // Re-running the box from a grid holding only the box's voxels.
    zarr::write_shards(&path, 0, &grid, Some(all)).unwrap();
    assert_eq!(zarr::read(&path, MemoryLimit::DEFAULT).unwrap().0, grid);
    // A box's shard with no voxel is removed.
    let fewer: BrickGrid = grid.iter().filter(|v| v.x < 512).collect();
    let right = ShardBox {
        min: IVec3::new(1, 0, 0),
        max: IVec3::new(3, 2, 1),
    };
    zarr::write_shards(&path, 0, &fewer, Some(right)).unwrap();
    assert!(!path.join("0/c/0/0/1").exists() && !path.join("0/c/0/1/2").exists());
    assert_eq!(zarr::read(&path, MemoryLimit::DEFAULT).unwrap().0, fewer);
}

/// The reader charges what the store holds, not its box: a few voxels in a
/// 16384³ store read under a 16 MiB limit; a store holding more than the
/// limit is refused with the limit's error.
#[test]
fn reading_a_sparse_store_is_charged_by_its_bricks() {
    let dir = temp_dir("sparse-cap");
    let dims = [16384, 16384, 16384];
    let grid: BrickGrid = [
        IVec3::new(0, 0, 0),
        IVec3::new(16383, 9000, 3),
        IVec3::new(5000, 5, 16383),
    ]
    .into_iter()
    .collect();
    let frame = GridFrame::new(DVec3::ZERO, 1.0, dims);
    let path = dir.join("big.zarr");
    zarr::write(&path, &grid, &frame, false, 1).unwrap();
    let small = MemoryLimit::new(16 << 20);
    assert_eq!(zarr::read(&path, small).unwrap().0, grid);
    // 40,000 bricks (about 3.7 MiB at 96 bytes each) against a 1 MiB limit.
    let many: BrickGrid = (0..40_000)
        .map(|i| IVec3::new(8 * (i % 200), 8 * (i / 200), 0))
        .collect();
    zarr::write(&path, &many, &frame, true, 1).unwrap();
    let err = zarr::read(&path, MemoryLimit::new(1 << 20)).unwrap_err();
    assert!(matches!(err, voxkit::VoxkitError::Limits { .. }), "{err}");
    assert_eq!(zarr::read(&path, small).unwrap().0, many);
    let _ = std::fs::remove_dir_all(&dir);
}
