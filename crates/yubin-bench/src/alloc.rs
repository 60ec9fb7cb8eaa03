//! A counting global allocator, for the memory figures of `rays`.
//!
//! Counting is off by default (one relaxed load per allocation) and is
//! switched on only around acceleration-structure builds, so tracing runs
//! with the plain system allocator's cost. While on, it tracks the live
//! byte count and its high-water mark across all threads, heap and
//! yubin's huge-page mappings together.
#![allow(unsafe_code)] // implementing `GlobalAlloc` is unsafe by definition

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicIsize, Ordering};

static ON: AtomicBool = AtomicBool::new(false);
static LIVE: AtomicIsize = AtomicIsize::new(0);
static PEAK: AtomicIsize = AtomicIsize::new(0);

/// The system allocator, counting while [`Counter`] is alive.
#[derive(Debug)]
pub struct CountingAlloc;

#[inline]
fn count(delta: isize) {
    if ON.load(Ordering::Relaxed) {
        let now = LIVE.fetch_add(delta, Ordering::Relaxed) + delta;
        if delta > 0 {
            PEAK.fetch_max(now + mapped(), Ordering::Relaxed);
        }
    }
}

/// The BVH's huge-page arrays, which are mapped rather than allocated:
/// counted with the heap, sampled at every allocation (they are made
/// between allocations and kept, so the samples see them).
fn mapped() -> isize {
    yubin_core::accel::huge_array_bytes() as isize
}

/// Heap and mapped bytes now.
fn live() -> isize {
    LIVE.load(Ordering::SeqCst) + mapped()
}

// SAFETY: every call forwards to `System` with the caller's arguments, so
// `System`'s guarantees carry over; counting only touches atomics.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded contract.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded contract.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded contract.
        unsafe { System.dealloc(ptr, layout) };
        count(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded contract.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            count(new_size as isize - layout.size() as isize);
        }
        p
    }
}

/// Counts allocations from its creation until it is dropped. Memory freed
/// during the window that was allocated before it shows as negative.
#[derive(Debug)]
pub struct Counter {
    start: isize,
}

impl Counter {
    /// Starts counting (one counter at a time).
    pub fn start() -> Self {
        let start = live();
        PEAK.store(start, Ordering::SeqCst);
        ON.store(true, Ordering::SeqCst);
        Self { start }
    }

    /// Net bytes allocated since the start (retained).
    pub fn retained(&self) -> isize {
        live() - self.start
    }

    /// Highest net byte count since the start.
    pub fn peak(&self) -> isize {
        PEAK.load(Ordering::SeqCst).max(live()) - self.start
    }
}

impl Drop for Counter {
    fn drop(&mut self) {
        ON.store(false, Ordering::SeqCst);
    }
}
