// Memory of <kloub-viewer> on a page: what its viewers share (one download, decode and upload per model URL), what
// they give back when removed, and a load loop that levels off. The helpers (the summed PSS of a browser's processes,
// the load-loop page, a browser no devtools client watches) are also what scripts/bench-memory.mjs measures with.
// Registered by run.mjs.
import { spawn } from 'node:child_process';
import { createServer } from 'node:http';
import { mkdtempSync, readFileSync, readdirSync, rmSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { extname, resolve } from 'node:path';
import { chromium } from 'playwright-core';
import { BASE_FLAGS, ROOT, WEBGPU_FLAGS, nonBackgroundFraction, viewportShot } from './lib.mjs';

export const MB = 1024 * 1024;
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const CHROMIUM = process.env.KLOUB_CHROMIUM ?? '/usr/bin/chromium';

/** The load loop's models, in turn (the sample library's). */
export const CYCLE = ['Knight/Knight.glb', 'Fox.glb', 'RobotExpressive/RobotExpressive.glb', 'CesiumMan/CesiumMan.glb'];

/** The browser tests' chromium flags (lib.mjs) and a raised WebGL context limit, as the issue measured. */
export const FLAGS = [...BASE_FLAGS, ...WEBGPU_FLAGS, '--max-active-webgl-contexts=64'];

/**
 * The summed PSS (bytes) of the browser launched with `--kloub-bench=<marker>` and all its descendants, and the same
 * per process type ({ browser, renderer, 'gpu-process', … }).
 */
export function pss(marker) {
  const parent = new Map();
  let root = 0;
  for (const pid of readdirSync('/proc')) {
    if (!/^[0-9]+$/.test(pid)) continue;
    try {
      const stat = readFileSync(`/proc/${pid}/stat`, 'utf8');
      parent.set(Number(pid), Number(stat.slice(stat.lastIndexOf(')') + 2).split(' ')[1]));
      if (!root && readFileSync(`/proc/${pid}/cmdline`, 'utf8').split('\0').includes(`--kloub-bench=${marker}`)) root = Number(pid);
    } catch { /* gone */ }
  }
  const mine = (pid) => { for (let p = pid, i = 0; p > 1 && i < 64; p = parent.get(p), i++) if (p === root) return true; return false; };
  let total = 0;
  const kinds = {};
  for (const pid of parent.keys()) {
    if (!root || !mine(pid)) continue;
    try {
      const m = readFileSync(`/proc/${pid}/smaps_rollup`, 'utf8').match(/^Pss:\s+(\d+) kB/m);
      if (!m) continue;
      const bytes = Number(m[1]) * 1024;
      total += bytes;
      const kind = readFileSync(`/proc/${pid}/cmdline`, 'utf8').match(/--type=([a-z-]+)/)?.[1] ?? 'browser';
      kinds[kind] = (kinds[kind] ?? 0) + bytes;
    } catch { /* gone or not readable */ }
  }
  return { total, kinds };
}

let launches = 0;
/** A unique marker for the next browser. */
export function marker() { return `${process.pid}-${++launches}`; }

/** Launches chromium through playwright with a marker (for `pss`); resolves to { browser, page, marker }. */
export async function launchMarked() {
  const mark = marker();
  const browser = await chromium.launch({ executablePath: CHROMIUM, headless: true, args: [...FLAGS, `--kloub-bench=${mark}`] });
  const page = await browser.newPage({ viewport: { width: 1280, height: 1000 } });
  return { browser, page, marker: mark };
}

/** Memory now, after a garbage collection in the page and a moment for the GPU process to free what it was told to. */
export async function settle(page, mark) {
  const cdp = await page.context().newCDPSession(page);
  await cdp.send('HeapProfiler.collectGarbage');
  await cdp.detach();
  await sleep(1500);
  return pss(mark);
}

// The load loop's page. It is driven by no tool: a devtools client (playwright) keeps every response body it sees in
// the page's memory (its network buffer, up to about 100 MB), which would read as growth. The page loads the models
// in turn itself and, after the 20th and the last load, collects garbage (--expose-gc) and asks the server to measure
// (/mark, answered once the memory is read).
const LOOP_PAGE = (impl, backend, loads) => `<!doctype html><html><head><meta charset="utf-8">
${impl === 'mv' ? '<script type="module" src="/mv/model-viewer.min.js"></script>' : ''}
<style>body{margin:0} kloub-viewer, model-viewer{width:320px;height:240px;display:block}</style></head><body>
<script type="module">
const models = ${JSON.stringify(CYCLE.map((m) => `/assets/${m}`))};
const settle = async (stage) => {
  for (let i = 0; i < 3; i++) { window.gc?.(); await new Promise((r) => setTimeout(r, 500)); }
  await fetch('/mark?stage=' + stage, { cache: 'no-store' });
};
let load;
if (${JSON.stringify(impl)} === 'mv') {
  const v = document.createElement('model-viewer');
  v.setAttribute('autoplay', '');
  document.body.append(v);
  load = (src) => new Promise((ok, fail) => {
    v.addEventListener('load', ok, { once: true });
    v.addEventListener('error', () => fail(new Error('model-viewer: error')), { once: true });
    v.src = src;
  });
} else {
  await import('/dist/kloub-viewer.js');
  const v = document.createElement('kloub-viewer');
  v.setAttribute('backend', ${JSON.stringify(backend)});
  v.setAttribute('autoplay', '');
  v.setAttribute('src', models[0]);
  document.body.append(v);
  await new Promise((ok) => v.addEventListener('load', ok, { once: true }));
  load = (src) => v.load(src);
}
try {
  for (let i = 0; i < ${loads}; i++) {
    await load(models[i % models.length]);
    if (i === 19) await settle('20');
  }
  await settle('last');
} catch (e) {
  await fetch('/mark?stage=error&message=' + encodeURIComponent(e.message));
}
</script></body></html>`;

// model-viewer's page of N elements with the model, autoplaying, no controls (as Kloub's embedded viewers).
const MV_PAGE = (n, w, h) => `<!doctype html><html><head><meta charset="utf-8">
<script type="module" src="/mv/model-viewer.min.js"></script>
<style>body{margin:0;display:flex;flex-wrap:wrap} model-viewer{width:${w}px;height:${h}px}</style></head><body>
${Array.from({ length: n }, () => '<model-viewer src="/assets/Fox.glb" autoplay></model-viewer>').join('\n')}
</body></html>`;

const MIME = { '.js': 'text/javascript', '.html': 'text/html', '.glb': 'model/gltf-binary', '.wasm': 'application/wasm' };

/**
 * A static server for the memory pages: /dist/ (web/dist), /assets/ (the sample library), /mv/ (model-viewer's
 * build), /mv.html?n=&w=&h=, /loop.html?impl=kloub|mv&backend=&loads=, and /mark for the loop page (handed to the
 * `onMark(stage, message)` set on the returned object). Resolves to { url, stop(), onMark }.
 */
export function startPageServer() {
  const roots = {
    '/dist/': resolve(ROOT, 'web/dist'),
    '/assets/': resolve(ROOT, 'web/assets'),
    '/mv/': resolve(ROOT, 'node_modules/@google/model-viewer/dist'),
  };
  const handle = { onMark: () => {} };
  const server = createServer((req, res) => {
    const url = new URL(req.url, 'http://x');
    const path = decodeURIComponent(url.pathname);
    const q = url.searchParams;
    if (path === '/mark') {
      handle.onMark(q.get('stage'), q.get('message'));
      res.writeHead(200, { 'cache-control': 'no-store' }).end();
      return;
    }
    if (path === '/loop.html') {
      res.writeHead(200, { 'content-type': 'text/html' }).end(LOOP_PAGE(q.get('impl'), q.get('backend'), Number(q.get('loads'))));
      return;
    }
    if (path === '/mv.html') {
      res.writeHead(200, { 'content-type': 'text/html' }).end(MV_PAGE(Number(q.get('n') ?? 0), Number(q.get('w') ?? 160), Number(q.get('h') ?? 120)));
      return;
    }
    const prefix = Object.keys(roots).find((p) => path.startsWith(p));
    const dir = prefix && roots[prefix];
    const file = dir && resolve(dir, path.slice(prefix.length));
    if (!file || !file.startsWith(dir) || !statSync(file, { throwIfNoEntry: false })?.isFile()) {
      res.writeHead(404).end('not found');
      return;
    }
    res.writeHead(200, { 'content-type': MIME[extname(file)] ?? 'application/octet-stream' }).end(readFileSync(file));
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => {
    handle.url = `http://127.0.0.1:${server.address().port}`;
    handle.stop = () => server.close();
    ok(handle);
  }));
}

/**
 * The load loop for `backend` (or model-viewer with `null`) in a chromium no devtools client is attached to:
 * resolves to the memory (summed PSS minus the same browser's on a blank page) after the 20th and the last of
 * `loads` loads, and the growth in between per process type.
 */
export async function loopRun(server, backend, loads) {
  const mark = marker();
  const profile = mkdtempSync(`${tmpdir()}/kloub-memory-`);
  const args = [...FLAGS, `--kloub-bench=${mark}`, `--user-data-dir=${profile}`, '--js-flags=--expose-gc', '--window-size=400,300'];
  // Each chromium runs in a process group of its own: stopping it stops its GPU and renderer processes too.
  const start = (url) => spawn(CHROMIUM, [...args, url], { stdio: 'ignore', detached: true });
  const signal = (child, sig) => { try { process.kill(-child.pid, sig); } catch { /* gone */ } };
  const kill = (child) => new Promise((ok) => {
    if (child.exitCode !== null) { signal(child, 'SIGKILL'); ok(); return; }
    child.once('exit', () => { signal(child, 'SIGKILL'); ok(); });
    signal(child, 'SIGTERM');
    setTimeout(() => signal(child, 'SIGKILL'), 3000);
  });
  try {
    // The blank browser first, then the same profile with the loop page.
    const blankChild = start('about:blank');
    await sleep(3000);
    const blank = pss(mark);
    await kill(blankChild);
    const marks = {};
    const done = new Promise((ok, fail) => {
      const timer = setTimeout(() => fail(new Error('the loop page did not finish within 10 minutes')), 600000);
      server.onMark = (stage, message) => {
        if (stage === 'error') { clearTimeout(timer); fail(new Error(`the loop page failed: ${message}`)); return; }
        marks[stage] = pss(mark);
        if (stage === 'last') { clearTimeout(timer); ok(); }
      };
    });
    const url = `${server.url}/loop.html?impl=${backend ? 'kloub' : 'mv'}&backend=${backend ?? ''}&loads=${loads}`;
    const child = start(url);
    try {
      await done;
    } finally {
      await kill(child);
    }
    const growth = Object.entries(marks.last.kinds)
      .map(([k, v]) => `${k} ${((v - (marks['20'].kinds[k] ?? 0)) / MB).toFixed(1)}`).join(', ');
    return { after20: marks['20'].total - blank.total, last: marks.last.total - blank.total, growth: `${growth} MB` };
  } finally {
    server.onMark = () => {};
    // A process of the browser may still be writing its profile for a moment.
    try {
      rmSync(profile, { recursive: true, force: true, maxRetries: 10, retryDelay: 200 });
    } catch (e) {
      console.warn(`     could not remove ${profile}: ${e.message}`);
    }
  }
}

function assert(cond, msg) { if (!cond) throw new Error(msg); }

const SAMPLES = ['Fox.glb', 'CesiumMan/CesiumMan.glb', 'RiggedFigure/RiggedFigure.glb', 'RobotExpressive/RobotExpressive.glb', 'Knight/Knight.glb'];

export function registerMemoryTests(test, BACKENDS) {
  for (const backend of BACKENDS) {
    test(`${backend}: 50 viewers of 5 models: each model downloaded, decoded and uploaded once; removing them releases every shared model`, async (ctx) => {
      const { page } = ctx;
      await page.goto(`${ctx.url}/embed.html?backend=${backend}`);
      await page.evaluate(() => { document.body.innerHTML = '<div id="grid" style="display:flex;flex-wrap:wrap;width:1000px"></div>'; });
      await sleep(500);
      const counters = () => page.evaluate(() => customElements.get('kloub-viewer')._testCounters());
      const before = await counters();
      await page.evaluate(({ b, samples }) => {
        const grid = document.getElementById('grid');
        for (let i = 0; i < 50; i++) {
          const v = document.createElement('kloub-viewer');
          v.id = `v${i}`;
          v.setAttribute('backend', b);
          v.setAttribute('src', `/assets/${samples[i % samples.length]}`);
          v.setAttribute('autoplay', '');
          // The Foxes play different clips: sharing the model shares nothing of the animation.
          if (i % samples.length === 0) v.setAttribute('animation-name', ['Survey', 'Walk', 'Run'][(i / samples.length) % 3]);
          v.style.cssText = 'width:100px;height:75px';
          grid.append(v);
        }
      }, { b: backend, samples: SAMPLES });
      await page.waitForFunction(() => {
        const vs = [...document.querySelectorAll('kloub-viewer')];
        return vs.length === 50 && vs.every((v) => v.dataset.status === 'ready' && (v.dataset.model ?? '') !== '' && Number(v.dataset.frames) > 0);
      }, null, { timeout: 240000, polling: 250 });
      const after = await counters();
      for (const sample of SAMPLES) {
        const url = `/assets/${sample}`;
        const c = after.models[url];
        assert(c?.fetches === 1 && c?.decodes === 1, `${url}: ${JSON.stringify(c)} (10 viewers: one download and one decode)`);
      }
      assert(after.uploads - before.uploads === SAMPLES.length, `${after.uploads - before.uploads} uploads for ${SAMPLES.length} models`);
      assert(after.liveModels === SAMPLES.length && after.liveUploads === SAMPLES.length, `shared now: ${JSON.stringify(after)}`);
      // One page device: the default environment is prefiltered at most once for all 50 (embed.html's viewers may have
      // made it already; none where the device cannot filter half floats).
      assert(after.environments - before.environments <= 1 && after.environments <= 1,
        `${after.environments - before.environments} environments prefiltered for 50 viewers of one look (${before.environments} before)`);
      const ds = await page.evaluate(() => [...document.querySelectorAll('kloub-viewer')].map((v) => ({ ...v.dataset })));
      for (const [i, d] of ds.entries()) {
        assert(d.src === `/assets/${SAMPLES[i % SAMPLES.length]}` && (d.error ?? '') === '', `viewer ${i}: ${d.src} ${d.error}`);
        if (i % SAMPLES.length === 0) assert(d.clip === ['Survey', 'Walk', 'Run'][(i / SAMPLES.length) % 3], `Fox ${i} plays ${d.clip}`);
      }
      for (let i = 0; i < SAMPLES.length; i++) {
        const shot = await viewportShot(page, `#v${i + 5}`);
        assert(nonBackgroundFraction(shot) > 0.01, `viewer ${i + 5} (${SAMPLES[i]}, the model's second viewer) shows nothing`);
      }
      await page.evaluate(() => document.querySelectorAll('kloub-viewer').forEach((v) => v.remove()));
      await page.waitForFunction(async () => {
        const c = await customElements.get('kloub-viewer')._testCounters();
        return c.liveModels === 0 && c.liveUploads === 0;
      }, null, { timeout: 10000, polling: 200 }).catch(async () => {
        throw new Error(`removing every viewer kept shared models: ${JSON.stringify(await counters())}`);
      });
      // Nothing is kept once no viewer shows a model: the next one downloads it again.
      await page.evaluate((b) => {
        const v = document.createElement('kloub-viewer');
        v.setAttribute('backend', b);
        v.setAttribute('src', '/assets/Fox.glb');
        document.getElementById('grid').append(v);
      }, backend);
      await page.waitForFunction(() => document.querySelector('kloub-viewer')?.dataset.status === 'ready' && document.querySelector('kloub-viewer').dataset.model === 'Fox.glb', null, { timeout: 30000 });
      const again = await counters();
      assert(again.models['/assets/Fox.glb'].fetches === 2 && again.liveUploads === 1, `after all were removed: ${JSON.stringify(again.models['/assets/Fox.glb'])}, ${again.liveUploads} uploads`);
    });

    test(`${backend}: 100 loads cycling four models in one viewer: the page's memory levels off (≤ 20 MB from the 20th load to the last)`, async () => {
      const server = await startPageServer();
      try {
        const r = await loopRun(server, backend, 100);
        console.log(`     ${backend}: after 20 loads ${(r.after20 / MB).toFixed(0)} MB, after 100 ${(r.last / MB).toFixed(0)} MB (${r.growth})`);
        assert(r.last - r.after20 <= 20 * MB, `the page grew ${((r.last - r.after20) / MB).toFixed(1)} MB from the 20th load to the 100th (${r.growth})`);
      } finally {
        server.stop();
      }
    });
  }
}
