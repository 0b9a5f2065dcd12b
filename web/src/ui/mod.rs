//! The side panel: model, clips with transitions, playback and timeline, clip blending, the
//! layer panel, warnings, stats.
//!
//! The panel changes the animation through [`Command`]s (the same ones the page's JS handle
//! sends) and edits the model's panel drafts ([`Model::layer`], [`Model::blend_weights`])
//! directly, reporting that they changed.

use kloub_core::animator::Crossfade;
use kloub_core::job::dqs::SkinningMethod;

use crate::candy::Sample;
use crate::control::Command;
use crate::model::Model;
use crate::render::SkinningPath;

mod animation;
mod ik;
mod pose;
mod scene;
mod skinning;
mod validation;

use animation::{blend_panel, clips, layer_panel, playback, transition_settings};
use ik::ik_panel;
use scene::{copies_control, joint_panel, morph_panel, outline_panel, ragdoll_panel, view_panel};
use skinning::{candy_panel, examples_panel, skinning_panel};

/// Read-only facts the panel shows.
pub struct PanelState<'a> {
    /// Whether a load is in progress.
    pub loading: bool,
    /// Active backend name.
    pub backend: &'a str,
    /// Smoothed frames per second while animating (`None`: idle, painting only on input).
    pub fps: Option<f32>,
    /// Smoothed CPU time per stage.
    pub stages: StageTimes,
    /// The skinning method.
    pub skinning: SkinningMethod,
    /// Where vertices are deformed.
    pub skinning_path: SkinningPath,
    /// Whether the user chose it (else it is the adapter's default, or the heatmap's).
    pub skinning_path_chosen: bool,
    /// Whether the compute path exists here (not on WebGL2).
    pub compute: bool,
    /// Whether the deviation heatmap is on.
    pub heatmap: bool,
    /// Under spherical joint blending: `(mesh, vertices, vertices falling back to DQS)` per
    /// skinned draw.
    pub sjb_fallbacks: &'a [(usize, usize, usize)],
    /// Models dropped together, to switch between (empty: one model).
    pub library: &'a [String],
    /// Which of [`PanelState::library`] is shown.
    pub library_shown: Option<usize>,
    /// Whether the ground grid is drawn.
    pub grid: bool,
    /// Which overlays are on.
    pub overlays: crate::overlay::Overlays,
    /// Lighting, background, environment, exposure and tone mapping.
    pub look: crate::render::uniforms::Look,
    /// Whether an environment image was given (the environment menu offers it).
    pub has_environment_image: bool,
    /// The environment photograph being fetched to light with (the light changes when it is in).
    pub environment_loading: Option<crate::render::environment::EnvironmentName>,
    /// The sample library of the Samples menu.
    pub samples: &'a [crate::samples::SampleEntry],
    /// Which of [`PanelState::samples`] is shown (its credit is drawn under the model's name).
    pub shown_sample: Option<usize>,
}

pub use crate::stage::StageTimes;

/// Panel state that lives across frames and models.
#[derive(Debug)]
pub struct PanelMemory {
    /// The clip list's filter text.
    pub clip_filter: String,
    /// While the timeline is dragged: whether playback resumes when it is released.
    pub scrub_resume: Option<bool>,
    /// Seconds the ragdoll takes to hand back to the animation.
    pub ragdoll_blend: f32,
    /// The Open menu's URL field.
    pub open_url: String,
}

/// What the user asked for that the panel cannot do itself.
#[derive(Debug, Default, PartialEq)]
pub struct PanelActions {
    /// Frame the camera on the model.
    pub frame: bool,
    /// Animation changes, applied in order after the panel is drawn.
    pub commands: Vec<Command>,
    /// [`Model::layer`] changed: apply it.
    pub layer_changed: bool,
    /// [`Model::blend_weights`] changed: apply them.
    pub blend_changed: bool,
    /// Download the model's `.kloub.json` sidecar.
    pub save_sidecar: bool,
    /// Open the keyboard help.
    pub help: bool,
    /// Ask the page for a file picker (`Some(true)`: a folder picker).
    pub open: Option<bool>,
    /// Run the glTF-Validator on the shown model (the element does).
    pub validate: bool,
}

