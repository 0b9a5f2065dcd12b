// <kloub-viewer>: Kloub's glTF animation viewer as a custom element.
//
//   <script type="module" src="kloub-viewer.js"></script>
//   <kloub-viewer src="Fox.glb" autoplay animation-name="Run"></kloub-viewer>
//
// Each element owns a canvas in its (open) shadow root and its own viewer; many may share a page.
// Nothing is put on `window`: the module exports the class and registers the tag (once).
// State is mirrored into the element's own data-* attributes (data-status, data-clip, data-time,
// ...; see kloub-viewer.d.ts) and reported by events: load, error, play, pause, timeupdate, loop,
// finished. The wasm module is loaded once per page, on the first connected element.
import init, { Viewer } from './kloub_web.js';

let wasm = null;
/** Loads and instantiates the wasm module once (shared by every element on the page). */
function loadWasm() {
  wasm ??= init({ module_or_path: new URL('./kloub_web_bg.wasm', import.meta.url) });
  return wasm;
}

const STYLE = `
:host { display: block; position: relative; width: 300px; height: 150px; overflow: hidden; }
:host([hidden]) { display: none; }
canvas { display: block; width: 100%; height: 100%; outline: none; touch-action: none; }
.kloub-loading { position: absolute; inset: 0; display: flex; align-items: center; justify-content: center;
  font: 14px system-ui, sans-serif; color: #888; pointer-events: none; }
:host(:not([data-status="loading"])) .kloub-loading { display: none; }
`;

const LOOP_MODES = new Set(['once', 'repeat', 'pingpong']);

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

export class KloubViewer extends HTMLElement {
  static observedAttributes = [
    'src', 'autoplay', 'animation-name', 'speed', 'loop', 'crossfade-duration', 'layer-clip', 'layer-root',
    'skinning', 'backend', 'controls',
  ];

  #viewer = null;
  #canvas;
  #mounting = null;
  #pendingTime = null;
  #teardown = null;
  #pickers = [];

