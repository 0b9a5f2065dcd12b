// Ad-hoc: CPU profile of the page's main thread while one <kloub-viewer> animates (self time by function).
import { openBrowser, startServer } from '../tests/browser/lib.mjs';
const backend = process.env.KLOUB_BACKENDS ?? 'webgl2';
const n = Number(process.env.N ?? 1);
const server = await startServer();
const ctx = await openBrowser();
const page = ctx.page;
await page.setViewportSize({ width: 840, height: 640 });
await page.goto(`${server.url}/embed.html`);
await page.evaluate(({ backend }) => {
  document.body.innerHTML = '';
  document.body.style.margin = '0';
  const v = document.createElement('kloub-viewer');
  v.setAttribute('backend', backend);
  v.setAttribute('src', '/assets/Fox.glb');
  v.setAttribute('autoplay', '');
  v.setAttribute('animation-name', 'Run');
  v.setAttribute('min-pixel-ratio', '1');
  v.style.cssText = 'width:800px;height:600px;border:0';
  document.body.append(v);
}, { backend });
await page.waitForFunction(() => document.querySelector('kloub-viewer').dataset.status === 'ready', null, { timeout: 120000 });
if (n > 1) await page.evaluate((n) => document.querySelector('kloub-viewer').setCopies(n), n);
if (process.env.KLOUB_BENCH_EVAL) await page.evaluate((body) => new Function('v', body)(document.querySelector('kloub-viewer')), process.env.KLOUB_BENCH_EVAL);
await new Promise((r) => setTimeout(r, 2000));
const cdp = await page.context().newCDPSession(page);
await cdp.send('Profiler.enable');
await cdp.send('Profiler.setSamplingInterval', { interval: 200 });
const f0 = await page.evaluate(() => Number(document.querySelector('kloub-viewer').dataset.frames));
await cdp.send('Profiler.start');
await new Promise((r) => setTimeout(r, 4000));
const { profile } = await cdp.send('Profiler.stop');
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
console.log(`frames ${frames}, ${(4000 / frames).toFixed(1)} ms/frame; per frame self time (ms):`);
for (const [name, t] of [...self].sort((a, b) => b[1] - a[1]).slice(0, Number(process.env.TOP ?? 40))) console.log((t / frames).toFixed(2).padStart(7), name.slice(0, 140));
await ctx.close();
server.stop();
