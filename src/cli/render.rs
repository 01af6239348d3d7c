//! `voxkit render INPUT -o OUT.png [options]`: the discrete ray caster on a
//! voxel file, a mesh (voxelized first) or a scalar volume.
//!
//! `--json` prints one line with `input`, `kind` (`grid` / `volume`),
//! `warnings` (what the mesh loader or voxel reader skipped, e.g. a .vox
//! file's hidden layers; each also printed to stderr as `warning: …`),
//! `dims`, `voxels`, for grids `tiles` (the grid's tiles), `stored_bricks`
//! (bricks with flags of their own) and `full_bricks` (bricks sharing the
//! full slot); for a `.zarr` store voxkit wrote (read chunk by chunk as the
//! rays reach it, never whole: [`PagedOccupancy`]) `stored_chunks`,
//! `chunks_decoded` and `pages_built` instead of the voxel counts; `ray`, `skip`, `size`, `rays`, `hits`,
//! `voxels_visited`, `bricks_skipped`, `rays_culled` (pixels whose tile no
//! ray needed to be cast through), `load_ms` (reading, and voxelizing a
//! mesh), `prepare_ms` (render structures), `render_ms` (per frame; the
//! median over `--turntable` frames and `--reps` repetitions), for a
//! volume with `--reps` 2 or more `floor_ms` (the memory floor: one
//! parallel pass reading every stored sample, timed after each repetition,
//! median) and `frame_over_floor` (`render_ms` over it, the figure that
//! holds as the machine's speed drifts), `frames`, `memory_bytes` (render structures
//! plus image buffers), `camera` (the first frame's, in world coordinates:
//! `eye`, `target`, `up`, its basis and `fov_y_deg` or `ortho_height`, enough
//! to cast the same pixel rays elsewhere), `peak_rss_mib` and, with `--measure`, the error
//! measures (`differing_pixels` against the 6-ray and, for meshes,
//! `mesh_depth_mean`, `mesh_depth_max`, `silhouette_disagree`).

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec3;

use super::CliError;
use super::voxelize::{ModeArg, peak_rss_mib};
use crate::camera::{Camera, SceneAxes, ViewPreset};
use crate::grid::{BrickGrid, GridFrame, MemoryLimit, ScalarVolume};
use crate::io::zarr::ChunkReader;
use crate::mesh::Mesh;
use crate::render::{
    GridTransform, NormalMode, OccupancyGrid, PagedOccupancy, RayKind, RenderImage, RenderOptions,
    RenderStats, Sampling, TransferFunction, VolumeMethod, VolumeMode, VolumeOptions, VolumeScene,
    render_grid, render_volume,
};
use crate::voxelize::pipeline::{VoxelizeOptions, voxelize_mesh};

/// `--volume` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum VolumeArg {
    /// Maximum intensity projection.
    Mip,
    /// Front-to-back alpha compositing through the transfer function.
    Composite,
    /// The iso-surface at --iso, shaded.
    Iso,
}

