//! The page's input as egui events. The element listens to its canvas (pointer, wheel, keys,
//! focus, clipboard) and hands each event over in a few numbers; this turns them into the
//! [`egui::RawInput`] of the viewer's next frame. Platform-free, so it is tested natively.

use egui::{Event, Modifiers, PointerButton, Pos2, TouchPhase, Vec2};

/// Modifier bits as the element sends them: 1 Alt, 2 Ctrl, 4 Shift, 8 Meta.
pub fn modifiers(bits: u8) -> Modifiers {
    let (alt, ctrl, shift, meta) = (bits & 1 != 0, bits & 2 != 0, bits & 4 != 0, bits & 8 != 0);
    // As on every non-Apple platform: Ctrl is the command key (Meta too, for Macs).
    Modifiers { alt, ctrl, shift, mac_cmd: false, command: ctrl || meta }
}

/// A DOM `MouseEvent.button` as egui's button.
pub fn button(index: u8) -> Option<PointerButton> {
    match index {
        0 => Some(PointerButton::Primary),
        1 => Some(PointerButton::Middle),
        2 => Some(PointerButton::Secondary),
        3 => Some(PointerButton::Extra1),
        4 => Some(PointerButton::Extra2),
        _ => None,
    }
}

/// Whether a DOM `KeyboardEvent.key` types text (one character, not a named key).
pub fn is_text(key: &str) -> bool {
    let mut chars = key.chars();
    matches!((chars.next(), chars.next()), (Some(c), None) if !c.is_control())
}

/// The events of one viewer since its last frame.
#[derive(Debug, Default)]
pub struct Input {
    events: Vec<Event>,
    modifiers: Modifiers,
    focused: bool,
    /// Whether Ctrl is really held (a wheel event with ctrlKey but no Ctrl is a trackpad pinch).
    ctrl_down: bool,
}

impl Input {
    /// Whether anything arrived since the last frame.
    pub fn is_empty(&self) -> bool {
        self.events.is_empty()
    }

    /// The pointer moved to `(x, y)` (CSS pixels from the canvas's top-left corner).
    pub fn pointer_move(&mut self, x: f32, y: f32) {
        if x.is_finite() && y.is_finite() {
            self.events.push(Event::PointerMoved(Pos2::new(x, y)));
        }
    }

    /// A button was pressed or released at `(x, y)`.
    pub fn pointer_button(&mut self, x: f32, y: f32, index: u8, pressed: bool, bits: u8) {
        let Some(button) = button(index) else { return };
        if !(x.is_finite() && y.is_finite()) {
            return;
        }
        self.modifiers = modifiers(bits);
        let pos = Pos2::new(x, y);
        self.events.push(Event::PointerMoved(pos));
        self.events.push(Event::PointerButton { pos, button, pressed, modifiers: self.modifiers });
    }

    /// The pointer left the canvas.
    pub fn pointer_gone(&mut self) {
        self.events.push(Event::PointerGone);
    }

    /// A wheel turn: DOM deltas and `deltaMode` (0 pixels, 1 lines, 2 pages).
    pub fn wheel(&mut self, dx: f32, dy: f32, mode: u8, bits: u8) {
        if !(dx.is_finite() && dy.is_finite()) {
            return;
        }
        let unit = match mode {
            0 => egui::MouseWheelUnit::Point,
            1 => egui::MouseWheelUnit::Line,
            _ => egui::MouseWheelUnit::Page,
        };
        let modifiers = modifiers(bits);
        let delta = -Vec2::new(dx, dy);
        if modifiers.ctrl && !self.ctrl_down {
            // A trackpad pinch (the browser says Ctrl without a Ctrl key): zoom.
            self.events.push(Event::Zoom((0.01 * delta.y).exp()));
        } else {
            self.events.push(Event::MouseWheel {
                unit,
                delta,
                modifiers,
                phase: TouchPhase::Move,
                source: egui::MouseWheelSource::Unknown,
            });
        }
    }

    /// A touch point: `phase` 0 start, 1 move, 2 end, 3 cancel.
    pub fn touch(&mut self, id: u32, phase: u8, x: f32, y: f32, force: f32) {
        if !(x.is_finite() && y.is_finite()) {
            return;
        }
        let phase = match phase {
            0 => TouchPhase::Start,
            1 => TouchPhase::Move,
            2 => TouchPhase::End,
            _ => TouchPhase::Cancel,
        };
        self.events.push(Event::Touch {
            device_id: egui::TouchDeviceId(0),
            id: egui::TouchId(u64::from(id)),
            phase,
            pos: Pos2::new(x, y),
            force: force.is_finite().then_some(force),
        });
    }

