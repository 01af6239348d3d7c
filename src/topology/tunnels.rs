//! Tunnel search: is there an N-connected path of **empty** voxels from one
//! side of a voxelized surface to the other?
//!
//! * Closed surfaces ([`closed_surface_tunnels`]): the outside is every empty
//!   voxel reachable from the grid border. Space beyond the grid counts as
//!   empty and connected, so a surface touching the grid border is handled:
//!   seeding with all empty border voxels is exactly what a virtual one-voxel
//!   empty padding would reach (every border voxel is face-adjacent to it).
//!   A tunnel exists iff the outside flood reaches one of the caller's inside
//!   seeds (e.g. solid-reference voxels that are not surface voxels).
//! * Open patches ([`patch_sides_connected`]): are two seed sets N-connected
//!   through empty voxels *inside the grid*? The caller sets the grid up so
//!   that going around the patch is impossible (e.g. the patch spans the grid
//!   cross-section).
//! * [`count_empty_components`]: N-components of the empty voxels of the grid.
//!
//! Connectivity N refers to the EMPTY voxels' paths: a 6-tunnel is a 6-path
//! (face steps), a 26-tunnel a 26-path. A 26-tunnel-free surface is also
//! 6-tunnel-free.
//!
//! # Cost
//! Scanline flood fill: one visited bit per voxel plus a stack of row seeds
//! (one per run of empty voxels, not one per voxel); O(voxels) time.
//! [`tunnel_path`] is the exception: a breadth-first search storing one byte
//! per voxel (the step that reached it) to return a shortest example path.

use std::collections::VecDeque;

use crate::error::{Result, VoxkitError};
use crate::grid::{BitGrid, Dims, MemoryLimit, Voxel};
use crate::metric::{Connectivity, adjacent};

/// The verdict of [`closed_surface_tunnels`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TunnelVerdict {
    /// Whether the outside is N-connected to an inside seed through empty voxels.
    pub tunnel: bool,
    /// The first inside seed (in the caller's order) found reached from outside.
    pub first_inside_reached: Option<Voxel>,
    /// Inside seeds that are empty (occupied seeds are ignored).
    pub inside_seeds_empty: u64,
    /// Empty voxels reachable from the grid border (the outside).
    pub outside_empty: u64,
    /// Empty voxels reachable from the inside seeds but not from outside.
    pub inside_empty: u64,
    /// Empty voxels reached by neither flood (cavities, pockets).
    pub unreached_empty: u64,
}

/// The verdict of [`patch_sides_connected`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PatchVerdict {
    /// Whether some empty voxel of side B is N-connected to an empty voxel of side A.
    pub connected: bool,
    /// The first side-B seed (in the caller's order) reached from side A.
    pub first_b_reached: Option<Voxel>,
    /// Empty voxels reachable from side A.
    pub reached_from_a: u64,
}

/// Row moves `(dy, dz, dx_reach)` of a scanline flood: a run in row (y, z)
/// reaches row (y+dy, z+dz) at x-offsets up to `dx_reach`.
fn row_moves(conn: Connectivity) -> &'static [(i32, i32, usize)] {
    const SIX: [(i32, i32, usize); 4] = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0)];
    const EIGHTEEN: [(i32, i32, usize); 8] = [
        (1, 0, 1),
        (-1, 0, 1),
        (0, 1, 1),
        (0, -1, 1),
        (1, 1, 0),
        (1, -1, 0),
        (-1, 1, 0),
        (-1, -1, 0),
    ];
    const TWENTY_SIX: [(i32, i32, usize); 8] = [
        (1, 0, 1),
        (-1, 0, 1),
        (0, 1, 1),
        (0, -1, 1),
        (1, 1, 1),
        (1, -1, 1),
        (-1, 1, 1),
        (-1, -1, 1),
    ];
    match conn {
        Connectivity::Six => &SIX,
        Connectivity::Eighteen => &EIGHTEEN,
        Connectivity::TwentySix => &TWENTY_SIX,
    }
}

/// Scanline flood fill of empty voxels, marking `visited`.
struct Flood<'a> {
    occ: &'a BitGrid,
    visited: BitGrid,
    dims: Dims,
    conn: Connectivity,
    stack: Vec<(u32, u32, u32)>,
}

