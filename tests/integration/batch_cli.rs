//! `voxkit voxelize DIR|GLOB… -o OUTDIR` (batch mode) end to end: every good
//! mesh's output is byte-identical to the single-mesh CLI's, every bad one is
//! reported and skipped (exit 2), nothing partial is left, reruns skip
//! existing outputs, collisions are refused, and a shared lattice is shared.

use crate::scratch::{Scratch, temp_dir as tmp};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn voxkit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxkit"))
        .args(args)
        .output()
        .expect("voxkit runs")
}

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The JSON lines of stdout.
fn json_lines(o: &Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// Every file below `dir`, relative to it.
fn files_below(dir: &Path) -> BTreeSet<PathBuf> {
    let mut found = BTreeSet::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                found.insert(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    found
}

/// Deterministic junk bytes.
fn junk(n: usize, seed: u64) -> Vec<u8> {
    let mut x = seed | 1;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x as u8
        })
        .collect()
}

/// A dataset folder: good meshes (relative paths) and broken ones, plus a
/// non-mesh file and a directory named like a mesh, which must be ignored.
struct Dataset {
    /// The scratch folder holding `dir` (and the tests' outputs beside
    /// it), removed with the dataset.
    _root: Scratch,
    dir: PathBuf,
    good: Vec<&'static str>,
    bad: Vec<&'static str>,
}

fn dataset(tag: &str) -> Dataset {
    let root = tmp(tag);
    let dir = root.join("in");
    let put = |rel: &str, bytes: &[u8]| {
        let p = dir.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    };
    let read = |p: &str| std::fs::read(data(p)).unwrap();
    let mut good = Vec::new();
    for name in [
        "fandisk.obj",
        "spot.obj",
        "spot_quadrangulated.obj",
        "stanford-bunny.obj",
        "teapot.obj",
    ] {
        put(name, &read(&format!("data/meshes/obj/{name}")));
    }
    good.extend([
        "fandisk.obj",
        "spot.obj",
        "spot_quadrangulated.obj",
        "stanford-bunny.obj",
        "teapot.obj",
    ]);
    // Equal names in sub-folders, an upper-case extension, the glTF.
    put("sub/deeper/spot.obj", &read("data/meshes/obj/teapot.obj"));
    put("sub/SPOT.OBJ", &read("data/meshes/obj/spot.obj"));
    put(
        "sub/BoxTextured.glb",
        &read("data/meshes/gltf/BoxTextured.glb"),
    );
    good.extend(["sub/deeper/spot.obj", "sub/SPOT.OBJ", "sub/BoxTextured.glb"]);

    let teapot = read("data/meshes/obj/teapot.obj");
    // Cut inside the 50th vertex line, after its first coordinate.
    let cut = teapot
        .windows(3)
        .enumerate()
        .filter(|(_, w)| w == b"\nv ")
        .nth(50)
        .map(|(i, _)| i + 5)
        .unwrap();
    put("broken/truncated.obj", &teapot[..cut]);
    let mut glb = b"glTF\x02\x00\x00\x00\x00\x01\x00\x00".to_vec();
    glb.extend(junk(244, 7));
    put("broken/garbage.glb", &glb);
    put("broken/empty.obj", b"");
    put(
        "broken/nan.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 NaN 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n",
    );
    put(
        "broken/past_the_end.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n",
    );
    put("broken/junk.ply", &junk(500, 11));
    let bad = vec![
        "broken/empty.obj",
        "broken/garbage.glb",
        "broken/junk.ply",
        "broken/nan.obj",
        "broken/past_the_end.obj",
        "broken/truncated.obj",
    ];
    // Ignored: not a mesh extension; a directory named like a mesh.
    put("notes.txt", b"not a mesh");
    put("x.obj/readme.md", b"a directory named x.obj");
    Dataset {
        _root: root,
        dir,
        good,
        bad,
    }
}

fn binvox_of(rel: &str) -> PathBuf {
    Path::new(rel).with_extension("binvox")
}

