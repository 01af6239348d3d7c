//! Image outputs of the ray caster: 8-bit RGBA PNG, float OpenEXR with a
//! depth channel, and animated GIF (turntables).
//!
//! Pixel layout everywhere: row-major, row 0 at the **top**, x fastest
//! (`index = x + width * y`), as in [`crate::triangle::Framebuffer`].
//!
//! Every writer validates its whole input first (so bad input never touches
//! the file system) and then writes through [`crate::io::atomic_write`]: a
//! failure leaves no partial file, and an existing file is refused unless
//! `overwrite`. Working buffers are checked against [`MemoryLimit::DEFAULT`]
//! before they are allocated; [`read_exr_limited`] takes an explicit limit.

use std::io::{Cursor, Write};
use std::path::Path;

use crate::error::{Result, VoxkitError};
use crate::grid::MemoryLimit;

/// Largest PNG width or height (the PNG specification's `2^31 - 1`).
const PNG_MAX_DIM: u32 = (1 << 31) - 1;

/// Largest GIF width or height (16-bit fields in the format).
const GIF_MAX_DIM: u32 = u16::MAX as u32;

/// NeuQuant speed for [`write_gif`]'s per-frame quantisation: 1 (best) to
/// 30 (fastest); 10 is the `gif` crate's recommended compromise.
const GIF_QUANT_SPEED: i32 = 10;

/// `width * height`, or `Invalid` if a side is zero or the count overflows.
fn pixel_count(what: &str, width: u32, height: u32) -> Result<usize> {
    if width == 0 || height == 0 {
        return Err(VoxkitError::invalid(format!(
            "{what}: image size {width}x{height} has a zero side"
        )));
    }
    usize::try_from(width as u64 * height as u64).map_err(|_| {
        VoxkitError::invalid(format!("{what}: image size {width}x{height} is too large"))
    })
}

