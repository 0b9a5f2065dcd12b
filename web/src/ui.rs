//! The side panel: model, clips, playback controls, warnings, stats.

use kloub_core::player::{LoopMode, Player};

use crate::app::Model;

/// Read-only facts the panel shows.
pub struct PanelState<'a> {
    /// The shown model, if any.
    pub model: Option<&'a Model>,
    /// Whether a load is in progress.
    pub loading: bool,
    /// Active backend name.
    pub backend: &'a str,
    /// Smoothed frames per second.
    pub fps: f32,
}

/// What the user asked for that the panel cannot do itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PanelActions {
    /// Frame the camera on the model.
    pub frame: bool,
}

/// Draws the side panel; edits `player` directly (clip, play/pause, speed, time, loop).
pub fn side_panel(ui: &mut egui::Ui, state: &PanelState<'_>, player: &mut Player) -> PanelActions {
    let mut actions = PanelActions::default();
    ui.add_space(6.0);
    ui.heading("Kloub");
    ui.horizontal(|ui| {
        match state.model {
            Some(model) => ui.strong(&model.name),
            None => ui.weak("no model"),
        };
        if state.loading {
            ui.spinner();
        }
    });
    ui.separator();

    if let Some(model) = state.model {
        clips(ui, model, player);
        if let Some(duration) = player.clip.and_then(|c| model.asset.clips.get(c)).map(|c| c.duration) {
            ui.separator();
            playback(ui, player, duration);
        }
        ui.separator();
        if ui.button("Frame model").on_hover_text("Or double-click the viewport").clicked() {
            actions.frame = true;
        }
        warnings(ui, model);
        ui.separator();
    }

    egui::Grid::new("stats").num_columns(2).show(ui, |ui| {
        ui.label("Backend");
        ui.monospace(state.backend);
        ui.end_row();
        ui.label("FPS");
        ui.monospace(format!("{:.0}", state.fps));
        ui.end_row();
    });
    ui.separator();
    ui.weak("Drop a .glb (or a .gltf with its .bin and textures) onto the page to open it.");
    ui.weak("Drag: orbit · right/middle or shift-drag: pan · scroll: zoom.");
    actions
}

fn clips(ui: &mut egui::Ui, model: &Model, player: &mut Player) {
    ui.strong(format!("Clips ({})", model.clip_names.len()));
    egui::ScrollArea::vertical().id_salt("clips").max_height(220.0).show(ui, |ui| {
        for (i, (name, clip)) in model.clip_names.iter().zip(&model.asset.clips).enumerate() {
            let label = format!("{name}  ({:.2} s)", clip.duration);
            if ui.selectable_label(player.clip == Some(i), label).clicked() {
                player.set_clip(Some(i));
                player.playing = true;
            }
        }
        if ui.selectable_label(player.clip.is_none(), "Rest pose").clicked() {
            player.set_clip(None);
        }
    });
}

fn playback(ui: &mut egui::Ui, player: &mut Player, duration: f32) {
    ui.horizontal(|ui| {
        let label = if player.playing { "Pause" } else { "Play" };
        if ui.button(label).clicked() {
            toggle_play(player, duration);
        }
        let mut repeat = player.loop_mode == LoopMode::Repeat;
        if ui.checkbox(&mut repeat, "Loop").changed() {
            player.loop_mode = if repeat { LoopMode::Repeat } else { LoopMode::Once };
        }
    });
    ui.horizontal(|ui| {
        ui.add(egui::Slider::new(&mut player.speed, -2.0..=2.0).text("speed").fixed_decimals(2));
        if ui.small_button("1×").on_hover_text("Reset speed").clicked() {
            player.speed = 1.0;
        }
    });
    ui.monospace(format!("{:6.3} / {:.3} s", player.time, duration));
    ui.add_enabled(
        duration > 0.0,
        egui::Slider::new(&mut player.time, 0.0..=duration.max(0.0)).show_value(false).text("time"),
    );
}

/// Play/pause; a finished one-shot clip restarts from its start (or end, playing backwards).
pub fn toggle_play(player: &mut Player, duration: f32) {
    if player.playing {
        player.playing = false;
        return;
    }
    if player.loop_mode == LoopMode::Once {
        if player.speed >= 0.0 && player.time >= duration {
            player.time = 0.0;
        } else if player.speed < 0.0 && player.time <= 0.0 {
            player.time = duration;
        }
    }
    player.playing = true;
}

fn warnings(ui: &mut egui::Ui, model: &Model) {
    if model.warnings.is_empty() {
        return;
    }
    egui::CollapsingHeader::new(format!("Import warnings ({})", model.warnings.len()))
        .id_salt("warnings")
        .show(ui, |ui| {
            egui::ScrollArea::vertical().id_salt("warning-list").max_height(200.0).show(ui, |ui| {
                for warning in &model.warnings {
                    ui.label(warning.to_string());
                }
            });
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn play_restarts_a_finished_one_shot() {
        let mut p = Player { loop_mode: LoopMode::Once, playing: false, time: 2.0, ..Player::new() };
        toggle_play(&mut p, 2.0);
        assert!(p.playing);
        assert_eq!(p.time, 0.0);
        toggle_play(&mut p, 2.0);
        assert!(!p.playing);
        p.speed = -1.0;
        p.time = 0.0;
        toggle_play(&mut p, 2.0);
        assert_eq!(p.time, 2.0);
        let mut looping = Player { playing: false, time: 2.0, ..Player::new() };
        toggle_play(&mut looping, 2.0);
        assert_eq!(looping.time, 2.0, "a looping clip resumes where it is");
    }
}
