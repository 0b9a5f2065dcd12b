//! The page's input in the light widget build: the element's pointer, touch, wheel and key
//! events (the same calls as [`super::input`], which hands them to egui in the full app) turned
//! straight into camera moves and shortcuts of the [`Stage`]. Platform-free, tested natively.
//!
//! As in the full app: drag orbits; right or middle drag, or Shift+drag, pans; the wheel and a
//! pinch zoom; two fingers pan; a double click frames the model; the keys of
//! [`Shortcut`] (space, arrows, Home, Shift+arrows, `+`/`-`, F, G).

use crate::stage::{Shortcut, Stage};

/// Milliseconds between two clicks of a double click.
const DOUBLE_CLICK_MS: f64 = 300.0;
/// Points a press may move and still be a click.
const CLICK_SLOP: f32 = 6.0;

/// One thing the input asks of the stage, in order.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Move {
    /// Orbit by a drag of `dx, dy` points.
    Orbit(f32, f32),
    /// Pan by a drag of `dx, dy` points.
    Pan(f32, f32),
    /// A wheel turn of this many points (positive: away from the user, zoom in).
    Scroll(f32),
    /// Multiply the distance by this factor (a pinch).
    Zoom(f32),
    /// Frame the model (double click).
    Frame,
    /// A shortcut key.
    Key(Shortcut),
}

/// A pressed button: which, where it went down (for a click), whether it moved away since.
#[derive(Clone, Copy, Debug)]
struct Press {
    button: u8,
    shift: bool,
    at: [f32; 2],
    dragged: bool,
}

/// The events of one viewer since its last frame, and what the pointer is doing.
#[derive(Debug, Default)]
pub struct Input {
    moves: Vec<Move>,
    press: Option<Press>,
    pointer: Option<[f32; 2]>,
    /// Touch points down: id and where.
    touches: Vec<(u32, [f32; 2])>,
    /// When and where the last click was (a second one close by is a double click).
    last_click: Option<(f64, [f32; 2])>,
    /// Whether Ctrl is really held (a wheel event with ctrlKey but no Ctrl is a trackpad pinch).
    ctrl_down: bool,
    /// The time of the event being handled (ms), set by the page ([`Input::set_time`]).
    now: f64,
}

fn finite(x: f32, y: f32) -> bool {
    x.is_finite() && y.is_finite()
}

impl Input {
    /// Whether anything arrived since the last frame.
    pub fn is_empty(&self) -> bool {
        self.moves.is_empty()
    }

    /// The time (ms) of the events that follow: a double click is two clicks within
    /// [`DOUBLE_CLICK_MS`].
    pub fn set_time(&mut self, ms: f64) {
        if ms.is_finite() {
            self.now = ms;
        }
    }

    /// Two touch points or more: they pan and pinch; the pointer does not orbit.
    fn multi_touch(&self) -> bool {
        self.touches.len() >= 2
    }

    /// The pointer moved to `(x, y)` (CSS pixels from the canvas's top-left corner).
    pub fn pointer_move(&mut self, x: f32, y: f32) {
        if !finite(x, y) {
            return;
        }
        if let (Some(press), Some([px, py])) = (self.press.as_mut(), self.pointer) {
            let (dx, dy) = (x - px, y - py);
            if (x - press.at[0]).hypot(y - press.at[1]) > CLICK_SLOP {
                press.dragged = true;
            }
            if press.dragged && (dx != 0.0 || dy != 0.0) {
                let pan = press.button != 0 || press.shift;
                if pan {
                    self.moves.push(Move::Pan(dx, dy));
                } else if !self.multi_touch() {
                    self.moves.push(Move::Orbit(dx, dy));
                }
            }
        }
        self.pointer = Some([x, y]);
    }

    /// A button (DOM numbering: 0 primary, 1 middle, 2 secondary) was pressed or released at
    /// `(x, y)`; `bits`: 1 Alt, 2 Ctrl, 4 Shift, 8 Meta.
    pub fn pointer_button(&mut self, x: f32, y: f32, index: u8, pressed: bool, bits: u8) {
        if !finite(x, y) || index > 2 {
            return;
        }
        if pressed {
            self.press = Some(Press { button: index, shift: bits & 4 != 0, at: [x, y], dragged: false });
            self.pointer = Some([x, y]);
            return;
        }
        self.pointer_move(x, y);
        let Some(press) = self.press.take() else { return };
        if press.button != index || press.dragged || self.multi_touch() {
            return;
        }
        // A click: the second within the double-click time and distance frames the model.
        match self.last_click {
            Some((t, at)) if self.now - t <= DOUBLE_CLICK_MS && (x - at[0]).hypot(y - at[1]) <= CLICK_SLOP => {
                self.moves.push(Move::Frame);
                self.last_click = None;
            }
            _ => self.last_click = Some((self.now, [x, y])),
        }
    }

