//! Mirroring the viewer's state into its element's `data-*` attributes and firing the element's
//! events (load, play, pause, timeupdate, progress).

use super::*;

impl Stage {
    /// Writes changed state into the element's `data-*` attributes and reports the events
    /// that state implies (`play`, `pause`, `timeupdate`, `load`).
    pub(crate) fn sync_dataset(&mut self) {
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
        d.set(Key::SkinningPathChosen, if self.scene.chosen_skinning_path().is_some() { "true" } else { "false" });
        d.set(Key::Heatmap, if self.scene.heatmap() { "true" } else { "false" });
        d.set(Key::Grid, if self.scene.grid() { "true" } else { "false" });
        d.set(Key::Overlays, &overlay_names(self.overlays));
        d.set(Key::Lighting, self.scene.look().lighting.name());
        #[cfg(feature = "full")]
        d.set(
            Key::Ragdoll,
            model.and_then(|m| m.ragdoll.as_ref()).map_or("", crate::ragdoll::RagdollState::state_name),
        );
        d.set(Key::Background, self.scene.look().background.name());
        d.set(Key::Exposure, &self.exposure_text);
        d.set(Key::ToneMapping, self.scene.look().tone_mapping.name());
        d.set(Key::Environment, self.scene.look().environment.name());
        d.set(Key::Shadow, &self.shadow_text);
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
        d.set(Key::Pose, &model.map_or(String::new(), Model::pose_json));
        #[cfg(feature = "full")]
        d.set(Key::Mode, model.map_or("animate", Model::mode_name));
        #[cfg(feature = "full")]
        d.set(Key::Obstacles, model.map_or("", |m| m.obstacles_json.as_str()));
        #[cfg(not(feature = "full"))]
        d.set(Key::Obstacles, "");
        #[cfg(not(feature = "full"))]
        d.set(Key::Mode, "animate");
        let t = &self.transition;
        let transition = format!(
            "{:.3},{},{}",
            t.duration,
            crate::control::easing_name(t.easing),
            crate::control::outgoing_name(t.outgoing)
        );
        d.set(Key::Transition, &transition);
        d.set(Key::Speed, &model.map_or(String::new(), |m| format!("{:.3}", m.animator.main().speed)));
        d.set(Key::Duration, &model.map_or(String::new(), |m| format!("{:.3}", m.duration())));
        d.set(Key::Loop, model.map_or("", |m| crate::control::loop_mode_name(m.animator.main().loop_mode)));
        let c = &self.camera;
        let camera = format!(
            "{:.5},{:.5},{:.5},{:.5},{:.5},{:.5}",
            c.yaw, c.pitch, c.distance, c.target.x, c.target.y, c.target.z
        );
        d.set(Key::Camera, &camera);
        let bounds = model.and_then(Model::grid_bounds).map_or(String::new(), |(min, max)| {
            format!("{:.5},{:.5},{:.5},{:.5},{:.5},{:.5}", min.x, min.y, min.z, max.x, max.y, max.z)
        });
        d.set(Key::Bounds, &bounds);
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
