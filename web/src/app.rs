//! The viewer app: loads models, plays their clips, draws them with
//! [`crate::render::SceneRenderer`] (in the browser straight into the canvas, see
//! [`App::set_direct`]; natively into a texture shown in the central panel), and mirrors its
//! state into the page ([`crate::dom`]). The shown model's state is [`crate::model::Model`].

use egui::{Color32, Pos2, Rect, Sense};
use glam::Vec3;
use kloub_core::animator::Crossfade;
use kloub_core::asset::NodeIndex;
use kloub_core::{Animator, Instance};

use kloub_core::job::dqs::SkinningMethod;

use crate::backend::backend_name;
use crate::candy::{CandyPanel, Sample};
use crate::control::{Command, Controls};
use crate::dom::{Dataset, Key};
use crate::ik::IkState;
use crate::load::{self, Inbox, LoadedModel};
use crate::model::{LayerDraft, Model};
use crate::overlay::{self, Overlays, Projection, nearest_within};
use crate::render::{Camera, SceneRenderer, display_msaa, scene_format};
use crate::ui;

mod commands;
mod dataset;
mod viewport;

use viewport::IkHandle;

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

/// The egui texture showing the scene renderer's output, and the renderer's
/// [`SceneRenderer::target_version`] it was registered for.
struct ViewportTexture {
    id: egui::TextureId,
    version: u64,
}

/// Smoothed frames per second.
#[derive(Debug, Default)]
struct Fps {
    mean_dt: f32,
}

impl Fps {
    fn update(&mut self, dt: f32) {
        if dt.is_finite() && dt > 0.0 {
            self.mean_dt = if self.mean_dt > 0.0 { self.mean_dt * 0.95 + dt * 0.05 } else { dt };
        }
    }

    fn fps(&self) -> f32 {
        if self.mean_dt > 0.0 { 1.0 / self.mean_dt } else { 0.0 }
    }
}

/// Files dropped together that hold several models: the side panel lists them.
struct Library {
    files: Vec<load::SourceFile>,
    models: Vec<String>,
    /// `models`' file names as a JSON array (`dataset.models`), made once.
    models_json: String,
    shown: Option<usize>,
}

/// The eframe app.
pub struct App {
    gpu: egui_wgpu::RenderState,
    backend: &'static str,
    scene: SceneRenderer,
    camera: Camera,
    model: Option<Model>,
    /// Transition settings of the clip list (duration 0: cut).
    transition: Crossfade,
    /// Panel state that outlives a model (filter text, scrubbing).
    panel: ui::PanelMemory,
    controls: Controls,
    inbox: Inbox,
    pending: usize,
    status: Status,
    last_error: String,
    error_window: Option<String>,
    viewport: Option<ViewportTexture>,
    /// Drawing straight into the canvas ([`App::set_direct`]): the scene is not drawn into a
    /// texture of its own for egui to show, the page draws it under egui's output.
    direct: bool,
    /// In direct mode: the scene prepared this frame, to be drawn into this rectangle of the
    /// canvas (`[x, y, width, height]` in pixels) by [`App::draw_scene`].
    scene_rect: Option<[u32; 4]>,
    /// A screenshot asked for in direct mode: the next frame also renders the offscreen target.
    screenshot_wanted: bool,
    dataset: Dataset,
    frames: u64,
    fps: Fps,
    /// The skinning method every model is shown with.
    skinning: SkinningMethod,
    /// Smoothed CPU time per stage.
    stages: ui::StageTimes,
    /// The IK goal whose target is being dragged in the viewport.
    ik_drag: Option<IkHandle>,
    /// Whether the side panel and menus show.
    panels: bool,
    /// On a narrow element (below [`NARROW`] points) the panel is a sheet over the view: open or not.
    sheet_open: bool,
    /// Overlays drawn over the model.
    overlays: Overlays,
    overlay_scratch: overlay::OverlayScratch,
    /// The keyboard-shortcut help window is open.
    help: bool,
    /// Where the 3D view was laid out last frame.
    viewport_rect: Rect,
    /// Large deliveries waiting one frame to be imported (the bar says "Parsing…").
    parsing: Vec<load::Delivery>,
    /// A screenshot being read back from the GPU.
    screenshot: Option<crate::render::readback::PendingReadback>,
    /// The last screenshot, PNG-encoded (kept for tests; downloaded in the browser).
    last_screenshot: Option<Vec<u8>>,
    /// Files dropped together holding several models, and which one is shown.
    library: Option<Library>,
    /// The Samples menu's library (from the page: `kloub serve`'s `/api/assets`).
    samples: Vec<crate::samples::SampleEntry>,
    /// The URL the shown model was fetched from (`None`: dropped files or a built-in sample).
    shown_url: Option<String>,
    /// The page says files are dragged over the viewer.
    drop_hint: bool,
    /// A model was installed and its first frame has not been reported (`load` event).
    announce_load: bool,
    /// Whether the main clock ran at the last report (`play`/`pause` events).
    reported_playing: bool,
    /// The last `progress` event's value (0–1) for the model being loaded; negative: none yet.
    reported_progress: f64,

