// Memory of <kloub-viewer> against model-viewer 4.4.0 (the npm dev dependency), on the same page and model, in the
// same headless Debian chromium with the same flags: a page of N viewers showing Fox at 160×120, after every one has
// drawn its model. Memory = the summed PSS (proportional set size, /proc/PID/smaps_rollup) of every process of the
// browser minus what the same browser used on a blank page, after a garbage collection. Prints a Markdown table,
// then the load loop (one viewer loading Knight, Fox, RobotExpressive and CesiumMan in turn, in a browser no devtools
// client watches: the page's growth from the 20th to the last load) and what removing every viewer of a page of 16
// gives back. Per-process figures go to stderr.
//
//   scripts/build-web.sh && cargo build -p kloub-server && node scripts/bench-memory.mjs
//
// KLOUB_BENCH_COUNTS (default "1,8,16,50"), KLOUB_BACKENDS (webgl2,webgpu), KLOUB_BENCH_LOADS (default 100),
// KLOUB_BENCH_PARTS ("table,loop,remove").
import { startServer, viewersPage } from '../tests/browser/lib.mjs';
import { MB, launchMarked, loopRun, settle, startPageServer } from '../tests/browser/memory.mjs';

const COUNTS = (process.env.KLOUB_BENCH_COUNTS ?? '1,8,16,50').split(',').map(Number);
const BACKENDS = (process.env.KLOUB_BACKENDS ?? 'webgl2,webgpu').split(',');
const LOADS = Number(process.env.KLOUB_BENCH_LOADS ?? 100);
const PARTS = (process.env.KLOUB_BENCH_PARTS ?? 'table,loop,remove').split(',');
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const mb = (bytes) => (bytes / MB).toFixed(0);
const byKind = (now, then = {}) => Object.entries(now).map(([k, v]) => `${k} ${((v - (then[k] ?? 0)) / MB).toFixed(1)}`).join(', ');

/** N viewers of Fox at w×h on `backend` on the (emptied) embed page, resolved when each drew its model. */
async function kloubPage(page, base, backend, n, { w = 160, h = 120 } = {}) {
  const viewer = { attrs: { backend, src: '/assets/Fox.glb', autoplay: '' }, style: `width:${w}px;height:${h}px` };
  // The embed page's own viewers start on the same backend: the page loads only that backend's build.
  await viewersPage(page, base, Array(n).fill(viewer), 'margin:0;max-width:none;display:flex;flex-wrap:wrap', backend);
  await allDrawn(page);
}

/** Adds `n` viewers of Fox to the page as it is (the module stays loaded), resolved when each drew its model. */
async function addViewers(page, backend, n, w = 160, h = 120) {
  await page.evaluate(({ n, backend, w, h }) => {
    for (let i = 0; i < n; i++) {
      const v = document.createElement('kloub-viewer');
      v.setAttribute('backend', backend);
      v.setAttribute('src', '/assets/Fox.glb');
      v.setAttribute('autoplay', '');
      v.style.cssText = `width:${w}px;height:${h}px`;
      document.body.append(v);
    }
  }, { n, backend, w, h });
  await allDrawn(page);
}

/** Waits until every viewer of the page shows its model and drew twice. */
function allDrawn(page) {
  return page.waitForFunction(() => [...document.querySelectorAll('kloub-viewer')].every((v) => v.dataset.status === 'ready'
    && (v.dataset.model ?? '') !== '' && Number(v.dataset.frames) >= 2), null, { timeout: 300000, polling: 200 });
}

async function modelViewerPage(page, base, n) {
  await page.goto(`${base}/mv.html?n=${n}`);
  await page.waitForFunction((n) => {
    const all = [...document.querySelectorAll('model-viewer')];
    return all.length === n && all.every((v) => v.loaded);
  }, n, { timeout: 300000, polling: 200 });
  await sleep(500);
}

/** The browser on a blank page, once its processes have started (the GPU process and the network service come up
 *  over the first seconds: measured too early, they would count as the page's). */
async function blankPage(page, marker) {
  await page.goto('about:blank');
  await sleep(4000);
  return settle(page, marker);
}

const wasmBytes = (page) => page.evaluate(() => customElements.get('kloub-viewer')?._testMemoryBytes?.() ?? null);

