//! Peak heap memory of a measured step: the benchmark binary's global allocator counts the
//! bytes live on the heap and their high-water mark, so the peak of a step is the mark
//! reached during it less the bytes live before it. This counts what the program asked
//! for (heap only: no stacks, code or mapped files), exactly and whatever the allocator
//! keeps cached, which the resident set of a process does not tell.
//!
//! Underneath is the allocator `svo-bake` links, so the report times the bake as the CLI
//! runs it: mimalloc (feature `mimalloc`, on by default), or the system allocator without
//! the feature.

// The allocator below is the one place in the project that needs `unsafe`: `GlobalAlloc`
// is an unsafe trait. Every call is passed unchanged to the inner allocator.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout};
use std::sync::atomic::{AtomicUsize, Ordering};

#[cfg(feature = "mimalloc")]
use mimalloc::MiMalloc as Inner;
#[cfg(not(feature = "mimalloc"))]
use std::alloc::System as Inner;

/// The allocator underneath, as the report names it.
pub const ALLOCATOR: &str = if cfg!(feature = "mimalloc") {
    "mimalloc"
} else {
    "the system allocator"
};

/// The allocator `svo-bake` links, counting live bytes and their high-water mark.
pub struct CountingAlloc;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(n: usize) {
    let now = LIVE.fetch_add(n, Ordering::Relaxed) + n;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

fn shrank(n: usize) {
    LIVE.fetch_sub(n, Ordering::Relaxed);
}

// SAFETY: every method forwards its arguments unchanged to `Inner`, which upholds the
// `GlobalAlloc` contract; the counters are plain atomics and never touch the memory.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller upholds `alloc`'s contract for `layout`, which is `Inner`'s.
        let p = unsafe { Inner.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let p = unsafe { Inner.alloc_zeroed(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from this allocator (that is, from `Inner`) with `layout`.
        unsafe { Inner.dealloc(ptr, layout) };
        shrank(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: `ptr` came from `Inner` with `layout`; the caller upholds the rest.
        let p = unsafe { Inner.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size >= layout.size() {
                grew(new_size - layout.size());
            } else {
                shrank(layout.size() - new_size);
            }
        }
        p
    }
}

/// Whether the counting allocator is the global one (the `svo-bench` binary installs it;
/// a library user or a test harness may not).
pub fn counting() -> bool {
    LIVE.load(Ordering::Relaxed) > 0
}

/// Runs `f` and returns its result with the most heap bytes that were live at once during
/// it beyond those live before it; `None` when the counting allocator is not installed.
pub fn measure<T>(f: impl FnOnce() -> T) -> (T, Option<u64>) {
    let before = LIVE.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    let out = f();
    let peak = PEAK.load(Ordering::Relaxed);
    let grew = counting().then(|| peak.saturating_sub(before) as u64);
    (out, grew)
}