    /// Where each IK target was drawn last frame, in points (for `dataset.ikTarget`).
    ik_markers: Vec<Pos2>,
    /// Where each goal's pole marker was painted (`None`: no pole).
    ik_pole_markers: Vec<Option<Pos2>>,
}

/// Deliveries at least this large get a "Parsing…" frame before their import.
const PARSE_NOTICE_BYTES: usize = 4 << 20;

/// Speed a click gives a ragdoll body, in skeleton sizes per second.
const RAGDOLL_PUSH: f32 = 2.0;

/// Degrees one Shift+arrow press orbits the camera.
const ORBIT_STEP: f32 = 15.0;
/// Distance factor of one `-` press (`+` divides by it).
const ZOOM_STEP: f32 = 1.25;

/// Steps per second of the ←/→ frame step.
pub(crate) const FRAME_RATE: f32 = 30.0;

/// What the help window lists.
const SHORTCUTS: &[(&str, &str)] = &[
    ("Space", "play / pause"),
    ("← →", "previous / next frame (1/30 s)"),
    ("Home", "back to the start"),
    ("↑ ↓", "previous / next clip"),
    ("Shift + arrows", "orbit the camera"),
    ("+ / -", "zoom in / out"),
    ("F", "frame the model (or double-click)"),
    ("B", "bones: the skeleton, names on hover, click to select"),
    ("W", "wireframe"),
    ("N", "normals"),
    ("G", "ground grid"),
    ("? or H", "this help"),
    ("Drag", "orbit"),
    ("Right/middle drag, Shift+drag", "pan"),
    ("Wheel, pinch", "zoom"),
    ("Drop files or a folder", "open a model (.glb, or .gltf with its files)"),
];

/// `data-overlays`: the overlays that are on, comma-separated.
fn overlay_names(o: Overlays) -> String {
    let names = [
        (o.skeleton, "skeleton"),
        (o.bounds, "bounds"),
        (o.wireframe, "wireframe"),
        (o.normals, "normals"),
        (o.bodies, "bodies"),
    ];
    names.iter().filter(|(on, _)| *on).map(|(_, n)| *n).collect::<Vec<_>>().join(",")
}

/// The panels' look: egui's themes with text and controls at WCAG AA contrast (4.5:1, here
/// 4.6 for rounding) against what they are drawn on — egui's weak text (2.3:1 in the dark
/// theme) and some widget states fall below it.
pub fn style_panels(ctx: &egui::Context) {
    use crate::ui::{contrast, over};
    /// `fg` moved towards black or white (whichever reads better on `bg`) until it reads.
    fn readable(fg: egui::Color32, bg: egui::Color32) -> egui::Color32 {
        let fg = over(fg, bg);
        let target = if contrast(egui::Color32::WHITE, bg) > contrast(egui::Color32::BLACK, bg) {
            egui::Color32::WHITE
        } else {
            egui::Color32::BLACK
        };
        (0..=20).map(|i| fg.lerp_to_gamma(target, i as f32 / 20.0)).find(|&c| contrast(c, bg) >= 4.6).unwrap_or(target)
    }
    ctx.all_styles_mut(|style| {
        let v = &mut style.visuals;
        let panel = v.panel_fill;
        v.weak_text_color = Some(readable(v.weak_text_color(), panel));
        let text = readable(v.text_color(), panel);
        v.widgets.noninteractive.fg_stroke.color = text;
        for w in [&mut v.widgets.inactive, &mut v.widgets.hovered, &mut v.widgets.active, &mut v.widgets.open] {
            w.fg_stroke.color = readable(w.fg_stroke.color, w.weak_bg_fill);
        }
        v.selection.stroke.color = readable(v.selection.stroke.color, v.selection.bg_fill);
    });
}

