//! The decoding and import benchmark of `benches/import.rs` compiled to wasm32 and run in Node,
//! where a web page decodes. Not a test: it prints figures (`scripts/bench-import.sh`). Natively
//! this file is empty.
#![cfg(target_arch = "wasm32")]

#[path = "../../benches/import_cases.rs"]
mod import_cases;

use wasm_bindgen::prelude::wasm_bindgen;
use wasm_bindgen_test::{console_log, wasm_bindgen_test};

#[wasm_bindgen]
extern "C" {
    /// `performance.now()`: milliseconds with sub-millisecond resolution.
    #[wasm_bindgen(js_namespace = performance, js_name = now)]
    fn performance_now() -> f64;
}

#[wasm_bindgen_test]
fn decode_and_import_speed() {
    let decode_cases = import_cases::decode_cases();
    import_cases::warm_up(&decode_cases, 200.0, &performance_now);
    for case in decode_cases {
        let rate = |ms: f64| case.decoded as f64 / (ms / 1000.0) / 1e6;
        let streams = import_cases::measure_streams(&case, &performance_now);
        let imported = import_cases::measure(&case, &performance_now);
        console_log!("decode wasm {} {} {} B: {:.1} MB/s", case.codec, case.name, case.decoded, rate(streams));
        console_log!("imported wasm {} {} {} B: {:.1} MB/s", case.codec, case.name, case.decoded, rate(imported));
    }
    let imports = import_cases::import_cases();
    import_cases::warm_up(&imports, 200.0, &performance_now);
    for case in imports {
        let ms = import_cases::measure(&case, &performance_now);
        console_log!("import wasm {} {} {} B: {ms:.3} ms", case.codec, case.name, case.glb.len());
    }
}

/// Each meshopt view on its own (`KLOUB_BENCH_VIEWS=1 bash scripts/bench-import.sh`, which
/// names each of this file's two benchmarks when it runs them).
#[wasm_bindgen_test]
fn decode_speed_per_view() {
    let cases: Vec<_> = import_cases::decode_cases().into_iter().filter(|c| c.codec == "meshopt").collect();
    import_cases::warm_up(&cases, 200.0, &performance_now);
    for case in &cases {
        for (view, ms) in import_cases::measure_views(case, &performance_now) {
            console_log!("view wasm {} {view}: {:.2} us", case.name, ms * 1000.0);
        }
    }
}
