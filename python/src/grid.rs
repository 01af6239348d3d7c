//! Meshes in, voxel grids out: `load_mesh`, `voxelize`, `load_grid` and the
//! grid class behind `voxkit.VoxelGrid`.
//!
//! Voxels are read only through the grid's public iteration
//! (`BrickGrid::bricks`), never by assuming how bricks are stored.

use std::path::PathBuf;

use glam::DVec3;
use ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use voxkit::grid::brick::BrickMask;
use voxkit::grid::{BrickGrid, GridFrame, MemoryLimit, Voxel};
use voxkit::io::{read_voxels_warned, write_voxels};
use voxkit::mesh::FIT_SLACK;
use voxkit::mesh::Mesh;
use voxkit::metric::Connectivity;
use voxkit::topology::tunnels::closed_surface_tunnels;
use voxkit::voxelize::measure::{ErrorMeasures, measure_external, measure_voxel_set};
use voxkit::voxelize::pipeline::{
    Lattice, VoxelizeMode, VoxelizeOptions, VoxelizeStats, quantize_mesh, voxelize_mesh,
};
use voxkit::voxelize::solid::InsideTest;

use crate::{convert, run, run_threads, value_error};

/// The bricks of one brick-x slab: (brick coordinate, z-columns), see
/// [`Grid::slabs`].
type Slab = Vec<(Voxel, [u8; 64])>;

/// `(vertices, faces)` arrays.
type MeshArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);

/// A voxel set in its world frame (the native half of `voxkit.VoxelGrid`).
#[pyclass(module = "voxkit._voxkit", name = "Grid", frozen)]
pub struct Grid {
    pub(crate) grid: BrickGrid,
    pub(crate) frame: GridFrame,
    count: u64,
    stats: Option<VoxelizeStats>,
    /// Whether the vertices were snapped to the lattice (`voxelize(snap=True)`).
    snap: bool,
}

impl Grid {
    pub(crate) fn new(
        grid: BrickGrid,
        frame: GridFrame,
        stats: Option<VoxelizeStats>,
        snap: bool,
    ) -> Self {
        let count = stats.as_ref().map_or_else(|| grid.count(), |s| s.voxels);
        Grid {
            grid,
            frame,
            count,
            stats,
            snap,
        }
    }

    /// Whether the mesh lies in the grid box (closed at its faces, up to
    /// `FIT_SLACK`): then it is measured in the grid's own frame.
    fn holds(&self, mesh: &Mesh) -> bool {
        let (lo, hi) = mesh.bounds();
        let (glo, ghi) = (self.frame.world_to_grid(lo), self.frame.world_to_grid(hi));
        (0..3).all(|a| {
            glo[a] >= -0.5 - FIT_SLACK && ghi[a] <= self.frame.dims[a] as f64 - 0.5 + FIT_SLACK
        })
    }

    /// The stored bricks as (brick coordinate, z-columns), sorted by (x, y,
    /// z) brick coordinate, and split into slabs of equal brick x. A
    /// column `lx + 8·ly` holds bit `lz` for voxel `(lx, ly, lz)` of the
    /// brick, so voxels come out in (x, y, z) order by walking columns.
    fn slabs(&self) -> Vec<Slab> {
        let mut bricks: Vec<(Voxel, [u8; 64])> =
            self.grid.bricks().map(|(k, m)| (k, columns(m))).collect();
        bricks.par_sort_unstable_by_key(|(k, _)| (k.x, k.y, k.z));
        let mut slabs: Vec<Slab> = Vec::new();
        for b in bricks {
            match slabs.last_mut() {
                Some(s) if s[0].0.x == b.0.x => s.push(b),
                _ => slabs.push(vec![b]),
            }
        }
        slabs
    }

