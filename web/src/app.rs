//! The full viewer app: the [`Stage`] (models, clips, camera, the scene renderer, the page's
//! state mirror) with egui's side panel, menus, notes, overlays and IK handles. In the browser
//! the scene is drawn straight into the canvas (see [`Stage::set_direct`]); natively into a
//! texture shown in the central panel. The shown model's state is [`crate::model::Model`].

use egui::{Color32, Pos2, Rect, Sense};
use glam::Vec3;

use crate::control::{Command, Controls, Wake};
use crate::dom::{Dataset, Key};
use crate::ik::IkState;
use crate::load;
use crate::model::Model;
use crate::overlay::{self, OverlayScratch, Projection, nearest_within};
use crate::stage::{Graphics, Shortcut, Stage, Status};
use crate::ui;

pub use crate::stage::{AppConfig, DEFAULT_CROSSFADE};

mod posing;
mod viewport;
mod world;

use viewport::IkHandle;

/// The egui texture showing the scene renderer's output, and the renderer's
/// [`SceneRenderer::target_version`] it was registered for.
struct ViewportTexture {
    id: egui::TextureId,
    version: u64,
}

/// The eframe app: the stage and the panels around it.
pub struct App {
    /// The viewer without its panels.
    pub(crate) stage: Stage,
    gpu: egui_wgpu::RenderState,
    /// Panel state that outlives a model (filter text, scrubbing).
    panel: ui::PanelMemory,
    viewport: Option<ViewportTexture>,
    /// The IK goal whose target is being dragged in the viewport.
    ik_drag: Option<IkHandle>,
    /// On a narrow element (below [`NARROW`] points) the panel is a sheet over the view: open or not.
    sheet_open: bool,
    overlay_scratch: OverlayScratch,
    /// The keyboard-shortcut help window is open.
    help: bool,
    /// Where each IK target was drawn last frame, in points (for `dataset.ikTarget`).
    ik_markers: Vec<Pos2>,
    /// Where each goal's pole marker was painted (`None`: no pole).
    ik_pole_markers: Vec<Option<Pos2>>,
    /// The obstacle being dragged over the floor.
    obstacle_drag: Option<usize>,
    /// Where each obstacle's centre was drawn last frame.
    obstacle_marks: Vec<Option<Pos2>>,
    /// The gizmo ring being dragged in pose mode.
    gizmo_drag: Option<posing::GizmoDrag>,
    /// Where the gizmo's rings could be grabbed last frame (X, Y, Z; none while sculpting),
    /// and its joint.
    gizmo_handles: Option<(Option<[Pos2; 3]>, Pos2)>,
    /// A sculpt stroke under way: the pointer at the last dab, that dab's centre (model
    /// space) and its depth.
    sculpt_stroke: Option<(Pos2, Vec3, f32)>,
    /// The sculpt brush's last hover: the pointer, view and shape it was cast for, and the hit.
    sculpt_hover: posing::SculptHover,
}

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

