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
}

impl Default for AppConfig {
    fn default() -> Self {
        Self {
            model_url: None,
            controls: Controls::default(),
            inbox: Inbox::default(),
            host: crate::dom::Host::default(),
            panels: true,
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
const FRAME_RATE: f32 = 30.0;

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

/// How far the wheel moves an IK target along the view direction, per scrolled point, as a
/// fraction of the camera's distance (scrolling up, positive, pulls it closer).
const IK_DEPTH_PER_POINT: f32 = 0.0002;

/// What an IK drag moves: goal `goal`'s target, or its pole.
#[derive(Clone, Copy, Debug, PartialEq)]
struct IkHandle {
    goal: usize,
    pole: bool,
}

impl IkHandle {
    /// The handle's point in `ik` (model space).
    fn point(self, ik: &mut IkState) -> Option<&mut Vec3> {
        if !self.pole {
            Some(&mut ik.target)
        } else if ik.active_pole().is_some() {
            ik.pole.as_mut()
        } else {
            None
        }
    }
}

/// Draws the IK chain, the target (green when reached) with the error, and the pole (a
/// diamond tied to the middle joint) when the goal has one; returns where the target and the
/// pole were drawn.
fn paint_ik(
    painter: &egui::Painter,
    projection: &Projection,
    ik: &IkState,
    origin: Vec3,
    dragging: bool,
) -> (Option<Pos2>, Option<Pos2>) {
    let points: Vec<Pos2> = ik.joints.iter().filter_map(|&p| projection.to_screen(p + origin).map(|s| s.0)).collect();
    let gold = Color32::from_rgb(255, 214, 64);
    let chain = egui::Stroke::new(2.0, gold);
    for w in points.windows(2) {
        painter.line_segment([w[0], w[1]], chain);
    }
    for &p in &points {
        painter.circle_filled(p, 3.5, gold);
    }
    let pole = ik.active_pole().and_then(|p| projection.to_screen(p + origin)).map(|(at, _)| {
        let blue = Color32::from_rgb(110, 170, 255);
        if let Some(&middle) = points.get(points.len() / 2) {
            painter.line_segment([middle, at], egui::Stroke::new(1.0, blue));
        }
        let r = if dragging { 8.0 } else { 6.5 };
        let diamond =
            vec![at + egui::vec2(0.0, -r), at + egui::vec2(r, 0.0), at + egui::vec2(0.0, r), at + egui::vec2(-r, 0.0)];
        painter.add(egui::Shape::convex_polygon(diamond, Color32::TRANSPARENT, egui::Stroke::new(2.0, blue)));
        at
    });
    let Some((at, _)) = projection.to_screen(ik.target + origin) else { return (None, pole) };
    let reached = ik.report.error <= 1e-3;
    let color = if reached { Color32::from_rgb(80, 220, 120) } else { Color32::from_rgb(255, 90, 80) };
    painter.circle_stroke(at, if dragging { 11.0 } else { 9.0 }, egui::Stroke::new(2.5, color));
    painter.circle_filled(at, 2.5, color);
    painter.text(
        at + egui::vec2(14.0, -14.0),
        egui::Align2::LEFT_BOTTOM,
        format!("error {:.4}", ik.report.error),
        egui::FontId::monospace(12.0),
        color,
    );
    (Some(at), pole)
}

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
        let scene = SceneRenderer::with_format(
            &gpu.device,
            &gpu.queue,
            display_msaa(&gpu.adapter),
            scene_format(gpu.adapter.get_info().backend),
        );
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
    pub fn replace_gpu(&mut self, gpu: egui_wgpu::RenderState) -> Result<(), String> {
        let mut scene = SceneRenderer::with_format(
            &gpu.device,
            &gpu.queue,
            display_msaa(&gpu.adapter),
            scene_format(gpu.adapter.get_info().backend),
        );
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
                .set_asset(&self.gpu.device, &self.gpu.queue, &model.asset)
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
            let bytes: usize = delivery.files.as_ref().map_or(0, |f| f.iter().map(|f| f.bytes.len()).sum());
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
            let result = match delivery.files {
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
                    let result = load::import_model(&files, None).and_then(|mut m| {
                        m.warnings.splice(0..0, notes);
                        self.install(m, None)
                    });
                    if result.is_ok() {
                        self.library = (models.len() > 1).then(|| {
                            let names: Vec<&str> = models.iter().map(|m| load::base_name(m)).collect();
                            let models_json = serde_json::Value::from(names).to_string();
                            Library { files, models, models_json, shown: Some(0) }
                        });
                        self.shown_url = delivery.url;
                    }
                    result
                }
                Err(message) => Err(message),
            };
            match result {
                Ok(()) => {
                    self.status = Status::Ready;
                    self.last_error.clear();
                    self.error_window = None;
                }
                Err(message) => self.fail(message),
            }
        }
        if self.pending > 0 || !self.parsing.is_empty() {
            self.status = Status::Loading;
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
            .set_asset(&self.gpu.device, &self.gpu.queue, &model.asset)
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

    /// Applies one command to the shown model (the side panel's actions go through here too).
    fn apply(&mut self, command: Command) -> Result<(), String> {
        match command {
            Command::SetSkinning(method) => {
                self.skinning = method;
                if let Some(model) = &mut self.model {
                    model.instance.set_skinning(&model.asset, method);
                    model.sync_copies();
                }
                return Ok(());
            }
            Command::SetSkinningPath(path) => {
                return self.scene.set_skinning_path(path);
            }
            Command::SetHeatmap(on) => {
                self.scene.set_heatmap(on);
                return Ok(());
            }
            Command::SetPanels(on) => {
                self.panels = on;
                return Ok(());
            }
            Command::SetTransitionDuration(seconds) => {
                self.transition.duration = seconds.max(0.0);
                return Ok(());
            }
            Command::SetTransition { easing, outgoing } => {
                self.transition.easing = easing.unwrap_or(self.transition.easing);
                self.transition.outgoing = outgoing.unwrap_or(self.transition.outgoing);
                return Ok(());
            }
            Command::SetDropHint(on) => {
                self.drop_hint = on;
                return Ok(());
            }
            Command::SetGrid(on) => {
                self.scene.set_grid(on);
                return Ok(());
            }
            Command::SetCameraLimits { limits, fov } => {
                self.camera.limits = limits.sanitized();
                self.camera.fov_y = fov.filter(|f| f.is_finite()).unwrap_or(45f32.to_radians());
                self.camera.constrain();
                return Ok(());
            }
            Command::SetOverlays(overlays) => {
                self.overlays = overlays;
                return Ok(());
            }
            Command::Screenshot => {
                self.screenshot();
                return Ok(());
            }
            Command::SetLighting(lighting) => {
                self.scene.set_look(crate::render::uniforms::Look { lighting, ..self.scene.look() });
                return Ok(());
            }
            Command::SetBackground(background) => {
                self.scene.set_look(crate::render::uniforms::Look { background, ..self.scene.look() });
                return Ok(());
            }
            Command::SetSamples(samples) => {
                self.samples = samples;
                return Ok(());
            }
            Command::LoadUrl(url) => {
                self.pending += 1;
                self.status = Status::Loading;
                if let Some(ctx) = self.controls.repaint_context() {
                    load::fetch_into(url, self.inbox.clone(), ctx);
                }
                return Ok(());
            }
            Command::ShowModel(i) => {
                let Some(library) = &self.library else { return Ok(()) };
                let Some(name) = library.models.get(i) else { return Ok(()) };
                let loaded = load::import_model(&library.files, Some(name))?;
                self.install(loaded, None)?;
                if let Some(library) = &mut self.library {
                    library.shown = Some(i);
                }
                return Ok(());
            }
            Command::LoadSample(Sample::CandyWrapper) => {
                let panel = CandyPanel::new();
                let loaded = panel.model();
                self.install(loaded, Some(panel))?;
                self.status = Status::Ready;
                self.last_error.clear();
                self.error_window = None;
                return Ok(());
            }
            _ => {}
        }
        let Some(model) = &mut self.model else { return Ok(()) };
        // Copies replay the main animator: only commands that change it need a re-sync.
        let animates = matches!(
            command,
            Command::Play
                | Command::Pause
                | Command::PlayClip(_)
                | Command::CrossfadeTo { .. }
                | Command::Seek(_)
                | Command::SetSpeed(_)
                | Command::SetLoop(_)
                | Command::SetLayer { .. }
                | Command::SetBlend(_)
                | Command::SetCandyPose { .. }
        );
        match command {
            Command::SetSkinning(_)
            | Command::SetSkinningPath(_)
            | Command::SetHeatmap(_)
            | Command::LoadSample(_)
            | Command::SetPanels(_)
            | Command::SetTransitionDuration(_)
            | Command::SetTransition { .. }
            | Command::SetDropHint(_)
            | Command::LoadUrl(_)
            | Command::SetSamples(_)
            | Command::SetGrid(_)
            | Command::SetCameraLimits { .. }
            | Command::SetOverlays(_)
            | Command::Screenshot
            | Command::SetLighting(_)
            | Command::SetBackground(_)
            | Command::ShowModel(_) => {}
            Command::SelectJoint(node) => model.selected_joint = node,
            Command::StartRagdoll => model.start_ragdoll()?,
            Command::StopRagdoll => model.ragdoll = None,
            Command::RagdollToAnimation(seconds) => {
                if let Some(ragdoll) = &mut model.ragdoll {
                    ragdoll.blend_back = Some((0.0, seconds.max(0.0)));
                }
            }
            Command::SetRagdollOptions { gravity, damping } => {
                model.ragdoll_options.gravity = gravity;
                model.ragdoll_options.damping = damping;
                let options = model.ragdoll_options;
                if let Some(ragdoll) = &mut model.ragdoll {
                    ragdoll.ragdoll.set_options(options);
                }
            }
            Command::SetMorph { node, target, weight } => {
                let n = model.asset.nodes.get(node as usize).ok_or_else(|| format!("node {node} does not exist"))?;
                if target >= n.weights.len() {
                    return Err(format!(
                        "{}: morph target {target} of {} does not exist",
                        model.name,
                        model.node_name(node)
                    ));
                }
                let start = model.asset.weight_offsets.get(node as usize).copied().unwrap_or(0) as usize;
                if let Some(slot) = model.morph_overrides.get_mut(start + target) {
                    *slot = weight.map(|w| if w.is_finite() { w } else { 0.0 });
                }
            }
            Command::SetCamera([yaw, pitch, distance, x, y, z]) => {
                self.camera.yaw = yaw;
                self.camera.pitch = pitch;
                self.camera.distance = distance;
                self.camera.target = Vec3::new(x, y, z);
                self.camera.orbit(0.0, 0.0);
            }
            Command::SetIk { effector, depth, target } => match effector {
                Some(effector) => {
                    let existing = model.ik.iter().position(|g| g.effector() == effector);
                    let like = existing.or(model.ik.len().checked_sub(1)).and_then(|i| model.ik.get(i));
                    let state = model.ik_goal(effector, depth, target.map(Vec3::from), like)?;
                    match existing {
                        Some(i) => {
                            model.ik[i] = state;
                            model.ik_selected = i;
                        }
                        None => {
                            model.ik.push(state);
                            model.ik_selected = model.ik.len() - 1;
                        }
                    }
                }
                None => {
                    model.ik.clear();
                    model.ik_selected = 0;
                }
            },
            Command::SetIkSolver { effector, solver, pole, softness, accelerate, iterations } => {
                let name = model.node_name(effector);
                let ik = model
                    .ik
                    .iter_mut()
                    .find(|g| g.effector() == effector)
                    .ok_or_else(|| format!("no IK goal on {name}: set its target first"))?;
                if solver == kloub_core::job::ik::IkSolver::TwoBone && ik.depth() != 2 {
                    return Err(format!("two-bone needs 2 joints above {name}, not {}", ik.depth()));
                }
                ik.solver = solver;
                ik.pole = pole.map(Vec3::from);
                ik.softness = softness.unwrap_or(ik.softness);
                ik.accelerate = accelerate.unwrap_or(ik.accelerate);
                ik.iterations = iterations.unwrap_or(ik.iterations);
            }
            Command::ReplaceIk { goal, effector, depth } => {
                if let Some(old) = model.ik.get(goal) {
                    let state = model.ik_goal(effector, depth, Some(old.target), Some(old))?;
                    model.ik[goal] = state;
                    model.ik_selected = goal;
                }
            }
            Command::RemoveIk(goal) => {
                if goal < model.ik.len() {
                    model.ik.remove(goal);
                    model.ik_selected = model.ik_selected.min(model.ik.len().saturating_sub(1));
                }
            }
            Command::SetCopies(n) => {
                model.set_copies(n);
                if let Some((min, max)) = model.grid_bounds() {
                    self.camera.frame_to_fit_aspect(min, max, view_aspect(self.viewport_rect));
                }
            }
            Command::SetCandyPose { twist, bend } => {
                if let Some(candy) = &mut model.candy {
                    candy.twist = twist.clamp(-360.0, 360.0);
                    candy.bend = bend.clamp(-180.0, 180.0);
                    candy.manual = true;
                    model.set_playing(false);
                }
            }
            Command::Play => model.set_playing(true),
            Command::Pause => model.set_playing(false),
            Command::PlayClip(clip) => model.play_clip(clip, self.transition)?,
            Command::CrossfadeTo { clip, seconds } => {
                model.play_clip(clip, Crossfade { duration: seconds, ..self.transition })?;
            }
            Command::Seek(t) => model.seek(t),
            Command::SetSpeed(speed) => model.set_speed(speed),
            Command::SetLoop(mode) => model.set_loop_mode(mode),
            Command::SetLayer { clip, root, weight } => {
                match clip {
                    Some(clip) => {
                        model.layer.enabled = true;
                        model.layer.clip = clip;
                        model.layer.root = root;
                        model.layer.weight = weight;
                    }
                    None => model.layer.enabled = false,
                }
                model.sync_layer()?;
            }
            Command::SetBlend(weights) => {
                model.blend_weights.iter_mut().for_each(|w| *w = 0.0);
                for (clip, weight) in weights {
                    if let Some(w) = model.blend_weights.get_mut(clip) {
                        *w = weight;
                    }
                }
                model.apply_blend()?;
            }
        }
        if animates && !model.copies.is_empty() {
            model.sync_copies();
        }
        Ok(())
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

    /// Draws the 3D viewport into `ui` and handles camera input.
    fn viewport(&mut self, ui: &mut egui::Ui) {
        let (rect, response) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
        self.viewport_rect = rect;
        let viewport = format!("{},{},{},{}", rect.min.x, rect.min.y, rect.width(), rect.height());
        self.dataset.set(Key::Viewport, &viewport);
        let height = rect.height();
        let delta = response.drag_delta();
        let shift = ui.input(|i| i.modifiers.shift);
        let multi_touch = ui.input(|i| i.multi_touch()).is_some_and(|t| t.num_touches >= 2);
        let projection = Projection::new(&self.camera, rect);
        let origin = self.model.as_ref().map_or(Vec3::ZERO, |m| m.copy_offset(0));
        // Every IK handle on screen: targets, and the poles of two-bone goals that have one.
        let markers: Vec<(IkHandle, Pos2, f32)> = self
            .model
            .as_ref()
            .map(|m| {
                m.ik.iter()
                    .enumerate()
                    .flat_map(|(goal, ik)| {
                        let target = projection
                            .to_screen(ik.target + origin)
                            .map(|(at, depth)| (IkHandle { goal, pole: false }, at, depth));
                        let pole = ik
                            .active_pole()
                            .and_then(|p| projection.to_screen(p + origin))
                            .map(|(at, depth)| (IkHandle { goal, pole: true }, at, depth));
                        [target, pole]
                    })
                    .flatten()
                    .collect()
            })
            .unwrap_or_default();
        let handle_at = |p: Pos2| nearest_within(p, markers.iter().map(|&(handle, at, _)| (at, handle)));
        if response.drag_started_by(egui::PointerButton::Primary) && !shift {
            // Where the press was: a quick drag may have moved off the handle before egui calls it a drag.
            let pressed_at = ui.input(|i| i.pointer.press_origin());
            self.ik_drag = pressed_at.or_else(|| response.interact_pointer_pos()).and_then(handle_at);
            if let (Some(handle), Some(model)) = (self.ik_drag, self.model.as_mut()) {
                model.ik_selected = handle.goal;
            }
        }
        let mut pending = None;
        // A click on a ragdoll body pushes it away from the camera.
        if response.clicked()
            && let (Some(model), Some(pointer)) = (self.model.as_mut(), response.interact_pointer_pos())
            && let Some(state) = &mut model.ragdoll
            && let (Some(near), Some(far)) = (projection.unproject(pointer, 0.0), projection.unproject(pointer, 0.9))
        {
            let dir = (far - near).normalize_or_zero();
            let ragdoll = &mut state.ragdoll;
            if let Some((body, at)) = ragdoll.pick(near - origin, dir, 1.5) {
                let speed = ragdoll.size() * RAGDOLL_PUSH;
                ragdoll.push(body, dir * speed, at);
            }
        }
        if let Some(handle) = self.ik_drag {
            if let (Some(&(_, _, depth)), Some(pointer), Some(ik)) = (
                markers.iter().find(|m| m.0 == handle),
                response.interact_pointer_pos(),
                self.model.as_mut().and_then(|m| m.ik.get_mut(handle.goal)),
            ) && let Some(world) = projection.unproject(pointer, depth)
                && let Some(point) = handle.point(ik)
            {
                *point = world - origin;
            }
            if !response.dragged() || response.drag_stopped() {
                self.ik_drag = None;
            }
        } else if response.clicked()
            && let (Some(model), Some(pointer)) = (self.model.as_ref(), response.interact_pointer_pos())
            && model.ik.is_empty()
            && (self.overlays.skeleton || !model.has_meshes())
        {
            // A click on a joint selects it (its axes and channel plot); elsewhere clears.
            let points = overlay::joint_points(model, &projection, origin);
            pending = Some(Command::SelectJoint(nearest_within(pointer, points.into_iter())));
        } else if response.clicked()
            && let (Some(model), Some(pointer)) = (self.model.as_ref(), response.interact_pointer_pos())
            && let Some(ik) = model.ik.get(model.ik_selected)
        {
            // A click on a joint makes it the effector (keeping the depth where possible).
            let joints = model.asset.skins.iter().flat_map(|s| s.joints.iter().copied()).filter_map(|j| {
                let p = model.instance.worlds().get(j as usize)?.w_axis.truncate();
                projection.to_screen(p + origin).map(|(at, _)| (at, j))
            });
            if let Some(joint) = nearest_within(pointer, joints) {
                let available = crate::ik::ancestors(&model.asset, joint);
                pending = Some(Command::ReplaceIk {
                    goal: model.ik_selected,
                    effector: joint,
                    depth: ik.depth().min(available).max(1),
                });
            }
        } else if response.dragged_by(egui::PointerButton::Primary) && !shift && !multi_touch {
            self.camera.orbit_pixels(delta.x, delta.y, height);
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
            || (response.dragged_by(egui::PointerButton::Primary) && shift)
        {
            self.camera.pan_pixels(delta.x, delta.y, height);
        }
        // The wheel over an IK ring (or while dragging one) moves its target along the view
        // direction instead of zooming.
        let ring = self.ik_drag.or_else(|| response.hover_pos().and_then(handle_at));
        if let Some(handle) = ring
            && let Some(ik) = self.model.as_mut().and_then(|m| m.ik.get_mut(handle.goal))
            && let Some(point) = handle.point(ik)
        {
            let scroll = ui.input(|i| {
                i.raw
                    .events
                    .iter()
                    .filter_map(|e| match e {
                        egui::Event::MouseWheel { unit, delta, .. } => Some(match unit {
                            egui::MouseWheelUnit::Point => delta.y,
                            egui::MouseWheelUnit::Line => delta.y * 40.0,
                            egui::MouseWheelUnit::Page => delta.y * 400.0,
                        }),
                        _ => None,
                    })
                    .sum::<f32>()
            });
            if scroll != 0.0
                && let Some(direction) = (*point + origin - self.camera.eye()).try_normalize()
            {
                *point -= direction * scroll * IK_DEPTH_PER_POINT * self.camera.distance;
            }
        } else if response.hovered() {
            let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta.y, i.zoom_delta()));
            if scroll != 0.0 {
                self.camera.zoom_scroll(scroll);
            }
            if zoom != 1.0 {
                self.camera.zoom(1.0 / zoom);
            }
        }
        // Two fingers pan (their pinch zooms through zoom_delta above); one finger orbits as a drag.
        if response.hovered()
            && let Some(touch) = ui.input(|i| i.multi_touch())
            && touch.num_touches >= 2
        {
            self.camera.pan_pixels(touch.translation_delta.x, touch.translation_delta.y, height);
        }
        if response.double_clicked() {
            self.frame_model();
        }

        let Some(model) = &mut self.model else {
            ui.painter().rect_filled(rect, 0.0, ui.visuals().extreme_bg_color);
            let invitation = if self.panels {
                "Drop a .glb or .gltf file here,\nor open one from Samples or Open (top of the panel)"
            } else {
                "Drop a .glb or .gltf file here"
            };
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                invitation,
                egui::FontId::proportional(18.0),
                ui.visuals().weak_text_color(),
            );
            return;
        };
        let ppp = ui.ctx().pixels_per_point();
        let size = [(rect.width() * ppp).round() as u32, (rect.height() * ppp).round() as u32];
        let gpu = &self.gpu;
        let offsets: Vec<Vec3> = (0..model.copy_count()).map(|c| model.copy_offset(c)).collect();
        let mut instances: Vec<&mut Instance> =
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
                return;
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
        if let Some(view) = view.filter(|_| !self.direct) {
            let version = self.scene.target_version();
            let mut renderer = gpu.renderer.write();
            let id = match &mut self.viewport {
                Some(texture) if texture.version == version => texture.id,
                Some(texture) => {
                    renderer.update_egui_texture_from_wgpu_texture(
                        &gpu.device,
                        &view,
                        wgpu::FilterMode::Linear,
                        texture.id,
                    );
                    texture.version = version;
                    texture.id
                }
                None => {
                    let id = renderer.register_native_texture(&gpu.device, &view, wgpu::FilterMode::Linear);
                    self.viewport = Some(ViewportTexture { id, version });
                    id
                }
            };
            let uv = Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0));
            ui.painter().image(id, rect, uv, Color32::WHITE);
        }
        if let Some(model) = self.model.as_mut() {
            let painter = ui.painter_at(rect);
            overlay::paint_mesh_lines(&painter, model, &projection, origin, self.overlays, &mut self.overlay_scratch);
            if self.overlays.bounds
                && let Some(bounds) = model.bounds
            {
                overlay::paint_box(&painter, &projection, bounds, origin);
            }
            // A file without meshes (a bare skeleton) always shows its skeleton.
            if self.overlays.skeleton || !model.has_meshes() {
                let points = overlay::joint_points(model, &projection, origin);
                let hovered = response.hover_pos().and_then(|p| nearest_within(p, points.iter().copied()));
                overlay::paint_skeleton(&painter, model, &points, model.selected_joint, hovered);
            }
            if self.overlays.bodies
                && let Some(state) = &model.ragdoll
            {
                overlay::paint_bodies(&painter, &projection, origin, &state.ragdoll);
            }
            if let Some(joint) = model.selected_joint {
                let size = model.bounds.map_or(1.0, |(lo, hi)| (hi - lo).length());
                overlay::paint_axes(&painter, model, &projection, origin, joint, size);
            }
        }
        self.ik_markers.clear();
        self.ik_pole_markers.clear();
        if let Some(model) = self.model.as_ref() {
            for ik in model.ik.iter().filter(|ik| ik.use_limits) {
                let frames = ik.limit_frames(model.instance.worlds());
                overlay::paint_limits(ui.painter(), &projection, origin, &frames, &ik.limits);
            }
            for (i, ik) in model.ik.iter().enumerate() {
                let selected = i == model.ik_selected && model.ik.len() > 1;
                let dragging = self.ik_drag.is_some_and(|h| h.goal == i);
                let (target, pole) = paint_ik(ui.painter(), &projection, ik, origin, dragging || selected);
                if let Some(at) = target {
                    self.ik_markers.push(at);
                }
                self.ik_pole_markers.push(pole);
            }
        }
        if let Some(command) = pending
            && let Err(message) = self.apply(command)
        {
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
                    let parsing = self.parsing.first().and_then(|d| d.files.as_ref().ok()).map(|files| {
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

    /// Writes changed state into the element's `data-*` attributes and reports the events
    /// that state implies (`play`, `pause`, `timeupdate`, `load`).
    fn sync_dataset(&mut self) {
        let d = &mut self.dataset;
        d.set(Key::Status, self.status.as_str());
        d.set(Key::Error, &self.last_error);
        let model = self.model.as_ref();
        d.set(Key::Model, model.map_or("", |m| m.name.as_str()));
        d.set(Key::Src, self.shown_url.as_deref().unwrap_or_default());
        d.set(Key::Models, self.library.as_ref().map_or("", |l| l.models_json.as_str()));
        d.set(Key::Clips, model.map_or("[]", |m| m.clips_json.as_str()));
        d.set(Key::Clip, model.map_or("", |m| m.clip_name(m.animator.main().clip)));
        let time_moved = d.set(Key::Time, &model.map_or(String::new(), |m| format!("{:.3}", m.animator.main().time)));
        d.set(Key::Playing, if model.is_some_and(Model::is_playing) { "true" } else { "false" });
        let fade = model.and_then(|m| m.animator.crossfade());
        d.set(Key::Crossfade, &fade.map_or(String::new(), |f| format!("{:.2}", f.weight)));
        d.set(Key::Layer, &model.map_or(String::new(), Model::layer_summary));
        d.set(Key::Skinning, self.skinning.name());
        d.set(Key::SkinningPath, self.scene.skinning_path().name());
        d.set(Key::Heatmap, if self.scene.heatmap() { "true" } else { "false" });
        d.set(Key::Grid, if self.scene.grid() { "true" } else { "false" });
        d.set(Key::Overlays, &overlay_names(self.overlays));
        d.set(Key::Lighting, self.scene.look().lighting.name());
        d.set(
            Key::Ragdoll,
            model.and_then(|m| m.ragdoll.as_ref()).map_or("", crate::ragdoll::RagdollState::state_name),
        );
        d.set(Key::Background, self.scene.look().background.name());
        let progress = self.inbox.progress().filter(|_| self.status == Status::Loading);
        d.set(
            Key::Progress,
            &progress.as_ref().map_or(String::new(), |p| {
                format!("{}/{}", p.received, p.total.map_or(String::new(), |t| t.to_string()))
            }),
        );
        d.set(Key::Joint, &model.and_then(|m| m.selected_joint.map(|j| m.node_name(j))).unwrap_or_default());
        let quality = model.and_then(|m| m.candy.as_ref()).and_then(|c| {
            let i = SkinningMethod::ALL.iter().position(|&m| m == self.skinning)?;
            let q = c.quality[i];
            Some(format!("{:.3},{:.3}", q.radius_kept, q.volume_ratio))
        });
        d.set(Key::Quality, quality.as_deref().unwrap_or(""));
        d.set(Key::Copies, &model.map_or(String::new(), |m| m.copy_count().to_string()));
        d.set(Key::Ik, &model.map_or(String::new(), Model::ik_summary));
        d.set(Key::IkGoals, &model.map_or(String::new(), Model::ik_goals_json));
        d.set(Key::Blend, &model.map_or(String::new(), Model::blend_summary));
        d.set(Key::Morphs, &model.map_or(String::new(), Model::morphs_json));
        let t = &self.transition;
        let transition = format!(
            "{:.3},{},{}",
            t.duration,
            crate::control::easing_name(t.easing),
            crate::control::outgoing_name(t.outgoing)
        );
        d.set(Key::Transition, &transition);
        let markers: Vec<String> = if model.is_some_and(|m| !m.ik.is_empty()) {
            self.ik_markers.iter().map(|p| format!("{:.1},{:.1}", p.x, p.y)).collect()
        } else {
            Vec::new()
        };
        d.set(Key::IkTarget, &markers.join(";"));
        let poles: Vec<String> = if model.is_some_and(|m| !m.ik.is_empty()) {
            self.ik_pole_markers.iter().map(|p| p.map_or(String::new(), |p| format!("{:.1},{:.1}", p.x, p.y))).collect()
        } else {
            Vec::new()
        };
        d.set(Key::IkPole, &poles.join(";"));
        d.set(Key::Speed, &model.map_or(String::new(), |m| format!("{:.3}", m.animator.main().speed)));
        d.set(Key::Duration, &model.map_or(String::new(), |m| format!("{:.3}", m.duration())));
        d.set(Key::Loop, model.map_or("", |m| crate::control::loop_mode_name(m.animator.main().loop_mode)));
        let c = &self.camera;
        let camera = format!(
            "{:.5},{:.5},{:.5},{:.5},{:.5},{:.5}",
            c.yaw, c.pitch, c.distance, c.target.x, c.target.y, c.target.z
        );
        d.set(Key::Camera, &camera);
        d.set(Key::Frames, &self.frames.to_string());

        let playing = model.is_some_and(Model::is_playing);
        if model.is_some() && playing != self.reported_playing {
            self.reported_playing = playing;
            d.host().emit(if playing { "play" } else { "pause" }, "");
        }
        if model.is_some() && time_moved {
            d.host().emit("timeupdate", d.get(Key::Time).unwrap_or(""));
        }
        // model-viewer's `progress`: the download's share (to 0.95; the rest is decoding and the first frame)
        // while a model loads, in steps of at least 1 %, then 1 just before its `load`.
        let download = progress
            .as_ref()
            .and_then(|p| p.total.filter(|&t| t > 0).map(|t| (p.received as f64 / t as f64).min(1.0) * 0.95));
        if let Some(fraction) = download
            && (self.reported_progress < 0.0 || fraction - self.reported_progress >= 0.01)
        {
            self.reported_progress = fraction;
            d.host().emit("progress", &format!("{fraction:.4}"));
        }
        if self.announce_load && self.frames > 0 {
            self.announce_load = false;
            if self.reported_progress < 1.0 {
                d.host().emit("progress", "1");
            }
            // The next load reports from 0 again.
            self.reported_progress = -1.0;
            d.host().emit("load", model.map_or("", |m| m.name.as_str()));
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
        let actions = if self.panels {
            egui::Panel::left("controls")
                .resizable(true)
                .default_size(270.0)
                .show(ui, |ui| ui::side_panel(ui, &state, self.model.as_mut(), &mut self.transition, &mut self.panel))
                .inner
        } else {
            ui::PanelActions::default()
        };
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
