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
    /// Bounce between the ends: forwards to the end, backwards to the start, and again.
    PingPong,
}

/// What happened during one [`Player::advance`]. Plain data: reporting it allocates nothing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlayerEvents {
    /// How many times the clock passed an end of the clip and went on: wrapped around
    /// ([`LoopMode::Repeat`]) or turned around ([`LoopMode::PingPong`]). Saturates.
    pub looped: u32,
    /// The clock reached the end (or the start, backwards) in [`LoopMode::Once`] and stopped.
    pub finished: bool,
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
    /// [`LoopMode::PingPong`] only: on the mirrored leg, where the clock runs at `-speed`.
    pub reversed: bool,
}

impl Default for Player {
    fn default() -> Self {
        Self::new()
    }
}

/// `clip`'s duration, 0 when unknown or not finite.
fn clip_duration(asset: &Asset, clip: Option<usize>) -> f32 {
    match clip.and_then(|c| asset.clips.get(c)) {
        Some(c) if c.duration.is_finite() => c.duration.max(0.0),
        _ => 0.0,
    }
}

/// `x` as a count of events, saturating (NaN counts 0).
fn count(x: f32) -> u32 {
    // `as` saturates float-to-int conversions and maps NaN to 0.
    x.abs() as u32
}

impl Player {
    /// No clip, time 0, speed 1, playing, repeating.
    pub fn new() -> Self {
        Self { clip: None, time: 0.0, speed: 1.0, playing: true, loop_mode: LoopMode::Repeat, reversed: false }
    }

    /// Switches to `clip` and rewinds to its start.
    pub fn set_clip(&mut self, clip: Option<usize>) {
        self.clip = clip;
        self.time = 0.0;
        self.reversed = false;
    }

    /// Duration of the current clip in `asset` (0 without a clip).
    pub fn duration(&self, asset: &Asset) -> f32 {
        clip_duration(asset, self.clip)
    }

    /// Jumps to `time`, clamped to `[0, duration]`; a non-finite time is ignored.
    /// The next sample finds its keys by binary search (O(log keys)).
    pub fn seek(&mut self, asset: &Asset, time: f32) {
        if time.is_finite() {
            self.time = time.clamp(0.0, self.duration(asset));
        }
    }

    /// Position in the clip as a fraction of its duration in `[0, 1]` (0 for a zero-length clip).
    pub fn normalized_time(&self, asset: &Asset) -> f32 {
        let d = self.duration(asset);
        if d > 0.0 && self.time.is_finite() { (self.time / d).clamp(0.0, 1.0) } else { 0.0 }
    }

    /// Seeks to a fraction `u` of the duration (clamped to `[0, 1]`; non-finite ignored).
    pub fn set_normalized_time(&mut self, asset: &Asset, u: f32) {
        if u.is_finite() {
            self.seek(asset, u.clamp(0.0, 1.0) * self.duration(asset));
        }
    }

