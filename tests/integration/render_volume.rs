//! Scalar-volume rendering against oracles: MIP == the brute-force maximum
//! over each column for axis-aligned views and over the cubes a perspective
//! ray meets; skipping on == off bit for bit for every mode, sampling and
//! ray kind; adaptive == 6-ray (MIP, iso first hits, compositing);
//! anisotropic and offset volumes; the CT head; 1 vs N threads; golden
//! images per mode derived independently.

use glam::{DMat3, DVec3, IVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::camera::Camera;
use voxkit::grid::{MemoryLimit, ScalarVolume, VolumeData, VolumeFrame};
use voxkit::render::{
    NormalMode, RayKind, RenderImage, RenderOptions, RenderStats, Sampling, TransferFunction,
    VolumeMethod, VolumeMode, VolumeOptions, VolumeScene, differing_values, render_volume,
};

fn volume(dims: [usize; 3], data: Vec<f32>, frame: VolumeFrame) -> ScalarVolume {
    ScalarVolume::new(dims, VolumeData::F32(data), frame).unwrap()
}

fn scene(v: &ScalarVolume) -> VolumeScene {
    VolumeScene::new(v, MemoryLimit::DEFAULT).unwrap()
}

fn opts(w: u32, h: u32, ray: RayKind, skip: bool) -> RenderOptions {
    RenderOptions {
        width: w,
        height: h,
        ray,
        skip,
        ..RenderOptions::default()
    }
}

fn render(
    s: &VolumeScene,
    cam: &Camera,
    o: &RenderOptions,
    vo: &VolumeOptions,
) -> (RenderImage, RenderStats) {
    render_volume(s, cam, o, vo).unwrap()
}

fn vopts(mode: VolumeMode, window: (f32, f32), sampling: Sampling) -> VolumeOptions {
    VolumeOptions {
        mode,
        window,
        transfer: TransferFunction::ramp(window),
        sampling,
        method: VolumeMethod::Rays,
    }
}

/// Values from a function of the voxel, x fastest.
fn fill(dims: [usize; 3], mut f: impl FnMut(i32, i32, i32) -> f32) -> Vec<f32> {
    let mut out = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] as i32 {
        for y in 0..dims[1] as i32 {
            for x in 0..dims[0] as i32 {
                out.push(f(x, y, z));
            }
        }
    }
    out
}

fn at(v: &ScalarVolume, p: IVec3) -> f32 {
    v.get(p.x as usize, p.y as usize, p.z as usize) as f32
}

/// An orthographic camera looking along `axis` (0, 1, 2; `sign` = the
/// direction of view) at a unit-spacing volume at the origin, one pixel per
/// voxel, pixel centres on voxel centres. Returns the camera and the image
/// size.
fn axis_camera(dims: [usize; 3], axis: usize, sign: f64) -> (Camera, u32, u32) {
    let c = DVec3::from_array(dims.map(|d| (d as f64 - 1.0) / 2.0));
    let mut dir = DVec3::ZERO;
    dir[axis] = sign;
    let (u, v) = match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let mut up = DVec3::ZERO;
    up[v] = 1.0;
    let eye = c - dir * (dims[axis] as f64 + 10.0);
    let cam = Camera::orthographic(eye, c, up, dims[v] as f64);
    (cam, dims[u] as u32, dims[v] as u32)
}

