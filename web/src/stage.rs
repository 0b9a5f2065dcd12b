//! The viewer without its panels: loads models, plays their clips, moves the camera, draws the
//! scene with [`crate::render::SceneRenderer`] and mirrors its state into the page
//! ([`crate::dom`]). No egui: the light widget build (`--no-default-features`) runs it on its own
//! ([`crate::page::view`] with [`crate::page::gesture`]'s input); the full app ([`crate::app::App`])
//! wraps it with egui's panels, overlays and IK handles. The shown model's state is
//! [`crate::model::Model`].

use emath::Rect;
use glam::Vec3;
use kloub_core::Animator;
use kloub_core::animator::Crossfade;
use kloub_core::asset::NodeIndex;
use kloub_core::job::dqs::SkinningMethod;

use crate::backend::backend_name;
use crate::candy::{CandyPanel, Sample};
use crate::control::{Command, Controls, Wake};
use crate::dom::{Dataset, Key};
use crate::load::{self, Inbox, LoadedModel};
use crate::model::{LayerDraft, Model};
use crate::render::{Camera, SceneRenderer, default_skinning_path, display_msaa, scene_format};

mod commands;
mod dataset;

/// What to do at start-up.
#[derive(Clone, Debug)]
pub struct AppConfig {
    /// Model fetched and shown on start (the element's `src`).
    pub model_url: Option<String>,
    /// The command channel the page's handle sends through.
    pub controls: Controls,
    /// Where files read by the page arrive.
    pub inbox: Inbox,
    /// Where the state mirror, events and fatal errors go.
    pub host: crate::dom::Host,
    /// Show the side panel and menus (the element's `controls` attribute).
    pub panels: bool,
    /// The page's key of the shared device: pipelines and model uploads are shared with the
    /// device's other viewers (`None`: nothing is shared).
    pub share: Option<u32>,
}

impl Default for AppConfig {
    fn default() -> Self {
        Self {
            model_url: None,
            controls: Controls::default(),
            inbox: Inbox::default(),
            host: crate::dom::Host::default(),
            panels: true,
            share: None,
        }
    }
}

/// State of the most recent load, as mirrored into `dataset.status`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// A fetch or a dropped file is being read.
    Loading,
    /// The last load succeeded (or nothing was asked for).
    Ready,
    /// The last load failed (the previous model, if any, is still shown).
    Error,
}

impl Status {
    /// The page-contract value.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Loading => "loading",
            Status::Ready => "ready",
            Status::Error => "error",
        }
    }
}

/// The device a viewer draws with (shared with the page's other viewers).
#[derive(Clone, Debug)]
pub struct Graphics {
    /// The adapter (its backend and limits).
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
}

#[cfg(feature = "full")]
impl From<&egui_wgpu::RenderState> for Graphics {
    fn from(render: &egui_wgpu::RenderState) -> Self {
        Self { adapter: render.adapter.clone(), device: render.device.clone(), queue: render.queue.clone() }
    }
}

/// Which overlays are on (the full app draws them over the scene).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Overlays {
    /// Bones between joints, joint dots, the hovered joint's name.
    pub skeleton: bool,
    /// The framing bounds as a box.
    pub bounds: bool,
    /// Triangle edges of the deformed meshes.
    pub wireframe: bool,
    /// Deformed vertex normals as short lines.
    pub normals: bool,
    /// The ragdoll's capsules.
    pub bodies: bool,
}

/// Smoothed CPU time per stage of a frame, in milliseconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct StageTimes {
    /// Clocks, sampling, blending, world matrices and skin palettes of every copy.
    pub animate: f32,
    /// Deforming vertices on the CPU (the CPU path, or morphs too large for the GPU).
    pub cpu_skin: f32,
    /// Writing palettes, uniforms and CPU-deformed vertices to the GPU.
    pub upload: f32,
    /// Recording and submitting the draws.
    pub draw: f32,
}

/// A key of the viewer's shortcuts (the same in both builds; the full app adds its help).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shortcut {
    /// Space: play / pause.
    PlayPause,
    /// ← / →: one frame back or on (1/30 s), pausing.
    Step(i8),
    /// Home: back to the start.
    Start,
    /// ↑ / ↓: the previous / next clip.
    Clip(i8),
    /// Shift + arrows: orbit by [`ORBIT_STEP`] degrees (yaw, pitch steps).
    Orbit(i8, i8),
    /// `+` / `-`: zoom in (1) or out (-1).
    Zoom(i8),
    /// F: frame the model.
    Frame,
    /// B, W, N: the skeleton, wireframe, normals overlays.
    Toggle(OverlayKind),
    /// G: the ground grid.
    Grid,
}

impl Shortcut {
    /// The shortcut of a key, by its name: a DOM `KeyboardEvent.key` (`" "`, `"+"`, `"f"`, `"ArrowLeft"`) or the
    /// same key as egui names it (`"Space"`, `"Plus"`, `"F"`, `"Left"`), with whether Shift was held. One table for both builds.
    pub fn from_key(name: &str, shift: bool) -> Option<Shortcut> {
        Some(match (name, shift) {
            ("ArrowLeft" | "Left", true) => Shortcut::Orbit(1, 0),
            ("ArrowRight" | "Right", true) => Shortcut::Orbit(-1, 0),
            ("ArrowUp" | "Up", true) => Shortcut::Orbit(0, 1),
            ("ArrowDown" | "Down", true) => Shortcut::Orbit(0, -1),
            ("ArrowLeft" | "Left", false) => Shortcut::Step(-1),
            ("ArrowRight" | "Right", false) => Shortcut::Step(1),
            ("ArrowUp" | "Up", false) => Shortcut::Clip(-1),
            ("ArrowDown" | "Down", false) => Shortcut::Clip(1),
            (" " | "Space", false) => Shortcut::PlayPause,
            ("Home", false) => Shortcut::Start,
            // `+` is Shift+= on most layouts.
            ("+" | "Plus" | "=" | "Equals", _) => Shortcut::Zoom(1),
            ("-" | "Minus", false) => Shortcut::Zoom(-1),
            ("f" | "F", false) => Shortcut::Frame,
            ("g" | "G", false) => Shortcut::Grid,
            ("b" | "B", false) => Shortcut::Toggle(OverlayKind::Skeleton),
            ("w" | "W", false) => Shortcut::Toggle(OverlayKind::Wireframe),
            ("n" | "N", false) => Shortcut::Toggle(OverlayKind::Normals),
            _ => return None,
        })
    }
}