    /// Every voxel as `(x, y, z)` `i32` triples in lexicographic order (the
    /// order of `numpy.argwhere(dense)`), flattened.
    fn sorted_voxels(&self) -> Vec<i32> {
        let slabs = self.slabs();
        let counts: Vec<usize> = slabs
            .iter()
            .map(|s| s.iter().map(|(_, c)| popcount(c)).sum())
            .collect();
        let total: usize = counts.iter().sum();
        let mut out = vec![0i32; 3 * total];
        let mut parts = Vec::with_capacity(slabs.len());
        let mut rest = out.as_mut_slice();
        for (slab, &n) in slabs.iter().zip(&counts) {
            let (head, tail) = rest.split_at_mut(3 * n);
            parts.push((slab, head));
            rest = tail;
        }
        parts.into_par_iter().for_each(|(slab, dst)| {
            let mut i = 0;
            let bx = slab[0].0.x * 8;
            for lx in 0..8 {
                // Runs of bricks with the same brick y, in z order.
                let mut start = 0;
                while start < slab.len() {
                    let by = slab[start].0.y;
                    let end = start + slab[start..].iter().take_while(|b| b.0.y == by).count();
                    for ly in 0..8 {
                        for (k, cols) in &slab[start..end] {
                            let mut c = cols[lx + 8 * ly];
                            while c != 0 {
                                let lz = c.trailing_zeros() as i32;
                                c &= c - 1;
                                dst[i] = bx + lx as i32;
                                dst[i + 1] = by * 8 + ly as i32;
                                dst[i + 2] = k.z * 8 + lz;
                                i += 3;
                            }
                        }
                    }
                    start = end;
                }
            }
        });
        out
    }

    fn dims_tuple(&self) -> (usize, usize, usize) {
        let d = self.frame.dims;
        (d[0], d[1], d[2])
    }
}

/// The brick's voxels as 64 z-columns (see [`Grid::slabs`]); the mask keeps
/// voxel `(lx, ly, lz)` in word `lz`, bit `lx + 8·ly`.
fn columns(m: &BrickMask) -> [u8; 64] {
    let mut cols = [0u8; 64];
    for (lz, &w) in m.iter().enumerate() {
        let mut w = w;
        while w != 0 {
            let b = w.trailing_zeros() as usize;
            w &= w - 1;
            cols[b] |= 1 << lz;
        }
    }
    cols
}

fn popcount(c: &[u8; 64]) -> usize {
    c.iter().map(|b| b.count_ones() as usize).sum()
}

fn mode_of(mode: &str) -> PyResult<VoxelizeMode> {
    Ok(match mode {
        "thin" => VoxelizeMode::Thin,
        "thick" => VoxelizeMode::Thick,
        "conservative" => VoxelizeMode::Conservative,
        "solid" => VoxelizeMode::Solid,
        _ => {
            return Err(value_error(format!(
                "mode must be \"thin\", \"thick\", \"conservative\" or \"solid\", got {mode:?}"
            )));
        }
    })
}

/// Solid mode's inside test by its command-line name.
fn inside_of(inside: &str) -> PyResult<InsideTest> {
    match inside {
        "winding" => Ok(InsideTest::Winding),
        "parity" => Ok(InsideTest::Parity),
        _ => Err(value_error(format!(
            "inside must be \"winding\" or \"parity\", got {inside:?}"
        ))),
    }
}

pub(crate) fn limit_of(max_memory_mib: u64) -> MemoryLimit {
    MemoryLimit::new(max_memory_mib.saturating_mul(1 << 20))
}

fn measures_dict<'py>(py: Python<'py>, m: &ErrorMeasures) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("reference_voxels", m.reference_voxels)?;
    d.set_item("missing", m.missing)?;
    d.set_item("extra", m.extra)?;
    d.set_item("max_distance", m.max_distance)?;
    d.set_item("mean_distance", m.mean_distance)?;
    d.set_item("far_voxels", m.far_voxels)?;
    d.set_item("closed", m.closed)?;
    d.set_item("tunnel6", m.tunnel6)?;
    d.set_item("tunnel26", m.tunnel26)?;
    d.set_item("note", m.note.clone())?;
    Ok(d)
}

#[pymethods]
impl Grid {
    /// Extents `(nx, ny, nz)` in voxels.
    #[getter]
    fn dims(&self) -> (usize, usize, usize) {
        self.dims_tuple()
    }

    /// World position of the min corner of voxel (0, 0, 0).
    #[getter]
    fn origin(&self) -> (f64, f64, f64) {
        let o = self.frame.origin;
        (o.x, o.y, o.z)
    }

    /// Voxel edge length in world units.
    #[getter]
    fn voxel_size(&self) -> f64 {
        self.frame.voxel_size
    }

