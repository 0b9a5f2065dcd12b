//! The sections about the scene: ragdoll, view (overlays, lighting, background), copies, morph
//! targets, the node outline and the selected joint with its channel plots.

use egui::{Color32, Sense, Stroke, pos2, vec2};
use glam::Vec3;
use kloub_core::asset::NodeIndex;
use kloub_core::clip::ChannelTarget;
use kloub_core::job::sample::{RotationLerp, sample_channel};

use crate::control::Command;
use crate::model::{MAX_COPIES, Model};

use super::animation::MAX_TREE_DEPTH;
use super::{PanelActions, PanelMemory, PanelState};

/// Ragdoll: start it from the pose on screen, reset, hand back to the animation, show the
/// bodies, gravity and damping.
pub(super) fn ragdoll_panel(
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
        let mut strength = model.ragdoll_options.strength;
        let power = ui
            .add(egui::Slider::new(&mut strength, 0.0..=1.0).max_decimals(2).text("strength"))
            .on_hover_text("Powered ragdoll: 0 falls limp, 1 follows the clip (a ball staggers it, it recovers)");
        if power.changed() {
            actions.commands.push(Command::SetRagdollStrength(strength));
        }
        obstacles(ui, model, actions);
        match running {
            Some(r) => {
                ui.label(format!("{} bodies, {}", r.ragdoll.bodies().len(), r.state_name()));
                ui.weak("Click in the view to throw a ball.");
            }
            None => {
                ui.weak("Gravity is scaled to the character's size: any model falls like a person.");
            }
        }
    });
    ui.separator();
}

/// The ragdoll's obstacles: add a preset at the character's feet, list them, delete.
fn obstacles(ui: &mut egui::Ui, model: &Model, actions: &mut PanelActions) {
    use kloub_core::ragdoll::Obstacle;
    let room = model.obstacles.len() < kloub_core::ragdoll::obstacles::MAX_OBSTACLES;
    ui.horizontal_wrapped(|ui| {
        ui.label("Add obstacle");
        for (name, label) in
            [("box", "Box"), ("sphere", "Sphere"), ("capsule", "Capsule"), ("stairs", "Stairs"), ("ramp", "Ramp")]
        {
            let add = ui.add_enabled(room, egui::Button::new(label).small());
            if add
                .on_hover_text(format!("Place a {name} beside the character (drag it in the view to move it)"))
                .clicked()
            {
                let (lo, hi) = model.bounds.unwrap_or((Vec3::ZERO, Vec3::ONE));
                let feet = Vec3::new(0.5 * (lo.x + hi.x), lo.y, 0.5 * (lo.z + hi.z));
                if let Some(o) = Obstacle::preset(name, feet, model.size()) {
                    let mut list = model.obstacles.clone();
                    list.push(o);
                    actions.commands.push(Command::SetObstacles(list));
                }
            }
        }
    });
    for (i, o) in model.obstacles.iter().enumerate() {
        ui.horizontal(|ui| {
            let c = o.center();
            ui.label(format!("{} {} at {:.2}, {:.2}, {:.2}", i + 1, o.name(), c.x, c.y, c.z));
            let delete = ui.small_button("Delete");
            delete.widget_info(|| {
                egui::WidgetInfo::labeled(egui::Role::Button, true, format!("Delete obstacle {}", i + 1))
            });
            if delete.clicked() {
                let mut list = model.obstacles.clone();
                list.remove(i);
                actions.commands.push(Command::SetObstacles(list));
            }
        });
    }
}

