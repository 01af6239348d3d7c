//! Stanford PLY input (ascii, binary little and big endian) via `ply-rs-bw`,
//! the maintained fork of `ply-rs`.
//!
//! What is read: the `vertex` element's `x`, `y`, `z` (any scalar type,
//! widened to f64) and the `face` element's `vertex_indices` (or
//! `vertex_index`) list of integers. Every other property (normals, colours,
//! confidence, ...) and every other element (`edge`, `material`, ...) is
//! skipped. Polygons with more than three vertices are fan-triangulated
//! (`0, k, k+1`), as the OBJ loader does.
//!
//! Checked before anything is read from the payload: the header parses, the
//! `vertex` and `face` elements have the properties above, and the bytes the
//! header's element counts need at the very least (binary: the scalar sizes
//! and list counts; ascii: one line of one-character tokens per element)
//! are present, so a header claiming 10^12 vertices fails with a typed error
//! and without allocating; the loader's own buffers are also checked against
//! [`MemoryLimit::DEFAULT`]. After reading: negative or out-of-range
//! indices and faces with fewer than three vertices are errors naming the
//! face. A file without faces (a point cloud) is an empty mesh, an error.
//!
//! Calls into `ply-rs-bw` run under [`crate::guard::contain`]: a panic in it
//! becomes [`VoxkitError::Invalid`].

use std::borrow::Cow;
use std::path::Path;

use glam::DVec3;
use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    BeginList, ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType,
    ScalarType,
};

use super::{LoadSummary, Mesh, clip};
use crate::error::{Result, VoxkitError};
use crate::grid::MemoryLimit;
use crate::guard::contain;

const KRATE: &str = "ply-rs-bw";

/// Loads a `.ply` file. See the module docs.
pub fn load(path: &Path) -> Result<Mesh> {
    let bytes = super::read_file(path)?;
    parse(&bytes, &path.display().to_string())
}

/// Parses PLY bytes (any encoding); `name` prefixes error messages.
///
/// ```
/// let ply = b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
///     property float y\nproperty float z\nproperty uchar red\n\
///     element face 1\nproperty list uchar int vertex_indices\nend_header\n\
///     0 0 0 255\n1 0 0 0\n1 1 0 0\n0 1 0 0\n4 0 1 2 3\n";
/// let m = voxkit::mesh::ply::parse(ply, "quad.ply").unwrap();
/// assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]); // fan-triangulated
/// // A header that claims more vertices than the bytes can hold:
/// let big = String::from_utf8_lossy(ply).replace("vertex 4", "vertex 1000000000000");
/// assert!(voxkit::mesh::ply::parse(big.as_bytes(), "big.ply").is_err());
/// ```
pub fn parse(bytes: &[u8], name: &str) -> Result<Mesh> {
    let mut reader = Reader::new(bytes);
    let header = contain(name, KRATE, || {
        Parser::<Skip>::new().read_header(&mut reader)
    })?
    .map_err(|e| ply_error(name, "header", &e))?;
    let layout = check_header(&header, reader.get_ref().len(), name)?;

    let mut positions: Vec<DVec3> = Vec::new();
    let mut faces: Vec<Face> = Vec::new();
    for (key, def) in &header.elements {
        let what = format!("element `{key}`");
        if *key == layout.vertex {
            let v = contain(name, KRATE, || {
                Parser::<Vertex>::new().read_payload_for_element(&mut reader, def, &header)
            })?
            .map_err(|e| ply_error(name, &what, &e))?;
            positions = v.into_iter().map(|v| v.p).collect();
        } else if *key == layout.face {
            faces = contain(name, KRATE, || {
                Parser::<Face>::new().read_payload_for_element(&mut reader, def, &header)
            })?
            .map_err(|e| ply_error(name, &what, &e))?;
        } else {
            contain(name, KRATE, || {
                Parser::<Skip>::new().read_payload_for_element(&mut reader, def, &header)
            })?
            .map_err(|e| ply_error(name, &what, &e))?;
        }
    }

    let n = positions.len();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        let idx = face.indices(name, f, n)?;
        super::fan(&idx, &mut triangles);
    }
    drop(faces);
    Mesh::from_parts_with(
        name,
        positions,
        triangles,
        Vec::new(),
        &mut LoadSummary::default(),
    )
}