    fn __len__(&self) -> usize {
        self.count as usize
    }

    /// Same frame (dims, origin, voxel size) and same set of voxels,
    /// compared brick by brick without expanding them.
    fn same_as(&self, py: Python<'_>, other: &Grid) -> bool {
        self.frame == other.frame
            && self.count == other.count
            && py.detach(|| self.grid == other.grid)
    }

    /// Counts and timings of the voxelization that made the grid (`None`
    /// for a loaded grid).
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(s) = &self.stats else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("triangles", s.triangles)?;
        d.set_item("skipped_triangles", s.skipped_triangles)?;
        d.set_item("segments", s.segments)?;
        d.set_item("voxels", s.voxels)?;
        d.set_item("bricks", s.bricks)?;
        d.set_item("estimated_bytes", s.estimated_bytes)?;
        d.set_item("quantize_ms", s.quantize_ms)?;
        d.set_item("kernel_ms", s.kernel_ms)?;
        d.set_item("polyline_ms", s.polyline_ms)?;
        d.set_item("voxelize_ms", s.total_ms)?;
        Ok(Some(d))
    }

    /// `(K, 3)` int32 voxel indices in (x, y, z) lexicographic order.
    fn indices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i32>>> {
        let flat = run(py, || Ok(self.sorted_voxels()))?;
        let n = flat.len() / 3;
        let a = Array2::from_shape_vec((n, 3), flat).expect("3 values per voxel");
        Ok(a.into_pyarray(py))
    }

    /// `(K, 3)` float64 world positions of the voxel centres, in the order
    /// of `indices()`.
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let frame = self.frame;
        let flat = run(py, || {
            let idx = self.sorted_voxels();
            Ok(idx
                .par_chunks_exact(3)
                .flat_map_iter(|c| {
                    frame
                        .voxel_center_world(Voxel::new(c[0], c[1], c[2]))
                        .to_array()
                })
                .collect::<Vec<f64>>())
        })?;
        let n = flat.len() / 3;
        Ok(Array2::from_shape_vec((n, 3), flat)
            .expect("3 values per voxel")
            .into_pyarray(py))
    }

    /// A C-ordered `bool` array of shape `dims`; refused with `MemoryError`
    /// past `max_memory_mib`.
    #[pyo3(signature = (max_memory_mib = 4096))]
    fn dense<'py>(
        &self,
        py: Python<'py>,
        max_memory_mib: u64,
    ) -> PyResult<Bound<'py, PyArray3<bool>>> {
        let [nx, ny, nz] = self.frame.dims;
        let cells = run(py, || {
            limit_of(max_memory_mib).check(
                &format!("a dense {nx}x{ny}x{nz} array"),
                nx as u128 * ny as u128 * nz as u128,
                1,
            )?;
            self.grid.check_inside(self.frame.dims)?;
            let mut cells = vec![false; nx * ny * nz];
            let slabs = self.slabs();
            let plane = ny * nz;
            // Slab s covers x in 8s..8s+8: one contiguous run of C-ordered
            // cells, written by one task.
            let mut chunks: Vec<Option<&mut [bool]>> =
                cells.chunks_mut(8 * plane).map(Some).collect();
            let work: Vec<(&Slab, &mut [bool])> = slabs
                .iter()
                .filter_map(|s| {
                    let bx = s[0].0.x as usize;
                    chunks.get_mut(bx).and_then(Option::take).map(|c| (s, c))
                })
                .collect();
            work.into_par_iter().for_each(|(slab, dst)| {
                for (k, cols) in slab {
                    for (col, &bits) in cols.iter().enumerate() {
                        let mut c = bits;
                        let (lx, ly) = (col % 8, col / 8);
                        let y = k.y as usize * 8 + ly;
                        while c != 0 {
                            let lz = c.trailing_zeros() as usize;
                            c &= c - 1;
                            dst[(lx * ny + y) * nz + k.z as usize * 8 + lz] = true;
                        }
                    }
                }
            });
            Ok(cells)
        })?;
        Ok(Array3::from_shape_vec((nx, ny, nz), cells)
            .expect("nx*ny*nz cells")
            .into_pyarray(py))
    }

    /// Writes the grid; the format follows the extension (`.binvox`,
    /// `.vox`, `.npy`, `.nrrd`), atomically.
    #[pyo3(signature = (path, overwrite = true))]
    fn save(&self, py: Python<'_>, path: PathBuf, overwrite: bool) -> PyResult<()> {
        run(py, || {
            write_voxels(&path, &self.grid, &self.frame, overwrite)
        })
    }

    /// Tunnel verdict of the grid alone, as `voxkit check --tunnels N
    /// --close K` decides it.
    #[pyo3(signature = (connectivity = 6, close = 1, max_memory_mib = 4096))]
    fn tunnels<'py>(
        &self,
        py: Python<'py>,
        connectivity: u32,
        close: u32,
        max_memory_mib: u64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let conn = match connectivity {
            6 => Connectivity::Six,
            26 => Connectivity::TwentySix,
            n => {
                return Err(value_error(format!(
                    "connectivity must be 6 or 26, got {n}"
                )));
            }
        };
        let limit = limit_of(max_memory_mib);
        let (verdict, enclosed) = run(py, || {
            let occ = self.grid.to_bit_grid(self.frame.dims, limit)?;
            let mut closed = occ.clone();
            for _ in 0..close {
                closed = voxkit::cli::dilate26(&closed, limit)?;
            }
            let inside = voxkit::cli::enclosed_empty(&closed, limit)?;
            drop(closed);
            limit.check("inside seeds", inside.len() as u128, 12)?;
            Ok((closed_surface_tunnels(&occ, conn, &inside)?, inside.len()))
        })?;
        let d = PyDict::new(py);
        d.set_item("tunnel", verdict.tunnel)?;
        d.set_item("connectivity", connectivity)?;
        d.set_item("close", close)?;
        d.set_item("enclosed", enclosed)?;
        d.set_item(
            "first_inside_reached",
            verdict.first_inside_reached.map(|v| (v.x, v.y, v.z)),
        )?;
        d.set_item("outside_empty", verdict.outside_empty)?;
        d.set_item("inside_empty", verdict.inside_empty)?;
        Ok(d)
    }

    /// The library's error measures of these voxels against a mesh, on
    /// this grid's lattice (`voxkit measure`).
    #[pyo3(signature = (vertices, faces, max_memory_mib = 4096))]
    fn measure<'py>(
        &self,
        py: Python<'py>,
        vertices: &Bound<'py, PyAny>,
        faces: &Bound<'py, PyAny>,
        max_memory_mib: u64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mesh = convert::mesh(vertices, faces)?;
        let limit = limit_of(max_memory_mib);
        let m = run(py, || {
            if self.holds(&mesh) {
                // As `voxkit voxelize --measure`: the reference restricted
                // to the (closed) grid box, tunnels against the mesh as
                // voxelized (snapped or not).
                let exact = quantize_mesh(&mesh, &self.frame, false);
                let snapped = self.snap.then(|| quantize_mesh(&mesh, &self.frame, true));
                let voxelized = snapped.as_ref().unwrap_or(&exact);
                return measure_voxel_set(&self.grid, self.frame.dims, &exact, voxelized, limit);
            }
            let voxels: Vec<[i64; 3]> = self
                .grid
                .iter_unordered()
                .map(|v| v.to_array().map(i64::from))
                .collect();
            let (m, _) = measure_external(
                &mesh,
                self.frame.origin,
                self.frame.voxel_size,
                &voxels,
                limit,
            )?;
            Ok(m)
        })?;
        measures_dict(py, &m)
    }

    fn __repr__(&self) -> String {
        let o = self.frame.origin;
        format!(
            "VoxelGrid(dims={:?}, voxels={}, origin=({}, {}, {}), voxel_size={})",
            self.dims_tuple(),
            self.count,
            o.x,
            o.y,
            o.z,
            self.frame.voxel_size
        )
    }
}