impl<'a> Flood<'a> {
    fn new(occ: &'a BitGrid, conn: Connectivity) -> Result<Self> {
        // Same size as `occ`, which already exists: no new limit to enforce.
        let visited = BitGrid::new(occ.dims(), MemoryLimit::new(u64::MAX))?;
        Ok(Flood {
            occ,
            visited,
            dims: occ.dims(),
            conn,
            stack: Vec::new(),
        })
    }

    #[inline]
    fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    #[inline]
    fn free(&self, i: usize) -> bool {
        !self.occ.get_index(i) && !self.visited.get_index(i)
    }

    /// Floods from `(x, y, z)` if it is empty and unvisited; returns the number
    /// of voxels newly marked.
    fn fill_from(&mut self, x: usize, y: usize, z: usize) -> u64 {
        if !self.free(self.index(x, y, z)) {
            return 0;
        }
        let [nx, ny, nz] = self.dims;
        let mut count = 0u64;
        self.stack.push((x as u32, y as u32, z as u32));
        while let Some((x, y, z)) = self.stack.pop() {
            let (x, y, z) = (x as usize, y as usize, z as usize);
            let row = self.index(0, y, z);
            if !self.free(row + x) {
                continue;
            }
            let mut x0 = x;
            while x0 > 0 && self.free(row + x0 - 1) {
                x0 -= 1;
            }
            let mut x1 = x;
            while x1 + 1 < nx && self.free(row + x1 + 1) {
                x1 += 1;
            }
            for xi in x0..=x1 {
                self.visited.set_index(row + xi, true);
            }
            count += (x1 - x0 + 1) as u64;
            for &(dy, dz, reach) in row_moves(self.conn) {
                let (yy, zz) = (y as i64 + dy as i64, z as i64 + dz as i64);
                if yy < 0 || zz < 0 || yy >= ny as i64 || zz >= nz as i64 {
                    continue;
                }
                let (yy, zz) = (yy as usize, zz as usize);
                let nrow = self.index(0, yy, zz);
                let a = x0.saturating_sub(reach);
                let b = (x1 + reach).min(nx - 1);
                let mut in_run = false;
                for xi in a..=b {
                    if self.free(nrow + xi) {
                        if !in_run {
                            self.stack.push((xi as u32, yy as u32, zz as u32));
                            in_run = true;
                        }
                    } else {
                        in_run = false;
                    }
                }
            }
        }
        count
    }

    /// Floods from every empty voxel on the grid's six faces.
    fn fill_from_border(&mut self) -> u64 {
        let [nx, ny, nz] = self.dims;
        let mut count = 0;
        for z in 0..nz {
            for y in 0..ny {
                let interior_row = z > 0 && z + 1 < nz && y > 0 && y + 1 < ny;
                if interior_row {
                    count += self.fill_from(0, y, z);
                    count += self.fill_from(nx - 1, y, z);
                } else {
                    for x in 0..nx {
                        count += self.fill_from(x, y, z);
                    }
                }
            }
        }
        count
    }
}

/// Linear index of a seed, or an error naming it if it lies outside the grid.
fn seed_index(occ: &BitGrid, v: Voxel, what: &str) -> Result<usize> {
    occ.linear_index(v).ok_or_else(|| {
        VoxkitError::invalid(format!(
            "{what} seed {v} lies outside the grid {:?}",
            occ.dims()
        ))
    })
}

fn empty_count(occ: &BitGrid) -> u64 {
    occ.len() as u64 - occ.count_ones()
}

