// Types of <kloub-viewer>, Kloub's glTF animation viewer element (kloub-viewer.js).

/** `detail` of each event a <kloub-viewer> dispatches. */
export interface KloubViewerEventMap {
  /** A model is on screen (after its first painted frame). */
  load: CustomEvent<{ name: string }>;
  /** A load or a call failed; the previous model stays on screen. */
  error: CustomEvent<{ message: string }>;
  /** The clock started. */
  play: CustomEvent<Record<string, never>>;
  /** The clock stopped. */
  pause: CustomEvent<Record<string, never>>;
  /** The clock moved (once per painted frame while it runs, and on seeks). */
  timeupdate: CustomEvent<{ currentTime: number }>;
  /** The clip wrapped around (repeat) or turned (pingpong); `count` ends passed this frame. */
  loop: CustomEvent<{ count: number }>;
  /** A `loop="once"` clip reached its end and stopped. */
  finished: CustomEvent<Record<string, never>>;
  /** While a model loads: 0–1 (the download to 0.95), and 1 just before its `load`. */
  progress: CustomEvent<{ totalProgress: number }>;
  /** The `poster` went away (the model's first frame, or `dismissPoster()`). */
  'poster-dismissed': CustomEvent<Record<string, never>>;
  /** The camera moved (after the frame that shows it). */
  'camera-change': CustomEvent<{ source: 'user-interaction' | 'none' }>;
  /** `validate()` finished: the glTF-Validator's report and its counts. */
  validation: CustomEvent<{ report: ValidationReport; errors: number; warnings: number; infos: number; hints: number }>;
}

/** One issue of a glTF-Validator report. */
export interface ValidationIssue {
  /** The validator's code, e.g. `ACCESSOR_INDEX_OOB`. */
  code: string;
  message: string;
  /** 0 error, 1 warning, 2 info, 3 hint. */
  severity: 0 | 1 | 2 | 3;
  /** The JSON pointer of the offending element, when there is one. */
  pointer?: string;
  /** A byte offset into the file, for issues in binary data. */
  offset?: number;
}

/** The Khronos glTF-Validator's report (its own format, as `validateBytes` gives it). */
export interface ValidationReport {
  uri: string;
  mimeType?: string;
  validatorVersion: string;
  issues: {
    numErrors: number;
    numWarnings: number;
    numInfos: number;
    numHints: number;
    messages: ValidationIssue[];
    truncated: boolean;
  };
  info?: Record<string, unknown>;
}

/** Tone mapping of `tone-mapping` and `setToneMapping`. */
export type ToneMapping = 'neutral' | 'aces' | 'none';
export type SkinningMethod = 'rigid' | 'lbs' | 'dqs' | 'sjb' | 'sjbbe';
export type SkinningPath = 'gpu' | 'compute' | 'cpu';
export type LoopMode = 'once' | 'repeat' | 'pingpong';
export type Backend = 'auto' | 'webgpu' | 'webgl2';
/** `transparent`: the page shows through the canvas around the model. */
export type Background = 'dark' | 'grey' | 'light' | 'transparent';

/** One model of the Samples menu's library: the shape of `kloub serve`'s `/api/assets` entries. */
export interface KloubSample {
  /** The name in the menu and for `loadSample`. */
  name: string;
  /** Where the model is fetched from. */
  url: string;
  /** One line crediting the model, shown under its name while it is on screen. */
  attribution?: string | null;
  /** The licence text (the credit's hover text). */
  licence?: string | null;
  /** Clip names, or their count. */
  clips?: string[] | number;
  joints?: number;
  /** Download size in bytes. */
  size?: number;
  /** The model the page opens with (`/models/default.glb`). */
  default?: boolean;
}

/**
 * The viewer state mirrored into the element's data-* attributes (also `viewer.state`).
 * Values are strings, as in `HTMLElement.dataset`.
 */
