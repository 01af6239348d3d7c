//! The numerical-stability suite: hard inputs with exact expectations.
//!
//! Every case feeds the library inputs at the edges of what it promises —
//! coordinates at the ends of the documented ranges, endpoints one
//! fixed-point unit (2^-20 voxel) away from ties, sliver and needle
//! triangles, damaged meshes, meshes at scales 1e-6 … 1e6 and 1e7 from the
//! origin, rays of 10^5 … 10^6 voxels, render rays grazing faces, edges and
//! corners — and compares the result with an **independent oracle** or a
//! **stated error bound**. The oracles here share no code with what they
//! judge:
//!
//! * lines: the exact parameter interval of the infinitesimally shifted
//!   segment in each voxel (rationals in `i128`, the shift `(ε³, ε, ε²)`
//!   carried symbolically), so a line is right iff its voxels' intervals
//!   chain from `t = 0` to `t = 1` ([`ShiftedLine`]); the 26-line by the
//!   symbolic rounding of the shifted line at each column centre; and an
//!   exact merge of crossing times for Amanatides–Woo;
//! * triangles: Pick's theorem in `i128`, and exact point-in-triangle tests;
//! * voxelization: a separating-axis triangle–cube test written here in
//!   `i128` ([`triangle_meets_cube`]), a brute-force enumeration of lattice
//!   line crossings for the thin and thick kernels, analytic insides for
//!   tunnel checks, the brute-force winding number for solids;
//! * rendering: the first occupied voxel of the shifted segment.
//!
//! [`cases`] lists the cases; [`run_case`] runs one (catching panics, so a
//! report always gets a row), [`run_all`] runs a tier and [`markdown_table`]
//! formats the results. `tests/stability.rs` has one `#[test]` per case
//! (the long tier `#[ignore]`d); `docs/stability.md` explains each
//! expectation and records runs.
//!
//! ```
//! use voxkit::stability::{cases, run_case, Tier};
//! let case = cases().into_iter().find(|c| c.name == "out_of_range_inputs_are_typed_errors").unwrap();
//! let r = run_case(&case, Tier::Quick);
//! assert!(r.passed, "{}", r.observed);
//! ```

use std::cmp::Ordering;
use std::collections::HashSet;
use std::time::Instant;

use glam::{DVec3, IVec3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::camera::Camera;
use crate::error::VoxkitError;
use crate::fixed::{self, FixedPoint, HALF, ONE};
use crate::grid::{BrickGrid, GridFrame, MemoryLimit, Voxel};
use crate::line::amanatides_woo::aw_line;
use crate::line::segment::{MAX_FIXED, NARROW_MAX_DELTA};
use crate::line::{GridBox, Line18, Line26, Segment, Tripod6};
use crate::mesh::Mesh;
use crate::metric::Connectivity;
use crate::render::{GridTransform, OccupancyGrid, RayKind, RenderOptions, render_grid};
use crate::topology::{closed_surface_tunnels, is_connected_path};
use crate::triangle::index::{COORD_LIMIT, TriangleIndex};
use crate::voxelize::conservative::{FixedTriangle, conservative_voxels};
use crate::voxelize::pipeline::{
    Lattice, Voxelization, VoxelizeMode, VoxelizeOptions, voxelize_mesh,
};
use crate::voxelize::solid::winding_number;
use crate::voxelize::surface::{
    LineFamily, MAX_TRIANGLE_SPAN, SurfaceTriangle, THICK_FAMILIES, THIN_FAMILIES, VOXEL_ONE,
    triangle_crossings,
};

/// Which tier to run: `Quick` for CI (all cases well under a minute in
/// release on two cores), `Long` for the report (larger sizes, minutes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tier {
    /// CI sizes.
    Quick,
    /// Report sizes (`#[ignore]`d tests, `voxkit report`).
    Long,
}

impl Tier {
    /// The tier's name.
    pub fn name(self) -> &'static str {
        match self {
            Tier::Quick => "quick",
            Tier::Long => "long",
        }
    }

    fn pick<T>(self, quick: T, long: T) -> T {
        match self {
            Tier::Quick => quick,
            Tier::Long => long,
        }
    }
}

/// What a case found: what it expected, what it observed, and whether the
/// observation meets the expectation.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Outcome {
    /// The exact expectation or the stated bound.
    pub expectation: String,
    /// What was measured.
    pub observed: String,
    /// Whether the observation meets the expectation.
    pub passed: bool,
}

/// One stability case.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    /// Area (`lines`, `triangles`, `voxelize`, `scale`, `aw`, `render`).
    pub area: &'static str,
    /// Case name (also the name of its test in `tests/stability.rs`).
    pub name: &'static str,
    /// The case at a tier.
    pub run: fn(Tier) -> Outcome,
}

/// The result of one case at one tier.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseResult {
    /// Area of the case.
    pub area: &'static str,
    /// Case name.
    pub name: String,
    /// Tier it ran at.
    pub tier: Tier,
    /// The expectation or bound.
    pub expectation: String,
    /// What was observed (or the panic message).
    pub observed: String,
    /// Whether it passed.
    pub passed: bool,
    /// Wall time in seconds.
    pub seconds: f64,
}

/// Every case of the suite, in report order.
pub fn cases() -> Vec<Case> {
    vec![
        Case {
            area: "lines",
            name: "line_endpoints_at_range_ends",
            run: line_endpoints_at_range_ends,
        },
        Case {
            area: "lines",
            name: "line_spans_at_i64_i128_switch",
            run: line_spans_at_i64_i128_switch,
        },
        Case {
            area: "lines",
            name: "out_of_range_inputs_are_typed_errors",
            run: out_of_range_inputs_are_typed_errors,
        },
        Case {
            area: "lines",
            name: "tripod_ties_one_unit_away",
            run: tripod_ties_one_unit_away,
        },
        Case {
            area: "lines",
            name: "line26_ties_one_unit_away",
            run: line26_ties_one_unit_away,
        },
        Case {
            area: "triangles",
            name: "triangle_index_at_range_ends",
            run: triangle_index_at_range_ends,
        },
        Case {
            area: "voxelize",
            name: "kernel_i64_i128_switch",
            run: kernel_i64_i128_switch,
        },
        Case {
            area: "voxelize",
            name: "sliver_and_needle_triangles",
            run: sliver_and_needle_triangles,
        },
        Case {
            area: "voxelize",
            name: "closed_mesh_with_slivers",
            run: closed_mesh_with_slivers,
        },
        Case {
            area: "voxelize",
            name: "damaged_meshes_surface",
            run: damaged_meshes_surface,
        },
        Case {
            area: "voxelize",
            name: "damaged_meshes_solid",
            run: damaged_meshes_solid,
        },
        Case {
            area: "scale",
            name: "spot_scaled_and_offset",
            run: spot_scaled_and_offset,
        },
        Case {
            area: "aw",
            name: "amanatides_woo_long_rays",
            run: amanatides_woo_long_rays,
        },
        Case {
            area: "render",
            name: "render_grazing_segments",
            run: render_grazing_segments,
        },
        Case {
            area: "render",
            name: "render_grazing_images",
            run: render_grazing_images,
        },
    ]
}

/// Runs one case at `tier`, timing it; a panic becomes a failed result
/// whose `observed` is the panic message.
pub fn run_case(case: &Case, tier: Tier) -> CaseResult {
    let start = Instant::now();
    let out = std::panic::catch_unwind(|| (case.run)(tier)).unwrap_or_else(|e| {
        let msg = e
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "panic".into());
        Outcome {
            expectation: "no panic".into(),
            observed: format!("panicked: {msg}"),
            passed: false,
        }
    });
    CaseResult {
        area: case.area,
        name: case.name.to_string(),
        tier,
        expectation: out.expectation,
        observed: out.observed,
        passed: out.passed,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Runs every case at `tier`.
pub fn run_all(tier: Tier) -> Vec<CaseResult> {
    cases().iter().map(|c| run_case(c, tier)).collect()
}

/// The results as a Markdown table (area, case, tier, verdict, seconds,
/// expectation, observed), `|` in texts escaped.
///
/// ```
/// use voxkit::stability::{markdown_table, CaseResult, Tier};
/// let r = CaseResult { area: "lines", name: "x".into(), tier: Tier::Quick,
///     expectation: "a | b".into(), observed: "ok".into(), passed: true, seconds: 0.5 };
/// let t = markdown_table(&[r]);
/// assert!(t.contains("| lines | x | quick | pass | 0.50 | a \\| b | ok |"));
/// ```
pub fn markdown_table(results: &[CaseResult]) -> String {
    let esc = |s: &str| s.replace('|', "\\|").replace('\n', " ");
    let mut t = String::from(
        "| area | case | tier | verdict | s | expectation | observed |\n|---|---|---|---|---:|---|---|\n",
    );
    for r in results {
        t.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} | {} | {} |\n",
            r.area,
            r.name,
            r.tier.name(),
            if r.passed { "pass" } else { "**FAIL**" },
            r.seconds,
            esc(&r.expectation),
            esc(&r.observed)
        ));
    }
    t
}

/// Collects failures of a case: the first few messages and a count.
#[derive(Default)]
struct Failures {
    count: u64,
    first: Vec<String>,
}

impl Failures {
    fn check(&mut self, ok: bool, msg: impl FnOnce() -> String) {
        if !ok {
            self.count += 1;
            if self.first.len() < 3 {
                self.first.push(msg());
            }
        }
    }

    fn outcome(self, expectation: impl Into<String>, summary: String) -> Outcome {
        let passed = self.count == 0;
        let observed = if passed {
            summary
        } else {
            format!(
                "{summary}; {} failures, first: {}",
                self.count,
                self.first.join(" / ")
            )
        };
        Outcome {
            expectation: expectation.into(),
            observed,
            passed,
        }
    }
}

// ---------------------------------------------------------------------------
// Oracle: the infinitesimally shifted segment.
// ---------------------------------------------------------------------------

/// Rank of each axis's infinitesimal in the world shift `(ε³, ε, ε²)`:
/// y's is the largest (rank 0), then z (1), then x (2).
const SHIFT_RANK: [usize; 3] = [2, 0, 1];

/// A parameter `q + c·δ_axis` along the shifted segment: `q` and `c`
/// rationals (`i128` numerator, positive denominator), `δ` of rank
/// [`SHIFT_RANK`]`[axis]`. Ordered by `q`, then by the coefficient of the
/// largest infinitesimal, and so on.
#[derive(Clone, Copy, Debug)]
struct SymT {
    q: (i128, i128),
    rank: usize,
    c: (i128, i128),
}

impl SymT {
    const ZERO: SymT = SymT {
        q: (0, 1),
        rank: 0,
        c: (0, 1),
    };
    const ONE: SymT = SymT {
        q: (1, 1),
        rank: 0,
        c: (0, 1),
    };

    fn coef(&self, rank: usize) -> (i128, i128) {
        if self.rank == rank { self.c } else { (0, 1) }
    }
}

