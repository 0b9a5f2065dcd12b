//! The side panel: model, clips with transitions, playback and timeline, clip blending, the
//! layer panel, warnings, stats.
//!
//! The panel changes the animation through [`Command`]s (the same ones the page's JS handle
//! sends) and edits the model's panel drafts ([`Model::layer`], [`Model::blend_weights`])
//! directly, reporting that they changed.

use egui::{Color32, Sense, Stroke, pos2, vec2};
use glam::Vec3;
use kloub_core::animator::{Crossfade, Easing, Outgoing};
use kloub_core::asset::NodeIndex;
use kloub_core::clip::ChannelTarget;
use kloub_core::job::dqs::SkinningMethod;
use kloub_core::job::ik::{IkSolver, JointLimit};
use kloub_core::job::sample::{RotationLerp, sample_channel};
use kloub_core::player::LoopMode;

use crate::candy::{CandyPanel, Sample, TABLE_BENDS};
use crate::control::Command;
use crate::model::{MAX_COPIES, Model};
use crate::render::SkinningPath;

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
    /// Lighting and background.
    pub look: crate::render::uniforms::Look,
    /// The sample library of the Samples menu.
    pub samples: &'a [crate::samples::SampleEntry],
    /// Which of [`PanelState::samples`] is shown (its credit is drawn under the model's name).
    pub shown_sample: Option<usize>,
}

/// Smoothed CPU milliseconds per frame of each stage (the GPU's own time is not included).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
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
}

/// Clip lists longer than this get a filter box.
const FILTER_FROM: usize = 8;

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
                        actions.commands.push(Command::LoadUrl(sample.url.clone()));
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
    ui.separator();

    if let Some(model) = model {
        egui::ScrollArea::vertical().id_salt("panel").auto_shrink([false, true]).show(ui, |ui| {
            if !model.clip_names.is_empty() {
                clips(ui, model, transition, memory, &mut actions);
                ui.separator();
                playback(ui, model, memory, &mut actions);
                ui.separator();
                transition_settings(ui, model, transition);
                if model.clip_names.len() > 1 {
                    blend_panel(ui, model, &mut actions);
                }
                layer_panel(ui, model, &mut actions);
                ui.separator();
            }
            if let Some(candy) = &model.candy {
                candy_panel(ui, candy, state.skinning, &mut actions);
                ui.separator();
            }
            if model.asset.skins.iter().any(|s| !s.joints.is_empty()) {
                skinning_panel(ui, state, &mut actions);
                ui.separator();
            }
            ik_panel(ui, model, &mut actions);
            if model.asset.skins.iter().any(|s| !s.joints.is_empty()) {
                ragdoll_panel(ui, model, state, memory, &mut actions);
            }
            copies_control(ui, model, &mut actions);
            morph_panel(ui, model);
            outline_panel(ui, model, &mut actions);
            view_panel(ui, state, &mut actions);
            joint_panel(ui, model, memory, &mut actions);
            warnings(ui, model);
            ui.separator();
            stats(ui, state);
        });
    } else {
        stats(ui, state);
    }
    actions
}

/// Morph target weights, one group per mesh node: a slider per target showing the animated
/// weight; dragging one holds it (the clip no longer drives it) until "animate" is ticked.
fn morph_panel(ui: &mut egui::Ui, model: &mut Model) {
    let groups: Vec<(usize, String, usize, usize)> = model
        .asset
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| !n.weights.is_empty())
        .filter_map(|(i, n)| {
            let start = *model.asset.weight_offsets.get(i)? as usize;
            let mesh = n.mesh.and_then(|m| model.asset.meshes.get(m as usize));
            let label = match (n.name.as_deref(), mesh.and_then(|m| m.name.as_deref())) {
                (Some(node), Some(mesh)) if node != mesh => format!("{node} ({mesh})"),
                (Some(name), _) | (None, Some(name)) => name.to_owned(),
                (None, None) => format!("node {i}"),
            };
            Some((i, label, start, n.weights.len()))
        })
        .collect();
    if groups.is_empty() {
        return;
    }
    let total: usize = groups.iter().map(|g| g.3).sum();
    egui::CollapsingHeader::new(format!("Morph targets ({total})")).id_salt("morphs").show(ui, |ui| {
        for (node, label, start, count) in groups {
            let names = model
                .asset
                .nodes
                .get(node)
                .and_then(|n| n.mesh)
                .and_then(|m| model.asset.meshes.get(m as usize))
                .map(|m| m.target_names.clone())
                .unwrap_or_default();
            egui::CollapsingHeader::new(label).id_salt(("morph node", node)).default_open(true).show(ui, |ui| {
                let held = (start..start + count).any(|i| model.morph_overrides.get(i).copied().flatten().is_some());
                let mut animate = !held;
                if ui.checkbox(&mut animate, "animate").on_hover_text("Let the clip drive these weights").changed()
                    && animate
                {
                    for slot in model.morph_overrides.iter_mut().skip(start).take(count) {
                        *slot = None;
                    }
                }
                for t in 0..count {
                    let slot = start + t;
                    let current = model.instance.pose().weights.get(slot).copied().unwrap_or(0.0);
                    let mut value = model.morph_overrides.get(slot).copied().flatten().unwrap_or(current);
                    let name = names.get(t).cloned().unwrap_or_else(|| format!("target {t}"));
                    if ui.add(egui::Slider::new(&mut value, 0.0..=1.0).text(name)).changed()
                        && let Some(o) = model.morph_overrides.get_mut(slot)
                    {
                        *o = Some(value);
                    }
                }
            });
        }
    });
    ui.separator();
}

