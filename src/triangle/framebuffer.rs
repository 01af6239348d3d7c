//! A small 2D pixel buffer ([`Framebuffer`]) and a colour + depth pair
//! ([`RenderTarget`]), with PNG output through the `png` crate.
//!
//! Layout: row-major, row 0 at the **top** (screen convention, y grows
//! downwards), `index = x + width * y`.

use std::io::Write;
use std::path::Path;

use crate::error::{Result, VoxkitError};
use crate::grid::MemoryLimit;

/// Largest supported width or height of a framebuffer, in pixels (2^15).
/// The rasterizer's fixed-point bound (see [`super::raster`]) relies on
/// every pixel centre being below this.
pub const MAX_DIM: u32 = 1 << 15;

/// An 8-bit RGB colour.
pub type Rgb8 = [u8; 3];
/// An 8-bit RGBA colour (straight alpha).
pub type Rgba8 = [u8; 4];

/// A pixel type that can be written to PNG.
pub trait PngPixel: Copy {
    /// The PNG colour type of this pixel.
    const COLOR: png::ColorType;
    /// Appends this pixel's bytes (8 bits per channel) to `out`.
    fn push_bytes(&self, out: &mut Vec<u8>);
}

impl PngPixel for u8 {
    const COLOR: png::ColorType = png::ColorType::Grayscale;
    fn push_bytes(&self, out: &mut Vec<u8>) {
        out.push(*self);
    }
}

impl PngPixel for Rgb8 {
    const COLOR: png::ColorType = png::ColorType::Rgb;
    fn push_bytes(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(self);
    }
}

impl PngPixel for Rgba8 {
    const COLOR: png::ColorType = png::ColorType::Rgba;
    fn push_bytes(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(self);
    }
}

/// A `width × height` buffer of pixels of type `P`.
///
/// ```
/// use voxkit::triangle::Framebuffer;
/// let mut fb = Framebuffer::new(4, 3, [0u8; 3]).unwrap();
/// fb.set(1, 2, [255, 0, 0]);
/// assert_eq!(fb.get(1, 2), Some([255, 0, 0]));
/// assert_eq!(fb.get(4, 0), None);
/// let mut png = Vec::new();
/// fb.encode_png(&mut png).unwrap();
/// assert_eq!(&png[1..4], b"PNG");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Framebuffer<P> {
    width: u32,
    height: u32,
    pixels: Vec<P>,
}

impl<P: Copy> Framebuffer<P> {
    /// A buffer filled with `fill`. Width and height must be in
    /// `1..=MAX_DIM`; the allocation is checked against
    /// [`MemoryLimit::DEFAULT`] first.
    pub fn new(width: u32, height: u32, fill: P) -> Result<Self> {
        Self::with_limit(width, height, fill, MemoryLimit::DEFAULT)
    }

    /// As [`Framebuffer::new`] with an explicit memory limit.
    pub fn with_limit(width: u32, height: u32, fill: P, limit: MemoryLimit) -> Result<Self> {
        if width == 0 || height == 0 || width > MAX_DIM || height > MAX_DIM {
            return Err(VoxkitError::invalid(format!(
                "framebuffer size {width}x{height} outside 1..={MAX_DIM}"
            )));
        }
        let n = width as usize * height as usize;
        limit.check("framebuffer", n as u128, std::mem::size_of::<P>() as u128)?;
        Ok(Framebuffer {
            width,
            height,
            pixels: vec![fill; n],
        })
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixel at `(x, y)`, or `None` outside the buffer.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Option<P> {
        (x < self.width && y < self.height).then(|| self.pixels[self.index(x, y)])
    }

    /// Sets the pixel at `(x, y)`; does nothing outside the buffer.
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, p: P) {
        if x < self.width && y < self.height {
            let i = self.index(x, y);
            self.pixels[i] = p;
        }
    }

    /// Linear index of `(x, y)` (x fastest). The caller keeps `(x, y)` inside.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        x as usize + self.width as usize * y as usize
    }

    /// All pixels, row-major from the top row.
    #[inline]
    pub fn pixels(&self) -> &[P] {
        &self.pixels
    }

    /// All pixels, mutable.
    #[inline]
    pub fn pixels_mut(&mut self) -> &mut [P] {
        &mut self.pixels
    }

    /// Row `y` as a mutable slice (panics if `y >= height`, a caller bug).
    #[inline]
    pub fn row_mut(&mut self, y: u32) -> &mut [P] {
        let w = self.width as usize;
        let s = w * y as usize;
        &mut self.pixels[s..s + w]
    }

    /// Sets every pixel to `p`.
    pub fn fill(&mut self, p: P) {
        self.pixels.fill(p);
    }
}

impl<P: PngPixel> Framebuffer<P> {
    /// Encodes the buffer as an 8-bit PNG into `w`.
    pub fn encode_png<W: Write>(&self, w: W) -> Result<()> {
        let mut enc = png::Encoder::new(w, self.width, self.height);
        enc.set_color(P::COLOR);
        enc.set_depth(png::BitDepth::Eight);
        let mut bytes = Vec::with_capacity(self.pixels.len() * 4);
        for p in &self.pixels {
            p.push_bytes(&mut bytes);
        }
        let mut writer = enc.write_header().map_err(png_err)?;
        writer.write_image_data(&bytes).map_err(png_err)?;
        writer.finish().map_err(png_err)
    }

    /// Writes the buffer as PNG to `path` through [`crate::io::atomic_write`]
    /// (nothing partial is left on failure; an existing file is refused
    /// unless `overwrite`).
    pub fn write_png(&self, path: &Path, overwrite: bool) -> Result<()> {
        crate::io::atomic_write(path, overwrite, |w| self.encode_png(w))
    }
}

fn png_err(e: png::EncodingError) -> VoxkitError {
    match e {
        png::EncodingError::IoError(source) => VoxkitError::from(source),
        other => VoxkitError::Unsupported(format!("PNG encoding: {other}")),
    }
}

/// A colour buffer with a depth buffer of the same size (depth initialised
/// to `+∞`; smaller depth is nearer).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderTarget {
    /// Colour.
    pub color: Framebuffer<Rgb8>,
    /// Depth per pixel (`+∞` where nothing was drawn).
    pub depth: Framebuffer<f32>,
}

impl RenderTarget {
    /// A `width × height` target cleared to `background` and depth `+∞`.
    pub fn new(width: u32, height: u32, background: Rgb8) -> Result<Self> {
        Ok(RenderTarget {
            color: Framebuffer::new(width, height, background)?,
            depth: Framebuffer::new(width, height, f32::INFINITY)?,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.color.width()
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.color.height()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_sizes() {
        assert!(Framebuffer::new(0, 3, 0u8).is_err());
        assert!(Framebuffer::new(MAX_DIM + 1, 3, 0u8).is_err());
        assert!(matches!(
            Framebuffer::with_limit(100, 100, [0u8; 4], MemoryLimit::new(1000)),
            Err(VoxkitError::Limits { .. })
        ));
    }

    #[test]
    fn png_round_trip_header_and_size() {
        let mut fb = Framebuffer::new(3, 2, [0u8; 4]).unwrap();
        fb.set(2, 1, [1, 2, 3, 4]);
        let mut out = Vec::new();
        fb.encode_png(&mut out).unwrap();
        let dec = png::Decoder::new(std::io::Cursor::new(out));
        let mut reader = dec.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (3, 2));
        assert_eq!(&buf[(2 + 3) * 4..(2 + 3) * 4 + 4], &[1, 2, 3, 4]);
    }
}
