// The standalone app page: one <kloub-viewer> with its panels, filling the window.
// ?src=URL picks the model, ?backend=gl|webgl2|webgpu the renderer. Without ?src= (or a src in the hash) the page
// opens the server's default model: the library's `default` entry (/models/default.glb), else its first model that
// imports, else nothing: the viewer's empty state invites a drop. Never an error on first load.
// The URL hash holds the exact view — model URL, clip, time, paused, speed, loop, layer, skinning method and path,
// camera, overlays, background, lighting, grid, heatmap, copies, crossfade settings, blend weights, IK goals with their
// solvers, held morph weights (web/hash-state.js) — and is kept up to date, so a
// copied link reopens what was on screen.
// Kept out of index.html so the page works under a CSP without 'unsafe-inline'.
import { viewToHash, hashToView, applyView } from './hash-state.js';

const viewer = document.getElementById('app');
const query = new URLSearchParams(location.search);
const view = hashToView(location.hash);
const src = view.src ?? query.get('src');
if (src) viewer.setAttribute('src', src);
const backend = query.get('backend');
if (backend) viewer.setAttribute('backend', backend === 'gl' ? 'webgl2' : backend);
if (view.clip) viewer.setAttribute('animation-name', view.clip);
if (view.speed !== undefined) viewer.setAttribute('speed', String(view.speed));
if (view.skinning) viewer.setAttribute('skinning', view.skinning);
if (view.layer) {
  viewer.setAttribute('layer-clip', view.layer.clip);
  viewer.setAttribute('layer-root', view.layer.root);
}
if (view.loop) viewer.setAttribute('loop', view.loop);
if (view.paused) viewer.removeAttribute('autoplay');
// Defined only now, so the element starts with the attributes above.
await import('./kloub-viewer.js');

// Applied once, after the first model from the hash is on screen: what attributes cannot say.
let pending = Object.keys(view).length > 0 ? view : null;
viewer.addEventListener('load', () => {
  if (!pending) return;
  const v = pending;
  pending = null;
  applyView(viewer, v, (key, e) => console.warn(`kloub: the URL hash's ${key} does not fit this view: ${e.message}`));
});

// The Samples menu lists the server's library (`kloub serve`'s /api/assets). A page served without that API
// (plain static files) has no library (null here) and opens the bundle's /models/default.glb.
const library = await fetch(new URL('api/assets', location.href))
  .then((r) => (r.ok ? r.json() : null))
  .then((list) => (Array.isArray(list) ? list : null))
  .catch((e) => {
    console.info(`kloub: no sample library (${e.message})`);
    return null;
  });
// The element takes up to 1,024 entries (a larger library is cut for the menu, not refused).
try {
  if (library) viewer.samples = library.slice(0, 1024);
} catch (e) {
  console.warn(`kloub: the sample library was not usable: ${e.message}`);
}
if (!src) {
  const shown = library?.filter((s) => s && typeof s.url === 'string' && !s.error) ?? [];
  const first = library === null ? '/models/default.glb' : shown.find((s) => s.default) ? '/models/default.glb' : shown[0]?.url;
  if (first) viewer.setAttribute('src', first);
}

// At most two hash writes a second while playing (browsers limit replaceState calls, Safari to 100 per 30 s).
const HASH_INTERVAL_MS = 500;

// Keep the hash current (replaceState: no history entry per frame). data-src is the URL the shown model came from
// (src, load(url) or the Samples menu); a dropped model has none: then no src.
let scheduled = false;
function writeHash() {
  scheduled = false;
  if (pending || viewer.dataset.status === 'loading' || !viewer.dataset.model) return;
  const hash = viewToHash(viewer.dataset, viewer.dataset.src || null);
  if (hash !== location.hash) history.replaceState(null, '', hash || location.pathname + location.search);
}
new MutationObserver(() => {
  if (!scheduled) {
    scheduled = true;
    setTimeout(writeHash, HASH_INTERVAL_MS);
  }
}).observe(viewer, { attributes: true, attributeFilter: ['data-clip', 'data-time', 'data-playing', 'data-speed', 'data-layer', 'data-skinning', 'data-camera', 'data-model', 'data-src', 'data-status', 'data-loop', 'data-overlays', 'data-background',
  'data-lighting', 'data-grid', 'data-heatmap', 'data-copies', 'data-skinning-path', 'data-skinning-path-chosen', 'data-transition', 'data-blend',
  'data-ik-goals', 'data-morphs', 'data-pose', 'data-obstacles'] });
