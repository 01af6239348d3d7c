//! Object File Format (`.off`) input: ModelNet's and the Princeton Shape
//! Benchmark's format.
//!
//! Hand-written: the one crate on crates.io (`off-rs`) reads coordinates as
//! f32 (ours stay f64, as from OBJ), wants `OFF` alone on the first line
//! (ModelNet has many files whose header reads `OFF490 518 0`, the counts
//! glued to the keyword) and rejects the `COFF` / `NOFF` variants. The
//! format is small: this parser is line based, as the files are written.
//!
//! - `#` starts a comment to the end of the line; blank lines are skipped.
//! - Header: `OFF`, optionally with the `ST`, `C`, `N` prefixes of the
//!   variants with texture coordinates, colours or normals per vertex (the
//!   extra numbers after the first three are ignored). The counts
//!   `vertices faces [edges]` follow on the next line or on the header line
//!   itself (`OFF 8 6 12`, ModelNet's `OFF8 6 12`). `4OFF` / `nOFF` (other
//!   dimensions) and `OFF BINARY` are [`VoxkitError::Unsupported`].
//! - One vertex per line (at least three numbers), then one face per line:
//!   `k i1 … ik` with `k ≥ 3` and 0-based indices; numbers after the `k`
//!   indices (a colour) are ignored. Polygons are fan-triangulated
//!   (`i1, ij, ij+1`). Anything after the last face is ignored.
//!
//! Errors name the file and the line: non-UTF-8 text, a bad header,
//! negative or unparsable counts, counts larger than the text can hold
//! (checked before anything is allocated: a vertex line takes at least 6
//! bytes, a face line 8), a missing line, a non-finite coordinate, a face
//! with fewer than three vertices or fewer indices than it announces, and a
//! negative or out-of-range index.

use std::path::Path;

use glam::DVec3;

use super::{LoadSummary, Mesh, clip};
use crate::error::{Result, VoxkitError};

/// What may stand before `OFF` in the header: texture coordinates,
/// colours, normals per vertex (the order the format fixes).
const HEADER_PREFIXES: [&str; 8] = ["", "C", "N", "CN", "ST", "STC", "STN", "STCN"];

/// Fewest bytes of a vertex line (`0 0 0` and its newline).
const MIN_VERTEX_BYTES: u128 = 6;
/// Fewest bytes of a face line (`3 0 1 2` and its newline).
const MIN_FACE_BYTES: u128 = 8;

/// Loads a `.off` file. See the module docs.
pub fn load(path: &Path) -> Result<Mesh> {
    let bytes = super::read_file(path)?;
    parse(&bytes, &path.display().to_string())
}