/// An overlay a key toggles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OverlayKind {
    /// B.
    Skeleton,
    /// W.
    Wireframe,
    /// N.
    Normals,
}

/// Smoothed frames per second.
#[derive(Debug, Default)]
pub(crate) struct Fps {
    mean_dt: f32,
}

impl Fps {
    pub(crate) fn update(&mut self, dt: f32) {
        if dt.is_finite() && dt > 0.0 {
            self.mean_dt = if self.mean_dt > 0.0 { self.mean_dt * 0.95 + dt * 0.05 } else { dt };
        }
    }

    #[cfg_attr(not(feature = "full"), allow(dead_code, reason = "the panels show it"))]
    pub(crate) fn fps(&self) -> f32 {
        if self.mean_dt > 0.0 { 1.0 / self.mean_dt } else { 0.0 }
    }
}

/// What a received model becomes when it is shown: the delivery's library of several models
/// and its URL (see [`Stage::finish_receive`]).
pub(crate) type Shown = Option<(Option<Library>, Option<String>)>;

/// Files dropped together that hold several models: the side panel lists them.
pub(crate) struct Library {
    pub(crate) files: Vec<load::SourceFile>,
    pub(crate) models: Vec<String>,
    /// `models`' file names as a JSON array (`dataset.models`), made once.
    pub(crate) models_json: String,
    pub(crate) shown: Option<usize>,
}

/// The viewer's state and everything it does without egui.
pub struct Stage {
    pub(crate) gpu: Graphics,
    #[cfg_attr(not(feature = "full"), expect(dead_code, reason = "the panels show it"))]
    pub(crate) backend: &'static str,
    pub(crate) scene: SceneRenderer,
    /// The sculpt the renderer shows: its id and version ([`crate::pose::SculptState`]).
    #[cfg(feature = "full")]
    sculpt_shown: Option<(u64, u64)>,
    pub(crate) camera: Camera,
    pub(crate) model: Option<Model>,
    /// Transition settings of the clip list (duration 0: cut).
    pub(crate) transition: Crossfade,
    pub(crate) controls: Controls,
    pub(crate) inbox: Inbox,
    pub(crate) pending: usize,
    pub(crate) status: Status,
    pub(crate) last_error: String,
    /// The last error until the user dismisses it (the full app's error window).
    pub(crate) error_window: Option<String>,
    /// Drawing straight into the canvas ([`Stage::set_direct`]): the scene is not drawn into a
    /// texture of its own for egui to show, the page draws it under egui's output.
    pub(crate) direct: bool,
    /// In direct mode: the scene prepared this frame, to be drawn into this rectangle of the
    /// canvas (`[x, y, width, height]` in pixels) by [`Stage::draw_scene`].
    pub(crate) scene_rect: Option<[u32; 4]>,
    /// A screenshot asked for in direct mode: the next frame also renders the offscreen target.
    pub(crate) screenshot_wanted: bool,
    pub(crate) dataset: Dataset,
    pub(crate) frames: u64,
    pub(crate) fps: Fps,
    /// The skinning method every model is shown with.
    pub(crate) skinning: SkinningMethod,
    /// Smoothed CPU time per stage.
    pub(crate) stages: StageTimes,
    /// Whether the side panel and menus show (the full app).
    pub(crate) panels: bool,
    /// Overlays drawn over the model (by the full app).
    pub(crate) overlays: Overlays,
    /// Where the 3D view was laid out last frame (points).
    pub(crate) view_rect: Rect,
    /// Large deliveries waiting one frame to be imported (the bar says "Parsing…").
    pub(crate) parsing: Vec<load::Delivery>,
    /// Deliveries that wait for the codecs module (a Draco file or a zip in a widget build).
    awaiting_codecs: Vec<load::Delivery>,
    /// Imported models waiting for the browser to decode their images ([`crate::decode`]),
    /// shown in order, with what [`Stage::finish_receive`] is to make of each.
    pub(crate) decoding: Vec<(LoadedModel, Shown)>,
    /// A screenshot being read back from the GPU.
    pub(crate) screenshot: Option<crate::render::readback::PendingReadback>,
    /// The last screenshot, PNG-encoded (kept for tests; downloaded in the browser).
    pub(crate) last_screenshot: Option<Vec<u8>>,
    /// Files dropped together holding several models, and which one is shown.
    pub(crate) library: Option<Library>,
    /// The Samples menu's library (from the page: `kloub serve`'s `/api/assets`).
    pub(crate) samples: Vec<crate::samples::SampleEntry>,
    /// The URL the shown model was fetched from (`None`: dropped files or a built-in sample).
    pub(crate) shown_url: Option<String>,
    /// The page says files are dragged over the viewer.
    pub(crate) drop_hint: bool,
    /// A model was installed and its first frame has not been reported (`load` event).
    pub(crate) announce_load: bool,
    /// Whether the main clock ran at the last report (`play`/`pause` events).
    pub(crate) reported_playing: bool,
    /// The last `progress` event's value (0–1) for the model being loaded; negative: none yet.
    pub(crate) reported_progress: f64,
    /// `data-exposure`, written when the exposure changes (not formatted every frame).
    pub(crate) exposure_text: String,
    /// `data-shadow`, written when the shadow changes.
    pub(crate) shadow_text: String,
    /// A photograph chosen to light with ([`crate::photos`]) whose file is still on its way:
    /// the light stays as it was (and `data-environment` says so) until it is in.
    pub(crate) environment_wanted: Option<crate::render::environment::EnvironmentName>,
}

/// `data-shadow`'s text: `intensity,softness`.
pub(crate) fn shadow_name(intensity: f32, softness: f32) -> String {
    format!("{intensity},{softness}")
}

/// `data-exposure`'s text for `exposure`: the shortest decimal that reads back the same.
pub(crate) fn exposure_name(exposure: f32) -> String {
    format!("{exposure}")
}

