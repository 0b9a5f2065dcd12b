#!/usr/bin/env bash
# Fuzzes the importer and the sidecar parser (core/fuzz: targets import, gltf_files, draco, meshopt, sidecar;
# cargo-fuzz on the nightly toolchain, both installed here if missing) for SECONDS per target (default 300),
# from seeds made of every model of tests/assets/ and tests/optimized/ (scripts/fuzz-seeds.mjs) and, when given,
# the glTF files under EXTRA_DIR (e.g. the glTF-Validator's test/ folder). Each target's corpus grows in
# target/fuzz-corpus/TARGET/ (not committed). A crash leaves its input in core/fuzz/artifacts/TARGET/ and fails
# the script; once fixed, it becomes a regression test beside the importer's (core/src/import/tests/).
#
#   bash scripts/fuzz.sh [SECONDS] [EXTRA_DIR]
#   KLOUB_FUZZ_TARGETS="draco meshopt" bash scripts/fuzz.sh 60   # some targets only
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-300}
extra=${2:-}
targets=${KLOUB_FUZZ_TARGETS:-import gltf_files draco meshopt sidecar}
rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
cargo +nightly fuzz --version >/dev/null 2>&1 || cargo install cargo-fuzz --locked
seeds=target/fuzz-seeds
rm -rf "$seeds"
node scripts/fuzz-seeds.mjs "$seeds" $extra
for target in $targets; do
  corpus=target/fuzz-corpus/$target
  mkdir -p "$corpus"
  cp -n "$seeds/$target"/* "$corpus/" 2>/dev/null || true
  echo "fuzz: $target for ${seconds}s from $(ls "$corpus" | wc -l) inputs"
  # -rss_limit_mb: what the import budget (256 MiB) and its bookkeeping may use; above it is a bug.
  set +e
  out=$(cd core && cargo +nightly fuzz run "$target" "../$corpus" -- -max_total_time="$seconds" -rss_limit_mb=1536 \
    -max_len=4194304 -timeout=20 2>&1)
  rc=$?
  set -e
  grep -E '^(Done|==[0-9]+==|SUMMARY|Test unit written|thread .* panicked)' <<<"$out" || true
  if [ "$rc" != 0 ] || compgen -G "core/fuzz/artifacts/$target/*" >/dev/null; then
    tail -40 <<<"$out" >&2
    echo "fuzz: $target FAILED (exit $rc; inputs in core/fuzz/artifacts/$target/)" >&2
    exit 1
  fi
  echo "fuzz: $target ok ($(grep -oE '^Done [0-9]+ runs' <<<"$out" | grep -oE '[0-9]+') runs)"
done
echo "fuzz: no crashes"