/// The scene outline: the node tree (click a node to select it: axes, channel plot) with what
/// each node carries, then the skins and the meshes.
fn outline_panel(ui: &mut egui::Ui, model: &Model, actions: &mut PanelActions) {
    let asset = &model.asset;
    egui::CollapsingHeader::new(format!(
        "Outline ({} nodes, {} skins, {} meshes)",
        asset.nodes.len(),
        asset.skins.len(),
        asset.meshes.len()
    ))
    .id_salt("outline")
    .show(ui, |ui| {
        let is_joint: Vec<bool> = {
            let mut v = vec![false; asset.nodes.len()];
            for j in asset.skins.iter().flat_map(|s| s.joints.iter()) {
                if let Some(slot) = v.get_mut(*j as usize) {
                    *slot = true;
                }
            }
            v
        };
        egui::ScrollArea::vertical().id_salt("outline nodes").max_height(260.0).show(ui, |ui| {
            for (i, node) in asset.nodes.iter().enumerate() {
                if node.parent.is_none()
                    && let Ok(i) = NodeIndex::try_from(i)
                {
                    outline_node(ui, model, &is_joint, i, 0, actions);
                }
            }
        });
        if !asset.skins.is_empty() {
            ui.strong("Skins");
            for (i, skin) in asset.skins.iter().enumerate() {
                let name = skin.name.clone().unwrap_or_else(|| format!("skin {i}"));
                ui.label(format!("{name}: {} joints", skin.joints.len()));
            }
        }
        if !asset.meshes.is_empty() {
            ui.strong("Meshes");
            for (i, mesh) in asset.meshes.iter().enumerate() {
                let name = mesh.name.clone().unwrap_or_else(|| format!("mesh {i}"));
                let vertices: u64 = mesh.primitives.iter().map(|p| u64::from(p.vertex_count)).sum();
                let triangles: usize = mesh.primitives.iter().map(|p| p.indices.len() / 3).sum();
                let targets = mesh.primitives.iter().map(|p| p.targets.len()).max().unwrap_or(0);
                let mut line =
                    format!("{name}: {} primitives, {vertices} vertices, {triangles} triangles", mesh.primitives.len());
                if targets > 0 {
                    line.push_str(&format!(", {targets} morph targets"));
                }
                ui.label(line);
            }
        }
    });
}

fn outline_node(
    ui: &mut egui::Ui,
    model: &Model,
    is_joint: &[bool],
    node: NodeIndex,
    depth: usize,
    actions: &mut PanelActions,
) {
    if depth > MAX_TREE_DEPTH {
        ui.weak("…");
        return;
    }
    let Some(n) = model.asset.nodes.get(node as usize) else { return };
    let mut label = model.node_name(node);
    if let Some(mesh) = n.mesh {
        label.push_str(&format!("  · mesh {mesh}"));
    }
    if let Some(skin) = n.skin {
        label.push_str(&format!("  · skin {skin}"));
    }
    if is_joint.get(node as usize).copied().unwrap_or(false) {
        label.push_str("  · joint");
    }
    if !n.weights.is_empty() {
        label.push_str(&format!("  · {} morphs", n.weights.len()));
    }
    let selected = model.selected_joint == Some(node);
    let mut clicked = false;
    if n.children.is_empty() {
        clicked = ui.selectable_label(selected, label).clicked();
    } else {
        let id = ui.make_persistent_id(("outline", node));
        egui::collapsing_header::CollapsingState::load_with_default_open(ui.ctx(), id, depth < 2)
            .show_header(ui, |ui| clicked = ui.selectable_label(selected, label).clicked())
            .body(|ui| {
                for &c in &n.children {
                    outline_node(ui, model, is_joint, c, depth + 1, actions);
                }
            });
    }
    if clicked {
        actions.commands.push(Command::SelectJoint(if selected { None } else { Some(node) }));
    }
}

impl Default for PanelMemory {
    fn default() -> Self {
        Self { clip_filter: String::new(), scrub_resume: None, ragdoll_blend: 0.5, open_url: String::new() }
    }
}

/// Ragdoll: start it from the pose on screen, reset, hand back to the animation, show the
/// bodies, gravity and damping.
fn ragdoll_panel(
    ui: &mut egui::Ui,
    model: &Model,
    state: &PanelState<'_>,
    memory: &mut PanelMemory,
    actions: &mut PanelActions,
) {
    egui::CollapsingHeader::new("Ragdoll").id_salt("ragdoll").default_open(true).show(ui, |ui| {
        let running = model.ragdoll.as_ref();
        ui.horizontal(|ui| {
            let start = if running.is_some() { "Drop again" } else { "Ragdoll" };
            if ui.button(start).on_hover_text("Let the character fall from the pose on screen").clicked() {
                actions.commands.push(Command::StartRagdoll);
            }
            if ui
                .add_enabled(running.is_some(), egui::Button::new("Reset"))
                .on_hover_text("Back to the animation at once")
                .clicked()
            {
                actions.commands.push(Command::StopRagdoll);
            }
            let blending = running.is_some_and(|r| r.blend_back.is_some());
            if ui
                .add_enabled(running.is_some() && !blending, egui::Button::new("To animation"))
                .on_hover_text("Blend back to the animation over the time below")
                .clicked()
            {
                actions.commands.push(Command::RagdollToAnimation(memory.ragdoll_blend));
            }
        });
        ui.add(egui::Slider::new(&mut memory.ragdoll_blend, 0.0..=3.0).suffix(" s").text("blend back"));
        let mut overlays = state.overlays;
        if ui.checkbox(&mut overlays.bodies, "Show bodies").changed() {
            actions.commands.push(Command::SetOverlays(overlays));
        }
        let (mut gravity, mut damping) = (model.ragdoll_options.gravity, model.ragdoll_options.damping);
        let g = ui.add(egui::Slider::new(&mut gravity, 0.0..=20.0).suffix(" m/s²").text("gravity"));
        let d = ui.add(egui::Slider::new(&mut damping, 0.0..=5.0).text("damping"));
        if g.changed() || d.changed() {
            actions.commands.push(Command::SetRagdollOptions { gravity, damping });
        }
        match running {
            Some(r) => {
                ui.label(format!("{} bodies, {}", r.ragdoll.bodies().len(), r.state_name()));
                ui.weak("Click a body to push it.");
            }
            None => {
                ui.weak("Gravity is scaled to the character's size: any model falls like a person.");
            }
        }
    });
    ui.separator();
}

