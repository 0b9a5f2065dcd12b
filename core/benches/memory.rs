//! Memory of the animation core: peak heap while importing each sample, what the imported
//! asset keeps, and what one more animated instance of a loaded character costs.
//!
//! ```text
//! cargo bench -p kloub-core --bench memory
//! ```
//! Prints a Markdown table. Counts heap bytes through a counting global allocator (the file's
//! own bytes, read before the import, are listed separately and not included in the peak).

use kloub_core::animator::{Crossfade, Layer, Outgoing};
use kloub_core::{Animator, Instance, NoResolver};
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

struct Counting;

// SAFETY: forwards every call unchanged to the system allocator; only counts bytes.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let now = CURRENT.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
        PEAK.fetch_max(now, Ordering::Relaxed);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size >= layout.size() {
            let now = CURRENT.fetch_add(new_size - layout.size(), Ordering::Relaxed) + new_size - layout.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        } else {
            CURRENT.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
        }
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn current() -> usize {
    CURRENT.load(Ordering::Relaxed)
}

/// Restarts peak tracking from the current level; returns that level.
fn reset_peak() -> usize {
    let now = current();
    PEAK.store(now, Ordering::Relaxed);
    now
}

fn kib(bytes: usize) -> String {
    format!("{:.1} KiB", bytes as f64 / 1024.0)
}

fn main() {
    // `cargo bench` passes `--bench`; this binary takes no options.
    let root = std::env::var_os("KLOUB_SHARED_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/assets"));
    println!(
        "| Sample | File | Peak during import | Asset kept | + Instance | + Animator (1 clip) | + Animator (crossfade + layer) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for (name, file, root_joint) in [
        ("Fox", "khronos/Fox/glTF-Binary/Fox.glb", "b_Spine01_02"),
        ("CesiumMan", "khronos/CesiumMan/glTF-Binary/CesiumMan.glb", "Skeleton_torso_joint_2"),
        ("RobotExpressive", "threejs/RobotExpressive/RobotExpressive.glb", "Abdomen"),
        ("Knight", "kaykit/Knight/Knight.glb", "chest"),
    ] {
        let bytes = std::fs::read(root.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        let before = reset_peak();
        let asset = kloub_core::import(&bytes, &NoResolver, &Default::default())
            .unwrap_or_else(|e| panic!("{file}: {e}"))
            .asset;
        let peak = PEAK.load(Ordering::Relaxed) - before;
        let kept = current() - before;

        let base = current();
        let instance = Instance::new(&asset);
        let instance_bytes = current() - base;

        let base = current();
        let mut single = Animator::new(&asset);
        single.play(&asset, Some(0)).expect("valid");
        let single_bytes = current() - base;

        let base = current();
        let mut blended = Animator::new(&asset);
        blended.play(&asset, Some(0)).expect("valid");
        let root_node = asset.nodes.iter().position(|n| n.name.as_deref() == Some(root_joint)).expect("root joint");
        blended.add_layer(&asset, Layer::new(asset.clips.len() - 1, root_node as u32)).expect("valid");
        let fade = Crossfade { outgoing: Outgoing::KeepPlaying, ..Crossfade::default() };
        blended.crossfade_to(&asset, Some(asset.clips.len() / 2), fade).expect("valid");
        let blended_bytes = current() - base;

        println!(
            "| {name} | {} | {} | {} | {} | {} | {} |",
            kib(bytes.len()),
            kib(peak),
            kib(kept),
            kib(instance_bytes),
            kib(single_bytes),
            kib(blended_bytes)
        );
        drop((instance, single, blended, asset));
    }
}
