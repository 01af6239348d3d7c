//! STL input (ascii and binary; the 3D-printing format of Thingi10K-style
//! collections) via `stl_io`.
//!
//! STL stores each triangle with its own three corners (f32). Corners with
//! bitwise-equal coordinates (after `-0.0` is read as `0.0`) become one
//! vertex, so a closed STL is an indexed closed mesh like the OBJ or PLY it
//! was exported from: code that works on indices sees shared edges, and the
//! summary counts real vertices. (Solid mode's boundary and caps compare
//! quantized positions, so they see the same either way.) Corners that
//! differ in the last bit stay distinct: merging by distance would change
//! the geometry. Facet normals are ignored (voxelization uses the
//! corners' order).
//!
//! Which encoding: a file of exactly `84 + 50·n` bytes, `n` being the count
//! at byte 80, is binary (even when its 80-byte header starts with `solid`,
//! as some exporters write); otherwise a UTF-8 file whose first word is `solid` is
//! ascii; anything else is binary, and then a count that needs more bytes
//! than the file has is an error before anything is read. Bytes after the
//! `n` records of a binary file are ignored, as other readers do.
//!
//! `stl_io` reads the first `solid ... endsolid` block of an ascii file;
//! further blocks (some exporters write one solid per part) are read the
//! same way, one after the other. Calls into `stl_io` run under
//! [`crate::guard::contain`].

use std::collections::HashMap;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use glam::DVec3;

use super::{LoadSummary, Mesh};
use crate::error::{Result, VoxkitError};
use crate::guard::contain;

const KRATE: &str = "stl_io";

/// Bytes of a binary STL's header (80) plus its triangle count (4).
const BINARY_HEADER: usize = 84;
/// Bytes of one binary STL triangle record.
const BINARY_RECORD: usize = 50;

/// Loads a `.stl` file. See the module docs.
pub fn load(path: &Path) -> Result<Mesh> {
    let bytes = super::read_file(path)?;
    parse(&bytes, &path.display().to_string())
}

/// Parses STL bytes (ascii or binary); `name` prefixes error messages.
///
/// ```
/// let stl = b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
///     vertex 0 1 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\n\
///     vertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
/// let m = voxkit::mesh::stl::parse(stl, "quad.stl").unwrap();
/// assert_eq!(m.triangles.len(), 2);
/// assert_eq!(m.positions.len(), 4); // the shared corners merged
/// ```
pub fn parse(bytes: &[u8], name: &str) -> Result<Mesh> {
    let mut merge = Merge::default();
    match encoding(bytes) {
        Encoding::Binary(_) if bytes.len() < BINARY_HEADER => {
            return Err(VoxkitError::invalid(format!(
                "{name}: not an STL file: {} bytes, too short for binary STL (84-byte header), \
                 and it does not start with `solid`",
                bytes.len()
            )));
        }
        Encoding::Binary(n) => {
            let need = BINARY_HEADER as u128 + n as u128 * BINARY_RECORD as u128;
            if need > bytes.len() as u128 {
                return Err(VoxkitError::invalid(format!(
                    "{name}: binary STL claims {n} triangles ({need} bytes), but the file has {} bytes",
                    bytes.len()
                )));
            }
            let records = &bytes[BINARY_HEADER..need as usize];
            // A header line that `stl_io` would take for ascii ("solid ")
            // is blanked in the copy it reads; the records are passed as is.
            let mut head = bytes[..BINARY_HEADER].to_vec();
            head[0] = b'\n';
            read_block(Spliced::new(head, records), &mut merge, name)?;
        }
        Encoding::Ascii => {
            // `encoding` checked that the bytes are UTF-8.
            let text = std::str::from_utf8(bytes).unwrap_or_default();
            for block in solids(text) {
                // `stl_io` wants the first line to start with "solid " (with
                // the space); a bare `solid` line is valid STL all the same.
                read_block(
                    Spliced::new(b"solid ".to_vec(), block.as_bytes()),
                    &mut merge,
                    name,
                )?;
            }
        }
    }
    let Merge {
        positions,
        triangles,
        ..
    } = merge;
    Mesh::from_parts_with(
        name,
        positions,
        triangles,
        Vec::new(),
        &mut LoadSummary::default(),
    )
}

enum Encoding {
    /// Binary with this many triangle records.
    Binary(u32),
    Ascii,
}

fn encoding(bytes: &[u8]) -> Encoding {
    let count = (bytes.len() >= BINARY_HEADER)
        .then(|| u32::from_le_bytes(bytes[80..84].try_into().expect("4 bytes")));
    if let Some(n) = count
        && BINARY_HEADER as u128 + n as u128 * BINARY_RECORD as u128 == bytes.len() as u128
    {
        return Encoding::Binary(n);
    }
    // Binary files with a `solid` header and a wrong count are common
    // enough: ascii must also be text.
    if first_word(bytes) == Some(b"solid".as_slice()) && std::str::from_utf8(bytes).is_ok() {
        return Encoding::Ascii;
    }
    Encoding::Binary(count.unwrap_or(0))
}

