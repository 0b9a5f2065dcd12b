#!/usr/bin/env bash
# Builds the web bundle into web/dist: release wasm32 → wasm-bindgen → wasm-opt, plus the page files,
# and precompressed .gz (gzip -9) and .br (brotli) siblings that `kloub serve` picks by Accept-Encoding.
# Incremental: cargo rebuilds only what changed, wasm-opt runs only when its input changed, files are
# copied only when their content changed, and a file is recompressed only when it is newer than its siblings.
# KLOUB_BROTLI_QUALITY (default 10) sets the brotli quality: 11 saves ~4% on the wasm for ~2x the time.
set -euo pipefail
cd "$(dirname "$0")/.."

PROFILE=wasm-release
DIST=web/dist

# WebAssembly SIMD (every browser with WebGPU or WebGL2 2021+ has it): glam's vector math uses it, ~1.3x faster
# per-frame animation in BENCHMARKS.md. Set only for the wasm target, so host build scripts are unaffected.
export CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS="${CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS:--C target-feature=+simd128}"
mkdir -p "$DIST"
# Three builds of kloub-web (see web/Cargo.toml's features), each bindgen'd under its own name:
#   kloub_web        the full app: panels, ragdoll, WebGPU and WebGL2 (the element loads it for `controls`)
#   kloub_widget     the light widget: the 3D view and the element's API, WebGPU only (the default)
#   kloub_widget_gl  the light widget on WebGL2 (browsers without WebGPU), through Kloub's own WebGL2 backend
#                    (web/src/gl: its shaders translated to GLSL at build time; no wgpu GL layer or naga in it)
# Cargo keeps each feature set's artifacts, so switching between them rebuilds only what changed.
# The scripts a page loads before its first frame (the element, each build's wasm-bindgen glue) go out minified by
# esbuild (npm dev dependency; ES module syntax kept, names of exports and properties untouched): −23 KB gzip of
# the widget's first download, and less to parse. The file is rewritten only when its content changed.
minify() { # source, destination
  node_modules/.bin/esbuild "$1" --minify --format=esm --log-level=warning --legal-comments=inline > "$2.new"
  if cmp -s "$2.new" "$2"; then rm "$2.new"; else mv "$2.new" "$2"; fi
}
# wasm-opt's flags after -Oz, the same for every module (scripts/wasm-opt.flags says why each).
mapfile -t WASM_OPT_FLAGS < <(grep -v '^#' scripts/wasm-opt.flags | grep .)
build_one() { # name, cargo feature flags... (KLOUB_PACKAGE: the crate, default kloub-web)
  local name=$1; shift
  local package=${KLOUB_PACKAGE:-kloub-web}
  cargo build --profile "$PROFILE" --target wasm32-unknown-unknown -p "$package" --lib "$@"
  wasm-bindgen --target web --no-typescript --out-name "$name" --out-dir target/wasm-bindgen \
    "target/wasm32-unknown-unknown/$PROFILE/${package//-/_}.wasm"
  # wasm-opt is the slow step (~1.5 min cold for the full app): skip it when its input did not change.
  # The mode is part of the key: a quick KLOUB_WASM_OPT=0 build must not pass for an optimised one.
  # KLOUB_SPLIT (webgpu or webgl2): the light widgets are split in two by scripts/wasm-split.mjs (what their first
  # frames run, and the rest, fetched after), profiled on that backend; the split replaces wasm-opt's single run.
  local split=${KLOUB_SPLIT:-}
  [ "${KLOUB_WASM_OPT:-1}" = 1 ] || split=
  local sum stamp="$DIST/.wasm-opt-input-$name"
  sum="$(sha256sum "target/wasm-bindgen/${name}_bg.wasm" | cut -d' ' -f1) opt=${KLOUB_WASM_OPT:-1} ${WASM_OPT_FLAGS[*]}"
  # The split also depends on the glue it patches, the element and profile pages that run, and binaryen's version.
  [ -z "$split" ] || sum="$sum split=$split names=${KLOUB_SPLIT_NAMES:-0} $(cat scripts/wasm-split.mjs web/kloub-viewer.js \
    "target/wasm-bindgen/$name.js" | sha256sum | cut -d' ' -f1) $(wasm-split --version 2>/dev/null | head -1 || true)"
  local glue="target/wasm-bindgen/$name.js"
  [ -z "$split" ] || glue="target/wasm-bindgen/$name.split.js"
  if [ "$(cat "$stamp" 2>/dev/null || true)" != "$sum" ] || [ ! -f "$DIST/${name}_bg.wasm" ] || [ ! -f "$glue" ] \
    || { [ -n "$split" ] && [ ! -f "$DIST/${name}_rest_bg.wasm" ]; }; then
    rm -f "$DIST/${name}_rest_bg.wasm" "$DIST/${name}_rest_bg.wasm".*
    if [ -n "$split" ]; then
      node scripts/wasm-split.mjs "$name" "$split" "target/wasm-bindgen/${name}_bg.wasm" \
        "target/wasm-bindgen/$name.js" "$DIST" "$glue"
    elif [ "${KLOUB_WASM_OPT:-1}" = 1 ]; then
      node_modules/.bin/wasm-opt -Oz "${WASM_OPT_FLAGS[@]}" "target/wasm-bindgen/${name}_bg.wasm" -o "$DIST/${name}_bg.wasm"
    else
      cp "target/wasm-bindgen/${name}_bg.wasm" "$DIST/${name}_bg.wasm"
    fi
    echo "$sum" > "$stamp"
  fi
  minify "$glue" "$DIST/$name.js"
}
build_one kloub_web
KLOUB_SPLIT=webgpu build_one kloub_widget --no-default-features --features webgpu
KLOUB_SPLIT=webgl2 build_one kloub_widget_gl --no-default-features --features gl
#   kloub_codecs     the Draco decoder and the zip reader (web/codecs), fetched by the widgets when a file needs them
KLOUB_PACKAGE=kloub-codecs build_one kloub_codecs
rm -f "$DIST/.wasm-opt-input"
# Copy only on change: unchanged files keep their mtime, so neither the compression below nor the
# server's embedding (server/build.rs) redo their work.
install_if_changed() { cmp -s "$1" "$2/$(basename "$1")" || cp "$1" "$2/"; }
# The element (the npm package's entry), its types, the app page built on it, and the embedding example.
minify web/kloub-viewer.js "$DIST/kloub-viewer.js"
for f in kloub-viewer.d.ts hash-state.js accessibility.js validator-worker.js index.html app.js style.css embed.html embed.js; do
  install_if_changed "web/$f" "$DIST"