/// The single-mesh CLI's output bytes and JSON for `mesh` with `opts`.
fn single(mesh: &Path, opts: &[&str], out: &Path) -> (Vec<u8>, serde_json::Value) {
    let mut args = vec!["voxelize", s(mesh), "-o", s(out), "--json", "--force"];
    args.extend(opts);
    let o = voxkit(&args);
    assert!(o.status.success(), "{}: {}", mesh.display(), stderr(&o));
    let j = serde_json::from_slice(&o.stdout).unwrap();
    (std::fs::read(out).unwrap(), j)
}

#[test]
fn batch_outputs_equal_single_runs_and_bad_meshes_are_reported_and_skipped() {
    let ds = dataset("main");
    let root = ds.dir.parent().unwrap().to_path_buf();
    let out = root.join("out");
    let opts = ["-r", "40", "--mode", "thick"];
    let mut args = vec!["voxelize", s(&ds.dir), "-o", s(&out), "--json"];
    args.extend(opts);
    let o = voxkit(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    let lines = json_lines(&o);
    assert_eq!(lines.len(), ds.good.len() + ds.bad.len() + 1);
    let summary = lines.last().unwrap();
    assert_eq!(summary["summary"], true);
    assert_eq!(summary["total"], ds.good.len() + ds.bad.len());
    assert_eq!(summary["done"], ds.good.len());
    assert_eq!(summary["failed"], ds.bad.len());
    assert_eq!(summary["skipped"], 0);
    let by_mesh: BTreeMap<PathBuf, &serde_json::Value> = lines[..lines.len() - 1]
        .iter()
        .map(|j| (PathBuf::from(j["mesh"].as_str().unwrap()), j))
        .collect();
    // One line per mesh, in sorted order of the inputs.
    let order: Vec<PathBuf> = lines[..lines.len() - 1]
        .iter()
        .map(|j| PathBuf::from(j["mesh"].as_str().unwrap()))
        .collect();
    let mut sorted = order.clone();
    sorted.sort();
    assert_eq!(order, sorted);
    assert_eq!(by_mesh.len(), order.len());

    let single_dir = root.join("single");
    std::fs::create_dir_all(&single_dir).unwrap();
    for (i, rel) in ds.good.iter().enumerate() {
        let mesh = ds.dir.join(rel);
        let j = by_mesh
            .get(&mesh)
            .unwrap_or_else(|| panic!("{rel}: no line"));
        assert_eq!(j["status"], "ok", "{rel}: {j}");
        let expected_out = out.join(binvox_of(rel));
        assert_eq!(j["output"], s(&expected_out), "{rel}");
        let (bytes, single_json) = single(&mesh, &opts, &single_dir.join(format!("{i}.binvox")));
        assert!(
            std::fs::read(&expected_out).unwrap() == bytes,
            "{rel}: batch output differs from the single run's"
        );
        // The single-mesh keys plus `status`; the same voxels and frame.
        let keys = |v: &serde_json::Value| -> BTreeSet<String> {
            v.as_object().unwrap().keys().cloned().collect()
        };
        let mut want = keys(&single_json);
        want.insert("status".into());
        assert_eq!(keys(j), want, "{rel}");
        for k in [
            "voxels",
            "dims",
            "origin",
            "voxel_size",
            "triangles",
            "mode",
        ] {
            assert_eq!(j[k], single_json[k], "{rel} {k}");
        }
    }
    for rel in &ds.bad {
        let mesh = ds.dir.join(rel);
        let j = by_mesh
            .get(&mesh)
            .unwrap_or_else(|| panic!("{rel}: no line"));
        assert_eq!(j["status"], "failed", "{rel}: {j}");
        assert!(!j["error"].as_str().unwrap().is_empty());
        let reported: Vec<&str> = err.lines().filter(|l| l.contains(s(&mesh))).collect();
        assert_eq!(reported.len(), 1, "{rel} on stderr once: {err}");
    }
    for ignored in ["notes.txt", "x.obj"] {
        let p = ds.dir.join(ignored);
        assert!(!err.contains(s(&p)), "{ignored} mentioned: {err}");
        assert!(!by_mesh.keys().any(|m| m.starts_with(&p)), "{ignored}");
    }
    // Exactly the good outputs: no temporary, partial or failed ones.
    let want: BTreeSet<PathBuf> = ds.good.iter().map(|r| binvox_of(r)).collect();
    assert_eq!(files_below(&out), want);

    // A rerun skips every existing output (a tampered one stays tampered)...
    let tampered = out.join("teapot.binvox");
    std::fs::write(&tampered, b"tampered").unwrap();
    let again = voxkit(&args);
    assert_eq!(again.status.code(), Some(2));
    let lines = json_lines(&again);
    let status = |lines: &[serde_json::Value], want: &str| {
        lines.iter().filter(|j| j["status"] == want).count()
    };
    assert_eq!(status(&lines, "skipped"), ds.good.len());
    assert_eq!(status(&lines, "failed"), ds.bad.len());
    assert_eq!(lines.last().unwrap()["skipped"], ds.good.len());
    assert_eq!(std::fs::read(&tampered).unwrap(), b"tampered");
    // ... and --force rewrites them all.
    args.push("--force");
    let forced = voxkit(&args);
    assert_eq!(forced.status.code(), Some(2));
    assert_eq!(status(&json_lines(&forced), "ok"), ds.good.len());
    let (bytes, _) = single(
        &ds.dir.join("teapot.obj"),
        &opts,
        &single_dir.join("t.binvox"),
    );
    assert!(std::fs::read(&tampered).unwrap() == bytes);
    assert_eq!(files_below(&out), want);

    // Without --json: no stdout line per mesh, one summary line; the same
    // stderr reports.
    let plain = voxkit(&["voxelize", s(&ds.dir), "-o", s(&out), "-r", "40", "-q"]);
    assert_eq!(plain.status.code(), Some(2));
    let stdout = String::from_utf8_lossy(&plain.stdout);
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    assert!(
        stdout.contains(&format!("{} failed", ds.bad.len())),
        "{stdout}"
    );
    for rel in &ds.bad {
        assert!(stderr(&plain).contains(s(&ds.dir.join(rel))));
    }
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn glob_patterns_mirror_paths_below_their_literal_part() {
    let ds = dataset("glob");
    let root = ds.dir.parent().unwrap().to_path_buf();
    let out = root.join("out");
    let pattern = format!("{}/**/*.obj", s(&ds.dir));
    let o = voxkit(&["voxelize", &pattern, "-o", s(&out), "-r", "24", "--json"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let lines = json_lines(&o);
    // `**/*.obj` is case-sensitive on the name, so not SPOT.OBJ; the
    // directory x.obj matches but is not a mesh file.
    let objs: Vec<&&str> = ds
        .good
        .iter()
        .chain(&ds.bad)
        .filter(|r| r.ends_with(".obj"))
        .collect();
    assert_eq!(lines.len(), objs.len() + 1);
    let good_objs: BTreeSet<PathBuf> = ds
        .good
        .iter()
        .filter(|r| r.ends_with(".obj"))
        .map(|r| binvox_of(r))
        .collect();
    assert_eq!(files_below(&out), good_objs);
    assert!(out.join("sub/deeper/spot.binvox").exists());
    // The same mesh given by pattern and by name (a directory or file):
    // one job, the same bytes.
    let one = root.join("one");
    let o = voxkit(&[
        "voxelize",
        &format!("{}/sp*.obj", s(&ds.dir)),
        s(&ds.dir.join("spot.obj")),
        "-o",
        s(&one),
        "-r",
        "24",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let lines = json_lines(&o);
    assert_eq!(lines.len(), 3, "spot.obj, spot_quadrangulated.obj, summary");
    assert!(
        std::fs::read(one.join("spot.binvox")).unwrap()
            == std::fs::read(out.join("spot.binvox")).unwrap()
    );
    // A pattern that matches no mesh is a failure of its own.
    let none = voxkit(&[
        "voxelize",
        &format!("{}/*.stl", s(&ds.dir)),
        s(&ds.dir.join("spot.obj")),
        "-o",
        s(&root.join("none")),
        "-r",
        "24",
    ]);
    assert_eq!(none.status.code(), Some(2));
    assert!(
        stderr(&none).contains("matches no mesh file"),
        "{}",
        stderr(&none)
    );
    assert!(root.join("none/spot.binvox").exists());
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn inputs_that_would_write_the_same_output_are_both_refused() {
    let root = tmp("collide");
    let spot = std::fs::read(data("data/meshes/obj/spot.obj")).unwrap();
    for rel in ["d/a.obj", "d/a.ply", "d/b.obj", "e/b.obj"] {
        let p = root.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, &spot).unwrap();
    }
    let out = root.join("out");
    let o = voxkit(&[
        "voxelize",
        s(&root.join("d")),
        "-o",
        s(&out),
        "-r",
        "16",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let lines = json_lines(&o);
    let err = stderr(&o);
    for (me, other) in [("d/a.obj", "d/a.ply"), ("d/a.ply", "d/a.obj")] {
        let line = lines
            .iter()
            .find(|j| j["mesh"] == s(&root.join(me)))
            .unwrap();
        assert_eq!(line["status"], "failed");
        assert!(
            line["error"]
                .as_str()
                .unwrap()
                .contains(s(&root.join(other)))
        );
        assert!(err.contains(s(&root.join(me))));
    }
    assert_eq!(
        files_below(&out),
        BTreeSet::from([PathBuf::from("b.binvox")])
    );
    // Two files of the same name named explicitly.
    let out2 = root.join("out2");
    let o = voxkit(&[
        "voxelize",
        s(&root.join("d/b.obj")),
        s(&root.join("e/b.obj")),
        "-o",
        s(&out2),
        "-r",
        "16",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("would also be written from"));
    assert!(files_below(&out2).is_empty());
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn a_shared_lattice_puts_every_mesh_on_the_same_voxel_corners() {
    let root = tmp("lattice");
    let input = root.join("in");
    std::fs::create_dir_all(&input).unwrap();
    for name in ["spot.obj", "teapot.obj", "fandisk.obj"] {
        std::fs::copy(data(&format!("data/meshes/obj/{name}")), input.join(name)).unwrap();
    }
    let out = root.join("out");
    let (h, origin) = (0.037, [0.0123, -0.21, 0.77]);
    let opts = ["--voxel-size", "0.037", "--origin", "0.0123,-0.21,0.77"];
    let mut args = vec![
        "voxelize",
        s(&input),
        "-o",
        s(&out),
        "--json",
        "--format",
        "npy",
    ];
    args.extend(opts);
    let o = voxkit(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let lines = json_lines(&o);
    let mut origins = Vec::new();
    for j in &lines[..lines.len() - 1] {
        assert_eq!(j["voxel_size"], h);
        assert!(j["resolution"].is_null());
        let o: Vec<f64> = j["origin"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        for a in 0..3 {
            let k = (o[a] - origin[a]) / h;
            assert!(
                (k - k.round()).abs() < 1e-6,
                "{}: axis {a} k = {k}",
                j["mesh"]
            );
        }
        origins.push(o);
        // The same bytes as the single-mesh CLI, in the chosen format.
        let mesh = PathBuf::from(j["mesh"].as_str().unwrap());
        let output = PathBuf::from(j["output"].as_str().unwrap());
        assert_eq!(output.extension().unwrap(), "npy");
        let (bytes, _) = single(&mesh, &opts, &root.join("single.npy"));
        assert!(
            std::fs::read(&output).unwrap() == bytes,
            "{}",
            mesh.display()
        );
    }
    // Pairwise: origins differ by integer multiples of h, and the meshes'
    // own boxes differ by non-integers (so the lattice, not luck, did it).
    assert_eq!(origins.len(), 3);
    for (i, p) in origins.iter().enumerate() {
        for q in &origins[i + 1..] {
            for (x, y) in p.iter().zip(q) {
                let k = (x - y) / h;
                assert!((k - k.round()).abs() < 1e-6, "{p:?} - {q:?}: {k}");
            }
        }
    }
    let own = voxkit(&[
        "voxelize",
        s(&input),
        "-o",
        s(&root.join("own")),
        "--voxel-size",
        "0.037",
        "--json",
    ]);
    let own = json_lines(&own);
    let o0: Vec<f64> = serde_json::from_value(own[0]["origin"].clone()).unwrap();
    let o1: Vec<f64> = serde_json::from_value(own[1]["origin"].clone()).unwrap();
    assert!(
        (0..3).any(|a| {
            let k = (o0[a] - o1[a]) / h;
            (k - k.round()).abs() > 1e-3
        }),
        "without --origin each mesh has its own lattice"
    );
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn the_memory_budget_fails_the_same_meshes_as_single_runs() {
    let ds = dataset("memory");
    let root = ds.dir.parent().unwrap().to_path_buf();
    let opts = ["-r", "200", "--max-memory", "2"];
    let out = root.join("out");
    let one = root.join("one.binvox");
    let mut args = vec!["voxelize", s(&ds.dir), "-o", s(&out), "--json"];
    args.extend(opts);
    let lines = json_lines(&voxkit(&args));
    let mut failed_by_limit = 0;
    for rel in &ds.good {
        let mesh = ds.dir.join(rel);
        let j = lines.iter().find(|j| j["mesh"] == s(&mesh)).unwrap();
        let mut sargs = vec!["voxelize", s(&mesh), "-o", s(&one), "--force"];
        sargs.extend(opts);
        let o = voxkit(&sargs);
        if o.status.success() {
            assert_eq!(j["status"], "ok", "{rel}: {j}");
        } else {
            assert_eq!(j["status"], "failed", "{rel}");
            let single_err = stderr(&o);
            assert!(single_err.contains(j["error"].as_str().unwrap()), "{rel}");
            failed_by_limit += usize::from(single_err.contains("memory limit"));
        }
    }
    assert!(
        failed_by_limit > 0,
        "the budget must bite for this test to mean anything"
    );
    assert!(lines.iter().any(|j| j["status"] == "ok"));
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn batch_arguments_are_checked_before_any_work() {
    let root = tmp("args");
    let input = root.join("in");
    std::fs::create_dir_all(&input).unwrap();
    std::fs::copy(data("data/meshes/obj/spot.obj"), input.join("spot.obj")).unwrap();
    let file = root.join("file.binvox");
    std::fs::write(&file, b"x").unwrap();
    for (args, why) in [
        (vec![s(&input), "-o", s(&file)], "-o is a file"),
        (
            vec![s(&input), "-o", s(&root.join("m")), "--measure"],
            "--measure",
        ),
    ] {
        let mut a = vec!["voxelize", "-r", "8"];
        a.extend(args);
        let o = voxkit(&a);
        assert_eq!(o.status.code(), Some(2), "{why}");
        assert_eq!(stderr(&o).lines().count(), 1, "{why}: {}", stderr(&o));
    }
    assert!(
        !root.join("m").exists(),
        "refused before creating the output directory"
    );
    // A pattern that matches nothing: its failure line and the count.
    let nothing = root.join("nothing-*.obj");
    let o = voxkit(&["voxelize", "-r", "8", s(&nothing), "-o", s(&root.join("n"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("matches no mesh file"),
        "{}",
        stderr(&o)
    );
    // An empty directory has nothing to do: an error, not a silent success.
    let empty = root.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let o = voxkit(&["voxelize", s(&empty), "-o", s(&root.join("e")), "-r", "8"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no mesh files"));
    // --format is batch mode's; a single mesh's format is its extension.
    let o = voxkit(&[
        "voxelize",
        s(&input.join("spot.obj")),
        "-o",
        s(&root.join("s.binvox")),
        "-r",
        "8",
        "--format",
        "npy",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!root.join("s.binvox").exists());
    std::fs::remove_dir_all(&root).unwrap();
}