export interface KloubViewerState {
  status?: 'waiting' | 'loading' | 'ready' | 'error' | 'lost';
  error?: string;
  backend?: 'webgpu' | 'webgl2';
  model?: string;
  /** The URL the shown model was fetched from; empty for dropped files and built-in samples. */
  src?: string;
  /** JSON array of `[clip, weight]` while two or more clips are blended; empty otherwise. */
  blend?: string;
  /** `"DURATION,EASING,OUTGOING"`, e.g. `"0.250,smoothstep,freeze"`. */
  transition?: string;
  /** JSON array of IK goals: `{effector, depth, target, solver, iterations, softness, patternMove, pole}`. */
  ikGoals?: string;
  /** JSON array of held morph weights: `[node, targetIndex, weight]`. */
  morphs?: string;
  /** JSON object of the joint rotations `setJointRotation` holds: `{"JOINT": [x, y, z, w]}`; empty without. */
  pose?: string;
  /** JSON array of the ragdoll's obstacles, as `setObstacles` takes them; empty without. */
  obstacles?: string;
  /** `animate`, `pose` (pose mode) or `sculpt` (an example pose being sculpted). */
  mode?: 'animate' | 'pose' | 'sculpt';
  /** JSON array of the model file names of a drop or zip holding several; empty for one model. */
  models?: string;
  /** Where each IK goal's pole marker is drawn, `"x,y"` in CSS px of the canvas, `;` per goal. */
  ikPole?: string;
  /** JSON array of clip names. */
  clips?: string;
  clip?: string;
  time?: string;
  duration?: string;
  playing?: 'true' | 'false';
  speed?: string;
  loop?: LoopMode;
  crossfade?: string;
  /** `CLIP@ROOT:WEIGHT`. */
  layer?: string;
  skinning?: SkinningMethod;
  skinningPath?: SkinningPath;
  /** `true` once a path was chosen; `false` while the adapter's default (or the heatmap's vertex shader) is used. */
  skinningPathChosen?: 'true' | 'false';
  heatmap?: 'true' | 'false';
  grid?: 'true' | 'false';
  /** Comma-separated: skeleton, bounds, wireframe, normals. */
  overlays?: string;
  /** The selected joint's name. */
  joint?: string;
  lighting?: 'studio' | 'outdoor' | 'flat' | 'rim';
  background?: Background;
  /** The exposure as a decimal number (1: as lit). */
  exposure?: string;
  toneMapping?: ToneMapping;
  /** `''` (the lighting preset's environment), `neutral`, `studio`, `outdoor` or `image` (an .hdr file). */
  environment?: '' | 'neutral' | 'studio' | 'outdoor' | 'image';
  /** The ground shadow: `intensity,softness`. */
  shadow?: string;
  /** While a model downloads: `RECEIVED/TOTAL` bytes. */
  progress?: string;
  ragdoll?: '' | 'simulating' | 'resting' | 'blending';
  quality?: string;
  copies?: string;
  ik?: string;
  ikTarget?: string;
  /** `yaw,pitch,distance,x,y,z`. */
  camera?: string;
  frames?: string;
  /** The 3D view's rectangle in CSS pixels of the canvas, `x,y,width,height`. */
  viewport?: string;
  /** The box the camera frames (the model over its clips, with its copies), `minx,miny,minz,maxx,maxy,maxz`. */
  bounds?: string;
  /** The panel: beside the view, or (narrower than 600 CSS px) a sheet over it, open or closed. */
  panel?: '' | 'side' | 'open' | 'closed';
}

export declare class KloubViewer extends HTMLElement {
  static readonly observedAttributes: string[];

