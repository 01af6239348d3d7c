//! numpy arrays → the library's types (read once, under the GIL).
//!
//! Vertices are `(N, 3)` `float64` or `float32`; faces `(M, 3)` of `int64`,
//! `int32`, `uint32` or `uint64` (the Python layer converts other dtypes).
//! Any strides are accepted: rows are read through an `ndarray` view.

use glam::DVec3;
use numpy::{PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use voxkit::mesh::Mesh;

use crate::value_error;

/// The rows of an `(N, 3)` array of `T`, if `obj` is one.
fn rows3<T, U>(
    obj: &Bound<'_, PyAny>,
    what: &str,
    f: impl Fn(T) -> U,
) -> PyResult<Option<Vec<[U; 3]>>>
where
    T: numpy::Element + Copy,
{
    let Ok(a) = obj.cast::<PyArray2<T>>() else {
        return Ok(None);
    };
    let shape = a.shape();
    if shape[1] != 3 {
        return Err(value_error(format!(
            "{what} must have 3 columns, got shape ({}, {})",
            shape[0], shape[1]
        )));
    }
    let ro = a.readonly();
    let view = ro.as_array();
    Ok(Some(
        view.rows()
            .into_iter()
            .map(|r| [f(r[0]), f(r[1]), f(r[2])])
            .collect(),
    ))
}

/// `(N, 3)` float coordinates as `DVec3`s.
pub(crate) fn points(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<DVec3>> {
    // Fast path: a C-contiguous float64 array, read as one flat slice.
    if let Ok(a) = obj.cast::<PyArray2<f64>>()
        && a.shape()[1] == 3
    {
        let ro = a.readonly();
        // ndarray's `as_slice` is `Some` for C order only (numpy's accepts
        // Fortran order too, which would swap coordinates).
        if let Some(flat) = ro.as_array().as_slice() {
            return Ok(flat
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2]))
                .collect());
        }
    }
    if let Some(v) = rows3::<f64, f64>(obj, what, |x| x)? {
        return Ok(v.into_iter().map(DVec3::from_array).collect());
    }
    if let Some(v) = rows3::<f32, f64>(obj, what, f64::from)? {
        return Ok(v.into_iter().map(DVec3::from_array).collect());
    }
    Err(shape_error(obj, what, "an (N, 3) float64 or float32 array"))
}

/// `(M, 3)` integer vertex indices as `u32` triples; negative indices and
/// indices past `u32::MAX` are errors (the library checks the rest).
pub(crate) fn faces(obj: &Bound<'_, PyAny>) -> PyResult<Vec<[u32; 3]>> {
    fn rows<T>(obj: &Bound<'_, PyAny>) -> PyResult<Option<Vec<[u32; 3]>>>
    where
        T: numpy::Element + Copy + TryInto<u32> + Into<i128>,
    {
        let Ok(a) = obj.cast::<PyArray2<T>>() else {
            return Ok(None);
        };
        let shape = a.shape();
        if shape[1] != 3 {
            return Err(value_error(format!(
                "faces must have 3 columns, got shape ({}, {})",
                shape[0], shape[1]
            )));
        }
        let ro = a.readonly();
        let view = ro.as_array();
        let tri = |t: usize, r: [T; 3]| -> PyResult<[u32; 3]> {
            let mut out = [0u32; 3];
            for (o, i) in out.iter_mut().zip(r) {
                *o = i.try_into().map_err(|_| {
                    value_error(format!(
                        "faces: triangle {t} uses vertex index {}, outside 0..2^32",
                        i.into()
                    ))
                })?;
            }
            Ok(out)
        };
        // Contiguous arrays (load_mesh's, trimesh's) as one flat slice.
        let out = match view.as_slice() {
            Some(flat) => flat
                .chunks_exact(3)
                .enumerate()
                .map(|(t, c)| tri(t, [c[0], c[1], c[2]]))
                .collect::<PyResult<_>>()?,
            None => view
                .rows()
                .into_iter()
                .enumerate()
                .map(|(t, r)| tri(t, [r[0], r[1], r[2]]))
                .collect::<PyResult<_>>()?,
        };
        Ok(Some(out))
    }
    if let Some(v) = rows::<i64>(obj)? {
        return Ok(v);
    }
    if let Some(v) = rows::<i32>(obj)? {
        return Ok(v);
    }
    if let Some(v) = rows::<u32>(obj)? {
        return Ok(v);
    }
    if let Some(v) = rows::<u64>(obj)? {
        return Ok(v);
    }
    Err(shape_error(obj, "faces", "an (M, 3) integer array"))
}

/// `(K, 3)` integer voxel indices (any integer dtype the faces take).
pub(crate) fn index_rows(obj: &Bound<'_, PyAny>) -> PyResult<Vec<[i64; 3]>> {
    if let Some(v) = rows3::<i64, i64>(obj, "indices", |x| x)? {
        return Ok(v);
    }
    if let Some(v) = rows3::<i32, i64>(obj, "indices", i64::from)? {
        return Ok(v);
    }
    Err(shape_error(obj, "indices", "a (K, 3) int32 or int64 array"))
}

/// A validated mesh from vertex and face arrays (the library's
/// `Mesh::from_parts`: non-finite coordinates and out-of-range indices are
/// errors, degenerate triangles are dropped).
pub(crate) fn mesh(vertices: &Bound<'_, PyAny>, faces_obj: &Bound<'_, PyAny>) -> PyResult<Mesh> {
    let v = points(vertices, "vertices")?;
    let f = faces(faces_obj)?;
    Mesh::from_parts("mesh", v, f, vec![]).map_err(crate::to_py_err)
}

fn shape_error(obj: &Bound<'_, PyAny>, what: &str, expected: &str) -> PyErr {
    let got = match obj.cast::<numpy::PyUntypedArray>() {
        Ok(a) => format!("an array of shape {:?} and dtype {}", a.shape(), a.dtype()),
        Err(_) => obj
            .get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_default(),
    };
    value_error(format!("{what} must be {expected}, got {got}"))
}

/// An optional point (validated by the library where it matters).
pub(crate) fn vec3(v: Option<[f64; 3]>) -> Option<DVec3> {
    v.map(DVec3::from_array)
}
