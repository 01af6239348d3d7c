//! Tunnel checks: hand-built shells with known verdicts, conservative
//! voxelizations of closed meshes, and the scanline flood against a plain
//! per-voxel breadth-first search on random grids.

use std::collections::VecDeque;

use glam::{DVec3, IVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use voxkit::grid::{BitGrid, MemoryLimit};
use voxkit::metric::{Connectivity, adjacent};
use voxkit::topology::tunnels::{
    closed_surface_tunnels, count_empty_components, patch_sides_connected, tunnel_path,
};
use voxkit::voxelize::conservative::conservative_reference;
use voxkit::voxelize::shapes::{IndexedMesh, random_rotation};
use voxkit::voxelize::solid::{interior_seeds, solid_voxels_parity};

const ALL: [Connectivity; 3] = [
    Connectivity::Six,
    Connectivity::Eighteen,
    Connectivity::TwentySix,
];
const SIX: Connectivity = Connectivity::Six;
const C26: Connectivity = Connectivity::TwentySix;

fn grid_from(n: [usize; 3], mut f: impl FnMut(IVec3) -> bool) -> BitGrid {
    let mut g = BitGrid::new(n, MemoryLimit::DEFAULT).unwrap();
    for z in 0..n[2] as i32 {
        for y in 0..n[1] as i32 {
            for x in 0..n[0] as i32 {
                let v = IVec3::new(x, y, z);
                if f(v) {
                    g.set(v, true);
                }
            }
        }
    }
    g
}

/// Checks a returned tunnel path: starts on the border, ends at a seed, all
/// empty, consecutive voxels N-adjacent.
fn assert_valid_path(g: &BitGrid, conn: Connectivity, seeds: &[IVec3], path: &[IVec3]) {
    let n = g.dims();
    let first = path[0];
    let on_border = (0..3).any(|a| first[a] == 0 || first[a] as usize + 1 == n[a]);
    assert!(on_border, "path starts inside: {first}");
    assert!(seeds.contains(path.last().unwrap()));
    assert!(
        path.iter()
            .all(|&v| g.linear_index(v).is_some() && !g.get(v))
    );
    assert!(path.windows(2).all(|w| adjacent(w[0], w[1], conn)));
}

/// Digital sphere shell: centres with (R − t) ≤ |v − c| ≤ (R + t).
fn band(n: usize, c: i32, r_lo2: f64, r_hi2: f64) -> BitGrid {
    grid_from([n; 3], |v| {
        let d2 = (v - IVec3::splat(c)).length_squared() as f64;
        d2 >= r_lo2 && d2 <= r_hi2
    })
}

#[test]
fn sphere_band_one_voxel_hole_is_a_six_tunnel() {
    let (n, c, r) = (25usize, 12i32, 9i32);
    // Band [R − ½, R + ½]: 6-tight (a face step changes |v − c| by ≤ 1).
    let lo = (r as f64 - 0.5).powi(2);
    let hi = (r as f64 + 0.5).powi(2);
    let mut g = band(n, c, lo, hi);
    let seeds = vec![IVec3::splat(c)];
    let v = closed_surface_tunnels(&g, SIX, &seeds).unwrap();
    assert!(!v.tunnel, "{v:?}");
    assert!(v.inside_empty > 2000 && v.outside_empty > 5000);
    let total_empty = g.len() as u64 - g.count_ones();
    assert_eq!(
        v.outside_empty + v.inside_empty + v.unreached_empty,
        total_empty
    );
    // On the axis only (c + R, c, c) is in the band: removing it opens a 6-path.
    let hole = IVec3::new(c + r, c, c);
    assert!(g.get(hole) && !g.get(hole - IVec3::X) && !g.get(hole + IVec3::X));
    g.set(hole, false);
    for conn in ALL {
        let v = closed_surface_tunnels(&g, conn, &seeds).unwrap();
        assert!(
            v.tunnel && v.first_inside_reached == Some(seeds[0]),
            "{conn:?}"
        );
        assert_eq!(v.inside_empty, 0);
        let path = tunnel_path(&g, conn, &seeds, MemoryLimit::DEFAULT)
            .unwrap()
            .unwrap();
        assert_valid_path(&g, conn, &seeds, &path);
        if conn == SIX {
            // The band was 6-tight: every 6-tunnel goes through the hole.
            assert!(path.contains(&hole));
        }
    }
}

#[test]
fn thick_sphere_band_has_no_26_tunnel() {
    // Band half-width √3/2 + margin: a 26-step changes |v − c| by ≤ √3.
    let (n, c, r) = (29usize, 14i32, 10.3f64);
    let t = 0.9;
    let g = band(n, c, (r - t) * (r - t), (r + t) * (r + t));
    let seeds = vec![IVec3::splat(c)];
    for conn in ALL {
        let v = closed_surface_tunnels(&g, conn, &seeds).unwrap();
        assert!(!v.tunnel, "{conn:?}");
        assert!(
            tunnel_path(&g, conn, &seeds, MemoryLimit::DEFAULT)
                .unwrap()
                .is_none()
        );
    }
}

/// A hollow box whose face has one voxel pushed inward ("dent"): the dent
/// voxel is a dead end for 6-paths but touches the interior diagonally.
#[test]
fn dent_is_26_leaky_but_6_tight() {
    let n = 12usize;
    let shell = |v: IVec3| {
        (1..=10).contains(&v.x)
            && (1..=10).contains(&v.y)
            && (1..=10).contains(&v.z)
            && (v.min_element() == 1 || v.max_element() == 10)
    };
    let mut g = grid_from([n; 3], shell);
    let seeds = vec![IVec3::splat(5), IVec3::new(2, 9, 3)];
    for conn in ALL {
        assert!(!closed_surface_tunnels(&g, conn, &seeds).unwrap().tunnel);
    }
    g.set(IVec3::new(10, 5, 5), false);
    g.set(IVec3::new(9, 5, 5), true);
    let v6 = closed_surface_tunnels(&g, SIX, &seeds).unwrap();
    assert!(!v6.tunnel, "{v6:?}");
    assert_eq!(v6.inside_empty, 8 * 8 * 8 - 1);
    let v18 = closed_surface_tunnels(&g, Connectivity::Eighteen, &seeds).unwrap();
    assert!(v18.tunnel);
    let v26 = closed_surface_tunnels(&g, C26, &seeds).unwrap();
    assert!(v26.tunnel && v26.first_inside_reached == Some(seeds[0]));
    let path = tunnel_path(&g, C26, &seeds, MemoryLimit::DEFAULT)
        .unwrap()
        .unwrap();
    assert_valid_path(&g, C26, &seeds, &path);
    assert!(path.contains(&IVec3::new(10, 5, 5)));
    assert!(
        tunnel_path(&g, SIX, &seeds, MemoryLimit::DEFAULT)
            .unwrap()
            .is_none()
    );
    // Components: 6 sees outside and inside apart; 26 joins them.
    assert_eq!(count_empty_components(&g, SIX).unwrap(), 2);
    assert_eq!(count_empty_components(&g, C26).unwrap(), 1);
}

/// A surface lying on the grid border: no empty border voxel, no outside
/// flood; a hole in the border face is a tunnel.
#[test]
fn surface_touching_the_grid_border() {
    let n = 9usize;
    let mut g = grid_from([n; 3], |v| v.min_element() == 0 || v.max_element() == 8);
    let seeds = vec![IVec3::splat(4)];
    for conn in ALL {
        let v = closed_surface_tunnels(&g, conn, &seeds).unwrap();
        assert!(!v.tunnel);
        assert_eq!(
            (v.outside_empty, v.inside_empty, v.unreached_empty),
            (0, 343, 0)
        );
    }
    g.set(IVec3::new(0, 3, 6), false);
    for conn in ALL {
        let v = closed_surface_tunnels(&g, conn, &seeds).unwrap();
        assert!(v.tunnel, "{conn:?}");
        assert_eq!(v.outside_empty, 344);
        let path = tunnel_path(&g, conn, &seeds, MemoryLimit::DEFAULT)
            .unwrap()
            .unwrap();
        assert_valid_path(&g, conn, &seeds, &path);
    }
    // Seeds outside the grid are bad input, not a panic.
    assert!(closed_surface_tunnels(&g, SIX, &[IVec3::new(-1, 0, 0)]).is_err());
    assert!(patch_sides_connected(&g, SIX, &[IVec3::new(9, 0, 0)], &[]).is_err());
}

/// Open patches: a naive plane (one voxel per column, unit steps) separates
/// 6-paths only; a flat full plane separates all; a 6-connected staircase
/// (standard plane) separates 26-paths too.
#[test]
fn open_patches_naive_standard_and_flat_planes() {
    let n = [16usize, 5, 16];
    let height = |x: i32| (x * 5) / 8 + 3; // slope 5/8: single steps
    let naive = grid_from(n, |v| v.z == height(v.x));
    // Standard plane: also fill the lower voxel where the height steps up,
    // making every column joint a face-connected staircase.
    let standard = grid_from(n, |v| {
        v.z == height(v.x) || (v.x > 0 && v.z == height(v.x) - 1 && height(v.x - 1) < height(v.x))
    });
    let flat = grid_from(n, |v| v.z == 7);
    let below: Vec<IVec3> = (0..16).map(|x| IVec3::new(x, 2, 0)).collect();
    let above: Vec<IVec3> = (0..16).map(|x| IVec3::new(x, 2, 15)).collect();
    let conn = |g: &BitGrid, c| {
        patch_sides_connected(g, c, &below, &above)
            .unwrap()
            .connected
    };
    assert!(!conn(&naive, SIX));
    assert!(conn(&naive, Connectivity::Eighteen));
    assert!(conn(&naive, C26));
    for c in ALL {
        assert!(!conn(&standard, c), "{c:?}");
        assert!(!conn(&flat, c), "{c:?}");
    }
    let v = patch_sides_connected(&naive, C26, &below, &above).unwrap();
    assert_eq!(v.first_b_reached, Some(above[0]));
    assert_eq!(v.reached_from_a, naive.len() as u64 - naive.count_ones());
}

/// Conservative voxelizations of closed meshes are 26-tunnel-free (any
/// 26-path between centres runs through the closed cubes it visits, and
/// crossing the surface needs a cube that meets it).
#[test]
fn conservative_shells_of_closed_meshes_have_no_tunnels() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    for case in 0..6 {
        let rot = random_rotation([rng.random(), rng.random(), rng.random()]);
        let off = DVec3::new(rng.random(), rng.random(), rng.random());
        let mesh = if case % 2 == 0 {
            IndexedMesh::uv_sphere(DVec3::ZERO, 9.3, 14, 24)
        } else {
            IndexedMesh::torus(DVec3::ZERO, 9.0, 3.4, 30, 14)
        }
        .transformed(rot, off + DVec3::splat(13.0));
        let tris = mesh.to_fixed_triangles().unwrap();
        let dims = [27usize; 3];
        let surface = voxels_to_grid(&conservative_reference(&tris).unwrap(), dims);
        let solid = solid_voxels_parity(&tris, dims, MemoryLimit::DEFAULT).unwrap();
        let seeds = interior_seeds(&solid, &surface);
        assert!(seeds.len() > 50, "case {case}: {} seeds", seeds.len());
        for conn in [SIX, C26] {
            let v = closed_surface_tunnels(&surface, conn, &seeds).unwrap();
            assert!(!v.tunnel, "case {case} {conn:?}: {v:?}");
            assert!(v.inside_empty >= seeds.len() as u64);
        }
        // Remove the surface voxels of one 6-line through the shell: a 6-tunnel.
        let mut holed = surface.clone();
        let s = seeds[seeds.len() / 2];
        let mut x = s.x;
        while x < 27 {
            holed.set(IVec3::new(x, s.y, s.z), false);
            x += 1;
        }
        let v = closed_surface_tunnels(&holed, SIX, &seeds).unwrap();
        assert!(v.tunnel, "case {case}");
    }
}