/// Camera framing, overlays, grid, screenshot and help.
fn view_panel(ui: &mut egui::Ui, state: &PanelState<'_>, actions: &mut PanelActions) {
    egui::CollapsingHeader::new("View").id_salt("view").default_open(true).show(ui, |ui| {
        ui.horizontal(|ui| {
            if ui.button("Frame model").on_hover_text("F, or double-click the viewport").clicked() {
                actions.frame = true;
            }
            if ui.button("Screenshot").on_hover_text("Save the view as a PNG").clicked() {
                actions.commands.push(Command::Screenshot);
            }
            if ui.button("?").on_hover_text("Keyboard and mouse (? or H)").clicked() {
                actions.help = true;
            }
        });
        let mut o = state.overlays;
        let mut grid = state.grid;
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut o.skeleton, "Skeleton")
                .on_hover_text("B: bones, names on hover, click a joint to select it");
            ui.checkbox(&mut o.wireframe, "Wireframe").on_hover_text("W: triangle edges as deformed now");
            ui.checkbox(&mut o.normals, "Normals").on_hover_text("N: deformed vertex normals");
            ui.checkbox(&mut o.bounds, "Bounds").on_hover_text("The animated bounds the camera frames");
            if ui.checkbox(&mut grid, "Grid").on_hover_text("G").changed() {
                actions.commands.push(Command::SetGrid(grid));
            }
        });
        if o != state.overlays {
            actions.commands.push(Command::SetOverlays(o));
        }
        ui.horizontal(|ui| {
            use crate::render::uniforms::{Background, Lighting};
            let mut lighting = state.look.lighting;
            egui::ComboBox::from_id_salt("lighting").selected_text(lighting.name()).show_ui(ui, |ui| {
                for l in Lighting::ALL {
                    ui.selectable_value(&mut lighting, l, l.name());
                }
            });
            ui.label("light");
            let mut background = state.look.background;
            egui::ComboBox::from_id_salt("background").selected_text(background.name()).show_ui(ui, |ui| {
                for b in Background::ALL {
                    ui.selectable_value(&mut background, b, b.name());
                }
            });
            ui.label("background");
            if lighting != state.look.lighting {
                actions.commands.push(Command::SetLighting(lighting));
            }
            if background != state.look.background {
                actions.commands.push(Command::SetBackground(background));
            }
        });
    });
}

/// Samples across a clip in the channel plot.
const PLOT_SAMPLES: usize = 96;
/// Height of one channel's plot, in points.
const PLOT_HEIGHT: f32 = 84.0;

/// The selected joint: its name and a plot of each of its channels in the playing clip over
/// the clip's time, with key markers and the current time; click or drag a plot to seek.
fn joint_panel(ui: &mut egui::Ui, model: &Model, memory: &mut PanelMemory, actions: &mut PanelActions) {
    let Some(joint) = model.selected_joint else { return };
    egui::CollapsingHeader::new(format!("Joint: {}", model.node_name(joint))).id_salt("joint").default_open(true).show(
        ui,
        |ui| {
            let main = model.animator.main();
            let clip = main.clip.and_then(|c| model.asset.clips.get(c));
            let channels: Vec<_> = clip
                .map(|c| {
                    c.channels().iter().filter(|ch| ch.node == joint && ch.target != ChannelTarget::Weights).collect()
                })
                .unwrap_or_default();
            if channels.is_empty() {
                ui.weak("The playing clip does not animate this joint.");
            }
            let duration = clip.map_or(0.0, |c| c.duration);
            for channel in channels {
                let (name, labels): (&str, &[&str]) = match channel.target {
                    ChannelTarget::Translation => ("translation", &["x", "y", "z"]),
                    ChannelTarget::Rotation => ("rotation", &["x", "y", "z", "w"]),
                    _ => ("scale", &["x", "y", "z"]),
                };
                ui.horizontal(|ui| {
                    ui.label(name);
                    for (label, color) in labels.iter().zip(PLOT_COLORS) {
                        ui.colored_label(color, *label);
                    }
                    ui.weak(format!("{} keys, {:?}", channel.times.len(), channel.interpolation));
                });
                channel_plot(ui, channel, duration, main.time, main.playing, memory, actions);
            }
        },
    );
}

/// Component colours of the channel plot: x, y, z, w.
const PLOT_COLORS: [Color32; 4] = [
    Color32::from_rgb(240, 90, 90),
    Color32::from_rgb(90, 210, 100),
    Color32::from_rgb(90, 150, 255),
    Color32::from_rgb(200, 200, 200),
];