    /// A key went down or up (DOM `key` and `code`). Returns whether the browser's own action
    /// should be prevented (keys egui uses; never copy, paste, reload or the developer tools).
    pub fn key(&mut self, key: &str, code: &str, pressed: bool, bits: u8) -> bool {
        self.modifiers = modifiers(bits);
        self.ctrl_down = self.modifiers.ctrl;
        let text = pressed && !self.modifiers.ctrl && !self.modifiers.command && is_text(key);
        if text {
            self.events.push(Event::Text(key.to_owned()));
        }
        let logical = egui::Key::from_name(key);
        let physical = egui::Key::from_name(code.strip_prefix("Key").unwrap_or(code));
        let Some(active) = logical.or(physical) else { return text };
        self.events.push(Event::Key {
            key: active,
            physical_key: physical,
            pressed,
            repeat: false,
            modifiers: self.modifiers,
        });
        let browser_shortcut = self.modifiers.command
            && matches!(active, egui::Key::C | egui::Key::V | egui::Key::X | egui::Key::R | egui::Key::I);
        !browser_shortcut && (text || matches!(active, egui::Key::Tab | egui::Key::Space) || active.name().len() > 1)
    }

    /// A request of assistive technology (through the element's mirrored nodes).
    pub fn accessibility(&mut self, request: egui::accesskit::ActionRequest) {
        self.events.push(Event::AccessKitActionRequest(request));
    }

    /// Text pasted into the viewer.
    pub fn paste(&mut self, text: String) {
        self.events.push(Event::Paste(text));
    }

    /// The browser's copy or cut command.
    pub fn copy(&mut self, cut: bool) {
        self.events.push(if cut { Event::Cut } else { Event::Copy });
    }

    /// The canvas gained or lost the keyboard focus.
    pub fn focus(&mut self, on: bool) {
        self.focused = on;
        if !on {
            self.ctrl_down = false;
            self.modifiers = Modifiers::default();
        }
        self.events.push(Event::WindowFocused(on));
    }

    /// The input of the next frame: everything since the last one, over a canvas of
    /// `size` points at `pixels_per_point`, at `time` seconds.
    pub fn take(&mut self, size: Vec2, pixels_per_point: f32, time: f64) -> egui::RawInput {
        let mut raw = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(Pos2::ZERO, size)),
            time: Some(time),
            focused: self.focused,
            events: std::mem::take(&mut self.events),
            ..Default::default()
        };
        if let Some(viewport) = raw.viewports.get_mut(&raw.viewport_id) {
            viewport.native_pixels_per_point = Some(pixels_per_point);
            viewport.focused = Some(self.focused);
            viewport.inner_rect = raw.screen_rect;
        }
        raw
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buttons_and_modifiers() {
        assert_eq!(button(0), Some(PointerButton::Primary));
        assert_eq!(button(2), Some(PointerButton::Secondary));
        assert_eq!(button(9), None);
        let m = modifiers(2 | 4);
        assert!(m.ctrl && m.shift && m.command && !m.alt);
    }

    #[test]
    fn keys_type_text_and_name_keys() {
        let mut input = Input::default();
        assert!(input.key("a", "KeyA", true, 0));
        assert!(input.key(" ", "Space", true, 0));
        assert!(input.key("ArrowLeft", "ArrowLeft", true, 4));
        // Ctrl+C stays the browser's (the copy event follows).
        assert!(!input.key("c", "KeyC", true, 2));
        let raw = input.take(Vec2::new(100.0, 50.0), 2.0, 1.0);
        let texts: Vec<&str> =
            raw.events.iter().filter_map(|e| if let Event::Text(t) = e { Some(t.as_str()) } else { None }).collect();
        assert_eq!(texts, ["a", " "]);
        assert!(
            raw.events
                .iter()
                .any(|e| matches!(e, Event::Key { key: egui::Key::ArrowLeft, modifiers, .. } if modifiers.shift))
        );
        assert!(input.is_empty());
        assert_eq!(raw.screen_rect, Some(egui::Rect::from_min_size(Pos2::ZERO, Vec2::new(100.0, 50.0))));
        assert_eq!(raw.viewports.values().next().and_then(|v| v.native_pixels_per_point), Some(2.0));
    }

    #[test]
    fn bad_numbers_are_dropped() {
        let mut input = Input::default();
        input.pointer_move(f32::NAN, 1.0);
        input.pointer_button(1.0, f32::INFINITY, 0, true, 0);
        input.wheel(f32::NAN, 0.0, 0, 0);
        input.touch(1, 0, f32::NAN, 0.0, 1.0);
        input.pointer_button(1.0, 1.0, 42, true, 0);
        assert!(input.is_empty());
    }

    #[test]
    fn pinch_wheel_zooms() {
        let mut input = Input::default();
        input.wheel(0.0, -10.0, 0, 2);
        input.key("Control", "ControlLeft", true, 2);
        input.wheel(0.0, -10.0, 0, 2);
        let raw = input.take(Vec2::splat(10.0), 1.0, 0.0);
        assert!(matches!(raw.events[0], Event::Zoom(z) if z > 1.0));
        assert!(matches!(raw.events.last(), Some(Event::MouseWheel { .. })));
    }
}