/// A `ply-rs-bw` error as one human line: `FILE: line N: PLY WHAT: what is
/// wrong`. Its messages span several lines, quote whole input lines and
/// embed `Debug` dumps of the grammar's errors (`ParseError { location:
/// LineCol { .. } }`); this keeps the line number and turns the known
/// messages into plain text, quoting at most the offending value.
fn ply_error(name: &str, what: &str, e: &ParseError) -> VoxkitError {
    let at = e.line().map(|l| format!("line {l}: ")).unwrap_or_default();
    VoxkitError::invalid(format!(
        "{name}: {at}PLY {what}: {}",
        ply_message(&e.to_string())
    ))
}

/// The plain-text core of one `ply-rs-bw` message (see [`ply_error`]).
fn ply_message(full: &str) -> String {
    // Display prefixes "Line N: ", which `ply_error` already gave.
    let full = match full.strip_prefix("Line ") {
        Some(r) => r.split_once(": ").map_or(full, |(_, m)| m),
        None => full,
    };
    let quoted = |key: &str| {
        let i = full.find(key)? + key.len();
        let rest = &full[i..];
        let end = rest
            .find("'\n")
            .or_else(|| rest.find("', "))
            .or_else(|| rest.rfind('\''))?;
        Some(clip(rest[..end].trim()))
    };
    let head = full.lines().next().unwrap_or("").trim();
    let eof = |kind: &str| {
        // "... element 'face' (expected 12, got 3)."
        let el = head.split('\'').nth(1).unwrap_or("?");
        let nums: Vec<&str> = head
            .rsplit_once('(')
            .map(|(_, r)| {
                r.split(|c: char| !c.is_ascii_digit())
                    .filter(|w| !w.is_empty())
                    .collect()
            })
            .unwrap_or_default();
        match nums.as_slice() {
            [want, got] => {
                format!("the file ends after {got} of {want} {kind}`{el}` elements (truncated?)")
            }
            _ => format!("the file ends inside {kind}element `{el}` (truncated?)"),
        }
    };
    if head.starts_with("Expected magic number") {
        return match quoted("String: '") {
            Some(l) => format!("not a PLY file: the first line is `{l}`, not `ply`"),
            None => "not a PLY file: the first line is not `ply`".into(),
        };
    }
    if head.starts_with("Unexpected end of file while reading binary element") {
        return eof("binary ");
    }
    if head.starts_with("Unexpected end of file while reading element") {
        return eof("");
    }
    if head.starts_with("Unexpected end of file while reading header") {
        return "the header has no `end_header` line".into();
    }
    if head.starts_with("Unexpected end of file") {
        return "the file ends early (truncated?)".into();
    }
    if head.starts_with("Couldn't parse line.") {
        return match quoted("String: ") {
            Some(l) => format!("cannot parse header line `{}`", l.trim_matches('\'')),
            None => "cannot parse a header line".into(),
        };
    }
    if head.starts_with("Couldn't read element line.")
        || head.starts_with("Couldn't parse element line")
    {
        if let Some(v) = quoted("Value: '") {
            return format!("cannot parse value `{v}`");
        }
        if full.contains("but found nothing") {
            return "too few values on the line".into();
        }
        if let Some(i) = full.find("Couldn't parse element at index ") {
            let k: String = full[i + 32..]
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            return format!("list entry {k} is not a number");
        }
        if full.contains("Expected") && full.contains("list elements") {
            return "a list has fewer entries than its count".into();
        }
        return match quoted("String: '") {
            Some(l) => format!("cannot parse the line `{l}`"),
            None => "cannot parse an element line".into(),
        };
    }
    if head.starts_with("Property") && head.contains("without preceding element") {
        return "a `property` line comes before any `element` line".into();
    }
    if head.starts_with("Found contradicting format") {
        return "two different `format` lines".into();
    }
    // Anything else: its first line, cut before any `Debug` dump.
    let cut = head
        .find('{')
        .and_then(|b| head[..b].rfind(": "))
        .map_or(head, |i| &head[..i]);
    clip(cut)
}

/// The names of the elements the mesh comes from.
struct Layout {
    vertex: String,
    face: String,
}

/// The face list property names voxkit reads (`vertex_index` is the older
/// spelling some exporters use).
const FACE_LISTS: [&str; 2] = ["vertex_indices", "vertex_index"];

