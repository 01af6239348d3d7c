//! Eight columns at a time: AVX2 lanes for the middle of the 26-line.
//!
//! In the middle of a 26-line (see [`super::line26`]) the voxel of column
//! `c` is the column centre, and its minor coordinate along local axis `k` is
//! `U(c) = floor((D_k·c + F_k) / D_m)` with the fixed-point direction
//! components `D` and an integer `F_k` (the numerator of
//! [`super::segment::Frame::centre`] divided by `S`, floored: the `S·D_k·c`
//! term is a multiple of `S`, so flooring the rest first does not change the
//! quotient). Its remainder `R(c) = D_k·c + F_k − U(c)·D_m ∈ [0, D_m)` follows
//! from the midpoint variable `E` of [`super::line26::Mid26State`] at that
//! column: `E = S·(R(c) + D_k − D_m) + φ` with `0 ≤ φ < S`, so
//! `R(c) = floor(E / S) + D_m − D_k` (see [`remainder_from_midpoint`]).
//!
//! Columns are independent given `R`: `U(c + j) − U(c) = floor((R(c) + j·D_k) / D_m)`.
//! The lanes hold eight consecutive columns and jump eight columns per step
//! (`8·D_k = Q·D_m + ρ`: `R += ρ`, and one more unit where that reaches
//! `D_m`), so the stepping is four vector operations per axis for eight voxels
//! and no lane waits for another. Values stay in `i32` when `D_m < 2^28`
//! (lines shorter than 256 voxels along their major axis; the bound is
//! [`LANES_MAX_DM`]): every intermediate is below `8·D_m < 2^31`.
//!
//! The iterator's `fold` writes the lanes' world coordinates into a small
//! buffer and hands the voxels to the caller's closure from there; the grid
//! walk writes linear indices and visits them. Both produce exactly the voxels
//! of the scalar stepping (tests in `tests/integration/lines.rs` compare them
//! on random and adversarial segments).

/// Largest fixed-point major direction component (exclusive) for which the
/// lanes run in `i32`: `2^28`, i.e. 256 voxels with 20 fraction bits.
pub(crate) const LANES_MAX_DM: i64 = 1 << 28;

