//! Mesh → voxel grid: the pipeline behind `voxkit voxelize`.
//!
//! [`voxelize_mesh`] runs, in order:
//! 1. **fit** the grid frame to the mesh bounds ([`Lattice`]: [`fit_frame`]
//!    for `-r N`, [`fit_frame_voxel_size`] for a voxel size);
//! 2. **quantize** every vertex once to fixed-point grid coordinates with
//!    [`VOXEL_FRAC_BITS`] fraction bits (1/256 voxel), or with
//!    [`VoxelizeOptions::snap`] to the integer voxel lattice (the voxel the
//!    vertex lies in, [`fitted_voxel`]). Coordinates are clamped into the
//!    fitted box `[-1/2, dims - 1/2]`, which only moves points by float
//!    rounding. Triangles that become degenerate (all edge cross products
//!    exactly zero) are skipped and counted: their area went to zero, and
//!    since shared vertices are quantized once their neighbours still close
//!    the surface;
//! 3. **estimate memory** and refuse with [`VoxkitError::Limits`] before
//!    allocating anything large (see [`estimate_bytes`]);
//! 4. run the **mode** ([`VoxelizeMode`]) into a sparse [`BrickGrid`]. With
//!    [`VoxelizeOptions::snap`] and [`VoxelizeOptions::kahan_kelsen`], the
//!    thin and thick surfaces (and solid's thin surface) take the
//!    Kahan–Kelsen route of [`crate::voxelize::snapped`]: the same voxels as
//!    the crossing kernel, enumerated per projected lattice triangle and
//!    split evenly across threads by a prefix sum over point counts. It is
//!    not the default because on meshes of many small triangles it is 2–3×
//!    slower than the crossing kernel (per-triangle index set-up against
//!    10–20 points per projected triangle); it pays where a few huge
//!    triangles would otherwise leave a thread with most of the work.
//!
//! # Polylines
//! Every polyline segment `[a, b]` is voxelized by the line engine with the
//! connectivity of the mode, at the same 1/256-voxel endpoints:
//! * *thin* and *solid*: the 26-connected line ([`Line26`]), the thinnest
//!   connected set (`d26 + 1` voxels for lattice endpoints);
//! * *thick*: the 6-connected tripod line ([`Tripod6`]), whose voxels cover
//!   the segment (no 26-gap between consecutive voxels);
//! * *conservative*: every voxel whose closed cube the segment touches (the
//!   exact conservative set of the degenerate triangle `[a, b, b]`).
//!
//! All three only list voxels the segment touches, so every mode stays a
//! subset of the conservative set. Voxels on the grid's max faces are
//! clamped into the grid, as for triangles.
//!
//! # Solid and non-watertight input
//! *Solid* is the thin surface ∪ the voxel centres inside by the chosen
//! [`InsideTest`]: by default the generalized winding number `w ≥ ½`, which
//! degrades gracefully on holes, flipped faces, duplicated sheets and
//! overlapping copies ([`solid_interior`](crate::voxelize::solid::solid_interior):
//! exact signed crossings of the mesh
//! closed by caps over its holes, plus the caps' winding number from a
//! Barnes–Hut tree with rigorous error bounds, decided by regions); or exact
//! crossing parity for watertight meshes. On a closed, consistently
//! oriented mesh both are exact. Wholly inside bricks are tiles (one flag).

//! # Determinism
//! The resulting voxel set does not depend on the number of threads (the
//! surface driver and the conservative fold are order-independent unions).

use std::sync::Arc;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Result, VoxkitError};
use crate::fixed::FRAC_BITS;
use crate::grid::brick::BrickMask;
use crate::grid::{BrickGrid, GridFrame, MemoryLimit, Voxel};
use crate::line::{Line26, Segment, Tripod6};
use crate::mesh::{MAX_FITTED_DIM, Mesh, fit_frame, fit_frame_voxel_size, fitted_voxel};
use crate::voxelize::conservative::{FixedTriangle, conservative_voxels};
use crate::voxelize::slab::BrickList;
use crate::voxelize::snapped::voxelize_snapped;
use crate::voxelize::solid::{InsideTest, SolidStats, solid_interior_with_progress};
use crate::voxelize::surface::{
    SurfaceMode, SurfaceTriangle, VOXEL_FRAC_BITS, VOXEL_ONE, voxelize_surface_slabs,
};