fn channel_plot(
    ui: &mut egui::Ui,
    channel: &kloub_core::clip::Channel,
    duration: f32,
    time: f32,
    playing: bool,
    memory: &mut PanelMemory,
    actions: &mut PanelActions,
) {
    let width = channel.width as usize;
    let mut samples = vec![[0.0f32; 4]; PLOT_SAMPLES + 1];
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for (i, sample) in samples.iter_mut().enumerate() {
        let t = duration * i as f32 / PLOT_SAMPLES as f32;
        if sample_channel(channel, t, RotationLerp::Slerp, &mut sample[..width]).is_ok() {
            for &v in &sample[..width] {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return;
    }
    let pad = ((hi - lo) * 0.08).max(1e-4);
    let (lo, hi) = (lo - pad, hi + pad);
    let full = ui.available_width().max(60.0);
    let (rect, response) = ui.allocate_exact_size(vec2(full, PLOT_HEIGHT), Sense::click_and_drag());
    let painter = ui.painter_at(rect);
    let visuals = ui.visuals();
    painter.rect_filled(rect, 3.0, visuals.extreme_bg_color);
    let x_of = |t: f32| rect.left() + if duration > 0.0 { (t / duration).clamp(0.0, 1.0) } else { 0.0 } * rect.width();
    let y_of = |v: f32| rect.bottom() - (v - lo) / (hi - lo) * rect.height();
    if lo < 0.0 && hi > 0.0 {
        painter.line_segment(
            [pos2(rect.left(), y_of(0.0)), pos2(rect.right(), y_of(0.0))],
            Stroke::new(1.0, visuals.faint_bg_color),
        );
    }
    for (c, color) in PLOT_COLORS.iter().enumerate().take(width) {
        let points: Vec<egui::Pos2> = samples
            .iter()
            .enumerate()
            .map(|(i, s)| pos2(x_of(duration * i as f32 / PLOT_SAMPLES as f32), y_of(s[c])))
            .collect();
        painter.add(egui::Shape::line(points, Stroke::new(1.5, *color)));
    }
    let tick = Stroke::new(1.0, visuals.weak_text_color());
    let mut last_column = f32::NEG_INFINITY;
    for &t in &channel.times {
        let x = x_of(t).round();
        if x > last_column {
            painter.line_segment([pos2(x, rect.bottom() - 6.0), pos2(x, rect.bottom())], tick);
            last_column = x;
        }
    }
    let x = x_of(time);
    painter
        .line_segment([pos2(x, rect.top()), pos2(x, rect.bottom())], Stroke::new(1.5, Color32::from_rgb(255, 170, 40)));
    painter.text(
        rect.left_top() + vec2(3.0, 2.0),
        egui::Align2::LEFT_TOP,
        format!("{hi:.3}"),
        egui::FontId::proportional(10.0),
        visuals.weak_text_color(),
    );
    painter.text(
        rect.left_bottom() + vec2(3.0, -8.0),
        egui::Align2::LEFT_BOTTOM,
        format!("{lo:.3}"),
        egui::FontId::proportional(10.0),
        visuals.weak_text_color(),
    );
    if duration > 0.0 {
        if response.drag_started() {
            memory.scrub_resume = Some(playing);
            if playing {
                actions.commands.push(Command::Pause);
            }
        }
        if (response.dragged() || response.clicked())
            && let Some(p) = response.interact_pointer_pos()
        {
            actions.commands.push(Command::Seek(((p.x - rect.left()) / rect.width()).clamp(0.0, 1.0) * duration));
        }
        if response.drag_stopped() && memory.scrub_resume.take() == Some(true) {
            actions.commands.push(Command::Play);
        }
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

fn clips(
    ui: &mut egui::Ui,
    model: &Model,
    transition: &Crossfade,
    memory: &mut PanelMemory,
    actions: &mut PanelActions,
) {
    ui.strong(format!("Clips ({})", model.clip_names.len()));
    if model.clip_names.len() > FILTER_FROM {
        ui.add(egui::TextEdit::singleline(&mut memory.clip_filter).hint_text("filter clips"));
    }
    let filter = memory.clip_filter.to_lowercase();
    let current = model.animator.main().clip;
    let blended = model.animator.tracks().len() > 1;
    let hint = if transition.duration > 0.0 {
        format!("Click: crossfade to this clip over {:.2} s", transition.duration)
    } else {
        "Click: switch to this clip".to_owned()
    };
    egui::ScrollArea::vertical().id_salt("clips").max_height(220.0).show(ui, |ui| {
        for (i, (name, clip)) in model.clip_names.iter().zip(&model.asset.clips).enumerate() {
            if !filter.is_empty() && !name.to_lowercase().contains(&filter) {
                continue;
            }
            let label = format!("{name}  ({:.2} s)", clip.duration);
            if ui.selectable_label(!blended && current == Some(i), label).on_hover_text(&hint).clicked() {
                actions.commands.push(Command::PlayClip(Some(i)));
            }
        }
        if ui.selectable_label(!blended && current.is_none(), "Rest pose").clicked() {
            actions.commands.push(Command::PlayClip(None));
        }
    });
}

fn transition_settings(ui: &mut egui::Ui, model: &Model, transition: &mut Crossfade) {
    egui::CollapsingHeader::new("Transition").id_salt("transition").default_open(true).show(ui, |ui| {
        ui.add(
            egui::Slider::new(&mut transition.duration, 0.0..=2.0)
                .text("crossfade s")
                .fixed_decimals(2)
                .clamping(egui::SliderClamping::Always),
        )
        .on_hover_text("Duration of the crossfade when a clip is clicked; 0 switches at once");
        ui.horizontal(|ui| {
            ui.label("Easing");
            egui::ComboBox::from_id_salt("easing").selected_text(easing_name(transition.easing)).show_ui(ui, |ui| {
                for e in [Easing::SmoothStep, Easing::Linear] {
                    ui.selectable_value(&mut transition.easing, e, easing_name(e));
                }
            });
        });
        ui.horizontal(|ui| {
            ui.label("Outgoing");
            egui::ComboBox::from_id_salt("outgoing").selected_text(outgoing_name(transition.outgoing)).show_ui(
                ui,
                |ui| {
                    for o in [Outgoing::Freeze, Outgoing::KeepPlaying, Outgoing::SyncTime] {
                        ui.selectable_value(&mut transition.outgoing, o, outgoing_name(o))
                            .on_hover_text(outgoing_hint(o));
                    }
                },
            );
        });
        if let Some(fade) = model.animator.crossfade() {
            ui.add(egui::ProgressBar::new(fade.weight).text(format!(
                "to {}  {:.0}%",
                model.clip_name(model.animator.main().clip),
                fade.weight * 100.0
            )));
        }
    });
}

fn method_label(method: SkinningMethod) -> &'static str {
    match method {
        SkinningMethod::Rigid => "Rigid (strongest joint)",
        SkinningMethod::Linear => "Linear blend (LBS)",
        SkinningMethod::DualQuaternion => "Dual quaternion (DQS)",
        SkinningMethod::SphericalJointBlend => "Spherical joint blend (SJB)",
    }
}

fn method_hint(method: SkinningMethod) -> &'static str {
    match method {
        SkinningMethod::Rigid => "Each vertex follows its strongest joint only: rigid parts, cracks at joints",
        SkinningMethod::Linear => {
            "Blends the joint matrices: the glTF reference; collapses under twist, loses volume when bent"
        }
        SkinningMethod::DualQuaternion => {
            "Blends rigid transforms as dual quaternions: keeps volume under twist and bend"
        }
        SkinningMethod::SphericalJointBlend => {
            "Rotates vertices about their shared joint centre (Hejl); vertices whose joints share no centre use DQS"
        }
    }
}

/// Skinning method and path, and SJB's fallback count.
fn skinning_panel(ui: &mut egui::Ui, state: &PanelState<'_>, actions: &mut PanelActions) {
    ui.strong("Skinning");
    egui::ComboBox::from_id_salt("skinning method").selected_text(method_label(state.skinning)).show_ui(ui, |ui| {
        for method in SkinningMethod::ALL {
            let response = ui.selectable_label(state.skinning == method, method_label(method));
            if response.on_hover_text(method_hint(method)).clicked() && state.skinning != method {
                actions.commands.push(Command::SetSkinning(method));
            }
        }
    });
    ui.horizontal(|ui| {
        for path in SkinningPath::ALL.into_iter().filter(|&p| p != SkinningPath::Compute || state.compute) {
            if ui.radio(state.skinning_path == path, path.label()).clicked() && state.skinning_path != path {
                actions.commands.push(Command::SetSkinningPath(path));
            }
        }
    });
    let mut heatmap = state.heatmap;
    let reference = if state.skinning == SkinningMethod::Linear { "DQS" } else { "LBS" };
    let toggle = ui
        .add_enabled(state.skinning_path == SkinningPath::Gpu, egui::Checkbox::new(&mut heatmap, "Deviation heatmap"))
        .on_hover_text(format!(
            "Colours each vertex by its distance from {reference}'s result: blue none, red 2% of the model's size \
             (vertex-shader path)"
        ));
    if toggle.changed() {
        actions.commands.push(Command::SetHeatmap(heatmap));
    }
    if state.skinning == SkinningMethod::SphericalJointBlend {
        let (vertices, fallbacks) =
            state.sjb_fallbacks.iter().fold((0, 0), |(v, f), &(_, vertices, fallbacks)| (v + vertices, f + fallbacks));
        ui.label(format!("{fallbacks} of {vertices} vertices share no joint centre and use DQS"))
            .on_hover_text(sjb_breakdown(state.sjb_fallbacks));
    }
}

/// Inverse kinematics: the goals (one target each), and for the selected one its effector,
/// depth, solver, iterations, limits and error.
fn ik_panel(ui: &mut egui::Ui, model: &mut Model, actions: &mut PanelActions) {
    let mut on = !model.ik.is_empty();
    let toggled = ui
        .checkbox(&mut on, "Inverse kinematics")
        .on_hover_text(
            "Drag a ring in the viewport to move its target; click a joint to make it the selected goal's end effector",
        )
        .changed();
    if toggled {
        let command = match (on, model.ik_offers.first()) {
            (true, Some(&(effector, depth))) => Command::SetIk { effector: Some(effector), depth, target: None },
            _ => Command::SetIk { effector: None, depth: 0, target: None },
        };
        actions.commands.push(command);
    }
    if model.ik.is_empty() {
        return;
    }
    ui.horizontal_wrapped(|ui| {
        for (i, goal) in model.ik.iter().enumerate() {
            let text = format!("{} ({:.4})", model.node_name(goal.effector()), goal.report.error);
            if ui.selectable_label(i == model.ik_selected, text).clicked() {
                model.ik_selected = i;
            }
        }
    });
    ui.horizontal(|ui| {
        let unused = model.ik_offers.iter().find(|(j, _)| model.ik.iter().all(|g| g.effector() != *j));
        if ui
            .add_enabled(unused.is_some(), egui::Button::new("Add target"))
            .on_hover_text("Another end effector (the next hand or foot)")
            .clicked()
            && let Some(&(effector, depth)) = unused
        {
            actions.commands.push(Command::SetIk { effector: Some(effector), depth, target: None });
        }
        if model.ik.len() > 1 && ui.button("Remove").clicked() {
            actions.commands.push(Command::RemoveIk(model.ik_selected));
        }
    });
    let selected = model.ik_selected.min(model.ik.len() - 1);
    let ik = &model.ik[selected];
    let (effector, depth) = (ik.effector(), ik.depth());
    let mut chosen = effector;
    egui::ComboBox::from_label("effector").selected_text(model.node_name(effector)).show_ui(ui, |ui| {
        let joints = model.asset.skins.iter().flat_map(|s| s.joints.iter().copied());
        for joint in joints {
            ui.selectable_value(&mut chosen, joint, model.node_name(joint));
        }
    });
    let mut new_depth = depth;
    ui.add(egui::Slider::new(&mut new_depth, 1..=31).text("joints above"));
    if chosen != effector || new_depth != depth {
        let depth = if chosen != effector { depth.min(2) } else { new_depth };
        actions.commands.push(Command::ReplaceIk { goal: selected, effector: chosen, depth });
    }
    let ik = &mut model.ik[selected];
    let two_bone_ok = ik.depth() == 2;
    egui::ComboBox::from_label("solver").selected_text(solver_label(ik.solver)).show_ui(ui, |ui| {
        for solver in IkSolver::ALL {
            if solver == IkSolver::TwoBone && !two_bone_ok {
                continue;
            }
            ui.selectable_value(&mut ik.solver, solver, solver_label(solver));
        }
    });
    ui.add(egui::Slider::new(&mut ik.iterations, 1..=128).text("iterations"));
    if ik.solver == IkSolver::TwoBone {
        ui.add(egui::Slider::new(&mut ik.softness, 0.0..=0.5).text("soft reach")).on_hover_text(
            "The last part of the reach (a fraction of the chain's length) is approached smoothly,\nso the elbow or knee eases into full extension instead of snapping straight",
        );
        let mut pole = ik.pole.is_some();
        if ui
            .checkbox(&mut pole, "Pole")
            .on_hover_text("The middle joint bends towards the blue diamond: drag it in the viewport (the wheel over it moves it in depth)")
            .changed()
        {
            ik.pole = pole.then(|| ik.default_pole());
        }
    }
    if ik.solver == IkSolver::Ccd {
        ui.checkbox(&mut ik.accelerate, "Pattern move").on_hover_text(
            "After each CCD sweep, extrapolate the turn it made while the error keeps falling.\nOff: CCD exactly as the thesis has it (slow near full reach).",
        );
    }
    let kinds: Vec<&str> = ik
        .limits
        .iter()
        .map(|l| match l {
            JointLimit::Free => "free",
            JointLimit::Hinge { .. } => "hinge",
            JointLimit::Ball { .. } => "ball",
        })
        .collect();
    ui.checkbox(&mut ik.use_limits, "Joint limits").on_hover_text(format!(
        "Inferred from the joint names: elbows and knees are hinges, shoulders and hips ball joints.\nThis chain, root first: {}",
        kinds.join(", ")
    ));
    ui.add(egui::Slider::new(&mut ik.weight, 0.0..=1.0).text("weight"))
        .on_hover_text("How much of the solve is applied over the animated pose");
    chain_editor(ui, model, selected);
    let ik = &mut model.ik[selected];
    let reached = ik.report.error <= 1e-3;
    ui.label(format!(
        "error {:.5} after {} iteration{}{}",
        ik.report.error,
        ik.report.iterations,
        if ik.report.iterations == 1 { "" } else { "s" },
        if reached { " (reached)" } else { "" }
    ));
    ui.horizontal(|ui| {
        if ui.button("Target to effector").clicked()
            && let Some(p) = ik.joints.last()
        {
            ik.target = *p;
        }
        let save = ui.button("Save limits").on_hover_text(
            "Download <model>.kloub.json with the joint limits and stiffness that differ from the defaults; \
             drop it with the model (or onto it) to load it",
        );
        if save.clicked() {
            actions.save_sidecar = true;
        }
    });
}

/// The selected goal's chain, root first: each rotating joint's stiffness and limit (kind,
/// axis, angles in degrees), edited in the model's joint settings (saved by "Save limits").
fn chain_editor(ui: &mut egui::Ui, model: &mut Model, goal: usize) {
    let Some(ik) = model.ik.get(goal) else { return };
    let joints: Vec<NodeIndex> = ik.chain.joints()[..ik.depth()].to_vec();
    let bones: Vec<Vec3> = ik.chain.joints()[1..]
        .iter()
        .map(|&c| model.asset.nodes.get(c as usize).map_or(Vec3::Y, |n| n.rest.translation))
        .collect();
    let mut changed = false;
    egui::CollapsingHeader::new("Chain joints: limits and stiffness").id_salt(("chain editor", goal)).show(ui, |ui| {
        for (i, &joint) in joints.iter().enumerate() {
            let j = joint as usize;
            let name = model.node_name(joint);
            let settings = &mut model.joint_settings;
            let (Some(limit), Some(stiffness)) = (settings.limits.get_mut(j), settings.stiffness.get_mut(j)) else {
                continue;
            };
            ui.separator();
            ui.strong(name);
            changed |= ui
                .add(egui::Slider::new(stiffness, 0.0..=1.0).text("stiffness η"))
                .on_hover_text("1 turns fully each sweep, 0 never moves")
                .changed();
            let kind = match limit {
                JointLimit::Free => 0,
                JointLimit::Hinge { .. } => 1,
                JointLimit::Ball { .. } => 2,
            };
            let mut new_kind = kind;
            ui.horizontal(|ui| {
                for (k, label) in ["free", "hinge", "ball"].into_iter().enumerate() {
                    ui.radio_value(&mut new_kind, k, label);
                }
            });
            if new_kind != kind {
                let bone = bones.get(i).copied().and_then(Vec3::try_normalize).unwrap_or(Vec3::Y);
                *limit = match new_kind {
                    1 => JointLimit::Hinge { axis: bone.any_orthonormal_vector(), min: 0.0, max: 150f32.to_radians() },
                    2 => JointLimit::Ball {
                        axis: bone,
                        swing: 60f32.to_radians(),
                        twist_min: (-45f32).to_radians(),
                        twist_max: 45f32.to_radians(),
                    },
                    _ => JointLimit::Free,
                };
                changed = true;
            }
            let degrees = |ui: &mut egui::Ui, value: &mut f32, range: std::ops::RangeInclusive<f32>, text: &str| {
                let mut d = value.to_degrees();
                let moved = ui.add(egui::Slider::new(&mut d, range).suffix("°").text(text)).changed();
                if moved {
                    *value = d.to_radians();
                }
                moved
            };
            match limit {
                JointLimit::Free => {}
                JointLimit::Hinge { axis, min, max } => {
                    ui.horizontal(|ui| {
                        ui.label("axis");
                        for (label, a) in [("x", Vec3::X), ("y", Vec3::Y), ("z", Vec3::Z)] {
                            if ui.selectable_label(axis.abs_diff_eq(a, 1e-4), label).clicked() {
                                *axis = a;
                                changed = true;
                            }
                        }
                        ui.weak(format!("({:.2}, {:.2}, {:.2})", axis.x, axis.y, axis.z));
                    });
                    changed |= degrees(ui, min, -180.0..=180.0, "min");
                    changed |= degrees(ui, max, -180.0..=180.0, "max");
                    if *min > *max {
                        std::mem::swap(min, max);
                    }
                }
                JointLimit::Ball { swing, twist_min, twist_max, .. } => {
                    changed |= degrees(ui, swing, 0.0..=180.0, "swing cone");
                    changed |= degrees(ui, twist_min, -180.0..=180.0, "twist min");
                    changed |= degrees(ui, twist_max, -180.0..=180.0, "twist max");
                    if *twist_min > *twist_max {
                        std::mem::swap(twist_min, twist_max);
                    }
                }
            }
        }
    });
    if changed {
        for ik in &mut model.ik {
            ik.use_settings(&model.joint_settings);
        }
    }
}

fn solver_label(solver: IkSolver) -> &'static str {
    match solver {
        IkSolver::Ccd => "CCD",
        IkSolver::TwoBone => "Two-bone (analytic)",
        IkSolver::Fabrik => "FABRIK",
        IkSolver::Dls => "Damped least squares",
    }
}

/// How many characters the grid shows.
fn copies_control(ui: &mut egui::Ui, model: &Model, actions: &mut PanelActions) {
    let mut copies = model.copy_count();
    let response = ui
        .add(egui::Slider::new(&mut copies, 1..=MAX_COPIES).logarithmic(true).text("copies"))
        .on_hover_text("Characters in a grid, each playing a little later than the previous (stress test)");
    if response.changed() {
        actions.commands.push(Command::SetCopies(copies));
    }
}

fn sjb_breakdown(draws: &[(usize, usize, usize)]) -> String {
    let lines: Vec<String> =
        draws.iter().map(|(mesh, vertices, fallbacks)| format!("mesh {mesh}: {fallbacks} of {vertices}")).collect();
    lines.join("\n")
}

/// The candy-wrapper sample: twist and bend sliders, quality per method, the volume table.
fn candy_panel(ui: &mut egui::Ui, candy: &CandyPanel, current: SkinningMethod, actions: &mut PanelActions) {
    ui.strong("Candy wrapper");
    let (mut twist, mut bend) = (candy.twist, candy.bend);
    let twisted = ui.add(egui::Slider::new(&mut twist, -180.0..=180.0).suffix("°").text("twist")).changed();
    let bent = ui.add(egui::Slider::new(&mut bend, 0.0..=150.0).suffix("°").text("bend")).changed();
    if twisted || bent || (!candy.manual && ui.button("Pose by sliders").clicked()) {
        actions.commands.push(Command::SetCandyPose { twist, bend });
    }
    if !candy.manual {
        ui.weak("A clip poses the rig; move a slider to take over.");
    }
    egui::Grid::new("candy quality").striped(true).show(ui, |ui| {
        ui.label("method");
        ui.label("radius at joint")
            .on_hover_text("Mean distance of the joint's cross-section from its centre, over the rest radius");
        ui.label("volume").on_hover_text("Enclosed volume over the rest volume");
        ui.end_row();
        for (method, q) in SkinningMethod::ALL.into_iter().zip(&candy.quality) {
            let name = method.name().to_uppercase();
            if method == current {
                ui.strong(name)
            } else {
                ui.label(name)
            };
            ui.label(format!("{:.0}%", q.radius_kept * 100.0));
            ui.label(format!("{:.1}%", q.volume_ratio * 100.0));
            ui.end_row();
        }
    });
    egui::CollapsingHeader::new("Volume under bend").id_salt("candy volume table").show(ui, |ui| {
        egui::Grid::new("candy volume").striped(true).show(ui, |ui| {
            ui.label("bend");
            for method in SkinningMethod::ALL {
                ui.label(method.name().to_uppercase());
            }
            ui.end_row();
            for (bend, row) in TABLE_BENDS.iter().zip(&candy.volume_table) {
                ui.label(format!("{bend:.0}°"));
                for v in row {
                    ui.label(format!("{:.1}%", v * 100.0));
                }
                ui.end_row();
            }
        });
    });
}

fn easing_name(e: Easing) -> &'static str {
    match e {
        Easing::SmoothStep => "smooth step",
        Easing::Linear => "linear",
    }
}