/// Camera framing, overlays, grid, screenshot and help.
pub(super) fn view_panel(ui: &mut egui::Ui, state: &PanelState<'_>, actions: &mut PanelActions) {
    egui::CollapsingHeader::new("View").id_salt("view").default_open(true).show(ui, |ui| {
        ui.horizontal(|ui| {
            if ui.button("Frame model").on_hover_text("F, or double-click the viewport").clicked() {
                actions.frame = true;
            }
            if ui.button("Screenshot").on_hover_text("Save the view as a PNG").clicked() {
                actions.commands.push(Command::Screenshot);
            }
            if ui
                .button("?")
                .on_hover_text("Keyboard and mouse (? or H)")
                .accessible_name("Keyboard and mouse help")
                .clicked()
            {
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
            let shown = egui::ComboBox::from_id_salt("lighting").selected_text(lighting.name()).show_ui(ui, |ui| {
                for l in Lighting::ALL {
                    ui.selectable_value(&mut lighting, l, l.name());
                }
            });
            super::named_combo(&shown, "Lighting");
            ui.label("light");
            let mut background = state.look.background;
            let shown = egui::ComboBox::from_id_salt("background").selected_text(background.name()).show_ui(ui, |ui| {
                for b in Background::ALL {
                    ui.selectable_value(&mut background, b, b.name());
                }
            });
            super::named_combo(&shown, "Background");
            ui.label("background");
            if lighting != state.look.lighting {
                actions.commands.push(Command::SetLighting(lighting));
            }
            if background != state.look.background {
                actions.commands.push(Command::SetBackground(background));
            }
        });
        // One control a row: two sliders side by side would widen the panel.
        let mut exposure = state.look.exposure;
        // A page may set more than the slider shows (up to MAX_EXPOSURE): kept as it is.
        let slider = egui::Slider::new(&mut exposure, 0.0..=4.0)
            .logarithmic(true)
            .smallest_positive(0.05)
            .clamping(egui::SliderClamping::Edits)
            .fixed_decimals(2)
            .text("exposure");
        ui.add(slider);
        if exposure != state.look.exposure {
            actions.commands.push(Command::SetExposure(exposure));
        }
        ui.horizontal(|ui| {
            use crate::render::uniforms::ToneMapping;
            let mut tone = state.look.tone_mapping;
            let shown = egui::ComboBox::from_id_salt("tone mapping").selected_text(tone.name()).show_ui(ui, |ui| {
                for t in ToneMapping::ALL {
                    ui.selectable_value(&mut tone, t, t.name());
                }
            });
            super::named_combo(&shown, "Tone mapping");
            ui.label("tone mapping");
            if tone != state.look.tone_mapping {
                actions.commands.push(Command::SetToneMapping(tone));
            }
        });
        ui.horizontal(|ui| {
            use crate::render::environment::EnvironmentName;
            use crate::render::uniforms::EnvironmentChoice;
            let label = |c: EnvironmentChoice| match c {
                EnvironmentChoice::Preset => "the light's",
                EnvironmentChoice::Named(n) => n.name(),
                EnvironmentChoice::Image => "image (.hdr)",
            };
            // A photograph on its way shows as chosen: choosing what lights the model now cancels it.
            let current = state.environment_loading.map_or(state.look.environment, EnvironmentChoice::Named);
            let mut environment = current;
            let shown =
                egui::ComboBox::from_id_salt("environment").selected_text(label(environment)).show_ui(ui, |ui| {
                    let choices = std::iter::once(EnvironmentChoice::Preset)
                        .chain(EnvironmentName::ALL.map(EnvironmentChoice::Named))
                        .chain(state.has_environment_image.then_some(EnvironmentChoice::Image));
                    for c in choices {
                        ui.selectable_value(&mut environment, c, label(c));
                    }
                });
            super::named_combo(&shown, "Environment");
            match state.environment_loading {
                Some(name) => ui.label(format!("environment (loading {}…)", name.name())),
                None => ui.label("environment"),
            };
            if environment != current {
                actions.commands.push(Command::SetEnvironment(environment, None));
            }
        });
        let mut degrees = state.look.environment_rotation.to_degrees();
        ui.add(egui::Slider::new(&mut degrees, 0.0..=360.0).suffix("°").fixed_decimals(0).text("turn"));
        if degrees != state.look.environment_rotation.to_degrees() {
            actions.commands.push(Command::SetEnvironmentRotation(degrees.to_radians()));
        }
        {
            let (mut intensity, mut softness) = (state.look.shadow_intensity, state.look.shadow_softness);
            ui.add(egui::Slider::new(&mut intensity, 0.0..=1.0).fixed_decimals(2).text("shadow"));
            ui.add_enabled(
                intensity > 0.0,
                egui::Slider::new(&mut softness, 0.0..=1.0).fixed_decimals(2).text("softness"),
            );
            if (intensity, softness) != (state.look.shadow_intensity, state.look.shadow_softness) {
                actions.commands.push(Command::SetShadow(intensity, softness));
            }
        }
    });
}

/// How many characters the grid shows.
pub(super) fn copies_control(ui: &mut egui::Ui, model: &Model, actions: &mut PanelActions) {
    let mut copies = model.copy_count();
    let response = ui
        .add(egui::Slider::new(&mut copies, 1..=MAX_COPIES).logarithmic(true).text("copies"))
        .on_hover_text("Characters in a grid, each playing a little later than the previous (stress test)");
    if response.changed() {
        actions.commands.push(Command::SetCopies(copies));
    }
}

/// Morph target weights, one group per mesh node: a slider per target showing the animated
/// weight; dragging one holds it (the clip no longer drives it) until "animate" is ticked.
pub(super) fn morph_panel(ui: &mut egui::Ui, model: &mut Model) {
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
pub(super) fn outline_panel(ui: &mut egui::Ui, model: &Model, actions: &mut PanelActions) {
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

pub(super) fn outline_node(
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

/// The selected joint: its name and a plot of each of its channels in the playing clip over
/// the clip's time, with key markers and the current time; click or drag a plot to seek.
pub(super) fn joint_panel(ui: &mut egui::Ui, model: &Model, memory: &mut PanelMemory, actions: &mut PanelActions) {
    let Some(joint) = model.selected_joint else { return };
    egui::CollapsingHeader::new(format!("Joint: {}", model.node_name(joint))).id_salt("joint").default_open(true).show(
        ui,
        |ui| {
            // In pose mode the pose section shows them.
            if !model.pose_mode {
                pose_fields(ui, model, joint, actions);
            }
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

/// Free posing (seed 001 App. C): the joint's local rotation as three angles in degrees (XYZ
/// Euler, in its parent's frame), held over the animation once edited; reset joint / reset all.
pub(super) fn pose_fields(ui: &mut egui::Ui, model: &Model, joint: NodeIndex, actions: &mut PanelActions) {
    let Some(local) = model.instance.pose().locals.get(joint as usize) else { return };
    let held = model.rotation_overrides.get(joint as usize).is_some_and(Option::is_some);
    let (x, y, z) = local.rotation.to_euler(glam::EulerRot::XYZ);
    let mut angles = [x.to_degrees(), y.to_degrees(), z.to_degrees()];
    let mut changed = false;
    ui.horizontal(|ui| {
        ui.label("Pose").on_hover_text(
            "The joint's rotation in its parent's frame (X, Y, Z Euler angles in degrees): edit to hold it over the \
             animation",
        );
        for (angle, axis) in angles.iter_mut().zip(["X", "Y", "Z"]) {
            let label = ui.label(axis);
            let response = ui
                .add(egui::DragValue::new(angle).speed(0.5).suffix("°").range(-180.0..=180.0).max_decimals(1))
                .labelled_by(label.id);
            changed |= response.on_hover_text(format!("Rotation about {axis}, degrees")).changed();
        }
    });
    if changed {
        let [x, y, z] = angles.map(f32::to_radians);
        let q = glam::Quat::from_euler(glam::EulerRot::XYZ, x, y, z).normalize();
        actions.commands.push(Command::SetJointRotation { node: joint, rotation: Some(q.to_array()) });
    }
    ui.horizontal(|ui| {
        if ui
            .add_enabled(held, egui::Button::new("Reset joint"))
            .on_hover_text("Let the animation drive this joint")
            .clicked()
        {
            actions.commands.push(Command::SetJointRotation { node: joint, rotation: None });
        }
        let any = model.rotation_overrides.iter().any(Option::is_some);
        if ui
            .add_enabled(any, egui::Button::new("Reset all"))
            .on_hover_text("Let the animation drive every joint")
            .clicked()
        {
            actions.commands.push(Command::ResetPose);
        }
        if held {
            ui.weak("held");
        }
    });
}

/// Samples across a clip in the channel plot.
pub(super) const PLOT_SAMPLES: usize = 96;

/// Height of one channel's plot, in points.
pub(super) const PLOT_HEIGHT: f32 = 84.0;

/// Component colours of the channel plot: x, y, z, w.
pub(super) const PLOT_COLORS: [Color32; 4] = [
    Color32::from_rgb(240, 90, 90),
    Color32::from_rgb(90, 210, 100),
    Color32::from_rgb(90, 150, 255),
    Color32::from_rgb(200, 200, 200),
];

pub(super) fn channel_plot(
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
