//! Wavefront OBJ input: a lenient parser of our own over the file's bytes.
//!
//! A voxelizer needs positions, faces, lines and nothing else, and OBJ files
//! in the wild are sloppy, so the parser reads exactly those records and is
//! liberal about everything around them:
//! - bytes, not text: a Latin-1 material or group name (or any non-UTF-8
//!   byte outside `v`, `f`, `l` and `p` records) does not matter;
//! - `\n` or `\r\n` line ends; a backslash at the end of a line continues the
//!   record on the next line (the spec's line continuation); `#` starts a
//!   comment anywhere on a line;
//! - materials and textures are never read: `mtllib` is not opened, so a
//!   missing or broken `.mtl` (an empty `newmtl`, say) cannot block the
//!   geometry; `vt`, `vn` and the texture / normal parts of face indices are
//!   skipped without being checked;
//! - `v x y z w` divides by `w` (as tobj does); `v x y z r g b` (vertex
//!   colours) keeps `x y z`. Colours on only some vertices, or extra values
//!   that are neither, are one warning each in
//!   [`super::LoadSummary::warnings`]; so are free-form records (`curv`,
//!   `curv2`, `surf`), the only geometry this reader does not read.
//!
//! What it does read it checks exactly, naming the file and line: every `v`
//! has three finite coordinates; every `f` / `l` vertex index is
//! nonzero and in range, negative (relative) indices counting back from the
//! vertices defined so far, positive ones possibly referring forward.
//! Faces are fan-triangulated `0, k, k+1`; each `l` record is one polyline;
//! `p` records are counted in [`super::LoadSummary::skipped_points`].
//! Positions are the file's own vertices in order (unused ones included:
//! bounds count only used ones).
//!
//! Files of [`PARALLEL_MIN_BYTES`] and more are parsed in parallel: a first
//! pass counts the `v` records and lines of each chunk (cut at line ends that
//! do not continue), so each chunk resolves relative indices and names lines
//! exactly as a serial parse would; the results are concatenated in order.

use std::borrow::Cow;
use std::path::Path;

use glam::DVec3;
use rayon::prelude::*;

use super::{LoadSummary, Mesh};
use crate::error::{Result, VoxkitError};

/// Files at least this large are parsed in parallel chunks.
pub const PARALLEL_MIN_BYTES: usize = 4 << 20;

/// Loads an OBJ file. See the module docs for what is read and checked.
pub fn load(path: &Path) -> Result<Mesh> {
    let bytes = super::read_file(path)?;
    parse(&bytes, &path.display().to_string())
}

/// Parses OBJ text; `name` prefixes error messages.
///
/// ```
/// let m = voxkit::mesh::obj::parse_str(
///     "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nl -4 -2 -1\n",
///     "quad.obj",
/// ).unwrap();
/// assert_eq!(m.triangles.len(), 2);          // the quad, fan-triangulated
/// assert_eq!(m.polylines.len(), 1);          // the `l` record
/// let line: Vec<_> = m.polylines[0].iter().map(|&i| m.positions[i as usize]).collect();
/// assert_eq!(line, [glam::DVec3::ZERO, glam::DVec3::new(1., 1., 0.), glam::DVec3::Y]);
/// ```
pub fn parse_str(text: &str, name: &str) -> Result<Mesh> {
    parse(text.as_bytes(), name)
}

/// Parses OBJ bytes (any encoding: only ASCII records are interpreted);
/// `name` prefixes error messages.
///
/// ```
/// // A Latin-1 material name, CRLF line ends and a continued face.
/// let m = voxkit::mesh::obj::parse(
///     b"usemtl caf\xe9\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 \\\r\n 3\r\n",
///     "latin1.obj",
/// ).unwrap();
/// assert_eq!(m.triangles, vec![[0, 1, 2]]);
/// assert!(m.summary.warnings.is_empty());
/// ```
pub fn parse(bytes: &[u8], name: &str) -> Result<Mesh> {
    let chunks = if bytes.len() >= PARALLEL_MIN_BYTES && rayon::current_num_threads() > 1 {
        split_chunks(bytes, rayon::current_num_threads() * 4)
    } else {
        vec![bytes]
    };
    // Vertex and line counts before each chunk.
    let mut starts = Vec::with_capacity(chunks.len());
    let (mut v0, mut l0) = (0usize, 0usize);
    for (i, c) in chunks.iter().enumerate() {
        starts.push((v0, l0));
        if i + 1 < chunks.len() {
            let (v, l) = count_chunk(c);
            v0 += v;
            l0 += l;
        }
    }
    let parts: Vec<Result<Part>> = if chunks.len() == 1 {
        vec![parse_chunk(bytes, 0, 0, name)]
    } else {
        chunks
            .par_iter()
            .zip(starts.par_iter())
            .map(|(c, &(v, l))| parse_chunk(c, v, l, name))
            .collect()
    };
    let mut all = Part::default();
    for part in parts {
        all.append(part?);
    }
    finish(all, name)
}