/// Deliveries at least this large get a "Parsing…" frame before their import.
const PARSE_NOTICE_BYTES: usize = 4 << 20;

/// Degrees one Shift+arrow press orbits the camera.
pub(crate) const ORBIT_STEP: f32 = 15.0;
/// Distance factor of one `-` press (`+` divides by it).
pub(crate) const ZOOM_STEP: f32 = 1.25;

/// Steps per second of the ←/→ frame step.
pub(crate) const FRAME_RATE: f32 = 30.0;

/// `data-overlays`: the overlays that are on, comma-separated.
pub(crate) fn overlay_names(o: Overlays) -> String {
    let names = [
        (o.skeleton, "skeleton"),
        (o.bounds, "bounds"),
        (o.wireframe, "wireframe"),
        (o.normals, "normals"),
        (o.bodies, "bodies"),
    ];
    names.iter().filter(|(on, _)| *on).map(|(_, n)| *n).collect::<Vec<_>>().join(",")
}

/// Exponential smoothing of a per-frame figure (a first value is taken as is).
pub(crate) fn smooth(mean: f32, value: f32) -> f32 {
    if !value.is_finite() {
        mean
    } else if mean > 0.0 {
        mean * 0.9 + value * 0.1
    } else {
        value
    }
}

/// The largest frame step the clock takes (a background tab resumes without a jump).
pub(crate) const MAX_DT: f32 = 0.25;

/// Crossfade duration of a click in the clip list until the user changes it, in seconds.
pub const DEFAULT_CROSSFADE: f32 = 0.3;

impl Stage {
    /// A viewer drawing with `gpu`, woken by `wake`; starts fetching `config.model_url`.
    pub fn new(gpu: Graphics, config: AppConfig, wake: Wake) -> Self {
        let backend = backend_name(gpu.adapter.get_info().backend);
        log::info!("kloub: rendering with {backend} ({:?})", gpu.adapter.get_info().name);
        let mut scene = new_scene(&gpu, config.share);
        scene.set_ibl_supported(crate::render::environment::supports_ibl(&gpu.adapter));
        if config.model_url.is_some() {
            // Compiled while the model downloads or imports (shared by the page's viewers).
            scene.warm_pipelines(&gpu.device);
        }
        let mut stage = Self {
            gpu,
            backend,
            scene,
            #[cfg(feature = "full")]
            sculpt_shown: None,
            camera: Camera::default(),
            model: None,
            transition: Crossfade { duration: DEFAULT_CROSSFADE, ..Crossfade::default() },
            controls: config.controls.clone(),
            inbox: config.inbox.clone(),
            pending: 0,
            status: Status::Ready,
            last_error: String::new(),
            error_window: None,
            dataset: Dataset::new(config.host.clone()),
            frames: 0,
            fps: Fps::default(),
            skinning: SkinningMethod::default(),
            stages: StageTimes::default(),
            panels: config.panels,
            library: None,
            samples: Vec::new(),
            shown_url: None,
            overlays: Overlays::default(),
            screenshot: None,
            last_screenshot: None,
            direct: false,
            scene_rect: None,
            screenshot_wanted: false,
            view_rect: Rect::ZERO,
            parsing: Vec::new(),
            awaiting_codecs: Vec::new(),
            decoding: Vec::new(),
            drop_hint: false,
            announce_load: false,
            reported_playing: false,
            reported_progress: -1.0,
            exposure_text: exposure_name(1.0),
            shadow_text: shadow_name(crate::render::uniforms::DEFAULT_SHADOW_INTENSITY, 1.0),
            environment_wanted: None,
        };
        stage.controls.set_repaint(wake.clone());
        stage.controls.set_supports_compute(stage.scene.supports_compute());
        stage.dataset.set(Key::Backend, backend);
        if let Some(url) = config.model_url {
            stage.pending += 1;
            stage.status = Status::Loading;
            load::fetch_into(url, stage.inbox.clone(), wake);
        }
        stage.sync_dataset();
        stage
    }

    /// Moves the viewer to a new device (the old one was lost): the renderer is rebuilt with
    /// the same settings and the shown model uploaded again; everything else (model, clocks,
    /// camera, IK goals, panels) is kept.
    ///
    /// # Errors
    /// When the model cannot be uploaded to the new device (it is then dropped, as a failed
    /// load would be).
    pub fn replace_gpu(&mut self, gpu: Graphics, share: Option<u32>) -> Result<(), String> {
        let mut scene = new_scene(&gpu, share);
        scene.set_grid(self.scene.grid());
        scene.set_heatmap(self.scene.heatmap());
        scene.set_look(self.scene.look());
        scene.set_environment_image(self.scene.environment_image());
        scene.set_ibl_supported(crate::render::environment::supports_ibl(&gpu.adapter));
        scene.set_ground(self.scene.ground());
        // Compute skinning is only there on WebGPU; another backend falls back to its default.
        if let Some(path) = self.scene.chosen_skinning_path()
            && scene.set_skinning_path(path).is_err()
        {
            log::warn!("kloub: the new device has no compute shaders: skinning where its adapter does by default");
        }
        self.scene = scene;
        self.gpu = gpu;
        // A sculpt under way goes to the new renderer with the next frame.
        #[cfg(feature = "full")]
        {
            self.sculpt_shown = None;
        }
        // The page wrote `lost` into the status meanwhile: written again with the next frame.
        self.dataset.forget(Key::Status);
        self.scene_rect = None;
        self.screenshot = None;
        self.controls.set_supports_compute(self.scene.supports_compute());
        let result = match &self.model {
            Some(model) => self
                .scene
                .set_shared_asset(&self.gpu.device, &self.gpu.queue, &model.asset)
                .map_err(|e| format!("{}: {e}", model.name)),
            None => Ok(()),
        };
        if let Err(message) = &result {
            self.model = None;
            self.scene.clear_asset();
            self.fail(message.clone());
        }
        result
    }

