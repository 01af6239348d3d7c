//! Image outputs of the ray caster (`voxkit::io::image`): PNG decodes back to
//! the same pixels, EXR round-trips all five channels bit for bit (including
//! `+inf` depth, NaN, -0.0, non-square sizes), GIF has the right frames and
//! size, and every bad input is an error that leaves no file (and no
//! temporary file) behind.

use std::path::Path;

use crate::scratch::temp_dir;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::VoxkitError;
use voxkit::grid::MemoryLimit;
use voxkit::io::image::{
    ExrImage, encode_png_rgba, read_exr, read_exr_limited, write_exr, write_gif, write_png_rgba,
};

/// Names of the entries in `dir`, sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn random_rgba8(rng: &mut ChaCha8Rng, n: usize) -> Vec<u8> {
    (0..n * 4).map(|_| rng.random()).collect()
}

fn decode_png(bytes: &[u8]) -> (u32, u32, png::ColorType, png::BitDepth, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (
        info.width,
        info.height,
        info.color_type,
        info.bit_depth,
        buf,
    )
}

#[test]
fn png_round_trips_pixels() {
    let dir = temp_dir("png");
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for (w, h) in [(1, 1), (7, 3), (3, 7), (64, 17)] {
        let rgba = random_rgba8(&mut rng, (w * h) as usize);
        let path = dir.join(format!("img-{w}x{h}.png"));
        write_png_rgba(&path, w, h, &rgba, false).unwrap();
        let file = std::fs::read(&path).unwrap();
        let (dw, dh, color, depth, pixels) = decode_png(&file);
        assert_eq!((dw, dh), (w, h));
        assert_eq!(color, png::ColorType::Rgba);
        assert_eq!(depth, png::BitDepth::Eight);
        assert_eq!(pixels, rgba, "{w}x{h}");
        // The in-memory encoder produces the same file.
        assert_eq!(encode_png_rgba(w, h, &rgba).unwrap(), file);
    }
    // Overwrite replaces the content.
    let path = dir.join("img-1x1.png");
    write_png_rgba(&path, 1, 1, &[9, 8, 7, 6], true).unwrap();
    assert_eq!(
        decode_png(&std::fs::read(&path).unwrap()).4,
        vec![9, 8, 7, 6]
    );
    assert_eq!(
        entries(&dir).len(),
        4,
        "no stray files: {:?}",
        entries(&dir)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

fn random_exr(rng: &mut ChaCha8Rng, w: u32, h: u32) -> (Vec<[f32; 4]>, Vec<f32>) {
    let n = (w * h) as usize;
    let mut rgba: Vec<[f32; 4]> = (0..n)
        .map(|_| {
            [
                rng.random::<f32>(),
                rng.random_range(-2.0..2.0),
                f32::from_bits(rng.random()), // any bit pattern, NaNs included
                rng.random::<f32>(),
            ]
        })
        .collect();
    let mut depth: Vec<f32> = (0..n)
        .map(|i| {
            if i % 3 == 0 {
                f32::INFINITY
            } else {
                rng.random_range(0.0..1.0e6)
            }
        })
        .collect();
    // Special values in fixed places.
    rgba[0] = [-0.0, f32::MIN_POSITIVE / 4.0, f32::MAX, f32::NAN];
    depth[n - 1] = f32::INFINITY;
    if n > 1 {
        depth[1] = 0.0;
    }
    (rgba, depth)
}

fn assert_bits_eq(a: &ExrImage, rgba: &[[f32; 4]], depth: &[f32]) {
    assert_eq!(a.rgba.len(), rgba.len());
    assert_eq!(a.depth.len(), depth.len());
    for (i, (p, q)) in a.rgba.iter().zip(rgba).enumerate() {
        for k in 0..4 {
            assert_eq!(p[k].to_bits(), q[k].to_bits(), "pixel {i} channel {k}");
        }
    }
    for (i, (p, q)) in a.depth.iter().zip(depth).enumerate() {
        assert_eq!(p.to_bits(), q.to_bits(), "depth {i}");
    }
}

#[test]
fn exr_round_trips_all_channels_bit_for_bit() {
    let dir = temp_dir("exr");
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    // Non-square, and more than one 16-line ZIP block.
    for (w, h) in [(1, 1), (7, 3), (3, 7), (40, 37)] {
        let (rgba, depth) = random_exr(&mut rng, w, h);
        let path = dir.join(format!("r-{w}x{h}.exr"));
        write_exr(&path, w, h, &rgba, &depth, false).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (w, h));
        assert_bits_eq(&back, &rgba, &depth);
        assert_eq!(back.depth[(w * h - 1) as usize], f32::INFINITY);
    }
    // Row order: row 0 is the top row, x fastest.
    let w = 7;
    let h = 3;
    let rgba: Vec<[f32; 4]> = (0..w * h)
        .map(|i| [(i % w) as f32, (i / w) as f32, 0.0, 1.0])
        .collect();
    let depth: Vec<f32> = (0..w * h).map(|i| i as f32).collect();
    let path = dir.join("order.exr");
    write_exr(&path, w, h, &rgba, &depth, false).unwrap();
    let back = read_exr(&path).unwrap();
    assert_eq!(back.rgba, rgba);
    assert_eq!(back.depth, depth);
    assert_eq!(
        entries(&dir).len(),
        5,
        "no stray files: {:?}",
        entries(&dir)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn exr_file_is_f32_zip_scanlines_with_five_channels() {
    let dir = temp_dir("exrmeta");
    let path = dir.join("m.exr");
    write_exr(&path, 7, 3, &[[0.5; 4]; 21], &[f32::INFINITY; 21], false).unwrap();
    let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
    assert_eq!(meta.headers.len(), 1);
    let header = &meta.headers[0];
    assert_eq!(header.layer_size, exr::math::Vec2(7, 3));
    assert!(!header.deep);
    assert_eq!(header.compression, exr::compression::Compression::ZIP16);
    assert_eq!(header.blocks, exr::meta::BlockDescription::ScanLines);
    let names: Vec<String> = header
        .channels
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(names, ["A", "B", "G", "R", "Z"]);
    assert!(
        header
            .channels
            .list
            .iter()
            .all(|c| c.sample_type == exr::meta::attribute::SampleType::F32)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn exr_reader_rejects_missing_channel_and_garbage() {
    use exr::prelude::*;
    let dir = temp_dir("exrbad");
    // A valid EXR without Z.
    let path = dir.join("noz.exr");
    let ch = |name: &str| AnyChannel::new(name, FlatSamples::F32(vec![1.0; 6]));
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![ch("R"), ch("G"), ch("B"), ch("A")]));
    Image::from_channels((3, 2), channels)
        .write()
        .to_file(&path)
        .unwrap();
    assert!(matches!(read_exr(&path), Err(VoxkitError::Invalid(_))));
    // Not an EXR at all.
    let junk = dir.join("junk.exr");
    std::fs::write(&junk, b"this is not an exr file").unwrap();
    assert!(read_exr(&junk).is_err());
    // Truncated file.
    let good = dir.join("good.exr");
    write_exr(&good, 7, 3, &[[0.25; 4]; 21], &[1.0; 21], false).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    let cut = dir.join("cut.exr");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    assert!(read_exr(&cut).is_err());
    // Missing file is an Io error naming the path.
    match read_exr(&dir.join("absent.exr")) {
        Err(VoxkitError::Io { path, .. }) => assert!(path.ends_with("absent.exr")),
        other => panic!("expected Io error, got {other:?}"),
    }
    // A tight memory limit is refused before decoding.
    assert!(matches!(
        read_exr_limited(&good, MemoryLimit::new(64)),
        Err(VoxkitError::Limits { .. })
    ));
    assert!(read_exr_limited(&good, MemoryLimit::new(1 << 20)).is_ok());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn gif_has_frames_size_loop_and_delay() {
    let dir = temp_dir("gif");
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (w, h) = (13u32, 5u32);
    let n = (w * h) as usize;
    // Frame 0: few colours (exact palette); frame 1: random (NeuQuant);
    // frame 2: half transparent.
    let mut f0 = vec![0u8; n * 4];
    for (i, p) in f0.chunks_exact_mut(4).enumerate() {
        p.copy_from_slice(if i % 2 == 0 {
            &[255, 0, 0, 255]
        } else {
            &[0, 0, 255, 255]
        });
    }
    let f1 = random_rgba8(&mut rng, n)
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2], 255])
        .collect::<Vec<u8>>();
    let mut f2 = f0.clone();
    for p in f2.chunks_exact_mut(4).step_by(2) {
        p[3] = 0;
    }
    let frames = vec![f0.clone(), f1, f2];
    let path = dir.join("turntable.gif");
    write_gif(&path, w, h, &frames, 4, false).unwrap();

    let file = std::fs::File::open(&path).unwrap();
    let mut opts = gif::DecodeOptions::new();
    opts.set_color_output(gif::ColorOutput::RGBA);
    let mut dec = opts.read_info(file).unwrap();
    assert_eq!((dec.width() as u32, dec.height() as u32), (w, h));
    let mut count = 0;
    let mut first = None;
    while let Some(frame) = dec.read_next_frame().unwrap() {
        assert_eq!((frame.width as u32, frame.height as u32), (w, h));
        assert_eq!(frame.delay, 4);
        if count == 0 {
            first = Some(frame.buffer.to_vec());
        }
        count += 1;
    }
    assert_eq!(count, 3);
    assert_eq!(dec.repeat(), gif::Repeat::Infinite);
    // A frame of two colours is exact.
    assert_eq!(first.unwrap(), f0);

    // One frame is enough.
    let single = dir.join("single.gif");
    write_gif(&single, w, h, &frames[..1], 0, false).unwrap();
    assert_eq!(
        entries(&dir).len(),
        2,
        "no stray files: {:?}",
        entries(&dir)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Every bad request is an error and leaves the directory as it was.
#[test]
fn bad_inputs_are_errors_and_leave_no_file() {
    let dir = temp_dir("bad");
    let png = dir.join("a.png");
    let exr_path = dir.join("a.exr");
    let gif_path = dir.join("a.gif");
    let invalid = |r: voxkit::Result<()>, what: &str| match r {
        Err(VoxkitError::Invalid(_)) => {}
        other => panic!("{what}: expected Invalid, got {other:?}"),
    };

    // PNG: wrong length, zero sizes.
    invalid(write_png_rgba(&png, 2, 2, &[0; 15], false), "png short");
    invalid(write_png_rgba(&png, 2, 2, &[0; 17], false), "png long");
    invalid(write_png_rgba(&png, 0, 2, &[], false), "png zero width");
    invalid(write_png_rgba(&png, 2, 0, &[], false), "png zero height");
    invalid(
        write_png_rgba(&png, u32::MAX, u32::MAX, &[0; 4], false),
        "png huge",
    );
    assert!(encode_png_rgba(3, 1, &[0; 4]).is_err());

    // EXR: wrong lengths, zero sizes.
    let px = [[0.0f32; 4]; 6];
    let z = [1.0f32; 6];
    invalid(
        write_exr(&exr_path, 3, 2, &px[..5], &z, false),
        "exr rgba short",
    );
    invalid(
        write_exr(&exr_path, 3, 2, &px, &z[..5], false),
        "exr depth short",
    );
    invalid(write_exr(&exr_path, 2, 2, &px, &z, false), "exr both long");
    invalid(
        write_exr(&exr_path, 0, 2, &[], &[], false),
        "exr zero width",
    );
    invalid(
        write_exr(&exr_path, 3, 0, &[], &[], false),
        "exr zero height",
    );

    // GIF: no frames, a frame of the wrong length, zero and oversize sides.
    let frame = vec![0u8; 3 * 2 * 4];
    invalid(write_gif(&gif_path, 3, 2, &[], 5, false), "gif no frames");
    invalid(
        write_gif(&gif_path, 3, 2, &[frame.clone(), vec![0; 23]], 5, false),
        "gif short frame",
    );
    invalid(
        write_gif(&gif_path, 0, 2, &[vec![]], 5, false),
        "gif zero width",
    );
    invalid(
        write_gif(&gif_path, 3, 0, &[vec![]], 5, false),
        "gif zero height",
    );
    invalid(
        write_gif(&gif_path, 65536, 1, &[vec![0; 65536 * 4]], 5, false),
        "gif too wide",
    );
    assert!(entries(&dir).is_empty(), "stray files: {:?}", entries(&dir));

    // Existing files are refused without overwrite, and keep their content.
    for p in [&png, &exr_path, &gif_path] {
        std::fs::write(p, b"old").unwrap();
    }
    invalid(write_png_rgba(&png, 3, 2, &frame, false), "png exists");
    invalid(write_exr(&exr_path, 3, 2, &px, &z, false), "exr exists");
    invalid(
        write_gif(&gif_path, 3, 2, std::slice::from_ref(&frame), 5, false),
        "gif exists",
    );
    for p in [&png, &exr_path, &gif_path] {
        assert_eq!(std::fs::read(p).unwrap(), b"old");
    }
    // Bad input with overwrite still leaves the old file as it was.
    invalid(
        write_png_rgba(&png, 3, 2, &frame[1..], true),
        "png bad overwrite",
    );
    invalid(
        write_exr(&exr_path, 3, 2, &px[1..], &z, true),
        "exr bad overwrite",
    );
    invalid(
        write_gif(&gif_path, 3, 2, &[], 5, true),
        "gif bad overwrite",
    );
    for p in [&png, &exr_path, &gif_path] {
        assert_eq!(std::fs::read(p).unwrap(), b"old");
    }
    assert_eq!(entries(&dir), ["a.exr", "a.gif", "a.png"]);

    // With overwrite, the files are replaced by valid images.
    write_png_rgba(&png, 3, 2, &frame, true).unwrap();
    write_exr(&exr_path, 3, 2, &px, &z, true).unwrap();
    write_gif(&gif_path, 3, 2, std::slice::from_ref(&frame), 5, true).unwrap();
    assert_eq!(decode_png(&std::fs::read(&png).unwrap()).4, frame);
    assert_eq!(read_exr(&exr_path).unwrap().depth, z);
    assert_eq!(entries(&dir), ["a.exr", "a.gif", "a.png"]);

    // A directory that does not exist is an Io error, and creates nothing.
    let missing = dir.join("no-such-dir").join("x.png");
    assert!(matches!(
        write_png_rgba(&missing, 3, 2, &frame, false),
        Err(VoxkitError::Io { .. })
    ));
    assert_eq!(entries(&dir), ["a.exr", "a.gif", "a.png"]);
    std::fs::remove_dir_all(&dir).unwrap();
}