fn cmp_rat(a: (i128, i128), b: (i128, i128)) -> Ordering {
    (a.0 * b.1).cmp(&(b.0 * a.1))
}

impl PartialEq for SymT {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for SymT {}
impl PartialOrd for SymT {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for SymT {
    fn cmp(&self, o: &Self) -> Ordering {
        cmp_rat(self.q, o.q).then_with(|| {
            (0..3)
                .map(|r| cmp_rat(self.coef(r), o.coef(r)))
                .find(|c| *c != Ordering::Equal)
                .unwrap_or(Ordering::Equal)
        })
    }
}

/// The segment `a–b` (fixed point) shifted by the infinitesimal world vector
/// `(ε³, ε, ε²)`: the segment the tie rule of the lines is defined by. It
/// passes through no voxel edge or corner, so the voxels whose interior it
/// meets form one chain of face-adjacent voxels.
#[derive(Clone, Copy, Debug)]
pub struct ShiftedLine {
    a: FixedPoint,
    d: [i128; 3],
}

impl ShiftedLine {
    /// The shifted segment of fixed-point endpoints `a`, `b`.
    pub fn new(a: FixedPoint, b: FixedPoint) -> Self {
        ShiftedLine {
            a,
            d: [0, 1, 2].map(|i| b[i] as i128 - a[i] as i128),
        }
    }

    /// The open parameter interval in which the shifted segment lies inside
    /// voxel `v`, or `None` if it does not enter `v`'s interior.
    fn interval(&self, v: Voxel) -> Option<(SymT, SymT)> {
        let (mut lo, mut hi) = (SymT::ZERO, SymT::ONE);
        for i in 0..3 {
            let c = v[i] as i128 * ONE as i128;
            let (fmin, fmax) = (c - HALF as i128, c + HALF as i128);
            let a = self.a[i] as i128;
            let d = self.d[i];
            let rank = SHIFT_RANK[i];
            if d == 0 {
                // a + δ (δ > 0 infinitesimal) lies in [fmin, fmax] iff fmin ≤ a < fmax.
                if !(fmin <= a && a < fmax) {
                    return None;
                }
                continue;
            }
            let (enter, exit) = if d > 0 {
                (
                    SymT {
                        q: (fmin - a, d),
                        rank,
                        c: (-1, d),
                    },
                    SymT {
                        q: (fmax - a, d),
                        rank,
                        c: (-1, d),
                    },
                )
            } else {
                (
                    SymT {
                        q: (a - fmax, -d),
                        rank,
                        c: (1, -d),
                    },
                    SymT {
                        q: (a - fmin, -d),
                        rank,
                        c: (1, -d),
                    },
                )
            };
            lo = lo.max(enter);
            hi = hi.min(exit);
        }
        (lo < hi).then_some((lo, hi))
    }

    /// `Ok` iff `path` is exactly the sequence of voxels the shifted segment
    /// passes through, in order: each voxel's interior is met, consecutive
    /// intervals meet end to start, the first starts at `t = 0` and the last
    /// ends at `t = 1`. With `whole == false` (a clipped run) the ends are
    /// not required to be `0` and `1`.
    fn check_chain(&self, path: &[Voxel], whole: bool) -> std::result::Result<(), String> {
        if path.is_empty() {
            return Err("empty path".into());
        }
        let mut prev: Option<SymT> = None;
        for (k, &v) in path.iter().enumerate() {
            let Some((lo, hi)) = self.interval(v) else {
                return Err(format!("voxel {k} {v} is not met by the shifted segment"));
            };
            match prev {
                None if whole && lo != SymT::ZERO => {
                    return Err(format!("first voxel {v} is entered after t = 0"));
                }
                Some(p) if p != lo => {
                    return Err(format!(
                        "voxel {k} {v} does not follow voxel {} {}",
                        k - 1,
                        path[k - 1]
                    ));
                }
                _ => {}
            }
            prev = Some(hi);
        }
        if whole && prev != Some(SymT::ONE) {
            return Err(format!(
                "last voxel {} is left before t = 1",
                path[path.len() - 1]
            ));
        }
        Ok(())
    }

