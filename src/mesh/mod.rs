//! Triangle meshes and polylines as the voxelizer takes them, with loaders for
//! Wavefront OBJ ([`obj`]), glTF 2.0 ([`gltf`]), Stanford PLY ([`ply`]),
//! STL ([`stl`]) and OFF ([`off`]), validation, bounds and the `-r N` grid
//! fitting rule.
//!
//! Each format module has `load(path)` and a byte-based `parse` (what the
//! fuzzers call); [`Mesh::load`] picks the module by extension. Polygons with
//! more than three vertices are fan-triangulated (`0, k, k+1`) in every
//! format. Calls into the parsing crates run under [`crate::guard::contain`],
//! so a panic inside one becomes a typed error. Sizes in headers (PLY element
//! counts, the binary STL triangle count, OFF counts) are checked against the
//! bytes present before anything is allocated from them.
//!
//! Every loader ends in [`Mesh::from_parts`], which is where validation lives:
//! non-finite coordinates and out-of-range indices are errors naming the file
//! and the element; degenerate triangles (a repeated index, or an exactly zero
//! cross product in f64) are dropped and counted in [`LoadSummary`]; a mesh
//! with nothing left is an error.
//!
//! # Fitting (`-r N`)
//! [`fit_frame`] makes the longest side of the bounding box span exactly `N`
//! voxels (`h = longest / N`), the other sides `ceil(side / h)` voxels (at
//! least 1), with the grid origin at the bounding box's min corner. A vertex
//! on the *min* face maps to grid coordinate `-0.5`, which the voxel rule
//! `floor(p + 0.5)` puts in voxel 0. A vertex on the *max* face maps to
//! `dims - 0.5`, which that rule would put in voxel `dims`, one past the grid:
//! **the fitted grid box is closed at its max faces**, i.e. such a vertex is
//! kept in voxel `dims - 1`. [`fitted_voxel`] applies this rule (it clamps the
//! voxel index into `0..dims`, which only ever moves points on, or within
//! rounding of, the max face). With `padding > 0` ([`fit_frame_padded`]) the
//! rule is not needed: voxel `dims - padding` lies inside the grid.

pub mod bundled;
pub mod gltf;
pub mod obj;
pub mod off;
pub mod ply;
pub mod stl;

use std::path::Path;

use glam::DVec3;

use crate::error::{Result, VoxkitError};
use crate::grid::{GridFrame, Voxel};

/// What a loader read and what it dropped.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadSummary {
    /// Vertices in [`Mesh::positions`].
    pub vertices: usize,
    /// Triangles kept in [`Mesh::triangles`].
    pub triangles: usize,
    /// Polylines kept in [`Mesh::polylines`].
    pub polylines: usize,
    /// Segments over all kept polylines.
    pub polyline_segments: usize,
    /// Triangles dropped as degenerate (a repeated index, or zero area in f64).
    pub degenerate_triangles: usize,
    /// Polylines dropped because they had fewer than two vertices.
    pub degenerate_polylines: usize,
    /// Elements skipped because voxelization has no use for them (OBJ `p`
    /// records, glTF `POINTS` primitives): counted points.
    pub skipped_points: usize,
    /// What the loader ignored or could only partly read while still loading
    /// the geometry (an unreadable material library, vertex colours on only
    /// some vertices, ...): one human line each, printed to stderr by the
    /// command line and listed under `warnings` in its `--json` output.
    pub warnings: Vec<String>,
}

/// A triangle mesh plus polylines in f64 world coordinates.
///
/// Invariants (established by [`Mesh::from_parts`], which every loader uses):
/// every coordinate is finite, every index is `< positions.len()`, no
/// triangle is degenerate, every polyline has at least two vertices, and the
/// mesh has at least one triangle or polyline.
///
/// ```
/// use glam::DVec3;
/// use voxkit::mesh::Mesh;
/// let m = Mesh::from_parts(
///     "tri",
///     vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ONE],
///     vec![[0, 1, 2], [0, 0, 1]], // the second is degenerate
///     vec![vec![2, 3]],
/// ).unwrap();
/// assert_eq!(m.triangles.len(), 1);
/// assert_eq!(m.summary.degenerate_triangles, 1);
/// assert_eq!(m.bounds(), (DVec3::ZERO, DVec3::ONE));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Vertex positions in world coordinates.
    pub positions: Vec<DVec3>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// Polylines (open; a closed loop repeats its first index at the end) as
    /// indices into `positions`.
    pub polylines: Vec<Vec<u32>>,
    /// Counts of what was loaded and skipped.
    pub summary: LoadSummary,
}

