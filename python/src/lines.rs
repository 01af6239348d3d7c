//! `line` and `lines`: the library's 3D line algorithms on grid-space
//! segments (voxel centres at integers), as `voxkit line` draws them.

use glam::{DVec3, IVec3};
use ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use rayon::prelude::*;
use voxkit::VoxkitError;
use voxkit::line::{AdaptiveRay, Line18, Line26, Segment, Tripod6};

use crate::{run, run_threads, value_error};

/// Which algorithm draws the line (`voxkit line --algo`).
#[derive(Clone, Copy)]
enum Kind {
    TwentySix,
    Eighteen,
    Tripod,
    Aw,
    Adaptive,
}

fn kind_of(kind: &str) -> PyResult<Kind> {
    Ok(match kind {
        "26" => Kind::TwentySix,
        "18" => Kind::Eighteen,
        "tripod" | "6" => Kind::Tripod,
        "aw" => Kind::Aw,
        "adaptive" => Kind::Adaptive,
        _ => {
            return Err(value_error(format!(
                "kind must be \"26\", \"18\", \"tripod\", \"aw\" or \"adaptive\", got {kind:?}"
            )));
        }
    })
}

/// The voxels of one segment, appended to `out` as `i64` triples.
fn draw(
    a: [f64; 3],
    b: [f64; 3],
    kind: Kind,
    flag_box: Option<(IVec3, IVec3)>,
    out: &mut Vec<i64>,
) -> voxkit::Result<()> {
    let seg = Segment::from_f64(a, b)?;
    let mut put = |v: IVec3| out.extend_from_slice(&v.to_array().map(i64::from));
    match kind {
        Kind::TwentySix => Line26::new(&seg).for_each(&mut put),
        Kind::Eighteen => Line18::new(&seg).for_each(&mut put),
        Kind::Tripod => Tripod6::new(&seg).for_each(&mut put),
        Kind::Adaptive => AdaptiveRay::new(&seg, move |v: IVec3| {
            flag_box.is_some_and(|(lo, hi)| v.cmpge(lo).all() && v.cmple(hi).all())
        })
        .for_each(&mut put),
        Kind::Aw => {
            // Amanatides–Woo runs in f64 on the segment's fixed-point
            // endpoints, as `voxkit line --algo aw` does.
            let p = |q: voxkit::fixed::FixedPoint| {
                DVec3::new(
                    voxkit::fixed::to_f64(q[0]),
                    voxkit::fixed::to_f64(q[1]),
                    voxkit::fixed::to_f64(q[2]),
                )
            };
            voxkit::line::amanatides_woo::aw_line(p(seg.a()), p(seg.b()))?.for_each(&mut put);
        }
    }
    Ok(())
}

fn flag_box_of(b: Option<[i32; 6]>) -> Option<(IVec3, IVec3)> {
    b.map(|b| (IVec3::new(b[0], b[1], b[2]), IVec3::new(b[3], b[4], b[5])))
}

/// The voxels of the segment `p0`–`p1` as a `(K, 3)` int64 array.
#[pyfunction]
#[pyo3(signature = (p0, p1, kind = "26", flag_box = None))]
pub fn line<'py>(
    py: Python<'py>,
    p0: [f64; 3],
    p1: [f64; 3],
    kind: &str,
    flag_box: Option<[i32; 6]>,
) -> PyResult<Bound<'py, PyArray2<i64>>> {
    let kind = kind_of(kind)?;
    let fb = flag_box_of(flag_box);
    let flat = run(py, || {
        let mut out = Vec::new();
        draw(p0, p1, kind, fb, &mut out)?;
        Ok(out)
    })?;
    let n = flat.len() / 3;
    Ok(Array2::from_shape_vec((n, 3), flat)
        .expect("3 per voxel")
        .into_pyarray(py))
}

/// Segments per parallel task in [`lines`].
const CHUNK: usize = 1024;

/// Every segment of an `(N, 6)` float64 array, in parallel: `(voxels (T,
/// 3) int64, offsets (N + 1,) int64)`, segment `i`'s voxels being
/// `voxels[offsets[i]:offsets[i + 1]]`.
#[pyfunction]
#[pyo3(signature = (segments, kind = "26", flag_box = None, threads = None))]
#[allow(clippy::type_complexity)]
pub fn lines<'py>(
    py: Python<'py>,
    segments: &Bound<'py, PyAny>,
    kind: &str,
    flag_box: Option<[i32; 6]>,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyArray2<i64>>, Bound<'py, PyArray1<i64>>)> {
    let kind = kind_of(kind)?;
    let fb = flag_box_of(flag_box);
    let arr = segments.cast::<PyArray2<f64>>().map_err(|_| {
        value_error("segments must be an (N, 6) float64 array of x0 y0 z0 x1 y1 z1 rows")
    })?;
    if arr.shape()[1] != 6 {
        return Err(value_error(format!(
            "segments must have shape (N, 6), got {:?}",
            arr.shape()
        )));
    }
    let rows: Vec<[f64; 6]> = {
        let ro = arr.readonly();
        ro.as_array()
            .rows()
            .into_iter()
            .map(|r| std::array::from_fn(|k| r[k]))
            .collect()
    };
    let (voxels, offsets) = run_threads(py, threads, || {
        let parts: Vec<(Vec<i64>, Vec<i64>)> = rows
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(c, chunk)| {
                let mut out = Vec::new();
                let mut ends = Vec::with_capacity(chunk.len());
                for (i, r) in chunk.iter().enumerate() {
                    draw([r[0], r[1], r[2]], [r[3], r[4], r[5]], kind, fb, &mut out).map_err(
                        |e| match e {
                            VoxkitError::Invalid(m) => {
                                VoxkitError::Invalid(format!("segment {}: {m}", c * CHUNK + i))
                            }
                            other => other,
                        },
                    )?;
                    ends.push((out.len() / 3) as i64);
                }
                Ok((out, ends))
            })
            .collect::<voxkit::Result<_>>()?;
        let total: usize = parts.iter().map(|(v, _)| v.len()).sum();
        let mut voxels = Vec::with_capacity(total);
        let mut offsets = Vec::with_capacity(rows.len() + 1);
        offsets.push(0i64);
        for (v, ends) in parts {
            let base = (voxels.len() / 3) as i64;
            voxels.extend_from_slice(&v);
            offsets.extend(ends.into_iter().map(|e| base + e));
        }
        Ok((voxels, offsets))
    })?;
    let n = voxels.len() / 3;
    Ok((
        Array2::from_shape_vec((n, 3), voxels)
            .expect("3 per voxel")
            .into_pyarray(py),
        Array1::from_vec(offsets).into_pyarray(py),
    ))
}
