//! A global allocator that backs large buffers with transparent huge pages.
//!
//! Why: a voxelization touches tens of megabytes of fresh memory (the
//! quantized triangles, the slabs' brick lists, the grid's arrays), and on
//! virtual machines a first touch of a 4 KiB page is expensive: 2.4–3.2 µs
//! each on the 2-core VM this was tuned on (mmap 64 MiB, write one byte per
//! page, fresh processes), against 0.42–0.51 µs per 4 KiB when the region
//! is marked `MADV_HUGEPAGE` and the kernel maps 2 MiB at a time. The bunny
//! (`voxkit voxelize`, thin, whole process) goes from 9,487 page faults to
//! 1,051 at 1024³ (peak RSS 26.2 → 35.6 MiB) and from 24,839 to 1,066 at
//! 2048³ (70.5 → 75.8 MiB).
//! Allocations of at least [`HUGE_THRESHOLD`] bytes that are *not* asked to
//! be zeroed (buffers about to be written in full: `Vec::with_capacity`,
//! `collect`, growth by `push`) get their own 2 MiB-aligned mapping with
//! that hint; everything else goes to the system allocator. Zeroed requests
//! stay on lazily mapped 4 KiB pages, so a large zeroed buffer that is only
//! touched sparsely (a dense bit grid) does not become resident in 2 MiB
//! steps. Such a mapping is resized without copying: shrunk or grown where
//! it lies when it can be, else its pages are moved by `mremap` (a vector
//! grown by `push` is neither copied nor touched twice).
//!
//! The `voxkit` binary installs it; a library user opts in with
//!
//! ```no_run
//! #[global_allocator]
//! static ALLOC: voxkit::alloc::HugePageAlloc = voxkit::alloc::HugePageAlloc;
//! ```
//!
//! Where transparent huge pages are off (`/sys/kernel/mm/transparent_hugepage/
//! enabled` set to `never`) the hint is ignored and the buffers get ordinary
//! pages; on targets other than Linux the allocator is the system one.

use std::alloc::{GlobalAlloc, Layout, System};

/// Allocations of at least this many bytes (and not zeroed) get huge pages.
pub const HUGE_THRESHOLD: usize = 1 << 19;

/// The huge page size the mappings are aligned and rounded to.
const HUGE_PAGE: usize = 2 << 20;

/// The system allocator, with large non-zeroed buffers on transparent huge
/// pages (see the [module docs](self)).
#[derive(Clone, Copy, Debug, Default)]
pub struct HugePageAlloc;

/// Whether an allocation of `layout` lives in its own huge-page mapping.
/// Decided by size and alignment only, so `dealloc` and `realloc` (which get
/// the layout the block was allocated or last resized with) find the same
/// answer as the call that made it.
#[inline]
fn is_huge(layout: Layout) -> bool {
    cfg!(target_os = "linux") && layout.size() >= HUGE_THRESHOLD && layout.align() <= HUGE_PAGE
}

// SAFETY: `is_huge` routes every call by the layout alone, which the
// caller passes unchanged from allocation (or the last resize) to free: a
// small block comes from `System` and goes back to it with the same layout;
// a huge-sized block (zeroed or not) is its own mapping from `huge::map`
// and goes back through `huge::unmap` with the same size.
unsafe impl GlobalAlloc for HugePageAlloc {
    #[inline]
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if is_huge(layout) {
            huge::map(layout.size(), true)
        } else {
            // SAFETY: forwarded with the caller's layout.
            unsafe { System.alloc(layout) }
        }
    }

    #[inline]
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if is_huge(layout) {
            // A fresh anonymous mapping reads as zero; without the hint its
            // pages are mapped one by one as they are touched.
            huge::map(layout.size(), false)
        } else {
            // SAFETY: forwarded with the caller's layout.
            unsafe { System.alloc_zeroed(layout) }
        }
    }

    #[inline]
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if is_huge(layout) {
            // SAFETY: huge-sized blocks all come from `huge::map` with this
            // size (`alloc`, `alloc_zeroed` and `realloc` alike).
            unsafe { huge::unmap(ptr, layout.size()) }
        } else {
            // SAFETY: small blocks come from `System` with this layout.
            unsafe { System.dealloc(ptr, layout) }
        }
    }

    #[inline]
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller guarantees `new_size` with `layout.align()` is
        // a valid layout.
        let new_layout = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        if !is_huge(layout) && !is_huge(new_layout) {
            // SAFETY: a small block of `System`, resized within `System`.
            return unsafe { System.realloc(ptr, layout, new_size) };
        }
        if is_huge(layout) && is_huge(new_layout) {
            // SAFETY: `ptr` is a live mapping of `layout.size()` bytes.
            if let Some(p) = unsafe { huge::resize(ptr, layout.size(), new_size) } {
                return p;
            }
        }
        // SAFETY: `new_layout` is valid with a non-zero size (the caller's
        // guarantees for `realloc`).
        let new = unsafe { self.alloc(new_layout) };
        if !new.is_null() {
            // SAFETY: both blocks are live, distinct and at least this long.
            unsafe {
                std::ptr::copy_nonoverlapping(ptr, new, layout.size().min(new_size));
                self.dealloc(ptr, layout);
            }
        }
        new
    }
}

