//! BrickGrid against a HashSet reference under seeded random operations, and
//! its conversions to and from dense grids.

use std::collections::HashSet;

use glam::IVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::VoxkitError;
use voxkit::grid::brick::brick_of;
use voxkit::grid::{BitGrid, BrickGrid, DenseGrid, MemoryLimit};

fn random_voxel(rng: &mut ChaCha8Rng, lo: i32, hi: i32) -> IVec3 {
    IVec3::new(
        rng.random_range(lo..hi),
        rng.random_range(lo..hi),
        rng.random_range(lo..hi),
    )
}

/// Sorted as BrickGrid::iter promises: brick (z, y, x), then x fastest inside.
fn reference_order(set: &HashSet<IVec3>) -> Vec<IVec3> {
    let mut v: Vec<IVec3> = set.iter().copied().collect();
    v.sort_by_key(|p| {
        let b = brick_of(*p);
        let l = *p - b * 8;
        (b.z, b.y, b.x, l.z, l.y, l.x)
    });
    v
}

fn check_same(g: &BrickGrid, set: &HashSet<IVec3>) {
    assert_eq!(g.count(), set.len() as u64);
    let bricks: HashSet<IVec3> = set.iter().map(|&v| brick_of(v)).collect();
    assert_eq!(
        g.brick_count(),
        bricks.len(),
        "one brick per occupied 8^3 block"
    );
    assert_eq!(g.iter().collect::<Vec<_>>(), reference_order(set));
    let bounds = set
        .iter()
        .fold(None, |acc: Option<(IVec3, IVec3)>, &v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        });
    assert_eq!(g.bounds(), bounds);
    assert_eq!(g.is_empty(), set.is_empty());
}

#[test]
fn random_ops_match_hashset() {
    let mut rng = ChaCha8Rng::seed_from_u64(0xB81C);
    for round in 0..20 {
        let (lo, hi) = if round % 2 == 0 {
            (-40, 40)
        } else {
            (-5000, 5000)
        };
        let mut g = BrickGrid::new();
        let mut set = HashSet::new();
        for _ in 0..3000 {
            let v = random_voxel(&mut rng, lo, hi);
            match rng.random_range(0..4) {
                0 | 1 => assert_eq!(g.insert(v), set.insert(v), "insert {v}"),
                2 => {
                    // Remove something likely present.
                    let v = if set.is_empty() || rng.random_bool(0.3) {
                        v
                    } else {
                        *set.iter().nth(rng.random_range(0..set.len())).unwrap()
                    };
                    assert_eq!(g.remove(v), set.remove(&v), "remove {v}");
                }
                _ => assert_eq!(g.contains(v), set.contains(&v), "contains {v}"),
            }
        }
        check_same(&g, &set);
        for &v in &set {
            assert!(g.contains(v));
            // A neighbour not in the set reads as empty.
            let n = v + IVec3::X;
            assert_eq!(g.contains(n), set.contains(&n));
        }
    }
}

#[test]
fn clearing_everything_releases_bricks() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut g = BrickGrid::new();
    let vs: Vec<IVec3> = (0..500)
        .map(|_| random_voxel(&mut rng, -100, 100))
        .collect();
    g.extend(vs.iter().copied());
    assert!(g.brick_count() > 0);
    for v in &vs {
        g.set(*v, false);
    }
    assert!(g.is_empty());
    assert_eq!(g.brick_count(), 0);
    assert_eq!(g.bounds(), None);
    assert_eq!(g, BrickGrid::new());
}

#[test]
fn union_and_merge_match_set_union() {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let parts: Vec<HashSet<IVec3>> = (0..4)
        .map(|k| {
            (0..(200 + 300 * k))
                .map(|_| random_voxel(&mut rng, -64, 64))
                .collect()
        })
        .collect();
    let grids: Vec<BrickGrid> = parts.iter().map(|s| s.iter().copied().collect()).collect();
    let all: HashSet<IVec3> = parts.iter().flatten().copied().collect();
    let merged = BrickGrid::merge(grids.clone());
    check_same(&merged, &all);
    let mut u = grids[0].clone();
    for g in &grids[1..] {
        u.union_with(g);
    }
    assert_eq!(u, merged);
    // Equality ignores insertion order.
    let rev: BrickGrid = reference_order(&all).into_iter().rev().collect();
    assert_eq!(rev, merged);
    assert_eq!(BrickGrid::merge(Vec::new()), BrickGrid::new());
}