    /// The pointer left the canvas.
    pub fn pointer_gone(&mut self) {
        self.pointer = None;
        self.press = None;
    }

    /// A wheel turn: DOM deltas and `deltaMode` (0 pixels, 1 lines, 2 pages).
    pub fn wheel(&mut self, dx: f32, dy: f32, mode: u8, bits: u8) {
        if !finite(dx, dy) {
            return;
        }
        // As egui counts them in the full app.
        let points = -dy
            * match mode {
                0 => 1.0,
                1 => 40.0,
                _ => 400.0,
            };
        if bits & 2 != 0 && !self.ctrl_down {
            // A trackpad pinch (the browser says Ctrl without a Ctrl key): zoom.
            self.moves.push(Move::Zoom(1.0 / (0.01 * -dy).exp()));
        } else if points != 0.0 {
            self.moves.push(Move::Scroll(points));
        }
    }

    /// A touch point: `phase` 0 start, 1 move, 2 end, 3 cancel. Two or more pan by their
    /// middle and zoom by their spread.
    pub fn touch(&mut self, id: u32, phase: u8, x: f32, y: f32, _force: f32) {
        if !finite(x, y) {
            return;
        }
        let before = self.spread();
        let found = self.touches.iter().position(|(i, _)| *i == id);
        match (phase, found) {
            (0, None) => self.touches.push((id, [x, y])),
            (0 | 1, Some(i)) => {
                if let Some(t) = self.touches.get_mut(i) {
                    t.1 = [x, y];
                }
            }
            (_, Some(i)) => {
                self.touches.remove(i);
            }
            _ => {}
        }
        // Only a move of a finger of a pair moves the camera (a finger added or lifted does not).
        if phase == 1
            && let (Some((mid0, d0)), Some((mid1, d1))) = (before, self.spread())
        {
            self.moves.push(Move::Pan(mid1[0] - mid0[0], mid1[1] - mid0[1]));
            if d0 > 1.0 && d1 > 1.0 {
                self.moves.push(Move::Zoom(d0 / d1));
            }
        }
    }

