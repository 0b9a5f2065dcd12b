#!/usr/bin/env bash
# Builds the web bundle into web/dist: release wasm32 → wasm-bindgen → wasm-opt, plus the page files.
# Incremental: cargo rebuilds only what changed, wasm-opt runs only when its input changed.
set -euo pipefail
cd "$(dirname "$0")/.."

PROFILE=wasm-release
DIST=web/dist
WASM_IN=target/wasm32-unknown-unknown/$PROFILE/kloub_web.wasm

cargo build --profile "$PROFILE" --target wasm32-unknown-unknown -p kloub-web --lib
mkdir -p "$DIST"
wasm-bindgen --target web --no-typescript --out-dir target/wasm-bindgen "$WASM_IN"

# wasm-opt is the slow step (~1.5 min cold): skip it when its input did not change.
sum=$(sha256sum target/wasm-bindgen/kloub_web_bg.wasm | cut -d' ' -f1)
if [ "$(cat "$DIST/.wasm-opt-input" 2>/dev/null || true)" != "$sum" ] || [ ! -f "$DIST/kloub_web_bg.wasm" ]; then
  if [ "${KLOUB_WASM_OPT:-1}" = 1 ]; then
    node_modules/.bin/wasm-opt -Oz --enable-bulk-memory --enable-nontrapping-float-to-int \
      --enable-sign-ext --enable-mutable-globals --enable-reference-types --enable-multivalue \
      target/wasm-bindgen/kloub_web_bg.wasm -o "$DIST/kloub_web_bg.wasm"
  else
    cp target/wasm-bindgen/kloub_web_bg.wasm "$DIST/kloub_web_bg.wasm"
  fi
  echo "$sum" > "$DIST/.wasm-opt-input"
fi
cp target/wasm-bindgen/kloub_web.js "$DIST/"
cp web/index.html web/boot.js "$DIST/"
[ -f web/style.css ] && cp web/style.css "$DIST/"
printf 'build-web: %s (%s bytes wasm)\n' "$DIST" "$(stat -c %s "$DIST/kloub_web_bg.wasm")" >&2