#[test]
fn dense_conversions_round_trip() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let dims = [37, 20, 9];
    let mut g = BrickGrid::new();
    for _ in 0..800 {
        g.insert(IVec3::new(
            rng.random_range(0..37),
            rng.random_range(0..20),
            rng.random_range(0..9),
        ));
    }
    let bits = g.to_bit_grid(dims, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(bits.count_ones(), g.count());
    assert_eq!(BrickGrid::from_bit_grid(&bits), g);
    // The bit grid's x-fastest order is the brick grid's set.
    let from_bits: HashSet<IVec3> = bits.iter_ones().collect();
    assert_eq!(from_bits, g.iter().collect());
    let dense = g.to_dense_u8(dims, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(
        dense.as_slice().iter().filter(|&&c| c == 1).count() as u64,
        g.count()
    );
    assert_eq!(BrickGrid::from_dense(&dense, |&c| c != 0), g);

    let mut d2 = DenseGrid::new([3, 3, 3], 0u16, MemoryLimit::DEFAULT).unwrap();
    *d2.get_mut(IVec3::new(2, 0, 1)).unwrap() = 9;
    let b2 = BrickGrid::from_dense(&d2, |&c| c > 5);
    assert_eq!(b2.iter().collect::<Vec<_>>(), vec![IVec3::new(2, 0, 1)]);
    let _ = BitGrid::new([1, 1, 1], MemoryLimit::DEFAULT).unwrap();
}

#[test]
fn dense_conversion_checks_limit_and_range() {
    let mut g = BrickGrid::new();
    g.insert(IVec3::new(5, 5, 5));
    let err = g
        .to_bit_grid([4096, 4096, 4096], MemoryLimit::new(1 << 20))
        .unwrap_err();
    assert!(matches!(err, VoxkitError::Limits { .. }), "{err}");
    let err = g
        .to_dense_u8([1000, 1000, 1000], MemoryLimit::new(1 << 20))
        .unwrap_err();
    assert!(matches!(err, VoxkitError::Limits { .. }), "{err}");
    // A voxel outside the requested box is refused, not dropped.
    let err = g.to_bit_grid([4, 8, 8], MemoryLimit::DEFAULT).unwrap_err();
    assert!(matches!(err, VoxkitError::Invalid(_)), "{err}");
    g.insert(IVec3::new(-1, 0, 0));
    assert!(g.to_dense_u8([8, 8, 8], MemoryLimit::DEFAULT).is_err());
}

#[test]
fn memory_grows_with_bricks_not_bounds() {
    // Two far-apart voxels: two bricks, tiny memory.
    let mut g = BrickGrid::new();
    g.insert(IVec3::new(0, 0, 0));
    g.insert(IVec3::new(1 << 28, 1 << 28, -(1 << 28)));
    assert_eq!(g.brick_count(), 2);
    assert!(g.heap_bytes() < 4096, "{}", g.heap_bytes());
    // A full 64^3 block: 512 bricks, each full.
    let mut full = BrickGrid::new();
    for z in 0..64 {
        for y in 0..64 {
            for x in 0..64 {
                full.insert(IVec3::new(x, y, z));
            }
        }
    }
    assert_eq!(full.brick_count(), 512);
    assert_eq!(full.count(), 64 * 64 * 64);
    assert!(full.bricks().all(|(_, m)| *m == [u64::MAX; 8]));
    assert!(full.heap_bytes() >= 512 * 64);
    // Extreme coordinates work (arithmetic shift for negatives).
    let mut e = BrickGrid::new();
    for v in [IVec3::MIN, IVec3::MAX, IVec3::new(i32::MIN, 0, i32::MAX)] {
        assert!(e.insert(v));
        assert!(e.contains(v));
    }
    assert_eq!(e.bounds(), Some((IVec3::MIN, IVec3::MAX)));
}

// ---------------------------------------------------------------------------
// Tiles: a wholly set brick as one flag. Every query must see a tile as the
// full mask, so a tiled grid is compared with the same voxels stored as
// masks ("materialized": inserted voxel by voxel, which never makes tiles)
// and with a HashSet.

use proptest::prelude::*;
use voxkit::grid::brick::{BrickMask, FULL_BRICK, mask_voxels};

/// The same voxels inserted one by one: full bricks as stored masks.
pub fn materialized(g: &BrickGrid) -> BrickGrid {
    let mut m = BrickGrid::new();
    m.extend(g.iter_unordered());
    assert_eq!(m.tile_count(), 0);
    m
}

/// The voxels of brick `b`'s mask `m`.
fn brick_voxels(b: IVec3, m: BrickMask) -> impl Iterator<Item = IVec3> {
    mask_voxels(m).map(move |l| b * 8 + l)
}

/// A grid operation of the property test.
#[derive(Clone, Debug)]
enum Op {
    Insert(IVec3),
    Remove(IVec3),
    InsertTile(IVec3),
    OrBrick(IVec3, BrickMask),
}

fn brick_coord() -> impl Strategy<Value = IVec3> {
    (-2..2i32, -2..2i32, -2..2i32).prop_map(|(x, y, z)| IVec3::new(x, y, z))
}

fn voxel_coord() -> impl Strategy<Value = IVec3> {
    (-16..16i32, -16..16i32, -16..16i32).prop_map(|(x, y, z)| IVec3::new(x, y, z))
}

/// Masks from empty through sparse and dense to full and full-but-one.
fn mask() -> impl Strategy<Value = BrickMask> {
    prop_oneof![
        Just([0u64; 8]),
        Just(FULL_BRICK),
        (0..512u32).prop_map(|i| {
            let mut m = FULL_BRICK;
            m[(i / 64) as usize] &= !(1 << (i % 64));
            m
        }),
        prop::array::uniform8(any::<u64>()),
        prop::array::uniform8(any::<u64>()).prop_map(|m| m.map(|w| w & w >> 7 & w >> 13)),
    ]
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => voxel_coord().prop_map(Op::Insert),
        3 => voxel_coord().prop_map(Op::Remove),
        2 => brick_coord().prop_map(Op::InsertTile),
        2 => (brick_coord(), mask()).prop_map(|(b, m)| Op::OrBrick(b, m)),
    ]
}

