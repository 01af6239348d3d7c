//! MagicaVoxel `.vox` (version 150, with the scene graph chunks).
//!
//! Layout written: `VOX ` 150, `MAIN` with children
//! - one `SIZE` + `XYZI` pair per model: the grid is cut into 256³ blocks
//!   (a model's coordinates are bytes), and every block holding a voxel
//!   becomes a model (an empty grid gives one empty model);
//! - the scene: root `nTRN` (node 0) → `nGRP` (node 1) → per model an `nTRN`
//!   (node 2 + 2i, translation `_t`) → `nSHP` (node 3 + 2i, model i);
//! - one `LAYR` (layer 0). No palette: voxels use colour index 1 of the
//!   default palette.
//!
//! The writer streams model by model from the bricks (a tile becomes its
//! 512 records directly); the reader turns every full brick into a tile.
//!
//! Axes are kept as they are: our (x, y, z) is MagicaVoxel's (x, y, z) (so
//! z is "up" in MagicaVoxel).
//!
//! Placement: MagicaVoxel puts a model's voxel `l` at `_t + l - size / 2`
//! (integer division: the pivot is the model's centre). A model whose block
//! starts at grid voxel `o` therefore gets `_t = o + size / 2`; our reader
//! inverts that. The grid frame (origin, voxel size, dims) has no place in
//! the format, so it is stored as extra attributes of the root `nTRN`
//! (`voxkit_origin`, `voxkit_voxel_size`, `voxkit_dims`), which other readers
//! ignore. A file without them reads with origin at the minimum corner of the
//! models' placed boxes (in voxel units), voxel size 1, dims the boxes' extent.
//!
//! Scene graph (read as the MagicaVoxel editor shows frame 0): from the root
//! `nTRN` (node 0) down, each `nTRN` composes its rotation `_r` (a signed
//! axis permutation, all 48 of them, exact in integers) and
//! translation `_t` with its parents'; `nGRP` groups nest; every `nSHP`
//! places its model, so a model used by several shape nodes (instancing) is
//! placed once per node. Voxel `l` of a model of size `s` is the unit cube
//! about `l + ½ - ⌊s/2⌋` (ogt_vox's pivot rule, which vengi and the editor's
//! files follow: the editor moves `_t` itself when it turns an odd-sized
//! model); a rotation maps that cube to a cube of the world lattice, so
//! placement is exact. Skipped, each with one warning line
//! ([`read_warned`]): `nTRN`s with `_hidden = 1` and those on a `LAYR` with
//! `_hidden = 1` (with their subtrees: the editor hides them); keyframes
//! after the first (an `nTRN` with several frames or an `nSHP` with several
//! models is read at the smallest `_f`, i.e. frame 0); and, in files without
//! a scene graph that hold several models (the 0.98 layout, where the
//! models are animation frames), every model but the first. The walk visits
//! each node at most once (a cycle or a node with two parents is an error),
//! and the bricks the placed models can cover are checked against the
//! memory limit before the grid is built.
//!
//! Colours: [`read_colored`] also returns each placed voxel's colour index
//! and the palette (the file's `RGBA` chunk, else MagicaVoxel's default),
//! so a renderer can draw a scene in its own colours.

use std::collections::HashMap;
use std::io::Write;

use glam::{DVec3, I64Vec3, IVec3};

use crate::error::{Result, VoxkitError};
use crate::grid::brick::{BRICK_EDGE, mask_voxels};
use crate::grid::{BrickGrid, GridFrame, MemoryLimit};

/// Maximum model extent (coordinates are bytes).
pub const MAX_MODEL: usize = 256;

fn chunk(out: &mut Vec<u8>, id: &[u8; 4], content: &[u8], children: &[u8]) {
    out.extend_from_slice(id);
    out.extend_from_slice(&(content.len() as u32).to_le_bytes());
    out.extend_from_slice(&(children.len() as u32).to_le_bytes());
    out.extend_from_slice(content);
    out.extend_from_slice(children);
}

