#!/usr/bin/env bash
# First-load size of the <kloub-viewer> widget (what a page embedding it downloads before the model): the element
# module, the wasm-bindgen glue and the wasm, raw / gzip -9 / brotli as `kloub serve` sends them; then what each
# crate contributes to the wasm (needs `cargo install twiggy`). Run after scripts/build-web.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
DIST=web/dist
printf '%-22s %10s %10s %10s\n' file raw gzip brotli
total=(0 0 0)
for f in kloub-viewer.js accessibility.js kloub_web.js kloub_web_bg.wasm; do
  raw=$(stat -c %s "$DIST/$f"); gz=$(stat -c %s "$DIST/$f.gz"); br=$(stat -c %s "$DIST/$f.br")
  printf '%-22s %10d %10d %10d\n' "$f" "$raw" "$gz" "$br"
  total=($((total[0] + raw)) $((total[1] + gz)) $((total[2] + br)))
done
printf '%-22s %10d %10d %10d\n' total "${total[@]}"
if command -v twiggy > /dev/null; then
  echo
  python3 scripts/wasm-size.py target/wasm-bindgen/kloub_web_bg.wasm | head -32
fi