/// Shift from [`VOXEL_FRAC_BITS`] (1/256) to the reference's
/// [`crate::fixed::FRAC_BITS`] (2^-20): the same points, exactly.
pub const FIXED_SHIFT: u32 = FRAC_BITS - VOXEL_FRAC_BITS;

/// A polyline segment in the fixed-point grid coordinates of [`SurfaceTriangle`].
pub type SurfaceSegment = [[i64; 3]; 2];

/// Which voxel set to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VoxelizeMode {
    /// 6-tunnel-free surface (three axis families of lattice lines).
    Thin,
    /// 26-tunnel-free surface (four body-diagonal families).
    Thick,
    /// Exactly the voxels whose closed cube meets the surface.
    Conservative,
    /// Thin surface plus the interior by the generalized winding number (or
    /// parity, [`VoxelizeOptions::inside`]).
    Solid,
}

impl VoxelizeMode {
    /// The mode's command-line name.
    pub fn name(self) -> &'static str {
        match self {
            VoxelizeMode::Thin => "thin",
            VoxelizeMode::Thick => "thick",
            VoxelizeMode::Conservative => "conservative",
            VoxelizeMode::Solid => "solid",
        }
    }
}

/// A progress report: `done` of `total` steps of the named phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// Phase name (`"quantize"`, `"surface"`, `"conservative"`, `"solid"`,
    /// `"polylines"`, `"done"`).
    pub phase: &'static str,
    /// Phases finished so far.
    pub done: u64,
    /// Phases in this run.
    pub total: u64,
    /// Within the phase, steps done of all (the solid phase's refined
    /// bricks), when it reports them.
    pub step: Option<(u64, u64)>,
}

/// A progress callback (called from the calling thread between phases, and
/// from worker threads for steps within a phase).
pub type ProgressFn = dyn Fn(Progress) + Send + Sync;

/// Which lattice the grid is fitted on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lattice {
    /// `N` voxels along the longest side of the mesh's bounding box (`-r N`,
    /// [`fit_frame`]).
    Resolution(u32),
    /// Voxels of edge `voxel_size` with corners at `origin + k·voxel_size`
    /// (`origin` defaults to the bounding box's min corner); the grid covers
    /// the bounding box (`--voxel-size H [--origin X,Y,Z]`,
    /// [`fit_frame_voxel_size`]).
    VoxelSize {
        /// Voxel edge in world units (finite, > 0).
        voxel_size: f64,
        /// A world point on the lattice (a voxel corner).
        origin: Option<DVec3>,
    },
}

impl Lattice {
    /// The grid frame of this lattice over `bounds`.
    ///
    /// # Errors
    /// [`VoxkitError::Invalid`] for a zero resolution, a voxel size that is
    /// not finite and positive or a non-finite origin;
    /// [`VoxkitError::Unsupported`] beyond [`MAX_FITTED_DIM`] voxels per axis.
    pub fn fit(&self, bounds: (DVec3, DVec3)) -> Result<GridFrame> {
        let frame = match *self {
            Lattice::Resolution(n) => fit_frame(bounds, n)?,
            Lattice::VoxelSize { voxel_size, origin } => {
                fit_frame_voxel_size(bounds, voxel_size, origin)?
            }
        };
        if frame.dims.iter().any(|&d| d > MAX_FITTED_DIM) {
            return Err(VoxkitError::Unsupported(format!(
                "a grid of {:?} voxels exceeds the supported {MAX_FITTED_DIM} per axis",
                frame.dims
            )));
        }
        Ok(frame)
    }
}