fn put_i32(out: &mut Vec<u8>, v: i32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_dict(out: &mut Vec<u8>, pairs: &[(&str, String)]) {
    put_i32(out, pairs.len() as i32);
    for (k, v) in pairs {
        put_i32(out, k.len() as i32);
        out.extend_from_slice(k.as_bytes());
        put_i32(out, v.len() as i32);
        out.extend_from_slice(v.as_bytes());
    }
}

/// Writes `grid` (voxels inside `frame.dims`, checked by the caller) as .vox,
/// streamed one model at a time ([`BrickGrid::brick_groups`]): a first pass
/// counts each model's voxels (512 per tile) so the chunk sizes are known,
/// then each model's `XYZI` records are written from its bricks, so the
/// writer holds one model's brick list, not the file. Errors: a scene over
/// the format's 4 GiB chunk size.
pub fn write(w: &mut dyn Write, grid: &BrickGrid, frame: &GridFrame) -> Result<()> {
    // Bricks (8) tile 256-blocks exactly: 32 bricks per model side.
    const MODEL_SHIFT: u32 = 5;
    debug_assert_eq!(MAX_MODEL as i32, BRICK_EDGE << MODEL_SHIFT);
    let mut counts: HashMap<IVec3, u64> = HashMap::new();
    for (k, m) in grid.bricks() {
        let n: u32 = m.iter().map(|w| w.count_ones()).sum();
        *counts.entry(k >> MODEL_SHIFT as i32).or_default() += u64::from(n);
    }
    let mut order: Vec<IVec3> = counts.keys().copied().collect();
    order.sort_unstable_by_key(|b| (b.z, b.y, b.x));
    if order.is_empty() {
        order.push(IVec3::ZERO);
        counts.insert(IVec3::ZERO, 0);
    }
    let offsets: Vec<(IVec3, [i32; 3])> = order
        .iter()
        .map(|b| {
            let o = *b * MAX_MODEL as i32;
            let size =
                std::array::from_fn(|a| (frame.dims[a] - o[a] as usize).min(MAX_MODEL) as i32);
            (o, size)
        })
        .collect();
    let scene = scene_chunks(frame, &offsets);
    // MAIN's children: per model SIZE (12 + 12) and XYZI (12 + 4 + 4 n).
    let total: u64 = order.iter().map(|b| 40 + 4 * counts[b]).sum::<u64>() + scene.len() as u64;
    let total = u32::try_from(total).map_err(|_| {
        VoxkitError::Unsupported(format!(
            "vox: the scene needs {total} bytes, over the format's 4 GiB chunk size"
        ))
    })?;

    let mut head = Vec::with_capacity(20);
    head.extend_from_slice(b"VOX ");
    put_i32(&mut head, 150);
    chunk(&mut head, b"MAIN", &[], &[]);
    // Patch MAIN's children size (the children follow directly).
    head[16..20].copy_from_slice(&total.to_le_bytes());
    w.write_all(&head)?;

    let mut groups = grid.brick_groups(MODEL_SHIFT).peekable();
    let mut out: Vec<u8> = Vec::with_capacity(1 << 16);
    for (b, (o, size)) in order.iter().zip(&offsets) {
        let mut c = Vec::with_capacity(12);
        size.iter().for_each(|&s| put_i32(&mut c, s));
        chunk(&mut out, b"SIZE", &c, &[]);
        let n = counts[b];
        out.extend_from_slice(b"XYZI");
        out.extend_from_slice(&(4 + 4 * n as u32).to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        put_i32(&mut out, n as i32);
        if let Some((_, bricks)) = groups.next_if(|(g, _)| g == b) {
            for (k, m) in bricks {
                let base = k * BRICK_EDGE - *o;
                for l in mask_voxels(*m) {
                    let l = base + l;
                    out.extend_from_slice(&[l.x as u8, l.y as u8, l.z as u8, 1]);
                }
                if out.len() >= 1 << 16 {
                    w.write_all(&out)?;
                    out.clear();
                }
            }
        }
    }
    w.write_all(&out)?;
    w.write_all(&scene)?;
    Ok(())
}

/// The scene graph after the models: root `nTRN` with the frame, `nGRP`,
/// per model an `nTRN` (its translation) and an `nSHP`, and one `LAYR`.
fn scene_chunks(frame: &GridFrame, offsets: &[(IVec3, [i32; 3])]) -> Vec<u8> {
    let mut main = Vec::new();
    let o = frame.origin;
    let mut c = Vec::new();
    put_i32(&mut c, 0);
    put_dict(
        &mut c,
        &[
            ("voxkit_origin", format!("{} {} {}", o.x, o.y, o.z)),
            ("voxkit_voxel_size", format!("{}", frame.voxel_size)),
            (
                "voxkit_dims",
                format!("{} {} {}", frame.dims[0], frame.dims[1], frame.dims[2]),
            ),
        ],
    );
    put_i32(&mut c, 1); // child: the group
    put_i32(&mut c, -1); // reserved
    put_i32(&mut c, -1); // layer
    put_i32(&mut c, 1); // frames
    put_dict(&mut c, &[]);
    chunk(&mut main, b"nTRN", &c, &[]);

    let mut c = Vec::new();
    put_i32(&mut c, 1);
    put_dict(&mut c, &[]);
    put_i32(&mut c, offsets.len() as i32);
    for i in 0..offsets.len() {
        put_i32(&mut c, 2 + 2 * i as i32);
    }
    chunk(&mut main, b"nGRP", &c, &[]);

    for (i, (o, size)) in offsets.iter().enumerate() {
        let t: [i32; 3] = std::array::from_fn(|a| o[a] + size[a] / 2);
        let mut c = Vec::new();
        put_i32(&mut c, 2 + 2 * i as i32);
        put_dict(&mut c, &[]);
        put_i32(&mut c, 3 + 2 * i as i32);
        put_i32(&mut c, -1);
        put_i32(&mut c, 0);
        put_i32(&mut c, 1);
        put_dict(&mut c, &[("_t", format!("{} {} {}", t[0], t[1], t[2]))]);
        chunk(&mut main, b"nTRN", &c, &[]);

        let mut c = Vec::new();
        put_i32(&mut c, 3 + 2 * i as i32);
        put_dict(&mut c, &[]);
        put_i32(&mut c, 1);
        put_i32(&mut c, i as i32);
        put_dict(&mut c, &[]);
        chunk(&mut main, b"nSHP", &c, &[]);
    }
    let mut c = Vec::new();
    put_i32(&mut c, 0);
    put_dict(&mut c, &[]);
    put_i32(&mut c, -1);
    chunk(&mut main, b"LAYR", &c, &[]);
    main
}

/// Little-endian cursor with truncation errors.
struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
}

fn bad(m: impl std::fmt::Display) -> VoxkitError {
    VoxkitError::invalid(format!("vox: {m}"))
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.b.len())
            .ok_or_else(|| bad("truncated"))?;
        let s = &self.b[self.pos..end];
        self.pos = end;
        Ok(s)
    }
    fn i32(&mut self) -> Result<i32> {
        Ok(i32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn len(&mut self) -> Result<usize> {
        let v = self.i32()?;
        usize::try_from(v).map_err(|_| bad(format!("negative length {v}")))
    }
    fn string(&mut self) -> Result<String> {
        let n = self.len()?;
        Ok(String::from_utf8_lossy(self.take(n)?).into_owned())
    }
    fn dict(&mut self) -> Result<HashMap<String, String>> {
        let n = self.len()?;
        let mut d = HashMap::new();
        for _ in 0..n {
            let k = self.string()?;
            let v = self.string()?;
            d.insert(k, v);
        }
        Ok(d)
    }
}

/// A signed axis permutation, MagicaVoxel's `_r`: the row-major 3×3 matrix
/// whose row `i` has its one non-zero entry, `sign[i]`, in column `axis[i]`,
/// applied to column vectors (`out[i] = sign[i] · in[axis[i]]`). All 48
/// (the 24 rotations and their mirror images, which MagicaVoxel's flip tool
/// writes) are exact on integer coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct AxisPerm {
    axis: [usize; 3],
    sign: [i64; 3],
}

