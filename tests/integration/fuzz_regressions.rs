//! Every input the fuzzers found a bug with, replayed through the fuzz
//! target's own entry point (`voxkit::fuzz_entry`): `fuzz/regressions/
//! <target>/<name>`. An input must not panic; a file named `ok-*` must be
//! accepted, any other must be refused with a typed error (it is malformed).

use std::path::Path;

use voxkit::fuzz_entry;

#[test]
fn every_fuzz_regression_input_is_handled() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let mut failures = Vec::new();
    let mut replayed = 0;
    for dir in std::fs::read_dir(&root).expect("fuzz/regressions exists") {
        let dir = dir.unwrap().path();
        let target = dir.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            fuzz_entry::TARGETS.contains(&target.as_str()),
            "fuzz/regressions/{target}: no such fuzz target"
        );
        for file in std::fs::read_dir(&dir).unwrap() {
            let path = file.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let data = std::fs::read(&path).unwrap();
            let outcome = std::panic::catch_unwind(|| fuzz_entry::run(&target, &data));
            replayed += 1;
            match (outcome, name.starts_with("ok-")) {
                (Err(_), _) => failures.push(format!("{target}/{name}: panicked")),
                (Ok(Err(e)), true) => failures.push(format!("{target}/{name}: refused: {e}")),
                (Ok(Ok(())), false) => failures.push(format!("{target}/{name}: accepted")),
                (Ok(Err(e)), false) => {
                    // A typed error names what is wrong.
                    assert!(!e.to_string().is_empty(), "{target}/{name}");
                }
                (Ok(Ok(())), true) => {}
            }
        }
    }
    assert!(replayed > 0, "no regression input under {}", root.display());
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn every_fuzz_target_has_an_entry_point() {
    for target in fuzz_entry::TARGETS {
        let _ = fuzz_entry::run(target, b"");
        let _ = fuzz_entry::run(target, b"\xff\x00\n@@DATA@@\n");
    }
    assert!(fuzz_entry::run("no-such-target", b"").is_err());
}
