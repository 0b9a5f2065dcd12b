#!/usr/bin/env bash
# Fuzzes the importer (core/fuzz, cargo-fuzz on the nightly toolchain, both installed here if missing) for
# SECONDS (default 300), starting from every model of tests/assets/ and tests/optimized/ (meshopt-compressed
# views included) and, when given, the glTF files under EXTRA_DIR (e.g. the glTF-Validator's test/ folder).
# A crash leaves its input in core/fuzz/artifacts/import/ and fails the script; the corpus grows in
# target/fuzz-corpus/ (not committed).
#
#   bash scripts/fuzz.sh [SECONDS] [EXTRA_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-300}
extra=${2:-}
rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
cargo +nightly fuzz --version >/dev/null 2>&1 || cargo install cargo-fuzz --locked
corpus=target/fuzz-corpus/import
mkdir -p "$corpus"
for dir in tests/assets tests/optimized $extra; do
  find "$dir" -type f \( -name '*.glb' -o -name '*.gltf' \) -size -4M -exec cp -n {} "$corpus/" \; 2>/dev/null || true
done
cd core
# -rss_limit_mb: what the import budget (256 MiB) and its bookkeeping may use; above it is a bug.
cargo +nightly fuzz run import "../$corpus" -- -max_total_time="$seconds" -rss_limit_mb=1536 -max_len=4194304 -timeout=20