impl AxisPerm {
    const IDENTITY: AxisPerm = AxisPerm {
        axis: [0, 1, 2],
        sign: [1, 1, 1],
    };

    /// Decodes the `_r` byte (MagicaVoxel-file-format-vox-extension.txt,
    /// "ROTATION type"): bits 0–1 the column of row 0's entry, bits 2–3 that
    /// of row 1 (row 2 takes the remaining column), bits 4, 5, 6 the signs of
    /// rows 0, 1, 2 (1 = negative). `None` for anything else (a repeated or
    /// out-of-range column, bit 7 set).
    pub(crate) fn from_byte(b: u32) -> Option<AxisPerm> {
        let (a0, a1) = ((b & 3) as usize, ((b >> 2) & 3) as usize);
        if b > 127 || a0 > 2 || a1 > 2 || a0 == a1 {
            return None;
        }
        let sign = |bit: u32| if (b >> bit) & 1 == 1 { -1 } else { 1 };
        Some(AxisPerm {
            axis: [a0, a1, 3 - a0 - a1],
            sign: [sign(4), sign(5), sign(6)],
        })
    }

    fn apply(&self, v: I64Vec3) -> I64Vec3 {
        I64Vec3::from_array(std::array::from_fn(|i| self.sign[i] * v[self.axis[i]]))
    }

    /// `self ∘ inner` (`inner` applied first).
    fn after(&self, inner: &AxisPerm) -> AxisPerm {
        AxisPerm {
            axis: std::array::from_fn(|i| inner.axis[self.axis[i]]),
            sign: std::array::from_fn(|i| self.sign[i] * inner.sign[self.axis[i]]),
        }
    }
}

/// An affine placement `x ↦ rot(x) + t` of model space (voxel offsets from
/// the model's pivot) in the world, the composition of the `nTRN` frames
/// from the root down.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Place {
    rot: AxisPerm,
    t: I64Vec3,
}

impl Place {
    const IDENTITY: Place = Place {
        rot: AxisPerm::IDENTITY,
        t: I64Vec3::ZERO,
    };

    /// `self ∘ inner`; `None` when a translation leaves ±2^30 (so no later
    /// coordinate arithmetic can overflow `i32`).
    fn then(&self, inner: &Place) -> Option<Place> {
        let t = self.rot.apply(inner.t) + self.t;
        (t.abs().max_element() < 1 << 30).then_some(Place {
            rot: self.rot.after(&inner.rot),
            t,
        })
    }

    /// Where voxel `l` of a model of `size` lands, per axis `cell[i] =
    /// sign[i] · l[a] + off[i]` with `a = axis[i]`: returns `off`.
    ///
    /// MagicaVoxel's pivot is `p = floor(size / 2)`; voxel `l` is the unit
    /// cube `[l - p, l - p + 1]` about it (ogt_vox's "model pivots"; the
    /// editor moves `_t` itself when it rotates an odd-sized model so that
    /// the centre voxel stays put). A signed permutation maps that cube to
    /// the cube with min corner `t + sign·(l - p)` on a positive axis and
    /// `t - (l - p) - 1` on a negated one: `off = t - p[a]`, resp.
    /// `t + p[a] - 1`.
    fn offsets(&self, size: IVec3) -> I64Vec3 {
        I64Vec3::from_array(std::array::from_fn(|i| {
            let a = self.rot.axis[i];
            let p = i64::from(size[a] / 2);
            if self.rot.sign[i] > 0 {
                self.t[i] - p
            } else {
                self.t[i] + p - 1
            }
        }))
    }
}

/// One parsed scene-graph node (`nTRN` keeps its first keyframe only).
enum Node {
    Transform {
        child: i32,
        layer: i32,
        hidden: bool,
        /// Keyframes in the file (the first is kept in `frame`).
        keyframes: usize,
        frame: Place,
    },
    Group(Vec<i32>),
    /// The model shown at frame 0, and how many keyframed models there are.
    Shape {
        model: i32,
        keyframes: usize,
    },
}

fn parse_ints<const N: usize>(s: &str) -> Option<[i64; N]> {
    let v: Vec<i64> = s
        .split_whitespace()
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    v.try_into().ok()
}

/// A keyframe's `_f` (frame index; absent means frame 0).
fn frame_index(d: &HashMap<String, String>) -> i64 {
    d.get("_f").and_then(|f| f.trim().parse().ok()).unwrap_or(0)
}

/// "node 4" / "nodes 4, 9, 12" (at most five ids, then "…").
fn node_list(ids: &[i32]) -> String {
    let mut s = if ids.len() == 1 { "node " } else { "nodes " }.to_string();
    let shown: Vec<String> = ids.iter().take(5).map(|i| i.to_string()).collect();
    s += &shown.join(", ");
    if ids.len() > 5 {
        s += &format!(" and {} more", ids.len() - 5);
    }
    s
}

/// Colours of a .vox scene: the RGBA palette indexed by MagicaVoxel colour
/// index, and each placed voxel's index.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VoxColors {
    /// RGBA of colour index `c` (1..=255). The file's `RGBA` chunk if it has
    /// one (its entry `i` is colour index `i + 1`), else MagicaVoxel's
    /// default palette. Index 0 means "empty" in MagicaVoxel and is
    /// `[0, 0, 0, 0]` here.
    pub palette: [[u8; 4]; 256],
    /// Every placed voxel with its colour index, in the grid coordinates of
    /// the grid returned beside it. Models in file order, each in its
    /// `XYZI` order; where models overlap, a voxel is listed once per model.
    pub voxels: Vec<(IVec3, u8)>,
}

