// Kloub browser tests: drive the real page served by `kloub serve` in Debian chromium, on WebGPU and WebGL2.
// Prints one line per test and closes with "browser: N passed, M failed"; exits 1 on any failure.
import { execFileSync } from 'node:child_process';
import { copyFileSync, mkdirSync, mkdtempSync, readFileSync, readdirSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { PNG } from 'pngjs';
import { basename, join } from 'node:path';
import {
  ROOT, SHARED, control, openApp, dataset, dataUrlShot, diffFraction, dropFiles, makeZip, nonBackgroundFraction, saturatedFraction, opaqueMeanRgb, openBrowser, pageUrl, recordEvents,
  savePng, startServer, startStatic, viewerEvents, viewersPage, viewportShot, waitForDataset, waitFrames,
} from './lib.mjs';
import { registerAccessibilityTests } from './accessibility.mjs';
import { registerMemoryTests } from './memory.mjs';
import { registerWidgetTests } from './widget.mjs';

const BACKENDS = (process.env.KLOUB_BACKENDS ?? 'webgpu,webgl2').split(',');
const FOX = join(SHARED, 'khronos/Fox/glTF-Binary/Fox.glb');
const RIGGED_SIMPLE = join(SHARED, 'khronos/RiggedSimple/glTF-Binary/RiggedSimple.glb');

/** Clicks the element matching `selector` in the viewer's accessibility mirror. */
async function inMirrorClick(page, selector) {
  await page.waitForFunction((s) => document.querySelector('kloub-viewer').shadowRoot.querySelector(`.kloub-a11y ${s}`), selector, { timeout: 10000 });
  await page.evaluate((s) => document.querySelector('kloub-viewer').shadowRoot.querySelector(`.kloub-a11y ${s}`).click(), selector);
}

/** Waits until the open menu's item starting with `name` is laid out (the panels' mirror lists it), and a frame more. */
async function openMenuItem(page, name) {
  await page.waitForFunction((n) => [...(document.querySelector('kloub-viewer').shadowRoot
    ?.querySelectorAll('.kloub-a11y [role="menuitem"]') ?? [])]
    .some((e) => (e.getAttribute('aria-label') ?? e.textContent ?? '').trim().startsWith(n)), name, { timeout: 15000, polling: 50 });
  await waitFrames(page, 2);
}

/** Column-major 4×4 product a · b. */
function multiply(a, b) {
  const out = new Array(16).fill(0);
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) for (let k = 0; k < 4; k++) out[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
  return out;
}

/** The inverse of a column-major rotation-and-translation matrix (scale 1). */
function invertRigid(m) {
  const out = new Array(16).fill(0);
  for (let c = 0; c < 3; c++) for (let r = 0; r < 3; r++) out[c * 4 + r] = m[r * 4 + c];
  for (let r = 0; r < 3; r++) out[12 + r] = -(out[r] * m[12] + out[4 + r] * m[13] + out[8 + r] * m[14]);
  out[15] = 1;
  return out;
}

/** The unit quaternion [x, y, z, w] of a column-major matrix's rotation (scale 1). */
function quaternionOf(m) {
  const [m00, m10, m20, m01, m11, m21, m02, m12, m22] = [m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]];
  const w = Math.sqrt(Math.max(0, 1 + m00 + m11 + m22)) / 2;
  const x = Math.sign(m21 - m12) * Math.sqrt(Math.max(0, 1 + m00 - m11 - m22)) / 2;
  const y = Math.sign(m02 - m20) * Math.sqrt(Math.max(0, 1 - m00 + m11 - m22)) / 2;
  const z = Math.sign(m10 - m01) * Math.sqrt(Math.max(0, 1 - m00 - m11 + m22)) / 2;
  const n = Math.hypot(x, y, z, w);
  return [x / n, y / n, z / n, w / n];
}

const ROBOT = join(SHARED, 'threejs/RobotExpressive/RobotExpressive.glb');
const RIGGED_FIGURE = join(SHARED, 'khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb');
const CESIUM_MAN = ['CesiumMan.gltf', 'CesiumMan_data.bin', 'CesiumMan_img0.jpg'].map((f) => join(SHARED, 'khronos/CesiumMan/glTF', f));
const RECURSIVE = join(SHARED, 'khronos/RecursiveSkeletons/glTF-Binary/RecursiveSkeletons.glb');
const KNIGHT = join(SHARED, 'kaykit/Knight/Knight.glb');

/** The box of pixels that differ from the most common colour, as fractions of the image: [x0, y0, x1, y1]. */
function contentBox(img) {
  // The background is a vertical gradient: each row's own most common colour is its background.
  const key = (i) => (img.data[i] >> 3) << 10 | (img.data[i + 1] >> 3) << 5 | (img.data[i + 2] >> 3);
  let [x0, y0, x1, y1] = [img.width, img.height, -1, -1];
  for (let y = 0; y < img.height; y++) {
    const counts = new Map();
    for (let x = 0; x < img.width; x++) { const k = key((y * img.width + x) * 4); counts.set(k, (counts.get(k) ?? 0) + 1); }
    const background = [...counts.entries()].sort((a, b) => b[1] - a[1])[0][0];
    const bg = [(background >> 10) << 3, ((background >> 5) & 31) << 3, (background & 31) << 3];
    for (let x = 0; x < img.width; x++) {
      const i = (y * img.width + x) * 4;
      // The background and the ground grid's faint lines are not content.
      const [r, g, b] = [img.data[i], img.data[i + 1], img.data[i + 2]];
      if (key(i) === background || Math.max(Math.abs(r - bg[0]), Math.abs(g - bg[1]), Math.abs(b - bg[2])) < 24) continue;
      x0 = Math.min(x0, x); y0 = Math.min(y0, y); x1 = Math.max(x1, x); y1 = Math.max(y1, y);
    }
  }
  return [x0 / img.width, y0 / img.height, (x1 + 1) / img.width, (y1 + 1) / img.height];
}

const tests = [];
// KLOUB_ONLY=regex runs only the tests whose names match (while working on one).
const only = process.env.KLOUB_ONLY ? new RegExp(process.env.KLOUB_ONLY) : null;
const test = (name, fn) => { if (!only || only.test(name)) tests.push({ name, fn }); };
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
function assert(cond, msg) { if (!cond) throw new Error(msg); }


/** Turns the (first) viewer's camera by `yaw` radians and waits for the frame that draws it, then two animation
 *  frames so that it is on screen. */
async function nudgeCamera(page, yaw) {
  const f = await page.evaluate((yaw) => {
    const v = document.querySelector('kloub-viewer');
    const frames = Number(v.dataset.frames);
    const c = v.camera;
    c[0] += yaw;
    v.camera = c;
    return frames;
  }, yaw);
  await page.waitForFunction((f) => Number(document.querySelector('kloub-viewer').dataset.frames) > f, f, { timeout: 30000, polling: 50 });
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
}