/// MIP along x, y and z (both ways) is each column's maximum, for every
/// ray kind, with and without skipping, and with a window inside the range
/// the hit is `None` exactly where the column stays at or below the low
/// end. With NaN samples (−∞) nearest sampling only: the pixel rays pass
/// voxel centres up to float noise (pixel positions are divided by the
/// image width), so a trilinear sample takes a weight of ~1e-15 from a
/// neighbour, and a −∞ neighbour makes it −∞; without NaN trilinear equals
/// nearest there.
#[test]
fn mip_is_the_column_maximum_along_axes() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let dims = [21usize, 17, 12];
    let values = fill(dims, |_, _, _| {
        let x: f32 = rng.random_range(-100.0..100.0);
        (x * 4.0).round() / 4.0
    });
    let with_nan: Vec<f32> = values
        .iter()
        .map(|&x| if rng.random_bool(0.02) { f32::NAN } else { x })
        .collect();
    let cases = [
        (with_nan, vec![Sampling::Nearest]),
        (values, vec![Sampling::Nearest, Sampling::Trilinear]),
    ];
    for (data, samplings) in cases {
        let vol = volume(dims, data, VolumeFrame::default());
        let s = scene(&vol);
        for axis in 0..3 {
            for sign in [1.0, -1.0] {
                let (cam, w, h) = axis_camera(dims, axis, sign);
                for window in [(-200.0, 200.0), (60.0, 100.0)] {
                    for &sampling in &samplings {
                        for kind in RayKind::ALL {
                            for skip in [false, true] {
                                let vo = vopts(VolumeMode::Mip, window, sampling);
                                let (img, _) = render(&s, &cam, &opts(w, h, kind, skip), &vo);
                                let what =
                                    format!("axis {axis} {sign} {kind:?} skip {skip} {sampling:?}");
                                check_columns(&vol, &cam, &img, axis, window, &what);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Checks an axis-aligned MIP against each pixel's column maximum.
fn check_columns(
    vol: &ScalarVolume,
    cam: &Camera,
    img: &RenderImage,
    axis: usize,
    window: (f32, f32),
    what: &str,
) {
    let (w, h) = (img.width, img.height);
    let n = vol.dims[axis] as i32;
    for py in 0..h {
        for px in 0..w {
            let (o, d) = cam.primary_ray(px as f64 + 0.5, py as f64 + 0.5, w, h);
            let col = o.round().as_ivec3();
            let mut best: Option<(f32, IVec3)> = None;
            for k in 0..n {
                let mut p = col;
                p[axis] = if d[axis] > 0.0 { k } else { n - 1 - k };
                let val = at(vol, p);
                if val > best.map_or(window.0, |b| b.0) {
                    best = Some((val, p));
                }
            }
            let i = (py * w + px) as usize;
            assert_eq!(img.hit[i], best.map(|b| b.1), "{what} pixel {px},{py}");
            let m = best.map_or(window.0, |b| b.0);
            let g = ((m - window.0) / (window.1 - window.0)).clamp(0.0, 1.0);
            assert_eq!(img.color[i], [g, g, g, 1.0], "{what} pixel {px},{py}");
        }
    }
}

/// A random frame: unit, anisotropic or sheared axes, offset origin.
fn random_frame(rng: &mut ChaCha8Rng) -> VolumeFrame {
    let origin = DVec3::new(
        rng.random_range(-50.0..50.0),
        rng.random_range(-50.0..50.0),
        rng.random_range(-50.0..50.0),
    );
    match rng.random_range(0..3) {
        0 => VolumeFrame::from_spacing(origin, DVec3::ONE),
        1 => VolumeFrame::from_spacing(
            origin,
            DVec3::new(
                rng.random_range(0.5..3.0),
                rng.random_range(0.5..3.0),
                rng.random_range(0.5..3.0),
            ),
        ),
        _ => VolumeFrame {
            origin,
            axes: DMat3::from_cols(
                DVec3::new(1.0, 0.2, 0.0),
                DVec3::new(-0.3, 1.1, 0.1),
                DVec3::new(0.0, 0.4, 2.0),
            ),
        },
    }
}

/// A random volume: a few Gaussian blobs on a zero background, values
/// quantized (ties), a sprinkle of NaN.
fn random_volume(rng: &mut ChaCha8Rng) -> ScalarVolume {
    let dims = [
        rng.random_range(1..40),
        rng.random_range(1..40),
        rng.random_range(1..40),
    ];
    let blobs: Vec<(DVec3, f64, f64)> = (0..rng.random_range(1..4))
        .map(|_| {
            (
                DVec3::from_array(dims.map(|d| rng.random_range(0.0..d as f64))),
                rng.random_range(1.5..8.0),
                rng.random_range(10.0..100.0),
            )
        })
        .collect();
    let nan = rng.random_bool(0.3);
    let data = fill(dims, |x, y, z| {
        if nan && rng.random_bool(0.01) {
            return f32::NAN;
        }
        let p = IVec3::new(x, y, z).as_dvec3();
        let v: f64 = blobs
            .iter()
            .map(|(c, s, a)| a * (-(p - *c).length_squared() / (2.0 * s * s)).exp())
            .sum();
        if v < 2.0 { 0.0 } else { v.round() as f32 }
    });
    volume(dims, data, random_frame(rng))
}

/// A random camera around (or inside) the world box of `vol`.
fn random_camera(rng: &mut ChaCha8Rng, vol: &ScalarVolume) -> Camera {
    let s = scene(vol);
    let d = vol.dims.map(|d| d as f64);
    let (lo, hi) = s
        .transform()
        .world_bounds(DVec3::splat(-0.5), DVec3::from_array(d) - 0.5);
    let centre = (lo + hi) * 0.5;
    let size = (hi - lo).length().max(1.0);
    let dir = loop {
        let v = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.length() > 0.1 {
            break v.normalize();
        }
    };
    let eye = centre + dir * size * rng.random_range(0.1..2.0);
    let target = centre + DVec3::new(rng.random_range(-1.0..1.0), 0.0, 0.0) * size * 0.1;
    let up = if dir.cross(DVec3::Z).length() < 0.1 {
        DVec3::Y
    } else {
        DVec3::Z
    };
    if rng.random_bool(0.3) {
        Camera::orthographic(eye, target, up, size)
    } else {
        Camera::perspective(eye, target, up, rng.random_range(30.0..80.0))
    }
}

/// Random options for a volume: every mode, a window inside its range, a
/// transfer function with transparent and opaque stretches.
fn random_modes(rng: &mut ChaCha8Rng, vol: &ScalarVolume) -> Vec<VolumeOptions> {
    let (a, b) = vol.range().unwrap_or((0.0, 1.0));
    let (a, b) = (a as f32, (b as f32).max(a as f32 + 1.0));
    let at = |t: f32| a + t * (b - a);
    let lo = at(rng.random_range(0.0..0.5));
    let window = (lo, lo + (b - a) * rng.random_range(0.2..1.0));
    let tf = TransferFunction::parse(&format!(
        "{}:0,{}:{}:#ff8000,{}:0.9:#2040ff",
        at(0.2),
        at(0.5),
        rng.random_range(0.05..0.5),
        at(0.9)
    ))
    .unwrap();
    [
        VolumeMode::Mip,
        VolumeMode::Composite,
        VolumeMode::Iso(at(rng.random_range(0.1..0.9))),
    ]
    .into_iter()
    .map(|mode| VolumeOptions {
        mode,
        window,
        transfer: if rng.random_bool(0.5) {
            tf.clone()
        } else {
            TransferFunction::ramp(window)
        },
        sampling: if rng.random_bool(0.5) {
            Sampling::Nearest
        } else {
            Sampling::Trilinear
        },
        method: VolumeMethod::Rays,
    })
    .collect()
}

/// Tiles culled before casting (rays whose tile meets only skippable
/// bricks) leave their pixels exactly as the cast rays do: a few small
/// blobs in a larger volume, so most tiles see nothing, and whole images at
/// tile scale (silhouettes cross tiles), every mode, sampling and ray kind,
/// perspective and orthographic, from outside and inside the volume.
#[test]
fn culled_tiles_equal_cast_rays() {
    let mut rng = ChaCha8Rng::seed_from_u64(808);
    let (mut culled, mut rays) = (0, 0);
    for round in 0..10 {
        let dims = [
            rng.random_range(40..90),
            rng.random_range(40..90),
            rng.random_range(40..90),
        ];
        let blobs: Vec<(DVec3, f64)> = (0..rng.random_range(1..4))
            .map(|_| {
                let c = DVec3::from_array(dims.map(|d| rng.random_range(0.0..d as f64)));
                (c, rng.random_range(1.0..4.0))
            })
            .collect();
        let data = fill(dims, |x, y, z| {
            let p = IVec3::new(x, y, z).as_dvec3();
            let v: f64 = blobs
                .iter()
                .map(|(c, s)| 100.0 * (-(p - *c).length_squared() / (2.0 * s * s)).exp())
                .sum();
            if v < 1.0 { 0.0 } else { v.round() as f32 }
        });
        let vol = volume(dims, data, random_frame(&mut rng));
        let s = scene(&vol);
        for _ in 0..3 {
            let cam = random_camera(&mut rng, &vol);
            for mut vo in random_modes(&mut rng, &vol) {
                vo.window.0 = vo.window.0.max(0.0);
                for kind in RayKind::ALL {
                    let o = |skip| opts(80, 56, kind, skip);
                    let (with, st) = render(&s, &cam, &o(true), &vo);
                    let without = render(&s, &cam, &o(false), &vo).0;
                    assert_eq!(
                        with, without,
                        "culling changed the image: round {round} {kind:?} {vo:?} {cam:?}"
                    );
                    culled += st.rays_culled;
                    rays += st.rays;
                }
            }
        }
    }
    assert!(culled * 4 > rays, "only {culled} of {rays} rays culled");
}

/// Skipping on == off bit for bit (colour, depth, hit) for every mode,
/// sampling and ray kind on random volumes and cameras; the adaptive ray's
/// image (MIP, iso first hits, compositing) is the 6-ray's; the 6-ray's
/// skipping does skip.
#[test]
fn skipping_changes_nothing_and_adaptive_equals_six() {
    let mut rng = ChaCha8Rng::seed_from_u64(2027);
    let (mut jumps, mut diff26, mut diff_aw, mut pixels) = (0, 0, 0, 0);
    for round in 0..14 {
        let vol = random_volume(&mut rng);
        let s = scene(&vol);
        for _ in 0..2 {
            let cam = random_camera(&mut rng, &vol);
            for mut vo in random_modes(&mut rng, &vol) {
                for sampling in [Sampling::Nearest, Sampling::Trilinear] {
                    vo.sampling = sampling;
                    let o = |kind, skip| opts(24, 20, kind, skip);
                    let six = render(&s, &cam, &o(RayKind::Six, false), &vo).0;
                    for kind in RayKind::ALL {
                        let (with, st) = render(&s, &cam, &o(kind, true), &vo);
                        let without = render(&s, &cam, &o(kind, false), &vo).0;
                        let what = format!("round {round} {kind:?} {vo:?} {cam:?}");
                        assert_eq!(with, without, "skipping changed the image: {what}");
                        assert!(with.color.iter().flatten().all(|c| c.is_finite()));
                        match kind {
                            RayKind::Six => jumps += st.bricks_skipped,
                            RayKind::Adaptive => {
                                assert_eq!(with, six, "adaptive differs from the 6-ray: {what}")
                            }
                            RayKind::TwentySix => diff26 += differing_values(&with, &six),
                            RayKind::AmanatidesWoo => diff_aw += differing_values(&with, &six),
                        }
                    }
                    pixels += 24 * 20;
                }
            }
        }
    }
    assert!(jumps > 1000, "only {jumps} jumps");
    // A–W passes through the same cubes as the 6-ray up to float ties.
    assert!(
        diff_aw * 100 < pixels,
        "A–W: {diff_aw} of {pixels} pixels differ"
    );
    assert!(diff26 > diff_aw, "26: {diff26}, A–W: {diff_aw}");
}

/// The cubes (voxel, entry t, exit t) the continuous ray `o + t·d`
/// (`t ≥ 0`) meets with a chord of positive length, by slab tests against
/// every voxel, in order of entry.
fn cubes_met(vol: &ScalarVolume, o: DVec3, d: DVec3) -> Vec<(IVec3, f64, f64)> {
    let [nx, ny, nz] = vol.dims.map(|n| n as i32);
    let mut out = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let v = IVec3::new(x, y, z);
                let (mut a, mut b) = (0.0f64, f64::INFINITY);
                for k in 0..3 {
                    let c = v[k] as f64;
                    if d[k] == 0.0 {
                        if (o[k] - c).abs() > 0.5 {
                            b = -1.0;
                        }
                        continue;
                    }
                    let (p, q) = ((c - 0.5 - o[k]) / d[k], (c + 0.5 - o[k]) / d[k]);
                    a = a.max(p.min(q));
                    b = b.min(p.max(q));
                }
                if b > a {
                    out.push((v, a, b));
                }
            }
        }
    }
    out.sort_by(|p, q| p.1.total_cmp(&q.1));
    out
}

/// Perspective and oblique views against brute force over the cubes the
/// continuous ray meets (grid-space rays from the camera's world rays):
/// the 6-ray's MIP is the largest value there and its composite the
/// front-to-back composite of the chords, except for pixels whose ray
/// passes within float noise of a cube's edge (a handful).
#[test]
fn six_ray_mip_and_composite_equal_brute_force_over_the_cubes() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let (mut checked, mut off) = (0, 0);
    for _ in 0..6 {
        let vol = random_volume(&mut rng);
        let s = scene(&vol);
        let inv = vol.frame.axes.inverse();
        let ref_len = vol.frame.axes.determinant().abs().cbrt();
        let cam = random_camera(&mut rng, &vol);
        let (w, h) = (20, 16);
        let (a, b) = vol.range().unwrap_or((0.0, 1.0));
        let window = (a as f32 - 1.0, b as f32 + 1.0);
        let mip = render(
            &s,
            &cam,
            &opts(w, h, RayKind::Six, true),
            &vopts(VolumeMode::Mip, window, Sampling::Nearest),
        )
        .0;
        let comp = render(
            &s,
            &cam,
            &opts(w, h, RayKind::Six, true),
            &vopts(VolumeMode::Composite, window, Sampling::Nearest),
        )
        .0;
        let tf = TransferFunction::ramp(window);
        for py in 0..h {
            for px in 0..w {
                let (ow, dw) = cam.primary_ray(px as f64 + 0.5, py as f64 + 0.5, w, h);
                let o = inv * (ow - vol.frame.origin);
                let d = inv * dw;
                let cubes = cubes_met(&vol, o, d);
                let i = (py * w + px) as usize;
                let mut best: Option<(f32, IVec3)> = None;
                let (mut c, mut al) = ([0.0f32; 3], 0.0f32);
                for &(v, t0, t1) in &cubes {
                    let val = at(&vol, v);
                    if val > best.map_or(window.0, |b| b.0) {
                        best = Some((val, v));
                    }
                    let tau = tf.opacity(if val.is_nan() { f32::NEG_INFINITY } else { val });
                    if al < 0.99 && tau > 0.0 {
                        let a = 1.0 - (1.0 - tau).powf(((t1 - t0) / ref_len) as f32);
                        let g = ((val - window.0) / (window.1 - window.0)).clamp(0.0, 1.0);
                        for ck in &mut c {
                            *ck += (1.0 - al) * a * g;
                        }
                        al += (1.0 - al) * a;
                    }
                }
                checked += 1;
                let mip_ok = mip.hit[i] == best.map(|b| b.1);
                let comp_ok = (comp.color[i][3] - al).abs() < 1e-3
                    && (comp.color[i][0] * comp.color[i][3] - c[0]).abs() < 1e-3;
                if !(mip_ok && comp_ok) {
                    off += 1;
                }
            }
        }
    }
    assert!(off * 200 <= checked, "{off} of {checked} pixels differ");
}

/// A cube of 16³ voxels with spacing (1, 1, 3) seen orthographically from
/// the front covers a rectangle three times taller than wide.
#[test]
fn anisotropic_volumes_keep_their_aspect() {
    let dims = [16usize, 16, 16];
    let vol = volume(
        dims,
        fill(dims, |x, _, _| x as f32),
        VolumeFrame::from_spacing(DVec3::ZERO, DVec3::new(1.0, 1.0, 3.0)),
    );
    let s = scene(&vol);
    // World box: x in [-0.5, 15.5], z in [-1.5, 46.5].
    let cam = Camera::orthographic(
        DVec3::new(7.5, -100.0, 22.5),
        DVec3::new(7.5, 0.0, 22.5),
        DVec3::Z,
        64.0,
    );
    for kind in RayKind::ALL {
        let (img, _) = render(
            &s,
            &cam,
            &opts(64, 64, kind, true),
            &vopts(VolumeMode::Mip, (-1.0, 15.0), Sampling::Nearest),
        );
        let covered: Vec<(u32, u32)> = (0..64 * 64)
            .filter(|&i| img.color[i as usize][3] > 0.0)
            .map(|i| (i % 64, i / 64))
            .collect();
        let (x0, x1) = (
            covered.iter().map(|p| p.0).min().unwrap(),
            covered.iter().map(|p| p.0).max().unwrap(),
        );
        let (y0, y1) = (
            covered.iter().map(|p| p.1).min().unwrap(),
            covered.iter().map(|p| p.1).max().unwrap(),
        );
        assert_eq!((x1 - x0 + 1, y1 - y0 + 1), (16, 48), "{kind:?}");
        assert_eq!(covered.len(), 16 * 48);
        // Grey rises left to right with x.
        let row = (y0 + 10) * 64;
        assert!(img.color[(row + x0) as usize][0] < img.color[(row + x1) as usize][0]);
    }
}

/// A volume far from the origin renders exactly as the same volume at the
/// origin with the camera moved along (exact offsets): the renderer works
/// in grid space from the volume's origin.
#[test]
fn non_zero_origins() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let dims = [20usize, 14, 9];
    let data = fill(dims, |x, y, z| ((x * 7 + y * 3 + z * 5) % 11) as f32);
    let spacing = DVec3::new(0.5, 1.0, 2.0);
    let shift = DVec3::new(1000.25, -512.0, 33.5);
    let at0 = volume(
        dims,
        data.clone(),
        VolumeFrame::from_spacing(DVec3::ZERO, spacing),
    );
    let far = volume(dims, data, VolumeFrame::from_spacing(shift, spacing));
    let (s0, s1) = (scene(&at0), scene(&far));
    for _ in 0..4 {
        let eye = DVec3::new(
            rng.random_range(-40..40) as f64 * 0.25,
            rng.random_range(-40..40) as f64 * 0.5,
            rng.random_range(10..60) as f64,
        );
        let target = DVec3::new(4.75, 6.5, 8.0);
        let c0 = Camera::perspective(eye, target, DVec3::Y, 50.0);
        let c1 = Camera::perspective(eye + shift, target + shift, DVec3::Y, 50.0);
        for mode in [VolumeMode::Mip, VolumeMode::Composite, VolumeMode::Iso(6.0)] {
            let vo = vopts(mode, (0.0, 10.0), Sampling::Trilinear);
            let o = opts(24, 24, RayKind::Adaptive, true);
            let (a, b) = (render(&s0, &c0, &o, &vo).0, render(&s1, &c1, &o, &vo).0);
            assert_eq!(a, b, "{mode:?}");
            assert!(a.hit.iter().any(Option::is_some));
        }
    }
}

/// The CT head (int16, spacing 3.2 × 3.2 × 1.5) in every mode and with
/// every ray kind gives a non-empty image; the adaptive ray's equals the
/// 6-ray's.
#[test]
fn ct_head_renders_in_every_mode() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/volumes/headsq_quarter/headsq_quarter.nhdr");
    let vol = voxkit::io::volume::read_volume(&path, MemoryLimit::DEFAULT).unwrap();
    let s = scene(&vol);
    let d = vol.dims.map(|n| n as f64);
    let (lo, hi) = s
        .transform()
        .world_bounds(DVec3::splat(-0.5), DVec3::from_array(d) - 0.5);
    let cam = Camera::framing(
        lo,
        hi,
        DVec3::new(0.3, -1.0, 0.2),
        DVec3::Z,
        Some(35.0),
        48,
        48,
    )
    .unwrap();
    let base = VolumeOptions::new(&vol, VolumeMode::Mip);
    let (wlo, whi) = base.window;
    assert!(wlo < whi);
    for mode in [
        VolumeMode::Mip,
        VolumeMode::Composite,
        VolumeMode::Iso(wlo + 0.3 * (whi - wlo)),
    ] {
        let vo = VolumeOptions {
            mode,
            ..base.clone()
        };
        let six = render(&s, &cam, &opts(48, 48, RayKind::Six, true), &vo).0;
        for kind in RayKind::ALL {
            let (img, st) = render(&s, &cam, &opts(48, 48, kind, true), &vo);
            let bright = img
                .color
                .iter()
                .filter(|c| c[3] > 0.2 && c[0] + c[1] + c[2] > 0.3)
                .count();
            assert!(
                bright > 48 * 48 / 10,
                "{mode:?} {kind:?}: only {bright} bright pixels ({st:?})"
            );
            assert!(st.hits as usize >= bright);
            if kind == RayKind::Adaptive {
                assert_eq!(img, six, "{mode:?}");
            }
        }
    }
}

/// One thread and several give the same images.
#[test]
fn threads_give_identical_images() {
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let vol = loop {
        let v = random_volume(&mut rng);
        if v.len() > 5000 {
            break v;
        }
    };
    let s = scene(&vol);
    let cam = random_camera(&mut rng, &vol);
    for vo in random_modes(&mut rng, &vol) {
        let o = opts(40, 30, RayKind::Adaptive, true);
        let many = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap()
            .install(|| render(&s, &cam, &o, &vo).0);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| render(&s, &cam, &o, &vo).0);
        assert_eq!(one, many);
    }
}