fn outgoing_name(o: Outgoing) -> &'static str {
    match o {
        Outgoing::Freeze => "from current pose",
        Outgoing::KeepPlaying => "keep playing",
        Outgoing::SyncTime => "sync time",
    }
}

fn outgoing_hint(o: Outgoing) -> &'static str {
    match o {
        Outgoing::Freeze => "Blend from a snapshot of the pose on screen when the crossfade starts",
        Outgoing::KeepPlaying => "The old clip keeps playing while it fades out",
        Outgoing::SyncTime => "The old clip keeps playing; the new one starts at the same fraction of its length",
    }
}

fn loop_name(mode: LoopMode) -> &'static str {
    match mode {
        LoopMode::Once => "once",
        LoopMode::Repeat => "repeat",
        LoopMode::PingPong => "ping-pong",
    }
}

fn playback(ui: &mut egui::Ui, model: &mut Model, memory: &mut PanelMemory, actions: &mut PanelActions) {
    let main = model.animator.main().clone();
    let duration = main.duration(&model.asset);
    ui.horizontal(|ui| {
        let playing = main.playing && memory.scrub_resume.is_none();
        let label = if playing { "Pause" } else { "Play" };
        if ui.button(label).on_hover_text("Play or pause every clip and layer").clicked() {
            actions.commands.push(if playing { Command::Pause } else { Command::Play });
        }
        if ui
            .button(if main.speed < 0.0 { "Forward" } else { "Reverse" })
            .on_hover_text("Play in the other direction (negates the speed)")
            .clicked()
        {
            actions.commands.push(Command::SetSpeed(-main.speed));
        }
        let mut mode = main.loop_mode;
        egui::ComboBox::from_id_salt("loop").selected_text(loop_name(mode)).width(80.0).show_ui(ui, |ui| {
            for m in [LoopMode::Repeat, LoopMode::Once, LoopMode::PingPong] {
                ui.selectable_value(&mut mode, m, loop_name(m));
            }
        });
        if mode != main.loop_mode {
            actions.commands.push(Command::SetLoop(mode));
        }
    });
    let mut speed = main.speed;
    ui.horizontal(|ui| {
        let slider = egui::Slider::new(&mut speed, -3.0..=3.0).text("speed").fixed_decimals(2);
        if ui.add(slider).changed() {
            actions.commands.push(Command::SetSpeed(speed));
        }
        if ui.small_button("1×").on_hover_text("Reset speed").clicked() {
            actions.commands.push(Command::SetSpeed(1.0));
        }
    });
    if main.clip.is_some() {
        let keys = main.clip.and_then(|c| model.key_times.get(c)).map_or(&[][..], Vec::as_slice);
        ui.monospace(format!("{:6.3} / {:.3} s   {} keys", main.time, duration, keys.len()));
        timeline(ui, main.time, duration, keys, main.playing, memory, actions);
    }
    let mut lerp = model.animator.rotation_lerp();
    ui.horizontal(|ui| {
        ui.label("Rotation keys");
        ui.radio_value(&mut lerp, RotationLerp::Slerp, "slerp")
            .on_hover_text("Spherical interpolation (glTF's definition)");
        ui.radio_value(&mut lerp, RotationLerp::Nlerp, "nlerp")
            .on_hover_text("Normalized linear interpolation: cheaper, slightly uneven speed");
    });
    model.animator.set_rotation_lerp(lerp);
}