/// MagicaVoxel's default palette as `0xAABBGGRR` (little-endian RGBA
/// bytes), entry `i` = colour index `i + 1`: the `default_palette` of the
/// MagicaVoxel file-format description (ephtracy/voxel-model,
/// `MagicaVoxel-file-format-vox.txt`) shifted by one, identical to
/// `resources/default_palette.bytes` of the `dot_vox` crate 5.2.0 (a test
/// checks them against each other).
#[rustfmt::skip]
const DEFAULT_RGBA: [u32; 256] = [
    0xffffffff, 0xffccffff, 0xff99ffff, 0xff66ffff, 0xff33ffff, 0xff00ffff, 0xffffccff, 0xffccccff,
    0xff99ccff, 0xff66ccff, 0xff33ccff, 0xff00ccff, 0xffff99ff, 0xffcc99ff, 0xff9999ff, 0xff6699ff,
    0xff3399ff, 0xff0099ff, 0xffff66ff, 0xffcc66ff, 0xff9966ff, 0xff6666ff, 0xff3366ff, 0xff0066ff,
    0xffff33ff, 0xffcc33ff, 0xff9933ff, 0xff6633ff, 0xff3333ff, 0xff0033ff, 0xffff00ff, 0xffcc00ff,
    0xff9900ff, 0xff6600ff, 0xff3300ff, 0xff0000ff, 0xffffffcc, 0xffccffcc, 0xff99ffcc, 0xff66ffcc,
    0xff33ffcc, 0xff00ffcc, 0xffffcccc, 0xffcccccc, 0xff99cccc, 0xff66cccc, 0xff33cccc, 0xff00cccc,
    0xffff99cc, 0xffcc99cc, 0xff9999cc, 0xff6699cc, 0xff3399cc, 0xff0099cc, 0xffff66cc, 0xffcc66cc,
    0xff9966cc, 0xff6666cc, 0xff3366cc, 0xff0066cc, 0xffff33cc, 0xffcc33cc, 0xff9933cc, 0xff6633cc,
    0xff3333cc, 0xff0033cc, 0xffff00cc, 0xffcc00cc, 0xff9900cc, 0xff6600cc, 0xff3300cc, 0xff0000cc,
    0xffffff99, 0xffccff99, 0xff99ff99, 0xff66ff99, 0xff33ff99, 0xff00ff99, 0xffffcc99, 0xffcccc99,
    0xff99cc99, 0xff66cc99, 0xff33cc99, 0xff00cc99, 0xffff9999, 0xffcc9999, 0xff999999, 0xff669999,
    0xff339999, 0xff009999, 0xffff6699, 0xffcc6699, 0xff996699, 0xff666699, 0xff336699, 0xff006699,
    0xffff3399, 0xffcc3399, 0xff993399, 0xff663399, 0xff333399, 0xff003399, 0xffff0099, 0xffcc0099,
    0xff990099, 0xff660099, 0xff330099, 0xff000099, 0xffffff66, 0xffccff66, 0xff99ff66, 0xff66ff66,
    0xff33ff66, 0xff00ff66, 0xffffcc66, 0xffcccc66, 0xff99cc66, 0xff66cc66, 0xff33cc66, 0xff00cc66,
    0xffff9966, 0xffcc9966, 0xff999966, 0xff669966, 0xff339966, 0xff009966, 0xffff6666, 0xffcc6666,
    0xff996666, 0xff666666, 0xff336666, 0xff006666, 0xffff3366, 0xffcc3366, 0xff993366, 0xff663366,
    0xff333366, 0xff003366, 0xffff0066, 0xffcc0066, 0xff990066, 0xff660066, 0xff330066, 0xff000066,
    0xffffff33, 0xffccff33, 0xff99ff33, 0xff66ff33, 0xff33ff33, 0xff00ff33, 0xffffcc33, 0xffcccc33,
    0xff99cc33, 0xff66cc33, 0xff33cc33, 0xff00cc33, 0xffff9933, 0xffcc9933, 0xff999933, 0xff669933,
    0xff339933, 0xff009933, 0xffff6633, 0xffcc6633, 0xff996633, 0xff666633, 0xff336633, 0xff006633,
    0xffff3333, 0xffcc3333, 0xff993333, 0xff663333, 0xff333333, 0xff003333, 0xffff0033, 0xffcc0033,
    0xff990033, 0xff660033, 0xff330033, 0xff000033, 0xffffff00, 0xffccff00, 0xff99ff00, 0xff66ff00,
    0xff33ff00, 0xff00ff00, 0xffffcc00, 0xffcccc00, 0xff99cc00, 0xff66cc00, 0xff33cc00, 0xff00cc00,
    0xffff9900, 0xffcc9900, 0xff999900, 0xff669900, 0xff339900, 0xff009900, 0xffff6600, 0xffcc6600,
    0xff996600, 0xff666600, 0xff336600, 0xff006600, 0xffff3300, 0xffcc3300, 0xff993300, 0xff663300,
    0xff333300, 0xff003300, 0xffff0000, 0xffcc0000, 0xff990000, 0xff660000, 0xff330000, 0xff0000ee,
    0xff0000dd, 0xff0000bb, 0xff0000aa, 0xff000088, 0xff000077, 0xff000055, 0xff000044, 0xff000022,
    0xff000011, 0xff00ee00, 0xff00dd00, 0xff00bb00, 0xff00aa00, 0xff008800, 0xff007700, 0xff005500,
    0xff004400, 0xff002200, 0xff001100, 0xffee0000, 0xffdd0000, 0xffbb0000, 0xffaa0000, 0xff880000,
    0xff770000, 0xff550000, 0xff440000, 0xff220000, 0xff110000, 0xffeeeeee, 0xffdddddd, 0xffbbbbbb,
    0xffaaaaaa, 0xff888888, 0xff777777, 0xff555555, 0xff444444, 0xff222222, 0xff111111, 0x00000000,
];