/// Options of [`voxelize_mesh`].
#[derive(Clone)]
pub struct VoxelizeOptions {
    /// The lattice: a resolution (`-r N`) or a voxel size.
    pub lattice: Lattice,
    /// Which voxel set.
    pub mode: VoxelizeMode,
    /// Round vertices to the integer voxel lattice instead of 1/256 voxel.
    pub snap: bool,
    /// With `snap`: enumerate the projected triangles' lattice points by
    /// Kahan–Kelsen indexing ([`crate::voxelize::snapped`]) instead of the
    /// crossing kernel. Same voxels; see the module docs for when it pays.
    pub kahan_kelsen: bool,
    /// Solid mode's inside test.
    pub inside: InsideTest,
    /// Cap on the estimated memory of the run.
    pub limit: MemoryLimit,
    /// Optional progress callback.
    pub progress: Option<Arc<ProgressFn>>,
}

impl std::fmt::Debug for VoxelizeOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VoxelizeOptions")
            .field("lattice", &self.lattice)
            .field("mode", &self.mode)
            .field("snap", &self.snap)
            .field("kahan_kelsen", &self.kahan_kelsen)
            .field("inside", &self.inside)
            .field("limit", &self.limit)
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

impl VoxelizeOptions {
    /// Options for `resolution` and `mode`: exact 1/256 vertices, default
    /// memory limit, no progress callback.
    pub fn new(resolution: u32, mode: VoxelizeMode) -> Self {
        Self::on_lattice(Lattice::Resolution(resolution), mode)
    }

    /// As [`VoxelizeOptions::new`] on any [`Lattice`].
    pub fn on_lattice(lattice: Lattice, mode: VoxelizeMode) -> Self {
        VoxelizeOptions {
            lattice,
            mode,
            snap: false,
            kahan_kelsen: false,
            inside: InsideTest::default(),
            limit: MemoryLimit::DEFAULT,
            progress: None,
        }
    }
}

/// What a run did and how long each phase took.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VoxelizeStats {
    /// Triangles voxelized.
    pub triangles: usize,
    /// Triangles skipped because quantization made them degenerate.
    pub skipped_triangles: usize,
    /// Polyline segments voxelized.
    pub segments: usize,
    /// Voxels set.
    pub voxels: u64,
    /// Occupied 8³ bricks.
    pub bricks: usize,
    /// Bytes estimated before the run (what the limit was checked against).
    pub estimated_bytes: u64,
    /// Fitting and quantization.
    pub quantize_ms: f64,
    /// The mode's kernel (surface, conservative or solid), including
    /// assembling the brick grid.
    pub kernel_ms: f64,
    /// Polyline segments.
    pub polyline_ms: f64,
    /// Whole run (everything above).
    pub total_ms: f64,
    /// Solid mode: caps, crossings, refined bricks, ambiguous voxels.
    pub solid: Option<SolidStats>,
}

/// The result of [`voxelize_mesh`].
#[derive(Clone, Debug)]
pub struct Voxelization {
    /// The voxels, all inside `0..frame.dims`.
    pub grid: BrickGrid,
    /// The fitted grid frame.
    pub frame: GridFrame,
    /// Counts and timings.
    pub stats: VoxelizeStats,
    /// The quantized mesh that was voxelized.
    pub mesh: QuantizedMesh,
    /// With [`VoxelizeOptions::snap`]: the same mesh at 1/256 voxel, the
    /// surface the snapped result is measured against.
    pub exact: Option<QuantizedMesh>,
}

impl Voxelization {
    /// The surface error measures compare against: the 1/256 mesh (also
    /// when the vertices were snapped).
    pub fn reference_mesh(&self) -> &QuantizedMesh {
        self.exact.as_ref().unwrap_or(&self.mesh)
    }
}

/// A mesh in fixed-point grid coordinates ([`VOXEL_FRAC_BITS`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct QuantizedMesh {
    /// Non-degenerate triangles.
    pub triangles: Vec<SurfaceTriangle>,
    /// Triangles that quantization made degenerate (skipped by the
    /// voxelizer, kept for the closedness test: a collinear triangle still
    /// pairs its neighbours' edges).
    pub degenerate: Vec<SurfaceTriangle>,
    /// Polyline segments.
    pub segments: Vec<SurfaceSegment>,
}