/// Parses OFF bytes; `name` prefixes error messages.
///
/// ```
/// // ModelNet's glued header, a quad with a colour, a comment.
/// let off = b"OFF4 1 0\n0 0 0\n1 0 0\n1 1 0 # corner\n0 1 0\n4 0 1 2 3 255 0 0\n";
/// let m = voxkit::mesh::off::parse(off, "quad.off").unwrap();
/// assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
/// assert!(voxkit::mesh::off::parse(b"OFF\n4 1 0\n0 0 0\n", "short.off").is_err());
/// ```
pub fn parse(bytes: &[u8], name: &str) -> Result<Mesh> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        VoxkitError::invalid(format!(
            "{name}: not UTF-8 text (invalid byte at offset {})",
            e.valid_up_to()
        ))
    })?;
    let mut lines = Lines::new(text);
    let (ln, first) = lines
        .next()
        .ok_or_else(|| VoxkitError::invalid(format!("{name}: empty file (no OFF header)")))?;
    let at = |ln: usize, msg: String| VoxkitError::invalid(format!("{name}: line {ln}: {msg}"));

    // Header keyword, possibly with the counts glued on or following.
    let word = first.split_whitespace().next().unwrap_or("");
    let Some(i) = word.find("OFF") else {
        return Err(at(
            ln,
            format!("expected the OFF header, found {:?}", clip(first)),
        ));
    };
    let prefix = &word[..i];
    if !HEADER_PREFIXES.contains(&prefix) {
        if prefix.ends_with('4') || prefix.ends_with('n') {
            return Err(VoxkitError::Unsupported(format!(
                "{name}: line {ln}: `{prefix}OFF` (a dimension other than 3)"
            )));
        }
        return Err(at(
            ln,
            format!("expected the OFF header, found {:?}", clip(first)),
        ));
    }
    // `first` is trimmed, so it starts with `word`.
    let end = i + 3;
    let mut counts_line = (ln, first[end..].trim());
    if counts_line.1.split_whitespace().next() == Some("BINARY") {
        return Err(VoxkitError::Unsupported(format!(
            "{name}: binary OFF is not supported"
        )));
    }
    if counts_line.1.is_empty() {
        counts_line = lines
            .next()
            .ok_or_else(|| at(ln + 1, "the counts line is missing".to_string()))?;
    }
    let (cln, counts) = counts_line;
    let words: Vec<&str> = counts.split_whitespace().collect();
    if !(2..=3).contains(&words.len()) {
        return Err(at(
            cln,
            format!(
                "expected `vertices faces [edges]`, found {:?}",
                clip(counts)
            ),
        ));
    }
    let count = |w: &str, what: &str| {
        w.parse::<u64>().map_err(|_| {
            at(
                cln,
                format!(
                    "the {what} count {:?} is not a non-negative integer",
                    clip(w)
                ),
            )
        })
    };
    let nv = count(words[0], "vertex")?;
    let nf = count(words[1], "face")?;
    if let Some(w) = words.get(2) {
        count(w, "edge")?;
    }
    // Cap before allocating: the lines the counts announce must fit in what
    // is left of the text (the last line may lack its newline).
    let need = nv as u128 * MIN_VERTEX_BYTES + nf as u128 * MIN_FACE_BYTES;
    let left = lines.remaining() as u128;
    if need > left + 1 {
        return Err(at(
            cln,
            format!(
                "{nv} vertices and {nf} faces need at least {need} bytes, but only {left} follow"
            ),
        ));
    }
    if nv > u32::MAX as u64 {
        return Err(VoxkitError::Unsupported(format!(
            "{name}: {nv} vertices; at most 2^32 - 1 are supported"
        )));
    }

    let mut positions = Vec::with_capacity(nv as usize);
    for v in 0..nv {
        let (ln, line) = lines.next().ok_or_else(|| {
            VoxkitError::invalid(format!("{name}: the file ends after {v} of {nv} vertices"))
        })?;
        let mut c = [0.0f64; 3];
        let mut words = line.split_whitespace();
        for (k, c) in c.iter_mut().enumerate() {
            let w = words
                .next()
                .ok_or_else(|| at(ln, format!("vertex {v} has {k} coordinates; 3 are needed")))?;
            *c = w.parse().map_err(|_| {
                at(
                    ln,
                    format!("vertex {v}: cannot parse coordinate {:?}", clip(w)),
                )
            })?;
        }
        let p = DVec3::from_array(c);
        if !p.is_finite() {
            return Err(at(
                ln,
                format!(
                    "vertex {v} has a non-finite coordinate ({}, {}, {})",
                    p.x, p.y, p.z
                ),
            ));
        }
        positions.push(p);
    }

    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(nf as usize);
    let mut idx: Vec<u32> = Vec::new();
    for f in 0..nf {
        let (ln, line) = lines.next().ok_or_else(|| {
            VoxkitError::invalid(format!("{name}: the file ends after {f} of {nf} faces"))
        })?;
        let mut words = line.split_whitespace();
        let k_word = words.next().unwrap_or("");
        let k: u64 = k_word.parse().map_err(|_| {
            at(
                ln,
                format!(
                    "face {f}: the vertex count {:?} is not a non-negative integer",
                    clip(k_word)
                ),
            )
        })?;
        if k < 3 {
            return Err(at(
                ln,
                format!("face {f} has {k} vertices; at least 3 are needed"),
            ));
        }
        idx.clear();
        for j in 0..k {
            let w = words
                .next()
                .ok_or_else(|| at(ln, format!("face {f} announces {k} vertices but lists {j}")))?;
            let i: i64 = w.parse().map_err(|_| {
                at(
                    ln,
                    format!("face {f}: cannot parse vertex index {:?}", clip(w)),
                )
            })?;
            if i < 0 || i as u64 >= nv {
                return Err(at(
                    ln,
                    format!("face {f} uses vertex index {i}, but there are {nv} vertices"),
                ));
            }
            idx.push(i as u32);
        }
        super::fan(&idx, &mut triangles);
    }
    Mesh::from_parts_with(
        name,
        positions,
        triangles,
        Vec::new(),
        &mut LoadSummary::default(),
    )
}

/// The significant lines of the text (comments cut, blank lines skipped)
/// with their 1-based numbers.
struct Lines<'a> {
    text: &'a str,
    /// Byte offset of the next unread line.
    pos: usize,
    /// 1-based number of the next unread line.
    number: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Lines {
            text,
            pos: 0,
            number: 1,
        }
    }

    /// Bytes not yet read.
    fn remaining(&self) -> usize {
        self.text.len() - self.pos
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (usize, &'a str);

    fn next(&mut self) -> Option<(usize, &'a str)> {
        while self.pos < self.text.len() {
            let rest = &self.text[self.pos..];
            let len = rest.find('\n').map_or(rest.len(), |i| i + 1);
            let line = &rest[..len];
            let n = self.number;
            self.pos += len;
            self.number += 1;
            let content = line.split('#').next().unwrap_or("").trim();
            if !content.is_empty() {
                return Some((n, content));
            }
        }
        None
    }
}
