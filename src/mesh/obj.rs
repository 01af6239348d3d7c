//! Wavefront OBJ input via `tobj`, plus a validating pre-pass of our own.
//!
//! `tobj` (built with `use_f64`, so coordinates are parsed straight to f64)
//! triangulates the faces (fans, negative indices resolved). Two things it
//! does not do the way a voxelizer needs, so a pre-pass over the text handles
//! them first:
//! - `l` records: `tobj` reads `l a b c` as a *triangle* and `l a b c d` as a
//!   quad (it shares the face parser), and a two-vertex `l` becomes a
//!   degenerate triangle or is ignored. The pre-pass parses every `l` as a
//!   polyline and hides those lines from `tobj`.
//! - Error locations: `tobj` reports "face vertex index out of bounds" with no
//!   line. The pre-pass checks every `v` (three finite coordinates) and every
//!   `f` / `l` index (nonzero, in range, resolved for negative values) and
//!   names the file, line and element.
//!
//! A missing `mtllib` is not an error: materials are not needed.
//! `p` records are skipped and counted in [`super::LoadSummary::skipped_points`].

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::{LoadSummary, Mesh};
use crate::error::{Result, VoxkitError};

/// Loads an OBJ file. See the module docs for what is checked.
pub fn load(path: &Path) -> Result<Mesh> {
    let bytes = super::read_file(path)?;
    let name = path.display().to_string();
    let text = String::from_utf8(bytes).map_err(|e| {
        VoxkitError::invalid(format!(
            "{name}: not UTF-8 text (invalid byte at offset {})",
            e.utf8_error().valid_up_to()
        ))
    })?;
    parse_str(&text, &name)
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
    let pre = prepass(text, name)?;
    let mut summary = LoadSummary {
        skipped_points: pre.points,
        ..LoadSummary::default()
    };

    let filtered;
    let tobj_input: &str = if pre.line_records.is_empty() {
        text
    } else {
        // Blank the `l` lines (keeping line structure) so tobj sees only faces.
        let mut s = String::with_capacity(text.len());
        let mut next = pre.line_records.iter().peekable();
        for (i, line) in text.lines().enumerate() {
            if next.peek() == Some(&&i) {
                next.next();
            } else {
                s.push_str(line);
            }
            s.push('\n');
        }
        filtered = s;
        &filtered
    };

    let mut positions: Vec<DVec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    if pre.faces > 0 {
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: false,
            ignore_points: true,
            ignore_lines: true,
        };
        let (models, _materials) = tobj::load_obj_buf(
            &mut tobj_input.as_bytes(),
            &opts,
            // Materials are irrelevant; a missing library must not fail the load.
            |_| Err(tobj::LoadError::OpenFileFailed),
        )
        .map_err(|e| VoxkitError::invalid(format!("{name}: {e}")))?;
        for model in models {
            let m = model.mesh;
            let base = positions.len();
            if base + m.positions.len() / 3 > u32::MAX as usize {
                return Err(VoxkitError::Unsupported(format!(
                    "{name}: more than 2^32 - 1 vertices"
                )));
            }
            positions.extend(
                m.positions
                    .chunks_exact(3)
                    .map(|c| DVec3::new(c[0], c[1], c[2])),
            );
            triangles.extend(
                m.indices
                    .chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]].map(|i| i + base as u32)),
            );
        }
    }

    // Polylines refer to the file's own vertex numbering: append the vertices
    // they use (once each) after tobj's.
    let mut remap: HashMap<usize, u32> = HashMap::new();
    let mut polylines = Vec::with_capacity(pre.polylines.len());
    for line in &pre.polylines {
        let mut out = Vec::with_capacity(line.len());
        for &v in line {
            let idx = *remap.entry(v).or_insert_with(|| {
                positions.push(pre.vertices[v]);
                (positions.len() - 1) as u32
            });
            out.push(idx);
        }
        polylines.push(out);
    }
    Mesh::from_parts_with(name, positions, triangles, polylines, &mut summary)
}