    /// The voxel of `candidates` that the shifted segment enters first, or
    /// `None` if it enters none (brute force over the candidates).
    fn first_entered(&self, candidates: impl Iterator<Item = Voxel>) -> Option<Voxel> {
        candidates
            .filter_map(|v| self.interval(v).map(|(lo, _)| (lo, v)))
            .min_by(|x, y| x.0.cmp(&y.0))
            .map(|(_, v)| v)
    }
}

/// The 26-line's voxel of column `c` (the voxel index along the major axis
/// `m`) by the world-shift rule, decided exactly: the shifted line's minor
/// coordinates at the column centre plane, rounded by `floor(x + ½)` with
/// an exact `.5` decided by the sign of the infinitesimal part. `None` when
/// the major axis is not strictly the longest (the frame's choice is then a
/// convention this oracle does not model).
fn line26_column(a: FixedPoint, b: FixedPoint, c: i64) -> Option<Voxel> {
    let d = [0, 1, 2].map(|i| b[i] as i128 - a[i] as i128);
    let m = (0..3).max_by_key(|&i| d[i].abs())?;
    if (0..3).any(|i| i != m && d[i].abs() == d[m].abs()) {
        return None;
    }
    let mut out = [0i64; 3];
    out[m] = c;
    let cm = c as i128 * ONE as i128;
    for u in (0..3).filter(|&u| u != m) {
        // x_u(c) = a_u + δ_u + (c − a_m − δ_m)·d_u/d_m, in fixed units; times d_m·sign.
        let s = d[m].signum();
        let den = d[m].abs();
        let num = (a[u] as i128) * den + (cm - a[m] as i128) * d[u] * s;
        // floor(x/ONE + ½) = floor((2·num + ONE·den) / (2·ONE·den)).
        let top = 2 * num + ONE as i128 * den;
        let bot = 2 * ONE as i128 * den;
        let mut k = top.div_euclid(bot);
        if top.rem_euclid(bot) == 0 {
            // Exactly on a boundary: the infinitesimal part δ_u − δ_m·d_u/d_m
            // decides; negative moves the point below the boundary.
            let neg = if SHIFT_RANK[u] < SHIFT_RANK[m] {
                false
            } else {
                // −δ_m·d_u/d_m dominates (d_u ≠ 0 here, else no δ_m term and δ_u > 0 decides).
                d[u] != 0 && (d[u] > 0) == (d[m] > 0)
            };
            if neg {
                k -= 1;
            }
        }
        out[u] = k as i64;
    }
    Some(Voxel::new(out[0] as i32, out[1] as i32, out[2] as i32))
}

fn voxel_of(p: FixedPoint) -> Voxel {
    Voxel::new(
        fixed::voxel_of(p[0]) as i32,
        fixed::voxel_of(p[1]) as i32,
        fixed::voxel_of(p[2]) as i32,
    )
}

/// Checks a 26-line against its documented contract (`line::line26`):
/// 26-connected, first voxel `V0` and last `V1`; every voxel is on the
/// shifted segment's chain, in chain order; and every column strictly
/// between the end columns holds the shifted line's rounded voxel at the
/// column centre ([`line26_column`]) — alone, except the first and last of
/// those columns, where the prefix and suffix (the tripod path compressed to
/// a 26-path) may add voxels. Returns `None` when the major axis is not
/// strictly the longest.
fn check_line26(
    a: FixedPoint,
    b: FixedPoint,
    path: &[Voxel],
) -> Option<std::result::Result<(), String>> {
    let d = [0, 1, 2].map(|i| b[i] as i128 - a[i] as i128);
    let m = (0..3).max_by_key(|&i| d[i].abs())?;
    if (0..3).any(|i| i != m && d[i].abs() == d[m].abs()) {
        return None;
    }
    let (v0, v1) = (voxel_of(a), voxel_of(b));
    if path.first() != Some(&v0) || path.last() != Some(&v1) {
        return Some(Err(format!(
            "ends {:?} {:?}, expected {v0} {v1}",
            path.first(),
            path.last()
        )));
    }
    if !is_connected_path(path, Connectivity::TwentySix) {
        return Some(Err("not 26-connected".into()));
    }
    let line = ShiftedLine::new(a, b);
    let mut prev: Option<SymT> = None;
    for (k, &v) in path.iter().enumerate() {
        let Some((lo, _)) = line.interval(v) else {
            return Some(Err(format!(
                "voxel {k} {v} is not on the shifted segment's chain"
            )));
        };
        if prev.is_some_and(|p| p >= lo) {
            return Some(Err(format!("voxel {k} {v} is out of chain order")));
        }
        prev = Some(lo);
    }
    let cols = (v1[m] - v0[m]).abs() as i64;
    let s = (v1[m] - v0[m]).signum() as i64;
    // The voxels of each column (the path is monotone along m): one pass.
    let mut by_col: std::collections::HashMap<i64, Vec<Voxel>> = std::collections::HashMap::new();
    for &v in path {
        by_col.entry(v[m] as i64).or_default().push(v);
    }
    for j in 1..cols {
        let c = v0[m] as i64 + s * j;
        let want = line26_column(a, b, c)?;
        let in_col = by_col.get(&c).map(Vec::as_slice).unwrap_or(&[]);
        if !in_col.contains(&want) {
            return Some(Err(format!(
                "column {j}: {in_col:?} lacks the centre voxel {want}"
            )));
        }
        if j > 1 && j < cols - 1 && in_col.len() != 1 {
            return Some(Err(format!("column {j}: {in_col:?}, expected only {want}")));
        }
    }
    Some(Ok(()))
}

fn seg(a: FixedPoint, b: FixedPoint) -> Segment {
    Segment::from_fixed(a, b).expect("segment in range")
}

// ---------------------------------------------------------------------------
// Lines.
// ---------------------------------------------------------------------------

/// Endpoints at ±2^30 (the range's ends, also exactly on them): the tripod
/// line is exactly the shifted segment's voxel chain; tripod, 26- and
/// 18-lines commute with an integer translation to the origin; a segment
/// spanning the whole range (−2^30 → 2^30, 2^31 voxels per axis) is checked
/// by clipped runs at its start, middle and end.
fn line_endpoints_at_range_ends(tier: Tier) -> Outcome {
    let mut rng = StdRng::seed_from_u64(1);
    let mut f = Failures::default();
    let n = tier.pick(300, 3000);
    let m = MAX_FIXED;
    let mut voxels = 0usize;
    for k in 0..n {
        // A corner of the range (each axis at +2^30 or −2^30), a short
        // segment inside it, endpoints possibly exactly on the range's end.
        let corner: [i64; 3] = std::array::from_fn(|_| if rng.random_bool(0.5) { m } else { -m });
        let mut p = || -> FixedPoint {
            std::array::from_fn(|i| {
                let back = if k % 4 == 0 && rng.random_bool(0.5) {
                    0
                } else {
                    rng.random_range(0..40 * ONE)
                };
                corner[i] - corner[i].signum() * back
            })
        };
        let (a, b) = (p(), p());
        let s = seg(a, b);
        let path: Vec<Voxel> = Tripod6::new(&s).collect();
        voxels += path.len();
        let oracle = ShiftedLine::new(a, b);
        if let Err(e) = oracle.check_chain(&path, true) {
            f.check(false, || format!("tripod {a:?}→{b:?}: {e}"));
        }
        // Translation by whole voxels commutes with every line (and the tie rule).
        let t: [i64; 3] =
            std::array::from_fn(|i| (corner[i] / ONE - corner[i].signum() * 20) * ONE);
        let (a0, b0) = (sub(a, t), sub(b, t));
        let tv = Voxel::new(
            (t[0] / ONE) as i32,
            (t[1] / ONE) as i32,
            (t[2] / ONE) as i32,
        );
        let s0 = seg(a0, b0);
        let moved = |it: &mut dyn Iterator<Item = Voxel>| it.map(|v| v + tv).collect::<Vec<_>>();
        f.check(moved(&mut Tripod6::new(&s0)) == path, || {
            format!("tripod not translation invariant {a:?}")
        });
        f.check(
            moved(&mut Line26::new(&s0)) == Line26::new(&s).collect::<Vec<_>>(),
            || format!("26-line not translation invariant {a:?}→{b:?}"),
        );
        f.check(
            moved(&mut Line18::new(&s0)) == Line18::new(&s).collect::<Vec<_>>(),
            || format!("18-line not translation invariant {a:?}→{b:?}"),
        );
        if let Some(Err(e)) = check_line26(a, b, &Line26::new(&s).collect::<Vec<_>>()) {
            f.check(false, || format!("26-line {a:?}→{b:?}: {e}"));
        }
    }
    // Whole-range segments: clipped runs near the start, the middle and the end.
    let mut runs = 0;
    for _ in 0..tier.pick(20, 200) {
        let off = |rng: &mut StdRng| rng.random_range(0..ONE);
        let a: FixedPoint = [-m + off(&mut rng), -m + off(&mut rng), m - off(&mut rng)];
        let b: FixedPoint = [
            m - off(&mut rng),
            m - 3 * ONE * rng.random_range(0..1000) - off(&mut rng),
            -m + off(&mut rng),
        ];
        let s = seg(a, b);
        let oracle = ShiftedLine::new(a, b);
        for (frac, end) in [
            (0.0, Some(voxel_of(a))),
            (0.5, None),
            (1.0, Some(voxel_of(b))),
        ] {
            let centre: [i64; 3] = std::array::from_fn(|i| {
                let x = a[i] as f64 + frac * (b[i] - a[i]) as f64;
                fixed::voxel_of(x as i64)
            });
            let lo = Voxel::new(
                centre[0] as i32 - 8,
                centre[1] as i32 - 8,
                centre[2] as i32 - 8,
            );
            let hi = lo + IVec3::splat(16);
            let run: Vec<Voxel> = Tripod6::clipped(&s, &GridBox { lo, hi }).collect();
            runs += 1;
            if let Err(e) = oracle.check_chain(&run, false) {
                f.check(false, || {
                    format!("clipped run at {frac} of {a:?}→{b:?}: {e}")
                });
            }
            f.check(
                run.iter().all(|&v| v.cmpge(lo).all() && v.cmple(hi).all()),
                || "run leaves its box".into(),
            );
            if let Some(e) = end {
                f.check(run.contains(&e), || {
                    format!("run at {frac} misses the end voxel {e}")
                });
            }
            voxels += run.len();
        }
    }
    f.outcome(
        "tripod == shifted-segment chain; 26-line meets its contract (chain, column-centre rounding); tripod/26/18 commute with integer translation; clipped runs of ±2^30 segments chain and hold the end voxels",
        format!("{n} corner segments, {runs} clipped runs, {voxels} voxels checked"),
    )
}

fn sub(a: FixedPoint, t: [i64; 3]) -> FixedPoint {
    [a[0] - t[0], a[1] - t[1], a[2] - t[2]]
}

/// Spans just under, at and just over 2^20 voxels (the `i64`/`i128` switch,
/// [`NARROW_MAX_DELTA`]) with sub-voxel endpoints: the tripod line is
/// exactly the shifted segment's chain and the 26-line exactly its column
/// rounding, on both sides of the switch.
fn line_spans_at_i64_i128_switch(tier: Tier) -> Outcome {
    let mut rng = StdRng::seed_from_u64(2);
    let mut f = Failures::default();
    let deltas = [
        NARROW_MAX_DELTA - 1,
        NARROW_MAX_DELTA,
        NARROW_MAX_DELTA + 1,
        NARROW_MAX_DELTA + ONE,
    ];
    let per = tier.pick(1, 4);
    let mut voxels = 0usize;
    let mut lines = 0;
    for &dm in &deltas {
        for _ in 0..per {
            let base: [i64; 3] =
                std::array::from_fn(|_| rng.random_range(-(1i64 << 45)..(1i64 << 45)));
            let m = rng.random_range(0..3);
            let mut d: [i64; 3] = std::array::from_fn(|_| rng.random_range(-(dm / 3)..(dm / 3)));
            d[m] = if rng.random_bool(0.5) { dm } else { -dm };
            let b = [base[0] + d[0], base[1] + d[1], base[2] + d[2]];
            let s = seg(base, b);
            let path: Vec<Voxel> = Tripod6::new(&s).collect();
            voxels += path.len();
            lines += 1;
            if let Err(e) = ShiftedLine::new(base, b).check_chain(&path, true) {
                f.check(false, || format!("tripod Δ={dm}: {e}"));
            }
            let rev: HashSet<Voxel> = Tripod6::new(&s.reversed()).collect();
            f.check(rev == path.iter().copied().collect(), || {
                format!("tripod Δ={dm}: reversal differs")
            });
            let p26: Vec<Voxel> = Line26::new(&s).collect();
            voxels += p26.len();
            match check_line26(base, b, &p26) {
                Some(Err(e)) => f.check(false, || format!("26-line Δ={dm}: {e}")),
                None => f.check(false, || "26-oracle not applicable".into()),
                _ => {}
            }
        }
    }
    f.outcome(
        "both sides of the 2^20-voxel switch: tripod == shifted-segment chain (and its reversal the same set); 26-line meets its contract (chain, column-centre rounding)",
        format!("{lines} lines with major span 2^20·2^20 fixed units −1, +0, +1, +2^20; {voxels} voxels"),
    )
}

/// Inputs just outside the documented ranges are typed errors
/// ([`VoxkitError::Invalid`]), never a panic; the range's ends are accepted.
fn out_of_range_inputs_are_typed_errors(_tier: Tier) -> Outcome {
    let mut f = Failures::default();
    let max = fixed::MAX_COORD;
    let unit = 1.0 / ONE as f64;
    let invalid = |r: &crate::Result<_>| matches!(r, Err(VoxkitError::Invalid(_)));
    let mut checks = 0;
    let mut check = |ok: bool, what: &str| {
        checks += 1;
        f.check(ok, || what.to_string());
    };
    check(
        Segment::from_f64([max, -max, max], [-max; 3]).is_ok(),
        "±2^30 rejected",
    );
    check(
        invalid(&Segment::from_f64([max + unit, 0.0, 0.0], [0.0; 3]).map(|_| ())),
        "2^30 + 2^-20 accepted",
    );
    check(
        invalid(&Segment::from_f64([0.0; 3], [0.0, -max - unit, 0.0]).map(|_| ())),
        "−2^30 − 2^-20 accepted",
    );
    check(
        invalid(&Segment::from_f64([f64::NAN, 0.0, 0.0], [0.0; 3]).map(|_| ())),
        "NaN accepted",
    );
    check(
        invalid(&Segment::from_f64([0.0; 3], [0.0, 0.0, f64::INFINITY]).map(|_| ())),
        "∞ accepted",
    );
    check(
        Segment::from_fixed([MAX_FIXED; 3], [-MAX_FIXED; 3]).is_ok(),
        "fixed ±2^50 rejected",
    );
    check(
        invalid(&Segment::from_fixed([MAX_FIXED + 1, 0, 0], [0; 3]).map(|_| ())),
        "fixed 2^50+1 accepted",
    );
    check(
        invalid(&Segment::from_fixed([0; 3], [0, 0, i64::MIN]).map(|_| ())),
        "i64::MIN accepted",
    );
    check(
        aw_line(DVec3::splat(max), DVec3::splat(-max)).is_ok(),
        "A–W ±2^30 rejected",
    );
    check(
        invalid(
            &aw_line(
                DVec3::new(max * (1.0 + f64::EPSILON), 0.0, 0.0),
                DVec3::ZERO,
            )
            .map(|_| ()),
        ),
        "A–W beyond 2^30 accepted",
    );
    check(
        invalid(&aw_line(DVec3::ZERO, DVec3::new(0.0, f64::NAN, 0.0)).map(|_| ())),
        "A–W NaN accepted",
    );
    let l = COORD_LIMIT;
    check(
        TriangleIndex::new([[l, l], [-l, l], [-l, -l]]).is_ok(),
        "triangle ±2^30 rejected",
    );
    check(
        invalid(&TriangleIndex::new([[l + 1, 0], [0, 0], [0, 1]]).map(|_| ())),
        "triangle 2^30+1 accepted",
    );
    check(
        invalid(&TriangleIndex::new([[0, 0], [0, -l - 1], [1, 0]]).map(|_| ())),
        "triangle −2^30−1 accepted",
    );
    check(
        conservative_voxels(&[[MAX_FIXED + 1, 0, 0], [0; 3], [0, ONE, 0]]).is_err(),
        "conservative beyond range accepted",
    );
    f.outcome(
        "range ends accepted; 2^-20 beyond them, NaN and ∞ give VoxkitError::Invalid (lines, A–W, TriangleIndex, conservative reference)",
        format!("{checks} inputs"),
    )
}

/// A segment through an exact tie (a voxel edge or corner, an endpoint on
/// a face or on a `.5` column boundary), possibly moved by one fixed-point
/// unit on random axes.
fn tie_segment(rng: &mut StdRng) -> (FixedPoint, FixedPoint) {
    // A point on a voxel edge/corner/face: some coordinates at k + ½.
    let p: [i64; 3] = std::array::from_fn(|_| {
        let k = rng.random_range(-6i64..6) * ONE;
        match rng.random_range(0..3) {
            0 => k + HALF,
            1 => k,
            _ => k + rng.random_range(0..ONE),
        }
    });
    // A direction of small integers (exact ties along it) or with a
    // sub-voxel part, and both endpoints at multiples of it from `p`.
    let small = [-3i64, -2, -1, 0, 0, 1, 2, 3];
    let dir: [i64; 3] = std::array::from_fn(|_| small[rng.random_range(0..small.len())] * HALF);
    let (s, t) = (rng.random_range(0..5), rng.random_range(0..5));
    let mut a: FixedPoint = std::array::from_fn(|i| p[i] - s * dir[i]);
    let mut b: FixedPoint = std::array::from_fn(|i| p[i] + t * dir[i]);
    for q in [&mut a, &mut b] {
        for c in q.iter_mut() {
            if rng.random_range(0..4) == 0 {
                *c += rng.random_range(-1..=1);
            }
        }
    }
    (a, b)
}

/// Sub-voxel endpoints at and one unit (2^-20) away from ties: the tripod
/// line is exactly the shifted segment's chain, and `b→a` is `a→b`
/// reversed.
fn tripod_ties_one_unit_away(tier: Tier) -> Outcome {
    let mut rng = StdRng::seed_from_u64(3);
    let mut f = Failures::default();
    let n = tier.pick(20_000, 300_000);
    let mut ties = 0;
    for _ in 0..n {
        let (a, b) = tie_segment(&mut rng);
        let s = seg(a, b);
        let path: Vec<Voxel> = Tripod6::new(&s).collect();
        if let Err(e) = ShiftedLine::new(a, b).check_chain(&path, true) {
            f.check(false, || format!("{a:?}→{b:?}: {e}"));
        }
        let mut rev: Vec<Voxel> = Tripod6::new(&s.reversed()).collect();
        rev.reverse();
        f.check(rev == path, || {
            format!("{a:?}→{b:?}: b→a is not a→b reversed")
        });
        // Count segments whose unshifted line touches an edge or corner.
        let touched = crate::topology::touched_voxels(a, b)
            .map(|t| t.len())
            .unwrap_or(0);
        ties += (touched > path.len()) as u64;
    }
    f.outcome(
        "tripod == shifted-segment chain exactly (order included); b→a == a→b reversed",
        format!("{n} segments near ties, {ties} of them through an exact edge or corner"),
    )
}

/// The 26-line near ties: exactly the shifted line's rounding at every
/// column centre, first and last voxel the endpoints' own.
fn line26_ties_one_unit_away(tier: Tier) -> Outcome {
    let mut rng = StdRng::seed_from_u64(4);
    let mut f = Failures::default();
    let n = tier.pick(20_000, 300_000);
    let (mut checked, mut symmetric) = (0u64, 0u64);
    for _ in 0..n {
        let (a, b) = tie_segment(&mut rng);
        let s = seg(a, b);
        let path: Vec<Voxel> = Line26::new(&s).collect();
        f.check(is_connected_path(&path, Connectivity::TwentySix), || {
            format!("{a:?}→{b:?}: not 26-connected")
        });
        if let Some(r) = check_line26(a, b, &path) {
            checked += 1;
            if let Err(e) = r {
                f.check(false, || format!("{a:?}→{b:?}: {e}"));
            }
        }
        let mut rev: Vec<Voxel> = Line26::new(&s.reversed()).collect();
        rev.reverse();
        symmetric += (rev == path) as u64;
    }
    f.outcome(
        "26-line: 26-connected from V0 to V1, on the shifted segment's chain in order, and the shifted line's rounded voxel at every inner column centre (alone in columns 2..M−2), where one axis is strictly longest",
        format!("{n} segments, {checked} with a strict major axis; b→a == a→b reversed on {symmetric}"),
    )
}

// ---------------------------------------------------------------------------
// Triangles.
// ---------------------------------------------------------------------------

fn gcd(a: i128, b: i128) -> i128 {
    let (mut a, mut b) = (a.abs(), b.abs());
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Lattice points of the closed triangle by Pick's theorem (`i128`).
fn pick_count(v: [[i64; 3]; 3]) -> i128 {
    let p = v.map(|q| [q[0] as i128, q[1] as i128]);
    let d2 = ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
        - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]))
        .abs();
    let bnd: i128 = (0..3)
        .map(|k| {
            let (u, w) = (p[k], p[(k + 1) % 3]);
            gcd(w[0] - u[0], w[1] - u[1])
        })
        .sum();
    if d2 == 0 {
        // Collinear: the segment between the extreme points.
        return bnd / 2 + 1;
    }
    // A = I + B/2 − 1  ⇒  I + B = (2A + B + 2) / 2.
    (d2 + bnd + 2) / 2
}