/// Draws the side panel.
pub fn side_panel(
    ui: &mut egui::Ui,
    state: &PanelState<'_>,
    model: Option<&mut Model>,
    transition: &mut Crossfade,
    memory: &mut PanelMemory,
) -> PanelActions {
    let mut actions = PanelActions::default();
    ui.add_space(6.0);
    ui.horizontal(|ui| {
        ui.heading("Kloub");
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            // Closes on a click outside only: the URL field inside takes clicks and typing.
            let stays_open =
                egui::containers::menu::MenuConfig::new().close_behavior(egui::PopupCloseBehavior::CloseOnClickOutside);
            egui::containers::menu::MenuButton::new("Open").config(stays_open).ui(ui, |ui| {
                if ui.button("Files…").on_hover_text("A .glb, or a .gltf with its .bin and textures").clicked() {
                    actions.open = Some(false);
                    ui.close();
                }
                if ui.button("Folder…").on_hover_text("Every model in a folder, with their files").clicked() {
                    actions.open = Some(true);
                    ui.close();
                }
                ui.separator();
                ui.label("URL (.glb, .gltf or .zip; other origins need CORS):");
                let field = ui.add(
                    egui::TextEdit::singleline(&mut memory.open_url)
                        .hint_text("https://…/model.glb")
                        .desired_width(240.0),
                );
                let entered = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
                let url = memory.open_url.trim().to_owned();
                if (ui.add_enabled(!url.is_empty(), egui::Button::new("Open URL")).clicked() || entered)
                    && !url.is_empty()
                {
                    actions.commands.push(Command::LoadUrl(url));
                    ui.close();
                }
            });
            ui.menu_button("Samples", |ui| {
                for (i, sample) in state.samples.iter().enumerate() {
                    let shown = state.shown_sample == Some(i);
                    if ui.selectable_label(shown, &sample.name).on_hover_text(sample.summary()).clicked() {
                        actions.commands.push(Command::LoadUrl(sample.load_url()));
                        ui.close();
                    }
                }
                if !state.samples.is_empty() {
                    ui.separator();
                }
                for sample in Sample::ALL {
                    if ui.button(sample.label()).clicked() {
                        actions.commands.push(Command::LoadSample(sample));
                        ui.close();
                    }
                }
            });
        });
    });
    ui.horizontal(|ui| {
        match &model {
            Some(model) => ui.strong(&model.name),
            None => ui.weak("no model"),
        };
        if state.loading {
            ui.spinner();
        }
    });
    if let Some(sample) = state.shown_sample.and_then(|i| state.samples.get(i))
        && !sample.attribution.is_empty()
    {
        let credit = ui.add(egui::Label::new(egui::RichText::new(&sample.attribution).small().weak()).wrap());
        if !sample.licence.is_empty() {
            credit.on_hover_text(&sample.licence);
        }
    }
    if state.library.len() > 1 {
        egui::CollapsingHeader::new(format!("Models ({})", state.library.len()))
            .id_salt("library")
            .default_open(true)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().id_salt("library list").max_height(160.0).show(ui, |ui| {
                    for (i, name) in state.library.iter().enumerate() {
                        let label = crate::load::base_name(name);
                        if ui.selectable_label(state.library_shown == Some(i), label).on_hover_text(name).clicked() {
                            actions.commands.push(Command::ShowModel(i));
                        }
                    }
                });
            });
    }
    if let Some(model) = &model {
        section(ui, "Validation", |ui| validation::validation_panel(ui, model, &mut actions));
    }
    ui.separator();

    if let Some(model) = model {
        egui::ScrollArea::vertical().id_salt("panel").auto_shrink([false, true]).show(ui, |ui| {
            if model.asset.skins.iter().any(|s| !s.joints.is_empty()) {
                section(ui, "Pose", |ui| pose::pose_panel(ui, model, &mut actions));
                ui.separator();
            }
            if !model.clip_names.is_empty() {
                section(ui, "Clips", |ui| clips(ui, model, transition, memory, &mut actions));
                ui.separator();
                section(ui, "Playback", |ui| playback(ui, model, memory, &mut actions));
                ui.separator();
                section(ui, "Transition", |ui| transition_settings(ui, model, transition));
                if model.clip_names.len() > 1 {
                    section(ui, "Blend", |ui| blend_panel(ui, model, &mut actions));
                }
                section(ui, "Layer", |ui| layer_panel(ui, model, &mut actions));
                ui.separator();
            }
            if let Some(candy) = &model.candy {
                section(ui, "Candy wrapper", |ui| candy_panel(ui, candy, state.skinning, &mut actions));
                ui.separator();
            }
            if model.asset.skins.iter().any(|s| !s.joints.is_empty()) {
                section(ui, "Skinning", |ui| {
                    skinning_panel(ui, state, &mut actions);
                    examples_panel(ui, model, state.skinning, &mut actions);
                });
                ui.separator();
            }
            section(ui, "IK", |ui| ik_panel(ui, model, &mut actions));
            if model.asset.skins.iter().any(|s| !s.joints.is_empty()) {
                section(ui, "Ragdoll", |ui| ragdoll_panel(ui, model, state, memory, &mut actions));
            }
            section(ui, "Copies", |ui| copies_control(ui, model, &mut actions));
            morph_panel(ui, model);
            outline_panel(ui, model, &mut actions);
            section(ui, "View", |ui| view_panel(ui, state, &mut actions));
            joint_panel(ui, model, memory, &mut actions);
            warnings(ui, model);
            ui.separator();
            section(ui, "Statistics", |ui| stats(ui, state));
        });
    } else {
        stats(ui, state);
    }
    actions
}