impl Mesh {
    /// Builds a validated mesh. `name` (usually the file path) prefixes every
    /// error message. Degenerate triangles and polylines with fewer than two
    /// vertices are dropped and counted; non-finite coordinates, indices out
    /// of range and an empty result are [`VoxkitError::Invalid`].
    pub fn from_parts(
        name: &str,
        positions: Vec<DVec3>,
        triangles: Vec<[u32; 3]>,
        polylines: Vec<Vec<u32>>,
    ) -> Result<Mesh> {
        let mut summary = LoadSummary::default();
        Self::from_parts_with(name, positions, triangles, polylines, &mut summary)
    }

    /// As [`Mesh::from_parts`], starting from a summary that a loader has
    /// partly filled (e.g. with skipped points).
    pub(crate) fn from_parts_with(
        name: &str,
        positions: Vec<DVec3>,
        mut triangles: Vec<[u32; 3]>,
        mut polylines: Vec<Vec<u32>>,
        summary: &mut LoadSummary,
    ) -> Result<Mesh> {
        if positions.len() > u32::MAX as usize {
            return Err(VoxkitError::Unsupported(format!(
                "{name}: {} vertices; at most 2^32 - 1 are supported",
                positions.len()
            )));
        }
        if let Some((i, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(VoxkitError::invalid(format!(
                "{name}: vertex {i} has a non-finite coordinate ({}, {}, {})",
                p.x, p.y, p.z
            )));
        }
        let n = positions.len();
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(VoxkitError::invalid(format!(
                    "{name}: triangle {t} uses vertex index {i}, but there are {n} vertices"
                )));
            }
        }
        for (l, line) in polylines.iter().enumerate() {
            if let Some(&i) = line.iter().find(|&&i| i as usize >= n) {
                return Err(VoxkitError::invalid(format!(
                    "{name}: polyline {l} uses vertex index {i}, but there are {n} vertices"
                )));
            }
        }
        let before = triangles.len();
        triangles.retain(|t| !is_degenerate(&positions, t));
        summary.degenerate_triangles += before - triangles.len();
        let before = polylines.len();
        polylines.retain(|l| l.len() >= 2);
        summary.degenerate_polylines += before - polylines.len();
        if triangles.is_empty() && polylines.is_empty() {
            return Err(VoxkitError::invalid(format!(
                "{name}: empty mesh (no non-degenerate triangle and no polyline)"
            )));
        }
        summary.vertices = n;
        summary.triangles = triangles.len();
        summary.polylines = polylines.len();
        summary.polyline_segments = polylines.iter().map(|l| l.len() - 1).sum();
        Ok(Mesh {
            positions,
            triangles,
            polylines,
            summary: summary.clone(),
        })
    }

    /// Loads a mesh, choosing the loader by extension (any case): `.obj`
    /// ([`obj::load`]), `.gltf` / `.glb` ([`gltf::load`]), `.ply`
    /// ([`ply::load`]), `.stl` ([`stl::load`]), `.off` ([`off::load`]).
    pub fn load(path: &Path) -> Result<Mesh> {
        match extension_of(path).as_str() {
            "obj" => obj::load(path),
            "gltf" | "glb" => gltf::load(path),
            "ply" => ply::load(path),
            "stl" => stl::load(path),
            "off" => off::load(path),
            _ => Err(VoxkitError::Unsupported(format!(
                "{}: unknown mesh format (expected .obj, .gltf, .glb, .ply, .stl or .off)",
                path.display()
            ))),
        }
    }

    /// Axis-aligned bounds `(min, max)` of the vertices that triangles and
    /// polylines use (unused vertices do not count).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        use rayon::prelude::*;
        // In parallel: on a million triangles the serial scan, a gather by
        // index, was a third of quantizing. Minima and maxima do not depend
        // on the order.
        let empty = || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let join = |a: (DVec3, DVec3), b: (DVec3, DVec3)| (a.0.min(b.0), a.1.max(b.1));
        let add = |(lo, hi): (DVec3, DVec3), i: u32| {
            let p = self.positions[i as usize];
            (lo.min(p), hi.max(p))
        };
        let triangles = self
            .triangles
            .par_iter()
            .with_min_len(4096)
            .fold(empty, |b, t| t.iter().fold(b, |b, &i| add(b, i)))
            .reduce(empty, join);
        let lines = self
            .polylines
            .iter()
            .flatten()
            .fold(empty(), |b, &i| add(b, i));
        join(triangles, lines)
    }

    /// The three corners of triangle `t`.
    #[inline]
    pub fn triangle(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }
}