/// What one chunk of the file holds. Indices are already 0-based and global.
#[derive(Default)]
struct Part {
    vertices: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    polylines: Vec<Vec<u32>>,
    points: usize,
    /// Vertices with three colour values after the coordinates.
    coloured: usize,
    /// Vertices with extra values that are neither `w` nor `r g b`: the
    /// first one's line and the count.
    odd_extras: Option<(usize, usize)>,
    /// Free-form records (`curv`, `curv2`, `surf`): the first one's line and
    /// the count.
    freeform: Option<(usize, usize)>,
    /// The largest positive index (0-based) and its line: positive indices
    /// may refer forward, so they are checked once all vertices are known.
    max_index: Option<(u32, usize)>,
}

impl Part {
    fn append(&mut self, mut o: Part) {
        if self.vertices.is_empty() {
            std::mem::swap(&mut self.vertices, &mut o.vertices);
        } else {
            self.vertices.append(&mut o.vertices);
        }
        if self.triangles.is_empty() {
            std::mem::swap(&mut self.triangles, &mut o.triangles);
        } else {
            self.triangles.append(&mut o.triangles);
        }
        self.polylines.append(&mut o.polylines);
        self.points += o.points;
        self.coloured += o.coloured;
        self.odd_extras = merge_first(self.odd_extras, o.odd_extras);
        self.freeform = merge_first(self.freeform, o.freeform);
        self.max_index = match (self.max_index, o.max_index) {
            (Some(a), Some(b)) => Some(if b.0 > a.0 { b } else { a }),
            (a, b) => a.or(b),
        };
    }
}

/// Adds two (first line, count) tallies, keeping the earlier line.
fn merge_first(a: Option<(usize, usize)>, b: Option<(usize, usize)>) -> Option<(usize, usize)> {
    match (a, b) {
        (Some((l, n)), Some((_, m))) => Some((l, n + m)),
        (a, b) => a.or(b),
    }
}

/// Tallies one more occurrence at (1-based) line `ln`.
fn tally(t: &mut Option<(usize, usize)>, ln: usize) {
    match t {
        Some((_, n)) => *n += 1,
        None => *t = Some((ln, 1)),
    }
}

/// Checks the forward references, turns the tallies into warnings and
/// validates through [`Mesh::from_parts_with`].
fn finish(all: Part, name: &str) -> Result<Mesh> {
    let n = all.vertices.len();
    if let Some((r, ln)) = all.max_index
        && r as usize >= n
    {
        return Err(VoxkitError::invalid(format!(
            "{name}: line {ln}: vertex index {} is out of range (the file has {n} vertices)",
            r as u64 + 1
        )));
    }
    let mut warnings = Vec::new();
    if all.coloured > 0 && all.coloured < n {
        warnings.push(format!(
            "vertex colours on only {} of {n} vertices ignored (colours are not used)",
            all.coloured
        ));
    }
    if let Some((ln, k)) = all.odd_extras {
        warnings.push(format!(
            "line {ln}: {k} vertex record(s) with extra values that are neither `w` nor `r g b`; the extra values were ignored"
        ));
    }
    if let Some((ln, k)) = all.freeform {
        warnings.push(format!(
            "line {ln}: {k} free-form record(s) (curv, curv2, surf) ignored: only polygons, lines and points are read"
        ));
    }
    let mut summary = LoadSummary {
        skipped_points: all.points,
        warnings,
        ..LoadSummary::default()
    };
    Mesh::from_parts_with(
        name,
        all.vertices,
        all.triangles,
        all.polylines,
        &mut summary,
    )
}

