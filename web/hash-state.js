// The view <-> URL hash, version 1:
//   "#v=1&src=URL&clip=NAME&t=SECONDS&paused=1&speed=X&layer=CLIP@ROOT:WEIGHT&skinning=M&path=P&camera=6 numbers
//    &loop=once|pingpong&overlays=skeleton,bounds,…&bg=grey|light|transparent&light=outdoor|flat|rim&grid=0&heatmap=1&copies=N
//    &fade=SECONDS,EASING,OUTGOING&blend=[[clip,weight],…]&ik=[{effector,depth,target,solver,…},…]
//    &morphs=[[node,target,weight],…]&pose={"JOINT":[x,y,z,w],…}&obstacles=[{shape,center,…},…]"
// Only values that differ from the viewer's defaults are written, so a default view has no hash. Reading ignores
// unknown keys and drops malformed values (each with a console warning), so a link made by a newer page still
// opens what this one understands. Pure functions over a <kloub-viewer>'s data-* state, shared by the app page
// and tests.

/** The hash format's version (`v=`). A hash without `v` is read as version 1 (the keys before it are a subset). */
export const HASH_VERSION = 1;

const LOOPS = ['once', 'repeat', 'pingpong'];
const OVERLAYS = ['skeleton', 'bounds', 'wireframe', 'normals', 'bodies'];
const BACKGROUNDS = ['dark', 'grey', 'light', 'transparent'];
const LIGHTING = ['studio', 'outdoor', 'flat', 'rim'];
const SKINNING = ['rigid', 'lbs', 'dqs', 'sjb', 'sjbbe'];
const PATHS = ['gpu', 'compute', 'cpu'];
const SOLVERS = ['ccd', 'twobone', 'fabrik', 'dls'];
const DEFAULT_TRANSITION = '0.300,smoothstep,freeze';
const KEYS = new Set(['v', 'src', 'clip', 't', 'paused', 'speed', 'layer', 'skinning', 'path', 'camera', 'loop',
  'overlays', 'bg', 'light', 'grid', 'heatmap', 'copies', 'fade', 'blend', 'ik', 'morphs', 'pose', 'obstacles']);
const SHAPES = ['box', 'sphere', 'capsule', 'stairs', 'ramp'];

