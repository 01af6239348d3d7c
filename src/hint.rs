//! Cache hints for hot loops whose access order is not memory order (the
//! surface slabs walk their triangles spatially).

/// Hints the CPU to fetch the cache line holding `p` into all cache
/// levels. A hint only: it never faults, whatever `p` is, and is a no-op
/// on targets without one.
#[inline(always)]
pub(crate) fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `_mm_prefetch` needs only SSE, which is in the x86-64
    // baseline target; a prefetch is a hint and never faults.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>(p.cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}
