// Frame cost of <kloub-viewer> against three.js r187 (the npm dev dependency), side by side in the same headless
// Debian chromium with the same flags, page size, models, counts and backend: an 800×600 canvas showing N copies of
// a character playing one clip, no antialiasing on the three.js side (GLTFLoader's materials), the element without
// `controls` on Kloub's, its adaptive resolution pinned to full size (`min-pixel-ratio="1"`). Prints a Markdown table of milliseconds per frame and the Kloub / three.js ratio.
//
//   scripts/build-web.sh && cargo build -p kloub-server && node scripts/bench-frame.mjs
//
// Frame time = wall time / frames drawn over KLOUB_BENCH_SECONDS (default 4) after a 2 s warm-up; both sides draw
// from requestAnimationFrame, which chromium paces to at most 60 a second (16.7 ms is the floor) and holds back while
// the GPU process (SwiftShader here: the CPU emulates the GPU) has not finished the previous frames, so the figure
// includes the GPU's work. The runs alternate three.js and Kloub per cell, so both see the same machine load.
// KLOUB_BENCH_EVAL: a function body run on the element `v` before measuring, e.g. "v.setGrid(false)".
// KLOUB_BENCH_THREE_IBL=1: three.js lights with an environment map as Kloub does (its RoomEnvironment through PMREM
// as `scene.environment`, plus the directional light) instead of a hemisphere light.
// KLOUB_BENCH_THREE_SHADOW=1: three.js draws a ground shadow as Kloub does (the key light's 512² PCF shadow map,
// every copy casting, a ShadowMaterial ground of opacity 0.6). With both, three.js draws the same kinds of light and
// shadow as Kloub's defaults (not from the same directions: Kloub's key light follows its camera).
// KLOUB_BENCH_SHOTS=<folder>: a screenshot of each page after it is measured.
// KLOUB_BENCH_PERF=<folder>: `perf record` of the GPU process over each measured window, a file per page (gpu-1.data, ...).
// KLOUB_BENCH_AB=<rounds>: Kloub alone, A against B, alternated for that many rounds in the same browser (each round
// measures both, A first in odd rounds and B first in even ones, each page loaded afresh), so that the shared
// machine's slow drifts fall on both alike; prints each round's GPU-process and all-process CPU ms per frame, each
// side's median, and the median of the rounds' B / A ratios (the measure of the difference). B is this build (or
// KLOUB_DIST) with KLOUB_BENCH_EVAL; A is KLOUB_BENCH_AB_DIST (another build's web/dist; default B's) with
// KLOUB_BENCH_AB_EVAL (default none). E.g. what the ground shadow costs: KLOUB_BENCH_AB=6 KLOUB_BENCH_AB_EVAL='v.shadowIntensity = 0'.
// KLOUB_BACKENDS (webgl2,webgpu), KLOUB_BENCH_CASES ("Fox:1,Fox:10,Fox:50,CesiumMan:1,CesiumMan:10,CesiumMan:50").
import { spawn } from 'node:child_process';
import { createServer } from 'node:http';
import { readFileSync, readdirSync, statSync } from 'node:fs';
import { extname, join, resolve } from 'node:path';
import { ROOT, median, openBrowser, startServer } from '../tests/browser/lib.mjs';

const SECONDS = Number(process.env.KLOUB_BENCH_SECONDS ?? 4);
const BACKENDS = (process.env.KLOUB_BACKENDS ?? 'webgl2,webgpu').split(',');
const MODELS = { Fox: ['Fox.glb', 'Run'], CesiumMan: ['CesiumMan/CesiumMan.glb', null] };
const CASES = (process.env.KLOUB_BENCH_CASES ?? 'Fox:1,Fox:10,Fox:50,CesiumMan:1,CesiumMan:10,CesiumMan:50')
  .split(',').map((c) => { const [model, n] = c.split(':'); return { model, n: Number(n) }; });
