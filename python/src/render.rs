//! `render` and `read_volume`: the library's ray caster (`voxkit render`)
//! on a voxel grid or a scalar volume, with the command line's defaults.

use clap::ValueEnum;
use glam::{DMat3, DVec3};
use ndarray::{Array1, Array2, Array3, ShapeBuilder};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use voxkit::VoxkitError;
use voxkit::camera::{Camera, SceneAxes, ViewPreset};
use voxkit::grid::{
    AnatomicalSpace, BrickGrid, GridFrame, MemoryLimit, ScalarVolume, VolumeData, VolumeFrame,
};
use voxkit::io::zarr::ChunkReader;
use voxkit::render::{
    GridTransform, NormalMode, OccupancyGrid, PagedOccupancy, PixelWindow, RayKind, RenderBricks,
    RenderImage, RenderOptions, Sampling, TransferFunction, VolumeMethod, VolumeMode,
    VolumeOptions, VolumeScene, occupied_world_box, render_grid_window,
};

use crate::grid::{Grid, limit_of};
use crate::{run, value_error};

/// A `ValueEnum` of the library by its command-line name.
fn named<T: ValueEnum>(what: &str, s: &str) -> PyResult<T> {
    T::from_str(s, true).map_err(|_| {
        let names: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value().map(|p| format!("{:?}", p.get_name())))
            .collect();
        value_error(format!(
            "{what} must be one of {}, got {s:?}",
            names.join(", ")
        ))
    })
}

/// The camera and image options shared by grids and volumes.
pub struct View {
    width: u32,
    height: u32,
    eye: Option<DVec3>,
    target: Option<DVec3>,
    up: Option<DVec3>,
    fov: f64,
    ortho: bool,
    view: ViewPreset,
    opts: RenderOptions,
}

impl View {
    /// The camera for the world box `[lo, hi]`, as `voxkit render` places
    /// it: `--eye` (looking at `--target`, default the box centre), or the
    /// preset view framing the box, moved to look at `--target` if given.
    fn camera(&self, lo: DVec3, hi: DVec3, axes: SceneAxes) -> voxkit::Result<Camera> {
        if !(self.fov > 0.0 && self.fov < 180.0) {
            return Err(VoxkitError::invalid(format!(
                "fov {}: the field of view must be in (0, 180) degrees",
                self.fov
            )));
        }
        let (dir, preset_up) = axes.view(self.view);
        let up = self.up.unwrap_or(preset_up);
        let target = self.target.unwrap_or((lo + hi) * 0.5);
        Ok(match self.eye {
            Some(eye) if self.ortho => {
                Camera::orthographic(eye, target, up, (hi - lo).length().max(1e-9))
            }
            Some(eye) => Camera::perspective(eye, target, up, self.fov),
            None => {
                let fov = (!self.ortho).then_some(self.fov);
                let mut c = Camera::framing(lo, hi, dir, up, fov, self.width, self.height)?;
                if let Some(t) = self.target {
                    c.eye += t - c.target;
                    c.target = t;
                }
                c
            }
        })
    }
}

#[allow(clippy::too_many_arguments)]
fn view_of(
    size: (u32, u32),
    eye: Option<[f64; 3]>,
    target: Option<[f64; 3]>,
    up: Option<[f64; 3]>,
    fov: f64,
    ortho: bool,
    view: &str,
    ray: &str,
    skip: bool,
    normals: &str,
    background: [f64; 3],
    max_memory_mib: u64,
) -> PyResult<View> {
    let (width, height) = size;
    let opts = RenderOptions {
        width,
        height,
        ray: named::<RayKind>("ray", ray)?,
        skip,
        normals: named::<NormalMode>("normals", normals)?,
        background: background.map(|c| c as f32),
        limit: limit_of(max_memory_mib),
        ..RenderOptions::default()
    };
    Ok(View {
        width,
        height,
        eye: eye.map(DVec3::from_array),
        target: target.map(DVec3::from_array),
        up: up.map(DVec3::from_array),
        fov,
        ortho,
        view: named::<ViewPreset>("view", view)?,
        opts,
    })
}

type Image<'py> = (Bound<'py, PyArray3<u8>>, Bound<'py, PyArray2<f32>>);

