//! Batch mode of `voxkit voxelize`: `voxkit voxelize DIR|GLOB|MESH… -o OUTDIR
//! [--format binvox|vox|npy|nrrd|zarr]` with the single-mesh options
//! (`-r N` or `--voxel-size H [--origin X,Y,Z]`, `--mode`, `--snap`, …).
//!
//! Batch mode is chosen by more than one input, or by an input that is a
//! directory or a glob pattern (a path that does not exist and contains `*`,
//! `?` or `[`; quote it so that the shell leaves it alone). Then `-o` is an
//! output directory, created if missing.
//!
//! # Which files, and where they go
//! * A directory is walked recursively (symbolic links followed, loops
//!   reported) for files with a mesh extension ([`is_mesh_path`]); other files
//!   are ignored. Each lands at `OUTDIR/<path relative to the directory>` with
//!   the extension replaced by `--format`'s (default binvox), so sub-folders
//!   are mirrored and equal names in different folders do not collide.
//! * A glob pattern (the `glob` crate's syntax, `**` included) takes the
//!   matching files with a mesh extension; the path relative to the
//!   pattern's literal leading directories is mirrored the same way.
//!   Matching directories are ignored; a pattern matching no mesh file is a
//!   failure. Patterns are case-sensitive, as in the shell (`*.obj` does not
//!   take `A.OBJ`; the directory walk does).
//! * A file named explicitly is voxelized whatever its extension (an
//!   unsupported one is a failure) and lands at `OUTDIR/<file name>`.
//!
//! Inputs are processed and reported in sorted order of their paths. Two
//! inputs that would write the same output (`a.obj` and `a.ply`) are both
//! failures, found before any work; the same file reached twice for the same
//! output (a directory and a file in it) is voxelized once.
//!
//! # Failures, skipping and resuming
//! Each mesh's load, voxelization and write is one job run under
//! [`std::panic::catch_unwind`]: an unreadable, malformed, empty or
//! unsupported mesh, a limits error, or a panic anywhere in our code or a
//! dependency fails that job only: one stderr line `voxkit: FILE: reason`
//! (also with `--json`), and the batch goes on. An output that exists is
//! skipped (not loaded) unless `--force`. Outputs are written atomically
//! ([`crate::io::atomic_write`], which also removes its temporary file when a
//! job panics while writing), and temporary files that a killed run left beside this run's
//! outputs are removed at the start (Linux: those whose process is gone), so
//! an interrupted run leaves only whole files and resumes where it stopped.
//!
//! Exit code 0 when every input succeeded or was skipped, 2 when any failed
//! (the last stderr line says how many).
//!
//! # Output
//! Without `--json`, one summary line on stdout: done, skipped (exist),
//! failed, time and meshes/s (done over wall time). With `--json`, one line
//! per input in input order: `status: "ok"` with the single-mesh keys
//! (`output` included); `status: "skipped"` with `mesh` and `output`;
//! `status: "failed"` with `mesh`, `output` (`null` when none could be
//! derived) and `error`; then one summary line `{"summary": true, "total",
//! "done", "skipped", "failed", "seconds", "meshes_per_s", "peak_rss_mib"}`.
//! `peak_rss_mib` is the process's peak so far, in every line. A progress bar
//! over files (done/total, failures) goes to stderr when it is a terminal,
//! unless `-q` or `--json`. `--measure` is refused in batch mode: its exact
//! reference set is a second voxelization outside the memory budget below;
//! measure single meshes instead.
//!
//! # Parallelism and memory
//! Meshes run in parallel *and* each voxelization runs on the rayon pool. The
//! file workers are plain threads, as many as the pool has, each taking the
//! next input in order; they are not rayon tasks, because a job may wait for
//! memory (below), and a rayon worker that waits can have stolen a job whose
//! memory it is itself holding further down its stack (and rayon's work
//! stealing would nest more jobs per thread than the budget counted).
//!
//! `--max-memory` is one budget for the whole batch. After loading and
//! quantizing ([`prepare_mesh`]), a job reserves the voxelizer's own estimate
//! of its peak ([`PreparedMesh::estimated_bytes`]) plus the loaded mesh,
//! waits until the jobs in flight leave that much room, and gives it back
//! after writing. A job always runs when nothing else is in flight, and each
//! job's estimate is checked against the whole budget exactly as for a single
//! mesh, so a batch fails the same meshes, with the same message, as single
//! runs with the same `--max-memory`, and writes the same bytes. We chose
//! this over splitting the budget evenly across workers because datasets mix
//! a few large meshes with many small ones: an even split would refuse a
//! large mesh that fits the whole budget, while the shared reservation lets
//! small meshes run side by side and a large one run alone. Loading and
//! quantizing are not gated (a mesh's size is known only once parsed): at
//! most one loaded, quantized mesh per worker (counted in its reservation
//! once admitted) waits outside the budget.