impl Default for PanelMemory {
    fn default() -> Self {
        Self { clip_filter: String::new(), scrub_resume: None, ragdoll_blend: 0.5, open_url: String::new() }
    }
}

fn stats(ui: &mut egui::Ui, state: &PanelState<'_>) {
    egui::Grid::new("stats").num_columns(2).show(ui, |ui| {
        ui.label("Backend");
        ui.monospace(state.backend);
        ui.end_row();
        ui.label("FPS");
        match state.fps {
            Some(fps) => ui.monospace(format!("{fps:.0}  ({:.1} ms)", 1000.0 / fps.max(1e-3))),
            None => ui.weak("idle"),
        };
        ui.end_row();
        let s = state.stages;
        for (name, ms, hint) in [
            ("animate", s.animate, "Sample, blend, world matrices and skin palettes (all copies)"),
            ("CPU skin", s.cpu_skin, "Morphing and skinning on the CPU"),
            ("upload", s.upload, "Palettes, uniforms and CPU-deformed vertices written to the GPU"),
            ("draw", s.draw, "Recording and submitting the render pass"),
        ] {
            ui.label(name).on_hover_text(hint);
            ui.monospace(format!("{ms:.3} ms"));
            ui.end_row();
        }
    });
    ui.separator();
    ui.weak("Drop a .glb (or a .gltf with its .bin and textures) onto the page to open it.");
    ui.weak("Drag: orbit · right/middle or shift-drag: pan · scroll: zoom.");
}

fn warnings(ui: &mut egui::Ui, model: &Model) {
    if model.warnings.is_empty() {
        return;
    }
    egui::CollapsingHeader::new(format!("Import warnings ({})", model.warnings.len())).id_salt("warnings").show(
        ui,
        |ui| {
            egui::ScrollArea::vertical().id_salt("warning-list").max_height(200.0).show(ui, |ui| {
                for warning in &model.warnings {
                    ui.label(warning.to_string());
                }
            });
        },
    );
}