/// What the validating pre-pass collects.
struct Prepass {
    vertices: Vec<DVec3>,
    /// Resolved 0-based vertex indices of each `l` record.
    polylines: Vec<Vec<usize>>,
    /// 0-based line numbers of the `l` records (ascending).
    line_records: Vec<usize>,
    faces: usize,
    points: usize,
}

fn prepass(text: &str, name: &str) -> Result<Prepass> {
    let mut pre = Prepass {
        vertices: Vec::new(),
        polylines: Vec::new(),
        line_records: Vec::new(),
        faces: 0,
        points: 0,
    };
    // Positive indices may refer forward; check them once all `v` are known.
    let mut forward: Vec<(usize, usize)> = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let at = |msg: String| VoxkitError::invalid(format!("{name}: line {}: {msg}", ln + 1));
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let vals: Vec<&str> = words.collect();
                if vals.len() < 3 {
                    return Err(at(format!(
                        "vertex {} needs 3 coordinates, found {}",
                        pre.vertices.len() + 1,
                        vals.len()
                    )));
                }
                let mut c = [0.0f64; 3];
                for (k, s) in vals[..3].iter().enumerate() {
                    c[k] = s.parse::<f64>().map_err(|_| {
                        at(format!(
                            "vertex {}: cannot parse coordinate {s:?}",
                            pre.vertices.len() + 1
                        ))
                    })?;
                }
                let mut p = DVec3::from_array(c);
                if vals.len() == 4 {
                    // Homogeneous `w`, applied as tobj does.
                    let w: f64 = vals[3].parse().map_err(|_| {
                        at(format!(
                            "vertex {}: cannot parse w {:?}",
                            pre.vertices.len() + 1,
                            vals[3]
                        ))
                    })?;
                    if w == 0.0 {
                        return Err(at(format!("vertex {}: w is 0", pre.vertices.len() + 1)));
                    }
                    p /= w;
                }
                if !p.is_finite() {
                    return Err(at(format!(
                        "vertex {} has a non-finite coordinate ({}, {}, {})",
                        pre.vertices.len() + 1,
                        p.x,
                        p.y,
                        p.z
                    )));
                }
                pre.vertices.push(p);
            }
            Some(kind @ ("f" | "l")) => {
                let n = pre.vertices.len();
                let mut idx = Vec::new();
                for w in words {
                    let mut comps = w.split('/');
                    let v = comps.next().unwrap_or("");
                    for extra in comps {
                        if !extra.is_empty() && extra.parse::<isize>().is_err() {
                            return Err(at(format!("cannot parse index {w:?}")));
                        }
                    }
                    let i: i64 = v
                        .parse()
                        .map_err(|_| at(format!("cannot parse vertex index {w:?}")))?;
                    let resolved = if i > 0 {
                        let r = (i - 1) as usize;
                        if r >= n {
                            forward.push((ln, r));
                        }
                        r
                    } else if i < 0 && i.unsigned_abs() as usize <= n {
                        (n as i64 + i) as usize
                    } else {
                        return Err(at(format!(
                            "vertex index {i} is out of range ({n} vertices defined so far)"
                        )));
                    };
                    idx.push(resolved);
                }
                if kind == "f" {
                    if idx.len() < 3 {
                        return Err(at(format!(
                            "face has {} vertices, at least 3 are needed",
                            idx.len()
                        )));
                    }
                    pre.faces += 1;
                } else {
                    pre.line_records.push(ln);
                    pre.polylines.push(idx);
                }
            }
            Some("p") => pre.points += words.count(),
            _ => {}
        }
    }
    let n = pre.vertices.len();
    if let Some(&(ln, r)) = forward.iter().find(|&&(_, r)| r >= n) {
        return Err(VoxkitError::invalid(format!(
            "{name}: line {}: vertex index {} is out of range (the file has {n} vertices)",
            ln + 1,
            r + 1
        )));
    }
    Ok(pre)
}
