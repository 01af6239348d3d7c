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

use std::collections::HashMap;
use std::io::Write;

use glam::{DVec3, IVec3};

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

/// Writes `grid` (voxels inside `frame.dims`, checked by the caller) as .vox.
pub fn write(w: &mut dyn Write, grid: &BrickGrid, frame: &GridFrame) -> Result<()> {
    // Bricks (8) tile 256-blocks exactly: group voxels by block.
    let per_block = (MAX_MODEL as i32) / BRICK_EDGE;
    let mut blocks: HashMap<IVec3, Vec<[u8; 4]>> = HashMap::new();
    for (k, m) in grid.sorted_bricks() {
        let block = k.div_euclid(IVec3::splat(per_block));
        let list = blocks.entry(block).or_default();
        let base = k * BRICK_EDGE - block * MAX_MODEL as i32;
        for l in mask_voxels(m) {
            let l = base + l;
            list.push([l.x as u8, l.y as u8, l.z as u8, 1]);
        }
    }
    let mut order: Vec<IVec3> = blocks.keys().copied().collect();
    order.sort_unstable_by_key(|b| (b.z, b.y, b.x));
    if order.is_empty() {
        order.push(IVec3::ZERO);
        blocks.insert(IVec3::ZERO, Vec::new());
    }

    let mut main = Vec::new();
    let mut offsets = Vec::with_capacity(order.len());
    for b in &order {
        let o = *b * MAX_MODEL as i32;
        let size: [i32; 3] =
            std::array::from_fn(|a| (frame.dims[a] - o[a] as usize).min(MAX_MODEL) as i32);
        let mut c = Vec::with_capacity(12);
        size.iter().for_each(|&s| put_i32(&mut c, s));
        chunk(&mut main, b"SIZE", &c, &[]);
        let vox = &blocks[b];
        let mut c = Vec::with_capacity(4 + 4 * vox.len());
        put_i32(&mut c, vox.len() as i32);
        vox.iter().for_each(|v| c.extend_from_slice(v));
        chunk(&mut main, b"XYZI", &c, &[]);
        offsets.push((o, size));
    }

    // Scene graph.
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

    let mut head = Vec::with_capacity(20);
    head.extend_from_slice(b"VOX ");
    put_i32(&mut head, 150);
    w.write_all(&head)?;
    let mut wrapper = Vec::with_capacity(12);
    chunk(&mut wrapper, b"MAIN", &[], &[]);
    // Patch MAIN's children size (the children follow directly).
    wrapper[8..12].copy_from_slice(&(main.len() as u32).to_le_bytes());
    w.write_all(&wrapper)?;
    w.write_all(&main)?;
    Ok(())
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

enum Node {
    Transform { child: i32, t: IVec3 },
    Group(Vec<i32>),
    Shape(Vec<i32>),
}

fn parse_ints<const N: usize>(s: &str) -> Option<[i64; N]> {
    let v: Vec<i64> = s
        .split_whitespace()
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    v.try_into().ok()
}

/// Reads a .vox file from memory (see the module docs for placement and the
/// frame). Errors: bad magic, truncated chunks, model sizes outside 1..=256,
/// voxels outside their model, rotated transforms (unsupported), a broken
/// scene graph.
pub fn read(bytes: &[u8], _limit: MemoryLimit) -> Result<(BrickGrid, GridFrame)> {
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
    let mut models: Vec<Vec<IVec3>> = Vec::new();
    let mut nodes: HashMap<i32, Node> = HashMap::new();
    let mut root_attrs = HashMap::new();
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
                    return Err(bad(format!("model size {s} outside 1..=256")));
                }
                sizes.push(s);
            }
            b"XYZI" => {
                let s = *sizes
                    .get(models.len())
                    .ok_or_else(|| bad("XYZI without SIZE"))?;
                let n = b.len()?;
                let raw = b.take(n.checked_mul(4).ok_or_else(|| bad("voxel count"))?)?;
                let mut vox = Vec::with_capacity(n);
                for q in raw.chunks_exact(4) {
                    let v = IVec3::new(q[0] as i32, q[1] as i32, q[2] as i32);
                    if v.cmpge(s).any() {
                        return Err(bad(format!(
                            "model {}: voxel {v} outside its size {s}",
                            models.len()
                        )));
                    }
                    vox.push(v);
                }
                models.push(vox);
            }
            b"nTRN" => {
                let node = b.i32()?;
                let attrs = b.dict()?;
                let child = b.i32()?;
                let _reserved = b.i32()?;
                let _layer = b.i32()?;
                let frames = b.len()?;
                let mut t = IVec3::ZERO;
                for f in 0..frames {
                    let d = b.dict()?;
                    if f > 0 {
                        continue;
                    }
                    if let Some(r) = d.get("_r")
                        && r.trim() != "4"
                    {
                        return Err(VoxkitError::Unsupported(format!(
                            "vox: node {node} has a rotation ({r}); only unrotated models are supported"
                        )));
                    }
                    if let Some(s) = d.get("_t") {
                        let [x, y, z] = parse_ints::<3>(s)
                            .filter(|a| a.iter().all(|v| v.unsigned_abs() < 1 << 30))
                            .ok_or_else(|| bad(format!("node {node}: bad translation {s:?}")))?;
                        t = IVec3::new(x as i32, y as i32, z as i32);
                    }
                }
                if node == 0 {
                    root_attrs = attrs;
                }
                nodes.insert(node, Node::Transform { child, t });
            }
            b"nGRP" => {
                let node = b.i32()?;
                b.dict()?;
                let n = b.len()?;
                let kids = (0..n).map(|_| b.i32()).collect::<Result<Vec<_>>>()?;
                nodes.insert(node, Node::Group(kids));
            }
            b"nSHP" => {
                let node = b.i32()?;
                b.dict()?;
                let n = b.len()?;
                let mut ids = Vec::with_capacity(n);
                for _ in 0..n {
                    ids.push(b.i32()?);
                    b.dict()?;
                }
                nodes.insert(node, Node::Shape(ids));
            }
            _ => {} // palette, materials, layers, cameras...: not needed
        }
    }
    if models.len() != sizes.len() {
        return Err(bad("SIZE without XYZI"));
    }
    if models.is_empty() {
        return Err(bad("no model"));
    }

    // Placement: voxel l of model m at offset[m] + l.
    let mut offset: Vec<Option<IVec3>> = vec![None; models.len()];
    if nodes.is_empty() {
        offset.iter_mut().for_each(|o| *o = Some(IVec3::ZERO));
    } else {
        // Walk from the root accumulating translations; a bounded walk so a
        // cyclic graph cannot hang.
        let mut stack = vec![(0i32, IVec3::ZERO)];
        let mut steps = 0usize;
        while let Some((id, acc)) = stack.pop() {
            steps += 1;
            if steps > 4 * nodes.len() + 4 {
                return Err(bad("scene graph has a cycle"));
            }
            match nodes.get(&id) {
                Some(Node::Transform { child, t }) => stack.push((*child, acc + *t)),
                Some(Node::Group(kids)) => stack.extend(kids.iter().map(|&k| (k, acc))),
                Some(Node::Shape(ids)) => {
                    for &m in ids {
                        let mi = usize::try_from(m)
                            .ok()
                            .filter(|&m| m < models.len())
                            .ok_or_else(|| {
                                bad(format!("shape node {id} uses missing model {m}"))
                            })?;
                        // Pivot at the model's centre (integer division).
                        offset[mi] = Some(acc - sizes[mi] / 2);
                    }
                }
                None => return Err(bad(format!("scene graph refers to missing node {id}"))),
            }
        }
    }

    let mut grid = BrickGrid::new();
    let mut lo = IVec3::MAX;
    let mut hi = IVec3::MIN;
    for (m, vox) in models.iter().enumerate() {
        // A model no shape node places is not part of the scene.
        let Some(o) = offset[m] else { continue };
        lo = lo.min(o);
        hi = hi.max(o + sizes[m]);
        grid.extend(vox.iter().map(|&v| v + o));
    }
    if lo.x > hi.x {
        return Err(bad("no model is placed in the scene"));
    }

    let frame = match (
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
            grid.check_inside(frame.dims)?;
            frame
        }
        _ => {
            // Shift so the placed boxes start at voxel 0.
            let dims = (hi - lo).as_uvec3();
            let mut shifted = BrickGrid::new();
            shifted.extend(grid.iter_unordered().map(|v| v - lo));
            grid = shifted;
            GridFrame::new(
                lo.as_dvec3(),
                1.0,
                [dims.x as usize, dims.y as usize, dims.z as usize],
            )
        }
    };
    Ok((grid, frame))
}
