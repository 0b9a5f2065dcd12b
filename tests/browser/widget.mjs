// The light widget build: a page with <kloub-viewer> and no `controls` downloads only the widget (its network log),
// within the size budget; the element's methods that need no panels work on it; `controls` set later (or a method
// that needs the full app) moves the viewer to the full app with the same model, clip and time. Registered by run.mjs.
import { existsSync, readFileSync, statSync } from 'node:fs';
import { join } from 'node:path';
import { PNG } from 'pngjs';
import { ROOT, makeZip, saturatedFraction, viewportShot, nonBackgroundFraction } from './lib.mjs';

/** What a page embedding the widget may download before its model, gzip (scripts/widget-size.sh's budget). */
export const WIDGET_BUDGET = 900 * 1024;
/** The module files of each build. */
const FILES = {
  widget: ['kloub_widget.js', 'kloub_widget_bg.wasm'],
  'widget-gl': ['kloub_widget_gl.js', 'kloub_widget_gl_bg.wasm'],
  full: ['kloub_web.js', 'kloub_web_bg.wasm'],
  // Not a build: the decoders (Draco, zip) the widget builds fetch when a file needs them.
  codecs: ['kloub_codecs.js', 'kloub_codecs_bg.wasm'],
};
/** Each light build's second half (scripts/wasm-split.mjs), fetched once a first frame is on screen. */
const REST = { widget: 'kloub_widget_rest_bg.wasm', 'widget-gl': 'kloub_widget_gl_rest_bg.wasm' };
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
function assert(cond, msg) { if (!cond) throw new Error(msg); }

/**
 * Serves a page of the server's origin holding one `<kloub-viewer>` with `attrs` (nothing else loads the element
 * first) and records the file names the page fetches. Resolves to the list (it keeps growing).
 */
async function widgetPage(page, url, attrs, { holdRest = false, base = null } = {}) {
  const fetched = [];
  page.on('request', (r) => fetched.push(new URL(r.url()).pathname.split('/').pop()));
  const attributes = Object.entries(attrs).map(([k, v]) => (v === '' ? k : `${k}="${v}"`)).join(' ');
  // The time of the element's first `load` (its model's first frame on screen), for what was fetched before it;
  // `holdRest`: the light build's second half is held back (a test hook), so a call that needs it must load it;
  // `base`: the document's base URL (a `<base href>`), against which relative URLs resolve.
  await page.route(`${url}/widget-test.html`, (route) => route.fulfill({
    contentType: 'text/html',
    body: `<!doctype html><html><head><meta charset="utf-8">${base ? `<base href="${base}">` : ''}<script type="module" src="/kloub-viewer.js"></script></head>
<body style="margin:0"><kloub-viewer id="v" ${attributes} style="display:block;width:640px;height:420px"></kloub-viewer>
<script type="module">
import '/kloub-viewer.js';
${holdRest ? "customElements.get('kloub-viewer')._testHoldRest(true);" : ''}
document.getElementById('v').addEventListener('load', () => { window.__firstLoadAt ??= performance.now(); });
</script></body></html>`,
  }));
  await page.goto(`${url}/widget-test.html`);
  return fetched;
}

const ds = (page) => page.evaluate(() => ({ ...document.getElementById('v').dataset }));
const waitFor = (page, fn, arg, what, timeout = 60000) =>
  page.waitForFunction(fn, arg, { timeout, polling: 50 }).catch(async (e) => {
    throw new Error(`${what}: ${e.message.split('\n')[0]}; dataset ${JSON.stringify(await ds(page))}`);
  });
const ready = (page) => waitFor(page, () => {
  const d = document.getElementById('v').dataset;
  return d.status === 'ready' && (d.model ?? '') !== '' && Number(d.frames) > 0;
}, null, 'the model to be shown');