fn inside_closed(v: &[[i64; 2]; 3], p: [i64; 2]) -> bool {
    let o = |a: [i64; 2], b: [i64; 2], c: [i64; 2]| {
        (b[0] as i128 - a[0] as i128) * (c[1] as i128 - a[1] as i128)
            - (b[1] as i128 - a[1] as i128) * (c[0] as i128 - a[0] as i128)
    };
    let area = o(v[0], v[1], v[2]).signum();
    let e = [o(v[0], v[1], p), o(v[1], v[2], p), o(v[2], v[0], p)];
    e.iter().all(|&x| x * area >= 0)
}

/// TriangleIndex with vertices at ±2^30: `len` == Pick's theorem in `i128`;
/// every probed index `i` (the first and last few, and random ones) gives a
/// point inside the closed triangle with `index_of(point(i)) == i`; points
/// just outside have no index.
fn triangle_index_at_range_ends(tier: Tier) -> Outcome {
    let mut rng = StdRng::seed_from_u64(5);
    let mut f = Failures::default();
    let l = COORD_LIMIT;
    let n = tier.pick(200, 3000);
    let mut probes = 0u64;
    for k in 0..n {
        let mut c = || -> i64 {
            match rng.random_range(0..4) {
                0 => l,
                1 => -l,
                2 => rng.random_range(-l..=l),
                _ => {
                    (if rng.random_bool(0.5) { l } else { -l })
                        - rng.random_range(-3..=3i64).signum() * rng.random_range(0..4)
                }
            }
        };
        let mut v: [[i64; 2]; 3] = std::array::from_fn(|_| [c().clamp(-l, l), c().clamp(-l, l)]);
        if k % 10 == 0 {
            // A needle along a range-spanning edge: c one unit off the line ab.
            v = [[-l, -l + 1], [l, l - 1], [0, 1]];
            if k % 20 == 0 {
                v[2] = [1, 0];
            }
        }
        let Ok(t) = TriangleIndex::new(v) else {
            f.check(false, || format!("{v:?} rejected"));
            continue;
        };
        let want = pick_count(v.map(|q| [q[0], q[1], 0]));
        f.check(t.len() as i128 == want, || {
            format!("{v:?}: len {} Pick {want}", t.len())
        });
        let len = t.len();
        let mut idx: Vec<u64> = (0..3)
            .flat_map(|j| [j, len.saturating_sub(1 + j)])
            .filter(|&i| i < len)
            .collect();
        idx.extend((0..20).map(|_| rng.random_range(0..len)));
        for i in idx {
            probes += 1;
            let Some(p) = t.point(i) else {
                f.check(false, || format!("{v:?}: no point {i}"));
                continue;
            };
            f.check(inside_closed(&v, p), || {
                format!("{v:?}: point({i}) = {p:?} outside")
            });
            f.check(t.index_of(p) == Some(i), || {
                format!("{v:?}: index_of(point({i})) = {:?}", t.index_of(p))
            });
        }
        f.check(t.point(len).is_none(), || {
            format!("{v:?}: point(len) exists")
        });
        for q in v {
            for step in [[1, 0], [-1, 0], [0, 1], [0, -1]] {
                let p = [q[0] + step[0], q[1] + step[1]];
                if !inside_closed(&v, p) {
                    probes += 1;
                    f.check(t.index_of(p).is_none(), || {
                        format!("{v:?}: outside {p:?} has an index")
                    });
                }
            }
        }
    }
    f.outcome(
        "len == Pick (i128); index_of(point(i)) == i with point(i) inside, for first/last/random i; outside points have no index",
        format!("{n} triangles with vertices at ±2^30, {probes} probes"),
    )
}

// ---------------------------------------------------------------------------
// Voxelization oracles.
// ---------------------------------------------------------------------------

/// Whether the closed triangle `tri` meets the closed cube of voxel `v`,
/// with coordinates in fixed point of `one` units per voxel: the
/// separating-axis theorem with all 13 axes, exact in `i128` (products stay
/// below 2^126 for coordinates up to 2^40 units from the voxel).
pub fn triangle_meets_cube(tri: &[[i64; 3]; 3], v: Voxel, one: i64) -> bool {
    let c = [v.x, v.y, v.z].map(|x| x as i128 * one as i128);
    let p = tri.map(|q| [0, 1, 2].map(|i| q[i] as i128 - c[i]));
    let h = (one / 2) as i128;
    let sub = |a: [i128; 3], b: [i128; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [i128; 3], b: [i128; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let e = [sub(p[1], p[0]), sub(p[2], p[1]), sub(p[0], p[2])];
    let mut axes: Vec<[i128; 3]> = vec![[1, 0, 0], [0, 1, 0], [0, 0, 1], cross(e[0], e[1])];
    for ei in e {
        for u in [[1, 0, 0], [0, 1, 0], [0, 0, 1]] {
            axes.push(cross(ei, u));
        }
    }
    for n in axes {
        if n == [0, 0, 0] {
            continue;
        }
        let proj = p.map(|q| q[0] * n[0] + q[1] * n[1] + q[2] * n[2]);
        let r = h * (n[0].abs() + n[1].abs() + n[2].abs());
        let (lo, hi) = (proj.iter().min().unwrap(), proj.iter().max().unwrap());
        if *lo > r || *hi < -r {
            return false;
        }
    }
    true
}

/// The crossing voxels of `family` for one triangle (1/256 units) by brute
/// force: every lattice line `(i, j)` of the family in the projected
/// bounding box, inside the closed projected triangle (exact orientation
/// tests), depth solved as an exact rational and rounded by `floor(t + ½)`.
fn brute_crossings(tri: &SurfaceTriangle, family: LineFamily) -> HashSet<Voxel> {
    let to_family = |p: [i64; 3]| -> [i128; 3] {
        let [x, y, z] = p.map(|c| c as i128);
        match family {
            LineFamily::Axis(0) => [y, z, x],
            LineFamily::Axis(1) => [z, x, y],
            LineFamily::Axis(_) => [x, y, z],
            LineFamily::Diagonal(s1, s2) => [y - s1 as i128 * x, z - s2 as i128 * x, x],
        }
    };
    let p = tri.map(to_family);
    let one = VOXEL_ONE as i128;
    let o2 = |a: [i128; 3], b: [i128; 3], q: [i128; 2]| {
        (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])
    };
    let area = o2(p[0], p[1], [p[2][0], p[2][1]]);
    let mut out = HashSet::new();
    if area == 0 {
        return out;
    }
    let lo = |k: usize| p.iter().map(|q| q[k]).min().unwrap().div_euclid(one) - 1;
    let hi = |k: usize| p.iter().map(|q| q[k]).max().unwrap().div_euclid(one) + 1;
    // Normal n = e1 × e2 (family coordinates); n_t = area.
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        area,
    ];
    for j in lo(1)..=hi(1) {
        for i in lo(0)..=hi(0) {
            let q = [i * one, j * one];
            let e = [o2(p[0], p[1], q), o2(p[1], p[2], q), o2(p[2], p[0], q)];
            if !e.iter().all(|&x| x * area.signum() >= 0) {
                continue;
            }
            // n·(P − p0) = 0  ⇒  t = p0_t − (n_u (u − p0_u) + n_v (v − p0_v)) / n_t.
            let mut num = p[0][2] * n[2] - (n[0] * (q[0] - p[0][0]) + n[1] * (q[1] - p[0][1]));
            let mut den = n[2];
            if den < 0 {
                (num, den) = (-num, -den);
            }
            // Voxel T = floor(t/one + ½) = floor((2·num + one·den) / (2·one·den)).
            let t = (2 * num + one * den).div_euclid(2 * one * den);
            out.insert(family.to_voxel(i as i64, j as i64, t as i64));
        }
    }
    out
}

