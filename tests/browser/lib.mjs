// Shared helpers for Kloub's browser tests: the real `kloub serve`, Debian chromium via playwright-core.
import { spawn } from 'node:child_process';
import { createServer } from 'node:http';
import { mkdirSync, readFileSync, statSync, writeFileSync } from 'node:fs';
import { crc32, deflateRawSync } from 'node:zlib';
import { basename, join, resolve } from 'node:path';
import { chromium } from 'playwright-core';
import { PNG } from 'pngjs';

export const ROOT = resolve(import.meta.dirname, '../..');
export const SHARED = process.env.KLOUB_SHARED_ASSETS ?? resolve(ROOT, 'tests/assets');

export const BASE_FLAGS = [
  '--headless', '--no-sandbox', '--disable-quic', '--no-first-run', '--disable-background-networking',
  '--disable-component-update', '--disable-sync', '--enable-unsafe-swiftshader',
];
// All four are needed for WebGPU on SwiftShader (see TOOLCHAIN.md).
export const WEBGPU_FLAGS = ['--enable-unsafe-webgpu', '--use-angle=swiftshader', '--enable-features=Vulkan', '--use-vulkan=swiftshader'];

/** Starts `kloub serve` on a free loopback port (the sample library, or `assets`); resolves to { url, stop() }. */
export async function startServer({ assets = join(ROOT, 'web/assets'), args = [], dist } = {}) {
  const bin = join(ROOT, 'target/debug/kloub');
  // KLOUB_DIST: another build's web/dist (benchmarks of an earlier build against this one).
  dist ??= process.env.KLOUB_DIST ?? join(ROOT, 'web/dist');
  const child = spawn(bin, ['serve', '--addr', '127.0.0.1:0', '--dist', dist, '--assets', assets, ...args], {
    stdio: ['ignore', 'pipe', 'pipe'],
  });
  const url = await new Promise((ok, fail) => {
    let out = '';
    const timer = setTimeout(() => fail(new Error(`kloub serve did not start: ${out}`)), 20000);
    const onData = (d) => {
      out += d;
      const m = out.match(/listening on (http:\/\/[0-9.:]+)/);
      if (m) { clearTimeout(timer); ok(m[1]); }
    };
    child.stdout.on('data', onData);
    child.stderr.on('data', onData);
    child.on('exit', (code) => fail(new Error(`kloub serve exited with ${code}: ${out}`)));
  });
  return { url, stop: () => child.kill('SIGINT') };
}

/**
 * A plain static file server for `dir` on a free loopback port, with `Access-Control-Allow-Origin: *` when `cors`
 * (another site's server, or one that forgot CORS); resolves to { url, stop() }. Only GET of files under `dir`.
 */
export async function startStatic(dir, { cors = false } = {}) {
  const server = createServer((req, res) => {
    const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    const file = join(dir, path);
    const headers = cors ? { 'access-control-allow-origin': '*' } : {};
    if (path.includes('..') || !file.startsWith(dir)) { res.writeHead(403, headers).end(); return; }
    try {
      if (!statSync(file).isFile()) throw new Error('not a file');
      res.writeHead(200, { ...headers, 'content-type': 'application/octet-stream' }).end(readFileSync(file));
    } catch {
      res.writeHead(404, headers).end('not found');
    }
  });
  await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
  return { url: `http://127.0.0.1:${server.address().port}`, stop: () => server.close() };
}

/** The median of `xs` (the mean of the middle two for an even count), for the benchmark scripts. */
export function median(xs) {
  const s = [...xs].sort((a, b) => a - b);
  const mid = Math.floor(s.length / 2);
  return s.length % 2 ? s[mid] : (s[mid - 1] + s[mid]) / 2;
}

/** Fraction of pixels with a clearly coloured (saturated) look: a texture, not flat grey shading. */
export function saturatedFraction(img) {
  let n = 0;
  for (let i = 0; i < img.data.length; i += 4) {
    const [r, g, b] = [img.data[i], img.data[i + 1], img.data[i + 2]];
    if (Math.max(r, g, b) - Math.min(r, g, b) > 40) n++;
  }
  return n / (img.width * img.height);
}

/**
 * A zip archive of `entries` ([{ name, bytes }]), deflated; `declare` overrides an entry's declared uncompressed size
 * (a zip bomb's lie) in both of its headers.
 */