    /// Moves every clock by `seconds` at once: the time the viewer was out of view or its
    /// page hidden, so that it comes back where it would be had it kept playing. (A ragdoll
    /// does not move while unseen.)
    pub fn catch_up(&mut self, seconds: f32) {
        if !(seconds.is_finite() && seconds > 0.0) {
            return;
        }
        if let Some(model) = &mut self.model
            && model.is_animating()
        {
            let events = model.advance(seconds);
            if events.looped > 0 {
                self.dataset.host().emit("loop", &events.looped.to_string());
            }
            if events.finished {
                self.dataset.host().emit("finished", "");
            }
        }
    }

    /// Whether the shown model moves by itself (clips playing, a crossfade, a falling ragdoll).
    pub fn animating(&self) -> bool {
        self.model.as_ref().is_some_and(|m| m.is_animating() || m.ragdoll_moving())
    }

    /// Whether the side panel and menus show (the viewer then draws through egui's panel
    /// layout; without them the page may lower the resolution to hold the frame rate).
    pub fn panels(&self) -> bool {
        self.panels
    }

    /// Draw the scene straight into the canvas (the page's runtime) rather than into a texture
    /// that egui shows (eframe natively): the page calls [`App::draw_scene`] after each frame,
    /// before painting egui's output over it.
    pub fn set_direct(&mut self, direct: bool) {
        self.direct = direct;
        self.scene_rect = None;
    }

    /// In direct mode: records the scene prepared by this frame into `encoder`, drawn into
    /// `view` (a canvas surface of `size` pixels, in the renderer's colour format) within the
    /// viewport's rectangle. Returns whether it drew (the surface is then cleared and egui's
    /// output goes over it; otherwise egui clears it).
    /// `shared`: the MSAA and depth attachments of a surface several viewers draw into one after
    /// another (see [`SceneRenderer::draw_into`]).
    pub fn draw_scene(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        size: [u32; 2],
        shared: Option<&mut Option<crate::render::scene::Attachments>>,
    ) -> bool {
        let Some(rect) = self.scene_rect.take() else { return false };
        self.scene.draw_into(&self.gpu.device, encoder, view, size, rect, shared);
        true
    }

    /// Whether the view's background is transparent (the page shows through the canvas).
    pub fn transparent(&self) -> bool {
        !self.scene.look().background.is_drawn()
    }

    /// The colour format [`App::draw_scene`] draws into (see `render::scene_format`).
    pub fn scene_format(&self) -> wgpu::TextureFormat {
        self.scene.format()
    }

    /// The values last mirrored into the element's `data-*` attributes (kept natively too, for tests).
    pub fn dataset(&self) -> &Dataset {
        &self.dataset
    }

    /// The message of the open error window, if any.
    pub fn error_message(&self) -> Option<&str> {
        self.error_window.as_deref()
    }

    /// The shown model, if any.
    pub fn model(&self) -> Option<&Model> {
        self.model.as_ref()
    }

    /// The command channel (what the page's JS handle sends through).
    pub fn controls(&self) -> &Controls {
        &self.controls
    }

    /// The crossfade settings a click in the clip list uses.
    pub fn transition(&self) -> Crossfade {
        self.transition
    }

    /// Imports and installs every delivery that arrived since the last frame (a photograph that
    /// came lights the model in [`Stage::tick`], after the page's commands).
    pub(crate) fn receive(&mut self) {
        // A large delivery is held for one frame so the "Parsing…" bar is painted before the
        // import blocks the frame; small ones are imported at once.
        // Models whose images the browser has decoded since, in the order they came.
        let max_size = self.gpu.device.limits().max_texture_dimension_2d;
        while self.decoding.first().is_some_and(|(m, _)| crate::decode::ready(&m.asset, max_size, None, None)) {
            let (model, shown) = self.decoding.remove(0);
            self.pending = self.pending.saturating_sub(1);
            let result = self.install(model, None);
            self.finish_receive(result, shown);
        }
        // Deliveries that waited for the codecs module come first once it is in (or has failed), so
        // that models are shown in the order they were asked for.
        let mut arrived = if crate::codecs::loading() { Vec::new() } else { std::mem::take(&mut self.awaiting_codecs) };
        arrived.append(&mut self.parsing);
        for delivery in self.inbox.take() {
            // A download shared with other viewers counts too (its files come as `shared`).
            let bytes: usize = delivery.contents().iter().map(|f| f.bytes.len()).sum();
            if bytes >= PARSE_NOTICE_BYTES {
                self.parsing.push(delivery);
            } else {
                arrived.push(delivery);
            }
        }
        if !self.parsing.is_empty() {
            self.status = Status::Loading;
            self.controls.wake();
        }
        for delivery in arrived {
            // Behind a delivery that waits for the codecs module, every later one waits too (still pending).
            if !self.awaiting_codecs.is_empty() {
                self.awaiting_codecs.push(delivery);
                continue;
            }
            self.pending = self.pending.saturating_sub(1);
            // A download shared with the page's other viewers: the model another viewer already
            // decoded from it, else its files (the first to get here decodes them for all).
            let files = match (delivery.files, delivery.shared, &delivery.url) {
                (Ok(_), Some(shared), Some(url)) => {
                    if let Some(model) = crate::shared::cached(url) {
                        self.show_when_decoded(model, Some((None, Some(url.clone()))));
                        continue;
                    }
                    if shared.is_empty() {
                        // It was shown when this viewer asked, and no more: download it again.
                        if let Some(wake) = self.controls.waker() {
                            self.pending += 1;
                            load::fetch_into(url.clone(), self.inbox.clone(), wake);
                        }
                        continue;
                    }
                    Ok(std::rc::Rc::unwrap_or_clone(shared))
                }
                (files, _, _) => files,
            };
            let result = match files {
                // A sidecar alone edits the shown model's joint settings.
                Ok(files) if !files.is_empty() && files.iter().all(|f| load::is_sidecar_name(&f.name)) => {
                    self.apply_sidecar(&files)
                }
                Ok(files) => {
                    // A Draco file or a zip in a widget build: the codecs module first.
                    match crate::codecs::ready_for(&files, self.controls.waker()) {
                        Ok(true) => {}
                        Ok(false) => {
                            self.pending += 1;
                            self.awaiting_codecs.push(load::Delivery { files: Ok(files), shared: None, ..delivery });
                            continue;
                        }
                        Err(message) => {
                            self.fail(format!("{}: {message}", delivery.origin));
                            continue;
                        }
                    }
                    // Zip archives open into their files first (a bomb is refused before it is inflated).
                    let expanded = load::expand_archives(files);
                    let (files, notes) = match expanded {
                        Ok(expanded) => expanded,
                        Err(message) => {
                            self.fail(message);
                            continue;
                        }
                    };
                    let models = load::model_names(&files);
                    let url = delivery.url.as_deref();
                    let imported = load::import_model(&files, None).map(|mut m| {
                        m.warnings.splice(0..0, notes);
                        // One model from a URL: the page's other viewers of that URL take this one
                        // (and wait for the same decoded images).
                        if let Some(url) = url
                            && models.len() <= 1
                        {
                            crate::shared::remember(url, &m);
                        }
                        m
                    });
                    let library = (models.len() > 1).then(|| {
                        let names: Vec<&str> = models.iter().map(|m| load::base_name(m)).collect();
                        let models_json = serde_json::Value::from(names).to_string();
                        Library { files, models, models_json, shown: Some(0) }
                    });
                    match imported {
                        Ok(model) => self.show_when_decoded(model, Some((library, delivery.url))),
                        Err(message) => self.finish_receive(Err(message), None),
                    }
                    continue;
                }
                Err(message) => Err(message),
            };
            self.finish_receive(result, None);
        }
        if self.pending > 0 || !self.parsing.is_empty() {
            self.status = Status::Loading;
        }
    }

