//! `voxkit demo` end to end: it runs from any directory (the mesh is
//! embedded), prints both tables and writes its files.

use crate::scratch::temp_dir;
use std::process::Command;

#[test]
fn demo_prints_tables_and_writes_files() {
    let dir = temp_dir("demo-test");
    let out = Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args([
            "demo",
            "--segments",
            "300",
            "--resolution",
            "48",
            "--size",
            "96",
        ])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    for row in [
        "| 26-line |",
        "| tripod 6-line |",
        "| Amanatides-Woo |",
        "| thin |",
        "| thick |",
        "| solid |",
        "| adaptive |",
    ] {
        assert!(text.contains(row), "missing {row} in:\n{text}");
    }
    // The tripod line's containment column is exact: every judged line covers its segment.
    let tripod = text
        .lines()
        .find(|l| l.starts_with("| tripod 6-line |"))
        .unwrap();
    assert_eq!(
        tripod.split('|').nth(6).unwrap().trim(),
        "100.0%",
        "{tripod}"
    );
    // The conservative row has no missing or extra voxels against the exact reference.
    let cons = text
        .lines()
        .find(|l| l.starts_with("| conservative |"))
        .unwrap();
    let cells: Vec<&str> = cons.split('|').map(str::trim).collect();
    assert_eq!((cells[4], cells[5]), ("0", "0"), "{cons}");
    let (grid, _) = voxkit::io::read_voxels(
        &dir.join("out/spot_thin.binvox"),
        voxkit::grid::MemoryLimit::DEFAULT,
    )
    .unwrap();
    assert!(grid.count() > 0);
    for mode in ["thin", "thick", "conservative", "solid"] {
        let (g, _) = voxkit::io::read_voxels(
            &dir.join(format!("out/spot_{mode}.binvox")),
            voxkit::grid::MemoryLimit::DEFAULT,
        )
        .unwrap();
        assert!(g.count() >= grid.count(), "{mode}");
    }
    for png in [
        "spot_mesh",
        "spot_ray_6",
        "spot_ray_26",
        "spot_ray_adaptive",
        "spot_ray_aw",
    ] {
        let bytes = std::fs::read(dir.join(format!("out/{png}.png"))).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{png}");
    }
    let exr = voxkit::io::image::read_exr(&dir.join("out/spot_ray_adaptive.exr")).unwrap();
    assert_eq!((exr.width, exr.height), (96, 96));
    // The adaptive ray's first hits are the 6-ray's on every pixel.
    let adaptive = text
        .lines()
        .find(|l| l.starts_with("| adaptive |"))
        .unwrap();
    assert_eq!(
        adaptive.split('|').nth(5).unwrap().trim(),
        "0",
        "{adaptive}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
