//! `voxkit report --quick` end to end: one Markdown file whose tables have
//! every algorithm, mode and ray kind, finite numbers, the exact rows that
//! must be exact, and SVG plots that exist and hold data; bad `-o` is exit 2.

use crate::scratch::temp_dir;
use std::path::Path;
use std::process::Command;

fn voxkit(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args(args)
        .output()
        .unwrap()
}

/// The rows (cells trimmed) of the table whose header starts with `header`.
fn table(md: &str, header: &str) -> Vec<Vec<String>> {
    let mut lines = md.lines().skip_while(|l| !l.starts_with(header));
    let head = lines.next().unwrap_or_else(|| panic!("no table {header}"));
    let width = head.matches('|').count();
    assert!(lines.next().unwrap().starts_with("|---"), "{header}");
    lines
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            assert_eq!(l.matches('|').count(), width, "ragged row {l}");
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_string())
                .collect()
        })
        .collect()
}

fn rows_named<'a>(rows: &'a [Vec<String>], first: &str) -> Vec<&'a Vec<String>> {
    rows.iter().filter(|r| r[0] == first).collect()
}

/// A number cell ("12.5", "3.0%", "1.93×") as f64; panics if it is not one.
fn number(cell: &str) -> f64 {
    let t = cell.trim_end_matches(['%', '×']).replace("**", "");
    t.parse::<f64>()
        .unwrap_or_else(|_| panic!("not a number: {cell:?}"))
}

fn check_svg(path: &Path) {
    let svg = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let start = svg.trim_start();
    assert!(
        start.starts_with("<svg") || start.starts_with("<?xml"),
        "{}",
        path.display()
    );
    assert!(
        svg.trim_end().ends_with("</svg>"),
        "{} truncated",
        path.display()
    );
    assert!(
        svg.contains("<circle"),
        "{} has no data points",
        path.display()
    );
    assert!(!svg.contains("NaN"), "{}", path.display());
}

