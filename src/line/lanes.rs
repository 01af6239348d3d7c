//! Eight columns at a time: AVX2 lanes for the 26-line and the tripod.
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
//! The tripod is the same sequence half a column later: its exit voxel of
//! column `c` along `k` is `floor((D_k·c + G_k) / D_m)` (the exit face instead
//! of the centre), so a column holds a u step iff the previous column's
//! remainder is at least `D_m − D_u`, and `e_vu / S` (floored, same sign as
//! `e_vu`) orders two steps; see [`tripod_voxels`].
//!
//! The lanes fill small buffers (world coordinates, linear indices, tripod
//! column codes) and the caller's loop hands the voxels on from there, so the
//! caller's closure inlines into a plain loop (a fill zeroes nothing: zeroing
//! the buffers per line cost more than a short line's stepping). The voxels
//! are exactly those of the scalar stepping: `tests/integration/lines.rs`
//! compares `fold` with `next` and walks with iterators on random and
//! adversarial segments, on both sides of the 256-voxel bound.
//!
//! AVX2 is detected at run time (std caches the answer); without it, and off
//! x86-64, the scalar stepping runs.

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

    /// A buffer for one fill of lanes (`CHUNK` values and one block of
    /// overrun).
    pub(crate) type Buffer = [MaybeUninit<i32>; BUF];

    /// An uninitialised [`Buffer`]: zeroing it per line cost more than a
    /// short line's stepping; only the values a fill wrote are read.
    #[inline(always)]
    pub(crate) fn buffer() -> Buffer {
        [MaybeUninit::uninit(); BUF]
    }

    /// The first `n` values of a buffer that a fill wrote.
    #[inline(always)]
    fn written(buf: &Buffer, n: usize) -> &[i32] {
        debug_assert!(n <= BUF);
        // SAFETY: the caller's fill wrote words 0..n (i32 is plain data).
        unsafe { std::slice::from_raw_parts(buf.as_ptr().cast::<i32>(), n) }
    }

    /// World coordinates of the middle columns after a start column, eight
    /// columns per step, in fills of up to [`CHUNK`] voxels.
    pub(crate) struct VoxelLanes {
        lanes: Lanes,
        /// World major axis (0, 1, 2) and the world axes of u and v.
        axes: [usize; 3],
        /// Lanes of the world coordinates along local m, u, v.
        w: [__m256i; 3],
        /// Whole-jump increments of m, u, v and the unit steps of u, v.
        jump: [__m256i; 3],
        unit: [__m256i; 2],
    }

    impl VoxelLanes {
        /// Lanes for the columns after `cur` (the voxel of the state's
        /// column); `steps`: world unit steps of local m, u, v.
        ///
        /// # Safety
        /// The CPU must support AVX2 ([`available`]).
        #[target_feature(enable = "avx2")]
        pub(crate) unsafe fn new(cols: &MidColumns, cur: IVec3, steps: [IVec3; 3]) -> Self {
            // Table look-ups, not `match` or `IVec3` indexing: those compile
            // to a jump on the major axis, which varies from line to line and
            // mispredicts.
            let ma = usize::from(steps[0].y != 0) + 2 * usize::from(steps[0].z != 0);
            let (ua, va) = ([1, 0, 0][ma], [2, 2, 1][ma]);
            let cur = cur.to_array();
            let (sm, su, sv) = (
                steps[0].to_array()[ma],
                steps[1].to_array()[ua],
                steps[2].to_array()[va],
            );
            let (lanes, [du, dv]) = Lanes::start(cols);
            let iota1 = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 8);
            let w = [
                _mm256_add_epi32(
                    _mm256_set1_epi32(cur[ma]),
                    _mm256_sign_epi32(iota1, _mm256_set1_epi32(sm)),
                ),
                _mm256_add_epi32(
                    _mm256_set1_epi32(cur[ua]),
                    _mm256_sign_epi32(du, _mm256_set1_epi32(su)),
                ),
                _mm256_add_epi32(
                    _mm256_set1_epi32(cur[va]),
                    _mm256_sign_epi32(dv, _mm256_set1_epi32(sv)),
                ),
            ];
            let jump = [
                _mm256_set1_epi32(8 * sm),
                _mm256_set1_epi32(lanes.q[0] * su),
                _mm256_set1_epi32(lanes.q[1] * sv),
            ];
            let unit = [_mm256_set1_epi32(su), _mm256_set1_epi32(sv)];
            VoxelLanes {
                lanes,
                axes: [ma, ua, va],
                w,
                jump,
                unit,
            }
        }

        /// Writes the next `n ≤ CHUNK` voxels' world x, y, z into `xyz` and
        /// returns them as slices.
        ///
        /// # Safety
        /// The CPU must support AVX2 ([`available`]).
        #[target_feature(enable = "avx2")]
        pub(crate) unsafe fn fill<'b>(
            &mut self,
            xyz: &'b mut [Buffer; 3],
            n: usize,
        ) -> [&'b [i32]; 3] {
            debug_assert!(n <= CHUNK);
            let world: [*mut MaybeUninit<i32>; 3] = [
                xyz[0].as_mut_ptr(),
                xyz[1].as_mut_ptr(),
                xyz[2].as_mut_ptr(),
            ];
            let local = self.axes.map(|w| world[w]);
            let mut b = 0;
            while b < n {
                // SAFETY: b + 8 ≤ n + 7 < BUF words of each buffer.
                unsafe {
                    _mm256_storeu_si256(local[0].add(b).cast(), self.w[0]);
                    _mm256_storeu_si256(local[1].add(b).cast(), self.w[1]);
                    _mm256_storeu_si256(local[2].add(b).cast(), self.w[2]);
                }
                let [cu, cv] = self.lanes.jump();
                self.w[0] = _mm256_add_epi32(self.w[0], self.jump[0]);
                self.w[1] = _mm256_add_epi32(
                    _mm256_add_epi32(self.w[1], self.jump[1]),
                    _mm256_and_si256(cu, self.unit[0]),
                );
                self.w[2] = _mm256_add_epi32(
                    _mm256_add_epi32(self.w[2], self.jump[2]),
                    _mm256_and_si256(cv, self.unit[1]),
                );
                b += 8;
            }
            let [x, y, z] = xyz;
            [written(x, n), written(y, n), written(z, n)]
        }
    }

    /// Linear indices of the middle columns after a start column, eight
    /// columns per step, in fills of up to [`CHUNK`] values.
    pub(crate) struct IndexLanes {
        lanes: Lanes,
        ix: __m256i,
        jump: __m256i,
        off: [__m256i; 2],
    }

    impl IndexLanes {
        /// Lanes for the columns after `idx` (the index of the state's
        /// column's voxel); `off`: index offsets of local m, u, v. Indices
        /// are `i32` in wrapping arithmetic: exact wherever they are in a
        /// grid of fewer than 2^31 cells.
        ///
        /// # Safety
        /// The CPU must support AVX2 ([`available`]).
        #[target_feature(enable = "avx2")]
        pub(crate) unsafe fn new(cols: &MidColumns, idx: usize, off: [isize; 3]) -> Self {
            let (lanes, [du, dv]) = Lanes::start(cols);
            let [om, ou, ov] = off.map(|o| o as i32);
            let iota1 = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 8);
            let ix = _mm256_add_epi32(
                _mm256_add_epi32(
                    _mm256_set1_epi32(idx as i32),
                    _mm256_mullo_epi32(iota1, _mm256_set1_epi32(om)),
                ),
                _mm256_add_epi32(
                    _mm256_mullo_epi32(du, _mm256_set1_epi32(ou)),
                    _mm256_mullo_epi32(dv, _mm256_set1_epi32(ov)),
                ),
            );
            let jump = _mm256_set1_epi32(
                om.wrapping_mul(8)
                    .wrapping_add(lanes.q[0].wrapping_mul(ou))
                    .wrapping_add(lanes.q[1].wrapping_mul(ov)),
            );
            let off = [_mm256_set1_epi32(ou), _mm256_set1_epi32(ov)];
            IndexLanes {
                lanes,
                ix,
                jump,
                off,
            }
        }

        /// Writes the next `n ≤ CHUNK` indices into `buf` and returns them.
        ///
        /// # Safety
        /// The CPU must support AVX2 ([`available`]).
        #[target_feature(enable = "avx2")]
        pub(crate) unsafe fn fill<'b>(&mut self, buf: &'b mut Buffer, n: usize) -> &'b [i32] {
            debug_assert!(n <= CHUNK);
            let mut b = 0;
            while b < n {
                // SAFETY: b + 8 ≤ n + 7 < BUF words; unaligned store.
                unsafe { _mm256_storeu_si256(buf.as_mut_ptr().add(b).cast(), self.ix) };
                let [cu, cv] = self.lanes.jump();
                self.ix = _mm256_add_epi32(
                    _mm256_add_epi32(self.ix, self.jump),
                    _mm256_add_epi32(
                        _mm256_and_si256(cu, self.off[0]),
                        _mm256_and_si256(cv, self.off[1]),
                    ),
                );
                b += 8;
            }
            written(buf, n)
        }
    }

    /// The largest fill.
    pub(crate) const FILL: usize = CHUNK;

    /// The tripod's columns, eight per step: for each column its code
    /// (bit 0: one u step in the column, bit 1: one v step, bit 2: the v face
    /// comes first), in fills of up to [`CHUNK`] codes. See
    /// [`super::tripod_voxels`] for the derivation.
    pub(crate) struct TripodLanes {
        lanes: Lanes,
        /// `D_m − D_k − 1`: a column steps along k iff the previous column's
        /// remainder exceeds it.
        step_at: [__m256i; 2],
        /// `e_vu / S` (floored) at each lane column's entry voxel, its
        /// whole-jump increment and the per-carry changes.
        e: __m256i,
        e_jump: __m256i,
        du: __m256i,
        dv: __m256i,
        /// Per-lane counts of u and v steps in the columns filled so far.
        moved: [__m256i; 2],
    }

    impl TripodLanes {
        /// Lanes for the columns after the exit voxel of column `c`, from its
        /// exit remainders `r = [R_u(c), R_v(c)]` and `e = floor(e_vu / S)`
        /// there.
        ///
        /// # Safety
        /// The CPU must support AVX2 ([`available`]).
        #[target_feature(enable = "avx2")]
        pub(crate) unsafe fn new(r: [i32; 2], e: i32, d: [i32; 3]) -> Self {
            let [dm, du, dv] = d;
            let vdm = _mm256_set1_epi32(dm);
            let iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            // Lane i holds the previous column, c + i: T = R + i·D ∈ [0, 8·D_m).
            let axis = |r: i32, d: i32| -> (__m256i, __m256i) {
                let t = _mm256_add_epi32(
                    _mm256_set1_epi32(r),
                    _mm256_mullo_epi32(iota, _mm256_set1_epi32(d)),
                );
                let mut q = _mm256_setzero_si256();
                let mut threshold = _mm256_set1_epi32(dm - 1);
                for _ in 1..8 {
                    q = _mm256_sub_epi32(q, _mm256_cmpgt_epi32(t, threshold));
                    threshold = _mm256_add_epi32(threshold, vdm);
                }
                (_mm256_sub_epi32(t, _mm256_mullo_epi32(q, vdm)), q)
            };
            let (ru, qu) = axis(r[0], du);
            let (rv, qv) = axis(r[1], dv);
            let (vdu, vdv) = (_mm256_set1_epi32(du), _mm256_set1_epi32(dv));
            // e_vu changes by −D_v per u step and +D_u per v step.
            let e = _mm256_add_epi32(
                _mm256_set1_epi32(e),
                _mm256_sub_epi32(_mm256_mullo_epi32(qv, vdu), _mm256_mullo_epi32(qu, vdv)),
            );
            let jump = |d: i32| ((8 * d) / dm, (8 * d) % dm);
            let (qju, rhou) = jump(du);
            let (qjv, rhov) = jump(dv);
            let e_jump = _mm256_set1_epi32(qjv.wrapping_mul(du).wrapping_sub(qju.wrapping_mul(dv)));
            TripodLanes {
                lanes: Lanes {
                    r: [ru, rv],
                    rho: [_mm256_set1_epi32(rhou), _mm256_set1_epi32(rhov)],
                    dm: vdm,
                    dm_minus_one: _mm256_set1_epi32(dm - 1),
                    q: [qju, qjv],
                },
                step_at: [
                    _mm256_set1_epi32(dm - du - 1),
                    _mm256_set1_epi32(dm - dv - 1),
                ],
                e,
                e_jump,
                du: vdu,
                dv: vdv,
                moved: [_mm256_setzero_si256(); 2],
            }
        }

        /// The u and v steps of all columns filled so far.
        ///
        /// # Safety
        /// The CPU must support AVX2 ([`available`]).
        #[target_feature(enable = "avx2")]
        pub(crate) unsafe fn moved(&self) -> [i64; 2] {
            self.moved.map(|m| {
                let mut a = [0i32; 8];
                // SAFETY: an unaligned store of eight i32.
                unsafe { _mm256_storeu_si256(a.as_mut_ptr().cast(), m) };
                a.iter().map(|&x| i64::from(x)).sum()
            })
        }

        /// Writes the codes of the next `n ≤ CHUNK` columns into `buf` and
        /// returns them.
        ///
        /// # Safety
        /// The CPU must support AVX2 ([`available`]).
        #[target_feature(enable = "avx2")]
        pub(crate) unsafe fn fill<'b>(&mut self, buf: &'b mut Buffer, n: usize) -> &'b [i32] {
            debug_assert!(n <= CHUNK);
            let (one, two, four) = (
                _mm256_set1_epi32(1),
                _mm256_set1_epi32(2),
                _mm256_set1_epi32(4),
            );
            let iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            let mut b = 0;
            while b < n {
                let [ru, rv] = self.lanes.r;
                let su = _mm256_cmpgt_epi32(ru, self.step_at[0]);
                let sv = _mm256_cmpgt_epi32(rv, self.step_at[1]);
                // Count only the lanes of columns below n.
                let valid = _mm256_cmpgt_epi32(_mm256_set1_epi32((n - b) as i32), iota);
                self.moved[0] = _mm256_sub_epi32(self.moved[0], _mm256_and_si256(su, valid));
                self.moved[1] = _mm256_sub_epi32(self.moved[1], _mm256_and_si256(sv, valid));
                let vfirst = _mm256_cmpgt_epi32(_mm256_setzero_si256(), self.e);
                let code = _mm256_or_si256(
                    _mm256_or_si256(_mm256_and_si256(su, one), _mm256_and_si256(sv, two)),
                    _mm256_and_si256(vfirst, four),
                );
                // SAFETY: b + 8 ≤ n + 7 < BUF words; unaligned store.
                unsafe { _mm256_storeu_si256(buf.as_mut_ptr().add(b).cast(), code) };
                let [cu, cv] = self.lanes.jump();
                self.e = _mm256_add_epi32(
                    _mm256_add_epi32(self.e, self.e_jump),
                    _mm256_sub_epi32(_mm256_and_si256(cv, self.du), _mm256_and_si256(cu, self.dv)),
                );
                b += 8;
            }
            written(buf, n)
        }
    }
}