fn kernel_crossings(tri: &SurfaceTriangle, family: LineFamily) -> HashSet<Voxel> {
    let mut got = HashSet::new();
    triangle_crossings(tri, family, &mut |v| {
        got.insert(v);
    });
    got
}

/// Checks one triangle's crossings in every family against the brute force,
/// and that each crossing voxel meets the triangle (thin, thick ⊆
/// conservative).
fn check_crossings(f: &mut Failures, tri: &SurfaceTriangle, what: &str) -> usize {
    let mut n = 0;
    for family in THIN_FAMILIES.iter().chain(THICK_FAMILIES.iter()) {
        let got = kernel_crossings(tri, *family);
        let want = brute_crossings(tri, *family);
        n += want.len();
        f.check(got == want, || {
            format!(
                "{what} {family:?}: kernel {} vs brute {} voxels ({} differ)",
                got.len(),
                want.len(),
                got.symmetric_difference(&want).count()
            )
        });
        for v in &got {
            f.check(triangle_meets_cube(tri, *v, VOXEL_ONE), || {
                format!("{what} {family:?}: {v} does not meet the triangle")
            });
        }
    }
    n
}

/// A closed tetrahedron whose faces all span about `span` voxels.
fn needle_tetra(span: i64, rng: &mut StdRng) -> Vec<SurfaceTriangle> {
    let o = VOXEL_ONE;
    let j = |rng: &mut StdRng| rng.random_range(0..o);
    let a = [8 * o + j(rng), 8 * o + j(rng), 8 * o + j(rng)];
    let b = [
        a[0] + span * o + j(rng),
        a[1] + 3 * o + j(rng),
        a[2] + 2 * o + j(rng),
    ];
    let c = [a[0] + span / 2 * o, a[1] + 6 * o + j(rng), a[2] + j(rng)];
    let d = [
        a[0] + span / 3 * o,
        a[1] + 2 * o + j(rng),
        a[2] + 5 * o + j(rng),
    ];
    let faces = [[a, c, b], [a, b, d], [a, d, c], [b, c, d]];
    faces.to_vec()
}

/// Runs the thin and thick modes of the pipeline on triangles given in
/// grid-space 1/256 units (as a world mesh on a unit lattice whose voxel
/// corners are at integers, so the pipeline quantizes them back exactly).
fn voxelize_grid_mesh(tris: &[SurfaceTriangle], mode: VoxelizeMode) -> crate::Result<Voxelization> {
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    for t in tris {
        let base = positions.len() as u32;
        for p in t {
            positions
                .push(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / VOXEL_ONE as f64 + 0.5);
        }
        faces.push([base, base + 1, base + 2]);
    }
    let mesh = Mesh::from_parts("stability", positions, faces, vec![])?;
    let opts = VoxelizeOptions::on_lattice(
        Lattice::VoxelSize {
            voxel_size: 1.0,
            origin: Some(DVec3::ZERO),
        },
        mode,
    );
    voxelize_mesh(&mesh, &opts)
}

/// Tunnel verdict of `v` against inside `seeds` (grid voxels, those not in
/// the output), flooding from the grid border.
fn tunnel(
    v: &Voxelization,
    conn: Connectivity,
    inside: impl Fn(DVec3) -> bool,
) -> crate::Result<(bool, usize)> {
    let dims = v.frame.dims;
    let occ = v.grid.to_bit_grid(dims, MemoryLimit::DEFAULT)?;
    let mut seeds = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let c = Voxel::new(x as i32, y as i32, z as i32);
                if !occ.get(c) && inside(c.as_dvec3()) {
                    seeds.push(c);
                }
            }
        }
    }
    let verdict = closed_surface_tunnels(&occ, conn, &seeds)?;
    Ok((verdict.tunnel, seeds.len()))
}

/// Whether grid point `p` is inside the convex mesh `tris` (1/256 units) by
/// more than `margin` voxels; each face's normal is oriented away from the
/// centroid of the vertices, so the faces' winding does not matter.
fn inside_convex(tris: &[SurfaceTriangle], p: DVec3, margin: f64) -> bool {
    let to = |c: [i64; 3]| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) / VOXEL_ONE as f64;
    let centroid = tris
        .iter()
        .flat_map(|t| t.iter())
        .map(|&c| to(c))
        .sum::<DVec3>()
        / (3 * tris.len()) as f64;
    tris.iter().all(|t| {
        let q = t.map(to);
        let mut n = (q[1] - q[0]).cross(q[2] - q[0]);
        if n.dot(centroid - q[0]) > 0.0 {
            n = -n;
        }
        n.dot(p - q[0]) < -margin * n.length()
    })
}

/// The voxelization kernels at their `i64`/`i128` switch
/// ([`MAX_TRIANGLE_SPAN`] = 2^10 voxels): needle triangles spanning
/// 2^10 − 1 … 2^10 + 2 voxels give exactly the brute-force lattice-line
/// crossings in all seven families, each inside the triangle's conservative
/// set; closed needle tetrahedra are 6-tunnel-free thin and 26-tunnel-free
/// thick.
fn kernel_i64_i128_switch(tier: Tier) -> Outcome {
    let mut rng = StdRng::seed_from_u64(6);
    let mut f = Failures::default();
    let spans: Vec<i64> = match tier {
        Tier::Quick => vec![
            MAX_TRIANGLE_SPAN - 2,
            MAX_TRIANGLE_SPAN - 1,
            MAX_TRIANGLE_SPAN,
            MAX_TRIANGLE_SPAN + 1,
        ],
        Tier::Long => (MAX_TRIANGLE_SPAN - 4..=MAX_TRIANGLE_SPAN + 4)
            .chain([2 * MAX_TRIANGLE_SPAN])
            .collect(),
    };
    let mut crossings = 0;
    let mut meshes = 0;
    for &span in &spans {
        let tet = needle_tetra(span - 1, &mut rng);
        for (k, t) in tet.iter().enumerate() {
            crossings += check_crossings(&mut f, t, &format!("span {span} face {k}"));
        }
        for (mode, conn) in [
            (VoxelizeMode::Thin, Connectivity::Six),
            (VoxelizeMode::Thick, Connectivity::TwentySix),
        ] {
            match voxelize_grid_mesh(&tet, mode) {
                Ok(v) => {
                    meshes += 1;
                    // The pipeline's frame origin shifts the mesh: map back.
                    let shift = v.frame.origin;
                    let (tun, seeds) =
                        tunnel(&v, conn, |p| inside_convex(&tet, p + shift, 0.0)).unwrap();
                    f.check(!tun && seeds > 0, || {
                        format!("span {span} {mode:?}: tunnel {tun}, {seeds} seeds")
                    });
                }
                Err(e) => f.check(false, || format!("span {span}: {e}")),
            }
        }
    }
    f.outcome(
        "kernel crossings == brute force (7 families) and ⊆ conservative on both sides of 2^10; thin 6- and thick 26-tunnel-free",
        format!("spans {spans:?}: {crossings} crossings, {meshes} closed needle meshes"),
    )
}

/// Near-degenerate and sliver triangles: needles (two vertices one unit
/// apart), slivers (the third vertex one unit off a long edge: area/edge²
/// ≈ 2^-20 / length), and exactly collinear ones. The exact conservative
/// reference ([`conservative_voxels`], 2^-20) == the separating-axis test
/// here, checked on the 26-neighbourhood of the long edge's tripod line
/// (which contains every voxel within 2^-20 of the edge); the thin and thick
/// kernels (1/256) == brute-force crossings.
fn sliver_and_needle_triangles(tier: Tier) -> Outcome {
    let mut rng = StdRng::seed_from_u64(7);
    let mut f = Failures::default();
    let (n, len) = tier.pick((60, 2000i64), (21, 200_000i64));
    let mut checked = 0u64;
    let mut min_ratio = f64::INFINITY;
    for k in 0..n {
        let a: FixedPoint = std::array::from_fn(|_| rng.random_range(-ONE * 50..ONE * 50));
        let dir: [i64; 3] = std::array::from_fn(|i| {
            if i == k % 3 {
                len * ONE
            } else {
                rng.random_range(-len * ONE / 2..len * ONE / 2)
            }
        });
        let dir = dir.map(|x| x & !1); // even, so that a + dir/2 is exactly collinear
        let b = [a[0] + dir[0], a[1] + dir[1], a[2] + dir[2]];
        let t = rng.random_range(0.0..1.0);
        let mut c: FixedPoint = std::array::from_fn(|i| a[i] + (dir[i] as f64 * t) as i64);
        match k % 3 {
            0 => c[(k / 3) % 3] += 1,            // sliver: one unit off the edge
            1 => c = [a[0] + 1, a[1], a[2] - 1], // needle: c next to a
            _ => c = [a[0] + dir[0] / 2, a[1] + dir[1] / 2, a[2] + dir[2] / 2], // collinear
        }
        let tri = [a, b, c];
        let area2 = {
            let e1 = DVec3::new(
                (b[0] - a[0]) as f64,
                (b[1] - a[1]) as f64,
                (b[2] - a[2]) as f64,
            );
            let e2 = DVec3::new(
                (c[0] - a[0]) as f64,
                (c[1] - a[1]) as f64,
                (c[2] - a[2]) as f64,
            );
            e1.cross(e2).length() / e1.length_squared()
        };
        if area2 > 0.0 {
            min_ratio = min_ratio.min(area2 / 2.0);
        }
        let got: HashSet<Voxel> = match conservative_voxels(&tri) {
            Ok(it) => it.collect(),
            Err(e) => {
                f.check(false, || format!("{tri:?}: {e}"));
                continue;
            }
        };
        // Candidates: the 26-neighbourhood of the tripod line of the longest edge.
        let mut cand: HashSet<Voxel> = HashSet::new();
        for v in Tripod6::new(&seg(a, b)) {
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        cand.insert(v + IVec3::new(dx, dy, dz));
                    }
                }
            }
        }
        f.check(got.iter().all(|v| cand.contains(v)), || {
            format!("{tri:?}: output outside the candidate set")
        });
        for v in &cand {
            checked += 1;
            let want = triangle_meets_cube(&tri, *v, ONE);
            f.check(got.contains(v) == want, || {
                format!("{tri:?}: {v} reference {} SAT {want}", got.contains(v))
            });
        }
    }
    // The thin and thick kernels (1/256 voxel) on slivers one quantum off a
    // long edge, needles and collinear triples.
    let mut crossings = 0;
    for k in 0..tier.pick(30, 120) {
        let o = VOXEL_ONE;
        let a: [i64; 3] = std::array::from_fn(|_| rng.random_range(-o * 20..o * 20));
        let dir: [i64; 3] = std::array::from_fn(|i| {
            if i == k % 3 {
                150 * o
            } else {
                rng.random_range(-60 * o..60 * o) & !1
            }
        });
        let b = [a[0] + dir[0], a[1] + dir[1], a[2] + dir[2]];
        let t = rng.random_range(0.0..1.0);
        let mut c: [i64; 3] = std::array::from_fn(|i| a[i] + (dir[i] as f64 * t) as i64);
        match k % 3 {
            0 => c[(k / 3) % 3] += if k % 2 == 0 { 1 } else { -1 },
            1 => c = [b[0] - 1, b[1] + 1, b[2]],
            _ => c = [a[0] + dir[0] / 2, a[1] + dir[1] / 2, a[2] + dir[2] / 2],
        }
        crossings += check_crossings(&mut f, &[a, b, c], &format!("1/256 sliver {k}"));
    }
    f.outcome(
        "conservative reference == exact SAT on every candidate; thin/thick crossings == brute force and ⊆ conservative",
        format!("{n} needles/slivers/collinear at 2^-20 with edges of {len} voxels (smallest area/edge² {min_ratio:.1e}), {checked} candidate voxels; {crossings} crossings of 1/256 slivers"),
    )
}