/// Tunnel check for a closed surface: flood-fills the empty voxels from the
/// grid border with N-connectivity `conn` and reports whether an inside seed
/// was reached.
///
/// `occ` is the surface occupancy (best with a border of empty voxels, but a
/// surface touching the border is fine: beyond the grid counts as outside).
/// `inside_seeds` are voxels known to be inside the surface; occupied seeds
/// are ignored.
///
/// # Errors
/// [`VoxkitError::Invalid`] if a seed lies outside the grid.
///
/// ```
/// use glam::IVec3;
/// use voxkit::grid::{BitGrid, MemoryLimit};
/// use voxkit::metric::Connectivity;
/// use voxkit::topology::tunnels::closed_surface_tunnels;
/// // A hollow 5³ box: faces occupied, 3³ interior empty.
/// let mut g = BitGrid::new([5, 5, 5], MemoryLimit::DEFAULT).unwrap();
/// for z in 0..5 { for y in 0..5 { for x in 0..5 {
///     let v = IVec3::new(x, y, z);
///     if v.min_element() == 0 || v.max_element() == 4 { g.set(v, true); }
/// }}}
/// let seed = [IVec3::splat(2)];
/// let v = closed_surface_tunnels(&g, Connectivity::TwentySix, &seed).unwrap();
/// assert!(!v.tunnel && v.inside_empty == 27 && v.outside_empty == 0);
/// g.set(IVec3::new(2, 2, 0), false); // punch a hole in the face on the border
/// assert!(closed_surface_tunnels(&g, Connectivity::Six, &seed).unwrap().tunnel);
/// ```
pub fn closed_surface_tunnels(
    occ: &BitGrid,
    conn: Connectivity,
    inside_seeds: &[Voxel],
) -> Result<TunnelVerdict> {
    let seeds: Vec<usize> = inside_seeds
        .iter()
        .map(|&v| seed_index(occ, v, "inside"))
        .collect::<Result<_>>()?;
    let mut flood = Flood::new(occ, conn)?;
    let outside_empty = flood.fill_from_border();
    let mut first_inside_reached = None;
    let mut inside_seeds_empty = 0;
    for (k, &i) in seeds.iter().enumerate() {
        if occ.get_index(i) {
            continue;
        }
        inside_seeds_empty += 1;
        if first_inside_reached.is_none() && flood.visited.get_index(i) {
            first_inside_reached = Some(inside_seeds[k]);
        }
    }
    let mut inside_empty = 0;
    for &v in inside_seeds {
        inside_empty += flood.fill_from(v.x as usize, v.y as usize, v.z as usize);
    }
    Ok(TunnelVerdict {
        tunnel: first_inside_reached.is_some(),
        first_inside_reached,
        inside_seeds_empty,
        outside_empty,
        inside_empty,
        unreached_empty: empty_count(occ) - outside_empty - inside_empty,
    })
}

/// Whether two seed sets (one per side of an open patch) are N-connected
/// through empty voxels of the grid. Paths stay inside the grid; occupied
/// seeds are ignored.
///
/// # Errors
/// [`VoxkitError::Invalid`] if a seed lies outside the grid.
///
/// ```
/// use glam::IVec3;
/// use voxkit::grid::{BitGrid, MemoryLimit};
/// use voxkit::metric::Connectivity;
/// use voxkit::topology::tunnels::patch_sides_connected;
/// // A "naive" digital plane z = floor((x + 1) / 2): one voxel per column,
/// // steps of one: 6-tight, but 26-paths slip through diagonally.
/// let mut g = BitGrid::new([6, 3, 6], MemoryLimit::DEFAULT).unwrap();
/// for x in 0..6 { for y in 0..3 { g.set(IVec3::new(x, y, (x + 1) / 2 + 1), true); } }
/// let below = [IVec3::new(0, 0, 0)];
/// let above = [IVec3::new(0, 0, 5)];
/// assert!(!patch_sides_connected(&g, Connectivity::Six, &below, &above).unwrap().connected);
/// assert!(patch_sides_connected(&g, Connectivity::TwentySix, &below, &above).unwrap().connected);
/// ```
pub fn patch_sides_connected(
    occ: &BitGrid,
    conn: Connectivity,
    side_a: &[Voxel],
    side_b: &[Voxel],
) -> Result<PatchVerdict> {
    for &v in side_a {
        seed_index(occ, v, "side A")?;
    }
    let b: Vec<usize> = side_b
        .iter()
        .map(|&v| seed_index(occ, v, "side B"))
        .collect::<Result<_>>()?;
    let mut flood = Flood::new(occ, conn)?;
    let mut reached_from_a = 0;
    for &v in side_a {
        reached_from_a += flood.fill_from(v.x as usize, v.y as usize, v.z as usize);
    }
    let first_b_reached = b
        .iter()
        .position(|&i| !occ.get_index(i) && flood.visited.get_index(i))
        .map(|k| side_b[k]);
    Ok(PatchVerdict {
        connected: first_b_reached.is_some(),
        first_b_reached,
        reached_from_a,
    })
}