/// Below this many bytes of spare capacity [`prefault_spare`] leaves the
/// pages to the writes that fill them (rayon's start-up would cost more).
const PREFAULT_MIN: usize = 8 << 20;

/// Maps in the pages of `v`'s spare capacity from all of rayon's threads
/// (one write of `T::default()` per 4 KiB page; the length is unchanged),
/// so that the serial writes that fill the vector next find its memory
/// mapped.
///
/// Why: the kernel clears each fresh page on its first touch, and on a
/// virtual machine whose host has taken back the guest's free memory that
/// first touch is slow. On the 2-core VM this was measured on, 512 MiB
/// of huge pages took 0.77–1.16 s to touch from one thread and 0.50–0.63
/// s from two, a few seconds after the previous process freed its memory
/// (48 against 30 ms when it ran straight after). A volume read from a
/// file is filled by one thread; its first touch need not be.
///
/// ```
/// let mut v: Vec<u16> = Vec::with_capacity(10 << 20);
/// voxkit::alloc::prefault_spare(&mut v);
/// assert!(v.is_empty() && v.capacity() >= 10 << 20);
/// v.extend(std::iter::repeat_n(7, 10 << 20));
/// ```
pub fn prefault_spare<T: Default + Send>(v: &mut Vec<T>) {
    use rayon::prelude::*;
    const PAGE: usize = 4096;
    let size = std::mem::size_of::<T>();
    let spare = v.spare_capacity_mut();
    if size == 0 || spare.len() * size < PREFAULT_MIN {
        return;
    }
    // One element per page: consecutive writes are at most 4096 bytes
    // apart, so none of the spare pages is missed.
    let stride = (PAGE / size).max(1);
    spare.par_chunks_mut(stride * 512).for_each(|c| {
        for x in c.iter_mut().step_by(stride) {
            x.write(T::default());
        }
    });
}

#[cfg(target_os = "linux")]
mod huge {
    use super::HUGE_PAGE;

    /// Bytes of the mapping behind a block of `size` bytes.
    #[inline]
    fn mapped_len(size: usize) -> usize {
        size.next_multiple_of(HUGE_PAGE)
    }

    /// A fresh zeroed mapping of at least `size` bytes, aligned to
    /// [`HUGE_PAGE`]; with `hint`, marked for transparent huge pages. Null
    /// when the system refuses.
    pub(super) fn map(size: usize, hint: bool) -> *mut u8 {
        fresh(mapped_len(size), hint)
    }

    /// A new mapping of `len` bytes (a multiple of [`HUGE_PAGE`]), aligned
    /// to [`HUGE_PAGE`]; with `hint`, marked for transparent huge pages.
    fn fresh(len: usize, hint: bool) -> *mut u8 {
        // Over-allocate by one huge page and trim both ends to align.
        let Some(span) = len.checked_add(HUGE_PAGE) else {
            return std::ptr::null_mut();
        };
        // SAFETY: an anonymous private mapping at an address of the
        // kernel's choosing touches no existing memory.
        let raw = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                span,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        if raw == libc::MAP_FAILED {
            return std::ptr::null_mut();
        }
        let raw = raw.cast::<u8>();
        let head = (raw as usize).next_multiple_of(HUGE_PAGE) - raw as usize;
        let tail = span - head - len;
        // SAFETY: the trimmed ranges are page-aligned parts of the mapping
        // just made, outside the `len` bytes kept at `raw + head`.
        unsafe {
            if head > 0 {
                libc::munmap(raw.cast(), head);
            }
            if tail > 0 {
                libc::munmap(raw.add(head + len).cast(), tail);
            }
        }
        // SAFETY: `head < span`, inside the mapping.
        let p = unsafe { raw.add(head) };
        if hint {
            // A hint: failure (THP compiled out) leaves ordinary pages.
            // SAFETY: advises only the mapping just made.
            unsafe { libc::madvise(p.cast(), len, libc::MADV_HUGEPAGE) };
        }
        p
    }

