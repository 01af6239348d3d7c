//! glTF 2.0 input (`.gltf` with external or data-URI buffers, and `.glb`)
//! via the `gltf` crate.
//!
//! Reads every primitive of the default scene (scene 0 when none is marked
//! default), walking the node tree recursively and applying node transforms
//! (TRS composed in f64) to the vertices, so an instanced mesh contributes
//! one copy per node. A file with no scene at all (the spec allows it: a
//! library of assets) reads every root node, or, with no nodes either, every
//! mesh once untransformed, with a warning saying so; a scene without nodes
//! is refused as empty. Buffers are loaded (data URIs, external `.bin`, the
//! GLB binary chunk); images are never decoded.
//!
//! Primitive modes: `TRIANGLES` as is; `TRIANGLE_STRIP` and `TRIANGLE_FAN`
//! converted to triangles; `LINES`, `LINE_STRIP`, `LINE_LOOP` become
//! polylines; `POINTS` are skipped and counted. Accessors are checked against
//! their buffer views and buffers before they are read (a truncated `.bin`
//! is an error, not a panic).
//!
//! Accessors: sparse ones (core glTF 2.0, with or without a base buffer
//! view) are read through the `gltf` crate's sparse iterator after their
//! index and value views are checked (indices must increase strictly and
//! stay below the count). Positions may be `float`, or, as
//! `KHR_mesh_quantization` allows, `(unsigned) byte` / `short`, normalized
//! or not: the crate's `read_positions` reads every position as `f32` bytes,
//! so integer positions are read with its typed iterator and dequantized
//! here (normalized: `c / 255`, `c / 65535`, `max(c / 127, -1)`,
//! `max(c / 32767, -1)`, the spec's formulas); the node transform (usually a
//! scale) then maps them to the model's units.
//!
//! Extensions: a file's `extensionsRequired` is checked before the crate
//! validates it (which would reject every required extension in a long
//! JSON error). Refused in one line naming the extension and what to do:
//! `KHR_draco_mesh_compression` (also when only used but a primitive's
//! positions exist only compressed), `EXT_meshopt_compression` views whose
//! fallback buffer has no data, and any other required extension that
//! changes geometry. Read: `KHR_mesh_quantization`; `EXT_meshopt_compression`
//! whose uncompressed fallback buffers carry the data (gltfpack `-cf`);
//! required material, texture and light extensions, which do not change the
//! geometry (ignored, with a warning).
//!
//! [`load`] reads a file; [`parse`] takes the bytes (and, optionally, the
//! folder external buffers are read from). The `gltf` crate's parsing,
//! validation, buffer import and accessor reads run under
//! [`crate::guard::contain`]: its validator, for one, indexes `accessors[i]`
//! with the file's `POSITION` index before checking it, which used to end
//! the process (exit 101) and is now a typed error.

use std::path::Path;

use glam::{DMat4, DQuat, DVec3};
use gltf::mesh::Mode;

use super::{LoadSummary, Mesh};
use crate::error::{Result, VoxkitError};
use crate::guard::contain;