const WIDTH = Number(process.env.KLOUB_BENCH_WIDTH ?? 800);
const HEIGHT = Number(process.env.KLOUB_BENCH_HEIGHT ?? 600);
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// The three.js page: N clones in a square grid as Kloub places its copies, each with its mixer, seen through the camera
// Kloub framed them with (measured first in each cell; its yaw, pitch, distance and target, 45° vertical field of view).
const THREE_PAGE = `<!doctype html><html><head><meta charset="utf-8">
<style>body{margin:0} canvas{display:block;width:${WIDTH}px;height:${HEIGHT}px}</style>
<script type="importmap">{"imports":{"three":"/three/build/THREE_BUILD","three/addons/":"/three/examples/jsm/"}}</script>
</head><body><script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { RoomEnvironment } from 'three/addons/environments/RoomEnvironment.js';
import * as SkeletonUtils from 'three/addons/utils/SkeletonUtils.js';
const q = new URLSearchParams(location.search);
const n = Number(q.get('n')), clipName = q.get('clip'), webgpu = q.get('backend') === 'webgpu';
const renderer = webgpu ? new THREE.WebGPURenderer({ antialias: false }) : new THREE.WebGLRenderer({ antialias: false });
renderer.setPixelRatio(1);
renderer.setSize(${WIDTH}, ${HEIGHT});
if (webgpu) await renderer.init();
document.body.append(renderer.domElement);
window.backend = webgpu ? (renderer.backend.isWebGPUBackend ? 'webgpu' : 'webgl2-fallback') : 'webgl2';
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x202124);
if (q.get('ibl') === '1') scene.environment = new THREE.PMREMGenerator(renderer).fromScene(new RoomEnvironment(), 0.04).texture;
else scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 1.5));
const sun = new THREE.DirectionalLight(0xffffff, 2);
sun.position.set(1, 2, 1.5);
scene.add(sun);
const gltf = await new GLTFLoader().loadAsync(q.get('model'));
const box = new THREE.Box3().setFromObject(gltf.scene);
const size = box.getSize(new THREE.Vector3());
const side = Math.ceil(Math.sqrt(n));
const rows = Math.ceil(n / side); // Kloub's grid: rows of side copies, centred on the number of rows
const spacing = Math.max(size.x, size.z) * 1.25; // Kloub's copy spacing (over its animated bounds)
const clip = gltf.animations.find((a) => a.name === clipName) ?? gltf.animations[0];
const mixers = [];
for (let i = 0; i < n; i++) {
  const copy = SkeletonUtils.clone(gltf.scene);
  copy.position.set((i % side - (side - 1) / 2) * spacing, 0, (Math.floor(i / side) - (rows - 1) / 2) * spacing);
  scene.add(copy);
  const mixer = new THREE.AnimationMixer(copy);
  mixer.clipAction(clip).play();
  mixers.push(mixer);
}
const extent = Math.max(size.y, spacing * side);
if (q.get('shadow') === '1') {
  // Like Kloub's ground shadow: the key light's 512² shadow map, filtered (PCF; r187 has no PCFSoftShadowMap), every
  // copy casting, a shadow-only ground of opacity 0.6 (Kloub's default shadow-intensity).
  renderer.shadowMap.enabled = true;
  renderer.shadowMap.type = THREE.PCFShadowMap;
  sun.castShadow = true;
  sun.shadow.mapSize.set(512, 512);
  const reach = spacing * side * 0.75 + size.y;
  Object.assign(sun.shadow.camera, { left: -reach, right: reach, top: reach, bottom: -reach, near: 0.01 * reach, far: 10 * reach });
  sun.position.normalize().multiplyScalar(3 * reach); // the same direction, far enough for the shadow camera
  sun.shadow.camera.updateProjectionMatrix();
  scene.traverse((o) => { if (o.isMesh) o.castShadow = true; });
  const ground = new THREE.Mesh(new THREE.PlaneGeometry(2 * reach, 2 * reach), new THREE.ShadowMaterial({ opacity: 0.6 }));
  ground.rotation.x = -Math.PI / 2;
  ground.position.y = box.min.y;
  ground.receiveShadow = true;
  scene.add(ground);
}
const camera = new THREE.PerspectiveCamera(45, ${WIDTH} / ${HEIGHT}, extent * 0.01, extent * 20);
// Kloub's camera (its yaw, pitch, distance and target, 45° vertical field of view): the same framing.
const [yaw, pitch, distance, tx, ty, tz] = (q.get('camera') ?? '').split(',').map(Number);
if (Number.isFinite(distance) && distance > 0) {
  camera.position.set(tx + distance * Math.sin(yaw) * Math.cos(pitch), ty + distance * Math.sin(pitch), tz + distance * Math.cos(yaw) * Math.cos(pitch));
  camera.near = distance * 0.01;
  camera.far = distance * 20;
  camera.updateProjectionMatrix();
  camera.lookAt(tx, ty, tz);
} else {
  camera.position.set(0, size.y * 0.6 + extent * 0.5, extent * 1.6);
  camera.lookAt(0, size.y * 0.4, 0);
}
const clock = new THREE.Clock();
window.frames = 0;
renderer.setAnimationLoop(() => {
  const dt = clock.getDelta();
  for (const m of mixers) m.update(dt);
  renderer.render(scene, camera);
  window.frames++;
});
window.ready = true;
</script></body></html>`;