/// `R(c)` of a minor axis from the midpoint variable `e` (scaled by
/// `S = 2^FRAC_BITS`) at column `c`, with the unscaled direction components
/// `dk ≤ dm`.
#[inline]
pub(crate) fn remainder_from_midpoint(e: i64, dk: i64, dm: i64) -> i64 {
    let r = (e >> crate::fixed::FRAC_BITS) + dm - dk;
    debug_assert!((0..dm).contains(&r), "remainder {r} outside [0, {dm})");
    r
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2 {
    use std::arch::x86_64::*;
    use std::mem::MaybeUninit;
    use std::ops::ControlFlow;

    use glam::IVec3;

    /// Columns handed to the consumer per buffer fill (the buffer holds one
    /// extra block: the last block of a fill may run past the count).
    const CHUNK: usize = 256;
    const BUF: usize = CHUNK + 8;

    /// Whether the CPU runs AVX2 (std caches the check).
    #[inline]
    pub(crate) fn available() -> bool {
        std::arch::is_x86_feature_detected!("avx2")
    }

    /// The compact column data of a 26-line middle, validated for the lanes.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct MidColumns {
        /// `R(c)` of u and v at the current column `c`.
        pub r: [i32; 2],
        /// Fixed-point direction components `[D_m, D_u, D_v]`.
        pub d: [i32; 3],
    }

    impl MidColumns {
        /// From the midpoint variables and the scaled direction components
        /// (`D·S`) of a narrow stepping state, if the lanes can run it.
        #[inline]
        pub(crate) fn new(e: [i64; 2], scaled_d: [i64; 3]) -> Option<Self> {
            let d = scaled_d.map(|x| x >> crate::fixed::FRAC_BITS);
            if !(1..super::LANES_MAX_DM).contains(&d[0]) {
                return None;
            }
            let r = [
                super::remainder_from_midpoint(e[0], d[1], d[0]),
                super::remainder_from_midpoint(e[1], d[2], d[0]),
            ];
            Some(MidColumns {
                r: r.map(|x| x as i32),
                d: d.map(|x| x as i32),
            })
        }
    }

    /// The remainder lanes of both minor axes.
    #[derive(Clone, Copy)]
    struct Lanes {
        r: [__m256i; 2],
        rho: [__m256i; 2],
        dm: __m256i,
        dm_minus_one: __m256i,
        /// Whole units of an eight-column jump, per minor axis.
        q: [i32; 2],
    }

    impl Lanes {
        /// Lanes for columns `c+1 ..= c+8` and their minor offsets
        /// `U(c+1+i) − U(c)` (u, v).
        #[target_feature(enable = "avx2")]
        #[inline]
        fn start(cols: &MidColumns) -> (Self, [__m256i; 2]) {
            let [dm, du, dv] = cols.d;
            let vdm = _mm256_set1_epi32(dm);
            let dm_minus_one = _mm256_set1_epi32(dm - 1);
            let (ru, qu) = start_axis(cols.r[0], du, dm);
            let (rv, qv) = start_axis(cols.r[1], dv, dm);
            // 8·D = Q·D_m + ρ (8·D ≤ 8·D_m < 2^31).
            let jump = |d: i32| ((8 * d) / dm, (8 * d) % dm);
            let (qju, rhou) = jump(du);
            let (qjv, rhov) = jump(dv);
            let lanes = Lanes {
                r: [ru, rv],
                rho: [_mm256_set1_epi32(rhou), _mm256_set1_epi32(rhov)],
                dm: vdm,
                dm_minus_one,
                q: [qju, qjv],
            };
            (lanes, [qu, qv])
        }

        /// Jumps every lane eight columns; returns the carry masks (all ones
        /// where the minor coordinate gains one unit beyond `q`).
        #[target_feature(enable = "avx2")]
        #[inline]
        fn jump(&mut self) -> [__m256i; 2] {
            let [ru, rv] = self.r;
            let (ru, cu) = jump_axis(ru, self.rho[0], self.dm_minus_one, self.dm);
            let (rv, cv) = jump_axis(rv, self.rho[1], self.dm_minus_one, self.dm);
            self.r = [ru, rv];
            [cu, cv]
        }
    }

    /// `r + rho` reduced below `dm`, and the mask of lanes that reached it.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn jump_axis(
        r: __m256i,
        rho: __m256i,
        dm_minus_one: __m256i,
        dm: __m256i,
    ) -> (__m256i, __m256i) {
        let t = _mm256_add_epi32(r, rho);
        let c = _mm256_cmpgt_epi32(t, dm_minus_one);
        (_mm256_sub_epi32(t, _mm256_and_si256(c, dm)), c)
    }

    /// Remainders and minor offsets `U(c+1+i) − U(c)` of lanes `i = 0..8` of
    /// one axis, from `R(c) = r` (`0 ≤ r < dm`, `0 ≤ d ≤ dm < 2^28`).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn start_axis(r: i32, d: i32, dm: i32) -> (__m256i, __m256i) {
        let vdm = _mm256_set1_epi32(dm);
        let iota1 = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 8);
        // T = R + (i+1)·D − D_m ∈ [−D_m, 8·D_m); ΔU = #{j ∈ 0..8 : T ≥ j·D_m}.
        let t = _mm256_add_epi32(
            _mm256_set1_epi32(r - dm),
            _mm256_mullo_epi32(iota1, _mm256_set1_epi32(d)),
        );
        let mut q = _mm256_setzero_si256();
        let mut threshold = _mm256_set1_epi32(-1);
        for _ in 0..8 {
            q = _mm256_sub_epi32(q, _mm256_cmpgt_epi32(t, threshold));
            threshold = _mm256_add_epi32(threshold, vdm);
        }
        // R = T + D_m − ΔU·D_m
        let rem = _mm256_sub_epi32(_mm256_add_epi32(t, vdm), _mm256_mullo_epi32(q, vdm));
        (rem, q)
    }

    /// World axes of local u and v when the major axis is world axis `MA`
    /// (the frame's permutation: the other two in x, y, z order).
    const fn minor_axes(ma: usize) -> (usize, usize) {
        match ma {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        }
    }

    /// Hands the voxels of the next `n` middle columns after `cur` (the voxel
    /// of the current column) to `g`, in order; returns the accumulator and
    /// the last voxel. `steps` are the world unit steps of local m, u, v.
    ///
    /// # Safety
    /// The CPU must support AVX2 ([`available`]).
    #[target_feature(enable = "avx2")]
    pub(crate) unsafe fn mid_voxels<B, G: FnMut(B, IVec3) -> B>(
        cols: &MidColumns,
        cur: IVec3,
        steps: [IVec3; 3],
        n: u64,
        acc: B,
        g: &mut G,
    ) -> (B, IVec3) {
        let major = steps[0].abs().to_array().iter().position(|&c| c != 0);
        match major {
            Some(0) => mid_voxels_on::<0, B, G>(cols, cur, steps, n, acc, g),
            Some(1) => mid_voxels_on::<1, B, G>(cols, cur, steps, n, acc, g),
            _ => mid_voxels_on::<2, B, G>(cols, cur, steps, n, acc, g),
        }
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    fn mid_voxels_on<const MA: usize, B, G: FnMut(B, IVec3) -> B>(
        cols: &MidColumns,
        cur: IVec3,
        steps: [IVec3; 3],
        n: u64,
        mut acc: B,
        g: &mut G,
    ) -> (B, IVec3) {
        let (ua, va) = minor_axes(MA);
        let sm = steps[0][MA];
        let (su, sv) = (steps[1][ua], steps[2][va]);
        let (mut lanes, [du, dv]) = Lanes::start(cols);
        let iota1 = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 8);
        let mut wm = _mm256_add_epi32(
            _mm256_set1_epi32(cur[MA]),
            _mm256_sign_epi32(iota1, _mm256_set1_epi32(sm)),
        );
        let mut wu = _mm256_add_epi32(
            _mm256_set1_epi32(cur[ua]),
            _mm256_sign_epi32(du, _mm256_set1_epi32(su)),
        );
        let mut wv = _mm256_add_epi32(
            _mm256_set1_epi32(cur[va]),
            _mm256_sign_epi32(dv, _mm256_set1_epi32(sv)),
        );
        let (vsu, vsv) = (_mm256_set1_epi32(su), _mm256_set1_epi32(sv));
        let jm = _mm256_set1_epi32(8 * sm);
        let ju = _mm256_set1_epi32(lanes.q[0] * su);
        let jv = _mm256_set1_epi32(lanes.q[1] * sv);
        // Uninitialised: zeroing 3×72 words per line cost more than a short
        // line's stepping. Only the first `take` words of a fill are read.
        let mut xs = [MaybeUninit::<i32>::uninit(); BUF];
        let mut ys = [MaybeUninit::<i32>::uninit(); BUF];
        let mut zs = [MaybeUninit::<i32>::uninit(); BUF];
        let mut last = cur;
        let mut left = n;
        while left > 0 {
            let take = left.min(CHUNK as u64) as usize;
            let mut b = 0;
            while b < take {
                let (ox, oy, oz) = match MA {
                    0 => (wm, wu, wv),
                    1 => (wu, wm, wv),
                    _ => (wu, wv, wm),
                };
                // SAFETY: b + 8 ≤ take + 7 < BUF words; unaligned stores.
                unsafe {
                    _mm256_storeu_si256(xs.as_mut_ptr().add(b).cast(), ox);
                    _mm256_storeu_si256(ys.as_mut_ptr().add(b).cast(), oy);
                    _mm256_storeu_si256(zs.as_mut_ptr().add(b).cast(), oz);
                }
                let [cu, cv] = lanes.jump();
                wm = _mm256_add_epi32(wm, jm);
                wu = _mm256_add_epi32(_mm256_add_epi32(wu, ju), _mm256_and_si256(cu, vsu));
                wv = _mm256_add_epi32(_mm256_add_epi32(wv, jv), _mm256_and_si256(cv, vsv));
                b += 8;
            }
            // SAFETY: the loop above wrote words 0..take of each buffer.
            let (x, y, z) = unsafe {
                (
                    std::slice::from_raw_parts(xs.as_ptr().cast::<i32>(), take),
                    std::slice::from_raw_parts(ys.as_ptr().cast::<i32>(), take),
                    std::slice::from_raw_parts(zs.as_ptr().cast::<i32>(), take),
                )
            };
            for i in 0..take {
                acc = g(acc, IVec3::new(x[i], y[i], z[i]));
            }
            last = IVec3::new(x[take - 1], y[take - 1], z[take - 1]);
            left -= take as u64;
        }
        (acc, last)
    }

    /// Visits the linear indices of the next `n` middle columns after `idx`
    /// (the index of the current column's voxel) in order; `off` are the
    /// index offsets of local m, u, v. Returns the last index, or
    /// `Err(index)` where the visitor stopped.
    ///
    /// # Safety
    /// The CPU must support AVX2 ([`available`]); every index visited must
    /// fit `i32` (the caller's grid has fewer than 2^31 cells).
    #[target_feature(enable = "avx2")]
    pub(crate) unsafe fn mid_indices<F: FnMut(usize) -> ControlFlow<()>>(
        cols: &MidColumns,
        idx: usize,
        off: [isize; 3],
        n: u64,
        visit: &mut F,
    ) -> Result<usize, usize> {
        let (mut lanes, [du, dv]) = Lanes::start(cols);
        // Wrapping i32 arithmetic: every in-grid index is below 2^31, so the
        // lanes are exact modulo 2^32 and exact where they are read.
        let [om, ou, ov] = off.map(|o| o as i32);
        let iota1 = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 8);
        let mut ix = _mm256_add_epi32(
            _mm256_add_epi32(
                _mm256_set1_epi32(idx as i32),
                _mm256_mullo_epi32(iota1, _mm256_set1_epi32(om)),
            ),
            _mm256_add_epi32(
                _mm256_mullo_epi32(du, _mm256_set1_epi32(ou)),
                _mm256_mullo_epi32(dv, _mm256_set1_epi32(ov)),
            ),
        );
        let (vou, vov) = (_mm256_set1_epi32(ou), _mm256_set1_epi32(ov));
        let jump = _mm256_set1_epi32(
            om.wrapping_mul(8)
                .wrapping_add(lanes.q[0].wrapping_mul(ou))
                .wrapping_add(lanes.q[1].wrapping_mul(ov)),
        );
        let mut buf = [MaybeUninit::<i32>::uninit(); BUF];
        let mut last = idx;
        let mut left = n;
        while left > 0 {
            let take = left.min(CHUNK as u64) as usize;
            let mut b = 0;
            while b < take {
                // SAFETY: b + 8 ≤ take + 7 < BUF words; unaligned store.
                unsafe { _mm256_storeu_si256(buf.as_mut_ptr().add(b).cast(), ix) };
                let [cu, cv] = lanes.jump();
                ix = _mm256_add_epi32(
                    _mm256_add_epi32(ix, jump),
                    _mm256_add_epi32(_mm256_and_si256(cu, vou), _mm256_and_si256(cv, vov)),
                );
                b += 8;
            }
            // SAFETY: the loop above wrote words 0..take.
            let ids = unsafe { std::slice::from_raw_parts(buf.as_ptr().cast::<i32>(), take) };
            for &i in ids {
                let i = i as u32 as usize;
                if visit(i).is_break() {
                    return Err(i);
                }
            }
            last = ids[take - 1] as u32 as usize;
            left -= take as u64;
        }
        Ok(last)
    }
}
