//! Process-wide allocator settings, made once at start-up by the `stencil` binary (and by the
//! benchmarks, so that they measure what the binary runs).

/// Keep memory the program frees for its next allocations instead of handing it back to the
/// operating system at once.
///
/// Why: each stage allocates and frees buffers of megabytes (the marching-squares links, the
/// triangulation, the triangles), and glibc returns freed memory at the top of its heaps to the
/// system, so the next buffer is made of fresh pages and pays a page fault for each. Keeping it,
/// vectorising and checking a 2000 × 2000 stencil took 60 % fewer page faults and 5–8 % less CPU
/// time (medians of 200 runs each way; the wall time moved less than this machine's noise). Blocks over 32 MiB (glibc's limit for this setting) are still mapped apart.
/// Only glibc has these knobs; elsewhere this does nothing.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets allocator parameters; it is called before any other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
    }
}