/** Drops `path` and waits until it is the shown, ready model. */
async function dropModel(page, path) {
  const name = path.split('/').pop();
  await dropFiles(page, [{ path }]);
  await page.waitForFunction((n) => document.querySelector('kloub-viewer').dataset.model === n && document.querySelector('kloub-viewer').dataset.status === 'ready', name, { timeout: 60000, polling: 100 });
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
    ([c, t]) => (c === null || document.querySelector('kloub-viewer').dataset.clip === c) && document.querySelector('kloub-viewer').dataset.playing === 'false' && document.querySelector('kloub-viewer').dataset.time === t,
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
    await ctx.page.waitForFunction((f) => Number(document.querySelector('kloub-viewer').dataset.frames) >= f + 5, frames, { timeout: 10000, polling: 50 })
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
    await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.model === 'RiggedSimple.glb', 'RiggedSimple.glb to load');
    await dropFiles(ctx.page, [{ path: FOX }]);
    await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.model === 'Fox.glb' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'Fox.glb to load');
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
    // Every crossfade weight the viewer publishes is recorded: the 0.3 s fade may begin and end between two polls.
    await page.evaluate(() => {
      const v = document.querySelector('kloub-viewer');
      window.__fades = [];
      new MutationObserver(() => { if (v.dataset.clip === 'Run' && v.dataset.crossfade) window.__fades.push(v.dataset.crossfade); })
        .observe(v, { attributes: true, attributeFilter: ['data-crossfade', 'data-clip'] });
    });
    await control(page, 'play');
    await control(page, 'playClip', 'Run');
    await waitForDataset(page, () => window.__fades.length > 0, 'the crossfade to start');
    const mid = Number(await page.evaluate(() => window.__fades[0]));
    // A slow frame (a loaded machine) may land on the last frame of the fade, weight 1.
    assert(mid >= 0 && mid <= 1, `crossfade weight ${mid}`);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.crossfade === '', 'the crossfade to finish');
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
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.layer === 'Wave@Abdomen:1.00' && document.querySelector('kloub-viewer').dataset.playing === 'true', 'the layer');
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
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.layer === '', 'the layer to be removed');
  });

  test(`${backend}: the candy wrapper shows LBS collapse and DQS/SJB keeping volume, on every path`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    await control(page, 'loadSample', 'candy-wrapper');
    // The sample starts still (posed by its sliders): it paints only on change, so no frame wait here.
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'Candy wrapper', 'the candy-wrapper sample');
    // SwiftShader is a CPU adapter: a viewer skins on the CPU there until told otherwise. The shots below are the
    // vertex shader's, compared with the other paths at the end.
    const unchosen = await dataset(page);
    assert(unchosen.skinningPath === 'cpu' && unchosen.skinningPathChosen === 'false', `the default path on a CPU adapter: ${unchosen.skinningPath}, chosen ${unchosen.skinningPathChosen}`);
    // The heatmap is the vertex shader's: it takes the unchosen default there and back.
    await control(page, 'setHeatmap', true);
    await waitForDataset(page, () => { const d = document.querySelector('kloub-viewer').dataset; return d.heatmap === 'true' && d.skinningPath === 'gpu'; }, 'the heatmap on the vertex-shader path');
    await control(page, 'setHeatmap', false);
    await waitForDataset(page, () => { const d = document.querySelector('kloub-viewer').dataset; return d.heatmap === 'false' && d.skinningPath === 'cpu'; }, 'the CPU path again');
    await control(page, 'setSkinningPath', 'gpu');
    await waitForDataset(page, () => { const d = document.querySelector('kloub-viewer').dataset; return d.skinningPath === 'gpu' && d.skinningPathChosen === 'true'; }, 'the vertex-shader path, chosen');
    await control(page, 'setCandyPose', 150, 0);
    const shots = {};
    for (const method of ['lbs', 'dqs', 'sjb']) {
      await control(page, 'setSkinning', method);
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.quality !== '', 'the quality readout');
      await waitForDataset(page, (m) => document.querySelector('kloub-viewer').dataset.skinning === m, `skinning ${method}`, 30000, method);
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      const radius = Number((await dataset(page)).quality.split(',')[0]);
      if (method === 'lbs') assert(Math.abs(radius - 0.259) < 0.01, `LBS keeps ${radius} of the radius at 150°`);
      else assert(radius > 0.99, `${method} keeps ${radius} of the radius at 150°`);
      shots[method] = await viewportShot(page);
      savePng(shots[method], `${backend}-candy-${method}.png`);
    }
    const changed = diffFraction(shots.lbs, shots.dqs);
    assert(changed > 0.004, `switching LBS to DQS changed only ${(changed * 100).toFixed(3)}% of the viewport`);
    // Bent 90° the sample's example pose keeps the volume under SJBBE, which SJB loses a little of.
    await control(page, 'setCandyPose', 0, 90);
    const volume = async (method) => {
      await control(page, 'setSkinning', method);
      await waitForDataset(page, (m) => document.querySelector('kloub-viewer').dataset.skinning === m, `skinning ${method}`, 30000, method);
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      return Number((await dataset(page)).quality.split(',')[1]);
    };
    const [sjbVolume, sjbbeVolume] = [await volume('sjb'), await volume('sjbbe')];
    assert(sjbbeVolume === 1 && sjbVolume < 1, `volume at 90°: SJB ${sjbVolume}, SJBBE ${sjbbeVolume}`);
    await control(page, 'setSkinning', 'sjb');
    await control(page, 'setCandyPose', 150, 0);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.skinning === 'sjb', 'SJB again');
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    if (backend === 'webgpu') {
      await control(page, 'setSkinningPath', 'compute');
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.skinningPath === 'compute', 'the compute path', 30000);
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
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.skinningPath === 'cpu', 'the CPU path', 30000);
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
    await waitForDataset(page, () => (document.querySelector('kloub-viewer').dataset.ik ?? '').startsWith('arm_joint_L_3:') && document.querySelector('kloub-viewer').dataset.ikTarget !== '', 'IK on the hand');
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const before = await viewportShot(page);
    const [x, y] = (await dataset(page)).ikTarget.split(',').map(Number);
    await page.mouse.move(x, y);
    await page.mouse.down();
    for (let i = 1; i <= 10; i++) await page.mouse.move(x - 4 * i, y - 3 * i);
    await page.mouse.up();
    await waitForDataset(page, ([tx, ty]) => {
      const [mx, my] = (document.querySelector('kloub-viewer').dataset.ikTarget ?? '').split(',').map(Number);
      return Math.abs(mx - tx) < 2 && Math.abs(my - ty) < 2;
    }, 'the target ring to follow the pointer', 20000, [x - 40, y - 30]);
    await waitForDataset(page, () => Number(document.querySelector('kloub-viewer').dataset.ik.split(':')[1]) < 1e-3, 'the hand to reach the target', 20000);
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const after = await viewportShot(page);
    savePng(before, `${backend}-ik-before.png`);
    savePng(after, `${backend}-ik-after.png`);
    const changed = diffFraction(before, after);
    assert(changed > 0.002, `dragging the target changed only ${(changed * 100).toFixed(3)}% of the viewport`);
    // The JS API: the goal switched to two-bone with a pole shows the pole's diamond; bad calls throw.
    const thrown = await page.evaluate(() => {
      const viewer = document.querySelector('kloub-viewer');
      viewer.setIkSolver('arm_joint_L_3', 'twobone', { pole: [0.6, 1.0, 0.4], softness: 0.05 });
      const fails = (f) => { try { f(); return false; } catch { return true; } };
      return [
        fails(() => viewer.setIkSolver('arm_joint_L_3', 'newton')),
        fails(() => viewer.setIkSolver('arm_joint_L_3', 'twobone', { softness: 2 })),
        fails(() => viewer.setIkSolver('no_such_joint', 'ccd')),
      ];
    });
    assert(thrown.every(Boolean), `setIkSolver accepted a bad call: ${thrown}`);
    await waitForDataset(page, () => /^-?[0-9.]+,-?[0-9.]+$/.test(document.querySelector('kloub-viewer').dataset.ikPole ?? ''), 'the pole diamond');
    const { ik } = await dataset(page);
    assert(Number.isFinite(Number(ik.split(':')[1])), `dataset.ik = ${ik}`);
    // A pole in front of the figure and one behind it bend the elbow differently (the arm moves on screen).
    const poleShot = async (pole) => {
      const before = (await dataset(page)).ikPole;
      await page.evaluate((p) => document.querySelector('kloub-viewer').setIkSolver('arm_joint_L_3', 'twobone', { pole: p }), pole);
      await waitForDataset(page, (b) => document.querySelector('kloub-viewer').dataset.ikPole !== b, 'the pole to move', 20000, before);
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      return viewportShot(page);
    };
    const front = await poleShot([0.3, 1.0, 1.5]);
    const back = await poleShot([0.3, 1.0, -1.5]);
    savePng(front, `${backend}-ik-pole-front.png`);
    savePng(back, `${backend}-ik-pole-back.png`);
    const swung = diffFraction(front, back);
    assert(swung > 0.001, `moving the pole from front to back changed only ${(swung * 100).toFixed(3)}% of the viewport`);
  });

  test(`${backend}: dropping CesiumMan's three glTF files shows the textured model`, async (ctx) => {
    await openApp(ctx, backend);
    await dropFiles(ctx.page, CESIUM_MAN.map((path) => ({ path })));
    await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.model === 'CesiumMan.gltf' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'CesiumMan.gltf to load');
    await waitFrames(ctx.page, 2);
    const shot = await viewportShot(ctx.page);
    savePng(shot, `${backend}-cesium-man.png`);
    assert((await dataset(ctx.page)).error === '', 'an error was reported');
    assert(nonBackgroundFraction(shot) > 0.02, 'the viewport shows nothing but background');
    // Lit grey would have no saturated pixels; CesiumMan's texture is blue and orange.
    const coloured = saturatedFraction(shot);
    assert(coloured > 0.01, `only ${(coloured * 100).toFixed(2)}% of the viewport is coloured: the texture is missing`);
  });

  test(`${backend}: optimized GLBs (meshopt from gltfpack -cc, Draco and WebP from glTF Transform) look like the original`, async (ctx) => {
    await openApp(ctx, backend);
    const original = join(SHARED, 'khronos/CesiumMan/glTF-Binary/CesiumMan.glb');
    // The same view of each (without the grid, whose thin lines move with any change of framing).
    await dropModel(ctx.page, original);
    await control(ctx.page, 'setGrid', false);
    const camera = await ctx.page.evaluate(() => document.querySelector('kloub-viewer').camera);
    const a = await still(ctx.page, null, 0.5);
    savePng(a, `${backend}-optimized-original.png`);
    for (const copy of ['CesiumMan.gltfpack-cc.glb', 'CesiumMan.draco.glb', 'CesiumMan.webp.glb']) {
      await dropModel(ctx.page, join(ROOT, 'tests/optimized', copy));
      const d = await dataset(ctx.page);
      assert(d.error === '', `${copy}: an error was reported: ${d.error}`);
      await ctx.page.evaluate((c) => { document.querySelector('kloub-viewer').camera = c; }, camera);
      const b = await still(ctx.page, null, 0.5);
      savePng(b, `${backend}-optimized-${copy.replace(/\.glb$/, '')}.png`);
      const shown = ctx.logs.filter((l) => l.includes(`showing ${copy}`));
      assert(shown.at(-1)?.includes('0 warnings'), `${copy}: import warnings: ${shown.at(-1)}`);
      assert(saturatedFraction(b) > 0.01, `${copy}: the texture is missing`);
      // Quantized positions, 8-bit octahedral normals and filtered rotations (meshopt), 14-bit positions
      // (Draco), a lossy texture (WebP): a few edge pixels apart.
      const differ = diffFraction(a, b, 24);
      assert(differ < 0.01, `${copy}: ${(differ * 100).toFixed(2)}% of the pixels differ from the original's`);
    }
  });

  if (backend === BACKENDS[0]) test(`${backend}: every optimized copy in tests/optimized opens and animates (meshopt, Draco, WebP, quantized)`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    const copies = readdirSync(join(ROOT, 'tests/optimized')).filter((f) => f.endsWith('.glb')).sort();
    assert(copies.length >= 17, `${copies.length} copies`);
    for (const copy of copies) {
      await dropFiles(page, [{ path: join(ROOT, 'tests/optimized', copy) }]);
      await waitForDataset(page, (name) => {
        const d = document.querySelector('kloub-viewer').dataset;
        return (d.model === name && d.status === 'ready') || d.status === 'error';
      }, `${copy} to load`, 60000, copy);
      const d = await dataset(page);
      assert(d.status === 'ready' && d.error === '', `${copy}: ${d.error}`);
      // Its clock runs: the copy animates.
      const t0 = Number(d.time);
      await page.waitForFunction((t0) => Number(document.querySelector('kloub-viewer').dataset.time) !== t0, t0, { timeout: 10000 });
    }
  });

  test(`${backend}: a sidecar's example poses shape skinning="sjbbe" (SJB by example) and leave the other methods alone`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    // CesiumMan's left elbow with one example pose: its rotation in the walk at 0.6 s (from `kloub pose`'s world
    // matrices: parent⁻¹ · joint), whose inline offsets move the elbow's support (the upper arm off the torso)
    // 0.25 along +X in the rest pose. Paused there, α = 1.
    const doc = JSON.parse(execFileSync(join(ROOT, 'target/debug/kloub'), ['pose', CESIUM_MAN[0], '--time', '0.6'], { maxBuffer: 1 << 26 }));
    const world = (name) => doc.frames[0].nodes.find((n) => n.name === name).world;
    const local = multiply(invertRigid(world('Skeleton_arm_joint_L__4_')), world('Skeleton_arm_joint_L__3_'));
    const offsets = new Float32Array(3273 * 3);
    for (let v = 0; v < 3273; v++) offsets[3 * v] = 0.25;
    const sidecar = { examples: { Skeleton_arm_joint_L__3_: [
      { rotation: quaternionOf(local), offsets: Buffer.from(offsets.buffer).toString('base64') },
    ] } };
    await dropFiles(page, [
      ...CESIUM_MAN.map((path) => ({ path })),
      { name: 'CesiumMan.kloub.json', bytes: Buffer.from(JSON.stringify(sidecar)) },
    ]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'CesiumMan.gltf' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'CesiumMan with its sidecar');
    // The vertex shader's SJBBE, compared with the CPU's at the end (SwiftShader's default is the CPU).
    await control(page, 'setSkinningPath', 'gpu');
    await page.evaluate(() => { const v = document.querySelector('kloub-viewer'); v.pause(); v.currentTime = 0.6; });
    const shot = async (method) => {
      await control(page, 'setSkinning', method);
      await waitForDataset(page, (m) => document.querySelector('kloub-viewer').dataset.skinning === m, `skinning ${method}`, 30000, method);
      // A paused viewer paints only on change: two animation frames let the change land.
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      return viewportShot(page);
    };
    const sjb = await shot('sjb');
    const sjbbe = await shot('sjbbe');
    savePng(sjbbe, `${backend}-sjbbe.png`);
    // The skinning section reads out the example's weight: 1 at the example's rotation.
    await page.waitForFunction(() => {
      const root = document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y');
      const texts = [root.textContent, ...[...root.querySelectorAll('[aria-label]')].map((n) => n.getAttribute('aria-label'))];
      return texts.some((t) => t.includes('Example poses (1)')) && texts.some((t) => t.includes('α 1.00'));
    }, null, { timeout: 10000 });
    const changed = diffFraction(sjb, sjbbe);
    assert(changed > 0.002, `the example changed only ${(changed * 100).toFixed(3)}% of the viewport`);
    const back = diffFraction(sjb, await shot('sjb'));
    assert(back < 0.0005, `SJB after SJBBE differs in ${(back * 100).toFixed(3)}% of the viewport: the example weights stayed`);
    // The CPU reference path draws SJBBE like the GPU.
    await control(page, 'setSkinningPath', 'cpu');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.skinningPath === 'cpu', 'the CPU path', 30000);
    const cpu = diffFraction(sjbbe, await shot('sjbbe'));
    assert(cpu < 0.001, `SJBBE on the CPU and on the GPU differ in ${(cpu * 100).toFixed(3)}% of the viewport`);
    // σ: off the example's rotation a narrower Gaussian gives less of it.
    const alpha = () => page.evaluate(() => {
      const m = document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent.match(/α (-?\d+\.\d\d)/);
      return m ? Number(m[1]) : null;
    });
    await page.evaluate(() => { document.querySelector('kloub-viewer').currentTime = 0.25; });
    await page.waitForFunction(() => document.querySelector('kloub-viewer').dataset.time === '0.250', null, { timeout: 10000 });
    await page.waitForFunction(() => !/α 1\.00/.test(document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent), null, { timeout: 10000 });
    const wide = await alpha();
    await page.evaluate(() => {
      const slider = document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y input[type="range"][aria-label="σ Skeleton_arm_joint_L__3_"]');
      slider.value = '0.3';
      slider.dispatchEvent(new Event('input', { bubbles: true }));
    });
    await page.waitForFunction((w) => {
      const m = document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent.match(/α (-?\d+\.\d\d)/);
      return m && Number(m[1]) !== w;
    }, wide, { timeout: 10000 });
    const narrow = await alpha();
    assert(Math.abs(narrow) < Math.abs(wide), `α ${wide} at σ 1, ${narrow} at σ 0.3`);
    // A broken sidecar dropped on the model: an error naming its pointer, the model stays.
    await dropFiles(page, [{ name: 'CesiumMan.kloub.json', bytes: Buffer.from(JSON.stringify({ examples: { Skeleton_arm_joint_L__3_: [{ rotation: [0, 0, 2, 0], offsets: '' }] } })) }]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.error !== '', 'the sidecar error');
    const d = await dataset(page);
    assert(d.error.includes('/examples/Skeleton_arm_joint_L__3_/0/rotation'), d.error);
    assert(d.model === 'CesiumMan.gltf', `the model went: ${d.model}`);
  });

  test(`${backend}: pose mode: a click selects a joint, a gizmo ring turns it; addExamplePose sculpts an example that is added, saved and dropped back exactly`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    await dropFiles(page, CESIUM_MAN.map((path) => ({ path })));
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'CesiumMan.gltf' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'CesiumMan');
    const joint = 'Skeleton_arm_joint_L__3_';
    const el = () => document.querySelector('kloub-viewer');
    const frames = () => page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    // The canvas's offset on the page: the hook reports canvas pixels.
    const offset = await page.evaluate(() => { const r = document.querySelector('kloub-viewer').getBoundingClientRect(); return [r.left, r.top]; });
    const gizmo = async () => {
      await frames();
      return page.evaluate(() => document.querySelector('kloub-viewer')._testGizmo());
    };
    await control(page, 'setPoseMode', true);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.mode === 'pose', 'pose mode');
    assert((await dataset(page)).playing !== 'true', 'pose mode stops the clip');
    // A click near a joint selects it: find the elbow's place, clear the selection, click there.
    await control(page, 'selectJoint', joint);
    await waitForDataset(page, (j) => document.querySelector('kloub-viewer').dataset.joint === j, 'the elbow selected', 10000, joint);
    let g = await gizmo();
    assert(g && g.rings && g.rings.length === 3, `the gizmo: ${JSON.stringify(g)}`);
    await control(page, 'selectJoint', null);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.joint === '', 'no joint selected');
    await page.mouse.click(offset[0] + g.joint[0], offset[1] + g.joint[1]);
    await waitForDataset(page, (j) => document.querySelector('kloub-viewer').dataset.joint === j, 'the click selects the elbow', 10000, joint);
    // Drag the Z ring along itself: the joint turns about its parent's Z, held in data-pose.
    g = await gizmo();
    const before = await page.evaluate((j) => document.querySelector('kloub-viewer').jointRotation(j), joint);
    const [hx, hy] = g.rings[2];
    const [cx, cy] = g.joint;
    const len = Math.hypot(hx - cx, hy - cy) || 1;
    const tangent = [-(hy - cy) / len, (hx - cx) / len];
    await page.mouse.move(offset[0] + hx, offset[1] + hy);
    await page.mouse.down();
    for (let i = 1; i <= 8; i++) await page.mouse.move(offset[0] + hx + tangent[0] * 6 * i, offset[1] + hy + tangent[1] * 6 * i);
    await page.mouse.up();
    await waitForDataset(page, (j) => (document.querySelector('kloub-viewer').dataset.pose ?? '').includes(j), 'the dragged joint held', 10000, joint);
    const after = await page.evaluate((j) => document.querySelector('kloub-viewer').jointRotation(j), joint);
    const dot = Math.abs(before.reduce((s, x, i) => s + x * after[i], 0));
    const turned = 2 * Math.acos(Math.min(1, dot)) * 180 / Math.PI;
    assert(turned > 5, `the ring drag turned the joint ${turned.toFixed(2)}°`);
    // Add an example pose at that rotation: the sculpt opens, under SJB by example.
    await control(page, 'addExamplePose', joint);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.mode === 'sculpt', 'the sculpt');
    assert((await dataset(page)).skinning === 'sjbbe', 'the sculpt shows SJB by example');
    g = await gizmo();
    const shape = await viewportShot(page);
    // Inflate strokes across the joint (its support is the upper arm around it).
    for (const dy of [-4, 0, 4]) {
      await page.mouse.move(offset[0] + g.joint[0] - 24, offset[1] + g.joint[1] + dy);
      await page.mouse.down();
      for (let i = 1; i <= 12; i++) await page.mouse.move(offset[0] + g.joint[0] - 24 + 4 * i, offset[1] + g.joint[1] + dy);
      await page.mouse.up();
    }
    await frames();
    const sculpted = await viewportShot(page);
    const changed = diffFraction(shape, sculpted);
    savePng(sculpted, `${backend}-sculpt.png`);
    assert(changed > 0.0005, `the strokes changed ${(changed * 100).toFixed(3)}% of the viewport`);
    await page.waitForFunction(() => /[1-9]\d* dabs/.test(document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent), null, { timeout: 10000 });
    // Done: the example is added. The joint still holds its rotation, so α is near 1 (not exactly: the example
    // pose is the bind pose with the elbow turned, and the walk also moves the joints' translations a little).
    await inMirrorClick(page, 'button[aria-label="Done"]');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.mode === 'pose', 'back in pose mode');
    await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent.includes('Example poses (1)'), null, { timeout: 10000 });
    const alpha = await page.evaluate(() => Number(document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent.match(/α (-?\d+\.\d\d)/)?.[1]));
    assert(alpha > 0.85 && alpha <= 1.0, `α ${alpha} at the example's rotation`);
    assert((await dataset(page)).pose.includes(joint), 'the held rotation survives Done');
    // Save: the sidecar holds the example inline; dropped back, it is restored exactly (saved again, the same bytes).
    const save = async () => {
      const download = page.waitForEvent('download', { timeout: 15000 });
      await inMirrorClick(page, 'button[aria-label="Save examples"]');
      const file = await (await download).path();
      return readFileSync(file, 'utf8');
    };
    const saved = await save();
    const doc = JSON.parse(saved);
    const example = doc.examples?.[joint]?.[0];
    assert(example && typeof example.offsets === 'string' && example.offsets.length > 100, `the saved sidecar: ${saved.slice(0, 300)}`);
    const q = example.rotation;
    assert(Math.abs(Math.abs(q.reduce((s, x, i) => s + x * after[i], 0)) - 1) < 1e-4, `the example's rotation ${q} is the posed one ${after}`);
    await dropFiles(page, [{ name: 'CesiumMan.kloub.json', bytes: Buffer.from(saved) }]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'ready' && document.querySelector('kloub-viewer').dataset.mode === 'animate', 'CesiumMan again with its sidecar');
    await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent.includes('Example poses (1)'), null, { timeout: 10000 });
    assert((await save()) === saved, 'the sidecar saved after dropping it back differs');
    // Selecting the example in the list poses the joint as in the example: α 1 there.
    await inMirrorClick(page, `button[aria-label="Pose example 1 of ${joint}"]`);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.mode === 'pose', 'pose mode from the list');
    const posed = await page.evaluate((j) => document.querySelector('kloub-viewer').jointRotation(j), joint);
    assert(Math.abs(Math.abs(q.reduce((s, x, i) => s + x * posed[i], 0)) - 1) < 1e-4, `posed as the example: ${posed} vs ${q}`);
    // A second example where the first one is: refused before any sculpting, nothing changes.
    const twin = await page.evaluate((j) => {
      try { document.querySelector('kloub-viewer').addExamplePose(j); return null; } catch (e) { return `${e.name}: ${e.message}`; }
    }, joint);
    // Refused at once (a RangeError) or when the command is applied (data-error and an error event).
    const refused = twin ?? (await page.waitForFunction(() => /same way/.test(document.querySelector('kloub-viewer').dataset.error) && document.querySelector('kloub-viewer').dataset.error, null, { timeout: 10000 }).then((h) => h.jsonValue()));
    assert(refused.includes('same way'), `a twin example: ${refused}`);
    await frames();
    assert((await dataset(page)).mode === 'pose', 'a refused example opened the sculpt');
    // Delete removes it.
    await inMirrorClick(page, `button[aria-label="Delete example 1 of ${joint}"]`);
    await page.waitForFunction(() => !document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent.includes('Example poses'), null, { timeout: 10000 });
    // A joint without a parent joint cannot have an example: an error, the model stays.
    const rootless = await page.evaluate(() => {
      try { document.querySelector('kloub-viewer').addExamplePose('Skeleton_torso_joint_1'); return null; } catch (e) { return `${e.name}: ${e.message}`; }
    });
    const why = rootless ?? (await page.waitForFunction(() => /parent joint/.test(document.querySelector('kloub-viewer').dataset.error) && document.querySelector('kloub-viewer').dataset.error, null, { timeout: 10000 }).then((h) => h.jsonValue()));
    assert(why.includes('parent joint'), why);
  });

  test(`${backend}: setJointRotation holds a joint over the animation, jointRotation reads it, resetPose lets go; data-pose and the URL hash keep it`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    const joint = 'b_LeftForeArm_010';
    await page.evaluate(() => { const v = document.querySelector('kloub-viewer'); v.pause(); v.currentTime = 0.3; });
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const before = await viewportShot(page);
    const animated = await page.evaluate((j) => document.querySelector('kloub-viewer').jointRotation(j), joint);
    assert(animated.length === 4 && Math.abs(Math.hypot(...animated) - 1) < 1e-4, `jointRotation: ${animated}`);
    const q = [0, 0, Math.SQRT1_2, Math.SQRT1_2];
    await page.evaluate(([j, q]) => document.querySelector('kloub-viewer').setJointRotation(j, q), [joint, q]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.pose !== '', 'the held pose');
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const near = (a, b) => a.every((x, i) => Math.abs(x - b[i]) < 1e-4);
    const held = await page.evaluate((j) => document.querySelector('kloub-viewer').jointRotation(j), joint);
    assert(near(held, q), `held ${held}`);
    assert(near(JSON.parse((await dataset(page)).pose)[joint], q), `data-pose ${(await dataset(page)).pose}`);
    const shot = await viewportShot(page);
    savePng(shot, `${backend}-pose-held.png`);
    assert(diffFraction(before, shot) > 0.001, 'holding the forearm changed nothing on screen');
    // Playing keeps it held; the hash carries it.
    await page.evaluate(() => document.querySelector('kloub-viewer').play());
    await waitFrames(page, 3);
    assert(near(await page.evaluate((j) => document.querySelector('kloub-viewer').jointRotation(j), joint), q), 'the clip took the joint back');
    await page.waitForFunction(() => location.hash.includes('pose='), null, { timeout: 10000 });
    // Bad calls throw and change nothing.
    for (const args of [[joint, [0, 0, 0.5, 0.5]], ['nobody', q], [joint, [0, 0, 1]]]) {
      const error = await page.evaluate((a) => { try { document.querySelector('kloub-viewer').setJointRotation(...a); return null; } catch (e) { return e.message; } }, args);
      assert(error && error.startsWith('setJointRotation'), `setJointRotation(${JSON.stringify(args)}) gave ${error}`);
    }
    await page.evaluate(() => document.querySelector('kloub-viewer').resetPose());
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.pose === '', 'the pose let go');
    // The panel's Pose fields of the selected joint (through the accessibility mirror, as a screen reader or a
    // keyboard would use them): Z set to 45° holds the joint.
    await page.evaluate((j) => document.querySelector('kloub-viewer').selectJoint(j), joint);
    await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y input[aria-label="Z"]'), null, { timeout: 10000 });
    await page.evaluate(() => {
      const z = document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y input[aria-label="Z"]');
      z.value = '45';
      z.dispatchEvent(new Event('input', { bubbles: true }));
    });
    await waitForDataset(page, (j) => (document.querySelector('kloub-viewer').dataset.pose ?? '').includes(j), 'the field to hold the joint', 10000, joint);
    const fromField = await page.evaluate((j) => document.querySelector('kloub-viewer').jointRotation(j), joint);
    assert(Math.abs(Math.hypot(...fromField) - 1) < 1e-4, `the field's rotation ${fromField}`);
    await inMirrorClick(page, 'button[aria-label="Reset all"]');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.pose === '', 'Reset all');
    await page.evaluate(() => document.querySelector('kloub-viewer').pause());
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    assert(!near(await page.evaluate((j) => document.querySelector('kloub-viewer').jointRotation(j), joint), q), 'resetPose kept the rotation');
  });

  if (backend === BACKENDS[0]) test(`${backend}: Validate runs the Khronos glTF-Validator on the dropped files (fetched only then) and the panel lists its report`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    // RiggedSimple as a .gltf with its .bin, its POSITION accessor's max doubled: Kloub shows it (a bounds hint it
    // does not use), the validator reports ACCESSOR_MAX_MISMATCH at that accessor.
    const dir = join(SHARED, 'khronos/RiggedSimple/glTF');
    const doc = JSON.parse(readFileSync(join(dir, 'RiggedSimple.gltf'), 'utf8'));
    const position = doc.meshes[0].primitives[0].attributes.POSITION;
    doc.accessors[position].max = doc.accessors[position].max.map((v) => v * 2 + 1);
    await dropFiles(page, [{ name: 'RiggedSimple.gltf', bytes: Buffer.from(JSON.stringify(doc)) }, { path: join(dir, 'RiggedSimple0.bin') }]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'RiggedSimple.gltf' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'RiggedSimple.gltf to load');
    const fetched = () => page.evaluate(() => performance.getEntriesByType('resource').filter((r) => /gltf-validator\.js|validator-worker\.js/.test(r.name)).length);
    assert(await fetched() === 0, 'the validator was fetched before it was asked for');
    await page.evaluate(() => {
      window.__validation = null;
      document.querySelector('kloub-viewer').addEventListener('validation', (e) => { window.__validation = e.detail; });
    });
    // A validator script that fails to load (a broken deploy, a flaky link): validate() says so, and the next call
    // starts a new worker instead of failing for the rest of the page's life.
    await page.context().route(/gltf-validator\.js$/, (route) => route.fulfill({ contentType: 'text/javascript', body: 'throw new Error("a broken validator");' }));
    const broken = await page.evaluate(() => document.querySelector('kloub-viewer').validate().then(() => 'resolved', (e) => e.message));
    assert(/^validate: the validator could not be loaded: .*a broken validator/.test(broken), broken);
    await page.context().unroute(/gltf-validator\.js$/);
    // The panel's button, through its accessibility mirror (as a screen reader or a click would press it).
    await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y button[aria-label="Validate"]'), null, { timeout: 10000 });
    await page.evaluate(() => document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y button[aria-label="Validate"]').click());
    await page.waitForFunction(() => window.__validation !== null, null, { timeout: 60000 });
    const detail = await page.evaluate(() => window.__validation);
    // (The worker fetches the validator itself: the page's own entries show the worker's script.)
    assert(await fetched() >= 1, 'the validator\'s worker was not fetched');
    const issue = detail.report.issues.messages.find((m) => m.code === 'ACCESSOR_MAX_MISMATCH');
    assert(detail.errors >= 1 && issue, `the report: ${JSON.stringify(detail.report.issues).slice(0, 400)}`);
    assert(issue.pointer.startsWith(`/accessors/${position}/max`), `pointer ${issue.pointer}`);
    // The panel: the badge with the counts and the issue with its code and pointer.
    const badge = `${detail.errors} error${detail.errors === 1 ? '' : 's'} · `;
    await page.waitForFunction((badge) => document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent.includes(badge)
      || [...document.querySelector('kloub-viewer').shadowRoot.querySelectorAll('.kloub-a11y [aria-label]')].some((n) => n.getAttribute('aria-label').includes(badge)), badge, { timeout: 10000 });
    const listed = await page.evaluate((pointer) => {
      const root = document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y');
      const texts = [root.textContent, ...[...root.querySelectorAll('[aria-label]')].map((n) => n.getAttribute('aria-label'))];
      return texts.some((t) => t.includes('ACCESSOR_MAX_MISMATCH')) && texts.some((t) => t.includes(pointer));
    }, issue.pointer);
    assert(listed, 'the panel does not list the issue with its code and pointer');
    await waitFrames(page, 2);
    savePng(PNG.sync.read(await page.screenshot()), `${backend}-validation.png`);
    // The method gives the same report to a page author.
    const again = await page.evaluate(() => document.querySelector('kloub-viewer').validate().then((r) => r.issues.numErrors));
    assert(again === detail.errors, `validate() found ${again} errors, the panel ${detail.errors}`);
    // A model from a .zip: the validator reads glTF, not archives, and validate() says so.
    await dropFiles(page, [{ name: 'model.zip', bytes: makeZip([{ name: 'RiggedSimple.glb', bytes: readFileSync(RIGGED_SIMPLE) }]) }]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'RiggedSimple.glb' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'the zipped model to load');
    const refusal = await page.evaluate(() => document.querySelector('kloub-viewer').validate().then(() => 'resolved', (e) => e.message));
    assert(/^validate: .*\.zip archive/.test(refusal), refusal);
  });

  test(`${backend}: an image the browser cannot decode is drawn white with a warning; the model shows`, async (ctx) => {
    await openApp(ctx, backend);
    // CesiumMan's JPEG with its header intact (the importer reads the size from it) and the scan after it garbled.
    const [gltf, bin, jpeg] = CESIUM_MAN;
    const broken = Buffer.from(readFileSync(jpeg));
    const scan = broken.indexOf(Buffer.from([0xff, 0xda]));
    assert(scan > 0, 'the JPEG has a scan');
    for (let i = scan + 2; i < broken.length - 2; i++) broken[i] = (i * 7919) & 0xff;
    await dropFiles(ctx.page, [{ path: gltf }, { path: bin }, { name: basename(jpeg), bytes: broken }]);
    await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.model === 'CesiumMan.gltf' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'CesiumMan.gltf to load');
    await waitFrames(ctx.page, 2);
    assert((await dataset(ctx.page)).error === '', 'an error was reported');
    const shot = await viewportShot(ctx.page);
    savePng(shot, `${backend}-undecodable-image.png`);
    assert(nonBackgroundFraction(shot) > 0.02, 'the model is not drawn');
    // The grid's red and blue axes only (the textured man is over 1 %: the test above).
    const coloured = saturatedFraction(shot);
    assert(coloured < 0.005, `${(coloured * 100).toFixed(2)}% of the viewport is coloured: the broken texture was drawn`);
    const shown = ctx.logs.filter((l) => l.includes('showing CesiumMan.gltf'));
    assert(shown.at(-1)?.includes('1 warnings'), `the import warning: ${shown.at(-1)}`);
  });

  test(`${backend}: a WebP texture (EXT_texture_webp) is drawn, preferred to its fallback`, async (ctx) => {
    await openApp(ctx, backend);
    // A green WebP made by the browser's own encoder, as the texture's EXT_texture_webp source; CesiumMan's blue
    // and orange JPEG stays as the fallback `source`.
    const webp = Buffer.from(await ctx.page.evaluate(async () => {
      const canvas = new OffscreenCanvas(16, 16);
      const g = canvas.getContext('2d');
      g.fillStyle = '#10c020';
      g.fillRect(0, 0, 16, 16);
      const blob = await canvas.convertToBlob({ type: 'image/webp', quality: 1 });
      return [...new Uint8Array(await blob.arrayBuffer())];
    }));
    assert(webp.subarray(8, 12).toString() === 'WEBP', 'the browser wrote a WebP');
    const [gltf, bin, jpeg] = CESIUM_MAN;
    const doc = JSON.parse(readFileSync(gltf, 'utf8'));
    doc.images.push({ uri: 'green.webp' });
    doc.textures[0].extensions = { EXT_texture_webp: { source: doc.images.length - 1 } };
    doc.extensionsUsed = [...(doc.extensionsUsed ?? []), 'EXT_texture_webp'];
    await dropFiles(ctx.page, [{ name: 'CesiumMan.gltf', bytes: Buffer.from(JSON.stringify(doc)) }, { path: bin }, { path: jpeg },
      { name: 'green.webp', bytes: webp }]);
    await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.model === 'CesiumMan.gltf' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'CesiumMan.gltf to load');
    await waitFrames(ctx.page, 2);
    assert((await dataset(ctx.page)).error === '', 'an error was reported');
    const shot = await viewportShot(ctx.page);
    let green = 0;
    for (let i = 0; i < shot.data.length; i += 4) {
      const [r, gr, b] = [shot.data[i], shot.data[i + 1], shot.data[i + 2]];
      if (gr > r + 40 && gr > b + 40) green++;
    }
    const fraction = green / (shot.width * shot.height);
    assert(fraction > 0.01, `only ${(fraction * 100).toFixed(2)}% of the viewport is green: the WebP is not drawn`);
  });

  for (const [name, path] of [['RecursiveSkeletons.glb', RECURSIVE], ['Knight.glb', KNIGHT]]) {
    test(`${backend}: frame-to-fit shows all of ${name}`, async (ctx) => {
      await openApp(ctx, backend);
      await dropModel(ctx.page, path);
      await control(ctx.page, 'pause');
      await control(ctx.page, 'setGrid', false);
      await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.grid === 'false' && document.querySelector('kloub-viewer').dataset.playing === 'false', 'the grid to hide');
      // Paused: the frame that published this is the last; two animation frames later it is on screen.
      await ctx.page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      const shot = await viewportShot(ctx.page);
      savePng(shot, `${backend}-fit-${name}.png`);
      const [x0, y0, x1, y1] = contentBox(shot);
      const box = [x0, y0, x1, y1].map((v) => v.toFixed(3)).join(', ');
      // Wholly inside (not cut by an edge) and large (not a speck in a corner).
      assert(x0 > 0.005 && y0 > 0.005 && x1 < 0.995 && y1 < 0.995, `${name} touches the viewport's edge: box ${box}`);
      assert(Math.max(x1 - x0, y1 - y0) > 0.3, `${name} is framed too small: box ${box}`);
    });
  }

  test(`${backend}: two <kloub-viewer> elements on one page play different clips independently, with their events`, async (ctx) => {
    const { page } = ctx;
    await recordEvents(page);
    await page.goto(`${ctx.url}/embed.html${backend === 'webgl2' ? '?backend=webgl2' : ''}`);
    await waitForDataset(page, () => ['left', 'right'].every((id) => document.getElementById(id).dataset.status === 'ready' && Number(document.getElementById(id).dataset.frames) > 0), 'both viewers');
    await page.waitForFunction(() => window.__kloubEvents.filter(([, t]) => t === 'load').length === 2, null, { timeout: 30000 });
    const state = await page.evaluate(() => ['left', 'right'].map((id) => ({ ...document.getElementById(id).dataset })));
    assert(state[0].backend === backend && state[1].backend === backend, `backends ${state[0].backend}, ${state[1].backend}`);
    assert(state[0].clip === 'Walk' && state[1].clip === 'Run', `clips ${state[0].clip}, ${state[1].clip}`);
    assert(state[1].loop === 'once' && state[1].speed === '0.500', `right: loop ${state[1].loop}, speed ${state[1].speed}`);
    // Fox's Run takes 0.54 s at speed 1: at 0.5 it finishes once, fires finished and stops; Walk loops on.
    await page.waitForFunction(() => window.__kloubEvents.some(([id, t]) => id === 'right' && t === 'finished'), null, { timeout: 30000 });
    await page.waitForFunction(() => window.__kloubEvents.some(([id, t]) => id === 'left' && t === 'loop'), null, { timeout: 30000 });
    const right = await page.evaluate(() => {
      const v = document.getElementById('right');
      return { paused: v.paused, time: v.currentTime, duration: v.duration };
    });
    assert(right.paused && Math.abs(right.time - right.duration) < 1e-3, `right after finishing: ${JSON.stringify(right)}`);
    // Pausing the left one leaves the right one alone; its clock stops, and currentTime seeks.
    await page.evaluate(() => document.getElementById('right').play());
    await page.evaluate(() => document.getElementById('left').pause());
    await waitForDataset(page, () => document.getElementById('left').dataset.playing === 'false', 'left to pause');
    await page.evaluate(() => { document.getElementById('left').currentTime = 0.25; });
    const immediate = await page.evaluate(() => document.getElementById('left').currentTime);
    assert(Math.abs(immediate - 0.25) < 1e-6, `currentTime right after setting it reads ${immediate}`);
    await waitForDataset(page, () => document.getElementById('left').dataset.time === '0.250', 'the seek');
    const t0 = await page.evaluate(() => [document.getElementById('left').currentTime, Number(document.getElementById('right').dataset.frames)]);
    await page.waitForFunction((f) => Number(document.getElementById('right').dataset.frames) >= f + 3, t0[1], { timeout: 30000 });
    const t1 = await page.evaluate(() => document.getElementById('left').currentTime);
    assert(t0[0] === 0.25 && t1 === 0.25, `the paused left clock moved: ${t0[0]} → ${t1}`);
    const events = await viewerEvents(page);
    const of = (id, type) => events.filter(([v, t]) => v === id && t === type);
    assert(of('left', 'pause').length === 1 && of('right', 'pause').length === 1, `pause events: ${JSON.stringify(events.filter(([, t]) => t === 'pause'))}`);
    assert(of('right', 'play').length >= 1, 'right fired no play event after play()');
    assert(of('left', 'finished').length === 0, 'left fired finished though it loops');
    assert(of('right', 'loop').length === 0, 'right fired loop though it plays once');
    assert(of('left', 'timeupdate').some(([, , d]) => d.currentTime === 0.25), 'no timeupdate at the seek');
    assert(of('left', 'load')[0][2].name === 'default.glb', `load detail ${JSON.stringify(of('left', 'load')[0][2])}`);
    // The two canvases show different poses.
    // Each in view in turn (the page may be shorter than both; a screenshot shows only what is in view). The left
    // one is paused and was in view all along; the right one plays, and draws again once scrolled into view.
    const shoot = async (id, playing) => {
      await page.locator(`#${id}`).scrollIntoViewIfNeeded();
      const f = await page.evaluate((id) => Number(document.getElementById(id).dataset.frames), id);
      if (playing) await page.waitForFunction(([id, f]) => Number(document.getElementById(id).dataset.frames) >= f + 2, [id, f], { timeout: 30000 });
      return viewportShot(page, `#${id}`);
    };
    const [a, b] = [await shoot('left', false), await shoot('right', true)];
    savePng(a, `${backend}-embed-left.png`);
    savePng(b, `${backend}-embed-right.png`);
    assert(nonBackgroundFraction(a) > 0.02 && nonBackgroundFraction(b) > 0.02, 'a viewer shows nothing');
    // Attributes changed on a shown model act at once (animation-name crossfades, speed applies).
    await page.evaluate(() => { const v = document.getElementById('left'); v.setAttribute('animation-name', 'Survey'); v.speed = 2; });
    await waitForDataset(page, () => document.getElementById('left').dataset.clip === 'Survey' && document.getElementById('left').dataset.speed === '2.000', 'the attribute changes');
    assert((await page.evaluate(() => document.getElementById('right').dataset.clip)) === 'Run', 'the other viewer changed too');
  });

  test(`${backend}: a <kloub-viewer> without background shows the page around the model; background (a theme or a CSS colour), grid and alt attributes; toBlob and toDataURL`, async (ctx) => {
    const { page } = ctx;
    await viewersPage(page, ctx.url, [{ attrs: { backend, src: '/assets/Fox.glb', 'min-pixel-ratio': '1' }, style: 'width:400px;height:300px' }],
      'margin:0;background:rgb(200,30,30)');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'ready' && Number(document.querySelector('kloub-viewer').dataset.frames) > 0, 'the viewer');
    const ds = await dataset(page);
    assert(ds.background === 'transparent' && ds.grid === 'false', `defaults without controls: background ${ds.background}, grid ${ds.grid}`);
    const red = (img) => {
      let n = 0;
      for (let i = 0; i < img.data.length; i += 4) if (Math.abs(img.data[i] - 200) < 8 && img.data[i + 1] < 40 && img.data[i + 2] < 40) n++;
      return n / (img.width * img.height);
    };
    const shot = await viewportShot(page);
    savePng(shot, `${backend}-transparent.png`);
    // The page's red all around the model, and the model itself (not red) in the middle.
    assert(red(shot) > 0.6 && red(shot) < 0.99, `red (the page) on ${(red(shot) * 100).toFixed(1)}% of the viewer`);
    assert(nonBackgroundFraction(shot) > 0.02, 'no model over the page');
    // toBlob / toDataURL: the frame at the element's size, transparent where the background is, no download.
    const blob = await page.evaluate(async () => {
      const b = await document.querySelector('kloub-viewer').toBlob();
      return { type: b.type, size: b.size };
    });
    assert(blob.type === 'image/png' && blob.size > 1000, `toBlob: ${JSON.stringify(blob)}`);
    const dataUrl = await page.evaluate(() => document.querySelector('kloub-viewer').toDataURL());
    const png = PNG.sync.read(Buffer.from(dataUrl.replace(/^data:image\/png;base64,/, ''), 'base64'));
    let opaque = 0;
    for (let i = 3; i < png.data.length; i += 4) if (png.data[i] === 255) opaque++;
    const opaqueShare = opaque / (png.width * png.height);
    assert(png.width === 400 && png.height === 300, `toDataURL: ${png.width}×${png.height}`);
    assert(png.data[3] === 0 && opaqueShare > 0.02 && opaqueShare < 0.9, `toDataURL: corner alpha ${png.data[3]}, ${(opaqueShare * 100).toFixed(1)}% opaque`);
    // A background covers the page; the grid attribute draws the ground grid over it.
    await page.evaluate(() => { const v = document.querySelector('kloub-viewer'); v.setAttribute('background', 'light'); v.grid = true; });
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.background === 'light' && document.querySelector('kloub-viewer').dataset.grid === 'true', 'background and grid');
    // The frame that mirrored the change drew it; one more (counted from before it is asked for: a paused widget
    // draws one frame per change, maybe before this test reads the count) makes sure it is on screen.
    await nudgeCamera(page, 0.01);
    const light = await viewportShot(page);
    assert(red(light) < 0.001, `the page shows through a light background on ${(red(light) * 100).toFixed(2)}%`);
    assert((await page.evaluate(() => document.querySelector('kloub-viewer').background)) === 'light', 'the background property');
    // A CSS colour is painted behind the canvas, which the scene leaves transparent.
    await page.evaluate(() => { const v = document.querySelector('kloub-viewer'); v.background = 'rgb(30, 200, 30)'; v.grid = false; });
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.background === 'transparent' && document.querySelector('kloub-viewer').dataset.grid === 'false', 'a CSS colour background');
    await nudgeCamera(page, -0.01);
    const green = await viewportShot(page);
    let g = 0;
    for (let i = 0; i < green.data.length; i += 4) if (Math.abs(green.data[i] - 30) < 8 && Math.abs(green.data[i + 1] - 200) < 8) g++;
    assert(g / (green.width * green.height) > 0.6, `the CSS colour shows on ${(100 * g / (green.width * green.height)).toFixed(1)}%`);
    assert((await page.evaluate(() => document.querySelector('kloub-viewer').background)) === 'rgb(30, 200, 30)', 'the background property with a colour');
    const thrown = await page.evaluate(() => { try { document.querySelector('kloub-viewer').background = 'no-such-colour'; return null; } catch (e) { return e.name; } });
    assert(thrown === 'RangeError', `an unknown background threw ${thrown}`);
    // Removing the attribute goes back to the default.
    await page.evaluate(() => document.querySelector('kloub-viewer').removeAttribute('background'));
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.background === 'transparent', 'the default background');
    // model-viewer's animation-crossfade-duration is in milliseconds.
    await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('animation-crossfade-duration', '750'));
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.transition.startsWith('0.750,'), 'animation-crossfade-duration');
    // alt names the element in the browser's accessibility tree, as an image; with controls it is no image.
    await page.evaluate(() => { document.querySelector('kloub-viewer').alt = 'A fox standing'; });
    const images = async () => {
      const cdp = await page.context().newCDPSession(page);
      const { nodes } = await cdp.send('Accessibility.getFullAXTree');
      await cdp.detach();
      return nodes.filter((n) => n.role?.value === 'image').map((n) => n.name?.value);
    };
    const named = await images();
    assert(named.includes('A fox standing'), `images in the accessibility tree: ${JSON.stringify(named)}`);
    await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('controls', ''));
    assert(!(await images()).includes('A fox standing'), 'with controls the element is still an image');
  });

  test(`${backend}: exposure and tone-mapping (model-viewer's attributes and properties) brighten, darken and re-map the model; setExposure and setToneMapping; data-exposure and data-tone-mapping`, async (ctx) => {
    const { page } = ctx;
    await viewersPage(page, ctx.url, [{ attrs: { backend, src: '/assets/Fox.glb', 'min-pixel-ratio': '1' }, style: 'width:320px;height:240px' }]);
    const viewer = () => document.querySelector('kloub-viewer');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'ready' && Number(document.querySelector('kloub-viewer').dataset.frames) > 0, 'the viewer');
    let ds = await dataset(page);
    assert(ds.exposure === '1' && ds.toneMapping === 'neutral', `defaults: exposure ${ds.exposure}, tone mapping ${ds.toneMapping}`);
    // The frame as toDataURL gives it (drawn after the change): the model's pixels only (the rest is transparent).
    const shot = () => dataUrlShot(page);
    const stats = (img) => {
      let sum = 0; let n = 0;
      for (let i = 0; i < img.data.length; i += 4) {
        if (img.data[i + 3] !== 255) continue;
        sum += 0.2126 * img.data[i] + 0.7152 * img.data[i + 1] + 0.0722 * img.data[i + 2];
        n++;
      }
      return { mean: sum / Math.max(n, 1), n };
    };
    const baseShot = await shot();
    const base = stats(baseShot);
    assert(base.n > 1000 && base.mean > 20, `the fox: ${JSON.stringify(base)}`);
    const expect = async (predicate, what) => waitForDataset(page, predicate, what);
    await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('exposure', '2'));
    await expect(() => document.querySelector('kloub-viewer').dataset.exposure === '2', 'exposure="2"');
    const bright = stats(await shot());
    assert(bright.mean > base.mean * 1.3, `exposure 2: mean ${bright.mean.toFixed(1)} vs ${base.mean.toFixed(1)} at 1`);
    await page.evaluate(() => { document.querySelector('kloub-viewer').exposure = 0.5; });
    await expect(() => document.querySelector('kloub-viewer').dataset.exposure === '0.5', 'the exposure property');
    const dim = stats(await shot());
    assert(dim.mean < base.mean * 0.8, `exposure 0.5: mean ${dim.mean.toFixed(1)} vs ${base.mean.toFixed(1)} at 1`);
    // Not a number from 0 to 64: read as 1, as model-viewer falls back to its default.
    await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('exposure', 'bright'));
    await expect(() => document.querySelector('kloub-viewer').dataset.exposure === '1', 'an invalid exposure');
    assert((await page.evaluate(() => document.querySelector('kloub-viewer').exposure)) === 1, 'the exposure property reads 1');
    // The method, without an attribute; 0 leaves every lit and emissive pixel black.
    await page.evaluate(() => { document.querySelector('kloub-viewer').removeAttribute('exposure'); document.querySelector('kloub-viewer').setExposure(0); });
    await expect(() => document.querySelector('kloub-viewer').dataset.exposure === '0', 'setExposure(0)');
    const black = stats(await shot());
    assert(black.mean < 1, `exposure 0: mean ${black.mean.toFixed(2)}`);
    await page.evaluate(() => document.querySelector('kloub-viewer').setExposure(1));
    // Tone mapping: ACES and none each map the fox's colours otherwise than Neutral.
    await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('tone-mapping', 'aces'));
    await expect(() => document.querySelector('kloub-viewer').dataset.toneMapping === 'aces' && document.querySelector('kloub-viewer').dataset.exposure === '1', 'tone-mapping="aces"');
    // Per pixel: the mean absolute difference of the model's pixels between two frames.
    const difference = (a, b) => {
      let sum = 0; let n = 0;
      for (let i = 0; i < a.data.length; i += 4) {
        if (a.data[i + 3] !== 255 || b.data[i + 3] !== 255) continue;
        for (let k = 0; k < 3; k++) sum += Math.abs(a.data[i + k] - b.data[i + k]);
        n += 3;
      }
      return sum / Math.max(n, 1);
    };
    const acesShot = await shot();
    const aces = stats(acesShot);
    assert(difference(acesShot, baseShot) > 3, `aces vs neutral: ${difference(acesShot, baseShot).toFixed(2)} per channel`);
    await page.evaluate(() => { document.querySelector('kloub-viewer').toneMapping = 'linear'; });
    await expect(() => document.querySelector('kloub-viewer').dataset.toneMapping === 'none', "model-viewer's linear");
    const noneShot = await shot();
    assert(difference(noneShot, acesShot) > 3, `none vs aces: ${difference(noneShot, acesShot).toFixed(2)} per channel (means ${stats(noneShot).mean.toFixed(1)}, ${aces.mean.toFixed(1)})`);
    await page.evaluate(() => document.querySelector('kloub-viewer').setToneMapping('neutral'));
    await expect(() => document.querySelector('kloub-viewer').dataset.toneMapping === 'neutral', 'setToneMapping');
    const again = stats(await shot());
    assert(Math.abs(again.mean - base.mean) < 1.5, `neutral again: mean ${again.mean.toFixed(1)} vs ${base.mean.toFixed(1)}`);
    const thrown = await page.evaluate(() => {
      const v = document.querySelector('kloub-viewer');
      const name = (f) => { try { f(); return null; } catch (e) { return e.name; } };
      return [name(() => v.setExposure(-1)), name(() => v.setExposure(Number.NaN)), name(() => v.setToneMapping('agx')), name(() => { v.toneMapping = 'filmic'; }), name(() => { v.exposure = 100; })];
    });
    assert(thrown.every((t) => t === 'RangeError'), `bad values threw ${JSON.stringify(thrown)}`);
    ds = await dataset(page);
    assert(ds.status === 'ready' && !ds.error, `still ready: ${JSON.stringify(ds)}`);
  });

  test(`${backend}: environment-image (model-viewer's attribute): a named environment, an .hdr image that colours the light, a broken file as an error event; setEnvironmentRotation`, async (ctx) => {
    const { page } = ctx;
    await viewersPage(page, ctx.url, [{ attrs: { backend, src: '/assets/Fox.glb', 'min-pixel-ratio': '1' }, style: 'width:320px;height:240px' }]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'ready' && Number(document.querySelector('kloub-viewer').dataset.frames) > 0, 'the viewer');
    assert((await dataset(page)).environment === '', 'the lighting preset\'s environment by default');
    const shot = () => dataUrlShot(page);
    const mean = opaqueMeanRgb; // over the model's pixels
    const studio = mean(await shot());
    await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('environment-image', 'outdoor'));
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.environment === 'outdoor', 'environment-image="outdoor"');
    const outdoor = mean(await shot());
    // The photograph of an overcast square lights the fox otherwise than the preset's studio made in code.
    const moved = Math.max(...[0, 1, 2].map((k) => Math.abs(outdoor[k] - studio[k])));
    console.log(`     outdoor ${outdoor.map((v) => v.toFixed(1))} vs the preset's studio ${studio.map((v) => v.toFixed(1))}`);
    assert(moved > 2, `outdoor ${outdoor.map((v) => v.toFixed(1))} vs studio ${studio.map((v) => v.toFixed(1))}`);
    // A Radiance .hdr file (flat scanlines, 64×32): red light from everywhere.
    const hdr = await page.evaluate(() => {
      const head = new TextEncoder().encode('#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 32 +X 64\n');
      const bytes = new Uint8Array(head.length + 64 * 32 * 4);
      bytes.set(head);
      // RGBE (128, 8, 8, 130): (2, 0.125, 0.125).
      for (let i = head.length; i < bytes.length; i += 4) bytes.set([128, 8, 8, 130], i);
      const url = URL.createObjectURL(new Blob([bytes]));
      document.querySelector('kloub-viewer').setAttribute('environment-image', url);
      return url;
    });
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.environment === 'image', 'an .hdr environment');
    const red = mean(await shot());
    const ratio = (c) => c[0] / Math.max(c[1], 1);
    assert(ratio(red) > 1.5 * ratio(studio), `under a red environment the fox is ${red.map((v) => v.toFixed(1))}, in the studio ${studio.map((v) => v.toFixed(1))}`);
    assert((await page.evaluate(() => document.querySelector('kloub-viewer').environmentImage)) === hdr, 'the environmentImage property');
    // Not an .hdr file: an error event naming the attribute; the model and the red light stay.
    const error = await page.evaluate(() => new Promise((resolve) => {
      const v = document.querySelector('kloub-viewer');
      v.addEventListener('error', (e) => resolve(String(e.detail?.message ?? e.detail)), { once: true });
      v.setAttribute('environment-image', URL.createObjectURL(new Blob([new TextEncoder().encode('not an image')])));
    }));
    assert(error.includes('environment-image') && error.includes('Radiance'), `the error: ${error}`);
    let ds = await dataset(page);
    assert(ds.status === 'ready' && ds.environment === 'image', `after a broken image: ${JSON.stringify({ status: ds.status, environment: ds.environment })}`);
    // A name again, turned; then back to the preset's.
    await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('environment-image', 'studio'));
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.environment === 'studio', 'environment-image="studio"');
    const thrown = await page.evaluate(() => { try { document.querySelector('kloub-viewer').setEnvironmentRotation(Number.NaN); return null; } catch (e) { return e.name; } });
    assert(thrown === 'RangeError', `setEnvironmentRotation(NaN) threw ${thrown}`);
    await page.evaluate(() => document.querySelector('kloub-viewer').setEnvironmentRotation(90));
    await page.evaluate(() => document.querySelector('kloub-viewer').removeAttribute('environment-image'));
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.environment === '', 'no environment-image');
    ds = await dataset(page);
    assert(ds.status === 'ready' && !ds.error, `still ready: ${JSON.stringify(ds)}`);
  });

  test(`${backend}: environment-image photographs ("studio", "outdoor") are fetched only when a viewer lights with one, once for all the page's viewers; a failed fetch is an error event, the light stays, and the next choice fetches again`, async (ctx) => {
    const { page } = ctx;
    const fetched = [];
    page.on('request', (r) => { if (r.url().includes('/environments/')) fetched.push(new URL(r.url()).pathname); });
    await viewersPage(page, ctx.url, [0, 1].map((i) => ({ id: `v${i}`, attrs: { backend, src: '/assets/Fox.glb', 'min-pixel-ratio': '1' }, style: 'width:240px;height:180px;display:inline-block' })));
    await waitForDataset(page, () => [...document.querySelectorAll('kloub-viewer')].every((v) => v.dataset.status === 'ready' && Number(v.dataset.frames) > 0), 'both viewers');
    const shot = (id) => dataUrlShot(page, `#${id}`);
    const mean = opaqueMeanRgb; // over the model's pixels
    // The room made in code: nothing to fetch.
    await page.evaluate(() => document.getElementById('v0').setAttribute('environment-image', 'neutral'));
    await waitForDataset(page, () => document.getElementById('v0').dataset.environment === 'neutral', 'environment-image="neutral"');
    const neutral = mean(await shot('v0'));
    assert(fetched.length === 0, `fetched before any photograph was chosen: ${fetched}`);
    const before = await page.evaluate(() => customElements.get('kloub-viewer')._testCounters());
    // The studio on both viewers, its file held back a while: until it is in, each keeps the light it had.
    let release;
    const held = new Promise((resolve) => { release = resolve; });
    await page.route(/\/environments\/studio\.hdr$/, async (route) => { await held; await route.continue(); });
    await page.evaluate(() => { for (const v of document.querySelectorAll('kloub-viewer')) v.setAttribute('environment-image', 'studio'); });
    await page.waitForTimeout(400);
    const waiting = await page.evaluate(() => [...document.querySelectorAll('kloub-viewer')].map((v) => v.dataset.environment));
    assert(JSON.stringify(waiting) === '["neutral",""]', `while the file is on its way: ${JSON.stringify(waiting)}`);
    const kept = mean(await shot('v0'));
    assert(Math.max(...[0, 1, 2].map((k) => Math.abs(kept[k] - neutral[k]))) < 1.5, `the neutral light kept: ${kept.map((v) => v.toFixed(1))} vs ${neutral.map((v) => v.toFixed(1))}`);
    release();
    // One fetch, both lit by it.
    await waitForDataset(page, () => [...document.querySelectorAll('kloub-viewer')].every((v) => v.dataset.environment === 'studio'), 'both viewers in the studio');
    await page.unroute(/\/environments\/studio\.hdr$/);
    assert(JSON.stringify(fetched) === '["/environments/studio.hdr"]', `fetched: ${fetched}`);
    const studio = mean(await shot('v0'));
    const counters = await page.evaluate(() => customElements.get('kloub-viewer')._testCounters());
    assert(JSON.stringify(counters.environmentFetches) === '[1,0]', `the module's fetches: ${JSON.stringify(counters.environmentFetches)}`);
    // Prefiltered once for the page's device, which both viewers share.
    assert(counters.environments === before.environments + 1, `environments prefiltered: ${before.environments} → ${counters.environments}`);
    // The photograph is not the room: the model's colour moves.
    const moved = Math.max(...[0, 1, 2].map((k) => Math.abs(studio[k] - neutral[k])));
    console.log(`     environment photographs: neutral ${neutral.map((v) => v.toFixed(1))}, studio ${studio.map((v) => v.toFixed(1))}`);
    assert(moved > 2, `the studio photograph ${studio.map((v) => v.toFixed(1))} vs the neutral room ${neutral.map((v) => v.toFixed(1))}`);
    // A failed fetch: an error event naming the attribute and the file; the studio stays, the model too.
    await page.route(/\/environments\/outdoor\.hdr$/, (route) => route.fulfill({ status: 503, body: 'busy' }));
    const error = await page.evaluate(() => new Promise((resolve) => {
      const v = document.getElementById('v0');
      v.addEventListener('error', (e) => resolve(String(e.detail?.message ?? e.detail)), { once: true });
      v.setAttribute('environment-image', 'outdoor');
    }));
    assert(error.includes('environment-image: outdoor') && error.includes('503'), `the error: ${error}`);
    let ds = await dataset(page);
    assert(ds.status === 'ready' && ds.environment === 'studio', `after the failed fetch: ${JSON.stringify({ status: ds.status, environment: ds.environment })}`);
    // The network is back, slowly: choosing it again fetches again; an .hdr URL chosen while it is on its way wins
    // (the photograph does not light the model when it comes before the URL's file), and the light before both stays
    // until the URL's file is in.
    await page.unroute(/\/environments\/outdoor\.hdr$/);
    const hold = () => { let release; const held = new Promise((resolve) => { release = resolve; }); return { held, release }; };
    const [photo, file] = [hold(), hold()];
    await page.route(/\/environments\/outdoor\.hdr$/, async (route) => { await photo.held; await route.continue(); });
    const red = Buffer.concat([Buffer.from('#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 32 +X 64\n'), Buffer.from(new Uint8Array(64 * 32 * 4).map((_, i) => [128, 8, 8, 130][i % 4]))]);
    await page.route(/\/held-environment\.hdr$/, async (route) => { await file.held; await route.fulfill({ status: 200, body: red }); });
    await page.evaluate(() => { document.getElementById('v0').environmentImage = 'studio'; });
    await page.evaluate(() => { document.getElementById('v0').environmentImage = 'outdoor'; });
    await page.evaluate(() => { document.getElementById('v0').environmentImage = '/held-environment.hdr'; });
    const arrived = page.waitForResponse(/\/environments\/outdoor\.hdr$/);
    photo.release();
    await arrived;
    await page.waitForTimeout(500);
    assert((await dataset(page)).environment === 'studio', `the photograph came while the URL was on its way and took over: ${(await dataset(page)).environment}`);
    file.release();
    await waitForDataset(page, () => document.getElementById('v0').dataset.environment === 'image', 'the .hdr URL');
    await page.unroute(/\/held-environment\.hdr$/);
    await page.unroute(/\/environments\/outdoor\.hdr$/);
    // Here now: chosen again, it lights at once.
    await page.evaluate(() => { document.getElementById('v0').environmentImage = 'outdoor'; });
    await waitForDataset(page, () => document.getElementById('v0').dataset.environment === 'outdoor', 'outdoor after the network came back');
    const outdoor = mean(await shot('v0'));
    // The overcast square is not the studio: the model's colour moves again.
    const changed = Math.max(...[0, 1, 2].map((k) => Math.abs(outdoor[k] - studio[k])));
    console.log(`     outdoor ${outdoor.map((v) => v.toFixed(1))}`);
    assert(changed > 2, `outdoor ${outdoor.map((v) => v.toFixed(1))} vs studio ${studio.map((v) => v.toFixed(1))}`);
    assert(fetched.filter((p) => p === '/environments/outdoor.hdr').length === 2 && fetched.length === 3, `fetched: ${fetched}`);
    ds = await dataset(page);
    assert(ds.status === 'ready' && !ds.error, `still ready: ${JSON.stringify(ds)}`);
  });

  test(`${backend}: shadow-intensity and shadow-softness (model-viewer's attributes): a soft ground shadow under the model by default, over the page; none at 0; data-shadow`, async (ctx) => {
    const { page } = ctx;
    await viewersPage(page, ctx.url, [{ attrs: { backend, src: '/assets/Fox.glb', 'min-pixel-ratio': '1' }, style: 'width:320px;height:240px' }]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'ready' && Number(document.querySelector('kloub-viewer').dataset.frames) > 0, 'the viewer');
    assert((await dataset(page)).shadow === '0.6,1', `the default shadow: ${(await dataset(page)).shadow}`);
    const shot = () => dataUrlShot(page);
    // The shadow over a transparent background: dark pixels that are not transparent (the model has some of its
    // own, so the counts are compared with the shadow off).
    const shaded = (img) => {
      let n = 0;
      for (let i = 0; i < img.data.length; i += 4) {
        if (img.data[i + 3] > 8 && img.data[i] < 40 && img.data[i + 1] < 40 && img.data[i + 2] < 40) n++;
      }
      return n;
    };
    const soft = shaded(await shot());
    await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('shadow-intensity', '0'));
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.shadow === '0,1', 'shadow-intensity="0"');
    const none = shaded(await shot());
    assert(soft > none + 300, `shadow pixels: ${soft} by default, ${none} at intensity 0`);
    await page.evaluate(() => { const v = document.querySelector('kloub-viewer'); v.shadowIntensity = 1; v.shadowSoftness = 0; });
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.shadow === '1,0', 'the shadow properties');
    const sharp = shaded(await shot());
    assert(sharp > none + 300, `a sharp full shadow: ${sharp} pixels (none: ${none})`);
    // Not a number from 0 to 1: the defaults (model-viewer ignores such values too).
    await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('shadow-intensity', '2'));
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.shadow === '0.6,0', 'an out-of-range shadow-intensity');
    const thrown = await page.evaluate(() => { try { document.querySelector('kloub-viewer').shadowSoftness = -1; return null; } catch (e) { return e.name; } });
    assert(thrown === 'RangeError', `shadowSoftness = -1 threw ${thrown}`);
  });

  test(`${backend}: 50 viewers on one page all animate through one shared device, none errs`, async (ctx) => {
    const { page } = ctx;
    await page.goto(`${ctx.url}/embed.html?backend=${backend}`);
    await page.evaluate((b) => {
      document.body.innerHTML = '<div id="grid" style="display:flex;flex-wrap:wrap;width:1000px"></div>';
      const grid = document.getElementById('grid');
      for (let i = 0; i < 50; i++) {
        const v = document.createElement('kloub-viewer');
        v.id = `v${i}`;
        v.setAttribute('backend', b);
        v.setAttribute('src', '/models/default.glb');
        v.setAttribute('autoplay', '');
        v.setAttribute('animation-name', ['Survey', 'Walk', 'Run'][i % 3]);
        v.style.cssText = 'width:100px;height:75px';
        grid.append(v);
      }
    }, backend);
    const states = () => page.evaluate(() => [...document.querySelectorAll('kloub-viewer')].map((v) => ({ ...v.dataset })));
    try {
      await page.waitForFunction(() => {
        const vs = [...document.querySelectorAll('kloub-viewer')];
        return vs.length === 50 && vs.every((v) => v.dataset.status === 'ready' && v.dataset.model === 'default.glb' && Number(v.dataset.frames) > 0);
      }, null, { timeout: 180000, polling: 250 });
    } catch (e) {
      const bad = (await states()).filter((d) => d.status !== 'ready' || !Number(d.frames));
      throw new Error(`${bad.length} of 50 viewers not ready and drawing: ${JSON.stringify(bad.slice(0, 3).map((d) => [d.status, d.error, d.frames]))}`);
    }
    const before = await states();
    await page.waitForFunction((f) => [...document.querySelectorAll('kloub-viewer')].every((v, i) => Number(v.dataset.frames) >= f[i] + 3 && v.dataset.time !== undefined),
      before.map((d) => Number(d.frames)), { timeout: 120000, polling: 250 });
    const after = await states();
    for (const [i, d] of after.entries()) {
      assert(d.backend === backend && d.status === 'ready' && (d.error ?? '') === '', `viewer ${i}: backend ${d.backend}, status ${d.status}, error ${d.error}`);
      assert(d.clip === ['Survey', 'Walk', 'Run'][i % 3] && d.playing === 'true', `viewer ${i}: clip ${d.clip}, playing ${d.playing}`);
      assert(d.time !== before[i].time, `viewer ${i}: its clock did not move (${d.time})`);
    }
    const shot = await viewportShot(page, '#v49');
    savePng(shot, `${backend}-fifty-last.png`);
    assert(nonBackgroundFraction(shot) > 0.02, 'the 50th viewer shows nothing');
    const bad = ctx.logs.filter((l) => l.startsWith('[pageerror]') || /panicked|Too many active WebGL contexts|CONTEXT_LOST/i.test(l));
    assert(bad.length === 0, `the page complained: ${bad.slice(0, 3).join('; ')}`);
  });

  test(`${backend}: a lost GPU device comes back with the same model, clip and time, with no reload`, async (ctx) => {
    const { page } = ctx;
    await page.goto(`${ctx.url}/embed.html?backend=${backend}`);
    // Full resolution throughout (slow SwiftShader frames would otherwise lower it), and no interaction prompt (it
    // appears 3 s after the load without input, which a slow machine reaches): the frames compared are equal.
    await page.evaluate(() => {
      for (const v of document.querySelectorAll('kloub-viewer')) {
        v.setAttribute('min-pixel-ratio', '1');
        v.setAttribute('interaction-prompt', 'none');
      }
    });
    await waitForDataset(page, () => ['left', 'right'].every((id) => document.getElementById(id).dataset.status === 'ready' && Number(document.getElementById(id).dataset.frames) > 0), 'both viewers');
    await page.evaluate(() => { const v = document.getElementById('left'); v.pause(); v.currentTime = 0.25; v.setSkinning('dqs'); });
    await waitForDataset(page, () => {
      const d = document.getElementById('left').dataset;
      return d.playing === 'false' && d.time === '0.250' && d.skinning === 'dqs';
    }, 'left paused at 0.25 s');
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const before = await viewportShot(page, '#left');
    savePng(before, `${backend}-before-loss.png`);
    await page.evaluate(() => {
      window.__statuses = [];
      for (const id of ['left', 'right']) {
        const v = document.getElementById(id);
        new MutationObserver(() => window.__statuses.push([id, v.dataset.status, performance.now()])).observe(v, { attributes: true, attributeFilter: ['data-status'] });
      }
    });
    const lost = await page.evaluate(async (b) => {
      const Viewer = customElements.get('kloub-viewer');
      if (b === 'webgl2') {
        const canvas = await Viewer._testGlCanvas();
        window.__lose = canvas.getContext('webgl2').getExtension('WEBGL_lose_context');
        window.__lose.loseContext();
      } else {
        await Viewer._testLoseDevices();
      }
      return performance.now();
    }, backend);
    await page.waitForFunction(() => ['left', 'right'].every((id) => window.__statuses.some(([v, s]) => v === id && s === 'lost')), null, { timeout: 10000 });
    if (backend === 'webgl2') await page.evaluate(() => window.__lose.restoreContext());
    const frames = await page.evaluate(() => Number(document.getElementById('right').dataset.frames));
    await waitForDataset(page, (f) => ['left', 'right'].every((id) => document.getElementById(id).dataset.status === 'ready')
      && Number(document.getElementById('right').dataset.frames) >= f + 3, 'both viewers back', 30000, frames);
    const back = await page.evaluate(() => Math.max(...window.__statuses.filter(([, s]) => s === 'ready').map(([, , t]) => t)));
    console.log(`     ${backend}: drawing again ${Math.round(back - lost)} ms after the loss`);
    const d = await page.evaluate(() => ({ ...document.getElementById('left').dataset }));
    assert(d.model === 'default.glb' && d.clip === 'Walk' && d.time === '0.250' && d.playing === 'false' && d.skinning === 'dqs',
      `left after the loss: ${d.model} ${d.clip} ${d.time} playing ${d.playing} skinning ${d.skinning}`);
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const after = await viewportShot(page, '#left');
    savePng(after, `${backend}-after-loss.png`);
    const diff = diffFraction(before, after);
    assert(nonBackgroundFraction(after) > 0.02 && diff < 0.02, `the left viewer does not show the same frame again: ${(diff * 100).toFixed(2)} % differ`);
    const errors = ctx.logs.filter((l) => l.startsWith('[pageerror]') || /panicked/.test(l));
    assert(errors.length === 0, `page errors: ${errors.join('; ')}`);
  });

  test(`${backend}: keyboard shortcuts reach the viewer: bones, play/pause, frame step`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    await control(page, 'pause');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.playing === 'false', 'a pause');
    const ds = await dataset(page);
    const [x, y, w, h] = ds.viewport.split(',').map(Number);
    // A click in the view focuses the canvas inside the element's shadow root.
    await page.mouse.click(x + w * 0.9, y + h * 0.9);
    await page.keyboard.press('b');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.overlays === 'skeleton', 'B to show the skeleton');
    await page.keyboard.press('Space');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.playing === 'true', 'space to play');
    await page.keyboard.press('Space');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.playing === 'false', 'space to pause');
    // From a frame boundary (a time read back to 3 decimals near a half frame would make the expected step ambiguous).
    await page.evaluate(() => { document.querySelector('kloub-viewer').currentTime = 0.5; });
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.time === '0.500', 'the seek to 0.5 s');
    await page.keyboard.press('ArrowRight');
    await waitForDataset(page, () => Math.abs(Number(document.querySelector('kloub-viewer').dataset.time) - 16 / 30) < 2e-3, '→ to step a frame', 30000);
  });

  test(`${backend}: Open → Files… in the panel opens a file chooser, and the chosen glTF files show`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    const ds = await dataset(page);
    const panelRight = Number(ds.viewport.split(',')[0]);
    // The panel's header row: "Open" is the rightmost button, then its menu's first item below it.
    await page.mouse.click(panelRight - 28, 18);
    const chooser = page.waitForEvent('filechooser', { timeout: 10000 });
    // The menu is laid out on the next frames (the default clip plays, so frames keep coming): clicked once the
    // panels' mirror lists its item, however busy the machine.
    await openMenuItem(page, 'Files');
    await page.mouse.click(panelRight - 20, 46);
    const picker = await chooser.catch(async (e) => {
      savePng(await viewportShot(page, 'body'), `${backend}-open-menu.png`);
      throw e;
    });
    assert(picker.isMultiple(), 'the file chooser takes several files');
    await picker.setFiles(CESIUM_MAN);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'CesiumMan.gltf' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'CesiumMan from the file chooser');
  });

  test(`${backend}: the Samples menu lists the server's library with credits; a sample loads and the link keeps it`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    // app.js hands /api/assets to the element: every bundled sample, each with its credit.
    await page.waitForFunction(() => document.querySelector('kloub-viewer').samples.length > 0, null, { timeout: 10000 });
    const samples = await page.evaluate(() => document.querySelector('kloub-viewer').samples);
    const names = samples.map((s) => s.name);
    for (const want of ['AnimatedMorphSphere', 'CesiumMan', 'Fox', 'Knight', 'RiggedFigure', 'RobotExpressive']) {
      assert(names.includes(want), `${want} missing from the library: ${names}`);
    }
    assert(samples.every((s) => (s.attribution ?? '').length > 20), 'every sample has a credit line');
    // The menu as a user opens it: "Samples" left of "Open" in the panel's header row, its first entry below.
    const ds = await dataset(page);
    const panelRight = Number(ds.viewport.split(',')[0]);
    await page.mouse.click(panelRight - 80, 18);
    await waitFrames(page, 3);
    await page.waitForTimeout(200);
    const menu = await viewportShot(page, 'body');
    await page.mouse.click(panelRight - 80, 46);
    await waitForDataset(page, () => {
      const d = document.querySelector('kloub-viewer').dataset;
      return d.model === 'AnimatedMorphSphere.glb' && d.status === 'ready';
    }, 'the first sample from the Samples menu').catch((e) => {
      savePng(menu, `${backend}-samples-menu.png`);
      throw e;
    });
    assert((await dataset(page)).src === '/assets/AnimatedMorphSphere/AnimatedMorphSphere.glb', 'data-src is the sample URL');
    // From a page script, by name; the link carries it. CesiumMan comes with its sidecar: example poses sculpted
    // for SJB by example (web/assets/CesiumMan/CesiumMan.kloub.json).
    const cesium = samples.find((s) => s.name === 'CesiumMan');
    assert(cesium.sidecar === '/assets/CesiumMan/CesiumMan.kloub.json', `CesiumMan's sidecar: ${cesium.sidecar}`);
    await control(page, 'loadSample', 'CesiumMan');
    await waitForDataset(page, () => {
      const d = document.querySelector('kloub-viewer').dataset;
      return d.model === 'CesiumMan.glb' && d.status === 'ready' && d.src === '/assets/CesiumMan/CesiumMan.glb#sidecar=/assets/CesiumMan/CesiumMan.kloub.json';
    }, 'CesiumMan by loadSample');
    await page.waitForFunction(() => document.querySelector('kloub-viewer').shadowRoot.querySelector('.kloub-a11y').textContent.includes('Example poses (2)'), null, { timeout: 10000 });
    await page.waitForFunction(() => decodeURIComponent(location.hash).includes('src=/assets/CesiumMan/CesiumMan.glb'), null, { timeout: 10000 });
    const thrown = await page.evaluate(() => {
      try { document.querySelector('kloub-viewer').loadSample('Nobody'); return null; } catch (e) { return `${e.name}: ${e.message}`; }
    });
    assert(thrown?.startsWith('RangeError') && thrown.includes('candy-wrapper') && thrown.includes('RobotExpressive'), `unknown sample: ${thrown}`);
    const link = await page.evaluate(() => location.href);
    await page.goto('about:blank');
    await page.goto(link);
    await waitForDataset(page, () => {
      const d = document.querySelector('kloub-viewer').dataset;
      return d.model === 'CesiumMan.glb' && d.status === 'ready';
    }, 'CesiumMan again from the link');
  });

  test(`${backend}: hostile arguments to every method: no wasm trap, every throw a TypeError/RangeError naming its method`, async (ctx) => {
    const { page } = ctx;
    const before = await openApp(ctx, backend);
    const report = await page.evaluate(async () => {
      const el = document.querySelector('kloub-viewer');
      const hostile = [NaN, Infinity, -Infinity, 1e308, -1e308, 2 ** 53, 1.5, 'x'.repeat(100000), 'no such name', {}, [], [1, 2], null, undefined, true, 10n, Symbol('s'), () => 0];
      // Each method with a valid argument list; every position gets every hostile value, the others staying valid.
      const valid = {
        crossfadeTo: ['Run', 0.2], setLayer: ['Survey', 'b_Neck_04', 0.5], setIkTarget: ['b_Head_05', [0, 1, 0], 2],
        setIkSolver: ['b_Head_05', 'ccd', { iterations: 8 }], playClip: ['Walk'], seek: [0.2], setSpeed: [1],
        setLoop: ['repeat'], setBlend: [['Walk'], [1]], setSkinning: ['lbs'], setSkinningPath: ['gpu'], setHeatmap: [false],
        setGrid: [true], setOverlays: [{ skeleton: false }], stopRagdoll: [0], setRagdollOptions: [{ gravity: 9.81 }],
        selectJoint: ['b_Head_05'], setMorphWeight: ['fox', 0, 0.5], setLighting: ['studio'], setBackground: ['dark'],
        setCopies: [1], loadSample: ['Fox'], setCandyPose: [0, 0], load: [[]],
        setObstacles: [[{ shape: 'sphere', center: [0, 0, 0], radius: 1 }]], setPoseMode: [false], startRagdoll: [{ strength: 0.5 }],
        toBlob: [{ mimeType: 'image/png', qualityArgument: 0.9 }], toDataURL: ['image/png', 0.9],
      };
      const setters = {
        currentTime: 0.1, speed: 1, camera: [0.5, 0.3, 200, 0, 30, 0], loop: 'repeat', skinning: 'lbs', animationName: 'Walk', src: '/models/default.glb',
        background: 'dark', grid: true, alt: 'a model', loading: 'eager', reveal: 'auto',
      };
      const calls = [];
      for (const [method, args] of Object.entries(valid)) {
        for (let pos = 0; pos < args.length; pos++) {
          for (const h of hostile) {
            const a = args.slice();
            a[pos] = h;
            calls.push([method, () => el[method](...a)]);
          }
        }
      }
      for (const [prop] of Object.entries(setters)) for (const h of hostile) calls.push([prop, () => { el[prop] = h; }]);
      // Attributes are strings, so they cannot trap; a bad one reaches the page as an error event (the model stays).
      // Not backend or src: changing them remounts or loads by design.
      const strings = ['NaN', 'Infinity', '-1', '1e308', '', 'x'.repeat(100000), '{}', 'null', 'bogus'];
      for (const name of ['animation-name', 'speed', 'loop', 'crossfade-duration', 'layer-clip', 'layer-root', 'skinning']) {
        for (const h of strings) calls.push([name, () => el.setAttribute(name, h)]);
        calls.push([name, () => el.removeAttribute(name)]);
      }
      let traps = [];
      let bad = [];
      let thrown = 0;
      const check = (method, e) => {
        if (e instanceof WebAssembly.RuntimeError || String(e?.message ?? e).includes('memory access out of bounds') || String(e?.message ?? e).includes('unreachable')) traps.push(`${method}: ${e}`);
        else if (!(e instanceof TypeError || e instanceof RangeError) || !e.message.startsWith(`${method}:`)) bad.push(`${method}: ${e?.constructor?.name} ${String(e?.message ?? e).slice(0, 120)}`);
        else thrown++;
      };
      const pending = [];
      for (const [method, call] of calls) {
        try {
          const r = call();
          if (r instanceof Promise) pending.push(r.catch((e) => { if (!(e instanceof Error)) bad.push(`${method}: rejected with ${typeof e}`); }));
        } catch (e) {
          check(method, e);
        }
      }
      await Promise.race([Promise.all(pending), new Promise((r) => setTimeout(r, 5000))]);
      return { calls: calls.length, thrown, traps, bad };
    });
    assert(report.traps.length === 0, `wasm traps: ${report.traps.slice(0, 5).join('; ')}`);
    assert(report.bad.length === 0, `${report.bad.length} throws that are not TypeError/RangeError naming the method: ${report.bad.slice(0, 8).join('; ')}`);
    assert(report.thrown > report.calls / 2, `only ${report.thrown} of ${report.calls} hostile calls were refused`);
    // The model stays and the viewer still animates (a clip again: playClip(null), a valid call, shows the rest pose).
    await control(page, 'playClip', 'Walk');
    await control(page, 'setSpeed', 1);
    await control(page, 'play');
    await waitFrames(page, 3);
    const after = await dataset(page);
    assert(after.model === before.model, `the model changed: ${before.model} -> ${after.model}`);
    const t0 = Number(after.time);
    await page.waitForFunction((t) => Number(document.querySelector('kloub-viewer').dataset.time) !== t, t0, { timeout: 10000 });
    const errors = ctx.logs.filter((l) => l.startsWith('[pageerror]'));
    assert(errors.length === 0, `page errors: ${errors.slice(0, 3).join('; ')}`);
  });

  test(`${backend}: Open → Folder… takes a whole folder; the .gltf's files resolve inside it`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    const panelRight = Number((await dataset(page)).viewport.split(',')[0]);
    await page.mouse.click(panelRight - 28, 18);
    const chooser = page.waitForEvent('filechooser', { timeout: 10000 });
    await openMenuItem(page, 'Folder');
    await page.mouse.click(panelRight - 20, 70);
    const picker = await chooser;
    // The folder holds the .gltf, its .bin and its texture: relative URIs resolve against the model's folder.
    await picker.setFiles(join(SHARED, 'khronos/CesiumMan/glTF'));
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'CesiumMan.gltf' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'CesiumMan from its folder');
    assert((await dataset(page)).error === '', `error: ${(await dataset(page)).error}`);
  });

  test(`${backend}: load() resolves with the model's name, or rejects with the error and keeps the model`, async (ctx) => {
    const { page } = ctx;
    await recordEvents(page);
    await openApp(ctx, backend);
    const bytes = readFileSync(RIGGED_SIMPLE).toString('base64');
    const name = await page.evaluate(async (b64) => {
      const bin = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
      return document.querySelector('kloub-viewer').load([new File([bin], 'RiggedSimple.glb')]);
    }, bytes);
    assert(name === 'RiggedSimple.glb', `load(files) resolved with ${name}`);
    const message = await page.evaluate(() => document.querySelector('kloub-viewer').load('/assets/missing.glb').then(() => 'resolved', (e) => e.message));
    assert(/missing\.glb/.test(message) && /404/.test(message), `load(url) of a missing file: ${message}`);
    const ds = await dataset(page);
    assert(ds.model === 'RiggedSimple.glb', `the model after the failed load: ${ds.model}`);
  });

  test(`${backend}: the ragdoll falls, settles and hands back to the animation`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    // Every drop starts from one pose (paused at 0.5 s): the simulation runs in fixed steps, so where the body
    // lands does not depend on how busy the machine was when the test paused.
    const atHalf = async () => {
      await control(page, 'seek', 0.5);
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.playing === 'false' && document.querySelector('kloub-viewer').dataset.time === '0.500', 'paused at 0.5 s');
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    };
    await control(page, 'pause');
    await atHalf();
    const standing = await viewportShot(page);
    await control(page, 'setOverlays', { bodies: true });
    await control(page, 'startRagdoll');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === 'simulating', 'the ragdoll to start');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === 'resting', 'the body to settle', 90000);
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const fallen = await viewportShot(page);
    savePng(standing, `${backend}-ragdoll-standing.png`);
    savePng(fallen, `${backend}-ragdoll-fallen.png`);
    const changed = diffFraction(standing, fallen);
    assert(changed > 0.01, `the fall changed only ${(changed * 100).toFixed(2)}% of the viewport`);
    await control(page, 'stopRagdoll', 0.3);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === '', 'the hand-back to the animation', 30000);

    // Obstacles: four slabs around the feet (clear of the standing body), a fifth of its height; dropped again,
    // whichever way it falls it lies on one, higher than on the bare ground.
    const ragdoll = () => page.evaluate(() => document.querySelector('kloub-viewer')._testRagdoll());
    const meanHeight = (r) => r.bodies.reduce((a, b) => a + b[1], 0) / r.bodies.length;
    await atHalf();
    await control(page, 'startRagdoll');
    await page.waitForFunction(() => document.querySelector('kloub-viewer')._testRagdoll() !== null, null, { timeout: 10000 });
    const start = await ragdoll();
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === 'resting', 'the body to settle again', 90000);
    const bare = meanHeight(await ragdoll());
    await control(page, 'stopRagdoll', 0);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === '', 'the ragdoll stopped');
    const height = Math.max(...start.bodies.map((b) => b[1])) - start.ground;
    // The lowest bodies (within a third of the height of the lowest one): never none.
    const lowestY = Math.min(...start.bodies.map((b) => b[1]));
    const low = start.bodies.filter((b) => b[1] <= lowestY + 0.3 * height);
    const [fx0, fx1] = [Math.min(...low.map((b) => b[0])), Math.max(...low.map((b) => b[0]))];
    const [fz0, fz1] = [Math.min(...low.map((b) => b[2])), Math.max(...low.map((b) => b[2]))];
    const g = 0.12 * height;
    const t = 0.2 * height;
    const far = 1.5 * height;
    const y = start.ground + t / 2;
    const box = (xa, xb, za, zb) => ({ shape: 'box', center: [(xa + xb) / 2, y, (za + zb) / 2], size: [xb - xa, t, zb - za] });
    const slabs = [
      box(fx0 - g - far, fx1 + g + far, fz1 + g, fz1 + g + far),
      box(fx0 - g - far, fx1 + g + far, fz0 - g - far, fz0 - g),
      box(fx0 - g - far, fx0 - g, fz0 - g, fz1 + g),
      box(fx1 + g, fx1 + g + far, fz0 - g, fz1 + g),
    ];
    await control(page, 'setObstacles', slabs);
    await waitForDataset(page, () => JSON.parse(document.querySelector('kloub-viewer').dataset.obstacles || '[]').length === 4, 'data-obstacles');
    const bad = await page.evaluate(() => {
      try { document.querySelector('kloub-viewer').setObstacles([{ shape: 'sphere', center: [0, 0, 0], radius: -1 }]); return null; } catch (e) { return `${e.name}: ${e.message}`; }
    });
    assert(bad?.startsWith('RangeError') && bad.includes('/0/radius'), `a bad obstacle: ${bad}`);
    await atHalf();
    await control(page, 'startRagdoll');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === 'resting', 'the body to rest on the slabs', 90000);
    const landed = await ragdoll();
    assert(meanHeight(landed) > bare + 0.25 * t, `on the slabs the bodies rest at ${meanHeight(landed).toFixed(3)} on average, on the bare ground ${bare.toFixed(3)} (slabs ${t.toFixed(3)} high)`);
    // A drag moves an obstacle over the floor: the first slab follows the pointer.
    await control(page, 'stopRagdoll', 0);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === '', 'the ragdoll stopped for the drag');
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const marks = await page.evaluate(() => document.querySelector('kloub-viewer')._testObstacles());
    const corner = await page.evaluate(() => { const r = document.querySelector('kloub-viewer').getBoundingClientRect(); return [r.left, r.top]; });
    const before = JSON.parse((await dataset(page)).obstacles)[0].center;
    const [mx, my] = marks[0];
    await page.mouse.move(corner[0] + mx, corner[1] + my);
    await page.mouse.down();
    for (let i = 1; i <= 6; i++) await page.mouse.move(corner[0] + mx + 8 * i, corner[1] + my + 4 * i);
    await page.mouse.up();
    await page.waitForFunction((b) => {
      const c = JSON.parse(document.querySelector('kloub-viewer').dataset.obstacles || '[]')[0]?.center;
      return c && (c[0] !== b[0] || c[2] !== b[2]) && Math.abs(c[1] - b[1]) < 1e-4;
    }, before, { timeout: 10000 });
    await control(page, 'startRagdoll');
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === 'simulating', 'the ragdoll again');
    // A click in the view throws a ball.
    const ds = await dataset(page);
    const [vx, vy, vw, vh] = ds.viewport.split(',').map(Number);
    await page.mouse.click(vx + vw / 2, vy + vh / 2);
    await page.waitForFunction(() => document.querySelector('kloub-viewer')._testRagdoll()?.balls === 1, null, { timeout: 10000 });
    // Powered at strength 1 (no obstacles): it stands as the clip holds it instead of falling.
    await control(page, 'stopRagdoll', 0);
    await control(page, 'setObstacles', []);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === '' && document.querySelector('kloub-viewer').dataset.obstacles === '', 'back, no obstacles');
    await control(page, 'startRagdoll', { strength: 1 });
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.ragdoll === 'simulating', 'the powered ragdoll');
    await page.waitForTimeout(1500);
    const powered = await ragdoll();
    const poweredTop = Math.max(...powered.bodies.map((b) => b[1]));
    const standingTop = Math.max(...start.bodies.map((b) => b[1]));
    assert(poweredTop > start.ground + 0.8 * (standingTop - start.ground), `the powered ragdoll fell: its highest body at ${poweredTop.toFixed(3)} (standing ${standingTop.toFixed(3)})`);
    assert((await dataset(page)).ragdoll === 'simulating', 'a powered ragdoll does not rest');
    await control(page, 'stopRagdoll', 0);
  });

  test(`${backend}: the URL hash reproduces the exact view`, async (ctx) => {
    const { page } = ctx;
    // A model from a URL (a dropped file has none): the bundled Fox by ?src=.
    await page.goto(`${pageUrl(ctx.url, backend)}${backend === 'webgl2' ? '&' : '?'}src=/assets/Fox.glb`);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'Fox.glb' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'Fox.glb from ?src=');
    await waitFrames(page, 2);
    await control(page, 'crossfadeTo', 'Run', 0);
    await control(page, 'pause');
    await control(page, 'setSpeed', 1.5);
    await control(page, 'setSkinning', 'dqs');
    await control(page, 'setLayer', 'Survey', 'b_Neck_04', 0.6);
    await page.evaluate(() => { document.querySelector('kloub-viewer').camera = [0.9, 0.35, 260, 5, 40, -10]; });
    await control(page, 'setLoop', 'pingpong');
    // Not bounds or copies here: the framing bounds grow with what has played (and size the copies' grid), which
    // a fresh page has not seen; the copies' setting is checked by data-* in the next test.
    await control(page, 'setOverlays', { skeleton: true, normals: true });
    await control(page, 'setBackground', 'light');
    await control(page, 'setLighting', 'rim');
    await control(page, 'setGrid', false);
    await control(page, 'setHeatmap', true);
    await control(page, 'setSkinningPath', 'cpu');
    await control(page, 'seek', 0.3);
    await waitForDataset(page, () => {
      const d = document.querySelector('kloub-viewer').dataset;
      return d.clip === 'Run' && d.time === '0.300' && d.playing === 'false' && d.speed === '1.500' && d.skinning === 'dqs' && d.layer.startsWith('Survey@') && d.camera.startsWith('0.90000,0.35000,260.00000,')
        && d.loop === 'pingpong' && d.overlays === 'skeleton,normals' && d.background === 'light' && d.lighting === 'rim' && d.grid === 'false'
        && d.heatmap === 'true' && d.skinningPath === 'cpu';
    }, 'the view to be set');
    await page.waitForFunction(() => location.hash.includes('camera=0.90000') && location.hash.includes('t=0.300') && location.hash.includes('path=cpu'), null, { timeout: 10000 });
    const hash = await page.evaluate(() => location.hash);
    const before = await dataset(page);
    const shotBefore = await viewportShot(page);
    // A fresh page from the link alone.
    await page.goto('about:blank');
    await page.goto(`${pageUrl(ctx.url, backend)}${hash}`);
    await waitForDataset(page, (t) => {
      const d = document.querySelector('kloub-viewer').dataset;
      return d.model === 'Fox.glb' && d.status === 'ready' && d.time === t && d.camera.startsWith('0.90000,');
    }, 'the view from the hash', 60000, before.time);
    // Paused: the frame that published this state is the last one; two animation frames later it is on screen.
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    const after = await dataset(page);
    for (const key of ['model', 'src', 'clip', 'time', 'playing', 'speed', 'layer', 'skinning', 'skinningPath', 'camera', 'loop', 'overlays', 'background', 'lighting', 'grid', 'heatmap', 'copies']) {
      assert(after[key] === before[key], `${key}: ${before[key]} before, ${after[key]} from the hash (${hash})`);
    }
    const shotAfter = await viewportShot(page);
    savePng(shotBefore, `${backend}-hash-before.png`);
    savePng(shotAfter, `${backend}-hash-after.png`);
    const changed = diffFraction(shotBefore, shotAfter);
    assert(changed < 0.001, `the view from the hash differs in ${(changed * 100).toFixed(3)}% of the viewport`);
  });

  test(`${backend}: the URL hash keeps blend weights, crossfade settings, IK goals with their solver, and held morph weights`, async (ctx) => {
    const { page } = ctx;
    const robot = '/assets/RobotExpressive/RobotExpressive.glb';
    await page.goto(`${pageUrl(ctx.url, backend)}${backend === 'webgl2' ? '&' : '?'}src=${robot}`);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.model === 'RobotExpressive.glb' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'RobotExpressive from ?src=');
    await waitFrames(page, 2);
    await control(page, 'pause');
    await control(page, 'setBlend', ['Walking', 'Wave'], [0.7, 0.3]);
    await control(page, 'setTransition', { duration: 0.6, easing: 'linear', outgoing: 'sync' });
    await control(page, 'setIkTarget', 'Palm2.L', [0.6, 3.2, 1.1], 2);
    await control(page, 'setIkSolver', 'Palm2.L', 'fabrik', { iterations: 24 });
    await control(page, 'setMorphWeight', 'Head', 'Surprised', 0.8);
    await control(page, 'setCopies', 3);
    // setBlend restarts the clocks: pause after it.
    await control(page, 'pause');
    await control(page, 'seek', 0.4);
    const keys = ['model', 'src', 'time', 'playing', 'blend', 'transition', 'ikGoals', 'morphs', 'copies'];
    await waitForDataset(page, () => {
      const d = document.querySelector('kloub-viewer').dataset;
      return d.blend.includes('Wave') && d.transition === '0.600,linear,sync' && d.ikGoals.includes('fabrik') && d.morphs !== '' && d.time === '0.400' && d.copies === '3' && d.playing === 'false';
    }, 'the settings to be mirrored');
    const before = await dataset(page);
    const goals = JSON.parse(before.ikGoals);
    assert(goals.length === 1 && goals[0].effector === 'Palm2.L' && goals[0].depth === 2 && goals[0].iterations === 24, `ikGoals ${before.ikGoals}`);
    assert(before.morphs === '[["Head",1,0.8]]', `morphs ${before.morphs}`);
    await page.waitForFunction(() => location.hash.includes('ik=') && location.hash.includes('morphs=') && location.hash.includes('fade=') && location.hash.includes('blend='), null, { timeout: 10000 });
    const hash = await page.evaluate(() => location.hash);
    await page.goto('about:blank');
    await page.goto(`${pageUrl(ctx.url, backend)}${hash}`);
    await waitForDataset(page, (t) => {
      const d = document.querySelector('kloub-viewer').dataset;
      return d.model === 'RobotExpressive.glb' && d.status === 'ready' && d.time === t && d.ikGoals !== '' && d.morphs !== '' && d.copies === '3';
    }, 'the settings from the hash', 60000, before.time);
    const after = await dataset(page);
    for (const key of keys) assert(after[key] === before[key], `${key}: ${before[key]} before, ${after[key]} from the hash`);
  });

  test(`${backend}: models from other origins: a .glb by ?src=, a multi-file .gltf by src; CORS, 404 and CSP failures say so`, async (ctx) => {
    const { page } = ctx;
    const sep = backend === 'webgl2' ? '&' : '?';
    const other = await startServer({ assets: join(ROOT, 'tests/assets') });
    const dir = mkdtempSync(join(tmpdir(), 'kloub-nocors-'));
    copyFileSync(FOX, join(dir, 'Fox.glb'));
    const plain = await startStatic(dir);
    const narrow = await startServer({ args: ['--connect-src', 'https://cdn.example.com'] });
    const ready = (name) => waitForDataset(page, (n) => {
      const d = document.querySelector('kloub-viewer').dataset;
      return d.model === n && d.status === 'ready';
    }, name, 60000, name);
    const failedLoad = (url) => page.evaluate((u) => document.querySelector('kloub-viewer').load(u).then(() => 'resolved', (e) => e.message), url);
    try {
      const fox = `${other.url}/assets/khronos/Fox/glTF-Binary/Fox.glb`;
      await page.goto(`${pageUrl(ctx.url, backend)}${sep}src=${encodeURIComponent(fox)}`);
      await ready('Fox.glb');
      assert((await dataset(page)).src === fox, 'data-src is the other origin\'s URL');
      // A .gltf fetches its .bin and texture relative to its own URL.
      const gltf = `${other.url}/assets/khronos/CesiumMan/glTF/CesiumMan.gltf`;
      await page.evaluate((u) => { document.querySelector('kloub-viewer').src = u; }, gltf);
      await ready('CesiumMan.gltf');
      await waitFrames(page, 3);
      const colour = saturatedFraction(await viewportShot(page));
      assert(colour > 0.005, `CesiumMan's texture from the other origin: ${(colour * 100).toFixed(2)}% coloured pixels`);
      // A server without CORS headers.
      const noCors = `${plain.url}/Fox.glb`;
      const cors = await failedLoad(noCors);
      assert(cors.includes('CORS') && cors.includes('Access-Control-Allow-Origin') && cors.includes(noCors), `no CORS: ${cors}`);
      assert((await dataset(page)).model === 'CesiumMan.gltf', 'the previous model stays after the CORS failure');
      const missing = await failedLoad(`${other.url}/assets/nope.glb`);
      assert(missing.includes('404') && missing.includes('/assets/nope.glb'), `404: ${missing}`);
      assert((await dataset(page)).model === 'CesiumMan.gltf', 'the previous model stays after the 404');
      // The same links the other way round: ?src= to the .gltf, src to the .glb.
      await page.goto(`${pageUrl(ctx.url, backend)}${sep}src=${encodeURIComponent(gltf)}`);
      await ready('CesiumMan.gltf');
      await page.evaluate((u) => { document.querySelector('kloub-viewer').src = u; }, fox);
      await ready('Fox.glb');
      // Open → URL in the panel, typed as a user would.
      const panelRight = Number((await dataset(page)).viewport.split(',')[0]);
      await page.mouse.click(panelRight - 28, 18);
      await waitFrames(page, 3);
      await page.waitForTimeout(200);
      await page.mouse.click(panelRight - 10, 117);
      await page.waitForTimeout(200);
      await page.keyboard.type(`${other.url}/assets/khronos/RiggedSimple/glTF-Binary/RiggedSimple.glb`);
      await page.keyboard.press('Enter');
      await ready('RiggedSimple.glb').catch(async (e) => {
        savePng(await viewportShot(page, 'body'), `${backend}-open-url.png`);
        throw e;
      });
      // A deployment that narrowed connect-src: its page refuses the other origin, and says so.
      await page.goto(`${pageUrl(narrow.url, backend)}${sep}src=${encodeURIComponent(fox)}`);
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'error', 'the CSP refusal');
      const csp = (await dataset(page)).error;
      assert(csp.includes('Content-Security-Policy') && csp.includes(other.url), `CSP: ${csp}`);
    } finally {
      other.stop();
      plain.stop();
      narrow.stop();
      rmSync(dir, { recursive: true, force: true });
    }
  });

  test(`${backend}: a .gltf whose buffer and texture are absolute URLs on another origin loads them (CORS)`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    const [gltf, bin, jpeg] = CESIUM_MAN;
    const data = mkdtempSync(join(tmpdir(), 'kloub-cdn-'));
    const site = mkdtempSync(join(tmpdir(), 'kloub-site-'));
    copyFileSync(bin, join(data, basename(bin)));
    copyFileSync(jpeg, join(data, basename(jpeg)));
    const cdn = await startStatic(data, { cors: true });
    const doc = JSON.parse(readFileSync(gltf, 'utf8'));
    doc.buffers[0].uri = `${cdn.url}/${basename(bin)}`;
    doc.images[0].uri = `${cdn.url}/${basename(jpeg)}`;
    writeFileSync(join(site, 'CesiumMan.gltf'), JSON.stringify(doc));
    const models = await startStatic(site, { cors: true });
    try {
      const result = await page.evaluate((u) => document.querySelector('kloub-viewer').load(u).then(() => 'loaded', (e) => e.message), `${models.url}/CesiumMan.gltf`);
      assert(result === 'loaded', `load: ${result}`);
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'ready', 'CesiumMan.gltf to be ready');
      await waitFrames(page, 3);
      const colour = saturatedFraction(await viewportShot(page));
      assert(colour > 0.005, `the texture from the absolute URL: ${(colour * 100).toFixed(2)}% coloured pixels`);
    } finally {
      cdn.stop();
      models.stop();
      rmSync(data, { recursive: true, force: true });
      rmSync(site, { recursive: true, force: true });
    }
  });

  test(`${backend}: zip archives: a zipped glTF folder animates, dropped and by URL; two models are listed; a bomb is refused`, async (ctx) => {
    const { page } = ctx;
    await openApp(ctx, backend);
    // A name climbing out of the archive is left out (with a warning); the rest opens.
    const cesium = makeZip([
      ...CESIUM_MAN.map((path) => ({ name: `CesiumMan/glTF/${basename(path)}`, bytes: readFileSync(path) })),
      { name: '../../escape.bin', bytes: Buffer.from('outside') },
    ]);
    await dropFiles(page, [{ name: 'CesiumMan.zip', bytes: cesium }]);
    await waitForDataset(page, () => {
      const d = document.querySelector('kloub-viewer').dataset;
      return d.model === 'CesiumMan.gltf' && d.status === 'ready';
    }, 'CesiumMan from the dropped zip');
    const t0 = Number((await dataset(page)).time);
    await page.waitForFunction((t) => Number(document.querySelector('kloub-viewer').dataset.time) !== t, t0, { timeout: 10000 });
    // Two models: the first is shown, both are listed to switch between.
    const two = makeZip([{ name: 'a/Fox.glb', bytes: readFileSync(FOX) }, { name: 'b/RiggedSimple.glb', bytes: readFileSync(RIGGED_SIMPLE) }]);
    await dropFiles(page, [{ name: 'two.zip', bytes: two }]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.models === '["Fox.glb","RiggedSimple.glb"]', 'both models listed');
    // A bomb: a kilobyte declaring 4 GB. Refused before inflating; Fox stays.
    const bomb = makeZip([{ name: 'huge.glb', bytes: Buffer.alloc(1024), declare: 0xfffffff0 }]);
    assert(bomb.length < 2048, `the bomb is ${bomb.length} bytes`);
    await dropFiles(page, [{ name: 'bomb.zip', bytes: bomb }]);
    await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'error', 'the bomb refused');
    const d = await dataset(page);
    assert(d.error.includes('bomb.zip') && d.error.includes('budget'), `bomb: ${d.error}`);
    assert(d.model === 'Fox.glb', `the model after the bomb: ${d.model}`);
    // By URL from another origin (with CORS): the same archive.
    const dir = mkdtempSync(join(tmpdir(), 'kloub-zip-'));
    writeFileSync(join(dir, 'CesiumMan.zip'), cesium);
    const files = await startStatic(dir, { cors: true });
    try {
      await page.goto(`${pageUrl(ctx.url, backend)}${backend === 'webgl2' ? '&' : '?'}src=${encodeURIComponent(`${files.url}/CesiumMan.zip`)}`);
      await waitForDataset(page, () => {
        const v = document.querySelector('kloub-viewer').dataset;
        return v.model === 'CesiumMan.gltf' && v.status === 'ready';
      }, 'CesiumMan from ?src=….zip');
    } finally {
      files.stop();
      rmSync(dir, { recursive: true, force: true });
    }
  });

  test(`${backend}: a broken file shows an error and keeps the previous model`, async (ctx) => {
    await recordEvents(ctx.page);
    await openApp(ctx, backend);
    await dropFiles(ctx.page, [{ path: FOX }]);
    await waitForDataset(ctx.page, () => document.querySelector('kloub-viewer').dataset.model === 'Fox.glb' && document.querySelector('kloub-viewer').dataset.status === 'ready', 'Fox.glb to load');
    const bytes = Buffer.from('glTF\x02\x00\x00\x00\xff\xff\x00\x00truncated', 'latin1');
    await dropFiles(ctx.page, [{ name: 'broken.glb', bytes }]);
    await waitForDataset(ctx.page, () => (document.querySelector('kloub-viewer').dataset.error ?? '') !== '', 'an error message');
    const ds = await dataset(ctx.page);
    assert(ds.model === 'Fox.glb', `the previous model was replaced: ${ds.model}`);
    assert(ds.error.includes('broken.glb'), `the error does not name the file: ${ds.error}`);
    // Fox keeps playing behind the error: frames keep coming (SwiftShader paints a few per second here).
    const frames = Number(ds.frames);
    const painting = await ctx.page
      .waitForFunction((f) => Number(document.querySelector('kloub-viewer').dataset.frames) >= f + 2, frames, { timeout: 10000, polling: 50 })
      .then(() => true, () => false);
    assert(painting, 'the viewer stopped painting after the error');
    const shot = await viewportShot(ctx.page);
    assert(nonBackgroundFraction(shot) > 0.02, 'the previous model is no longer drawn');
    const errors = await viewerEvents(ctx.page).then((e) => e.filter(([, t]) => t === 'error'));
    assert(errors.length === 1 && errors[0][2].message.includes('broken.glb'), `error events: ${JSON.stringify(errors)}`);
  });
}