/// `(vertices (N,3) float64, faces (M,3) int64)` of an OBJ, glTF/GLB, PLY,
/// STL or OFF file (chosen by extension, as `Mesh::load` does).
#[pyfunction]
pub fn load_mesh<'py>(py: Python<'py>, path: PathBuf) -> PyResult<MeshArrays<'py>> {
    let mesh = run(py, || Mesh::load(&path))?;
    warn_each(py, &path, &mesh.summary.warnings)?;
    let v: Vec<f64> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
    let f: Vec<i64> = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(i64::from))
        .collect();
    let (nv, nf) = (mesh.positions.len(), mesh.triangles.len());
    Ok((
        Array2::from_shape_vec((nv, 3), v)
            .expect("3 per vertex")
            .into_pyarray(py),
        Array2::from_shape_vec((nf, 3), f)
            .expect("3 per face")
            .into_pyarray(py),
    ))
}

/// Voxelizes vertex and face arrays (see `voxkit.voxelize`).
#[pyfunction]
#[pyo3(signature = (vertices, faces, resolution = None, voxel_size = None, origin = None, mode = "thin", snap = false, max_memory_mib = 4096, threads = None, inside = "winding"))]
#[allow(clippy::too_many_arguments)]
pub fn voxelize(
    py: Python<'_>,
    vertices: &Bound<'_, PyAny>,
    faces: &Bound<'_, PyAny>,
    resolution: Option<i64>,
    voxel_size: Option<f64>,
    origin: Option<[f64; 3]>,
    mode: &str,
    snap: bool,
    max_memory_mib: u64,
    threads: Option<usize>,
    inside: &str,
) -> PyResult<Grid> {
    let mode = mode_of(mode)?;
    let inside = inside_of(inside)?;
    let lattice = match (resolution, voxel_size) {
        (Some(_), Some(_)) => {
            return Err(value_error("give resolution or voxel_size, not both"));
        }
        (None, Some(h)) => Lattice::VoxelSize {
            voxel_size: h,
            origin: convert::vec3(origin),
        },
        (r, None) => {
            if origin.is_some() {
                return Err(value_error("origin applies only with voxel_size"));
            }
            let r = r.unwrap_or(256);
            let r = u32::try_from(r)
                .ok()
                .filter(|&r| r >= 1)
                .ok_or_else(|| value_error(format!("resolution must be in 1..2^32, got {r}")))?;
            Lattice::Resolution(r)
        }
    };
    let mesh = convert::mesh(vertices, faces)?;
    let mut opts = VoxelizeOptions::on_lattice(lattice, mode);
    opts.snap = snap;
    opts.inside = inside;
    opts.limit = limit_of(max_memory_mib);
    let v = run_threads(py, threads, || voxelize_mesh(&mesh, &opts))?;
    Ok(Grid::new(v.grid, v.frame, Some(v.stats), snap))
}