/// Arguments of `voxkit render`.
///
/// World coordinates (`--eye`, `--target`, `--up`, EXR depth) are those of
/// the input's own frame: binvox `translate`/`scale`, NRRD `space origin` and
/// `space directions`, MetaImage `Offset`/`ElementSpacing`, the voxkit frame
/// stored in .vox files, the mesh's own coordinates; `.npy` has none (voxel
/// (i,j,k) centred at (i+½, j+½, k+½), unit voxels).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "World coordinates (--eye, --target, --up and the EXR's Z) are those of the \
input's own frame: binvox translate/scale, NRRD space origin/directions, MetaImage \
Offset/ElementSpacing, the mesh's own coordinates; .npy files get unit voxels from the origin. \
Meshes and binvox/npy/NRRD grids are taken as Y-up, scalar volumes and .vox files as Z-up \
(override with --up)."
)]
pub struct RenderArgs {
    /// Input: .binvox, .vox, .npy, .nrrd, .zarr (OME-Zarr store), .nhdr, .mhd/.mha, .nii/.nii.gz/.hdr (NIfTI), or a mesh (.obj, .gltf, .glb, .ply, .stl, .off).
    pub input: PathBuf,
    /// Output PNG (with --turntable N: a .gif, or a PNG name numbered per frame).
    #[arg(short = 'o', long = "output", value_name = "OUT.png")]
    pub output: PathBuf,
    /// Also write an OpenEXR with float R, G, B, A and Z (distance along the ray, +inf for misses).
    #[arg(long, value_name = "OUT.exr")]
    pub exr: Option<PathBuf>,
    /// Image size.
    #[arg(long, value_name = "WxH", default_value = "1024x1024", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Ray kind.
    #[arg(long, value_enum, default_value = "adaptive")]
    pub ray: RayKind,
    /// Do not skip empty space (the image is identical; only slower).
    #[arg(long)]
    pub no_skip: bool,
    /// Camera position (world).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<DVec3>,
    /// Point looked at (world; default: the centre of the data).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<DVec3>,
    /// Up direction.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up: Option<DVec3>,
    /// Vertical field of view in degrees, in (0, 180).
    #[arg(long, value_name = "DEG", default_value_t = 35.0)]
    pub fov: f64,
    /// Orthographic projection.
    #[arg(long)]
    pub ortho: bool,
    /// View direction preset (ignored with --eye).
    #[arg(long, value_enum, default_value = "iso")]
    pub view: ViewPreset,
    /// Write N frames around the vertical axis (at most 100000; a GIF's frames
    /// must fit --max-memory).
    #[arg(long, value_name = "N")]
    pub turntable: Option<u32>,
    /// Render each frame N times and report the median time (benchmarking).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub reps: u32,
    /// Normals for shading: smooth (occupancy or value gradient) or the entry face.
    #[arg(long, value_enum, default_value = "smooth")]
    pub normals: NormalMode,
    /// Background colour, linear RGB in [0, 1].
    #[arg(long, value_name = "R,G,B", value_parser = parse_vec3, default_value = "0.07,0.08,0.1")]
    pub background: DVec3,
    /// Scalar volumes: maximum intensity, front-to-back compositing, or an iso-surface
    /// (default: mip; a 0/1 uint8 volume without --volume renders as a voxel grid).
    #[arg(long, value_enum)]
    pub volume: Option<VolumeArg>,
    /// Iso value for --volume iso (default: the middle of the window).
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub iso: Option<f32>,
    /// Value window LO,HI mapped to black..white (default: the data's 1% and 99.5% percentiles).
    #[arg(long, value_name = "LO,HI", value_parser = parse_window, allow_hyphen_values = true)]
    pub window: Option<(f32, f32)>,
    /// Transfer function for compositing: value:opacity points, each with an optional
    /// :#rrggbb colour, comma-separated
    /// (default: a linear opacity ramp over the window).
    #[arg(long, value_name = "V:O[:#RRGGBB],...", allow_hyphen_values = true)]
    pub tf: Option<String>,
    /// How visited voxels are sampled.
    #[arg(long, value_enum, default_value = "nearest")]
    pub sampling: Sampling,
    /// Scalar volumes: one exact discrete ray per pixel, or shear-warp (object order, faster,
    /// not exact: --measure reports its difference from the 6-ray image; iso-surfaces and
    /// perspective eyes inside the volume cast rays).
    #[arg(long, value_enum, default_value = "rays")]
    pub method: VolumeMethod,
    /// Meshes: voxels along the longest side.
    #[arg(
        short = 'r',
        long = "resolution",
        value_name = "N",
        default_value_t = 256
    )]
    pub resolution: u32,
    /// Meshes: which voxel set to render.
    #[arg(long, value_enum, default_value = "thin")]
    pub mode: ModeArg,
    /// Print one line of JSON.
    #[arg(long)]
    pub json: bool,
    /// Measure the image error (against the 6-ray image, and for meshes the rasterized mesh).
    #[arg(long)]
    pub measure: bool,
    /// Overwrite existing outputs.
    #[arg(long)]
    pub force: bool,
    /// Memory limit in MiB (checked before allocating).
    #[arg(long, value_name = "MIB", default_value_t = 4096)]
    pub max_memory: u64,
    /// No progress bar.
    #[arg(short = 'q', long)]
    pub quiet: bool,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .to_ascii_lowercase()
        .split_once('x')
        .map(|(a, b)| (a.trim().parse::<u32>(), b.trim().parse::<u32>()))
        .ok_or_else(|| format!("{s:?}: expected WxH, e.g. 1024x768"))?;
    match (w, h) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(format!("{s:?}: width and height must be positive integers")),
    }
}

