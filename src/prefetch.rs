//! Asking the CPU to start loading what a loop will read soon: the renderer's reads jump
//! across arrays of millions of records (BVH nodes and leaves, per-triangle attributes), the
//! geodesic searches' across per-span records, and each would otherwise wait on memory in
//! turn. A hint only: results never depend on it.

/// The cache line size of the CPUs minos runs on (x86-64).
#[cfg(target_arch = "x86_64")]
const LINE: usize = 64;

/// Asks the CPU to start loading `items[i]`, every cache line it spans, where the platform
/// has a prefetch instruction (x86-64). Never reads it; nothing happens when `i` is out of
/// range.
#[inline(always)]
pub(crate) fn prefetch<T>(items: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(item) = items.get(i) {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let start = (item as *const T).cast::<i8>();
        let size = std::mem::size_of::<T>().max(1);
        // SAFETY (all three): a prefetch reads nothing the program sees; the addresses are
        // inside `item`.
        if (start as usize % LINE) + size <= LINE {
            // The item sits in one line (the geodesic searches' records): one hint.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start) };
            return;
        }
        // One address per line from the start, then the last byte, whose line the others
        // miss when the item does not begin a line.
        for offset in (0..size).step_by(LINE).chain([size - 1]) {
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(offset)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (items, i);
}