/// A closed mesh containing slivers: an octahedron whose faces are split
/// into slivers by vertices one quantum (1/256 voxel) off an edge; thin is
/// 6-tunnel-free, thick 26-tunnel-free, conservative == SAT brute force.
fn closed_mesh_with_slivers(tier: Tier) -> Outcome {
    let mut f = Failures::default();
    let mut rng = StdRng::seed_from_u64(8);
    let reps = tier.pick(6, 40);
    let mut voxels = 0u64;
    for r in 0..reps {
        let o = VOXEL_ONE;
        let c = [
            40 * o + rng.random_range(0..o),
            40 * o + rng.random_range(0..o),
            40 * o + rng.random_range(0..o),
        ];
        let rad = 30 * o + rng.random_range(0..8 * o);
        let v = |d: [i64; 3]| [c[0] + d[0] * rad, c[1] + d[1] * rad, c[2] + d[2] * rad];
        let (px, nx, py, ny, pz, nz) = (
            v([1, 0, 0]),
            v([-1, 0, 0]),
            v([0, 1, 0]),
            v([0, -1, 0]),
            v([0, 0, 1]),
            v([0, 0, -1]),
        );
        let faces = [
            [px, py, pz],
            [py, nx, pz],
            [nx, ny, pz],
            [ny, px, pz],
            [py, px, nz],
            [nx, py, nz],
            [ny, nx, nz],
            [px, ny, nz],
        ];
        let mut tris = Vec::new();
        for (k, t) in faces.iter().enumerate() {
            // Split the face at a point one quantum (1/256 voxel) off its
            // edge t0–t1, outwards or inwards.
            let s = rng.random_range(1..20) as i64;
            let m = [0, 1, 2].map(|i| t[0][i] + (t[1][i] - t[0][i]) * s / 20);
            let off = if (k + r) % 2 == 0 { 1 } else { -1 };
            let m = [m[0] + off, m[1], m[2] - off];
            tris.push([t[0], m, t[2]]);
            tris.push([m, t[1], t[2]]);
            // The sliver (t0, t1, m) closes the gap to the neighbour, which
            // keeps the unsplit edge t1→t0: every edge is paired again.
            tris.push([t[0], t[1], m]);
        }
        for (mode, conn) in [
            (VoxelizeMode::Thin, Some(Connectivity::Six)),
            (VoxelizeMode::Thick, Some(Connectivity::TwentySix)),
            (VoxelizeMode::Conservative, None),
        ] {
            let vx = match voxelize_grid_mesh(&tris, mode) {
                Ok(vx) => vx,
                Err(e) => {
                    f.check(false, || format!("{mode:?}: {e}"));
                    continue;
                }
            };
            voxels += vx.grid.count();
            // Grid = mesh coordinates − frame origin (a whole number of voxels).
            let shift = vx.frame.origin;
            let conv: Vec<SurfaceTriangle> = faces.to_vec();
            if let Some(conn) = conn {
                // Seeds ½ voxel inside the octahedron: clear of the slivers.
                let (tun, seeds) =
                    tunnel(&vx, conn, |p| inside_convex(&conv, p + shift, 0.5)).unwrap();
                f.check(!tun && seeds > 0, || {
                    format!("rep {r} {mode:?}: tunnel {tun} ({seeds} seeds)")
                });
            }
            check_surface_against_sat(&mut f, &vx, mode, &format!("rep {r}"));
        }
    }
    f.outcome(
        "thin 6-tunnel-free, thick 26-tunnel-free (seeds: centres ½ voxel inside the octahedron), thin/thick ⊆ conservative == SAT brute force",
        format!("{reps} octahedra with 1/256-voxel slivers on every face, {voxels} voxels"),
    )
}

/// Conservative output == SAT brute force over the quantized triangles
/// (candidates: their voxel bounding boxes); thin/thick output ⊆ it.
fn check_surface_against_sat(f: &mut Failures, v: &Voxelization, mode: VoxelizeMode, what: &str) {
    let dims = v.frame.dims.map(|d| d as i32);
    let tris = &v.mesh.triangles;
    let in_grid = |c: Voxel| c.cmpge(IVec3::ZERO).all() && c.cmplt(IVec3::from_array(dims)).all();
    let mut want: HashSet<Voxel> = HashSet::new();
    for t in tris {
        let lo = |i: usize| {
            ((t.iter().map(|p| p[i]).min().unwrap() + VOXEL_ONE / 2).div_euclid(VOXEL_ONE) - 1)
                as i32
        };
        let hi = |i: usize| {
            ((t.iter().map(|p| p[i]).max().unwrap() + VOXEL_ONE / 2).div_euclid(VOXEL_ONE) + 1)
                as i32
        };
        for z in lo(2)..=hi(2) {
            for y in lo(1)..=hi(1) {
                for x in lo(0)..=hi(0) {
                    let c = Voxel::new(x, y, z);
                    if in_grid(c) && !want.contains(&c) && triangle_meets_cube(t, c, VOXEL_ONE) {
                        want.insert(c);
                    }
                }
            }
        }
    }
    let got: HashSet<Voxel> = v.grid.iter().collect();
    if mode == VoxelizeMode::Conservative {
        f.check(got == want, || {
            format!(
                "{what}: conservative {} vs SAT {} ({} differ)",
                got.len(),
                want.len(),
                got.symmetric_difference(&want).count()
            )
        });
    } else {
        let extra = got.difference(&want).count();
        f.check(extra == 0, || {
            format!("{what} {mode:?}: {extra} voxels outside the conservative set")
        });
    }
}

/// The damaged variants of a box (world units, a `16 × 12 × 10` box with
/// non-lattice corners): coincident vertices (a triangle soup),
/// zero-area faces, T-junctions, inconsistent winding, slivers (a face split
/// by a vertex 1e-12·edge off its diagonal), and an open box (one face
/// removed). Returns `(name, mesh, closed)`.
fn damaged_boxes() -> Vec<(&'static str, Mesh, bool)> {
    let lo = DVec3::new(2.3, 1.7, 2.1);
    let hi = DVec3::new(18.3, 13.7, 12.1);
    let corner = |k: u32| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let pos: Vec<DVec3> = (0..8).map(corner).collect();
    // Outward (counter-clockwise) quads.
    let quads: [[u32; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let tris_of = |q: [u32; 4]| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]];
    let base: Vec<[u32; 3]> = quads.iter().flat_map(|&q| tris_of(q)).collect();
    let mk = |p: Vec<DVec3>, t: Vec<[u32; 3]>| {
        Mesh::from_parts("damaged box", p, t, vec![]).expect("valid mesh")
    };
    let mut out = Vec::new();
    out.push(("box", mk(pos.clone(), base.clone()), true));
    // Coincident vertices: every triangle has its own copies.
    let mut p = Vec::new();
    let mut t = Vec::new();
    for tri in &base {
        let b = p.len() as u32;
        p.extend(tri.iter().map(|&i| pos[i as usize]));
        t.push([b, b + 1, b + 2]);
    }
    out.push(("coincident vertices", mk(p, t), true));
    // Zero-area faces: collinear triangles along edges and a repeated vertex position.
    let mut p = pos.clone();
    let mut t = base.clone();
    p.push((pos[0] + pos[1]) * 0.5);
    p.push(pos[3]);
    t.push([0, 8, 1]);
    t.push([3, 9, 2]);
    out.push(("zero-area faces", mk(p, t), true));
    // T-junction: the -z face split at the midpoint of its edge 0–1 (vertex 8)
    // while the -y face keeps the unsplit edge.
    let mut p = pos.clone();
    p.push((pos[0] + pos[1]) * 0.5);
    let mut t: Vec<[u32; 3]> = base.iter().skip(2).copied().collect();
    t.extend([[0, 2, 8], [8, 2, 3], [8, 3, 1]]);
    out.push(("T-junction", mk(p, t), true));
    // Inconsistent winding: every other triangle flipped.
    let t: Vec<[u32; 3]> = base
        .iter()
        .enumerate()
        .map(|(k, f)| if k % 2 == 0 { [f[0], f[2], f[1]] } else { *f })
        .collect();
    out.push(("inconsistent winding", mk(pos.clone(), t), true));
    // Slivers: the +z face's diagonal 4–7 gets a vertex 1e-12·edge off it,
    // splitting both triangles into slivers (collinear in f64? no: exact
    // collinearity is broken by 1e-12 relative, which 1/256 quantization
    // removes).
    let mut p = pos.clone();
    let mid =
        pos[4] * 0.37 + pos[7] * 0.63 + DVec3::new(1e-12, -1e-12, 0.0) * (pos[7] - pos[4]).length();
    p.push(mid);
    let mut t: Vec<[u32; 3]> = base
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != 2 && *k != 3)
        .map(|(_, f)| *f)
        .collect();
    t.extend([[4, 5, 8], [5, 7, 8], [4, 8, 6], [8, 7, 6]]);
    out.push(("slivers", mk(p, t), true));
    // Open: one face removed.
    out.push(("open box", mk(pos.clone(), base[2..].to_vec()), false));
    out
}