export function makeZip(entries) {
  const locals = [];
  const centrals = [];
  let offset = 0;
  for (const { name, bytes, declare } of entries) {
    const data = deflateRawSync(bytes);
    const nameBytes = Buffer.from(name, 'utf8');
    const size = declare ?? bytes.length;
    const head = Buffer.alloc(30);
    head.writeUInt32LE(0x04034b50, 0); head.writeUInt16LE(20, 4); head.writeUInt16LE(0, 6); head.writeUInt16LE(8, 8);
    head.writeUInt16LE(0, 10); head.writeUInt16LE(0x21, 12); head.writeUInt32LE(crc32(bytes), 14);
    head.writeUInt32LE(data.length, 18); head.writeUInt32LE(size, 22); head.writeUInt16LE(nameBytes.length, 26);
    head.writeUInt16LE(0, 28);
    const central = Buffer.alloc(46);
    central.writeUInt32LE(0x02014b50, 0); central.writeUInt16LE(20, 4); central.writeUInt16LE(20, 6);
    central.writeUInt16LE(0, 8); central.writeUInt16LE(8, 10); central.writeUInt16LE(0, 12); central.writeUInt16LE(0x21, 14);
    central.writeUInt32LE(crc32(bytes), 16); central.writeUInt32LE(data.length, 20); central.writeUInt32LE(size, 24);
    central.writeUInt16LE(nameBytes.length, 28); central.writeUInt32LE(offset, 42);
    locals.push(head, nameBytes, data);
    centrals.push(central, nameBytes);
    offset += head.length + nameBytes.length + data.length;
  }
  const cd = Buffer.concat(centrals);
  const end = Buffer.alloc(22);
  end.writeUInt32LE(0x06054b50, 0); end.writeUInt16LE(entries.length, 8); end.writeUInt16LE(entries.length, 10);
  end.writeUInt32LE(cd.length, 12); end.writeUInt32LE(offset, 16);
  return Buffer.concat([...locals, cd, end]);
}

/** Launches chromium for one backend ('webgpu' | 'webgl2'); returns { browser, page, close() }. */
export async function openBrowser() {
  // playwright gives every launch a fresh, empty profile directory of its own.
  const browser = await chromium.launch({
    executablePath: process.env.KLOUB_CHROMIUM ?? '/usr/bin/chromium',
    headless: true,
    args: [...BASE_FLAGS, ...WEBGPU_FLAGS],
  });
  const page = await browser.newPage({ viewport: { width: 1024, height: 640 } });
  const logs = [];
  page.on('console', (m) => logs.push(`[${m.type()}] ${m.text()}`));
  page.on('pageerror', (e) => logs.push(`[pageerror] ${e.message}`));
  return {
    browser, page, logs,
    async close() { await browser.close(); },
  };
}

/** The page URL for a backend: WebGL2 is forced with ?backend=gl even though WebGPU is available. */
export function pageUrl(base, backend) {
  return backend === 'webgl2' ? `${base}/?backend=gl` : `${base}/`;
}

/** Opens the app for `backend` and waits for the default model; resolves to its dataset. */
export async function openApp(ctx, backend) {
  await ctx.page.goto(pageUrl(ctx.url, backend));
  await waitForDataset(ctx.page, () => {
    const d = document.querySelector('kloub-viewer').dataset;
    return d.status === 'ready' && (d.model ?? '') !== '';
  }, 'the default model to be ready');
  const ds = await dataset(ctx.page);
  if (ds.backend !== backend) throw new Error(`expected backend ${backend}, page reports ${ds.backend}`);
  return ds;
}

/** Waits until `predicate(arg)` holds (evaluated in the page); on timeout the error shows the dataset. */
export async function waitForDataset(page, predicate, what, timeout = 60000, arg = null) {
  try {
    await page.waitForFunction(predicate, arg, { timeout, polling: 100 });
  } catch (e) {
    const ds = await page.evaluate(() => ({ ...document.querySelector('kloub-viewer').dataset }));
    throw new Error(`timed out waiting for ${what}; dataset = ${JSON.stringify(ds)}`);
  }
}

export async function dataset(page) {
  return page.evaluate(() => ({ ...document.querySelector('kloub-viewer').dataset }));
}

/** Drops files on the canvas the way a user's drag and drop does (dragenter, dragover, drop). */
export async function dropFiles(page, files) {
  const payload = files.map((f) => ({
    name: f.name ?? basename(f.path),
    b64: (f.bytes ?? readFileSync(f.path)).toString('base64'),
  }));
  await page.evaluate(async (payload) => {
    const dt = new DataTransfer();
    for (const f of payload) {
      const bin = Uint8Array.from(atob(f.b64), (c) => c.charCodeAt(0));
      dt.items.add(new File([bin], f.name, { type: 'application/octet-stream' }));
    }
    const target = document.querySelector('kloub-viewer').shadowRoot.querySelector('canvas');
    for (const type of ['dragenter', 'dragover', 'drop']) {
      target.dispatchEvent(new DragEvent(type, { dataTransfer: dt, bubbles: true, cancelable: true }));
    }
  }, payload);
}

/**
 * Screenshot of the 3D viewport of the viewer matched by `selector` (its rect is published in data-viewport as
 * "x,y,w,h" CSS px of the canvas).
 */
export async function viewportShot(page, selector = 'kloub-viewer') {
  const { viewport, left, top } = await page.evaluate((s) => {
    const el = document.querySelector(s);
    const r = el.getBoundingClientRect();
    return { viewport: el.dataset.viewport, left: r.left, top: r.top };
  }, selector);
  const [x, y, width, height] = (viewport ?? '').split(',').map(Number);
  // Whole pixels: a fractional element size must not make two shots of one view differ in size.
  const clip = width > 0 && height > 0
    ? { x: Math.round(x + left), y: Math.round(y + top), width: Math.floor(width), height: Math.floor(height) } : undefined;
  return PNG.sync.read(await page.screenshot({ clip }));
}