/// Height of the timeline strip in points.
const TIMELINE_HEIGHT: f32 = 30.0;

/// The timeline: a strip with a tick per key time and the playhead; click or drag to scrub
/// (playback pauses while dragging and resumes on release).
fn timeline(
    ui: &mut egui::Ui,
    time: f32,
    duration: f32,
    keys: &[f32],
    playing: bool,
    memory: &mut PanelMemory,
    actions: &mut PanelActions,
) {
    let width = ui.available_width().max(60.0);
    let (rect, response) = ui.allocate_exact_size(vec2(width, TIMELINE_HEIGHT), Sense::click_and_drag());
    let response = response.on_hover_text("Click or drag to scrub; ticks mark key times");
    let painter = ui.painter_at(rect);
    let visuals = ui.visuals();
    painter.rect_filled(rect, 3.0, visuals.extreme_bg_color);
    let x_of = |t: f32| {
        let u = if duration > 0.0 { (t / duration).clamp(0.0, 1.0) } else { 0.0 };
        rect.left() + u * rect.width()
    };
    // One tick per pixel column at most, however many keys the clip has.
    let tick = Stroke::new(1.0, visuals.weak_text_color());
    let mut last_column = f32::NEG_INFINITY;
    for &t in keys {
        let x = x_of(t).round();
        if x > last_column {
            painter.line_segment([pos2(x, rect.bottom() - 9.0), pos2(x, rect.bottom() - 2.0)], tick);
            last_column = x;
        }
    }
    let x = x_of(time);
    painter.rect_filled(
        egui::Rect::from_min_max(rect.left_top(), pos2(x, rect.bottom() - 11.0)),
        3.0,
        visuals.selection.bg_fill.gamma_multiply(0.5),
    );
    painter
        .line_segment([pos2(x, rect.top()), pos2(x, rect.bottom())], Stroke::new(2.0, Color32::from_rgb(255, 170, 40)));

    if duration <= 0.0 {
        return;
    }
    let pointer_time =
        |pos: Option<egui::Pos2>| pos.map(|p| ((p.x - rect.left()) / rect.width()).clamp(0.0, 1.0) * duration);
    if response.drag_started() {
        memory.scrub_resume = Some(playing);
        if playing {
            actions.commands.push(Command::Pause);
        }
    }
    if (response.dragged() || response.clicked())
        && let Some(t) = pointer_time(response.interact_pointer_pos())
    {
        actions.commands.push(Command::Seek(t));
    }
    if response.drag_stopped()
        && let Some(resume) = memory.scrub_resume.take()
        && resume
    {
        actions.commands.push(Command::Play);
    }
}