const MIME = { '.js': 'text/javascript', '.html': 'text/html', '.glb': 'model/gltf-binary' };
function startThreeServer() {
  const three = resolve(ROOT, 'node_modules/three');
  const assets = resolve(ROOT, 'web/assets');
  const server = createServer((req, res) => {
    const url = new URL(req.url, 'http://x');
    const path = decodeURIComponent(url.pathname);
    if (path === '/three.html') {
      const build = url.searchParams.get('backend') === 'webgpu' ? 'three.webgpu.js' : 'three.module.js';
      res.writeHead(200, { 'content-type': 'text/html' }).end(THREE_PAGE.replace('THREE_BUILD', build));
      return;
    }
    const [dir, rest] = path.startsWith('/three/') ? [three, path.slice(7)] : path.startsWith('/assets/') ? [assets, path.slice(8)] : [null, null];
    const file = dir && resolve(dir, rest);
    if (!file || !file.startsWith(dir) || !statSync(file, { throwIfNoEntry: false })?.isFile()) {
      res.writeHead(404).end('not found');
      return;
    }
    res.writeHead(200, { 'content-type': MIME[extname(file)] ?? 'application/octet-stream' }).end(readFileSync(file));
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok({ url: `http://127.0.0.1:${server.address().port}`, stop: () => server.close() })));
}

/** CPU time (ms) used so far by every chromium process, and by the GPU process alone (where SwiftShader draws). */
function browserCpuMs() {
  let ticks = 0;
  let gpu = 0;
  for (const pid of readdirSync('/proc')) {
    if (!/^[0-9]+$/.test(pid)) continue;
    let stat;
    let cmd;
    try { stat = readFileSync(`/proc/${pid}/stat`, 'utf8'); cmd = readFileSync(`/proc/${pid}/cmdline`, 'utf8'); } catch { continue; }
    const close = stat.lastIndexOf(')');
    if (!/chrom/.test(stat.slice(stat.indexOf('(') + 1, close))) continue;
    const fields = stat.slice(close + 2).split(' ');
    const t = Number(fields[11]) + Number(fields[12]);
    ticks += t;
    if (cmd.includes('--type=gpu-process')) gpu += t;
  }
  return { all: ticks * 10, gpu: gpu * 10 }; // USER_HZ is 100 on Linux
}

/**
 * With KLOUB_BENCH_PERF=<folder>: `perf record` of the GPU process (where SwiftShader draws) over the measured window,
 * one file per page measured (`perf report -i <file> --sort dso` says where its CPU time went).
 */
let perfRuns = 0;
function perfGpuProcess() {
  const dir = process.env.KLOUB_BENCH_PERF;
  if (!dir) return Promise.resolve();
  const gpu = readdirSync('/proc').filter((pid) => /^[0-9]+$/.test(pid)).find((pid) => {
    try { return readFileSync(`/proc/${pid}/cmdline`, 'utf8').includes('--type=gpu-process'); } catch { return false; }
  });
  if (!gpu) return Promise.resolve();
  perfRuns += 1;
  const out = join(dir, `gpu-${perfRuns}.data`);
  const child = spawn('perf', ['record', '-q', '-e', 'cpu-clock', '-F', '999', '-p', gpu, '-o', out, '--', 'sleep', String(SECONDS)], { stdio: 'ignore' });
  return new Promise((ok) => child.on('exit', () => { console.error(`bench-frame: perf of the GPU process in ${out}`); ok(); }));
}

/**
 * Frames counted by `count()` (in the page) over SECONDS after the warm-up: wall ms per frame, and CPU ms per frame
 * summed over the browser's processes (what the frame costs the machine, including SwiftShader's GPU work; unlike
 * the wall time it is not rounded up to the 16.7 ms vsync).
 */
