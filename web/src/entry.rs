//! The wasm entry point: the [`Viewer`] handle that the `<kloub-viewer>` element
//! (`web/kloub-viewer.js`) creates, configures and mounts on its own canvas. Many viewers may
//! run on one page: they draw with one shared device ([`crate::page::gpu`]), each writes only
//! to its own element (state as `data-*` attributes, events through the element's callback,
//! the error overlay into its shadow root). The element schedules the frames
//! ([`Viewer::frame`]) and forwards input.

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use wasm_bindgen::prelude::*;

#[cfg(feature = "full")]
use crate::app::App;
use crate::backend::BackendChoice;
use crate::stage::AppConfig;
use kloub_core::job::dqs::SkinningMethod;

use crate::candy::Sample;
use crate::control::{Command, Controls, Prefs, parse_loop_mode};
use crate::dom::{self, Host};
use crate::load::{Delivery, Inbox, SourceFile};
use crate::page::gpu;
use crate::page::view::{Next, View};
use crate::render::SkinningPath;

/// Controls one viewer from JavaScript. Names are resolved against the model shown at the
/// call (an unknown name throws); the change applies at the next frame, the same way the side
/// panel's controls do. State is read back from the element's `data-*` attributes.
#[wasm_bindgen]
pub struct Viewer {
    controls: Controls,
    inbox: Inbox,
    id: u32,
    mounted: Rc<RefCell<Option<Mounted>>>,
}

struct Mounted {
    view: View,
    host: Host,
    backend: BackendChoice,
}

thread_local! {
    static NEXT_ID: Cell<u32> = const { Cell::new(1) };
    /// Each mounted viewer's `emit`, to say `kloub:wake` when its egui context asks for a frame.
    static WAKERS: RefCell<Vec<(u32, js_sys::Function)>> = const { RefCell::new(Vec::new()) };
    /// The page's handler of a panic (the element module recreates the module instance).
    static PANIC_HANDLER: RefCell<Option<js_sys::Function>> = const { RefCell::new(None) };
}

/// Asks the element of viewer `id` for a frame in `delay_ms`.
fn wake(id: u32, delay_ms: f64) {
    let emit =
        WAKERS.with(|w| w.try_borrow().ok().and_then(|w| w.iter().find(|(i, _)| *i == id).map(|(_, f)| f.clone())));
    if let Some(emit) = emit {
        let _ = emit.call2(&JsValue::NULL, &"kloub:wake".into(), &delay_ms.into());
    }
}

#[cfg(feature = "full")]
fn watch_repaints(id: u32, ctx: &egui::Context) {
    ctx.set_request_repaint_callback(move |info| wake(id, info.delay.as_secs_f64() * 1000.0));
}

impl Default for Viewer {
    fn default() -> Self {
        Self::new()
    }
}

#[wasm_bindgen]
impl Viewer {
    /// A viewer that is not shown yet: configure it, then [`Viewer::mount`] it.
    #[wasm_bindgen(constructor)]
    pub fn new() -> Viewer {
        crate::page::log::init();
        install_panic_hook();
        let id = NEXT_ID.with(|n| {
            let id = n.get();
            n.set(id.wrapping_add(1));
            id
        });
        Viewer { controls: Controls::default(), inbox: Inbox::default(), id, mounted: Rc::default() }
    }

    /// Starts the viewer on `canvas`, mirroring its state into `element.dataset`, putting
    /// the error overlay into `overlay` (the element's shadow root) and reporting events
    /// through `emit(type, detail)` (also `kloub:wake` with a delay in ms when it wants a
    /// frame, and `kloub:lost` when the page's device is lost). `backend`: `"webgpu"`,
    /// `"webgl2"` (also `"gl"`) or `null`/`"auto"` (WebGPU when available); every viewer of
    /// a backend shares one device. `src`: a model URL to show first. The side panel shows
    /// unless [`Viewer::set_panels`] said otherwise. Resolves when the viewer can draw;
    /// rejects (after showing the overlay) when no device could be made.
    pub fn mount(
        &self,
        canvas: web_sys::HtmlCanvasElement,
        element: web_sys::HtmlElement,
        overlay: web_sys::Node,
        emit: Option<js_sys::Function>,
        backend: Option<String>,
        src: Option<String>,
    ) -> js_sys::Promise {
        let host = Host::new(element, overlay, emit.clone());
        let controls = self.controls.clone();
        let inbox = self.inbox.clone();
        let mounted = self.mounted.clone();
        let id = self.id;
        wasm_bindgen_futures::future_to_promise(async move {
            if mounted.borrow().is_some() {
                return Err(js_sys::Error::new("mount: this viewer is already mounted").into());
            }
            host.write(dom::Key::Status.name(), "loading");
            let choice = BackendChoice::from_query(backend.as_deref());
            let started = gpu::shared(choice).await.and_then(|gpu| {
                let config = AppConfig {
                    model_url: src.filter(|s| !s.is_empty()),
                    controls,
                    inbox,
                    host: host.clone(),
                    panels: true,
                    share: Some(gpu.generation),
                };
                #[cfg(feature = "full")]
                return View::new(gpu, canvas, |ctx, render| {
                    watch_repaints(id, ctx);
                    App::with_gpu(ctx, render, config)
                });
                #[cfg(not(feature = "full"))]
                View::new(gpu, canvas, |graphics| {
                    crate::stage::Stage::new(graphics, config, crate::control::Wake::new(move || wake(id, 0.0)))
                })
            });
            let view = match started {
                Ok(view) => view,
                Err(error) => {
                    let message = format!("Kloub could not start: {error}");
                    host.show_fatal(&message);
                    return Err(js_sys::Error::new(&message).into());
                }
            };
            if let Some(emit) = emit {
                WAKERS.with(|w| w.borrow_mut().push((id, emit.clone())));
                gpu::listen(id, emit);
            }
            dom::register(&host);
            *mounted.borrow_mut() = Some(Mounted { view, host, backend: choice });
            wake(id, 0.0);
            Ok(JsValue::UNDEFINED)
        })
    }

