//! Nothing to link: the benchmarks are this crate's tests (`tests/wasm_decode.rs`,
//! `tests/wasm_frame.rs`, `tests/wasm_skin.rs`), which exist on wasm32 only and are run by
//! `scripts/bench-import.sh` and `scripts/bench-wasm.sh`.
