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