/// Grid-space fixed-point triangles of `mesh` in `frame` (see the module
/// docs).
pub fn quantize_mesh(mesh: &Mesh, frame: &GridFrame, snap: bool) -> QuantizedMesh {
    let hi = frame.dims.map(|d| d as i64 * VOXEL_ONE - VOXEL_ONE / 2);
    let lo = -VOXEL_ONE / 2;
    let q: Vec<[i64; 3]> = mesh
        .positions
        .par_iter()
        .map(|&w| {
            let g = frame.world_to_grid(w);
            if snap {
                fitted_voxel(frame, g)
                    .to_array()
                    .map(|c| c as i64 * VOXEL_ONE)
            } else {
                let f = (g * VOXEL_ONE as f64).round();
                let c = [f.x, f.y, f.z];
                std::array::from_fn(|a| (c[a] as i64).clamp(lo, hi[a]))
            }
        })
        .collect();
    let mut tris: Vec<SurfaceTriangle> = mesh
        .triangles
        .par_iter()
        .map(|t| t.map(|i| q[i as usize]))
        .collect();
    let degenerate: Vec<bool> = tris.par_iter().map(is_degenerate).collect();
    let skipped: Vec<SurfaceTriangle> = tris
        .iter()
        .zip(&degenerate)
        .filter_map(|(t, &d)| d.then_some(*t))
        .collect();
    if !skipped.is_empty() {
        let mut flags = degenerate.iter();
        tris.retain(|_| !flags.next().copied().unwrap_or(false));
    }
    let segments = mesh
        .polylines
        .iter()
        .flat_map(|l| l.windows(2).map(|w| [q[w[0] as usize], q[w[1] as usize]]))
        .collect();
    QuantizedMesh {
        triangles: tris,
        degenerate: skipped,
        segments,
    }
}

/// Whether the fixed-point triangle has zero area (exact).
fn is_degenerate(t: &SurfaceTriangle) -> bool {
    let e1 = [0, 1, 2].map(|a| (t[1][a] - t[0][a]) as i128);
    let e2 = [0, 1, 2].map(|a| (t[2][a] - t[0][a]) as i128);
    e1[1] * e2[2] == e1[2] * e2[1]
        && e1[2] * e2[0] == e1[0] * e2[2]
        && e1[0] * e2[1] == e1[1] * e2[0]
}

/// The triangle in the conservative reference's 2^-20 fixed point (exact).
#[inline]
pub fn to_reference(t: &SurfaceTriangle) -> FixedTriangle {
    t.map(|p| p.map(|c| c << FIXED_SHIFT))
}

/// A segment as the degenerate reference triangle `[a, b, b]`.
#[inline]
pub fn segment_to_reference(s: &SurfaceSegment) -> FixedTriangle {
    let t: SurfaceTriangle = [s[0], s[1], s[1]];
    to_reference(&t)
}

/// The voxels of polyline `segments` for `mode` (see the module docs).
///
/// # Errors
/// None for segments quantized in a fitted frame (their coordinates are far
/// inside the line engine's ±2^30 range); the error is kept for other callers.
pub fn polyline_voxels(
    segments: &[SurfaceSegment],
    mode: VoxelizeMode,
    dims: crate::grid::Dims,
) -> Result<BrickGrid> {
    if mode == VoxelizeMode::Conservative {
        return Ok(conservative_grid(
            segments.par_iter().map(segment_to_reference),
            dims,
        ));
    }
    let hi = Voxel::new(dims[0] as i32 - 1, dims[1] as i32 - 1, dims[2] as i32 - 1);
    let parts: Vec<Result<BrickGrid>> = segments
        .par_chunks(256)
        .map(|chunk| {
            let mut g = BrickGrid::new();
            for s in chunk {
                let seg = Segment::from_fixed(
                    s[0].map(|c| c << FIXED_SHIFT),
                    s[1].map(|c| c << FIXED_SHIFT),
                )?;
                let mut put = |v: Voxel| {
                    g.insert(v.clamp(Voxel::ZERO, hi));
                };
                if mode == VoxelizeMode::Thick {
                    Tripod6::new(&seg).for_each(&mut put);
                } else {
                    Line26::new(&seg).for_each(&mut put);
                }
            }
            Ok(g)
        })
        .collect();
    let mut out = BrickGrid::new();
    for p in parts {
        out.union_with(&p?);
    }
    Ok(out)
}

