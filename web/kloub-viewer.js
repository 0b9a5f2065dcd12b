// <kloub-viewer>: Kloub's glTF animation viewer as a custom element.
//
//   <script type="module" src="kloub-viewer.js"></script>
//   <kloub-viewer src="Fox.glb" autoplay animation-name="Run"></kloub-viewer>
//
// Each element owns a canvas in its (open) shadow root and its own viewer; many may share a page.
// Nothing is put on `window`: the module exports the class and registers the tag (once).
// State is mirrored into the element's own data-* attributes (data-status, data-clip, data-time,
// ...; see kloub-viewer.d.ts) and reported by events: load, error, play, pause, timeupdate, loop,
// finished. The wasm module is loaded once per page, on the first connected element: the light widget build
// (WebGPU only, or with WebGL2 where the browser has no WebGPU) unless the element has `controls`; the full app
// (panels, ragdoll, IK handles, overlays) is loaded when an element or a method needs it, and every viewer of the
// page moves over to it with its state.
// Imported when needed, not before the first frame: hash-state.js (a viewer moving to another build or back
// from a panic) and accessibility.js (the panels' mirror, with `controls`).

// ---- the page runtime: one module instance, one frame loop, shared by every element ----

/** The module's builds, lightest first (web/Cargo.toml's features). A page runs one at a time. */
const BUILDS = ['widget', 'widget-gl', 'full'];
/** Each build's glue module (literal imports, so that bundlers see them). */
const GLUE = {
  widget: (q) => (q ? import(`./kloub_widget.js?instance=${q}`) : import('./kloub_widget.js')),
  'widget-gl': (q) => (q ? import(`./kloub_widget_gl.js?instance=${q}`) : import('./kloub_widget_gl.js')),
  full: (q) => (q ? import(`./kloub_web.js?instance=${q}`) : import('./kloub_web.js')),
};
const WASM = { widget: 'kloub_widget_bg.wasm', 'widget-gl': 'kloub_widget_gl_bg.wasm', full: 'kloub_web_bg.wasm' };
/** The build the page runs (null until the first element chose). */
let build = null;
/** Each build's compiled module (a promise), by build. */
const compiled = {};
let runtime = null;
let instance = 0;
let webgpu = null;
/** The elements whose viewer is mounted (the frame loop draws them). */
const mounted = new Set();
const TICK = Symbol('tick');
const SHOW = Symbol('show');
const REVIVE = Symbol('revive');
const MOVE = Symbol('move');
const NEEDS_FULL = Symbol('needsFull');
const SIZE = Symbol('size');
const NEAR = Symbol('near');

/**
 * The wasm module's exports, instantiated once per page (and again after a panic: a new instance from the same
 * compiled module, so no download).
 */
/** The wasm at `url`, compiled while it streams in (or once downloaded, where the server's MIME type is not wasm's). */
async function compileWasm(url) {
  try {
    return await WebAssembly.compileStreaming(fetch(url));
  } catch {
    const response = await fetch(url);
    if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
    return WebAssembly.compile(await response.arrayBuffer());
  }
}

/** A build's wasm, downloaded and compiled once (compiled while it streams in); a failure may be tried again. */
function compileBuild(name) {
  compiled[name] ??= compileWasm(new URL(`./${WASM[name]}`, import.meta.url)).catch((e) => {
    delete compiled[name];
    throw e;
  });
  return compiled[name];
}

function loadRuntime() {
  build ??= 'full';
  runtime ??= (async () => {
    // Each instance needs its own copy of the glue module (it keeps the instance in a module variable); fetched
    // while the wasm downloads and compiles.
    const [module, glue] = await Promise.all([
      compileBuild(build),
      // A model with a sidecar needs the second half before its first frame: downloaded beside the first.
      GLUE[build](instance).then((g) => {
        if (rest.early && g.loadRest && !rest.held) compileRest(g).catch(() => {});
        return g;
      }),
    ]);
    await glue.default({ module_or_path: module });
    glue.setPanicHandler(onPanic);
    glue.setPrefetch(takePrefetch, takeImages, loadCodecs, loadEnvironment);
    if (glue.loadRest) {
      glue.setRestFailureHandler((message) => {
        rest.syncFailed = true;
        onPanic(message);
      });
      // The last instance could not load the second half when a call needed it: this one loads it before any
      // viewer mounts (a failure here is the page's error).
      if (rest.syncFailed) await glue.loadRest(compileRest(glue));
      else if (rest.wanted) startRest(glue);
      else setTimeout(restTimer, REST_LATEST_MS);
    }
    return glue;
  })();
  return runtime;
}

/**
 * The light builds' second halves (scripts/wasm-split.mjs): the functions no first frame ran, a file of their own
 * that the page fetches once a first frame is on screen or a model failed (or REST_LATEST_MS after the module
 * started), so that it does not share the link with the model. A call that needs one before then loads it
 * synchronously (the glue).
 * `wanted`: the page asked for it; `early`: a viewer's model comes with a sidecar, which only the second half reads,
 * so it is downloaded as soon as the glue is imported (beside the first half, for the page's first viewers) and
 * loaded before that viewer mounts (no synchronous load on its way to a first frame); `held`: a test hook;
 * `syncFailed`: an instance could not load it when a call needed it (each later instance loads it before its
 * viewers mount); `compiled`: each second half's compiled module (a promise), by URL, shared by the page's
 * instances.
 */
const rest = { wanted: false, early: false, held: false, syncFailed: false, compiled: {} };
const REST_LATEST_MS = 10000;
function wantRest() {
  if (rest.wanted || rest.held) return;
  rest.wanted = true;
  runtime?.then(startRest, () => {});
}
/** The latest time for the second half, unless a viewer is still loading its model (then a while later). */
function restTimer() {
  if (rest.wanted) return;
  if ([...mounted].some((element) => element.dataset.status === 'loading')) setTimeout(restTimer, REST_LATEST_MS);
  else wantRest();
}
/** `glue`'s second half, downloaded and compiled once per page (a promise); a failure may be tried again. */
function compileRest(glue) {
  const key = glue.REST_URL.href;
  rest.compiled[key] ??= compileWasm(glue.REST_URL).catch((e) => {
    delete rest.compiled[key];
    throw e;
  });
  return rest.compiled[key];
}
function startRest(glue) {
  if (!glue.loadRest || rest.held) return; // not split, or held (a test)
  if (glue.restState() !== null) {
    // A call loaded it already: a later instance (after a panic) takes the same compiled module.
    rest.compiled[glue.REST_URL.href] ??= Promise.resolve(glue.restModule());
    return;
  }
  glue.loadRest(compileRest(glue)).catch((e) => {
    // Its functions still load when first called (synchronously); a later instance tries the download again.
    console.warn(`kloub-viewer: the module's second half did not load: ${e instanceof Error ? e.message : e}`);
  });
}

/**
 * An environment photograph (`environment-image="studio"` or `"outdoor"`: web/environments), fetched from beside
 * this module when a viewer first lights with it; the module keeps it for the page's other viewers.
 */
async function loadEnvironment(file) {
  const url = new URL(`./environments/${file}`, import.meta.url);
  const response = await fetch(url).catch((e) => { throw new Error(`${url}: ${e instanceof Error ? e.message : e}`); });
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  const bytes = new Uint8Array(await response.arrayBuffer());
  if (bytes.length > MAX_HDR_BYTES) throw new Error(`${url}: ${bytes.length} bytes: at most ${MAX_HDR_BYTES} are read`);
  return bytes;
}

let codecs = null;
let codecsInstance = 0;
/**
 * The decoders few files need (Draco, zip archives: web/codecs), a module of their own that the widget builds
 * leave out of their first download: loaded once per page, when a file needs them (the module asks, or the
 * element sees a Draco GLB or a zip while the module still downloads). `fresh`: a new instance (after a trap in
 * the last one, or a failed load: a new module URL, which the browser fetches again).
 */
function loadCodecs(fresh = false) {
  if (fresh) {
    codecs = null;
    codecsInstance++;
  }
  codecs ??= (async () => {
    const n = codecsInstance;
    const glue = await (n ? import(`./kloub_codecs.js?instance=${n}`) : import('./kloub_codecs.js'));
    await glue.default({ module_or_path: new URL('./kloub_codecs_bg.wasm', import.meta.url) });
    return glue;
  })().catch((e) => {
    codecs = null;
    codecsInstance++;
    throw e;
  });
  return codecs;
}

/** Whether the browser gives a WebGPU adapter (asked once). */
function hasWebGpu() {
  webgpu ??= (async () => {
    try {
      return Boolean(navigator.gpu) && (await navigator.gpu.requestAdapter()) !== null;
    } catch {
      return false;
    }
  })();
  return webgpu;
}

/**
 * The lightest build that serves `element`: the full app for `controls` (or a method that needs it), else the
 * widget, with WebGL2 where the element asks for it or the browser has no WebGPU.
 */
async function buildFor(element) {
  if (element.hasAttribute('controls') || element[NEEDS_FULL]) return 'full';
  const backend = element.getAttribute('backend');
  if (backend === 'webgl2' || backend === 'gl') return 'widget-gl';
  if (backend === 'webgpu') return 'widget';
  if (!navigator.gpu) return 'widget-gl';
  // Most likely: downloaded while the browser is asked for an adapter.
  if (build === null) {
    compileBuild('widget').catch(() => {});
    GLUE.widget(0).catch(() => {});
  }
  return (await hasWebGpu()) ? 'widget' : 'widget-gl';
}

/**
 * Runs the page on `to` when it runs a lighter build (or none yet): the new build is downloaded while the old one
 * keeps drawing, then every mounted viewer moves over with its state (model, clip, time, camera, settings).
 */
async function ensureBuild(to) {
  if (build !== null && BUILDS.indexOf(to) <= BUILDS.indexOf(build)) return;
  build = to;
  runtime = null;
  await loadRuntime();
  if (build !== to) return;
  for (const element of [...mounted]) element[MOVE]();
}

const prefetched = new Set();
/** Downloads started before the module was ready, by absolute URL, until a viewer takes them ([`takePrefetch`]). */
const prefetches = new Map();
/** The largest GLB whose images are decoded while the module loads (a larger one waits for the importer). */
const PREDECODE_LIMIT = 64 << 20;

/**
 * Starts downloading a model while the module loads (once per URL and page); the viewer's fetch of the same URL
 * then takes the response (`takePrefetch`). For a GLB the browser also decodes its embedded images meanwhile, as
 * the viewer would after its import (same options), and the viewer takes the bitmaps (`takeImages`) instead of
 * decoding them again. What no viewer takes within a minute is dropped.
 */
/** `url` made absolute, without a `#sidecar=` fragment (the model's download is the same with or without one). */
function modelHref(url) {
  const u = new URL(url, document.baseURI);
  if (u.hash.startsWith('#sidecar=')) u.hash = '';
  return u.href;
}

/**
 * The sidecar's absolute URL in a `model.glb#sidecar=model.kloub.json` src (split as `web/src/load.rs`'s
 * `split_sidecar` splits it, relative to the model's URL, both against the document's base URL), or null for a
 * src without one.
 */
function sidecarHref(src) {
  const at = src.indexOf('#sidecar=');
  if (at < 0 || at + 9 === src.length) return null;
  try {
    return new URL(src.slice(at + 9), new URL(src.slice(0, at), document.baseURI)).href;
  } catch {
    return null;
  }
}

/**
 * `full`: the element will run the full app (which decodes Draco and zips itself). A sidecar named in `src` is
 * fetched beside the model, and the light build's second half (which reads sidecars) beside the module.
 */
function prefetchModel(src, full = false) {
  let href;
  try {
    href = modelHref(src);
  } catch {
    return;
  }
  const sidecar = sidecarHref(src);
  if (sidecar !== null) {
    rest.early = true;
    prefetch(sidecar, null);
  }
  prefetch(href, full);
}

/**
 * Starts downloading `href` (once per page); `full`: as for `prefetchModel`, or null for a file that is not a model
 * (no images to decode).
 */
function prefetch(href, full) {
  if (!/^https?:/.test(href) || prefetched.has(href)) return;
  prefetched.add(href);
  const controller = new AbortController();
  // What the viewer's own fetch would send: CORS, credentials for the same origin only.
  const response = fetch(href, { mode: 'cors', credentials: 'same-origin', signal: controller.signal });
  // Registered before the viewer can read the body: the clone is made first.
  const images = full === null ? null
    : response.then((r) => (r.ok ? decodeGlbImages(r.clone(), full) : null)).catch(() => null);
  response.catch(() => {});
  // `decoded`: the bitmaps once settled, so a viewer whose module arrives after them shows the model in the frame
  // that imports it (a promise would wait for another animation frame, which a busy GPU process delays).
  const entry = { response, abort: () => controller.abort(), images, decoded: undefined };
  images?.then((bitmaps) => { entry.decoded = bitmaps; });
  prefetches.set(href, entry);
  // A zip needs the codecs module in the widget builds: fetched beside the model.
  if (full === false && build !== 'full' && /\.zip$/i.test(new URL(href).pathname)) loadCodecs().catch(() => {});
  setTimeout(() => {
    if (prefetches.get(href) !== entry) return;
    prefetches.delete(href);
    if (entry.response) controller.abort();
    entry.images?.then((bitmaps) => bitmaps?.forEach((b) => b?.close()));
  }, 60000);
}

/** The viewer's side of a prefetch: `{response, abort}` for `url` once (`undefined` when none was started). */
function takePrefetch(url) {
  return takeFrom(url, 'response', (e) => ({ response: e.response, abort: e.abort }));
}

/**
 * The bitmaps of a prefetched GLB's images, once: `{images, decoded}`, `images` a promise of an array with a bitmap or
 * `null` per image (or of `null`), `decoded` what it resolved to if it has (else `undefined`).
 */
function takeImages(url) {
  return takeFrom(url, 'images', (e) => ({ images: e.images, decoded: e.decoded }));
}

function takeFrom(url, field, pick) {
  let href;
  try {
    href = modelHref(url);
  } catch {
    return undefined;
  }
  const entry = prefetches.get(href);
  if (!entry?.[field]) return undefined;
  const taken = pick(entry);
  entry[field] = null;
  if (!entry.response && !entry.images) prefetches.delete(href);
  return taken;
}