fn voxels_to_grid(v: &[IVec3], dims: [usize; 3]) -> BitGrid {
    let mut g = BitGrid::new(dims, MemoryLimit::DEFAULT).unwrap();
    for &p in v {
        assert!(g.set(p, true), "voxel {p} outside the test grid");
    }
    g
}

// ---- plain BFS oracle ------------------------------------------------------

fn bfs_labels(g: &BitGrid, conn: Connectivity) -> (Vec<u32>, u32) {
    let [nx, ny, nz] = g.dims();
    let moves: Vec<IVec3> = (-1..=1)
        .flat_map(|z| (-1..=1).flat_map(move |y| (-1..=1).map(move |x| IVec3::new(x, y, z))))
        .filter(|&m| adjacent(IVec3::ZERO, m, conn))
        .collect();
    let mut label = vec![0u32; g.len()];
    let mut next = 0;
    for z in 0..nz as i32 {
        for y in 0..ny as i32 {
            for x in 0..nx as i32 {
                let v = IVec3::new(x, y, z);
                let i = g.linear_index(v).unwrap();
                if g.get(v) || label[i] != 0 {
                    continue;
                }
                next += 1;
                label[i] = next;
                let mut q = VecDeque::from([v]);
                while let Some(p) = q.pop_front() {
                    for &m in &moves {
                        let w = p + m;
                        if let Some(j) = g.linear_index(w)
                            && !g.get(w)
                            && label[j] == 0
                        {
                            label[j] = next;
                            q.push_back(w);
                        }
                    }
                }
            }
        }
    }
    (label, next)
}