  /** Model URL (attribute `src`); setting it loads the model. */
  src: string;
  /** Start new models playing (attribute `autoplay`). */
  autoplay: boolean;
  /** The clip shown; setting it crossfades to that clip (attribute `animation-name`). */
  animationName: string;
  /** Playback speed, negative plays backwards (attribute `speed`, default 1). */
  speed: number;
  /** Loop mode (attribute `loop`: absent or "" repeats, "once", "pingpong"). */
  loop: LoopMode;
  /** Skinning method (attribute `skinning`, default `lbs`). */
  skinning: SkinningMethod;
  /** Side panel and menus shown (attribute `controls`). */
  controls: boolean;
  /** Behind the model (attribute `background`): a theme or any CSS colour (painted behind the transparent canvas);
   *  default `transparent` without `controls`, `dark` with them. */
  background: Background | string;
  /** The accessible name (attribute `alt`); without `controls` the element has the role `img`. */
  alt: string;
  /** When the model is fetched (attribute `loading`): `auto` and `eager` at once, `lazy` once the element nears the
   *  viewport (until then `data-status` is `waiting` and nothing is fetched). */
  loading: 'auto' | 'lazy' | 'eager';
  /** An image shown until the model's first frame (attribute `poster`). */
  poster: string;
  /** `auto`: the poster goes at the model's first frame; `manual`: only at `dismissPoster()` (attribute `reveal`). */
  reveal: 'auto' | 'manual';
  /** Hides the poster (fires `poster-dismissed`). */
  dismissPoster(): void;
  /* Attributes without properties: `camera-controls` (user orbit/zoom/pan and keys; otherwise the view takes no
     input), `camera-orbit` ("θ φ r", deg/rad, m/cm/mm/%, auto), `camera-target` ("x y z", auto), `auto-rotate`,
     `auto-rotate-delay` (ms, default 3000), `rotation-per-second` (default π/32 rad), `min-camera-orbit` /
     `max-camera-orbit` ("θ φ r", auto or ±Infinity: unbounded), `field-of-view` (auto: 45deg), `disable-zoom`,
     `disable-pan`, `interaction-prompt` (auto | none), `interaction-prompt-threshold` (ms, default 3000),
     `animation-crossfade-duration` (ms). */
  /** The ground grid (attribute `grid`; `grid="false"` turns it off): by default on with `controls` only. */
  grid: boolean;
  /** Attribute `exposure` (model-viewer's): 0 to 64, 1 when absent or invalid. */
  exposure: number;
  /** Attribute `environment-image` (model-viewer's): `neutral` (made in code), `studio` or `outdoor` (photographs
   *  fetched from `environments/` beside the module when first used), or the URL of a Radiance .hdr image (up to
   *  2048×1024 pixels); `''` for the lighting preset's own. A file that cannot be fetched or read is an `error` event
   *  and the light before it stays. */
  environmentImage: string;
  /** Attribute `shadow-intensity` (model-viewer's): the ground shadow's darkness, 0 (none) to 1; 0.6 when absent. */
  shadowIntensity: number;
  /** Attribute `shadow-softness` (model-viewer's): 0 (sharp) to 1 (the default). */
  shadowSoftness: number;
  /** Attribute `tone-mapping` (model-viewer's); the setter also takes `auto` (neutral) and `linear` (none). */
  toneMapping: ToneMapping | 'auto' | 'linear';
  /* Attribute `min-pixel-ratio`: the lowest resolution (canvas pixels per CSS pixel, default 0.5) a viewer without
     `controls` may drop to while frames are slow. */
  /** The renderer in use; choose it with the `backend` attribute (auto | webgpu | webgl2). */
  readonly backend: string;

  /** Starts the clock. */
  play(): void;
  /** Stops the clock. */
  pause(): void;
  readonly paused: boolean;
  /** The clock in seconds; setting it seeks (clamped to the clip). */
  currentTime: number;
  /** The clip's duration in seconds (0 without a clip). */
  readonly duration: number;
  readonly availableAnimations: string[];
  /** A model is shown. */
  readonly loaded: boolean;