test('<kloub-viewer>: changing backend remounts on the other renderer; a removed element stops', async (ctx) => {
  const { page } = ctx;
  await page.goto(`${ctx.url}/embed.html?backend=webgpu`);
  await waitForDataset(page, () => ['left', 'right'].every((id) => document.getElementById(id).dataset.status === 'ready'), 'both viewers');
  await page.evaluate(() => document.getElementById('left').setAttribute('backend', 'webgl2'));
  await waitForDataset(page, () => {
    const d = document.getElementById('left').dataset;
    return d.backend === 'webgl2' && d.status === 'ready' && d.model === 'default.glb';
  }, 'the left viewer on WebGL2');
  assert((await page.evaluate(() => document.getElementById('right').dataset.backend)) === 'webgpu', 'the right viewer changed backend');
  // Removing an element stops its viewer: its frame count no longer moves while the other's does. The element
  // stops on the task after its removal (a move within the page reconnects at once), so frames already under way
  // may still land: count from the point where the other viewer has painted twice since.
  await page.evaluate(() => {
    const right = document.getElementById('right');
    right.remove();
    window.__removed = right;
  });
  const leftFrames = () => page.evaluate(() => Number(document.getElementById('left').dataset.frames));
  const leftSettled = await leftFrames();
  await page.waitForFunction((f) => Number(document.getElementById('left').dataset.frames) >= f + 2, leftSettled, { timeout: 30000 });
  const before = await page.evaluate(() => Number(window.__removed.dataset.frames));
  const left0 = await leftFrames();
  await page.waitForFunction((f) => Number(document.getElementById('left').dataset.frames) >= f + 5, left0, { timeout: 30000 });
  const after = await page.evaluate(() => Number(window.__removed.dataset.frames));
  assert(after === before, `the removed viewer kept painting: ${before} -> ${after}`);
  const errors = ctx.logs.filter((l) => l.startsWith('[pageerror]'));
  assert(errors.length === 0, `page errors: ${errors.join('; ')}`);
});

