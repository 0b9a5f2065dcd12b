// Splits a light widget build's wasm in two: what a page runs until its viewers' first frames (the first download)
// and the rest (`<name>_rest_bg.wasm`), which the element fetches once a first frame is on screen (at once for a
// model with a sidecar, which only the rest reads). Called by
// scripts/build-web.sh for `kloub_widget` and `kloub_widget_gl` (issue 20: the bytes before the first frame).
//
//   node scripts/wasm-split.mjs <name> <backend: webgpu|webgl2> <bindgen wasm> <bindgen glue> <out dir> <glue out>
//
// 1. binaryen's `wasm-split --instrument` (Debian's binaryen; npm's has no wasm-split) marks each function when it
//    first runs; the element (web/kloub-viewer.js) with that module shows, in the build's headless chromium (the
//    browser tests' own, with their flags), one page at a time (PAGES): one embedded Fox with camera controls, twice
//    (its model served a second late, so the module is ready first, then the module a second late, so the element
//    has the model and its decoded images when the module starts: the two orders take different paths); six models
//    of web/assets on one page; and a page with the attributes viewers commonly set, answered as on a hardware
//    adapter (`__kloubProfileHardware`: SwiftShader is a CPU adapter, where the viewer takes other paths), with
//    input and a viewer removed. Each runs until its viewers drew frames and two seconds more; each page's profile
//    is read out of the module's memory, and they are merged, with every `viewer_*` entry point added (KEEP).
// 2. `wasm-split --profile` keeps the functions that ran in the primary module and moves the others to the secondary.
//    The primary imports a placeholder (namespace `placeholder`, named by its table slot) for each function moved:
//    every call to one goes through the function table. The secondary imports the primary's memory, tables, globals
//    and the functions it calls (exported with the prefix `%`), and its element segment writes its functions over the
//    placeholders when it is instantiated. wasm-opt -Oz (with scripts/wasm-opt.flags: large functions with one caller not inlined)
//    then runs on each (splitting the unoptimised module and
//    optimising each half gives a primary ~60 KB gzip smaller than splitting the optimised one: the whole
//    program's inlining merges functions a first frame needs with ones it does not). Both halves are then
//    instantiated together here: a build whose halves do not link fails.
// 3. The glue (wasm-bindgen's) is given the placeholders: one called before the secondary is there (a function the
//    profile did not see run, e.g. a message for a broken file) loads it synchronously (a synchronous request and
//    compile) and calls the real function, or, if that fails, gives the instance up as a panic would (the element's
//    handler, `setRestFailureHandler`); `loadRest(modulePromise)`, which the element calls once a first frame is
//    shown (before a viewer whose model has a sidecar mounts), instantiates it in the background.
//
// binaryen 108's wasm-split writes the export `__wbindgen_externrefs` (wasm-bindgen's externref table) as the
// function table's; `fixExternrefExport` points it back at the externref table, in the instrumented module and the
// primary.
import { execFileSync } from 'node:child_process';
import { createServer } from 'node:http';
import { mkdtempSync, readFileSync, rmSync, statSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { extname, join, resolve } from 'node:path';
import { chromium } from 'playwright-core';
import { BASE_FLAGS, WEBGPU_FLAGS } from '../tests/browser/lib.mjs';

const ROOT = resolve(import.meta.dirname, '..');
const [name, backend, wasmIn, glueIn, outDir, glueOut] = process.argv.slice(2);
if (!glueOut || !['webgpu', 'webgl2'].includes(backend)) {
  console.error('usage: node scripts/wasm-split.mjs <name> <webgpu|webgl2> <bindgen wasm> <bindgen glue> <out dir> <glue out>');
  process.exit(2);
}
// wasm-opt's flags after -Oz (scripts/wasm-opt.flags, shared with build-web.sh, says why each); the WebAssembly
// features among them also for wasm-split and wasm-dis.
const OPT_FLAGS = readFileSync(join(ROOT, 'scripts/wasm-opt.flags'), 'utf8').split('\n').map((l) => l.trim())
  .filter((l) => l && !l.startsWith('#'));
const FEATURES = OPT_FLAGS.filter((f) => f.startsWith('--enable-'));
// What the first frames are profiled on: skinned, textured (PNG, JPEG), morphed, many clips, a sidecar, normal maps.
const MODELS = ['Fox.glb', 'CesiumMan/CesiumMan.glb', 'RobotExpressive/RobotExpressive.glb',
  'AnimatedMorphSphere/AnimatedMorphSphere.glb', 'RiggedFigure/RiggedFigure.glb', 'Knight/Knight.glb'];

const work = mkdtempSync(join(tmpdir(), `kloub-split-${name}-`));
const run = (cmd, args) => execFileSync(cmd, args, { stdio: ['ignore', 'inherit', 'inherit'] });

/** LEB128 (unsigned) at `i` of `b`: [value, next index]. */
function leb(b, i) {
  let value = 0;
  let shift = 0;
  for (;;) {
    if (i >= b.length) throw new Error('truncated wasm');
    const byte = b[i++];
    value += (byte & 0x7f) * 2 ** shift;
    shift += 7;
    if (byte < 0x80) return [value, i];
  }
}

/** Calls `visit(kind, at)` for each import of the import section starting at `start` (`at`: where its type begins). */
function eachImport(b, start, visit) {
  let n, j;
  [n, j] = leb(b, start);
  for (let k = 0; k < n; k++) {
    let len;
    [len, j] = leb(b, j); j += len;
    [len, j] = leb(b, j); j += len;
    const kind = b[j++];
    visit(kind, j);
    if (kind === 0) [, j] = leb(b, j);
    else if (kind === 1) { j++; const flags = b[j++]; [, j] = leb(b, j); if (flags & 1) [, j] = leb(b, j); }
    else if (kind === 2) { const flags = b[j++]; [, j] = leb(b, j); if (flags & 1) [, j] = leb(b, j); }
    else if (kind === 3) j += 2;
    else throw new Error(`import kind ${kind}`);
  }
}

/** Points the export `__wbindgen_externrefs` at the module's externref table (see the header); the bytes, fixed. */
function fixExternrefExport(path) {
  const b = readFileSync(path);
  const tables = [];
  let fixed = false;
  for (const [id, i] of sections(b)) {
    if (id === 2) { // imported tables come first in the table index space
      eachImport(b, i, (kind, at) => { if (kind === 1) tables.push(b[at]); });
    } else if (id === 4) {
      let n, j;
      [n, j] = leb(b, i);
      for (let k = 0; k < n; k++) { tables.push(b[j++]); const flags = b[j++]; [, j] = leb(b, j); if (flags & 1) [, j] = leb(b, j); }
    } else if (id === 7) {
      let n, j;
      [n, j] = leb(b, i);
      for (let k = 0; k < n; k++) {
        let len;
        [len, j] = leb(b, j);
        const exported = b.toString('latin1', j, j + len);
        j += len;
        const kind = b[j++];
        const at = j;
        let index;
        [index, j] = leb(b, j);
        if (exported === '__wbindgen_externrefs' && kind === 1) {
          const want = tables.indexOf(0x6f);
          if (want < 0 || want > 127 || j - at !== 1) throw new Error(`${path}: externref table ${want}, export at ${index}`);
          b[at] = want;
          fixed = true;
        }
      }
    }
  }
  if (!fixed) throw new Error(`${path}: no table export __wbindgen_externrefs`);
  writeFileSync(path, b);
}

/** Each section of a module: [id, start, end] of its contents. */
function sections(b) {
  const out = [];
  for (let i = 8; i < b.length;) {
    const id = b[i++];
    let size;
    [size, i] = leb(b, i);
    out.push([id, i, i + size]);
    i += size;
  }
  return out;
}

/** The module's imported function count and its functions' names by index (the name section's). */
function functionNames(b) {
  let imported = 0;
  const names = new Map();
  for (const [id, start, end] of sections(b)) {
    if (id === 2) {
      eachImport(b, start, (kind) => { if (kind === 0) imported++; });
    } else if (id === 0) {
      let len, j;
      [len, j] = leb(b, start);
      if (b.toString('latin1', j, j + len) !== 'name') continue;
      j += len;
      while (j < end) {
        const sub = b[j++];
        let size;
        [size, j] = leb(b, j);
        const next = j + size;
        if (sub === 1) {
          let n;
          [n, j] = leb(b, j);
          for (let k = 0; k < n; k++) {
            let index;
            [index, j] = leb(b, j);
            [len, j] = leb(b, j);
            names.set(index, b.toString('utf8', j, j + len));
            j += len;
          }
        }
        j = next;
      }
    }
  }
  return { imported, names };
}

/**
 * The profile with the functions KEEP names marked as run (binaryen's profile: the module's 8-byte hash, then a
 * 32-bit first-call time per defined function, 0 for none), and how many were added.
 */
function keepByName(profileBytes, wasm) {
  const { imported, names } = functionNames(wasm);
  if (names.size === 0) throw new Error('the module has no function names (wasm-bindgen keeps them: was it stripped?)');
  const out = Buffer.from(profileBytes);
  const defined = (out.length - 8) / 4;
  let added = 0;
  for (let i = 0; i < defined; i++) {
    const name = names.get(imported + i) ?? '';
    if (out.readUInt32LE(8 + 4 * i) === 0 && KEEP.some((k) => k.test(name))) {
      out.writeUInt32LE(1, 8 + 4 * i);
      added++;
    }
  }
  return { profile: out, added };
}

/** The name the secondary imports the primary's function table under (`primary`, a funcref table). */
function tableImport(wasm) {
  const modules = WebAssembly.Module.imports(new WebAssembly.Module(wasm));
  const tables = modules.filter((i) => i.module === 'primary' && i.kind === 'table' && i.name !== '__wbindgen_externrefs');
  if (tables.length !== 1) throw new Error(`the second half imports ${tables.length} function tables: ${tables.map((t) => t.name)}`);
  return tables[0].name;
}

/** Instantiates the primary (every import a stub: it has no start function) and the secondary against it. */
function checkLink(primaryBytes, secondaryBytes) {
  const primary = new WebAssembly.Module(primaryBytes);
  const imports = {};
  for (const i of WebAssembly.Module.imports(primary)) {
    if (i.kind !== 'function') throw new Error(`the first half imports a ${i.kind} (${i.module}.${i.name})`);
    (imports[i.module] ??= {})[i.name] = () => { throw new Error(`stub ${i.module}.${i.name} called`); };
  }
  const exports = new WebAssembly.Instance(primary, imports).exports;
  new WebAssembly.Instance(new WebAssembly.Module(secondaryBytes), { primary: exports });
}

const TYPES = { '.js': 'text/javascript', '.wasm': 'application/wasm', '.html': 'text/html', '.json': 'application/json' };
/** Serves `files` (URL path → file) and web/assets under /assets/; files ending in `late` a second late. */
async function serve(files, late) {
  const server = createServer(async (req, res) => {
    const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    if (late && path.endsWith(late)) await new Promise((ok) => setTimeout(ok, 1000));
    let file = files[path];
    if (!file && path.startsWith('/assets/') && !path.includes('..')) file = join(ROOT, 'web', path);
    try {
      if (!file || !statSync(file).isFile()) throw new Error('none');
      // As `kloub serve` answers (a Content-Length: the viewer reads it for its progress and budget).
      const body = readFileSync(file);
      res.writeHead(200, { 'content-type': TYPES[extname(file)] ?? 'application/octet-stream', 'content-length': body.length }).end(body);
    } catch {
      res.writeHead(404).end();
    }
  });
  await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
  return { url: `http://127.0.0.1:${server.address().port}`, close: () => server.close() };
}

/**
 * The pages profiled, each in a fresh page: one embedded viewer with camera controls, its model served late (the
 * module is ready first) and then early (the module is last: the element has the model and its decoded images
 * when the module starts), as the two orders take different paths; then the six models together.
 */
const attr = backend === 'webgl2' ? 'backend="webgl2"' : '';
const ONE = `<kloub-viewer src="/assets/${MODELS[0]}" autoplay camera-controls ${attr} style="display:block;width:640px;height:420px"></kloub-viewer>`;
// What a page's viewers commonly set before their first frame, answered as on a hardware
// adapter (`__kloubProfileHardware`: SwiftShader, which the profile runs on, is a CPU adapter, where the viewer skins
// on the CPU without MSAA; a GPU skins in the vertex shader with 4× MSAA), then input over it and a second viewer
// removed.
const SET = `<script>window.__kloubProfileHardware = true;</script>
<kloub-viewer id="a" src="/assets/CesiumMan/CesiumMan.glb" autoplay camera-controls ${attr}
  exposure="1.2" tone-mapping="aces" shadow-intensity="0.4" shadow-softness="0.3" crossfade-duration="0.4" skinning="lbs"
  speed="1.5" loop="repeat" background="#334455" camera-orbit="30deg 75deg auto" field-of-view="40deg" min-pixel-ratio="0.5"
  alt="a walking man" poster="data:image/gif;base64,R0lGODlhAQABAAAAACw=" style="display:block;width:480px;height:320px"></kloub-viewer>
<kloub-viewer id="b" src="/assets/${MODELS[0]}" autoplay ${attr} style="display:block;width:200px;height:150px"></kloub-viewer>
`;
const PAGES = [
  { body: ONE, late: '.glb' },
  { body: ONE, late: '.wasm' },
  { body: MODELS.map((m) => `<kloub-viewer src="/assets/${m}" autoplay ${attr} style="display:inline-block;width:300px;height:200px"></kloub-viewer>`).join('\n') },
  { body: SET, input: true },
];
/**
 * Functions kept in the first half whether the profile saw them run or not (by name, wasm-bindgen's output keeps
 * the names): every entry point of the element's calls into the module (the work behind each is in the half where
 * the profile found it).
 */
const KEEP = [/^(__wbg_)?viewer_/];

async function profile(instrumented, { body, late, input = false }) {
  const page = join(work, 'page.html');
  writeFileSync(page, `<!doctype html><meta charset="utf-8"><body style="margin:0">
<script type="module" src="/kloub-viewer.js"></script>
${body}`);
  const server = await serve({
    '/page.html': page,
    '/kloub-viewer.js': join(ROOT, 'web/kloub-viewer.js'),
    [`/${name}.js`]: glueIn,
    [`/${name}_bg.wasm`]: instrumented,
  }, late);
  const browser = await chromium.launch({ executablePath: process.env.KLOUB_CHROMIUM ?? '/usr/bin/chromium', headless: true, args: [...BASE_FLAGS, ...WEBGPU_FLAGS] });
  try {
    const tab = await browser.newPage({ viewport: { width: 1024, height: 640 } });
    const logs = [];
    tab.on('console', (m) => logs.push(`[${m.type()}] ${m.text()}`));
    tab.on('pageerror', (e) => logs.push(`[pageerror] ${e.message}`));
    await tab.goto(`${server.url}/page.html`);
    await tab.waitForFunction(() => {
      const views = [...document.querySelectorAll('kloub-viewer')];
      return views.every((v) => v.dataset.status === 'ready' && Number(v.dataset.frames) > 10);
    }, null, { timeout: 180000 }).catch(async (e) => {
      const states = await tab.evaluate(() => [...document.querySelectorAll('kloub-viewer')].map((v) => `${v.getAttribute('src')}: ${v.dataset.status} ${v.dataset.error ?? ''}`));
      throw new Error(`${e.message}\n${states.join('\n')}\n${logs.join('\n')}`);
    });
    if (input) {
      // A pointer over the view, a drag, the wheel, a key; then the second viewer removed.
      const box = await tab.locator('#a').boundingBox();
      await tab.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
      await tab.mouse.down();
      for (let i = 1; i <= 4; i++) await tab.mouse.move(box.x + box.width / 2 + 15 * i, box.y + box.height / 2 + 5 * i);
      await tab.mouse.up();
      await tab.mouse.wheel(0, -120);
      await tab.focus('#a');
      await tab.keyboard.press('ArrowLeft');
      await tab.evaluate(() => document.getElementById('b').remove());
    }
    // Two seconds more: what the first seconds after a first frame run (the adaptive resolution's first change,
    // events) is in the first half too; the second half is still downloading then on a slow link.
    await tab.waitForTimeout(2000);
    const bytes = await tab.evaluate(async (glue) => {
      const exports = await (await import(glue)).default();
      const memory = exports.memory;
      const at = memory.buffer.byteLength;
      memory.grow(4);
      const length = exports.__write_profile(at, 4 * 65536);
      return Array.from(new Uint8Array(memory.buffer, at, length));
    }, `/${name}.js`);
    return Buffer.from(bytes);
  } finally {
    await browser.close();
    server.close();
  }
}

/** wasm-bindgen's glue with the placeholders and `loadRest` (see the header). */
function patchGlue(source, table) {
  const marker = 'const imports = __wbg_get_imports();';
  const count = source.split(marker).length - 1;
  if (count !== 2) throw new Error(`${glueIn}: expected 2 × "${marker}", found ${count}`);
  return `${source.replaceAll(marker, 'const imports = __kloubSplitImports(__wbg_get_imports());')}
// ---- the module's second half (scripts/wasm-split.mjs) ----
const __kloubRestUrl = new URL('${name}_rest_bg.wasm', import.meta.url);
let __kloubRest = null;
let __kloubRestModule = null;
let __kloubRestSync = false;
let __kloubRestFirst = null;
function __kloubSplitImports(imports) {
  imports.placeholder = new Proxy({}, {
    get(_, slot) {
      const index = Number(slot);
      return (...args) => {
        if (__kloubRest === null) __kloubRestFirst ??= index;
        __kloubRestNow();
        return wasm[${JSON.stringify(table)}].get(index)(...args);
      };
    },
  });
  return imports;
}
function __kloubRestInstantiate(module) {
  if (__kloubRest === null) __kloubRest = new WebAssembly.Instance(module, { primary: wasm });
}
let __kloubRestFailure = null;
/**
 * A function of the second half was called before it was here: load it now (synchronously). If that fails (no
 * network, the file missing, a browser that compiles only small modules synchronously), the call cannot go on: the
 * instance is given up as after a panic (the element makes a new one, which loads the second half before its
 * viewers mount), then the error is thrown through the module's frames.
 */
function __kloubRestNow() {
  if (__kloubRest !== null) return;
  try {
    if (__kloubRestModule === null) {
      const request = new XMLHttpRequest();
      request.open('GET', __kloubRestUrl, false);
      request.overrideMimeType('text/plain; charset=x-user-defined');
      request.send();
      if (request.status !== 200) throw new Error(\`\${__kloubRestUrl}: HTTP \${request.status}\`);
      const text = request.responseText;
      const bytes = new Uint8Array(text.length);
      for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i) & 0xff;
      __kloubRestModule = new WebAssembly.Module(bytes);
    }
    __kloubRestInstantiate(__kloubRestModule);
    __kloubRestSync = true;
  } catch (e) {
    const message = \`the module's second half could not be loaded when first needed: \${e instanceof Error ? e.message : e}\`;
    if (__kloubRestFailure !== null) __kloubRestFailure(message);
    throw new Error(message);
  }
}
/** Called with a message when the second half could not be loaded synchronously (the instance is then dead). */
export function setRestFailureHandler(handler) {
  __kloubRestFailure = handler;
}
/** The second half's URL (beside this glue), for the element to fetch and compile. */
export const REST_URL = __kloubRestUrl;
/** The second half's file name (beside this glue), for the element to fetch and compile. */
export const REST_WASM = '${name}_rest_bg.wasm';
/**
 * Instantiates the second half from \`module\` (a promise of its compiled module) once it is here, unless a call
 * needed it first (once: a second call gets the first one's promise). Resolves to how it came: 'async', or 'sync'
 * when a call loaded it before.
 */
let __kloubRestLoading = null;
export function loadRest(module) {
  __kloubRestLoading ??= (async () => {
    const compiled = await module;
    if (wasm === undefined) throw new Error('loadRest before the module is initialised');
    if (__kloubRest === null) {
      __kloubRestModule ??= compiled;
      const instance = await WebAssembly.instantiate(__kloubRestModule, { primary: wasm });
      // A call may have instantiated it meanwhile: either instance's functions are the same code over the same
      // memory, tables and globals (all the primary's); the table holds the last one's.
      __kloubRest ??= instance;
    }
    return __kloubRestSync ? 'sync' : 'async';
  })();
  __kloubRestLoading.catch(() => { __kloubRestLoading = null; });
  return __kloubRestLoading;
}
/** The second half's compiled module once here (null before), for a later instance of the page to reuse. */
export function restModule() {
  return __kloubRestModule;
}
/** Whether the second half is instantiated, and how: null, 'async' or 'sync'. */
export function restState() {
  return __kloubRest === null ? null : __kloubRestSync ? 'sync' : 'async';
}
/** The table slot of the first placeholder called (null if none was): \`target/wasm-bindgen/<name>.placeholders\` names it. */
export function restFirstCall() {
  return __kloubRestFirst;
}
`;
}

try {
  const bg = join(work, 'in.wasm');
  writeFileSync(bg, readFileSync(wasmIn));
  const instrumented = join(work, 'instrumented.wasm');
  run('wasm-split', ['--instrument', bg, '-o', instrumented, ...FEATURES]);
  fixExternrefExport(instrumented);
  const profiles = [];
  for (const [i, body] of PAGES.entries()) {
    profiles.push(join(work, `profile${i}`));
    writeFileSync(profiles[i], await profile(instrumented, body));
  }
  const merged = join(work, 'merged');
  run('wasm-split', ['--merge-profiles', ...profiles, '-o', merged]);
  const prof = join(work, 'profile');
  const kept = keepByName(readFileSync(merged), readFileSync(bg));
  writeFileSync(prof, kept.profile);
  const primary = join(work, 'primary.wasm');
  const secondary = join(work, 'secondary.wasm');
  // KLOUB_SPLIT_NAMES=1 keeps the functions' names in the first half (a page's stack traces then name them: for
  // finding what a page ran before the second half came that the profile did not).
  const names = process.env.KLOUB_SPLIT_NAMES === '1' ? ['-g'] : [];
  run('wasm-split', ['--split', bg, `--profile=${prof}`, '--export-prefix=%', '-o1', primary, '-o2', secondary,
    `--placeholdermap`, ...names, ...FEATURES]);
  // Each placeholder's slot and function, for a page that had to load the second half early (`restFirstCall`).
  writeFileSync(join(resolve(glueOut, '..'), `${name}.placeholders`), readFileSync(`${primary}.placeholders`));
  const wasmOpt = join(ROOT, 'node_modules/.bin/wasm-opt');
  run(wasmOpt, ['-Oz', ...OPT_FLAGS, ...names, primary, '-o', join(outDir, `${name}_bg.wasm`)]);
  fixExternrefExport(join(outDir, `${name}_bg.wasm`));
  run(wasmOpt, ['-Oz', ...OPT_FLAGS, secondary, '-o', join(outDir, `${name}_rest_bg.wasm`)]);
  // A placeholder is a JS function: one taking or returning a v128 could not be called (a TypeError). Rust passes
  // SIMD values through memory, so none has; a change that made one would fail here, not in a page.
  const text = execFileSync(join(ROOT, 'node_modules/.bin/wasm-dis'), [...FEATURES, join(outDir, `${name}_bg.wasm`)], { maxBuffer: 1 << 30 }).toString();
  const vector = text.split('\n').filter((line) => line.includes('(import "placeholder"') && line.includes('v128'));
  if (vector.length > 0) throw new Error(`placeholders with v128 in their signature:\n${vector.slice(0, 5).join('\n')}`);
  // The two halves link (what a page does), and the glue finds the table under the name the second half uses.
  const first = readFileSync(join(outDir, `${name}_bg.wasm`));
  const rest = readFileSync(join(outDir, `${name}_rest_bg.wasm`));
  checkLink(first, rest);
  writeFileSync(glueOut, patchGlue(readFileSync(glueIn, 'utf8'), tableImport(rest)));
  console.log(`wasm-split ${name}: ${first.length} B first, ${rest.length} B after the first frame `
    + `(${kept.added} functions kept by name beside the profile's)`);
} finally {
  rmSync(work, { recursive: true, force: true });
}