    /// Frees a block of `size` bytes made by [`map`].
    ///
    /// # Safety
    /// `p` must come from [`map`] (or [`resize`]) with this `size`.
    pub(super) unsafe fn unmap(p: *mut u8, size: usize) {
        // SAFETY: by the contract, `p..p + mapped_len(size)` is our mapping.
        unsafe { libc::munmap(p.cast(), mapped_len(size)) };
    }

    /// The block resized to `new_size` without copying: shrunk or grown
    /// where it is when it can be, else its pages moved by `mremap` to a
    /// fresh aligned mapping; `None` when the system refuses (the block is
    /// then unchanged).
    ///
    /// # Safety
    /// `p` must come from [`map`] (or `resize`) with `size`.
    pub(super) unsafe fn resize(p: *mut u8, size: usize, new_size: usize) -> Option<*mut u8> {
        let (len, new_len) = (mapped_len(size), mapped_len(new_size));
        if new_len <= len {
            if new_len < len {
                // SAFETY: the tail is the end of our mapping, past the
                // `new_len` bytes kept.
                unsafe { libc::munmap(p.add(new_len).cast(), len - new_len) };
            }
            return Some(p);
        }
        // Grow in place where the address space after the block is free.
        // SAFETY: `p..p + len` is our mapping; without MREMAP_MAYMOVE it
        // stays where it is or the call fails.
        let q = unsafe { libc::mremap(p.cast(), len, new_len, 0) };
        if q != libc::MAP_FAILED {
            // SAFETY: advises only the mapping just grown.
            unsafe { libc::madvise(p.cast(), new_len, libc::MADV_HUGEPAGE) };
            return Some(p);
        }
        // Else move the pages (no copy, no new faults for them) to the
        // start of a fresh aligned mapping of the new size.
        let dest = fresh(new_len, true);
        if dest.is_null() {
            return None;
        }
        // SAFETY: `p..p + len` is our mapping and `dest..dest + new_len`
        // the one just made; MREMAP_FIXED replaces `dest..dest + len` with
        // `p`'s pages and unmaps `p`.
        let q = unsafe {
            libc::mremap(
                p.cast(),
                len,
                len,
                libc::MREMAP_MAYMOVE | libc::MREMAP_FIXED,
                dest.cast::<libc::c_void>(),
            )
        };
        if q == libc::MAP_FAILED {
            // SAFETY: `dest` is the fresh mapping of `new_len` bytes.
            unsafe { libc::munmap(dest.cast(), new_len) };
            return None;
        }
        Some(dest)
    }
}

