// Time to first frame of an embedded viewer on a slow link: <kloub-viewer src=Fox.glb autoplay> (no controls: the
// light widget build) against model-viewer 4.4.0 (the npm dev dependency) on the same page and model, in the same
// headless Debian chromium with the browser tests' flags. Each run is a fresh browser context (cold cache) throttled
// with CDP network emulation to a "Fast 4G" profile: 9 Mbit/s both ways, 170 ms round trip. Measured: from the
// navigation's start to the element's `load` event (Kloub: the model's first frame is drawn; model-viewer: the model
// is loaded and shown), in ms; and the bytes the page transferred by then. Both are served by one local server with
// gzip -9 (what `kloub serve` and a CDN send; model-viewer's module and Kloub's files alike), the model as is.
//
//   scripts/build-web.sh && node scripts/bench-first-frame.mjs
//
// KLOUB_BENCH_RUNS (default 5; the median is printed), KLOUB_BACKENDS (webgpu,webgl2).
import { createServer } from 'node:http';
import { readFileSync, statSync } from 'node:fs';
import { extname, resolve } from 'node:path';
import { brotliCompressSync, constants, gzipSync } from 'node:zlib';
import { chromium } from 'playwright-core';
import { BASE_FLAGS, ROOT, WEBGPU_FLAGS } from '../tests/browser/lib.mjs';

const RUNS = Number(process.env.KLOUB_BENCH_RUNS ?? 5);
const BACKENDS = (process.env.KLOUB_BACKENDS ?? 'webgpu,webgl2').split(',');
/** `gzip` (default) or `br` (brotli 10, as `kloub serve` sends its bundle), for both viewers' files. */
const ENCODING = process.env.KLOUB_BENCH_ENCODING ?? 'gzip';
const PROFILE = { offline: false, latency: 170, downloadThroughput: (9e6 / 8), uploadThroughput: (9e6 / 8) };
const MIME = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm', '.glb': 'model/gltf-binary' };
const ROOTS = {
  '/dist/': resolve(ROOT, 'web/dist'),
  '/assets/': resolve(ROOT, 'web/assets'),
  '/mv/': resolve(ROOT, 'node_modules/@google/model-viewer/dist'),
};
const STYLE = 'display:block;width:640px;height:480px';
const PAGES = {
  '/kloub.html': (q) => `<!doctype html><meta charset="utf-8"><script type="module" src="/dist/kloub-viewer.js"></script>
<kloub-viewer src="/assets/Fox.glb" autoplay ${q.get('backend') === 'webgl2' ? 'backend="webgl2"' : ''} style="${STYLE}"></kloub-viewer>
<script>document.querySelector('kloub-viewer').addEventListener('load', () => { window.__firstFrame = performance.now(); });</script>`,
  '/mv.html': () => `<!doctype html><meta charset="utf-8"><script type="module" src="/mv/model-viewer.min.js"></script>
<model-viewer src="/assets/Fox.glb" autoplay style="${STYLE}"></model-viewer>
<script>document.querySelector('model-viewer').addEventListener('load', () => { window.__firstFrame = performance.now(); });</script>`,
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

/** One cold, throttled load of `path`: [ms from navigation start to the first frame, bytes transferred by then]. */
async function run(browser, url) {
  const context = await browser.newContext({ viewport: { width: 800, height: 600 } });
  const page = await context.newPage();
  const cdp = await context.newCDPSession(page);
  await cdp.send('Network.enable');
  await cdp.send('Network.emulateNetworkConditions', PROFILE);
  let bytes = 0;
  cdp.on('Network.loadingFinished', (e) => { bytes += e.encodedDataLength; });
  await page.goto(url);
  await page.waitForFunction(() => window.__firstFrame !== undefined, null, { timeout: 120000, polling: 50 });
  const ms = await page.evaluate(() => window.__firstFrame);
  await context.close();
  return [ms, bytes];
}

const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];
const server = await serve();
const browser = await chromium.launch({ executablePath: process.env.KLOUB_CHROMIUM ?? '/usr/bin/chromium', headless: true, args: [...BASE_FLAGS, ...WEBGPU_FLAGS] });
try {
  const impls = [
    ...BACKENDS.map((b) => [`kloub-viewer (widget), ${b === 'webgl2' ? 'WebGL2' : 'WebGPU'}`, `/kloub.html?backend=${b}`]),
    ['model-viewer 4.4.0 (WebGL)', '/mv.html'],
  ];
  const rows = [];
  for (const [name, path] of impls) {
    const times = [];
    let transferred = 0;
    for (let i = 0; i < RUNS; i++) {
      const [ms, bytes] = await run(browser, `${server.url}${path}`);
      times.push(ms);
      transferred = bytes;
      console.error(`${name}: run ${i + 1}: ${ms.toFixed(0)} ms, ${bytes} B`);
    }
    rows.push([name, median(times), Math.min(...times), Math.max(...times), transferred]);
  }
  const mv = rows.at(-1)[1];
  console.log(`Fox, cold cache, 9 Mbit/s, 170 ms RTT, ${ENCODING}; median of ${RUNS} runs\n`);
  console.log('| viewer | first frame (median) | min–max | transferred by then | vs model-viewer |');
  console.log('|---|---:|---:|---:|---:|');
  for (const [name, med, min, max, bytes] of rows) {
    console.log(`| ${name} | ${med.toFixed(0)} ms | ${min.toFixed(0)}–${max.toFixed(0)} ms | ${(bytes / 1024).toFixed(0)} KB | ${(med / mv).toFixed(2)}× |`);
  }
} finally {
  await browser.close();
  server.stop();
}