    /// Moves the viewer to a new device after `kloub:lost`, drawing on `canvas` (a fresh
    /// one: the old canvas's context belongs to the lost device). Its model, clocks, camera
    /// and settings stay. Resolves when it can draw again; rejects while no device can be made
    /// (try again later).
    pub fn reattach(&self, canvas: web_sys::HtmlCanvasElement) -> js_sys::Promise {
        let mounted = self.mounted.clone();
        let id = self.id;
        wasm_bindgen_futures::future_to_promise(async move {
            let Some(backend) = mounted.borrow().as_ref().map(|m| m.backend) else {
                return Err(js_sys::Error::new("reattach: this viewer is not mounted").into());
            };
            let gpu = gpu::shared(backend).await.map_err(|e| js_sys::Error::new(&e))?;
            let mut slot = mounted.borrow_mut();
            let Some(m) = slot.as_mut() else { return Err(js_sys::Error::new("reattach: unmounted meanwhile").into()) };
            if m.view.gpu().generation != gpu.generation || m.view.gpu().is_lost() {
                m.view.reattach(gpu, canvas).map_err(|e| js_sys::Error::new(&e))?;
                #[cfg(feature = "full")]
                watch_repaints(id, &m.view.ctx);
            }
            drop(slot);
            wake(id, 0.0);
            Ok(JsValue::UNDEFINED)
        })
    }

    /// Draws a frame at `now` (ms, the animation frame's timestamp) on a canvas of `width` ×
    /// `height` pixels, `ppp` canvas pixels per CSS pixel. Returns when the next frame is
    /// wanted: a delay in ms (0: the next animation frame), `Infinity` (only when something
    /// changes: `kloub:wake` says so) or -1 (the device is lost: [`Viewer::reattach`]).
    pub fn frame(&self, now: f64, width: u32, height: u32, ppp: f32) -> f64 {
        let Ok(mut slot) = self.mounted.try_borrow_mut() else { return f64::INFINITY };
        let Some(m) = slot.as_mut() else { return f64::INFINITY };
        match m.view.frame(now, width, height, ppp) {
            Next::In(ms) => ms,
            Next::Idle => f64::INFINITY,
            Next::Lost => -1.0,
        }
    }

    /// Moves every clock by `seconds`: the time the viewer was out of view while playing, so
    /// that it comes back where it would be.
    #[wasm_bindgen(js_name = catchUp)]
    pub fn catch_up(&self, seconds: f64) {
        if let Ok(mut slot) = self.mounted.try_borrow_mut()
            && let Some(m) = slot.as_mut()
        {
            m.view.stage_mut().catch_up(seconds as f32);
        }
    }

    /// Whether the shown model moves (a frame is wanted every animation frame while in view).
    #[wasm_bindgen(getter)]
    pub fn animating(&self) -> bool {
        self.mounted.try_borrow().ok().and_then(|m| m.as_ref().map(|m| m.view.stage().animating())).unwrap_or(false)
    }

    fn with_input(&self, f: impl FnOnce(&mut crate::page::view::Input)) {
        if let Ok(mut slot) = self.mounted.try_borrow_mut()
            && let Some(m) = slot.as_mut()
        {
            // The widget's double click is timed by the events' arrival.
            #[cfg(not(feature = "full"))]
            m.view.input.set_time(crate::page::view::now_ms());
            f(&mut m.view.input);
        }
    }

    /// Input: the pointer moved to `x, y` (CSS pixels in the canvas).
    #[wasm_bindgen(js_name = pointerMove)]
    pub fn pointer_move(&self, x: f32, y: f32) {
        self.with_input(|i| i.pointer_move(x, y));
    }

    /// Input: `button` (DOM numbering) pressed or released; `modifiers` bits 1 Alt, 2 Ctrl,
    /// 4 Shift, 8 Meta.
    #[wasm_bindgen(js_name = pointerButton)]
    pub fn pointer_button(&self, x: f32, y: f32, button: u8, pressed: bool, modifiers: u8) {
        self.with_input(|i| i.pointer_button(x, y, button, pressed, modifiers));
    }

    /// Input: the pointer left the canvas.
    #[wasm_bindgen(js_name = pointerGone)]
    pub fn pointer_gone(&self) {
        self.with_input(crate::page::view::Input::pointer_gone);
    }

    /// Input: a wheel event (`deltaMode` 0 pixels, 1 lines, 2 pages).
    pub fn wheel(&self, dx: f32, dy: f32, mode: u8, modifiers: u8) {
        self.with_input(|i| i.wheel(dx, dy, mode, modifiers));
    }

    /// Input: a touch point (`phase` 0 start, 1 move, 2 end, 3 cancel).
    pub fn touch(&self, id: u32, phase: u8, x: f32, y: f32, force: f32) {
        self.with_input(|i| i.touch(id, phase, x, y, force));
    }

    /// Input: a key (`key` and `code` of the DOM event). Returns whether the page should
    /// prevent the browser's default action.
    pub fn key(&self, key: &str, code: &str, pressed: bool, modifiers: u8) -> bool {
        let mut prevent = false;
        self.with_input(|i| prevent = i.key(key, code, pressed, modifiers));
        prevent
    }

    /// Input: pasted text.
    pub fn paste(&self, text: String) {
        self.with_input(|i| i.paste(text));
    }

    /// Input: the browser's copy (`cut` false) or cut command.
    pub fn copy(&self, cut: bool) {
        self.with_input(|i| i.copy(cut));
    }

    /// Input: the canvas gained or lost the keyboard focus.
    pub fn focus(&self, on: bool) {
        self.with_input(|i| i.focus(on));
    }

    #[cfg(feature = "full")]
    fn with_view(&self, f: impl FnOnce(&mut View)) {
        if let Ok(mut slot) = self.mounted.try_borrow_mut()
            && let Some(m) = slot.as_mut()
        {
            f(&mut m.view);
        }
    }

    #[cfg(feature = "full")]
    /// Mirrors the panels' accessibility tree for the element (see [`Viewer::take_accessibility`]),
    /// or stops.
    #[wasm_bindgen(js_name = setAccessibility)]
    pub fn set_accessibility(&self, on: bool) {
        self.with_view(|v| v.set_accessibility(on));
    }

    #[cfg(feature = "full")]
    /// What changed in the panels' accessibility tree with the last frame: JSON of the nodes
    /// to create or update and the ids that went away (`undefined`: nothing).
    #[wasm_bindgen(js_name = takeAccessibility)]
    pub fn take_accessibility(&self) -> Option<String> {
        let mut out = None;
        self.with_view(|v| out = v.take_accessibility());
        out
    }

