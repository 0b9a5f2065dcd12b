// Kloub browser tests: drive the real page served by `kloub serve` in Debian chromium, on WebGPU and WebGL2.
// Prints one line per test and closes with "browser: N passed, M failed"; exits 1 on any failure.
import { join } from 'node:path';
import {
  SHARED, control, dataset, diffFraction, dropFiles, nonBackgroundFraction, openBrowser, pageUrl, savePng, startServer,
  viewportShot, waitForDataset, waitFrames,
} from './lib.mjs';

const BACKENDS = (process.env.KLOUB_BACKENDS ?? 'webgpu,webgl2').split(',');
const FOX = join(SHARED, 'khronos/Fox/glTF-Binary/Fox.glb');
const RIGGED_SIMPLE = join(SHARED, 'khronos/RiggedSimple/glTF-Binary/RiggedSimple.glb');
const ROBOT = join(SHARED, 'threejs/RobotExpressive/RobotExpressive.glb');
const RIGGED_FIGURE = join(SHARED, 'khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb');

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

/** Drops `path` and waits until it is the shown, ready model. */
async function dropModel(page, path) {
  const name = path.split('/').pop();
  await dropFiles(page, [{ path }]);
  await page.waitForFunction((n) => document.body.dataset.model === n && document.body.dataset.status === 'ready', name, { timeout: 60000, polling: 100 });
  // Names resolve against the shown model once its first frame ran.
  await waitFrames(page, 2);
}

/** Pauses on `clip` at `time` (cut, no crossfade) and returns a screenshot of the settled viewport. */
async function still(page, clip, time) {
  if (clip !== null) await control(page, 'crossfadeTo', clip, 0);
  await control(page, 'pause');
  await control(page, 'seek', time);
  const t = time.toFixed(3);
  await page.waitForFunction(
    ([c, t]) => (c === null || document.body.dataset.clip === c) && document.body.dataset.playing === 'false' && document.body.dataset.time === t,
    [clip, t], { timeout: 30000, polling: 50 });
  // A paused viewer paints only on change: the frame that published this state is the last one.
  // Two animation frames later it is on screen.
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  return viewportShot(page);
}

