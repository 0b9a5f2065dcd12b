// Where a <kloub-viewer> frame goes: a CDP CPU profile of the page's main thread while one element animates Fox's
// Run at 800×600 (self time per frame by function), and the CPU time per frame of each kind of chromium process
// (the GPU process is where SwiftShader draws). A development tool, not part of the tests.
//   KLOUB_BACKENDS=webgl2|webgpu  N=copies  KLOUB_BENCH_EVAL='v.setGrid(true)'  TOP=40
//   node scripts/profile-frame.mjs   (after scripts/build-web.sh and cargo build -p kloub-server)
import { readFileSync, readdirSync } from 'node:fs';
import { openBrowser, startServer, viewersPage } from '../tests/browser/lib.mjs';

/** CPU ms used so far by chromium's processes, by process type (--type=…; the browser process has none). */
function cpuByType() {
  const out = {};
  for (const pid of readdirSync('/proc')) {
    if (!/^[0-9]+$/.test(pid)) continue;
    let stat, cmd;
    try { stat = readFileSync(`/proc/${pid}/stat`, 'utf8'); cmd = readFileSync(`/proc/${pid}/cmdline`, 'utf8'); } catch { continue; }
    const close = stat.lastIndexOf(')');
    if (!/chrom/.test(stat.slice(stat.indexOf('(') + 1, close))) continue;
    const fields = stat.slice(close + 2).split(' ');
    const type = /--type=([a-z-]+)/.exec(cmd)?.[1] ?? 'browser';
    out[type] = (out[type] ?? 0) + (Number(fields[11]) + Number(fields[12])) * 10;
  }
  return out;
}
const backend = process.env.KLOUB_BACKENDS ?? 'webgl2';
const n = Number(process.env.N ?? 1);
const server = await startServer();
const ctx = await openBrowser();
const page = ctx.page;
await page.setViewportSize({ width: 840, height: 640 });
await viewersPage(page, server.url, [{
  attrs: { backend, src: '/assets/Fox.glb', autoplay: '', 'animation-name': 'Run', 'min-pixel-ratio': '1' },
  style: 'width:800px;height:600px;border:0',
}]);
await page.waitForFunction(() => document.querySelector('kloub-viewer').dataset.status === 'ready', null, { timeout: 120000 });
if (n > 1) await page.evaluate((n) => document.querySelector('kloub-viewer').setCopies(n), n);
if (process.env.KLOUB_BENCH_EVAL) await page.evaluate((body) => new Function('v', body)(document.querySelector('kloub-viewer')), process.env.KLOUB_BENCH_EVAL);
await new Promise((r) => setTimeout(r, 2000));
const cdp = await page.context().newCDPSession(page);
await cdp.send('Profiler.enable');
await cdp.send('Profiler.setSamplingInterval', { interval: 200 });
const f0 = await page.evaluate(() => Number(document.querySelector('kloub-viewer').dataset.frames));
const c0 = cpuByType();
await cdp.send('Profiler.start');
await new Promise((r) => setTimeout(r, 4000));
const { profile } = await cdp.send('Profiler.stop');
const c1 = cpuByType();
const f1 = await page.evaluate(() => Number(document.querySelector('kloub-viewer').dataset.frames));
const frames = f1 - f0;
const self = new Map();
const dt = new Map();
for (let i = 0; i < profile.samples.length; i++) dt.set(profile.samples[i], (dt.get(profile.samples[i]) ?? 0) + (profile.timeDeltas[i] ?? 0));
let total = 0;
for (const node of profile.nodes) {
  const t = (dt.get(node.id) ?? 0) / 1000;
  total += t;
  const name = `${node.callFrame.functionName || '(anon)'} ${node.callFrame.url.split('/').pop()}`;
  self.set(name, (self.get(name) ?? 0) + t);
}
console.log(`frames ${frames}, ${(4000 / frames).toFixed(1)} ms/frame; CPU ms per frame by process: ${
  Object.keys(c1).map((k) => `${k} ${((c1[k] - (c0[k] ?? 0)) / frames).toFixed(1)}`).join(', ')}`);
console.log('main thread self time per frame (ms):');
for (const [name, t] of [...self].sort((a, b) => b[1] - a[1]).slice(0, Number(process.env.TOP ?? 40))) console.log((t / frames).toFixed(2).padStart(7), name.slice(0, 140));
await ctx.close();
server.stop();