/// Random sparse and dense grids: component counts, closed-surface verdicts
/// and patch verdicts agree with a per-voxel BFS labelling.
#[test]
fn flood_matches_bfs_oracle_on_random_grids() {
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    for case in 0..150 {
        let n = [
            rng.random_range(1..12),
            rng.random_range(1..12),
            rng.random_range(1..12),
        ];
        let p = [0.15, 0.35, 0.5, 0.65][case % 4];
        let g = grid_from(n, |_| rng.random_bool(p));
        for conn in ALL {
            let (label, count) = bfs_labels(&g, conn);
            assert_eq!(
                count_empty_components(&g, conn).unwrap(),
                count as u64,
                "case {case}"
            );
            // Outside = labels present on the border.
            let mut outside = vec![false; count as usize + 1];
            for z in 0..n[2] as i32 {
                for y in 0..n[1] as i32 {
                    for x in 0..n[0] as i32 {
                        let v = IVec3::new(x, y, z);
                        let border = (0..3).any(|a| v[a] == 0 || v[a] as usize + 1 == n[a]);
                        let l = label[g.linear_index(v).unwrap()];
                        if border && l != 0 {
                            outside[l as usize] = true;
                        }
                    }
                }
            }
            let seeds: Vec<IVec3> = (0..4)
                .map(|_| {
                    IVec3::new(
                        rng.random_range(0..n[0] as i32),
                        rng.random_range(0..n[1] as i32),
                        rng.random_range(0..n[2] as i32),
                    )
                })
                .collect();
            let seed_label = |v: IVec3| label[g.linear_index(v).unwrap()];
            let want_tunnel = seeds
                .iter()
                .any(|&s| seed_label(s) != 0 && outside[seed_label(s) as usize]);
            let v = closed_surface_tunnels(&g, conn, &seeds).unwrap();
            assert_eq!(v.tunnel, want_tunnel, "case {case} {conn:?}");
            let size = |l: u32| label.iter().filter(|&&x| x == l).count() as u64;
            let out_total: u64 = (1..=count).filter(|&l| outside[l as usize]).map(size).sum();
            assert_eq!(v.outside_empty, out_total);
            let mut inside_labels: Vec<u32> = seeds
                .iter()
                .map(|&s| seed_label(s))
                .filter(|&l| l != 0 && !outside[l as usize])
                .collect();
            inside_labels.sort_unstable();
            inside_labels.dedup();
            assert_eq!(
                v.inside_empty,
                inside_labels.iter().map(|&l| size(l)).sum::<u64>()
            );
            if want_tunnel {
                let path = tunnel_path(&g, conn, &seeds, MemoryLimit::DEFAULT)
                    .unwrap()
                    .unwrap();
                assert_valid_path(&g, conn, &seeds, &path);
            }
            let pv = patch_sides_connected(&g, conn, &seeds[..2], &seeds[2..]).unwrap();
            let want = seeds[..2].iter().any(|&a| {
                seed_label(a) != 0 && seeds[2..].iter().any(|&b| seed_label(b) == seed_label(a))
            });
            assert_eq!(pv.connected, want, "case {case} {conn:?}");
        }
    }
}