/**
 * The images embedded in a GLB (`bufferView` in the binary chunk; PNG, JPEG, WebP), decoded by the browser as the
 * viewer decodes them: not premultiplied, no colour conversion. `null` for a file that is not a GLB, and per
 * image that is not embedded or fails (the viewer decodes those itself, and reports what fails).
 */
async function decodeGlbImages(response, full = false) {
  const type = response.headers.get('content-type') ?? '';
  const length = Number(response.headers.get('content-length') ?? 0);
  let glb = type.includes('gltf-binary');
  try {
    glb ||= /\.glb$/i.test(new URL(response.url).pathname);
  } catch {
    // No usable URL: the type decides.
  }
  if (!glb || length > PREDECODE_LIMIT) {
    response.body?.cancel().catch(() => {});
    return null;
  }
  const buffer = await response.arrayBuffer();
  if (buffer.byteLength > PREDECODE_LIMIT || buffer.byteLength < 20) return null;
  const view = new DataView(buffer);
  const jsonLength = view.getUint32(12, true);
  // 'glTF' version 2, then the JSON chunk and the binary chunk.
  if (view.getUint32(0, true) !== 0x46546c67 || view.getUint32(4, true) !== 2) return null;
  if (view.getUint32(16, true) !== 0x4e4f534a || 20 + jsonLength + 8 > buffer.byteLength) return null;
  const binStart = 20 + jsonLength;
  const binLength = view.getUint32(binStart, true);
  if (view.getUint32(binStart + 4, true) !== 0x004e4942 || binStart + 8 + binLength > buffer.byteLength) return null;
  let json;
  try {
    json = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 20, jsonLength)));
  } catch {
    return null;
  }
  // A Draco GLB needs the codecs module in the widget builds: fetched while the module downloads.
  if (!full && build !== 'full' && json?.extensionsUsed?.includes?.('KHR_draco_mesh_compression')) loadCodecs().catch(() => {});
  const images = Array.isArray(json?.images) ? json.images : [];
  const embedded = json?.buffers?.[0] && json.buffers[0].uri === undefined;
  const types = new Set(['image/png', 'image/jpeg', 'image/webp']);
  return Promise.all(images.map((image) => {
    const view = json.bufferViews?.[image?.bufferView];
    const start = view?.byteOffset ?? 0;
    const size = view?.byteLength;
    if (!embedded || view?.buffer !== 0 || !types.has(image.mimeType) || !Number.isInteger(start)
      || !Number.isInteger(size) || start < 0 || size <= 0 || start + size > binLength) return null;
    const blob = new Blob([new Uint8Array(buffer, binStart + 8 + start, size)], { type: image.mimeType });
    return createImageBitmap(blob, { premultiplyAlpha: 'none', colorSpaceConversion: 'none' }).catch(() => null);
  }));
}

const panics = [];
/** A Rust panic (a bug): the instance is dead. Make a new one and bring every viewer back from its state. */
function onPanic(message) {
  // Called inside the panic hook: nothing here may call into the dead instance.
  if (runtime === null) return;
  runtime = null;
  instance += 1;
  const now = performance.now();
  panics.push(now);
  while (panics.length > 0 && panics[0] < now - 10000) panics.shift();
  const giveUp = panics.length > 3;
  setTimeout(() => {
    for (const element of [...mounted]) element[REVIVE](String(message), giveUp);
  }, 0);
}

/** The frame loop: one requestAnimationFrame for the page, drawing only the viewers in view that asked for a frame. */
const loop = { raf: 0, timer: 0, last: 0, interval: 16.7, scale: 1, changed: 0, started: 0 };
function requestFrame() {
  if (loop.raf) return;
  if (loop.timer) {
    clearTimeout(loop.timer);
    loop.timer = 0;
  }
  loop.raf = requestAnimationFrame(tick);
}
function tick(now) {
  loop.raf = 0;
  let soonest = Infinity;
  let drew = 0;
  for (const element of mounted) {
    const [due, drawn] = element[TICK](now);
    soonest = Math.min(soonest, due);
    drew += drawn;
  }
  if (drew > 0) adapt(now);
  if (soonest <= now + 20) requestFrame();
  else if (Number.isFinite(soonest)) loop.timer = setTimeout(() => { loop.timer = 0; requestFrame(); }, soonest - now - 10);
}
/**
 * Holds the frame rate by lowering the resolution of viewers without panels (down to their min-pixel-ratio) when
 * frames take longer than 1/30 s, and raising it again when they take less than 1/50 s.
 */
function adapt(now) {
  const dt = now - loop.last;
  loop.last = now;
  // The page's first second of frames holds one-time work (shaders compiled, environments prefiltered, textures
  // uploaded): it neither counts towards the average nor sets a resolution (on WebGL2 a resize waits for that work).
  if (loop.started === 0) loop.started = now;
  if (dt <= 0 || dt > 500 || now - loop.started < 1000) return;
  loop.interval = loop.interval * 0.9 + dt * 0.1;
  if (now - loop.changed < 1000) return;
  if (loop.interval > 1000 / 30 && loop.scale > 0.25) {
    loop.scale = Math.max(0.25, loop.scale * 0.8);
    loop.changed = now;
  } else if (loop.interval < 1000 / 50 && loop.scale < 1) {
    loop.scale = Math.min(1, loop.scale * 1.15);
    loop.changed = now;
  }
}

const visibility = new IntersectionObserver((entries) => {
  for (const entry of entries) entry.target[SHOW](entry.isIntersecting);
});
/** `loading="lazy"` elements: mounted (module, viewer, model download) once they come within half a screen. */
const nearby = new IntersectionObserver((entries) => {
  for (const entry of entries) if (entry.isIntersecting) entry.target[NEAR]();
}, { rootMargin: '50% 0px' });
const sizes = new ResizeObserver((entries) => {
  for (const entry of entries) entry.target[SIZE](entry.contentRect.width, entry.contentRect.height);
});
document.addEventListener('visibilitychange', () => {
  for (const element of mounted) element[SHOW](null);
});
/** The page's motion preference: no UI animations in the panels when reduced. */
const reducedMotion = window.matchMedia('(prefers-reduced-motion: reduce)');
const MOTION = Symbol('motion');
reducedMotion.addEventListener?.('change', () => {
  for (const element of mounted) element[MOTION]();
});

/** Modifier bits of an input event: 1 Alt, 2 Ctrl, 4 Shift, 8 Meta. */
const modifierBits = (e) => (e.altKey ? 1 : 0) | (e.ctrlKey ? 2 : 0) | (e.shiftKey ? 4 : 0) | (e.metaKey ? 8 : 0);

/** A CSS-style angle (`30deg`, `0.5rad`, a bare number is radians) in radians, or null for `auto`. */
function parseAngle(attr, token) {
  if (token === 'auto') return null;
  if (/^[-+]?Infinity$/.test(token)) return token.startsWith('-') ? -Infinity : Infinity;
  const m = /^(-?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?)(deg|rad)?$/i.exec(token);
  if (!m) throw new RangeError(`${attr}: "${token}" is not an angle (e.g. 30deg, 0.5rad, auto)`);
  const v = Number(m[1]);
  return (m[2] ?? 'rad').toLowerCase() === 'deg' ? (v * Math.PI) / 180 : v;
}
/** A length (`2m`, `150cm`, `20mm`, a bare number is metres, `%` of `auto`) in metres, or null for `auto`. */
function parseLength(attr, token, auto) {
  if (token === 'auto') return null;
  const m = /^(-?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?)(m|cm|mm|%)?$/i.exec(token);
  if (!m) throw new RangeError(`${attr}: "${token}" is not a length (e.g. 2m, 150cm, 50%, auto)`);
  const v = Number(m[1]);
  switch ((m[2] ?? 'm').toLowerCase()) {
    case 'cm': return v / 100;
    case 'mm': return v / 1000;
    case '%': return (v / 100) * auto;
    default: return v;
  }
}
/** An orbit attribute's "θ φ r" (missing ones `auto`): [θ, φ, r] in radians and metres, null where `auto`; `%` of
 *  r is of `distance`. */
function orbitTokens(attr, text, distance) {
  const t = String(text).trim().split(/\s+/);
  if (t.length > 3 || t[0] === '') throw new RangeError(`${attr}: "${text}": expected "θ φ r" (e.g. "30deg 75deg 2m")`);
  return [parseAngle(attr, t[0] ?? 'auto'), parseAngle(attr, t[1] ?? 'auto'), parseLength(attr, t[2] ?? 'auto', distance)];
}
/** model-viewer's `camera-orbit` ("θ φ r", any of them `auto`) over the framed camera `[yaw, pitch, distance, …]`. */
function parseOrbit(text, framed) {
  const [theta, phi, r] = orbitTokens('camera-orbit', text, framed[2]);
  if (r !== null && !(r > 0)) throw new RangeError(`camera-orbit: radius "${text}": expected a positive length`);
  // θ turns the eye from +Z towards +X (Kloub's yaw); φ is measured down from +Y (Kloub's pitch is up from the horizon).
  return [theta ?? framed[0], phi === null ? framed[1] : Math.PI / 2 - phi, r ?? framed[2]];
}
/** model-viewer's `camera-target` ("x y z", lengths or `auto`) over the framed target. */
function parseTarget(text, framed) {
  const t = String(text).trim().split(/\s+/);
  if (t.length !== 3) throw new RangeError(`camera-target: "${text}": expected "x y z" (e.g. "0m 1m 0m")`);
  return t.map((token, i) => parseLength('camera-target', token, framed[3 + i]) ?? framed[3 + i]);
}

const STYLE = `
:host { display: block; position: relative; width: 300px; height: 150px; overflow: clip; }
:host([hidden]) { display: none; }
canvas { display: block; width: 100%; height: 100%; outline: none; touch-action: auto; }
:host([controls]) canvas, :host([camera-controls]) canvas { touch-action: none; }
.kloub-note { position: absolute; inset: auto 0 0 0; padding: 6px 10px; font: 13px system-ui, sans-serif;
  color: #eee; background: rgba(20, 20, 20, 0.8); pointer-events: none; }
.kloub-note[hidden] { display: none; }
.kloub-loading { position: absolute; inset: 0; display: flex; align-items: center; justify-content: center;
  font: 14px system-ui, sans-serif; color: #888; pointer-events: none; }
:host(:not([data-status="loading"])) .kloub-loading { display: none; }
.kloub-poster { position: absolute; inset: 0; width: 100%; height: 100%; object-fit: contain; pointer-events: none; }
.kloub-poster[hidden] { display: none; }
.kloub-prompt { position: absolute; left: 50%; bottom: 12px; transform: translateX(-50%); padding: 4px 12px;
  border-radius: 12px; font: 13px system-ui, sans-serif; color: #fff; background: rgba(0, 0, 0, 0.55);
  pointer-events: none; white-space: nowrap; animation: kloub-nudge 2s ease-in-out infinite; }
.kloub-prompt[hidden] { display: none; }
.kloub-live { position: absolute; width: 1px; height: 1px; margin: -1px; padding: 0; overflow: hidden;
  clip-path: inset(50%); white-space: nowrap; border: 0; }
@media (prefers-reduced-motion: reduce) { .kloub-prompt { animation: none; } }
@keyframes kloub-nudge { 0%, 100% { transform: translateX(-50%); } 50% { transform: translateX(calc(-50% + 8px)); } }
`;

const LOOP_MODES = new Set(['once', 'repeat', 'pingpong']);
const SKINNING = ['rigid', 'lbs', 'dqs', 'sjb', 'sjbbe'];
const SKINNING_PATHS = ['gpu', 'compute', 'cpu'];
const IK_SOLVERS = ['ccd', 'twobone', 'fabrik', 'dls'];
const LIGHTING = ['studio', 'outdoor', 'flat', 'rim'];
const BACKGROUNDS = ['dark', 'grey', 'light', 'transparent'];
/** Tone mappings; model-viewer's `auto` is `neutral` and its `linear` is `none`. */
const TONE_MAPPINGS = ['neutral', 'aces', 'none'];
const TONE_ALIASES = { auto: 'neutral', linear: 'none' };
/** The largest exposure (everything is white long before). */
const MAX_EXPOSURE = 64;
/** The ground shadow's darkness without `shadow-intensity`. */
const DEFAULT_SHADOW_INTENSITY = 0.6;
/** An attribute holding a number from 0 to 1, or `fallback` when absent or anything else. */
function unitAttribute(value, fallback) {
  const x = value === null || value.trim() === '' ? NaN : Number(value);
  return Number.isFinite(x) && x >= 0 && x <= 1 ? x : fallback;
}
/** The environments Kloub ships (`environment-image` names); anything else is the URL of an .hdr image. */
const ENVIRONMENTS = ['neutral', 'studio', 'outdoor'];
/** The largest .hdr file fetched for `environment-image` (2048×1024 pixels uncompressed is 8 MiB). */
const MAX_HDR_BYTES = 16 << 20;
const EASINGS = ['smoothstep', 'linear'];
const OUTGOING = ['freeze', 'keep', 'sync'];
/** Argument bounds of the page API (README, "Embedding"). */
const MAX_SPEED = 100;
const MAX_SECONDS = 3600;
const MAX_COPIES = 100;
const MAX_NAME = 4096;
const MAX_URL = 65536;
const MAX_LIST = 1024;