    /// Shows an imported model now, or once the browser has decoded its images (and those of
    /// the models received before it that wait too): the previous model stays until then.
    fn show_when_decoded(&mut self, model: LoadedModel, shown: Shown) {
        let max_size = self.gpu.device.limits().max_texture_dimension_2d;
        let url = shown.as_ref().and_then(|(_, url)| url.as_deref());
        if crate::decode::ready(&model.asset, max_size, self.controls.waker(), url) && self.decoding.is_empty() {
            let result = self.install(model, None);
            self.finish_receive(result, shown);
        } else {
            self.pending += 1;
            self.decoding.push((model, shown));
        }
    }

    /// The end of one delivery: on success `shown` (the delivery's library of several models,
    /// and its URL; `None` for a sidecar) becomes the shown one and the status is ready; on
    /// failure the error is shown (the model stays).
    pub(crate) fn finish_receive(&mut self, result: Result<(), String>, shown: Shown) {
        match result {
            Ok(()) => {
                if let Some((library, url)) = shown {
                    self.library = library;
                    self.shown_url = url;
                }
                self.status = Status::Ready;
                self.last_error.clear();
                self.error_window = None;
            }
            Err(message) => self.fail(message),
        }
    }

    /// Makes `loaded` the shown model, playing its first clip (a sample starts posed by its
    /// sliders instead); on error nothing changes.
    pub(crate) fn install(&mut self, mut loaded: LoadedModel, candy: Option<CandyPanel>) -> Result<(), String> {
        // Images the browser could not decode (drawn white).
        loaded.warnings.extend(crate::decode::warnings(&loaded.asset));
        let prefs = self.controls.prefs();
        let named = prefs.clip.as_deref().and_then(|name| {
            let found = loaded.asset.clips.iter().position(|c| c.name.as_deref() == Some(name));
            if found.is_none() {
                log::warn!("kloub: {}: no clip named {name:?}; playing the first", loaded.name);
            }
            found
        });
        let clip = if loaded.asset.clips.is_empty() || candy.is_some() { None } else { Some(named.unwrap_or(0)) };
        let mut model = Model::new(loaded, clip)?;
        // Set again by the caller when the model came from a URL.
        self.shown_url = None;
        model.instance.set_skinning(&model.asset, self.skinning);
        if candy.is_none() {
            model.set_speed(prefs.speed);
            model.set_loop_mode(prefs.loop_mode);
            if let Some((layer_clip, root, weight)) = &prefs.layer {
                let clip = model.clip_names.iter().position(|c| c == layer_clip);
                let node = model.asset.nodes.iter().position(|n| n.name.as_deref() == Some(root.as_str()));
                match (clip, node.and_then(|n| NodeIndex::try_from(n).ok())) {
                    (Some(clip), Some(root)) => {
                        model.layer = LayerDraft { enabled: true, clip, root, weight: *weight, ..model.layer };
                        model.sync_layer()?;
                    }
                    _ => log::warn!("kloub: {}: no layer clip {layer_clip:?} or root {root:?}", model.name),
                }
            }
            if !prefs.autoplay {
                model.set_playing(false);
            }
        }
        model.candy = candy;
        let copies = self.model.as_ref().map_or(1, Model::copy_count);
        let bounds = model.animated_bounds(clip);
        model.bounds = bounds;
        if let Some((min, max)) = bounds {
            let extent = max - min;
            model.copy_spacing = (extent.x.max(extent.z) * 1.25).max(1e-3);
        }
        model.evaluate().map_err(|e| format!("{}: {e}", model.name))?;
        model.set_copies(copies);
        self.scene
            .set_shared_asset(&self.gpu.device, &self.gpu.queue, &model.asset)
            .map_err(|e| format!("{}: {e}", model.name))?;
        if let Some((min, max)) = model.grid_bounds() {
            self.camera.frame_to_fit_aspect(min, max, view_aspect(self.view_rect));
        }
        log::info!(
            "kloub: showing {} ({} clips, {} warnings)",
            model.name,
            model.clip_names.len(),
            model.warnings.len()
        );
        let nodes = model.asset.nodes.iter().map(|n| n.name.clone()).collect();
        let morphs = model
            .asset
            .nodes
            .iter()
            .map(|n| {
                let mesh = n.mesh.and_then(|m| model.asset.meshes.get(m as usize));
                let names = mesh.map_or(&[][..], |m| m.target_names.as_slice());
                (0..n.weights.len()).map(|t| names.get(t).cloned().unwrap_or_else(|| format!("target {t}"))).collect()
            })
            .collect();
        self.controls.publish(model.clip_names.clone(), nodes, morphs);
        self.reported_playing = model.is_playing();
        self.model = Some(model);
        // The model shown before may have been the last of its kind on the page: its shared GPU
        // part goes now.
        crate::render::scene::release_unused_uploads(None);
        self.announce_load = true;
        Ok(())
    }