fn scalar_bytes(t: &ScalarType) -> u128 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The fewest payload bytes one element of `def` can take.
fn min_element_bytes(def: &ElementDef, encoding: &Encoding) -> u128 {
    let props = def.properties.len() as u128;
    match encoding {
        // One token of at least one character and one separator (or the
        // newline) per property; an element with none still takes a line.
        Encoding::Ascii => (2 * props).max(1),
        Encoding::BinaryBigEndian | Encoding::BinaryLittleEndian => def
            .properties
            .values()
            .map(|p| match &p.data_type {
                PropertyType::Scalar(t) => scalar_bytes(t),
                PropertyType::List(count, _) => scalar_bytes(count),
            })
            .sum::<u128>()
            // Zero-size elements still cost a loop step each: count them as
            // one byte so their number is bounded by the input too.
            .max(1),
    }
}

/// Checks the header against what voxkit reads and against the bytes that
/// follow it (see the module docs).
fn check_header(header: &Header, payload: usize, name: &str) -> Result<Layout> {
    let err = |msg: String| VoxkitError::invalid(format!("{name}: PLY header: {msg}"));
    let mut need: u128 = 0;
    for (key, def) in &header.elements {
        let min = min_element_bytes(def, &header.encoding);
        let bytes = (def.count as u128).saturating_mul(min);
        need = need.saturating_add(bytes);
        // The last ascii line may lack its newline.
        let slack = u128::from(matches!(header.encoding, Encoding::Ascii));
        if need > payload as u128 + slack {
            return Err(err(format!(
                "{} `{key}` elements need at least {bytes} bytes, but only {payload} bytes \
                 follow the header (in all)",
                def.count
            )));
        }
    }
    let vertex = header
        .elements
        .get("vertex")
        .ok_or_else(|| err("no `vertex` element".to_string()))?;
    for axis in ["x", "y", "z"] {
        match vertex.properties.get(axis).map(|p| &p.data_type) {
            Some(PropertyType::Scalar(_)) => {}
            Some(PropertyType::List(..)) => {
                return Err(err(format!("vertex property `{axis}` is a list")));
            }
            None => return Err(err(format!("the `vertex` element has no `{axis}`"))),
        }
    }
    let face = header.elements.get("face").ok_or_else(|| {
        err("no `face` element: a point cloud has no surface to voxelize".to_string())
    })?;
    let lists: Vec<_> = FACE_LISTS
        .iter()
        .filter_map(|n| face.properties.get(*n))
        .collect();
    match lists[..] {
        [p] => match &p.data_type {
            PropertyType::List(_, ScalarType::Float | ScalarType::Double) => {
                return Err(err(format!("face list `{}` holds floats", p.name)));
            }
            PropertyType::List(..) => {}
            PropertyType::Scalar(_) => {
                return Err(err(format!("face property `{}` is not a list", p.name)));
            }
        },
        [] => {
            return Err(err(
                "the `face` element has no `vertex_indices` list".to_string()
            ));
        }
        _ => {
            return Err(err(
                "the `face` element has both `vertex_indices` and `vertex_index`".to_string(),
            ));
        }
    }
    // Our own buffers (the payload bound above already caps them at a
    // constant times the input; this keeps a huge input within the limit).
    let limit = MemoryLimit::DEFAULT;
    limit.check(
        &format!("{name}: PLY vertices"),
        vertex.count as u128,
        std::mem::size_of::<Vertex>() as u128 * 2,
    )?;
    limit.check(
        &format!("{name}: PLY faces"),
        face.count as u128,
        std::mem::size_of::<Face>() as u128 * 2,
    )?;
    Ok(Layout {
        vertex: vertex.name.clone(),
        face: face.name.clone(),
    })
}

/// An element whose values voxkit does not need.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// A `vertex` element: its position, every other property ignored.
struct Vertex {
    p: DVec3,
}