    #[cfg(feature = "full")]
    /// An action of assistive technology on a mirrored node: `click`, `focus`, `setValue`
    /// (with `number` or `text`), `increment`, `decrement`, `scrollIntoView`. Returns whether
    /// it was understood (it takes effect with the next frame).
    #[wasm_bindgen(js_name = accessibilityAction)]
    pub fn accessibility_action(&self, node: &str, action: &str, number: Option<f64>, text: Option<String>) -> bool {
        let Some(request) = crate::page::a11y::action_request(node, action, number, text) else { return false };
        self.with_input(|i| i.accessibility(request));
        true
    }

    #[cfg(feature = "full")]
    /// Test hook: every control of the panels' accessibility tree as egui built it, as JSON
    /// `[[role, name], …]` (what the page's accessibility tree must list).
    #[wasm_bindgen(js_name = _testAccessibilityControls)]
    pub fn test_accessibility_controls(&self) -> String {
        let mut out = "[]".to_owned();
        self.with_view(|v| out = v.accessibility_controls());
        out
    }

    #[cfg(feature = "full")]
    /// No UI animations when the page prefers reduced motion.
    #[wasm_bindgen(js_name = setReducedMotion)]
    pub fn set_reduced_motion(&self, on: bool) {
        self.with_view(|v| v.set_reduced_motion(on));
    }

    #[cfg(feature = "full")]
    /// The keyboard moved to the 3D view: panel widgets let go of egui's focus.
    #[wasm_bindgen(js_name = releaseFocus)]
    pub fn release_focus(&self) {
        self.with_view(View::release_focus);
    }

    /// Stops the viewer and frees its GPU resources (the element left the page).
    pub fn destroy(&self) {
        if let Some(m) = self.mounted.borrow_mut().take() {
            dom::unregister(&m.host);
            gpu::unlisten(self.id);
            WAKERS.with(|w| w.borrow_mut().retain(|(i, _)| *i != self.id));
            let gpu = m.view.gpu().clone();
            drop(m);
            // Its model may have been the last of its kind on the page.
            crate::render::scene::release_unused_uploads(None);
            // wgpu frees dropped resources when the device is polled (each frame submits; a page
            // whose last viewer went away submits nothing more): free them now.
            let _ = gpu.device.poll(wgpu::PollType::Poll);
        }
    }

    /// How every newly shown model starts: `autoplay`, the clip named `clip` (`null`: the
    /// first), `speed`, loop mode `loop_mode` (`"once"`, `"repeat"`, `"pingpong"`), and a
    /// layer of `layer_clip` on the subtree under `layer_root` (both or neither).
    pub fn configure(
        &self,
        autoplay: bool,
        clip: Option<String>,
        speed: f32,
        loop_mode: &str,
        layer_clip: Option<String>,
        layer_root: Option<String>,
    ) -> Result<(), JsValue> {
        if !speed.is_finite() {
            return Err(range_error("speed must be a finite number"));
        }
        let loop_mode = parse_loop_mode(loop_mode).map_err(range_error)?;
        let layer = match (layer_clip.filter(|s| !s.is_empty()), layer_root.filter(|s| !s.is_empty())) {
            (Some(clip), Some(root)) => Some((clip, root, 1.0)),
            _ => None,
        };
        let clip = clip.filter(|s| !s.is_empty());
        self.controls.set_prefs(Prefs { autoplay, clip, speed, loop_mode, layer });
        Ok(())
    }

    /// The glTF-Validator's report on the shown model, as the element's `validate()` summarises
    /// it (see [`crate::validation::parse`]); the side panel lists it.
    #[cfg(feature = "full")]
    #[wasm_bindgen(js_name = setValidation)]
    pub fn set_validation(&self, json: &str) -> Result<(), JsValue> {
        let validation = crate::validation::parse(json).map_err(range_error)?;
        self.controls.send(Command::SetValidation(validation));
        Ok(())
    }

    /// Fetches and shows the model at `url` (relative URIs inside resolve against it).
    #[wasm_bindgen(js_name = loadUrl)]
    pub fn load_url(&self, url: String) {
        self.controls.send_global(Command::LoadUrl(url));
    }

    /// The Samples menu's library: a JSON array shaped like `kloub serve`'s `/api/assets`
    /// (`[{name, url, attribution, licence, clips, joints, size, default}]`). Replaces the
    /// previous list; throws when `json` is not such an array.
    #[wasm_bindgen(js_name = setSamples)]
    pub fn set_samples(&self, json: &str) -> Result<(), JsValue> {
        let samples = crate::samples::parse(json).map_err(range_error)?;
        self.controls.send_global(Command::SetSamples(samples));
        Ok(())
    }

    /// Shows the model among `files` (names with relative folders, e.g. `CesiumMan/CesiumMan.gltf`,
    /// and their bytes): a `.glb`/`.gltf`; the other files resolve its URIs. Several models
    /// are listed in the side panel to switch between.
    #[wasm_bindgen(js_name = loadFiles)]
    pub fn load_files(&self, names: Vec<String>, contents: Vec<js_sys::Uint8Array>) -> Result<(), JsValue> {
        if names.len() != contents.len() {
            return Err(range_error("loadFiles: names and contents differ in length"));
        }
        let files = names.into_iter().zip(contents).map(|(name, bytes)| SourceFile { name, bytes: bytes.to_vec() });
        self.inbox.push(Delivery {
            origin: "dropped files".to_owned(),
            url: None,
            files: Ok(files.collect()),
            shared: None,
        });
        self.controls.wake();
        Ok(())
    }

    /// Bounds the camera (yaw, pitch in radians, distance in model units; NaN: no bound
    /// there), lets the user zoom and pan or not, and sets the vertical field of view (radians;
    /// NaN: 45°). The element's `min-camera-orbit`, `max-camera-orbit`, `disable-zoom`,
    /// `disable-pan` and `field-of-view`.
    #[wasm_bindgen(js_name = setCameraLimits)]
    #[expect(clippy::too_many_arguments, reason = "flat numbers across the wasm boundary")]
    pub fn set_camera_limits(
        &self,
        yaw_min: f32,
        yaw_max: f32,
        pitch_min: f32,
        pitch_max: f32,
        distance_min: f32,
        distance_max: f32,
        zoom: bool,
        pan: bool,
        fov: f32,
    ) {
        let limits = crate::render::camera::CameraLimits {
            yaw: [yaw_min, yaw_max],
            pitch: [pitch_min, pitch_max],
            distance: [distance_min, distance_max],
            zoom,
            pan,
        };
        let fov = (fov.is_finite()).then(|| fov.clamp(1f32.to_radians(), 170f32.to_radians()));
        self.controls.send_global(Command::SetCameraLimits { limits, fov });
    }

