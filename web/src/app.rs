//! The viewer app: loads models, plays their clips, draws them with
//! [`crate::render::SceneRenderer`] into a texture shown in the central panel, and mirrors its
//! state into the page ([`crate::dom`]).

use egui::{Color32, Pos2, Rect, Sense};
use glam::Vec3;
use kloub_core::player::Player;
use kloub_core::{Asset, Instance, Warning};

use crate::backend::backend_name;
use crate::dom::{Dataset, Key};
use crate::load::{self, Inbox, LoadedModel};
use crate::render::{Camera, SceneRenderer, msaa_samples};
use crate::ui;

/// What to do at start-up.
#[derive(Clone, Debug, Default)]
pub struct AppConfig {
    /// Model fetched and shown on start (the page contract: `/models/default.glb`).
    pub model_url: Option<String>,
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

/// A model being shown: the immutable asset and its per-frame evaluation state.
pub struct Model {
    /// Display name (the file name).
    pub name: String,
    /// The imported asset.
    pub asset: Asset,
    /// Pose, world matrices and palettes, evaluated every frame.
    pub instance: Instance,
    /// Import warnings.
    pub warnings: Vec<Warning>,
    /// Clip display names, by clip index.
    pub clip_names: Vec<String>,
    /// `clip_names` as a JSON array (for `dataset.clips`).
    pub clips_json: String,
}

/// Frames sampled across a clip to frame the camera on the animated (skinned) bounds.
const FIT_SAMPLES: u32 = 8;

impl Model {
    /// Wraps a loaded model and evaluates it once at `clip`, time 0.
    ///
    /// # Errors
    /// The evaluation error (an asset the jobs reject).
    pub fn new(loaded: LoadedModel, clip: Option<usize>) -> Result<Self, String> {
        let LoadedModel { name, asset, warnings } = loaded;
        let mut instance = Instance::new(&asset);
        instance.evaluate(&asset, clip, 0.0).map_err(|e| format!("{name}: {e}"))?;
        let clip_names: Vec<String> =
            asset.clips.iter().enumerate().map(|(i, c)| c.display_name(i)).collect();
        let clips_json = serde_json::to_string(&clip_names).map_err(|e| e.to_string())?;
        Ok(Self { name, asset, instance, warnings, clip_names, clips_json })
    }