/// Damaged meshes, surface modes: conservative == SAT brute force; thin and
/// thick ⊆ it; where the mesh is closed, thin is 6- and thick 26-tunnel-free
/// (seeds: centres at least ½ voxel inside the box).
fn damaged_meshes_surface(tier: Tier) -> Outcome {
    let mut f = Failures::default();
    let res = tier.pick(20, 64);
    let mut runs = 0;
    for (name, mesh, closed) in damaged_boxes() {
        for (mode, conn) in [
            (VoxelizeMode::Conservative, None),
            (VoxelizeMode::Thin, Some(Connectivity::Six)),
            (VoxelizeMode::Thick, Some(Connectivity::TwentySix)),
        ] {
            let v = match voxelize_mesh(&mesh, &VoxelizeOptions::new(res, mode)) {
                Ok(v) => v,
                Err(e) => {
                    f.check(false, || format!("{name} {mode:?}: {e}"));
                    continue;
                }
            };
            runs += 1;
            check_surface_against_sat(&mut f, &v, mode, name);
            if let (Some(conn), true) = (conn, closed) {
                let (blo, bhi) = mesh.bounds();
                let (glo, ghi) = (v.frame.world_to_grid(blo), v.frame.world_to_grid(bhi));
                let inside = |p: DVec3| p.cmpgt(glo + 0.5).all() && p.cmplt(ghi - 0.5).all();
                let (tun, seeds) = tunnel(&v, conn, inside).unwrap();
                f.check(!tun && seeds > 0, || {
                    format!("{name} {mode:?}: tunnel {tun} ({seeds} seeds)")
                });
            }
        }
    }
    f.outcome(
        "conservative == SAT brute force; thin, thick ⊆ conservative; closed variants thin 6-, thick 26-tunnel-free",
        format!("7 variants (box, coincident vertices, zero-area faces, T-junction, inconsistent winding, slivers, open) × 3 modes at -r {res}: {runs} runs"),
    )
}

/// Damaged meshes, solid mode: every voxel off the thin surface is inside
/// iff the brute-force generalized winding number of the quantized mesh is
/// ≥ ½ (allowing `|w − ½| < 1e-9`, the same solid angles summed in
/// another order); for the closed, consistently wound box, parity gives
/// the same; flipped faces make the winding number non-integer and the
/// rule still holds.
fn damaged_meshes_solid(tier: Tier) -> Outcome {
    let mut f = Failures::default();
    let res = tier.pick(16, 40);
    let mut centres = 0u64;
    for (name, mesh, _) in damaged_boxes() {
        let thin = voxelize_mesh(&mesh, &VoxelizeOptions::new(res, VoxelizeMode::Thin));
        let solid = voxelize_mesh(&mesh, &VoxelizeOptions::new(res, VoxelizeMode::Solid));
        let (Ok(thin), Ok(solid)) = (thin, solid) else {
            f.check(false, || format!("{name}: voxelization failed"));
            continue;
        };
        let fixed: Vec<FixedTriangle> = solid
            .mesh
            .triangles
            .iter()
            .map(crate::voxelize::pipeline::to_reference)
            .collect();
        let dims = solid.frame.dims;
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let c = Voxel::new(x as i32, y as i32, z as i32);
                    if thin.grid.contains(c) {
                        f.check(solid.grid.contains(c), || {
                            format!("{name}: surface voxel {c} missing from solid")
                        });
                        continue;
                    }
                    centres += 1;
                    let w = winding_number(c.as_dvec3(), &fixed);
                    f.check(
                        solid.grid.contains(c) == (w >= 0.5) || (w - 0.5).abs() < 1e-9,
                        || format!("{name}: {c} w = {w}, solid {}", solid.grid.contains(c)),
                    );
                }
            }
        }
        if name == "box" {
            let mut o = VoxelizeOptions::new(res, VoxelizeMode::Solid);
            o.inside = crate::voxelize::solid::InsideTest::Parity;
            if let Ok(p) = voxelize_mesh(&mesh, &o) {
                f.check(
                    p.grid.iter().collect::<HashSet<_>>()
                        == solid.grid.iter().collect::<HashSet<_>>(),
                    || "box: parity != winding".into(),
                );
            }
        }
    }
    f.outcome(
        "solid ⊇ thin; off the thin surface, inside ⇔ brute-force winding number ≥ ½ (|w − ½| < 1e-9 excused); parity == winding on the closed box",
        format!("7 variants at -r {res}, {centres} centres off the surface"),
    )
}

// ---------------------------------------------------------------------------
// Scale.
// ---------------------------------------------------------------------------

/// Spot scaled by 1e-6 … 1e6 (powers of two and not) and moved 1e7 from the
/// origin, voxelized thin at the same `-r`, against the unit mesh. Stated
/// bound: the fitted dims are equal; every quantized vertex coordinate
/// (1/256 voxel) differs by at most one unit (the f64 error of
/// `(w − origin)/h` is ≤ ~4 ulp of the world coordinates over the voxel
/// size: at 1e7, 2^-29 world units / (1/128) voxel ≈ 2.4e-7 voxel, far below
/// a quantum); voxel sets are identical when no vertex moved, and otherwise
/// every differing voxel meets (conservatively, SAT) a triangle with a
/// moved vertex in one of the two meshes.
fn spot_scaled_and_offset(tier: Tier) -> Outcome {
    let mut f = Failures::default();
    let res = tier.pick(128, 512);
    let Ok(spot) = Mesh::load("data/meshes/obj/spot.obj".as_ref()) else {
        return Outcome {
            expectation: "data/meshes/obj/spot.obj loads".into(),
            observed: "not found (run from the repository root)".into(),
            passed: false,
        };
    };
    let opts = VoxelizeOptions::new(res, VoxelizeMode::Thin);
    let base = voxelize_mesh(&spot, &opts).expect("unit spot");
    let base_set: HashSet<Voxel> = base.grid.iter().collect();
    let transforms: Vec<(&str, f64, DVec3)> = vec![
        ("×2^20", 1048576.0, DVec3::ZERO),
        ("×2^-20", 1.0 / 1048576.0, DVec3::ZERO),
        ("×1e-6", 1e-6, DVec3::ZERO),
        ("×1e6", 1e6, DVec3::ZERO),
        ("+1e7", 1.0, DVec3::splat(1e7)),
        ("+(1e7,−3e7,5e6)", 1.0, DVec3::new(1e7, -3e7, 5e6)),
        ("×1e3 +1e7", 1e3, DVec3::splat(1e7)),
    ];
    let mut summary = Vec::new();
    for (name, s, off) in transforms {
        let mut m = spot.clone();
        for p in &mut m.positions {
            *p = *p * s + off;
        }
        let v = match voxelize_mesh(&m, &opts) {
            Ok(v) => v,
            Err(e) => {
                f.check(false, || format!("{name}: {e}"));
                continue;
            }
        };
        f.check(v.frame.dims == base.frame.dims, || {
            format!("{name}: dims {:?} vs {:?}", v.frame.dims, base.frame.dims)
        });
        if v.frame.dims != base.frame.dims || v.mesh.triangles.len() != base.mesh.triangles.len() {
            f.check(false, || {
                format!(
                    "{name}: {} vs {} triangles kept",
                    v.mesh.triangles.len(),
                    base.mesh.triangles.len()
                )
            });
            continue;
        }
        // Per-vertex quantized coordinates (triangles are in mesh order).
        let mut moved_coords = 0u64;
        let mut max_diff = 0i64;
        let mut moved_tris: Vec<SurfaceTriangle> = Vec::new();
        for (t0, t1) in base.mesh.triangles.iter().zip(&v.mesh.triangles) {
            let mut moved = false;
            for (p0, p1) in t0.iter().zip(t1) {
                for i in 0..3 {
                    let d = (p0[i] - p1[i]).abs();
                    max_diff = max_diff.max(d);
                    if d != 0 {
                        moved = true;
                        moved_coords += 1;
                    }
                }
            }
            if moved {
                moved_tris.push(*t0);
                moved_tris.push(*t1);
            }
        }
        f.check(max_diff <= 1, || {
            format!("{name}: a vertex moved by {max_diff}/256 voxel")
        });
        let set: HashSet<Voxel> = v.grid.iter().collect();
        let diff: Vec<Voxel> = set.symmetric_difference(&base_set).copied().collect();
        let unexplained = diff
            .iter()
            .filter(|c| {
                !moved_tris
                    .iter()
                    .any(|t| triangle_meets_cube(t, **c, VOXEL_ONE))
            })
            .count();
        f.check(unexplained == 0, || {
            format!("{name}: {unexplained} differing voxels away from moved vertices")
        });
        f.check(!moved_tris.is_empty() || diff.is_empty(), || {
            format!("{name}: no vertex moved but {} voxels differ", diff.len())
        });
        summary.push(format!(
            "{name}: {} coords moved (max {max_diff}/256), {} voxels differ",
            moved_coords,
            diff.len()
        ));
    }
    f.outcome(
        "same dims; quantized vertices within 1/256 voxel of the unit mesh's; identical voxels unless a vertex moved, and then differences only on triangles with a moved vertex",
        format!("spot thin -r {res} ({} voxels): {}", base_set.len(), summary.join("; ")),
    )
}

// ---------------------------------------------------------------------------
// Amanatides–Woo.
// ---------------------------------------------------------------------------

/// The exact merge of crossing times (rationals in `i128`), ties broken y,
/// then z, then x: the sequence Amanatides–Woo defines, computed exactly.
/// Returns the voxel path and the number of exact ties met.
fn exact_merge(a: FixedPoint, b: FixedPoint) -> (Vec<Voxel>, u64) {
    let v0 = voxel_of(a);
    let v1 = voxel_of(b);
    let mut cur = [v0.x as i64, v0.y as i64, v0.z as i64];
    let d: [i128; 3] = std::array::from_fn(|i| b[i] as i128 - a[i] as i128);
    let s: [i64; 3] = std::array::from_fn(|i| d[i].signum() as i64);
    let mut left: [i64; 3] = std::array::from_fn(|i| (v1[i] as i64 - cur[i]).abs());
    let mut path = vec![v0];
    let mut ties = 0;
    // Crossing time of axis i from the current voxel: (face − a)/d with
    // face = cur ± ½, as numerator/denominator with a positive denominator.
    let time = |i: usize, c: i64| -> (i128, i128) {
        let face = c as i128 * ONE as i128 + s[i] as i128 * HALF as i128;
        let num = face - a[i] as i128;
        if d[i] < 0 { (-num, -d[i]) } else { (num, d[i]) }
    };
    let priority = [2usize, 0, 1]; // y, then z, then x
    while left.iter().any(|&l| l > 0) {
        let mut best: Option<(usize, (i128, i128))> = None;
        for i in 0..3 {
            if left[i] == 0 {
                continue;
            }
            let t = time(i, cur[i]);
            best = match best {
                None => Some((i, t)),
                Some((j, u)) => match cmp_rat(t, u) {
                    Ordering::Less => Some((i, t)),
                    Ordering::Equal => {
                        ties += 1;
                        if priority[i] < priority[j] {
                            Some((i, t))
                        } else {
                            Some((j, u))
                        }
                    }
                    Ordering::Greater => Some((j, u)),
                },
            };
        }
        let (i, _) = best.expect("an axis with steps left");
        cur[i] += s[i];
        left[i] -= 1;
        path.push(Voxel::new(cur[0] as i32, cur[1] as i32, cur[2] as i32));
    }
    (path, ties)
}