for (const backend of BACKENDS) {
  test(`${backend}: the default model loads and plays on open`, async (ctx) => {
    const ds = await openApp(ctx, backend);
    assert(JSON.parse(ds.clips).length > 0, `no clips listed: ${ds.clips}`);
    const frames = Number(ds.frames);
    // It keeps painting while the clip plays (the first frames compile pipelines: allow a few seconds).
    await ctx.page.waitForFunction((f) => Number(document.body.dataset.frames) >= f + 5, frames, { timeout: 10000, polling: 50 })
      .catch(() => {});
    const later = Number((await dataset(ctx.page)).frames);
    assert(later >= frames + 5, `fewer than 5 frames painted in 10 s while playing (${frames} → ${later})`);
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

  test(`${backend}: clicking Run while Walk plays on Fox crossfades into Run`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    await dropModel(page, FOX);
    const walk = await still(page, 'Walk', 0);
    // playClip is what a click in the clip list does: a crossfade with the panel's duration (0.3 s).
    await control(page, 'play');
    await control(page, 'playClip', 'Run');
    await waitForDataset(page, () => document.body.dataset.clip === 'Run' && document.body.dataset.crossfade !== '', 'the crossfade to start');
    const mid = Number((await dataset(page)).crossfade);
    assert(mid >= 0 && mid < 1, `crossfade weight ${mid}`);
    await waitForDataset(page, () => document.body.dataset.crossfade === '', 'the crossfade to finish');
    const faded = await still(page, null, 0);
    const cut = await still(page, 'Run', 0);
    savePng(walk, `${backend}-crossfade-walk.png`);
    savePng(faded, `${backend}-crossfade-run.png`);
    const changed = diffFraction(walk, faded);
    assert(changed > 0.003, `Walk -> Run changed only ${(changed * 100).toFixed(3)}% of the viewport`);
    const residual = diffFraction(faded, cut);
    assert(residual < 0.0005, `after the crossfade the pose differs from Run's by ${(residual * 100).toFixed(3)}%`);
    let threw = false;
    try { await control(page, 'crossfadeTo', 'Gallop', 0.2); } catch (e) { threw = /Gallop/.test(e.message); }
    assert(threw, 'an unknown clip name does not throw an error naming it');
  });

  test(`${backend}: a Wave layer on RobotExpressive's upper body changes only the upper body`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    await dropModel(page, ROBOT);
    const plain = await still(page, 'Walking', 0.3);
    await control(page, 'setLayer', 'Wave', 'Abdomen', 1);
    await control(page, 'play');
    await waitForDataset(page, () => document.body.dataset.layer === 'Wave@Abdomen:1.00' && document.body.dataset.playing === 'true', 'the layer');
    await new Promise((r) => setTimeout(r, 700));
    const layered = await still(page, 'Walking', 0.3);
    savePng(plain, `${backend}-layer-off.png`);
    savePng(layered, `${backend}-layer-wave.png`);
    const changed = diffFraction(plain, layered);
    assert(changed > 0.003, `the Wave layer changed only ${(changed * 100).toFixed(3)}% of the viewport`);
    // The feet (the lowest part of the framed robot, below the hanging hands) are outside the layer: the same pose.
    const legs = diffFraction(plain, layered, 16, 0.75, 1);
    assert(legs < 0.0005, `the legs changed: ${(legs * 100).toFixed(3)}% of the lower viewport`);
    await control(page, 'setLayer', null, null, 0);
    await waitForDataset(page, () => document.body.dataset.layer === '', 'the layer to be removed');
  });

  test(`${backend}: the candy wrapper shows LBS collapse and DQS/SJB keeping volume, on every path`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    await control(page, 'loadSample', 'candy-wrapper');
    // The sample starts still (posed by its sliders): it paints only on change, so no frame wait here.
    await waitForDataset(page, () => document.body.dataset.model === 'Candy wrapper', 'the candy-wrapper sample');
    await control(page, 'setCandyPose', 150, 0);
    const shots = {};
    for (const method of ['lbs', 'dqs', 'sjb']) {
      await control(page, 'setSkinning', method);
      await waitForDataset(page, () => document.body.dataset.quality !== '', 'the quality readout');
      await waitForDataset(page, (m) => document.body.dataset.skinning === m, `skinning ${method}`, 30000, method);
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      const radius = Number((await dataset(page)).quality.split(',')[0]);
      if (method === 'lbs') assert(Math.abs(radius - 0.259) < 0.01, `LBS keeps ${radius} of the radius at 150°`);
      else assert(radius > 0.99, `${method} keeps ${radius} of the radius at 150°`);
      shots[method] = await viewportShot(page);
      savePng(shots[method], `${backend}-candy-${method}.png`);
    }
    const changed = diffFraction(shots.lbs, shots.dqs);
    assert(changed > 0.004, `switching LBS to DQS changed only ${(changed * 100).toFixed(3)}% of the viewport`);
    if (backend === 'webgpu') {
      await control(page, 'setSkinningPath', 'compute');
      await waitForDataset(page, () => document.body.dataset.skinningPath === 'compute', 'the compute path', 30000);
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      const compute = await viewportShot(page);
      savePng(compute, `${backend}-candy-sjb-compute.png`);
      const d = diffFraction(shots.sjb, compute);
      assert(d < 0.001, `SJB in the vertex shader and in the compute pass differ in ${(d * 100).toFixed(3)}% of the viewport`);
    } else {
      let refused = false;
      try { await control(page, 'setSkinningPath', 'compute'); } catch { refused = true; }
      assert(refused, 'WebGL2 accepted the compute skinning path');
    }
    await control(page, 'setSkinningPath', 'cpu');
    await waitForDataset(page, () => document.body.dataset.skinningPath === 'cpu', 'the CPU path', 30000);
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const cpu = await viewportShot(page);
    const gpuVsCpu = diffFraction(shots.sjb, cpu);
    assert(gpuVsCpu < 0.001, `SJB on the GPU and on the CPU differ in ${(gpuVsCpu * 100).toFixed(3)}% of the viewport`);
    let threw = false;
    try { await control(page, 'setSkinning', 'vsp'); } catch { threw = true; }
    assert(threw, 'an unknown skinning method did not throw');
  });

  test(`${backend}: dragging the IK target moves RiggedFigure's hand onto it`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    await dropModel(page, RIGGED_FIGURE);
    await control(page, 'pause');
    await control(page, 'setIkTarget', 'arm_joint_L_3');
    await waitForDataset(page, () => (document.body.dataset.ik ?? '').startsWith('arm_joint_L_3:') && document.body.dataset.ikTarget !== '', 'IK on the hand');
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const before = await viewportShot(page);
    const [x, y] = (await dataset(page)).ikTarget.split(',').map(Number);
    await page.mouse.move(x, y);
    await page.mouse.down();
    for (let i = 1; i <= 10; i++) await page.mouse.move(x - 4 * i, y - 3 * i);
    await page.mouse.up();
    await waitForDataset(page, ([tx, ty]) => {
      const [mx, my] = (document.body.dataset.ikTarget ?? '').split(',').map(Number);
      return Math.abs(mx - tx) < 2 && Math.abs(my - ty) < 2;
    }, 'the target ring to follow the pointer', 20000, [x - 40, y - 30]);
    await waitForDataset(page, () => Number(document.body.dataset.ik.split(':')[1]) < 1e-3, 'the hand to reach the target', 20000);
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const after = await viewportShot(page);
    savePng(before, `${backend}-ik-before.png`);
    savePng(after, `${backend}-ik-after.png`);
    const changed = diffFraction(before, after);
    assert(changed > 0.002, `dragging the target changed only ${(changed * 100).toFixed(3)}% of the viewport`);
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
    // Fox keeps playing behind the error: frames keep coming (SwiftShader paints a few per second here).
    const frames = Number(ds.frames);
    const painting = await ctx.page
      .waitForFunction((f) => Number(document.body.dataset.frames) >= f + 2, frames, { timeout: 10000, polling: 50 })
      .then(() => true, () => false);
    assert(painting, 'the viewer stopped painting after the error');
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