/// The golden volume: 32 × 32 × 16 voxels of unit size, a smooth analytic
/// density (a ball and a ramp), viewed straight down −z with one pixel per
/// voxel column (pixel (x, y) sees column (x, 31 − y)).
fn golden() -> (ScalarVolume, Camera) {
    let dims = [32usize, 32, 16];
    let data = fill(dims, |x, y, z| {
        let p = IVec3::new(x, y, z).as_dvec3() - DVec3::new(15.5, 15.5, 7.5);
        let ball = 100.0 - 8.0 * p.length();
        let ramp = 2.0 * x as f64 + z as f64;
        ball.max(ramp).round() as f32
    });
    let vol = volume(dims, data, VolumeFrame::default());
    let cam = Camera::orthographic(
        DVec3::new(15.5, 15.5, 50.0),
        DVec3::new(15.5, 15.5, 0.0),
        DVec3::Y,
        32.0,
    );
    (vol, cam)
}

/// Golden images, one per mode, against values derived here from the
/// column of each pixel. Along an axis through voxel centres every chord
/// is exactly one voxel long (`ℓ/ℓ_ref = 1`, so the corrected opacity is
/// the transfer function's), every ray kind visits exactly the column,
/// and trilinear samples are the voxels' values. The tolerance, 1e-5, is
/// `f32` rounding: the renderer forms the corrected opacity as
/// `1 − (1 − τ)^1`, which differs from `τ` by up to an ulp of 1 (6e-8) per
/// voxel, over at most 16 voxels; hits and depths are exact.
#[test]
fn golden_images_per_mode() {
    let (vol, cam) = golden();
    let s = scene(&vol);
    let window = (10.0f32, 100.0f32);
    let tf = TransferFunction::parse("20:0,60:0.2:#ff8000,100:0.8:#ffffff").unwrap();
    let ro = RenderOptions {
        width: 32,
        height: 32,
        normals: voxkit::render::NormalMode::Face,
        ..RenderOptions::default()
    };
    let column = |i: usize| -> Vec<(IVec3, f32)> {
        let (x, y) = ((i % 32) as i32, 31 - (i / 32) as i32);
        (0..16)
            .rev()
            .map(|z| {
                let v = IVec3::new(x, y, z);
                (v, at(&vol, v))
            })
            .collect()
    };
    let close = |a: [f32; 4], b: [f32; 4]| (0..4).all(|k| (a[k] - b[k]).abs() <= 1e-5);
    for kind in RayKind::ALL {
        for sampling in [Sampling::Nearest, Sampling::Trilinear] {
            let o = RenderOptions { ray: kind, ..ro };
            let mk = |mode| VolumeOptions {
                mode,
                window,
                transfer: tf.clone(),
                sampling,
                method: VolumeMethod::Rays,
            };
            let mip = render(&s, &cam, &o, &mk(VolumeMode::Mip)).0;
            let comp = render(&s, &cam, &o, &mk(VolumeMode::Composite)).0;
            let iso = render(&s, &cam, &o, &mk(VolumeMode::Iso(70.0))).0;
            let smooth = render(
                &s,
                &cam,
                &RenderOptions {
                    normals: NormalMode::Smooth,
                    ..o
                },
                &mk(VolumeMode::Iso(70.0)),
            )
            .0;
            for i in 0..32 * 32 {
                let col = column(i);
                let what = format!("{kind:?} {sampling:?} pixel {i}");
                // MIP.
                let (m, v) =
                    col.iter().fold(
                        (window.0, None),
                        |(m, v), &(p, s)| {
                            if s > m { (s, Some(p)) } else { (m, v) }
                        },
                    );
                let g = ((m - window.0) / (window.1 - window.0)).clamp(0.0, 1.0);
                assert!(close(mip.color[i], [g, g, g, 1.0]), "MIP {what}");
                assert_eq!(mip.hit[i], v);
                if let Some(v) = v {
                    assert_eq!(mip.depth[i], 50.0 - (v.z as f32 + 0.5));
                }
                // Composite: front to back, one reference length per voxel.
                let (mut c, mut a, mut first) = ([0.0f32; 3], 0.0f32, None);
                for &(p, s) in &col {
                    let tau = tf.opacity(s);
                    if tau > 0.0 && a < 0.99 {
                        first.get_or_insert(p);
                        let rgb = tf.color(s).unwrap();
                        for k in 0..3 {
                            c[k] += (1.0 - a) * tau * rgb[k];
                        }
                        a += (1.0 - a) * tau;
                    }
                }
                assert_eq!(comp.hit[i], first, "composite {what}");
                if a > 0.0 {
                    let want = [c[0] / a, c[1] / a, c[2] / a, a];
                    assert!(
                        close(comp.color[i], want),
                        "composite {what}: {:?} vs {want:?}",
                        comp.color[i]
                    );
                }
                // Iso at 70: the first voxel ≥ 70 from the top; the face
                // normal faces the eye (full light), the smooth one is the
                // central-difference gradient.
                let hit = col.iter().find(|(_, s)| *s >= 70.0).map(|(p, _)| *p);
                assert_eq!(iso.hit[i], hit, "iso {what}");
                if let Some(p) = hit {
                    assert_eq!(iso.depth[i], 50.0 - (p.z as f32 + 0.5));
                    // The transfer function's colour at the iso value.
                    let base = tf.color(70.0).unwrap();
                    assert!(
                        close(iso.color[i], [base[0], base[1], base[2], 1.0]),
                        "iso {what}"
                    );
                    let f =
                        |q: IVec3| at(&vol, q.clamp(IVec3::ZERO, IVec3::new(31, 31, 15))) as f64;
                    let mut grad = DVec3::ZERO;
                    for k in 0..3 {
                        let (mut a, mut b) = (p, p);
                        a[k] -= 1;
                        b[k] += 1;
                        let lim = [31, 31, 15][k];
                        let span = (b[k].min(lim) - a[k].max(0)) as f64;
                        grad[k] = (f(b) - f(a)) / span;
                    }
                    let lambert = if grad.length() > 0.0 {
                        (grad.z.abs() / grad.length()) as f32
                    } else {
                        1.0
                    };
                    let l = 0.25 + 0.75 * lambert;
                    let want = [base[0] * l, base[1] * l, base[2] * l, 1.0];
                    assert!(
                        (0..3).all(|k| (smooth.color[i][k] - want[k]).abs() < 1e-5),
                        "smooth iso {what}: {:?} vs {want:?}",
                        smooth.color[i]
                    );
                }
            }
        }
    }
}