/// Loads a `.gltf` or `.glb` file: reads it and calls [`parse`] with the
/// file's folder as the base for external buffers.
pub fn load(path: &Path) -> Result<Mesh> {
    let name = path.display().to_string();
    let bytes = super::read_file(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse(&bytes, Some(base), &name)
}

/// Parses glTF JSON or GLB bytes; `name` prefixes error messages. External
/// buffer URIs are resolved against `base_dir`; with `None` they are an error
/// (data URIs and the GLB binary chunk need no folder). A panic inside the
/// `gltf` crate is contained ([`crate::guard::contain`]) and becomes
/// [`VoxkitError::Invalid`].
///
/// ```
/// // A triangle as glTF JSON, its buffer (three f32 VEC3) in a data URI.
/// let json = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
///   "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
///   "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
///                 "min":[0,0,0],"max":[1,1,0]}],
///   "bufferViews":[{"buffer":0,"byteLength":36}],
///   "buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]}"#;
/// let m = voxkit::mesh::gltf::parse(json.as_bytes(), None, "tri.gltf").unwrap();
/// assert_eq!(m.triangles.len(), 1);
/// // The same document with an external buffer needs a folder to read it from.
/// let ext = json.replace("data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA", "tri.bin");
/// assert!(voxkit::mesh::gltf::parse(ext.as_bytes(), None, "tri.gltf").is_err());
/// // An out-of-range accessor index makes the gltf crate's validator panic:
/// // contained, it is a typed error.
/// let bad = json.replace(r#""POSITION":0"#, r#""POSITION":7"#);
/// let err = voxkit::mesh::gltf::parse(bad.as_bytes(), None, "bad.gltf").unwrap_err();
/// assert!(err.to_string().contains("the gltf reader failed on this input"), "{err}");
/// ```
pub fn parse(bytes: &[u8], base_dir: Option<&Path>, name: &str) -> Result<Mesh> {
    let (json, blob) = if bytes.starts_with(b"glTF") {
        let glb = contain(name, "gltf", || {
            gltf::binary::Glb::from_slice(bytes)
                .map(|g| (g.json.into_owned(), g.bin.map(|b| b.into_owned())))
        })?
        .map_err(|e| VoxkitError::invalid(format!("{name}: GLB container: {e}")))?;
        (std::borrow::Cow::Owned(glb.0), glb.1)
    } else {
        (std::borrow::Cow::Borrowed(bytes), None)
    };
    let mut summary = LoadSummary::default();
    let pre = preflight(&json, name, &mut summary)?;
    let root = contain(name, "gltf", || match &pre.json {
        Some(fixed) => gltf::json::deserialize::from_slice::<gltf::json::Root>(fixed),
        None => gltf::json::deserialize::from_slice::<gltf::json::Root>(&json),
    })?
    .map_err(|e| VoxkitError::invalid(format!("{name}: glTF JSON: {e}")))?;
    let doc = contain(name, "gltf", || gltf::Document::from_json(root))?
        .map_err(|e| VoxkitError::invalid(format!("{name}: {}", describe(&e))))?;
    let buffers = import_buffers(&doc, base_dir, blob, &pre.dataless, name)?;

    let mut acc = Collect {
        name,
        buffers: &buffers,
        dataless: &pre.dataless,
        positions: Vec::new(),
        triangles: Vec::new(),
        polylines: Vec::new(),
        summary,
        max_depth: doc.nodes().len(),
    };
    match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => {
            if scene.nodes().len() == 0 {
                return Err(VoxkitError::invalid(format!(
                    "{name}: scene {} is empty (it has no nodes): nothing to load",
                    scene.index()
                )));
            }
            for node in scene.nodes() {
                acc.node(&node, DMat4::IDENTITY, 0)?;
            }
        }
        None => acc.without_scene(&doc)?,
    }
    let Collect {
        positions,
        triangles,
        polylines,
        mut summary,
        ..
    } = acc;
    Mesh::from_parts_with(name, positions, triangles, polylines, &mut summary)
}

/// What [`preflight`] found: the JSON to parse instead of the file's (when
/// it had to be adjusted), and the buffers that hold no data (meshopt
/// fallbacks).
struct Preflight {
    json: Option<Vec<u8>>,
    dataless: Vec<usize>,
}

/// Extensions that change only materials, textures, lights or metadata:
/// required or not, the geometry reads the same without them.
fn geometry_neutral(ext: &str) -> bool {
    ext.starts_with("KHR_materials_")
        || ext.starts_with("KHR_texture_")
        || ext.starts_with("EXT_texture_")
        || matches!(
            ext,
            "KHR_lights_punctual"
                | "EXT_lights_image_based"
                | "MSFT_texture_dds"
                | "KHR_xmp_json_ld"
        )
}