/// Everything a reader of the grid can ask, against the set `want`.
fn check_queries(g: &BrickGrid, want: &HashSet<IVec3>) {
    check_same(g, want);
    let m = materialized(g);
    assert_eq!(*g, m);
    assert_eq!(m, *g);
    assert_eq!(g.brick_count(), g.mask_count() + g.tile_count());
    // Tiles are full, are never also stored masks, and every full brick is
    // either a tile or a full stored mask.
    for b in g.tiles() {
        assert!(g.is_tile(b));
        assert!((0..512).all(|i| want.contains(&(b * 8 + IVec3::new(i % 8, i / 8 % 8, i / 64)))));
    }
    let tiles: HashSet<IVec3> = g.tiles().collect();
    assert_eq!(tiles.len(), g.tile_count());
    for bz in -3..3 {
        for by in -3..3 {
            for bx in -3..3 {
                let b = IVec3::new(bx, by, bz);
                assert_eq!(g.brick(b), m.brick(b), "brick {b}");
                assert_eq!(g.is_tile(b), tiles.contains(&b));
                if g.is_tile(b) {
                    assert_eq!(g.brick(b), Some(&FULL_BRICK));
                }
            }
        }
    }
    for x in -17..17 {
        for y in -17..17 {
            for z in -17..17 {
                let v = IVec3::new(x, y, z);
                assert_eq!(g.contains(v), want.contains(&v), "contains {v}");
            }
        }
    }
    // Brick iterations: storage order, sorted, borrowed and owned.
    let mut stored: Vec<(IVec3, BrickMask)> = g.bricks().map(|(k, m)| (k, *m)).collect();
    stored.sort_by_key(|(k, _)| (k.z, k.y, k.x));
    assert_eq!(g.sorted_bricks(), stored);
    assert_eq!(m.sorted_bricks(), stored);
    let borrowed: Vec<(IVec3, BrickMask)> = g.sorted_bricks_iter().map(|(k, m)| (k, *m)).collect();
    assert_eq!(borrowed, stored);
    let unordered: HashSet<IVec3> = g.iter_unordered().collect();
    assert_eq!(&unordered, want);
    assert_eq!(g.iter_unordered().count() as u64, g.count());
    // Layers: ascending, non-empty, each brick once in its own layer.
    for axis in 0..3 {
        let mut seen = Vec::new();
        let mut last = i32::MIN;
        for (c, layer) in g.brick_layers(axis) {
            assert!(c > last && !layer.is_empty(), "axis {axis} layer {c}");
            last = c;
            for (k, m) in layer {
                assert_eq!(k[axis], c);
                seen.push((k, *m));
            }
        }
        seen.sort_by_key(|(k, _)| (k.z, k.y, k.x));
        assert_eq!(seen, stored, "layers along {axis}");
    }
    // Groups: in (z, y, x) order, bricks sorted inside.
    for shift in [2, 3, 5] {
        let flat: Vec<(IVec3, BrickMask)> = g
            .brick_groups(shift)
            .flat_map(|(c, list)| {
                assert!(!list.is_empty());
                list.into_iter().map(move |(k, m)| {
                    assert_eq!(k >> shift as i32, c);
                    (k, *m)
                })
            })
            .collect();
        let mut want_order = stored.clone();
        want_order.sort_by_key(|(k, _)| {
            let c = *k >> shift as i32;
            (c.z, c.y, c.x, k.z, k.y, k.x)
        });
        assert_eq!(flat, want_order, "groups of 2^{shift}");
    }
    // Dense conversions of the grid moved into the positive octant, built
    // back from its bricks by from_parts_tiled (tiles passed as tiles).
    let shift = IVec3::splat(3);
    let (mut keys, mut masks, mut tiles) = (Vec::new(), Vec::new(), Vec::new());
    for (k, m) in g.bricks() {
        if g.is_tile(k) {
            tiles.push(k + shift);
        } else {
            keys.push(k + shift);
            masks.push(*m);
        }
    }
    let moved = BrickGrid::from_parts_tiled(keys, masks, tiles);
    let dims = [48, 48, 48];
    let moved_set: HashSet<IVec3> = want.iter().map(|v| *v + shift * 8).collect();
    check_same(&moved, &moved_set);
    let bits = moved.to_bit_grid(dims, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(bits.iter_ones().collect::<HashSet<_>>(), moved_set);
    let dense = moved.to_dense_u8(dims, MemoryLimit::DEFAULT).unwrap();
    assert_eq!(
        dense.as_slice().iter().filter(|&&c| c == 1).count(),
        moved_set.len()
    );
    let back = BrickGrid::from_bit_grid(&bits);
    assert_eq!(back, moved);
    // Conversions make every full brick a tile.
    assert!(
        back.bricks()
            .all(|(k, m)| back.is_tile(k) == (*m == FULL_BRICK))
    );
    assert_eq!(BrickGrid::from_dense(&dense, |&c| c != 0), moved);
    let mut compact = m.clone();
    compact.compact_tiles();
    assert_eq!(compact, *g);
    assert!(
        compact
            .bricks()
            .all(|(k, m)| compact.is_tile(k) == (*m == FULL_BRICK))
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    /// Random mixes of tiles, partial and full masks, under voxel and brick
    /// operations: every query on the tiled grid equals the HashSet's and
    /// the materialized grid's.
    #[test]
    fn tiles_read_as_full_bricks(
        tiles in prop::collection::vec(brick_coord(), 0..12),
        parts in prop::collection::vec((brick_coord(), mask()), 0..12),
        ops in prop::collection::vec(op(), 0..60),
    ) {
        let mut want: HashSet<IVec3> = HashSet::new();
        for &(b, m) in &parts {
            want.extend(brick_voxels(b, m));
        }
        for &b in &tiles {
            want.extend(brick_voxels(b, FULL_BRICK));
        }
        let (keys, masks): (Vec<IVec3>, Vec<BrickMask>) = parts.iter().copied().unzip();
        let mut g = BrickGrid::from_parts_tiled(keys, masks, tiles.clone());
        check_queries(&g, &want);
        for op in &ops {
            match *op {
                Op::Insert(v) => prop_assert_eq!(g.insert(v), want.insert(v), "insert {}", v),
                Op::Remove(v) => {
                    let tile = g.is_tile(v >> 3);
                    prop_assert_eq!(g.remove(v), want.remove(&v), "remove {}", v);
                    if tile {
                        // The rest of the tile is now a stored mask.
                        prop_assert!(!g.is_tile(v >> 3));
                        prop_assert_eq!(g.brick(v >> 3).map(|m| m.iter().map(|w| w.count_ones()).sum::<u32>()), Some(511));
                    }
                }
                Op::InsertTile(b) => {
                    g.insert_tile(b);
                    want.extend(brick_voxels(b, FULL_BRICK));
                    prop_assert!(g.is_tile(b));
                }
                Op::OrBrick(b, m) => {
                    g.or_brick(b, &m);
                    want.extend(brick_voxels(b, m));
                    let full = brick_voxels(b, FULL_BRICK).all(|v| want.contains(&v));
                    // A brick that or_brick fills is a tile (or_brick of
                    // nothing stores nothing, not even a conversion).
                    if m != [0; 8] {
                        prop_assert_eq!(g.is_tile(b), full);
                    }
                }
            }
        }
        check_queries(&g, &want);
        // Unions and merges with tiles on either side.
        let other = materialized(&g);
        let mut u = BrickGrid::new();
        u.union_with(&g);
        // A union stores a full mask as a tile (or_brick), as compaction
        // does; `insert` leaves a mask it fills as a mask.
        let mut compacted = g.clone();
        compacted.compact_tiles();
        prop_assert_eq!(u.tile_count(), compacted.tile_count());
        u.union_with(&other);
        check_queries(&u, &want);
        let merged = BrickGrid::merge([other, g.clone(), BrickGrid::new()]);
        check_queries(&merged, &want);
    }
}

#[test]
fn tile_writes_and_from_parts_tiled() {
    let b = IVec3::new(1, -1, 0);
    let mut g = BrickGrid::new();
    g.insert_tile(b);
    // Inserting into a tile changes nothing and reports "already set".
    assert!(!g.insert(b * 8 + IVec3::new(3, 4, 5)));
    assert_eq!((g.count(), g.mask_count(), g.tile_count()), (512, 0, 1));
    g.set(b * 8, true);
    assert_eq!(g.count(), 512);
    // Clearing a voxel of a tile materializes the other 511.
    g.set(b * 8 + IVec3::new(7, 7, 7), false);
    assert_eq!((g.count(), g.mask_count(), g.tile_count()), (511, 1, 0));
    assert!(!g.is_tile(b) && !g.contains(b * 8 + IVec3::new(7, 7, 7)));
    // Filling it again voxel by voxel keeps a (full) mask; or_brick and
    // compact_tiles make it a tile.
    assert!(g.insert(b * 8 + IVec3::new(7, 7, 7)));
    assert_eq!((g.mask_count(), g.tile_count()), (1, 0));
    assert_eq!(g.brick(b), Some(&FULL_BRICK));
    let mut h = g.clone();
    h.compact_tiles();
    assert_eq!((h.mask_count(), h.tile_count()), (0, 1));
    assert_eq!(h, g);
    g.remove(b * 8);
    g.or_brick(b, &[1, 0, 0, 0, 0, 0, 0, 0]);
    assert!(g.is_tile(b) && g.mask_count() == 0);
    // from_parts_tiled: unsorted keys, repeats merged, a key both a mask
    // and a tile is a tile, full masks become tiles, empty masks vanish.
    let one = [1, 0, 0, 0, 0, 0, 0, 0];
    let two = [2, 0, 0, 0, 0, 0, 0, 0];
    let k = |x, y, z| IVec3::new(x, y, z);
    let g = BrickGrid::from_parts_tiled(
        vec![
            k(3, 0, 0),
            k(-5, 2, 1),
            k(0, 0, 0),
            k(3, 0, 0),
            k(9, 9, 9),
            k(4, 4, 4),
        ],
        vec![one, one, FULL_BRICK, two, [0; 8], one],
        vec![k(4, 4, 4), k(-1, -1, -1), k(-1, -1, -1)],
    );
    assert_eq!((g.mask_count(), g.tile_count()), (2, 3));
    assert_eq!(g.brick(k(3, 0, 0)), Some(&[3, 0, 0, 0, 0, 0, 0, 0]));
    assert_eq!(g.brick(k(9, 9, 9)), None);
    assert!(g.is_tile(k(0, 0, 0)) && g.is_tile(k(4, 4, 4)) && g.is_tile(k(-1, -1, -1)));
    assert_eq!(g.count(), 3 + 3 * 512);
    assert_eq!(
        g.bounds(),
        Some((IVec3::new(-40, -8, -8), IVec3::new(39, 39, 39)))
    );
    // Equality is by voxels: a tile equals the same brick as a full mask.
    let mut masks_only = BrickGrid::new();
    masks_only.extend(g.iter());
    assert_eq!(masks_only, g);
    masks_only.remove(IVec3::new(32, 32, 32));
    assert_ne!(masks_only, g);
}

/// Tiles cost a bit each in a 4³-brick block word, not 64 bytes: a solid
/// box of N = 64³ tiles (512³ voxels) takes under 1 byte per tile, and a
/// ball of about 400k tiles under 2; even scattered tiles, one per block,
/// stay under 64 bytes each (a mask alone is 64, plus key and map entry).
#[test]
fn tile_memory_is_far_below_a_mask_per_brick() {
    let n = 64;
    let mut g = BrickGrid::new();
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                g.insert_tile(IVec3::new(x, y, z));
            }
        }
    }
    let tiles = (n * n * n) as usize;
    assert_eq!(g.tile_count(), tiles);
    assert_eq!(g.count(), 512 * tiles as u64);
    eprintln!(
        "box of {tiles} tiles: {} heap bytes ({:.3} per tile)",
        g.heap_bytes(),
        g.heap_bytes() as f64 / tiles as f64
    );
    assert!(g.heap_bytes() < tiles, "{} bytes", g.heap_bytes());

    // A ball of radius 46 bricks (368 voxels): the interior of a solid at 1024³.
    let r = 46;
    let ball = BrickGrid::from_parts_tiled(
        Vec::new(),
        Vec::new(),
        (-r..=r)
            .flat_map(|z| (-r..=r).flat_map(move |y| (-r..=r).map(move |x| IVec3::new(x, y, z))))
            .filter(|b| b.length_squared() <= r * r)
            .collect(),
    );
    let tiles = ball.tile_count();
    eprintln!(
        "ball of {tiles} tiles: {} heap bytes ({:.3} per tile)",
        ball.heap_bytes(),
        ball.heap_bytes() as f64 / tiles as f64
    );
    assert!(tiles > 400_000);
    assert!(ball.heap_bytes() < 2 * tiles, "{} bytes", ball.heap_bytes());

    let mut scattered = BrickGrid::new();
    for i in 0..10_000 {
        scattered.insert_tile(IVec3::new(4 * (i % 100), 4 * (i / 100), -8));
    }
    eprintln!(
        "10000 scattered tiles: {} heap bytes",
        scattered.heap_bytes()
    );
    assert!(scattered.heap_bytes() < 64 * 10_000);
    // The same box of voxels as stored masks: at least 64 bytes per brick.
    let m = materialized(&BrickGrid::from_parts_tiled(
        Vec::new(),
        Vec::new(),
        vec![IVec3::ZERO, IVec3::X, IVec3::Y],
    ));
    assert!(m.heap_bytes() >= 3 * 64);
}