use std::collections::{BTreeMap, HashMap};
use std::io::{IsTerminal, Write};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, mpsc};
use std::time::Instant;

use super::CliError;
use super::voxelize::{VoxelizeArgs, peak_rss_mib, result_json, voxelize_options};
use crate::io::{process_gone, remove_temp_files};
use crate::mesh::{Mesh, is_mesh_path};
use crate::voxelize::pipeline::{PreparedMesh, VoxelizeOptions, prepare_mesh};

/// Whether `inputs` make a batch: more than one, or a directory or a glob
/// pattern among them.
pub(super) fn is_batch(inputs: &[PathBuf]) -> bool {
    inputs.len() > 1 || inputs.iter().any(|p| p.is_dir() || is_pattern(p))
}

/// A path that does not exist and has glob metacharacters is a pattern (so
/// an existing file named `a[1].obj` is still that file).
fn is_pattern(p: &Path) -> bool {
    !p.exists() && p.to_string_lossy().contains(['*', '?', '['])
}

/// One input of the batch, in the order it is reported.
#[derive(Debug)]
struct Entry {
    /// The mesh file (or the directory / pattern a listing failure concerns).
    input: PathBuf,
    /// Where its voxels go (`None` when the listing failed).
    output: Option<PathBuf>,
    /// Set when the entry failed before any work (listing, collision).
    failed: Option<String>,
}

/// What happened to one entry.
enum Outcome {
    /// Written; the `--json` line.
    Done(serde_json::Value),
    /// The output existed.
    Skipped,
    /// The reason, for stderr and `error`.
    Failed(String),
}

/// The leading components of a pattern that contain no glob metacharacter:
/// the directory its matches are taken relative to.
fn pattern_base(pattern: &Path) -> PathBuf {
    let mut base = PathBuf::new();
    let comps: Vec<Component> = pattern.components().collect();
    // The last component is the file pattern itself, never part of the base.
    for c in &comps[..comps.len().saturating_sub(1)] {
        if c.as_os_str().to_string_lossy().contains(['*', '?', '[']) {
            break;
        }
        base.push(c);
    }
    base
}

/// `outdir/relative` with the extension replaced by `ext`.
fn output_for(outdir: &Path, relative: &Path, ext: &str) -> PathBuf {
    outdir.join(relative).with_extension(ext)
}

/// Lists the entries of `inputs` (see the module docs), sorted by input path,
/// with collisions marked as failures.
fn list_entries(inputs: &[PathBuf], outdir: &Path, ext: &str) -> Vec<Entry> {
    let mut entries = Vec::new();
    let job = |input: PathBuf, relative: &Path| Entry {
        output: Some(output_for(outdir, relative, ext)),
        input,
        failed: None,
    };
    let failure = |input: PathBuf, reason: String| Entry {
        input,
        output: None,
        failed: Some(reason),
    };
    for input in inputs {
        if input.is_dir() {
            for item in walkdir::WalkDir::new(input).follow_links(true) {
                match item {
                    Ok(e) if e.file_type().is_file() && is_mesh_path(e.path()) => {
                        let relative = e.path().strip_prefix(input).unwrap_or(e.path());
                        entries.push(job(e.path().to_path_buf(), relative));
                    }
                    Ok(_) => {}
                    Err(err) => {
                        let at = err.path().unwrap_or(input).to_path_buf();
                        entries.push(failure(at, format!("cannot list: {err}")));
                    }
                }
            }
        } else if is_pattern(input) {
            let pattern = input.to_string_lossy();
            let base = pattern_base(input);
            let before = entries.len();
            match glob::glob(&pattern) {
                Err(err) => entries.push(failure(input.clone(), format!("bad pattern: {err}"))),
                Ok(paths) => {
                    for item in paths {
                        match item {
                            Ok(p) if p.is_file() && is_mesh_path(&p) => {
                                let relative = p
                                    .strip_prefix(&base)
                                    .map(Path::to_path_buf)
                                    .unwrap_or_else(|_| file_name(&p));
                                entries.push(job(p, &relative));
                            }
                            Ok(_) => {}
                            Err(err) => {
                                let at = err.path().to_path_buf();
                                entries.push(failure(at, format!("cannot list: {}", err.error())));
                            }
                        }
                    }
                    if entries.len() == before {
                        entries.push(failure(input.clone(), "matches no mesh file".into()));
                    }
                }
            }
        } else {
            entries.push(job(input.clone(), &file_name(input)));
        }
    }
    entries.sort_by(|a, b| (&a.input, &a.output).cmp(&(&b.input, &b.output)));
    resolve_collisions(entries)
}

