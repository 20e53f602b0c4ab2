//! Asking the CPU to start loading what a loop will read soon: the renderer's reads jump
//! across arrays of millions of records (BVH nodes and leaves, per-triangle attributes), and
//! each would otherwise wait on memory in turn.

/// Asks the CPU to start loading `items[i]`, every cache line it spans, where the platform
/// has a prefetch instruction (x86-64). Never reads it; nothing happens when `i` is out of
/// range.
#[inline(always)]
pub(super) fn prefetch<T>(items: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(item) = items.get(i) {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let start = (item as *const T).cast::<i8>();
        let size = std::mem::size_of::<T>().max(1);
        // One address per line from the start, then the last byte, whose line the others
        // miss when the item does not begin a line.
        let lines = (0..size).step_by(64).chain([size - 1]);
        for offset in lines {
            // SAFETY: a prefetch reads nothing the program sees; the address is inside
            // `item`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(offset)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (items, i);
}
