// Time to first frame of an embedded viewer on a slow link: <kloub-viewer src=Fox.glb autoplay> (no controls: the
// light widget build) against model-viewer 4.4.0 (the npm dev dependency) on the same page and model, in the same
// headless Debian chromium with the browser tests' flags. Each run is a fresh browser (its GPU stack started once on
// a blank page, as a user's browser has it) and a fresh context (cold cache) throttled with CDP network emulation to
// a "Fast 4G" profile: 9 Mbit/s both ways, 170 ms round trip. Measured from the navigation's start, in ms: the
// element's `load` event (Kloub: the model's first frame is drawn; model-viewer: the model is loaded, its first
// frame still to come), and the first animation frame after it — the model's first frame on screen for both (with
// SwiftShader the browser makes no frame while the GPU process still works on the last: model-viewer's shaders and
// environment); and the bytes the page transferred by then. Both are served by one local server with gzip -9 (what
// `kloub serve` and a CDN send; model-viewer's module and Kloub's files alike), the model as is.
//
//   scripts/build-web.sh && node scripts/bench-first-frame.mjs
//
// KLOUB_BENCH_RUNS (default 5; the median is printed), KLOUB_BACKENDS (webgpu,webgl2), KLOUB_BENCH_ENCODING=br,
// KLOUB_BENCH_TRACE=1 (each run's resource timings, console, long tasks and gaps between animation frames),
// KLOUB_BENCH_PROFILE=1 (each run's heaviest functions by self time, and at the end each viewer's functions by
// inclusive time per run: keep the names in the wasm to read Kloub's, see BENCHMARKS.md),
// KLOUB_BENCH_FOCUS=name (with KLOUB_BENCH_PROFILE=1: what the functions whose name contains it called, directly
// or not, by inclusive time per run), KLOUB_BENCH_ATTRS (more attributes on the <kloub-viewer>, e.g. 'shadow-intensity="0"' to compare with
// model-viewer's defaults, which draw no ground shadow), KLOUB_BENCH_SIDECAR=1 (CesiumMan with its sidecar for Kloub,
// without it for model-viewer, which has none: what a sidecar costs the first frame), KLOUB_BENCH_WASM=1 (each run's
// WebAssembly compilation until `load`, from a Chrome trace: V8 compiles a function with its baseline compiler,
// Liftoff, when it is first called, on the thread that calls it, and recompiles the hot ones with TurboFan in the
// background; Kloub only, and tracing slows its runs: read the ratios from runs without it), KLOUB_BENCH_FLAGS (more
// chromium flags, separated by ';', e.g. '--js-flags=--no-wasm-lazy-compilation --trace-wasm-compilation-times': a
// switch given twice keeps its last value, so an --enable-features= here replaces the WebGPU flags' own), KLOUB_DIST
// (another build's web/dist: two builds, one run after the other).
import { createServer } from 'node:http';
import { mkdtempSync, readFileSync, rmSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { extname, join, resolve } from 'node:path';
import { brotliCompressSync, constants, gzipSync } from 'node:zlib';
import { chromium } from 'playwright-core';
import { BASE_FLAGS, ROOT, WEBGPU_FLAGS, median } from '../tests/browser/lib.mjs';

const RUNS = Number(process.env.KLOUB_BENCH_RUNS ?? 5);
const BACKENDS = (process.env.KLOUB_BACKENDS ?? 'webgpu,webgl2').split(',');
/** `gzip` (default) or `br` (brotli 10, as `kloub serve` sends its bundle), for both viewers' files. */
const ENCODING = process.env.KLOUB_BENCH_ENCODING ?? 'gzip';
/** KLOUB_BENCH_TRACE=1: each run's resource timings (start, first byte, end) and the page's console, on stderr. */
const TRACE = process.env.KLOUB_BENCH_TRACE === '1';
/** KLOUB_BENCH_PROFILE=1: the main thread's CPU profile of each run, its heaviest functions (self time) up to `load`. */
const PROFILE_CPU = process.env.KLOUB_BENCH_PROFILE === '1';
/** KLOUB_BENCH_WASM=1: each Kloub run's WebAssembly compilation until `load` (a Chrome trace's v8.wasm events). */
const WASM = process.env.KLOUB_BENCH_WASM === '1';
/** KLOUB_BENCH_FLAGS: more chromium flags, separated by ';' (V8's go in one --js-flags=, separated by spaces). */
const FLAGS = (process.env.KLOUB_BENCH_FLAGS ?? '').split(';').map((f) => f.trim()).filter(Boolean);
/** KLOUB_BENCH_FOCUS: with the profile, the callees of the functions whose name contains this, inclusive. */
const FOCUS = process.env.KLOUB_BENCH_FOCUS;
const PROFILE = { offline: false, latency: 170, downloadThroughput: (9e6 / 8), uploadThroughput: (9e6 / 8) };
const MIME = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm', '.glb': 'model/gltf-binary' };
const ROOTS = {
  // KLOUB_DIST: another build's web/dist (an earlier build against this one).
  '/dist/': resolve(process.env.KLOUB_DIST ?? resolve(ROOT, 'web/dist')),
  '/assets/': resolve(ROOT, 'web/assets'),
  '/mv/': resolve(ROOT, 'node_modules/@google/model-viewer/dist'),
};
const STYLE = 'display:block;width:640px;height:480px';
/** KLOUB_BENCH_ATTRS: more attributes on the <kloub-viewer> (its defaults otherwise). */
const ATTRS = process.env.KLOUB_BENCH_ATTRS ?? '';
/**
 * KLOUB_BENCH_SIDECAR=1: CesiumMan with its sidecar (web/assets/CesiumMan, 210 KB of example poses, which only the
 * widget's second half reads) instead of Fox; model-viewer shows the same model without it.
 */
const SIDECAR = process.env.KLOUB_BENCH_SIDECAR === '1';
const MODEL = SIDECAR ? '/assets/CesiumMan/CesiumMan.glb' : '/assets/Fox.glb';
const KLOUB_SRC = SIDECAR ? `${MODEL}#sidecar=CesiumMan.kloub.json` : MODEL;
// The `load` event's time, and that of the first animation frame callback after it: model-viewer fires `load` when
// its model is loaded and draws it (compiling its shaders) in its next animation frame, whose callback runs before
// this later-registered one; Kloub fires `load` once the model's first frame is drawn.
const ON_LOAD = `() => { window.__firstFrame = performance.now(); requestAnimationFrame(() => { window.__painted = performance.now(); }); }`;
const PAGES = {
  '/kloub.html': (q) => `<!doctype html><meta charset="utf-8"><script type="module" src="/dist/kloub-viewer.js"></script>
<kloub-viewer src="${KLOUB_SRC}" autoplay ${q.get('backend') === 'webgl2' ? 'backend="webgl2"' : ''} ${ATTRS} style="${STYLE}"></kloub-viewer>
<script>document.querySelector('kloub-viewer').addEventListener('load', ${ON_LOAD});</script>`,
  '/mv.html': () => `<!doctype html><meta charset="utf-8"><script type="module" src="/mv/model-viewer.min.js"></script>
<model-viewer src="${MODEL}" autoplay style="${STYLE}"></model-viewer>
<script>document.querySelector('model-viewer').addEventListener('load', ${ON_LOAD});</script>`,
};

const compressed = new Map();
function serve() {
  const server = createServer((req, res) => {
    const url = new URL(req.url, 'http://x');
    const path = decodeURIComponent(url.pathname);
    if (PAGES[path]) {
      res.writeHead(200, { 'content-type': 'text/html', 'cache-control': 'no-store' }).end(PAGES[path](url.searchParams));
      return;
    }
    const prefix = Object.keys(ROOTS).find((p) => path.startsWith(p));
    const file = prefix && resolve(ROOTS[prefix], path.slice(prefix.length));
    if (!file || !file.startsWith(ROOTS[prefix]) || !statSync(file, { throwIfNoEntry: false })?.isFile()) {
      res.writeHead(404).end();
      return;
    }
    const type = MIME[extname(file)] ?? 'application/octet-stream';
    const accepts = req.headers['accept-encoding'] ?? '';
    const encoding = ENCODING === 'br' && /\bbr\b/.test(accepts) ? 'br' : /\bgzip\b/.test(accepts) ? 'gzip' : null;
    if (type !== 'model/gltf-binary' && encoding) {
      const key = `${encoding}:${file}`;
      if (!compressed.has(key)) {
        const data = readFileSync(file);
        compressed.set(key, encoding === 'br'
          ? brotliCompressSync(data, { params: { [constants.BROTLI_PARAM_QUALITY]: 10, [constants.BROTLI_PARAM_LGWIN]: 24 } })
          : gzipSync(data, { level: 9 }));
      }
      res.writeHead(200, { 'content-type': type, 'content-encoding': encoding }).end(compressed.get(key));
    } else {
      res.writeHead(200, { 'content-type': type }).end(readFileSync(file));
    }
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok({ url: `http://127.0.0.1:${server.address().port}`, stop: () => server.close() })));
}

/** One cold, throttled load of `url`: [ms to `load`, bytes transferred by then, ms to the next animation frame]. */
async function run(url) {
  // A browser of its own per run: its GPU process (SwiftShader) may still be busy with the previous page's work.
  // Warmed as a user's browser is (its GPU process up, WebGL2 and WebGPU started once) on a blank page of
  // another context, so that neither viewer pays for starting the browser's GPU stack.
  const browser = await chromium.launch({ executablePath: process.env.KLOUB_CHROMIUM ?? '/usr/bin/chromium', headless: true, args: [...BASE_FLAGS, ...WEBGPU_FLAGS, ...FLAGS] });
  const warm = await browser.newContext();
  const blank = await warm.newPage();
  await blank.evaluate(async () => {
    const gl = document.createElement('canvas').getContext('webgl2');
    gl.clear(gl.COLOR_BUFFER_BIT);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
    const adapter = await navigator.gpu?.requestAdapter();
    const device = await adapter?.requestDevice();
    device?.destroy();
  });
  await warm.close();
  const context = await browser.newContext({ viewport: { width: 800, height: 600 } });
  const page = await context.newPage();
  if (TRACE) {
    // The page's console lines, each stamped with the page's clock when it was written.
    await page.addInitScript(() => {
      for (const level of ['log', 'info', 'warn', 'error', 'debug']) {
        const original = console[level].bind(console);
        console[level] = (...args) => original(`[${performance.now().toFixed(0)} ms]`, ...args);
      }
      new PerformanceObserver((list) => {
        for (const e of list.getEntries()) console.info(`long task from ${e.startTime.toFixed(0)} ms for ${e.duration.toFixed(0)} ms`);
      }).observe({ type: 'longtask', buffered: true });
      let last = 0;
      const tick = (t) => {
        if (last && t - last > 100) console.info(`no animation frame from ${last.toFixed(0)} to ${t.toFixed(0)} ms`);
        last = t;
        requestAnimationFrame(tick);
      };
      requestAnimationFrame(tick);
    });
    page.on('console', (m) => console.error(`  console: ${m.text()}`));
  }
  const cdp = await context.newCDPSession(page);
  await cdp.send('Network.enable');
  await cdp.send('Network.emulateNetworkConditions', PROFILE);
  let bytes = 0;
  cdp.on('Network.loadingFinished', (e) => { bytes += e.encodedDataLength; });
  if (PROFILE_CPU) {
    await cdp.send('Profiler.enable');
    await cdp.send('Profiler.setSamplingInterval', { interval: 200 });
    await cdp.send('Profiler.start');
  }
  const trace = WASM && url.includes('/kloub.html') ? join(mkdtempSync(join(tmpdir(), 'kloub-trace-')), 'trace.json') : null;
  try {
    if (trace) await browser.startTracing(page, { path: trace, categories: ['v8.wasm', 'devtools.timeline'] });
    return await measure(browser, page, cdp, url, trace, () => bytes);
  } finally {
    if (trace) rmSync(resolve(trace, '..'), { recursive: true, force: true });
    await context.close();
    await browser.close();
  }
}

/** The part of `run` between the navigation and the browser's closing: [ms to `load`, bytes, ms to the next frame]. */
async function measure(browser, page, cdp, url, trace, bytes) {
  await page.goto(url);
  await page.waitForFunction(() => window.__painted !== undefined, null, { timeout: 120000, polling: 50 });
  const [ms, painted] = await page.evaluate(() => [window.__firstFrame, window.__painted]);
  if (PROFILE_CPU) {
    if (!INCLUSIVE.has(url)) INCLUSIVE.set(url, new Map());
    printProfile((await cdp.send('Profiler.stop')).profile, ms, INCLUSIVE.get(url));
  }
  if (TRACE) {
    const entries = await page.evaluate(() => performance.getEntriesByType('resource')
      .map((e) => [e.name.replace(location.origin, ''), e.startTime, e.responseStart, e.responseEnd, e.encodedBodySize]));
    for (const [name, start, first, end, size] of entries) {
      console.error(`  ${name}: ${start.toFixed(0)} → first byte ${first.toFixed(0)} → ${end.toFixed(0)} ms (${size} B)`);
    }
    console.error(`  first frame: ${ms.toFixed(0)} ms`);
  }
  if (trace) {
    await browser.stopTracing();
    printWasm(JSON.parse(readFileSync(trace, 'utf8')), ms);
  }
  return [ms, bytes(), painted];
}

/**
 * The WebAssembly compilation in a Chrome trace until `untilMs` after the page's first request (within a few ms of the
 * navigation's start, the page clock's zero): when the module's compilation finished (its last byte arrived), and, on
 * the page's main thread and in the background, how long V8's compilers ran (wall clock, and the thread's CPU time:
 * on a busy machine a thread waits for a core), in trace events (one may compile several functions).
 */
function printWasm(json, untilMs) {
  const events = Array.isArray(json) ? json : json.traceEvents;
  const start = Math.min(...events.filter((e) => e.name === 'ResourceSendRequest').map((e) => e.ts));
  // The page's renderer: the process that compiled its module (a trace holds every process's threads).
  const renderer = events.find((e) => e.name === 'wasm.StartStreamingCompilation')?.pid;
  const main = events.find((e) => e.ph === 'M' && e.name === 'thread_name' && e.pid === renderer && e.args?.name === 'CrRendererMain');
  const until = start + untilMs * 1000;
  const sums = new Map();
  for (const e of events) {
    if (e.ph !== 'X' || e.ts > until || !['wasm.CompileLazy', 'wasm.TopTierCompilation'].includes(e.name)) continue;
    const where = main && e.pid === main.pid && e.tid === main.tid ? 'main thread' : 'background';
    const key = `${e.name === 'wasm.CompileLazy' ? 'Liftoff on first call' : 'TurboFan'} (${where})`;
    const [wall, cpu, n] = sums.get(key) ?? [0, 0, 0];
    sums.set(key, [wall + e.dur / 1000, cpu + (e.tdur ?? 0) / 1000, n + 1]);
  }
  const finished = events.filter((e) => e.name === 'wasm.FinishStreaming' && e.ts <= until).map((e) => ((e.ts - start) / 1000).toFixed(0));
  console.error(`  wasm: streaming compilation finished at ${finished.join(', ')} ms; until \`load\` at ${untilMs.toFixed(0)} ms:`);
  for (const [key, [wall, cpu, n]] of sums) console.error(`    ${key}: ${n} tasks, ${wall.toFixed(0)} ms wall, ${cpu.toFixed(0)} ms CPU`);
}

/** Per viewer, the inclusive time of each function over its runs' profiles (printed at the end). */
const INCLUSIVE = new Map();

/** The functions with the most self time in `profile` (a CDP CPU profile) until `untilMs` after its start; each
 * sample's stack also adds to `inclusive` (every distinct function on it, once). */
function printProfile(profile, untilMs, inclusive) {
  const byId = new Map(profile.nodes.map((n) => [n.id, n]));
  const parent = new Map();
  for (const n of profile.nodes) for (const c of n.children ?? []) parent.set(c, n.id);
  const self = new Map();
  let t = profile.startTime;
  const end = profile.startTime + untilMs * 1000;
  profile.samples.forEach((id, i) => {
    t += profile.timeDeltas[i];
    if (t > end) return;
    const f = byId.get(id).callFrame;
    const key = `${f.functionName || '(anonymous)'} ${f.url.split('/').pop()}`;
    self.set(key, (self.get(key) ?? 0) + profile.timeDeltas[i] / 1000);
    const seen = new Set();
    const stack = [];
    for (let node = id; node !== undefined; node = parent.get(node)) {
      // Rust's symbol hashes dropped: a function and its copies count as one.
      const name = (byId.get(node).callFrame.functionName || '(anonymous)').replace(/::h[0-9a-f]{16}|\[[0-9a-f]{16}\]/g, '');
      stack.push(name);
      if (!seen.has(name)) {
        seen.add(name);
        inclusive.set(name, (inclusive.get(name) ?? 0) + profile.timeDeltas[i] / 1000);
      }
    }
    // What the outermost function named like FOCUS called, directly or not, each once per sample ("focus: " keys).
    const at = FOCUS ? stack.findLastIndex((n) => n.includes(FOCUS)) : -1;
    const callees = new Set(stack.slice(0, Math.max(at, 0)));
    if (at >= 0 && callees.size === 0) callees.add('(self)');
    for (const name of callees) {
      inclusive.set(`focus: ${name}`, (inclusive.get(`focus: ${name}`) ?? 0) + profile.timeDeltas[i] / 1000);
    }
  });
  for (const [key, msSelf] of [...self].sort((a, b) => b[1] - a[1]).slice(0, 25)) {
    console.error(`  ${msSelf.toFixed(1).padStart(7)} ms  ${key}`);
  }
}

const server = await serve();
try {
  const impls = [
    ...BACKENDS.map((b) => [`kloub-viewer (widget), ${b === 'webgl2' ? 'WebGL2' : 'WebGPU'}`, `/kloub.html?backend=${b}`]),
    ['model-viewer 4.4.0 (WebGL)', '/mv.html'],
  ];
  // The viewers take turns, run by run: a slower or faster spell of the shared machine falls on all of them alike.
  const results = impls.map(() => ({ times: [], painted: [], transferred: 0 }));
  for (let i = 0; i < RUNS; i++) {
    for (const [k, [name, path]] of impls.entries()) {
      const [ms, bytes, frame] = await run(`${server.url}${path}`);
      results[k].times.push(ms);
      results[k].painted.push(frame);
      results[k].transferred = bytes;
      console.error(`${name}: run ${i + 1}: load ${ms.toFixed(0)} ms, next frame ${frame.toFixed(0)} ms, ${bytes} B`);
    }
  }
  const rows = impls.map(([name], k) => {
    const { times, painted, transferred } = results[k];
    return [name, median(times), Math.min(...times), Math.max(...times), transferred, median(painted)];
  });
  for (const [url, inclusive] of INCLUSIVE) {
    // What the main thread did until `load`, inclusive of callees, per run: where Kloub's time after its wasm goes.
    console.error(`${url}: inclusive time per run until \`load\``);
    const pseudo = /^(focus: )?\((root|program|idle|garbage collector|anonymous)\)$/;
    const focused = (n) => n.startsWith('focus: ');
    const top = (keep) => {
      for (const [name, total] of [...inclusive].filter(([n]) => !pseudo.test(n) && keep(n)).sort((a, b) => b[1] - a[1]).slice(0, 40)) {
        console.error(`  ${(total / RUNS).toFixed(1).padStart(7)} ms  ${name.slice(0, 140)}`);
      }
    };
    top((n) => !focused(n));
    if (FOCUS) {
      console.error(`  called by ${FOCUS}, directly or not:`);
      top(focused);
    }
  }
  const mv = rows.at(-1)[1];
  const mvPainted = rows.at(-1)[5];
  console.log(`${SIDECAR ? 'CesiumMan (Kloub with its sidecar)' : 'Fox'}, cold cache, 9 Mbit/s, 170 ms RTT, ${ENCODING}; median of ${RUNS} runs\n`);
  console.log('| viewer | `load` (median) | min–max | transferred by then | vs model-viewer | next frame after `load` | vs model-viewer |');
  console.log('|---|---:|---:|---:|---:|---:|---:|');
  for (const [name, med, min, max, bytes, frame] of rows) {
    console.log(`| ${name} | ${med.toFixed(0)} ms | ${min.toFixed(0)}–${max.toFixed(0)} ms | ${(bytes / 1024).toFixed(0)} KB | ${(med / mv).toFixed(2)}× | ${frame.toFixed(0)} ms | ${(frame / mvPainted).toFixed(2)}× |`);
  }
} finally {
  server.stop();
}