/// Checks that a buffer holds exactly `count * per_pixel` elements.
fn check_len(what: &str, len: usize, count: usize, per_pixel: usize, w: u32, h: u32) -> Result<()> {
    let expected = count.checked_mul(per_pixel);
    if expected != Some(len) {
        return Err(VoxkitError::invalid(format!(
            "{what}: {len} values given, a {w}x{h} image needs {}",
            count as u128 * per_pixel as u128
        )));
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// PNG
// ---------------------------------------------------------------------------

/// Validates a PNG request; returns nothing but errors.
fn check_png(width: u32, height: u32, rgba: &[u8]) -> Result<()> {
    let n = pixel_count("PNG", width, height)?;
    if width > PNG_MAX_DIM || height > PNG_MAX_DIM {
        return Err(VoxkitError::invalid(format!(
            "PNG: image size {width}x{height} exceeds {PNG_MAX_DIM} on a side"
        )));
    }
    check_len("PNG RGBA bytes", rgba.len(), n, 4, width, height)
}

/// Streams an already validated 8-bit RGBA image as PNG into `w` (the same
/// approach as `Framebuffer::encode_png`, without copying the pixels).
fn encode_png_into<W: Write>(w: W, width: u32, height: u32, rgba: &[u8]) -> Result<()> {
    let mut enc = png::Encoder::new(w, width, height);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    // fdeflate's PNG-tuned compressor: a 1024² render encodes in ~4 ms
    // instead of 56–71 ms (`Balanced`), for files 1.2–1.9× larger; the
    // encode was ~6% of a whole `voxkit render` command.
    enc.set_compression(png::Compression::Fast);
    let mut writer = enc.write_header().map_err(png_err)?;
    writer.write_image_data(rgba).map_err(png_err)?;
    writer.finish().map_err(png_err)
}

fn png_err(e: png::EncodingError) -> VoxkitError {
    match e {
        png::EncodingError::IoError(source) => VoxkitError::from(source),
        png::EncodingError::Format(f) => VoxkitError::invalid(format!("PNG encoding: {f}")),
        other => VoxkitError::Unsupported(format!("PNG encoding: {other}")),
    }
}

/// Encodes an 8-bit RGBA image (straight alpha, 4 bytes per pixel,
/// row-major from the top row) as PNG in memory.
///
/// `rgba.len()` must be `width * height * 4` and both sides positive, else
/// [`VoxkitError::Invalid`]. The output buffer is checked against
/// [`MemoryLimit::DEFAULT`] first.
///
/// ```
/// let png = voxkit::io::image::encode_png_rgba(2, 1, &[255, 0, 0, 255, 0, 0, 255, 128]).unwrap();
/// assert_eq!(&png[1..4], b"PNG");
/// assert!(voxkit::io::image::encode_png_rgba(2, 1, &[0; 7]).is_err());
/// ```
pub fn encode_png_rgba(width: u32, height: u32, rgba: &[u8]) -> Result<Vec<u8>> {
    check_png(width, height, rgba)?;
    // Deflate output is at most a little above the input size; reserve
    // nothing up front, but refuse requests whose input alone is over the limit.
    MemoryLimit::DEFAULT.check("PNG encoding buffer", rgba.len() as u128, 1)?;
    let mut out = Vec::new();
    encode_png_into(&mut out, width, height, rgba)?;
    Ok(out)
}

/// Writes an 8-bit RGBA image (straight alpha, 4 bytes per pixel, row-major
/// from the top row) as a PNG file, through [`crate::io::atomic_write`].
///
/// `rgba.len()` must be `width * height * 4` and both sides positive, else
/// [`VoxkitError::Invalid`] (and nothing is written). An existing `path` is
/// refused unless `overwrite`. The pixels are streamed into the file without
/// an intermediate copy.
pub fn write_png_rgba(
    path: &Path,
    width: u32,
    height: u32,
    rgba: &[u8],
    overwrite: bool,
) -> Result<()> {
    check_png(width, height, rgba)?;
    crate::io::atomic_write(path, overwrite, |w| encode_png_into(w, width, height, rgba))
}

// ---------------------------------------------------------------------------
// OpenEXR
// ---------------------------------------------------------------------------

/// A float RGBA + depth image as read by [`read_exr`].
#[derive(Clone, Debug, PartialEq)]
pub struct ExrImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Colour and alpha per pixel, row-major from the top row.
    pub rgba: Vec<[f32; 4]>,
    /// The `Z` channel per pixel: distance along the ray in world units,
    /// `+∞` where the ray missed.
    pub depth: Vec<f32>,
}

/// Bytes per pixel the EXR writer holds besides the caller's buffers: five
/// `f32` channel copies (20) and the encoded file (at most about 20 more,
/// ZIP never expands much beyond the raw data).
const EXR_WRITE_BYTES_PER_PIXEL: u128 = 48;

fn exr_err(path: &Path, e: exr::error::Error) -> VoxkitError {
    use exr::error::Error;
    match e {
        Error::Io(source) => VoxkitError::Io {
            path: path.to_path_buf(),
            source,
        },
        Error::Invalid(msg) => VoxkitError::invalid(format!("{}: EXR: {msg}", path.display())),
        Error::NotSupported(msg) => {
            VoxkitError::Unsupported(format!("{}: EXR: {msg}", path.display()))
        }
        Error::Aborted => VoxkitError::invalid(format!("{}: EXR: aborted", path.display())),
    }
}

/// Encodes validated channel data into an in-memory EXR file. (`exr` wants a
/// `Write + Seek` sink, which `atomic_write`'s `&mut dyn Write` is not.)
fn encode_exr(
    path: &Path,
    width: u32,
    height: u32,
    rgba: &[[f32; 4]],
    depth: &[f32],
) -> Result<Vec<u8>> {
    use exr::prelude::*;

    let channel = |name: &'static str, k: usize| {
        AnyChannel::new(name, FlatSamples::F32(rgba.iter().map(|p| p[k]).collect()))
    };
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::from_vec(vec![
        channel("R", 0),
        channel("G", 1),
        channel("B", 2),
        channel("A", 3),
        AnyChannel::new("Z", FlatSamples::F32(depth.to_vec())),
    ]);
    // Compression: ZIP over blocks of 16 scan lines (`Encoding::SMALL_LOSSLESS`:
    // ZIP16, scan lines, increasing line order). It is lossless on the raw
    // bytes, so every f32 — +inf depth, NaN payloads, -0.0, subnormals —
    // round-trips bit for bit, and every OpenEXR reader supports it. It also
    // shrinks the large flat background areas of a render well. PXR24 and
    // B44 are lossy for f32 and thus unusable for depth; PIZ is lossless too
    // but slower and tuned for half floats; RLE and none give larger files.
    let encoding = Encoding::SMALL_LOSSLESS;
    let attributes = LayerAttributes {
        comments: Some(Text::from(
            "voxkit: Z is the distance along the ray in world units, +inf where the ray missed",
        )),
        ..LayerAttributes::default()
    };
    let layer = Layer::new(
        (width as usize, height as usize),
        attributes,
        encoding,
        AnyChannels::sort(channels),
    );
    let image = Image::from_layer(layer);
    let mut cursor = Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut cursor)
        .map_err(|e| exr_err(path, e))?;
    Ok(cursor.into_inner())
}