const finite = (v) => typeof v === 'number' && Number.isFinite(v);
const point = (v) => Array.isArray(v) && v.length === 3 && v.every(finite);
const json = (text) => {
  try {
    return JSON.parse(text);
  } catch {
    return undefined;
  }
};
/** An IK goal as `data-ik-goals` lists it, or null when any field is off. */
function ikGoal(g) {
  if (!g || typeof g !== 'object' || typeof g.effector !== 'string' || g.effector === '') return null;
  if (!Number.isInteger(g.depth) || g.depth < 1 || g.depth > 31 || !point(g.target) || !SOLVERS.includes(g.solver)) return null;
  if (!Number.isInteger(g.iterations) || g.iterations < 1 || g.iterations > 128) return null;
  if (!finite(g.softness) || g.softness < 0 || g.softness > 0.5 || typeof g.patternMove !== 'boolean') return null;
  if (g.pole !== null && !point(g.pole)) return null;
  const { effector, depth, target, solver, iterations, softness, patternMove, pole } = g;
  return { effector, depth, target, solver, iterations, softness, patternMove, pole };
}

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
  // Only a chosen path: the default is the adapter's (the CPU on a CPU adapter), and the heatmap's is the vertex shader.
  if (state.skinningPath && (state.skinningPathChosen === undefined ? state.skinningPath !== 'gpu' : state.skinningPathChosen === 'true')) {
    p.set('path', state.skinningPath);
  }
  if (state.camera) p.set('camera', state.camera);
  if (state.loop && state.loop !== 'repeat') p.set('loop', state.loop);
  if (state.overlays) p.set('overlays', state.overlays);
  if (state.background && state.background !== 'dark') p.set('bg', state.background);
  if (state.lighting && state.lighting !== 'studio') p.set('light', state.lighting);
  if (state.grid === 'false') p.set('grid', '0');
  if (state.heatmap === 'true') p.set('heatmap', '1');
  if (state.copies && state.copies !== '1') p.set('copies', state.copies);
  if (state.transition && state.transition !== DEFAULT_TRANSITION) p.set('fade', state.transition);
  if (state.blend) p.set('blend', state.blend);
  if (state.ikGoals) p.set('ik', state.ikGoals);
  if (state.morphs) p.set('morphs', state.morphs);
  if (state.pose) p.set('pose', state.pose);
  if (state.obstacles) p.set('obstacles', state.obstacles);
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
  if (p.has('fade')) {
    const fade = /^([0-9]+(?:\.[0-9]+)?),(smoothstep|linear),(freeze|keep|sync)$/.exec(p.get('fade') ?? '');
    if (fade && Number(fade[1]) <= 3600) view.transition = { duration: Number(fade[1]), easing: fade[2], outgoing: fade[3] };
    else bad('fade');
  }
  if (p.has('blend')) {
    const blend = json(p.get('blend'));
    const ok = Array.isArray(blend) && blend.length > 0 && blend.length <= 1024
      && blend.every((b) => Array.isArray(b) && b.length === 2 && typeof b[0] === 'string' && finite(b[1]) && b[1] >= 0);
    if (ok) view.blend = { names: blend.map((b) => b[0]), weights: blend.map((b) => b[1]) };
    else bad('blend');
  }
  if (p.has('ik')) {
    const goals = json(p.get('ik'));
    const checked = Array.isArray(goals) && goals.length <= 64 ? goals.map(ikGoal) : [null];
    if (checked.length > 0 && checked.every((g) => g !== null)) view.ik = checked;
    else bad('ik');
  }
  if (p.has('morphs')) {
    const morphs = json(p.get('morphs'));
    const ok = Array.isArray(morphs) && morphs.length > 0 && morphs.length <= 4096 && morphs.every((m) => Array.isArray(m)
      && m.length === 3 && typeof m[0] === 'string' && Number.isInteger(m[1]) && m[1] >= 0 && finite(m[2]) && Math.abs(m[2]) <= 10);
    if (ok) view.morphs = morphs.map(([node, target, weight]) => ({ node, target, weight }));
    else bad('morphs');
  }
  if (p.has('pose')) {
    const pose = json(p.get('pose'));
    const held = pose && typeof pose === 'object' && !Array.isArray(pose) ? Object.entries(pose) : [];
    const unit = (q) => Array.isArray(q) && q.length === 4 && q.every(finite) && Math.abs(Math.hypot(...q) - 1) <= 1e-3;
    if (held.length > 0 && held.length <= 1024 && held.every(([, q]) => unit(q))) view.pose = held;
    else bad('pose');
  }
  if (p.has('obstacles')) {
    // Checked in shape here; the viewer checks every field (and says which one is off).
    const list = json(p.get('obstacles'));
    const ok = Array.isArray(list) && list.length <= 64 && list.every((o) => o && typeof o === 'object' && SHAPES.includes(o.shape) && point(o.center));
    if (ok) view.obstacles = list;
    else bad('obstacles');
  }
  return view;
}

/**
 * Applies a view (from `hashToView`) to a <kloub-viewer> whose model is shown: what attributes cannot say. Each
 * setting on its own: one that does not fit this model or backend is left out (`warn(key, error)`), the rest apply.
 * Copies first: their grid reframes the camera, which the view's camera then overrides.
 */
export function applyView(viewer, v, warn = () => {}) {
  const apply = [
    ['copies', () => viewer.setCopies(v.copies)],
    ['camera', () => { viewer.camera = v.camera; }],
    ['layer', () => viewer.setLayer(v.layer.clip, v.layer.root, v.layer.weight)],
    ['skinning', () => viewer.setSkinning(v.skinning)],
    ['skinningPath', () => viewer.setSkinningPath(v.skinningPath)],
    ['speed', () => viewer.setSpeed(v.speed)],
    ['loop', () => viewer.setLoop(v.loop)],
    ['overlays', () => viewer.setOverlays(v.overlays)],
    ['background', () => viewer.setBackground(v.background)],
    ['lighting', () => viewer.setLighting(v.lighting)],
    ['grid', () => viewer.setGrid(v.grid)],
    ['heatmap', () => viewer.setHeatmap(v.heatmap)],
    ['transition', () => viewer.setTransition(v.transition)],
    ['blend', () => viewer.setBlend(v.blend.names, v.blend.weights)],
    ['ik', () => {
      for (const g of v.ik) {
        viewer.setIkTarget(g.effector, g.target, g.depth);
        viewer.setIkSolver(g.effector, g.solver, { pole: g.pole, softness: g.softness, patternMove: g.patternMove, iterations: g.iterations });
      }
    }],
    ['morphs', () => { for (const m of v.morphs) viewer.setMorphWeight(m.node, m.target, m.weight); }],
    ['pose', () => { for (const [joint, q] of v.pose) viewer.setJointRotation(joint, q); }],
    ['obstacles', () => viewer.setObstacles(v.obstacles)],
    ['time', () => { viewer.currentTime = v.time; }],
  ];
  for (const [key, set] of apply) {
    if (v[key] === undefined) continue;
    try {
      set();
    } catch (e) {
      warn(key, e);
    }
  }
}