    /// Shows or hides the ground grid.
    #[wasm_bindgen(js_name = setGrid)]
    pub fn set_grid(&self, on: bool) {
        self.controls.send_global(Command::SetGrid(on));
    }

    /// Turns the overlays on or off: the skeleton (names on hover, click to select), the
    /// framing bounds, the deformed wireframe, the normals and the ragdoll's bodies.
    #[wasm_bindgen(js_name = setOverlays)]
    pub fn set_overlays(&self, skeleton: bool, bounds: bool, wireframe: bool, normals: bool, bodies: bool) {
        let overlays = crate::stage::Overlays { skeleton, bounds, wireframe, normals, bodies };
        self.controls.send_global(Command::SetOverlays(overlays));
    }

    /// Selects the joint named `name` (its axes are drawn and its channels plotted); `null`
    /// clears the selection.
    #[wasm_bindgen(js_name = selectJoint)]
    pub fn select_joint(&self, name: Option<String>) -> Result<(), JsValue> {
        let node = match name.as_deref() {
            None | Some("") => None,
            Some(name) => Some(self.controls.node_index(name).map_err(range_error)?),
        };
        self.controls.send(Command::SelectJoint(node));
        Ok(())
    }

    /// Holds morph target `target` (its index, or its name from the mesh's `targetNames`) of
    /// the mesh on node `node` at `weight`; `null` weight lets the clip drive it again.
    #[wasm_bindgen(js_name = setMorphWeight)]
    pub fn set_morph_weight(&self, node: String, target: JsValue, weight: Option<f32>) -> Result<(), JsValue> {
        let node_index = self.controls.morph_node_index(&node).map_err(range_error)?;
        let target = match (target.as_f64(), target.as_string()) {
            (Some(i), _) if i >= 0.0 && i.fract() == 0.0 => i as usize,
            (_, Some(name)) => self.controls.morph_target_index(node_index, &name).map_err(range_error)?,
            _ => return Err(range_error("setMorphWeight: target is an index or a name")),
        };
        self.controls.send(Command::SetMorph { node: node_index, target, weight });
        Ok(())
    }

    /// Holds joint `name`'s local rotation at `rotation` (a unit quaternion `[x, y, z, w]`, in
    /// its parent's frame) over the animation; `null` lets the animation drive it again.
    #[wasm_bindgen(js_name = setJointRotation)]
    pub fn set_joint_rotation(&self, name: String, rotation: Option<Vec<f32>>) -> Result<(), JsValue> {
        let node = self.controls.node_index(&name).map_err(range_error)?;
        let rotation = match rotation.as_deref() {
            None => None,
            Some(&[x, y, z, w]) => {
                use kloub_core::math::QuatExt;
                glam::Quat::from_xyzw(x, y, z, w).check_unit().map_err(|length| {
                    range_error(format!(
                        "setJointRotation: [{x}, {y}, {z}, {w}] is not a unit quaternion (length {length})"
                    ))
                })?;
                Some([x, y, z, w])
            }
            Some(other) => {
                return Err(range_error(format!(
                    "setJointRotation: expected [x, y, z, w], got {} numbers",
                    other.len()
                )));
            }
        };
        self.controls.send(Command::SetJointRotation { node, rotation });
        Ok(())
    }

    /// The local rotation `[x, y, z, w]` of joint `name` in the last drawn pose (held or animated).
    #[wasm_bindgen(js_name = jointRotation)]
    pub fn joint_rotation(&self, name: String) -> Result<Vec<f32>, JsValue> {
        self.controls.joint_rotation(&name).map(|q| q.to_vec()).map_err(range_error)
    }

    #[cfg(feature = "full")]
    /// Enters (`true`) or leaves pose mode: the clip stops where it is, clicks select joints and
    /// the gizmo turns them; leaving plays the clip again if it played.
    #[wasm_bindgen(js_name = setPoseMode)]
    pub fn set_pose_mode(&self, on: bool) {
        self.controls.send(Command::SetPoseMode(on));
    }

    #[cfg(feature = "full")]
    /// Records joint `name`'s rotation on screen as a new example pose (SJB by example) and
    /// opens the sculpt on its support (pose mode).
    #[wasm_bindgen(js_name = addExamplePose)]
    pub fn add_example_pose(&self, name: String) -> Result<(), JsValue> {
        let node = self.controls.node_index(&name).map_err(range_error)?;
        self.controls.send(Command::AddExamplePose(node));
        Ok(())
    }

    #[cfg(feature = "full")]
    /// Test hook: where the pose gizmo's rings can be grabbed, `[[x, y] of X, Y, Z, [x, y] of
    /// the joint]` in CSS pixels of the canvas, as drawn last frame; `""` without a gizmo.
    #[wasm_bindgen(js_name = _testGizmo)]
    pub fn test_gizmo(&self) -> String {
        let mut out = String::new();
        self.with_view(|v| out = v.app.gizmo_json());
        out
    }

    /// Lets the animation drive every joint again.
    #[wasm_bindgen(js_name = resetPose)]
    pub fn reset_pose(&self) {
        self.controls.send(Command::ResetPose);
    }

    /// Lighting preset: `"studio"`, `"outdoor"`, `"flat"` or `"rim"`.
    #[wasm_bindgen(js_name = setLighting)]
    pub fn set_lighting(&self, name: &str) -> Result<(), JsValue> {
        let lighting = crate::render::uniforms::Lighting::from_name(name).map_err(range_error)?;
        self.controls.send_global(Command::SetLighting(lighting));
        Ok(())
    }

    /// Background: `"dark"`, `"grey"` or `"light"`.
    #[wasm_bindgen(js_name = setBackground)]
    pub fn set_background(&self, name: &str) -> Result<(), JsValue> {
        let background = crate::render::uniforms::Background::from_name(name).map_err(range_error)?;
        self.controls.send_global(Command::SetBackground(background));
        Ok(())
    }

