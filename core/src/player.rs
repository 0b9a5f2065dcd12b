//! Playback clock: which clip, at what time, how fast, looping or not.

use crate::asset::Asset;

/// What happens at the end of a clip.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LoopMode {
    /// Stop (and pause) at the end (or the start, when playing backwards).
    Once,
    /// Wrap around.
    #[default]
    Repeat,
}

/// A playback clock for one clip of an asset.
#[derive(Clone, Debug, PartialEq)]
pub struct Player {
    /// Index of the playing clip in [`Asset::clips`]; `None` shows the rest pose.
    pub clip: Option<usize>,
    /// Current time in seconds, within `[0, duration]`.
    pub time: f32,
    /// Playback rate; negative plays backwards.
    pub speed: f32,
    /// Whether [`Player::advance`] moves the clock.
    pub playing: bool,
    /// End-of-clip behaviour.
    pub loop_mode: LoopMode,
}

impl Default for Player {
    fn default() -> Self {
        Self::new()
    }
}

impl Player {
    /// No clip, time 0, speed 1, playing, repeating.
    pub fn new() -> Self {
        Self { clip: None, time: 0.0, speed: 1.0, playing: true, loop_mode: LoopMode::Repeat }
    }

    /// Switches to `clip` and rewinds to its start.
    pub fn set_clip(&mut self, clip: Option<usize>) {
        self.clip = clip;
        self.time = 0.0;
    }

    /// Advances the clock by `dt` seconds of wall time times `speed`. Does nothing when
    /// paused, without a clip, or when `dt`/`speed` are not finite. A clip index out of range
    /// of `asset` is cleared. Zero-duration clips keep time 0.
    pub fn advance(&mut self, asset: &Asset, dt: f32) {
        let Some(index) = self.clip else { return };
        let Some(clip) = asset.clips.get(index) else {
            self.clip = None;
            self.time = 0.0;
            return;
        };
        let duration = if clip.duration.is_finite() { clip.duration.max(0.0) } else { 0.0 };
        let step = dt * self.speed;
        if !self.playing || !step.is_finite() {
            return;
        }
        if duration <= 0.0 {
            self.time = 0.0;
            if self.loop_mode == LoopMode::Once {
                self.playing = false;
            }
            return;
        }
        let t = if self.time.is_finite() { self.time } else { 0.0 } + step;
        self.time = match self.loop_mode {
            LoopMode::Repeat => {
                let wrapped = t.rem_euclid(duration);
                // rem_euclid can round up to `duration` itself for tiny negative inputs.
                if wrapped >= duration { 0.0 } else { wrapped }
            }
            LoopMode::Once => {
                if (step > 0.0 && t >= duration) || (step < 0.0 && t <= 0.0) {
                    self.playing = false;
                }
                t.clamp(0.0, duration)
            }
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clip::Clip;

    fn asset(durations: &[f32]) -> Asset {
        Asset {
            clips: durations.iter().map(|&d| Clip { duration: d, ..Clip::default() }).collect(),
            ..Asset::default()
        }
    }

    #[test]
    fn repeat_wraps_forwards_and_backwards() {
        let a = asset(&[2.0]);
        let mut p = Player::new();
        p.set_clip(Some(0));
        p.advance(&a, 1.5);
        assert_eq!(p.time, 1.5);
        p.advance(&a, 1.0);
        assert!((p.time - 0.5).abs() < 1e-6);
        p.speed = -1.0;
        p.advance(&a, 1.0);
        assert!((p.time - 1.5).abs() < 1e-6, "{}", p.time);
        p.speed = 2.0;
        p.advance(&a, 0.25);
        assert!((p.time - 0.0).abs() < 1e-6 || (p.time - 2.0).abs() < 1e-6);
        assert!(p.playing);
    }

    #[test]
    fn once_stops_at_the_ends() {
        let a = asset(&[1.0]);
        let mut p = Player { loop_mode: LoopMode::Once, ..Player::new() };
        p.set_clip(Some(0));
        p.advance(&a, 0.4);
        assert!(p.playing);
        p.advance(&a, 0.8);
        assert_eq!(p.time, 1.0);
        assert!(!p.playing);
        p.advance(&a, 0.8);
        assert_eq!(p.time, 1.0, "paused clock does not move");
        p.playing = true;
        p.speed = -3.0;
        p.advance(&a, 0.5);
        assert_eq!(p.time, 0.0);
        assert!(!p.playing);
    }

    #[test]
    fn zero_duration_bad_inputs_and_missing_clips_are_safe() {
        let a = asset(&[0.0]);
        let mut p = Player::new();
        p.set_clip(Some(0));
        p.advance(&a, 0.3);
        assert_eq!(p.time, 0.0);
        p.advance(&a, f32::NAN);
        p.advance(&a, f32::INFINITY);
        assert_eq!(p.time, 0.0);
        p.set_clip(Some(5));
        p.advance(&a, 0.1);
        assert_eq!(p.clip, None);
        let mut idle = Player::new();
        idle.advance(&a, 1.0);
        assert_eq!(idle.time, 0.0);
    }
}