/// Hands the voxels of the next `n` middle columns after `cur` (the voxel of
/// the state's column) to `g`, in order; returns the accumulator and the last
/// voxel. `steps`: world unit steps of local m, u, v. The loop over each fill
/// runs here, outside the AVX2 functions, so `g` inlines into the caller.
///
/// # Safety
/// The CPU must support AVX2 ([`avx2::available`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn mid_voxels<B, G: FnMut(B, glam::IVec3) -> B>(
    cols: &avx2::MidColumns,
    cur: glam::IVec3,
    steps: [glam::IVec3; 3],
    n: u64,
    mut acc: B,
    g: &mut G,
) -> (B, glam::IVec3) {
    // SAFETY (both calls): the caller guarantees AVX2.
    let mut lanes = unsafe { avx2::VoxelLanes::new(cols, cur, steps) };
    let mut xyz = [avx2::buffer(), avx2::buffer(), avx2::buffer()];
    let mut last = cur;
    let mut left = n;
    while left > 0 {
        let take = left.min(avx2::FILL as u64) as usize;
        let [x, y, z] = unsafe { lanes.fill(&mut xyz, take) };
        for i in 0..take {
            acc = g(acc, glam::IVec3::new(x[i], y[i], z[i]));
        }
        last = glam::IVec3::new(x[take - 1], y[take - 1], z[take - 1]);
        left -= take as u64;
    }
    (acc, last)
}

