#!/usr/bin/env bash
# Installs what Kloub's build and tests need, only what is missing. Idempotent and quick when all is present.
# Used by scripts/run.sh and scripts/test.sh; safe to run by hand.
set -euo pipefail
cd "$(dirname "$0")/.."

log() { printf 'setup: %s\n' "$*" >&2; }

# Debian packages: chromium for browser tests (and the widgets' split profile), Mesa lavapipe/llvmpipe for native
# rendering without a GPU.
need_apt=()
[ -x /usr/bin/chromium ] || need_apt+=(chromium)
ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 || need_apt+=(mesa-vulkan-drivers)
[ -e /usr/lib/x86_64-linux-gnu/libvulkan.so.1 ] || ldconfig -p 2>/dev/null | grep -q libvulkan.so.1 || need_apt+=(libvulkan1)
ldconfig -p 2>/dev/null | grep -q libEGL.so.1 || need_apt+=(libegl1 libegl-mesa0 libgl1-mesa-dri)
# binaryen's wasm-split (scripts/wasm-split.mjs splits the light widgets; npm's binaryen has no wasm-split).
command -v wasm-split >/dev/null || need_apt+=(binaryen)
if [ "${KLOUB_SETUP_APT:-1}" = 1 ] && [ ${#need_apt[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    log "apt-get install ${need_apt[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need_apt[@]}" >/dev/null
  else
    log "missing Debian packages (${need_apt[*]}); install them as root"
  fi
fi

# Rust wasm target.
if ! rustup target list --installed 2>/dev/null | grep -qx wasm32-unknown-unknown; then
  log "rustup target add wasm32-unknown-unknown"
  rustup target add wasm32-unknown-unknown
fi

# wasm-bindgen-cli, pinned to the wasm-bindgen crate version in Cargo.toml.
WBG_VERSION=0.2.130
if [ "$(wasm-bindgen --version 2>/dev/null | awk '{print $2}')" != "$WBG_VERSION" ]; then
  log "cargo install wasm-bindgen-cli $WBG_VERSION (about 2 minutes)"
  # No --locked: its lock file pins a crate the registry no longer has.
  cargo install wasm-bindgen-cli --version "$WBG_VERSION"
fi

# npm packages (binaryen's wasm-opt, playwright-core, pngjs, axe-core for the accessibility audit, gltfpack and
# glTF Transform for tests/optimized/ via scripts/make-optimized.sh, draco3dgltf as the reference decoder).
# Never downloads a browser.
stamp=node_modules/.kloub-installed
if [ ! -f "$stamp" ] || [ package.json -nt "$stamp" ] || { [ -f package-lock.json ] && [ package-lock.json -nt "$stamp" ]; }; then
  log "npm install"
  if [ -f package-lock.json ]; then npm ci --no-audit --no-fund --loglevel=error; else npm install --no-audit --no-fund --loglevel=error; fi
  touch "$stamp"
fi