    /// Exposure: a factor on the shaded colour before tone mapping (model-viewer's `exposure`;
    /// 1: as lit), 0 to 64.
    #[wasm_bindgen(js_name = setExposure)]
    pub fn set_exposure(&self, exposure: f32) -> Result<(), JsValue> {
        let max = crate::render::uniforms::MAX_EXPOSURE;
        if !(exposure.is_finite() && (0.0..=max).contains(&exposure)) {
            return Err(range_error(format!("setExposure: {exposure}: expected a number from 0 to {max}")));
        }
        self.controls.send_global(Command::SetExposure(exposure));
        Ok(())
    }

    /// Tone mapping: `"neutral"` (Khronos PBR Neutral, the default), `"aces"` or `"none"`
    /// (model-viewer's `auto` and `linear` are taken as `neutral` and `none`).
    #[wasm_bindgen(js_name = setToneMapping)]
    pub fn set_tone_mapping(&self, name: &str) -> Result<(), JsValue> {
        let tone = crate::render::uniforms::ToneMapping::from_name(name).map_err(range_error)?;
        self.controls.send_global(Command::SetToneMapping(tone));
        Ok(())
    }

    /// The environment lighting the meshes: `"neutral"`, `"studio"` or `"outdoor"`, or `""`
    /// for the lighting preset's own (model-viewer's `environment-image` names; an image comes
    /// through [`Viewer::set_environment_image`]).
    #[wasm_bindgen(js_name = setEnvironment)]
    pub fn set_environment(&self, name: &str) -> Result<(), JsValue> {
        use crate::render::uniforms::EnvironmentChoice;
        let choice = if name.is_empty() {
            EnvironmentChoice::Preset
        } else {
            EnvironmentChoice::Named(crate::render::environment::EnvironmentName::from_name(name).map_err(range_error)?)
        };
        self.controls.send_global(Command::SetEnvironment(choice, None));
        Ok(())
    }

    /// Forgets an environment photograph the viewer is still waiting for (the page fetches an
    /// image instead): the light stays as it is.
    #[wasm_bindgen(js_name = dropPendingEnvironment)]
    pub fn drop_pending_environment(&self) {
        self.controls.send_global(Command::DropPendingEnvironment);
    }

    /// Lights the meshes with a Radiance `.hdr` file's equirectangular image (up to 2048 × 1024
    /// pixels; larger ones are refused).
    #[wasm_bindgen(js_name = setEnvironmentImage)]
    pub fn set_environment_image(&self, bytes: &[u8]) -> Result<(), JsValue> {
        let image = crate::render::environment::read_environment(bytes)
            .map_err(|e| range_error(format!("environment image: {e}")))?;
        let choice = crate::render::uniforms::EnvironmentChoice::Image;
        self.controls.send_global(Command::SetEnvironment(choice, Some(std::sync::Arc::new(image))));
        Ok(())
    }

    /// The ground shadow: `intensity` 0 (none) to 1 and `softness` 0 (sharp) to 1
    /// (model-viewer's `shadow-intensity` and `shadow-softness`).
    #[wasm_bindgen(js_name = setShadow)]
    pub fn set_shadow(&self, intensity: f32, softness: f32) -> Result<(), JsValue> {
        for (name, value) in [("intensity", intensity), ("softness", softness)] {
            if !(value.is_finite() && (0.0..=1.0).contains(&value)) {
                return Err(range_error(format!("setShadow: {name} {value}: expected 0 to 1")));
            }
        }
        self.controls.send_global(Command::SetShadow(intensity, softness));
        Ok(())
    }

    /// Turns the environment about the vertical axis by `degrees` (counter-clockwise seen from
    /// above).
    #[wasm_bindgen(js_name = setEnvironmentRotation)]
    pub fn set_environment_rotation(&self, degrees: f32) -> Result<(), JsValue> {
        if !degrees.is_finite() {
            return Err(range_error(format!("setEnvironmentRotation: {degrees}: expected a finite number of degrees")));
        }
        self.controls.send_global(Command::SetEnvironmentRotation(degrees.to_radians()));
        Ok(())
    }

    /// Turns the character into a ragdoll from the pose on screen (throws later, as an
    /// `error` event, for a model without a skin).
    #[wasm_bindgen(js_name = startRagdoll)]
    pub fn start_ragdoll(&self, strength: Option<f32>) -> Result<(), JsValue> {
        // Omitted, the strength is 0: a limp ragdoll, whatever an earlier call asked for.
        let s = strength.unwrap_or(0.0);
        if !(s.is_finite() && (0.0..=1.0).contains(&s)) {
            return Err(range_error(format!("startRagdoll: strength {s}: expected 0 to 1")));
        }
        self.controls.send(Command::SetRagdollStrength(s));
        self.controls.send(Command::StartRagdoll);
        Ok(())
    }

    #[cfg(feature = "full")]
    /// The ragdoll's obstacles, a JSON array of boxes, spheres, capsules, stairs and ramps (see
    /// the README); a running ragdoll takes them at once.
    #[wasm_bindgen(js_name = setObstacles)]
    pub fn set_obstacles(&self, json: &str) -> Result<(), JsValue> {
        let list = kloub_core::ragdoll::Obstacle::list_from_json(json)
            .map_err(|e| range_error(format!("setObstacles: {e}")))?;
        self.controls.send(Command::SetObstacles(list));
        Ok(())
    }

    #[cfg(feature = "full")]
    /// Test hook: where each obstacle's centre was drawn, `[[x, y] | null, …]` in CSS pixels of
    /// the canvas.
    #[wasm_bindgen(js_name = _testObstacles)]
    pub fn test_obstacles(&self) -> String {
        let mut out = "[]".to_owned();
        self.with_view(|v| out = v.app.obstacles_json());
        out
    }

    #[cfg(feature = "full")]
    /// Test hook: the ragdoll's ground and each body's centre, `{"ground": y, "bodies": [[x, y,
    /// z], …]}`; `""` without a ragdoll.
    #[wasm_bindgen(js_name = _testRagdoll)]
    pub fn test_ragdoll(&self) -> String {
        let mut out = String::new();
        self.with_view(|v| out = v.app.ragdoll_json());
        out
    }

    /// Ends the ragdoll: back to the animation at once, or blending over `seconds`.
    #[wasm_bindgen(js_name = stopRagdoll)]
    pub fn stop_ragdoll(&self, seconds: Option<f32>) -> Result<(), JsValue> {
        match seconds {
            None => self.controls.send(Command::StopRagdoll),
            Some(s) if s.is_finite() && s >= 0.0 => self.controls.send(Command::RagdollToAnimation(s)),
            Some(s) => return Err(range_error(format!("stopRagdoll: {s} seconds: expected >= 0"))),
        }
        Ok(())
    }