/// Gives egui its fonts: Ubuntu-Light for all text (monospace included: the panel has no
/// code) and egui's icon font as the fallback, as egui's defaults do minus the monospace font.
pub fn install_fonts(ctx: &egui::Context) {
    use egui::{FontData, FontDefinitions, FontFamily, FontTweak};
    use std::sync::Arc;
    let mut fonts = FontDefinitions::empty();
    fonts
        .font_data
        .insert("Ubuntu-Light".to_owned(), Arc::new(FontData::from_static(epaint_default_fonts::UBUNTU_LIGHT)));
    let icons =
        FontData::from_static(epaint_default_fonts::EGUI_ICONS).tweak(FontTweak { scale: 0.9, ..Default::default() });
    fonts.font_data.insert("egui-icons".to_owned(), Arc::new(icons));
    for family in [FontFamily::Proportional, FontFamily::Monospace] {
        fonts.families.insert(family, vec!["Ubuntu-Light".to_owned(), "egui-icons".to_owned()]);
    }
    ctx.set_fonts(fonts);
}

/// Exponential smoothing of a per-frame figure (a first value is taken as is).
fn smooth(mean: f32, value: f32) -> f32 {
    if !value.is_finite() {
        mean
    } else if mean > 0.0 {
        mean * 0.9 + value * 0.1
    } else {
        value
    }
}

/// Below this width (points: CSS pixels) the side panel is a sheet opened over the view: phones
/// (360–430 wide upright) and narrow embeds; from a small tablet or laptop window up, a side panel.
const NARROW: f32 = 600.0;

/// The largest frame step the clock takes (a background tab resumes without a jump).
const MAX_DT: f32 = 0.25;

/// Crossfade duration of a click in the clip list until the user changes it, in seconds.
pub const DEFAULT_CROSSFADE: f32 = 0.3;