test('<kloub-viewer>: a panic inside the module: every viewer comes back from its state and says so in an error event', async (ctx) => {
  const { page } = ctx;
  await recordEvents(page);
  await page.goto(`${ctx.url}/embed.html`);
  await waitForDataset(page, () => ['left', 'right'].every((id) => document.getElementById(id).dataset.status === 'ready' && Number(document.getElementById(id).dataset.frames) > 0), 'both viewers');
  await page.evaluate(() => {
    const v = document.getElementById('left');
    v.pause();
    v.currentTime = 0.25;
    v.setSkinning('dqs');
    v.setOverlays({ skeleton: true });
    v.camera = [0.9, 0.3, 300, 0, 40, 0];
  });
  await waitForDataset(page, () => {
    const d = document.getElementById('left').dataset;
    return d.playing === 'false' && d.time === '0.250' && d.skinning === 'dqs' && d.overlays === 'skeleton' && d.camera.startsWith('0.90000,');
  }, 'the left view set up');
  await page.evaluate(() => customElements.get('kloub-viewer')._testPanic('injected by the test'));
  await page.waitForFunction(() => ['left', 'right'].every((id) => window.__kloubEvents.some(([v, t, d]) => v === id && t === 'error' && /recovered from an internal error: [\s\S]*injected by the test/.test(d.message))), null, { timeout: 30000 });
  await waitForDataset(page, () => {
    const [l, r] = ['left', 'right'].map((id) => document.getElementById(id).dataset);
    return l.status === 'ready' && r.status === 'ready' && l.model === 'default.glb' && l.time === '0.250' && l.skinning === 'dqs' && l.camera.startsWith('0.90000,');
  }, 'both viewers back with their state', 60000);
  const d = await page.evaluate(() => ({ ...document.getElementById('left').dataset }));
  assert(d.clip === 'Walk' && d.playing === 'false' && d.overlays === 'skeleton', `left after the panic: ${d.clip} playing ${d.playing} overlays ${d.overlays}`);
  const frames = await page.evaluate(() => Number(document.getElementById('right').dataset.frames));
  // The revived right viewer runs (its Run plays once from the start at half speed, then stops).
  await page.evaluate(() => { const v = document.getElementById('right'); v.currentTime = 0; v.play(); });
  await page.waitForFunction((f) => Number(document.getElementById('right').dataset.frames) >= f + 3, frames, { timeout: 30000 });
  // Methods reach the new instance.
  await page.evaluate(() => document.getElementById('left').setSkinning('sjb'));
  await waitForDataset(page, () => document.getElementById('left').dataset.skinning === 'sjb', 'a method call after the recovery');
});

