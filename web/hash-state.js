// The view <-> URL hash: "#src=URL&clip=NAME&t=SECONDS&paused=1&speed=X&layer=CLIP@ROOT:WEIGHT&skinning=M&camera=6 numbers".
// Pure functions over a <kloub-viewer>'s data-* state, shared by the app page and tests.

/** The hash for a viewer's `dataset` (and the model URL, or null when the model came from files). */
export function viewToHash(state, src) {
  const p = new URLSearchParams();
  if (src) p.set('src', src);
  if (state.clip) p.set('clip', state.clip);
  if (state.time) p.set('t', state.time);
  if (state.playing !== 'true') p.set('paused', '1');
  if (state.speed && Number(state.speed) !== 1) p.set('speed', state.speed);
  if (state.layer) p.set('layer', state.layer);
  if (state.skinning && state.skinning !== 'lbs') p.set('skinning', state.skinning);
  if (state.camera) p.set('camera', state.camera);
  const text = p.toString();
  return text ? `#${text}` : '';
}

/** The view a hash describes; keys that are missing or malformed are left out. */
export function hashToView(hash) {
  const p = new URLSearchParams(String(hash).replace(/^#/, ''));
  const view = {};
  const number = (key) => {
    const text = (p.get(key) ?? '').trim();
    const v = Number(text);
    return text !== '' && Number.isFinite(v) ? v : undefined;
  };
  if (p.get('src')) view.src = p.get('src');
  if (p.get('clip')) view.clip = p.get('clip');
  if (number('t') !== undefined) view.time = number('t');
  if (p.get('paused') === '1') view.paused = true;
  if (number('speed') !== undefined) view.speed = number('speed');
  const layer = /^(.+)@(.+):([0-9.]+)$/.exec(p.get('layer') ?? '');
  if (layer && Number.isFinite(Number(layer[3]))) view.layer = { clip: layer[1], root: layer[2], weight: Number(layer[3]) };
  if (p.get('skinning')) view.skinning = p.get('skinning');
  const camera = (p.get('camera') ?? '').split(',').map(Number);
  if (camera.length === 6 && camera.every(Number.isFinite) && camera[2] > 0) view.camera = camera;
  return view;
}
