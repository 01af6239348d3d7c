//! `voxkit._voxkit`: the native half of the Python package `voxkit`.
//!
//! Thin glue over the `voxkit` library, nothing of the engine written again:
//! numpy arrays are read (under the GIL, once) into the library's types, the
//! work runs with the GIL released ([`run`]: `Python::detach`, rayon
//! inside), and results go back as numpy arrays that own the Rust buffers
//! (no copy). The public Python API, its docstrings and the coercion of
//! trimesh / Open3D objects live in `voxkit/__init__.py`.
//!
//! Errors: [`VoxkitError`] becomes `ValueError` (invalid or unsupported
//! input), `MemoryError` (a refused memory estimate) or `OSError` (I/O, with
//! `errno` and the file name, so a missing file is `FileNotFoundError`), with
//! the library's message. A panic is caught at the boundary and raised as
//! `RuntimeError`; it never takes the interpreter down.

mod convert;
mod grid;
mod lines;
mod render;

use std::cell::RefCell;
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;

use pyo3::exceptions::{PyMemoryError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use voxkit::VoxkitError;

/// The same allocator as the `voxkit` binary: large buffers that are about
/// to be written in full get transparent huge pages (see `voxkit::alloc`),
/// so a voxelization from Python pays the same page faults as the CLI's.
#[global_allocator]
static ALLOC: voxkit::alloc::HugePageAlloc = voxkit::alloc::HugePageAlloc;

/// The Python exception for a library error.
pub(crate) fn to_py_err(e: VoxkitError) -> PyErr {
    match e {
        VoxkitError::Invalid(_) | VoxkitError::Unsupported(_) => {
            PyValueError::new_err(e.to_string())
        }
        VoxkitError::Limits { .. } => PyMemoryError::new_err(e.to_string()),
        VoxkitError::Io { path, source } => {
            let name = path.display().to_string();
            match source.raw_os_error() {
                // OSError(errno, strerror, filename) picks the subclass
                // (FileNotFoundError, PermissionError, ...) from errno.
                Some(code) => PyOSError::new_err((code, source.to_string(), name)),
                None => PyOSError::new_err(format!("{name}: {source}")),
            }
        }
    }
}

/// Runs `work` with the GIL released and any panic caught: the library's
/// errors become Python exceptions ([`to_py_err`]), a panic a
/// `RuntimeError` naming it.
pub(crate) fn run<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> voxkit::Result<T> + Send,
{
    match py.detach(|| catch_unwind(AssertUnwindSafe(work))) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(to_py_err(e)),
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(PyRuntimeError::new_err(format!(
                "voxkit internal error (please report it): {what}"
            )))
        }
    }
}

thread_local! {
    /// The pools of [`run_threads`] started by this (Python) thread, by
    /// size: kept for the thread's next calls, ended with the thread.
    static POOLS: RefCell<HashMap<usize, Arc<rayon::ThreadPool>>> = RefCell::new(HashMap::new());
}

/// As [`run`], inside a pool of `threads` workers when given (`None`:
/// rayon's global pool, one worker per core). Each calling thread has pools
/// of its own (started on its first such call, reused after), so calls from
/// several Python threads each with `threads=1` run side by side instead of
/// queueing for one shared pool.
pub(crate) fn run_threads<T, F>(py: Python<'_>, threads: Option<usize>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> voxkit::Result<T> + Send,
{
    let Some(n) = threads else {
        return run(py, work);
    };
    if n == 0 {
        return Err(value_error("threads must be at least 1"));
    }
    let pool = POOLS.with(|pools| -> PyResult<Arc<rayon::ThreadPool>> {
        if let Some(p) = pools.borrow().get(&n) {
            return Ok(p.clone());
        }
        let p = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start {n} threads: {e}")))?;
        let p = Arc::new(p);
        pools.borrow_mut().insert(n, p.clone());
        Ok(p)
    })?;
    run(py, move || pool.install(work))
}

/// A `ValueError` with `msg`.
pub(crate) fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// A panic raised on purpose, to test that the boundary turns it into a
/// `RuntimeError` (not part of the public API).
#[pyfunction]
fn _panic_for_test(py: Python<'_>) -> PyResult<()> {
    run(py, || -> voxkit::Result<()> {
        panic!("deliberate test panic")
    })
}

/// The native module.
#[pymodule]
fn _voxkit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(grid::load_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(grid::voxelize, m)?)?;
    m.add_function(wrap_pyfunction!(grid::load_grid, m)?)?;
    m.add_function(wrap_pyfunction!(grid::measure_indices, m)?)?;
    m.add_function(wrap_pyfunction!(grid::plan_tiles, m)?)?;
    m.add_function(wrap_pyfunction!(grid::voxelize_tile, m)?)?;
    m.add_function(wrap_pyfunction!(grid::finish_tiles, m)?)?;
    m.add_function(wrap_pyfunction!(lines::line, m)?)?;
    m.add_function(wrap_pyfunction!(lines::lines, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_grid, m)?)?;
    m.add_function(wrap_pyfunction!(render::open_store, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_volume, m)?)?;
    m.add_function(wrap_pyfunction!(render::read_volume, m)?)?;
    m.add_function(wrap_pyfunction!(render::write_png, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_for_test, m)?)?;
    m.add_class::<grid::Grid>()?;
    m.add_class::<render::Store>()?;
    Ok(())
}