fn file_name(p: &Path) -> PathBuf {
    p.file_name()
        .map(PathBuf::from)
        .unwrap_or_else(|| p.to_path_buf())
}

/// Keeps one entry for a file reached twice for the same output (a directory
/// and a file in it), and marks every entry whose output a different file
/// would also write.
fn resolve_collisions(entries: Vec<Entry>) -> Vec<Entry> {
    let mut by_output: HashMap<PathBuf, Vec<usize>> = HashMap::new();
    for (i, e) in entries.iter().enumerate() {
        if let (Some(out), None) = (&e.output, &e.failed) {
            by_output.entry(out.clone()).or_default().push(i);
        }
    }
    let mut keep = vec![true; entries.len()];
    let mut reasons = vec![None; entries.len()];
    for (out, ids) in by_output {
        let file = |i: usize| {
            entries[i]
                .input
                .canonicalize()
                .unwrap_or_else(|_| entries[i].input.clone())
        };
        let mut files: Vec<PathBuf> = ids.iter().map(|&i| file(i)).collect();
        files.sort();
        files.dedup();
        if files.len() == 1 {
            for &i in &ids[1..] {
                keep[i] = false;
            }
            continue;
        }
        for &i in &ids {
            let others: Vec<String> = ids
                .iter()
                .filter(|&&j| file(j) != file(i))
                .map(|&j| entries[j].input.display().to_string())
                .collect();
            reasons[i] = Some(format!(
                "{} would also be written from {}; rename one (nothing written)",
                out.display(),
                others.join(", ")
            ));
        }
    }
    entries
        .into_iter()
        .zip(keep.into_iter().zip(reasons))
        .filter(|(_, (keep, _))| *keep)
        .map(|(mut e, (_, reason))| {
            if reason.is_some() {
                e.failed = reason;
            }
            e
        })
        .collect()
}

/// The shared memory budget: jobs reserve their estimate before allocating
/// and wait while the jobs in flight leave too little room (see the module
/// docs). A job always runs when nothing else is in flight.
struct MemoryGate {
    budget: u64,
    in_use: Mutex<u64>,
    freed: Condvar,
}

/// Bytes held from a [`MemoryGate`] until dropped (also when unwinding).
struct Reservation<'a> {
    gate: &'a MemoryGate,
    bytes: u64,
}

impl MemoryGate {
    fn new(budget: u64) -> Self {
        MemoryGate {
            budget,
            in_use: Mutex::new(0),
            freed: Condvar::new(),
        }
    }

    fn reserve(&self, bytes: u64) -> Reservation<'_> {
        let bytes = bytes.min(self.budget);
        // The lock is never held across our code, so poisoning cannot hide
        // an inconsistent count.
        let mut in_use = self.in_use.lock().unwrap_or_else(|e| e.into_inner());
        while *in_use > 0 && *in_use + bytes > self.budget {
            in_use = self.freed.wait(in_use).unwrap_or_else(|e| e.into_inner());
        }
        *in_use += bytes;
        Reservation { gate: self, bytes }
    }
}

impl Drop for Reservation<'_> {
    fn drop(&mut self) {
        let mut in_use = self.gate.in_use.lock().unwrap_or_else(|e| e.into_inner());
        *in_use -= self.bytes;
        self.gate.freed.notify_all();
    }
}

/// Bytes a loaded mesh holds (positions, triangles, polylines).
fn mesh_bytes(mesh: &Mesh) -> u64 {
    let polyline: usize = mesh.polylines.iter().map(Vec::len).sum();
    (24 * mesh.positions.len() + 12 * mesh.triangles.len() + 4 * polyline) as u64
}