async function measure(page, count) {
  await sleep(2000);
  const [t0, f0] = await page.evaluate(count);
  const c0 = browserCpuMs();
  const perf = perfGpuProcess();
  await sleep(SECONDS * 1000);
  await perf;
  const [t1, f1] = await page.evaluate(count);
  const c1 = browserCpuMs();
  const frames = f1 - f0;
  return frames > 0
    ? { wall: (t1 - t0) / frames, cpu: (c1.all - c0.all) / frames, gpu: (c1.gpu - c0.gpu) / frames }
    : { wall: Infinity, cpu: Infinity, gpu: Infinity };
}

/** With KLOUB_BENCH_SHOTS=<folder>: a screenshot of what was measured (to see that both pages show the same). */
async function shot(page, name) {
  const dir = process.env.KLOUB_BENCH_SHOTS;
  if (dir) await page.screenshot({ path: join(dir, `${name}.png`) });
}

async function three(page, base, backend, { model, n }, camera) {
  const [file, clip] = MODELS[model];
  const ibl = process.env.KLOUB_BENCH_THREE_IBL === '1' ? '1' : '0';
  const shadow = process.env.KLOUB_BENCH_THREE_SHADOW === '1' ? '1' : '0';
  await page.goto(`${base}/three.html?backend=${backend}&n=${n}&model=/assets/${file}&clip=${clip ?? ''}&ibl=${ibl}&shadow=${shadow}&camera=${camera.join(',')}`);
  await page.waitForFunction(() => window.ready === true, null, { timeout: 120000 });
  const used = await page.evaluate(() => window.backend);
  if (used !== backend) throw new Error(`three.js used ${used}, not ${backend}`);
  return measure(page, () => [performance.now(), window.frames]);
}

async function kloub(page, base, backend, { model, n }, evalBody = process.env.KLOUB_BENCH_EVAL) {
  const [file, clip] = MODELS[model];
  await page.goto(`${base}/embed.html`);
  await page.evaluate(({ backend, file, clip, w, h }) => {
    document.body.innerHTML = '';
    document.body.style.margin = '0';
    const v = document.createElement('kloub-viewer');
    v.setAttribute('backend', backend);
    v.setAttribute('src', `/assets/${file}`);
    v.setAttribute('autoplay', '');
    if (clip) v.setAttribute('animation-name', clip);
    // The same pixels as three.js: the resolution stays at 1 canvas pixel per CSS pixel however slow the frames.
    v.setAttribute('min-pixel-ratio', '1');
    v.style.cssText = `width:${w}px;height:${h}px;border:0`;
    document.body.append(v);
  }, { backend, file, clip, w: WIDTH, h: HEIGHT });
  await page.waitForFunction(() => document.querySelector('kloub-viewer').dataset.status === 'ready'
    && document.querySelector('kloub-viewer').dataset.clips !== '[]', null, { timeout: 120000 });
  const used = await page.evaluate(() => document.querySelector('kloub-viewer').dataset.backend);
  if (used !== backend) throw new Error(`Kloub used ${used}, not ${backend}`);
  if (evalBody) {
    // An experiment on the element before measuring (e.g. `v.setGrid(false)`), to see what a part of the frame costs.
    await page.evaluate((body) => new Function('v', body)(document.querySelector('kloub-viewer')), evalBody);
  }
  if (n > 1) {
    await page.evaluate((n) => document.querySelector('kloub-viewer').setCopies(n), n);
    await page.waitForFunction((n) => document.querySelector('kloub-viewer').dataset.copies === String(n), n, { timeout: 30000 });
  }
  const result = await measure(page, () => [performance.now(), Number(document.querySelector('kloub-viewer').dataset.frames)]);
  // [yaw, pitch, distance, target x, y, z] (radians, model units; the field of view is 45° vertically).
  result.camera = await page.evaluate(() => document.querySelector('kloub-viewer').camera);
  return result;
}