  /** Crossfades to the clip `name` over `seconds` (default: the `crossfade-duration` attribute, else 0.3). */
  crossfadeTo(name: string | null, seconds?: number): void;
  /** Plays `clip` on the subtree under `rootJoint` with `weight` in [0, 1]; a null clip removes the layer. */
  setLayer(clip: string | null, rootJoint: string | null, weight?: number): void;
  /** Drags `joint` to the world point by IK (`depth` joints above it turn, default 2); null clears every goal. Needs the full app (its handle is drawn in the view): on the light widget build the page loads it first. */
  setIkTarget(joint: string | null, target?: [number, number, number] | null, depth?: number): void;
  /**
   * The solver of `joint`'s IK goal (set its target first). Two-bone: `pole` (the middle joint bends towards it;
   * null or left out: none) and `softness` (0–0.5 of the chain's length eased); CCD: `patternMove`. Left out:
   * unchanged (except the pole).
   */
  setIkSolver(
    joint: string,
    solver: 'ccd' | 'twobone' | 'fabrik' | 'dls',
    options?: { pole?: [number, number, number] | null; softness?: number; patternMove?: boolean; iterations?: number },
  ): void;
  /** Shows a model from a URL or from files; resolves with its name once it is on screen. */
  load(urlOrFiles: string | URL | FileList | File[]): Promise<string>;
  /**
   * Runs the Khronos glTF-Validator (fetched on first use, run in a worker) on the shown model: its dropped files,
   * or the file at `data-src` and what it refers to. Resolves with the report and dispatches `validation`; with
   * `controls` the panel's Validation section lists it. Rejects when no model is shown or the files are gone.
   */
  validate(): Promise<ValidationReport>;

