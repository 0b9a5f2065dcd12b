// The view <-> URL hash, version 1:
//   "#v=1&src=URL&clip=NAME&t=SECONDS&paused=1&speed=X&layer=CLIP@ROOT:WEIGHT&skinning=M&path=P&camera=6 numbers
//    &loop=once|pingpong&overlays=skeleton,bounds,…&bg=grey|light&light=outdoor|flat|rim&grid=0&heatmap=1&copies=N"
// Only values that differ from the viewer's defaults are written, so a default view has no hash. Reading ignores
// unknown keys and drops malformed values (each with a console warning), so a link made by a newer page still
// opens what this one understands. Pure functions over a <kloub-viewer>'s data-* state, shared by the app page
// and tests.

/** The hash format's version (`v=`). A hash without `v` is read as version 1 (the keys before it are a subset). */
export const HASH_VERSION = 1;

const LOOPS = ['once', 'repeat', 'pingpong'];
const OVERLAYS = ['skeleton', 'bounds', 'wireframe', 'normals', 'bodies'];
const BACKGROUNDS = ['dark', 'grey', 'light'];
const LIGHTING = ['studio', 'outdoor', 'flat', 'rim'];
const SKINNING = ['rigid', 'lbs', 'dqs', 'sjb'];
const PATHS = ['gpu', 'compute', 'cpu'];
const KEYS = new Set(['v', 'src', 'clip', 't', 'paused', 'speed', 'layer', 'skinning', 'path', 'camera', 'loop',
  'overlays', 'bg', 'light', 'grid', 'heatmap', 'copies']);

/** The hash for a viewer's `dataset` (and the model URL, or null when the model came from files). */
export function viewToHash(state, src) {
  const p = new URLSearchParams();
  if (src) p.set('src', src);
  if (state.clip) p.set('clip', state.clip);
  if (state.time) p.set('t', state.time);
  if (state.playing !== undefined && state.playing !== 'true') p.set('paused', '1');
  if (state.speed && Number(state.speed) !== 1) p.set('speed', state.speed);
  if (state.layer) p.set('layer', state.layer);
  if (state.skinning && state.skinning !== 'lbs') p.set('skinning', state.skinning);
  if (state.skinningPath && state.skinningPath !== 'gpu') p.set('path', state.skinningPath);
  if (state.camera) p.set('camera', state.camera);
  if (state.loop && state.loop !== 'repeat') p.set('loop', state.loop);
  if (state.overlays) p.set('overlays', state.overlays);
  if (state.background && state.background !== 'dark') p.set('bg', state.background);
  if (state.lighting && state.lighting !== 'studio') p.set('light', state.lighting);
  if (state.grid === 'false') p.set('grid', '0');
  if (state.heatmap === 'true') p.set('heatmap', '1');
  if (state.copies && state.copies !== '1') p.set('copies', state.copies);
  const text = p.toString();
  return text ? `#v=${HASH_VERSION}&${text}` : '';
}

/** The view a hash describes; keys that are missing or malformed are left out (`warn` hears why). */
export function hashToView(hash, warn = (message) => console.warn(`kloub: URL hash: ${message}`)) {
  const p = new URLSearchParams(String(hash).replace(/^#/, ''));
  const view = {};
  for (const key of p.keys()) if (!KEYS.has(key)) warn(`unknown key ${JSON.stringify(key)} ignored`);
  if (p.has('v') && p.get('v') !== String(HASH_VERSION)) warn(`version ${JSON.stringify(p.get('v'))}: read as version ${HASH_VERSION}`);
  const bad = (key) => warn(`${key}=${JSON.stringify(p.get(key))} dropped`);
  const number = (key) => {
    const text = (p.get(key) ?? '').trim();
    const v = Number(text);
    if (text !== '' && Number.isFinite(v)) return v;
    if (p.has(key)) bad(key);
    return undefined;
  };
  const oneOf = (key, accepted) => {
    if (!p.has(key)) return undefined;
    if (accepted.includes(p.get(key))) return p.get(key);
    bad(key);
    return undefined;
  };
  const flag = (key) => {
    if (!p.has(key)) return undefined;
    if (p.get(key) === '1' || p.get(key) === '0') return p.get(key) === '1';
    bad(key);
    return undefined;
  };
  if (p.get('src')) view.src = p.get('src');
  if (p.get('clip')) view.clip = p.get('clip');
  const time = number('t');
  if (time !== undefined) view.time = time;
  if (p.get('paused') === '1') view.paused = true;
  const speed = number('speed');
  if (speed !== undefined) view.speed = speed;
  if (p.has('layer')) {
    const layer = /^(.+)@(.+):([0-9.]+)$/.exec(p.get('layer') ?? '');
    if (layer && Number.isFinite(Number(layer[3]))) view.layer = { clip: layer[1], root: layer[2], weight: Number(layer[3]) };
    else bad('layer');
  }
  const skinning = oneOf('skinning', SKINNING);
  if (skinning) view.skinning = skinning;
  const path = oneOf('path', PATHS);
  if (path) view.skinningPath = path;
  if (p.has('camera')) {
    const camera = (p.get('camera') ?? '').split(',').map(Number);
    if (camera.length === 6 && camera.every(Number.isFinite) && camera[2] > 0) view.camera = camera;
    else bad('camera');
  }
  const loop = oneOf('loop', LOOPS);
  if (loop) view.loop = loop;
  if (p.has('overlays')) {
    const names = (p.get('overlays') ?? '').split(',').filter((n) => n !== '');
    if (names.every((n) => OVERLAYS.includes(n))) view.overlays = Object.fromEntries(names.map((n) => [n, true]));
    else bad('overlays');
  }
  const background = oneOf('bg', BACKGROUNDS);
  if (background) view.background = background;
  const lighting = oneOf('light', LIGHTING);
  if (lighting) view.lighting = lighting;
  const grid = flag('grid');
  if (grid !== undefined) view.grid = grid;
  const heatmap = flag('heatmap');
  if (heatmap !== undefined) view.heatmap = heatmap;
  const copies = number('copies');
  if (copies !== undefined) {
    if (Number.isInteger(copies) && copies >= 1 && copies <= 100) view.copies = copies;
    else bad('copies');
  }
  return view;
}