done
# The Khronos glTF-Validator (npm gltf-validator, Apache-2.0), fetched by validate() on its first call only.
validator=node_modules/gltf-validator
cmp -s "$validator/gltf_validator.dart.js" "$DIST/gltf-validator.js" || cp "$validator/gltf_validator.dart.js" "$DIST/gltf-validator.js"
cmp -s "$validator/LICENSE" "$DIST/gltf-validator.LICENSE.txt" || cp "$validator/LICENSE" "$DIST/gltf-validator.LICENSE.txt"
cmp -s "$validator/NOTICES" "$DIST/gltf-validator.NOTICES.txt" || cp "$validator/NOTICES" "$DIST/gltf-validator.NOTICES.txt"
# The environment photographs (web/environments, CC0), fetched beside the module when a viewer first lights with one.
mkdir -p "$DIST/environments"
for f in web/environments/studio.hdr web/environments/outdoor.hdr web/environments/LICENSE.md; do
  install_if_changed "$f" "$DIST/environments"
done
rm -f "$DIST/boot.js" "$DIST"/boot.js.*
# web/dist is an npm-ready package: `npm pack web/dist` (or `npm run pack`) gives kloub-viewer-<version>.tgz.
version=$(node -p "require('./package.json').version")
cat > "$DIST/package.json.new" <<JSON
{
  "name": "kloub-viewer",
  "version": "$version",
  "description": "<kloub-viewer>: a glTF character animation viewer element (Rust + WebAssembly, WebGPU or WebGL2).",
  "license": "MIT OR Apache-2.0",
  "type": "module",
  "main": "./kloub-viewer.js",
  "module": "./kloub-viewer.js",
  "types": "./kloub-viewer.d.ts",
  "exports": { ".": { "types": "./kloub-viewer.d.ts", "default": "./kloub-viewer.js" }, "./kloub_web_bg.wasm": "./kloub_web_bg.wasm", "./kloub_widget_bg.wasm": "./kloub_widget_bg.wasm", "./kloub_widget_rest_bg.wasm": "./kloub_widget_rest_bg.wasm", "./kloub_widget_gl_bg.wasm": "./kloub_widget_gl_bg.wasm", "./kloub_widget_gl_rest_bg.wasm": "./kloub_widget_gl_rest_bg.wasm", "./kloub_codecs_bg.wasm": "./kloub_codecs_bg.wasm" },
  "files": ["kloub-viewer.js", "kloub-viewer.d.ts", "hash-state.js", "accessibility.js", "validator-worker.js", "gltf-validator.js", "gltf-validator.LICENSE.txt", "gltf-validator.NOTICES.txt", "kloub_web.js", "kloub_web_bg.wasm", "kloub_widget.js", "kloub_widget_bg.wasm", "kloub_widget_rest_bg.wasm", "kloub_widget_gl.js", "kloub_widget_gl_bg.wasm", "kloub_widget_gl_rest_bg.wasm", "kloub_codecs.js", "kloub_codecs_bg.wasm", "environments/studio.hdr", "environments/outdoor.hdr", "environments/LICENSE.md"],
  "sideEffects": ["./kloub-viewer.js"]
}
JSON
cmp -s "$DIST/package.json.new" "$DIST/package.json" && rm "$DIST/package.json.new" || mv "$DIST/package.json.new" "$DIST/package.json"

