//! Test helpers shared by the unit tests: sample assets and a per-thread allocation counter
//! (the global allocator of the core's test binary).

use crate::asset::Asset;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::PathBuf;

/// `tests/assets` in the repository, or `$KLOUB_SHARED_ASSETS`.
pub fn shared_assets() -> PathBuf {
    std::env::var_os("KLOUB_SHARED_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets"))
}

/// Imports a shared sample (path relative to [`shared_assets`]) without external files.
pub fn load(file: &str) -> Asset {
    let bytes = std::fs::read(shared_assets().join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
    crate::import(&bytes, &crate::NoResolver, &Default::default()).unwrap_or_else(|e| panic!("{file}: {e}")).asset
}

/// A deterministic uniform generator in [0, 1] (xorshift32 from `seed`, which must not be 0).
pub fn xorshift(mut seed: u32) -> impl FnMut() -> f32 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        seed as f32 / u32::MAX as f32
    }
}

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

struct Counting;

// SAFETY: forwards every call unchanged to the system allocator; only counts.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by this thread so far.
pub fn allocations() -> u64 {
    ALLOCATIONS.with(Cell::get)
}

#[test]
fn the_counter_counts() {
    let before = allocations();
    std::hint::black_box(vec![0u8; 16]);
    assert!(allocations() > before);
}