/// The first whitespace-separated word of `bytes`.
fn first_word(bytes: &[u8]) -> Option<&[u8]> {
    bytes
        .split(|b| b.is_ascii_whitespace())
        .find(|w| !w.is_empty())
}

/// The text of each `solid` block after its `solid` keyword, in order.
fn solids(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = text.trim_start();
    while rest.split_whitespace().next() == Some("solid") {
        let body = &rest["solid".len()..];
        // Up to and including the line whose first word is `endsolid`.
        let mut end = body.len();
        let mut at = 0;
        for line in body.split_inclusive('\n') {
            at += line.len();
            if line.split_whitespace().next() == Some("endsolid") {
                end = at;
                break;
            }
        }
        out.push(&body[..end]);
        rest = body[end..].trim_start();
    }
    if out.is_empty() || !rest.is_empty() {
        // Let stl_io report what follows (it is not a `solid` block).
        out.push(rest);
    }
    out
}

/// Reads one STL stream with `stl_io` into `merge`. Only the calls into
/// `stl_io` are contained; merging is ours.
fn read_block(mut src: Spliced<'_>, merge: &mut Merge, name: &str) -> Result<()> {
    let err = |e: std::io::Error| {
        let msg = e
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        VoxkitError::invalid(format!("{name}: STL: {msg}"))
    };
    let mut reader = contain(name, KRATE, || stl_io::create_stl_reader(&mut src))?.map_err(err)?;
    while let Some(t) = contain(name, KRATE, || reader.next())? {
        merge.add(t.map_err(err)?, name)?;
    }
    Ok(())
}

/// Corners → indexed vertices, merging bitwise-equal positions.
#[derive(Default)]
struct Merge {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    index: HashMap<[u32; 3], u32>,
}

impl Merge {
    fn add(&mut self, t: stl_io::Triangle, name: &str) -> Result<()> {
        let f = self.triangles.len();
        let mut tri = [0u32; 3];
        for (k, v) in t.vertices.iter().enumerate() {
            if let Some(c) = v.0.iter().find(|c| !c.is_finite()) {
                return Err(VoxkitError::invalid(format!(
                    "{name}: STL triangle {f} corner {k} has a non-finite coordinate ({c})"
                )));
            }
            // `+ 0.0` turns -0.0 into 0.0: the same point, another bit pattern.
            let c = v.0.map(|c| c + 0.0);
            let next = self.positions.len();
            let i = *self
                .index
                .entry(c.map(f32::to_bits))
                .or_insert_with(|| next as u32);
            if i as usize == next {
                if next >= u32::MAX as usize {
                    return Err(VoxkitError::Unsupported(format!(
                        "{name}: more than 2^32 - 1 vertices"
                    )));
                }
                self.positions.push(DVec3::from_array(c.map(f64::from)));
            }
            tri[k] = i;
        }
        self.triangles.push(tri);
        Ok(())
    }
}

/// A `Read + Seek` stream of a small owned head followed by a borrowed
/// body: how the binary header and the ascii `solid ` keyword are adjusted
/// without copying the file.
struct Spliced<'a> {
    head: Vec<u8>,
    body: &'a [u8],
    pos: u64,
}

impl<'a> Spliced<'a> {
    fn new(head: Vec<u8>, body: &'a [u8]) -> Self {
        Spliced { head, body, pos: 0 }
    }
    fn len(&self) -> u64 {
        (self.head.len() + self.body.len()) as u64
    }
}

impl Read for Spliced<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let h = self.head.len() as u64;
        let n = if self.pos < h {
            let src = &self.head[self.pos as usize..];
            let n = src.len().min(buf.len());
            buf[..n].copy_from_slice(&src[..n]);
            n
        } else {
            let at = ((self.pos - h) as usize).min(self.body.len());
            let src = &self.body[at..];
            let n = src.len().min(buf.len());
            buf[..n].copy_from_slice(&src[..n]);
            n
        };
        self.pos += n as u64;
        Ok(n)
    }
}

impl Seek for Spliced<'_> {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        let target = match to {
            SeekFrom::Start(p) => Some(p),
            SeekFrom::Current(d) => self.pos.checked_add_signed(d),
            SeekFrom::End(d) => self.len().checked_add_signed(d),
        };
        self.pos = target.ok_or_else(|| {
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "seek before the start")
        })?;
        Ok(self.pos)
    }
}