    /// Ragdoll gravity (m/s² for a person-sized skeleton) and velocity damping per second.
    #[wasm_bindgen(js_name = setRagdollOptions)]
    pub fn set_ragdoll_options(&self, gravity: f32, damping: f32) -> Result<(), JsValue> {
        if !(gravity.is_finite() && damping.is_finite() && damping >= 0.0) {
            return Err(range_error("setRagdollOptions: finite gravity and damping >= 0 expected"));
        }
        self.controls.send(Command::SetRagdollOptions { gravity, damping });
        Ok(())
    }

    /// Saves the view as `<model>.png` (a download).
    pub fn screenshot(&self) {
        self.controls.send_global(Command::Screenshot);
    }

    /// Shows the "drop to open" hint while files are dragged over the viewer.
    #[wasm_bindgen(js_name = setDropHint)]
    pub fn set_drop_hint(&self, on: bool) {
        self.controls.send_global(Command::SetDropHint(on));
    }

    /// Shows or hides the side panel and menus.
    #[wasm_bindgen(js_name = setPanels)]
    pub fn set_panels(&self, on: bool) {
        self.controls.send_global(Command::SetPanels(on));
    }

    /// The crossfade duration a clip change uses (the panel's setting), in seconds.
    #[wasm_bindgen(js_name = setCrossfadeDuration)]
    pub fn set_crossfade_duration(&self, seconds: f32) -> Result<(), JsValue> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(range_error(format!("crossfade duration {seconds}: expected seconds >= 0")));
        }
        self.controls.send_global(Command::SetTransitionDuration(seconds));
        Ok(())
    }

    /// How clip changes crossfade: `easing` `"smoothstep"` | `"linear"` and what the outgoing
    /// clip does, `outgoing` `"freeze"` | `"keep"` | `"sync"` (`null`: unchanged).
    #[wasm_bindgen(js_name = setTransition)]
    pub fn set_transition(&self, easing: Option<String>, outgoing: Option<String>) -> Result<(), JsValue> {
        let easing = easing.as_deref().map(crate::control::parse_easing).transpose().map_err(range_error)?;
        let outgoing = outgoing.as_deref().map(crate::control::parse_outgoing).transpose().map_err(range_error)?;
        self.controls.send_global(Command::SetTransition { easing, outgoing });
        Ok(())
    }

    /// Places the camera: `yaw` and `pitch` in radians, `distance` from the target point
    /// `x, y, z` (the values of `data-camera`).
    #[wasm_bindgen(js_name = setCamera)]
    pub fn set_camera(&self, yaw: f32, pitch: f32, distance: f32, x: f32, y: f32, z: f32) -> Result<(), JsValue> {
        let values = [yaw, pitch, distance, x, y, z];
        if values.iter().any(|v| !v.is_finite()) || distance <= 0.0 {
            return Err(range_error("setCamera: finite numbers and a positive distance expected"));
        }
        self.controls.send(Command::SetCamera(values));
        Ok(())
    }

    /// Runs every clock (clip, blended clips, layer).
    pub fn play(&self) {
        self.controls.send(Command::Play);
    }

    /// Stops every clock.
    pub fn pause(&self) {
        self.controls.send(Command::Pause);
    }

    /// Plays the clip named `name` as a click in the clip list does (crossfading with the
    /// panel's duration when something plays). `null` or `""` shows the rest pose.
    #[wasm_bindgen(js_name = playClip)]
    pub fn play_clip(&self, name: Option<String>) -> Result<(), JsValue> {
        let clip = self.clip(name)?;
        self.controls.send(Command::PlayClip(clip));
        Ok(())
    }

    /// Crossfades to the clip named `name` over `seconds` (0: cut), from the current pose.
    #[wasm_bindgen(js_name = crossfadeTo)]
    pub fn crossfade_to(&self, name: Option<String>, seconds: f32) -> Result<(), JsValue> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(range_error(format!("crossfade duration {seconds}: expected seconds >= 0")));
        }
        let clip = self.clip(name)?;
        self.controls.send(Command::CrossfadeTo { clip, seconds });
        Ok(())
    }

    /// Applies the clip named `clip` to the subtree under the joint (or node) named `root`
    /// with `weight` in `[0, 1]`; `null` or `""` as `clip` removes the layer.
    #[wasm_bindgen(js_name = setLayer)]
    pub fn set_layer(&self, clip: Option<String>, root: Option<String>, weight: f32) -> Result<(), JsValue> {
        let clip = self.clip(clip)?;
        let root = match (clip, root.as_deref()) {
            (None, _) => 0,
            (Some(_), Some(name)) => self.controls.node_index(name).map_err(range_error)?,
            (Some(_), None) => return Err(range_error("setLayer: a root joint name is required")),
        };
        if !(weight.is_finite() && (0.0..=1.0).contains(&weight)) {
            return Err(range_error(format!("layer weight {weight}: expected a number in [0, 1]")));
        }
        self.controls.send(Command::SetLayer { clip, root, weight });
        Ok(())
    }

    /// Moves the main clock to `seconds` (clamped to the clip).
    pub fn seek(&self, seconds: f32) -> Result<(), JsValue> {
        if !seconds.is_finite() {
            return Err(range_error("seek: time must be a finite number"));
        }
        self.controls.send(Command::Seek(seconds));
        Ok(())
    }

    /// Playback speed of the base clips; negative plays backwards.
    #[wasm_bindgen(js_name = setSpeed)]
    pub fn set_speed(&self, speed: f32) -> Result<(), JsValue> {
        if !speed.is_finite() {
            return Err(range_error("setSpeed: speed must be a finite number"));
        }
        self.controls.send(Command::SetSpeed(speed));
        Ok(())
    }

    /// Loop mode of the base clips: `"once"`, `"repeat"` or `"pingpong"`.
    #[wasm_bindgen(js_name = setLoop)]
    pub fn set_loop(&self, mode: &str) -> Result<(), JsValue> {
        let mode = parse_loop_mode(mode).map_err(range_error)?;
        self.controls.send(Command::SetLoop(mode));
        Ok(())
    }

    /// Blends clips by weight: `names[i]` with `weights[i]` (relative; 0 leaves a clip out).
    #[wasm_bindgen(js_name = setBlend)]
    pub fn set_blend(&self, names: Vec<String>, weights: Vec<f32>) -> Result<(), JsValue> {
        if names.len() != weights.len() {
            return Err(range_error("setBlend: names and weights differ in length"));
        }
        let mut blend = Vec::with_capacity(names.len());
        for (name, weight) in names.iter().zip(weights) {
            if !(weight.is_finite() && weight >= 0.0) {
                return Err(range_error(format!("setBlend: weight {weight} of {name:?} must be >= 0")));
            }
            blend.push((self.controls.clip_index(name).map_err(range_error)?, weight));
        }
        self.controls.send(Command::SetBlend(blend));
        Ok(())
    }

    /// Skinning method: `"rigid"`, `"lbs"` (linear blend), `"dqs"` (dual quaternion), `"sjb"`
    /// (spherical joint blending) or `"sjbbe"` (SJB by the sidecar's example poses). Kept across
    /// models.
    #[wasm_bindgen(js_name = setSkinning)]
    pub fn set_skinning(&self, method: &str) -> Result<(), JsValue> {
        let method = SkinningMethod::from_name(method).ok_or_else(|| {
            range_error(format!("skinning {method:?}: expected \"rigid\", \"lbs\", \"dqs\", \"sjb\" or \"sjbbe\""))
        })?;
        self.controls.send_global(Command::SetSkinning(method));
        Ok(())
    }

    /// Where vertices are deformed: `"gpu"` (vertex shader), `"compute"` (a compute pass;
    /// WebGPU only) or `"cpu"` (kloub_core's reference, uploaded every frame). Kept across
    /// models. Until called: the adapter's default ([`crate::render::default_skinning_path`]).
    #[wasm_bindgen(js_name = setSkinningPath)]
    pub fn set_skinning_path(&self, path: &str) -> Result<(), JsValue> {
        let path = SkinningPath::from_name(path).map_err(range_error)?;
        if path == SkinningPath::Compute && !self.controls.supports_compute() {
            return Err(range_error("setSkinningPath: \"compute\" needs WebGPU; this page runs on WebGL2"));
        }
        self.controls.send_global(Command::SetSkinningPath(path));
        Ok(())
    }

    /// Shows `n` characters in a grid (1 to 100), each playing 0.37 s later than the previous.
    /// Kept across models.
    #[wasm_bindgen(js_name = setCopies)]
    pub fn set_copies(&self, n: u32) -> Result<(), JsValue> {
        if !(1..=crate::model::MAX_COPIES as u32).contains(&n) {
            return Err(range_error(format!("setCopies: {n} copies: expected 1 to {}", crate::model::MAX_COPIES)));
        }
        self.controls.send(Command::SetCopies(n as usize));
        Ok(())
    }

    /// Colours skinned vertices by their distance from linear blend skinning's result (from
    /// dual quaternions' when LBS is the method): blue none, red 2% of the model's size.
    /// Vertex-shader path only.
    #[wasm_bindgen(js_name = setHeatmap)]
    pub fn set_heatmap(&self, on: bool) {
        self.controls.send_global(Command::SetHeatmap(on));
    }

    /// Inverse kinematics: drags the joint named `effector` (with `depth` joints above it
    /// rotating, default 2) towards the world point `x, y, z` (all three omitted: where the
    /// joint is now, to drag it from there in the viewport). Sets that joint's goal, or adds
    /// one: several effectors are solved together. `null` removes every goal.
    #[wasm_bindgen(js_name = setIkTarget)]
    pub fn set_ik_target(
        &self,
        effector: Option<String>,
        x: Option<f32>,
        y: Option<f32>,
        z: Option<f32>,
        depth: Option<u32>,
    ) -> Result<(), JsValue> {
        let Some(name) = effector else {
            self.controls.send(Command::SetIk { effector: None, depth: 0, target: None });
            return Ok(());
        };
        let target = match (x, y, z) {
            (None, None, None) => None,
            (Some(x), Some(y), Some(z)) if x.is_finite() && y.is_finite() && z.is_finite() => Some([x, y, z]),
            _ => return Err(range_error("setIkTarget: give x, y and z as finite numbers, or none of them")),
        };
        let effector = self.controls.node_index(&name).map_err(range_error)?;
        let depth = depth.unwrap_or(2) as usize;
        if !(1..32).contains(&depth) {
            return Err(range_error(format!("setIkTarget: depth {depth}: expected 1 to 31")));
        }
        self.controls.send(Command::SetIk { effector: Some(effector), depth, target });
        Ok(())
    }

    /// Inverse kinematics: the solver of the goal on the joint named `effector` (set its target
    /// first): `"ccd"`, `"twobone"` (2 joints above the effector), `"fabrik"` or `"dls"`. For
    /// two-bone, the middle joint bends towards the world point `pole_x, pole_y, pole_z` (all
    /// three omitted: no pole) and `softness` eases the last part of the reach (a fraction of
    /// the chain's length, 0 to 0.5); for CCD, `pattern_move` toggles the pattern move after
    /// each sweep. `iterations`: at most 1 to 128 per frame. Options left out stay as they are.
    #[wasm_bindgen(js_name = setIkSolver)]
    #[allow(clippy::too_many_arguments)]
    pub fn set_ik_solver(
        &self,
        effector: &str,
        solver: &str,
        pole_x: Option<f32>,
        pole_y: Option<f32>,
        pole_z: Option<f32>,
        softness: Option<f32>,
        pattern_move: Option<bool>,
        iterations: Option<u32>,
    ) -> Result<(), JsValue> {
        let solver = kloub_core::job::ik::IkSolver::ALL.into_iter().find(|s| s.name() == solver).ok_or_else(|| {
            range_error(format!("setIkSolver: solver {solver:?}: expected ccd, twobone, fabrik or dls"))
        })?;
        let pole = match (pole_x, pole_y, pole_z) {
            (None, None, None) => None,
            (Some(x), Some(y), Some(z)) if x.is_finite() && y.is_finite() && z.is_finite() => Some([x, y, z]),
            _ => return Err(range_error("setIkSolver: give the pole's x, y and z as finite numbers, or none")),
        };
        if softness.is_some_and(|s| !(0.0..=0.5).contains(&s)) {
            return Err(range_error("setIkSolver: softness: expected 0 to 0.5"));
        }
        if iterations.is_some_and(|n| !(1..=128).contains(&n)) {
            return Err(range_error("setIkSolver: iterations: expected 1 to 128"));
        }
        let effector = self.controls.node_index(effector).map_err(range_error)?;
        self.controls.send(Command::SetIkSolver {
            effector,
            solver,
            pole,
            softness,
            accelerate: pattern_move,
            iterations,
        });
        Ok(())
    }

    /// Shows a built-in sample: `"candy-wrapper"`.
    #[wasm_bindgen(js_name = loadSample)]
    pub fn load_sample(&self, name: &str) -> Result<(), JsValue> {
        let sample = Sample::from_name(name).map_err(range_error)?;
        self.controls.send_global(Command::LoadSample(sample));
        Ok(())
    }

    /// Poses the candy-wrapper sample: `twist` about the bone axis and `bend`, in degrees.
    #[wasm_bindgen(js_name = setCandyPose)]
    pub fn set_candy_pose(&self, twist: f32, bend: f32) -> Result<(), JsValue> {
        if !(twist.is_finite() && bend.is_finite()) {
            return Err(range_error("setCandyPose: angles must be finite numbers"));
        }
        self.controls.send(Command::SetCandyPose { twist, bend });
        Ok(())
    }

    /// Names of the shown model's clips.
    #[wasm_bindgen(getter, js_name = availableAnimations)]
    pub fn available_animations(&self) -> Vec<String> {
        self.controls.clip_names()
    }

    fn clip(&self, name: Option<String>) -> Result<Option<usize>, JsValue> {
        match name.as_deref() {
            None | Some("") => Ok(None),
            Some(name) => self.controls.clip_index(name).map(Some).map_err(range_error),
        }
    }
}

