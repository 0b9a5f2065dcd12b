// Kloub browser tests: drive the real page served by `kloub serve` in Debian chromium, on WebGPU and WebGL2.
// Prints one line per test and closes with "browser: N passed, M failed"; exits 1 on any failure.
import { join } from 'node:path';
import {
  SHARED, dataset, diffFraction, dropFiles, nonBackgroundFraction, openBrowser, pageUrl, savePng, startServer,
  viewportShot, waitForDataset,
} from './lib.mjs';

const BACKENDS = (process.env.KLOUB_BACKENDS ?? 'webgpu,webgl2').split(',');
const FOX = join(SHARED, 'khronos/Fox/glTF-Binary/Fox.glb');
const RIGGED_SIMPLE = join(SHARED, 'khronos/RiggedSimple/glTF-Binary/RiggedSimple.glb');

const tests = [];
const test = (name, fn) => tests.push({ name, fn });
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
function assert(cond, msg) { if (!cond) throw new Error(msg); }

/** Opens the app for `backend` and waits for the default model. */
async function openApp(ctx, backend) {
  await ctx.page.goto(pageUrl(ctx.url, backend));
  await waitForDataset(ctx.page, () => document.body.dataset.status === 'ready', 'the default model to be ready');
  const ds = await dataset(ctx.page);
  assert(ds.backend === backend, `expected backend ${backend}, page reports ${ds.backend}`);
  return ds;
}

for (const backend of BACKENDS) {
  test(`${backend}: the default model loads and plays on open`, async (ctx) => {
    const ds = await openApp(ctx, backend);
    assert(JSON.parse(ds.clips).length > 0, `no clips listed: ${ds.clips}`);
    const frames = Number(ds.frames);
    await sleep(500);
    const later = Number((await dataset(ctx.page)).frames);
    assert(later > frames, `no frames painted in 0.5 s (${frames} → ${later})`);
    const shot = await viewportShot(ctx.page);
    savePng(shot, `${backend}-default.png`);
    assert(nonBackgroundFraction(shot) > 0.02, 'the viewport shows nothing but background');
  });

  test(`${backend}: dropping Fox.glb lists Survey/Walk/Run and animates`, async (ctx) => {
    await openApp(ctx, backend);
    await dropFiles(ctx.page, [{ path: RIGGED_SIMPLE }]);
    await waitForDataset(ctx.page, () => document.body.dataset.model === 'RiggedSimple.glb', 'RiggedSimple.glb to load');
    await dropFiles(ctx.page, [{ path: FOX }]);
    await waitForDataset(ctx.page, () => document.body.dataset.model === 'Fox.glb' && document.body.dataset.status === 'ready', 'Fox.glb to load');
    const clips = JSON.parse((await dataset(ctx.page)).clips);
    for (const name of ['Survey', 'Walk', 'Run']) assert(clips.includes(name), `clip ${name} not listed: ${clips}`);
    await sleep(300);
    const a = await viewportShot(ctx.page);
    await sleep(500);
    const b = await viewportShot(ctx.page);
    savePng(a, `${backend}-fox-a.png`);
    savePng(b, `${backend}-fox-b.png`);
    assert(nonBackgroundFraction(a) > 0.02, 'the viewport shows nothing but background');
    const changed = diffFraction(a, b);
    assert(changed > 0.002, `the viewport did not change in 0.5 s (${(changed * 100).toFixed(3)}% pixels differ)`);
  });

  test(`${backend}: a broken file shows an error and keeps the previous model`, async (ctx) => {
    await openApp(ctx, backend);
    await dropFiles(ctx.page, [{ path: FOX }]);
    await waitForDataset(ctx.page, () => document.body.dataset.model === 'Fox.glb' && document.body.dataset.status === 'ready', 'Fox.glb to load');
    const bytes = Buffer.from('glTF\x02\x00\x00\x00\xff\xff\x00\x00truncated', 'latin1');
    await dropFiles(ctx.page, [{ name: 'broken.glb', bytes }]);
    await waitForDataset(ctx.page, () => (document.body.dataset.error ?? '') !== '', 'an error message');
    const ds = await dataset(ctx.page);
    assert(ds.model === 'Fox.glb', `the previous model was replaced: ${ds.model}`);
    assert(ds.error.includes('broken.glb'), `the error does not name the file: ${ds.error}`);
    const frames = Number(ds.frames);
    await sleep(300);
    assert(Number((await dataset(ctx.page)).frames) > frames, 'the viewer stopped painting after the error');
    const shot = await viewportShot(ctx.page);
    assert(nonBackgroundFraction(shot) > 0.02, 'the previous model is no longer drawn');
  });
}

const server = await startServer();
let passed = 0;
let failed = 0;
try {
  for (const t of tests) {
    const started = Date.now();
    let ctx;
    try {
      ctx = { url: server.url, ...(await openBrowser()) };
      await t.fn(ctx);
      passed++;
      console.log(`ok   ${t.name} (${Date.now() - started} ms)`);
    } catch (e) {
      failed++;
      console.log(`FAIL ${t.name}: ${e.message}`);
      for (const line of ctx?.logs.slice(-20) ?? []) console.log(`     ${line}`);
    } finally {
      await ctx?.close();
    }
  }
} finally {
  server.stop();
}
console.log(`browser: ${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
