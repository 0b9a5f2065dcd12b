#!/usr/bin/env bash
# Decoding speed and import time, in one run (core/benches/import_cases.rs says what is measured):
# Kloub natively (cargo bench --bench import) and as wasm in Node (core/wasm-bench/tests/wasm_decode.rs through
# wasm-bindgen-test-runner, with the web build's profile (wasm-release: what ships) and simd128), the reference decoders from npm (draco3dgltf, meshoptimizer)
# and three.js r187's GLTFLoader.parse in Node (scripts/bench-import.mjs). Prints two Markdown tables.
# The three run one after the other KLOUB_BENCH_ROUNDS times (default 3) and each cell keeps its best round
# (the highest MB/s, the lowest ms), the same for every side: a shared machine's slow spells last seconds,
# longer than one side's run, and fall on one side or the other.
#
#   bash scripts/bench-import.sh
#   KLOUB_BENCH_ROUNDS=1 bash scripts/bench-import.sh   # quicker, noisier
#   KLOUB_BENCH_VIEWS=1 bash scripts/bench-import.sh    # also each meshopt view alone (µs per decode, best round)
set -euo pipefail
cd "$(dirname "$0")/.."
log=$(mktemp)
trap 'rm -f "$log"' EXIT
for _ in $(seq "${KLOUB_BENCH_ROUNDS:-3}"); do
  cargo bench -q -p kloub-core --bench import 2>/dev/null | grep -E '^(decode|imported|import) ' >>"$log"
  CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS="${CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS:--C target-feature=+simd128}" \
    CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER="${CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER:-wasm-bindgen-test-runner}" \
    cargo test --profile wasm-release -p kloub-wasm-bench --target wasm32-unknown-unknown --test wasm_decode -- decode_and_import_speed \
    --nocapture 2>/dev/null \
    | grep -oE '(decode|imported|import) wasm .*' >>"$log"
  node scripts/bench-import.mjs >>"$log"
  if [ -n "${KLOUB_BENCH_VIEWS:-}" ]; then
    CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS="${CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS:--C target-feature=+simd128}" \
      CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER="${CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER:-wasm-bindgen-test-runner}" \
      cargo test --profile wasm-release -p kloub-wasm-bench --target wasm32-unknown-unknown --test wasm_decode -- decode_speed_per_view \
      --nocapture 2>/dev/null | grep -oE 'view wasm .*' >>"$log"
  fi
done
if [ -n "${KLOUB_BENCH_VIEWS:-}" ]; then
  # "view SIDE FILE VIEW: VALUE us" → one row per view: Kloub wasm, the reference, and their ratio (best rounds).
  echo "Each meshopt view alone (µs per decode; view: index, mode, filter, count × stride):"
  echo
  echo "| file | view | Kloub wasm | reference | reference / Kloub wasm |"
  echo "|---|---|---:|---:|---:|"
  awk '$1 == "view" { key = $3 " " $4; x = $5 + 0
      if (!((key, $2) in v) || x < v[key, $2]) v[key, $2] = x
      if (!(key in seen)) { seen[key] = 1; order[++n] = key } }
    END { for (i = 1; i <= n; i++) { split(order[i], k, " "); sub(/:$/, "", k[2])
      printf "| %s | %s | %.2f | %.2f | %.2f× |\n", k[1], k[2], v[order[i], "wasm"], v[order[i], "reference"], v[order[i], "reference"] / v[order[i], "wasm"] } }' "$log"
  echo
fi
# "KIND SIDE CODEC FILE BYTES B: VALUE UNIT" → one row per file and kind.
awk '
  { kind = $1; side = $3 == "" ? "" : $2; file = $4; x = $(NF - 1) + 0; codec[file] = $3
    # The best round: MB/s the highest, ms the lowest.
    if (!((kind, side, file) in v) || ($NF == "MB/s" ? x > v[kind, side, file] : x < v[kind, side, file])) v[kind, side, file] = x
    if (side != "three" && side != "reference") bytes[kind, file] = $5
    if (!((kind, file) in seen)) { seen[kind, file] = 1; order[kind, ++n[kind]] = file } }
  # One table: a row per file of `kind`, its `anchor` side beside Kloub native and wasm, and the ratio that is
  # better above 1 (`faster` says whether that is Kloub wasm / anchor, as for MB/s, or anchor / Kloub wasm, as for ms).
  function table(kind, title, anchor, heading, faster, suffix,   i, f, ratio) {
    printf "%s\n\n| file | %s | %s | Kloub native | Kloub wasm (Node) | %s |%s\n|---|---|---:|---:|---:|---:|---:|%s\n", title, kind == "decode" ? "codec" : "variant", kind == "decode" ? "decoded" : "bytes", heading, kind == "decode" ? " Kloub wasm through the importer | its ratio |" : "", kind == "decode" ? "---:|---:|" : ""
    for (i = 1; i <= n[kind]; i++) {
      f = order[kind, i]
      ratio = faster ? v[kind, "wasm", f] / v[kind, anchor, f] : v[kind, anchor, f] / v[kind, "wasm", f]
      extra = kind == "decode" ? sprintf(" %s | %.2f× |", v["imported", "wasm", f], v["imported", "wasm", f] / v[kind, anchor, f]) : ""
      printf "| %s | %s | %s%s | %s | %s | %s | %.2f× |%s\n", f, codec[f], bytes[kind, f], suffix, v[kind, "native", f], v[kind, "wasm", f], v[kind, anchor, f], ratio, extra
    }
  }
  END {
    table("decode", "Decoding (MB/s of decoded data):", "reference", "reference (Node) | Kloub wasm / reference", 1, " B")
    print ""
    table("import", "Import without images (ms per file, to a ready asset / three.js scene):", "three", "three.js r187 (Node) | three.js / Kloub wasm", 0, "")
  }' "$log"