/** The frame of the viewer matched by `selector` as its `toDataURL()` gives it (drawn after the last change), decoded. */
export async function dataUrlShot(page, selector = 'kloub-viewer') {
  const url = await page.evaluate((s) => document.querySelector(s).toDataURL(), selector);
  return PNG.sync.read(Buffer.from(url.replace(/^data:image\/png;base64,/, ''), 'base64'));
}

/** Mean red, green and blue over the opaque pixels of `img` (a model's, over a transparent background). */
export function opaqueMeanRgb(img) {
  const sum = [0, 0, 0]; let n = 0;
  for (let i = 0; i < img.data.length; i += 4) {
    if (img.data[i + 3] !== 255) continue;
    for (let k = 0; k < 3; k++) sum[k] += img.data[i + k];
    n++;
  }
  return sum.map((v) => v / Math.max(n, 1));
}

/**
 * Fraction of pixels whose largest channel difference exceeds `threshold`, over the rows from
 * fraction `top` to fraction `bottom` of the image (default: all of it).
 */
export function diffFraction(a, b, threshold = 16, top = 0, bottom = 1) {
  if (a.width !== b.width || a.height !== b.height) return 1;
  const y0 = Math.floor(top * a.height);
  const y1 = Math.ceil(bottom * a.height);
  let n = 0;
  for (let i = y0 * a.width * 4; i < y1 * a.width * 4; i += 4) {
    const d = Math.max(Math.abs(a.data[i] - b.data[i]), Math.abs(a.data[i + 1] - b.data[i + 1]), Math.abs(a.data[i + 2] - b.data[i + 2]));
    if (d > threshold) n++;
  }
  return n / (a.width * Math.max(1, y1 - y0));
}

/** Waits until the app has painted `n` more frames. */
export async function waitFrames(page, n = 2) {
  const start = Number(await page.evaluate(() => document.querySelector('kloub-viewer').dataset.frames));
  await page.waitForFunction((f) => Number(document.querySelector('kloub-viewer').dataset.frames) >= f, start + n, { timeout: 30000, polling: 50 });
}

/** Calls `method(...args)` on the page's (first) <kloub-viewer>. */
export async function control(page, method, ...args) {
  return page.evaluate(([m, a]) => document.querySelector('kloub-viewer')[m](...a), [method, args]);
}

/** Fraction of pixels that differ from the most common colour (how much of the view is not background). */
export function nonBackgroundFraction(img) {
  const counts = new Map();
  for (let i = 0; i < img.data.length; i += 4 * 7) {
    const key = (img.data[i] >> 3) << 10 | (img.data[i + 1] >> 3) << 5 | (img.data[i + 2] >> 3);
    counts.set(key, (counts.get(key) ?? 0) + 1);
  }
  const total = Math.ceil(img.data.length / (4 * 7));
  return 1 - Math.max(...counts.values()) / total;
}

/** Writes a screenshot under tests/out/browser/ for a person to look at after a failure. */
export function savePng(img, name) {
  const dir = join(ROOT, 'tests/out/browser');
  mkdirSync(dir, { recursive: true });
  writeFileSync(join(dir, name), PNG.sync.write(img));
}

/**
 * Records every event a <kloub-viewer> dispatches (capture listeners on the document, installed before the page
 * loads): `window.__kloubEvents` holds [viewerId, type, detail] in order. Call before `page.goto`.
 */
export async function recordEvents(page) {
  await page.addInitScript(() => {
    window.__kloubEvents = [];
    for (const type of ['load', 'error', 'play', 'pause', 'timeupdate', 'loop', 'finished']) {
      document.addEventListener(type, (e) => {
        if (e.target?.localName === 'kloub-viewer') window.__kloubEvents.push([e.target.id, type, e.detail]);
      }, true);
    }
  });
}

/** The recorded events (see `recordEvents`), optionally only those of one viewer id. */
export async function viewerEvents(page, id = null) {
  const all = await page.evaluate(() => window.__kloubEvents ?? []);
  return id === null ? all : all.filter(([v]) => v === id);
}

/**
 * Opens the server's embed.html and puts `viewers` in place of its body: each `{ id, attrs, style }` becomes a
 * `<kloub-viewer>` with those attributes and inline style; `bodyStyle` is the body's inline style. `backend`: the
 * page's own two viewers start on it (embed.html's `?backend=`), so that the page loads that backend's build first.
 */
export async function viewersPage(page, url, viewers, bodyStyle = 'margin:0', backend = null) {
  await page.goto(`${url}/embed.html${backend ? `?backend=${backend}` : ''}`);
  await page.evaluate(({ viewers, bodyStyle }) => {
    document.body.innerHTML = '';
    document.body.style.cssText = bodyStyle;
    for (const { id, attrs = {}, style = '' } of viewers) {
      const v = document.createElement('kloub-viewer');
      if (id) v.id = id;
      for (const [name, value] of Object.entries(attrs)) v.setAttribute(name, value);
      v.style.cssText = style;
      document.body.append(v);
    }
  }, { viewers, bodyStyle });
}