/// Sum of the triangles' areas in voxels² (f64; for estimates only).
fn surface_area(tris: &[SurfaceTriangle]) -> f64 {
    let s2 = (VOXEL_ONE * VOXEL_ONE) as f64;
    tris.par_iter()
        .map(|t| {
            let e1 = [0, 1, 2].map(|a| (t[1][a] - t[0][a]) as f64);
            let e2 = [0, 1, 2].map(|a| (t[2][a] - t[0][a]) as f64);
            let n = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() / s2
        })
        .sum()
}

/// Bytes per occupied brick while voxelizing: the slab arena entry (76 B)
/// plus the final [`BrickGrid`] (64 B mask, 12 B key, ~24 B of map entry).
pub const BYTES_PER_BRICK: u64 = 180;

/// Estimated peak bytes of a run, computed before allocating:
/// * the quantized triangles (72 B each) and their slab lists (4 B each);
/// * *thin/thick/solid surface*: the slab tables, 4 B per 8³ brick cell of
///   the grid box, plus bricks at [`BYTES_PER_BRICK`], where the number of
///   bricks is estimated as voxels / 8 (a surface brick usually holds far
///   more) and voxels as `k · area + 4 · perimeter-ish` with `k = √3` (thin),
///   3 (thick, conservative);
/// * *conservative*: per-thread partial grids, counted twice;
/// * *solid*: the surface as for thin, as many partial interior bricks
///   again, a tile flag per brick of the box (1 B, an upper bound), and the
///   closed copy of the mesh plus the winding trees (~200 B per triangle).
pub fn estimate_bytes(
    tris: &[SurfaceTriangle],
    segments: usize,
    dims: [usize; 3],
    mode: VoxelizeMode,
) -> u64 {
    let cells = dims.map(|d| d.div_ceil(8) as u64);
    let table = 4 * cells[0] * cells[1] * cells[2];
    let area = surface_area(tris);
    let k = match mode {
        VoxelizeMode::Thin | VoxelizeMode::Solid => 3f64.sqrt(),
        VoxelizeMode::Thick | VoxelizeMode::Conservative => 3.0,
    };
    let voxels = k * area + 8.0 * (tris.len() + segments) as f64;
    let bricks = (voxels / 8.0).min((cells[0] * cells[1] * cells[2]) as f64) as u64;
    let base = 76 * tris.len() as u64;
    let n = dims.iter().map(|&d| d as u64).product::<u64>();
    match mode {
        VoxelizeMode::Thin | VoxelizeMode::Thick => base + table + bricks * BYTES_PER_BRICK,
        VoxelizeMode::Conservative => base + 2 * bricks * BYTES_PER_BRICK,
        VoxelizeMode::Solid => {
            base + table + 2 * bricks * BYTES_PER_BRICK + n.div_ceil(512) + 200 * tris.len() as u64
        }
    }
}

/// Voxelizes `mesh` as described in the [module docs](self).
///
/// # Errors
/// [`VoxkitError::Invalid`] for a zero resolution or a mesh without extent;
/// [`VoxkitError::Limits`] when the estimate exceeds `opts.limit` (nothing
/// large has been allocated then); [`VoxkitError::Unsupported`] from the
/// solid fill for triangles spanning 2^20 voxels or more.
///
/// ```
/// use glam::DVec3;
/// use voxkit::mesh::Mesh;
/// use voxkit::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, voxelize_mesh};
/// let m = Mesh::from_parts("tri", vec![DVec3::ZERO, DVec3::X, DVec3::Y], vec![[0, 1, 2]], vec![]).unwrap();
/// let v = voxelize_mesh(&m, &VoxelizeOptions::new(8, VoxelizeMode::Thin)).unwrap();
/// assert_eq!(v.frame.dims, [8, 8, 1]);
/// // The triangle lies in the plane z = -1/2: every lattice point of its
/// // projection gives one voxel in layer 0 (x + y ≤ 7.5 → 36 voxels).
/// assert_eq!(v.stats.voxels, 36);
/// ```
pub fn voxelize_mesh(mesh: &Mesh, opts: &VoxelizeOptions) -> Result<Voxelization> {
    prepare_mesh(mesh, opts)?.voxelize()
}