// Every method checks its arguments here before anything reaches wasm: a wrong type is a TypeError, a value out of
// range or not among the accepted names a RangeError, each message naming the method, the argument and what is
// accepted. (wasm-bindgen's glue does not check types: a number where a string is expected traps inside wasm.)
function describe(value) {
  if (value === null) return 'null';
  if (Array.isArray(value)) return 'an array';
  if (typeof value === 'string') return value.length > 40 ? `a string of ${value.length} characters` : JSON.stringify(value);
  if (typeof value === 'number' || typeof value === 'boolean' || typeof value === 'bigint') return String(value);
  return typeof value === 'object' ? 'an object' : typeof value;
}
function str(method, arg, value) {
  if (typeof value !== 'string') throw new TypeError(`${method}: ${arg} must be a string, got ${describe(value)}`);
  if (value.length > MAX_NAME) throw new RangeError(`${method}: ${arg} is ${value.length} characters long: at most ${MAX_NAME}`);
  return value;
}
function optStr(method, arg, value) { return value === null || value === undefined ? null : str(method, arg, value); }
function url(method, arg, value) {
  if (typeof value !== 'string') throw new TypeError(`${method}: ${arg} must be a URL string, got ${describe(value)}`);
  if (value.length > MAX_URL) throw new RangeError(`${method}: ${arg} is ${value.length} characters long: at most ${MAX_URL}`);
  return value;
}
function oneOf(method, arg, value, accepted) {
  if (typeof value !== 'string') throw new TypeError(`${method}: ${arg} must be one of ${accepted.map((a) => `"${a}"`).join(', ')}; got ${describe(value)}`);
  if (!accepted.includes(value)) throw new RangeError(`${method}: ${arg} ${describe(value)}: expected ${accepted.map((a) => `"${a}"`).join(', ')}`);
  return value;
}
function num(method, arg, value, { min = -1e9, max = 1e9, integer = false } = {}) {
  if (typeof value !== 'number') throw new TypeError(`${method}: ${arg} must be a number, got ${describe(value)}`);
  if (!Number.isFinite(value)) throw new RangeError(`${method}: ${arg} ${value}: expected a finite number`);
  if (integer && !Number.isInteger(value)) throw new RangeError(`${method}: ${arg} ${value}: expected an integer`);
  if (value < min || value > max) throw new RangeError(`${method}: ${arg} ${value}: expected ${integer ? 'an integer' : 'a number'} from ${min} to ${max}`);
  return value;
}
function bool(method, arg, value) {
  if (typeof value !== 'boolean') throw new TypeError(`${method}: ${arg} must be true or false, got ${describe(value)}`);
  return value;
}
/** A plain object (an options bag): not null, not an array. `shape` says what is expected. */
function obj(method, shape, value) {
  if (value === null || typeof value !== 'object' || Array.isArray(value)) {
    throw new TypeError(`${method}: expected ${shape}, got ${describe(value)}`);
  }
  return value;
}
function vec3(method, arg, value) {
  if (!Array.isArray(value) && !ArrayBuffer.isView(value)) throw new TypeError(`${method}: ${arg} must be [x, y, z], got ${describe(value)}`);
  if (value.length !== 3) throw new RangeError(`${method}: ${arg} has ${value.length} numbers: expected [x, y, z]`);
  return Array.from(value, (v, i) => num(method, `${arg}[${i}]`, v));
}

/** A point or size as model-viewer returns them: `{ x, y, z }`, printed as `"xm ym zm"`. */
function vector3(x, y, z) {
  return Object.freeze({ x, y, z, toString() { return `${x}m ${y}m ${z}m`; } });
}

/** The loop attribute's mode: absent or "" repeats, "false" plays once. */
function loopMode(value) {
  if (value === null || value === '' || value === 'true') return 'repeat';
  if (value === 'false') return 'once';
  return LOOP_MODES.has(value) ? value : 'repeat';
}