for (const backend of BACKENDS) test(`${backend}: <kloub-viewer>: loading="lazy" fetches only the models near the view; poster until the first frame (reveal manual: until dismissPoster); progress reaches 1 before load`, async (ctx) => {
  const { page } = ctx;
  const fetched = new Set();
  page.on('request', (r) => { const m = /Fox\.glb\?lazy=(\d+)/.exec(r.url()); if (m) fetched.add(Number(m[1])); });
  await page.setViewportSize({ width: 800, height: 600 });
  await page.goto(`${ctx.url}/embed.html`);
  const posterShown = await page.evaluate((b) => {
    document.body.innerHTML = '';
    document.body.style.margin = '0';
    window.__events = [];
    for (let i = 0; i < 30; i++) {
      const v = document.createElement('kloub-viewer');
      v.id = `v${i}`;
      v.setAttribute('backend', b);
      v.setAttribute('loading', 'lazy');
      v.setAttribute('src', `/assets/Fox.glb?lazy=${i}`);
      v.style.cssText = 'width:300px;height:250px;margin-bottom:150px';
      for (const type of ['progress', 'load', 'poster-dismissed']) v.addEventListener(type, (e) => window.__events.push([i, type, e.detail]));
      document.body.append(v);
    }
    // A poster (a red image) on the first: shown at once, before any frame.
    const red = document.createElement('canvas');
    red.width = 4; red.height = 3;
    const g = red.getContext('2d'); g.fillStyle = 'rgb(220, 20, 20)'; g.fillRect(0, 0, 4, 3);
    const first = document.getElementById('v0');
    first.poster = red.toDataURL('image/png');
    first.reveal = 'manual';
    const img = first.shadowRoot.querySelector('.kloub-poster');
    return !img.hidden && img.getAttribute('src').startsWith('data:image/png');
  }, backend);
  assert(posterShown, 'the poster is not shown before the first frame');
  await page.waitForFunction(() => ['v0', 'v1'].every((id) => document.getElementById(id).dataset.status === 'ready'), null, { timeout: 60000 });
  await page.waitForFunction(() => window.__events.some(([i, t]) => i === 0 && t === 'load'), null, { timeout: 30000 });
  // 400 px per element, 600 px of view plus half a screen below: the first three at most.
  const early = [...fetched].sort((a, b) => a - b);
  assert(early.length >= 2 && early.every((i) => i <= 3), `fetched before scrolling: ${early}`);
  const far = await page.evaluate(() => document.getElementById('v29').dataset.status);
  assert(far === 'waiting', `the last viewer's status before scrolling: ${far}`);
  // progress: 0..1, never down, 1 right before load.
  const events = await page.evaluate(() => window.__events.filter(([i]) => i === 0));
  const progress = events.filter(([, t]) => t === 'progress').map(([, , d]) => d.totalProgress);
  assert(progress.length > 0 && progress.every((p, k) => p >= 0 && p <= 1 && (k === 0 || p >= progress[k - 1])), `progress ${progress}`);
  const loadAt = events.findIndex(([, t]) => t === 'load');
  assert(loadAt > 0 && events[loadAt - 1][1] === 'progress' && events[loadAt - 1][2].totalProgress === 1, `events ${JSON.stringify(events)}`);
  // reveal="manual": the poster stays over the model until dismissPoster().
  const shot = PNG.sync.read(await page.screenshot({ clip: { x: 0, y: 0, width: 300, height: 250 } }));
  const centre = ((125 * 300) + 150) * 4;
  assert(shot.data[centre] > 200 && shot.data[centre + 1] < 40, `the poster is not on screen after load: ${[...shot.data.slice(centre, centre + 3)]}`);
  await page.evaluate(() => document.getElementById('v0').dismissPoster());
  const after = await page.evaluate(() => ({ hidden: document.getElementById('v0').shadowRoot.querySelector('.kloub-poster').hidden, events: window.__events.filter(([i, t]) => i === 0 && t === 'poster-dismissed').length }));
  assert(after.hidden && after.events === 1, `after dismissPoster: ${JSON.stringify(after)}`);
  // Scrolled to the end, the last ones load.
  await page.evaluate(() => document.getElementById('v29').scrollIntoView());
  await page.waitForFunction(() => document.getElementById('v29').dataset.status === 'ready', null, { timeout: 60000 });
  assert(fetched.has(29), 'the last model was not fetched after scrolling to it');
  assert(fetched.size < 30, `every model was fetched (${fetched.size}), not only those scrolled past`);
});