/// MagicaVoxel's default palette indexed by colour index (index 0, unused,
/// is transparent black).
pub fn default_palette() -> [[u8; 4]; 256] {
    let mut p = [[0u8; 4]; 256];
    for (c, rgba) in p.iter_mut().enumerate().skip(1) {
        *rgba = DEFAULT_RGBA[c - 1].to_le_bytes();
    }
    p
}

/// The palette of an `RGBA` chunk: entry `i` is colour index `i + 1` (the
/// format's quirk); the 256th entry has no index and is dropped. A short
/// chunk leaves the remaining indices at their default colours.
fn palette_of_chunk(body: &[u8]) -> Result<[[u8; 4]; 256]> {
    if !body.len().is_multiple_of(4) || body.len() > 1024 {
        return Err(bad(format!("RGBA chunk of {} bytes", body.len())));
    }
    let mut p = default_palette();
    for (c, rgba) in body.chunks_exact(4).take(255).enumerate() {
        p[c + 1].copy_from_slice(rgba);
    }
    Ok(p)
}

/// Reads a .vox file from memory (see the module docs for placement, the
/// scene graph and the frame). What was skipped (hidden layers and nodes,
/// animation frames other than the first) is dropped here; use
/// [`read_warned`] to get it. Errors: bad magic, truncated chunks, model
/// sizes outside 1..=256, voxels outside their model, invalid rotations, a
/// broken scene graph, every model hidden.
pub fn read(bytes: &[u8], limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
    let s = read_scene(bytes, limit, false)?;
    Ok((s.grid, s.frame))
}

/// [`read`], plus one line per thing the reader skipped, as MagicaVoxel's
/// editor does (hidden layers, hidden nodes, animation frames after the
/// first): a user should see these.
pub fn read_warned(
    bytes: &[u8],
    limit: MemoryLimit,
) -> Result<(BrickGrid, GridFrame, Vec<String>)> {
    let s = read_scene(bytes, limit, false)?;
    Ok((s.grid, s.frame, s.warnings))
}

/// A .vox scene as read: the grid, its frame, the colours (empty voxel list
/// unless asked for) and the warnings (see [`read_warned`]).
#[derive(Clone, Debug)]
pub struct VoxScene {
    /// The placed voxels.
    pub grid: BrickGrid,
    /// The grid's frame.
    pub frame: GridFrame,
    /// Palette and per-voxel colour indices ([`read_colored`] only).
    pub colors: VoxColors,
    /// One line per thing skipped while reading.
    pub warnings: Vec<String>,
}

/// [`read_warned`], plus the colours: the palette (the file's or the
/// default) and the colour index of every placed voxel, for drawing the
/// scene in its colours. The colour list is checked against `limit` before
/// it is built.
pub fn read_colored(bytes: &[u8], limit: MemoryLimit) -> Result<VoxScene> {
    read_scene(bytes, limit, true)
}