/// Visits the linear indices of the next `n` middle columns after `idx`
/// (the index of the state's column's voxel) in order; `off`: index offsets
/// of local m, u, v. Returns the last index, or `Err(index)` where the
/// visitor stopped.
///
/// # Safety
/// The CPU must support AVX2 ([`avx2::available`]), and every index visited
/// must be below 2^31 (a grid of fewer than 2^31 cells, the line clipped to
/// it).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn mid_indices<F: FnMut(usize) -> std::ops::ControlFlow<()>>(
    cols: &avx2::MidColumns,
    idx: usize,
    off: [isize; 3],
    n: u64,
    visit: &mut F,
) -> Result<usize, usize> {
    // SAFETY (both calls): the caller guarantees AVX2.
    let mut lanes = unsafe { avx2::IndexLanes::new(cols, idx, off) };
    let mut buf = avx2::buffer();
    let mut last = idx;
    let mut left = n;
    while left > 0 {
        let take = left.min(avx2::FILL as u64) as usize;
        let ids = unsafe { lanes.fill(&mut buf, take) };
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

/// Columns per fill of the tripod's emission buffers (a column emits up to
/// three voxels).
#[cfg(target_arch = "x86_64")]
const TRIPOD_FILL: usize = 64;

/// Per column code (see [`avx2::TripodLanes`]): the voxels the column emits
/// (its entry voxel and one per minor step).
#[cfg(target_arch = "x86_64")]
const TRIPOD_COUNT: [usize; 8] = [1, 2, 2, 3, 1, 2, 2, 3];

/// Hands the tripod voxels of the `k` columns after the exit voxel `x` of
/// the current column to `g`, in order; returns the accumulator and the exit
/// voxel of the last of them. `r`, `e`: the exit remainders and the floored
/// `e_vu / S` at `x` (see [`avx2::TripodLanes::new`]); `steps`: world unit
/// steps of local m, u, v.
///
/// A tripod column `c` (the voxels with local m coordinate `c`) is entered by
/// an m step and holds one or two more voxels for its minor steps: the line
/// crosses the u face of its column at most once (`D_u ≤ D_m`), and it does
/// iff the exit numerator of the previous column, `D_u·c + G_u`, leaves a
/// remainder of at least `D_m − D_u` (the tripod's exit voxel along u is
/// `floor((D_u·c + G_u) / D_m)`, the 26-line's formula half a column later).
/// With both steps, `e_vu < 0` puts the v face first. The codes come eight
/// columns at a time from the lanes; the voxels are written branch-free
/// (each column stores its entry, middle and exit voxel at fixed offsets
/// from a cursor that advances by the column's count).
///
/// # Safety
/// The CPU must support AVX2 ([`avx2::available`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn tripod_voxels<B, G: FnMut(B, glam::IVec3) -> B>(
    r: [i32; 2],
    e: i32,
    d: [i32; 3],
    x: glam::IVec3,
    steps: [glam::IVec3; 3],
    k: u64,
    mut acc: B,
    g: &mut G,
) -> (B, glam::IVec3) {
    use std::arch::x86_64::{__m128i, _mm_add_epi32, _mm_loadu_si128, _mm_storeu_si128};
    use std::mem::MaybeUninit;
    let v4 = |v: glam::IVec3| -> __m128i {
        let a = [v.x, v.y, v.z, 0];
        // SAFETY: an unaligned load of four i32.
        unsafe { _mm_loadu_si128(a.as_ptr().cast()) }
    };
    let [m, u, v] = steps;
    // Per code: the steps from the column's entry voxel to its middle
    // voxel (when it has two minor steps) and to its exit voxel, in one
    // entry so that one index finds both.
    let moves: [[__m128i; 2]; 8] = std::array::from_fn(|c| {
        let first = match c {
            1 | 3 | 5 => u,
            2 | 6 | 7 => v,
            _ => glam::IVec3::ZERO,
        };
        let exit = u * (c & 1) as i32 + v * (c >> 1 & 1) as i32;
        [v4(first), v4(exit)]
    });
    // Bytes each column's voxels take in the buffer.
    const ADVANCE: [usize; 8] = {
        let mut a = [0; 8];
        let mut c = 0;
        while c < 8 {
            a[c] = TRIPOD_COUNT[c] * std::mem::size_of::<glam::IVec3>();
            c += 1;
        }
        a
    };
    let step_m = v4(m);
    // SAFETY: SSE2 is part of the x86-64 baseline.
    let add = |a: __m128i, b: __m128i| unsafe { _mm_add_epi32(a, b) };
    // SAFETY (both calls): the caller guarantees AVX2.
    let mut lanes = unsafe { avx2::TripodLanes::new(r, e, d) };
    let mut codes = avx2::buffer();
    // Voxels as packed `IVec3`s (12 bytes): each is written by a 16-byte
    // store whose fourth word spills into the next entry, which a later
    // store of this column or the next overwrites (one entry of pad).
    let mut out = [MaybeUninit::<glam::IVec3>::uninit(); 3 * TRIPOD_FILL + 3];
    let mut exit = v4(x);
    let mut left = k;
    while left > 0 {
        let take = left.min(TRIPOD_FILL as u64) as usize;
        let cs = unsafe { lanes.fill(&mut codes, take) };
        let start = out.as_mut_ptr().cast::<u8>();
        // Byte offset of the column's entry voxel.
        let mut p = 0usize;
        for &c in cs {
            let c = (c & 7) as usize;
            let [first, delta] = moves[c];
            let entry = add(exit, step_m);
            exit = add(entry, delta);
            // SAFETY: before a column p ≤ 36·(TRIPOD_FILL − 1) (at most
            // three voxels per column), and its stores end by byte p + 28 <
            // 12·(3·TRIPOD_FILL + 3); unaligned stores of four i32 in order.
            unsafe {
                _mm_storeu_si128(start.add(p).cast(), entry);
                _mm_storeu_si128(start.add(p + 12).cast(), add(entry, first));
                p += ADVANCE[c];
                _mm_storeu_si128(start.add(p - 12).cast(), exit);
            }
        }
        // SAFETY: the loop wrote entries 0..p / 12 in full (each entry's
        // last store is its own).
        let vs = unsafe { std::slice::from_raw_parts(out.as_ptr().cast::<glam::IVec3>(), p / 12) };
        for &v in vs {
            acc = g(acc, v);
        }
        left -= take as u64;
    }
    let mut last = [0i32; 4];
    // SAFETY: an unaligned store of four i32.
    unsafe { _mm_storeu_si128(last.as_mut_ptr().cast(), exit) };
    (acc, glam::IVec3::new(last[0], last[1], last[2]))
}

/// [`tripod_voxels`] for a grid walk: visits the linear indices of the
/// tripod voxels of the `k` columns after the exit voxel's index `x`; `off`:
/// index offsets of local m, u, v. Returns the index of the last column's
/// exit voxel and the u and v steps taken, or `Err(index)` where the visitor
/// stopped.
///
/// # Safety
/// The CPU must support AVX2 ([`avx2::available`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn tripod_indices<F: FnMut(usize) -> std::ops::ControlFlow<()>>(
    r: [i32; 2],
    e: i32,
    d: [i32; 3],
    x: usize,
    off: [isize; 3],
    k: u64,
    visit: &mut F,
) -> Result<(usize, [i64; 2]), usize> {
    use std::mem::MaybeUninit;
    let [om, ou, ov] = off;
    // Per code: the index steps from the column's entry voxel to its middle
    // voxel and to its exit voxel (as in `tripod_voxels`).
    let first: [isize; 8] = [0, ou, ov, ou, 0, ou, ov, ov];
    let moves: [[isize; 2]; 8] =
        std::array::from_fn(|c| [first[c], ou * (c & 1) as isize + ov * (c >> 1 & 1) as isize]);
    // SAFETY (both calls): the caller guarantees AVX2.
    let mut lanes = unsafe { avx2::TripodLanes::new(r, e, d) };
    let mut codes = avx2::buffer();
    let mut out = [MaybeUninit::<usize>::uninit(); 3 * TRIPOD_FILL + 2];
    let mut exit = x;
    let mut left = k;
    while left > 0 {
        let take = left.min(TRIPOD_FILL as u64) as usize;
        let cs = unsafe { lanes.fill(&mut codes, take) };
        let base = out.as_mut_ptr().cast::<usize>();
        let mut p = 0usize;
        for &c in cs {
            let c = (c & 7) as usize;
            let [first, delta] = moves[c];
            let entry = exit.wrapping_add_signed(om);
            exit = entry.wrapping_add_signed(delta);
            // SAFETY: p + 2 < 3·TRIPOD_FILL + 2 (at most three voxels per
            // column).
            unsafe {
                base.add(p).write(entry);
                base.add(p + 1).write(entry.wrapping_add_signed(first));
                p += TRIPOD_COUNT[c];
                base.add(p - 1).write(exit);
            }
        }
        // SAFETY: the loop wrote entries 0..p.
        let ids = unsafe { std::slice::from_raw_parts(out.as_ptr().cast::<usize>(), p) };
        for &i in ids {
            if visit(i).is_break() {
                return Err(i);
            }
        }
        left -= take as u64;
    }
    // SAFETY: the caller guarantees AVX2.
    Ok((exit, unsafe { lanes.moved() }))
}
