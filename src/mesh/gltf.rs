//! glTF 2.0 input (`.gltf` with external or data-URI buffers, and `.glb`)
//! via the `gltf` crate.
//!
//! Reads every primitive of the default scene (scene 0 when none is marked
//! default), walking the node tree recursively and applying node transforms
//! (TRS composed in f64) to the vertices, so an instanced mesh contributes
//! one copy per node. Buffers are loaded (data URIs, external `.bin`, the GLB
//! binary chunk); images are never decoded.
//!
//! Primitive modes: `TRIANGLES` as is; `TRIANGLE_STRIP` and `TRIANGLE_FAN`
//! converted to triangles; `LINES`, `LINE_STRIP`, `LINE_LOOP` become
//! polylines; `POINTS` are skipped and counted. Accessors are checked against
//! their buffer views and buffers before they are read (a truncated `.bin`
//! is an error, not a panic); sparse accessors are not supported.
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
    let gltf = contain(name, "gltf", || gltf::Gltf::from_slice(bytes))?
        .map_err(|e| VoxkitError::invalid(format!("{name}: glTF: {e}")))?;
    let buffers = contain(name, "gltf", || {
        gltf::import_buffers(&gltf.document, base_dir, gltf.blob.clone())
    })?
    .map_err(|e| VoxkitError::invalid(format!("{name}: glTF buffers: {e}")))?;
    let doc = &gltf.document;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| VoxkitError::invalid(format!("{name}: the file has no scene")))?;

    let mut acc = Collect {
        name,
        buffers: &buffers,
        positions: Vec::new(),
        triangles: Vec::new(),
        polylines: Vec::new(),
        summary: LoadSummary::default(),
        max_depth: doc.nodes().len(),
    };
    for node in scene.nodes() {
        acc.node(&node, DMat4::IDENTITY, 0)?;
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

struct Collect<'a> {
    name: &'a str,
    buffers: &'a [gltf::buffer::Data],
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
                self.primitive(&prim, &world, mesh.index(), node.index())?;
            }
        }
        for child in node.children() {
            self.node(&child, world, depth + 1)?;
        }
        Ok(())
    }

    fn primitive(
        &mut self,
        prim: &gltf::Primitive,
        world: &DMat4,
        mesh: usize,
        node: usize,
    ) -> Result<()> {
        let what = format!(
            "{}: mesh {mesh} primitive {} (node {node})",
            self.name,
            prim.index()
        );
        let pos_acc = prim
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| VoxkitError::invalid(format!("{what}: no POSITION attribute")))?;
        if pos_acc.data_type() != gltf::accessor::DataType::F32
            || pos_acc.dimensions() != gltf::accessor::Dimensions::Vec3
        {
            return Err(VoxkitError::invalid(format!(
                "{what}: POSITION must be float VEC3"
            )));
        }
        check_accessor(&pos_acc, self.buffers, &what)?;
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
            check_accessor(a, self.buffers, &what)?;
        }
        let buffers = self.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let raw: Vec<[f32; 3]> = contain(self.name, "gltf", || {
            reader.read_positions().map(|it| it.collect::<Vec<_>>())
        })?
        .ok_or_else(|| VoxkitError::invalid(format!("{what}: unreadable POSITION")))?;
        let local: Vec<DVec3> = raw
            .into_iter()
            .map(|p| world.transform_point3(DVec3::from_array(p.map(f64::from))))
            .collect();
        let n = local.len();
        let indices: Vec<u32> = match contain(self.name, "gltf", || {
            reader
                .read_indices()
                .map(|ix| ix.into_u32().collect::<Vec<_>>())
        })? {
            Some(ix) => ix,
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
}

/// Checks that every byte an accessor reads lies inside its view and buffer.
fn check_accessor(a: &gltf::Accessor, buffers: &[gltf::buffer::Data], what: &str) -> Result<()> {
    let err = |msg: String| VoxkitError::invalid(format!("{what}: accessor {}: {msg}", a.index()));
    if a.sparse().is_some() {
        return Err(VoxkitError::Unsupported(format!(
            "{what}: accessor {} is sparse",
            a.index()
        )));
    }
    let view = a
        .view()
        .ok_or_else(|| err("has no buffer view".to_string()))?;
    let data = buffers
        .get(view.buffer().index())
        .ok_or_else(|| err(format!("buffer {} is missing", view.buffer().index())))?;
    let view_end = view.offset() as u128 + view.length() as u128;
    if view_end > data.len() as u128 {
        return Err(err(format!(
            "buffer view {} ends at byte {view_end}, past the {} bytes of buffer {}",
            view.index(),
            data.len(),
            view.buffer().index()
        )));
    }
    let size = a.size() as u128;
    let stride = view.stride().map_or(size, |s| s as u128);
    if a.count() > 0 {
        let last = a.offset() as u128 + (a.count() as u128 - 1) * stride + size;
        if last > view.length() as u128 {
            return Err(err(format!(
                "{} elements need {last} bytes, buffer view {} has {}",
                a.count(),
                view.index(),
                view.length()
            )));
        }
    }
    Ok(())
}