fn blend_panel(ui: &mut egui::Ui, model: &mut Model, actions: &mut PanelActions) {
    let tracks = model.animator.tracks().len();
    let title = if tracks > 1 { format!("Blend clips ({tracks} playing)") } else { "Blend clips".to_owned() };
    egui::CollapsingHeader::new(title).id_salt("blend").show(ui, |ui| {
        ui.weak("Weights are relative; every clip with a weight above 0 plays.");
        egui::ScrollArea::vertical().id_salt("blend-list").max_height(200.0).show(ui, |ui| {
            for (name, weight) in model.clip_names.iter().zip(model.blend_weights.iter_mut()) {
                let slider = egui::Slider::new(weight, 0.0..=1.0).text(name.as_str()).fixed_decimals(2);
                if ui.add(slider).changed() {
                    actions.blend_changed = true;
                }
            }
        });
    });
}

fn layer_panel(ui: &mut egui::Ui, model: &mut Model, actions: &mut PanelActions) {
    let title = match model.animator.layers().first() {
        Some(_) => format!("Layer: {}", model.layer_summary()),
        None => "Layer".to_owned(),
    };
    egui::CollapsingHeader::new(title).id_salt("layer").show(ui, |ui| {
        let before = model.layer;
        let draft = &mut model.layer;
        ui.checkbox(&mut draft.enabled, "Apply a second clip to a subtree");
        ui.horizontal(|ui| {
            ui.label("Clip");
            let selected = model.clip_names.get(draft.clip).map_or("", String::as_str);
            egui::ComboBox::from_id_salt("layer-clip").selected_text(selected).show_ui(ui, |ui| {
                for (i, name) in model.clip_names.iter().enumerate() {
                    ui.selectable_value(&mut draft.clip, i, name);
                }
            });
        });
        let max_weight = if draft.additive { 2.0 } else { 1.0 };
        ui.add(egui::Slider::new(&mut draft.weight, 0.0..=max_weight).text("weight").fixed_decimals(2));
        ui.add(egui::Slider::new(&mut draft.falloff, 0.0..=1.0).text("falloff").fixed_decimals(2))
            .on_hover_text("Each generation below the root weighs (1 − falloff) times its parent");
        ui.add(egui::Slider::new(&mut draft.speed, -3.0..=3.0).text("layer speed").fixed_decimals(2));
        ui.checkbox(&mut draft.additive, "Additive (adds the clip's motion relative to its first frame)");
        let root_name = model.node_name(model.layer.root);
        ui.label(format!("Root bone: {root_name}"));
        egui::ScrollArea::vertical().id_salt("joint-tree").max_height(220.0).show(ui, |ui| {
            let mut root = model.layer.root;
            for (i, node) in model.asset.nodes.iter().enumerate() {
                if node.parent.is_none() && model.in_joint_tree.get(i).copied().unwrap_or(false) {
                    joint_tree(ui, model, i as NodeIndex, &mut root, 0);
                }
            }
            model.layer.root = root;
        });
        if model.layer != before {
            // Picking a clip or a root is asking for the layer.
            if model.layer.clip != before.clip || model.layer.root != before.root {
                model.layer.enabled = true;
            }
            actions.layer_changed = true;
        }
    });
}