/** The files the page requested before the element's first `load` and from then on (its resource timings). */
const aroundLoad = (page) => page.evaluate(() => {
  const at = window.__firstLoadAt ?? Infinity;
  const name = (e) => new URL(e.name).pathname.split('/').pop();
  const entries = performance.getEntriesByType('resource');
  return { before: entries.filter((e) => e.startTime < at).map(name), after: entries.filter((e) => e.startTime >= at).map(name) };
});
const restState = (page) => page.evaluate(() => customElements.get('kloub-viewer')._testRest());
/** Waits for the second half's state to be `state` (waitForFunction does not await a promise). */
async function waitForRest(page, state, timeout = 30000) {
  const end = Date.now() + timeout;
  let now = await restState(page);
  while (now !== state) {
    if (Date.now() > end) throw new Error(`the second half: ${now}, not ${state}, after ${timeout} ms`);
    await sleep(50);
    now = await restState(page);
  }
}

/** The build each fetched module file belongs to. */
function buildsFetched(fetched) {
  return Object.entries(FILES).filter(([, files]) => files.some((f) => fetched.includes(f))).map(([b]) => b);
}

export function registerWidgetTests(test, backends) {
  for (const backend of backends) {
    const attrs = { src: '/models/default.glb', autoplay: '', 'camera-controls': '', ...(backend === 'webgl2' ? { backend: 'webgl2' } : {}) };
    const light = backend === 'webgl2' ? 'widget-gl' : 'widget';

    test(`${backend}: <kloub-viewer> without controls fetches only the light build (within ${WIDGET_BUDGET} B gzip), animates, and its methods work`, async (ctx) => {
      const { page } = ctx;
      const fetched = await widgetPage(page, ctx.url, attrs);
      await ready(page);
      const d0 = await ds(page);
      assert(d0.backend === backend, `backend ${d0.backend}`);
      // The build's second half (what no first frame runs) is fetched after that frame, and instantiated (the test
      // hooks below are in it: called sooner, they would load it themselves).
      const split = (await restState(page)) !== 'whole'; // a KLOUB_WASM_OPT=0 build is not split
      if (split) await waitForRest(page, 'async');
      // The element started the model's download while the module loaded, and had the browser decode Fox's
      // texture meanwhile: the viewer took both (one download, no second decode).
      assert(fetched.filter((f) => f === 'default.glb').length === 1, `the model was fetched ${fetched.filter((f) => f === 'default.glb').length} times`);
      const counters = await page.evaluate(() => customElements.get('kloub-viewer')._testCounters());
      assert(counters.predecoded === 1, `images taken from the prefetch: ${JSON.stringify(counters)}`);
      assert(await page.evaluate(() => customElements.get('kloub-viewer')._testBuild()) === light, 'the page runs the light build');
      assert(JSON.stringify(buildsFetched(fetched)) === JSON.stringify([light]), `module files fetched: ${fetched.filter((f) => /kloub_/.test(f))}`);
      // What the page downloaded of Kloub's files before the model's first frame, as `kloub serve` sends them gzip:
      // within the budget, on both backends (the WebGL2 widget draws through Kloub's own WebGL2 backend, web/src/gl).
      const { before, after } = await aroundLoad(page);
      const ours = [...new Set(before)].filter((f) => existsSync(join(ROOT, 'web/dist', `${f}.gz`)) && !f.endsWith('.html'));
      for (const f of ['kloub-viewer.js', ...FILES[light]]) assert(ours.includes(f), `${f} was not fetched before the first frame: ${ours}`);
      assert(!split || (!before.includes(REST[light]) && after.filter((f) => f === REST[light]).length === 1),
        `the second half: before ${before}, after ${after}; requests ${fetched.filter((f) => /kloub_/.test(f))}; `
        + `first call into it before it came: slot ${await page.evaluate(() => customElements.get('kloub-viewer')._testRestFirstCall())}`);
      const bytes = ours.reduce((sum, f) => sum + statSync(join(ROOT, 'web/dist', `${f}.gz`)).size, 0);
      assert(bytes <= WIDGET_BUDGET, `the ${light} build is ${bytes} B gzip, over its budget of ${WIDGET_BUDGET} B`);
      // It animates: frames keep coming and the time moves.
      const frames = Number(d0.frames);
      await waitFor(page, (f) => Number(document.getElementById('v').dataset.frames) > f + 10, frames, 'frames while playing');
      const shot = await viewportShot(page, '#v');
      assert(nonBackgroundFraction(shot) > 0.02, 'the view shows nothing but background');

      // The element's API without the panels.
      const clips = JSON.parse(d0.clips);
      assert(clips.length >= 2, `clips ${d0.clips}`);
      await page.evaluate((clip) => {
        const v = document.getElementById('v');
        v.pause();
        v.playClip(clip);
        v.pause();
        v.currentTime = 0.5;
        v.speed = 1.5;
        v.setSkinning('dqs');
        v.setGrid(true);
        v.setBackground('light');
        v.setLighting('flat');
        v.setCopies(3);
        v.camera = [0.7, 0.2, 4, 0, 1, 0];
      }, clips[1]);
      await waitFor(page, (clip) => {
        const d = document.getElementById('v').dataset;
        return d.clip === clip && d.playing === 'false' && d.time === '0.500' && d.skinning === 'dqs' && d.grid === 'true'
          && d.background === 'light' && d.lighting === 'flat' && d.copies === '3' && d.camera.startsWith('0.70000,0.20000,4.00000');
      }, clips[1], 'the methods to apply');
      assert(Math.abs((await page.evaluate(() => document.getElementById('v').speed)) - 1.5) < 1e-6, 'speed');
      const dims = await page.evaluate(() => document.getElementById('v').getDimensions());
      assert(dims.x > 0 && dims.y > 0 && dims.z > 0, `getDimensions ${JSON.stringify(dims)}`);
      const blob = await page.evaluate(async () => (await document.getElementById('v').toBlob()).size);
      assert(blob > 1000, `toBlob gave ${blob} B`);
      // screenshot() downloads the frame as a PNG (encoded by the browser in the light builds).
      const [download] = await Promise.all([page.waitForEvent('download'), page.evaluate(() => document.getElementById('v').screenshot())]);
      assert(download.suggestedFilename() === 'default.png', `screenshot file ${download.suggestedFilename()}`);
      const png = PNG.sync.read(readFileSync(await download.path()));
      assert(png.width > 100 && png.height > 100 && nonBackgroundFraction(png) > 0.02, `screenshot ${png.width}×${png.height}`);
      // Camera input: a drag on the canvas orbits, the wheel zooms, a key (Home) goes back to the start.
      const before2 = (await ds(page)).camera.split(',').map(Number);
      const box = await page.locator('#v').boundingBox();
      await page.mouse.move(box.x + 300, box.y + 200);
      await page.mouse.down();
      for (let i = 1; i <= 5; i++) await page.mouse.move(box.x + 300 + i * 20, box.y + 200);
      await page.mouse.up();
      await page.mouse.wheel(0, -200);
      await waitFor(page, (yaw) => Number(document.getElementById('v').dataset.camera.split(',')[0]) !== yaw, before2[0], 'a drag to orbit');
      await waitFor(page, (dist) => Number(document.getElementById('v').dataset.camera.split(',')[2]) < dist, before2[2], 'the wheel to zoom');
      await page.keyboard.press('Home');
      await waitFor(page, () => document.getElementById('v').dataset.time === '0.000', null, 'Home to seek to the start');
      assert(buildsFetched(fetched).length === 1, `still only the light build: ${fetched.filter((f) => /kloub_/.test(f))}`);
      // A panic: the new instance takes the compiled second half (no second download) and the viewer comes back.
      const loads = fetched.filter((f) => f === REST[light]).length;
      await page.evaluate(() => customElements.get('kloub-viewer')._testPanic('test'));
      await waitFor(page, () => document.getElementById('v').dataset.status === 'ready', null, 'the viewer back after a panic');
      if (split) await waitForRest(page, 'async');
      assert(fetched.filter((f) => f === REST[light]).length === loads, 'the second half was downloaded again after the panic');
    });

    test(`${backend}: a call that needs the light build's second half before it came loads it at once, and the view goes on`, async (ctx) => {
      const { page } = ctx;
      const fetched = await widgetPage(page, ctx.url, attrs, { holdRest: true });
      await ready(page);
      if ((await restState(page)) === 'whole') return; // a KLOUB_WASM_OPT=0 build is not split
      await sleep(500);
      assert(await restState(page) === null && !fetched.includes(REST[light]), `held back: ${await restState(page)}, ${fetched}`);
      // Dual quaternion skinning on the CPU path (SwiftShader's default): no profiled first frame ran it.
      const frames = Number((await ds(page)).frames);
      await page.evaluate(() => document.getElementById('v').setSkinning('dqs'));
      await waitFor(page, (f) => {
        const d = document.getElementById('v').dataset;
        return d.skinning === 'dqs' && Number(d.frames) > f + 10;
      }, frames, 'frames skinned with DQS');
      assert(await restState(page) === 'sync', `the second half: ${await restState(page)}`);
      assert(fetched.filter((f) => f === REST[light]).length === 1, `fetched ${fetched.filter((f) => f === REST[light]).length} times`);
      const d = await ds(page);
      assert(d.status === 'ready' && d.error === '', `after the call: ${d.status} ${d.error}`);
      const shot = await viewportShot(page, '#v');
      assert(nonBackgroundFraction(shot) > 0.02, 'the view shows nothing but background');
      // Let go, the element asks for it as usual: no second download or instance.
      await page.evaluate(() => customElements.get('kloub-viewer')._testHoldRest(false));
      await sleep(500);
      assert(await restState(page) === 'sync' && fetched.filter((f) => f === REST[light]).length === 1, 'one second half');
    });

    test(`${backend}: when the second half cannot be loaded as a call needs it, the page recovers as from a panic`, async (ctx) => {
      const { page } = ctx;
      // The first request for the second half fails; the next ones are answered.
      let refused = 0;
      await page.route(new RegExp(`/${REST[light]}$`), (route) => (refused++ === 0 ? route.fulfill({ status: 503, body: 'busy' }) : route.continue()));
      await widgetPage(page, ctx.url, attrs, { holdRest: true });
      await ready(page);
      if ((await restState(page)) === 'whole') return;
      await page.evaluate(() => {
        window.__errors = [];
        document.getElementById('v').addEventListener('error', (e) => window.__errors.push(e.detail.message));
        document.getElementById('v').setSkinning('dqs');
      }).catch(() => {}); // the call itself throws: the instance is given up
      await waitFor(page, () => window.__errors.length > 0, null, 'an error event');
      const errors = await page.evaluate(() => window.__errors);
      assert(errors.some((m) => /second half could not be loaded/.test(m)), `errors: ${errors}`);
      // The new instance loaded the second half before mounting the viewer; the model is back and draws.
      await waitFor(page, () => {
        const d = document.getElementById('v').dataset;
        return d.status === 'ready' && d.model === 'default.glb' && Number(d.frames) > 5;
      }, null, 'the viewer back');
      assert(await restState(page) === 'async', `the second half: ${await restState(page)}`);
      assert(refused >= 2, `requests for the second half: ${refused}`);
      const shot = await viewportShot(page, '#v');
      assert(nonBackgroundFraction(shot) > 0.02, 'the view shows nothing but background');
    });

    test(`${backend}: a model with a sidecar on the light build: the second half comes beside the first, no synchronous load; the sidecar is fetched once and read, both relative to the page's <base>`, async (ctx) => {
      const { page } = ctx;
      // Relative to the document's base URL, as the element and fetch() resolve them (the viewer too).
      const model = 'CesiumMan.glb';
      const fetched = await widgetPage(page, ctx.url, { ...attrs, src: `${model}#sidecar=CesiumMan.kloub.json` }, { base: '/assets/CesiumMan/' });
      await waitFor(page, () => {
        const d = document.getElementById('v').dataset;
        return d.status === 'ready' && d.model === 'CesiumMan.glb' && Number(d.frames) > 0;
      }, null, 'CesiumMan with its sidecar');
      const state = await restState(page);
      if (state === 'whole') return; // a KLOUB_WASM_OPT=0 build is not split
      // Loaded before the viewer asked for it: no call waited for a synchronous download.
      assert(state === 'async', `the second half: ${state}`);
      const first = await page.evaluate(() => customElements.get('kloub-viewer')._testRestFirstCall());
      assert(first === null, `a call into the second half before it came: slot ${first}`);
      const { before } = await aroundLoad(page);
      assert(before.includes(REST[light]) && before.includes('CesiumMan.kloub.json'), `before the first frame: ${before}`);
      for (const f of [REST[light], 'CesiumMan.kloub.json', 'CesiumMan.glb']) {
        assert(fetched.filter((g) => g === f).length === 1, `${f} fetched ${fetched.filter((g) => g === f).length} times`);
      }
      // The sidecar is read: a broken one fails the load with its JSON pointer, and the model stays.
      // Only at the address relative to the model under the page's <base>: one resolved otherwise finds nothing.
      await page.route(`${ctx.url}/assets/CesiumMan/broken.kloub.json`, (route) => route.fulfill({
        contentType: 'application/json',
        body: '{"examples": {"Skeleton_arm_joint_L__3_": [{"rotation": [0, 0, 0, 2], "offsets": ""}]}}',
      }));
      await page.evaluate((src) => {
        window.__errors = [];
        const v = document.getElementById('v');
        v.addEventListener('error', (e) => window.__errors.push(e.detail.message));
        v.src = src;
      }, `${model}#sidecar=broken.kloub.json`);
      await waitFor(page, () => window.__errors.length > 0, null, 'an error event for the broken sidecar');
      const errors = await page.evaluate(() => window.__errors);
      assert(errors.some((m) => m.includes('/examples/Skeleton_arm_joint_L__3_/0')), `errors: ${errors}`);
      const d = await ds(page);
      assert(d.model === 'CesiumMan.glb' && Number(d.frames) > 0, `after the broken sidecar: ${JSON.stringify(d)}`);
      assert(await restState(page) === 'async', 'the second half stayed as it came');
    });

    test(`${backend}: setting controls on a widget loads the full app: the panel appears with the same model, clip and time`, async (ctx) => {
      const { page } = ctx;
      const fetched = await widgetPage(page, ctx.url, attrs);
      await ready(page);
      const clips = JSON.parse((await ds(page)).clips);
      await page.evaluate((clip) => {
        const v = document.getElementById('v');
        v.playClip(clip);
        v.pause();
        v.currentTime = 0.5;
        v.camera = [0.4, 0.1, 5, 0, 0.8, 0];
      }, clips[1]);
      await waitFor(page, (clip) => {
        const d = document.getElementById('v').dataset;
        return d.clip === clip && d.time === '0.500' && d.playing === 'false' && d.camera.startsWith('0.40000,0.10000,5.00000');
      }, clips[1], 'the widget to pause on the clip');
      const loads = await page.evaluate(() => {
        window.__loads = 0;
        document.getElementById('v').addEventListener('load', () => { window.__loads++; });
        document.getElementById('v').setAttribute('controls', '');
        return window.__loads;
      });
      await waitFor(page, () => customElements.get('kloub-viewer')._testBuild() === 'full', null, 'the full app to load');
      await waitFor(page, () => {
        const d = document.getElementById('v').dataset;
        return d.panel === 'side' && d.status === 'ready' && d.time === '0.500';
      }, null, 'the panel to appear with the model back');
      await sleep(300);
      const d = await ds(page);
      assert(d.model === 'default.glb' && d.clip === clips[1] && d.time === '0.500' && d.playing === 'false', `state after the move: ${JSON.stringify(d)}`);
      assert(d.camera.startsWith('0.40000,0.10000,5.00000'), `camera after the move: ${d.camera}`);
      assert(d.backend === backend, `backend after the move: ${d.backend}`);
      assert(buildsFetched(fetched).includes('full'), 'the full app was fetched');
      assert(await page.evaluate(() => window.__loads) === loads, 'the move is not a second load event');
      const controls = await page.evaluate(() => document.getElementById('v')._testAccessibilityControls().length);
      assert(controls > 5, `the panels' controls: ${controls}`);
    });

    test(`${backend}: a Draco GLB and a zipped glTF folder in a widget: the decoders are fetched once, the light build stays`, async (ctx) => {
      const { page } = ctx;
      const serveFile = (name, body) => page.route(`${ctx.url}/files/${name}`, (route) => route.fulfill({
        contentType: name.endsWith('.zip') ? 'application/zip' : 'model/gltf-binary', body,
      }));
      await serveFile('CesiumMan.draco.glb', readFileSync(join(ROOT, 'tests/optimized/CesiumMan.draco.glb')));
      const folder = join(ROOT, 'tests/assets/khronos/CesiumMan/glTF');
      const zip = makeZip(['CesiumMan.gltf', 'CesiumMan_data.bin', 'CesiumMan_img0.jpg']
        .filter((f) => existsSync(join(folder, f)))
        .map((f) => ({ name: `CesiumMan/glTF/${f}`, bytes: readFileSync(join(folder, f)) })));
      await serveFile('CesiumMan.zip', zip);
      const fetched = await widgetPage(page, ctx.url, { ...attrs, src: '/files/CesiumMan.draco.glb' });
      await ready(page);
      let d = await ds(page);
      assert(d.error === '' && d.model === 'CesiumMan.draco.glb', `Draco: ${JSON.stringify(d)}`);
      assert(JSON.stringify(buildsFetched(fetched)) === JSON.stringify([light, 'codecs']), `module files fetched: ${fetched.filter((f) => /kloub_/.test(f))}`);
      const frames = Number(d.frames);
      await waitFor(page, (f) => Number(document.getElementById('v').dataset.frames) > f + 10, frames, 'frames while playing');
      const shot = await viewportShot(page, '#v');
      assert(saturatedFraction(shot) > 0.01, 'the Draco CesiumMan is shown without its texture');
      // A zip by URL: the same decoders, not fetched again.
      await page.evaluate(() => { document.getElementById('v').src = '/files/CesiumMan.zip'; });
      await waitFor(page, () => {
        const d = document.getElementById('v').dataset;
        return (d.model === 'CesiumMan.gltf' && d.status === 'ready') || d.status === 'error';
      }, null, 'the zip to open');
      d = await ds(page);
      assert(d.error === '', `zip: ${d.error}`);
      assert(fetched.filter((f) => f === 'kloub_codecs_bg.wasm').length === 1, `the decoders were fetched ${fetched.filter((f) => f === 'kloub_codecs_bg.wasm').length} times`);
      const counters = await page.evaluate(() => customElements.get('kloub-viewer')._testCounters());
      assert(counters.codecLoads === 1, `codecs asked for: ${JSON.stringify(counters)}`);
      assert(await page.evaluate(() => customElements.get('kloub-viewer')._testBuild()) === light, 'the page still runs the light build');
    });

    test(`${backend}: startRagdoll on a widget loads the full app and the character falls`, async (ctx) => {
      const { page } = ctx;
      const fetched = await widgetPage(page, ctx.url, attrs);
      await ready(page);
      assert(!buildsFetched(fetched).includes('full'), 'no full app before it is needed');
      await page.evaluate(() => document.getElementById('v').startRagdoll());
      await waitFor(page, () => ['simulating', 'resting'].includes(document.getElementById('v').dataset.ragdoll), null, 'the ragdoll to start');
      assert(buildsFetched(fetched).includes('full'), 'the full app was fetched');
      await sleep(200);
      const d = await ds(page);
      assert(d.status === 'ready' && d.model === 'default.glb', `state: ${JSON.stringify(d)}`);
    });
  }
}
