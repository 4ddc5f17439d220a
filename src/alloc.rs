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