/// Reads a voxel file (`.binvox`, `.vox`, `.npy`, `.nrrd`) or OME-Zarr store
/// (`.zarr`; `level` > 0 reads that level of its pyramid).
#[pyfunction]
#[pyo3(signature = (path, max_memory_mib = 4096, level = 0))]
pub fn load_grid(py: Python<'_>, path: PathBuf, max_memory_mib: u64, level: u32) -> PyResult<Grid> {
    if level > 0 {
        if !voxkit::io::zarr::is_zarr_path(&path) {
            return Err(value_error(format!(
                "{}: level {level} applies to the pyramid of a .zarr store",
                path.display()
            )));
        }
        let (grid, frame) = run(py, || {
            voxkit::io::zarr::read_level(&path, level, limit_of(max_memory_mib))
        })?;
        return Ok(Grid::new(grid, frame, None, false));
    }
    let (grid, frame, warnings) = run(py, || read_voxels_warned(&path, limit_of(max_memory_mib)))?;
    warn_each(py, &path, &warnings)?;
    Ok(Grid::new(grid, frame, None, false))
}

/// Issues each of a reader's warnings (what it skipped while still reading
/// the file: hidden .vox layers, glTF extensions ignored, ...) as a Python
/// `UserWarning` naming the file, as the command line prints them.
fn warn_each(py: Python<'_>, path: &std::path::Path, warnings: &[String]) -> PyResult<()> {
    warn_about(py, &path.display().to_string(), warnings)
}

/// Issues each of `warnings` about `what` (a file, or an array) as a
/// Python `UserWarning`, `"{what}: {warning}"`.
pub(crate) fn warn_about(py: Python<'_>, what: &str, warnings: &[String]) -> PyResult<()> {
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    for w in warnings {
        let msg = std::ffi::CString::new(format!("{what}: {w}"))
            .unwrap_or_else(|_| c"(a warning with a NUL byte)".to_owned());
        PyErr::warn(py, &category, &msg, 1)?;
    }
    Ok(())
}