/// Tunnel verdicts on a grid with tiles equal those on the same voxels
/// stored as masks: a thick spherical shell (its wall holds whole bricks,
/// which become tiles), closed and then drilled through (the drill clears
/// voxels inside tiles, which then become masks).
#[test]
fn tiles_give_the_same_tunnel_verdicts_as_masks() {
    use voxkit::grid::BrickGrid;
    let (n, c) = (80usize, 40i32);
    let shell = band(n, c, 14.0f64.powi(2), 36.0f64.powi(2));
    let mut tiled = BrickGrid::from_bit_grid(&shell);
    assert!(tiled.tile_count() > 100, "{} tiles", tiled.tile_count());
    let seeds = vec![IVec3::splat(c), IVec3::new(c + 5, c - 3, c + 2)];
    for drilled in [false, true] {
        if drilled {
            // A straight one-voxel hole along +x from the cavity outward.
            for x in c..n as i32 {
                tiled.remove(IVec3::new(x, c, c));
            }
        }
        let mut masks = BrickGrid::new();
        masks.extend(tiled.iter());
        assert_eq!(masks.tile_count(), 0);
        let a = tiled.to_bit_grid([n; 3], MemoryLimit::DEFAULT).unwrap();
        let b = masks.to_bit_grid([n; 3], MemoryLimit::DEFAULT).unwrap();
        assert_eq!(a, b);
        for conn in ALL {
            let va = closed_surface_tunnels(&a, conn, &seeds).unwrap();
            let vb = closed_surface_tunnels(&b, conn, &seeds).unwrap();
            assert_eq!(va, vb, "{conn:?}");
            assert_eq!(va.tunnel, drilled, "{conn:?}");
        }
    }
}