/// Below this width (points: CSS pixels) the side panel is a sheet opened over the view: phones
/// (360–430 wide upright) and narrow embeds; from a small tablet or laptop window up, a side panel.
const NARROW: f32 = 600.0;

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
        install_fonts(ctx);
        style_panels(ctx);
        let stage = Stage::new(Graphics::from(&gpu), config, Wake::egui(ctx));
        Self {
            stage,
            gpu,
            panel: ui::PanelMemory::default(),
            viewport: None,
            ik_drag: None,
            gizmo_drag: None,
            obstacle_drag: None,
            obstacle_marks: Vec::new(),
            gizmo_handles: None,
            sculpt_stroke: None,
            sculpt_hover: posing::SculptHover::default(),
            sheet_open: false,
            overlay_scratch: OverlayScratch::default(),
            help: false,
            ik_markers: Vec::new(),
            ik_pole_markers: Vec::new(),
        }
    }

    /// Moves the viewer to a new device (the old one was lost): see [`Stage::replace_gpu`].
    ///
    /// # Errors
    /// When the model cannot be uploaded to the new device.
    pub fn replace_gpu(&mut self, gpu: egui_wgpu::RenderState, share: Option<u32>) -> Result<(), String> {
        self.viewport = None;
        let result = self.stage.replace_gpu(Graphics::from(&gpu), share);
        self.gpu = gpu;
        result
    }

    /// Wakes `ctx` (instead of the previous context) when a command arrives, after the
    /// viewer moved to a new egui context (the status is written again: [`Stage::replace_gpu`]).
    pub fn set_context(&mut self, ctx: &egui::Context) {
        self.stage.controls.set_repaint(Wake::egui(ctx));
        ctx.request_repaint();
    }

    /// The viewer without its panels.
    pub fn stage(&self) -> &Stage {
        &self.stage
    }

    /// The viewer without its panels, to change.
    pub fn stage_mut(&mut self) -> &mut Stage {
        &mut self.stage
    }

    /// See [`Stage::dataset`].
    pub fn dataset(&self) -> &Dataset {
        self.stage.dataset()
    }

    /// See [`Stage::error_message`].
    pub fn error_message(&self) -> Option<&str> {
        self.stage.error_message()
    }

    /// See [`Stage::model`].
    pub fn model(&self) -> Option<&Model> {
        self.stage.model()
    }

    /// See [`Stage::controls`].
    pub fn controls(&self) -> &Controls {
        self.stage.controls()
    }

    /// `data-ik-target` and `data-ik-pole`: where the IK handles were painted.
    fn sync_ik_markers(&mut self) {
        let has_ik = self.stage.model.as_ref().is_some_and(|m| !m.ik.is_empty());
        let markers: Vec<String> = if has_ik {
            self.ik_markers.iter().map(|p| format!("{:.1},{:.1}", p.x, p.y)).collect()
        } else {
            Vec::new()
        };
        self.stage.dataset.set(Key::IkTarget, &markers.join(";"));
        let poles: Vec<String> = if has_ik {
            self.ik_pole_markers.iter().map(|p| p.map_or(String::new(), |p| format!("{:.1},{:.1}", p.x, p.y))).collect()
        } else {
            Vec::new()
        };
        self.stage.dataset.set(Key::IkPole, &poles.join(";"));
    }

    /// See [`Stage::last_screenshot`].
    pub fn last_screenshot(&self) -> Option<&[u8]> {
        self.stage.last_screenshot()
    }

    /// Starts reading files dropped on the page this frame.
    fn take_drops(&mut self, ctx: &egui::Context) {
        let dropped = ctx.input(|i| i.raw.dropped_files.clone());
        if !dropped.is_empty() {
            self.stage.pending += 1;
            self.stage.status = Status::Loading;
            load::read_dropped_into(dropped, self.stage.inbox.clone(), Wake::egui(ctx));
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
        let presses: Vec<(K, bool)> = ctx.input(|i| {
            i.events
                .iter()
                .filter_map(|e| match e {
                    egui::Event::Key { key, pressed: true, modifiers, .. } => Some((*key, modifiers.shift)),
                    _ => None,
                })
                .collect()
        });
        for (key, shift) in presses {
            match (key, shift) {
                (K::Questionmark, _) | (K::H, false) => self.help = !self.help,
                (K::Escape, false) => self.help = false,
                _ => {
                    if let Some(shortcut) = Shortcut::from_key(key.name(), shift) {
                        self.stage.shortcut(shortcut);
                    }
                }
            }
        }
    }

    /// While a model downloads: its name and a progress bar over the top of the viewport.
    fn loading_bar(&self, ctx: &egui::Context) {
        if self.stage.status != Status::Loading {
            return;
        }
        let progress = self.stage.inbox.progress();
        let rect = self.stage.view_rect;
        egui::Area::new(egui::Id::unique("kloub-loading-bar"))
            .order(egui::Order::Foreground)
            .fixed_pos(egui::pos2(rect.center().x - 160.0, rect.top() + 12.0))
            .interactable(false)
            .show(ctx, |ui| {
                egui::Frame::popup(ui.style()).show(ui, |ui| {
                    ui.set_width(320.0);
                    let mb = |b: u64| b as f64 / 1_048_576.0;
                    let parsing = self.stage.parsing.first().map(load::Delivery::contents).map(|files| {
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
        let Some(message) = &self.stage.error_window else { return };
        let mut open = true;
        let mut dismissed = false;
        egui::Window::new("Could not open the model")
            .open(&mut open)
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_TOP, [0.0, 24.0])
            .show(ctx, |ui| {
                ui.label(message.as_str());
                if self.stage.model.is_some() {
                    ui.weak("The previous model is still shown.");
                }
                dismissed = ui.button("Dismiss").clicked();
            });
        if !open || dismissed {
            self.stage.error_window = None;
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
        if !(self.stage.view_rect.width() > 0.0 && self.stage.view_rect.height() > 0.0) {
            self.stage.view_rect = ui.max_rect();
        }
        self.stage.receive();
        self.take_drops(&ctx);
        // egui may run extra layout passes for one painted frame: the clock moves once.
        if ctx.current_pass_index() == 0 {
            let (stable_dt, unstable_dt) = ctx.input(|i| (i.stable_dt, i.unstable_dt));
            self.stage.tick(stable_dt, unstable_dt);
        }

        // Frames are painted on demand: a rate means something only while the model moves.
        let animating = self.stage.model.as_ref().is_some_and(Model::is_animating);
        let sjb_fallbacks = match &self.stage.model {
            Some(model) if self.stage.skinning.uses_sjb_plan() => {
                // Written on the first frame that skins with SJB: counted from the moment it is chosen.
                self.stage.scene.write_sjb_pivots(&self.stage.gpu.queue, &model.asset);
                self.stage.scene.sjb_fallbacks()
            }
            _ => Vec::new(),
        };
        let state = ui::PanelState {
            loading: self.stage.status == Status::Loading,
            backend: self.stage.backend,
            fps: animating.then(|| self.stage.fps.fps()),
            stages: self.stage.stages,
            skinning: self.stage.skinning,
            skinning_path: self.stage.scene.skinning_path(),
            skinning_path_chosen: self.stage.scene.chosen_skinning_path().is_some(),
            compute: self.stage.scene.supports_compute(),
            heatmap: self.stage.scene.heatmap(),
            sjb_fallbacks: &sjb_fallbacks,
            library: self.stage.library.as_ref().map_or(&[], |l| l.models.as_slice()),
            grid: self.stage.scene.grid(),
            overlays: self.stage.overlays,
            look: self.stage.scene.look(),
            has_environment_image: self.stage.scene.has_environment_image(),
            environment_loading: self.stage.environment_wanted,
            library_shown: self.stage.library.as_ref().and_then(|l| l.shown),
            samples: &self.stage.samples,
            shown_sample: self
                .stage
                .shown_url
                .as_deref()
                .and_then(|url| self.stage.samples.iter().position(|s| s.is_shown_from(url))),
        };
        // A phone's width: the panel becomes a sheet the user opens over the full-width view.
        let narrow = ui.available_width() < NARROW;
        let actions = if !self.stage.panels {
            ui::PanelActions::default()
        } else if !narrow {
            egui::Panel::left("controls")
                .resizable(true)
                .default_size(270.0)
                .show(ui, |ui| {
                    ui::side_panel(ui, &state, self.stage.model.as_mut(), &mut self.stage.transition, &mut self.panel)
                })
                .inner
        } else if self.sheet_open {
            let screen = ui.max_rect();
            let width = (screen.width() - 40.0).clamp(200.0, 360.0);
            let (model, transition, memory) = (self.stage.model.as_mut(), &mut self.stage.transition, &mut self.panel);
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
        let panel = match (self.stage.panels, narrow, self.sheet_open) {
            (false, ..) => "",
            (true, false, _) => "side",
            (true, true, true) => "open",
            (true, true, false) => "closed",
        };
        self.stage.dataset.set(Key::Panel, panel);
        if actions.frame {
            self.stage.frame_model();
        }
        self.help |= actions.help;
        if let Some(folder) = actions.open {
            // The element opens its file input (the click is still the user's gesture).
            self.stage.dataset.host().emit("kloub:open", if folder { "folder" } else { "files" });
        }
        if actions.validate
            && let Some(model) = &mut self.stage.model
        {
            // The element runs the validator and answers with setValidation.
            model.validating = true;
            model.validation = None;
            self.stage.dataset.host().emit("kloub:validate", "");
        }
        self.stage.finish_screenshot();
        if actions.save_sidecar
            && let Some(model) = &self.stage.model
        {
            let stem = model.name.rsplit_once('.').map_or(model.name.as_str(), |(stem, _)| stem);
            let text = model.sidecar_json();
            if let Err(message) =
                crate::dom::download(&format!("{stem}.kloub.json"), text.as_bytes(), "application/json")
            {
                self.stage.fail(message);
            }
        }
        for command in actions.commands {
            if let Err(message) = self.stage.apply(command) {
                self.stage.fail(message);
            }
        }
        if let Some(model) = &mut self.stage.model {
            let result = if actions.layer_changed { model.sync_layer() } else { Ok(()) };
            let result = result.and_then(|()| if actions.blend_changed { model.apply_blend() } else { Ok(()) });
            if actions.layer_changed || actions.blend_changed {
                model.sync_copies();
            }
            if let Err(message) = result {
                self.stage.fail(message);
            }
        }

        if ctx.current_pass_index() == 0 {
            self.shortcuts(&ctx);
        }
        self.stage.evaluate();
        egui::CentralPanel::no_frame().show(ui, |ui| self.viewport(ui));
        self.loading_bar(&ctx);
        self.help_window(&ctx);
        Self::drop_hint(&ctx, self.stage.drop_hint);
        self.error_window(&ctx);

        if !ctx.will_discard() {
            self.stage.frames += 1;
        }
        self.stage.sync_dataset();
        self.sync_ik_markers();
        if self.stage.model.as_ref().is_some_and(|m| m.is_animating() || m.ragdoll_moving()) {
            ctx.request_repaint();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn egui_key_names_reach_the_shared_shortcuts() {
        use egui::Key as K;
        let cases = [
            (K::Space, false, Some(Shortcut::PlayPause)),
            (K::Plus, true, Some(Shortcut::Zoom(1))),
            (K::Equals, false, Some(Shortcut::Zoom(1))),
            (K::Minus, false, Some(Shortcut::Zoom(-1))),
            (K::F, false, Some(Shortcut::Frame)),
            (K::ArrowLeft, true, Some(Shortcut::Orbit(1, 0))),
            (K::Home, false, Some(Shortcut::Start)),
            (K::F, true, None),
            (K::Q, false, None),
        ];
        for (key, shift, want) in cases {
            assert_eq!(Shortcut::from_key(key.name(), shift), want, "{key:?} shift {shift}");
        }
    }
}