/// Writes one OpenEXR image with `f32` channels `R`, `G`, `B`, `A` (from
/// `rgba`) and `Z` (from `depth`: distance along the ray in world units,
/// `+∞` for misses), scan lines, ZIP compression (lossless, so every value
/// round-trips bit for bit, `+∞` included), through
/// [`crate::io::atomic_write`].
///
/// `rgba.len()` and `depth.len()` must both equal `width * height`, and both
/// sides must be positive, else [`VoxkitError::Invalid`] (nothing is
/// written). An existing `path` is refused unless `overwrite`. The encoder's
/// working memory (about 48 bytes per pixel) is checked against
/// [`MemoryLimit::DEFAULT`] first.
///
/// ```
/// use voxkit::io::image::{read_exr, write_exr};
/// let dir = std::env::temp_dir().join(format!("voxkit-doc-exr-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("render.exr");
/// let rgba = [[1.0, 0.5, 0.25, 1.0], [0.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3, 1.0]];
/// let depth = [2.5, f32::INFINITY, 7.0];
/// write_exr(&path, 3, 1, &rgba, &depth, false).unwrap();
/// let back = read_exr(&path).unwrap();
/// assert_eq!((back.width, back.height), (3, 1));
/// assert_eq!(back.rgba, rgba);
/// assert_eq!(back.depth[1], f32::INFINITY);
/// // Lengths must match the size; nothing is written then.
/// assert!(write_exr(&dir.join("bad.exr"), 2, 2, &rgba, &depth, false).is_err());
/// assert!(!dir.join("bad.exr").exists());
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    rgba: &[[f32; 4]],
    depth: &[f32],
    overwrite: bool,
) -> Result<()> {
    let n = pixel_count("EXR", width, height)?;
    check_len("EXR rgba pixels", rgba.len(), n, 1, width, height)?;
    check_len("EXR depth values", depth.len(), n, 1, width, height)?;
    MemoryLimit::DEFAULT.check("EXR encoding", n as u128, EXR_WRITE_BYTES_PER_PIXEL)?;
    crate::io::atomic_write(path, overwrite, |w| {
        let bytes = encode_exr(path, width, height, rgba, depth)?;
        w.write_all(&bytes)?;
        Ok(())
    })
}

/// Reads an OpenEXR file written by [`write_exr`] (or any flat, non-deep
/// OpenEXR image whose first layer has channels named `R`, `G`, `B`, `A`
/// and `Z`), with memory checked against [`MemoryLimit::DEFAULT`].
/// See [`read_exr_limited`].
pub fn read_exr(path: &Path) -> Result<ExrImage> {
    read_exr_limited(path, MemoryLimit::DEFAULT)
}

