//! `sweep`'s allocator settings (`src/heap.rs`) take effect: after them, a block of 8 MiB
//! comes from the heap rather than from a mapping of its own, and freeing 16 MiB at the top
//! of the heap leaves it there for the next allocation instead of handing it back.
//!
//! glibc reports the top of the heap (`keepcost`) for the main arena only, the one the main
//! thread allocates from, so this test runs on the main thread: it has its own `main`
//! (`harness = false`).

#[path = "../src/heap.rs"]
#[allow(dead_code)]
mod heap;

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[allow(unsafe_code)]
mod glibc {
    /// glibc's `struct mallinfo2` (2.33 and later).
    #[repr(C)]
    #[derive(Debug, Clone, Copy)]
    pub struct MallInfo2 {
        pub arena: usize,
        pub ordblks: usize,
        pub smblks: usize,
        /// Blocks allocated by mapping them, and their bytes.
        pub hblks: usize,
        pub hblkhd: usize,
        pub usmblks: usize,
        pub fsmblks: usize,
        pub uordblks: usize,
        pub fordblks: usize,
        /// Free bytes at the top of the main arena's heap, which trimming would release.
        pub keepcost: usize,
    }

    extern "C" {
        fn mallinfo2() -> MallInfo2;
    }

    pub fn info() -> MallInfo2 {
        // SAFETY: `mallinfo2` takes nothing and returns a plain struct by value.
        unsafe { mallinfo2() }
    }
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn main() {
    use std::hint::black_box;
    assert!(heap::keep_freed_memory(), "glibc refused a setting");

    // 8 MiB, below the 32 MiB threshold: from the heap, not mapped (the default threshold,
    // 128 KiB, maps it).
    let mapped = glibc::info().hblkhd;
    let block = black_box(vec![1u8; 8 << 20]);
    let during = glibc::info();
    assert!(
        during.hblkhd < mapped + (8 << 20),
        "8 MiB was mapped on its own: {} bytes mapped before, {} during",
        mapped,
        during.hblkhd
    );
    drop(block);

    // 16 MiB at the top of the heap, freed: kept there (the default trim threshold, 128 KiB,
    // hands it back to the system).
    let top = black_box(vec![1u8; 16 << 20]);
    drop(top);
    let after = glibc::info();
    assert!(
        after.keepcost >= 16 << 20,
        "the freed top of the heap was handed back: {} bytes left at the top",
        after.keepcost
    );
    println!(
        "heap settings: ok (8 MiB from the heap, {} bytes kept at its top)",
        after.keepcost
    );
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn main() {
    assert!(!heap::keep_freed_memory());
}
