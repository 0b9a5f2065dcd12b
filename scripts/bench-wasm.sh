#!/usr/bin/env bash
# The per-frame animation benchmark compiled to wasm32 with the web build's profile (wasm-release: what ships) and run in Node through
# wasm-bindgen-test-runner: core/wasm-bench/tests/wasm_frame.rs (µs per character per frame) and
# core/wasm-bench/tests/wasm_skin.rs (CPU skinning vertices/s per method). Prints Markdown tables.
# Needs tests/assets (compiled in) and the runner from scripts/setup.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS="${CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS:--C target-feature=+simd128}" \
  CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER="${CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER:-wasm-bindgen-test-runner}" \
  cargo test --profile wasm-release -p kloub-wasm-bench --target wasm32-unknown-unknown --test wasm_frame --test wasm_skin -- --nocapture
