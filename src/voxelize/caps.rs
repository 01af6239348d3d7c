//! Caps over a mesh's boundary: the triangles that close its holes.
//!
//! Seen as a 2-chain (each triangle an oriented cell, vertices identified by
//! position), a mesh `S` has a boundary `∂S`: the directed edges whose uses do
//! not cancel (an edge used `a→b` by one triangle and `b→a` by another
//! cancels). `∂S` is empty for a closed, consistently oriented mesh; holes,
//! open seams, flipped faces (an edge used twice the same way counts twice)
//! and T-junctions all leave edges in it.
//!
//! [`boundary_caps`] returns a chain `S'` with `∂S' = ∂S`: the boundary is
//! split into short directed cycles ([`boundary_cycles`]; a boundary is
//! always a union of cycles), and each cycle is triangulated on its own
//! (`close_cycle`: a 3-cycle is its own triangle, a longer one is halved by
//! its shortest halving chord, recursively). Short cycles keep the caps on
//! the holes they close. Then `S − S'`
//! is closed, so
//!
//! `w_S(q) = w_{S−S'}(q) + w_{S'}(q)`
//!
//! for the generalized winding number `w` (it is additive over triangles):
//! an exact integer (a signed crossing count) plus the winding number of the
//! caps alone, which is small and smooth away from the holes. That split is
//! what [`crate::voxelize::solid`] evaluates.

use std::collections::HashMap;
use std::hash::Hash;

use glam::DVec3;
use rayon::prelude::*;

use crate::grid::brick::FxHasher;
use crate::voxelize::surface::SurfaceTriangle;

type FxBuild = std::hash::BuildHasherDefault<FxHasher>;

/// The directed boundary edges of a triangle chain, each repeated by its
/// multiplicity (an edge used twice `a→b` and never `b→a` appears twice).
/// Vertices are compared by key (positions, for geometric boundaries).
/// Sorted, so the result does not depend on hashing order.
///
/// ```
/// use voxkit::voxelize::caps::boundary_edges;
/// // Two triangles sharing the edge 1–2 (used 1→2 and 2→1): a square's rim.
/// let e = boundary_edges([[0, 1, 2], [2, 1, 3]]);
/// assert_eq!(e, vec![(0, 1), (1, 3), (2, 0), (3, 2)]);
/// ```
pub fn boundary_edges<K, I>(triangles: I) -> Vec<(K, K)>
where
    K: Copy + Ord + Hash + Send + Sync,
    I: IntoIterator<Item = [K; 3]>,
{
    // Every use as (smaller, larger, ±1), sorted so that uses of one edge
    // are adjacent (a parallel sort beats a hash map on meshes of 10^5+).
    let triangles = triangles.into_iter();
    let mut uses: Vec<(K, K, i8)> = Vec::with_capacity(3 * triangles.size_hint().0);
    for t in triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            match a.cmp(&b) {
                std::cmp::Ordering::Less => uses.push((a, b, 1)),
                std::cmp::Ordering::Greater => uses.push((b, a, -1)),
                std::cmp::Ordering::Equal => {}
            }
        }
    }
    uses.par_sort_unstable_by(|x, y| (x.0, x.1).cmp(&(y.0, y.1)));
    uncancelled(
        &uses,
        |x, y| (x.0, x.1) == (y.0, y.1),
        |u| i64::from(u.2),
        |u| (u.0, u.1),
    )
}

/// The edges whose uses do not cancel, from uses sorted so that the uses of
/// one edge are adjacent (`same`): each group's signs (`+1` for a use
/// `smaller → larger`, `−1` the other way) summed, its edge (`(smaller,
/// larger)`, read once a group) directed by the sum's sign and repeated by
/// its size. Sorted.
fn uncancelled<U: Sync, K: Copy + Ord + Send + Sync>(
    uses: &[U],
    same: impl Fn(&U, &U) -> bool + Send + Sync,
    sign: impl Fn(&U) -> i64 + Sync,
    edge: impl Fn(&U) -> (K, K) + Sync,
) -> Vec<(K, K)> {
    // Pieces of ~64k uses cut between groups, counted first and then
    // written into one buffer of the exact size: most groups cancel, and a
    // collect of the few left grew per-thread vectors by copying, each copy
    // onto fresh pages.
    const PIECE: usize = 1 << 16;
    let n = uses.len();
    let mut cuts = vec![0];
    for i in 1..n.div_ceil(PIECE) {
        let mut c = (i * PIECE).max(cuts[cuts.len() - 1]);
        while c < n && same(&uses[c - 1], &uses[c]) {
            c += 1;
        }
        if c < n && c > cuts[cuts.len() - 1] {
            cuts.push(c);
        }
    }
    cuts.push(n);
    // Each group's net count (zero for a group that cancels).
    let net = |group: &[U]| -> i64 { group.iter().map(&sign).sum() };
    let piece = |w: &[usize]| uses[w[0]..w[1]].chunk_by(&same);
    let counts: Vec<usize> = cuts
        .par_windows(2)
        .map(|w| piece(w).map(|g| net(g).unsigned_abs() as usize).sum())
        .collect();
    let total = counts.iter().sum();
    let mut out: Vec<(K, K)> = Vec::with_capacity(total);
    let mut rest = &mut out.spare_capacity_mut()[..total];
    let mut slots = Vec::with_capacity(counts.len());
    for &c in &counts {
        let (head, tail) = rest.split_at_mut(c);
        slots.push(head);
        rest = tail;
    }
    cuts.par_windows(2).zip(slots).for_each(|(w, slot)| {
        let mut slot = slot.iter_mut();
        for group in piece(w) {
            let m = net(group);
            if m == 0 {
                continue;
            }
            let (a, b) = edge(&group[0]);
            let e = if m > 0 { (a, b) } else { (b, a) };
            for s in slot.by_ref().take(m.unsigned_abs() as usize) {
                s.write(e);
            }
        }
        debug_assert!(
            slot.next().is_none(),
            "the counting pass counted this piece"
        );
    });
    // SAFETY: the slots tile `0..total` of the spare capacity, and each
    // piece writes every slot of its own: the same groups and net counts as
    // the counting pass, which sized the slot. `K` is `Copy` (no drop
    // glue), so nothing leaks if a panic unwinds first.
    unsafe { out.set_len(total) };
    out.par_sort_unstable();
    out
}