/// A refused argument as JavaScript sees it: a `RangeError` (an `Error`, with a stack), never a
/// bare string.
fn range_error(message: impl AsRef<str>) -> JsValue {
    js_sys::RangeError::new(message.as_ref()).into()
}

/// Which build of the module this is: `"full"` (panels, ragdoll, WebGPU and WebGL2), `"widget"`
/// (the light build: no panels or ragdoll, WebGPU only) or `"widget-gl"` (the light build on WebGL2,
/// through Kloub's own WebGL2 backend, `crate::gl`).
#[wasm_bindgen(js_name = buildName)]
pub fn build_name() -> String {
    if cfg!(feature = "full") {
        "full"
    } else if cfg!(feature = "gl") {
        "widget-gl"
    } else {
        "widget"
    }
    .to_owned()
}

/// Hands a panic (a bug) to the page: `handler(message)` is called from the panic hook, and the
/// element module recreates the module instance and remounts every viewer from its state. Without
/// a handler every viewer shows the error.
#[wasm_bindgen(js_name = setPanicHandler)]
pub fn set_panic_handler(handler: Option<js_sys::Function>) {
    PANIC_HANDLER.with(|h| *h.borrow_mut() = handler);
}

/// Hands the element's prefetches to the module: `take(url)` gives a download started before the
/// module was ready, `images(url)` the images of a GLB the browser decoded meanwhile
/// ([`crate::prefetch`]); `codecs()` a promise of the codecs module, which the widget builds
/// load when a file needs a Draco decoder or a zip reader ([`crate::codecs`]);
/// `environment(file)` a promise of the bytes of an environment photograph beside the module
/// ([`crate::photos`]).
#[wasm_bindgen(js_name = setPrefetch)]
pub fn set_prefetch(
    take: Option<js_sys::Function>,
    images: Option<js_sys::Function>,
    codecs: Option<js_sys::Function>,
    environment: Option<js_sys::Function>,
) {
    crate::prefetch::set_hooks(take, images);
    crate::codecs::set_loader(codecs);
    crate::photos::set_loader(environment);
}