/// NaN samples never hold a maximum or reach an iso value; bad windows and
/// iso values are errors.
#[test]
fn nan_samples_and_bad_options() {
    let dims = [4usize, 4, 4];
    let data = fill(dims, |x, _, _| if x == 2 { f32::NAN } else { x as f32 });
    let vol = volume(dims, data, VolumeFrame::default());
    let s = scene(&vol);
    assert_eq!(s.value(IVec3::new(2, 0, 0)), Some(f32::NEG_INFINITY));
    let (cam, w, h) = axis_camera(dims, 0, 1.0);
    for mode in [VolumeMode::Mip, VolumeMode::Composite, VolumeMode::Iso(1.5)] {
        for sampling in [Sampling::Nearest, Sampling::Trilinear] {
            let vo = vopts(mode, (-1.0, 3.0), sampling);
            let img = render(&s, &cam, &opts(w, h, RayKind::Six, true), &vo).0;
            assert!(img.color.iter().flatten().all(|c| c.is_finite()));
            let want = match mode {
                VolumeMode::Mip => Some(3),
                VolumeMode::Composite => Some(0),
                _ => Some(3),
            };
            if sampling == Sampling::Nearest {
                assert!(img.hit.iter().all(|h| h.map(|v| v.x) == want), "{mode:?}");
            }
        }
    }
    let (cam, w, h) = axis_camera(dims, 2, 1.0);
    let o = opts(w, h, RayKind::Six, true);
    for bad in [
        vopts(VolumeMode::Mip, (2.0, 2.0), Sampling::Nearest),
        vopts(VolumeMode::Mip, (f32::NAN, 2.0), Sampling::Nearest),
        vopts(VolumeMode::Iso(f32::NAN), (0.0, 2.0), Sampling::Nearest),
    ] {
        assert!(render_volume(&s, &cam, &o, &bad).is_err(), "{bad:?}");
    }
    assert!(
        VolumeScene::new(&vol, MemoryLimit::new(100)).is_err(),
        "the memory limit is checked"
    );
}

