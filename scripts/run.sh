#!/usr/bin/env bash
# The README's run command: install what is missing, build the web bundle, serve it at http://127.0.0.1:8080.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build-web.sh
cargo build --release -p kloub-server
exec target/release/kloub serve --addr "${KLOUB_ADDR:-127.0.0.1:8080}" --dist web/dist --assets web/assets "$@"
