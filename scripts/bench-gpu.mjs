// GPU-path frame time of the real page in headless Debian chromium: N = 1, 10, 100 copies of Fox
// playing Run, per backend (WebGPU and WebGL2, both on SwiftShader: the CPU emulates the GPU here)
// and skinning method/path (the compute path on WebGPU only). Prints a Markdown table of milliseconds per
// painted frame.
//
//   scripts/build-web.sh && cargo build -p kloub-server && node scripts/bench-gpu.mjs
//
// Frame time = wall time / frames painted over KLOUB_BENCH_SECONDS (default 5) after a 1.5 s warm-up;
// chromium paces frames to at most 60 per second, so 16.7 ms is the floor.
import { join } from 'node:path';
import { SHARED, control, dropFiles, openBrowser, pageUrl, startServer, waitForDataset } from '../tests/browser/lib.mjs';

const SECONDS = Number(process.env.KLOUB_BENCH_SECONDS ?? 5);
const BACKENDS = (process.env.KLOUB_BACKENDS ?? 'webgpu,webgl2').split(',');
const COUNTS = [1, 10, 100];
const CONFIGS = [['lbs', 'gpu'], ['dqs', 'gpu'], ['sjb', 'gpu'], ['lbs', 'compute'], ['sjb', 'compute'], ['lbs', 'cpu']];
const FOX = join(SHARED, 'khronos/Fox/glTF-Binary/Fox.glb');
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

const server = await startServer();
const rows = [];
try {
  for (const backend of BACKENDS) {
    const ctx = await openBrowser();
    try {
      const { page } = ctx;
      await page.goto(pageUrl(server.url, backend));
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'ready', 'the default model');
      await dropFiles(page, [{ path: FOX }]);
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'Fox.glb' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'Fox.glb');
      await sleep(300);
      await control(page, 'crossfadeTo', 'Run', 0);
      for (const [method, path] of CONFIGS.filter(([, p]) => p !== 'compute' || backend === 'webgpu')) {
        await control(page, 'setSkinning', method);
        await control(page, 'setSkinningPath', path);
        const cells = [];
        for (const n of COUNTS) {
          await control(page, 'setCopies', n);
          await page.waitForFunction((n) => document.querySelector('kloub-viewer').dataset.copies === String(n), n, { timeout: 30000, polling: 50 });
          await sleep(1500);
          const before = await page.evaluate(() => [performance.now(), Number(document.querySelector('kloub-viewer').dataset.frames)]);
          await sleep(SECONDS * 1000);
          const after = await page.evaluate(() => [performance.now(), Number(document.querySelector('kloub-viewer').dataset.frames)]);
          const frames = after[1] - before[1];
          cells.push(frames > 0 ? ((after[0] - before[0]) / frames).toFixed(1) : 'n/a');
        }
        rows.push(`| ${backend} | ${method} | ${path} | ${cells.join(' | ')} |`);
        console.error(rows.at(-1));
      }
    } finally {
      await ctx.close();
    }
  }
} finally {
  server.stop();
}
console.log('| Backend (SwiftShader) | Method | Path | N = 1 | N = 10 | N = 100 |');
console.log('|---|---|---|---:|---:|---:|');
for (const r of rows) console.log(r);