    /// Advances the clock by `dt` seconds of wall time times `speed` and reports loop and
    /// finish events. Does nothing when paused, without a clip, or when `dt`/`speed` are
    /// not finite. A clip index out of range of `asset` is cleared. Zero-duration clips keep
    /// time 0 (and finish at once in [`LoopMode::Once`]).
    pub fn advance(&mut self, asset: &Asset, dt: f32) -> PlayerEvents {
        let mut events = PlayerEvents::default();
        let Some(index) = self.clip else { return events };
        if asset.clips.get(index).is_none() {
            self.set_clip(None);
            return events;
        }
        let duration = self.duration(asset);
        let step = dt * self.speed;
        if !self.playing || !step.is_finite() {
            return events;
        }
        if duration <= 0.0 {
            self.time = 0.0;
            if self.loop_mode == LoopMode::Once {
                self.playing = false;
                events.finished = true;
            }
            return events;
        }
        let now = if self.time.is_finite() { self.time.clamp(0.0, duration) } else { 0.0 };
        match self.loop_mode {
            LoopMode::Repeat if (0.0..duration).contains(&(now + step)) => {
                // Inside the clip (most frames): no wrap, no division.
                self.time = now + step;
                self.reversed = false;
            }
            LoopMode::Repeat => {
                let t = now + step;
                events.looped = count((t / duration).floor());
                let wrapped = t.rem_euclid(duration);
                // rem_euclid can round up to `duration` itself for tiny negative inputs.
                self.time = if wrapped >= duration { 0.0 } else { wrapped };
                self.reversed = false;
            }
            LoopMode::Once => {
                let t = now + step;
                if (step > 0.0 && t >= duration) || (step < 0.0 && t <= 0.0) {
                    self.playing = false;
                    events.finished = true;
                }
                self.time = t.clamp(0.0, duration);
                self.reversed = false;
            }
            LoopMode::PingPong => {
                // Unfold the bounce onto a cycle of 2·duration: [0, d] forwards, [d, 2d] back.
                let cycle = 2.0 * duration;
                let from = if self.reversed { cycle - now } else { now };
                let to = from + step;
                events.looped = count((to / duration).floor() - (from / duration).floor());
                let mut p = to.rem_euclid(cycle);
                if p >= cycle {
                    p = 0.0;
                }
                self.reversed = p >= duration;
                self.time = if self.reversed { (cycle - p).clamp(0.0, duration) } else { p };
            }
        }
        events
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clip::Clip;

    fn asset(durations: &[f32]) -> Asset {
        Asset {
            clips: durations
                .iter()
                .map(|&d| {
                    let mut clip = Clip::default();
                    clip.duration = d;
                    clip
                })
                .collect(),
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
    fn repeat_counts_wraps_in_both_directions() {
        let a = asset(&[1.0]);
        let mut p = Player::new();
        p.set_clip(Some(0));
        assert_eq!(p.advance(&a, 0.5), PlayerEvents::default());
        assert_eq!(p.advance(&a, 0.75), PlayerEvents { looped: 1, finished: false });
        assert!((p.time - 0.25).abs() < 1e-6);
        assert_eq!(p.advance(&a, 3.0).looped, 3, "three wraps in one long frame");
        p.speed = -1.0;
        assert_eq!(p.advance(&a, 0.5).looped, 1, "backwards through the start");
        assert!((p.time - 0.75).abs() < 1e-5, "{}", p.time);
        assert_eq!(p.advance(&a, 1e30).looped, u32::MAX, "saturates");
        assert!(p.time >= 0.0 && p.time < 1.0);
    }

    #[test]
    fn once_reports_finished_once() {
        let a = asset(&[1.0]);
        let mut p = Player { loop_mode: LoopMode::Once, ..Player::new() };
        p.set_clip(Some(0));
        assert!(!p.advance(&a, 0.5).finished);
        assert_eq!(p.advance(&a, 0.6), PlayerEvents { looped: 0, finished: true });
        assert!(!p.advance(&a, 0.6).finished, "stopped: no second event");
        let z = asset(&[0.0]);
        let mut p = Player { loop_mode: LoopMode::Once, ..Player::new() };
        p.set_clip(Some(0));
        assert!(p.advance(&z, 0.1).finished, "a zero-length clip finishes at once");
        assert!(!p.playing);
    }

    #[test]
    fn ping_pong_bounces_and_counts_turns() {
        let a = asset(&[2.0]);
        let mut p = Player { loop_mode: LoopMode::PingPong, ..Player::new() };
        p.set_clip(Some(0));
        assert_eq!(p.advance(&a, 1.5).looped, 0);
        assert_eq!((p.time, p.reversed), (1.5, false));
        // 1.5 + 1 = 2.5: turned at the end, now at 1.5 going back.
        assert_eq!(p.advance(&a, 1.0).looped, 1);
        assert!((p.time - 1.5).abs() < 1e-6 && p.reversed, "{p:?}");
        assert_eq!(p.advance(&a, 1.0).looped, 0);
        assert!((p.time - 0.5).abs() < 1e-6 && p.reversed);
        // Through the start: forwards again.
        assert_eq!(p.advance(&a, 1.0).looped, 1);
        assert!((p.time - 0.5).abs() < 1e-6 && !p.reversed, "{p:?}");
        // Two full legs and a bit in one frame: two turns.
        assert_eq!(p.advance(&a, 4.25).looped, 2);
        assert!((p.time - 0.75).abs() < 1e-5 && !p.reversed, "{p:?}");
        // Negative speed runs the bounce the other way.
        p.speed = -1.0;
        assert_eq!(p.advance(&a, 1.0).looped, 1, "through the start backwards");
        assert!((p.time - 0.25).abs() < 1e-5 && p.reversed, "{p:?}");
        p.speed = -2.0;
        assert_eq!(p.advance(&a, 1.0).looped, 1, "reversed at speed -2 moves forwards to the end");
        assert!((p.time - 1.75).abs() < 1e-5 && !p.reversed, "{p:?}");
        assert!(p.playing, "ping-pong never finishes");
    }

    #[test]
    fn seek_and_normalized_time_clamp() {
        let a = asset(&[2.0]);
        let mut p = Player::new();
        p.set_clip(Some(0));
        p.seek(&a, 1.5);
        assert_eq!(p.time, 1.5);
        assert_eq!(p.normalized_time(&a), 0.75);
        p.seek(&a, 9.0);
        assert_eq!(p.time, 2.0);
        p.seek(&a, f32::NAN);
        assert_eq!(p.time, 2.0, "NaN ignored");
        p.set_normalized_time(&a, 0.25);
        assert_eq!(p.time, 0.5);
        p.set_normalized_time(&a, -3.0);
        assert_eq!(p.time, 0.0);
        p.set_clip(None);
        assert_eq!((p.duration(&a), p.normalized_time(&a)), (0.0, 0.0));
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
