//! STL input (ascii and binary; the 3D-printing format of Thingi10K-style
//! collections).
//!
//! STL stores each triangle with its own three corners. Corners with
//! bitwise-equal coordinates (after `-0.0` is read as `0.0`) become one
//! vertex, so a closed STL is an indexed closed mesh like the OBJ or PLY it
//! was exported from: code that works on indices sees shared edges, and the
//! summary counts real vertices. (Solid mode's boundary and caps compare
//! quantized positions, so they see the same either way.) Corners that
//! differ in the last bit stay distinct: merging by distance would change
//! the geometry. Facet normals are ignored (voxelization uses the
//! corners' order).
//!
//! **Precision.** Binary STL stores `f32`, which `f64` holds exactly. Ascii
//! STL is decimal text, read as `f64` with correct rounding (Rust's float
//! parser), so a file written with 17 significant digits comes back bit for
//! bit. (A reader that rounds ascii to `f32`, as binary holds, moves such
//! corners by up to 2⁻²⁴ of their magnitude.)
//!
//! **Which encoding.** A file of exactly `84 + 50·n` bytes, `n` being the
//! count at byte 80, is binary (even when its 80-byte header starts with
//! `solid`, as some exporters write). Otherwise a file whose first word is
//! `solid` (any case) and which holds no control bytes other than
//! whitespace is ascii: names and comments in Latin-1 or any other 8-bit
//! encoding are fine, while binary records (whose floats and attribute
//! words hold NULs and other control bytes) are not taken for text. Anything
//! else is binary, and then a count that needs more bytes than the file has
//! is an error before anything is read. Bytes after the `n` records of a
//! binary file are ignored, as other readers do.
//!
//! **Ascii grammar, read liberally.** Keywords in any case; any number of
//! `solid … endsolid` blocks one after the other (some exporters write one
//! per part); a `facet` ends at `endfacet`, its corners being the `vertex`
//! lines inside it (`outer loop` and `endloop` are accepted and not
//! required). A facet with more than three corners is a polygon and is
//! fanned into triangles. A file that ends between facets without
//! `endsolid` loads with a warning (it may be truncated); one that ends
//! inside a facet is an error.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::{LoadSummary, Mesh};
use crate::error::{Result, VoxkitError};

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
///
/// // Ascii is read as f64: 0.1 is the f64 nearest to 0.1, not the f32.
/// let tri = b"solid\nfacet\nvertex 0.1 0 0\nvertex 1 0 0\nvertex 0 1 0\nendfacet\nendsolid\n";
/// let m = voxkit::mesh::stl::parse(tri, "tri.stl").unwrap();
/// assert_eq!(m.positions[0].x, 0.1);
/// ```
pub fn parse(bytes: &[u8], name: &str) -> Result<Mesh> {
    let mut merge = Merge::default();
    let mut summary = LoadSummary::default();
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
            merge.reserve(n as usize);
            for (t, record) in records.chunks_exact(BINARY_RECORD).enumerate() {
                // Bytes 0..12 are the facet normal, 48..50 the attribute word.
                let corner = |k: usize| {
                    let at = 12 + 12 * k;
                    let c = |i: usize| {
                        let b = &record[at + 4 * i..at + 4 * i + 4];
                        f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                    };
                    [c(0), c(1), c(2)]
                };
                let corners = [corner(0), corner(1), corner(2)];
                merge.add(&corners, &|| format!("triangle {t}"), name)?;
            }
        }
        Encoding::Ascii => parse_ascii(bytes, name, &mut merge, &mut summary)?,
    }
    let Merge {
        positions,
        triangles,
        ..
    } = merge;
    Mesh::from_parts_with(name, positions, triangles, Vec::new(), &mut summary)
}

enum Encoding {
    /// Binary with this many triangle records.
    Binary(u32),
    Ascii,
}