    /// The middle of the first two touch points and their distance (`None`: fewer than two).
    fn spread(&self) -> Option<([f32; 2], f32)> {
        let [(_, a), (_, b)] = [self.touches.first()?, self.touches.get(1)?];
        Some(([(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0], (a[0] - b[0]).hypot(a[1] - b[1])))
    }

    /// A key went down or up (DOM `key` and `code`). Returns whether the browser's own action
    /// should be prevented (only for the viewer's shortcut keys, never with Ctrl or Meta).
    pub fn key(&mut self, key: &str, code: &str, pressed: bool, bits: u8) -> bool {
        let (ctrl, shift, meta) = (bits & 2 != 0, bits & 4 != 0, bits & 8 != 0);
        self.ctrl_down = ctrl;
        if ctrl || meta {
            return false;
        }
        let shortcut = shortcut(key, code, shift);
        if pressed && let Some(s) = shortcut {
            self.moves.push(Move::Key(s));
        }
        shortcut.is_some()
    }

    /// Pasted text (nothing in the widget takes text).
    pub fn paste(&mut self, _text: String) {}

    /// The browser's copy or cut command (nothing in the widget to copy).
    pub fn copy(&mut self, _cut: bool) {}

    /// The canvas gained or lost the keyboard focus.
    pub fn focus(&mut self, on: bool) {
        if !on {
            self.ctrl_down = false;
            self.press = None;
        }
    }

    /// Applies what arrived since the last frame to `stage`, whose view is `height` points tall.
    pub fn apply(&mut self, stage: &mut Stage, height: f32) {
        for m in self.moves.drain(..) {
            let camera = &mut stage.camera;
            match m {
                Move::Orbit(dx, dy) => camera.orbit_pixels(dx, dy, height),
                Move::Pan(dx, dy) => camera.pan_pixels(dx, dy, height),
                Move::Scroll(points) => camera.zoom_scroll(points),
                Move::Zoom(factor) => camera.zoom(factor),
                Move::Frame => stage.frame_model(),
                Move::Key(shortcut) => stage.shortcut(shortcut),
            }
        }
    }
}

/// The widget's shortcut of a key: the app's ([`Shortcut::from_key`]), a letter also by its `code` (other
/// layouts), without the overlay toggles (the overlays are drawn by the full app).
fn shortcut(key: &str, code: &str, shift: bool) -> Option<Shortcut> {
    let letter = code.strip_prefix("Key").filter(|l| l.len() == 1);
    Shortcut::from_key(letter.unwrap_or(key), shift).filter(|s| !matches!(s, Shortcut::Toggle(_)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drag_orbits_and_a_right_or_shift_drag_pans() {
        let mut input = Input::default();
        input.pointer_button(10.0, 10.0, 0, true, 0);
        input.pointer_move(12.0, 10.0);
        assert!(input.moves.is_empty(), "within the click slop: no drag yet");
        input.pointer_move(30.0, 15.0);
        assert_eq!(input.moves, [Move::Orbit(18.0, 5.0)]);
        input.pointer_button(30.0, 15.0, 0, false, 0);
        input.moves.clear();
        input.pointer_button(10.0, 10.0, 2, true, 0);
        input.pointer_move(20.0, 10.0);
        input.pointer_button(20.0, 10.0, 2, false, 0);
        input.pointer_button(10.0, 10.0, 0, true, 4);
        input.pointer_move(10.0, 30.0);
        assert_eq!(input.moves, [Move::Pan(10.0, 0.0), Move::Pan(0.0, 20.0)]);
    }

    #[test]
    fn two_quick_clicks_in_one_place_frame() {
        let mut input = Input::default();
        let click = |input: &mut Input, t: f64, x: f32| {
            input.set_time(t);
            input.pointer_button(x, 5.0, 0, true, 0);
            input.pointer_button(x, 5.0, 0, false, 0);
        };
        click(&mut input, 0.0, 5.0);
        click(&mut input, 500.0, 5.0);
        assert!(input.moves.is_empty(), "too slow");
        click(&mut input, 700.0, 5.0);
        assert_eq!(input.moves, [Move::Frame]);
        click(&mut input, 800.0, 5.0);
        click(&mut input, 900.0, 50.0);
        assert_eq!(input.moves, [Move::Frame], "too far apart");
    }

    #[test]
    fn wheel_zooms_and_a_trackpad_pinch_too() {
        let mut input = Input::default();
        input.wheel(0.0, -3.0, 1, 0);
        input.wheel(0.0, f32::NAN, 0, 0);
        assert_eq!(input.moves, [Move::Scroll(120.0)]);
        input.moves.clear();
        input.wheel(0.0, -10.0, 0, 2);
        let Some(Move::Zoom(f)) = input.moves.first().copied() else { panic!("{:?}", input.moves) };
        assert!(f < 1.0, "pinching out zooms in: {f}");
    }

    #[test]
    fn two_fingers_pan_and_pinch() {
        let mut input = Input::default();
        input.touch(1, 0, 0.0, 0.0, 1.0);
        input.touch(2, 0, 100.0, 0.0, 1.0);
        assert!(input.moves.is_empty());
        input.touch(2, 1, 200.0, 0.0, 1.0);
        assert_eq!(input.moves, [Move::Pan(50.0, 0.0), Move::Zoom(0.5)]);
        input.touch(2, 2, 200.0, 0.0, 1.0);
        input.touch(1, 1, 10.0, 0.0, 1.0);
        assert_eq!(input.moves.len(), 2, "one finger left: no pan or pinch");
    }

    #[test]
    fn keys_are_the_apps_shortcuts() {
        let mut input = Input::default();
        assert!(input.key(" ", "Space", true, 0));
        assert!(input.key("ArrowLeft", "ArrowLeft", true, 4));
        assert!(input.key("f", "KeyF", true, 0));
        assert!(!input.key("c", "KeyC", true, 2), "Ctrl+C stays the browser's");
        assert!(!input.key("q", "KeyQ", true, 0));
        assert!(input.key(" ", "Space", false, 0), "the release is the viewer's too");
        assert_eq!(
            input.moves,
            [Move::Key(Shortcut::PlayPause), Move::Key(Shortcut::Orbit(1, 0)), Move::Key(Shortcut::Frame)]
        );
    }
}