    /// World bounds of the drawable meshes over `clip` (sampled at a few times, skinning
    /// included), or of the rest pose without a clip. Leaves the instance evaluated at
    /// `time`. `None` when nothing is drawable.
    pub fn animated_bounds(&mut self, clip: Option<usize>, time: f32) -> Option<(Vec3, Vec3)> {
        let duration = clip.and_then(|c| self.asset.clips.get(c)).map_or(0.0, |c| c.duration);
        let samples = if duration > 0.0 { FIT_SAMPLES } else { 1 };
        let mut bounds: Option<(Vec3, Vec3)> = None;
        for i in 0..samples {
            let t = duration * i as f32 / samples as f32;
            if self.instance.evaluate(&self.asset, clip, t).is_err() {
                continue;
            }
            if let Some((lo, hi)) = self.instance.scene_bounds(&self.asset) {
                bounds = Some(bounds.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
            }
        }
        // The same evaluation succeeded in `Model::new`; a failure here only leaves the
        // last sampled pose, which the next frame overwrites.
        let _ = self.instance.evaluate(&self.asset, clip, time);
        bounds
    }

    /// Display name of `clip`, `""` for the rest pose.
    pub fn clip_name(&self, clip: Option<usize>) -> &str {
        clip.and_then(|c| self.clip_names.get(c)).map_or("", String::as_str)
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

/// The eframe app.
pub struct App {
    gpu: egui_wgpu::RenderState,
    backend: &'static str,
    scene: SceneRenderer,
    camera: Camera,
    model: Option<Model>,
    player: Player,
    inbox: Inbox,
    pending: usize,
    status: Status,
    last_error: String,
    error_window: Option<String>,
    viewport: Option<ViewportTexture>,
    dataset: Dataset,
    frames: u64,
    fps: Fps,
}

/// The largest frame step the clock takes (a background tab resumes without a jump).
const MAX_DT: f32 = 0.25;

impl App {
    /// Creates the app on eframe's wgpu device and starts fetching `config.model_url`.
    ///
    /// # Errors
    /// When eframe was started without the wgpu renderer.
    pub fn new(cc: &eframe::CreationContext<'_>, config: AppConfig) -> Result<Self, String> {
        let gpu = cc.wgpu_render_state.clone().ok_or("eframe was started without the wgpu renderer")?;
        let backend = backend_name(gpu.adapter.get_info().backend);
        log::info!("kloub: rendering with {backend} ({:?})", gpu.adapter.get_info().name);
        let scene = SceneRenderer::new(&gpu.device, &gpu.queue, msaa_samples(&gpu.adapter));
        let mut app = Self {
            gpu,
            backend,
            scene,
            camera: Camera::default(),
            model: None,
            player: Player::new(),
            inbox: Inbox::default(),
            pending: 0,
            status: Status::Ready,
            last_error: String::new(),
            error_window: None,
            viewport: None,
            dataset: Dataset::default(),
            frames: 0,
            fps: Fps::default(),
        };
        app.dataset.set(Key::Backend, backend);
        if let Some(url) = config.model_url {
            app.pending += 1;
            app.status = Status::Loading;
            load::fetch_into(url, app.inbox.clone(), cc.egui_ctx.clone());
        }
        app.sync_dataset();
        Ok(app)
    }

    /// The values last mirrored into `document.body.dataset` (kept natively too, for tests).
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

    /// The playback clock.
    pub fn player(&self) -> &Player {
        &self.player
    }

    /// Imports and installs every delivery that arrived since the last frame.
    fn receive(&mut self) {
        for delivery in self.inbox.take() {
            self.pending = self.pending.saturating_sub(1);
            let result = delivery.files.and_then(load::import_files).and_then(|m| self.install(m));
            match result {
                Ok(()) => {
                    self.status = Status::Ready;
                    self.last_error.clear();
                    self.error_window = None;
                }
                Err(message) => self.fail(message),
            }
        }
        if self.pending > 0 {
            self.status = Status::Loading;
        }
    }

    /// Makes `loaded` the shown model, playing its first clip; on error nothing changes.
    fn install(&mut self, loaded: LoadedModel) -> Result<(), String> {
        let clip = if loaded.asset.clips.is_empty() { None } else { Some(0) };
        let mut model = Model::new(loaded, clip)?;
        let bounds = model.animated_bounds(clip, 0.0);
        self.scene
            .set_asset(&self.gpu.device, &self.gpu.queue, &model.asset)
            .map_err(|e| format!("{}: {e}", model.name))?;
        if let Some((min, max)) = bounds {
            self.camera.frame_to_fit(min, max);
        }
        log::info!("kloub: showing {} ({} clips, {} warnings)", model.name, model.clip_names.len(), model.warnings.len());
        self.player.set_clip(clip);
        self.player.playing = true;
        self.model = Some(model);
        Ok(())
    }

    fn fail(&mut self, message: String) {
        log::warn!("kloub: {message}");
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

    /// Advances the clock and evaluates the pose for this frame.
    fn evaluate(&mut self) {
        let Some(model) = &mut self.model else { return };
        if let Err(e) = model.instance.evaluate(&model.asset, self.player.clip, self.player.time) {
            // Fall back to the rest pose so the error is reported once, not every frame.
            let message = format!("{}: cannot play {:?}: {e}", model.name, model.clip_name(self.player.clip));
            self.player.set_clip(None);
            self.fail(message);
        }
    }

    /// Draws the 3D viewport into `ui` and handles camera input.
    fn viewport(&mut self, ui: &mut egui::Ui) {
        let (rect, response) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
        let viewport = format!("{},{},{},{}", rect.min.x, rect.min.y, rect.width(), rect.height());
        self.dataset.set(Key::Viewport, &viewport);
        let height = rect.height();
        let delta = response.drag_delta();
        let shift = ui.input(|i| i.modifiers.shift);
        if response.dragged_by(egui::PointerButton::Primary) && !shift {
            self.camera.orbit_pixels(delta.x, delta.y, height);
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
            || (response.dragged_by(egui::PointerButton::Primary) && shift)
        {
            self.camera.pan_pixels(delta.x, delta.y, height);
        }
        if response.hovered() {
            let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta.y, i.zoom_delta()));
            if scroll != 0.0 {
                self.camera.zoom_scroll(scroll);
            }
            if zoom != 1.0 {
                self.camera.zoom(1.0 / zoom);
            }
        }
        if response.double_clicked() {
            self.frame_model();
        }

        let Some(model) = &mut self.model else {
            ui.painter().rect_filled(rect, 0.0, ui.visuals().extreme_bg_color);
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "Drop a .glb or .gltf file here",
                egui::FontId::proportional(18.0),
                ui.visuals().weak_text_color(),
            );
            return;
        };
        let ppp = ui.ctx().pixels_per_point();
        let size = [(rect.width() * ppp).round() as u32, (rect.height() * ppp).round() as u32];
        let gpu = &self.gpu;
        let rendered =
            self.scene.render(&gpu.device, &gpu.queue, &model.asset, &mut model.instance, &self.camera, size);
        let view = match rendered {
            // A cheap handle clone, so the renderer can be asked for its target version.
            Ok(view) => view.clone(),
            Err(e) => {
                // Unreachable with an asset the renderer accepted; drop it rather than fail every frame.
                let message = format!("{}: cannot draw: {e}", model.name);
                self.model = None;
                self.scene.clear_asset();
                self.fail(message);
                return;
            }
        };
        let version = self.scene.target_version();
        let mut renderer = gpu.renderer.write();
        let id = match &mut self.viewport {
            Some(texture) if texture.version == version => texture.id,
            Some(texture) => {
                renderer.update_egui_texture_from_wgpu_texture(&gpu.device, &view, wgpu::FilterMode::Linear, texture.id);
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

    /// Frames the camera on the current model's animated bounds.
    fn frame_model(&mut self) {
        let Some(model) = &mut self.model else { return };
        if let Some((min, max)) = model.animated_bounds(self.player.clip, self.player.time) {
            self.camera.frame_to_fit(min, max);
        }
    }

    /// A full-window hint while files are dragged over the page.
    fn drop_hint(ctx: &egui::Context) {
        if ctx.input(|i| i.raw.hovered_files.is_empty()) {
            return;
        }
        let painter = ctx.layer_painter(egui::LayerId::new(egui::Order::Foreground, egui::Id::unique("kloub-drop-hint")));
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

    /// Writes changed state into `document.body.dataset`.
    fn sync_dataset(&mut self) {
        let d = &mut self.dataset;
        d.set(Key::Status, self.status.as_str());
        d.set(Key::Error, &self.last_error);
        let model = self.model.as_ref();
        d.set(Key::Model, model.map_or("", |m| m.name.as_str()));
        d.set(Key::Clips, model.map_or("[]", |m| m.clips_json.as_str()));
        d.set(Key::Clip, model.map_or("", |m| m.clip_name(self.player.clip)));
        d.set(Key::Frames, &self.frames.to_string());
    }
}

impl eframe::App for App {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.receive();
        self.take_drops(&ctx);
        // egui may run extra layout passes for one painted frame: the clock moves once.
        if ctx.current_pass_index() == 0 {
            let (stable_dt, unstable_dt) = ctx.input(|i| (i.stable_dt, i.unstable_dt));
            self.fps.update(unstable_dt);
            if let Some(model) = &self.model {
                self.player.advance(&model.asset, stable_dt.clamp(0.0, MAX_DT));
            }
        }

        let panel = ui::PanelState {
            model: self.model.as_ref(),
            loading: self.status == Status::Loading,
            backend: self.backend,
            fps: self.fps.fps(),
        };
        let actions = egui::Panel::left("controls")
            .resizable(true)
            .default_size(250.0)
            .show(ui, |ui| ui::side_panel(ui, &panel, &mut self.player))
            .inner;
        if actions.frame {
            self.frame_model();
        }

        self.evaluate();
        egui::CentralPanel::no_frame().show(ui, |ui| self.viewport(ui));
        Self::drop_hint(&ctx);
        self.error_window(&ctx);

        if !ctx.will_discard() {
            self.frames += 1;
        }
        self.sync_dataset();
        if self.player.playing && self.player.clip.is_some() {
            ctx.request_repaint();
        }
    }
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