  /** Plays `name` as a click in the clip list does (crossfading when something plays). */
  playClip(name: string | null): void;
  seek(seconds: number): void;
  setSpeed(speed: number): void;
  setLoop(mode: LoopMode): void;
  /** Blends clips by relative weight as the base pose. */
  setBlend(names: string[], weights: number[]): void;
  setSkinning(method: SkinningMethod): void;
  /** How clip changes crossfade; keys left out stay as they are. */
  setTransition(options: { duration?: number; easing?: 'smoothstep' | 'linear'; outgoing?: 'freeze' | 'keep' | 'sync' }): void;
  /** `compute` throws on WebGL2. Until called: `gpu`, or `cpu` on a CPU adapter (SwiftShader, llvmpipe). */
  setSkinningPath(path: SkinningPath): void;
  /** Colours vertices by their distance from linear blend skinning's result. */
  setHeatmap(on: boolean): void;
  /** Overlays: the skeleton (names on hover), the framing bounds, the deformed wireframe, the normals. Needs the full app: on the light widget build the page loads it first and the call applies once the model is back (errors then come as `error` events). */
  setOverlays(overlays: { skeleton?: boolean; bounds?: boolean; wireframe?: boolean; normals?: boolean; bodies?: boolean }): void;
  /** Drops the character as a ragdoll from the pose on screen (data-ragdoll: simulating, then resting); `strength` 0 (limp, the default) to 1 powers it towards the clip as it plays on (a push or a ball staggers it, it recovers; a powered ragdoll rests only while the clip is paused). Needs the full app: on the light widget build the page loads it first and the call applies once the model is back (errors then come as `error` events). */
  startRagdoll(options?: { strength?: number }): void;
  /** The ragdoll's obstacles in model units (`data-obstacles` mirrors them; a running ragdoll takes them at once): `box` (`center`, `size` [x, y, z], `rotation`?), `sphere` (`center`, `radius`), `capsule` (`center`, `radius`, `height`, `rotation`?), `stairs` (`center` of the footprint on the floor, `size` [width, rise, run], `steps`, `rotation`?, climbing towards +Z), `ramp` (like stairs, a wedge). Bad input throws a RangeError naming the pointer (`/2/radius`). Needs the full app. */
  setObstacles(list: Array<{ shape: 'box' | 'sphere' | 'capsule' | 'stairs' | 'ramp'; center: [number, number, number]; size?: [number, number, number]; radius?: number; height?: number; steps?: number; rotation?: [number, number, number, number] }>): void;
  /** Ends the ragdoll: at once, or blending back to the animation over `seconds`. Needs the full app: on the light widget build the page loads it first and the call applies once the model is back (errors then come as `error` events). */
  stopRagdoll(seconds?: number): void;
  /** Gravity in m/s² for a person-sized body (scaled to the model) and velocity damping per second. Needs the full app: on the light widget build the page loads it first and the call applies once the model is back (errors then come as `error` events). */
  setRagdollOptions(options: { gravity?: number; damping?: number }): void;
  /** Selects a joint by name: its axes are drawn and its channels plotted in the panel; null clears. Needs the full app: on the light widget build the page loads it first and the call applies once the model is back (errors then come as `error` events). */
  selectJoint(name: string | null): void;
  /** Holds morph target `target` (index or name) of the mesh on node `node` at `weight`; null lets the clip drive it. */
  setMorphWeight(node: string, target: number | string, weight: number | null): void;
  /** Holds joint `name`'s local rotation (a unit quaternion `[x, y, z, w]` in its parent's frame) over the animation; null lets the animation drive it again. IK solves on top. */
  setJointRotation(name: string, rotation: [number, number, number, number] | null): void;
  /** Joint `name`'s local rotation `[x, y, z, w]` in the last drawn pose (held or animated). */
  jointRotation(name: string): [number, number, number, number];
  /** Lets the animation drive every joint again. */
  resetPose(): void;
  /** Pose mode on or off (`data-mode`): the clip stops where it is, a click on the model selects a joint and the gizmo's three rings turn it; leaving plays the clip again if it played. Needs the full app: on the light widget build the page loads it first. */
  setPoseMode(on: boolean): void;
  /** Records joint `name`'s rotation on screen as a new example pose of SJB by example and opens the sculpt on its support (`data-mode="sculpt"`); the panel's Done adds it. Errors (a joint without a parent joint or with several children, a bone left where it is at rest, four examples already) come as `error` events. Needs the full app. */
  addExamplePose(name: string): void;
  setLighting(name: 'studio' | 'outdoor' | 'flat' | 'rim'): void;
  setBackground(name: Background): void;
  /** Exposure, 0 to 64 (1: as lit): a factor on the shaded colour before tone mapping. */
  setExposure(exposure: number): void;
  /** Tone mapping: Khronos PBR Neutral (the default), ACES filmic, or none (clamped). */
  setToneMapping(name: ToneMapping): void;
  /** Turns the environment about the vertical axis by `degrees` (counter-clockwise seen from above). */
  setEnvironmentRotation(degrees: number): void;
  /** Downloads the view as `<model>.png`. */
  screenshot(): void;
  /** The current frame at the canvas's size in device pixels, transparent where the background is; no download
   *  (model-viewer's `toBlob`; `idealAspect` is not supported). */
  toBlob(options?: { mimeType?: string; qualityArgument?: number }): Promise<Blob>;
  /** The centre of the box the camera frames (the model over its clips, with its copies), world units; null
   *  without a model (model-viewer's method of the same name). */
  getBoundingBoxCenter(): { x: number; y: number; z: number } | null;
  /** The size of that box; null without a model (model-viewer's `getDimensions()`). */
  getDimensions(): { x: number; y: number; z: number } | null;
  /** The current frame as a data URL (default `image/png`). */
  toDataURL(type?: string, encoderOptions?: number): string;
  /** Shows or hides the ground grid. */
  setGrid(on: boolean): void;
  /** Shows 1 to 100 characters in a grid, each 0.37 s behind the previous. */
  setCopies(n: number): void;
  /** A model of `samples` by name, or the built-in `'candy-wrapper'`; unknown names throw a RangeError. */
  loadSample(name: string): void;
  /** The Samples menu's library (the app page sets it from `/api/assets`). */
  samples: KloubSample[];
  setCandyPose(twistDegrees: number, bendDegrees: number): void;
  /** `[yaw, pitch, distance, targetX, targetY, targetZ]`. */
  camera: number[];
  readonly state: KloubViewerState;

  addEventListener<K extends keyof KloubViewerEventMap>(
    type: K,
    listener: (this: KloubViewer, event: KloubViewerEventMap[K]) => unknown,
    options?: boolean | AddEventListenerOptions,
  ): void;
  addEventListener(type: string, listener: EventListenerOrEventListenerObject, options?: boolean | AddEventListenerOptions): void;
  removeEventListener<K extends keyof KloubViewerEventMap>(
    type: K,
    listener: (this: KloubViewer, event: KloubViewerEventMap[K]) => unknown,
    options?: boolean | EventListenerOptions,
  ): void;
  removeEventListener(type: string, listener: EventListenerOrEventListenerObject, options?: boolean | EventListenerOptions): void;
}

declare global {
  interface HTMLElementTagNameMap {
    'kloub-viewer': KloubViewer;
  }
}