for (const backend of BACKENDS) test(`${backend}: <kloub-viewer>: camera-orbit and camera-target over the framing; camera-controls gates input; auto-rotate turns and waits after interaction; camera-change says who moved it; min/max-camera-orbit, disable-zoom, field-of-view`, async (ctx) => {
  const { page } = ctx;
  await page.setViewportSize({ width: 800, height: 600 });
  await viewersPage(page, ctx.url, [{ attrs: { src: '/assets/Fox.glb', backend }, style: 'width:400px;height:300px' }]);
  // No camera-change can come before the model is shown and a camera attribute changes it.
  await page.evaluate(() => {
    window.__changes = [];
    document.querySelector('kloub-viewer').addEventListener('camera-change', (e) => window.__changes.push(e.detail.source));
  });
  await waitForDataset(page, () => document.querySelector('kloub-viewer').loaded, 'the model');
  const camera = () => page.evaluate(() => document.querySelector('kloub-viewer').camera);
  const framed = await camera();
  const near = (a, b, eps = 1e-3) => Math.abs(a - b) <= eps * Math.max(1, Math.abs(b));
  await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('camera-orbit', '90deg 60deg 150%'));
  await page.waitForFunction((d) => Math.abs(document.querySelector('kloub-viewer').camera[2] - 1.5 * d) < 1e-2 * d, framed[2], { timeout: 30000 });
  let c = await camera();
  assert(near(c[0], Math.PI / 2) && near(c[1], Math.PI / 6) && near(c[2], 1.5 * framed[2], 1e-3), `camera-orbit 90deg 60deg 150%: ${c} (framed ${framed})`);
  await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('camera-target', '0m 50cm 0m'));
  await page.waitForFunction(() => Math.abs(document.querySelector('kloub-viewer').camera[4] - 0.5) < 1e-3, null, { timeout: 30000 });
  c = await camera();
  assert(near(c[3], 0) && near(c[5], 0) && near(c[0], Math.PI / 2), `camera-target 0m 50cm 0m: ${c}`);
  assert((await page.evaluate(() => window.__changes)).every((s) => s === 'none') && (await page.evaluate(() => window.__changes.length)) >= 2, 'camera-change for the attributes');
  // Without camera-controls a drag leaves the camera alone.
  const drag = async () => {
    await page.mouse.move(200, 150);
    await page.mouse.down();
    for (let i = 1; i <= 8; i++) await page.mouse.move(200 + 10 * i, 150 + 4 * i);
    await page.mouse.up();
  };
  const before = await camera();
  const f0 = await page.evaluate(() => Number(document.querySelector('kloub-viewer').dataset.frames));
  await drag();
  // Whatever the drag did is drawn by the next frame (an attribute change asks for one).
  await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('grid', 'false'));
  await page.waitForFunction((f) => Number(document.querySelector('kloub-viewer').dataset.frames) > f, f0, { timeout: 30000 });
  assert(JSON.stringify(await camera()) === JSON.stringify(before), `a drag without camera-controls moved the camera: ${before} → ${await camera()}`);
  // With camera-controls it orbits, and camera-change says the user did it.
  await page.evaluate(() => { document.querySelector('kloub-viewer').setAttribute('camera-controls', ''); window.__changes = []; });
  await drag();
  await page.waitForFunction((b) => document.querySelector('kloub-viewer').camera[0] !== b, before[0], { timeout: 30000 });
  assert((await page.evaluate(() => window.__changes)).includes('user-interaction'), `camera-change sources after a drag: ${await page.evaluate(() => window.__changes)}`);
  // auto-rotate: turns at rotation-per-second once the delay is over; a user drag holds it for the delay again.
  await page.evaluate(() => { const v = document.querySelector('kloub-viewer'); v.setAttribute('rotation-per-second', '90deg'); v.setAttribute('auto-rotate-delay', '3000'); v.setAttribute('auto-rotate', ''); });
  // Turned by more than `by` since yaw `y`: the yaw wraps into [0, 2π), so the difference is taken around the circle
  // (a plain `>` never held once `y + by` passed 2π, which the time a drag takes under load decided).
  const turnedBy = ([y, by]) => {
    const d = (((document.querySelector('kloub-viewer').camera[0] - y) % (2 * Math.PI)) + 2 * Math.PI) % (2 * Math.PI);
    return d > by && d < Math.PI;
  };
  const y0 = (await camera())[0];
  await page.waitForFunction(turnedBy, [y0, 0.3], { timeout: 30000, polling: 100 });
  await drag();
  const held = (await camera())[0];
  await sleep(1000);
  const still = (await camera())[0];
  assert(near(still, held, 1e-6), `auto-rotate kept turning within its delay after a drag: ${held} → ${still}`);
  await page.waitForFunction(turnedBy, [still, 0.1], { timeout: 30000, polling: 100 });
  // min/max-camera-orbit hold every change, camera-orbit's included.
  await page.evaluate(() => {
    const v = document.querySelector('kloub-viewer');
    v.removeAttribute('auto-rotate');
    v.setAttribute('min-camera-orbit', '-30deg auto auto');
    v.setAttribute('max-camera-orbit', '30deg 80deg auto');
    v.setAttribute('camera-orbit', '80deg 20deg auto');
  });
  // The camera eases to the new orbit: wait until both angles arrive (yaw clamped to 30deg; φ 20deg is within the
  // limits, pitch 70deg), or time out if either never does.
  await page.waitForFunction(() => {
    const c = document.querySelector('kloub-viewer').camera;
    return Math.abs(c[0] - Math.PI / 6) < 1e-3 && Math.abs(c[1] - (70 * Math.PI) / 180) < 1e-3;
  }, null, { timeout: 30000, polling: 50 });
  c = await camera();
  // φ at most 80deg: the pitch at least 10deg; φ 20deg asked for is within (pitch 70deg).
  assert(near(c[1], (70 * Math.PI) / 180), `pitch within the limits: ${c}`);
  await drag();
  await sleep(300);
  c = await camera();
  assert(c[0] <= Math.PI / 6 + 1e-4 && c[0] >= -Math.PI / 6 - 1e-4, `a drag left the yaw limits: ${c}`);
  // disable-zoom: the wheel no longer zooms (it did before).
  const wheel = async () => {
    const d = (await camera())[2];
    await page.mouse.move(200, 150);
    // The element has seen the wheel (its canvas's listener ran before this one): the next frame applies it. The
    // frame count is taken inside the listener, before any frame could draw it (read afterwards, a frame drawn for
    // the wheel itself could already be counted, and nothing would ask for another: a timeout under load).
    const seen = page.evaluate(() => new Promise((r) => {
      const v = document.querySelector('kloub-viewer');
      v.addEventListener('wheel', () => {
        const f = Number(v.dataset.frames);
        // A real change (the same value again asks for nothing), so a frame comes after the wheel whatever it did.
        v.setAttribute('grid', v.getAttribute('grid') === 'false' ? 'true' : 'false');
        r(f);
      }, { once: true });
    }));
    await page.mouse.wheel(0, -400);
    const f = await seen;
    await page.waitForFunction((f) => Number(document.querySelector('kloub-viewer').dataset.frames) > f, f, { timeout: 30000 });
    return [d, (await camera())[2]];
  };
  const [d0, d1] = await wheel();
  assert(d1 < d0, `the wheel did not zoom: ${d0} → ${d1}`);
  await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('disable-zoom', ''));
  const [d2, d3] = await wheel();
  assert(d3 === d2, `disable-zoom: the wheel zoomed ${d2} → ${d3}`);
  // field-of-view: a narrower lens at the same distance shows the model larger (at the framed distance: the wheel
  // above zoomed in, and a model filling the view cannot grow by the ratio).
  await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('camera-orbit', 'auto auto 100%'));
  await page.waitForFunction((d) => Math.abs(document.querySelector('kloub-viewer').camera[2] - d) < 1e-3 * d, framed[2], { timeout: 30000 });
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  const cover = async () => nonBackgroundFraction(await viewportShot(page));
  const wide = await cover();
  const f1 = await page.evaluate(() => Number(document.querySelector('kloub-viewer').dataset.frames));
  await page.evaluate(() => document.querySelector('kloub-viewer').setAttribute('field-of-view', '20deg'));
  // The frame that applied it (one: a paused widget draws once per change), then two animation frames to be on screen.
  await page.waitForFunction((f) => Number(document.querySelector('kloub-viewer').dataset.frames) > f, f1, { timeout: 30000 });
  await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  const narrow = await cover();
  assert(narrow > 1.8 * wide, `field-of-view 20deg: the model covers ${(narrow * 100).toFixed(1)}% (45deg: ${(wide * 100).toFixed(1)}%)`);
});