  constructor() {
    super();
    const root = this.attachShadow({ mode: 'open' });
    const style = document.createElement('style');
    style.textContent = STYLE;
    this.#canvas = document.createElement('canvas');
    this.#canvas.setAttribute('part', 'canvas');
    this.#canvas.tabIndex = 0;
    const loading = document.createElement('div');
    loading.className = 'kloub-loading';
    loading.textContent = 'Loading…';
    // The panel's Open menu: file inputs the viewer clicks through the "kloub:open" request.
    this.#pickers = ['files', 'folder'].map((kind) => {
      const input = document.createElement('input');
      input.type = 'file';
      input.multiple = true;
      input.hidden = true;
      if (kind === 'folder') input.webkitdirectory = true;
      else input.accept = '.glb,.gltf,.bin,.png,.jpg,.jpeg,.webp,.ktx2,.json';
      input.addEventListener('change', () => {
        const files = [...input.files].map((file) => ({ name: file.webkitRelativePath || file.name, file }));
        input.value = '';
        if (files.length > 0) this.#loadFiles(files).catch((e) => this.#fail(String(e)));
      });
      return input;
    });
    root.append(style, this.#canvas, loading, ...this.#pickers);
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

  connectedCallback() {
    if (this.#teardown) {
      clearTimeout(this.#teardown);
      this.#teardown = null;
    }
    if (!this.#mounting) this.#mounting = this.#mount();
  }

  disconnectedCallback() {
    // Moving the element within the page reconnects it at once: only a real removal stops the viewer.
    this.#teardown = setTimeout(() => {
      this.#teardown = null;
      this.#viewer?.destroy();
      this.#viewer = null;
      this.#mounting = null;
    }, 0);
  }

  attributeChangedCallback(name, old, value) {
    const viewer = this.#viewer;
    if (!viewer || old === value) return;
    try {
      this.#configure();
      switch (name) {
        case 'src': if (value) viewer.loadUrl(value); break;
        // Before a model is shown the names cannot resolve: configure() above makes the next model start so.
        case 'animation-name': if (value && this.loaded) this.crossfadeTo(value, this.#crossfadeSeconds()); break;
        case 'speed': viewer.setSpeed(this.speed); break;
        case 'loop': viewer.setLoop(loopMode(value)); break;
        case 'crossfade-duration': viewer.setCrossfadeDuration(this.#crossfadeSeconds()); break;
        case 'layer-clip': case 'layer-root': {
          if (!this.loaded) break;
          const clip = this.getAttribute('layer-clip');
          const root = this.getAttribute('layer-root');
          if (!clip) viewer.setLayer(null, null, 0);
          else if (root) viewer.setLayer(clip, root, 1);
          break;
        }
        case 'skinning': if (value) viewer.setSkinning(value); break;
        case 'controls': viewer.setPanels(value !== null); break;
        case 'backend': this.#remount(); break;
        default: break;
      }
    } catch (e) {
      this.#fail(e instanceof Error ? e.message : String(e));
    }
  }

  async #mount() {
    this.dataset.status = 'loading';
    try {
      await loadWasm();
      const viewer = new Viewer();
      this.#viewer = viewer;
      this.#configure();
      const emit = (type, detail) => {
        // A request of the viewer's own, answered while the user's click is still being handled.
        if (type === 'kloub:open') this.#pickers[detail === 'folder' ? 1 : 0].click();
        else queueMicrotask(() => this.#dispatch(type, detail));
      };
      const backend = this.getAttribute('backend');
      viewer.setPanels(this.hasAttribute('controls'));
      await viewer.mount(this.#canvas, this, this.shadowRoot, emit, backend === 'auto' ? null : backend,
        this.getAttribute('src'));
      // Removed from the page while starting: stop now (disconnectedCallback found nothing to stop).
      if (!this.isConnected && this.#viewer === viewer) {
        viewer.destroy();
        this.#viewer = null;
        this.#mounting = null;
        return;
      }
      if (this.hasAttribute('crossfade-duration')) viewer.setCrossfadeDuration(this.#crossfadeSeconds());
      if (this.hasAttribute('skinning')) viewer.setSkinning(this.getAttribute('skinning'));
    } catch (e) {
      const message = e instanceof Error ? e.message : String(e);
      if (this.dataset.status !== 'error') this.#fail(`Kloub could not start: ${message}`);
    }
  }

  #remount() {
    this.#viewer?.destroy();
    this.#viewer = null;
    // A fresh canvas: a context of the other backend cannot be created on the old one.
    const canvas = this.#canvas.cloneNode(false);
    this.#canvas.replaceWith(canvas);
    this.#canvas = canvas;
    this.#mounting = this.#mount();
  }

  #configure() {
    const layerClip = this.getAttribute('layer-clip');
    const layerRoot = this.getAttribute('layer-root');
    this.#viewer?.configure(this.hasAttribute('autoplay'), this.getAttribute('animation-name'), this.speed,
      loopMode(this.getAttribute('loop')), layerClip, layerRoot);
  }

  #crossfadeSeconds() {
    const s = Number(this.getAttribute('crossfade-duration'));
    return Number.isFinite(s) && s >= 0 ? s : 0.3;
  }

  #dispatch(type, detail) {
    let data;
    switch (type) {
      case 'error': data = { message: detail }; break;
      case 'load': data = { name: detail }; break;
      case 'timeupdate': this.#pendingTime = null; data = { currentTime: Number(detail) }; break;
      case 'loop': data = { count: Number(detail) }; break;
      default: data = {};
    }
    this.dispatchEvent(new CustomEvent(type, { detail: data }));
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

  async #loadFiles(entries) {
    const names = entries.map((e) => e.name);
    const contents = await Promise.all(entries.map(async (e) => new Uint8Array(await e.file.arrayBuffer())));
    this.#require().loadFiles(names, contents);
  }

  // ---- attributes as properties ----

  get src() { return this.getAttribute('src') ?? ''; }
  set src(value) { this.setAttribute('src', value); }
  get autoplay() { return this.hasAttribute('autoplay'); }
  set autoplay(on) { this.toggleAttribute('autoplay', Boolean(on)); }
  get animationName() { return this.dataset.clip ?? ''; }
  set animationName(value) { this.setAttribute('animation-name', value); }
  get speed() {
    const s = Number(this.getAttribute('speed') ?? 1);
    return Number.isFinite(s) ? s : 1;
  }
  set speed(value) { this.setAttribute('speed', String(value)); }
  get loop() { return loopMode(this.getAttribute('loop')); }
  set loop(mode) { this.setAttribute('loop', mode); }
  get skinning() { return this.dataset.skinning ?? this.getAttribute('skinning') ?? 'lbs'; }
  set skinning(method) { this.setAttribute('skinning', method); }
  get backend() { return this.dataset.backend ?? ''; }
  get controls() { return this.hasAttribute('controls'); }
  set controls(on) { this.toggleAttribute('controls', Boolean(on)); }

  // ---- media-element vocabulary ----

  /** Runs every clock. */
  play() { this.#require().play(); }
  /** Stops every clock. */
  pause() { this.#require().pause(); }
  get paused() { return this.dataset.playing !== 'true'; }
  get currentTime() { return this.#pendingTime ?? Number(this.dataset.time ?? 0); }
  set currentTime(seconds) {
    this.#require().seek(Number(seconds));
    const d = this.duration;
    this.#pendingTime = Math.min(Math.max(Number(seconds), 0), d > 0 ? d : Number(seconds));
  }
  get duration() { return Number(this.dataset.duration ?? 0) || 0; }
  get availableAnimations() { return JSON.parse(this.dataset.clips ?? '[]'); }
  /** True once a model is shown. */
  get loaded() { return (this.dataset.model ?? '') !== '' && this.dataset.status !== 'loading'; }

  /** Crossfades to the clip `name` over `seconds` (default: crossfade-duration). */
  crossfadeTo(name, seconds = this.#crossfadeSeconds()) { this.#require().crossfadeTo(name, seconds); }
  /** Plays `clip` on the subtree under the joint `rootJoint` with `weight` in [0, 1]; a null clip removes it. */
  setLayer(clip, rootJoint, weight = 1) { this.#require().setLayer(clip, rootJoint, weight); }
  /** Drags `joint` to the world point `[x, y, z]` by IK (`depth` joints above it turn); null clears every goal. */
  setIkTarget(joint, target, depth) {
    const [x, y, z] = target ?? [];
    this.#require().setIkTarget(joint ?? null, x, y, z, depth);
  }
  /**
   * The solver of `joint`'s IK goal ('ccd' | 'twobone' | 'fabrik' | 'dls') and its options:
   * `{ pole: [x, y, z] | null, softness, patternMove, iterations }` (left out: unchanged; no pole: none).
   */
  setIkSolver(joint, solver, options) {
    options ??= {};
    const [x, y, z] = options.pole ?? [];
    this.#require().setIkSolver(joint, solver, x, y, z, options.softness, options.patternMove, options.iterations);
  }

  /**
   * Shows a model: a URL, or files (a FileList or File[]; a .gltf with its .bin and textures).
   * Resolves with the model's name after its first painted frame; rejects with its error.
   */
  load(urlOrFiles) {
    const viewer = this.#require();
    const done = new Promise((resolve, reject) => {
      const ok = (e) => { off(); resolve(e.detail.name); };
      const bad = (e) => { off(); reject(new Error(e.detail.message)); };
      const off = () => { this.removeEventListener('load', ok); this.removeEventListener('error', bad); };
      this.addEventListener('load', ok);
      this.addEventListener('error', bad);
    });
    if (typeof urlOrFiles === 'string' || urlOrFiles instanceof URL) {
      viewer.loadUrl(String(urlOrFiles));
    } else {
      const files = [...urlOrFiles].map((file) => ({ name: file.webkitRelativePath || file.name, file }));
      this.#loadFiles(files).catch((e) => this.#fail(String(e)));
    }
    return done;
  }

  // ---- the rest of the viewer ----

  playClip(name) { this.#require().playClip(name); }
  seek(seconds) { this.currentTime = seconds; }
  setSpeed(speed) { this.speed = speed; }
  setLoop(mode) { this.#require().setLoop(mode); }
  setBlend(names, weights) { this.#require().setBlend(names, Float32Array.from(weights)); }
  setSkinning(method) { this.#require().setSkinning(method); }
  setSkinningPath(path) { this.#require().setSkinningPath(path); }
  setHeatmap(on) { this.#require().setHeatmap(Boolean(on)); }
  setGrid(on) { this.#require().setGrid(Boolean(on)); }
  /** Overlays: `{ skeleton, bounds, wireframe, normals, bodies }` (missing keys: off). */
  setOverlays({ skeleton = false, bounds = false, wireframe = false, normals = false, bodies = false } = {}) {
    this.#require().setOverlays(Boolean(skeleton), Boolean(bounds), Boolean(wireframe), Boolean(normals), Boolean(bodies));
  }
  /** Drops the character as a ragdoll from the pose on screen. */
  startRagdoll() { this.#require().startRagdoll(); }
  /** Ends the ragdoll: at once, or blending back to the animation over `seconds`. */
  stopRagdoll(seconds) { this.#require().stopRagdoll(seconds ?? undefined); }
  /** Ragdoll gravity (m/s² for a person-sized body) and damping. */
  setRagdollOptions({ gravity = 9.81, damping = 0.5 } = {}) { this.#require().setRagdollOptions(gravity, damping); }
  /** Selects a joint by name (axes drawn, channels plotted in the panel); null clears. */
  selectJoint(name) { this.#require().selectJoint(name ?? null); }
  /** Holds morph target `target` (index or name) of the mesh on `node` at `weight`; null lets the clip drive it. */
  setMorphWeight(node, target, weight) { this.#require().setMorphWeight(node, target, weight ?? undefined); }
  /** Lighting preset: studio, outdoor, flat or rim. */
  setLighting(name) { this.#require().setLighting(name); }
  /** Background: dark, grey or light. */
  setBackground(name) { this.#require().setBackground(name); }
  /** Downloads the view as `<model>.png`. */
  screenshot() { this.#require().screenshot(); }
  setCopies(n) { this.#require().setCopies(n); }
  loadSample(name) { this.#require().loadSample(name); }
  setCandyPose(twist, bend) { this.#require().setCandyPose(twist, bend); }
  /** The camera as [yaw, pitch, distance, targetX, targetY, targetZ] (radians, model units). */
  get camera() { return (this.dataset.camera ?? '').split(',').filter((v) => v !== '').map(Number); }
  set camera(values) { this.#require().setCamera(...values); }
  /** Every mirrored state value (a copy of the data-* attributes). */
  get state() { return { ...this.dataset }; }
}

if (!customElements.get('kloub-viewer')) customElements.define('kloub-viewer', KloubViewer);