fn encoding(bytes: &[u8]) -> Encoding {
    let count = (bytes.len() >= BINARY_HEADER)
        .then(|| u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]));
    if let Some(n) = count
        && BINARY_HEADER as u128 + n as u128 * BINARY_RECORD as u128 == bytes.len() as u128
    {
        return Encoding::Binary(n);
    }
    // Binary files with a `solid` header and a wrong count are common
    // enough: ascii must also be text.
    let is_text = |b: &u8| *b >= 0x20 || b.is_ascii_whitespace();
    let solid = first_word(bytes).is_some_and(|w| w.eq_ignore_ascii_case(b"solid"));
    if solid && bytes.iter().all(is_text) {
        return Encoding::Ascii;
    }
    Encoding::Binary(count.unwrap_or(0))
}

/// The first whitespace-separated word of `bytes`.
fn first_word(bytes: &[u8]) -> Option<&[u8]> {
    words(bytes).next()
}

/// The whitespace-separated words of `line`.
fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|w| !w.is_empty())
}

/// Where the ascii reader is.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Place {
    /// Before the first `solid`, or after an `endsolid`.
    Outside,
    /// Inside `solid` (line of the keyword), between facets.
    Solid(usize),
    /// Inside a `facet` (line of the keyword).
    Facet(usize),
}

/// Reads the ascii grammar of the module docs into `merge`.
fn parse_ascii(
    bytes: &[u8],
    name: &str,
    merge: &mut Merge,
    summary: &mut LoadSummary,
) -> Result<()> {
    let at = |ln: usize, msg: String| VoxkitError::invalid(format!("{name}: line {ln}: {msg}"));
    let quoted = |w: &[u8]| String::from_utf8_lossy(w).into_owned();
    let mut place = Place::Outside;
    let mut corners: Vec<[f64; 3]> = Vec::with_capacity(3);
    let mut polygons = 0usize;
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let ln = i + 1;
        let mut w = words(line);
        let Some(key) = w.next() else { continue };
        let Some(key) = Keyword::of(key) else {
            return Err(at(
                ln,
                format!("`{}` is not an ascii STL keyword", quoted(key)),
            ));
        };
        match (key, place) {
            // A name follows `solid` and `endsolid`: any text.
            (Keyword::Solid, Place::Outside) => place = Place::Solid(ln),
            (Keyword::EndSolid, Place::Solid(_)) => place = Place::Outside,
            (Keyword::Facet, Place::Solid(_)) => {
                corners.clear();
                place = Place::Facet(ln);
            }
            (Keyword::Outer | Keyword::EndLoop, Place::Facet(_)) => {}
            (Keyword::Vertex, Place::Facet(_)) => {
                let mut c = [0.0f64; 3];
                let mut count = 0;
                for word in w {
                    let v = std::str::from_utf8(word)
                        .ok()
                        .and_then(|s| s.parse::<f64>().ok())
                        .ok_or_else(|| at(ln, format!("`{}` is not a number", quoted(word))))?;
                    if !v.is_finite() {
                        return Err(at(ln, format!("a non-finite coordinate ({v})")));
                    }
                    if count < 3 {
                        c[count] = v;
                    }
                    count += 1;
                }
                if count != 3 {
                    return Err(at(ln, format!("`vertex` with {count} coordinates, not 3")));
                }
                corners.push(c);
            }
            (Keyword::EndFacet, Place::Facet(f)) => {
                if corners.len() < 3 {
                    return Err(at(
                        ln,
                        format!("the facet begun on line {f} has {} corners", corners.len()),
                    ));
                }
                if corners.len() > 3 {
                    polygons += 1;
                }
                // A polygon is fanned from its first corner.
                for k in 1..corners.len() - 1 {
                    let tri = [corners[0], corners[k], corners[k + 1]];
                    merge.add(&tri, &|| format!("line {f}: facet"), name)?;
                }
                place = Place::Solid(f);
            }
            (_, Place::Facet(f)) => {
                return Err(at(
                    ln,
                    format!("`{}` before the facet begun on line {f} ended", key.word()),
                ));
            }
            (_, Place::Solid(s)) if key == Keyword::Solid => {
                return Err(at(
                    ln,
                    format!("`solid` inside the solid begun on line {s}"),
                ));
            }
            (_, Place::Solid(_)) => {
                return Err(at(ln, format!("`{}` outside a facet", key.word())));
            }
            (_, Place::Outside) => {
                return Err(at(ln, format!("`{}` outside a `solid` block", key.word())));
            }
        }
    }
    match place {
        Place::Facet(f) => Err(VoxkitError::invalid(format!(
            "{name}: the file ends inside the facet begun on line {f} (truncated?)"
        ))),
        Place::Solid(s) => {
            summary.warnings.push(format!(
                "{name}: the solid begun on line {s} has no `endsolid`; the file may be truncated"
            ));
            Ok(())
        }
        Place::Outside => {
            if polygons > 0 {
                summary.warnings.push(format!(
                    "{name}: {polygons} facet(s) with more than three corners, fanned into triangles"
                ));
            }
            Ok(())
        }
    }
}

