//! The `i64` set-up paths against the general `i128` ones.
//!
//! A frame with `wide` forced on takes every general path: `i128` decision
//! variables, column centres by `i128` floor division, end paths from `i128`
//! tripod variables. Lines, plans and stepping states built from the narrow
//! frame must equal those of the forced-wide copy, on both sides of the
//! switch bound ([`NARROW_MAX_DELTA`]) and near the coordinate range ends.
//! (Debug builds also assert every `i64` start state against `i128` and every
//! division-free column centre against the division.)

use glam::IVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::line18::{Line18, last_crossed};
use super::line26::{Line26, Mid26State, Plan26};
use super::segment::{Frame, MAX_FIXED, NARROW_MAX_DELTA, Segment};
use super::tripod6::{Tripod6, TripodState};
use crate::fixed::ONE;

/// A random segment of direction span `span` (fixed point; the major axis
/// gets exactly `±span` for some kinds), anchored at `anchor` on every axis.
/// Kinds: integer endpoints, sub-voxel, quarter-voxel (ties), axis-parallel /
/// in-plane, exact diagonals.
fn segment(rng: &mut ChaCha8Rng, span: i64, anchor: i64) -> Segment {
    let kind = rng.random_range(0..6);
    let grain = match kind {
        0 => ONE,
        3 => ONE / 4,
        _ => 1,
    };
    let snap = |x: i64| x.div_euclid(grain) * grain;
    let a: [i64; 3] = std::array::from_fn(|_| snap(anchor + rng.random_range(-2 * ONE..=2 * ONE)));
    let mut d: [i64; 3] = std::array::from_fn(|_| snap(rng.random_range(-span..=span)));
    let m = rng.random_range(0..3);
    if rng.random_bool(0.5) {
        d[m] = if rng.random_bool(0.5) { span } else { -span };
    }
    match kind {
        4 => {
            d[(m + 1) % 3] = 0;
            if rng.random_bool(0.5) {
                d[(m + 2) % 3] = 0;
            }
        }
        5 => {
            let t = snap(rng.random_range(0..=span));
            d = std::array::from_fn(|_| if rng.random_bool(0.5) { t } else { -t });
            if rng.random_bool(0.3) {
                d[m] = 0;
            }
        }
        _ => {}
    }
    let a = a.map(|x| x.clamp(-MAX_FIXED, MAX_FIXED));
    // Point the direction inwards where it would leave the range.
    let b: [i64; 3] = std::array::from_fn(|k| {
        if (a[k] + d[k]).abs() > MAX_FIXED {
            a[k] - d[k]
        } else {
            a[k] + d[k]
        }
    });
    Segment::from_fixed(a, b).unwrap()
}

fn wide(f: &Frame) -> Frame {
    let mut w = *f;
    w.wide = true;
    w
}

/// Collects with `next` (no `fold`), checking that `size_hint` is exact
/// (or, for the 18-line, a true range) at every step.
fn by_next(mut it: impl Iterator<Item = IVec3>) -> Vec<IVec3> {
    let mut out = Vec::new();
    loop {
        let (lo, hi) = it.size_hint();
        match it.next() {
            Some(v) => {
                assert!(lo >= 1 || hi.is_none_or(|h| h >= 1));
                out.push(v);
            }
            None => {
                assert_eq!(lo, 0);
                break;
            }
        }
    }
    out
}

/// The 18-line by definition: the 26-line with each corner move split at
/// the voxel after its first two crossings, read from the general `i128`
/// tripod variables.
fn line18_reference(f: &Frame) -> Vec<IVec3> {
    let w = wide(f);
    let plan = Plan26::new(&w);
    let mut out = vec![w.voxel_world([0; 3])];
    let mut prev = [0i64; 3];
    for p in 1..plan.count() {
        let c = plan.voxel_at(&w, p);
        if (0..3).all(|k| c[k] == prev[k] + 1) {
            let mut mid = c;
            mid[last_crossed(&w, prev)] -= 1;
            out.push(w.voxel_world(mid));
        }
        out.push(w.voxel_world(c));
        prev = c;
    }
    out
}