/// As [`read_exr`], with an explicit memory limit: the file size and the
/// decoded size announced by every layer's header are checked against
/// `limit` before the file is read or decoded ([`VoxkitError::Limits`]).
///
/// The five channels are found by name in the first layer; a missing one is
/// [`VoxkitError::Invalid`]. `f32` channels are returned as stored; `f16`
/// channels are widened (exactly); `u32` or subsampled channels are
/// [`VoxkitError::Unsupported`]. Other channels are ignored. Malformed files
/// are `Invalid` or `Unsupported`, as the `exr` crate judges them.
pub fn read_exr_limited(path: &Path, limit: MemoryLimit) -> Result<ExrImage> {
    use exr::prelude::*;

    let io_err = |source| VoxkitError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file_len = std::fs::metadata(path).map_err(io_err)?.len();
    limit.check("EXR file", file_len as u128, 1)?;
    let bytes = std::fs::read(path).map_err(io_err)?;

    // Header first: refuse images whose decoded samples would not fit.
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(&bytes), false)
        .map_err(|e| exr_err(path, e))?;
    for header in meta.headers.iter() {
        let area = header.layer_size.0 as u128 * header.layer_size.1 as u128;
        // Decoded samples of every channel, plus our own 20 bytes per pixel.
        let per_pixel = header.channels.bytes_per_pixel as u128 + 20;
        limit.check(
            "EXR decoding",
            (file_len as u128).saturating_add(area.saturating_mul(per_pixel)),
            1,
        )?;
    }

    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| exr_err(path, e))?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.0, layer.size.1);
    let (width, height) = match (u32::try_from(w), u32::try_from(h)) {
        (Ok(a), Ok(b)) if a > 0 && b > 0 => (a, b),
        _ => {
            return Err(VoxkitError::invalid(format!(
                "{}: EXR layer size {w}x{h} is not supported",
                path.display()
            )));
        }
    };
    let n = pixel_count("EXR", width, height)?;

    let find = |name: &str| -> crate::error::Result<Vec<f32>> {
        let channel = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name == *name)
            .ok_or_else(|| {
                VoxkitError::invalid(format!(
                    "{}: EXR has no channel `{name}` (needs R, G, B, A and Z)",
                    path.display()
                ))
            })?;
        let values: Vec<f32> = match &channel.sample_data {
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
            FlatSamples::U32(_) => {
                return Err(VoxkitError::Unsupported(format!(
                    "{}: EXR channel `{name}` holds u32 samples, floats expected",
                    path.display()
                )));
            }
        };
        if values.len() != n {
            return Err(VoxkitError::Unsupported(format!(
                "{}: EXR channel `{name}` has {} samples for {width}x{height} pixels \
                 (subsampled channels are not supported)",
                path.display(),
                values.len()
            )));
        }
        Ok(values)
    };
    let (r, g, b, a) = (find("R")?, find("G")?, find("B")?, find("A")?);
    let depth = find("Z")?;
    let rgba = (0..n).map(|i| [r[i], g[i], b[i], a[i]]).collect();
    Ok(ExrImage {
        width,
        height,
        rgba,
        depth,
    })
}

// ---------------------------------------------------------------------------
// GIF
// ---------------------------------------------------------------------------

fn gif_err(e: gif::EncodingError) -> VoxkitError {
    match e {
        gif::EncodingError::Io(source) => VoxkitError::from(source),
        gif::EncodingError::Format(f) => VoxkitError::invalid(format!("GIF encoding: {f}")),
        other => VoxkitError::Unsupported(format!("GIF encoding: {other}")),
    }
}