/// The file extensions (lower case, without the dot) that name a mesh
/// format voxkit reads. Batch voxelization picks files by this list.
pub const MESH_EXTENSIONS: &[&str] = &["obj", "gltf", "glb", "ply", "stl", "off"];

/// Whether `path` has a mesh extension ([`MESH_EXTENSIONS`], any case).
///
/// ```
/// use std::path::Path;
/// assert!(voxkit::mesh::is_mesh_path(Path::new("scan.PLY")));
/// assert!(!voxkit::mesh::is_mesh_path(Path::new("grid.binvox")));
/// ```
pub fn is_mesh_path(path: &Path) -> bool {
    MESH_EXTENSIONS.contains(&extension_of(path).as_str())
}

/// A mesh file's bytes; a failure is [`VoxkitError::Io`] naming the file.
fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| VoxkitError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Fan-triangulates one polygon (`0, k, k+1`) into `out`: every loader's
/// rule for faces with more than three vertices.
pub(crate) fn fan(idx: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..idx.len().saturating_sub(1) {
        out.push([idx[0], idx[k], idx[k + 1]]);
    }
}

/// At most 40 characters of `s` for a message, with "…" when cut.
pub(crate) fn clip(s: &str) -> String {
    match s.char_indices().nth(40) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

/// The lower-case extension of `path` ("" when it has none).
fn extension_of(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// A repeated index, or an exactly zero cross product of the edge vectors in
/// f64.
fn is_degenerate(p: &[DVec3], t: &[u32; 3]) -> bool {
    if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
        return true;
    }
    let [a, b, c] = t.map(|i| p[i as usize]);
    (b - a).cross(c - a) == DVec3::ZERO
}

/// The grid frame for `-r resolution` over the box `bounds = (min, max)`:
/// see the module docs for the rule. Equivalent to
/// [`fit_frame_padded`]`(bounds, resolution, 0)`.
///
/// ```
/// use glam::DVec3;
/// let f = voxkit::mesh::fit_frame((DVec3::ZERO, DVec3::new(2.0, 1.0, 0.3)), 10).unwrap();
/// assert_eq!(f.voxel_size, 0.2);
/// assert_eq!(f.dims, [10, 5, 2]);
/// assert_eq!(f.origin, DVec3::ZERO);
/// // A vertex on the max x face is kept in voxel 9, not 10.
/// let g = f.world_to_grid(DVec3::new(2.0, 1.0, 0.3));
/// assert_eq!(voxkit::mesh::fitted_voxel(&f, g).to_array(), [9, 4, 1]);
/// ```
pub fn fit_frame(bounds: (DVec3, DVec3), resolution: u32) -> Result<GridFrame> {
    fit_frame_padded(bounds, resolution, 0)
}

/// As [`fit_frame`], with `padding` empty voxels added on every side (the
/// origin moves down by `padding * h`, each extent grows by `2 * padding`).
pub fn fit_frame_padded(
    bounds: (DVec3, DVec3),
    resolution: u32,
    padding: u32,
) -> Result<GridFrame> {
    let (lo, hi) = bounds;
    if !lo.is_finite() || !hi.is_finite() || hi.cmplt(lo).any() {
        return Err(VoxkitError::invalid(format!(
            "cannot fit a grid to bounds {lo}..{hi}"
        )));
    }
    if resolution == 0 {
        return Err(VoxkitError::invalid("resolution must be at least 1"));
    }
    let ext = hi - lo;
    let longest = ext.max_element();
    if longest <= 0.0 {
        return Err(VoxkitError::invalid(format!(
            "cannot fit a grid to a single point {lo}: the bounding box has no extent"
        )));
    }
    let n = resolution as f64;
    let h = longest / n;
    let axis = ext
        .to_array()
        .iter()
        .position(|&e| e == longest)
        .unwrap_or(0);
    let mut dims = [0usize; 3];
    for a in 0..3 {
        dims[a] = if a == axis {
            resolution as usize
        } else {
            // `ext / longest * n` rather than `ext / h`: it cannot exceed `n`
            // by rounding, and an exact multiple stays exact.
            ((ext[a] / longest * n).ceil() as usize).clamp(1, resolution as usize)
        };
        dims[a] += 2 * padding as usize;
    }
    let origin = lo - DVec3::splat(padding as f64 * h);
    Ok(GridFrame::new(origin, h, dims))
}

/// The grid frame for voxel size `h` over the box `bounds = (min, max)`: the
/// grid lies on the lattice whose voxel corners are `origin + k·h` (`k`
/// integer; `origin` defaults to the box's min corner) and covers the box.
/// Its min corner is the lattice corner at or below the box's min on each
/// axis, and each side spans `ceil((max - corner) / h)` voxels (at least 1),
/// so, as with [`fit_frame`], the box is closed at its max faces: a vertex on
/// the last lattice plane is kept in voxel `dims - 1` ([`fitted_voxel`]).
/// A box end less than [`FIT_SLACK`] voxels beyond a lattice plane counts as
/// on it (`h = longest / N` rarely divides the box exactly in `f64`); such a
/// vertex is clamped onto the plane, which moves it less than the
/// voxelizer's 1/256-voxel rounding ever sees. So with the default origin and
/// `h` = [`fit_frame`]'s voxel size, the frames agree.
///
/// Fails with [`VoxkitError::Invalid`] for a size that is not finite and
/// positive, a non-finite origin or bounds, and with
/// [`VoxkitError::Unsupported`] when a side would span more than
/// [`MAX_FITTED_DIM`] voxels (the caller's memory estimate caps the rest).
///
/// ```
/// use glam::DVec3;
/// use voxkit::mesh::fit_frame_voxel_size;
/// let b = (DVec3::ZERO, DVec3::new(2.0, 1.0, 0.3));
/// let f = fit_frame_voxel_size(b, 0.2, None).unwrap();
/// assert_eq!((f.origin, f.dims), (DVec3::ZERO, [10, 5, 2]));
/// // A lattice pinned elsewhere: corners at 0.05 + 0.2·k, covering the box.
/// let f = fit_frame_voxel_size(b, 0.2, Some(DVec3::splat(0.05))).unwrap();
/// assert!((f.origin - DVec3::splat(-0.15)).length() < 1e-12);
/// assert_eq!(f.dims, [11, 6, 3]);
/// ```
pub fn fit_frame_voxel_size(
    bounds: (DVec3, DVec3),
    voxel_size: f64,
    origin: Option<DVec3>,
) -> Result<GridFrame> {
    let (lo, hi) = bounds;
    if !lo.is_finite() || !hi.is_finite() || hi.cmplt(lo).any() {
        return Err(VoxkitError::invalid(format!(
            "cannot fit a grid to bounds {lo}..{hi}"
        )));
    }
    if !(voxel_size.is_finite() && voxel_size > 0.0) {
        return Err(VoxkitError::invalid(format!(
            "voxel size must be finite and positive, got {voxel_size}"
        )));
    }
    let pin = origin.unwrap_or(lo);
    if !pin.is_finite() {
        return Err(VoxkitError::invalid(format!(
            "lattice origin must be finite, got {pin}"
        )));
    }
    let h = voxel_size;
    let mut corner = DVec3::ZERO;
    let mut dims = [0usize; 3];
    for a in 0..3 {
        // Whole voxels from the pinned corner down to the box (0 for the
        // default origin), and the sides' counts, with the box narrowed by
        // FIT_SLACK on both ends against rounding in the divisions.
        let k = ((lo[a] - pin[a]) / h + FIT_SLACK).floor();
        let n = ((hi[a] - pin[a]) / h - k - FIT_SLACK).ceil().max(1.0);
        if !(k.is_finite() && n.is_finite()) || n > MAX_FITTED_DIM as f64 {
            return Err(VoxkitError::Unsupported(format!(
                "voxel size {h} over bounds {lo}..{hi} needs more than {MAX_FITTED_DIM} voxels per axis"
            )));
        }
        corner[a] = pin[a] + k * h;
        dims[a] = n as usize;
    }
    Ok(GridFrame::new(corner, h, dims))
}

/// How far (in voxels) a box end may lie beyond a lattice plane and still
/// count as on it in [`fit_frame_voxel_size`]: 2^-10, under half of the
/// voxelizer's 1/256-voxel step, so clamping such a vertex onto the plane
/// does not change its fixed-point coordinate.
pub const FIT_SLACK: f64 = 1.0 / 1024.0;

/// The most voxels per axis a fitted grid may have (2^22).
pub const MAX_FITTED_DIM: usize = 1 << 22;

/// The voxel of grid-space point `g` in a fitted frame: `floor(g + 0.5)`,
/// clamped into `0..dims` so that points on the max faces of the grid box are
/// kept in the last voxel (the fitted box is closed; see the module docs).
#[inline]
pub fn fitted_voxel(frame: &GridFrame, g: DVec3) -> Voxel {
    let v = (g + DVec3::splat(0.5)).floor();
    Voxel::new(
        (v.x as i64).clamp(0, frame.dims[0] as i64 - 1) as i32,
        (v.y as i64).clamp(0, frame.dims[1] as i64 - 1) as i32,
        (v.z as i64).clamp(0, frame.dims[2] as i64 - 1) as i32,
    )
}