/// Number of N-connected components of the empty voxels inside the grid
/// (space beyond the grid does not connect anything).
///
/// ```
/// use glam::IVec3;
/// use voxkit::grid::{BitGrid, MemoryLimit};
/// use voxkit::metric::Connectivity;
/// use voxkit::topology::tunnels::count_empty_components;
/// // A diagonal wall in 2 × 2 × 1: the two empty voxels touch along an edge.
/// let mut g = BitGrid::new([2, 2, 1], MemoryLimit::DEFAULT).unwrap();
/// g.set(IVec3::new(0, 0, 0), true);
/// g.set(IVec3::new(1, 1, 0), true);
/// assert_eq!(count_empty_components(&g, Connectivity::Six).unwrap(), 2);
/// assert_eq!(count_empty_components(&g, Connectivity::Eighteen).unwrap(), 1);
/// ```
pub fn count_empty_components(occ: &BitGrid, conn: Connectivity) -> Result<u64> {
    let mut flood = Flood::new(occ, conn)?;
    let [nx, ny, nz] = occ.dims();
    let mut components = 0;
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if flood.fill_from(x, y, z) > 0 {
                    components += 1;
                }
            }
        }
    }
    Ok(components)
}

/// A shortest N-connected path of empty voxels from the grid border (the
/// outside) to one of `inside_seeds`, or `None` if there is no tunnel. The
/// path starts at an empty border voxel and ends at an empty inside seed.
///
/// Breadth-first search with one byte per voxel (the step that reached it).
///
/// # Errors
/// [`VoxkitError::Invalid`] if a seed lies outside the grid;
/// [`VoxkitError::Limits`] if the byte-per-voxel table exceeds `limit`.
pub fn tunnel_path(
    occ: &BitGrid,
    conn: Connectivity,
    inside_seeds: &[Voxel],
    limit: MemoryLimit,
) -> Result<Option<Vec<Voxel>>> {
    let mut is_target = BitGrid::new(occ.dims(), MemoryLimit::new(u64::MAX))?;
    for &v in inside_seeds {
        let i = seed_index(occ, v, "inside")?;
        if !occ.get_index(i) {
            is_target.set_index(i, true);
        }
    }
    limit.check("tunnel path table", occ.len() as u128, 1)?;
    const UNSEEN: u8 = 255;
    const ROOT: u8 = 254;
    let moves: Vec<Voxel> = (-1..=1)
        .flat_map(|z| (-1..=1).flat_map(move |y| (-1..=1).map(move |x| Voxel::new(x, y, z))))
        .filter(|&m| adjacent(Voxel::ZERO, m, conn))
        .collect();
    let [nx, ny, nz] = occ.dims();
    let mut from = vec![UNSEEN; occ.len()];
    let mut queue = VecDeque::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let on_border =
                    x == 0 || y == 0 || z == 0 || x + 1 == nx || y + 1 == ny || z + 1 == nz;
                let v = Voxel::new(x as i32, y as i32, z as i32);
                if on_border
                    && let Some(i) = occ.linear_index(v)
                    && !occ.get_index(i)
                    && from[i] == UNSEEN
                {
                    from[i] = ROOT;
                    queue.push_back(v);
                }
            }
        }
    }
    while let Some(v) = queue.pop_front() {
        let i = occ.linear_index(v).unwrap_or(0);
        if is_target.get_index(i) {
            let mut path = vec![v];
            let mut cur = v;
            loop {
                let ci = occ.linear_index(cur).unwrap_or(0);
                if from[ci] == ROOT {
                    break;
                }
                cur -= moves[from[ci] as usize];
                path.push(cur);
            }
            path.reverse();
            return Ok(Some(path));
        }
        for (m, &d) in moves.iter().enumerate() {
            let w = v + d;
            if let Some(j) = occ.linear_index(w)
                && !occ.get_index(j)
                && from[j] == UNSEEN
            {
                from[j] = m as u8;
                queue.push_back(w);
            }
        }
    }
    Ok(None)
}