/** Where `point` lands in a view of `aspect` (width / height) seen by `camera` ([yaw, pitch, distance, x, y, z],
 *  an orbit around the target, Y up) with a vertical field of view of `fovDeg`: [x, y] from the view's centre as
 *  fractions of its width and height (−0.5 … 0.5). Written here from the definition, not taken from the viewer. */
function projectFraction(point, camera, fovDeg, aspect) {
  const [yaw, pitch, distance, ...target] = camera;
  const eye = [target[0] + distance * Math.sin(yaw) * Math.cos(pitch), target[1] + distance * Math.sin(pitch), target[2] + distance * Math.cos(yaw) * Math.cos(pitch)];
  const sub = (a, b) => a.map((v, i) => v - b[i]);
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => { const l = Math.hypot(...a); return a.map((v) => v / l); };
  const forward = norm(sub(target, eye));
  const right = norm(cross(forward, [0, 1, 0]));
  const up = cross(right, forward);
  const v = sub(point, eye);
  const depth = dot(v, forward);
  const t = Math.tan((fovDeg * Math.PI) / 360);
  return [dot(v, right) / (depth * t * aspect) / 2, dot(v, up) / (depth * t) / 2];
}

for (const backend of BACKENDS) {
  test(`${backend}: <kloub-viewer>: a model is framed whole and centred at 4:3, 1:1 and 9:16 (its bounds' centre within 2 % of the element's)`, async (ctx) => {
    const { page } = ctx;
    await page.setViewportSize({ width: 800, height: 600 });
    const report = [];
    for (const model of ['Fox.glb', 'CesiumMan/CesiumMan.glb', 'Knight/Knight.glb']) {
      for (const [w, h] of [[400, 300], [300, 300], [225, 400]]) {
        await viewersPage(page, ctx.url, [{ attrs: { src: `/assets/${model}`, 'min-pixel-ratio': '1', backend }, style: `width:${w}px;height:${h}px;border:0;border-radius:0` }],
          'margin:0;background:#fff');
        await waitForDataset(page, () => document.querySelector('kloub-viewer').loaded, model);
        await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
        const name = `${model.split('/').pop()} at ${w}×${h}`;
        // The bounds' centre, projected from the camera the element reports, lands on the element's centre: the
        // view fills the element (no panel, no offset) and the camera aims at the bounds.
        const { centre, camera, view, used } = await page.evaluate(() => {
          const v = document.querySelector('kloub-viewer');
          const c = v.getBoundingBoxCenter();
          return { centre: [c.x, c.y, c.z], camera: v.camera, view: v.dataset.viewport.split(',').map(Number), used: v.dataset.backend };
        });
        assert(used === backend, `${name}: drawn with ${used}`);
        assert(Math.abs(view[0]) < 1 && Math.abs(view[1]) < 1 && Math.abs(view[2] - w) < 1 && Math.abs(view[3] - h) < 1, `${name}: the view is ${view}, not the element`);
        const [fx, fy] = projectFraction(centre, camera, 45, w / h);
        assert(Math.abs(fx) <= 0.02 && Math.abs(fy) <= 0.02, `${name}: the bounds' centre is ${(fx * 100).toFixed(1)} %, ${(fy * 100).toFixed(1)} % off the element's centre`);
        const shot = await viewportShot(page);
        const [x0, y0, x1, y1] = contentBox(shot);
        const box = [x0, y0, x1, y1].map((v) => v.toFixed(3)).join(', ');
        report.push(`${name}: ${box}`);
        // Whole (not cut by an edge), not a speck, and about centred: the box of the silhouette, not of the bounds
        // (a fox's tail or a raised arm moves it off the bounds' centre, which is the view's centre by construction).
        assert(x0 > 0.005 && y0 > 0.005 && x1 < 0.995 && y1 < 0.995, `${name} touches an edge: ${box}`);
        assert(Math.max(x1 - x0, y1 - y0) > 0.3, `${name} is framed too small: ${box}`);
        assert(Math.abs((x0 + x1) / 2 - 0.5) < 0.1 && Math.abs((y0 + y1) / 2 - 0.5) < 0.1, `${name} is off centre: ${box}`);
      }
    }
    console.log(`     framing (${backend}): ${report.join('; ')}`);
  });
}

