//! Exact division by a loop-invariant `u64` with multiplications only.
//!
//! Möller & Granlund, *Improved division by invariant integers* (IEEE TC
//! 2011), Algorithm 4 (`div_2by1`): with the divisor shifted so its top bit
//! is set (`d`) and the precomputed reciprocal `v = ⌊(2^128 − 1)/d⌋ − 2^64`,
//! a two-word numerator `u1·2^64 + u0` with `u1 < d` is divided by one
//! 64×64→128 product, one low product and at most two corrections.
//!
//! Why: `TriangleIndex::point` divides by three per-triangle constants. The
//! hardware `div` costs 40–90 cycles on common x86-64 cores and its latency
//! grows with the operand size (and a quotient of a 128-bit product needs a
//! library call), so random access got slower as triangles grew. With the
//! reciprocal every division costs the same few cycles at every size.

/// A divisor `1 ≤ d < 2^64` prepared for repeated exact division.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Recip {
    /// `d << shift` (top bit set).
    norm: u64,
    /// `⌊(2^128 − 1)/norm⌋ − 2^64`.
    v: u64,
    /// Leading zeros of `d`.
    shift: u32,
}

impl Recip {
    /// Prepares division by `d` (`d ≥ 1`; one `u128` division, done once).
    pub(crate) fn new(d: u64) -> Recip {
        assert!(d > 0, "division by zero");
        let shift = d.leading_zeros();
        let norm = d << shift;
        // ⌊(2^128 − 1)/norm⌋ ∈ [2^64, 2^65) because norm ≥ 2^63: dropping the
        // top bit subtracts 2^64.
        let v = (u128::MAX / norm as u128) as u64;
        Recip { norm, v, shift }
    }

    /// The divisor.
    #[inline(always)]
    pub(crate) fn divisor(&self) -> u64 {
        self.norm >> self.shift
    }

    /// `(⌊n/d⌋, n mod d)` for `n < d·2^64` (the quotient fits in `u64`).
    #[inline(always)]
    pub(crate) fn divrem_wide(&self, n: u128) -> (u64, u64) {
        debug_assert!(n >> 64 < self.divisor() as u128, "quotient overflows u64");
        // n·2^shift < norm·2^64 ≤ 2^128: the shift loses nothing.
        let n = n << self.shift;
        let (u1, u0) = ((n >> 64) as u64, n as u64);
        let q = (self.v as u128 * u1 as u128).wrapping_add(((u1 as u128 + 1) << 64) | u0 as u128);
        let (mut q1, q0) = ((q >> 64) as u64, q as u64);
        let mut r = u0.wrapping_sub(q1.wrapping_mul(self.norm));
        // Branch-free first correction (taken about half the time).
        let dec = r > q0;
        q1 = q1.wrapping_sub(dec as u64);
        r = r.wrapping_add(self.norm & 0u64.wrapping_sub(dec as u64));
        // The second correction is rare.
        if r >= self.norm {
            q1 += 1;
            r -= self.norm;
        }
        (q1, r >> self.shift)
    }

    /// `(⌊n/d⌋, n mod d)`.
    #[inline(always)]
    pub(crate) fn divrem(&self, n: u64) -> (u64, u64) {
        self.divrem_wide(n as u128)
    }

    /// `(⌊a·b/d⌋, a·b mod d)` exactly, for `a·b < d·2^64`.
    #[inline(always)]
    pub(crate) fn mul_divrem(&self, a: u64, b: u64) -> (u64, u64) {
        self.divrem_wide(a as u128 * b as u128)
    }
}

#[cfg(test)]
mod tests {
    use super::Recip;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn check(d: u64, n: u128) {
        let r = Recip::new(d);
        let (q, m) = r.divrem_wide(n);
        assert_eq!(q as u128, n / d as u128, "{n} / {d}");
        assert_eq!(m as u128, n % d as u128, "{n} % {d}");
    }

    /// Against `u128` division: edge divisors (1, powers of two and their
    /// neighbours, `u64::MAX`), numerators at the ends of the valid range and
    /// random ones of every bit length.
    #[test]
    fn matches_u128_division() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x2ec1);
        let mut ds = vec![1u64, 2, 3, 5, 7, 10, u64::MAX, u64::MAX - 1, (1 << 62) + 1];
        for b in 0..64 {
            ds.extend([
                1u64 << b,
                (1u64 << b).wrapping_sub(1).max(1),
                (1u64 << b) + 1,
            ]);
        }
        for _ in 0..300 {
            let bits = rng.random_range(1..=64);
            ds.push((rng.random::<u64>() >> (64 - bits)).max(1));
        }
        for &d in &ds {
            let top = ((d as u128) << 64) - 1; // largest n with a u64 quotient
            for n in [0, 1, d as u128 - 1, d as u128, d as u128 + 1, top, top - 1] {
                check(d, n);
            }
            for _ in 0..200 {
                let bits = rng.random_range(0..=128u32);
                let n = if bits == 0 {
                    0
                } else {
                    rng.random::<u128>() >> (128 - bits)
                };
                check(d, n % (top + 1));
            }
            // Products a·b with a, b < d (the use in point(i)).
            for _ in 0..50 {
                let (a, b) = (rng.random_range(0..d), rng.random_range(0..d));
                let r = Recip::new(d);
                let p = a as u128 * b as u128;
                assert_eq!(
                    r.mul_divrem(a, b),
                    ((p / d as u128) as u64, (p % d as u128) as u64)
                );
            }
            let x = rng.random::<u64>();
            assert_eq!(Recip::new(d).divrem(x), (x / d, x % d));
            assert_eq!(Recip::new(d).divisor(), d);
        }
    }
}