#[test]
fn quick_report_has_every_table_row_and_plot() {
    let dir = temp_dir("report-test");
    let md_path = dir.join("r.md");
    let out = voxkit(&["report", "--quick", "-q", "-o", md_path.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let md = std::fs::read_to_string(&md_path).unwrap();
    // No measurement is NaN or infinite (the stability section's texts name
    // NaN and ∞ inputs, so only what comes before it is searched).
    let measured = md.split("## Numerical stability").next().unwrap();
    for word in ["NaN", "| inf", "inf |"] {
        assert!(!measured.contains(word), "{word} in the report");
    }
    for section in [
        "## Machine",
        "## Lines",
        "## Triangle indexing",
        "## Voxelization",
        "## Rendering",
        "## Numerical stability",
    ] {
        assert!(md.contains(section), "missing {section}");
    }

    // Numerical stability: one row per case of the suite, every one passing.
    // (Its texts may hold escaped `\|`, so rows are read whole here.)
    let stability: Vec<&str> = md
        .lines()
        .skip_while(|l| !l.starts_with("| area | case | tier | verdict |"))
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .collect();
    assert_eq!(stability.len(), voxkit::stability::cases().len());
    for row in &stability {
        assert!(row.contains(" | quick | pass | "), "{row}");
    }

    // Lines: every algorithm; the exact lines are connected, touch only
    // touched voxels, and the tripod covers every segment.
    let lines = table(&md, "| algorithm | voxels/line | M voxels/s |");
    for name in [
        "26-line",
        "18-line",
        "tripod 6-line",
        "Amanatides-Woo",
        "adaptive 26/6",
    ] {
        let r = rows_named(&lines, name);
        assert_eq!(r.len(), 1, "{name}");
        for cell in &r[0][1..] {
            assert!(number(cell).is_finite(), "{name}: {cell}");
        }
        assert_eq!(r[0][8], "100.0%", "{name} connected");
        assert!(number(&r[0][6]) <= 0.867, "{name} max distance {}", r[0][6]);
    }
    assert_eq!(rows_named(&lines, "tripod 6-line")[0][5], "0.00%");
    let long = table(&md, "| voxels/ray | rays |");
    assert_eq!(long.len(), 3);
    for r in &long {
        assert!(number(&r[0]) > 500.0 && number(&r[2]) <= 100.0, "{r:?}");
    }

    // Triangles: both shapes, both enumerations agree on the points.
    let tri = table(&md, "| shape | extent | points |");
    assert_eq!(rows_named(&tri, "fat").len(), 3);
    assert_eq!(rows_named(&tri, "skinny 45°").len(), 3);
    assert!(tri.iter().all(|r| r[8] == "yes"), "{tri:?}");

    // Voxelization: every mesh × mode × snap × resolution; the exact
    // conservative set has no missing or extra voxels; thin is 6-tunnel-free on Spot.
    let vox = table(&md, "| mesh | mode | snap | -r |");
    assert_eq!(vox.len(), 2 * 4 * 2 * 2);
    for mesh in ["stanford-bunny.obj", "spot.obj"] {
        for mode in ["thin", "thick", "conservative", "solid"] {
            for snap in ["no", "yes"] {
                for res in ["64", "128"] {
                    let n = vox
                        .iter()
                        .filter(|r| r[0] == mesh && r[1] == mode && r[2] == snap && r[3] == res)
                        .count();
                    assert_eq!(n, 1, "{mesh} {mode} {snap} {res}");
                }
            }
        }
    }
    for r in &vox {
        for cell in &r[4..13] {
            assert!(number(cell).is_finite(), "{r:?}");
        }
        if r[1] == "conservative" && r[2] == "no" {
            assert_eq!((r[8].as_str(), r[9].as_str()), ("0", "0"), "{r:?}");
        }
        if r[0] == "spot.obj" && r[1] == "thin" {
            assert_eq!(r[13], "no", "{r:?}");
        }
    }
    for mesh in ["spot.obj", "stanford-bunny.obj"] {
        assert_eq!(
            md.matches(&format!("**Pareto front, {mesh}**")).count(),
            2,
            "{mesh}"
        );
    }

    // Rendering: every ray kind with and without skipping; the 6-ray is the
    // reference; skipping never changes a pixel's hit.
    let render = table(&md, "| ray | skipping | ms/frame |");
    assert_eq!(render.len(), 8);
    for kind in ["6", "26", "adaptive", "aw"] {
        let r = rows_named(&render, kind);
        assert_eq!(r.len(), 2, "{kind}: {render:?}");
        assert_eq!(r[0][4], r[1][4], "{kind}: skipping changed hits");
        assert!(number(&r[0][2]) > 0.0);
    }
    assert_eq!(rows_named(&render, "6")[0][4], "0");
    assert_eq!(rows_named(&render, "adaptive")[0][4], "0");
    let mesh_err = table(&md, "| -r | ms/frame | pixels both hit |");
    assert_eq!(mesh_err.len(), 3);
    for r in &mesh_err {
        assert!(number(&r[2]) > 0.0, "{r:?}");
        for cell in r {
            assert!(number(cell).is_finite(), "{r:?}");
        }
    }

    // Plots: every linked SVG exists and holds data; at least one per area.
    let links: Vec<&str> = md
        .lines()
        .filter(|l| l.starts_with("!["))
        .map(|l| l.rsplit_once("](").unwrap().1.trim_end_matches(')'))
        .collect();
    assert!(links.len() >= 6, "{links:?}");
    for l in &links {
        assert!(l.starts_with("r/"), "{l}");
        check_svg(&dir.join(l));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_output_paths_exit_2() {
    let dir = temp_dir("report-bad-o");
    // A directory.
    let out = voxkit(&["report", "--quick", "-o", dir.to_str().unwrap()]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("directory"));
    // Under a regular file: no directory can be made there.
    let file = dir.join("file.txt");
    std::fs::write(&file, "x").unwrap();
    let out = voxkit(&[
        "report",
        "--quick",
        "-o",
        file.join("r.md").to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
    let _ = std::fs::remove_dir_all(&dir);
}