    /// Applies dropped `<model>.kloub.json` sidecars to the shown model (and its IK goal).
    fn apply_sidecar(&mut self, files: &[load::SourceFile]) -> Result<(), String> {
        let Some(model) = &mut self.model else {
            return Err("drop the model first, then its .kloub.json (or both together)".into());
        };
        // Example poses change the model's morph targets: it is shown again with the sidecar,
        // as if both had been dropped together.
        if let Some(file) = files.last() {
            let text = std::str::from_utf8(&file.bytes).map_err(|_| format!("{}: not UTF-8 text", file.name))?;
            let examples = kloub_core::examples::Examples::from_json(&model.base_asset, text)
                .map_err(|e| format!("{}: {e}", file.name))?;
            if !examples.poses.is_empty() || model.examples.is_some() {
                let loaded = model.reloaded(text.to_owned());
                return self.install(loaded, None);
            }
        }
        #[cfg(feature = "full")]
        let mut obstacles = None;
        for file in files {
            let text = std::str::from_utf8(&file.bytes).map_err(|_| format!("{}: not UTF-8 text", file.name))?;
            #[cfg(feature = "full")]
            {
                let list = crate::model::obstacles_in_sidecar(text).map_err(|e| format!("{}: {e}", file.name))?;
                if !list.is_empty() {
                    obstacles = Some(list);
                }
            }
            model.joint_settings.apply_json(&model.asset, text).map_err(|e| format!("{}: {e}", file.name))?;
        }
        // The obstacles once every file read well; a running ragdoll takes them at once.
        #[cfg(feature = "full")]
        if let Some(list) = obstacles {
            model.set_obstacles(list)?;
        }
        for ik in &mut model.ik {
            ik.use_settings(&model.joint_settings);
        }
        Ok(())
    }

    /// Shows the model again with `examples` (the sculpt's "Done", an example deleted): its
    /// morph targets change, so it is installed again as if its sidecar had been dropped,
    /// keeping the camera, the clip and its time, the held rotations and morph weights, the IK
    /// goals, the selected joint, pose mode and the candy wrapper's panel (a ragdoll, a layer
    /// or blend being edited start again from the prefs). On error the model stays as it was.
    #[cfg(feature = "full")]
    pub(crate) fn set_examples(&mut self, examples: kloub_core::examples::Examples) -> Result<(), String> {
        let Some(model) = &self.model else { return Ok(()) };
        let loaded = model.reloaded(model.sidecar_json_with(Some(&examples)));
        let camera = self.camera;
        let main = model.animator.main();
        let (clip, time, playing) = (main.clip, main.time, model.is_playing());
        let (overrides, selected) = (model.rotation_overrides.clone(), model.selected_joint);
        let (pose_mode, resume, within) = (model.pose_mode, model.resume_playing, model.pose_within_limits);
        let (ik, ik_selected, morphs) = (model.ik.clone(), model.ik_selected, model.morph_overrides.clone());
        let shown_url = self.shown_url.clone();
        let candy = self.model.as_mut().and_then(|m| m.candy.take());
        if let Err(e) = self.install(loaded, candy.clone()) {
            // The model stays as it was, its candy panel too.
            if let Some(model) = &mut self.model {
                model.candy = candy;
            }
            return Err(e);
        }
        self.camera = camera;
        self.shown_url = shown_url;
        let transition = Crossfade { duration: 0.0, ..self.transition };
        if let Some(model) = &mut self.model {
            if model.animator.main().clip != clip {
                model.play_clip(clip, transition)?;
            }
            model.seek(time);
            model.set_playing(playing);
            model.rotation_overrides = overrides;
            model.selected_joint = selected;
            model.pose_mode = pose_mode;
            model.resume_playing = resume;
            model.pose_within_limits = within;
            model.ik = ik;
            model.ik_selected = ik_selected;
            // Held morph weights, where the example targets left the slots where they were.
            if model.morph_overrides.len() == morphs.len() {
                model.morph_overrides = morphs;
            }
            model.evaluate()?;
        }
        Ok(())
    }

    /// Lights with the photograph [`Stage::environment_wanted`] names once it is in; reports
    /// why not if its fetch failed (the light before it stays).
    fn receive_environment(&mut self) {
        use crate::render::environment::Builtin;
        let Some(name) = self.environment_wanted else {
            return;
        };
        let Builtin::Photo(photo) = name.builtin() else {
            return;
        };
        match crate::photos::poll(photo, self.controls.waker()) {
            Ok(false) => {}
            Ok(true) => {
                self.environment_wanted = None;
                let environment = crate::render::uniforms::EnvironmentChoice::Named(name);
                self.scene.set_look(crate::render::uniforms::Look { environment, ..self.scene.look() });
                self.controls.wake();
            }
            Err(message) => {
                self.environment_wanted = None;
                self.environment_failed(name, &message);
            }
        }
    }

    /// A photograph that could not be had: an `error` event (the model, its status and the
    /// light stay as they were).
    pub(crate) fn environment_failed(&mut self, name: crate::render::environment::EnvironmentName, message: &str) {
        let message = format!("environment-image: {}: {message}", name.name());
        log::warn!("kloub: {message}");
        self.dataset.host().emit("error", &message);
    }

    pub(crate) fn fail(&mut self, message: String) {
        log::warn!("kloub: {message}");
        self.dataset.host().emit("error", &message);
        self.status = Status::Error;
        self.last_error.clone_from(&message);
        self.error_window = Some(message);
    }

    /// Applies the commands the page queued since the last frame.
    pub(crate) fn apply_commands(&mut self) {
        for command in self.controls.take() {
            if let Err(message) = self.apply(command) {
                self.fail(message);
            }
        }
    }