/// The meshopt extension names (the EXT and its KHR successor).
const MESHOPT: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];
const DRACO: &str = "KHR_draco_mesh_compression";

fn draco_refusal(name: &str, place: &str) -> VoxkitError {
    VoxkitError::Unsupported(format!(
        "{name}: {place} uses {DRACO} (Draco-compressed geometry), which voxkit does not \
         decode; re-export without Draco compression"
    ))
}

/// Checks the file's extensions on its raw JSON, before the `gltf` crate
/// sees it, and adjusts what the crate would refuse although the file is
/// valid: `extensionsRequired` (the crate knows none of the extensions
/// voxkit reads) and scenes without `nodes` (optional in the spec, required
/// by the crate's types). Refuses, in one line, what voxkit cannot read.
fn preflight(json: &[u8], name: &str, summary: &mut LoadSummary) -> Result<Preflight> {
    use serde_json::Value;
    let mut v: Value = serde_json::from_slice(json)
        .map_err(|e| VoxkitError::invalid(format!("{name}: glTF JSON: {e}")))?;
    let mut changed = false;
    let required: Vec<String> = v
        .get("extensionsRequired")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .filter_map(|e| e.as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default();
    if required.iter().any(|e| e == DRACO) {
        return Err(draco_refusal(name, "the file"));
    }
    for ext in &required {
        if ext == "KHR_mesh_quantization" || MESHOPT.contains(&ext.as_str()) {
            continue;
        }
        if geometry_neutral(ext) {
            summary.warnings.push(format!(
                "ignored required extension {ext} (it does not change the geometry)"
            ));
            continue;
        }
        return Err(VoxkitError::Unsupported(format!(
            "{name}: the file requires the glTF extension {ext}, which voxkit does not read; \
             re-export without it"
        )));
    }
    // Draco used but not required: the primitives keep uncompressed
    // accessors, unless their positions exist only compressed.
    let accessors = v.get("accessors").and_then(Value::as_array);
    for (mi, mesh) in array(&v, "meshes").iter().enumerate() {
        for (pi, prim) in array(mesh, "primitives").iter().enumerate() {
            if prim.pointer(&format!("/extensions/{DRACO}")).is_none() {
                continue;
            }
            let pos = prim
                .pointer("/attributes/POSITION")
                .and_then(Value::as_u64)
                .and_then(|i| accessors.and_then(|a| a.get(i as usize)));
            if pos.is_none_or(|a| a.get("bufferView").is_none() && a.get("sparse").is_none()) {
                return Err(draco_refusal(name, &format!("mesh {mi} primitive {pi}")));
            }
        }
    }
    // Meshopt fallback buffers marked `fallback: true` carry no data unless
    // they have a URI (gltfpack `-cf` writes one); reading a view of a
    // dataless one is refused where it happens (`check_view`).
    let dataless: Vec<usize> = array(&v, "buffers")
        .iter()
        .enumerate()
        .filter(|(_, b)| {
            b.get("uri").is_none()
                && MESHOPT.iter().any(|m| {
                    b.pointer(&format!("/extensions/{m}/fallback"))
                        .and_then(Value::as_bool)
                        == Some(true)
                })
        })
        .map(|(i, _)| i)
        .collect();
    if !required.is_empty() {
        v["extensionsRequired"] = Value::Array(Vec::new());
        changed = true;
    }
    if let Some(scenes) = v.get_mut("scenes").and_then(Value::as_array_mut) {
        for s in scenes.iter_mut().filter_map(Value::as_object_mut) {
            if !s.contains_key("nodes") {
                s.insert("nodes".into(), Value::Array(Vec::new()));
                changed = true;
            }
        }
    }
    let json = changed.then(|| serde_json::to_vec(&v).expect("a parsed JSON value serializes"));
    Ok(Preflight { json, dataless })
}

/// `v[key]` as a slice (empty when absent or not an array).
fn array<'v>(v: &'v serde_json::Value, key: &str) -> &'v [serde_json::Value] {
    v.get(key)
        .and_then(serde_json::Value::as_array)
        .map_or(&[], Vec::as_slice)
}

