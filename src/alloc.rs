//! Allocator tuning for the `lumo` binary (call [`return_big_frees_to_os`] first thing).

/// Allocations of at least this many bytes get their own memory mapping.
pub const MMAP_THRESHOLD: usize = 4 << 20;

/// With glibc, makes every allocation of at least [`MMAP_THRESHOLD`] bytes its own memory
/// mapping, given back to the operating system as soon as it is freed. By default glibc raises
/// this threshold (up to 32 MiB) each time it frees a big mapped block (reading a 31 MB file
/// already does), and big arrays allocated after that come from the heap, whose freed memory it
/// keeps: starting a 1.3 M-triangle scene then peaks ~34 MB (26 bytes per triangle) higher.
/// Elsewhere (other platforms, other allocators) it does nothing. Returns whether it applied.
pub fn return_big_frees_to_os() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        /// glibc's `M_MMAP_THRESHOLD` (malloc.h).
        const M_MMAP_THRESHOLD: std::ffi::c_int = -3;
        unsafe extern "C" {
            fn mallopt(param: std::ffi::c_int, value: std::ffi::c_int) -> std::ffi::c_int;
        }
        // SAFETY: mallopt only changes a malloc parameter; any value in range is valid, and
        // setting it fixes the threshold (glibc then stops adjusting it).
        unsafe { mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD as std::ffi::c_int) == 1 }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        false
    }
}

/// The system allocator, asking the kernel to back every block of at least [`MMAP_THRESHOLD`]
/// bytes with transparent huge pages (`madvise(MADV_HUGEPAGE)`, as Embree does for its BVH
/// memory). Such blocks are fresh mappings (see [`return_big_frees_to_os`]), so the advice
/// comes before their first touch. Starting a big scene writes and then frees some hundred
/// megabytes of such blocks (the glTF buffers, the builder's primitive records and binary
/// tree, the leaf packets); in 4 KiB pages, faulting them in and unmapping them took a third
/// of the start's CPU time on a virtual machine, where each fault and each page-table entry
/// costs more. Where the kernel has no transparent huge pages, or only for madvised memory,
/// the advice is ignored or taken; nothing else changes. Elsewhere than Linux it is the system
/// allocator.
pub struct HugePageAlloc;

// SAFETY: every call is passed to `System` unchanged; the advice only changes how the kernel
// backs memory the allocation owns.
unsafe impl std::alloc::GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's guarantees.
        let p = unsafe { std::alloc::System.alloc(layout) };
        advise_huge_pages(p, layout.size());
        p
    }

    unsafe fn alloc_zeroed(&self, layout: std::alloc::Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's guarantees.
        let p = unsafe { std::alloc::System.alloc_zeroed(layout) };
        advise_huge_pages(p, layout.size());
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        // SAFETY: forwarded with the caller's guarantees.
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded with the caller's guarantees.
        let p = unsafe { std::alloc::System.realloc(ptr, layout, new_size) };
        advise_huge_pages(p, new_size);
        p
    }
}

/// Advises huge pages for the whole pages of `len` bytes at `p`, when `len` is at least
/// [`MMAP_THRESHOLD`] (a failed advice is only a lost optimisation).
#[inline]
fn advise_huge_pages(p: *mut u8, len: usize) {
    #[cfg(target_os = "linux")]
    if len >= MMAP_THRESHOLD && !p.is_null() {
        /// Linux's `MADV_HUGEPAGE` (asm-generic/mman-common.h).
        const MADV_HUGEPAGE: std::ffi::c_int = 14;
        const PAGE: usize = 4096;
        let start = (p as usize).next_multiple_of(PAGE);
        // SAFETY: the range lies within the block just allocated (from its first whole page);
        // madvise with MADV_HUGEPAGE changes no contents and fails harmlessly.
        unsafe { advise(start, p as usize + len, MADV_HUGEPAGE) };
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (p, len);
}

/// The size of the blocks [`release_unused`] gives back: a transparent huge page, so that no
/// huge page is split.
const RELEASE_BLOCK: usize = 2 << 20;

/// Gives the memory of the whole 2 MiB-aligned blocks within `len` bytes at `p` back to the
/// operating system (Linux's `madvise(MADV_DONTNEED)`); they read back as zeros. For arrays
/// whose tail or middle is finished with before the array is freed (the BVH builder's
/// primitive records, each range of which is dead once its subtree is built), so that the
/// process's peak does not hold them beside what is built from them. Elsewhere than Linux, and
/// for ranges holding no whole block, it does nothing.
///
/// # Safety
/// Nothing may read the range's contents afterwards expecting what was there (a write, or a
/// read expecting anything, is fine: the memory stays mapped and owned by its allocation).
pub(crate) unsafe fn release_unused(p: *const u8, len: usize) {
    #[cfg(target_os = "linux")]
    {
        /// Linux's `MADV_DONTNEED` (asm-generic/mman-common.h).
        const MADV_DONTNEED: std::ffi::c_int = 4;
        let start = (p as usize).next_multiple_of(RELEASE_BLOCK);
        let end = (p as usize + len) / RELEASE_BLOCK * RELEASE_BLOCK;
        // SAFETY: the range lies within the caller's block (rounded inwards to whole blocks),
        // whose contents the caller has finished with; on failure nothing changes.
        unsafe { advise(start, end, MADV_DONTNEED) };
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (p, len);
}

/// Linux's `madvise(advice)` on the bytes from `start` (page-aligned) to `end`, if any; its
/// failure is ignored (an advice not taken).
///
/// # Safety
/// The range must belong to one allocation, and `advice` must suit what its owner does with it.
#[cfg(target_os = "linux")]
unsafe fn advise(start: usize, end: usize, advice: std::ffi::c_int) {
    unsafe extern "C" {
        fn madvise(
            addr: *mut std::ffi::c_void,
            len: usize,
            advice: std::ffi::c_int,
        ) -> std::ffi::c_int;
    }
    if end > start {
        // SAFETY: passed on from the caller.
        unsafe { madvise(start as *mut std::ffi::c_void, end - start, advice) };
    }
}
