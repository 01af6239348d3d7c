//! Makes a folder of OBJ meshes for measuring batch voxelization:
//! `cargo run --release --example make_dataset -- OUTDIR N [SEED]`.
//!
//! Each mesh is one of the bundled meshes (data/meshes/obj/) under a random
//! rotation, uniform scale (0.5–2) and translation (±10), refined by 0–2
//! levels of midpoint subdivision (each triangle into four; a level is left
//! out where it would pass 300 000 triangles). Seeded (default seed 1), so
//! the same arguments give the same files.

use std::collections::HashMap;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use voxkit::mesh::Mesh;

/// Subdivision stops before a mesh would pass this many triangles.
const MAX_TRIANGLES: usize = 300_000;

/// One level of midpoint subdivision: every edge's midpoint shared by the
/// triangles on both sides, so a closed mesh stays closed.
fn subdivide(positions: &mut Vec<DVec3>, triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
    let mut mid = |a: u32, b: u32, positions: &mut Vec<DVec3>| {
        *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
            positions.push((positions[a as usize] + positions[b as usize]) * 0.5);
            (positions.len() - 1) as u32
        })
    };
    let mut out = Vec::with_capacity(triangles.len() * 4);
    for &[a, b, c] in triangles {
        let (ab, bc, ca) = (
            mid(a, b, positions),
            mid(b, c, positions),
            mid(c, a, positions),
        );
        out.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    out
}

fn write_obj(path: &Path, positions: &[DVec3], triangles: &[[u32; 3]]) -> std::io::Result<()> {
    let mut w = BufWriter::new(std::fs::File::create(path)?);
    for p in positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for t in triangles {
        writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    w.flush()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(outdir), Some(count)) = (args.first(), args.get(1)) else {
        eprintln!("usage: make_dataset OUTDIR N [SEED]");
        std::process::exit(2);
    };
    let count: usize = count.parse()?;
    let seed: u64 = args.get(2).map_or(Ok(1), |s| s.parse())?;
    let outdir = PathBuf::from(outdir);
    std::fs::create_dir_all(&outdir)?;

    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/meshes/obj");
    let mut sources = Vec::new();
    for name in [
        "spot",
        "stanford-bunny",
        "teapot",
        "fandisk",
        "spot_quadrangulated",
    ] {
        sources.push((name, Mesh::load(&data.join(format!("{name}.obj")))?));
    }
    let mut rng = StdRng::seed_from_u64(seed);
    let mut total_triangles = 0;
    for i in 0..count {
        let (name, mesh) = &sources[rng.random_range(0..sources.len())];
        let axis = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .try_normalize()
        .unwrap_or(DVec3::Z);
        let rotation = DQuat::from_axis_angle(axis, rng.random_range(0.0..std::f64::consts::TAU));
        let scale = rng.random_range(0.5..2.0);
        let shift = DVec3::new(
            rng.random_range(-10.0..10.0),
            rng.random_range(-10.0..10.0),
            rng.random_range(-10.0..10.0),
        );
        let levels = rng.random_range(0..=2u32);
        let mut positions: Vec<DVec3> = mesh
            .positions
            .iter()
            .map(|&p| rotation * (p * scale) + shift)
            .collect();
        let mut triangles = mesh.triangles.clone();
        let mut done = 0;
        while done < levels && triangles.len() * 4 <= MAX_TRIANGLES {
            triangles = subdivide(&mut positions, &triangles);
            done += 1;
        }
        total_triangles += triangles.len();
        write_obj(
            &outdir.join(format!("m{i:04}_{name}_s{done}.obj")),
            &positions,
            &triangles,
        )?;
    }
    println!(
        "{count} meshes, {total_triangles} triangles, in {}",
        outdir.display()
    );
    Ok(())
}
