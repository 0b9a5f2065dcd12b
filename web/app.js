// The standalone app page: one <kloub-viewer> with its panels, filling the window.
// ?src=URL picks the model (default: the bundled Fox), ?backend=gl|webgl2|webgpu the renderer.
// The URL hash holds the exact view — model URL, clip, time, paused, speed, layer, skinning, camera —
// and is kept up to date, so a copied link reopens what was on screen.
// Kept out of index.html so the page works under a CSP without 'unsafe-inline'.
import { viewToHash, hashToView } from './hash-state.js';

const viewer = document.getElementById('app');
const query = new URLSearchParams(location.search);
const view = hashToView(location.hash);
const src = view.src ?? query.get('src') ?? '/models/default.glb';
viewer.setAttribute('src', src);
const backend = query.get('backend');
if (backend) viewer.setAttribute('backend', backend === 'gl' ? 'webgl2' : backend);
if (view.clip) viewer.setAttribute('animation-name', view.clip);
if (view.speed !== undefined) viewer.setAttribute('speed', String(view.speed));
if (view.skinning) viewer.setAttribute('skinning', view.skinning);
if (view.layer) {
  viewer.setAttribute('layer-clip', view.layer.clip);
  viewer.setAttribute('layer-root', view.layer.root);
}
if (view.paused) viewer.removeAttribute('autoplay');
// Defined only now, so the element starts with the attributes above.
await import('./kloub-viewer.js');

// Applied once, after the first model from the hash is on screen: what attributes cannot say.
let pending = Object.keys(view).length > 0 ? view : null;
viewer.addEventListener('load', () => {
  if (!pending) return;
  const v = pending;
  pending = null;
  try {
    if (v.camera) viewer.camera = v.camera;
    if (v.layer) viewer.setLayer(v.layer.clip, v.layer.root, v.layer.weight);
    if (v.time !== undefined) viewer.currentTime = v.time;
  } catch (e) {
    console.warn(`kloub: the URL hash does not fit this model: ${e.message}`);
  }
});

// At most two hash writes a second while playing (browsers limit replaceState calls, Safari to 100 per 30 s).
const HASH_INTERVAL_MS = 500;

// Keep the hash current (replaceState: no history entry per frame). A dropped model has no URL: then no src.
let scheduled = false;
function writeHash() {
  scheduled = false;
  if (pending || viewer.dataset.status === 'loading' || !viewer.dataset.model) return;
  const fromUrl = viewer.dataset.model === decodeURIComponent(src.split(/[?#]/)[0].split('/').pop());
  const hash = viewToHash(viewer.dataset, fromUrl ? viewer.getAttribute('src') : null);
  if (hash !== location.hash) history.replaceState(null, '', hash || location.pathname + location.search);
}
new MutationObserver(() => {
  if (!scheduled) {
    scheduled = true;
    setTimeout(writeHash, HASH_INTERVAL_MS);
  }
}).observe(viewer, { attributes: true, attributeFilter: ['data-clip', 'data-time', 'data-playing', 'data-speed', 'data-layer', 'data-skinning', 'data-camera', 'data-model', 'data-status'] });
// The src attribute follows later loads from URLs only through the element; a drop keeps src stale on purpose.