#[cfg(not(target_os = "linux"))]
mod huge {
    // `is_huge` is false off Linux: these are never called.
    pub(super) fn map(_: usize, _: bool) -> *mut u8 {
        unreachable!("huge blocks are Linux-only")
    }
    pub(super) unsafe fn unmap(_: *mut u8, _: usize) {
        unreachable!("huge blocks are Linux-only")
    }
    pub(super) unsafe fn resize(_: *mut u8, _: usize, _: usize) -> Option<*mut u8> {
        unreachable!("huge blocks are Linux-only")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fills `len` bytes at `p` with a pattern depending on `seed`.
    fn fill(p: *mut u8, len: usize, seed: u8) {
        for i in 0..len {
            // SAFETY: the callers pass live blocks of at least `len` bytes.
            unsafe {
                p.add(i)
                    .write((i as u8).wrapping_mul(31).wrapping_add(seed))
            };
        }
    }

    fn holds(p: *const u8, len: usize, seed: u8) -> bool {
        // SAFETY: as in `fill`.
        (0..len)
            .all(|i| unsafe { p.add(i).read() } == (i as u8).wrapping_mul(31).wrapping_add(seed))
    }

    #[test]
    fn blocks_on_both_sides_of_the_threshold_keep_their_bytes_through_resizes() {
        let a = HugePageAlloc;
        // Small → huge → larger huge (same mapping) → much larger → shrunk
        // in place → grown again (moved or in place) → small.
        let sizes = [
            1000,
            HUGE_THRESHOLD + 8,
            HUGE_THRESHOLD + 4096,
            3 * HUGE_PAGE + 5,
            HUGE_PAGE + 17,
            9 * HUGE_PAGE,
            HUGE_THRESHOLD - 1,
            64,
        ];
        for align in [8, 64, 4096] {
            let mut layout = Layout::from_size_align(sizes[0], align).unwrap();
            // SAFETY: non-zero size, valid alignment.
            let mut p = unsafe { a.alloc(layout) };
            assert!(!p.is_null());
            fill(p, layout.size(), 7);
            for &size in &sizes[1..] {
                let keep = layout.size().min(size);
                // SAFETY: `p` is live with `layout`; `size` is non-zero.
                p = unsafe { a.realloc(p, layout, size) };
                assert!(!p.is_null());
                assert_eq!(
                    p as usize % align,
                    0,
                    "alignment {align} after resizing to {size}"
                );
                assert!(holds(p, keep, 7), "bytes lost resizing to {size}");
                layout = Layout::from_size_align(size, align).unwrap();
                fill(p, size, 7);
            }
            // SAFETY: `p` is live with `layout`.
            unsafe { a.dealloc(p, layout) };
        }
    }

    #[test]
    fn zeroed_huge_blocks_read_as_zero_and_huge_blocks_are_huge_page_aligned() {
        let a = HugePageAlloc;
        let layout = Layout::from_size_align(5 * HUGE_THRESHOLD + 3, 16).unwrap();
        // Reuse: the second round may get the first round's address back.
        for _ in 0..2 {
            // SAFETY: non-zero size, valid alignment.
            let z = unsafe { a.alloc_zeroed(layout) };
            assert!(!z.is_null());
            // SAFETY: `z` is a live block of `layout.size()` bytes.
            let bytes = unsafe { std::slice::from_raw_parts(z, layout.size()) };
            assert!(bytes.iter().all(|&b| b == 0));
            if cfg!(target_os = "linux") {
                assert_eq!(z as usize % HUGE_PAGE, 0);
            }
            fill(z, layout.size(), 1);
            // SAFETY: as above.
            let p = unsafe { a.alloc(layout) };
            assert!(!p.is_null());
            fill(p, layout.size(), 2);
            assert!(holds(z, layout.size(), 1) && holds(p, layout.size(), 2));
            // SAFETY: both live with `layout`.
            unsafe {
                a.dealloc(z, layout);
                a.dealloc(p, layout);
            }
        }
    }

    /// A huge block that cannot grow where it lies (the page after its
    /// mapping is taken) has its pages moved by `mremap`: its bytes kept,
    /// its new address huge-page aligned, the old range no longer ours.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_blocked_huge_block_grows_by_moving_its_pages() {
        let a = HugePageAlloc;
        let layout = Layout::from_size_align(2 * HUGE_PAGE, 64).unwrap();
        // SAFETY: non-zero size, valid alignment.
        let p = unsafe { a.alloc(layout) };
        assert!(!p.is_null());
        fill(p, layout.size(), 5);
        // Take the page right after the block's mapping, so it cannot grow in place.
        // SAFETY: MAP_FIXED_NOREPLACE maps only where nothing is mapped.
        let guard = unsafe {
            libc::mmap(
                p.add(2 * HUGE_PAGE).cast(),
                4096,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS | libc::MAP_FIXED_NOREPLACE,
                -1,
                0,
            )
        };
        assert_eq!(guard.cast::<u8>(), unsafe { p.add(2 * HUGE_PAGE) });
        let new_size = 5 * HUGE_PAGE + 3;
        // SAFETY: `p` comes from `map` (through `alloc`) with this size.
        let q = unsafe { huge::resize(p, layout.size(), new_size) }
            .expect("mremap moves the pages rather than failing");
        assert_ne!(q, p, "the block could not have grown in place");
        assert_eq!(q as usize % HUGE_PAGE, 0);
        assert!(holds(q, layout.size(), 5));
        fill(q, new_size, 6);
        // SAFETY: `q` is live with the new layout; `guard` is the page mapped above.
        unsafe {
            a.dealloc(q, Layout::from_size_align(new_size, 64).unwrap());
            libc::munmap(guard, 4096);
        }
    }

    #[test]
    fn growth_by_doubling_through_the_threshold_keeps_every_element() {
        // What a growing `Vec<u64>` asks of it, by hand.
        let a = HugePageAlloc;
        let mut raw: Option<(*mut u8, Layout)> = None;
        let mut cap = 16usize;
        for _ in 0..20 {
            let layout = Layout::array::<u64>(cap).unwrap();
            let p = match raw {
                // SAFETY: non-zero size.
                None => unsafe { a.alloc(layout) },
                // SAFETY: `q` is live with `old`.
                Some((q, old)) => unsafe { a.realloc(q, old, layout.size()) },
            };
            assert!(!p.is_null());
            let words = p.cast::<u64>();
            let prev = raw.map_or(0, |(_, old)| old.size() / 8);
            for i in 0..cap {
                if i < prev {
                    // SAFETY: `i < cap`, inside the block.
                    assert_eq!(unsafe { words.add(i).read() }, i as u64);
                } else {
                    // SAFETY: as above.
                    unsafe { words.add(i).write(i as u64) };
                }
            }
            raw = Some((p, layout));
            cap *= 2;
        }
        if let Some((p, layout)) = raw {
            // SAFETY: live with `layout`.
            unsafe { a.dealloc(p, layout) };
        }
    }
}