/// One line for a `gltf` crate error: a validation report lists every
/// problem (thousands on a broken file), so only the first is named.
fn describe(e: &gltf::Error) -> String {
    match e {
        gltf::Error::Validation(list) if !list.is_empty() => {
            let (path, err) = &list[0];
            let more = match list.len() - 1 {
                0 => String::new(),
                1 => " (and 1 more problem)".to_string(),
                n => format!(" (and {n} more problems)"),
            };
            format!("invalid glTF: {path}: {err}{more}")
        }
        other => format!("glTF: {other}"),
    }
}

/// The buffers' bytes: data URIs, external files (relative to `base`), the
/// GLB binary chunk. A dataless meshopt fallback gets no bytes (and must not
/// take the GLB chunk, which the crate gives to any buffer without a URI).
fn import_buffers(
    doc: &gltf::Document,
    base: Option<&Path>,
    mut blob: Option<Vec<u8>>,
    dataless: &[usize],
    name: &str,
) -> Result<Vec<gltf::buffer::Data>> {
    let mut out = Vec::with_capacity(doc.buffers().len());
    for b in doc.buffers() {
        if dataless.contains(&b.index()) {
            out.push(gltf::buffer::Data(Vec::new()));
            continue;
        }
        let data = contain(name, "gltf", || {
            gltf::buffer::Data::from_source_and_blob(b.source(), base, &mut blob)
        })?
        .map_err(|e| {
            let src = match b.source() {
                gltf::buffer::Source::Uri(u) if u.starts_with("data:") => " (data URI)".to_string(),
                gltf::buffer::Source::Uri(u) => format!(" ({u})"),
                gltf::buffer::Source::Bin => " (GLB binary chunk)".to_string(),
            };
            VoxkitError::invalid(format!("{name}: buffer {}{src}: {e}", b.index()))
        })?;
        if data.len() < b.length() {
            return Err(VoxkitError::invalid(format!(
                "{name}: buffer {} has {} bytes, the file declares {}",
                b.index(),
                data.len(),
                b.length()
            )));
        }
        out.push(data);
    }
    Ok(out)
}

struct Collect<'a> {
    name: &'a str,
    buffers: &'a [gltf::buffer::Data],
    /// Buffers without data (meshopt fallbacks).
    dataless: &'a [usize],
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    polylines: Vec<Vec<u32>>,
    summary: LoadSummary,
    /// A tree cannot be deeper than it has nodes: deeper means a cycle.
    max_depth: usize,
}

/// A node's local transform in f64.
fn local_matrix(node: &gltf::Node) -> DMat4 {
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => DMat4::from_scale_rotation_translation(
            DVec3::from_array(scale.map(f64::from)),
            DQuat::from_array(rotation.map(f64::from)).normalize(),
            DVec3::from_array(translation.map(f64::from)),
        ),
    }
}