/// `(rgb (H, W, 3) uint8, depth (H, W) float32)` of a rendered image.
fn to_arrays<'py>(py: Python<'py>, img: RenderImage, background: [f32; 3]) -> Image<'py> {
    let (w, h) = (img.width as usize, img.height as usize);
    let mut rgb = img.to_rgba8(background);
    // RGBA → RGB in place (each pixel moves left; never over one unread).
    for p in 0..w * h {
        rgb.copy_within(4 * p..4 * p + 3, 3 * p);
    }
    rgb.truncate(3 * w * h);
    (
        Array3::from_shape_vec((h, w, 3), rgb)
            .expect("3 bytes per pixel")
            .into_pyarray(py),
        Array2::from_shape_vec((h, w), img.depth)
            .expect("one depth per pixel")
            .into_pyarray(py),
    )
}

/// Renders a voxel grid, or a store opened by `open_store` (its world
/// frame; Y up, as `voxkit render` takes binvox/npy/NRRD grids and stores).
#[pyfunction]
#[pyo3(signature = (grid, size, eye, target, up, fov, ortho, view, ray, skip, normals, background, max_memory_mib, pixels = None))]
#[allow(clippy::too_many_arguments)]
pub fn render_grid<'py>(
    py: Python<'py>,
    grid: &Bound<'py, PyAny>,
    size: (u32, u32),
    eye: Option<[f64; 3]>,
    target: Option<[f64; 3]>,
    up: Option<[f64; 3]>,
    fov: f64,
    ortho: bool,
    view: &str,
    ray: &str,
    skip: bool,
    normals: &str,
    background: [f64; 3],
    max_memory_mib: u64,
    pixels: Option<(u32, u32, u32, u32)>,
) -> PyResult<Image<'py>> {
    let v = view_of(
        size,
        eye,
        target,
        up,
        fov,
        ortho,
        view,
        ray,
        skip,
        normals,
        background,
        max_memory_mib,
    )?;
    let window = window_of(&v, pixels);
    let img = if let Ok(store) = grid.cast::<Store>() {
        let store = store.get();
        run(py, || {
            render_with(&store.paged, &store.xf, SceneAxes::Y_UP, &v, window)
        })?
    } else {
        let grid = grid.cast::<Grid>()?.get();
        run(py, || {
            render_occupancy(&grid.grid, &grid.frame, SceneAxes::Y_UP, &v, window)
        })?
    };
    Ok(to_arrays(py, img, v.opts.background))
}

/// The pixels to render: `(x, y, width, height)` of the frame, or all.
fn window_of(v: &View, pixels: Option<(u32, u32, u32, u32)>) -> PixelWindow {
    match pixels {
        Some((x, y, width, height)) => PixelWindow {
            x,
            y,
            width,
            height,
        },
        None => PixelWindow::full(&v.opts),
    }
}

/// A voxel store (`.zarr` that voxkit wrote) opened for rendering: its
/// chunks are decoded as rays reach them and kept for later renders.
#[pyclass(module = "voxkit._voxkit", name = "Store", frozen)]
pub struct Store {
    paged: PagedOccupancy,
    xf: GridTransform,
}

#[pymethods]
impl Store {
    /// Grid extents `[nx, ny, nz]`.
    #[getter]
    fn dims(&self) -> [usize; 3] {
        self.paged.dims()
    }
    /// Chunks (64³) the store holds.
    #[getter]
    fn stored_chunks(&self) -> usize {
        self.paged.stored_chunks()
    }
    /// Chunks decoded by the renders so far.
    #[getter]
    fn chunks_decoded(&self) -> u64 {
        self.paged.chunks_decoded()
    }
    /// Render pages built so far.
    #[getter]
    fn pages_built(&self) -> u64 {
        self.paged.pages_built()
    }
    /// Bytes held: chunk tables, decoded chunks and pages.
    #[getter]
    fn memory_bytes(&self) -> u64 {
        self.paged.heap_bytes()
    }
}

/// Opens level `level` of the store at `path` for rendering, or `None`
/// when another tool wrote it (load it with `load_grid` instead).
#[pyfunction]
#[pyo3(signature = (path, level, max_memory_mib))]
pub fn open_store(
    py: Python<'_>,
    path: std::path::PathBuf,
    level: u32,
    max_memory_mib: u64,
) -> PyResult<Option<Store>> {
    let limit = limit_of(max_memory_mib);
    run(py, || {
        let Some(reader) = ChunkReader::open(&path, level, limit)? else {
            return Ok(None);
        };
        let xf = GridTransform::from_frame(reader.frame())?;
        Ok(Some(Store {
            paged: PagedOccupancy::new(reader, limit)?,
            xf,
        }))
    })
}