/// Deepest joint-tree level drawn (deeper chains end in "…").
const MAX_TREE_DEPTH: usize = 64;

/// One node of the joint tree and, when expanded, its children; a click selects it as root.
fn joint_tree(ui: &mut egui::Ui, model: &Model, node: NodeIndex, selected: &mut NodeIndex, depth: usize) {
    if depth > MAX_TREE_DEPTH {
        ui.weak("…");
        return;
    }
    let Some(n) = model.asset.nodes.get(node as usize) else { return };
    let mut children = n
        .children
        .iter()
        .copied()
        .filter(|&c| model.in_joint_tree.get(c as usize).copied().unwrap_or(false))
        .peekable();
    let label = model.node_name(node);
    if children.peek().is_none() {
        if ui.selectable_label(*selected == node, label).clicked() {
            *selected = node;
        }
        return;
    }
    let id = ui.make_persistent_id(("joint", node));
    // Open the first levels, and the way down to the selected root.
    let open = depth < 3 || is_ancestor(model, node, *selected);
    egui::collapsing_header::CollapsingState::load_with_default_open(ui.ctx(), id, open)
        .show_header(ui, |ui| {
            if ui.selectable_label(*selected == node, label).clicked() {
                *selected = node;
            }
        })
        .body(|ui| {
            for c in children {
                joint_tree(ui, model, c, selected, depth + 1);
            }
        });
}

/// Whether `node` is a proper ancestor of `of` (bounded walk: the importer refuses cycles).
fn is_ancestor(model: &Model, node: NodeIndex, of: NodeIndex) -> bool {
    let nodes = &model.asset.nodes;
    let mut current = nodes.get(of as usize).and_then(|n| n.parent);
    for _ in 0..nodes.len() {
        match current {
            Some(p) if p == node => return true,
            Some(p) => current = nodes.get(p as usize).and_then(|n| n.parent),
            None => return false,
        }
    }
    false
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
