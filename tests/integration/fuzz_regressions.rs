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
                    if let Some(why) = not_one_line(&e.to_string()) {
                        failures.push(format!("{target}/{name}: {why}"));
                    }
                }
                (Ok(Ok(())), true) => {}
            }
        }
    }
    assert!(replayed > 0, "no regression input under {}", root.display());
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Why `message` is not one useful line: empty, several lines, or a
/// dependency's `Debug` dump (a struct literal such as `ParseError {`).
fn not_one_line(message: &str) -> Option<String> {
    if message.trim().is_empty() {
        return Some("empty error message".into());
    }
    if message.contains('\n') || message.contains('\r') {
        return Some(format!("error message on several lines: {message:?}"));
    }
    // `Name { field: …`: a type name, ` { `, a field name and a colon.
    let dump = message.match_indices(" { ").any(|(at, _)| {
        let before = message[..at].rsplit(|c: char| !c.is_alphanumeric()).next();
        let after = message[at + 3..].split(':').next().unwrap_or_default();
        before.is_some_and(|w| w.starts_with(char::is_uppercase))
            && !after.is_empty()
            && after.chars().all(|c| c.is_ascii_lowercase() || c == '_')
    });
    dump.then(|| format!("error message quotes a Debug dump: {message}"))
}

/// Every input of a fuzzing run's corpus (`VOXKIT_FUZZ_CORPUS`, a
/// `fuzz/corpus` folder with one subfolder per target) is handled without a
/// panic and, when refused, in one line. Run by hand after fuzzing:
/// `VOXKIT_FUZZ_CORPUS=fuzz/corpus cargo test --release --test integration
/// fuzz_corpus -- --ignored`.
#[test]
#[ignore = "needs a fuzzing run's corpus in VOXKIT_FUZZ_CORPUS"]
fn fuzz_corpus_errors_are_one_line() {
    let root = std::env::var("VOXKIT_FUZZ_CORPUS").expect("VOXKIT_FUZZ_CORPUS names the corpus");
    let (mut refused, mut failures) = (0, Vec::new());
    for target in fuzz_entry::TARGETS {
        let Ok(dir) = std::fs::read_dir(Path::new(&root).join(target)) else {
            continue;
        };
        for file in dir {
            let path = file.unwrap().path();
            let data = std::fs::read(&path).unwrap();
            match std::panic::catch_unwind(|| fuzz_entry::run(target, &data)) {
                Err(_) => failures.push(format!("{}: panicked", path.display())),
                Ok(Err(e)) => {
                    refused += 1;
                    if let Some(why) = not_one_line(&e.to_string()) {
                        failures.push(format!("{}: {why}", path.display()));
                    }
                }
                Ok(Ok(())) => {}
            }
        }
    }
    eprintln!("{refused} refused inputs checked");
    assert!(refused > 0, "no refused input under {root}");
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

#[test]
fn the_one_line_check_catches_dumps_and_line_breaks() {
    assert!(not_one_line("a.ply: line 3: `x` is not a number").is_none());
    assert!(not_one_line("a.ply: ParseError { location: LineCol { line: 1 } }").is_some());
    assert!(not_one_line("a.ply: bad\nheader").is_some());
    assert!(not_one_line(" ").is_some());
}
