//! How the process's allocator gives memory back to the system.
//!
//! glibc's `malloc` returns a freed block to the system when it is large: one of more than
//! 128 KiB (a threshold it then raises as such blocks come and go) is unmapped, and the top
//! of the heap is trimmed once more than twice that is free there. A projection of a jam of
//! thousands of people allocates and frees vectors of that size many times per step (the
//! interior point's and the active set's, one entry per row or unknown), so by default each
//! of them is mapped afresh, its pages faulted in and zeroed by the kernel every time.
//! [`keep_freed_memory`] raises both thresholds, so freed memory stays with the process for its
//! next allocations (measured: `docs/lab/2026-11-23-per-size-table-release-by-release.md`).
//! The resident set then does not shrink after a peak, and the peak itself (what `sweep run`
//! reports) is the same.

/// Makes glibc's allocator keep freed memory (blocks of up to 32 MiB are not mapped on their
/// own, and the heap is not trimmed below 1 GiB of free space at its top). Call it first
/// thing in `main`, before any thread starts. Elsewhere than on glibc it does nothing.
/// Returns whether the allocator took both settings (`false` off glibc).
pub fn keep_freed_memory() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    return glibc::keep_freed_memory();
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    false
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[allow(unsafe_code)]
mod glibc {
    use std::ffi::c_int;

    // From glibc's <malloc.h>.
    const M_TRIM_THRESHOLD: c_int = -1;
    const M_MMAP_THRESHOLD: c_int = -3;

    extern "C" {
        fn mallopt(param: c_int, value: c_int) -> c_int;
    }

    pub(super) fn keep_freed_memory() -> bool {
        // 32 MiB is the largest mmap threshold glibc takes on 64-bit systems; a larger one is
        // refused (mallopt returns 0 and nothing changes). Either call failing only leaves
        // glibc's defaults, so the result is not an error.
        // SAFETY: `mallopt` takes two integers and changes two of the allocator's parameters
        // under its own lock; nothing is passed by pointer. glibc marks it unsafe only while
        // the allocator initializes (`MT-Unsafe init`): `main` calls it before any other thread
        // exists, and in the test the allocator is long initialized.
        unsafe {
            mallopt(M_MMAP_THRESHOLD, 32 << 20) == 1 && mallopt(M_TRIM_THRESHOLD, 1 << 30) == 1
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    fn glibc_takes_both_settings() {
        // A threshold above glibc's limit would be refused silently; this one is taken.
        assert!(super::keep_freed_memory());
    }
}