fn check(seg: &Segment, full_lines: bool) {
    let f = Frame::new(seg);
    assert_eq!(
        f.wide,
        f.d[0] > NARROW_MAX_DELTA,
        "switch bound for {seg:?}"
    );
    let w = wide(&f);
    let m = f.end[0];
    if m >= 2 {
        assert_eq!(f.centre_first(), w.centre(1), "{seg:?}");
        assert_eq!(f.centre_last(), w.centre(m - 1), "{seg:?}");
    }
    assert_eq!(Plan26::new(&f), Plan26::new(&w), "plan of {seg:?}");
    if f.wide {
        return;
    }
    if full_lines {
        let t = Tripod6::from_frame(&f).collect::<Vec<_>>();
        assert_eq!(t, Tripod6::from_frame(&w).collect::<Vec<_>>(), "{seg:?}");
        assert_eq!(t, by_next(Tripod6::from_frame(&f)), "{seg:?}");
        let l = Line26::from_frame(&f).collect::<Vec<_>>();
        assert_eq!(l, Line26::from_frame(&w).collect::<Vec<_>>(), "{seg:?}");
        assert_eq!(l, by_next(Line26::from_frame(&f)), "{seg:?}");
        let e = Line18::from_frame(&f).collect::<Vec<_>>();
        assert_eq!(e, line18_reference(&f), "18-line of {seg:?}");
        assert_eq!(e, Line18::from_frame(&w).collect::<Vec<_>>(), "{seg:?}");
        assert_eq!(e, by_next(Line18::from_frame(&f)), "{seg:?}");
    } else {
        // Long lines: the stepping states from the start and from the last
        // column centre, step by step.
        let mut a = TripodState::<i64>::at(&f, [0; 3]);
        let mut b = TripodState::<i128>::at(&f, [0; 3]);
        for _ in 0..f.tripod_steps().min(3000) {
            assert_eq!(a.step(), b.step(), "{seg:?}");
        }
        if m >= 2 {
            for c in [f.centre_first(), f.centre_last()] {
                let mut a = Mid26State::<i64>::at(&f, c);
                let mut b = Mid26State::<i128>::at(&f, c);
                for _ in 0..(m - c[0]).min(3000) {
                    assert_eq!(a.step(), b.step(), "{seg:?}");
                }
            }
        }
    }
}

#[test]
fn narrow_setup_equals_general_setup() {
    let mut rng = ChaCha8Rng::seed_from_u64(2_0_2_0);
    let near_end = MAX_FIXED - 3 * ONE;
    for (span, anchor, n, full) in [
        (8 * ONE, 0, 3000, true),
        (64 * ONE, 0, 1500, true),
        (64 * ONE, near_end, 500, true),
        (64 * ONE, -near_end, 500, true),
        // both sides of the switch bound, at the range ends too
        (NARROW_MAX_DELTA, 0, 300, false),
        (NARROW_MAX_DELTA, near_end, 300, false),
        (NARROW_MAX_DELTA, -near_end, 300, false),
        (NARROW_MAX_DELTA + 1, near_end, 200, false),
        (NARROW_MAX_DELTA + 1, -near_end, 200, false),
        (1 << 45, 0, 200, false),
    ] {
        for _ in 0..n {
            check(&segment(&mut rng, span, anchor), full);
        }
    }
}

/// Exactly at the switch bound: a major component of `2^40` (2^20 voxels)
/// is narrow, one more unit of `2^-20` is wide; both give the general
/// path's plan and (narrow) the same full line.
#[test]
fn switch_bound_is_exact() {
    let a = [-(1 << 39) + 12_345, 3 * ONE / 4, -ONE / 2];
    for (extra, is_wide) in [(0, false), (1, true)] {
        let b = [
            a[0] + NARROW_MAX_DELTA + extra,
            a[1] + 777_777,
            a[2] - (1 << 39),
        ];
        let seg = Segment::from_fixed(a, b).unwrap();
        assert_eq!(Frame::new(&seg).wide, is_wide);
        check(&seg, false);
    }
    // One full narrow line of 2^20 columns, compared voxel by voxel.
    let b = [a[0] + NARROW_MAX_DELTA, a[1] + 777_777, a[2] - (1 << 39)];
    let f = Frame::new(&Segment::from_fixed(a, b).unwrap());
    assert!(Line26::from_frame(&f).eq(Line26::from_frame(&wide(&f))));
}