/// Writes an animated GIF that loops forever, one frame per entry of
/// `frames` (each 8-bit RGBA, `width * height * 4` bytes, row-major from the
/// top row), each shown for `delay_centis` hundredths of a second, through
/// [`crate::io::atomic_write`].
///
/// Each frame gets its own 256-colour palette (exact when the frame has at
/// most 256 distinct colours, NeuQuant at speed 10 otherwise, by the `gif`
/// crate's `Frame::from_rgba_speed`). GIF has 1-bit transparency: alpha 0 is
/// transparent, any other alpha opaque. Frames are disposed to the
/// background, so transparent pixels never show the previous frame.
///
/// At least one frame, both sides in `1..=65535` and every frame of the
/// right length, else [`VoxkitError::Invalid`] (all checked before anything
/// is written). An existing `path` is refused unless `overwrite`.
pub fn write_gif(
    path: &Path,
    width: u32,
    height: u32,
    frames: &[Vec<u8>],
    delay_centis: u16,
    overwrite: bool,
) -> Result<()> {
    let n = pixel_count("GIF", width, height)?;
    if width > GIF_MAX_DIM || height > GIF_MAX_DIM {
        return Err(VoxkitError::invalid(format!(
            "GIF: image size {width}x{height} exceeds {GIF_MAX_DIM} on a side"
        )));
    }
    if frames.is_empty() {
        return Err(VoxkitError::invalid("GIF: at least one frame is needed"));
    }
    for (i, f) in frames.iter().enumerate() {
        check_len(&format!("GIF frame {i}"), f.len(), n, 4, width, height)?;
    }
    // Per frame: a copy of the RGBA pixels (4), the palette indices (1) and
    // the LZW output (at most about 1 more).
    MemoryLimit::DEFAULT.check("GIF frame encoding", n as u128, 6)?;
    let (w16, h16) = (width as u16, height as u16);
    crate::io::atomic_write(path, overwrite, |w| {
        let mut enc = gif::Encoder::new(w, w16, h16, &[]).map_err(gif_err)?;
        enc.set_repeat(gif::Repeat::Infinite).map_err(gif_err)?;
        let mut scratch = Vec::new();
        for f in frames {
            // `from_rgba_speed` rewrites alpha in place, so work on a copy.
            scratch.clear();
            scratch.extend_from_slice(f);
            let mut frame = gif::Frame::from_rgba_speed(w16, h16, &mut scratch, GIF_QUANT_SPEED);
            frame.delay = delay_centis;
            frame.dispose = gif::DisposalMethod::Background;
            enc.write_frame(&frame).map_err(gif_err)?;
        }
        enc.into_inner().map_err(gif_err)?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_count_rejects_zero_sides() {
        assert!(pixel_count("t", 0, 5).is_err());
        assert!(pixel_count("t", 5, 0).is_err());
        assert_eq!(pixel_count("t", 7, 3).unwrap(), 21);
    }

    #[test]
    fn check_len_reports_mismatch() {
        assert!(check_len("t", 84, 21, 4, 7, 3).is_ok());
        assert!(check_len("t", 83, 21, 4, 7, 3).is_err());
        assert!(check_len("t", 0, usize::MAX, 4, 1, 1).is_err());
    }

    #[test]
    fn png_encoder_writes_signature() {
        let png = encode_png_rgba(1, 1, &[1, 2, 3, 4]).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert!(matches!(
            encode_png_rgba(0, 1, &[]),
            Err(VoxkitError::Invalid(_))
        ));
    }

    #[test]
    fn exr_encoder_writes_magic() {
        let bytes = encode_exr(Path::new("mem"), 1, 1, &[[0.0; 4]], &[f32::INFINITY]).unwrap();
        assert_eq!(&bytes[..4], &[0x76, 0x2f, 0x31, 0x01]);
    }

    #[test]
    fn gif_rejects_oversize_and_empty() {
        let p = Path::new("/nonexistent-dir-voxkit/x.gif");
        assert!(matches!(
            write_gif(p, 65536, 1, &[vec![0; 65536 * 4]], 5, false),
            Err(VoxkitError::Invalid(_))
        ));
        assert!(matches!(
            write_gif(p, 1, 1, &[], 5, false),
            Err(VoxkitError::Invalid(_))
        ));
    }
}