impl Vertex {
    fn set(&mut self, key: &str, v: f64) -> PropertyAccessResult {
        match key {
            "x" => self.p.x = v,
            "y" => self.p.y = v,
            "z" => self.p.z = v,
            _ => return PropertyAccessResult::Ignored,
        }
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex { p: DVec3::ZERO }
    }
    fn set_char(&mut self, key: &str, v: i8) -> PropertyAccessResult {
        self.set(key, v.into())
    }
    fn set_uchar(&mut self, key: &str, v: u8) -> PropertyAccessResult {
        self.set(key, v.into())
    }
    fn set_short(&mut self, key: &str, v: i16) -> PropertyAccessResult {
        self.set(key, v.into())
    }
    fn set_ushort(&mut self, key: &str, v: u16) -> PropertyAccessResult {
        self.set(key, v.into())
    }
    fn set_int(&mut self, key: &str, v: i32) -> PropertyAccessResult {
        self.set(key, v.into())
    }
    fn set_uint(&mut self, key: &str, v: u32) -> PropertyAccessResult {
        self.set(key, v.into())
    }
    fn set_float(&mut self, key: &str, v: f32) -> PropertyAccessResult {
        self.set(key, v.into())
    }
    fn set_double(&mut self, key: &str, v: f64) -> PropertyAccessResult {
        self.set(key, v)
    }
}

/// A `face` element's index list. `int` and `uint` lists (nearly every file)
/// are filled in place; the narrower types arrive through the setters.
struct Face {
    unsigned: Vec<u32>,
    signed: Vec<i32>,
}

fn is_face_list(key: &str) -> bool {
    FACE_LISTS.contains(&key)
}

impl Face {
    /// The face's indices, checked: none negative, none `>= n`, at least
    /// three of them.
    fn indices(&self, name: &str, f: usize, n: usize) -> Result<Cow<'_, [u32]>> {
        let err = |msg: String| VoxkitError::invalid(format!("{name}: PLY face {f}: {msg}"));
        let idx: Cow<'_, [u32]> = if self.signed.is_empty() {
            Cow::Borrowed(&self.unsigned)
        } else {
            let mut out = Vec::with_capacity(self.signed.len());
            for &i in &self.signed {
                out.push(u32::try_from(i).map_err(|_| err(format!("negative vertex index {i}")))?);
            }
            Cow::Owned(out)
        };
        if idx.len() < 3 {
            return Err(err(format!(
                "{} vertices; a face needs at least 3",
                idx.len()
            )));
        }
        if let Some(&i) = idx.iter().find(|&&i| i as usize >= n) {
            return Err(err(format!("vertex index {i}, but there are {n} vertices")));
        }
        Ok(idx)
    }

    fn set_signed(&mut self, key: &str, v: impl Iterator<Item = i32>) -> PropertyAccessResult {
        if is_face_list(key) {
            self.signed = v.collect();
            // Non-empty `signed` marks the list as signed; an empty list is
            // empty either way.
            self.unsigned.clear();
            PropertyAccessResult::Set
        } else {
            PropertyAccessResult::Ignored
        }
    }

    fn set_unsigned(&mut self, key: &str, v: impl Iterator<Item = u32>) -> PropertyAccessResult {
        if is_face_list(key) {
            self.unsigned = v.collect();
            self.signed.clear();
            PropertyAccessResult::Set
        } else {
            PropertyAccessResult::Ignored
        }
    }
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face {
            unsigned: Vec::new(),
            signed: Vec::new(),
        }
    }
    fn begin_list_int(&mut self, key: &str, _len: usize) -> BeginList<'_, i32> {
        if is_face_list(key) {
            self.unsigned.clear();
            BeginList::Fill(&mut self.signed)
        } else {
            BeginList::UseSetter
        }
    }
    fn begin_list_uint(&mut self, key: &str, _len: usize) -> BeginList<'_, u32> {
        if is_face_list(key) {
            self.signed.clear();
            BeginList::Fill(&mut self.unsigned)
        } else {
            BeginList::UseSetter
        }
    }
    fn set_list_char(&mut self, key: &str, v: Vec<i8>) -> PropertyAccessResult {
        self.set_signed(key, v.into_iter().map(i32::from))
    }
    fn set_list_uchar(&mut self, key: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.set_unsigned(key, v.into_iter().map(u32::from))
    }
    fn set_list_short(&mut self, key: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.set_signed(key, v.into_iter().map(i32::from))
    }
    fn set_list_ushort(&mut self, key: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.set_unsigned(key, v.into_iter().map(u32::from))
    }
    fn set_list_int(&mut self, key: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.set_signed(key, v.into_iter())
    }
    fn set_list_uint(&mut self, key: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.set_unsigned(key, v.into_iter())
    }
}