/// Progress phases of a run of `mode`.
fn total_phases(mode: VoxelizeMode) -> u64 {
    3 + u64::from(mode == VoxelizeMode::Solid)
}

fn report_progress(opts: &VoxelizeOptions, phase: &'static str, done: u64) {
    if let Some(p) = &opts.progress {
        p(Progress {
            phase,
            done,
            total: total_phases(opts.mode),
            step: None,
        });
    }
}

/// A mesh fitted, quantized and checked against the memory limit: steps 1–3
/// of [`voxelize_mesh`], nothing large allocated yet. Its
/// [`estimated_bytes`](PreparedMesh::estimated_bytes) lets a caller that runs
/// several meshes at once (the batch CLI) budget memory across them before
/// [`PreparedMesh::voxelize`] allocates.
///
/// ```
/// use glam::DVec3;
/// use voxkit::mesh::Mesh;
/// use voxkit::voxelize::pipeline::{VoxelizeMode, VoxelizeOptions, prepare_mesh, voxelize_mesh};
/// let m = Mesh::from_parts("tri", vec![DVec3::ZERO, DVec3::X, DVec3::Y], vec![[0, 1, 2]], vec![]).unwrap();
/// let opts = VoxelizeOptions::new(8, VoxelizeMode::Thin);
/// let prepared = prepare_mesh(&m, &opts).unwrap();
/// assert!(prepared.estimated_bytes() > 0);
/// let v = prepared.voxelize().unwrap();
/// assert_eq!(v.grid, voxelize_mesh(&m, &opts).unwrap().grid);
/// ```
pub struct PreparedMesh<'a> {
    mesh: &'a Mesh,
    opts: &'a VoxelizeOptions,
    frame: GridFrame,
    quantized: QuantizedMesh,
    estimated_bytes: u64,
    quantize_ms: f64,
}