/// The shared reader; the colour list is built only if `colors`.
fn read_scene(bytes: &[u8], limit: MemoryLimit, colors: bool) -> Result<VoxScene> {
    let mut c = Cursor { b: bytes, pos: 0 };
    if c.take(4)? != b"VOX " {
        return Err(bad("missing 'VOX ' magic"));
    }
    let _version = c.i32()?;
    if c.take(4)? != b"MAIN" {
        return Err(bad("missing MAIN chunk"));
    }
    let main_content = c.len()?;
    let main_children = c.len()?;
    c.take(main_content)?;
    let end = c
        .pos
        .checked_add(main_children)
        .filter(|&e| e <= bytes.len())
        .ok_or_else(|| bad("MAIN chunk is truncated"))?;

    let mut sizes: Vec<IVec3> = Vec::new();
    // Each model's `XYZI` records (x, y, z, colour index), borrowed from
    // the input once checked.
    let mut models: Vec<&[u8]> = Vec::new();
    let mut palette = None;
    let mut nodes: HashMap<i32, Node> = HashMap::new();
    let mut root_attrs = HashMap::new();
    // Layer id → (hidden, name).
    let mut layers: HashMap<i32, (bool, String)> = HashMap::new();
    let mut animated_transforms: Vec<i32> = Vec::new();
    let mut animated_shapes: Vec<i32> = Vec::new();
    while c.pos < end {
        let id: [u8; 4] = c.take(4)?.try_into().expect("4 bytes");
        let n_content = c.len()?;
        let n_children = c.len()?;
        let body = c.take(n_content)?;
        c.take(n_children)?;
        let mut b = Cursor { b: body, pos: 0 };
        match &id {
            b"SIZE" => {
                let s = IVec3::new(b.i32()?, b.i32()?, b.i32()?);
                if s.cmplt(IVec3::ONE).any() || s.cmpgt(IVec3::splat(MAX_MODEL as i32)).any() {
                    return Err(bad(format!(
                        "SIZE chunk of model {}: size {s} outside 1..=256",
                        sizes.len()
                    )));
                }
                sizes.push(s);
            }
            b"XYZI" => {
                let s = *sizes.get(models.len()).ok_or_else(|| {
                    bad(format!("XYZI chunk of model {} without SIZE", models.len()))
                })?;
                let n = b.len()?;
                let raw = b.take(n.checked_mul(4).ok_or_else(|| bad("voxel count"))?)?;
                for q in raw.chunks_exact(4) {
                    let v = IVec3::new(q[0] as i32, q[1] as i32, q[2] as i32);
                    if v.cmpge(s).any() {
                        return Err(bad(format!(
                            "XYZI chunk of model {}: voxel {v} outside its size {s}",
                            models.len()
                        )));
                    }
                }
                models.push(raw);
            }
            b"nTRN" => {
                let node = b.i32()?;
                let attrs = b.dict()?;
                let child = b.i32()?;
                let _reserved = b.i32()?;
                let layer = b.i32()?;
                let frames = b.len()?;
                // Keyframes: the editor shows frame 0, i.e. the keyframe
                // with the smallest `_f` (ogt_vox samples it the same way).
                let mut first: Option<(i64, HashMap<String, String>)> = None;
                for _ in 0..frames {
                    let d = b.dict()?;
                    let f = frame_index(&d);
                    if first.as_ref().is_none_or(|(g, _)| f < *g) {
                        first = Some((f, d));
                    }
                }
                let mut frame = Place::IDENTITY;
                if let Some((_, d)) = first {
                    if let Some(r) = d.get("_r") {
                        frame.rot = r
                            .trim()
                            .parse::<u32>()
                            .ok()
                            .and_then(AxisPerm::from_byte)
                            .ok_or_else(|| {
                                bad(format!(
                                    "nTRN node {node}: rotation _r = {r:?} is not a signed axis permutation"
                                ))
                            })?;
                    }
                    if let Some(s) = d.get("_t") {
                        let t = parse_ints::<3>(s)
                            .filter(|a| a.iter().all(|v| v.unsigned_abs() < 1 << 30))
                            .ok_or_else(|| {
                                bad(format!("nTRN node {node}: bad translation _t = {s:?}"))
                            })?;
                        frame.t = I64Vec3::from_array(t);
                    }
                }
                let hidden = attrs.get("_hidden").is_some_and(|h| h.trim() == "1");
                if node == 0 {
                    root_attrs = attrs;
                }
                nodes.insert(
                    node,
                    Node::Transform {
                        child,
                        layer,
                        hidden,
                        keyframes: frames,
                        frame,
                    },
                );
            }
            b"nGRP" => {
                let node = b.i32()?;
                b.dict()?;
                let n = b.len()?;
                // A count the chunk cannot hold must not size an allocation.
                let mut kids = Vec::with_capacity(n.min((b.b.len() - b.pos) / 4));
                for _ in 0..n {
                    kids.push(b.i32()?);
                }
                nodes.insert(node, Node::Group(kids));
            }
            b"nSHP" => {
                let node = b.i32()?;
                b.dict()?;
                let n = b.len()?;
                // Several models are the shape's animation keyframes (`_f`
                // in each model's attributes): frame 0 shows the first. The
                // count is checked by reading, never used to allocate
                // (fuzzing found 1.4·10^9 asked in a 1.4 KB file).
                let mut first: Option<(i64, i32)> = None;
                for _ in 0..n {
                    let m = b.i32()?;
                    let f = frame_index(&b.dict()?);
                    if first.is_none_or(|(g, _)| f < g) {
                        first = Some((f, m));
                    }
                }
                let (_, model) =
                    first.ok_or_else(|| bad(format!("nSHP node {node} has no model")))?;
                nodes.insert(
                    node,
                    Node::Shape {
                        model,
                        keyframes: n,
                    },
                );
            }
            b"LAYR" => {
                let layer = b.i32()?;
                let attrs = b.dict()?;
                let hidden = attrs.get("_hidden").is_some_and(|h| h.trim() == "1");
                let name = attrs.get("_name").cloned().unwrap_or_default();
                layers.insert(layer, (hidden, name));
            }
            b"RGBA" => palette = Some(palette_of_chunk(body)?),
            _ => {} // materials, cameras, index map, notes...: not needed
        }
    }
    if models.len() != sizes.len() {
        return Err(bad(format!(
            "SIZE chunk of model {} without XYZI",
            models.len()
        )));
    }
    if models.is_empty() {
        return Err(bad("no model"));
    }

    let mut warnings = Vec::new();
    // Placements (model, world placement of its pivot frame).
    let mut placed: Vec<(usize, Place)> = Vec::new();
    if nodes.is_empty() {
        // No scene graph: the 0.98 layout, where several models are the
        // frames of an animation (MagicaVoxel-file-format-vox.txt). Frame 0
        // is what the editor shows; the model keeps its own coordinates
        // (a translation by its pivot cancels the pivot).
        if models.len() > 1 {
            warnings.push(format!(
                "{} models and no scene graph: they are animation frames \
                 (MagicaVoxel 0.98 layout); read frame 0 only",
                models.len()
            ));
        }
        let p = (sizes[0] / 2).as_i64vec3();
        placed.push((
            0,
            Place {
                rot: AxisPerm::IDENTITY,
                t: p,
            },
        ));
    } else {
        // Depth-first from the root (node 0), composing the transforms. A
        // scene graph is a tree, so the walk is bounded by the node count:
        // a cycle or shared subtrees cannot make it hang or multiply.
        let mut hidden_nodes: Vec<i32> = Vec::new();
        let mut hidden_layers: Vec<i32> = Vec::new();
        let mut stack = vec![(0i32, Place::IDENTITY)];
        let mut steps = 0usize;
        while let Some((id, acc)) = stack.pop() {
            steps += 1;
            if steps > nodes.len() {
                return Err(bad(format!(
                    "scene graph: node {id} is reached twice (a cycle or a shared node)"
                )));
            }
            match nodes.get(&id) {
                Some(Node::Transform {
                    child,
                    layer,
                    hidden,
                    keyframes,
                    frame,
                }) => {
                    if *hidden {
                        hidden_nodes.push(id);
                        continue;
                    }
                    if layers.get(layer).is_some_and(|(h, _)| *h) {
                        if !hidden_layers.contains(layer) {
                            hidden_layers.push(*layer);
                        }
                        continue;
                    }
                    if *keyframes > 1 {
                        animated_transforms.push(id);
                    }
                    let next = acc.then(frame).ok_or_else(|| {
                        bad(format!("nTRN node {id}: placement out of range ±2^30"))
                    })?;
                    stack.push((*child, next));
                }
                Some(Node::Group(kids)) => stack.extend(kids.iter().rev().map(|&k| (k, acc))),
                Some(Node::Shape {
                    model: m,
                    keyframes,
                }) => {
                    if *keyframes > 1 {
                        animated_shapes.push(id);
                    }
                    let mi = usize::try_from(*m)
                        .ok()
                        .filter(|&m| m < models.len())
                        .ok_or_else(|| bad(format!("nSHP node {id} uses missing model {m}")))?;
                    placed.push((mi, acc));
                }
                None => return Err(bad(format!("scene graph refers to missing node {id}"))),
            }
        }
        if !hidden_nodes.is_empty() {
            warnings.push(format!(
                "skipped hidden {} (hidden in MagicaVoxel, so not shown)",
                node_list(&hidden_nodes)
            ));
        }
        hidden_layers.sort_unstable();
        for l in hidden_layers {
            let name = &layers[&l].1;
            let name = if name.is_empty() {
                String::new()
            } else {
                format!(" ({name:?})")
            };
            warnings.push(format!("skipped hidden layer {l}{name}"));
        }
        animated_transforms.sort_unstable();
        if !animated_transforms.is_empty() {
            warnings.push(format!(
                "animated transforms in {}: read frame 0 (the first keyframe) only",
                node_list(&animated_transforms)
            ));
        }
        animated_shapes.sort_unstable();
        if !animated_shapes.is_empty() {
            warnings.push(format!(
                "animated shapes in {}: read frame 0 (the first keyframe's model) only",
                node_list(&animated_shapes)
            ));
        }
    }
    if placed.is_empty() {
        return Err(bad(if warnings.is_empty() {
            "no model is placed in the scene".to_string()
        } else {
            format!(
                "nothing is visible ({}); show the models in MagicaVoxel to read them",
                warnings.join("; ")
            )
        }));
    }

    // Per placement: the offsets of `cell[i] = sign[i]·l[axis[i]] + off[i]`
    // and the box of the placed model.
    let mut lo = I64Vec3::MAX;
    let mut hi = I64Vec3::MIN;
    let mut bricks: u128 = 0;
    let layout: Vec<(AxisPerm, I64Vec3, &[u8])> = placed
        .iter()
        .map(|&(m, place)| {
            let off = place.offsets(sizes[m]);
            let s = sizes[m].as_i64vec3();
            for i in 0..3 {
                let ext = s[place.rot.axis[i]] - 1;
                let (a, b) = if place.rot.sign[i] > 0 {
                    (off[i], off[i] + ext)
                } else {
                    (off[i] - ext, off[i])
                };
                lo[i] = lo[i].min(a);
                hi[i] = hi[i].max(b + 1);
            }
            // An instance covers at most one brick per voxel and at most
            // its box's bricks (one more per axis when unaligned).
            let box_bricks: u128 = s
                .to_array()
                .iter()
                .map(|&e| (e as u128).div_ceil(8) + 1)
                .product();
            bricks += box_bricks.min((models[m].len() / 4) as u128);
            (place.rot, off, models[m])
        })
        .collect();
    // Instancing multiplies voxels: cap the grid being built (~96 bytes per
    // brick with its map entry) before building it.
    limit.check("vox scene (placed models)", bricks, 96)?;
    let lo = lo.as_ivec3();
    let hi = hi.as_ivec3();

    // With the frame stored, voxels keep their placed coordinates;
    // without it, they shift so the placed boxes start at voxel 0.
    let (frame, shift) = match (
        root_attrs.get("voxkit_origin"),
        root_attrs.get("voxkit_voxel_size"),
        root_attrs.get("voxkit_dims"),
    ) {
        (Some(o), Some(h), Some(d)) => {
            let o: Vec<f64> = o
                .split_whitespace()
                .map(|s| s.parse().ok())
                .collect::<Option<_>>()
                .filter(|v: &Vec<f64>| v.len() == 3)
                .ok_or_else(|| bad(format!("bad voxkit_origin {o:?}")))?;
            let h: f64 = h
                .parse()
                .map_err(|_| bad(format!("bad voxkit_voxel_size {h:?}")))?;
            let d = parse_ints::<3>(d)
                .filter(|d| d.iter().all(|&x| x > 0 && x <= i32::MAX as i64))
                .ok_or_else(|| bad(format!("bad voxkit_dims {d:?}")))?;
            let frame = GridFrame::new(DVec3::new(o[0], o[1], o[2]), h, d.map(|x| x as usize));
            (frame, IVec3::ZERO)
        }
        _ => {
            let dims = (hi - lo).as_uvec3();
            let frame = GridFrame::new(
                lo.as_dvec3(),
                1.0,
                [dims.x as usize, dims.y as usize, dims.z as usize],
            );
            (frame, -lo)
        }
    };

    let records = || {
        layout.iter().flat_map(move |&(rot, off, raw)| {
            let off = off.as_ivec3() + shift;
            let sign = rot.sign.map(|s| s as i32);
            raw.chunks_exact(4).map(move |q| {
                let v = IVec3::from_array(std::array::from_fn(|i| {
                    sign[i] * q[rot.axis[i]] as i32 + off[i]
                }));
                (v, q[3])
            })
        })
    };
    let mut grid = BrickGrid::new();
    grid.extend(records().map(|(v, _)| v));
    grid.compact_tiles();
    grid.check_inside(frame.dims)?;
    let mut voxels = Vec::new();
    if colors {
        let n: usize = layout.iter().map(|(_, _, raw)| raw.len() / 4).sum();
        limit.check(
            "vox colour list",
            n as u128,
            std::mem::size_of::<(IVec3, u8)>() as u128,
        )?;
        voxels.reserve_exact(n);
        voxels.extend(records());
    }
    let colors = VoxColors {
        palette: palette.unwrap_or_else(default_palette),
        voxels,
    };
    Ok(VoxScene {
        grid,
        frame,
        colors,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain of translations whose sum leaves ±2^30 is a typed error, not
    /// an `i32` overflow (regression: nested `_t`s each within range used to
    /// overflow the accumulated offset).
    #[test]
    fn nested_translations_beyond_range_are_an_error() {
        let mut main = Vec::new();
        let mut c = Vec::new();
        [1, 1, 1].iter().for_each(|&v| put_i32(&mut c, v));
        chunk(&mut main, b"SIZE", &c, &[]);
        let mut c = Vec::new();
        put_i32(&mut c, 1);
        c.extend_from_slice(&[0, 0, 0, 1]);
        chunk(&mut main, b"XYZI", &c, &[]);
        // Three transforms of 2^30 - 1 each, then the shape.
        for node in 0..3 {
            let mut c = Vec::new();
            put_i32(&mut c, node);
            put_dict(&mut c, &[]);
            put_i32(&mut c, node + 1);
            put_i32(&mut c, -1);
            put_i32(&mut c, 0);
            put_i32(&mut c, 1);
            put_dict(&mut c, &[("_t", format!("{} 0 0", (1 << 30) - 1))]);
            chunk(&mut main, b"nTRN", &c, &[]);
        }
        let mut c = Vec::new();
        put_i32(&mut c, 3);
        put_dict(&mut c, &[]);
        put_i32(&mut c, 1);
        put_i32(&mut c, 0);
        put_dict(&mut c, &[]);
        chunk(&mut main, b"nSHP", &c, &[]);
        let mut file = b"VOX ".to_vec();
        put_i32(&mut file, 150);
        chunk(&mut file, b"MAIN", &[], &main);
        assert!(matches!(
            read(&file, MemoryLimit::DEFAULT),
            Err(VoxkitError::Invalid(_))
        ));
    }

    #[test]
    fn default_palette_is_magicavoxels() {
        let p = default_palette();
        assert_eq!(p[0], [0, 0, 0, 0]);
        for (i, c) in dot_vox::DEFAULT_PALETTE.iter().take(255).enumerate() {
            assert_eq!(p[i + 1], <[u8; 4]>::from(c), "colour index {}", i + 1);
        }
        assert_eq!(p[1], [255, 255, 255, 255]);
    }

    #[test]
    fn custom_palette_from_dot_vox_reads_back() {
        let palette: Vec<dot_vox::Color> = (0..256u32)
            .map(|i| dot_vox::Color {
                r: i as u8,
                g: (255 - i) as u8,
                b: (i * 7) as u8,
                a: 100 + (i % 100) as u8,
            })
            .collect();
        // dot_vox's `i` is the file's colour index minus one.
        let voxels: Vec<dot_vox::Voxel> =
            [(0, 0, 0, 0), (3, 1, 2, 7), (4, 4, 4, 254), (1, 2, 3, 128)]
                .iter()
                .map(|&(x, y, z, i)| dot_vox::Voxel { x, y, z, i })
                .collect();
        let data = dot_vox::DotVoxData {
            version: 150,
            index_map: dot_vox::DEFAULT_INDEX_MAP.to_vec(),
            models: vec![dot_vox::Model {
                size: dot_vox::Size { x: 5, y: 5, z: 5 },
                voxels: voxels.clone(),
            }],
            palette: palette.clone(),
            materials: vec![],
            scenes: vec![],
            layers: vec![],
        };
        let mut bytes = Vec::new();
        data.write_vox(&mut bytes).unwrap();
        let VoxScene {
            grid,
            frame,
            colors,
            ..
        } = read_colored(&bytes, MemoryLimit::DEFAULT).unwrap();
        assert_eq!(frame.dims, [5, 5, 5]);
        assert_eq!(grid.count(), 4);
        assert_eq!(colors.voxels.len(), 4);
        for (v, (p, c)) in voxels.iter().zip(&colors.voxels) {
            assert_eq!(p.to_array(), [v.x as i32, v.y as i32, v.z as i32]);
            assert!(grid.contains(*p));
            assert_eq!(*c, v.i + 1);
            // The colour dot_vox shows for the voxel is the one we give.
            assert_eq!(
                colors.palette[*c as usize],
                <[u8; 4]>::from(palette[v.i as usize])
            );
        }
        // `read` sees the same grid.
        assert_eq!(read(&bytes, MemoryLimit::DEFAULT).unwrap(), (grid, frame));
    }

    #[test]
    fn own_files_use_the_default_palette_and_index_1() {
        let mut grid = BrickGrid::new();
        for v in [
            IVec3::new(0, 0, 0),
            IVec3::new(299, 5, 2),
            IVec3::new(7, 260, 1),
        ] {
            grid.insert(v);
        }
        let frame = GridFrame::new(DVec3::new(1.0, 2.0, 3.0), 0.5, [300, 261, 3]);
        let mut bytes = Vec::new();
        write(&mut bytes, &grid, &frame).unwrap();
        let VoxScene {
            grid: g,
            frame: f,
            colors,
            warnings,
        } = read_colored(&bytes, MemoryLimit::DEFAULT).unwrap();
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!((&g, f), (&grid, frame));
        assert_eq!(colors.palette, default_palette());
        let mut placed: Vec<IVec3> = colors
            .voxels
            .iter()
            .map(|&(v, c)| {
                assert_eq!(c, 1);
                v
            })
            .collect();
        placed.sort_by_key(|v| (v.z, v.y, v.x));
        let mut want: Vec<IVec3> = grid.iter().collect();
        want.sort_by_key(|v| (v.z, v.y, v.x));
        assert_eq!(placed, want);
        // The grid's bricks count against the limit before it is built (at
        // most one per placed voxel: 3 × 96 bytes), and so does the colour
        // list.
        assert!(read(&bytes, MemoryLimit::new(3 * 96)).is_ok());
        for r in [
            read(&bytes, MemoryLimit::new(3 * 96 - 1)).map(|_| ()),
            read_colored(&bytes, MemoryLimit::new(10)).map(|_| ()),
        ] {
            assert!(matches!(r, Err(VoxkitError::Limits { .. })));
        }
    }

    #[test]
    fn rgba_chunk_sizes() {
        assert!(palette_of_chunk(&[0; 1028]).is_err());
        assert!(palette_of_chunk(&[0; 7]).is_err());
        // A short chunk overrides the first indices only.
        let p = palette_of_chunk(&[9, 9, 9, 9]).unwrap();
        assert_eq!(p[1], [9; 4]);
        assert_eq!(p[2], default_palette()[2]);
    }
}