fn render_occupancy(
    grid: &BrickGrid,
    frame: &GridFrame,
    axes: SceneAxes,
    v: &View,
    window: PixelWindow,
) -> voxkit::Result<RenderImage> {
    let xf = GridTransform::from_frame(frame)?;
    render_in(grid, frame.dims, &xf, axes, v, window)
}

fn render_in(
    grid: &BrickGrid,
    dims: [usize; 3],
    xf: &GridTransform,
    axes: SceneAxes,
    v: &View,
    window: PixelWindow,
) -> voxkit::Result<RenderImage> {
    let occ = OccupancyGrid::new(grid, dims, v.opts.limit)?;
    render_with(&occ, xf, axes, v, window)
}

/// Frames the occupied voxels (unless the view places the camera) and
/// renders the window.
fn render_with<G: RenderBricks>(
    occ: &G,
    xf: &GridTransform,
    axes: SceneAxes,
    v: &View,
    window: PixelWindow,
) -> voxkit::Result<RenderImage> {
    let (lo, hi) = occupied_world_box(occ, xf);
    let cam = v.camera(lo, hi, axes)?;
    Ok(render_grid_window(occ, xf, &cam, &v.opts, window)?.0)
}

/// Writes an `(H, W, 3)` or `(H, W, 4)` uint8 image as a PNG file
/// (atomically; an existing file is replaced only if `overwrite`).
#[pyfunction]
#[pyo3(signature = (path, image, overwrite = false))]
pub fn write_png(
    py: Python<'_>,
    path: std::path::PathBuf,
    image: numpy::PyReadonlyArray3<'_, u8>,
    overwrite: bool,
) -> PyResult<()> {
    let a = image.as_array();
    let (h, w, c) = a.dim();
    if c != 3 && c != 4 {
        return Err(value_error(format!(
            "expected an (H, W, 3) or (H, W, 4) uint8 image, got shape ({h}, {w}, {c})"
        )));
    }
    let (Ok(width), Ok(height)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(value_error(format!("image {w}x{h} is too large for PNG")));
    };
    let mut rgba = Vec::with_capacity(w * h * 4);
    for row in a.outer_iter() {
        for px in row.outer_iter() {
            rgba.extend_from_slice(&[px[0], px[1], px[2], if c == 4 { px[3] } else { 255 }]);
        }
    }
    run(py, || {
        voxkit::io::image::write_png_rgba(&path, width, height, &rgba, overwrite)
    })
}

/// The samples of a 3D array in x-fastest order (any layout).
fn samples<T: numpy::Element + Copy>(a: &Bound<'_, PyAny>) -> Option<([usize; 3], Vec<T>)> {
    let a = a.cast::<PyArray3<T>>().ok()?;
    let ro = a.readonly();
    let view = ro.as_array();
    let s = view.shape();
    let dims = [s[0], s[1], s[2]];
    // The transposed view iterates with axis 0 (x) fastest.
    Some((dims, view.t().iter().copied().collect()))
}

