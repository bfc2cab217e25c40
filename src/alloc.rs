//! Process-wide allocator settings, made once at start-up by the `stencil` binary (and by the
//! benchmarks, so that they measure what the binary runs): [`keep_freed_memory`], and on Linux
//! the global allocator [`HugePages`].

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
        libc::mallopt(libc::M_MMAP_THRESHOLD, MAPPED_FROM as i32);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
    }
}

/// Blocks from this size up are mapped apart by glibc ([`keep_freed_memory`]'s threshold), so
/// they arrive as fresh zero pages.
#[cfg(target_os = "linux")]
const MAPPED_FROM: usize = 32 << 20;

/// The system allocator, but blocks of [`HUGE_FROM`] bytes and more ask the kernel for huge
/// pages (2 MiB) where they cover whole ones (`madvise(MADV_HUGEPAGE)`; Linux's default is to
/// give them only to memory that asks).
///
/// Why: a mesh's rendering fills buffers of tens of megabytes (its samples' surfaces, the
/// fragments its lines read), each page of them fresh memory: `make` of `samples/trefoil.obj`
/// took 28,000 page faults, a fifth of its CPU time in the kernel. With huge pages it takes
/// 1,500, and 20 % less CPU (the same as glibc's own `glibc.malloc.hugetlb=1` setting, which a
/// program cannot set for itself). Only whole huge pages inside a block are asked for, so the
/// memory held grows by little (a block's untouched tail at most).
#[cfg(target_os = "linux")]
pub struct HugePages;

/// Blocks this large may hold a whole huge page (those of twice this size always do).
#[cfg(target_os = "linux")]
const HUGE_FROM: usize = HUGE_PAGE;

/// The size of a huge page on x86-64 and most arm64 kernels (where it is other, the advice
/// covers fewer or no pages: only speed changes).
#[cfg(target_os = "linux")]
const HUGE_PAGE: usize = 2 << 20;

#[cfg(target_os = "linux")]
#[global_allocator]
static GLOBAL: HugePages = HugePages;

#[cfg(target_os = "linux")]
impl HugePages {
    /// Ask for huge pages for the whole 2 MiB pages inside the `size` bytes at `p` (a block
    /// just allocated, none of it touched yet unless moved there by a reallocation).
    fn advise(p: *mut u8, size: usize) {
        if p.is_null() || size < HUGE_FROM {
            return;
        }
        let start = (p as usize).next_multiple_of(HUGE_PAGE);
        let end = (p as usize + size) / HUGE_PAGE * HUGE_PAGE;
        if end > start {
            // SAFETY: the range lies inside the block just allocated to us; the advice changes
            // only how its pages are backed, never their contents. A kernel without huge pages
            // refuses it, which changes nothing.
            unsafe {
                libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
            }
        }
    }
}

// SAFETY: every block comes from and returns to `System` with the layout asked for; the advice
// and the zeroing below touch only the block just allocated.
#[cfg(target_os = "linux")]
unsafe impl std::alloc::GlobalAlloc for HugePages {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        let p = unsafe { std::alloc::System.alloc(layout) };
        Self::advise(p, layout.size());
        p
    }

    unsafe fn alloc_zeroed(&self, layout: std::alloc::Layout) -> *mut u8 {
        let size = layout.size();
        if !(HUGE_FROM..MAPPED_FROM).contains(&size) {
            // Small blocks, and mapped ones, which calloc leaves untouched (fresh pages are zero).
            let p = unsafe { std::alloc::System.alloc_zeroed(layout) };
            Self::advise(p, size);
            return p;
        }
        // From a heap, calloc would clear the block before it could be advised: its pages
        // would be faulted in one by one. Advised first, they are cleared as huge pages.
        let p = unsafe { std::alloc::System.alloc(layout) };
        Self::advise(p, size);
        if !p.is_null() {
            unsafe { std::ptr::write_bytes(p, 0, size) };
        }
        p
    }

    unsafe fn dealloc(&self, p: *mut u8, layout: std::alloc::Layout) {
        unsafe { std::alloc::System.dealloc(p, layout) }
    }

    unsafe fn realloc(&self, p: *mut u8, layout: std::alloc::Layout, size: usize) -> *mut u8 {
        let q = unsafe { std::alloc::System.realloc(p, layout, size) };
        Self::advise(q, size);
        q
    }
}