/// For tests: panics inside the module (as a bug would), so recovery can be checked.
/// Test hook: what the page's viewers share, as JSON: per model URL the downloads started and
/// the imports done, the assets uploaded to a GPU, the pipeline kits and named environments built, the decoded
/// models still shown, the images decoded while the module loaded, the codecs module's loads and the
/// environment photographs' fetches (studio, outdoor).
#[wasm_bindgen(js_name = _testCounters)]
pub fn test_counters() -> String {
    let models: serde_json::Map<String, serde_json::Value> = crate::shared::counts()
        .into_iter()
        .map(|(url, c)| (url, serde_json::json!({ "fetches": c.fetches, "decodes": c.decodes })))
        .collect();
    serde_json::json!({
        "models": models,
        "uploads": crate::render::scene::uploads_made(),
        "kits": crate::render::pipelines::kits_built(),
        "environments": crate::render::pipelines::environments_built(),
        "liveModels": crate::shared::live_models(),
        "liveUploads": crate::render::scene::live_uploads(),
        "predecoded": crate::decode::predecoded(),
        "codecLoads": crate::codecs::loads(),
        "environmentFetches": crate::photos::fetches(),
    })
    .to_string()
}

/// Test hook: the size of the module's linear memory in bytes (it grows, never shrinks).
#[wasm_bindgen(js_name = _testMemoryBytes)]
pub fn test_memory_bytes() -> f64 {
    (core::arch::wasm32::memory_size(0) as f64) * 65536.0
}

#[wasm_bindgen(js_name = _testPanic)]
pub fn test_panic(message: &str) {
    panic!("test panic: {message}");
}

/// For tests: loses every device of the page (WebGPU `device.destroy()`, WebGL2
/// `WEBGL_lose_context`), as a GPU reset would.
#[wasm_bindgen(js_name = _testLoseDevices)]
pub fn test_lose_devices() {
    for gpu in gpu::live() {
        gpu.lose_for_test();
    }
}

/// For tests: the page's WebGL2 canvas (`null` before a WebGL2 viewer mounts), to lose and
/// restore its context as a page or browser would.
#[wasm_bindgen(js_name = _testGlCanvas)]
pub fn test_gl_canvas() -> Option<web_sys::HtmlCanvasElement> {
    gpu::live().iter().find_map(|g| g.gl.as_ref().map(|gl| gl.canvas.clone()))
}

fn install_panic_hook() {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let message = info.to_string();
            let handler = PANIC_HANDLER.with(|h| h.try_borrow().ok().and_then(|h| h.clone()));
            match handler {
                Some(handler) => {
                    let _ = handler.call1(&JsValue::NULL, &JsValue::from_str(&message));
                }
                None => dom::show_fatal_everywhere(&message),
            }
            previous(info);
        }));
    });
}