fn parse_window(s: &str) -> Result<(f32, f32), String> {
    match s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Vec<_>>()[..]
    {
        [Ok(lo), Ok(hi)] if lo.is_finite() && hi.is_finite() && lo < hi => Ok((lo, hi)),
        _ => Err(format!("{s:?}: expected LO,HI with LO < HI")),
    }
}

pub(crate) fn parse_vec3(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{s:?}: expected three numbers X,Y,Z"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(x, y, z)),
        _ => Err(format!("{s:?}: expected three finite numbers X,Y,Z")),
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Mesh files `render` voxelizes first ([`crate::mesh::MESH_EXTENSIONS`]).
fn is_mesh(path: &Path) -> bool {
    crate::mesh::is_mesh_path(path)
}

/// What was loaded: a voxel grid in its frame, with the scene's axes.
struct Scene {
    grid: BrickGrid,
    dims: [usize; 3],
    xf: GridTransform,
    /// Voxel edge for error measures in voxels (meshes).
    voxel_size: f64,
    colors: Option<crate::io::vox::VoxColors>,
    axes: SceneAxes,
    mesh: Option<Mesh>,
}

/// A loaded input: a voxel grid, a voxel store read as rays reach it, or
/// a scalar volume.
enum Input {
    Grid(Box<Scene>),
    Store(Box<PagedOccupancy>, GridTransform),
    Volume(Box<ScalarVolume>),
}

impl Scene {
    fn from_frame(grid: BrickGrid, frame: &GridFrame, axes: SceneAxes) -> Result<Self, CliError> {
        Ok(Scene {
            grid,
            dims: frame.dims,
            xf: GridTransform::from_frame(frame)?,
            voxel_size: frame.voxel_size,
            colors: None,
            axes,
            mesh: None,
        })
    }
}

fn load(
    args: &RenderArgs,
    limit: MemoryLimit,
    warnings: &mut Vec<String>,
) -> Result<Input, CliError> {
    let path = &args.input;
    let named = |e: crate::VoxkitError| CliError::bad_input(format!("{}: {e}", path.display()));
    if is_mesh(path) {
        let mesh = Mesh::load(path)?;
        super::print_warnings(path, &mesh.summary.warnings);
        warnings.extend(mesh.summary.warnings.iter().cloned());
        let mut opts = VoxelizeOptions::new(args.resolution, args.mode.into());
        opts.limit = limit;
        let v = voxelize_mesh(&mesh, &opts)?;
        let mut scene = Scene::from_frame(v.grid, &v.frame, SceneAxes::Y_UP)?;
        scene.mesh = Some(mesh);
        return Ok(Input::Grid(Box::new(scene)));
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "vox" => {
            limit.check(
                "reading the .vox file",
                std::fs::metadata(path)
                    .map_err(|e| CliError::bad_input(format!("{}: {e}", path.display())))?
                    .len() as u128,
                1,
            )?;
            let bytes = std::fs::read(path)
                .map_err(|e| CliError::bad_input(format!("{}: {e}", path.display())))?;
            let vox = crate::io::vox::read_colored(&bytes, limit).map_err(named)?;
            super::print_warnings(path, &vox.warnings);
            warnings.extend(vox.warnings);
            let mut scene = Scene::from_frame(vox.grid, &vox.frame, SceneAxes::Z_UP)?;
            scene.colors = Some(vox.colors);
            Ok(Input::Grid(Box::new(scene)))
        }
        "zarr" if let Some(reader) = ChunkReader::open(path, 0, limit)? => {
            // A store voxkit wrote: only the chunks the rays reach are read.
            let xf = GridTransform::from_frame(reader.frame())?;
            let paged = PagedOccupancy::new(reader, limit)?;
            Ok(Input::Store(Box::new(paged), xf))
        }
        "binvox" | "zarr" => {
            let (grid, frame, w) = crate::io::read_voxels_warned(path, limit)?;
            super::print_warnings(path, &w);
            warnings.extend(w);
            Ok(Input::Grid(Box::new(Scene::from_frame(
                grid,
                &frame,
                SceneAxes::Y_UP,
            )?)))
        }
        _ => {
            let vol = crate::io::volume::read_volume(path, limit)?;
            if vol.is_binary() && args.volume.is_none() {
                // A 0/1 grid (what `voxkit voxelize` writes): occupancy.
                let xf = GridTransform::new(vol.frame.origin, vol.frame.axes)?;
                let h = vol.frame.spacing().min_element();
                return Ok(Input::Grid(Box::new(Scene {
                    grid: vol.to_brick_grid(),
                    dims: vol.dims,
                    xf,
                    voxel_size: h,
                    colors: None,
                    axes: SceneAxes::Y_UP,
                    mesh: None,
                })));
            }
            Ok(Input::Volume(Box::new(vol)))
        }
    }
}

/// The camera for the options, framing the world box `[lo, hi]`.
pub(crate) fn camera(
    args: &RenderArgs,
    lo: DVec3,
    hi: DVec3,
    axes: SceneAxes,
) -> Result<Camera, CliError> {
    let (w, h) = args.size;
    let fov = (!args.ortho).then_some(args.fov);
    if !(args.fov > 0.0 && args.fov < 180.0) {
        return Err(CliError::bad_input(format!(
            "--fov {}: the field of view must be in (0, 180) degrees",
            args.fov
        )));
    }
    let (dir, preset_up) = axes.view(args.view);
    let up = args.up.unwrap_or(preset_up);
    let target = args.target.unwrap_or((lo + hi) * 0.5);
    let cam = match args.eye {
        Some(eye) => {
            let size = (hi - lo).length().max(1e-9);
            if args.ortho {
                Camera::orthographic(eye, target, up, size)
            } else {
                Camera::perspective(eye, target, up, args.fov)
            }
        }
        None => {
            let mut c = Camera::framing(lo, hi, dir, up, fov, w, h)?;
            if let Some(t) = args.target {
                let shift = t - c.target;
                c.eye += shift;
                c.target = t;
            }
            c
        }
    };
    crate::render::camera_check(&cam)?;
    Ok(cam)
}

/// Most turntable frames: each is a file (PNG) or held in memory until the
/// GIF is written, and every output name is checked before rendering.
pub(crate) const MAX_FRAMES: u32 = 100_000;

/// The number of frames `args` asks for, checked before any is rendered or
/// named: at least one, at most [`MAX_FRAMES`], and a GIF's frames (RGBA,
/// kept until it is written) within `limit`.
pub(crate) fn check_frames(args: &RenderArgs, limit: MemoryLimit) -> Result<u32, CliError> {
    let frames = args.turntable.unwrap_or(1);
    if frames == 0 {
        return Err(CliError::bad_input("--turntable needs at least one frame"));
    }
    if frames > MAX_FRAMES {
        return Err(CliError::bad_input(format!(
            "--turntable {frames}: at most {MAX_FRAMES} frames"
        )));
    }
    if is_gif(&args.output) {
        let (w, h) = args.size;
        limit.check(
            &format!("{frames} GIF frames of {w}x{h}"),
            u128::from(frames) * u128::from(w) * u128::from(h),
            4,
        )?;
    }
    Ok(frames)
}

/// The camera of frame `i` of `frames`: a turntable orbits the base camera
/// about the scene's up axis through the target.
pub(crate) fn frame_camera(base: &Camera, axes: SceneAxes, i: u32, frames: u32) -> Camera {
    if frames > 1 {
        base.orbited(
            axes.up,
            std::f64::consts::TAU * f64::from(i) / f64::from(frames),
        )
    } else {
        *base
    }
}

/// Runs `voxkit render`.
/// The (first frame's) camera in world coordinates, so that other tools can
/// cast the same pixel rays: pixel `(x, y)` of a `W×H` image looks along
/// `f + r·n_x·s_r + u·n_y·s_u` from `eye` (perspective; orthographic: from
/// `eye + r·n_x·s_r + u·n_y·s_u` along `f`), `n_x = 2(x + ½)/W − 1`,
/// `n_y = 1 − 2(y + ½)/H`, with `(r, u, f)` the camera's basis and
/// `s_u = tan(fov/2)` or `height/2`, `s_r = s_u·W/H`.
fn camera_json(cam: &Camera) -> serde_json::Value {
    let (r, u, f) = cam.basis();
    let v = |d: DVec3| serde_json::json!([d.x, d.y, d.z]);
    let mut j = serde_json::json!({
        "eye": v(cam.eye),
        "target": v(cam.target),
        "up": v(cam.up),
        "right_axis": v(r),
        "up_axis": v(u),
        "forward_axis": v(f),
    });
    let obj = j.as_object_mut().expect("json! of an object literal");
    match cam.projection {
        crate::camera::Projection::Perspective { fov_y_deg } => {
            obj.insert("fov_y_deg".into(), fov_y_deg.into());
        }
        crate::camera::Projection::Orthographic { height } => {
            obj.insert("ortho_height".into(), height.into());
        }
    }
    j
}

pub fn run(args: RenderArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let limit = MemoryLimit::new(args.max_memory.saturating_mul(1 << 20));
    let frames = check_frames(&args, limit)?;
    if args.reps == 0 {
        return Err(CliError::bad_input("--reps needs at least one render"));
    }
    let outputs = frame_paths(&args.output, args.turntable)?;
    for p in outputs.iter().chain(args.exr.iter()) {
        if !args.force && p.exists() {
            return Err(CliError::bad_input(format!(
                "{} exists (use --force to overwrite)",
                p.display()
            )));
        }
    }
    let (w, h) = args.size;
    crate::render::check_image(w, h, limit)?;
    let t = Instant::now();
    let mut warnings = Vec::new();
    let input = load(&args, limit, &mut warnings)?;
    let load_ms = ms(t);
    if matches!(input, Input::Grid(_) | Input::Store(..))
        && (args.volume.is_some()
            || args.iso.is_some()
            || args.window.is_some()
            || args.tf.is_some())
    {
        return Err(CliError::bad_input(format!(
            "{}: --volume, --iso, --window and --tf apply to scalar volumes, not to a voxel grid or mesh",
            args.input.display()
        )));
    }
    let opts = RenderOptions {
        width: w,
        height: h,
        ray: args.ray,
        skip: !args.no_skip,
        normals: args.normals,
        background: args.background.as_vec3().to_array(),
        limit,
        ..RenderOptions::default()
    };
    let t = Instant::now();
    let mut info = serde_json::Map::new();
    // The volume is handed to its render structures (rearranged in place,
    // not copied); a grid scene is kept for the camera and the measures.
    let (renderer, grid): (Renderer, Option<Box<Scene>>) = match input {
        Input::Grid(scene) => {
            let mut occ = OccupancyGrid::new(&scene.grid, scene.dims, limit)?;
            if let Some(c) = &scene.colors {
                occ.set_colors(&c.voxels, c.palette);
            }
            info.insert("kind".into(), "grid".into());
            info.insert("dims".into(), serde_json::json!(scene.dims));
            info.insert("voxels".into(), occ.voxel_count().into());
            info.insert("tiles".into(), scene.grid.tile_count().into());
            info.insert("stored_bricks".into(), occ.stored_bricks().into());
            info.insert("full_bricks".into(), occ.full_bricks().into());
            (Renderer::Grid(occ), Some(scene))
        }
        Input::Store(paged, xf) => {
            info.insert("kind".into(), "grid".into());
            info.insert("dims".into(), serde_json::json!(paged.dims()));
            info.insert("stored_chunks".into(), paged.stored_chunks().into());
            let scene = Scene {
                grid: BrickGrid::new(),
                dims: paged.dims(),
                xf,
                // Only mesh measures read it; a store has no mesh.
                voxel_size: 1.0,
                colors: None,
                axes: SceneAxes::Y_UP,
                mesh: None,
            };
            (Renderer::Store(paged), Some(Box::new(scene)))
        }
        Input::Volume(vol) => {
            // The default window reads every sample: only when none is
            // given, and then while the bricks are built.
            let (vs, window) = match args.window {
                Some(w) => (VolumeScene::from_volume(*vol, limit)?, w),
                None => VolumeScene::with_default_window(*vol, limit)?,
            };
            let w = vs.warnings();
            super::print_warnings(&args.input, &w);
            warnings.extend(w);
            let vopts = volume_options(&args, window)?;
            info.insert("kind".into(), "volume".into());
            info.insert("dims".into(), serde_json::json!(vs.dims()));
            info.insert("dtype".into(), vs.bricks().source_type().name().into());
            info.insert(
                "mode".into(),
                format!("{:?}", vopts.mode).to_lowercase().into(),
            );
            info.insert(
                "window".into(),
                serde_json::json!([vopts.window.0, vopts.window.1]),
            );
            (Renderer::Volume(Box::new(vs), vopts), None)
        }
    };
    let prepare_ms = ms(t);
    let (xf, axes) = match (&grid, &renderer) {
        (Some(scene), _) => (scene.xf, scene.axes),
        (None, Renderer::Volume(vs, _)) => (*vs.transform(), vs.scene_axes()),
        _ => unreachable!("the renderer follows the input"),
    };
    let (lo, hi) = match &renderer {
        Renderer::Grid(occ) => crate::render::occupied_world_box(occ, &xf),
        Renderer::Store(paged) => crate::render::occupied_world_box(paged.as_ref(), &xf),
        Renderer::Volume(vs, _) => {
            let d = vs.dims().map(|x| x as f64);
            xf.world_bounds(DVec3::splat(-0.5), DVec3::from_array(d) - 0.5)
        }
    };
    let base_cam = camera(&args, lo, hi, axes)?;
    // A bar over frames; a single frame gets a spinner (drawn from the first
    // tick, so renders under a tick never show it).
    let bar = (!args.quiet && std::io::stderr().is_terminal()).then(|| {
        if frames == 1 {
            let b = indicatif::ProgressBar::new_spinner();
            b.set_message("rendering");
            b.enable_steady_tick(std::time::Duration::from_millis(1000));
            return b;
        }
        let b = indicatif::ProgressBar::new(frames as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {elapsed_precise} [{bar:30}] frame {pos}/{len}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let mut times = Vec::new();
    // The memory floor beside the frames, interleaved with them.
    let mut floors = Vec::new();
    let mut floor = |renderer: &Renderer| {
        if let (Renderer::Volume(vs, _), true) = (renderer, args.reps > 1) {
            let t = Instant::now();
            std::hint::black_box(vs.bricks().max_pass());
            floors.push(ms(t));
        }
    };
    let mut first: Option<(RenderImage, RenderStats, Camera)> = None;
    let mut gif_frames = Vec::new();
    for i in 0..frames {
        let cam = frame_camera(&base_cam, axes, i, frames);
        let mut rendered = renderer.render(&xf, &cam, &opts)?;
        times.push(rendered.1.render_ms);
        floor(&renderer);
        for _ in 1..args.reps {
            // The repeated frame writes into the one before's buffers, as
            // an interactive renderer redraws into its frame buffer.
            rendered.0.recycle();
            rendered = renderer.render(&xf, &cam, &opts)?;
            times.push(rendered.1.render_ms);
            floor(&renderer);
        }
        let (img, stats) = rendered;
        let rgba = img.to_rgba8(opts.background);
        if is_gif(&args.output) {
            gif_frames.push(rgba);
        } else {
            crate::io::image::write_png_rgba(&outputs[i as usize], w, h, &rgba, args.force)?;
        }
        if let Some(b) = &bar {
            b.inc(1);
        }
        if first.is_none() {
            first = Some((img, stats, cam));
        } else {
            img.recycle();
        }
    }
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    if is_gif(&args.output) {
        crate::io::image::write_gif(&args.output, w, h, &gif_frames, 8, args.force)?;
    }
    let (img, stats, cam) = first.expect("at least one frame");
    if let Some(exr) = &args.exr {
        let premultiplied: Vec<[f32; 4]> = img
            .color
            .iter()
            .map(|c| [c[0] * c[3], c[1] * c[3], c[2] * c[3], c[3]])
            .collect();
        crate::io::image::write_exr(exr, w, h, &premultiplied, &img.depth, args.force)?;
    }
    times.sort_by(f64::total_cmp);
    let render_ms = times[times.len() / 2];
    let mut j = serde_json::json!({
        "input": args.input.display().to_string(),
        "output": args.output.display().to_string(),
        "ray": args.ray.name(),
        "method": if stats.shear_warp { "shear-warp" } else { "rays" },
        "skip": !args.no_skip,
        "size": [w, h],
        "frames": frames,
        "rays": stats.rays,
        "hits": stats.hits,
        "voxels_visited": stats.voxels_visited,
        "bricks_skipped": stats.bricks_skipped,
        "rays_culled": stats.rays_culled,
        "load_ms": load_ms,
        "prepare_ms": prepare_ms,
        "render_ms": render_ms,
        "memory_bytes": renderer.heap_bytes() as u64 + w as u64 * h as u64 * 36,
    });
    let obj = j.as_object_mut().expect("json! of an object literal");
    if !floors.is_empty() {
        floors.sort_by(f64::total_cmp);
        let floor_ms = floors[floors.len() / 2];
        obj.insert("floor_ms".into(), floor_ms.into());
        obj.insert("frame_over_floor".into(), (render_ms / floor_ms).into());
    }
    obj.insert("camera".into(), camera_json(&base_cam));
    obj.extend(info);
    obj.insert("warnings".into(), serde_json::json!(warnings));
    if let Renderer::Store(paged) = &renderer {
        // What the rays reached of the store (all frames).
        obj.insert("chunks_decoded".into(), paged.chunks_decoded().into());
        obj.insert("pages_built".into(), paged.pages_built().into());
    }
    if args.measure {
        let t = Instant::now();
        let six = RenderOptions {
            ray: RayKind::Six,
            ..opts
        };
        let (reference, _) = match &renderer {
            Renderer::Volume(vs, vopts) => {
                // Against the exact image, whatever the method.
                let exact = VolumeOptions {
                    method: VolumeMethod::Rays,
                    ..vopts.clone()
                };
                render_volume(vs, &cam, &six, &exact)?
            }
            _ => renderer.render(&xf, &cam, &six)?,
        };
        let differing = match &renderer {
            Renderer::Grid(_) | Renderer::Store(_) => img.differing_hits(&reference),
            Renderer::Volume(..) => crate::render::differing_values(&img, &reference),
        };
        obj.insert("differing_pixels".into(), differing.into());
        if stats.shear_warp {
            let d = crate::render::measure::image_difference(&img, &reference, opts.background);
            obj.insert(
                "difference".into(),
                serde_json::json!({
                    "mean_levels": d.mean, "p99_levels": d.p99, "max_levels": d.max,
                    "share_over_2_levels": d.over_2,
                }),
            );
        }
        if let Some(scene) = &grid
            && let Some(mesh) = &scene.mesh
        {
            let m = crate::render::measure::against_mesh(&img, mesh, &cam, scene.voxel_size)?;
            obj.insert("mesh_depth_mean".into(), m.depth_mean.into());
            obj.insert("mesh_depth_max".into(), m.depth_max.into());
            obj.insert("silhouette_disagree".into(), m.silhouette_disagree.into());
        }
        obj.insert("measure_ms".into(), ms(t).into());
    }
    obj.insert("peak_rss_mib".into(), serde_json::json!(peak_rss_mib()));
    if args.json {
        writeln!(out, "{j}")?;
    } else {
        writeln!(
            out,
            "{}: {}x{} {} rays ({} skip), {} hits, {} voxels visited, {} jumps; load {:.1} ms, prepare {:.1} ms, render {:.1} ms/frame{}",
            args.output.display(),
            w,
            h,
            if stats.shear_warp {
                "shear-warp"
            } else {
                args.ray.name()
            },
            if args.no_skip { "no" } else { "with" },
            stats.hits,
            stats.voxels_visited,
            stats.bricks_skipped,
            load_ms,
            prepare_ms,
            render_ms,
            obj.get("differing_pixels")
                .map(|d| format!("; {d} pixels differ from the 6-ray image"))
                .unwrap_or_default()
        )?;
    }
    Ok(())
}

/// The render structures of the input.
enum Renderer {
    Grid(OccupancyGrid),
    Store(Box<PagedOccupancy>),
    Volume(Box<VolumeScene>, VolumeOptions),
}

impl Renderer {
    fn render(
        &self,
        xf: &GridTransform,
        cam: &Camera,
        opts: &RenderOptions,
    ) -> crate::Result<(RenderImage, RenderStats)> {
        match self {
            Renderer::Grid(occ) => render_grid(occ, xf, cam, opts),
            Renderer::Store(paged) => render_grid(paged.as_ref(), xf, cam, opts),
            Renderer::Volume(vs, vopts) => render_volume(vs, cam, opts, vopts),
        }
    }

    fn heap_bytes(&self) -> usize {
        match self {
            Renderer::Grid(occ) => occ.heap_bytes(),
            Renderer::Store(paged) => paged.heap_bytes() as usize,
            Renderer::Volume(vs, _) => vs.heap_bytes(),
        }
    }
}

/// The volume options of the arguments, over `window` (the arguments' own
/// or the data's default).
pub(crate) fn volume_options(
    args: &RenderArgs,
    window: (f32, f32),
) -> Result<VolumeOptions, CliError> {
    let mut v = VolumeOptions::with_window(VolumeMode::Mip, window);
    if let Some(tf) = &args.tf {
        v.transfer = TransferFunction::parse(tf)?;
    }
    v.mode = match args.volume.unwrap_or(VolumeArg::Mip) {
        VolumeArg::Mip => VolumeMode::Mip,
        VolumeArg::Composite => VolumeMode::Composite,
        VolumeArg::Iso => {
            let level = args.iso.unwrap_or(v.middle_of_window());
            if !level.is_finite() {
                return Err(CliError::bad_input("--iso must be a finite value"));
            }
            VolumeMode::Iso(level)
        }
    };
    if args.iso.is_some() && !matches!(v.mode, VolumeMode::Iso(_)) {
        return Err(CliError::bad_input("--iso needs --volume iso"));
    }
    v.sampling = args.sampling;
    v.method = args.method;
    Ok(v)
}

fn is_gif(p: &Path) -> bool {
    p.extension()
        .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case("gif"))
}

/// The PNG path of every frame: `OUT.png` alone, or `OUT_000.png`, … for a
/// turntable (a `.gif` output is one file).
fn frame_paths(output: &Path, turntable: Option<u32>) -> Result<Vec<PathBuf>, CliError> {
    let ext = output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match (ext.as_str(), turntable) {
        ("gif", Some(_)) => Ok(vec![output.to_path_buf()]),
        ("gif", None) => Err(CliError::bad_input(
            "a .gif output needs --turntable N (a single frame is written as PNG)",
        )),
        ("png", None) => Ok(vec![output.to_path_buf()]),
        ("png", Some(n)) => {
            let stem = output.with_extension("");
            Ok((0..n)
                .map(|i| PathBuf::from(format!("{}_{i:03}.png", stem.display())))
                .collect())
        }
        _ => Err(CliError::bad_input(format!(
            "{}: the output must be a .png (or .gif with --turntable)",
            output.display()
        ))),
    }
}
