//! Cache hints for the block streams of the spring kernels and the elastoplastic lattice passes.
//! A kernel reads its blocks in order, one cache line or more a block, between loads scattered over
//! the slots' displacements and totals; on a body whose blocks do not fit the caches, the cores'
//! own prefetchers can fall behind that stream, and the kernel then waits on it. So a kernel asks
//! for the block some way ahead of the one it computes
//! (docs/DECISIONS.md#block-streams-prefetched). A hint changes no value the kernel computes.
//!
//! Its `unsafe` is the call of the SSE prefetch instruction, which every x86-64 CPU has (see
//! `docs/DECISIONS.md#where-unsafe-is-allowed`). Elsewhere the hint is nothing.

/// Asks the CPU to bring the cache line holding `items[index]` into its caches, where `items` is
/// the array starting at `first`; `index` may lie past the array's end (the hint is then for
/// memory the program never reads, which is harmless: a prefetch never faults).
#[inline(always)]
pub(crate) fn prefetch<T>(first: *const T, index: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let at = first.wrapping_add(index).cast::<i8>();
        // SAFETY: `_mm_prefetch`'s one precondition is the SSE feature, part of every x86-64
        // CPU. The instruction reads nothing the program sees and never faults, whatever the
        // address, so an address past the array's end is sound.
        #[allow(unsafe_code)]
        unsafe {
            _mm_prefetch::<_MM_HINT_T0>(at);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _no_hint = (first, index);
}

/// [`prefetch`] for every cache line of `items[index]`, an item that spans several.
#[inline(always)]
pub(crate) fn prefetch_item<T>(first: *const T, index: usize) {
    let start = first.wrapping_add(index).cast::<u8>();
    let size = std::mem::size_of::<T>();
    let mut offset = 0;
    while offset < size {
        prefetch(start.wrapping_add(offset), 0);
        offset += 64;
    }
    prefetch(start.wrapping_add(size - 1), 0);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernels ask for blocks past their arrays' ends near the end of a chunk: such hints,
    /// and one for an address nothing maps, neither fault nor change what they point near.
    #[test]
    fn hints_past_an_array_or_at_no_memory_are_harmless() {
        let blocks = vec![[7.0f32; 56]; 3];
        for index in [0, 2, 3, 40, 1 << 20] {
            prefetch(blocks.as_ptr(), index);
            prefetch_item(blocks.as_ptr(), index);
        }
        prefetch(std::ptr::null::<u8>(), 0);
        prefetch_item(std::ptr::null::<[f32; 56]>(), usize::MAX / 512);
        assert!(blocks.iter().flatten().all(|&value| value == 7.0));
    }
}