    /// Evaluates the pose for this frame.
    pub(crate) fn evaluate(&mut self) {
        let Some(model) = &mut self.model else { return };
        let started = web_time::Instant::now();
        let result = model.evaluate();
        // A sculpt's shape goes to the renderer when a dab changed it.
        #[cfg(feature = "full")]
        {
            let shown = model.sculpt.as_ref().map(|s| (s.id, s.version));
            if shown != self.sculpt_shown {
                self.scene.set_sculpt(model.sculpt.as_ref().map(|s| s.mesh(&model.asset)));
                self.sculpt_shown = shown;
            }
        }
        self.stages.animate = smooth(self.stages.animate, started.elapsed().as_secs_f32() * 1000.0);
        self.controls.publish_rotations(model.instance.pose().locals.iter().map(|l| l.rotation.to_array()));
        if let Err(e) = result {
            // Fall back to the rest pose so the error is reported once, not every frame.
            let message = format!("{}: cannot play {:?}: {e}", model.name, model.clip_name(model.animator.main().clip));
            model.animator = Animator::new(&model.asset);
            model.layer.enabled = false;
            self.fail(message);
        }
    }

    /// Starts saving the view (the 3D viewport, without the panels' overlays) as a PNG: the
    /// GPU copy is read back over the next frames, then offered as `<model>.png`.
    pub(crate) fn screenshot(&mut self) {
        if self.direct {
            // Drawn straight into the canvas, the scene has no texture of its own: the next
            // frame renders one.
            self.screenshot_wanted = true;
            return;
        }
        if let Some(texture) = self.scene.target_texture() {
            self.screenshot =
                Some(crate::render::readback::PendingReadback::start(&self.gpu.device, &self.gpu.queue, texture, 4));
        }
    }

    /// Finishes a screenshot whose pixels arrived.
    pub(crate) fn finish_screenshot(&mut self) {
        let Some(pending) = &self.screenshot else { return };
        let Some(result) = pending.poll(&self.gpu.device) else {
            self.controls.wake();
            return;
        };
        let (width, height) = pending.size();
        self.screenshot = None;
        let stem = self.model.as_ref().map_or("kloub", |m| m.name.rsplit_once('.').map_or(m.name.as_str(), |s| s.0));
        // The widget builds have the browser encode the PNG (no encoder in their download).
        #[cfg(all(target_arch = "wasm32", not(feature = "full")))]
        if let Err(message) = result.and_then(|mut pixels| {
            crate::render::readback::unpremultiply(&mut pixels);
            crate::dom::download_rgba(&format!("{stem}.png"), &pixels, width, height)
        }) {
            self.fail(message);
        }
        #[cfg(not(all(target_arch = "wasm32", not(feature = "full"))))]
        let png = result.and_then(|pixels| {
            let mut pixels = pixels;
            crate::render::readback::unpremultiply(&mut pixels);
            use image::ImageEncoder;
            let image = image::RgbaImage::from_raw(width, height, pixels).ok_or("screenshot: size mismatch")?;
            // The PNG encoder itself, not `write_to`: that one would link every encoder `image` has.
            let mut out = Vec::new();
            image::codecs::png::PngEncoder::new(&mut out)
                .write_image(image.as_raw(), width, height, image::ExtendedColorType::Rgba8)
                .map_err(|e| format!("screenshot: {e}"))?;
            Ok(out)
        });
        #[cfg(not(all(target_arch = "wasm32", not(feature = "full"))))]
        match png {
            Ok(png) => {
                #[cfg(target_arch = "wasm32")]
                if let Err(message) = crate::dom::download(&format!("{stem}.png"), &png, "image/png") {
                    self.fail(message);
                }
                #[cfg(not(target_arch = "wasm32"))]
                let _ = stem;
                self.last_screenshot = Some(png);
            }
            Err(message) => self.fail(message),
        }
    }

    /// The last screenshot as PNG bytes (natively kept for tests).
    pub fn last_screenshot(&self) -> Option<&[u8]> {
        self.last_screenshot.as_deref()
    }

    /// Frames the camera on the current model's animated bounds.
    pub(crate) fn frame_model(&mut self) {
        let Some(model) = &mut self.model else { return };
        let clip = model.animator.main().clip;
        if let Some((min, max)) = model.animated_bounds(clip) {
            self.camera.frame_to_fit_aspect(min, max, view_aspect(self.view_rect));
        }
        // Restore the animated pose the bounds sampling overwrote.
        self.evaluate();
    }

    /// Where the 3D view is laid out this frame (points from the canvas's top-left corner; also
    /// `data-viewport`): what framing fits a model to.
    pub(crate) fn set_view_rect(&mut self, rect: Rect) {
        self.view_rect = rect;
        let viewport = format!("{},{},{},{}", rect.min.x, rect.min.y, rect.width(), rect.height());
        self.dataset.set(Key::Viewport, &viewport);
    }

    /// The clocks of one painted frame: `stable_dt` moves the model (clamped to [`MAX_DT`]),
    /// `unstable_dt` is this frame's real duration (the frame rate); the page's commands apply first.
    pub(crate) fn tick(&mut self, stable_dt: f32, unstable_dt: f32) {
        self.fps.update(unstable_dt);
        self.apply_commands();
        // After the commands: a photograph that came in the meantime lights the model only if
        // it is still wanted (an image chosen since drops it: the commands are the page's order,
        // whatever the network's).
        self.receive_environment();
        if let Some(model) = &mut self.model {
            #[cfg(feature = "full")]
            model.advance_ragdoll(stable_dt.clamp(0.0, MAX_DT));
            let events = model.advance(stable_dt.clamp(0.0, MAX_DT));
            if events.looped > 0 {
                self.dataset.host().emit("loop", &events.looped.to_string());
            }
            if events.finished {
                self.dataset.host().emit("finished", "");
            }
        }
    }