/** Reads every file of a dropped folder tree (webkitGetAsEntry), with paths relative to the drop. */
async function readEntry(entry, out) {
  if (entry.isFile) {
    const file = await new Promise((ok, fail) => entry.file(ok, fail));
    out.push({ name: entry.fullPath.replace(/^\//, ''), file });
  } else if (entry.isDirectory) {
    const reader = entry.createReader();
    for (;;) {
      const batch = await new Promise((ok, fail) => reader.readEntries(ok, fail));
      if (batch.length === 0) break;
      for (const child of batch) await readEntry(child, out);
    }
  }
}

/** The files of a drop: folders are walked; plain files keep their names. */
async function droppedFiles(dataTransfer) {
  const out = [];
  const entries = [...(dataTransfer.items ?? [])]
    .filter((item) => item.kind === 'file')
    .map((item) => (item.webkitGetAsEntry ? item.webkitGetAsEntry() : null));
  if (entries.length > 0 && entries.every((e) => e)) {
    for (const entry of entries) await readEntry(entry, out);
  } else {
    for (const file of dataTransfer.files ?? []) out.push({ name: file.webkitRelativePath || file.name, file });
  }
  return out;
}

/** The validator's worker, shared by the page's viewers (started by the first validate()). */
let validatorWorker = null;
/** The worker itself, once started (`validatorWorker` is the promise of it). */
let validatorInstance = null;
let validatorRequests = 0;
const validatorPending = new Map();
/** How long one validation may run before its worker is stopped (a validator that never answers). */
const VALIDATION_TIMEOUT_MS = 180_000;

/** Stops the validator's worker and rejects every pending validation with `message`. */
function stopValidator(worker, message) {
  worker.terminate();
  if (validatorInstance !== worker) return;
  validatorInstance = null;
  validatorWorker = null;
  for (const [id, pending] of validatorPending) {
    clearTimeout(pending.timer);
    validatorPending.delete(id);
    pending.reject(new Error(message));
  }
}

/**
 * Validates `request` ({ name, bytes, files, base }) in the validator's worker; resolves with the report. `transfer`
 * lists the buffers handed to the worker without a copy.
 */
async function validateInWorker(request, transfer) {
  if (!validatorWorker) {
    validatorWorker = (async () => {
      // A worker from a blob: the page may come from another origin than the element.
      const source = await fetch(new URL('./validator-worker.js', import.meta.url));
      if (!source.ok) throw new Error(`validator-worker.js: HTTP ${source.status}`);
      const blob = URL.createObjectURL(new Blob([await source.text()], { type: 'text/javascript' }));
      const worker = new Worker(blob);
      validatorInstance = worker;
      URL.revokeObjectURL(blob);
      worker.onmessage = ({ data }) => {
        if (data.loadError) {
          stopValidator(worker, data.loadError);
          return;
        }
        const pending = validatorPending.get(data.id);
        validatorPending.delete(data.id);
        clearTimeout(pending?.timer);
        if (data.error) pending?.reject(new Error(data.error));
        else pending?.resolve(data.report);
      };
      worker.onerror = (event) => {
        event.preventDefault();
        stopValidator(worker, `the validator failed: ${event.message || 'its worker stopped'}`);
      };
      worker.postMessage({ validator: new URL('./gltf-validator.js', import.meta.url).href });
      return worker;
    })();
    validatorWorker.catch(() => { validatorWorker = null; });
  }
  const worker = await validatorWorker;
  const id = ++validatorRequests;
  return new Promise((resolve, reject) => {
    const timer = setTimeout(
      () => stopValidator(worker, `the validator did not answer within ${VALIDATION_TIMEOUT_MS / 1000} s`),
      VALIDATION_TIMEOUT_MS,
    );
    validatorPending.set(id, { resolve, reject, timer });
    worker.postMessage({ id, ...request }, transfer);
  });
}

class KloubViewer extends HTMLElement {
  static observedAttributes = [
    'src', 'autoplay', 'animation-name', 'speed', 'loop', 'crossfade-duration', 'layer-clip', 'layer-root',
    'skinning', 'backend', 'controls', 'min-pixel-ratio', 'background', 'grid', 'alt', 'loading', 'poster', 'reveal',
    'camera-controls', 'camera-orbit', 'camera-target', 'auto-rotate', 'auto-rotate-delay', 'rotation-per-second',
    'min-camera-orbit', 'max-camera-orbit', 'field-of-view', 'disable-zoom', 'disable-pan', 'animation-crossfade-duration',
    'interaction-prompt', 'interaction-prompt-threshold', 'exposure', 'tone-mapping', 'environment-image',
    'shadow-intensity', 'shadow-softness',
  ];

  #viewer = null;
  /** Canvas pixels per CSS pixel of the last frame drawn. */
  #ppp = 1;
  /** The camera as the model was framed at its load ([yaw, pitch, distance, x, y, z]): `auto` in camera-orbit/target. */
  #framed = null;
  /** When the user last moved the camera (ms), for auto-rotate's delay; and whether input came since the last frame. */
  #interacted = -Infinity;
  #userInput = false;
  /** The camera mirrored after the last frame, to fire `camera-change` when it moves. */
  #lastCamera = '';
  /** The time of the last frame drawn (auto-rotate's step). */
  #lastDraw = 0;
  /** `auto-rotate-delay` (ms) and `rotation-per-second` (rad), read when they change, not every frame. */
  #rotation = { delay: 3000, rate: Math.PI / 32 };
  /** `loading="lazy"`: the element has come near the viewport (it mounts from then on). */
  #near = false;
  /** The `poster` image, shown until the first frame of a model (or `dismissPoster()` with `reveal="manual"`). */
  #poster;
  #posterDismissed = false;
  /** The interaction prompt (a hint to drag), its timer, and whether the user has moved the camera yet. */
  #prompt;
  #promptTimer = null;
  #userMoved = false;
  /** ElementInternals: the element's role and accessible name, without touching its attributes. */
  #internals;
  #canvas;
  /** The panels mirrored for assistive technology and the keyboard (with `controls`). */
  #a11y = null;
  /** Announcements for screen readers (an aria-live region). */
  #live;
  #mounting = null;
  #pendingTime = null;
  #teardown = null;
  #pickers = [];
  #samples = [];
  /** The files of the last model loaded from files (to bring it back after a panic). */
  #files = null;
  /** Calls that need the full app, made while the page ran the widget: applied once the viewer moved over. */
  #afterMove = [];
  /** Once the model is back after a move or a panic: restores the rest of the view. */
  #onModelBack = null;
  /** Moving to another build: the model's second `load` is not reported to the page. */
  #moving = false;
  /** Scheduling: when the viewer wants its next frame (ms), whether it is in view, its CSS size. */
  #due = 0;
  #inView = true;
  #hiddenAt = null;
  #cssSize = null;
  #lost = false;
  /** Input handed over since the last frame. */
  #inputPending = false;
  /** The pointer moved with a button held since the last frame (a release then ends a drag, not a click). */
  #dragged = false;
  #note;
  #primaryTouch = null;

  constructor() {
    super();
    this.#internals = this.attachInternals();
    const root = this.attachShadow({ mode: 'open' });
    const style = document.createElement('style');
    style.textContent = STYLE;
    const loading = document.createElement('div');
    loading.className = 'kloub-loading';
    loading.textContent = 'Loading…';
    this.#note = document.createElement('div');
    this.#note.className = 'kloub-note';
    this.#note.setAttribute('role', 'status');
    this.#note.hidden = true;
    // The panel's Open menu: file inputs the viewer clicks through the "kloub:open" request.
    this.#pickers = ['files', 'folder'].map((kind) => {
      const input = document.createElement('input');
      input.type = 'file';
      input.multiple = true;
      input.hidden = true;
      if (kind === 'folder') input.webkitdirectory = true;
      else input.accept = '.glb,.gltf,.zip,.bin,.png,.jpg,.jpeg,.webp,.ktx2,.json';
      input.addEventListener('change', () => {
        const files = [...input.files].map((file) => ({ name: file.webkitRelativePath || file.name, file }));
        input.value = '';
        if (files.length > 0) this.#loadFiles(files).catch((e) => this.#fail(String(e)));
      });
      return input;
    });
    this.#canvas = this.#newCanvas();
    this.#poster = document.createElement('img');
    this.#poster.className = 'kloub-poster';
    this.#poster.setAttribute('part', 'poster');
    this.#poster.alt = '';
    this.#poster.hidden = true;
    this.#prompt = document.createElement('div');
    this.#prompt.className = 'kloub-prompt';
    this.#prompt.setAttribute('part', 'interaction-prompt');
    this.#prompt.setAttribute('aria-hidden', 'true');
    this.#prompt.textContent = '⟲ Drag to turn · scroll or pinch to zoom';
    this.#prompt.hidden = true;
    this.#live = document.createElement('div');
    this.#live.className = 'kloub-live';
    this.#live.setAttribute('role', 'status');
    this.#live.setAttribute('aria-live', 'polite');
    root.append(style, this.#canvas, this.#poster, this.#prompt, loading, this.#note, this.#live, ...this.#pickers);
    this.#announcer();
    // Drops are read here (folders too) and handed over whole; capture runs before the canvas's own handler.
    const drag = (on) => (event) => {
      if (!this.hasAttribute('controls') || !event.dataTransfer) return;
      event.preventDefault();
      event.stopPropagation();
      this.#viewer?.setDropHint(on);
    };
    root.addEventListener('dragenter', drag(true), true);
    root.addEventListener('dragover', drag(true), true);
    root.addEventListener('dragleave', drag(false), true);
    root.addEventListener('drop', (event) => {
      drag(false)(event);
      if (this.hasAttribute('controls') && event.dataTransfer) {
        droppedFiles(event.dataTransfer).then((files) => this.#loadFiles(files), (e) => this.#fail(`cannot read the drop: ${e}`));
      }
    }, true);
  }

  /** A canvas with the input listeners that feed the viewer (a fresh one after a device loss or a backend change). */
  #newCanvas() {
    const canvas = document.createElement('canvas');
    canvas.setAttribute('part', 'canvas');
    canvas.tabIndex = 0;
    const input = (fn) => (event) => {
      const viewer = this.#viewer;
      if (!viewer || this.#lost) return;
      // Without `controls` or `camera-controls` the view takes no input: the page keeps its scrolling and keys.
      if (!this.#interactive() && event.type !== 'focus' && event.type !== 'blur') return;
      if (event.type !== 'focus' && event.type !== 'blur' && event.type !== 'pointerleave'
        && (event.type !== 'pointermove' || event.buttons !== 0)) {
        this.#interacted = performance.now();
        this.#userInput = true;
        this.#userMoved = true;
        this.#prompt.hidden = true;
      }
      // A press, release or key after other input not yet drawn: draw that input first, so that a quick press,
      // move and release (a drag between two animation frames) reaches the viewer as a drag, not as one click, and
      // keys typed right after a click on a text field reach the field the click focused.
      const release = event.type === 'pointerup' || event.type === 'pointercancel';
      const edge = event.type === 'pointerdown' || event.type === 'keydown' || (release && this.#dragged);
      if (edge && this.#inputPending) this.#draw(performance.now());
      if (event.type === 'pointermove' && event.buttons !== 0) this.#dragged = true;
      fn(viewer, event);
      this.#inputPending = true;
      this.#wake(0);
    };
    const at = (event) => {
      const rect = canvas.getBoundingClientRect();
      return [event.clientX - rect.left, event.clientY - rect.top];
    };
    const touchPhase = { pointerdown: 0, pointermove: 1, pointerup: 2, pointercancel: 3 };
    const pointer = input((viewer, event) => {
      const [x, y] = at(event);
      const touch = event.pointerType === 'touch';
      if (touch) {
        viewer.touch(event.pointerId, touchPhase[event.type], x, y, event.pressure);
        if (event.type === 'pointerdown' && this.#primaryTouch === null) this.#primaryTouch = event.pointerId;
        // Only the first finger moves egui's pointer; the others are touches (pinch, two-finger pan).
        if (event.pointerId !== this.#primaryTouch) return;
        if (event.type === 'pointerup' || event.type === 'pointercancel') this.#primaryTouch = null;
      }
      switch (event.type) {
        case 'pointerdown':
          canvas.focus({ preventScroll: true });
          canvas.setPointerCapture?.(event.pointerId);
          viewer.pointerButton(x, y, event.button, true, modifierBits(event));
          break;
        case 'pointerup': case 'pointercancel':
          viewer.pointerButton(x, y, Math.max(event.button, 0), false, modifierBits(event));
          if (touch) viewer.pointerGone();
          break;
        default: viewer.pointerMove(x, y);
      }
    });
    for (const type of ['pointerdown', 'pointermove', 'pointerup', 'pointercancel']) canvas.addEventListener(type, pointer);
    canvas.addEventListener('pointerleave', input((viewer, event) => { if (event.pointerType === 'mouse') viewer.pointerGone(); }));
    canvas.addEventListener('wheel', input((viewer, event) => {
      event.preventDefault();
      viewer.wheel(event.deltaX, event.deltaY, event.deltaMode, modifierBits(event));
    }), { passive: false });
    const key = (pressed) => input((viewer, event) => {
      // With the panels mirrored, Tab walks the page's focus order (the panel's controls, the view) instead of
      // egui's; Escape leaves the view once nothing of egui's (a menu, the help) is open to close.
      if (event.key === 'Tab' && this.hasAttribute('controls')) return;
      const popup = this.#a11y?.root.querySelector('[data-popup]');
      if (viewer.key(event.key, event.code, pressed, modifierBits(event))) event.preventDefault();
      if (pressed && event.key === 'Escape' && !popup) {
        const first = this.#a11y?.root.querySelector('button, input');
        if (first) first.focus();
        else canvas.blur();
      }
    });
    canvas.addEventListener('keydown', key(true));
    canvas.addEventListener('keyup', key(false));
    canvas.addEventListener('focus', input((viewer) => {
      viewer.focus(true);
      viewer.releaseFocus?.();
    }));
    canvas.addEventListener('blur', input((viewer) => viewer.focus(false)));
    canvas.addEventListener('paste', input((viewer, event) => {
      const text = event.clipboardData?.getData('text/plain');
      if (text) {
        event.preventDefault();
        viewer.paste(text);
      }
    }));
    canvas.addEventListener('copy', input((viewer) => viewer.copy(false)));
    canvas.addEventListener('cut', input((viewer) => viewer.copy(true)));
    canvas.addEventListener('contextmenu', (event) => event.preventDefault());
    return canvas;
  }

  #replaceCanvas() {
    const canvas = this.#newCanvas();
    this.#canvas.replaceWith(canvas);
    this.#canvas = canvas;
    this.#present();
  }

  /** What the page sees of the element besides its pixels: `role="img"` named by `alt` for an embedded viewer (with
   *  `controls` it is an application of its own), and a CSS colour `background` behind the transparent canvas. */
  #present() {
    this.#internals.role = this.hasAttribute('controls') ? null : 'img';
    // A view that takes no input is no tab stop.
    this.#canvas.tabIndex = this.#interactive() ? 0 : -1;
    this.#internals.ariaLabel = this.getAttribute('alt');
    this.#labelCanvas();
    this.#canvas.style.backgroundColor = this.#cssBackground() ?? '';
  }

  /** The 3D view's name for assistive technology: what it shows and the keys it takes (it is a tab stop only with
   *  `controls` or `camera-controls`). */
  #labelCanvas() {
    const canvas = this.#canvas;
    if (!this.#interactive()) {
      canvas.removeAttribute('role');
      canvas.removeAttribute('aria-label');
      canvas.removeAttribute('aria-roledescription');
      return;
    }
    const model = this.dataset.model;
    const what = this.getAttribute('alt') || (model ? `3D view of ${model}` : '3D view');
    const keys = this.hasAttribute('controls')
      ? 'Shift and the arrow keys turn the camera, plus and minus zoom, F frames the model; Space plays or pauses, '
        + 'Left and Right step a frame, Up and Down change the clip; Escape leaves the view'
      : 'Shift and the arrow keys turn the camera, plus and minus zoom; Escape leaves the view';
    canvas.setAttribute('role', 'application');
    canvas.setAttribute('aria-roledescription', '3D view');
    canvas.setAttribute('aria-label', `${what}. ${keys}.`);
  }

  /** Says what happens to screen readers (an aria-live region): a model loaded, an error, the clip changed, the
   *  ragdoll started or came to rest. */
  #announcer() {
    const say = (text) => {
      // The same text twice is announced twice only if the region changes in between.
      if (this.#live.textContent === text) this.#live.textContent = '';
      queueMicrotask(() => { this.#live.textContent = text; });
    };
    this.addEventListener('load', (event) => {
      let clips = 0;
      try { clips = JSON.parse(this.dataset.clips ?? '[]').length; } catch { /* none */ }
      const name = event.detail?.name || this.dataset.model || 'The model';
      say(`${name} loaded: ${clips} ${clips === 1 ? 'clip' : 'clips'}.`);
      this.#labelCanvas();
    });
    this.addEventListener('error', (event) => say(`Error: ${event.detail?.message ?? ''}`));
    let clip = null;
    let ragdoll = '';
    new MutationObserver(() => {
      const now = this.dataset.clip ?? '';
      if (clip !== null && now !== clip && this.dataset.status === 'ready' && now !== '') say(`Playing ${now}.`);
      clip = now;
      const state = this.dataset.ragdoll ?? '';
      if (state !== ragdoll) {
        if (state === 'simulating') say('Ragdoll started.');
        else if (state === 'resting') say('The ragdoll came to rest.');
        ragdoll = state;
      }
    }).observe(this, { attributes: true, attributeFilter: ['data-clip', 'data-ragdoll'] });
  }

  [MOTION]() {
    this.#viewer?.setReducedMotion?.(reducedMotion.matches);
    this.#wake(0);
  }

  /** The `background` attribute when it is a CSS colour (not one of the themes), else null. */
  #cssBackground() {
    const value = this.getAttribute('background');
    return value !== null && !BACKGROUNDS.includes(value) && CSS.supports('color', value) ? value : null;
  }

  connectedCallback() {
    if (this.#teardown) {
      clearTimeout(this.#teardown);
      this.#teardown = null;
    }
    visibility.observe(this);
    sizes.observe(this);
    this.#present();
    this.#showPoster();
    if (this.#mounting) return;
    if (this.getAttribute('loading') === 'lazy' && !this.#near) {
      // Nothing is fetched (module, model) until the element nears the viewport.
      this.dataset.status = 'waiting';
      nearby.observe(this);
      return;
    }
    this.#mounting = this.#mount();
  }

  /** A `loading="lazy"` element came near the viewport (or stopped being lazy): mount it now. */
  [NEAR]() {
    nearby.unobserve(this);
    this.#near = true;
    if (this.isConnected && !this.#mounting && !this.#teardown) this.#mounting = this.#mount();
  }

  /** Shows the `poster` image while no model has been revealed yet. */
  #showPoster() {
    const src = this.getAttribute('poster');
    if (src && this.#poster.getAttribute('src') !== src) this.#poster.src = src;
    this.#poster.hidden = !src || this.#posterDismissed;
  }

  /** Hides the poster for good and says so (`poster-dismissed`), once. */
  dismissPoster() {
    if (this.#posterDismissed) return;
    this.#posterDismissed = true;
    const shown = !this.#poster.hidden;
    this.#poster.hidden = true;
    if (shown) this.dispatchEvent(new CustomEvent('poster-dismissed', { detail: {} }));
  }

  disconnectedCallback() {
    // Moving the element within the page reconnects it at once: only a real removal stops the viewer.
    this.#teardown = setTimeout(() => {
      this.#teardown = null;
      nearby.unobserve(this);
      visibility.unobserve(this);
      sizes.unobserve(this);
      this.#unmount();
      this.#mounting = null;
    }, 0);
  }

  #unmount() {
    mounted.delete(this);
    this.#a11y?.clear();
    this.#viewer?.destroy();
    this.#viewer = null;
  }

  attributeChangedCallback(name, old, value) {
    if (['alt', 'controls', 'camera-controls', 'background'].includes(name)) this.#present();
    if (name === 'poster') this.#showPoster();
    if (['min-camera-orbit', 'max-camera-orbit', 'field-of-view', 'disable-zoom', 'disable-pan'].includes(name)) this.#applyLimits();
    if (name === 'camera-orbit' || name === 'camera-target') this.#applyCameraAttributes();
    if (name === 'auto-rotate-delay' || name === 'rotation-per-second') this.#readRotation();
    if (name === 'auto-rotate' || name === 'auto-rotate-delay') { this.#interacted = performance.now(); this.#wake(0); }
    if (['camera-controls', 'controls', 'interaction-prompt', 'interaction-prompt-threshold'].includes(name)) this.#schedulePrompt();
    if (name === 'loading' && value !== 'lazy' && this.isConnected && !this.#mounting) this[NEAR]();
    const viewer = this.#viewer;
    if (!viewer || old === value) return;
    try {
      this.#configure();
      switch (name) {
        case 'src':
          if (value) this.#loadUrl(value);
          break;
        // Before a model is shown the names cannot resolve: configure() above makes the next model start so.
        case 'animation-name': if (value && this.loaded) this.crossfadeTo(value, this.#crossfadeSeconds()); break;
        case 'speed': viewer.setSpeed(this.speed); break;
        case 'loop': viewer.setLoop(loopMode(value)); break;
        case 'crossfade-duration': case 'animation-crossfade-duration': viewer.setCrossfadeDuration(this.#crossfadeSeconds()); break;
        case 'layer-clip': case 'layer-root': {
          if (!this.loaded) break;
          const clip = this.getAttribute('layer-clip');
          const root = this.getAttribute('layer-root');
          if (!clip) viewer.setLayer(null, null, 0);
          else if (root) viewer.setLayer(clip, root, 1);
          break;
        }
        case 'skinning': if (value) viewer.setSkinning(value); break;
        case 'controls':
          // The panels are the full app's: the page moves to it (this viewer with its state).
          if (value !== null && build !== 'full') {
            ensureBuild('full').catch((e) => this.#fail(`controls: the full app could not be loaded: ${e.message ?? e}`));
            break;
          }
          viewer.setPanels(value !== null);
          if (value !== null) {
            // The mirror first: turning the tree on sends it whole with the next frame, once.
            this.#mirror().then(() => {
              if (this.#viewer !== viewer || !this.hasAttribute('controls')) return;
              viewer.setAccessibility?.(true);
              this.#wake(0);
            });
          } else {
            viewer.setAccessibility?.(false);
            this.#a11y?.clear();
          }
          if (!this.hasAttribute('background')) viewer.setBackground(this.#background());
          if (!this.hasAttribute('grid')) viewer.setGrid(this.grid);
          break;
        case 'background': viewer.setBackground(this.#background()); break;
        case 'grid': viewer.setGrid(this.grid); break;
        case 'exposure': viewer.setExposure(this.exposure); break;
        case 'tone-mapping': viewer.setToneMapping(this.toneMapping); break;
        case 'environment-image': this.#applyEnvironment(viewer); break;
        case 'shadow-intensity': case 'shadow-softness': viewer.setShadow(this.shadowIntensity, this.shadowSoftness); break;
        case 'backend': this.#remount(); break;
        default: break;
      }
      this.#wake(0);
    } catch (e) {
      this.#fail(e instanceof Error ? e.message : String(e));
    }
  }

  /**
   * Mounts a viewer on the shared runtime. `revive`: the state (a dataset snapshot) of a viewer lost to a panic,
   * shown again once its model is back.
   */
  async #mount(revive = null) {
    this.dataset.status = 'loading';
    try {
      if (!revive && this.getAttribute('src')) prefetchModel(this.getAttribute('src'), this.hasAttribute('controls') || this[NEEDS_FULL]);
      await ensureBuild(await buildFor(this));
      const onBuild = build;
      let glue = await loadRuntime();
      const source = () => (revive ? (revive.src || (this.#files ? null : this.getAttribute('src'))) : this.getAttribute('src'));
      // A sidecar is read by the second half: loaded before the viewer asks for it (downloaded since the module
      // was; a failure here leaves it to the synchronous load, which reports it). Removed meanwhile: stop; the
      // page's instance replaced meanwhile (a panic): the new one's.
      while (glue.loadRest && glue.restState() === null && !rest.held && sidecarHref(source() ?? '') !== null) {
        await glue.loadRest(compileRest(glue)).catch(() => {});
        if (!this.isConnected) {
          this.#mounting = null;
          return;
        }
        const now = await loadRuntime();
        if (now === glue) break;
        glue = now;
      }
      // Read after the wait: a src set meanwhile (the viewer did not exist to take it) is the one shown.
      const src = source();
      const viewer = new glue.Viewer();
      this.#viewer = viewer;
      this.#configure();
      const emit = (type, detail) => {
        // A request of the viewer's own, answered while the user's click is still being handled.
        if (type === 'kloub:open') this.#pickers[detail === 'folder' ? 1 : 0].click();
        else if (type === 'kloub:validate') this.validate().catch(() => {});
        else if (type === 'kloub:wake') this.#wake(Number(detail));
        else if (type === 'kloub:lost') this.#onLost(detail);
        else queueMicrotask(() => this.#dispatch(type, detail));
      };
      const backend = this.getAttribute('backend');
      viewer.setPanels(this.hasAttribute('controls'));
      viewer.setBackground(this.#background());
      viewer.setGrid(this.grid);
      if (this.hasAttribute('exposure')) viewer.setExposure(this.exposure);
      if (this.hasAttribute('tone-mapping')) viewer.setToneMapping(this.toneMapping);
      if (this.hasAttribute('environment-image')) this.#applyEnvironment(viewer);
      if (this.hasAttribute('shadow-intensity') || this.hasAttribute('shadow-softness')) viewer.setShadow(this.shadowIntensity, this.shadowSoftness);
      this.#applyLimits();
      if (revive && src) this.#reviveOnLoad(revive);
      await viewer.mount(this.#canvas, this, this.shadowRoot, emit, backend === 'auto' ? null : backend, src);
      // Removed from the page while starting: stop now (disconnectedCallback found nothing to stop).
      if (!this.isConnected && this.#viewer === viewer) {
        viewer.destroy();
        this.#viewer = null;
        this.#mounting = null;
        return;
      }
      mounted.add(this);
      // The page moved to another build while this one started: move over too.
      if (build !== onBuild) {
        this[MOVE]();
        return;
      }
      if (this.hasAttribute('controls')) await this.#mirror();
      this.#a11y?.clear();
      viewer.setAccessibility?.(this.hasAttribute('controls'));
      viewer.setReducedMotion?.(reducedMotion.matches);
      if (this.#samples.length > 0) viewer.setSamples(JSON.stringify(this.#samples));
      if (this.hasAttribute('crossfade-duration') || this.hasAttribute('animation-crossfade-duration')) {
        viewer.setCrossfadeDuration(this.#crossfadeSeconds());
      }
      if (this.hasAttribute('skinning')) viewer.setSkinning(this.getAttribute('skinning'));
      if (revive && !src && this.#files) {
        this.#reviveOnLoad(revive);
        this.#loadFiles(this.#files).catch((e) => this.#fail(String(e)));
      } else if (!src) {
        // No model to wait for: what was asked of the full app applies now.
        this.#moving = false;
        this.#flushAfterMove();
      }
      this.#wake(0);
    } catch (e) {
      const message = e instanceof Error ? e.message : String(e);
      if (this.dataset.status !== 'error') this.#fail(`Kloub could not start: ${message}`);
    }
  }

  /** The panels' mirror for assistive technology (made once, with `controls`): before the view in the shadow root,
   *  so that Tab walks the panel, then the 3D view. */
  async #mirror() {
    if (this.#a11y) return;
    const { AccessibilityMirror, ACCESSIBILITY_STYLE } = await import('./accessibility.js');
    if (this.#a11y) return;
    const root = this.shadowRoot;
    const style = document.createElement('style');
    style.textContent = ACCESSIBILITY_STYLE;
    root.prepend(style);
    this.#a11y = new AccessibilityMirror(root, (id, action, number, text) => {
      const viewer = this.#viewer;
      if (!viewer || this.#lost) return;
      viewer.accessibilityAction?.(id, action, number ?? undefined, text ?? undefined);
      this.#inputPending = true;
      this.#wake(0);
    }, (key) => {
      const viewer = this.#viewer;
      if (!viewer || this.#lost) return;
      viewer.key(key, key, true, 0);
      viewer.key(key, key, false, 0);
      this.#inputPending = true;
      this.#wake(0);
    });
    root.insertBefore(this.#a11y.root, this.#canvas);
  }

  /** After a panic: once the model is shown again, restores the rest of the view from the snapshot. */
  #reviveOnLoad(snapshot) {
    const state = import('./hash-state.js');
    this.#onModelBack = async () => {
      this.#onModelBack = null;
      const { viewToHash, hashToView, applyView } = await state;
      const view = hashToView(viewToHash(snapshot, null), () => {});
      if (snapshot.playing === 'true') delete view.paused;
      // The clip first (a cut), then the time on it.
      if (view.clip && view.clip !== this.dataset.clip) {
        try {
          this.crossfadeTo(view.clip, 0);
        } catch (e) {
          console.warn(`kloub: after recovery, clip could not be restored: ${e.message}`);
        }
      }
      applyView(this, view, (key, e) => console.warn(`kloub: after recovery, ${key} could not be restored: ${e.message}`));
      // The hash leaves out what equals the app's defaults; an embedded viewer's defaults differ (no grid, no
      // background), so these two are restored as they were.
      if (snapshot.grid === 'true' || snapshot.grid === 'false') this.setGrid(snapshot.grid === 'true');
      if (BACKGROUNDS.includes(snapshot.background)) this.setBackground(snapshot.background);
      // Set by method (an attribute is applied again at the mount).
      const exposure = Number(snapshot.exposure);
      if (!this.hasAttribute('exposure') && Number.isFinite(exposure) && exposure >= 0 && exposure <= MAX_EXPOSURE) this.setExposure(exposure);
      if (!this.hasAttribute('tone-mapping') && TONE_MAPPINGS.includes(snapshot.toneMapping)) this.setToneMapping(snapshot.toneMapping);
      // The environment and shadow chosen in the panel (an attribute is applied again at the mount).
      if (!this.hasAttribute('environment-image') && ENVIRONMENTS.includes(snapshot.environment)) this.#viewer?.setEnvironment(snapshot.environment);
      const [intensity, softness] = (snapshot.shadow ?? '').split(',').map(Number);
      if (!this.hasAttribute('shadow-intensity') && !this.hasAttribute('shadow-softness') && [intensity, softness].every((x) => x >= 0 && x <= 1)) {
        this.#viewer?.setShadow(intensity, softness);
      }
      if (snapshot.playing === 'true') this.play();
      else if (snapshot.playing === 'false') this.pause();
      if (snapshot.skinning && snapshot.skinning !== this.getAttribute('skinning')) this.setSkinning(snapshot.skinning);
      this.#flushAfterMove();
    };
  }

  /** Applies the calls that waited for the full app. */
  #flushAfterMove() {
    const calls = this.#afterMove;
    this.#afterMove = [];
    for (const [method, fn] of calls) {
      try {
        this.#call(method, fn);
      } catch (e) {
        this.#fail(e instanceof Error ? e.message : String(e));
      }
    }
  }

  /**
   * The page moved to another build (the full app): this viewer comes back on it from its state, without a second
   * `load` event.
   */
  [MOVE]() {
    if (!mounted.has(this)) return;
    // One last frame of the old viewer applies the calls it has not drawn yet (a pause, a seek, a camera set just
    // before the call that needed the full app), so that the snapshot below holds them.
    if (this.#viewer && !this.#lost) this.#draw(performance.now());
    mounted.delete(this);
    const snapshot = { ...this.dataset };
    this.#a11y?.clear();
    this.#viewer?.destroy();
    this.#viewer = null;
    this.#replaceCanvas();
    this.#lost = false;
    // A model already reported by `load` comes back quietly; one still loading reports its first `load` as usual.
    this.#moving = (snapshot.model ?? '') !== '';
    this.#mounting = this.#mount(snapshot);
  }

  [REVIVE](message, giveUp) {
    mounted.delete(this);
    // The old viewer belongs to the dead instance: dropped without a call.
    this.#viewer = null;
    if (giveUp) {
      this.#fail(`Kloub stopped after repeated internal errors: ${message}`);
      this.#showNote('Kloub stopped after repeated internal errors. Reload the page to try again.');
      return;
    }
    const snapshot = { ...this.dataset };
    this.#replaceCanvas();
    this.#lost = false;
    this.#showNote(null);
    this.#dispatch('error', `Kloub recovered from an internal error: ${message}`);
    this.#mounting = this.#mount(snapshot);
  }

  /** The page's device was lost: say so, then move to a new device (with a fresh canvas) as soon as there is one. */
  #onLost(detail) {
    if (this.#lost) return;
    this.#lost = true;
    this.dataset.status = 'lost';
    this.#showNote('The graphics context was lost; restoring…');
    console.warn(`kloub: device lost (${detail}); restoring`);
    const attempt = (n) => {
      const viewer = this.#viewer;
      if (!viewer || !this.#lost) return;
      setTimeout(() => {
        if (viewer !== this.#viewer) return;
        const previous = this.#canvas;
        this.#replaceCanvas();
        viewer.reattach(this.#canvas).then(() => {
          this.#lost = false;
          this.#showNote(null);
          this.#wake(0);
        }, (e) => {
          console.warn(`kloub: no new device yet (${e.message ?? e})`);
          if (n < 60) attempt(n + 1);
          else {
            previous.remove();
            this.#fail(`the graphics context was lost and could not be restored: ${e.message ?? e}`);
          }
        });
      }, Math.min(1000, 50 * 2 ** n)); // soon after the loss, then backing off to once a second
    };
    attempt(0);
  }

  #showNote(text) {
    this.#note.textContent = text ?? '';
    this.#note.hidden = !text;
  }

  /** The viewer wants a frame in `delay` ms. */
  #wake(delay) {
    const at = performance.now() + (Number.isFinite(delay) && delay > 0 ? delay : 0);
    if (at < this.#due) this.#due = at;
    if (mounted.has(this)) requestFrame();
  }

  /** The frame loop's call: draws when in view and due; returns [when next due, frames drawn]. */
  [TICK](now) {
    const viewer = this.#viewer;
    if (!viewer || this.#lost || !this.#inView || document.hidden) return [Infinity, 0];
    if (now < this.#due) return [this.#due, 0];
    return this.#draw(now);
  }

  /** Draws a frame now; returns [when the next is due, frames drawn]. */
  #draw(now) {
    const viewer = this.#viewer;
    if (!viewer || this.#lost) return [Infinity, 0];
    this.#inputPending = false;
    this.#dragged = false;
    const css = this.#cssSize ?? [this.#canvas.clientWidth, this.#canvas.clientHeight];
    if (css[0] <= 0 || css[1] <= 0) {
      this.#due = Infinity;
      return [Infinity, 0];
    }
    const dpr = window.devicePixelRatio || 1;
    const floor = Math.min(dpr, this.#minPixelRatio());
    const ppp = this.hasAttribute('controls') ? dpr : Math.max(floor, dpr * loop.scale);
    this.#ppp = ppp;
    const rotating = this.#autoRotate(now);
    const next = viewer.frame(now, Math.max(1, Math.round(css[0] * ppp)), Math.max(1, Math.round(css[1] * ppp)), ppp);
    if (next < 0) {
      this.#onLost('the device is gone');
      return [Infinity, 0];
    }
    this.#lastDraw = now;
    const mirrored = viewer.takeAccessibility?.();
    if (mirrored !== undefined) this.#a11y?.apply(mirrored);
    const camera = this.dataset.camera ?? '';
    if (this.loaded && camera !== this.#lastCamera) {
      const source = this.#userInput ? 'user-interaction' : 'none';
      if (this.#lastCamera !== '') queueMicrotask(() => this.dispatchEvent(new CustomEvent('camera-change', { detail: { source } })));
      this.#lastCamera = camera;
    }
    this.#userInput = false;
    // Turning, the next frame is due at once; waiting for the delay, when it ends.
    const wait = rotating === null ? next : rotating;
    this.#due = now + Math.min(next, wait);
    return [this.#due, 1];
  }

  /**
   * model-viewer's `interaction-prompt` (`auto`, the default, or `none`): with `camera-controls` (and without the
   * app's panels), a hint to drag shows after `interaction-prompt-threshold` ms (default 3000) from the load without
   * the user moving the camera, and goes for good at the first input.
   */
  #schedulePrompt() {
    clearTimeout(this.#promptTimer);
    this.#promptTimer = null;
    const wanted = this.hasAttribute('camera-controls') && !this.hasAttribute('controls')
      && this.getAttribute('interaction-prompt') !== 'none' && !this.#userMoved && this.loaded;
    if (!wanted) {
      this.#prompt.hidden = true;
      return;
    }
    const t = Number(this.getAttribute('interaction-prompt-threshold') ?? 3000);
    const delay = Number.isFinite(t) && t >= 0 ? Math.min(t, 600000) : 3000;
    this.#promptTimer = setTimeout(() => {
      this.#promptTimer = null;
      if (!this.#userMoved && this.isConnected) this.#prompt.hidden = false;
    }, delay);
  }

  /** `controls` or `camera-controls`: the view takes pointer, wheel, touch and keys. */
  #interactive() { return this.hasAttribute('controls') || this.hasAttribute('camera-controls'); }

  /**
   * `auto-rotate`: turns the camera about the target at `rotation-per-second` (default π/32 rad, as model-viewer),
   * from `auto-rotate-delay` ms (default 3000) after the load or the user's last camera input. Returns null when
   * not rotating, 0 when turning (the next frame is due now), else the ms left of the delay.
   */
  #autoRotate(now) {
    if (!this.hasAttribute('auto-rotate') || !this.loaded || this.#framed === null) return null;
    const { delay, rate } = this.#rotation;
    const left = this.#interacted + delay - now;
    if (left > 0) return left;
    const dt = Math.min(0.1, Math.max(0, (now - this.#lastDraw) / 1000));
    const c = this.camera;
    if (c.length === 6 && dt > 0) this.#viewer.setCamera(c[0] + rate * dt, c[1], c[2], c[3], c[4], c[5]);
    return 0;
  }

  /**
   * `min-camera-orbit` / `max-camera-orbit` ("θ φ r", `auto`: unbounded there; φ is measured down from +Y, so the
   * smallest φ bounds the pitch from above; r in `%` of the framed distance once a model is framed),
   * `field-of-view` (`auto`: 45°), `disable-zoom`, `disable-pan`: sent to the viewer, which holds every camera
   * change (input, attributes, methods) inside them.
   */
  #applyLimits() {
    const viewer = this.#viewer;
    if (!viewer) return;
    const framedDistance = this.#framed?.[2] ?? NaN;
    const orbit = (attr) => {
      const text = this.getAttribute(attr);
      if (text === null) return [NaN, NaN, NaN];
      try {
        return orbitTokens(attr, text, framedDistance).map((v) => v ?? NaN);
      } catch (e) {
        console.warn(`kloub-viewer: ${e.message}`);
        return [NaN, NaN, NaN];
      }
    };
    const [yawMin, phiMin, rMin] = orbit('min-camera-orbit');
    const [yawMax, phiMax, rMax] = orbit('max-camera-orbit');
    let fov = NaN;
    const fovText = this.getAttribute('field-of-view');
    if (fovText !== null) {
      try { fov = parseAngle('field-of-view', fovText.trim()) ?? NaN; } catch (e) { console.warn(`kloub-viewer: ${e.message}`); }
    }
    viewer.setCameraLimits(yawMin, yawMax, Math.PI / 2 - phiMax, Math.PI / 2 - phiMin, rMin, rMax,
      !this.hasAttribute('disable-zoom'), !this.hasAttribute('disable-pan'), fov);
    this.#wake(0);
  }

  /** Reads `auto-rotate-delay` and `rotation-per-second` (an unreadable one warns once and keeps its default). */
  #readRotation() {
    const delay = Number(this.getAttribute('auto-rotate-delay') ?? 3000);
    let rate = Math.PI / 32;
    const text = this.getAttribute('rotation-per-second');
    if (text) {
      try { rate = parseAngle('rotation-per-second', text.trim()) ?? rate; } catch (e) { console.warn(`kloub-viewer: ${e.message}`); }
    }
    this.#rotation = { delay: Number.isFinite(delay) && delay >= 0 ? delay : 3000, rate };
  }

  /** Applies `camera-orbit` and `camera-target` over the camera the model was framed with. */
  #applyCameraAttributes() {
    const framed = this.#framed;
    if (!framed || !this.#viewer) return;
    const orbit = this.getAttribute('camera-orbit');
    const target = this.getAttribute('camera-target');
    if (orbit === null && target === null) return;
    try {
      const [yaw, pitch, distance] = orbit === null ? framed.slice(0, 3) : parseOrbit(orbit, framed);
      const [x, y, z] = target === null ? framed.slice(3) : parseTarget(target, framed);
      this.#viewer.setCamera(yaw, pitch, distance, x, y, z);
      this.#wake(0);
    } catch (e) {
      console.warn(`kloub-viewer: ${e.message}`);
    }
  }

  /** The `background` attribute, or the default: `transparent` for an embedded viewer (the page shows through, as
   *  with model-viewer), `dark` for the app (`controls`). An unknown value is warned about and the default used. */
  #background() {
    const value = this.getAttribute('background');
    if (value !== null && BACKGROUNDS.includes(value)) return value;
    // A CSS colour is painted behind the canvas (see #present), which the scene leaves transparent.
    if (this.#cssBackground() !== null) return 'transparent';
    if (value !== null) console.warn(`kloub-viewer: background "${value}" is neither one of ${BACKGROUNDS.join(', ')} nor a CSS colour`);
    return this.hasAttribute('controls') ? 'dark' : 'transparent';
  }

  #minPixelRatio() {
    const v = Number(this.getAttribute('min-pixel-ratio') ?? 0.5);
    return Number.isFinite(v) && v > 0 ? Math.min(v, 8) : 0.5;
  }

  /** In view or not (`null`: the page's visibility changed). Out of view nothing is drawn; back in view, the clocks
   *  jump by the time away, as if the viewer had kept playing. */
  [SHOW](inView) {
    if (inView !== null) this.#inView = inView;
    const shown = this.#inView && !document.hidden;
    const now = performance.now();
    if (!shown) {
      if (this.#hiddenAt === null && this.#viewer?.animating) this.#hiddenAt = now;
      return;
    }
    if (this.#hiddenAt !== null) {
      this.#viewer?.catchUp((now - this.#hiddenAt) / 1000);
      this.#hiddenAt = null;
      this.#wake(0);
    } else if (mounted.has(this)) {
      // The canvas still shows the last frame: draw only what was asked for meanwhile (a frame due).
      requestFrame();
    }
  }

  [SIZE](width, height) {
    this.#cssSize = [width, height];
    this.#wake(0);
  }

  /** Loads the model at `url` in the mounted viewer; one with a sidecar asks for the second half now (it reads it). */
  #loadUrl(url) {
    if (sidecarHref(url) !== null) wantRest();
    this.#viewer?.loadUrl(url);
  }

  #remount() {
    this.#unmount();
    // A fresh canvas: a context of the other backend cannot be created on the old one.
    this.#replaceCanvas();
    this.#mounting = this.#mount();
  }

  #configure() {
    const layerClip = this.getAttribute('layer-clip');
    const layerRoot = this.getAttribute('layer-root');
    this.#viewer?.configure(this.hasAttribute('autoplay'), this.getAttribute('animation-name'), this.speed,
      loopMode(this.getAttribute('loop')), layerClip, layerRoot);
  }

  /** `crossfade-duration` (seconds), else model-viewer's `animation-crossfade-duration` (milliseconds); 0.3 s. */
  #crossfadeSeconds() {
    const text = this.getAttribute('crossfade-duration');
    const ms = this.getAttribute('animation-crossfade-duration');
    const s = text !== null ? Number(text) : ms !== null ? Number(ms) / 1000 : NaN;
    return Number.isFinite(s) && s >= 0 ? Math.min(s, MAX_SECONDS) : 0.3;
  }

  #dispatch(type, detail) {
    let data;
    switch (type) {
      case 'error': wantRest(); data = { message: detail }; break;
      case 'load':
        wantRest();
        if (this.#onModelBack) this.#onModelBack();
        if (this.#moving) {
          this.#moving = false;
          this.#applyLimits();
          return;
        }
        data = { name: detail };
        // The framing of the new model is what camera-orbit/camera-target's `auto` and `%` refer to.
        this.#framed = this.camera.length === 6 ? this.camera : null;
        this.#interacted = performance.now();
        this.#applyLimits();
        this.#applyCameraAttributes();
        this.#schedulePrompt();
        // The first frame of a model is on screen: the poster goes, unless the page reveals it itself.
        if (this.getAttribute('reveal') !== 'manual') queueMicrotask(() => this.dismissPoster());
        break;
      case 'progress': data = { totalProgress: Number(detail) }; break;
      case 'timeupdate': this.#pendingTime = null; data = { currentTime: Number(detail) }; break;
      case 'loop': data = { count: Number(detail) }; break;
      default: data = {};
    }
    this.dispatchEvent(new CustomEvent(type, { detail: data }));
  }

  /**
   * `environment-image`: a name, or the URL of a Radiance .hdr image fetched here and handed to the viewer. A file
   * that cannot be fetched or read is an `error` event; the model and the light before it stay.
   */
  #applyEnvironment(viewer) {
    const value = this.getAttribute('environment-image') ?? '';
    if (value === '' || ENVIRONMENTS.includes(value)) {
      viewer.setEnvironment(value);
      return;
    }
    // A photograph still on its way is no longer wanted: the light stays as it is until this image is in.
    viewer.dropPendingEnvironment();
    const report = (message) => {
      const text = `environment-image: ${value}: ${message}`;
      console.warn(`kloub: ${text}`);
      this.#dispatch('error', text);
    };
    (async () => {
      const response = await fetch(new URL(value, document.baseURI));
      if (!response.ok) throw new Error(`HTTP ${response.status}`);
      const length = Number(response.headers.get('content-length'));
      if (length > MAX_HDR_BYTES) throw new Error(`${length} bytes: at most ${MAX_HDR_BYTES} are read`);
      const bytes = new Uint8Array(await response.arrayBuffer());
      if (bytes.length > MAX_HDR_BYTES) throw new Error(`${bytes.length} bytes: at most ${MAX_HDR_BYTES} are read`);
      // Changed or unmounted meanwhile: this image is no longer wanted.
      if (this.#viewer !== viewer || this.getAttribute('environment-image') !== value) return;
      viewer.setEnvironmentImage(bytes);
      this.#wake(0);
    })().catch((e) => {
      // Changed or unmounted meanwhile: nobody asks for this image any more.
      if (this.#viewer !== viewer || this.getAttribute('environment-image') !== value) return;
      report(e instanceof Error ? e.message : String(e));
    });
  }

  #fail(message) {
    this.dataset.status = 'error';
    this.dataset.error = message;
    this.#dispatch('error', message);
  }

  #require() {
    if (!this.#viewer) throw new Error('kloub-viewer: not started yet (wait for the load event)');
    return this.#viewer;
  }

  /**
   * Calls the viewer; what it throws reaches the page as an Error whose message starts with `method`. `full`: the
   * call needs the full app (IK handles, overlays, the ragdoll): on the widget build the full app is loaded first and
   * the call applies once the model is back on it (an error then comes as an `error` event).
   */
  #call(method, fn, full = false) {
    const viewer = this.#require();
    if (full && build !== 'full') {
      this[NEEDS_FULL] = true;
      this.#afterMove.push([method, fn]);
      ensureBuild('full').catch((e) => this.#fail(`${method}: the full app could not be loaded: ${e.message ?? e}`));
      return undefined;
    }
    try {
      return fn(viewer);
    } catch (e) {
      if (e instanceof Error) {
        if (!e.message.startsWith(`${method}:`)) e.message = `${method}: ${e.message}`;
        throw e;
      }
      throw new RangeError(`${method}: ${String(e)}`);
    }
  }

  async #loadFiles(entries) {
    this.#files = entries;
    const names = entries.map((e) => e.name);
    const contents = await Promise.all(entries.map(async (e) => new Uint8Array(await e.file.arrayBuffer())));
    this.#require().loadFiles(names, contents);
  }

  // ---- attributes as properties ----

  get src() { return this.getAttribute('src') ?? ''; }
  set src(value) { this.setAttribute('src', url('src', 'value', value)); }
  /** The ground grid: the `grid` attribute (present: on, `grid="false"`: off), by default on with `controls` only. */
  get grid() {
    const value = this.getAttribute('grid');
    return value === null ? this.hasAttribute('controls') : value !== 'false';
  }
  set grid(on) { this.setAttribute('grid', bool('grid', 'on', on) ? '' : 'false'); }
  get background() { return this.#cssBackground() ?? this.#background(); }
  set background(value) {
    if (typeof value !== 'string' || !(BACKGROUNDS.includes(value) || CSS.supports('color', value))) {
      throw new RangeError(`background: expected one of ${BACKGROUNDS.join(', ')} or a CSS colour, got ${describe(value)}`);
    }
    this.setAttribute('background', value);
  }
  /** Exposure (attribute `exposure`, model-viewer's): a factor on the shaded colour before tone mapping, 0 to 64;
   *  1 (as lit) when absent or not such a number. */
  get exposure() {
    const value = this.getAttribute('exposure');
    const e = value === null || value.trim() === '' ? NaN : Number(value);
    return Number.isFinite(e) && e >= 0 && e <= MAX_EXPOSURE ? e : 1;
  }
  set exposure(value) { this.setAttribute('exposure', String(num('exposure', 'value', value, { min: 0, max: MAX_EXPOSURE }))); }
  /** Tone mapping (attribute `tone-mapping`, model-viewer's): `neutral` (Khronos PBR Neutral, the default), `aces` or
   *  `none`; model-viewer's `auto` reads as `neutral`, `linear` as `none`, anything else as `neutral`. */
  get toneMapping() {
    const value = this.getAttribute('tone-mapping') ?? 'neutral';
    const name = TONE_ALIASES[value] ?? value;
    return TONE_MAPPINGS.includes(name) ? name : 'neutral';
  }
  set toneMapping(value) {
    const accepted = [...TONE_MAPPINGS, ...Object.keys(TONE_ALIASES)];
    this.setAttribute('tone-mapping', oneOf('toneMapping', 'value', value, accepted));
  }
  /** The ground shadow's darkness (attribute `shadow-intensity`, model-viewer's): 0 (none) to 1; Kloub's default,
   *  when absent or not such a number, is 0.6 (model-viewer's is 0: off). */
  get shadowIntensity() { return unitAttribute(this.getAttribute('shadow-intensity'), DEFAULT_SHADOW_INTENSITY); }
  set shadowIntensity(value) { this.setAttribute('shadow-intensity', String(num('shadowIntensity', 'value', value, { min: 0, max: 1 }))); }
  /** The ground shadow's blur (attribute `shadow-softness`, model-viewer's): 0 (sharp) to 1 (the default). */
  get shadowSoftness() { return unitAttribute(this.getAttribute('shadow-softness'), 1); }
  set shadowSoftness(value) { this.setAttribute('shadow-softness', String(num('shadowSoftness', 'value', value, { min: 0, max: 1 }))); }
  /** The environment lighting the model (attribute `environment-image`, model-viewer's): `neutral`, `studio`,
   *  `outdoor`, or the URL of a Radiance .hdr image; `''` (absent) for the lighting preset's own. */
  get environmentImage() { return this.getAttribute('environment-image') ?? ''; }
  set environmentImage(value) {
    if (value === '' || value === null) this.removeAttribute('environment-image');
    else this.setAttribute('environment-image', url('environmentImage', 'value', value));
  }
  /** When the model is fetched (attribute `loading`): `auto` and `eager` at once, `lazy` when the element nears
   *  the viewport. */
  get loading() { const v = this.getAttribute('loading'); return v === 'lazy' || v === 'eager' ? v : 'auto'; }
  set loading(value) { this.setAttribute('loading', oneOf('loading', 'value', value, ['auto', 'lazy', 'eager'])); }
  /** An image shown until the model's first frame (attribute `poster`). */
  get poster() { return this.getAttribute('poster') ?? ''; }
  set poster(value) { this.setAttribute('poster', url('poster', 'value', value)); }
  /** `auto`: the poster goes at the model's first frame; `manual`: at `dismissPoster()` (attribute `reveal`). */
  get reveal() { return this.getAttribute('reveal') === 'manual' ? 'manual' : 'auto'; }
  set reveal(value) { this.setAttribute('reveal', oneOf('reveal', 'value', value, ['auto', 'manual'])); }
  /** The accessible name (attribute `alt`). */
  get alt() { return this.getAttribute('alt') ?? ''; }
  set alt(value) { this.setAttribute('alt', str('alt', 'value', value)); }
  get autoplay() { return this.hasAttribute('autoplay'); }
  set autoplay(on) { this.toggleAttribute('autoplay', Boolean(on)); }
  get animationName() { return this.dataset.clip ?? ''; }
  set animationName(value) { this.setAttribute('animation-name', str('animationName', 'value', value)); }
  get speed() {
    const s = Number(this.getAttribute('speed') ?? 1);
    return Number.isFinite(s) && Math.abs(s) <= MAX_SPEED ? s : 1;
  }
  set speed(value) { this.setAttribute('speed', String(num('speed', 'value', value, { min: -MAX_SPEED, max: MAX_SPEED }))); }
  get loop() { return loopMode(this.getAttribute('loop')); }
  set loop(mode) { this.setAttribute('loop', oneOf('loop', 'mode', mode, [...LOOP_MODES])); }
  get skinning() { return this.dataset.skinning ?? this.getAttribute('skinning') ?? 'lbs'; }
  set skinning(method) { this.setAttribute('skinning', oneOf('skinning', 'method', method, SKINNING)); }
  get backend() { return this.dataset.backend ?? ''; }
  get controls() { return this.hasAttribute('controls'); }
  set controls(on) { this.toggleAttribute('controls', Boolean(on)); }

  // ---- media-element vocabulary ----

  /** Runs every clock. */
  play() { this.#call('play', (v) => v.play()); }
  /** Stops every clock. */
  pause() { this.#call('pause', (v) => v.pause()); }
  get paused() { return this.dataset.playing !== 'true'; }
  get currentTime() { return this.#pendingTime ?? Number(this.dataset.time ?? 0); }
  set currentTime(seconds) {
    num('currentTime', 'seconds', seconds);
    this.#call('currentTime', (v) => v.seek(seconds));
    const d = this.duration;
    this.#pendingTime = Math.min(Math.max(seconds, 0), d > 0 ? d : seconds);
  }
  get duration() { return Number(this.dataset.duration ?? 0) || 0; }
  get availableAnimations() { return JSON.parse(this.dataset.clips ?? '[]'); }
  /** True once a model is shown. */
  get loaded() { return (this.dataset.model ?? '') !== '' && this.dataset.status !== 'loading'; }

  /** Crossfades to the clip `name` over `seconds` (default: crossfade-duration). */
  crossfadeTo(name, seconds = this.#crossfadeSeconds()) {
    const m = 'crossfadeTo';
    optStr(m, 'name', name);
    num(m, 'seconds', seconds, { min: 0, max: MAX_SECONDS });
    this.#call(m, (v) => v.crossfadeTo(name ?? null, seconds));
  }
  /** Plays `clip` on the subtree under the joint `rootJoint` with `weight` in [0, 1]; a null clip removes it. */
  setLayer(clip, rootJoint, weight = 1) {
    const m = 'setLayer';
    optStr(m, 'clip', clip);
    if (clip === null || clip === undefined) optStr(m, 'rootJoint', rootJoint);
    else str(m, 'rootJoint', rootJoint);
    num(m, 'weight', weight, { min: 0, max: 1 });
    this.#call(m, (v) => v.setLayer(clip ?? null, rootJoint ?? null, weight));
  }
  /** Drags `joint` to the world point `[x, y, z]` by IK (`depth` joints above it turn); null clears every goal. */
  setIkTarget(joint, target, depth) {
    const m = 'setIkTarget';
    optStr(m, 'joint', joint);
    const point = target === null || target === undefined ? [] : vec3(m, 'target', target);
    if (depth !== undefined && depth !== null) num(m, 'depth', depth, { min: 1, max: 31, integer: true });
    const [x, y, z] = point;
    this.#call(m, (v) => v.setIkTarget(joint ?? null, x, y, z, depth ?? undefined), true);
  }
  /**
   * The solver of `joint`'s IK goal ('ccd' | 'twobone' | 'fabrik' | 'dls') and its options:
   * `{ pole: [x, y, z] | null, softness, patternMove, iterations }` (left out: unchanged; no pole: none).
   */
  setIkSolver(joint, solver, options) {
    const m = 'setIkSolver';
    str(m, 'joint', joint);
    oneOf(m, 'solver', solver, IK_SOLVERS);
    options ??= {};
    obj(m, '{ pole, softness, patternMove, iterations }', options);
    const { pole, softness, patternMove, iterations } = options;
    const [x, y, z] = pole === null || pole === undefined ? [] : vec3(m, 'options.pole', pole);
    if (softness !== undefined) num(m, 'options.softness', softness, { min: 0, max: 0.5 });
    if (patternMove !== undefined) bool(m, 'options.patternMove', patternMove);
    if (iterations !== undefined) num(m, 'options.iterations', iterations, { min: 1, max: 128, integer: true });
    this.#call(m, (v) => v.setIkSolver(joint, solver, x, y, z, softness, patternMove, iterations), true);
  }

  /**
   * Shows a model: a URL, or files (a FileList or File[]; a .gltf with its .bin and textures).
   * Resolves with the model's name after its first painted frame; rejects with its error.
   */
  load(urlOrFiles) {
    const m = 'load';
    let files = null;
    if (typeof urlOrFiles === 'string' || urlOrFiles instanceof URL) {
      url(m, 'urlOrFiles', String(urlOrFiles));
    } else if (urlOrFiles !== null && typeof urlOrFiles === 'object' && typeof urlOrFiles.length === 'number') {
      files = Array.from(urlOrFiles);
      if (files.length === 0) throw new RangeError(`${m}: urlOrFiles is empty: expected a URL or at least one File`);
      if (!files.every((f) => f instanceof Blob && typeof f.name === 'string')) {
        throw new TypeError(`${m}: urlOrFiles must be a URL string, a URL, a FileList or an array of File`);
      }
    } else {
      throw new TypeError(`${m}: urlOrFiles must be a URL string, a URL, a FileList or an array of File, got ${describe(urlOrFiles)}`);
    }
    const viewer = this.#require();
    const done = new Promise((resolve, reject) => {
      const ok = (e) => { off(); resolve(e.detail.name); };
      const bad = (e) => {
        // An environment that could not be had is not the model's error: the load goes on.
        if (String(e.detail?.message).startsWith('environment-image:')) return;
        off();
        reject(new Error(e.detail.message));
      };
      const off = () => { this.removeEventListener('load', ok); this.removeEventListener('error', bad); };
      this.addEventListener('load', ok);
      this.addEventListener('error', bad);
    });
    if (files === null) {
      this.#loadUrl(String(urlOrFiles));
    } else {
      const entries = files.map((file) => ({ name: file.webkitRelativePath || file.name, file }));
      this.#loadFiles(entries).catch((e) => this.#fail(String(e)));
    }
    return done;
  }

  /**
   * Validates the shown model with the Khronos glTF-Validator (fetched on the first call, run in a worker): the
   * dropped files, or the file at `data-src` with the files it refers to. Resolves with the validator's report
   * (`{ issues: { numErrors, numWarnings, numInfos, numHints, messages: [{ code, message, severity, pointer }] }, … }`;
   * severity 0 error, 1 warning, 2 info, 3 hint) and dispatches `validation`; with `controls` the panel lists it.
   */
  async validate() {
    const m = 'validate';
    const viewer = this.#require();
    const shown = this.dataset.model;
    const finish = (summary) => {
      if (typeof viewer.setValidation === 'function') viewer.setValidation(JSON.stringify(summary));
    };
    try {
      if (!shown) throw new Error('no model is shown');
      const src = this.dataset.src;
      const zipped = 'a model inside a .zip archive cannot be validated; drop or link its files';
      let request;
      let transfer = [];
      if (src && /\.zip([?#]|$)/i.test(src)) throw new Error(zipped);
      if (src) {
        const response = await fetch(src);
        if (!response.ok) throw new Error(`${src}: HTTP ${response.status}`);
        const bytes = await response.arrayBuffer();
        request = { name: shown, bytes, files: null, base: new URL(src, document.baseURI).href };
        transfer = [bytes];
      } else {
        const entries = this.#files ?? [];
        const main = entries.find((e) => e.name === shown || e.name.split('/').pop() === shown);
        if (!main && entries.some((e) => /\.zip$/i.test(e.name))) throw new Error(zipped);
        if (!main) throw new Error(`the files of ${shown} are not at hand`);
        // The File objects themselves: the worker reads only the ones the model refers to, without a copy here.
        const files = {};
        for (const e of entries) files[e.name.replace(/\\/g, '/')] = e.file;
        request = { name: main.name, bytes: main.file, files, base: null };
      }
      const report = await validateInWorker(request, transfer);
      const issues = report.issues ?? {};
      const summary = {
        name: shown,
        validator: `${report.validatorVersion ?? ''}`,
        errors: issues.numErrors ?? 0,
        warnings: issues.numWarnings ?? 0,
        infos: issues.numInfos ?? 0,
        hints: issues.numHints ?? 0,
        truncated: issues.truncated === true,
        issues: (issues.messages ?? []).slice(0, 500).map((i) => ({ severity: i.severity, code: i.code, pointer: i.pointer ?? '', message: i.message })),
      };
      finish(summary);
      this.dispatchEvent(new CustomEvent('validation', { detail: { report, errors: summary.errors, warnings: summary.warnings, infos: summary.infos, hints: summary.hints } }));
      return report;
    } catch (e) {
      const message = `${m}: ${e instanceof Error ? e.message : String(e)}`;
      finish({ name: shown ?? '', error: message });
      throw new Error(message);
    }
  }

  // ---- the rest of the viewer ----

  playClip(name) {
    optStr('playClip', 'name', name);
    this.#call('playClip', (v) => v.playClip(name ?? null));
  }
  seek(seconds) {
    num('seek', 'seconds', seconds);
    this.currentTime = seconds;
  }
  setSpeed(speed) {
    num('setSpeed', 'speed', speed, { min: -MAX_SPEED, max: MAX_SPEED });
    this.speed = speed;
  }
  setLoop(mode) {
    oneOf('setLoop', 'mode', mode, [...LOOP_MODES]);
    this.#call('setLoop', (v) => v.setLoop(mode));
  }
  setBlend(names, weights) {
    const m = 'setBlend';
    if (!Array.isArray(names)) throw new TypeError(`${m}: names must be an array of clip names, got ${describe(names)}`);
    if (!Array.isArray(weights) && !ArrayBuffer.isView(weights)) throw new TypeError(`${m}: weights must be an array of numbers, got ${describe(weights)}`);
    if (names.length !== weights.length) throw new RangeError(`${m}: ${names.length} names but ${weights.length} weights`);
    if (names.length > MAX_LIST) throw new RangeError(`${m}: ${names.length} clips: at most ${MAX_LIST}`);
    names.forEach((n, i) => str(m, `names[${i}]`, n));
    const w = Array.from(weights, (x, i) => num(m, `weights[${i}]`, x, { min: 0, max: 1e6 }));
    this.#call(m, (v) => v.setBlend(names, Float32Array.from(w)));
  }
  /**
   * How clip changes crossfade: `{ duration, easing, outgoing }` — seconds (the `crossfade-duration` attribute),
   * 'smoothstep' | 'linear', and what the outgoing clip does: 'freeze' | 'keep' (keeps playing) | 'sync' (keeps
   * playing, the new clip starts in step). Keys left out stay as they are.
   */
  setTransition(options) {
    const m = 'setTransition';
    obj(m, '{ duration, easing, outgoing }', options);
    const { duration, easing, outgoing } = options;
    if (duration !== undefined) num(m, 'duration', duration, { min: 0, max: MAX_SECONDS });
    if (easing !== undefined) oneOf(m, 'easing', easing, EASINGS);
    if (outgoing !== undefined) oneOf(m, 'outgoing', outgoing, OUTGOING);
    this.#call(m, (v) => v.setTransition(easing ?? null, outgoing ?? null));
    if (duration !== undefined) this.setAttribute('crossfade-duration', String(duration));
  }
  setSkinning(method) {
    oneOf('setSkinning', 'method', method, SKINNING);
    this.#call('setSkinning', (v) => v.setSkinning(method));
  }
  setSkinningPath(path) {
    oneOf('setSkinningPath', 'path', path, SKINNING_PATHS);
    this.#call('setSkinningPath', (v) => v.setSkinningPath(path));
  }
  setHeatmap(on) {
    bool('setHeatmap', 'on', on);
    this.#call('setHeatmap', (v) => v.setHeatmap(on));
  }
  setGrid(on) {
    bool('setGrid', 'on', on);
    this.#call('setGrid', (v) => v.setGrid(on));
  }
  /** Exposure, 0 to 64 (1: as lit): a factor on the shaded colour before tone mapping. */
  setExposure(exposure) {
    num('setExposure', 'exposure', exposure, { min: 0, max: MAX_EXPOSURE });
    this.#call('setExposure', (v) => v.setExposure(exposure));
  }
  /** Turns the environment about the vertical axis by `degrees` (counter-clockwise seen from above). */
  setEnvironmentRotation(degrees) {
    num('setEnvironmentRotation', 'degrees', degrees);
    this.#call('setEnvironmentRotation', (v) => v.setEnvironmentRotation(degrees));
  }
  /** Tone mapping: `neutral` (Khronos PBR Neutral), `aces` or `none`. */
  setToneMapping(name) {
    oneOf('setToneMapping', 'name', name, TONE_MAPPINGS);
    this.#call('setToneMapping', (v) => v.setToneMapping(name));
  }
  /** Overlays: `{ skeleton, bounds, wireframe, normals, bodies }` (missing keys: off). */
  setOverlays(overlays = {}) {
    const m = 'setOverlays';
    obj(m, 'an object such as { skeleton: true }', overlays);
    const keys = ['skeleton', 'bounds', 'wireframe', 'normals', 'bodies'];
    const on = keys.map((k) => (overlays[k] === undefined ? false : bool(m, k, overlays[k])));
    this.#call(m, (v) => v.setOverlays(...on), true);
  }
  /**
   * Drops the character as a ragdoll from the pose on screen; `{strength}` (0 limp, the default, to 1) powers it
   * towards the clip as it plays on (seed 000's animation + physics correction).
   */
  startRagdoll(options = {}) {
    const m = 'startRagdoll';
    obj(m, '{ strength }', options);
    const { strength } = options;
    if (strength !== undefined) num(m, 'strength', strength, { min: 0, max: 1 });
    this.#call(m, (v) => v.startRagdoll(strength), true);
  }
  /**
   * The ragdoll's obstacles: `[{shape: 'box' | 'sphere' | 'capsule' | 'stairs' | 'ramp', center: [x, y, z], size?,
   * radius?, height?, steps?, rotation?}]` in model units (see the README); `data-obstacles` mirrors them.
   */
  setObstacles(list) {
    const m = 'setObstacles';
    if (!Array.isArray(list)) throw new TypeError(`${m}: expected an array of obstacles, got ${describe(list)}`);
    let json;
    try {
      json = JSON.stringify(list);
    } catch (e) {
      throw new TypeError(`${m}: the list is not JSON: ${e.message}`);
    }
    this.#call(m, (v) => v.setObstacles(json), true);
  }
  /** Ends the ragdoll: at once, or blending back to the animation over `seconds`. */
  stopRagdoll(seconds) {
    if (seconds !== undefined && seconds !== null) num('stopRagdoll', 'seconds', seconds, { min: 0, max: MAX_SECONDS });
    this.#call('stopRagdoll', (v) => v.stopRagdoll(seconds ?? undefined), true);
  }
  /** Ragdoll gravity (m/s² for a person-sized body) and damping. */
  setRagdollOptions(options = {}) {
    const m = 'setRagdollOptions';
    obj(m, '{ gravity, damping }', options);
    const { gravity = 9.81, damping = 0.5 } = options;
    num(m, 'gravity', gravity, { min: -1000, max: 1000 });
    num(m, 'damping', damping, { min: 0, max: 1000 });
    this.#call(m, (v) => v.setRagdollOptions(gravity, damping), true);
  }
  /** Selects a joint by name (axes drawn, channels plotted in the panel); null clears. */
  selectJoint(name) {
    optStr('selectJoint', 'name', name);
    this.#call('selectJoint', (v) => v.selectJoint(name ?? null), true);
  }
  /** Holds morph target `target` (index or name) of the mesh on `node` at `weight`; null lets the clip drive it. */
  setMorphWeight(node, target, weight) {
    const m = 'setMorphWeight';
    str(m, 'node', node);
    if (typeof target === 'number') num(m, 'target', target, { min: 0, max: 65535, integer: true });
    else if (typeof target !== 'string') throw new TypeError(`${m}: target must be an index or a name, got ${describe(target)}`);
    else str(m, 'target', target);
    if (weight !== undefined && weight !== null) num(m, 'weight', weight, { min: -10, max: 10 });
    this.#call(m, (v) => v.setMorphWeight(node, target, weight ?? undefined));
  }
  /**
   * Holds joint `name`'s local rotation (a unit quaternion `[x, y, z, w]` in its parent's frame) over the animation;
   * null lets the animation drive it again. IK solves on top of it.
   */
  setJointRotation(name, rotation) {
    const m = 'setJointRotation';
    str(m, 'name', name);
    if (rotation !== null && rotation !== undefined) {
      if (!Array.isArray(rotation) || rotation.length !== 4) throw new TypeError(`${m}: rotation must be [x, y, z, w], got ${describe(rotation)}`);
      rotation.forEach((x, i) => num(m, `rotation[${i}]`, x, { min: -1.001, max: 1.001 }));
    }
    this.#call(m, (v) => v.setJointRotation(name, rotation ?? undefined));
  }
  /** Joint `name`'s local rotation `[x, y, z, w]` in the last drawn pose (held or animated). */
  jointRotation(name) {
    str('jointRotation', 'name', name);
    return Array.from(this.#call('jointRotation', (v) => v.jointRotation(name)));
  }
  /** Lets the animation drive every joint again (drops the rotations `setJointRotation` holds). */
  resetPose() {
    this.#call('resetPose', (v) => v.resetPose());
  }
  /** Pose mode on or off: the clip stops where it is, a click selects a joint, the gizmo's rings turn it. */
  setPoseMode(on) {
    bool('setPoseMode', 'on', on);
    this.#call('setPoseMode', (v) => v.setPoseMode(on), true);
  }
  /** Records joint `name`'s rotation on screen as a new example pose (SJB by example) and opens the sculpt on its support. */
  addExamplePose(name) {
    str('addExamplePose', 'name', name);
    this.#call('addExamplePose', (v) => v.addExamplePose(name), true);
  }
  /** Lighting preset: studio, outdoor, flat or rim. */
  setLighting(name) {
    oneOf('setLighting', 'name', name, LIGHTING);
    this.#call('setLighting', (v) => v.setLighting(name));
  }
  /** Background: dark, grey or light. */
  setBackground(name) {
    oneOf('setBackground', 'name', name, BACKGROUNDS);
    this.#call('setBackground', (v) => v.setBackground(name));
  }
  /** Downloads the view as `<model>.png`. */
  screenshot() { this.#call('screenshot', (v) => v.screenshot()); }

  /**
   * The view as it is now, at the canvas's size in device pixels, transparent where the background is (a CSS
   * colour `background` is not in it), in a 2D canvas of its own. A frame is drawn now and copied in the same task:
   * neither a WebGPU canvas nor the page's WebGL2 canvas keeps its pixels after the frame is shown.
   */
  #snapshot(method) {
    this.#require();
    if (this.#lost) throw new Error(`${method}: the graphics context is lost`);
    this.#draw(performance.now());
    // The page's only WebGL2 viewer shows the shared canvas (placed after its own) instead of its own; every viewer
    // is drawn in the top-left corner of what it shows. The 3D view is `data-viewport` (CSS px) within it.
    const shown = [...this.shadowRoot.querySelectorAll('canvas')].find((c) => c !== this.#canvas) ?? this.#canvas;
    const [x, y, w, h] = (this.dataset.viewport ?? '').split(',').map(Number);
    const ppp = this.#ppp;
    const sx = Math.round((x || 0) * ppp);
    const sy = Math.round((y || 0) * ppp);
    const width = Math.max(1, Math.min(shown.width - sx, Math.round((w || this.#canvas.clientWidth) * ppp)));
    const height = Math.max(1, Math.min(shown.height - sy, Math.round((h || this.#canvas.clientHeight) * ppp)));
    const copy = document.createElement('canvas');
    copy.width = width;
    copy.height = height;
    copy.getContext('2d').drawImage(shown, sx, sy, width, height, 0, 0, width, height);
    return copy;
  }

  /** The current frame as an image Blob (model-viewer's `toBlob`; default `image/png`), without downloading. */
  toBlob(options = {}) {
    const m = 'toBlob';
    if (options === null || typeof options !== 'object') throw new TypeError(`${m}: options must be an object`);
    const { mimeType = 'image/png', qualityArgument } = options;
    str(m, 'mimeType', mimeType);
    if (qualityArgument !== undefined) num(m, 'qualityArgument', qualityArgument, { min: 0, max: 1 });
    const copy = this.#snapshot(m);
    return new Promise((resolve, reject) => copy.toBlob(
      (blob) => (blob ? resolve(blob) : reject(new Error(`${m}: the browser made no ${mimeType} image`))), mimeType, qualityArgument));
  }

  /** The current frame as a data URL (model-viewer's `toDataURL`; default `image/png`). */
  toDataURL(type = 'image/png', encoderOptions = undefined) {
    str('toDataURL', 'type', type);
    if (encoderOptions !== undefined) num('toDataURL', 'encoderOptions', encoderOptions, { min: 0, max: 1 });
    return this.#snapshot('toDataURL').toDataURL(type, encoderOptions);
  }
  setCopies(n) {
    num('setCopies', 'n', n, { min: 1, max: MAX_COPIES, integer: true });
    this.#call('setCopies', (v) => v.setCopies(n));
  }
  /**
   * Shows a sample: a model of the `samples` library by name (fetched from its URL), or a built-in one
   * (`'candy-wrapper'`). Unknown names throw a RangeError listing the names there are.
   */
  loadSample(name) {
    str('loadSample', 'name', name);
    const viewer = this.#require();
    const entry = this.#samples.find((s) => s.name === name);
    if (entry) {
      // A sample with a sidecar (example poses, joint settings) loads with it.
      viewer.loadUrl(typeof entry.sidecar === 'string' && entry.sidecar !== '' ? `${entry.url}#sidecar=${entry.sidecar}` : entry.url);
      return;
    }
    try {
      viewer.loadSample(name);
    } catch (e) {
      const library = this.#samples.map((s) => s.name);
      throw new RangeError(`loadSample: ${e instanceof Error ? e.message : e}${library.length > 0 ? `, ${library.join(', ')}` : ''}`);
    }
  }
  /**
   * The Samples menu's library: `[{name, url, attribution?, licence?, clips?, joints?, size?, default?, sidecar?}]`
   * (`sidecar`: a `.kloub.json` loaded with the model), the shape of `kloub serve`'s `/api/assets` (the app page sets it from there). Entries without a name or URL are
   * left out; setting anything but an array throws a TypeError.
   */
  get samples() { return this.#samples.map((s) => ({ ...s })); }
  set samples(list) {
    if (!Array.isArray(list)) throw new TypeError('samples: expected an array of {name, url, …}');
    const kept = list
      .filter((s) => s && typeof s === 'object' && typeof s.name === 'string' && s.name !== '' && typeof s.url === 'string' && s.url !== '' && !s.error)
      .map((s) => ({ ...s }));
    if (kept.length > MAX_LIST) throw new RangeError(`samples: ${kept.length} entries: at most ${MAX_LIST}`);
    this.#samples = kept;
    this.#viewer?.setSamples(JSON.stringify(this.#samples));
  }
  setCandyPose(twist, bend) {
    num('setCandyPose', 'twist', twist, { min: -720, max: 720 });
    num('setCandyPose', 'bend', bend, { min: -720, max: 720 });
    this.#call('setCandyPose', (v) => v.setCandyPose(twist, bend));
  }
  /** The camera as [yaw, pitch, distance, targetX, targetY, targetZ] (radians, model units). */
  get camera() { return (this.dataset.camera ?? '').split(',').filter((v) => v !== '').map(Number); }
  /** model-viewer's `getBoundingBoxCenter()`: the centre of the box the camera frames (the model over its clips), in
   *  world units, or null without a model. */
  getBoundingBoxCenter() {
    const b = this.#bounds();
    return b && vector3((b[0] + b[3]) / 2, (b[1] + b[4]) / 2, (b[2] + b[5]) / 2);
  }
  /** model-viewer's `getDimensions()`: the size of that box, or null without a model. */
  getDimensions() {
    const b = this.#bounds();
    return b && vector3(b[3] - b[0], b[4] - b[1], b[5] - b[2]);
  }
  #bounds() {
    const b = (this.dataset.bounds ?? '').split(',').map(Number);
    return b.length === 6 && b.every(Number.isFinite) ? b : null;
  }
  set camera(values) {
    const m = 'camera';
    if (!Array.isArray(values) && !ArrayBuffer.isView(values)) throw new TypeError(`${m}: expected [yaw, pitch, distance, x, y, z], got ${describe(values)}`);
    if (values.length !== 6) throw new RangeError(`${m}: ${values.length} numbers: expected 6 ([yaw, pitch, distance, x, y, z])`);
    const [yaw, pitch, distance, x, y, z] = Array.from(values, (v, i) => num(m, `[${i}]`, v));
    if (!(distance > 0)) throw new RangeError(`${m}: distance ${distance}: expected a positive number`);
    this.#call(m, (v) => v.setCamera(yaw, pitch, distance, x, y, z));
  }
  // ---- test hooks (not part of the page API) ----

  /** Panics inside the module as a bug would; every viewer of the page comes back from its state. */
  static async _testPanic(message = 'test') {
    const glue = await loadRuntime();
    try {
      glue._testPanic(message);
    } catch {
      // The trap that ends the instance; the panic handler has already started the recovery.
    }
  }
  /** What the page's viewers share: { models: { url: { fetches, decodes } }, uploads, kits, liveModels, liveUploads }. */
  static async _testCounters() { return JSON.parse((await loadRuntime())._testCounters()); }
  /** The size of the module's linear memory in bytes (null before it loaded). */
  static _testMemoryBytes() { return runtime === null ? null : loadRuntime().then((glue) => glue._testMemoryBytes()); }
  /** Loses every GPU device of the page (WebGPU device.destroy(), WebGL2 WEBGL_lose_context). */
  static async _testLoseDevices() { (await loadRuntime())._testLoseDevices(); }
  /** The page's shared WebGL2 canvas (null until a WebGL2 viewer mounts). */
  static async _testGlCanvas() { return (await loadRuntime())._testGlCanvas() ?? null; }

  /** The ARIA role and name of every control of the panels as the viewer built them ([[role, name], …]). */
  _testObstacles() { return JSON.parse(this.#viewer?._testObstacles?.() ?? '[]'); }
  _testRagdoll() { const r = this.#viewer?._testRagdoll?.() ?? ''; return r === '' ? null : JSON.parse(r); }
  _testGizmo() { const g = this.#viewer?._testGizmo?.() ?? ''; return g === '' ? null : JSON.parse(g); }
  _testAccessibilityControls() { return JSON.parse(this.#viewer?._testAccessibilityControls?.() ?? '[]'); }
  /** The build the page runs: 'widget', 'widget-gl' or 'full' (null before the first element mounted). */
  static _testBuild() { return build; }
  /** The light build's second half: null before it is instantiated, 'async' (fetched after a first frame), 'sync'
   *  (a call needed it first) or 'whole' (a build that is not split). */
  static async _testRest() {
    const glue = await loadRuntime();
    return glue.restState ? glue.restState() : 'whole';
  }
  /** The table slot of the first of the second half's functions called before it was loaded (null if none). */
  static async _testRestFirstCall() { return (await loadRuntime()).restFirstCall?.() ?? null; }
  /** Holds the second half back (`true`) so that a call must load it synchronously, or lets it load (`false`). */
  static _testHoldRest(held) {
    rest.held = held;
    if (!held) wantRest();
  }

  /** Every mirrored state value (a copy of the data-* attributes). */
  get state() { return { ...this.dataset }; }
}

if (!customElements.get('kloub-viewer')) customElements.define('kloub-viewer', KloubViewer);