impl PreparedMesh<'_> {
    /// The estimated peak bytes of [`PreparedMesh::voxelize`] (what the
    /// limit was checked against; see [`estimate_bytes`]).
    pub fn estimated_bytes(&self) -> u64 {
        self.estimated_bytes
    }

    /// The fitted grid frame.
    pub fn frame(&self) -> &GridFrame {
        &self.frame
    }

    /// Step 4 of [`voxelize_mesh`]: runs the mode.
    ///
    /// # Errors
    /// [`VoxkitError::Unsupported`] from the solid fill for triangles
    /// spanning 2^20 voxels or more.
    pub fn voxelize(self) -> Result<Voxelization> {
        let PreparedMesh {
            mesh,
            opts,
            frame,
            quantized,
            estimated_bytes: estimated,
            quantize_ms,
        } = self;
        let start = Instant::now();
        let mut done = 1;
        let mut report = |phase: &'static str| {
            report_progress(opts, phase, done);
            done += 1;
        };
        let (triangles, skipped, segments) = (
            &quantized.triangles,
            &quantized.degenerate,
            &quantized.segments,
        );
        let kk = opts.snap && opts.kahan_kelsen;
        let dims_i = frame.dims.map(|d| d as i32);
        let t0 = Instant::now();
        let mut solid_stats = None;
        let mut grid = match opts.mode {
            VoxelizeMode::Thin | VoxelizeMode::Thick => {
                report("surface");
                let surface = if opts.mode == VoxelizeMode::Thin {
                    SurfaceMode::Thin
                } else {
                    SurfaceMode::Thick
                };
                bricks_to_grid(surface_bricks(triangles, dims_i, surface, kk)?)
            }
            VoxelizeMode::Conservative => {
                report("conservative");
                conservative_grid(triangles.par_iter().map(to_reference), frame.dims)
            }
            VoxelizeMode::Solid => {
                report("surface");
                let mut g =
                    bricks_to_grid(surface_bricks(triangles, dims_i, SurfaceMode::Thin, kk)?);
                report("solid");
                // Solid's own steps: its refined bricks, every 64th reported.
                let bricks = |done: u64, total: u64| {
                    if let Some(p) = &opts.progress
                        && (done.is_multiple_of(64) || done == total)
                    {
                        p(Progress {
                            phase: "solid",
                            done: 2,
                            total: total_phases(opts.mode),
                            step: Some((done, total)),
                        });
                    }
                };
                let (inside, s) = solid_interior_with_progress(
                    triangles,
                    skipped,
                    frame.dims,
                    opts.inside,
                    &g,
                    Some(&bricks),
                )?;
                solid_stats = Some(s);
                g.union_with(&inside);
                g
            }
        };
        let kernel_ms = ms(t0.elapsed());

        report("polylines");
        let t1 = Instant::now();
        if !segments.is_empty() {
            grid.union_with(&polyline_voxels(segments, opts.mode, frame.dims)?);
        }
        let polyline_ms = ms(t1.elapsed());
        report("done");

        let stats = VoxelizeStats {
            triangles: triangles.len(),
            skipped_triangles: skipped.len(),
            segments: segments.len(),
            voxels: grid.count(),
            bricks: grid.brick_count(),
            estimated_bytes: estimated,
            quantize_ms,
            kernel_ms,
            polyline_ms,
            total_ms: quantize_ms + ms(start.elapsed()),
            solid: solid_stats,
        };
        Ok(Voxelization {
            grid,
            frame,
            stats,
            exact: opts.snap.then(|| quantize_mesh(mesh, &frame, false)),
            mesh: quantized,
        })
    }
}

/// Steps 1–3 of [`voxelize_mesh`]: fits the frame, quantizes the mesh and
/// checks the memory estimate against `opts.limit`.
///
/// # Errors
/// [`VoxkitError::Invalid`] for a zero resolution or a mesh without extent;
/// [`VoxkitError::Limits`] when the estimate exceeds `opts.limit`.
pub fn prepare_mesh<'a>(mesh: &'a Mesh, opts: &'a VoxelizeOptions) -> Result<PreparedMesh<'a>> {
    let start = Instant::now();
    report_progress(opts, "quantize", 0);
    let frame = opts.lattice.fit(mesh.bounds())?;
    let quantized = quantize_mesh(mesh, &frame, opts.snap);
    let (triangles, segments) = (&quantized.triangles, &quantized.segments);
    let mut estimated = estimate_bytes(triangles, segments.len(), frame.dims, opts.mode);
    let kk = opts.snap && opts.kahan_kelsen;
    if kk && opts.mode != VoxelizeMode::Conservative {
        // The Kahan–Kelsen set-up of one batch: at most one indexed pair per
        // triangle and family (4 families for thick, 3 for thin and solid).
        use crate::voxelize::snapped::{BATCH_TRIANGLES, BYTES_PER_PAIR};
        let families = if opts.mode == VoxelizeMode::Thick {
            4
        } else {
            3
        };
        let batch = triangles.len().min(BATCH_TRIANGLES) as u64;
        estimated += families * batch * BYTES_PER_PAIR;
    }
    opts.limit.check(
        &format!(
            "voxelizing {} triangles into {:?} ({})",
            triangles.len(),
            frame.dims,
            opts.mode.name()
        ),
        estimated as u128,
        1,
    )?;
    Ok(PreparedMesh {
        mesh,
        opts,
        frame,
        quantized,
        estimated_bytes: estimated,
        quantize_ms: ms(start.elapsed()),
    })
}