/// Cuts `bytes` into about `pieces` chunks at line ends that do not continue
/// the record (a backslash before the line end).
fn split_chunks(bytes: &[u8], pieces: usize) -> Vec<&[u8]> {
    let target = bytes.len().div_ceil(pieces.max(1)).max(1 << 20);
    let mut out = Vec::new();
    let mut start = 0;
    while start < bytes.len() {
        let mut cut = (start + target).min(bytes.len());
        loop {
            match memchr::memchr(b'\n', &bytes[cut..]) {
                None => {
                    cut = bytes.len();
                    break;
                }
                Some(k) => {
                    cut += k + 1;
                    if !continues(&bytes[start..cut - 1]) {
                        break;
                    }
                }
            }
        }
        out.push(&bytes[start..cut]);
        start = cut;
    }
    out
}

/// Whether a line (without its `\n`) ends in a continuation backslash.
fn continues(line: &[u8]) -> bool {
    line.trim_ascii_end().last() == Some(&b'\\')
}

/// The logical lines of a chunk: `(first physical line, 1-based, record)`,
/// with continued lines joined by a space and comments cut off.
struct Records<'a> {
    rest: &'a [u8],
    line: usize,
}

impl<'a> Iterator for Records<'a> {
    type Item = (usize, Cow<'a, [u8]>);

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let first = self.line + 1;
        let (mut line, mut rest) = split_line(self.rest);
        self.line += 1;
        let mut joined: Cow<'a, [u8]> = Cow::Borrowed(line);
        while continues(line) {
            let owned = joined.to_mut();
            let keep = owned.trim_ascii_end().len() - 1; // drop the backslash
            owned.truncate(keep);
            if rest.is_empty() {
                break;
            }
            owned.push(b' ');
            (line, rest) = split_line(rest);
            self.line += 1;
            owned.extend_from_slice(line);
        }
        self.rest = rest;
        if let Some(h) = memchr::memchr(b'#', &joined) {
            match &mut joined {
                Cow::Borrowed(b) => *b = &b[..h],
                Cow::Owned(v) => v.truncate(h),
            }
        }
        Some((first, joined))
    }
}

/// The first line of `b` (without `\n`) and what follows it.
#[inline]
fn split_line(b: &[u8]) -> (&[u8], &[u8]) {
    match memchr::memchr(b'\n', b) {
        Some(k) => (&b[..k], &b[k + 1..]),
        None => (b, &[]),
    }
}

/// ASCII-whitespace-separated words (space, tab, `\r`, form feed, ...).
#[inline]
fn words(b: &[u8]) -> impl Iterator<Item = &[u8]> {
    b.split(|c| c.is_ascii_whitespace())
        .filter(|w| !w.is_empty())
}

/// The record's keyword and the rest of it.
#[inline]
fn keyword(rec: &[u8]) -> (&[u8], &[u8]) {
    let r = rec.trim_ascii_start();
    let end = r
        .iter()
        .position(|c| c.is_ascii_whitespace())
        .unwrap_or(r.len());
    (&r[..end], &r[end..])
}

/// `v` records and physical lines in a chunk (the parallel parse's first
/// pass; it classifies records exactly as [`parse_chunk`] does).
fn count_chunk(c: &[u8]) -> (usize, usize) {
    let mut it = Records { rest: c, line: 0 };
    let mut v = 0;
    for (_, rec) in &mut it {
        if keyword(&rec).0 == b"v" {
            v += 1;
        }
    }
    (v, it.line)
}