/// The library's error measures of any tool's `(K, 3)` voxel indices on
/// the lattice `origin + i·voxel_size` (`voxkit measure`).
#[pyfunction]
#[pyo3(signature = (vertices, faces, indices, origin, voxel_size, max_memory_mib = 4096))]
pub fn measure_indices<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    indices: &Bound<'py, PyAny>,
    origin: [f64; 3],
    voxel_size: f64,
    max_memory_mib: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = convert::mesh(vertices, faces)?;
    let voxels = convert::index_rows(indices)?;
    let (m, _) = run(py, || {
        measure_external(
            &mesh,
            DVec3::from_array(origin),
            voxel_size,
            &voxels,
            limit_of(max_memory_mib),
        )
    })?;
    measures_dict(py, &m)
}

/// Options of a tiled run (`--voxel-size H --origin X,Y,Z`, mode, inside).
fn tiled_options(
    voxel_size: f64,
    origin: Option<[f64; 3]>,
    mode: &str,
    inside: &str,
    max_memory_mib: u64,
) -> PyResult<VoxelizeOptions> {
    let mut opts = VoxelizeOptions::on_lattice(
        Lattice::VoxelSize {
            voxel_size,
            origin: convert::vec3(origin),
        },
        mode_of(mode)?,
    );
    opts.inside = inside_of(inside)?;
    opts.limit = limit_of(max_memory_mib);
    Ok(opts)
}

/// Plans a tiled run into an OME-Zarr store (`voxkit voxelize … --plan`):
/// writes the store's metadata and returns the plan as a JSON string.
#[pyfunction]
#[pyo3(signature = (mesh_path, store, voxel_size, origin, tile_size, mode = "thin", inside = "winding", force = false, max_memory_mib = 4096, pyramid = false))]
#[allow(clippy::too_many_arguments)]
pub fn plan_tiles(
    py: Python<'_>,
    mesh_path: PathBuf,
    store: PathBuf,
    voxel_size: f64,
    origin: Option<[f64; 3]>,
    tile_size: u32,
    mode: &str,
    inside: &str,
    force: bool,
    max_memory_mib: u64,
    pyramid: bool,
) -> PyResult<String> {
    let opts = tiled_options(voxel_size, origin, mode, inside, max_memory_mib)?;
    let j = run(py, || {
        voxkit::tiled::plan(&mesh_path, &store, &opts, tile_size, force, pyramid)
    })?;
    Ok(j.to_string())
}

/// Builds the pyramid levels of a tiled store that span several tiles
/// (`voxkit voxelize … --finish`), once every tile is done; returns the
/// report as a JSON string.
#[pyfunction]
#[pyo3(signature = (store, max_memory_mib = 4096))]
pub fn finish_tiles(py: Python<'_>, store: PathBuf, max_memory_mib: u64) -> PyResult<String> {
    let j = run(py, || {
        voxkit::tiled::finish(&store, limit_of(max_memory_mib))
    })?;
    Ok(j.to_string())
}

/// Voxelizes one tile into a planned store (`voxkit voxelize … --tile
/// I,J,K`) and returns its report as a JSON string.
#[pyfunction]
#[pyo3(signature = (mesh_path, store, voxel_size, origin, tile_size, tile, mode = "thin", inside = "winding", max_memory_mib = 4096, threads = None))]
#[allow(clippy::too_many_arguments)]
pub fn voxelize_tile(
    py: Python<'_>,
    mesh_path: PathBuf,
    store: PathBuf,
    voxel_size: f64,
    origin: Option<[f64; 3]>,
    tile_size: u32,
    tile: [u32; 3],
    mode: &str,
    inside: &str,
    max_memory_mib: u64,
    threads: Option<usize>,
) -> PyResult<String> {
    let opts = tiled_options(voxel_size, origin, mode, inside, max_memory_mib)?;
    let j = run_threads(py, threads, || {
        voxkit::tiled::run_tile(&mesh_path, &store, &opts, tile_size, tile)
    })?;
    Ok(j.to_string())
}