/// The surface of `mode`: with `kahan_kelsen` (snapped vertices only) by
/// Kahan–Kelsen indexing ([`voxelize_snapped`], work split evenly by a
/// prefix sum over the projected triangles' point counts), otherwise by the
/// lattice-line crossing kernel
/// ([`voxelize_surface`](crate::voxelize::surface::voxelize_surface)). Both
/// give the same voxels on snapped input.
pub(crate) fn surface_bricks(
    triangles: &[SurfaceTriangle],
    dims: [i32; 3],
    mode: SurfaceMode,
    kahan_kelsen: bool,
) -> Result<Vec<BrickList>> {
    if kahan_kelsen {
        Ok(vec![voxelize_snapped(triangles, dims, mode)?])
    } else {
        Ok(voxelize_surface_slabs(triangles, dims, mode))
    }
}

fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// The surface driver's brick lists (each brick exactly once over all
/// lists) as a [`BrickGrid`]: every brick is copied once into arrays sized
/// up front, the lists in parallel into their own ranges (the copy's cost
/// is mostly first touches of fresh pages, which then fault on every core
/// at once instead of on one). The arrays are not zeroed first: written
/// once, in full, they are the kind of buffer [`crate::alloc::HugePageAlloc`]
/// maps with huge pages.
pub(crate) fn bricks_to_grid(lists: Vec<BrickList>) -> BrickGrid {
    let total = lists.iter().map(Vec::len).sum();
    let mut keys: Vec<Voxel> = Vec::with_capacity(total);
    let mut masks: Vec<BrickMask> = Vec::with_capacity(total);
    let mut parts = Vec::with_capacity(lists.len());
    let (mut key_rest, mut mask_rest) = (
        &mut keys.spare_capacity_mut()[..total],
        &mut masks.spare_capacity_mut()[..total],
    );
    for list in lists {
        let (k, kr) = key_rest.split_at_mut(list.len());
        let (m, mr) = mask_rest.split_at_mut(list.len());
        (key_rest, mask_rest) = (kr, mr);
        parts.push((list, k, m));
    }
    parts.into_par_iter().for_each(|(list, k, m)| {
        for (((corner, bits), key), mask) in list.into_iter().zip(k).zip(m) {
            key.write(Voxel::from_array(corner) >> 3);
            mask.write(bits);
        }
    });
    // SAFETY: the parts tile `0..total` of both spare capacities (each
    // takes the next `list.len()` slots, and `total` is the sum of those
    // lengths), and every part writes each of its slots: the zipped
    // iterators all have the list's length. `Voxel` and `BrickMask` have
    // no drop glue, so nothing is lost if a panic unwinds before this.
    unsafe {
        keys.set_len(total);
        masks.set_len(total);
    }
    // The slabs are disjoint and each lists its bricks once, none empty.
    BrickGrid::from_unique_parts(keys, masks)
}

/// The exact conservative set of reference triangles, restricted to the grid
/// box `0..dims`. Voxels just outside can only be touched on the box's faces
/// (every point lies in `[-1/2, dims - 1/2]`), where the voxel inside the
/// box is touched too, so dropping them is the same as clamping them.
/// Parallel fold of per-thread grids; the union does not depend on the split.
pub fn conservative_grid(
    tris: impl ParallelIterator<Item = FixedTriangle>,
    dims: [usize; 3],
) -> BrickGrid {
    let d = dims.map(|d| d as i32);
    let inside =
        move |v: Voxel| v.x >= 0 && v.y >= 0 && v.z >= 0 && v.x < d[0] && v.y < d[1] && v.z < d[2];
    let parts: Vec<BrickGrid> = tris
        .fold(BrickGrid::new, |mut g, t| {
            // Coordinates are within the fitted grid box, far inside the
            // reference's ±2^30 range, so construction cannot fail.
            if let Ok(it) = conservative_voxels(&t) {
                for v in it.filter(|&v| inside(v)) {
                    g.insert(v);
                }
            }
            g
        })
        .collect();
    BrickGrid::merge(parts)
}