/// Parses one chunk whose first vertex is number `v0` (0-based) and whose
/// first line follows line `l0`.
fn parse_chunk(c: &[u8], v0: usize, l0: usize, name: &str) -> Result<Part> {
    let mut part = Part::default();
    let mut idx: Vec<u32> = Vec::new();
    for (ln, rec) in (Records { rest: c, line: l0 }) {
        let (kw, body) = keyword(&rec);
        match kw {
            b"v" => {
                let vn = v0 + part.vertices.len() + 1;
                let at = |m: String| line_err(name, ln, format!("vertex {vn}{m}"));
                let mut ws = words(body);
                let mut c = [0.0f64; 3];
                for (k, slot) in c.iter_mut().enumerate() {
                    let w = ws
                        .next()
                        .ok_or_else(|| at(format!(" needs 3 coordinates, found {k}")))?;
                    *slot = parse_f64(w)
                        .ok_or_else(|| at(format!(": cannot parse coordinate {}", show(w))))?;
                }
                let mut p = DVec3::from_array(c);
                let extra: [Option<&[u8]>; 4] = std::array::from_fn(|_| ws.next());
                match extra {
                    [None, ..] => {}
                    [Some(w), None, ..] => {
                        let w = parse_f64(w)
                            .ok_or_else(|| at(format!(": cannot parse w {}", show(w))))?;
                        if w == 0.0 {
                            return Err(at(": w is 0".into()));
                        }
                        p /= w;
                    }
                    [Some(r), Some(g), Some(b), None]
                        if [r, g, b].iter().all(|x| parse_f64(x).is_some()) =>
                    {
                        part.coloured += 1
                    }
                    _ => tally(&mut part.odd_extras, ln),
                }
                if !p.is_finite() {
                    return Err(at(format!(
                        " has a non-finite coordinate ({}, {}, {})",
                        p.x, p.y, p.z
                    )));
                }
                part.vertices.push(p);
            }
            // Points are skipped: counted, not resolved.
            b"p" => part.points += words(body).count(),
            b"f" | b"l" => {
                let n = v0 + part.vertices.len();
                idx.clear();
                for w in words(body) {
                    idx.push(resolve(w, n, ln, name, &mut part.max_index)?);
                }
                match kw {
                    b"f" => {
                        if idx.len() < 3 {
                            return Err(line_err(
                                name,
                                ln,
                                format!("face has {} vertices, at least 3 are needed", idx.len()),
                            ));
                        }
                        super::fan(&idx, &mut part.triangles);
                    }
                    _ => part.polylines.push(idx.clone()),
                }
            }
            b"curv" | b"curv2" | b"surf" => tally(&mut part.freeform, ln),
            _ => {}
        }
    }
    Ok(part)
}

/// One face / line / point vertex: the index before the first `/`, 0-based;
/// `n` vertices are defined so far.
#[inline]
fn resolve(
    w: &[u8],
    n: usize,
    ln: usize,
    name: &str,
    max: &mut Option<(u32, usize)>,
) -> Result<u32> {
    let v = w.split(|&c| c == b'/').next().unwrap_or(w);
    let i = parse_i64(v)
        .ok_or_else(|| line_err(name, ln, format!("cannot parse vertex index {}", show(w))))?;
    let out_of_range = || {
        line_err(
            name,
            ln,
            format!("vertex index {i} is out of range ({n} vertices defined so far)"),
        )
    };
    if i > 0 {
        let r = u32::try_from(i - 1).map_err(|_| out_of_range())?;
        if r as usize >= n && max.is_none_or(|(m, _)| r > m) {
            *max = Some((r, ln));
        }
        Ok(r)
    } else if i < 0 && i.unsigned_abs() <= n as u64 {
        Ok((n as i64 + i) as u32)
    } else {
        Err(out_of_range())
    }
}

/// `file: line N: message`.
fn line_err(name: &str, ln: usize, msg: String) -> VoxkitError {
    VoxkitError::invalid(format!("{name}: line {ln}: {msg}"))
}

/// A word for a message: quoted, non-UTF-8 bytes shown lossily, long words cut.
fn show(w: &[u8]) -> String {
    format!("`{}`", super::clip(&String::from_utf8_lossy(w)))
}

/// A decimal float (Rust's grammar: `1`, `-2.5e3`, `inf`, `nan`, ...).
#[inline]
fn parse_f64(w: &[u8]) -> Option<f64> {
    std::str::from_utf8(w).ok()?.parse().ok()
}

/// A decimal integer with optional sign; `None` on anything else or overflow.
#[inline]
fn parse_i64(w: &[u8]) -> Option<i64> {
    let (neg, digits) = match w.first()? {
        b'-' => (true, &w[1..]),
        b'+' => (false, &w[1..]),
        _ => (false, w),
    };
    if digits.is_empty() {
        return None;
    }
    let mut v: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        v = v.checked_mul(10)?.checked_add((d - b'0') as i64)?;
    }
    Some(if neg { -v } else { v })
}