/** KLOUB_BENCH_AB: A against B in alternating rounds (see the top of this file). */
async function abRounds(rounds) {
  let a = null;
  let b = null;
  try {
    a = process.env.KLOUB_BENCH_AB_DIST ? await startServer({ dist: process.env.KLOUB_BENCH_AB_DIST }) : null;
    b = await startServer();
    for (const backend of BACKENDS) {
      const ctx = await openBrowser();
      try {
        await ctx.page.setViewportSize({ width: WIDTH + 40, height: HEIGHT + 40 });
        for (const c of CASES) {
          const ratios = { gpu: [], cpu: [] };
          const seen = { a: [], b: [] };
          for (let round = 0; round < rounds; round++) {
            const runA = () => kloub(ctx.page, (a ?? b).url, backend, c, process.env.KLOUB_BENCH_AB_EVAL ?? '');
            const runB = () => kloub(ctx.page, b.url, backend, c);
            let ra;
            let rb;
            if (round % 2 === 0) {
              ra = await runA();
              rb = await runB();
            } else {
              rb = await runB();
              ra = await runA();
            }
            seen.a.push(ra);
            seen.b.push(rb);
            // A window that drew no frame reads Infinity: its round gives no ratio.
            if (Number.isFinite(ra.gpu) && Number.isFinite(rb.gpu)) {
              ratios.gpu.push(rb.gpu / ra.gpu);
              ratios.cpu.push(rb.cpu / ra.cpu);
            }
            console.error(`bench-frame A/B: ${backend} ${c.model} ×${c.n} round ${round + 1}: A ${ra.wall.toFixed(1)} ms (CPU ${ra.cpu.toFixed(1)}, GPU process ${ra.gpu.toFixed(1)}), B ${rb.wall.toFixed(1)} ms (CPU ${rb.cpu.toFixed(1)}, GPU process ${rb.gpu.toFixed(1)})`);
          }
          const m = (side, key) => median(seen[side].map((r) => r[key])).toFixed(1);
          const r = (xs) => (xs.length ? median(xs).toFixed(3) : 'n/a');
          console.log(`| ${backend} | ${c.model} ×${c.n} | ${m('a', 'wall')} | ${m('b', 'wall')} | ${m('a', 'gpu')} | ${m('b', 'gpu')} | ${r(ratios.gpu)} | ${m('a', 'cpu')} | ${m('b', 'cpu')} | ${r(ratios.cpu)} |`);
        }
      } finally {
        await ctx.close();
      }
    }
  } finally {
    a?.stop();
    b?.stop();
  }
}

if (process.env.KLOUB_BENCH_AB) {
  console.log(`| Backend (SwiftShader) | Case (${WIDTH}×${HEIGHT}) | A ms (median) | B ms | A GPU-process CPU ms (median) | B | median of the rounds' B / A | A all-process CPU ms (median) | B | median of the rounds' B / A |`);
  console.log('|---|---|---:|---:|---:|---:|---:|---:|---:|---:|');
  await abRounds(Number(process.env.KLOUB_BENCH_AB) || 6);
  process.exit(0);
}

const kloubServer = await startServer();
const threeServer = await startThreeServer();
const rows = [];
try {
  for (const backend of BACKENDS) {
    const ctx = await openBrowser();
    try {
      await ctx.page.setViewportSize({ width: WIDTH + 40, height: HEIGHT + 40 });
      for (const c of CASES) {
        // Kloub first: three.js then looks through the camera Kloub framed (the same pixels covered).
        const k = await kloub(ctx.page, kloubServer.url, backend, c);
        await shot(ctx.page, `${backend}-${c.model}-${c.n}-kloub`);
        const t = await three(ctx.page, threeServer.url, backend, c, k.camera);
        await shot(ctx.page, `${backend}-${c.model}-${c.n}-three`);
        rows.push([backend, `${c.model} ×${c.n}`, t, k]);
        console.error(`bench-frame: ${backend} ${c.model} ×${c.n}: three.js ${t.wall.toFixed(1)} ms (CPU ${t.cpu.toFixed(1)}, GPU process ${t.gpu.toFixed(1)}), Kloub ${k.wall.toFixed(1)} ms (CPU ${k.cpu.toFixed(1)}, GPU process ${k.gpu.toFixed(1)})`);
      }
    } finally {
      await ctx.close();
    }
  }
} finally {
  kloubServer.stop();
  threeServer.stop();
}
console.log(`| Backend (SwiftShader) | Case (${WIDTH}×${HEIGHT}) | three.js r187 ms | Kloub ms | Kloub / three.js | three.js CPU ms | Kloub CPU ms | CPU ratio |`);
console.log('|---|---|---:|---:|---:|---:|---:|---:|');
for (const [backend, name, t, k] of rows) {
  console.log(`| ${backend} | ${name} | ${t.wall.toFixed(1)} | ${k.wall.toFixed(1)} | ${(k.wall / t.wall).toFixed(2)} | ${t.cpu.toFixed(1)} | ${k.cpu.toFixed(1)} | ${(k.cpu / t.cpu).toFixed(2)} |`);
}