/// What every job shares.
struct Context<'a> {
    args: &'a VoxelizeArgs,
    opts: VoxelizeOptions,
    gate: MemoryGate,
}

/// Loads, voxelizes and writes one mesh; the `--json` line on success.
fn voxelize_one(ctx: &Context, input: &Path, output: &Path) -> Result<serde_json::Value, String> {
    let t = Instant::now();
    let mesh = Mesh::load(input).map_err(|e| e.to_string())?;
    let load_ms = ms(t);
    let prepared: PreparedMesh = prepare_mesh(&mesh, &ctx.opts).map_err(|e| e.to_string())?;
    let held = ctx
        .gate
        .reserve(prepared.estimated_bytes().saturating_add(mesh_bytes(&mesh)));
    let v = prepared.voxelize().map_err(|e| e.to_string())?;
    if let Some(dir) = output.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let t = Instant::now();
    super::voxelize::write_output(ctx.args, output, &v, ctx.opts.limit)
        .map_err(|e| e.to_string())?;
    let write_ms = ms(t);
    let json = result_json(
        ctx.args,
        input,
        output,
        &v,
        load_ms,
        write_ms,
        &mesh.summary.warnings,
    );
    drop(v);
    drop(held);
    Ok(json)
}

/// One entry, with panics contained.
fn process(ctx: &Context, entry: &Entry) -> Outcome {
    if let Some(reason) = &entry.failed {
        return Outcome::Failed(reason.clone());
    }
    let Some(output) = &entry.output else {
        return Outcome::Failed("no output path".into());
    };
    if !ctx.args.force && output.exists() {
        return Outcome::Skipped;
    }
    contained(|| voxelize_one(ctx, &entry.input, output))
}

/// Runs `job` under `catch_unwind`: a panic becomes a failure (a panic
/// inside a writer leaves no temporary file: `atomic_write` removes it while
/// unwinding).
fn contained(job: impl FnOnce() -> Result<serde_json::Value, String>) -> Outcome {
    match catch_unwind(AssertUnwindSafe(job)) {
        Ok(Ok(json)) => Outcome::Done(json),
        Ok(Err(reason)) => Outcome::Failed(reason),
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(no message)".into());
            Outcome::Failed(format!("internal error (panic): {msg}"))
        }
    }
}