/// A `ScalarVolume` from a 3D numpy array indexed `[x, y, z]`, placed by
/// `axes` where given (its rows as numpy holds them; its columns are the
/// world steps of the grid axes: `world = origin + axes · (i, j, k)`), else
/// by `spacing` along the world axes; in `space` where named.
fn volume_of(
    array: &Bound<'_, PyAny>,
    spacing: [f64; 3],
    origin: [f64; 3],
    axes: Option<[[f64; 3]; 3]>,
    space: Option<&str>,
) -> PyResult<ScalarVolume> {
    let (dims, data) = if let Some((d, v)) = samples::<bool>(array) {
        (d, VolumeData::U8(v.into_iter().map(u8::from).collect()))
    } else if let Some((d, v)) = samples::<u8>(array) {
        (d, VolumeData::U8(v))
    } else if let Some((d, v)) = samples::<i8>(array) {
        (d, VolumeData::I8(v))
    } else if let Some((d, v)) = samples::<i16>(array) {
        (d, VolumeData::I16(v))
    } else if let Some((d, v)) = samples::<u16>(array) {
        (d, VolumeData::U16(v))
    } else if let Some((d, v)) = samples::<i32>(array) {
        (d, VolumeData::I32(v))
    } else if let Some((d, v)) = samples::<u32>(array) {
        (d, VolumeData::U32(v))
    } else if let Some((d, v)) = samples::<f32>(array) {
        (d, VolumeData::F32(v))
    } else if let Some((d, v)) = samples::<f64>(array) {
        (d, VolumeData::F64(v))
    } else if let Some((d, v)) = samples::<i64>(array) {
        // NumPy's default integer type: in the narrowest type that holds
        // every sample exactly.
        (d, VolumeData::from_i64(v))
    } else if let Some((d, v)) = samples::<u64>(array) {
        (d, VolumeData::from_u64(v))
    } else {
        let got = match array.cast::<numpy::PyUntypedArray>() {
            Ok(a) => format!("shape {:?}, dtype {}", a.shape(), a.dtype()),
            Err(_) => "not a numpy array".to_string(),
        };
        return Err(value_error(format!(
            "a volume must be a 3D array of bool, (u)int8/16/32/64, float16/32 or float64 ({got})"
        )));
    };
    let origin = DVec3::from_array(origin);
    let frame = match axes {
        Some(rows) => VolumeFrame {
            origin,
            axes: DMat3::from_cols_array_2d(&rows).transpose(),
        },
        None => VolumeFrame::from_spacing(origin, DVec3::from_array(spacing)),
    };
    let space = space.map(space_of).transpose()?;
    Ok(ScalarVolume::new(dims, data, frame)
        .map_err(crate::to_py_err)?
        .with_space(space))
}

/// An anatomical space by name: `"RAS"`, `"LAS"` or `"LPS"` (any case, or
/// NRRD's long names).
fn space_of(name: &str) -> PyResult<AnatomicalSpace> {
    AnatomicalSpace::from_nrrd(name).ok_or_else(|| {
        value_error(format!(
            "space must be \"RAS\", \"LAS\" or \"LPS\" (or None), got {name:?}"
        ))
    })
}

/// The short name of an anatomical space, as [`space_of`] reads it.
fn space_name(space: AnatomicalSpace) -> &'static str {
    match space {
        AnatomicalSpace::Ras => "RAS",
        AnatomicalSpace::Las => "LAS",
        AnatomicalSpace::Lps => "LPS",
    }
}

/// Renders a scalar volume (`voxkit render` on a volume file): MIP,
/// compositing or an iso-surface; a 0/1 volume without `volume` renders as
/// a voxel grid, as on the command line. Z up.
#[pyfunction]
#[pyo3(signature = (array, spacing, origin, axes, space, size, eye, target, up, fov, ortho, view, ray, skip, normals, background, max_memory_mib, volume, iso, window, tf, sampling, method))]
#[allow(clippy::too_many_arguments)]
pub fn render_volume<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    spacing: [f64; 3],
    origin: [f64; 3],
    axes: Option<[[f64; 3]; 3]>,
    space: Option<&str>,
    size: (u32, u32),
    eye: Option<[f64; 3]>,
    target: Option<[f64; 3]>,
    up: Option<[f64; 3]>,
    fov: f64,
    ortho: bool,
    view: &str,
    ray: &str,
    skip: bool,
    normals: &str,
    background: [f64; 3],
    max_memory_mib: u64,
    volume: Option<&str>,
    iso: Option<f32>,
    window: Option<(f32, f32)>,
    tf: Option<&str>,
    sampling: &str,
    method: &str,
) -> PyResult<Image<'py>> {
    let v = view_of(
        size,
        eye,
        target,
        up,
        fov,
        ortho,
        view,
        ray,
        skip,
        normals,
        background,
        max_memory_mib,
    )?;
    let sampling = named::<Sampling>("sampling", sampling)?;
    let method = named::<VolumeMethod>("method", method)?;
    let mode = match volume {
        None | Some("mip") => None,
        Some("composite") => Some(VolumeMode::Composite),
        Some("iso") => Some(VolumeMode::Iso(f32::NAN)),
        Some(other) => {
            return Err(value_error(format!(
                "volume must be \"mip\", \"composite\" or \"iso\", got {other:?}"
            )));
        }
    };
    if iso.is_some() && volume != Some("iso") {
        return Err(value_error("iso applies only with volume=\"iso\""));
    }
    if let Some((lo, hi)) = window
        && !(lo.is_finite() && hi.is_finite() && lo < hi)
    {
        return Err(value_error(format!(
            "window must be (lo, hi) with lo < hi, got ({lo}, {hi})"
        )));
    }
    let vol = volume_of(array, spacing, origin, axes, space)?;
    let tf = tf.map(str::to_string);
    let (img, warnings) = run(py, || {
        if volume.is_none() && vol.is_binary() {
            // A 0/1 grid: occupancy, as `voxkit render` treats it.
            let xf = GridTransform::new(vol.frame.origin, vol.frame.axes)?;
            let full = PixelWindow::full(&v.opts);
            let img = render_in(
                &vol.to_brick_grid(),
                vol.dims,
                &xf,
                SceneAxes::Y_UP,
                &v,
                full,
            )?;
            return Ok((img, Vec::new()));
        }
        // The default window reads every sample: only when none is given,
        // and then while the bricks are built.
        let (scene, w) = match window {
            Some(w) => (VolumeScene::from_volume(vol, v.opts.limit)?, w),
            None => VolumeScene::with_default_window(vol, v.opts.limit)?,
        };
        let mut vopts = VolumeOptions::with_window(VolumeMode::Mip, w);
        if let Some(tf) = &tf {
            vopts.transfer = TransferFunction::parse(tf)?;
        }
        vopts.sampling = sampling;
        vopts.method = method;
        vopts.mode = match mode {
            None => VolumeMode::Mip,
            Some(VolumeMode::Iso(_)) => {
                let level = iso.unwrap_or(vopts.middle_of_window());
                if !level.is_finite() {
                    return Err(VoxkitError::invalid("iso must be a finite value"));
                }
                VolumeMode::Iso(level)
            }
            Some(m) => m,
        };
        let xf = *scene.transform();
        let d = scene.dims().map(|x| x as f64);
        let (lo, hi) = xf.world_bounds(DVec3::splat(-0.5), DVec3::from_array(d) - 0.5);
        let cam = v.camera(lo, hi, scene.scene_axes())?;
        let img = voxkit::render::render_volume(&scene, &cam, &v.opts, &vopts)?.0;
        Ok((img, scene.warnings()))
    })?;
    crate::grid::warn_about(py, "volume", &warnings)?;
    Ok(to_arrays(py, img, v.opts.background))
}