/// Bias of [`packed_position`]'s coordinates.
const PACK_BIAS: i64 = 1 << 30;

/// A position as one `u128` key (32 bits per biased coordinate, x in the
/// high bits): monotone in the lexicographic order of `[i64; 3]` for
/// coordinates within `±2^30`, which fitted triangles are.
fn packed_position(p: [i64; 3]) -> u128 {
    p.iter().fold(0u128, |k, &c| {
        (k << 32) | (c + PACK_BIAS).clamp(0, u32::MAX as i64) as u128
    })
}

/// The squared distance between two fixed-point positions, exactly.
fn distance2(p: [i64; 3], q: [i64; 3]) -> i128 {
    (0..3)
        .map(|k| (p[k] - q[k]) as i128 * (p[k] - q[k]) as i128)
        .sum()
}

/// The position of a [`packed_position`] key.
fn unpacked_position(k: u128) -> [i64; 3] {
    [2, 1, 0].map(|i| ((k >> (32 * i)) as u32) as i64 - PACK_BIAS)
}

/// Every edge use of the triangles `first` then `second` (use `u` is edge
/// `u % 3` of triangle `u / 3`), written in parallel as `pack(smaller end,
/// larger end, 1 if the use runs smaller → larger else 0)`; `none` for a
/// degenerate edge.
fn packed_uses<U: Copy + Send + Sync>(
    first: &[SurfaceTriangle],
    second: &[SurfaceTriangle],
    none: U,
    pack: impl Fn([i64; 3], [i64; 3], u64) -> U + Sync,
) -> Vec<U> {
    let triangle = |i: usize| first.get(i).unwrap_or_else(|| &second[i - first.len()]);
    (0..3 * (first.len() + second.len()))
        .into_par_iter()
        .map(|u| {
            let t = triangle(u / 3);
            let (a, b) = (t[u % 3], t[(u + 1) % 3]);
            match a.cmp(&b) {
                std::cmp::Ordering::Less => pack(a, b, 1),
                std::cmp::Ordering::Greater => pack(b, a, 0),
                std::cmp::Ordering::Equal => none,
            }
        })
        .collect()
}