    /// A shortcut key (when no text field has the keyboard).
    pub(crate) fn shortcut(&mut self, key: Shortcut) {
        let mut commands = Vec::new();
        match key {
            Shortcut::Frame => self.frame_model(),
            Shortcut::Toggle(kind) => {
                let mut overlays = self.overlays;
                match kind {
                    OverlayKind::Skeleton => overlays.skeleton ^= true,
                    OverlayKind::Wireframe => overlays.wireframe ^= true,
                    OverlayKind::Normals => overlays.normals ^= true,
                }
                commands.push(Command::SetOverlays(overlays));
            }
            Shortcut::Grid => commands.push(Command::SetGrid(!self.scene.grid())),
            Shortcut::Orbit(yaw, pitch) => {
                let step = ORBIT_STEP.to_radians();
                self.camera.orbit(f32::from(yaw) * step, f32::from(pitch) * step);
            }
            Shortcut::Zoom(direction) => {
                self.camera.zoom(if direction > 0 { 1.0 / ZOOM_STEP } else { ZOOM_STEP });
            }
            Shortcut::PlayPause | Shortcut::Step(_) | Shortcut::Start | Shortcut::Clip(_) => {
                let Some(model) = &self.model else { return };
                match key {
                    Shortcut::PlayPause => {
                        commands.push(if model.is_playing() { Command::Pause } else { Command::Play });
                    }
                    Shortcut::Step(step) => {
                        let time = model.animator.main().time;
                        commands.push(Command::Pause);
                        commands.push(Command::Seek(((time * FRAME_RATE).round() + f32::from(step)) / FRAME_RATE));
                    }
                    Shortcut::Start => commands.push(Command::Seek(0.0)),
                    _ => {
                        let clips = model.clip_names.len();
                        let clip = model.animator.main().clip;
                        let next = if key == Shortcut::Clip(1) { 1 } else { clips.saturating_sub(1) };
                        if clips > 0 && next > 0 {
                            commands.push(Command::PlayClip(Some(clip.map_or(0, |c| (c + next) % clips))));
                        }
                    }
                }
            }
        }
        for command in commands {
            if let Err(message) = self.apply(command) {
                self.fail(message);
            }
        }
    }

    /// Prepares the shown model's frame for the 3D view laid out at `rect` (points), `ppp`
    /// pixels per point: in direct mode for [`Stage::draw_scene`], otherwise (and for a
    /// screenshot) rendered into the renderer's own texture, whose view is returned. A model
    /// the renderer cannot draw is dropped with an error.
    pub(crate) fn render_view(&mut self, rect: Rect, ppp: f32) -> Option<wgpu::TextureView> {
        let model = self.model.as_mut()?;
        let size = [(rect.width() * ppp).round() as u32, (rect.height() * ppp).round() as u32];
        let gpu = &self.gpu;
        let offsets: Vec<Vec3> = (0..model.copy_count()).map(|c| model.copy_offset(c)).collect();
        let mut instances: Vec<&mut kloub_core::Instance> =
            std::iter::once(&mut model.instance).chain(model.copies.iter_mut().map(|(_, i)| i)).collect();
        let offscreen = !self.direct || self.screenshot_wanted;
        let rendered = if offscreen {
            self.scene
                .render_copies(&gpu.device, &gpu.queue, &model.asset, &mut instances, &offsets, &self.camera, size)
                .map(|view| Some(view.clone()))
        } else {
            Ok(None)
        };
        let rendered = rendered.and_then(|view| {
            if self.direct {
                let aspect = size[0].max(1) as f32 / size[1].max(1) as f32;
                self.scene.prepare_copies(
                    &gpu.device,
                    &gpu.queue,
                    &model.asset,
                    &mut instances,
                    &offsets,
                    &self.camera,
                    aspect,
                )?;
                let at = |v: f32| (v * ppp).round().max(0.0) as u32;
                self.scene_rect = Some([at(rect.min.x), at(rect.min.y), size[0], size[1]]);
            }
            Ok(view)
        });
        drop(instances);
        let times = self.scene.times();
        self.stages.cpu_skin = smooth(self.stages.cpu_skin, times.cpu_skin_ms);
        self.stages.upload = smooth(self.stages.upload, times.upload_ms);
        self.stages.draw = smooth(self.stages.draw, times.draw_ms);
        let view = match rendered {
            Ok(view) => view,
            Err(e) => {
                // Unreachable with an asset the renderer accepted; drop it rather than fail every frame.
                let message = format!("{}: cannot draw: {e}", model.name);
                self.model = None;
                self.scene_rect = None;
                self.scene.clear_asset();
                self.fail(message);
                return None;
            }
        };
        if self.screenshot_wanted {
            self.screenshot_wanted = false;
            if let Some(texture) = self.scene.target_texture() {
                self.screenshot = Some(crate::render::readback::PendingReadback::start(
                    &self.gpu.device,
                    &self.gpu.queue,
                    texture,
                    4,
                ));
            }
        }
        view.filter(|_| !self.direct)
    }

    /// Whether a frame is wanted soon: the model moves, a load or screenshot is under way.
    #[cfg_attr(feature = "full", expect(dead_code, reason = "the widget build's frame loop"))]
    pub(crate) fn busy(&self) -> bool {
        self.animating() || self.status == Status::Loading || self.screenshot.is_some()
    }
}

/// Width / height of the 3D view's rectangle (1 before it has a size): what framing fits the model to.
pub(crate) fn view_aspect(rect: Rect) -> f32 {
    if rect.width() > 0.0 && rect.height() > 0.0 { rect.width() / rect.height() } else { 1.0 }
}

/// A scene renderer for the view on `gpu`: its multisampling, the colour format its canvas
/// is drawn in and its default skinning path (all rebuilt the same way when the device is
/// replaced).
fn new_scene(gpu: &Graphics, share: Option<u32>) -> SceneRenderer {
    let mut scene = SceneRenderer::shared(
        &gpu.device,
        &gpu.queue,
        display_msaa(&gpu.adapter),
        scene_format(gpu.adapter.get_info().backend),
        share,
    );
    scene.set_default_skinning_path(default_skinning_path(&gpu.adapter));
    scene
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_names() {
        assert_eq!(Status::Loading.as_str(), "loading");
        assert_eq!(Status::Ready.as_str(), "ready");
        assert_eq!(Status::Error.as_str(), "error");
    }

    #[test]
    fn fps_smooths() {
        let mut fps = Fps::default();
        assert_eq!(fps.fps(), 0.0);
        fps.update(0.02);
        assert!((fps.fps() - 50.0).abs() < 1e-3);
        fps.update(f32::NAN);
        fps.update(0.0);
        assert!((fps.fps() - 50.0).abs() < 1e-3);
    }
}
