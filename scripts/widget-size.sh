#!/usr/bin/env bash
# First-load size of the <kloub-viewer> widget: what a page embedding it without `controls` downloads before its
# model (the element module and the light build's wasm-bindgen glue and the first half of its wasm: the second half,
# what no first frame runs, comes after the first frame; hash-state.js and accessibility.js
# are imported only when a viewer moves to another build or has `controls`), raw / gzip -9 /
# brotli as `kloub serve` sends them; then what a browser without WebGPU downloads instead of the light wasm, and
# what a Draco file or a zip adds (the decoders, web/codecs), what the full app (panels, ragdoll: loaded for `controls`)
# adds. Then what each crate contributes to each wasm
# (needs `cargo install twiggy`). Run after scripts/build-web.sh. Exits non-zero when either widget (WebGPU, or
# WebGL2) is over its budget (KLOUB_WIDGET_BUDGET bytes gzip, default 900 KB = 921,600).
set -euo pipefail
cd "$(dirname "$0")/.."
DIST=web/dist
BUDGET=${KLOUB_WIDGET_BUDGET:-921600}
table() { # title, files...
  local title=$1; shift
  printf '\n%s\n%-26s %10s %10s %10s\n' "$title" file raw gzip brotli
  total=(0 0 0)
  for f in "$@"; do
    raw=$(stat -c %s "$DIST/$f"); gz=$(stat -c %s "$DIST/$f.gz"); br=$(stat -c %s "$DIST/$f.br")
    printf '%-26s %10d %10d %10d\n' "$f" "$raw" "$gz" "$br"
    total=($((total[0] + raw)) $((total[1] + gz)) $((total[2] + br)))
  done
  printf '%-26s %10d %10d %10d\n' total "${total[@]}"
}
ELEMENT=(kloub-viewer.js)
table "widget (WebGPU): before the model" "${ELEMENT[@]}" kloub_widget.js kloub_widget_bg.wasm
widget=${total[1]}
table "widget without WebGPU (WebGL2): before the model" "${ELEMENT[@]}" kloub_widget_gl.js kloub_widget_gl_bg.wasm
widget_gl=${total[1]}
# The light widgets' second halves (scripts/wasm-split.mjs): what no first frame runs, fetched after the first frame.
[ ! -f "$DIST/kloub_widget_rest_bg.wasm" ] || table "widget's second half: after the first frame" kloub_widget_rest_bg.wasm
[ ! -f "$DIST/kloub_widget_gl_rest_bg.wasm" ] || table "widget with WebGL2, second half: after the first frame" kloub_widget_gl_rest_bg.wasm
table "decoders (a Draco file or a zip in a widget): loaded on demand" kloub_codecs.js kloub_codecs_bg.wasm
table "full app (controls, or a method that needs it): loaded on demand" kloub_web.js kloub_web_bg.wasm hash-state.js accessibility.js
printf '\nwidget: %d B gzip of a budget of %d B (%s)\n' "$widget" "$BUDGET" "$([ "$widget" -le "$BUDGET" ] && [ "$widget_gl" -le "$BUDGET" ] && echo within || echo OVER)"
printf 'widget with WebGL2: %d B gzip of a budget of %d B (%s)\n' "$widget_gl" "$BUDGET" "$([ "$widget_gl" -le "$BUDGET" ] && echo within || echo OVER)"
if command -v twiggy > /dev/null; then
  for name in kloub_widget kloub_widget_gl kloub_web; do
    if [ -f "target/wasm-bindgen/${name}_bg.wasm" ]; then
      printf '\n%s\n' "$name"
      python3 scripts/wasm-size.py "target/wasm-bindgen/${name}_bg.wasm" | head -24
    fi
  done
fi
[ "$widget" -le "$BUDGET" ] && [ "$widget_gl" -le "$BUDGET" ]
