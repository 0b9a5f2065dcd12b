//! The animation sections of the side panel: the clip list, playback and its timeline, the
//! crossfade settings, clip blending and the layer.

use egui::{Color32, Sense, Stroke, pos2, vec2};
use kloub_core::animator::{Crossfade, Easing, Outgoing};
use kloub_core::asset::NodeIndex;
use kloub_core::job::sample::RotationLerp;
use kloub_core::player::LoopMode;

use crate::control::Command;
use crate::model::Model;

use super::{PanelActions, PanelMemory};

/// Clip lists longer than this get a filter box.
pub(super) const FILTER_FROM: usize = 8;

pub(super) fn clips(
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
    // A list box for assistive technology: the playing clip is its selected option.
    let list = egui::UiBuilder::new().accessibility_role(egui::accesskit::Role::ListBox).accessibility_label("Clips");
    ui.scope_builder(list, |ui| {
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
        })
    });
}

pub(super) fn playback(ui: &mut egui::Ui, model: &mut Model, memory: &mut PanelMemory, actions: &mut PanelActions) {
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
        let shown = egui::ComboBox::from_id_salt("loop").selected_text(loop_name(mode)).width(80.0).show_ui(ui, |ui| {
            for m in [LoopMode::Repeat, LoopMode::Once, LoopMode::PingPong] {
                ui.selectable_value(&mut mode, m, loop_name(m));
            }
        });
        super::named_combo(&shown, "Loop");
        if mode != main.loop_mode {
            actions.commands.push(Command::SetLoop(mode));
        }
    });
    let mut speed = main.speed;
    ui.horizontal(|ui| {
        // Steps of 0.05: the keyboard reaches 2× (and ½×, 1.5×, …) exactly.
        let slider = egui::Slider::new(&mut speed, -3.0..=3.0).text("speed").fixed_decimals(2).step_by(0.05);
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
    super::radio_row(ui, "Rotation keys", |ui| {
        ui.label("Rotation keys");
        ui.radio_value(&mut lerp, RotationLerp::Slerp, "slerp")
            .on_hover_text("Spherical interpolation (glTF's definition)");
        ui.radio_value(&mut lerp, RotationLerp::Nlerp, "nlerp")
            .on_hover_text("Normalized linear interpolation: cheaper, slightly uneven speed");
    });
    model.animator.set_rotation_lerp(lerp);
}

/// Height of the timeline strip in points.
pub(super) const TIMELINE_HEIGHT: f32 = 30.0;

/// The timeline: a strip with a tick per key time and the playhead; click or drag to scrub
/// (playback pauses while dragging and resumes on release).
pub(super) fn timeline(
    ui: &mut egui::Ui,
    time: f32,
    duration: f32,
    keys: &[f32],
    playing: bool,
    memory: &mut PanelMemory,
    actions: &mut PanelActions,
) {
    let width = ui.available_width().max(60.0);
    let (rect, _) = ui.allocate_exact_size(vec2(width, TIMELINE_HEIGHT), Sense::hover());
    // A fixed id: the timeline stays the same node for assistive technology while the panel changes.
    let response = ui.interact(rect, ui.scope_id().with("timeline"), Sense::click_and_drag());
    let response = response.on_hover_text("Click or drag to scrub; ticks mark key times");
    // For assistive technology a slider of the clip's time ("1.46 of 3.42 seconds"); setting it
    // seeks, a step is a frame.
    response.widget_info(|| egui::WidgetInfo::slider(true, f64::from(time), "time"));
    ui.ctx().accesskit_node_builder(response.id, |node| {
        use egui::accesskit::Action;
        node.set_min_numeric_value(0.0);
        node.set_max_numeric_value(f64::from(duration));
        node.set_numeric_value_step(1.0 / f64::from(crate::stage::FRAME_RATE));
        node.set_value(format!("{time:.2} of {duration:.2} seconds"));
        node.add_action(Action::SetValue);
        node.add_action(Action::Increment);
        node.add_action(Action::Decrement);
    });
    let asked = ui.input(|i| {
        use egui::accesskit::{Action, ActionData};
        // The last request of the frame wins (keys pressed faster than frames).
        let set = i
            .accesskit_action_requests(response.id, Action::SetValue)
            .filter_map(|r| match r.data {
                Some(ActionData::NumericValue(v)) if v.is_finite() => Some(v as f32),
                _ => None,
            })
            .last();
        let steps = i.num_accesskit_action_requests(response.id, Action::Increment) as f32
            - i.num_accesskit_action_requests(response.id, Action::Decrement) as f32;
        (set, steps)
    });
    if duration > 0.0 {
        match asked {
            (Some(t), _) => actions.commands.push(Command::Seek(t.clamp(0.0, duration))),
            (None, steps) if steps != 0.0 => {
                let t = time + steps / crate::stage::FRAME_RATE;
                actions.commands.push(Command::Seek(t.clamp(0.0, duration)));
            }
            _ => {}
        }
    }
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

pub(super) fn transition_settings(ui: &mut egui::Ui, model: &Model, transition: &mut Crossfade) {
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
            let shown = egui::ComboBox::from_id_salt("easing").selected_text(easing_name(transition.easing)).show_ui(
                ui,
                |ui| {
                    for e in [Easing::SmoothStep, Easing::Linear] {
                        ui.selectable_value(&mut transition.easing, e, easing_name(e));
                    }
                },
            );
            super::named_combo(&shown, "Easing");
        });
        ui.horizontal(|ui| {
            ui.label("Outgoing");
            let shown = egui::ComboBox::from_id_salt("outgoing")
                .selected_text(outgoing_name(transition.outgoing))
                .show_ui(ui, |ui| {
                    for o in [Outgoing::Freeze, Outgoing::KeepPlaying, Outgoing::SyncTime] {
                        ui.selectable_value(&mut transition.outgoing, o, outgoing_name(o))
                            .on_hover_text(outgoing_hint(o));
                    }
                });
            super::named_combo(&shown, "Outgoing");
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

pub(super) fn easing_name(e: Easing) -> &'static str {
    match e {
        Easing::SmoothStep => "smooth step",
        Easing::Linear => "linear",
    }
}

pub(super) fn outgoing_name(o: Outgoing) -> &'static str {
    match o {
        Outgoing::Freeze => "from current pose",
        Outgoing::KeepPlaying => "keep playing",
        Outgoing::SyncTime => "sync time",
    }
}

pub(super) fn outgoing_hint(o: Outgoing) -> &'static str {
    match o {
        Outgoing::Freeze => "Blend from a snapshot of the pose on screen when the crossfade starts",
        Outgoing::KeepPlaying => "The old clip keeps playing while it fades out",
        Outgoing::SyncTime => "The old clip keeps playing; the new one starts at the same fraction of its length",
    }
}

pub(super) fn loop_name(mode: LoopMode) -> &'static str {
    match mode {
        LoopMode::Once => "once",
        LoopMode::Repeat => "repeat",
        LoopMode::PingPong => "ping-pong",
    }
}

pub(super) fn blend_panel(ui: &mut egui::Ui, model: &mut Model, actions: &mut PanelActions) {
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

pub(super) fn layer_panel(ui: &mut egui::Ui, model: &mut Model, actions: &mut PanelActions) {
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
            let shown = egui::ComboBox::from_id_salt("layer-clip").selected_text(selected).show_ui(ui, |ui| {
                for (i, name) in model.clip_names.iter().enumerate() {
                    ui.selectable_value(&mut draft.clip, i, name);
                }
            });
            super::named_combo(&shown, "Layer clip");
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
pub(super) const MAX_TREE_DEPTH: usize = 64;

/// One node of the joint tree and, when expanded, its children; a click selects it as root.
pub(super) fn joint_tree(ui: &mut egui::Ui, model: &Model, node: NodeIndex, selected: &mut NodeIndex, depth: usize) {
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
pub(super) fn is_ancestor(model: &Model, node: NodeIndex, of: NodeIndex) -> bool {
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