/// Removes temporary files that killed runs left beside the outputs: one
/// directory listing per output directory.
fn remove_stale_temp_files(entries: &[Entry]) {
    let mut by_dir: BTreeMap<&Path, Vec<&Path>> = BTreeMap::new();
    for out in entries.iter().filter_map(|e| e.output.as_deref()) {
        if let Some(dir) = out.parent() {
            by_dir.entry(dir).or_default().push(out);
        }
    }
    for (dir, outs) in by_dir {
        let Ok(listing) = std::fs::read_dir(dir) else {
            continue; // not created yet: nothing stale
        };
        let names: std::collections::HashSet<String> = outs
            .iter()
            .filter_map(|o| o.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .collect();
        for item in listing.flatten() {
            let file = item.file_name();
            let file = file.to_string_lossy();
            if !(file.starts_with('.') && file.ends_with(".tmp")) {
                continue;
            }
            // `.NAME.PID.N.tmp`: NAME may itself contain dots.
            let inner = &file[1..file.len() - 4];
            let mut it = inner.rsplitn(3, '.');
            let (Some(_n), Some(_pid), Some(name)) = (it.next(), it.next(), it.next()) else {
                continue;
            };
            if names.contains(name) {
                remove_temp_files(&dir.join(name), process_gone);
            }
        }
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Runs batch mode (see the module docs).
pub(super) fn run(args: &VoxelizeArgs, out: &mut dyn Write) -> Result<(), CliError> {
    if args.measure {
        return Err(CliError::bad_input(
            "--measure is for single meshes (its reference set is not in the batch's memory budget)",
        ));
    }
    let opts = voxelize_options(args)?;
    let outdir = &args.output;
    if outdir.exists() && !outdir.is_dir() {
        return Err(CliError::bad_input(format!(
            "{}: batch mode writes into a directory, and this is a file",
            outdir.display()
        )));
    }
    std::fs::create_dir_all(outdir)
        .map_err(|e| CliError::bad_input(format!("{}: {e}", outdir.display())))?;
    let ext = args.format.map_or("binvox", |f| f.extension());
    let entries = list_entries(&args.inputs, outdir, ext);
    if entries.is_empty() {
        return Err(CliError::bad_input(format!(
            "no mesh files (.{}) in {}",
            crate::mesh::MESH_EXTENSIONS.join(", ."),
            args.inputs
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    remove_stale_temp_files(&entries);

    let ctx = Context {
        args,
        gate: MemoryGate::new(opts.limit.bytes),
        opts,
    };
    let bar = (!args.quiet && !args.json && std::io::stderr().is_terminal()).then(|| {
        let b = indicatif::ProgressBar::new(entries.len() as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {elapsed_precise} [{bar:30}] {pos}/{len} meshes {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b.enable_steady_tick(std::time::Duration::from_millis(120));
        b
    });

    // Panics are reported as failures of their mesh, one line each; the
    // default hook's multi-line message would interleave with them.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let start = Instant::now();
    let workers = rayon::current_num_threads().clamp(1, entries.len());
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<(usize, Outcome)>();
    let (mut done, mut skipped, mut failed) = (0usize, 0usize, 0usize);
    let written: std::io::Result<()> = std::thread::scope(|scope| {
        for _ in 0..workers {
            let tx = tx.clone();
            let (ctx, entries, next) = (&ctx, &entries, &next);
            scope.spawn(move || {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(entry) = entries.get(i) else { break };
                    if tx.send((i, process(ctx, entry))).is_err() {
                        break;
                    }
                }
            });
        }
        drop(tx);
        // Report in input order: outcomes wait here until those before them
        // are in.
        let mut pending: BTreeMap<usize, Outcome> = BTreeMap::new();
        let mut emitted = 0;
        let mut result = Ok(());
        for (i, outcome) in rx {
            match &outcome {
                Outcome::Done(_) => done += 1,
                Outcome::Skipped => skipped += 1,
                Outcome::Failed(_) => failed += 1,
            }
            if let Some(b) = &bar {
                b.inc(1);
                if failed > 0 {
                    b.set_message(format!("({failed} failed)"));
                }
            }
            pending.insert(i, outcome);
            while let Some(outcome) = pending.remove(&emitted) {
                let entry = &entries[emitted];
                emitted += 1;
                if result.is_ok() {
                    result = emit(args.json, entry, outcome, out, bar.as_ref());
                }
            }
        }
        result
    });
    std::panic::set_hook(hook);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    written?;
    let seconds = start.elapsed().as_secs_f64();
    let rate = done as f64 / seconds.max(1e-9);
    let total = entries.len();
    if args.json {
        let summary = serde_json::json!({
            "summary": true,
            "total": total,
            "done": done,
            "skipped": skipped,
            "failed": failed,
            "seconds": seconds,
            "meshes_per_s": rate,
            "peak_rss_mib": peak_rss_mib(),
        });
        writeln!(out, "{summary}")?;
    } else {
        writeln!(
            out,
            "{total} meshes: {done} done, {skipped} skipped (output exists), {failed} failed in {seconds:.2} s ({rate:.1} meshes/s) → {}",
            outdir.display()
        )?;
    }
    if failed > 0 {
        return Err(CliError::bad_input(format!(
            "{failed} of {total} meshes failed (see above)"
        )));
    }
    Ok(())
}

/// Writes one entry's report: the `--json` line, the loader's warnings on
/// stderr, and for a failure one stderr line (above the progress bar).
fn emit(
    json: bool,
    entry: &Entry,
    outcome: Outcome,
    out: &mut dyn Write,
    bar: Option<&indicatif::ProgressBar>,
) -> std::io::Result<()> {
    let mesh = entry.input.display().to_string();
    let output = entry.output.as_ref().map(|o| o.display().to_string());
    if let Outcome::Done(j) = &outcome {
        let warnings: Vec<String> = j["warnings"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|w| w.as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default();
        match bar {
            Some(b) => b.suspend(|| super::print_warnings(&entry.input, &warnings)),
            None => super::print_warnings(&entry.input, &warnings),
        }
    }
    if let Outcome::Failed(reason) = &outcome {
        // Typed errors name the file already; the others get it prefixed.
        let line = if reason.contains(&mesh) {
            format!("voxkit: {reason}")
        } else {
            format!("voxkit: {mesh}: {reason}")
        };
        match bar {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }
    if !json {
        return Ok(());
    }
    let line = match outcome {
        Outcome::Done(mut j) => {
            let obj = j.as_object_mut().expect("result_json is an object");
            obj.insert("status".into(), "ok".into());
            obj.insert("peak_rss_mib".into(), serde_json::json!(peak_rss_mib()));
            j
        }
        Outcome::Skipped => serde_json::json!({
            "mesh": mesh,
            "output": output,
            "status": "skipped",
        }),
        Outcome::Failed(reason) => serde_json::json!({
            "mesh": mesh,
            "output": output,
            "status": "failed",
            "error": reason,
        }),
    };
    writeln!(out, "{line}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicU64;

    fn scratch(tag: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("voxkit-batch-unit-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_panicking_writer_is_a_failure_and_leaves_no_file() {
        let dir = scratch("panic");
        let out = dir.join("a.binvox");
        let hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        let outcome = contained(|| {
            crate::io::atomic_write(&out, false, |w| {
                w.write_all(b"partial")?;
                panic!("writer bug");
            })
            .map_err(|e| e.to_string())?;
            Ok(serde_json::json!({}))
        });
        std::panic::set_hook(hook);
        match outcome {
            Outcome::Failed(reason) => assert!(reason.contains("writer bug"), "{reason}"),
            _ => panic!("a panic must be a failure"),
        }
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().collect();
        assert!(left.is_empty(), "{left:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn stale_temp_files_of_dead_processes_are_removed_and_others_kept() {
        if !Path::new("/proc/self").exists() {
            return; // the sweep only knows dead processes on Linux
        }
        let dir = scratch("stale");
        let out = dir.join("m.v1.binvox");
        // No process has a pid above the kernel's maximum (2^22).
        let dead = dir.join(format!(".m.v1.binvox.{}.0.tmp", (1u32 << 22) + 7));
        let alive = dir.join(format!(".m.v1.binvox.{}.3.tmp", std::process::id()));
        let other = dir.join(format!(".n.binvox.{}.0.tmp", (1u32 << 22) + 7));
        for f in [&dead, &alive, &other] {
            std::fs::write(f, b"x").unwrap();
        }
        let entries = [Entry {
            input: PathBuf::from("m.v1.obj"),
            output: Some(out),
            failed: None,
        }];
        remove_stale_temp_files(&entries);
        assert!(!dead.exists());
        assert!(alive.exists(), "a live writer's file stays");
        assert!(other.exists(), "not an output of this run");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_memory_gate_never_admits_more_than_the_budget() {
        let budget = 1000;
        let gate = MemoryGate::new(budget);
        let in_flight = AtomicU64::new(0);
        let peak = AtomicU64::new(0);
        std::thread::scope(|s| {
            for t in 0..4u64 {
                let (gate, in_flight, peak) = (&gate, &in_flight, &peak);
                s.spawn(move || {
                    for i in 0..300u64 {
                        let bytes = (i * 7919 + t * 104_729) % 700 + 1;
                        let held = gate.reserve(bytes);
                        let now = in_flight.fetch_add(bytes, Ordering::SeqCst) + bytes;
                        peak.fetch_max(now, Ordering::SeqCst);
                        std::thread::yield_now();
                        in_flight.fetch_sub(bytes, Ordering::SeqCst);
                        drop(held);
                    }
                });
            }
        });
        let peak = peak.load(Ordering::SeqCst);
        assert!(peak <= budget, "{peak} bytes in flight");
        // Jobs that fit together run together.
        let a = gate.reserve(400);
        let b = gate.reserve(600);
        assert_eq!(*gate.in_use.lock().unwrap(), 1000);
        drop((a, b));
        // Alone, a job above the budget still runs (its own limit check
        // decides), holding the whole budget.
        let big = gate.reserve(5000);
        assert_eq!(big.bytes, budget);
    }

    #[test]
    fn pattern_bases_stop_at_the_first_wildcard() {
        assert_eq!(
            pattern_base(Path::new("data/m/*.obj")),
            PathBuf::from("data/m")
        );
        assert_eq!(
            pattern_base(Path::new("data/**/x/*.obj")),
            PathBuf::from("data")
        );
        assert_eq!(pattern_base(Path::new("*.obj")), PathBuf::new());
        assert_eq!(pattern_base(Path::new("/a/b?/c.obj")), PathBuf::from("/a"));
    }
}