for (const backend of BACKENDS) test(`${backend}: <kloub-viewer>: interaction-prompt shows a hint to drag after its threshold, gone at the first drag; none shows nothing`, async (ctx) => {
  const { page } = ctx;
  await page.setViewportSize({ width: 800, height: 600 });
  const attrs = { src: '/assets/Fox.glb', 'camera-controls': '', 'interaction-prompt-threshold': '300', backend };
  const style = 'display:inline-block;width:380px;height:280px;border:0';
  await viewersPage(page, ctx.url, [{ id: 'a', attrs, style }, { id: 'b', attrs: { ...attrs, 'interaction-prompt': 'none' }, style }]);
  const shown = (id) => page.evaluate((id) => !document.getElementById(id).shadowRoot.querySelector('.kloub-prompt').hidden, id);
  await waitForDataset(page, () => ['a', 'b'].every((id) => document.getElementById(id).loaded), 'both models');
  await page.waitForFunction(() => !document.getElementById('a').shadowRoot.querySelector('.kloub-prompt').hidden, null, { timeout: 30000 });
  await sleep(500);
  assert(!(await shown('b')), 'interaction-prompt="none" showed the prompt');
  await page.mouse.move(150, 140);
  await page.mouse.down();
  await page.mouse.move(190, 150);
  await page.mouse.up();
  assert(!(await shown('a')), 'the prompt stayed after a drag');
  await sleep(600);
  assert(!(await shown('a')), 'the prompt came back after the user had moved the camera');
});

for (const backend of BACKENDS) test(`${backend}: the app at a phone's width (390×844): the view keeps the full width; the panel is a sheet that opens and closes; one finger orbits, a pinch zooms`, async (ctx) => {
  const { page } = ctx;
  await page.setViewportSize({ width: 390, height: 844 });
  await openApp(ctx, backend);
  let ds = await dataset(page);
  const width = await page.evaluate(() => document.querySelector('kloub-viewer').getBoundingClientRect().width);
  const [, , vw] = ds.viewport.split(',').map(Number);
  assert(ds.panel === 'closed' && Math.abs(vw - width) < 1, `closed: panel ${ds.panel}, view ${vw} of ${width} px`);
  await waitFrames(page, 2);
  const closed = await viewportShot(page);
  savePng(closed, `${backend}-phone-closed.png`);
  const [x0, , x1] = contentBox(closed);
  assert(nonBackgroundFraction(closed) > 0.02 && x1 - x0 > 0.3, `the model across the width: box ${x0.toFixed(3)}..${x1.toFixed(3)}`);
  // The button in the view's corner opens the sheet; its close button closes it.
  await page.mouse.click(30, 24);
  await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.panel === 'open', 'the sheet to open');
  // data-panel changes during the frame that draws the sheet: the page shows it once that frame is presented.
  await waitFrames(page, 2);
  const open = await viewportShot(page);
  savePng(open, `${backend}-phone-open.png`);
  assert(diffFraction(closed, open) > 0.2, 'the sheet is not over the view');
  await page.mouse.click(50, 16);
  await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.panel === 'closed', 'the sheet to close');
  // Touch (Chromium's touch emulation): one finger orbits, two fingers pinching apart zoom in.
  const cdp = await page.context().newCDPSession(page);
  await cdp.send('Emulation.setTouchEmulationEnabled', { enabled: true, maxTouchPoints: 5 });
  await control(page, 'pause');
  const touch = async (type, points) => cdp.send('Input.dispatchTouchEvent', { type, touchPoints: points.map(([x, y], id) => ({ x, y, id })) });
  const cam0 = await page.evaluate(() => document.querySelector('kloub-viewer').camera);
  await touch('touchStart', [[200, 500]]);
  for (let i = 1; i <= 8; i++) { await touch('touchMove', [[200 + 12 * i, 500]]); await sleep(30); }
  await touch('touchEnd', []);
  await page.waitForFunction((y) => Math.abs(document.querySelector('kloub-viewer').camera[0] - y) > 0.1, cam0[0], { timeout: 30000 });
  const cam1 = await page.evaluate(() => document.querySelector('kloub-viewer').camera);
  await touch('touchStart', [[180, 500], [220, 500]]);
  for (let i = 1; i <= 8; i++) { await touch('touchMove', [[180 - 10 * i, 500], [220 + 10 * i, 500]]); await sleep(30); }
  await touch('touchEnd', []);
  await page.waitForFunction((d) => document.querySelector('kloub-viewer').camera[2] < d * 0.9, cam1[2], { timeout: 30000 });
  await cdp.send('Emulation.setTouchEmulationEnabled', { enabled: false });
  await cdp.detach();
  // Back to a wide window: the panel is beside the view again.
  await page.setViewportSize({ width: 1200, height: 800 });
  await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.panel === 'side', 'the side panel');
  ds = await dataset(page);
  assert(Number(ds.viewport.split(',')[0]) > 100, `the view beside the panel: ${ds.viewport}`);
});

test('<kloub-viewer>: only viewers in view draw; out of view an autoplaying one draws nothing and comes back where it would be; a paused one draws nothing', async (ctx) => {
  const { page } = ctx;
  await page.goto(`${ctx.url}/embed.html`);
  await page.evaluate(() => {
    const spacer = document.createElement('div');
    spacer.style.height = '4000px';
    document.body.append(spacer);
  });
  await waitForDataset(page, () => ['left', 'right'].every((id) => document.getElementById(id).dataset.status === 'ready' && Number(document.getElementById(id).dataset.frames) > 0), 'both viewers');
  const frames = (id) => page.evaluate((i) => Number(document.getElementById(i).dataset.frames), id);
  // A paused, untouched viewer draws nothing.
  await page.evaluate(() => document.getElementById('right').pause());
  await waitForDataset(page, () => document.getElementById('right').dataset.playing === 'false', 'right paused');
  await sleep(1000);
  const r0 = await frames('right');
  await sleep(3000);
  const r1 = await frames('right');
  assert(r1 === r0, `the paused viewer drew ${r1 - r0} frames in 3 s`);
  // Out of view, the playing left viewer draws nothing.
  await page.evaluate(() => window.scrollTo(0, 3000));
  await sleep(500);
  const [l0, t0] = await page.evaluate(() => [Number(document.getElementById('left').dataset.frames), performance.now()]);
  await sleep(3000);
  const l1 = await frames('left');
  assert(l1 === l0, `the viewer out of view drew ${l1 - l0} frames in 3 s`);
  const time0 = await page.evaluate(() => Number(document.getElementById('left').dataset.time));
  // Back in view it draws again, its clock moved on by the time away (Walk loops every ~0.7 s: compare in phase).
  await page.evaluate(() => window.scrollTo(0, 0));
  await page.waitForFunction((f) => Number(document.getElementById('left').dataset.frames) >= f + 3, l1, { timeout: 30000 });
  const [time1, t1, duration] = await page.evaluate(() => [Number(document.getElementById('left').dataset.time), performance.now(), document.getElementById('left').duration]);
  assert(time1 !== time0, 'the clock did not move after coming back into view');
  const expected = (time0 + (t1 - t0) / 1000) % duration;
  const off = Math.min(Math.abs(time1 - expected), duration - Math.abs(time1 - expected));
  assert(off < 0.35, `back in view at ${time1.toFixed(3)} s; had it kept playing it would be near ${expected.toFixed(3)} s`);
  assert((await frames('right')) === r1, 'the paused viewer drew while the other scrolled');
});

test('kloub serve --assets: a library without Fox opens its first model; an empty one shows the empty state, no error', async (ctx) => {
  const { page } = ctx;
  const base = mkdtempSync(join(tmpdir(), 'kloub-first-'));
  const [one, empty] = [join(base, 'one'), join(base, 'empty')];
  mkdirSync(join(one, 'figures'), { recursive: true });
  mkdirSync(empty);
  copyFileSync(RIGGED_FIGURE, join(one, 'figures/RiggedFigure.glb'));
  writeFileSync(join(one, 'broken.glb'), 'not a model');
  for (const [dir, want] of [[one, 'RiggedFigure.glb'], [empty, '']]) {
    const server = await startServer({ assets: dir });
    try {
      await page.goto(`${server.url}/`);
      await waitForDataset(page, (w) => {
        const d = document.querySelector('kloub-viewer').dataset;
        return d.status === 'ready' && Number(d.frames) >= 1 && (d.model ?? '') === w;
      }, `the page on ${dir} to settle`, 60000, want);
      await page.waitForTimeout(500);
      const d = await dataset(page);
      assert(d.status === 'ready' && (d.error ?? '') === '', `${dir}: status ${d.status}, error ${d.error}`);
      assert((d.model ?? '') === want, `${dir}: shows ${JSON.stringify(d.model)}, expected ${JSON.stringify(want)}`);
      if (want) assert(d.src === '/assets/figures/RiggedFigure.glb', `data-src ${d.src}`);
    } finally {
      server.stop();
    }
  }
  rmSync(base, { recursive: true, force: true });
});

test('three.js r187 still draws the committed reference pictures of tests/reference (Kloub is compared with them in tests/reference.rs)', async () => {
  const { renderReferences, referenceScenes } = await import('../../scripts/reference-three.mjs');
  const names = referenceScenes();
  assert(names.length >= 5, `reference scenes: ${names.join(', ')}`);
  for (const { name, png } of await renderReferences(names)) {
    const committed = PNG.sync.read(readFileSync(join(ROOT, 'tests/reference', name, 'three.png')));
    assert(committed.width === png.width && committed.height === png.height, `${name}: ${png.width}×${png.height}, committed ${committed.width}×${committed.height}`);
    let differing = 0;
    for (let i = 0; i < png.data.length; i += 4) {
      let d = 0;
      for (let k = 0; k < 4; k++) d = Math.max(d, Math.abs(png.data[i + k] - committed.data[i + k]));
      if (d > 3) differing++;
    }
    const share = differing / (png.width * png.height);
    if (share > 0.002) savePng(png, `reference-${name}-three.png`);
    assert(share <= 0.002, `${name}: ${(share * 100).toFixed(2)}% of the pixels differ from the committed three.png; run node scripts/reference-three.mjs`);
  }
});

test('WebGPU and WebGL2 show the same materials: the reference scenes (metal/rough spheres, normal maps with derived and file tangents, alpha mask and blend) drawn by both backends agree', async (ctx) => {
  const { page } = ctx;
  const shots = {};
  for (const name of ['sphere_grid', 'normal_plane', 'tangent_planes', 'alpha_quads']) {
    const file = join(ROOT, 'tests/out/reference', name, 'scene.glb');
    let bytes;
    try { bytes = readFileSync(file); } catch { throw new Error(`${file} is missing: run \`cargo test -p kloub-tests --test reference\` first (it writes it)`); }
    for (const backend of BACKENDS) {
      await viewersPage(page, ctx.url, [{ attrs: { backend, 'min-pixel-ratio': '1', 'interaction-prompt': 'none', 'shadow-intensity': '0' }, style: 'width:256px;height:256px' }], 'margin:0', backend);
      await waitForDataset(page, () => document.querySelector('kloub-viewer').dataset.status === 'ready', `${backend} viewer`);
      await page.evaluate(async (b64) => {
        const data = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
        await document.querySelector('kloub-viewer').load([new File([data], 'scene.glb')]);
      }, bytes.toString('base64'));
      shots[`${name}/${backend}`] = await dataUrlShot(page);
    }
    if (BACKENDS.length < 2) continue;
    const [a, b] = BACKENDS.map((backend) => shots[`${name}/${backend}`]);
    // Pixels either backend covers, composited over grey; how many differ by more than 12 levels in a channel, and
    // by how much on average. The backends blend differently on purpose (WebGPU in linear light on an sRGB view of its
    // canvas, WebGL2 in gamma space on a plain one, as three.js's WebGL renderer and the browser do): the blended
    // quad of alpha_quads (its blue pixels) is held to a mean difference only; all else matches to rounding.
    const bluish = (i) => [a, b].some((img) => img.data[i + 2] > img.data[i] + 20);
    const compare = (blended) => {
      let covered = 0; let differing = 0; let total = 0;
      for (let y = 0; y < a.height; y++) {
        for (let x = 0; x < a.width; x++) {
          const i = (y * a.width + x) * 4;
          if (a.data[i + 3] === 0 && b.data[i + 3] === 0) continue;
          if (name === 'alpha_quads' && bluish(i) !== blended) continue;
          covered++;
          let d = 0;
          for (let k = 0; k < 3; k++) {
            const over = (img) => img.data[i + k] * img.data[i + 3] / 255 + 128 * (1 - img.data[i + 3] / 255);
            d = Math.max(d, Math.abs(over(a) - over(b)));
          }
          total += d;
          if (d > 12) differing++;
        }
      }
      return { covered, share: differing / Math.max(covered, 1), mean: total / Math.max(covered, 1) };
    };
    const opaque = compare(false);
    console.log(`     ${name}: ${opaque.covered} pixels, ${(opaque.share * 100).toFixed(2)} % differ between ${BACKENDS.join(' and ')}`);
    if (opaque.share > 0.01) { savePng(a, `materials-${name}-${BACKENDS[0]}.png`); savePng(b, `materials-${name}-${BACKENDS[1]}.png`); }
    assert(opaque.covered > 3000, `${name}: only ${opaque.covered} pixels drawn`);
    assert(opaque.share <= 0.01, `${name}: ${(opaque.share * 100).toFixed(2)} % of the pixels differ between the backends`);
    if (name === 'alpha_quads') {
      const blended = compare(true);
      console.log(`     ${name}, blended quad: mean difference ${blended.mean.toFixed(1)} levels`);
      assert(blended.covered > 3000 && blended.mean < 40, `${name}, blended quad: mean difference ${blended.mean.toFixed(1)} levels over ${blended.covered} pixels`);
    }
  }
});

test('hash-state.js: a view round-trips through the hash; malformed keys are dropped', async () => {
  const { viewToHash, hashToView } = await import('../../web/hash-state.js');
  const state = { clip: 'Run', time: '0.300', playing: 'false', speed: '1.500', layer: 'Survey@b_Neck_04:0.60', skinning: 'dqs', camera: '0.9,0.35,260,5,40,-10' };
  const hash = viewToHash(state, '/assets/Fox.glb');
  assert(hash.startsWith('#v=1&'), `versioned: ${hash}`);
  const view = hashToView(hash);
  const want = { src: '/assets/Fox.glb', clip: 'Run', time: 0.3, paused: true, speed: 1.5, layer: { clip: 'Survey', root: 'b_Neck_04', weight: 0.6 }, skinning: 'dqs', camera: [0.9, 0.35, 260, 5, 40, -10] };
  assert(JSON.stringify(view) === JSON.stringify(want), `round trip: ${JSON.stringify(view)}`);
  assert(viewToHash({ playing: 'true', speed: '1.000', skinning: 'lbs' }, null) === '', 'defaults make no hash');
  // Only a chosen skinning path goes into the link (a CPU adapter's default, or the heatmap's, does not).
  assert(viewToHash({ skinningPath: 'cpu', skinningPathChosen: 'false' }, null) === '', 'an unchosen path makes no hash');
  assert(viewToHash({ skinningPath: 'gpu', skinningPathChosen: 'true' }, null) === '#v=1&path=gpu', `a chosen path: ${viewToHash({ skinningPath: 'gpu', skinningPathChosen: 'true' }, null)}`);
  const warnings = [];
  const bad = hashToView('#t=abc&speed=&camera=1,2,3&layer=nothing&clip=&loop=sideways&overlays=skeleton,x&bg=red&grid=2&copies=1000&future=1', (w) => warnings.push(w));
  assert(JSON.stringify(bad) === '{}', `malformed keys kept: ${JSON.stringify(bad)}`);
  assert(warnings.length === 10, `one warning per dropped or unknown key: ${JSON.stringify(warnings)}`);
  const full = { loop: 'once', overlays: 'skeleton,normals', background: 'grey', lighting: 'flat', grid: 'false', heatmap: 'true', copies: '7', skinningPath: 'compute', playing: 'true' };
  const back = hashToView(viewToHash(full, null), () => { throw new Error('no warning expected'); });
  const wantFull = { skinningPath: 'compute', loop: 'once', overlays: { skeleton: true, normals: true }, background: 'grey', lighting: 'flat', grid: false, heatmap: true, copies: 7 };
  assert(JSON.stringify(back) === JSON.stringify(wantFull), `every setting round-trips: ${JSON.stringify(back)}`);
  const zero = hashToView('#camera=0,0,0,0,0,0');
  assert(zero.camera === undefined, 'a zero camera distance is refused');
  // The ragdoll's obstacles, as data-obstacles writes them.
  const obstacles = '[{"shape":"sphere","center":[0,1,0],"radius":0.5},{"shape":"stairs","center":[0,0,2],"size":[1,1,2],"steps":4,"rotation":[0,0,0,1]}]';
  const withObstacles = hashToView(viewToHash({ obstacles, playing: 'true' }, null), () => { throw new Error('no warning expected'); });
  assert(JSON.stringify(withObstacles.obstacles) === obstacles, `obstacles round-trip: ${JSON.stringify(withObstacles)}`);
  const dropped = [];
  assert(hashToView('#obstacles=[{"shape":"cone","center":[0,0,0]}]', (w) => dropped.push(w)).obstacles === undefined && dropped.length === 1, 'an unknown shape is dropped');
});

registerAccessibilityTests(test, BACKENDS);
registerMemoryTests(test, BACKENDS);
registerWidgetTests(test, BACKENDS);

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