const kloubServer = await startServer();
const pages = await startPageServer();
const impls = [...BACKENDS.map((b) => ({ name: `kloub-viewer, ${b === 'webgl2' ? 'WebGL2' : 'WebGPU'}`, backend: b })), { name: 'model-viewer 4.4.0 (WebGL)', backend: null }];
try {
  if (PARTS.includes('table')) {
    const rows = [];
    for (const impl of impls) {
      const cells = [];
      for (const n of COUNTS) {
        const { browser, page, marker } = await launchMarked();
        try {
          const blank = await blankPage(page, marker);
          if (impl.backend) await kloubPage(page, kloubServer.url, impl.backend, n);
          else await modelViewerPage(page, pages.url, n);
          await sleep(1000);
          const now = await settle(page, marker);
          cells.push(now.total - blank.total);
          const wasm = impl.backend ? await wasmBytes(page) : null;
          console.error(`bench-memory: ${impl.name} N=${n}: ${mb(now.total - blank.total)} MB; over the blank page by process: ${byKind(now.kinds, blank.kinds)} MB${wasm ? `; wasm memory ${mb(wasm)} MB` : ''}`);
        } catch (e) {
          cells.push(NaN);
          console.error(`bench-memory: ${impl.name} N=${n}: ${e.message.split('\n')[0]}`);
        } finally {
          await browser.close();
        }
      }
      rows.push([impl.name, cells]);
    }
    const span = COUNTS[COUNTS.length - 1] - COUNTS[0];
    const slope = (cells) => (cells[cells.length - 1] - cells[0]) / span;
    console.log(`| | ${COUNTS.map((n) => `N = ${n}`).join(' | ')} | each extra viewer |`);
    console.log(`|---|${COUNTS.map(() => '---:').join('|')}|---:|`);
    for (const [name, cells] of rows) console.log(`| ${name} | ${cells.map((c) => `${mb(c)} MB`).join(' | ')} | ${(slope(cells) / MB).toFixed(2)} MB |`);
    const mv = rows[rows.length - 1][1];
    for (const [name, cells] of rows.slice(0, -1)) {
      console.log(`\n${name}: the first viewer ${(cells[0] / mv[0]).toFixed(2)}× model-viewer's, each extra viewer ${(slope(cells) / slope(mv)).toFixed(2)}×`);
    }
  }
  if (PARTS.includes('loop')) {
    console.log(`\n| One viewer, ${LOADS} loads cycling 4 models | after 20 | after ${LOADS} | growth |`);
    console.log('|---|---:|---:|---:|');
    for (const impl of impls) {
      try {
        const r = await loopRun(pages, impl.backend, LOADS);
        console.log(`| ${impl.name} | ${mb(r.after20)} MB | ${mb(r.last)} MB | ${((r.last - r.after20) / MB).toFixed(1)} MB |`);
        console.error(`bench-memory: loop ${impl.name}: growth by process ${r.growth}`);
      } catch (e) {
        console.error(`bench-memory: loop ${impl.name}: ${e.message}`);
      }
    }
  }
  if (PARTS.includes('remove')) {
    console.log('\n| 16 viewers removed | module loaded, no viewer | 16 viewers | all removed | left over |');
    console.log('|---|---:|---:|---:|---:|');
    for (const impl of impls.filter((i) => i.backend)) {
      const { browser, page, marker } = await launchMarked();
      try {
        const blank = await blankPage(page, marker);
        // The module loaded (one viewer mounted, then removed): what a page with the element and no viewer costs.
        await kloubPage(page, kloubServer.url, impl.backend, 1);
        await page.evaluate(() => document.querySelector('kloub-viewer').remove());
        await sleep(1500);
        const empty = await settle(page, marker);
        const wasmEmpty = await wasmBytes(page);
        await addViewers(page, impl.backend, 16);
        const full = await settle(page, marker);
        await page.evaluate(() => document.querySelectorAll('kloub-viewer').forEach((v) => v.remove()));
        await sleep(3000);
        const removed = await settle(page, marker);
        console.error(`bench-memory: remove ${impl.name}: left over by process ${byKind(removed.kinds, empty.kinds)} MB; wasm memory ${mb(await wasmBytes(page))} MB (${mb(wasmEmpty)} MB before the 16)`);
        console.log(`| ${impl.name} | ${mb(empty.total - blank.total)} MB | ${mb(full.total - blank.total)} MB | ${mb(removed.total - blank.total)} MB | ${((removed.total - empty.total) / MB).toFixed(1)} MB |`);
      } catch (e) {
        console.error(`bench-memory: remove ${impl.name}: ${e.message.split('\n')[0]}`);
      } finally {
        await browser.close();
      }
    }
  }
} finally {
  kloubServer.stop();
  pages.stop();
}