impl App {
    /// Creates the app on eframe's wgpu device and starts fetching `config.model_url` (native
    /// tests; the page runs the app through [`App::with_gpu`]).
    ///
    /// # Errors
    /// When eframe was started without the wgpu renderer.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn new(cc: &eframe::CreationContext<'_>, config: AppConfig) -> Result<Self, String> {
        let gpu = cc.wgpu_render_state.clone().ok_or("eframe was started without the wgpu renderer")?;
        Ok(Self::with_gpu(&cc.egui_ctx, gpu, config))
    }

    /// Creates the app on `gpu` (a device that may be shared with other viewers, and this
    /// viewer's own egui renderer), drawing its panels through `ctx`, and starts fetching
    /// `config.model_url`.
    pub fn with_gpu(ctx: &egui::Context, gpu: egui_wgpu::RenderState, config: AppConfig) -> Self {
        let backend = backend_name(gpu.adapter.get_info().backend);
        log::info!("kloub: rendering with {backend} ({:?})", gpu.adapter.get_info().name);
        install_fonts(ctx);
        style_panels(ctx);
        let scene = new_scene(&gpu, config.share);
        let mut app = Self {
            gpu,
            backend,
            scene,
            camera: Camera::default(),
            model: None,
            transition: Crossfade { duration: DEFAULT_CROSSFADE, ..Crossfade::default() },
            panel: ui::PanelMemory::default(),
            controls: config.controls.clone(),
            inbox: config.inbox.clone(),
            pending: 0,
            status: Status::Ready,
            last_error: String::new(),
            error_window: None,
            viewport: None,
            dataset: Dataset::new(config.host.clone()),
            frames: 0,
            fps: Fps::default(),
            skinning: SkinningMethod::default(),
            stages: ui::StageTimes::default(),
            ik_drag: None,
            ik_markers: Vec::new(),
            ik_pole_markers: Vec::new(),
            panels: config.panels,
            sheet_open: false,
            library: None,
            samples: Vec::new(),
            shown_url: None,
            overlays: Overlays::default(),
            overlay_scratch: overlay::OverlayScratch::default(),
            help: false,
            screenshot: None,
            last_screenshot: None,
            direct: false,
            scene_rect: None,
            screenshot_wanted: false,
            viewport_rect: Rect::ZERO,
            parsing: Vec::new(),
            drop_hint: false,
            announce_load: false,
            reported_playing: false,
            reported_progress: -1.0,
        };
        app.controls.set_repaint(ctx.clone());
        app.controls.set_supports_compute(app.scene.supports_compute());
        app.dataset.set(Key::Backend, backend);
        if let Some(url) = config.model_url {
            app.pending += 1;
            app.status = Status::Loading;
            load::fetch_into(url, app.inbox.clone(), ctx.clone());
        }
        app.sync_dataset();
        app
    }

    /// Moves the viewer to a new device (the old one was lost): the renderer is rebuilt with
    /// the same settings and the shown model uploaded again; everything else (model, clocks,
    /// camera, IK goals, panels) is kept.
    ///
    /// # Errors
    /// When the model cannot be uploaded to the new device (it is then dropped, as a failed
    /// load would be).
    pub fn replace_gpu(&mut self, gpu: egui_wgpu::RenderState, share: Option<u32>) -> Result<(), String> {
        let mut scene = new_scene(&gpu, share);
        scene.set_grid(self.scene.grid());
        scene.set_heatmap(self.scene.heatmap());
        scene.set_look(self.scene.look());
        scene.set_ground(self.scene.ground());
        // Compute skinning is only there on WebGPU; another backend falls back to the vertex shader.
        if scene.set_skinning_path(self.scene.skinning_path()).is_err() {
            log::warn!("kloub: the new device has no compute shaders: skinning in the vertex shader");
        }
        self.scene = scene;
        self.gpu = gpu;
        self.viewport = None;
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

    /// Wakes `ctx` (instead of the previous context) when a command arrives, after the
    /// viewer moved to a new egui context; the status is written again.
    pub fn set_context(&mut self, ctx: &egui::Context) {
        self.controls.set_repaint(ctx.clone());
        self.dataset.forget(Key::Status);
        ctx.request_repaint();
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

    /// Imports and installs every delivery that arrived since the last frame.
    fn receive(&mut self) {
        // A large delivery is held for one frame so the "Parsing…" bar is painted before the
        // import blocks the frame; small ones are imported at once.
        let mut arrived = std::mem::take(&mut self.parsing);
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
            self.pending = self.pending.saturating_sub(1);
            // A download shared with the page's other viewers: the model another viewer already
            // decoded from it, else its files (the first to get here decodes them for all).
            let files = match (delivery.files, delivery.shared, &delivery.url) {
                (Ok(_), Some(shared), Some(url)) => {
                    if let Some(model) = crate::shared::cached(url) {
                        let result = self.install(model, None);
                        self.finish_receive(result, Some((None, Some(url.clone()))));
                        continue;
                    }
                    if shared.is_empty() {
                        // It was shown when this viewer asked, and no more: download it again.
                        if let Some(ctx) = self.controls.repaint_context() {
                            self.pending += 1;
                            load::fetch_into(url.clone(), self.inbox.clone(), ctx);
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
                    let result = load::import_model(&files, None).and_then(|mut m| {
                        m.warnings.splice(0..0, notes);
                        // One model from a URL: the page's other viewers of that URL take this one.
                        if let Some(url) = url
                            && models.len() <= 1
                        {
                            crate::shared::remember(url, &m);
                        }
                        self.install(m, None)
                    });
                    let library = (models.len() > 1).then(|| {
                        let names: Vec<&str> = models.iter().map(|m| load::base_name(m)).collect();
                        let models_json = serde_json::Value::from(names).to_string();
                        Library { files, models, models_json, shown: Some(0) }
                    });
                    self.finish_receive(result, Some((library, delivery.url)));
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

    /// The end of one delivery: on success `shown` (the delivery's library of several models,
    /// and its URL; `None` for a sidecar) becomes the shown one and the status is ready; on
    /// failure the error is shown (the model stays).
    fn finish_receive(&mut self, result: Result<(), String>, shown: Option<(Option<Library>, Option<String>)>) {
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
    fn install(&mut self, loaded: LoadedModel, candy: Option<CandyPanel>) -> Result<(), String> {
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
            self.camera.frame_to_fit_aspect(min, max, view_aspect(self.viewport_rect));
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
        for file in files {
            let text = std::str::from_utf8(&file.bytes).map_err(|_| format!("{}: not UTF-8 text", file.name))?;
            model.joint_settings.apply_json(&model.asset, text).map_err(|e| format!("{}: {e}", file.name))?;
        }
        for ik in &mut model.ik {
            ik.use_settings(&model.joint_settings);
        }
        Ok(())
    }

    fn fail(&mut self, message: String) {
        log::warn!("kloub: {message}");
        self.dataset.host().emit("error", &message);
        self.status = Status::Error;
        self.last_error.clone_from(&message);
        self.error_window = Some(message);
    }

    /// Starts reading files dropped on the page this frame.
    fn take_drops(&mut self, ctx: &egui::Context) {
        let dropped = ctx.input(|i| i.raw.dropped_files.clone());
        if !dropped.is_empty() {
            self.pending += 1;
            self.status = Status::Loading;
            load::read_dropped_into(dropped, self.inbox.clone(), ctx.clone());
        }
    }

    /// Applies the commands the page queued since the last frame.
    fn apply_commands(&mut self) {
        for command in self.controls.take() {
            if let Err(message) = self.apply(command) {
                self.fail(message);
            }
        }
    }

    /// Evaluates the pose for this frame.
    fn evaluate(&mut self) {
        let Some(model) = &mut self.model else { return };
        let started = web_time::Instant::now();
        let result = model.evaluate();
        self.stages.animate = smooth(self.stages.animate, started.elapsed().as_secs_f32() * 1000.0);
        if let Err(e) = result {
            // Fall back to the rest pose so the error is reported once, not every frame.
            let message = format!("{}: cannot play {:?}: {e}", model.name, model.clip_name(model.animator.main().clip));
            model.animator = Animator::new(&model.asset);
            model.layer.enabled = false;
            self.fail(message);
        }
    }

    /// Keyboard shortcuts (when no text field has the keyboard): space play/pause, ←/→ step
    /// a frame (1/30 s), Home to the start, ↑/↓ previous/next clip, F frame, B bones,
    /// W wireframe, N normals, G grid, ? or H help.
    fn shortcuts(&mut self, ctx: &egui::Context) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        use egui::Key as K;
        // Each press with whether Shift was held (from the event itself, as the browser sent it).
        let press = |key: K, shift: bool| {
            ctx.input(|i| {
                i.events.iter().any(|e| {
                    matches!(e, egui::Event::Key { key: k, pressed: true, modifiers, .. }
                        if *k == key && modifiers.shift == shift)
                })
            })
        };
        let pressed = |key: K| press(key, false);
        let mut commands = Vec::new();
        if pressed(K::Questionmark) || press(K::Questionmark, true) || pressed(K::H) {
            self.help = !self.help;
        }
        if pressed(K::Escape) {
            self.help = false;
        }
        if pressed(K::F) {
            self.frame_model();
        }
        let mut overlays = self.overlays;
        overlays.skeleton ^= pressed(K::B);
        overlays.wireframe ^= pressed(K::W);
        overlays.normals ^= pressed(K::N);
        if overlays != self.overlays {
            commands.push(Command::SetOverlays(overlays));
        }
        if pressed(K::G) {
            commands.push(Command::SetGrid(!self.scene.grid()));
        }
        // Shift + arrows orbit, + and - zoom: the camera without a pointer.
        let shifted = |key: K| f32::from(u8::from(press(key, true)));
        let step = ORBIT_STEP.to_radians();
        self.camera.orbit(
            (shifted(K::ArrowLeft) - shifted(K::ArrowRight)) * step,
            (shifted(K::ArrowUp) - shifted(K::ArrowDown)) * step,
        );
        // `+` is Shift+= on most layouts.
        if pressed(K::Plus) || press(K::Plus, true) || pressed(K::Equals) || press(K::Equals, true) {
            self.camera.zoom(1.0 / ZOOM_STEP);
        }
        if pressed(K::Minus) {
            self.camera.zoom(ZOOM_STEP);
        }
        if let Some(model) = &self.model {
            if pressed(K::Space) {
                commands.push(if model.is_playing() { Command::Pause } else { Command::Play });
            }
            let time = model.animator.main().time;
            let step = if pressed(K::ArrowRight) {
                1.0
            } else if pressed(K::ArrowLeft) {
                -1.0
            } else {
                0.0
            };
            if step != 0.0 {
                commands.push(Command::Pause);
                commands.push(Command::Seek(((time * FRAME_RATE).round() + step) / FRAME_RATE));
            }
            if pressed(K::Home) {
                commands.push(Command::Seek(0.0));
            }
            let clips = model.clip_names.len();
            let clip = model.animator.main().clip;
            let next = if pressed(K::ArrowDown) {
                1
            } else if pressed(K::ArrowUp) {
                clips.saturating_sub(1)
            } else {
                0
            };
            if clips > 0 && next > 0 {
                commands.push(Command::PlayClip(Some(clip.map_or(0, |c| (c + next) % clips))));
            }
        }
        for command in commands {
            if let Err(message) = self.apply(command) {
                self.fail(message);
            }
        }
    }

    /// While a model downloads: its name and a progress bar over the top of the viewport.
    fn loading_bar(&self, ctx: &egui::Context) {
        if self.status != Status::Loading {
            return;
        }
        let progress = self.inbox.progress();
        let rect = self.viewport_rect;
        egui::Area::new(egui::Id::unique("kloub-loading-bar"))
            .order(egui::Order::Foreground)
            .fixed_pos(egui::pos2(rect.center().x - 160.0, rect.top() + 12.0))
            .interactable(false)
            .show(ctx, |ui| {
                egui::Frame::popup(ui.style()).show(ui, |ui| {
                    ui.set_width(320.0);
                    let mb = |b: u64| b as f64 / 1_048_576.0;
                    let parsing = self.parsing.first().map(load::Delivery::contents).map(|files| {
                        let bytes: usize = files.iter().map(|f| f.bytes.len()).sum();
                        let name = files.iter().find(|f| load::is_model_name(&f.name)).or(files.first());
                        (name.map_or("files", |f| load::base_name(&f.name)).to_owned(), bytes)
                    });
                    match progress {
                        _ if parsing.is_some() => {
                            let (name, bytes) = parsing.unwrap_or_default();
                            ui.horizontal(|ui| {
                                ui.spinner();
                                ui.label(format!("Parsing {name} ({:.1} MB)…", mb(bytes as u64)));
                            });
                        }
                        Some(load::Progress { name, received, total: Some(total) }) if total > 0 => {
                            ui.label(format!("Loading {name}: {:.1} of {:.1} MB", mb(received), mb(total)));
                            ui.add(
                                egui::ProgressBar::new((received as f64 / total as f64).min(1.0) as f32)
                                    .show_percentage(),
                            );
                        }
                        Some(load::Progress { name, received, .. }) => {
                            ui.label(format!("Loading {name}: {:.1} MB", mb(received)));
                            ui.add(egui::ProgressBar::new(0.0).animate(true));
                        }
                        None => {
                            ui.horizontal(|ui| {
                                ui.spinner();
                                ui.label("Loading…");
                            });
                        }
                    }
                });
            });
        ctx.request_repaint();
    }

    /// The keyboard-shortcut help window (`?`).
    fn help_window(&mut self, ctx: &egui::Context) {
        if !self.help {
            return;
        }
        let mut open = true;
        egui::Window::new("Keyboard and mouse").open(&mut open).collapsible(false).resizable(false).show(ctx, |ui| {
            egui::Grid::new("help grid").striped(true).show(ui, |ui| {
                for (keys, what) in SHORTCUTS {
                    ui.strong(*keys);
                    ui.label(*what);
                    ui.end_row();
                }
            });
        });
        self.help &= open;
    }

    /// Starts saving the view (the 3D viewport, without the panels' overlays) as a PNG: the
    /// GPU copy is read back over the next frames, then offered as `<model>.png`.
    fn screenshot(&mut self) {
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
    fn finish_screenshot(&mut self, ctx: &egui::Context) {
        let Some(pending) = &self.screenshot else { return };
        let Some(result) = pending.poll(&self.gpu.device) else {
            ctx.request_repaint();
            return;
        };
        let (width, height) = pending.size();
        self.screenshot = None;
        let png = result.and_then(|pixels| {
            let mut pixels = pixels;
            crate::render::readback::unpremultiply(&mut pixels);
            let image = image::RgbaImage::from_raw(width, height, pixels).ok_or("screenshot: size mismatch")?;
            let mut out = std::io::Cursor::new(Vec::new());
            image.write_to(&mut out, image::ImageFormat::Png).map_err(|e| format!("screenshot: {e}"))?;
            Ok(out.into_inner())
        });
        match png {
            Ok(png) => {
                let stem =
                    self.model.as_ref().map_or("kloub", |m| m.name.rsplit_once('.').map_or(m.name.as_str(), |s| s.0));
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
    fn frame_model(&mut self) {
        let Some(model) = &mut self.model else { return };
        let clip = model.animator.main().clip;
        if let Some((min, max)) = model.animated_bounds(clip) {
            self.camera.frame_to_fit_aspect(min, max, view_aspect(self.viewport_rect));
        }
        // Restore the animated pose the bounds sampling overwrote.
        self.evaluate();
    }

    /// A full-window hint while files are dragged over the page.
    fn drop_hint(ctx: &egui::Context, page_says: bool) {
        if !page_says && ctx.input(|i| i.raw.hovered_files.is_empty()) {
            return;
        }
        let painter =
            ctx.layer_painter(egui::LayerId::new(egui::Order::Foreground, egui::Id::unique("kloub-drop-hint")));
        let rect = ctx.content_rect();
        painter.rect_filled(rect, 0.0, Color32::from_black_alpha(160));
        painter.text(
            rect.center(),
            egui::Align2::CENTER_CENTER,
            "Drop to open (.glb, or .gltf with its .bin and textures)",
            egui::FontId::proportional(22.0),
            Color32::WHITE,
        );
    }

    /// The dismissible error window.
    fn error_window(&mut self, ctx: &egui::Context) {
        let Some(message) = &self.error_window else { return };
        let mut open = true;
        let mut dismissed = false;
        egui::Window::new("Could not open the model")
            .open(&mut open)
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_TOP, [0.0, 24.0])
            .show(ctx, |ui| {
                ui.label(message.as_str());
                if self.model.is_some() {
                    ui.weak("The previous model is still shown.");
                }
                dismissed = ui.button("Dismiss").clicked();
            });
        if !open || dismissed {
            self.error_window = None;
        }
    }
}

#[cfg(not(target_arch = "wasm32"))]
impl eframe::App for App {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.frame(ui);
    }
}

impl App {
    /// One frame: commands, clocks, panels, the 3D view and its overlays, drawn into `ui`
    /// (the whole canvas).
    pub fn frame(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        // Before the first 3D view is laid out, a model that arrives is framed for the whole area
        // (exactly the view's shape without panels).
        if !(self.viewport_rect.width() > 0.0 && self.viewport_rect.height() > 0.0) {
            self.viewport_rect = ui.max_rect();
        }
        self.receive();
        self.take_drops(&ctx);
        // egui may run extra layout passes for one painted frame: the clock moves once.
        if ctx.current_pass_index() == 0 {
            let (stable_dt, unstable_dt) = ctx.input(|i| (i.stable_dt, i.unstable_dt));
            self.fps.update(unstable_dt);
            self.apply_commands();
            if let Some(model) = &mut self.model {
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

        // Frames are painted on demand: a rate means something only while the model moves.
        let animating = self.model.as_ref().is_some_and(Model::is_animating);
        let sjb_fallbacks =
            if self.skinning == SkinningMethod::SphericalJointBlend { self.scene.sjb_fallbacks() } else { Vec::new() };
        let state = ui::PanelState {
            loading: self.status == Status::Loading,
            backend: self.backend,
            fps: animating.then(|| self.fps.fps()),
            stages: self.stages,
            skinning: self.skinning,
            skinning_path: self.scene.skinning_path(),
            compute: self.scene.supports_compute(),
            heatmap: self.scene.heatmap(),
            sjb_fallbacks: &sjb_fallbacks,
            library: self.library.as_ref().map_or(&[], |l| l.models.as_slice()),
            grid: self.scene.grid(),
            overlays: self.overlays,
            look: self.scene.look(),
            library_shown: self.library.as_ref().and_then(|l| l.shown),
            samples: &self.samples,
            shown_sample: self
                .shown_url
                .as_deref()
                .and_then(|url| self.samples.iter().position(|s| s.is_shown_from(url))),
        };
        // A phone's width: the panel becomes a sheet the user opens over the full-width view.
        let narrow = ui.available_width() < NARROW;
        let actions = if !self.panels {
            ui::PanelActions::default()
        } else if !narrow {
            egui::Panel::left("controls")
                .resizable(true)
                .default_size(270.0)
                .show(ui, |ui| ui::side_panel(ui, &state, self.model.as_mut(), &mut self.transition, &mut self.panel))
                .inner
        } else if self.sheet_open {
            let screen = ui.max_rect();
            let width = (screen.width() - 40.0).clamp(200.0, 360.0);
            let (model, transition, memory) = (self.model.as_mut(), &mut self.transition, &mut self.panel);
            let mut close = false;
            let actions = egui::Area::new(egui::Id::unique("kloub-sheet"))
                .order(egui::Order::Foreground)
                .fixed_pos(screen.min)
                .show(&ctx, |ui| {
                    egui::Frame::side_top_panel(ui.style()).show(ui, |ui| {
                        ui.set_width(width);
                        ui.set_height(screen.height() - 12.0);
                        ui.horizontal(|ui| {
                            close = ui.button("Close panel").clicked();
                        });
                        ui::side_panel(ui, &state, model, transition, memory)
                    })
                })
                .inner
                .inner;
            self.sheet_open = !close;
            actions
        } else {
            let screen = ui.max_rect();
            egui::Area::new(egui::Id::unique("kloub-sheet-button"))
                .order(egui::Order::Foreground)
                .fixed_pos(screen.min + egui::vec2(8.0, 8.0))
                .show(&ctx, |ui| {
                    if ui.add(egui::Button::new("Panel").min_size(egui::vec2(44.0, 32.0))).clicked() {
                        self.sheet_open = true;
                    }
                });
            ui::PanelActions::default()
        };
        let panel = match (self.panels, narrow, self.sheet_open) {
            (false, ..) => "",
            (true, false, _) => "side",
            (true, true, true) => "open",
            (true, true, false) => "closed",
        };
        self.dataset.set(Key::Panel, panel);
        if actions.frame {
            self.frame_model();
        }
        self.help |= actions.help;
        if let Some(folder) = actions.open {
            // The element opens its file input (the click is still the user's gesture).
            self.dataset.host().emit("kloub:open", if folder { "folder" } else { "files" });
        }
        self.finish_screenshot(&ctx);
        if actions.save_sidecar
            && let Some(model) = &self.model
        {
            let stem = model.name.rsplit_once('.').map_or(model.name.as_str(), |(stem, _)| stem);
            let text = model.sidecar_json();
            if let Err(message) =
                crate::dom::download(&format!("{stem}.kloub.json"), text.as_bytes(), "application/json")
            {
                self.fail(message);
            }
        }
        for command in actions.commands {
            if let Err(message) = self.apply(command) {
                self.fail(message);
            }
        }
        if let Some(model) = &mut self.model {
            let result = if actions.layer_changed { model.sync_layer() } else { Ok(()) };
            let result = result.and_then(|()| if actions.blend_changed { model.apply_blend() } else { Ok(()) });
            if actions.layer_changed || actions.blend_changed {
                model.sync_copies();
            }
            if let Err(message) = result {
                self.fail(message);
            }
        }

        if ctx.current_pass_index() == 0 {
            self.shortcuts(&ctx);
        }
        self.evaluate();
        egui::CentralPanel::no_frame().show(ui, |ui| self.viewport(ui));
        self.loading_bar(&ctx);
        self.help_window(&ctx);
        Self::drop_hint(&ctx, self.drop_hint);
        self.error_window(&ctx);

        if !ctx.will_discard() {
            self.frames += 1;
        }
        self.sync_dataset();
        if self.model.as_ref().is_some_and(|m| m.is_animating() || m.ragdoll_moving()) {
            ctx.request_repaint();
        }
    }
}

/// Width / height of the 3D view's rectangle (1 before it has a size): what framing fits the model to.
fn view_aspect(rect: egui::Rect) -> f32 {
    if rect.width() > 0.0 && rect.height() > 0.0 { rect.width() / rect.height() } else { 1.0 }
}

/// A scene renderer for the view on `gpu`: its multisampling and the colour format its canvas
/// is drawn in (both rebuilt the same way when the device is replaced).
fn new_scene(gpu: &egui_wgpu::RenderState, share: Option<u32>) -> SceneRenderer {
    SceneRenderer::shared(
        &gpu.device,
        &gpu.queue,
        display_msaa(&gpu.adapter),
        scene_format(gpu.adapter.get_info().backend),
        share,
    )
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
