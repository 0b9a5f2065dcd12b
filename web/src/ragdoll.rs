//! The ragdoll in the viewer: the main character handed to [`kloub_core::ragdoll::Ragdoll`]
//! from its current animated pose (with the animation's velocities), simulated on wall time,
//! and handed back to the animation over a chosen duration.

use glam::Mat4;
use kloub_core::ragdoll::{Obstacle, Ragdoll, obstacles};

/// A running ragdoll of the shown model.
#[derive(Debug)]
pub struct RagdollState {
    /// The simulation.
    pub ragdoll: Ragdoll,
    /// Blending back to the animation: seconds elapsed and the duration.
    pub blend_back: Option<(f32, f32)>,
    /// The clip's time when the powered ragdoll's targets were last set.
    pub target_time: Option<f32>,
}

impl RagdollState {
    /// How much of the pose the ragdoll writes: 1 while simulating, falling to 0 while
    /// blending back.
    pub fn weight(&self) -> f32 {
        match self.blend_back {
            Some((elapsed, duration)) if duration > 0.0 => (1.0 - elapsed / duration).clamp(0.0, 1.0),
            Some(_) => 0.0,
            None => 1.0,
        }
    }

    /// `data-ragdoll`: `simulating`, `resting` or `blending`.
    pub fn state_name(&self) -> &'static str {
        if self.blend_back.is_some() {
            "blending"
        } else if self.ragdoll.is_resting() {
            "resting"
        } else {
            "simulating"
        }
    }

    /// Advances by `dt` seconds of wall time; returns false once the hand-back has finished.
    pub fn advance(&mut self, dt: f32) -> bool {
        self.ragdoll.step(dt);
        if let Some((elapsed, duration)) = &mut self.blend_back {
            *elapsed += dt.max(0.0);
            return *elapsed < *duration;
        }
        true
    }
}

impl crate::model::Model {
    /// Replaces the ragdoll's obstacles (a running ragdoll takes them at once).
    ///
    /// # Errors
    /// More than [`obstacles::MAX_OBSTACLES`]; nothing changes then.
    pub fn set_obstacles(&mut self, list: Vec<Obstacle>) -> Result<(), String> {
        if list.len() > obstacles::MAX_OBSTACLES {
            return Err(format!("{} obstacles: at most {}", list.len(), obstacles::MAX_OBSTACLES));
        }
        if let Some(state) = &mut self.ragdoll {
            state.ragdoll.set_obstacles(&list);
        }
        self.obstacles_json = if list.is_empty() { String::new() } else { Obstacle::list_to_json(&list) };
        self.obstacles = list;
        Ok(())
    }
}

/// The worlds of the previous frame, kept so a ragdoll starts with the animation's velocity.
#[derive(Debug, Default)]
pub struct PreviousWorlds {
    /// Node worlds one frame ago.
    pub worlds: Vec<Mat4>,
    /// Seconds between that frame and the current one.
    pub dt: f32,
}
