#!/usr/bin/env bash
# The README's test command: the whole suite.
#   1. lints (clippy, deny unwrap outside tests)  2. Rust tests, native (unit, contracts, golden images on lavapipe,
#   shader validation), then the core's import suite on wasm32 under Node (scripts/test-wasm.sh), then each fuzz
#   target for a few seconds (scripts/fuzz.sh)  3. web bundle build  4. browser tests on WebGPU and WebGL2 against the
#   real `kloub serve`.
# Ends with one line "tests: N passed, M failed" and exits non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
export CARGO_TERM_COLOR=never

bash scripts/setup.sh

step() { printf '\n== %s\n' "$*"; }
# Sums a log's libtest "test result:" lines (cargo test, wasm-bindgen-test-runner): prints "passed failed".
results() { awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } } END { print p + 0, f + 0 }' "$1"; }
log=$(mktemp)
trap 'rm -f "$log"' EXIT

step "clippy"
cargo clippy --workspace --all-targets --quiet -- -D warnings
# The light widget builds (web/Cargo.toml's features) as the page gets them: wasm32, on WebGPU and on WebGL2.
for features in "--features webgpu" "--features gl"; do
  # shellcheck disable=SC2086
  CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS="-C target-feature=+simd128" \
    cargo clippy --target wasm32-unknown-unknown -p kloub-web --lib --no-default-features $features --quiet -- -D warnings
done

step "cargo test (native)"
set +e
cargo test --workspace 2>&1 | tee "$log"
cargo_rc=${PIPESTATUS[0]}
set -e
read -r rust_pass rust_fail < <(results "$log")
if [ "$cargo_rc" != 0 ] && [ "$rust_fail" = 0 ]; then rust_fail=1; fi  # a build failure counts as a failure

step "cargo test (wasm32 under Node: the core's import suite, the meshopt decoder)"
set +e
bash scripts/test-wasm.sh 2>&1 | tee "$log"
wasm_rc=${PIPESTATUS[0]}
set -e
read -r wasm_pass wasm_fail < <(results "$log")
if [ "$wasm_rc" != 0 ] && [ "$wasm_fail" = 0 ]; then wasm_fail=1; fi
rust_pass=$((rust_pass + wasm_pass)) rust_fail=$((rust_fail + wasm_fail))  # counted with the native Rust tests

step "fuzz smoke (each target of core/fuzz for ${KLOUB_FUZZ_SECONDS:=10} s)"
set +e
bash scripts/fuzz.sh "$KLOUB_FUZZ_SECONDS" 2>&1 | tee "$log"
fuzz_rc=${PIPESTATUS[0]}
set -e
fuzz_pass=$(grep -cE '^fuzz: [a-z_]+ ok' "$log" || true)
fuzz_fail=$(grep -cE '^fuzz: [a-z_]+ FAILED' "$log" || true)
if [ "$fuzz_rc" != 0 ] && [ "$fuzz_fail" = 0 ]; then fuzz_fail=1; fi
rust_pass=$((rust_pass + fuzz_pass)) rust_fail=$((rust_fail + fuzz_fail))

step "web bundle"
bash scripts/build-web.sh
cargo build --quiet -p kloub-server

step "browser tests"
set +e
node tests/browser/run.mjs 2>&1 | tee "$log"
browser_rc=${PIPESTATUS[0]}
set -e
read -r web_pass web_fail < <(awk '/^browser: [0-9]+ passed, [0-9]+ failed/ { p = $2; f = $4 } END { print p + 0, f + 0 }' "$log")
if [ "$browser_rc" != 0 ] && [ "$web_fail" = 0 ]; then web_fail=1; fi

printf '\nrust: %s passed, %s failed; browser: %s passed, %s failed\n' "$rust_pass" "$rust_fail" "$web_pass" "$web_fail"
printf 'tests: %s passed, %s failed\n' "$((rust_pass + web_pass))" "$((rust_fail + web_fail))"
[ "$((rust_fail + web_fail))" = 0 ]