/// Amanatides–Woo (`f64`, crossing times recomputed per step) on rays of
/// 10^5 (quick) / 2·10^6 (long) voxels with random directions and endpoints
/// on the 2^-20 lattice, near the origin and near ±2^30: equal to the exact
/// merge of crossing times voxel for voxel (its module docs: each time is a
/// correctly rounded quotient of exact operands, so only crossings within
/// an ulp can swap — none occur). Also reported: voxels differing from the
/// exact tripod line and the first divergence step (0 expected where the
/// line has no exact tie).
fn amanatides_woo_long_rays(tier: Tier) -> Outcome {
    let mut rng = StdRng::seed_from_u64(9);
    let mut f = Failures::default();
    let (n, len) = tier.pick((12, 100_000i64), (24, 2_000_000i64));
    let (mut voxels, mut tripod_diff, mut tied_lines) = (0u64, 0u64, 0u64);
    for k in 0..n {
        let far = k % 2 == 1;
        let centre: FixedPoint = if far {
            std::array::from_fn(|_| {
                (if rng.random_bool(0.5) { 1 } else { -1 }) * (MAX_FIXED - len * ONE * 2)
            })
        } else {
            [0; 3]
        };
        let a: FixedPoint =
            std::array::from_fn(|i| centre[i] + rng.random_range(-ONE * 100..ONE * 100));
        // A random direction with L1 length ≈ len voxels.
        let w: [f64; 3] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let l1 = w.iter().map(|x| x.abs()).sum::<f64>();
        let b: FixedPoint =
            std::array::from_fn(|i| a[i] + (w[i] / l1 * len as f64 * ONE as f64) as i64);
        let (want, ties) = exact_merge(a, b);
        let to = |p: FixedPoint| {
            DVec3::new(
                fixed::to_f64(p[0]),
                fixed::to_f64(p[1]),
                fixed::to_f64(p[2]),
            )
        };
        let aw: Vec<Voxel> = match aw_line(to(a), to(b)) {
            Ok(l) => l.collect(),
            Err(e) => {
                f.check(false, || format!("{e}"));
                continue;
            }
        };
        voxels += aw.len() as u64;
        let first = aw.iter().zip(&want).position(|(x, y)| x != y);
        f.check(aw.len() == want.len() && first.is_none(), || {
            format!(
                "line {k}: A–W differs from the exact merge at step {first:?} (lengths {} vs {})",
                aw.len(),
                want.len()
            )
        });
        let tri: Vec<Voxel> = Tripod6::new(&seg(a, b)).collect();
        let d = tri.iter().zip(&aw).filter(|(x, y)| x != y).count() as u64;
        tripod_diff += d;
        tied_lines += (ties > 0) as u64;
        f.check(d == 0 || ties > 0, || {
            format!("line {k}: A–W differs from the tripod in {d} voxels without an exact tie")
        });
    }
    f.outcome(
        "A–W == exact merge of crossing times (ties y, z, x) voxel for voxel; == tripod line on lines without exact ties",
        format!("{n} rays of ~{len} voxels (half near ±2^30): {voxels} voxels, 0 divergences from the exact merge required; {tripod_diff} voxels differ from the tripod ({tied_lines} lines with exact ties)"),
    )
}

// ---------------------------------------------------------------------------
// Rendering.
// ---------------------------------------------------------------------------

/// A small scene: a 2×2×2 block, single voxels, an L and a diagonal chain
/// (voxels meeting only at edges and corners) in a 12³ grid.
fn render_scene() -> (BrickGrid, [usize; 3]) {
    let mut g = BrickGrid::new();
    for v in [
        [3, 3, 3],
        [4, 3, 3],
        [3, 4, 3],
        [4, 4, 3],
        [3, 3, 4],
        [4, 3, 4],
        [3, 4, 4],
        [4, 4, 4],
        [7, 2, 5],
        [8, 2, 5],
        [8, 3, 5],
        [1, 8, 8],
        [2, 9, 9],
        [3, 10, 10],
        [9, 9, 2],
        [10, 10, 2],
        [6, 8, 4],
    ] {
        g.insert(IVec3::from_array(v));
    }
    (g, [12, 12, 12])
}

/// Segments through the faces, edges and corners of occupied voxels (on
/// them exactly and one unit off), inside the grid.
fn grazing_segments(
    rng: &mut StdRng,
    occ: &[Voxel],
    dims: [usize; 3],
    n: usize,
) -> Vec<(FixedPoint, FixedPoint)> {
    let dirs: Vec<[i64; 3]> = {
        let mut d = Vec::new();
        for x in -2..=2i64 {
            for y in -2..=2i64 {
                for z in -2..=2i64 {
                    if (x, y, z) != (0, 0, 0) {
                        d.push([x, y, z]);
                    }
                }
            }
        }
        d
    };
    let lim = dims.map(|d| d as i64 * ONE - HALF);
    let mut out = Vec::new();
    while out.len() < n {
        let v = occ[rng.random_range(0..occ.len())];
        // A corner, edge point or face point of v.
        let p: [i64; 3] = std::array::from_fn(|i| {
            let c = v[i] as i64 * ONE;
            match rng.random_range(0..3) {
                0 => c - HALF,
                1 => c + HALF,
                _ => c + rng.random_range(-HALF..HALF),
            }
        });
        let d = dirs[rng.random_range(0..dirs.len())].map(|x| x * HALF);
        let (s, t) = (rng.random_range(1..20), rng.random_range(1..20));
        let mut a: FixedPoint = std::array::from_fn(|i| p[i] - s * d[i]);
        let mut b: FixedPoint = std::array::from_fn(|i| p[i] + t * d[i]);
        for q in [&mut a, &mut b] {
            for (i, c) in q.iter_mut().enumerate() {
                if rng.random_range(0..5) == 0 {
                    *c += rng.random_range(-1..=1);
                }
                *c = (*c).clamp(-HALF, lim[i] - 1);
            }
        }
        out.push((a, b));
    }
    out
}

/// Render kernel on grazing segments: the 6-ray's first hit (skipping on
/// and off) == the first occupied voxel the shifted segment enters (brute
/// force over the occupied voxels); the adaptive ray's == the 6-ray's.
fn render_grazing_segments(tier: Tier) -> Outcome {
    let mut rng = StdRng::seed_from_u64(10);
    let mut f = Failures::default();
    let (g, dims) = render_scene();
    let occ = OccupancyGrid::new(&g, dims, MemoryLimit::DEFAULT).expect("scene");
    let vox: Vec<Voxel> = g.iter().collect();
    let n = tier.pick(20_000, 300_000);
    let mut hits = 0;
    for (a, b) in grazing_segments(&mut rng, &vox, dims, n) {
        let s = seg(a, b);
        let want = ShiftedLine::new(a, b).first_entered(vox.iter().copied());
        hits += want.is_some() as u64;
        for skip in [true, false] {
            let six = crate::render::first_hit(&occ, &s, RayKind::Six, skip);
            f.check(six == want, || {
                format!("{a:?}→{b:?} skip {skip}: 6-ray {six:?}, oracle {want:?}")
            });
            let ad = crate::render::first_hit(&occ, &s, RayKind::Adaptive, skip);
            f.check(ad == six, || {
                format!("{a:?}→{b:?} skip {skip}: adaptive {ad:?}, 6-ray {six:?}")
            });
        }
    }
    f.outcome(
        "6-ray first hit == first occupied voxel entered by the shifted segment (skip on and off); adaptive == 6-ray",
        format!("{n} segments through faces, edges and corners of occupied voxels, {hits} hits"),
    )
}

/// Whole images with rays exactly along voxel face planes, edges and
/// through corners (axis-aligned orthographic views with pixel centres on
/// faces, 45° and isometric views): every pixel's 6-ray hit == the
/// brute-force first occupied voxel of the pixel's fixed-point segment
/// ([`crate::render::pixel_segment`]); adaptive == 6-ray; skipping changes
/// nothing.
fn render_grazing_images(tier: Tier) -> Outcome {
    let mut f = Failures::default();
    let (g, dims) = render_scene();
    let occ = OccupancyGrid::new(&g, dims, MemoryLimit::DEFAULT).expect("scene");
    let xf = GridTransform::from_frame(&GridFrame::new(DVec3::ZERO, 1.0, dims)).expect("frame");
    let vox: Vec<Voxel> = g.iter().collect();
    let size = tier.pick(24u32, 96);
    // World = grid + ½: world integers are grid face planes.
    let c = 6.0;
    let mut cams: Vec<(String, Camera)> = Vec::new();
    for (k, dir) in [
        DVec3::Z,
        DVec3::X,
        DVec3::Y,
        -DVec3::Z,
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(-1.0, 1.0, 1.0),
    ]
    .into_iter()
    .enumerate()
    {
        let up = if dir.cross(DVec3::Y).length() < 1e-9 {
            DVec3::Z
        } else {
            DVec3::Y
        };
        // Height = size/… so pixel centres land on world integers (faces)
        // or half-integers (voxel centres) for the axis views.
        for h in [size as f64, size as f64 / 2.0] {
            cams.push((
                format!("ortho {k} h{h}"),
                Camera::orthographic(DVec3::splat(c) + dir * 40.0, DVec3::splat(c), up, h),
            ));
        }
        cams.push((
            format!("persp {k}"),
            Camera::perspective(DVec3::splat(c) + dir * 20.0, DVec3::splat(c), up, 40.0),
        ));
    }
    let mut pixels = 0u64;
    for (name, cam) in &cams {
        let opts = |ray, skip| RenderOptions {
            width: size,
            height: size,
            ray,
            skip,
            ..RenderOptions::default()
        };
        let (six, _) = render_grid(&occ, &xf, cam, &opts(RayKind::Six, true)).expect("render");
        let (six_ns, _) = render_grid(&occ, &xf, cam, &opts(RayKind::Six, false)).expect("render");
        let (ad, _) = render_grid(&occ, &xf, cam, &opts(RayKind::Adaptive, true)).expect("render");
        f.check(six.hit == six_ns.hit, || {
            format!(
                "{name}: skipping changed {} pixels",
                six.differing_hits(&six_ns)
            )
        });
        f.check(ad.hit == six.hit, || {
            format!(
                "{name}: adaptive differs in {} pixels",
                ad.differing_hits(&six)
            )
        });
        for y in 0..size {
            for x in 0..size {
                pixels += 1;
                let want =
                    crate::render::pixel_segment(&occ, &xf, cam, size, size, x, y).and_then(|s| {
                        ShiftedLine::new(s.a(), s.b()).first_entered(vox.iter().copied())
                    });
                let got = six.hit[(y * size + x) as usize];
                f.check(got == want, || {
                    format!("{name} pixel ({x},{y}): 6-ray {got:?}, oracle {want:?}")
                });
            }
        }
    }
    f.outcome(
        "per pixel: 6-ray hit == brute-force first voxel of the pixel's segment; adaptive == 6-ray; skip on == off",
        format!("{} cameras (axis, 45°, isometric; rays on face planes and edges), {pixels} pixels", cams.len()),
    )
}