/// The ascii STL keywords, matched in any case.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Keyword {
    Solid,
    Facet,
    Outer,
    Vertex,
    EndLoop,
    EndFacet,
    EndSolid,
}

impl Keyword {
    const ALL: [Keyword; 7] = [
        Keyword::Solid,
        Keyword::Facet,
        Keyword::Outer,
        Keyword::Vertex,
        Keyword::EndLoop,
        Keyword::EndFacet,
        Keyword::EndSolid,
    ];

    fn word(self) -> &'static str {
        match self {
            Keyword::Solid => "solid",
            Keyword::Facet => "facet",
            Keyword::Outer => "outer",
            Keyword::Vertex => "vertex",
            Keyword::EndLoop => "endloop",
            Keyword::EndFacet => "endfacet",
            Keyword::EndSolid => "endsolid",
        }
    }

    fn of(word: &[u8]) -> Option<Keyword> {
        Self::ALL
            .into_iter()
            .find(|k| word.eq_ignore_ascii_case(k.word().as_bytes()))
    }
}

/// Corners → indexed vertices, merging bitwise-equal positions.
#[derive(Default)]
struct Merge {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    index: HashMap<[u64; 3], u32>,
}

impl Merge {
    fn reserve(&mut self, triangles: usize) {
        // A closed mesh has about half as many vertices as triangles; the
        // count is checked against the file's size before this is called.
        self.triangles.reserve(triangles);
        self.index.reserve(triangles / 2);
        self.positions.reserve(triangles / 2);
    }

    /// Adds one triangle; `place` names it in errors.
    fn add(
        &mut self,
        corners: &[[f64; 3]; 3],
        place: &dyn Fn() -> String,
        name: &str,
    ) -> Result<()> {
        let mut tri = [0u32; 3];
        for (k, c) in corners.iter().enumerate() {
            if let Some(v) = c.iter().find(|v| !v.is_finite()) {
                return Err(VoxkitError::invalid(format!(
                    "{name}: STL {} corner {k} has a non-finite coordinate ({v})",
                    place()
                )));
            }
            // `+ 0.0` turns -0.0 into 0.0: the same point, another bit pattern.
            let c = c.map(|v| v + 0.0);
            let next = self.positions.len();
            let i = *self
                .index
                .entry(c.map(f64::to_bits))
                .or_insert_with(|| next as u32);
            if i as usize == next {
                if next >= u32::MAX as usize {
                    return Err(VoxkitError::Unsupported(format!(
                        "{name}: more than 2^32 - 1 vertices"
                    )));
                }
                self.positions.push(DVec3::from_array(c));
            }
            tri[k] = i;
        }
        self.triangles.push(tri);
        Ok(())
    }
}
