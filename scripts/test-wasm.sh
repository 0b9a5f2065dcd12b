#!/usr/bin/env bash
# The core's unit tests on wasm32-unknown-unknown under Node: the import suite's hand-made
# broken documents (the tests reading tests/assets from disk are native-only), and kloub-meshopt's
# (its data-parallel steps on wasm's simd128 against the scalar ones), through
# wasm-bindgen-test-runner from wasm-bindgen-cli 0.2.130 (scripts/setup.sh installs it).
# Prints the runner's libtest-style "test result:" line, which scripts/test.sh counts.
# Extra arguments go to cargo test, e.g. a test-name filter after `--`.
set -euo pipefail
cd "$(dirname "$0")/.."

WBG_VERSION=0.2.130  # = the wasm-bindgen pin in Cargo.toml; wasm-bindgen-test in core/ and core/meshopt/Cargo.toml matches it
runner="${CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER:-wasm-bindgen-test-runner}"
if [ "$("$runner" --version 2>/dev/null | awk '{print $2}')" != "$WBG_VERSION" ]; then
  echo "test-wasm: $runner $WBG_VERSION is required (bash scripts/setup.sh installs it)" >&2
  exit 1
fi
CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS="${CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS:--C target-feature=+simd128}" \
  CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER="$runner" \
  cargo test -p kloub-core -p kloub-meshopt --target wasm32-unknown-unknown --lib "$@"