/// What [`read_volume`] returns: `(array, spacing, origin, axes, space)`.
type VolumeParts<'py> = (
    Bound<'py, PyAny>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
    Option<&'static str>,
);

/// `(array [x, y, z] in the file's dtype (Fortran order: no copy), spacing
/// (3,), origin (3,), axes (3, 3), space)` of a scalar-volume file (NRRD /
/// NHDR, MetaImage, NIfTI, .npy). `origin` is the world position of voxel
/// (0, 0, 0)'s centre; `axes` the frame, `world = origin + axes · (i, j,
/// k)` (its columns are the grid axes' world steps); `spacing` their
/// lengths; `space` `"RAS"`, `"LAS"`, `"LPS"` or `None`.
#[pyfunction]
#[pyo3(signature = (path, max_memory_mib))]
pub fn read_volume<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    max_memory_mib: u64,
) -> PyResult<VolumeParts<'py>> {
    let vol = run(py, || {
        voxkit::io::volume::read_volume(&path, MemoryLimit::new(max_memory_mib << 20))
    })?;
    let [nx, ny, nz] = vol.dims;
    let shape = (nx, ny, nz).f();
    macro_rules! arr {
        ($v:expr) => {
            Array3::from_shape_vec(shape, $v)
                .expect("nx*ny*nz samples")
                .into_pyarray(py)
                .into_any()
        };
    }
    let (frame, space) = (vol.frame, vol.space);
    let array = match vol.data {
        VolumeData::I8(v) => arr!(v),
        VolumeData::U8(v) => arr!(v),
        VolumeData::I16(v) => arr!(v),
        VolumeData::U16(v) => arr!(v),
        VolumeData::I32(v) => arr!(v),
        VolumeData::U32(v) => arr!(v),
        VolumeData::F32(v) => arr!(v),
        VolumeData::F64(v) => arr!(v),
    };
    let spacing = Array1::from_vec(frame.spacing().to_array().to_vec()).into_pyarray(py);
    let origin = Array1::from_vec(frame.origin.to_array().to_vec()).into_pyarray(py);
    let rows = frame.axes.transpose().to_cols_array();
    let axes = Array2::from_shape_vec((3, 3), rows.to_vec())
        .expect("3x3")
        .into_pyarray(py);
    Ok((array, spacing, origin, axes, space.map(space_name)))
}
