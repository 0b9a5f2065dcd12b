//! The CPU skinning benchmark of `benches/skin.rs` compiled to wasm32 (SIMD128) and run in
//! Node: vertices per second for every method and for the `stream` bandwidth kernel, on the
//! same workload (`benches/skin_workload.rs`). Not a test: it prints figures.
//!
//! ```text
//! scripts/bench-wasm.sh
//! ```
#![cfg(target_arch = "wasm32")]

use kloub_core::NoResolver;
use kloub_core::job::dqs::SkinningMethod;
use wasm_bindgen::prelude::wasm_bindgen;
use wasm_bindgen_test::{console_log, wasm_bindgen_test};

#[path = "../../benches/skin_workload.rs"]
#[allow(dead_code)]
mod skin_workload;
use skin_workload::{BYTES_PER_VERTEX, VERTICES, Workload};

#[wasm_bindgen]
extern "C" {
    /// `performance.now()`: milliseconds with sub-millisecond resolution.
    #[wasm_bindgen(js_namespace = performance, js_name = now)]
    fn performance_now() -> f64;
}

/// Timed runs per figure; the median is reported.
const RUNS: usize = 9;

fn median_ms(mut run: impl FnMut()) -> f64 {
    run();
    let mut times: Vec<f64> = (0..RUNS)
        .map(|_| {
            let start = performance_now();
            run();
            performance_now() - start
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[RUNS / 2]
}

#[wasm_bindgen_test]
fn skinning_vertices_per_second_in_node() {
    let bytes = include_bytes!("../../../tests/assets/khronos/CesiumMan/glTF-Binary/CesiumMan.glb");
    let asset = kloub_core::import(bytes, &NoResolver, &Default::default()).expect("imports").asset;
    let mut work = Workload::new(&asset);
    let rate = |ms: f64| VERTICES as f64 / (ms / 1000.0) / 1e6;
    let stream = rate(median_ms(|| work.stream()));
    console_log!("| Kernel (wasm, Node) | M vertices/s | of `stream` |");
    console_log!("|---|---:|---:|");
    console_log!("| stream ({:.1} GB/s) | {stream:.1} | 100% |", stream * 1e6 * BYTES_PER_VERTEX as f64 / 1e9);
    for method in SkinningMethod::ALL {
        let r = rate(median_ms(|| work.skin(method)));
        console_log!("| {} | {r:.1} | {:.0}% |", method.name(), 100.0 * r / stream);
    }
}