# Precompress with node's zlib (no extra tool). Brotli quality 10 takes ~11 s for the ~7 MB wasm on 2 cores.
node --input-type=module - "$DIST" "${KLOUB_BROTLI_QUALITY:-10}" <<'EOF'
import { existsSync, readFileSync, statSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import zlib from 'node:zlib';
const [dist, quality] = process.argv.slice(2);
const C = zlib.constants;
for (const name of ['index.html', 'app.js', 'hash-state.js', 'accessibility.js', 'validator-worker.js', 'gltf-validator.js', 'kloub-viewer.js', 'embed.html', 'embed.js', 'style.css', 'kloub_web.js', 'kloub_web_bg.wasm', 'kloub_widget.js', 'kloub_widget_bg.wasm', 'kloub_widget_rest_bg.wasm', 'kloub_widget_gl.js', 'kloub_widget_gl_bg.wasm', 'kloub_widget_gl_rest_bg.wasm', 'kloub_codecs.js', 'kloub_codecs_bg.wasm', 'environments/studio.hdr', 'environments/outdoor.hdr']) {
  const file = join(dist, name);
  if (!existsSync(file)) continue;
  const mtime = statSync(file).mtimeMs;
  const fresh = (ext) => existsSync(`${file}.${ext}`) && statSync(`${file}.${ext}`).mtimeMs >= mtime;
  if (fresh('gz') && fresh('br')) continue;
  const data = readFileSync(file);
  const started = Date.now();
  const gz = zlib.gzipSync(data, { level: 9 });
  const br = zlib.brotliCompressSync(data, {
    params: {
      [C.BROTLI_PARAM_QUALITY]: Number(quality),
      [C.BROTLI_PARAM_LGWIN]: 24,
      [C.BROTLI_PARAM_SIZE_HINT]: data.length,
      [C.BROTLI_PARAM_MODE]: name.endsWith('.wasm') ? C.BROTLI_MODE_GENERIC : C.BROTLI_MODE_TEXT,
    },
  });
  writeFileSync(`${file}.gz`, gz);
  writeFileSync(`${file}.br`, br);
  console.error(`build-web: ${name}: ${data.length} B, gzip ${gz.length} B, brotli ${br.length} B (${Date.now() - started} ms)`);
}
EOF
printf 'build-web: %s (wasm: full %s, widget %s, widget with WebGL2 %s, codecs %s bytes)\n' "$DIST" \
  "$(stat -c %s "$DIST/kloub_web_bg.wasm")" "$(stat -c %s "$DIST/kloub_widget_bg.wasm")" "$(stat -c %s "$DIST/kloub_widget_gl_bg.wasm")" "$(stat -c %s "$DIST/kloub_codecs_bg.wasm")" >&2