impl Collect<'_> {
    fn node(&mut self, node: &gltf::Node, parent: DMat4, depth: usize) -> Result<()> {
        if depth > self.max_depth {
            return Err(VoxkitError::invalid(format!(
                "{}: node {} is part of a cycle in the node hierarchy",
                self.name,
                node.index()
            )));
        }
        let world = parent * local_matrix(node);
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                self.primitive(&prim, &world, mesh.index(), Some(node.index()))?;
            }
        }
        for child in node.children() {
            self.node(&child, world, depth + 1)?;
        }
        Ok(())
    }

    /// A file without scenes: every root node (a node no other node lists as
    /// a child) with its subtree, or, without nodes, every mesh once.
    fn without_scene(&mut self, doc: &gltf::Document) -> Result<()> {
        let name = self.name;
        if doc.nodes().len() > 0 {
            let mut is_child = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            let roots: Vec<gltf::Node> = doc.nodes().filter(|n| !is_child[n.index()]).collect();
            if roots.is_empty() {
                return Err(VoxkitError::invalid(format!(
                    "{name}: the file has no scene, and every node is another's child (a cycle)"
                )));
            }
            self.summary.warnings.push(format!(
                "the file has no scene: read its {} root node{}",
                roots.len(),
                if roots.len() == 1 { "" } else { "s" }
            ));
            for n in roots {
                self.node(&n, DMat4::IDENTITY, 0)?;
            }
            return Ok(());
        }
        if doc.meshes().len() == 0 {
            return Err(VoxkitError::invalid(format!(
                "{name}: the file has no scene and no meshes: nothing to load"
            )));
        }
        self.summary.warnings.push(format!(
            "the file has no scene and no nodes: read each of its {} mesh{} once, untransformed",
            doc.meshes().len(),
            if doc.meshes().len() == 1 { "" } else { "es" }
        ));
        for mesh in doc.meshes() {
            for prim in mesh.primitives() {
                self.primitive(&prim, &DMat4::IDENTITY, mesh.index(), None)?;
            }
        }
        Ok(())
    }

    fn primitive(
        &mut self,
        prim: &gltf::Primitive,
        world: &DMat4,
        mesh: usize,
        node: Option<usize>,
    ) -> Result<()> {
        let what = match node {
            Some(n) => format!(
                "{}: mesh {mesh} primitive {} (node {n})",
                self.name,
                prim.index()
            ),
            None => format!("{}: mesh {mesh} primitive {}", self.name, prim.index()),
        };
        let pos_acc = prim
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| VoxkitError::invalid(format!("{what}: no POSITION attribute")))?;
        {
            use gltf::accessor::DataType::*;
            if !matches!(pos_acc.data_type(), F32 | I8 | U8 | I16 | U16)
                || pos_acc.dimensions() != gltf::accessor::Dimensions::Vec3
            {
                return Err(VoxkitError::invalid(format!(
                    "{what}: POSITION accessor {} is {:?} {:?}; positions are VEC3 of float, or of \
                     (unsigned) byte or short (KHR_mesh_quantization)",
                    pos_acc.index(),
                    pos_acc.dimensions(),
                    pos_acc.data_type()
                )));
            }
        }
        self.check_accessor(&pos_acc, &what)?;
        let idx_acc = prim.indices();
        if let Some(a) = &idx_acc {
            use gltf::accessor::DataType::*;
            if !matches!(a.data_type(), U8 | U16 | U32)
                || a.dimensions() != gltf::accessor::Dimensions::Scalar
            {
                return Err(VoxkitError::invalid(format!(
                    "{what}: indices must be unsigned integer scalars"
                )));
            }
            self.check_accessor(a, &what)?;
        }
        let local: Vec<DVec3> = self
            .read_positions(&pos_acc, &what)?
            .into_iter()
            .map(|p| world.transform_point3(p))
            .collect();
        let n = local.len();
        let indices: Vec<u32> = match idx_acc {
            Some(a) if a.count() == 0 => Vec::new(),
            Some(_) => {
                let buffers = self.buffers;
                let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                contain(self.name, "gltf", || {
                    reader
                        .read_indices()
                        .map(|ix| ix.into_u32().collect::<Vec<_>>())
                })?
                .ok_or_else(|| VoxkitError::invalid(format!("{what}: unreadable indices")))?
            }
            None => (0..n as u32).collect(),
        };
        if let Some((k, &i)) = indices.iter().enumerate().find(|&(_, &i)| i as usize >= n) {
            return Err(VoxkitError::invalid(format!(
                "{what}: index {k} is {i}, but the primitive has {n} vertices"
            )));
        }
        let base = self.positions.len();
        if base + n > u32::MAX as usize {
            return Err(VoxkitError::Unsupported(format!(
                "{what}: more than 2^32 - 1 vertices in total"
            )));
        }
        let b = base as u32;
        let ix = &indices;
        let group = match prim.mode() {
            Mode::Triangles => 3,
            Mode::Lines => 2,
            _ => 1,
        };
        if !ix.len().is_multiple_of(group) {
            return Err(VoxkitError::invalid(format!(
                "{what}: {} indices is not a multiple of {group} for mode {:?}",
                ix.len(),
                prim.mode()
            )));
        }
        match prim.mode() {
            Mode::Triangles => self
                .triangles
                .extend(ix.chunks_exact(3).map(|c| [c[0] + b, c[1] + b, c[2] + b])),
            Mode::TriangleStrip => {
                for k in 0..ix.len().saturating_sub(2) {
                    // Alternate the winding as the spec does.
                    let t = if k % 2 == 0 {
                        [ix[k], ix[k + 1], ix[k + 2]]
                    } else {
                        [ix[k + 1], ix[k], ix[k + 2]]
                    };
                    self.triangles.push(t.map(|i| i + b));
                }
            }
            Mode::TriangleFan => {
                for k in 1..ix.len().saturating_sub(1) {
                    self.triangles.push([ix[0] + b, ix[k] + b, ix[k + 1] + b]);
                }
            }
            Mode::Lines => self
                .polylines
                .extend(ix.chunks_exact(2).map(|c| vec![c[0] + b, c[1] + b])),
            Mode::LineStrip => self.polylines.push(ix.iter().map(|i| i + b).collect()),
            Mode::LineLoop => {
                let mut l: Vec<u32> = ix.iter().map(|i| i + b).collect();
                if let Some(&first) = l.first() {
                    l.push(first);
                }
                self.polylines.push(l);
            }
            Mode::Points => {
                self.summary.skipped_points += ix.len();
                return Ok(());
            }
        }
        self.positions.extend(local);
        Ok(())
    }

    /// A (checked) POSITION accessor's values in f64, dequantized: float
    /// as is; integer components as integers, or, normalized, by the glTF
    /// spec's formulas (`c / (2^n - 1)` unsigned, `max(c / (2^(n-1) - 1),
    /// -1)` signed). Dense and sparse accessors both go through the `gltf`
    /// crate's typed iterator.
    fn read_positions(&self, a: &gltf::Accessor, what: &str) -> Result<Vec<DVec3>> {
        use gltf::accessor::{DataType, Iter};
        if a.count() == 0 {
            return Ok(Vec::new());
        }
        let buffers = self.buffers;
        let norm = a.normalized();
        fn read<T>(
            a: &gltf::Accessor,
            buffers: &[gltf::buffer::Data],
            scale: Option<f64>,
        ) -> Option<Vec<DVec3>>
        where
            T: gltf::accessor::Item + Copy + Into<f64>,
        {
            let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| &d.0[..]);
            let it = Iter::<[T; 3]>::new(a.clone(), get)?;
            Some(
                it.map(|p| {
                    let v = DVec3::from_array(p.map(Into::into));
                    match scale {
                        Some(s) => (v / s).max(DVec3::NEG_ONE),
                        None => v,
                    }
                })
                .collect(),
            )
        }
        let out = contain(self.name, "gltf", || {
            let s = |max: f64| norm.then_some(max);
            match a.data_type() {
                DataType::F32 => read::<f32>(a, buffers, None),
                DataType::I8 => read::<i8>(a, buffers, s(127.0)),
                DataType::U8 => read::<u8>(a, buffers, s(255.0)),
                DataType::I16 => read::<i16>(a, buffers, s(32767.0)),
                DataType::U16 => read::<u16>(a, buffers, s(65535.0)),
                DataType::U32 => None,
            }
        })?;
        let out = out.ok_or_else(|| {
            VoxkitError::invalid(format!(
                "{what}: accessor {}: unreadable POSITION",
                a.index()
            ))
        })?;
        if out.len() != a.count() {
            return Err(VoxkitError::invalid(format!(
                "{what}: accessor {}: read {} positions of {}",
                a.index(),
                out.len(),
                a.count()
            )));
        }
        Ok(out)
    }

    /// Checks that every byte an accessor reads lies inside its views and
    /// buffers, sparse parts included, and that sparse indices increase
    /// strictly below the count (the crate's iterator would silently skip
    /// others).
    fn check_accessor(&self, a: &gltf::Accessor, what: &str) -> Result<()> {
        let err =
            |msg: String| VoxkitError::invalid(format!("{what}: accessor {}: {msg}", a.index()));
        let size = a.size() as u128;
        match a.view() {
            Some(view) => self.check_view(&view, a.offset(), a.count(), size, what, a.index())?,
            None if a.sparse().is_none() => {
                return Err(err("has no buffer view and is not sparse".to_string()));
            }
            None => {}
        }
        let Some(sp) = a.sparse() else {
            return Ok(());
        };
        let n = sp.count();
        if n == 0 || n > a.count() {
            return Err(err(format!(
                "sparse count {n} outside 1..={} (the accessor's count)",
                a.count()
            )));
        }
        let iv = sp.indices().view();
        let isize = sp.indices().index_type().size();
        self.check_view(
            &iv,
            sp.indices().offset(),
            n,
            isize as u128,
            what,
            a.index(),
        )?;
        let vv = sp.values().view();
        self.check_view(&vv, sp.values().offset(), n, size, what, a.index())?;
        // Indices: strictly increasing, below the count.
        let data = &self.buffers[iv.buffer().index()].0;
        let stride = iv.stride().unwrap_or(isize);
        let start = iv.offset() + sp.indices().offset();
        let mut prev: Option<u64> = None;
        for k in 0..n {
            let p = start + k * stride;
            let b = &data[p..p + isize];
            let i = match isize {
                1 => u64::from(b[0]),
                2 => u64::from(u16::from_le_bytes([b[0], b[1]])),
                _ => u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            };
            if i >= a.count() as u64 || prev.is_some_and(|q| i <= q) {
                return Err(err(format!(
                    "sparse index {k} is {i}; sparse indices must increase strictly and stay below \
                     the count {}",
                    a.count()
                )));
            }
            prev = Some(i);
        }
        Ok(())
    }

    /// Checks that `count` elements of `size` bytes from `offset` in `view`
    /// (its stride, or packed) lie inside the view, and the view inside its
    /// buffer (a dataless meshopt fallback is refused here, where it is
    /// read).
    fn check_view(
        &self,
        view: &gltf::buffer::View,
        offset: usize,
        count: usize,
        size: u128,
        what: &str,
        accessor: usize,
    ) -> Result<()> {
        let err = |msg: String| VoxkitError::invalid(format!("{what}: accessor {accessor}: {msg}"));
        let bi = view.buffer().index();
        if self.dataless.contains(&bi) {
            return Err(VoxkitError::Unsupported(format!(
                "{what}: accessor {accessor}: buffer view {} is meshopt-compressed and its fallback \
                 buffer {bi} has no data; voxkit does not decode EXT_meshopt_compression: re-export \
                 without it, or with uncompressed fallback data (gltfpack -cf)",
                view.index()
            )));
        }
        let data = self
            .buffers
            .get(bi)
            .ok_or_else(|| err(format!("buffer {bi} is missing")))?;
        let view_end = view.offset() as u128 + view.length() as u128;
        if view_end > data.len() as u128 {
            return Err(err(format!(
                "buffer view {} ends at byte {view_end}, past the {} bytes of buffer {bi}",
                view.index(),
                data.len(),
            )));
        }
        let stride = view.stride().map_or(size, |s| s as u128);
        if count > 0 {
            let last = offset as u128 + (count as u128 - 1) * stride + size;
            if last > view.length() as u128 {
                return Err(err(format!(
                    "{count} elements need {last} bytes, buffer view {} has {}",
                    view.index(),
                    view.length()
                )));
            }
        }
        Ok(())
    }
}
