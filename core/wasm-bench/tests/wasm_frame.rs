//! The per-frame benchmark of `benches/frame.rs` (`pose`, `single` and `crossfade_layer`), compiled to
//! wasm32 and run in Node, where a web page would run it. Not a test: it prints figures.
//!
//! ```text
//! scripts/bench-wasm.sh
//! ```
//! The samples are compiled in from `tests/assets` in the repository (wasm has no file
//! system). Natively this file is empty: `cargo bench --bench frame` measures the same work.
#![cfg(target_arch = "wasm32")]

#[path = "../../benches/frame_setup.rs"]
mod frame_setup;

use frame_setup::{Posed, clip, node};
use kloub_core::asset::Asset;
use kloub_core::{Animator, Instance, NoResolver};
use wasm_bindgen::prelude::wasm_bindgen;
use wasm_bindgen_test::{console_log, wasm_bindgen_test};

#[wasm_bindgen]
extern "C" {
    /// `performance.now()`: milliseconds with sub-millisecond resolution.
    #[wasm_bindgen(js_namespace = performance, js_name = now)]
    fn performance_now() -> f64;
}

type Character = (&'static str, &'static [u8], &'static str, &'static str, &'static str, &'static str);

/// (name, bytes, base clip, crossfade target, layer clip, layer root joint) — as in `benches/frame.rs`.
const CHARACTERS: [Character; 4] = [
    (
        "Fox",
        include_bytes!("../../../tests/assets/khronos/Fox/glTF-Binary/Fox.glb"),
        "Walk",
        "Run",
        "Survey",
        "b_Spine01_02",
    ),
    (
        "CesiumMan",
        include_bytes!("../../../tests/assets/khronos/CesiumMan/glTF-Binary/CesiumMan.glb"),
        "0",
        "0",
        "0",
        "Skeleton_torso_joint_2",
    ),
    (
        "RobotExpressive",
        include_bytes!("../../../tests/assets/threejs/RobotExpressive/RobotExpressive.glb"),
        "Walking",
        "Running",
        "Wave",
        "Abdomen",
    ),
    (
        "Knight",
        include_bytes!("../../../tests/assets/kaykit/Knight/Knight.glb"),
        "Walking_A",
        "Running_A",
        "Cheer",
        "chest",
    ),
];

/// Timed batches per figure; the median is reported.
const BATCHES: usize = 7;
/// Wall time each batch aims for, in milliseconds.
const BATCH_MS: f64 = 150.0;

/// Median microseconds per frame of `advance` + `evaluate` (into an instance: worlds and palettes).
fn measure(asset: &Asset, animator: &mut Animator, instance: &mut Instance) -> f64 {
    time(|| frame_setup::instance_frame(asset, animator, instance))
}

/// Median microseconds per call of `frame`.
fn time(mut frame: impl FnMut()) -> f64 {
    // Warm up and size a batch to about BATCH_MS.
    let mut n = 64u32;
    loop {
        let start = performance_now();
        for _ in 0..n {
            frame();
        }
        let ms = performance_now() - start;
        if ms > BATCH_MS / 4.0 {
            n = ((f64::from(n) * BATCH_MS / ms) as u32).max(1);
            break;
        }
        n *= 4;
    }
    let mut per_frame: Vec<f64> = (0..BATCHES)
        .map(|_| {
            let start = performance_now();
            for _ in 0..n {
                frame();
            }
            (performance_now() - start) * 1000.0 / f64::from(n)
        })
        .collect();
    per_frame.sort_by(f64::total_cmp);
    per_frame[BATCHES / 2]
}

#[wasm_bindgen_test]
fn frame_cost_per_character_in_node() {
    console_log!("| Character | `pose` (wasm, Node) | `single` (wasm, Node) | `crossfade_layer` (wasm, Node) |");
    console_log!("|---|---:|---:|---:|");
    for (name, bytes, base, target, over, root) in CHARACTERS {
        let asset = kloub_core::import(bytes, &NoResolver, &Default::default()).expect("imports").asset;
        let (base, target, over, root) =
            (clip(&asset, base), clip(&asset, target), clip(&asset, over), node(&asset, root));
        let mut instance = Instance::new(&asset);

        // `pose`: advance + sample + blend + world transforms (no palettes), as benches/frame.rs.
        let mut animator = Animator::new(&asset);
        animator.play(&asset, Some(base)).expect("valid");
        let mut buffers = Posed::new(&asset);
        let posed = time(|| buffers.frame(&asset, &mut animator));

        let mut animator = Animator::new(&asset);
        animator.play(&asset, Some(base)).expect("valid");
        let single = measure(&asset, &mut animator, &mut instance);

        let mut animator = frame_setup::crossfade_layer(&asset, base, target, over, root);
        let layered = measure(&asset, &mut animator, &mut instance);
        console_log!("| {name} | {posed:.2} µs | {single:.2} µs | {layered:.2} µs |");
    }
}