/// [`packed_boundary_edges`] with each use in one `u128` when the
/// coordinates span less than 2^21 (a grid of up to 8,192 voxels a side at
/// 1/256 voxel): the six coordinates less their minimum in 21 bits each,
/// the sign in the lowest bit. Sorting them as integers sorts them by
/// (lower end, upper end) and puts the uses of one edge next to each other;
/// a third less memory than 24-byte uses, and sorted in two-word compares.
/// `None` when the coordinates span more or lie beyond `±2^30`.
fn narrow_boundary_edges(
    first: &[SurfaceTriangle],
    second: &[SurfaceTriangle],
) -> Option<Vec<(u128, u128)>> {
    const BITS: u32 = 21;
    let soup = first.par_iter().chain(second);
    let (base, top) = soup
        .map(|t| {
            let c = t.iter().flatten();
            (*c.clone().min().unwrap_or(&0), *c.max().unwrap_or(&0))
        })
        .reduce(|| (i64::MAX, i64::MIN), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    if base > top {
        return Some(Vec::new());
    }
    if top - base >= 1 << BITS || base < -PACK_BIAS || top >= PACK_BIAS {
        return None;
    }
    // Degenerate edges (a == b) become this, which no use can be (it would
    // need bit 127) and which sorts last.
    const NONE: u128 = u128::MAX;
    let field = |c: i64| (c - base) as u128;
    let mut uses = packed_uses(first, second, NONE, |lo, hi, sign| {
        let k = lo
            .iter()
            .chain(&hi)
            .fold(0u128, |k, &c| k << BITS | field(c));
        k << 1 | u128::from(sign)
    });
    uses.par_sort_unstable();
    let end = uses.partition_point(|&u| u != NONE);
    let mask = (1u128 << BITS) - 1;
    Some(uncancelled(
        &uses[..end],
        |x, y| x >> 1 == y >> 1,
        |&u| if u & 1 == 1 { 1 } else { -1 },
        |&u| {
            let c: [i64; 6] =
                std::array::from_fn(|i| ((u >> (1 + BITS * (5 - i as u32))) & mask) as i64 + base);
            let (lo, hi) = ([c[0], c[1], c[2]], [c[3], c[4], c[5]]);
            (packed_position(lo), packed_position(hi))
        },
    ))
}

/// [`boundary_edges`] of the fixed-point triangles `first` and `second` by
/// [`packed_position`] keys,
/// each use packed in 24 bytes instead of 48 (the six biased coordinates in
/// 31 bits each, the sign in the lowest bit) and written in parallel: on
/// large meshes the uses' fresh memory is most of the caps' time. `None`
/// when a coordinate is beyond `±2^30`.
fn packed_boundary_edges(
    first: &[SurfaceTriangle],
    second: &[SurfaceTriangle],
) -> Option<Vec<(u128, u128)>> {
    const BITS: u32 = 31;
    let fits = |c: i64| (0..1 << BITS).contains(&(c + PACK_BIAS));
    let soup = first.par_iter().chain(second);
    if !soup.all(|t| t.iter().flatten().all(|&c| fits(c))) {
        return None;
    }
    // Degenerate edges (a == b) become this, which no use can be (its
    // middle word would need bit 63) and which sorts last.
    const NONE: [u64; 3] = [u64::MAX; 3];
    let biased = |p: [i64; 3]| p.map(|c| (c + PACK_BIAS) as u64);
    let mut uses = packed_uses(first, second, NONE, |lo, hi, sign| {
        let (p, q) = (biased(lo), biased(hi));
        // (x y | sign), (z x'), (y' z'): in the order of (lo, hi).
        [
            (p[0] << BITS | p[1]) << 2 | sign,
            p[2] << BITS | q[0],
            q[1] << BITS | q[2],
        ]
    });
    let key = |u: &[u64; 3]| (u[0] >> 1, u[1], u[2]);
    uses.par_sort_unstable_by_key(key);
    let end = uses.partition_point(|u| *u != NONE);
    let mask = (1u64 << BITS) - 1;
    Some(uncancelled(
        &uses[..end],
        |x, y| key(x) == key(y),
        |u| if u[0] & 1 == 1 { 1 } else { -1 },
        |u| {
            let c = [
                u[0] >> (BITS + 2),
                (u[0] >> 2) & mask,
                u[1] >> BITS,
                u[1] & mask,
                u[2] >> BITS,
                u[2] & mask,
            ]
            .map(|c| c as i64 - PACK_BIAS);
            let (lo, hi) = ([c[0], c[1], c[2]], [c[3], c[4], c[5]]);
            (packed_position(lo), packed_position(hi))
        },
    ))
}

/// Groups boundary edges by connected component (edges sharing a vertex),
/// in a deterministic order (by the smallest edge of each component).
pub fn boundary_components<K: Copy + Ord + Hash>(edges: &[(K, K)]) -> Vec<Vec<(K, K)>> {
    let mut id: HashMap<K, usize, FxBuild> = HashMap::default();
    for &(a, b) in edges {
        let n = id.len();
        id.entry(a).or_insert(n);
        let n = id.len();
        id.entry(b).or_insert(n);
    }
    let mut parent: Vec<usize> = (0..id.len()).collect();
    fn find(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for &(a, b) in edges {
        let (ra, rb) = (find(&mut parent, id[&a]), find(&mut parent, id[&b]));
        if ra != rb {
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let mut slot: HashMap<usize, usize, FxBuild> = HashMap::default();
    let mut out: Vec<Vec<(K, K)>> = Vec::new();
    // `edges` is sorted by the caller's contract or not; components come out
    // in the order of their first edge either way.
    for &(a, b) in edges {
        let r = find(&mut parent, id[&a]);
        let s = *slot.entry(r).or_insert_with(|| {
            out.push(Vec::new());
            out.len() - 1
        });
        out[s].push((a, b));
    }
    out
}

/// Caps `S'` with `∂S' = ∂S` for fixed-point triangles (see the
/// [module docs](self)), kept local: the boundary (a balanced directed
/// multigraph, in-degree = out-degree at every vertex) is split into short
/// directed cycles ([`boundary_cycles`]), and each cycle is closed on its
/// own: a 3-cycle by its own triangle, a longer one by `n − 2` triangles
/// between its vertices (halved by short chords). Oriented like `S` (so
/// `S − S'`, the mesh plus the reversed caps, is closed). One fan per
/// boundary *component* would be valid too, but where holes are everywhere
/// (a scan, triangles deleted at random) the holes touch at vertices, one
/// component spans the whole mesh, and its fan from a far centroid cuts
/// through the whole volume: then the caps' winding number jumps in every
/// brick and every brick must be decided voxel by voxel. Local caps lie on
/// the holes they close, so `w_{S'}` is smooth away from the surface. `degenerate` triangles (zero area) take part in the
/// boundary: they still pair their neighbours' edges. Caps of zero area are
/// dropped (they add nothing to a winding number or a crossing count).
/// Empty for a closed, consistently oriented mesh.
///
/// ```
/// use voxkit::voxelize::caps::boundary_caps;
/// // A unit square (two triangles, 1/256 fixed point) has one boundary loop:
/// let (o, x, y, xy) = ([0, 0, 0], [256, 0, 0], [0, 256, 0], [256, 256, 0]);
/// let caps = boundary_caps(&[[o, x, xy], [o, xy, y]], &[]);
/// assert_eq!(caps.len(), 2); // the square again, cut by a diagonal
/// assert!(caps.iter().all(|t| t.contains(&o) || t.contains(&x)));
/// ```
pub fn boundary_caps(
    triangles: &[SurfaceTriangle],
    degenerate: &[SurfaceTriangle],
) -> Vec<SurfaceTriangle> {
    boundary_caps_with_rim(triangles, degenerate).triangles
}

/// Caps and the boundary they close, as [`boundary_caps_with_rim`] returns
/// them.
#[derive(Clone, Debug, Default)]
pub struct Caps {
    /// The caps `S'` (as [`boundary_caps`] returns them).
    pub triangles: Vec<SurfaceTriangle>,
    /// `∂S`, the directed boundary edges of the mesh (with the degenerate
    /// triangles), sorted, with multiplicity. `∂S' = ∂S` as chains, except
    /// that caps of zero area are dropped: each is a flat loop whose
    /// Biot–Savart field vanishes off its line, so `∇w_{S'}` is the field of
    /// this rim wherever `w_{S'}` is smooth ([`crate::voxelize::winding::RimTree`]
    /// bounds it). Without dropped caps it is exactly `boundary_edges` of the
    /// caps, in the same order.
    pub rim: Vec<([i64; 3], [i64; 3])>,
}

/// [`boundary_caps`], keeping the boundary edges it found: the caps' own rim
/// without a second sort of their edges.
///
/// ```
/// use voxkit::voxelize::caps::{boundary_caps_with_rim, boundary_edges};
/// let (o, x, y, xy) = ([0, 0, 0], [256, 0, 0], [0, 256, 0], [256, 256, 0]);
/// let caps = boundary_caps_with_rim(&[[o, x, xy], [o, xy, y]], &[]);
/// assert_eq!(caps.rim, boundary_edges(caps.triangles.iter().copied()));
/// ```
pub fn boundary_caps_with_rim(
    triangles: &[SurfaceTriangle],
    degenerate: &[SurfaceTriangle],
) -> Caps {
    let boundary = Boundary::of(triangles, degenerate);
    Caps {
        triangles: boundary.caps(),
        rim: boundary.edges().collect(),
    }
}

/// A soup's boundary `∂S` ([`boundary_edges`] of the triangles and the
/// degenerate ones), kept packed: the caps over it ([`Boundary::caps`])
/// and a tree of its edges (the rim the caps' bounds need) can then be
/// built at the same time, the serial cycle search on one core and the
/// tree on the other.
#[derive(Clone, Debug, Default)]
pub struct Boundary {
    /// Sorted [`packed_position`] pairs, with multiplicity.
    edges: Vec<(u128, u128)>,
}

impl Boundary {
    /// The boundary of `triangles` with `degenerate` (zero-area triangles,
    /// which still pair their neighbours' edges).
    pub fn of(triangles: &[SurfaceTriangle], degenerate: &[SurfaceTriangle]) -> Self {
        let edges = narrow_boundary_edges(triangles, degenerate)
            .or_else(|| packed_boundary_edges(triangles, degenerate))
            .unwrap_or_else(|| {
                let soup = triangles.iter().chain(degenerate);
                boundary_edges(soup.map(|t| t.map(packed_position)))
            });
        Boundary { edges }
    }

    /// The edges, sorted as [`boundary_edges`] sorts them: `packed_position`
    /// is monotone in the lexicographic order of `[i64; 3]` (x in the high
    /// bits, no clamping below 2^30).
    pub fn edges(&self) -> impl Iterator<Item = ([i64; 3], [i64; 3])> + '_ {
        self.edges
            .iter()
            .map(|&(a, b)| (unpacked_position(a), unpacked_position(b)))
    }

    /// The caps closing the boundary (as [`boundary_caps`] returns them).
    pub fn caps(&self) -> Vec<SurfaceTriangle> {
        let dist2 = |a: u128, b: u128| distance2(unpacked_position(a), unpacked_position(b));
        let mut caps = Vec::with_capacity(self.edges.len());
        for cycle in boundary_cycles(&self.edges, dist2) {
            let cycle: Vec<[i64; 3]> = cycle.into_iter().map(unpacked_position).collect();
            close_cycle(&cycle, &mut caps);
        }
        caps
    }
}

/// Caps closing one directed cycle (`v0 → v1 → … → v0`, no vertex
/// repeated), zero-area triangles dropped, appended to `caps`: `n − 2`
/// triangles for `n` vertices, the fewest a triangulation of the cycle can
/// have. A 3-cycle is its own triangle; a longer one is cut by the shortest
/// of its halving chords `v_i – v_{i+⌊n/2⌋}` into two cycles that use it in
/// opposite directions, recursively. Halving keeps the caps small where
/// they can be (a fan from one apex puts every cap at the apex, each as
/// long as the hole is wide), and a random hole of `k` missing triangles
/// gets `k` caps back, not the `k + 2` of a fan from its centroid.
fn close_cycle(cycle: &[[i64; 3]], caps: &mut Vec<SurfaceTriangle>) {
    let n = cycle.len();
    if n < 3 {
        return;
    }
    if let [a, b, c] = cycle[..] {
        let t = [a, b, c];
        if !zero_area(&t) {
            caps.push(t);
        }
        return;
    }
    // The shortest of the chords that halve the cycle.
    let mid = n / 2;
    let i = (0..n)
        .min_by_key(|&i| (distance2(cycle[i], cycle[(i + mid) % n]), i))
        .unwrap_or(0);
    let arc = |from: usize, len: usize| -> Vec<[i64; 3]> {
        (0..=len).map(|k| cycle[(from + k) % n]).collect()
    };
    close_cycle(&arc(i, mid), caps);
    close_cycle(&arc(i + mid, n - mid), caps);
}

/// Splits a directed boundary (sorted edges with multiplicity, as
/// [`boundary_edges`] returns them; in-degree = out-degree at every vertex)
/// into directed cycles, each given by its vertices in order (the cycle
/// `v0 → v1 → … → v0`). Every edge is used exactly once. Short cycles are
/// taken first (triangles, then quadrilaterals: single missing triangles and
/// pairs of them); the rest is walked, turning at each vertex towards the
/// out-edge whose end is nearest (`dist2`) to the vertex the walk came from,
/// and cut into a cycle whenever the walk comes back to a vertex of its path.
/// Deterministic: it depends only on the sorted edge list.
///
/// ```
/// use voxkit::voxelize::caps::boundary_cycles;
/// // Two triangles' rims touching at vertex 0: two 3-cycles, not one 6-cycle.
/// let e = [(0u32, 1), (0, 3), (1, 2), (2, 0), (3, 4), (4, 0)];
/// let d = |a: u32, b: u32| (a as i128 - b as i128).pow(2);
/// let c = boundary_cycles(&e, d);
/// assert_eq!(c, vec![vec![0, 1, 2], vec![0, 3, 4]]);
/// ```
pub fn boundary_cycles<K: Copy + Ord + Hash + Send + Sync>(
    edges: &[(K, K)],
    dist2: impl Fn(K, K) -> i128,
) -> Vec<Vec<K>> {
    let sorted: std::borrow::Cow<[(K, K)]> = if edges.is_sorted() {
        edges.into()
    } else {
        let mut e = edges.to_vec();
        e.par_sort_unstable();
        e.into()
    };
    let edges = &sorted[..];
    let g = OutEdges::new(edges);
    let mut used = vec![false; edges.len()];
    let mut cycles = Vec::new();
    // Triangles, then quadrilaterals. Each edge's first cycle is searched
    // for in parallel with the edges used before the pass; the serial pass
    // takes it while its edges are still unused (then it is also the first
    // among the cycles of unused edges, which only shrink) and searches
    // again only when another cycle took one of them.
    for len in [3usize, 4] {
        let first: Vec<Option<[u32; 4]>> = (0..edges.len())
            .into_par_iter()
            .map(|i| short_cycle(&g, i, len, |e| used[e]))
            .collect();
        for (i, first) in first.into_iter().enumerate() {
            let Some(ids) = first else { continue };
            let fresh = |ids: &[u32; 4]| ids[..len].iter().all(|&e| !used[e as usize]);
            let ids = if fresh(&ids) {
                ids
            } else if used[i] {
                continue;
            } else if let Some(ids) = short_cycle(&g, i, len, |e| used[e]) {
                ids
            } else {
                continue;
            };
            cycles.push(ids[..len].iter().map(|&e| edges[e as usize].0).collect());
            for &e in &ids[..len] {
                used[e as usize] = true;
            }
        }
    }
    // The rest: walks cut into cycles where they meet themselves. `at[v]`:
    // the position of vertex `v` on the current path (`NOT_ON_PATH` off it).
    const NOT_ON_PATH: u32 = u32::MAX;
    let mut at = vec![NOT_ON_PATH; g.vertices.len()];
    for start in 0..edges.len() {
        if used[start] {
            continue;
        }
        let mut path = vec![g.source[start]];
        at[g.source[start] as usize] = 0;
        let mut next = Some(start);
        while let Some(e) = next {
            used[e] = true;
            let v = g.target[e];
            let i = at[v as usize];
            if i != NOT_ON_PATH {
                // Back on the path: path[i..] is a cycle.
                for &w in &path[i as usize + 1..] {
                    at[w as usize] = NOT_ON_PATH;
                }
                let cycle = path.split_off(i as usize);
                cycles.push(cycle.iter().map(|&w| g.vertices[w as usize]).collect());
                path.push(v);
                at[v as usize] = i;
            } else {
                at[v as usize] = path.len() as u32;
                path.push(v);
            }
            next = g
                .out(v)
                .filter(|&i| !used[i])
                .min_by_key(|&i| (dist2(edges[i].1, edges[e].0), i));
        }
        debug_assert_eq!(path.len(), 1, "a balanced boundary closes every walk");
        for &w in &path {
            at[w as usize] = NOT_ON_PATH;
        }
    }
    cycles
}

/// The first directed cycle of `len` (3 or 4) edges through edge `i`, `i`
/// first, visiting no vertex twice, among the edges `used` does not hold:
/// the edges in order (unused lanes `u32::MAX`). "First" is in the order of
/// the out-edge lists, the second edge varying slowest.
fn short_cycle<K: Copy + Ord + Hash + Send + Sync>(
    g: &OutEdges<K>,
    i: usize,
    len: usize,
    used: impl Fn(usize) -> bool,
) -> Option<[u32; 4]> {
    if used(i) {
        return None;
    }
    let (a, b) = (g.source[i], g.target[i]);
    // An unused edge `from → to` not in `skip`.
    let find = |from: u32, to: u32, skip: &[usize]| -> Option<usize> {
        g.out(from)
            .find(|&e| !used(e) && g.target[e] == to && !skip.contains(&e))
    };
    let id = |e: usize| e as u32;
    for j in g.out(b) {
        if used(j) || j == i {
            continue;
        }
        let c = g.target[j];
        if c == a || c == b {
            continue;
        }
        if len == 3 {
            if let Some(k) = find(c, a, &[i, j]) {
                return Some([id(i), id(j), id(k), u32::MAX]);
            }
            continue;
        }
        for k in g.out(c) {
            if used(k) || k == i || k == j {
                continue;
            }
            let d = g.target[k];
            if d == a || d == b || d == c {
                continue;
            }
            if let Some(l) = find(d, a, &[i, j, k]) {
                return Some([id(i), id(j), id(k), id(l)]);
            }
        }
    }
    None
}

/// A sorted directed edge list as a dense graph: vertices numbered in key
/// order, each edge's ends as numbers, and each vertex's out-edges as a
/// range of the list (the list is sorted by source), so that following an
/// edge costs no search.
struct OutEdges<K> {
    /// Vertex keys by number: every source, then targets that are no
    /// source (none when the boundary is balanced).
    vertices: Vec<K>,
    /// `first[v]..first[v + 1]`: the out-edges of vertex `v`.
    first: Vec<usize>,
    source: Vec<u32>,
    target: Vec<u32>,
}

impl<K: Copy + Ord + Hash + Send + Sync> OutEdges<K> {
    /// `edges` sorted.
    fn new(edges: &[(K, K)]) -> Self {
        let mut vertices: Vec<K> = Vec::new();
        let mut first = Vec::new();
        let mut source = Vec::with_capacity(edges.len());
        for (i, e) in edges.iter().enumerate() {
            if vertices.last() != Some(&e.0) {
                vertices.push(e.0);
                first.push(i);
            }
            source.push(vertices.len() as u32 - 1);
        }
        let sources = vertices.len();
        first.push(edges.len());
        // Each target's number from a hash of the sources (a binary search
        // per edge missed the cache at every step: a third of the cycle
        // search on a million triangles), sinks' numbers after them.
        let mut number: HashMap<K, u32, FxBuild> = HashMap::default();
        number.reserve(sources);
        for (v, &k) in vertices.iter().enumerate() {
            number.insert(k, v as u32);
        }
        let found: Vec<Option<u32>> = edges
            .par_iter()
            .map(|e| number.get(&e.1).copied())
            .collect();
        let mut sinks: Vec<K> = edges
            .iter()
            .zip(&found)
            .filter(|(_, f)| f.is_none())
            .map(|(e, _)| e.1)
            .collect();
        sinks.sort_unstable();
        sinks.dedup();
        // Sinks have no out-edges: empty ranges at the end.
        first.extend(std::iter::repeat_n(edges.len(), sinks.len()));
        let target = edges
            .iter()
            .zip(found)
            .map(|(e, f)| match f {
                Some(v) => v,
                None => (sources + sinks.binary_search(&e.1).unwrap_or(0)) as u32,
            })
            .collect();
        vertices.extend(sinks);
        OutEdges {
            vertices,
            first,
            source,
            target,
        }
    }

    fn out(&self, v: u32) -> std::ops::Range<usize> {
        self.first[v as usize]..self.first[v as usize + 1]
    }
}

/// Closes an indexed mesh's holes: for each boundary component (by vertex
/// index), a new vertex at its centroid and the reversed fan over its
/// boundary edges, so that the result has no boundary. Returns the new
/// positions and triangles (the old ones first, unchanged). A simple hole
/// filler for closed test meshes, not a fairing one.
///
/// ```
/// use glam::DVec3;
/// use voxkit::voxelize::caps::{boundary_edges, close_holes};
/// // A square (two triangles) becomes a closed double-sided sheet.
/// let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ONE.with_z(0.0)];
/// let (q, t) = close_holes(&p, &[[0, 1, 3], [0, 3, 2]]);
/// assert_eq!((q.len(), t.len()), (5, 6));
/// assert!(boundary_edges(t.iter().copied()).is_empty());
/// ```
pub fn close_holes(positions: &[DVec3], triangles: &[[u32; 3]]) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut p = positions.to_vec();
    let mut t = triangles.to_vec();
    let edges = boundary_edges(triangles.iter().copied());
    for component in boundary_components(&edges) {
        let centre = component
            .iter()
            .map(|&(a, _)| positions[a as usize])
            .sum::<DVec3>()
            / component.len() as f64;
        let apex = p.len() as u32;
        p.push(centre);
        t.extend(component.iter().map(|&(a, b)| [apex, b, a]));
    }
    (p, t)
}

fn zero_area(t: &SurfaceTriangle) -> bool {
    let e1 = [0, 1, 2].map(|a| (t[1][a] - t[0][a]) as i128);
    let e2 = [0, 1, 2].map(|a| (t[2][a] - t[0][a]) as i128);
    e1[1] * e2[2] == e1[2] * e2[1]
        && e1[2] * e2[0] == e1[0] * e2[2]
        && e1[0] * e2[1] == e1[1] * e2[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube_faces() -> (Vec<[i64; 3]>, Vec<[usize; 3]>) {
        let v: Vec<[i64; 3]> = (0..8)
            .map(|i| [(i & 1) * 512, ((i >> 1) & 1) * 512, ((i >> 2) & 1) * 512])
            .collect();
        // Outward-oriented cube.
        let f = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        (v, f)
    }

    fn tris(v: &[[i64; 3]], f: &[[usize; 3]]) -> Vec<SurfaceTriangle> {
        f.iter().map(|t| t.map(|i| v[i])).collect()
    }

    /// A boundary by packed uses (`None` where the packing declines).
    type Packing = fn(&[SurfaceTriangle], &[SurfaceTriangle]) -> Option<Vec<(u128, u128)>>;

    /// A packing finds the same boundary as the generic sort on 200 random
    /// soups (two slices) over small random lattices whose points have
    /// coordinates drawn by `coordinate` (few points, so that edges repeat,
    /// cancel, run both ways, twice the same way, and degenerate).
    fn assert_packing_matches(
        seed: u64,
        coordinate: impl Fn(&mut rand::rngs::StdRng, usize) -> i64,
        packing: Packing,
    ) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        for trial in 0..200 {
            let lattice: Vec<[i64; 3]> = (0..rng.random_range(3..12))
                .map(|_| [0, 1, 2].map(|_| coordinate(&mut rng, trial)))
                .collect();
            let mut soup = |n: usize| -> Vec<SurfaceTriangle> {
                (0..n)
                    .map(|_| [0, 1, 2].map(|_| lattice[rng.random_range(0..lattice.len())]))
                    .collect()
            };
            let (first, second) = (soup(trial % 40), soup(trial % 7));
            let generic =
                boundary_edges(first.iter().chain(&second).map(|t| t.map(packed_position)));
            assert_eq!(packing(&first, &second), Some(generic), "trial {trial}");
        }
    }

    /// The boundary equals a count of signed uses per edge in a map (an
    /// oracle sharing no code with the sort), on soups of up to 60k
    /// triangles over a few lattice points: edges used thousands of times,
    /// so that groups straddle the pieces `uncancelled` cuts its work into.
    #[test]
    fn boundary_edges_equal_a_count_per_edge() {
        use rand::{Rng, SeedableRng};
        use std::collections::BTreeMap;
        let mut rng = rand::rngs::StdRng::seed_from_u64(23);
        for (points, triangles) in [(4u32, 30_000), (40, 60_000), (2_000, 50_000), (9, 5)] {
            let soup: Vec<[u32; 3]> = (0..triangles)
                .map(|_| [0, 1, 2].map(|_| rng.random_range(0..points)))
                .collect();
            let mut count: BTreeMap<(u32, u32), i64> = BTreeMap::new();
            for t in &soup {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    if a != b {
                        *count.entry((a.min(b), a.max(b))).or_default() +=
                            if a < b { 1 } else { -1 };
                    }
                }
            }
            let mut expected = Vec::new();
            for (&(a, b), &m) in &count {
                let e = if m > 0 { (a, b) } else { (b, a) };
                expected.extend(std::iter::repeat_n(e, m.unsigned_abs() as usize));
            }
            expected.sort_unstable();
            assert_eq!(
                boundary_edges(soup.iter().copied()),
                expected,
                "{points} points"
            );
            let at = |i: u32| [i as i64 % 13, i as i64 / 13 % 13, i as i64 / 169].map(|c| c * 256);
            let fixed: Vec<SurfaceTriangle> = soup.iter().map(|t| t.map(at)).collect();
            let mut by_position: Vec<_> = expected.iter().map(|&(a, b)| (at(a), at(b))).collect();
            by_position.sort_unstable();
            let found: Vec<_> = Boundary::of(&fixed, &[]).edges().collect();
            assert_eq!(found, by_position, "{points} points, by position");
        }
    }

    /// The packed uses find the same boundary as the generic sort, with
    /// coordinates at both ends of the packed range; beyond it they decline.
    #[test]
    fn packed_edges_equal_the_generic_sort() {
        use rand::Rng;
        let limit = (1i64 << 30) - 1;
        let coordinate = |rng: &mut rand::rngs::StdRng, _| match rng.random_range(0..6) {
            0 => -PACK_BIAS,
            1 => limit,
            _ => rng.random_range(-4..4) * 256,
        };
        assert_packing_matches(5, coordinate, packed_boundary_edges);
        let (a, b) = ([0, 0, 0], [256, 0, 0]);
        for far in [[1 << 30, 0, 0], [0, -PACK_BIAS - 1, 0]] {
            assert_eq!(packed_boundary_edges(&[[a, b, far]], &[]), None);
        }
    }

    /// The one-word uses find the same boundary as the generic sort, on
    /// lattices inside a window of 2^21 whose ends are used (the window
    /// anywhere in `±2^30`, at both ends too); a window one wider, or one
    /// beyond `±2^30`, declines.
    #[test]
    fn narrow_edges_equal_the_generic_sort() {
        use rand::Rng;
        let span = (1i64 << 21) - 1;
        // One window per trial: the seed of its base is the trial.
        let base = |trial: usize| match trial % 3 {
            0 => -PACK_BIAS,
            1 => PACK_BIAS - 1 - span,
            _ => -PACK_BIAS + (trial as i64 * 7_919_993) % (2 * PACK_BIAS - span),
        };
        let coordinate = |rng: &mut rand::rngs::StdRng, trial| match rng.random_range(0..5) {
            0 => base(trial),
            1 => base(trial) + span,
            _ => base(trial) + span / 2 + rng.random_range(-4..4) * 256,
        };
        assert_packing_matches(9, coordinate, narrow_boundary_edges);
        let (a, b) = ([0, 0, 0], [256, 0, 0]);
        for far in [[span + 1, 0, 0], [0, -span - 1, 0]] {
            assert_eq!(narrow_boundary_edges(&[[a, b, far]], &[]), None);
        }
        let beyond = [a, b, [0, 256, 0]].map(|p| p.map(|c| c + PACK_BIAS));
        assert_eq!(narrow_boundary_edges(&[beyond], &[]), None);
        assert_eq!(
            narrow_boundary_edges(&[[a, b, [span, 0, 0]]], &[]).map(|e| e.len()),
            Some(3)
        );
    }

    /// A hole's caps close it (their boundary is the cycle) with the
    /// fewest triangles (`n − 2`) and without a fan's apex: few caps meet
    /// at any vertex, so a brick near the cap is near few of them (a fan
    /// puts all `n` at its apex).
    #[test]
    fn cycles_are_halved_not_fanned() {
        for n in [3usize, 4, 9, 16, 17, 31, 64, 400] {
            let cycle: Vec<[i64; 3]> = (0..n)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / n as f64;
                    let z = if i % 3 == 0 { 256 } else { 0 }; // not planar
                    [(4e5 * a.cos()) as i64, (4e5 * a.sin()) as i64, z]
                })
                .collect();
            let mut caps = Vec::new();
            close_cycle(&cycle, &mut caps);
            let mut want: Vec<_> = (0..n).map(|i| (cycle[i], cycle[(i + 1) % n])).collect();
            want.sort_unstable();
            assert_eq!(boundary_edges(caps.iter().copied()), want, "n = {n}");
            let mut degree = HashMap::new();
            for t in &caps {
                for p in t {
                    *degree.entry(*p).or_insert(0) += 1;
                }
            }
            assert_eq!(caps.len(), n - 2, "n = {n}");
            let most = degree.values().copied().max().unwrap_or(0);
            assert!(
                most <= 2 + 2 * n.ilog2() as usize,
                "n = {n}: {most} caps at one vertex"
            );
        }
    }

    #[test]
    fn closed_mesh_has_no_caps() {
        let (v, f) = cube_faces();
        assert!(boundary_caps(&tris(&v, &f), &[]).is_empty());
    }

    #[test]
    fn mesh_minus_caps_is_closed() {
        let (v, f) = cube_faces();
        for drop in [vec![0], vec![0, 1], vec![0, 5, 9], vec![2, 3, 4, 5]] {
            let kept: Vec<_> = f
                .iter()
                .enumerate()
                .filter(|(i, _)| !drop.contains(i))
                .map(|(_, t)| *t)
                .collect();
            let s = tris(&v, &kept);
            let caps = boundary_caps(&s, &[]);
            assert!(!caps.is_empty());
            let reversed = caps.iter().map(|t| [t[0], t[2], t[1]]);
            let closed: Vec<SurfaceTriangle> = s.iter().copied().chain(reversed).collect();
            assert!(
                boundary_edges(closed.iter().copied()).is_empty(),
                "{drop:?}"
            );
        }
    }

    #[test]
    fn flipped_face_counts_its_edges_twice() {
        let (v, mut f) = cube_faces();
        f[0] = [f[0][0], f[0][2], f[0][1]];
        let e = boundary_edges(tris(&v, &f).iter().copied());
        assert_eq!(e.len(), 6); // three edges, each twice
        let Caps {
            triangles: caps,
            rim,
        } = boundary_caps_with_rim(&tris(&v, &f), &[]);
        assert_eq!(rim, boundary_edges(caps.iter().copied()));
        let reversed = caps.iter().map(|t| [t[0], t[2], t[1]]);
        let closed: Vec<SurfaceTriangle> = tris(&v, &f).into_iter().chain(reversed).collect();
        assert!(boundary_edges(closed.iter().copied()).is_empty());
    }

    /// Holes everywhere (5, 20 and 40% of a sphere's faces deleted at
    /// random, 100 draws each, so holes touch at vertices and the boundary
    /// is one large component): the caps always close the mesh, and they
    /// stay on the holes they close. Measured against the widest hole (the
    /// bounding-box diagonal of a cluster of deleted faces joined by edges):
    /// at 5% and 20% no cap edge is longer (largest ratio 0.95 and 0.88);
    /// at 40%, where holes merge, a cycle can run through a vertex where two
    /// holes touch into the next one: 19 draws of 100 have a longer cap
    /// edge, at most 1.42× the widest hole. (A first version asserted a
    /// fixed 12.5-voxel bound and failed at 40%: the holes themselves are
    /// wider. Turning across the hole by the normal at such vertices gave 17
    /// of 100, not worth its cost; kept in the note of issue 22.)
    #[test]
    fn caps_of_scattered_holes_close_the_mesh_and_stay_local() {
        use crate::voxelize::shapes::IndexedMesh;
        use rand::{Rng, SeedableRng};
        let m = IndexedMesh::uv_sphere(DVec3::splat(30.0), 25.0, 24, 40);
        let q: Vec<[i64; 3]> = m
            .vertices
            .iter()
            .map(|v| v.to_array().map(|c| (c * 256.0).round() as i64))
            .collect();
        let len = |a: [i64; 3], b: [i64; 3]| {
            ((0..3).map(|k| ((a[k] - b[k]) as f64).powi(2)).sum::<f64>()).sqrt()
        };
        // Per deletion rate: draws with a cap edge longer than the widest
        // hole, and the largest ratio.
        let mut wider = [(0, 0.0f64); 3];
        for seed in 0..100 {
            let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
            for (r, pct) in [5, 20, 40].into_iter().enumerate() {
                let deleted: Vec<bool> = m
                    .faces
                    .iter()
                    .map(|_| rng.random_range(0..100) < pct)
                    .collect();
                let s: Vec<SurfaceTriangle> = m
                    .faces
                    .iter()
                    .zip(&deleted)
                    .filter(|(_, d)| !**d)
                    .map(|(f, _)| f.map(|i| q[i as usize]))
                    .collect();
                let Caps {
                    triangles: caps,
                    rim,
                } = boundary_caps_with_rim(&s, &[]);
                let reversed = caps.iter().map(|t| [t[0], t[2], t[1]]);
                let closed: Vec<SurfaceTriangle> = s.iter().copied().chain(reversed).collect();
                assert!(
                    boundary_edges(closed.iter().copied()).is_empty(),
                    "{seed} {pct}%"
                );
                // The rim handed to the caps' tree is their own boundary, in
                // the order a second sort of their edges would give.
                assert_eq!(rim, boundary_edges(caps.iter().copied()), "{seed} {pct}%");
                let widest_cap = caps
                    .iter()
                    .flat_map(|t| (0..3).map(|i| len(t[i], t[(i + 1) % 3])))
                    .fold(0.0, f64::max);
                let ratio = widest_cap / widest_cluster(&m.faces, &deleted, &q);
                wider[r].0 += usize::from(ratio > 1.0);
                wider[r].1 = wider[r].1.max(ratio);
            }
        }
        assert_eq!((wider[0].0, wider[1].0), (0, 0), "{wider:?}");
        assert!(wider[2].0 <= 25 && wider[2].1 < 1.5, "{wider:?}");
    }

    /// The largest bounding-box diagonal of a cluster of `deleted` faces
    /// (faces joined by a shared edge).
    fn widest_cluster(faces: &[[u32; 3]], deleted: &[bool], q: &[[i64; 3]]) -> f64 {
        let mut parent: Vec<usize> = (0..faces.len()).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        let mut by_edge: HashMap<(u32, u32), usize> = HashMap::new();
        for (i, f) in faces.iter().enumerate().filter(|(i, _)| deleted[*i]) {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if let Some(&j) = by_edge.get(&(a.min(b), a.max(b))) {
                    let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                    parent[ri] = rj;
                } else {
                    by_edge.insert((a.min(b), a.max(b)), i);
                }
            }
        }
        let mut boxes: HashMap<usize, ([i64; 3], [i64; 3])> = HashMap::new();
        for (i, f) in faces.iter().enumerate().filter(|(i, _)| deleted[*i]) {
            let b = boxes
                .entry(root(&mut parent, i))
                .or_insert(([i64::MAX; 3], [i64::MIN; 3]));
            for &v in f {
                for (a, &c) in q[v as usize].iter().enumerate() {
                    b.0[a] = b.0[a].min(c);
                    b.1[a] = b.1[a].max(c);
                }
            }
        }
        boxes
            .values()
            .map(|(lo, hi)| {
                ((0..3)
                    .map(|a| ((hi[a] - lo[a]) as f64).powi(2))
                    .sum::<f64>())
                .sqrt()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn cycles_use_every_edge_once() {
        // A figure eight (two loops through vertex 0), a doubled edge pair
        // and a hexagon.
        let e = [
            (0, 1),
            (1, 2),
            (2, 0),
            (0, 3),
            (3, 4),
            (4, 0),
            (7, 8),
            (8, 7),
            (7, 8),
            (8, 7),
            (10, 11),
            (11, 12),
            (12, 13),
            (13, 14),
            (14, 15),
            (15, 10),
        ];
        let c = boundary_cycles(&e, |a: i32, b: i32| i128::from(a - b).pow(2));
        let mut used: Vec<(i32, i32)> = c
            .iter()
            .flat_map(|v| (0..v.len()).map(move |i| (v[i], v[(i + 1) % v.len()])))
            .collect();
        used.sort_unstable();
        let mut want = e.to_vec();
        want.sort_unstable();
        assert_eq!(used, want);
        assert_eq!(c.iter().map(Vec::len).max(), Some(6));
    }

    #[test]
    fn components_are_separate() {
        let e = [(0, 1), (1, 2), (2, 0), (5, 6), (6, 5)];
        let c = boundary_components(&e);
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].len(), 3);
    }
}
