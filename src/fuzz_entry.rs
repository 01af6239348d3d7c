//! The entry points of the fuzz targets in `fuzz/` (cargo-fuzz, libFuzzer),
//! kept in the library so that the targets and the regression test
//! (`tests/integration/fuzz_regressions.rs`, which replays every file under
//! `fuzz/regressions/<target>/`) run the same code. Not a public API.
//!
//! Each function takes the raw fuzz input and returns what the reader
//! returned: `Ok` for input it accepted, a typed error otherwise. A panic,
//! a hang or an allocation beyond libFuzzer's `-malloc_limit_mb` is a bug.
//! Where a cheap independent check exists (a written file reads back with
//! the same voxels), a failing check panics, so the fuzzer reports it.

use glam::{DVec3, IVec3};

use crate::camera::{Camera, SceneAxes};
use crate::cli::CliError;
use crate::error::{Result, VoxkitError};
use crate::grid::{BrickGrid, GridFrame, MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
use crate::line::Segment;
use crate::metric::{Connectivity, adjacent};
use crate::render::{GridTransform, OccupancyGrid, RenderImage, RenderOptions};

/// The memory limit every reader gets under fuzzing: small, so that a
/// header asking for more is refused before anything is allocated, and
/// well under libFuzzer's 1 GiB allocation limit.
pub const LIMIT: MemoryLimit = MemoryLimit::new(256 << 20);

/// The names of the fuzz targets, each a function of this module and a
/// directory under `fuzz/regressions/`.
pub const TARGETS: &[&str] = &[
    "obj",
    "gltf",
    "ply",
    "stl",
    "off",
    "binvox",
    "vox",
    "npy",
    "nrrd",
    "volume_nrrd",
    "volume_meta",
    "volume_npy",
    "volume_nifti",
    "line",
    "render",
];

/// Runs the entry point of `target` (one of [`TARGETS`]) on `data`.
pub fn run(target: &str, data: &[u8]) -> Result<()> {
    match target {
        "obj" => obj(data),
        "gltf" => gltf(data),
        "ply" => ply(data),
        "stl" => stl(data),
        "off" => off(data),
        "binvox" => binvox(data),
        "vox" => vox(data),
        "npy" => npy(data),
        "nrrd" => nrrd(data),
        "volume_nrrd" => volume_nrrd(data),
        "volume_meta" => volume_meta(data),
        "volume_npy" => volume_npy(data),
        "volume_nifti" => volume_nifti(data),
        "line" => line(data),
        "render" => render(data),
        _ => Err(VoxkitError::invalid(format!("no fuzz target {target:?}"))),
    }
}

/// OBJ bytes (any encoding, as in `obj::load`).
pub fn obj(data: &[u8]) -> Result<()> {
    let mesh = crate::mesh::obj::parse(data, "fuzz.obj")?;
    check_mesh(&mesh);
    Ok(())
}

/// glTF JSON or GLB bytes (no base directory: external buffers are an
/// error, data URIs and the GLB chunk are read).
pub fn gltf(data: &[u8]) -> Result<()> {
    check_mesh(&crate::mesh::gltf::parse(data, None, "fuzz.glb")?);
    Ok(())
}

/// PLY bytes (ASCII or binary).
pub fn ply(data: &[u8]) -> Result<()> {
    check_mesh(&crate::mesh::ply::parse(data, "fuzz.ply")?);
    Ok(())
}

/// STL bytes (ASCII or binary).
pub fn stl(data: &[u8]) -> Result<()> {
    check_mesh(&crate::mesh::stl::parse(data, "fuzz.stl")?);
    Ok(())
}

/// OFF bytes.
pub fn off(data: &[u8]) -> Result<()> {
    check_mesh(&crate::mesh::off::parse(data, "fuzz.off")?);
    Ok(())
}

/// A loaded mesh's indices must point at its positions.
fn check_mesh(mesh: &crate::mesh::Mesh) {
    let n = mesh.positions.len();
    for t in &mesh.triangles {
        assert!(
            t.iter().all(|&i| (i as usize) < n),
            "triangle index out of range"
        );
    }
    for l in &mesh.polylines {
        assert!(
            l.iter().all(|&i| (i as usize) < n),
            "polyline index out of range"
        );
    }
    assert!(
        mesh.positions.iter().all(|p| p.is_finite()),
        "a non-finite position"
    );
    assert!(
        !(mesh.triangles.is_empty() && mesh.polylines.is_empty()),
        "an empty mesh was accepted"
    );
    let _ = mesh.bounds();
}

/// Writes what a voxel reader returned with `write` and reads it back with
/// `read`: the voxel count must survive the round trip. A write that is
/// refused (a limit) is fine.
fn round_trip(
    grid: &BrickGrid,
    frame: &GridFrame,
    write: impl Fn(&mut Vec<u8>, &BrickGrid, &GridFrame) -> Result<()>,
    read: impl Fn(&[u8]) -> Result<(BrickGrid, GridFrame)>,
) {
    let mut bytes = Vec::new();
    if write(&mut bytes, grid, frame).is_err() {
        return;
    }
    let (again, _) = read(&bytes).expect("a file we wrote must read back");
    assert_eq!(
        again.count(),
        grid.count(),
        "voxel count changed in a round trip"
    );
}

/// `.binvox` bytes.
pub fn binvox(data: &[u8]) -> Result<()> {
    use crate::io::binvox;
    let (grid, frame) = binvox::read(data, LIMIT)?;
    round_trip(
        &grid,
        &frame,
        |w, g, f| binvox::write(w, g, f, LIMIT),
        |b| binvox::read(b, LIMIT),
    );
    Ok(())
}

/// MagicaVoxel `.vox` bytes, with colours.
pub fn vox(data: &[u8]) -> Result<()> {
    use crate::io::vox;
    let s = vox::read_colored(data, LIMIT)?;
    // Every placed voxel (instances, rotations, groups) is in the grid, and
    // the grid has no voxel that no placement put there.
    assert!(
        s.colors.voxels.iter().all(|&(v, _)| s.grid.contains(v)),
        "a placed voxel is missing from the grid"
    );
    let distinct: std::collections::HashSet<_> = s.colors.voxels.iter().map(|p| p.0).collect();
    assert_eq!(
        distinct.len() as u64,
        s.grid.count(),
        "grid and placed voxels differ"
    );
    round_trip(
        &s.grid,
        &s.frame,
        |w, g, f| vox::write(w, g, f),
        |b| vox::read(b, LIMIT),
    );
    Ok(())
}

/// `.npy` bytes as a voxel grid.
pub fn npy(data: &[u8]) -> Result<()> {
    use crate::io::npy;
    let (grid, frame) = npy::read(data, LIMIT)?;
    round_trip(
        &grid,
        &frame,
        |w, g, f| npy::write(w, g, f, LIMIT),
        |b| npy::read(b, LIMIT),
    );
    Ok(())
}

/// `.nrrd` bytes as a voxel grid.
pub fn nrrd(data: &[u8]) -> Result<()> {
    use crate::io::nrrd;
    let (grid, frame) = nrrd::read(data, LIMIT)?;
    round_trip(
        &grid,
        &frame,
        |w, g, f| nrrd::write(w, g, f, LIMIT),
        |b| nrrd::read(b, LIMIT),
    );
    Ok(())
}

/// Splits the input of a detached-header target at the first
/// [`DATA_SEPARATOR`]: the header before it, the data file after it. Without
/// one, the whole input is an attached file and there is no data file.
pub const DATA_SEPARATOR: &[u8] = b"\n@@DATA@@\n";

fn split_data(data: &[u8]) -> Option<(&[u8], &[u8])> {
    let at = data
        .windows(DATA_SEPARATOR.len())
        .position(|w| w == DATA_SEPARATOR)?;
    Some((&data[..at], &data[at + DATA_SEPARATOR.len()..]))
}

/// Reads a scalar volume from memory: an attached file named `attached`,
/// or a header named `detached` whose data files all hold the bytes after
/// [`DATA_SEPARATOR`]; then uses the volume as the renderer and `voxkit
/// render` do (range, percentiles, `f32` copy, occupancy).
fn volume(data: &[u8], attached: &str, detached: &str) -> Result<()> {
    use crate::io::volume::read_volume_bytes;
    let vol = match split_data(data) {
        None => read_volume_bytes(attached.as_ref(), data, &[], LIMIT)?,
        Some((header, body)) => read_volume_bytes(detached.as_ref(), header, body, LIMIT)?,
    };
    check_volume(&vol);
    Ok(())
}

fn check_volume(vol: &ScalarVolume) {
    assert_eq!(vol.len(), vol.dims.iter().product::<usize>());
    let _ = vol.range();
    let _ = vol.percentiles(&[0.01, 0.5, 0.995]);
    if vol.is_binary() {
        let _ = vol.to_brick_grid();
    }
    let _ = vol.to_f32(LIMIT);
}

/// NRRD: an attached `.nrrd`, or a detached `.nhdr` and its data
/// (split at [`DATA_SEPARATOR`]).
pub fn volume_nrrd(data: &[u8]) -> Result<()> {
    volume(data, "fuzz.nrrd", "fuzz.nhdr")
}

/// MetaImage: an attached `.mha`, or a `.mhd` and its data (split at
/// [`DATA_SEPARATOR`]).
pub fn volume_meta(data: &[u8]) -> Result<()> {
    volume(data, "fuzz.mha", "fuzz.mhd")
}

/// `.npy` as a scalar volume (every dtype).
pub fn volume_npy(data: &[u8]) -> Result<()> {
    volume(data, "fuzz.npy", "fuzz.npy")
}

/// NIfTI-1/2: a `.nii` (plain or gzipped), or a `.hdr` and its `.img`
/// (split at [`DATA_SEPARATOR`]).
pub fn volume_nifti(data: &[u8]) -> Result<()> {
    volume(data, "fuzz.nii", "fuzz.hdr")
}

/// Segments longer than this (in 6-steps) are parsed but not drawn, so
/// that the target cannot hang by design; `voxkit line` itself streams any
/// length in constant memory.
pub const MAX_LINE_STEPS: u64 = 100_000;

/// `voxkit line` input: every line of the text through the stdin parser
/// ([`crate::cli::line::parse_line`]), each segment drawn by every
/// algorithm and checked (first and last voxel, connectivity, the exact
/// counts); then the first line as the command's own arguments through
/// clap and [`crate::cli::run`].
pub fn line(data: &[u8]) -> Result<()> {
    use crate::cli::line::{LineAlgo, parse_line, voxels};
    let text = std::str::from_utf8(data).map_err(|_| VoxkitError::invalid("not UTF-8"))?;
    let mut first_error = None;
    for (i, l) in text.lines().enumerate().take(64) {
        let seg = match parse_line(l, i + 1) {
            Ok(Some(seg)) => seg,
            Ok(None) => continue,
            Err(e) => {
                assert_eq!(e.code, 2);
                first_error.get_or_insert(e);
                continue;
            }
        };
        if steps(&seg) > MAX_LINE_STEPS {
            continue;
        }
        let flags = [-2, -2, -2, 2, 2, 2];
        for (algo, conn, exact) in [
            (LineAlgo::TwentySix, Connectivity::TwentySix, true),
            (LineAlgo::Eighteen, Connectivity::Eighteen, true),
            (LineAlgo::Tripod, Connectivity::Six, true),
            (LineAlgo::Aw, Connectivity::Six, false),
            (LineAlgo::Adaptive, Connectivity::TwentySix, false),
        ] {
            let fb = (algo == LineAlgo::Adaptive).then_some(&flags[..]);
            match voxels(algo, fb, &seg) {
                Ok(vs) => check_line(&seg, &vs.collect::<Vec<_>>(), conn, exact, algo),
                // Amanatides–Woo refuses what it cannot step in f64.
                Err(e) => assert!(
                    algo == LineAlgo::Aw && e.code == 2,
                    "{algo:?}: {}",
                    e.message
                ),
            }
        }
        let t6 = crate::line::Tripod6::new(&seg);
        let (v0, v1) = (seg.start_voxel(), seg.end_voxel());
        assert_eq!(
            t6.len() as u64,
            crate::metric::d6(v0, v1) + 1,
            "tripod count"
        );
    }
    line_cli(text.lines().next().unwrap_or(""));
    match first_error {
        Some(e) => Err(VoxkitError::invalid(e.message)),
        None => Ok(()),
    }
}

/// The 6-steps from the start voxel to the end voxel.
fn steps(seg: &Segment) -> u64 {
    crate::metric::d6(seg.start_voxel(), seg.end_voxel())
}

fn check_line(
    seg: &Segment,
    path: &[IVec3],
    conn: Connectivity,
    exact: bool,
    algo: crate::cli::line::LineAlgo,
) {
    assert!(!path.is_empty(), "{algo:?}: no voxel for {seg:?}");
    for w in path.windows(2) {
        assert!(
            adjacent(w[0], w[1], conn),
            "{algo:?}: {w:?} not {conn:?}-adjacent, {seg:?}"
        );
    }
    if exact {
        assert_eq!(
            path[0],
            seg.start_voxel(),
            "{algo:?}: first voxel of {seg:?}"
        );
        assert_eq!(
            path[path.len() - 1],
            seg.end_voxel(),
            "{algo:?}: last voxel of {seg:?}"
        );
    }
}

/// `voxkit line ARGS` with the words of `args`, run when its segments are
/// short (never from stdin: without coordinates it is only parsed).
fn line_cli(args: &str) {
    use clap::Parser;
    let argv = ["voxkit", "line"]
        .into_iter()
        .chain(args.split_whitespace());
    let Ok(cli) = crate::cli::Cli::try_parse_from(argv) else {
        return;
    };
    let crate::cli::Command::Line(ref a) = cli.command else {
        unreachable!("parsed as `voxkit line`")
    };
    if a.coords.is_empty() {
        return;
    }
    let short = a.coords.chunks(6).all(|c| {
        let f: Vec<&str> = c.iter().map(String::as_str).collect();
        crate::cli::line::parse_segment(&f, "", "").is_ok_and(|s| steps(&s) <= MAX_LINE_STEPS)
    });
    if short {
        let mut out = Vec::new();
        if let Err(e) = crate::cli::run(cli, &mut out) {
            assert_eq!(e.code, 2, "{}", e.message);
        }
    }
}

/// Image sides at most this under fuzzing (the camera still sees the
/// requested aspect ratio's limit: sides are clamped, not the arguments).
pub const MAX_IMAGE_SIDE: u32 = 8;

/// Turntable frames rendered at most (the first, a middle and the last).
const MAX_FRAMES: u32 = 3;

/// The render camera. Text input is the argument list of `voxkit render
/// in.binvox -o out.png` (words split at whitespace) through clap and the
/// command's own camera set-up (`cli::render`), rendered at most
/// 8×8 of a tiny fixed grid (or, with `--volume`, a tiny scalar volume);
/// input starting with byte `0xFF` is a list of `f64`s for the camera
/// constructors directly. A camera the command accepts must render an image
/// of finite colours and depths; one it refuses is a typed error.
pub fn render(data: &[u8]) -> Result<()> {
    if let Some(rest) = data.strip_prefix(&[0xFF]) {
        return render_raw_camera(rest);
    }
    let text = std::str::from_utf8(data).map_err(|_| VoxkitError::invalid("not UTF-8"))?;
    render_cli(text).map_err(|e| {
        assert_eq!(e.code, 2, "{}", e.message);
        VoxkitError::invalid(e.message)
    })
}

fn tiny_grid() -> (OccupancyGrid, GridTransform) {
    let dims = [5, 4, 3];
    let grid: BrickGrid = (0..5)
        .flat_map(|x| (0..4).flat_map(move |y| (0..3).map(move |z| IVec3::new(x, y, z))))
        .filter(|v| (v.x * 7 + v.y * 3 + v.z * 5) % 4 != 0)
        .collect();
    let occ = OccupancyGrid::new(&grid, dims, LIMIT).expect("a tiny grid fits");
    let frame = GridFrame::new(DVec3::new(-1.0, 0.5, 2.0), 0.25, dims);
    (
        occ,
        GridTransform::from_frame(&frame).expect("a valid frame"),
    )
}

fn tiny_volume() -> ScalarVolume {
    let dims = [4, 3, 5];
    let data: Vec<f32> = (0..60).map(|i| ((i * 37) % 11) as f32 - 3.0).collect();
    let frame = VolumeFrame::from_spacing(DVec3::new(0.5, -2.0, 1.0), DVec3::new(1.0, 0.5, 2.0));
    ScalarVolume::new(dims, VolumeData::F32(data), frame).expect("a valid volume")
}

/// An image the renderer returned must be of finite values.
fn check_image(img: &RenderImage) {
    for c in &img.color {
        assert!(c.iter().all(|x| x.is_finite()), "colour {c:?}");
    }
    for d in &img.depth {
        assert!(!d.is_nan() && *d >= 0.0, "depth {d}");
    }
}

fn render_cli(text: &str) -> std::result::Result<(), CliError> {
    use crate::cli::render::{camera, frame_camera, volume_options};
    use clap::Parser;
    let base = ["voxkit", "render", "in.binvox", "-o", "out.png"];
    let argv = base.into_iter().chain(text.split_whitespace());
    let cli =
        crate::cli::Cli::try_parse_from(argv).map_err(|e| CliError::bad_input(e.to_string()))?;
    let crate::cli::Command::Render(mut args) = cli.command else {
        unreachable!("parsed as `voxkit render`")
    };
    let frames = crate::cli::render::check_frames(&args, LIMIT)?;
    args.size = (
        args.size.0.min(MAX_IMAGE_SIDE),
        args.size.1.min(MAX_IMAGE_SIDE),
    );
    let opts = RenderOptions {
        width: args.size.0,
        height: args.size.1,
        ray: args.ray,
        skip: !args.no_skip,
        normals: args.normals,
        background: args.background.as_vec3().to_array(),
        limit: LIMIT,
        ..RenderOptions::default()
    };
    let volume_args =
        args.volume.is_some() || args.iso.is_some() || args.window.is_some() || args.tf.is_some();
    let picks = [0, frames / 2, frames - 1];
    if volume_args {
        let vol = tiny_volume();
        let vs = crate::render::VolumeScene::new(&vol, LIMIT)?;
        let window = args
            .window
            .unwrap_or_else(|| crate::render::VolumeOptions::default_window(&vol));
        let vopts = volume_options(&args, window)?;
        let d = vs.dims().map(|x| x as f64);
        let (lo, hi) = vs
            .transform()
            .world_bounds(DVec3::splat(-0.5), DVec3::from_array(d) - 0.5);
        let base_cam = camera(&args, lo, hi, SceneAxes::Z_UP)?;
        for &i in &picks[..MAX_FRAMES.min(frames) as usize] {
            let cam = frame_camera(&base_cam, SceneAxes::Z_UP, i, frames);
            let (img, _) = crate::render::render_volume(&vs, &cam, &opts, &vopts)?;
            check_image(&img);
        }
    } else {
        let (occ, xf) = tiny_grid();
        let (lo, hi) = crate::render::occupied_world_box(&occ, &xf);
        let base_cam = camera(&args, lo, hi, SceneAxes::Y_UP)?;
        for &i in &picks[..MAX_FRAMES.min(frames) as usize] {
            let cam = frame_camera(&base_cam, SceneAxes::Y_UP, i, frames);
            let (img, _) = crate::render::render_grid(&occ, &xf, &cam, &opts)?;
            check_image(&img);
        }
    }
    Ok(())
}

/// The camera constructors on arbitrary numbers: 8-byte little-endian
/// `f64`s (eye, target, up, fov, height, box min, box max, toward-eye,
/// orbit angle), then a byte each for width and height.
fn render_raw_camera(data: &[u8]) -> Result<()> {
    let mut f = data
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .chain(std::iter::repeat(1.0));
    let mut v3 = || {
        DVec3::new(
            f.next().unwrap_or(1.0),
            f.next().unwrap_or(1.0),
            f.next().unwrap_or(1.0),
        )
    };
    let (eye, target, up) = (v3(), v3(), v3());
    let (fov, height) = (v3().x, v3().x);
    let (lo, hi, toward) = (v3(), v3(), v3());
    let angle = v3().x;
    let side = |i: usize| {
        data.get(data.len().wrapping_sub(i))
            .map_or(4, |&b| u32::from(b % 9))
    };
    let (w, h) = (side(1), side(2));
    let (occ, xf) = tiny_grid();
    let opts = RenderOptions {
        width: w,
        height: h,
        limit: LIMIT,
        ..RenderOptions::default()
    };
    let mut first_error = None;
    let cams = [
        Ok(Camera::perspective(eye, target, up, fov)),
        Ok(Camera::orthographic(eye, target, up, height)),
        Camera::framing(lo, hi, toward, up, Some(fov), w, h),
        Camera::framing(lo, hi, toward, up, None, w, h),
    ];
    for cam in cams {
        let result = cam.and_then(|c| {
            for c in [c, c.orbited(up, angle)] {
                let (img, _) = crate::render::render_grid(&occ, &xf, &c, &opts)?;
                check_image(&img);
            }
            Ok(())
        });
        if let Err(e) = result {
            first_error.get_or_insert(e);
        }
    }
    first_error.map_or(Ok(()), Err)
}
