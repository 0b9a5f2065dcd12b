#!/usr/bin/env bash
# Load benchmark of `kloub serve` on loopback with wrk: requests/s, p99 latency and errors for index.html, the
# .wasm (brotli, as a browser asks for it) and a ~500 KB GLB of the sample library, 64 connections for
# KLOUB_BENCH_SECONDS (default 30) each, and the server's RSS before and after. Prints a Markdown table.
#
#   scripts/bench-serve.sh            # needs web/dist (scripts/build-web.sh) and tests/assets
#
# Installs wrk with apt when it is missing (root only). Not part of the test suite: the figures go to BENCHMARKS.md.
set -euo pipefail
cd "$(dirname "$0")/.."

SECONDS_EACH=${KLOUB_BENCH_SECONDS:-30}
CONNECTIONS=${KLOUB_BENCH_CONNECTIONS:-64}
THREADS=${KLOUB_BENCH_THREADS:-2}
ADDR=127.0.0.1:${KLOUB_BENCH_PORT:-18089}
ASSETS=${KLOUB_BENCH_ASSETS:-tests/assets}
GLB=${KLOUB_BENCH_GLB:-/assets/threejs/RobotExpressive/RobotExpressive.glb}

if ! command -v wrk >/dev/null; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends wrk >/dev/null
  else
    echo "bench-serve: wrk is missing (apt-get install wrk)" >&2
    exit 1
  fi
fi
[ -f web/dist/kloub_web_bg.wasm ] || ./scripts/build-web.sh
cargo build --release -p kloub-server >&2

target/release/kloub serve --addr "$ADDR" --dist web/dist --assets "$ASSETS" 2>/dev/null &
pid=$!
trap 'kill "$pid" 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  curl -fsS -o /dev/null "http://$ADDR/" 2>/dev/null && break
  sleep 0.1
done
rss() { awk '/VmRSS/ {print $2}' "/proc/$pid/status"; }
rss_before=$(rss)

printf '| Path | Bytes per response | Requests/s | Transfer/s | p50 | p99 | Errors |\n|---|---:|---:|---:|---:|---:|---:|\n'
for spec in "/index.html|identity" "/kloub_web_bg.wasm|br" "$GLB|identity"; do
  path=${spec%%|*}
  encoding=${spec##*|}
  size=$(curl -fsS -H "Accept-Encoding: $encoding" -o /dev/null -w '%{size_download}' "http://$ADDR$path")
  out=$(wrk -t"$THREADS" -c"$CONNECTIONS" -d"${SECONDS_EACH}s" --latency -H "Accept-Encoding: $encoding" \
    "http://$ADDR$path")
  rps=$(awk '/^Requests\/sec:/ {print $2}' <<<"$out")
  transfer=$(awk '/^Transfer\/sec:/ {print $2}' <<<"$out")
  p50=$(awk '$1 == "50%" {print $2}' <<<"$out")
  p99=$(awk '$1 == "99%" {print $2}' <<<"$out")
  # wrk prints "Socket errors: ..." and "Non-2xx or 3xx responses: N" only when there are some.
  socket=$(awk '/Socket errors:/ {gsub(",", ""); print $4 + $6 + $8 + $10}' <<<"$out")
  non2xx=$(awk '/Non-2xx/ {print $NF}' <<<"$out")
  errors=$(( ${socket:-0} + ${non2xx:-0} ))
  printf '| `%s` (%s) | %s | %s | %s | %s | %s | %s |\n' "$path" "$encoding" "$size" "$rps" "$transfer" "$p50" "$p99" "$errors"
done
rss_after=$(rss)
printf '\nServer RSS: %s KiB before, %s KiB after (%s s × 3 paths, %s connections, wrk -t%s).\n' \
  "$rss_before" "$rss_after" "$SECONDS_EACH" "$CONNECTIONS" "$THREADS"