/// A volume of 8- or 16-bit integers composites exactly as its `f32` copy
/// (compositing reads the integer types' opacities, `ln(1 − τ)` and
/// colours from a per-value table, the `f32` volume computes them per
/// voxel): every ray kind, coloured and ramp transfer functions, value
/// ranges with negative values and values past 255.
#[test]
fn integer_volumes_composite_like_their_f32_copies() {
    let mut rng = ChaCha8Rng::seed_from_u64(1616);
    let mut cases = 0;
    for round in 0..40 {
        let vol = random_volume(&mut rng);
        let VolumeData::F32(values) = &vol.data else {
            unreachable!()
        };
        if values.iter().any(|v| v.is_nan()) {
            continue;
        }
        let shift = [0.0, -100.0, 20000.0][round % 3];
        let shifted: Vec<f32> = values.iter().map(|v| v + shift).collect();
        let max = shifted.iter().fold(f32::NEG_INFINITY, |m, &v| m.max(v));
        let mut typed = vec![VolumeData::I16(shifted.iter().map(|&v| v as i16).collect())];
        if shift >= 0.0 {
            typed.push(VolumeData::U16(shifted.iter().map(|&v| v as u16).collect()));
        }
        if shift == 0.0 && max <= 255.0 {
            typed.push(VolumeData::U8(shifted.iter().map(|&v| v as u8).collect()));
        }
        if shift > 0.0 {
            typed.remove(0);
        }
        let reference = ScalarVolume::new(vol.dims, VolumeData::F32(shifted), vol.frame).unwrap();
        let s_ref = scene(&reference);
        let cam = random_camera(&mut rng, &reference);
        for mut vo in random_modes(&mut rng, &reference) {
            if vo.mode != VolumeMode::Composite {
                continue;
            }
            vo.sampling = Sampling::Nearest;
            for kind in RayKind::ALL {
                let o = opts(40, 32, kind, rng.random_bool(0.5));
                let (want, _) = render(&s_ref, &cam, &o, &vo);
                for data in &typed {
                    let v = ScalarVolume::new(vol.dims, data.clone(), vol.frame).unwrap();
                    let (got, _) = render(&scene(&v), &cam, &o, &vo);
                    assert_eq!(got, want, "{kind:?}, {:?}", v.data.scalar_type());
                    cases += 1;
                }
            }
        }
    }
    assert!(cases >= 100, "only {cases} cases");
}