/// A section of the panel, one named group for assistive technology (its controls are read
/// as "Playback", "Skinning", … ).
fn section<R>(ui: &mut egui::Ui, name: &str, add: impl FnOnce(&mut egui::Ui) -> R) -> R {
    let builder = egui::UiBuilder::new().accessibility_role(egui::accesskit::Role::Group).accessibility_label(name);
    ui.scope_builder(builder, add).inner
}

/// A combo box named for assistive technology (its label sits beside it, or is implied), and
/// whether its list is open.
fn named_combo<R>(shown: &egui::InnerResponse<Option<R>>, name: &str) {
    let open = shown.inner.is_some();
    shown.response.ctx.accesskit_node_builder(shown.response.id, |node| {
        node.set_label(name);
        node.set_expanded(open);
    });
}

/// A row of radio buttons, one named radio group for assistive technology.
fn radio_row<R>(ui: &mut egui::Ui, name: &str, add: impl FnOnce(&mut egui::Ui) -> R) -> R {
    ui.horizontal(|ui| {
        let builder =
            egui::UiBuilder::new().accessibility_role(egui::accesskit::Role::RadioGroup).accessibility_label(name);
        ui.scope_builder(builder, add).inner
    })
    .inner
}

/// `fg` (egui's premultiplied colour, possibly translucent) as drawn over the opaque `bg`.
pub fn over(fg: egui::Color32, bg: egui::Color32) -> egui::Color32 {
    let a = 1.0 - f32::from(fg.a()) / 255.0;
    let mix = |f: u8, b: u8| (f32::from(f) + f32::from(b) * a).round().clamp(0.0, 255.0) as u8;
    egui::Color32::from_rgb(mix(fg.r(), bg.r()), mix(fg.g(), bg.g()), mix(fg.b(), bg.b()))
}

/// WCAG 2.1 contrast ratio of two colours (1 to 21).
pub fn contrast(a: egui::Color32, b: egui::Color32) -> f32 {
    let luminance = |c: egui::Color32| {
        let channel = |v: u8| {
            let v = f32::from(v) / 255.0;
            if v <= 0.040_45 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
        };
        0.2126 * channel(c.r()) + 0.7152 * channel(c.g()) + 0.0722 * channel(c.b())
    };
    let (la, lb) = (luminance(a), luminance(b));
    (la.max(lb) + 0.05) / (la.min(lb) + 0.05)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_panels_text_has_at_least_wcag_aa_contrast_in_both_themes() {
        assert!((contrast(egui::Color32::BLACK, egui::Color32::WHITE) - 21.0).abs() < 0.01);
        for theme in [egui::Theme::Dark, egui::Theme::Light] {
            let ctx = egui::Context::default();
            crate::app::style_panels(&ctx);
            let style = ctx.style_of(theme);
            let v = &style.visuals;
            let mut pairs = vec![
                ("text on the panel", v.text_color(), v.panel_fill),
                ("weak text on the panel", v.weak_text_color(), v.panel_fill),
                ("strong text on the panel", v.strong_text_color(), v.panel_fill),
                ("text in a popup", v.text_color(), v.window_fill),
                ("text in a field", v.text_color(), v.extreme_bg_color),
                ("selected text", v.selection.stroke.color, v.selection.bg_fill),
            ];
            for (state, w) in [
                ("inactive", &v.widgets.inactive),
                ("hovered", &v.widgets.hovered),
                ("active", &v.widgets.active),
                ("open", &v.widgets.open),
            ] {
                pairs.push((state, w.fg_stroke.color, w.weak_bg_fill));
            }
            for (what, fg, bg) in pairs {
                let ratio = contrast(over(fg, bg), bg);
                assert!(ratio >= 4.5, "{theme:?}: {what}: {fg:?} on {bg:?} is {ratio:.2}:1, below 4.5:1");
            }
        }
    }
}
