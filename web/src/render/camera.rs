//! An orbit camera: yaw and pitch around a target, at a distance, with frame-to-fit.

use glam::{Mat4, Vec3};

/// Orbit camera looking at [`Camera::target`] from [`Camera::eye`].
///
/// `yaw = 0, pitch = 0` looks from +Z towards −Z (the glTF front view); positive yaw turns
/// the eye towards +X, positive pitch raises it. Y is up. Every mutator ignores non-finite
/// input, so the camera never becomes NaN.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// The point looked at and orbited around.
    pub target: Vec3,
    /// Rotation about the world Y axis, radians.
    pub yaw: f32,
    /// Elevation, radians, kept inside (−π/2, π/2).
    pub pitch: f32,
    /// Distance from the eye to the target (> 0).
    pub distance: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Radius of the framed scene: sets the clipping planes and the zoom limits.
    pub radius: f32,
    /// Where the camera may go and what the user may do to it.
    pub limits: CameraLimits,
}

/// Bounds on the orbit (model-viewer's `min-camera-orbit` / `max-camera-orbit`) and whether the
/// user may zoom and pan (`disable-zoom`, `disable-pan`). They hold for every change: input,
/// [`Camera::orbit`], [`Camera::zoom`], [`Camera::pan_pixels`] and [`Camera::constrain`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraLimits {
    /// Yaw range, radians; unbounded (`±∞`) wraps around.
    pub yaw: [f32; 2],
    /// Pitch range, radians (always within the camera's own ±(π/2 − 0.01)).
    pub pitch: [f32; 2],
    /// Distance range (model units), on top of the zoom's 1 %..100× of the framed radius.
    pub distance: [f32; 2],
    /// The wheel, pinch and keys may zoom.
    pub zoom: bool,
    /// Dragging with the right button, Shift or two fingers may pan.
    pub pan: bool,
}

impl Default for CameraLimits {
    fn default() -> Self {
        Self {
            yaw: [f32::NEG_INFINITY, f32::INFINITY],
            pitch: [-MAX_PITCH, MAX_PITCH],
            distance: [0.0, f32::INFINITY],
            zoom: true,
            pan: true,
        }
    }
}

impl CameraLimits {
    /// Limits from untrusted numbers: NaN bounds become the defaults, swapped pairs are sorted.
    pub fn sanitized(self) -> Self {
        let d = Self::default();
        let pair = |v: [f32; 2], default: [f32; 2]| {
            let lo = if v[0].is_nan() { default[0] } else { v[0] };
            let hi = if v[1].is_nan() { default[1] } else { v[1] };
            if lo <= hi { [lo, hi] } else { [hi, lo] }
        };
        let pitch = pair(self.pitch, d.pitch);
        let distance = pair(self.distance, d.distance);
        Self {
            yaw: pair(self.yaw, d.yaw),
            pitch: [pitch[0].clamp(-MAX_PITCH, MAX_PITCH), pitch[1].clamp(-MAX_PITCH, MAX_PITCH)],
            distance: [distance[0].max(0.0), distance[1].max(0.0)],
            zoom: self.zoom,
            pan: self.pan,
        }
    }
}

/// Largest pitch magnitude: just short of straight up or down, so `look_at` stays defined.
const MAX_PITCH: f32 = std::f32::consts::FRAC_PI_2 - 0.01;

impl Default for Camera {
    fn default() -> Self {
        Self {
            target: Vec3::ZERO,
            yaw: 0.5,
            pitch: 0.25,
            distance: 3.0,
            fov_y: 45f32.to_radians(),
            radius: 1.0,
            limits: CameraLimits::default(),
        }
    }
}

impl Camera {
    /// The eye position (pitch limited to (−π/2, π/2) so the view stays defined).
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.clamp(-MAX_PITCH, MAX_PITCH).sin_cos();
        self.target + self.distance.max(1e-4) * Vec3::new(sy * cp, sp, cy * cp)
    }

    /// World-to-view matrix (right-handed, Y up).
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye(), self.target, Vec3::Y)
    }

    /// The field of view actually used: `fov_y` limited to 1°..170°.
    pub fn fov(&self) -> f32 {
        if self.fov_y.is_finite() {
            self.fov_y.clamp(1f32.to_radians(), 170f32.to_radians())
        } else {
            45f32.to_radians()
        }
    }

    /// Near and far clipping distances: tight around the framed sphere, with room for the
    /// ground grid (which extends to 10 radii).
    pub fn clip_planes(&self) -> (f32, f32) {
        let near = (self.distance - 2.0 * self.radius).max(self.distance * 0.01).max(1e-4);
        let far = self.distance + 12.0 * self.radius;
        (near, far.max(near * 2.0))
    }

    /// View-to-clip matrix for `aspect` = width / height (depth 0..1 as wgpu expects).
    pub fn projection(&self, aspect: f32) -> Mat4 {
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
        let (near, far) = self.clip_planes();
        glam::camera::rh::proj::directx::perspective(self.fov(), aspect, near, far)
    }

    /// World-to-clip matrix for `aspect` = width / height.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// Aims at the centre of the box `min..max` and backs off until its bounding sphere fits
    /// the vertical field of view (with a small margin). Keeps yaw and pitch. For a view at
    /// least as wide as it is tall; [`Camera::frame_to_fit_aspect`] for any shape.
    pub fn frame_to_fit(&mut self, min: Vec3, max: Vec3) {
        self.frame_to_fit_aspect(min, max, 1.0);
    }

    /// [`Camera::frame_to_fit`] for a view of `aspect` = width / height: the sphere fits the
    /// narrower of the vertical and horizontal fields of view, so a tall, narrow view (a phone
    /// held upright) shows all of the model too, centred.
    pub fn frame_to_fit_aspect(&mut self, min: Vec3, max: Vec3, aspect: f32) {
        if !min.is_finite() || !max.is_finite() {
            return;
        }
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect.min(1.0) } else { 1.0 };
        let radius = (0.5 * (max - min).length()).max(1e-3);
        self.target = 0.5 * (min + max);
        self.radius = radius;
        let vertical = self.fov();
        let horizontal = 2.0 * ((0.5 * vertical).tan() * aspect).atan();
        self.distance = radius * 1.05 / (0.5 * vertical.min(horizontal)).sin();
        self.constrain();
    }

    /// Turns the eye around the target by `yaw` and `pitch` radians.
    pub fn orbit(&mut self, yaw: f32, pitch: f32) {
        if !yaw.is_finite() || !pitch.is_finite() {
            return;
        }
        self.yaw += yaw;
        self.pitch += pitch;
        self.constrain();
    }

    /// Brings yaw, pitch and distance within [`Camera::limits`] (an unbounded yaw wraps to
    /// `0..2π`).
    pub fn constrain(&mut self) {
        let l = self.limits;
        self.yaw = if l.yaw[0].is_finite() || l.yaw[1].is_finite() {
            self.yaw.clamp(l.yaw[0], l.yaw[1])
        } else {
            self.yaw.rem_euclid(std::f32::consts::TAU)
        };
        self.pitch = self.pitch.clamp(l.pitch[0].max(-MAX_PITCH), l.pitch[1].min(MAX_PITCH));
        self.distance = self.distance.clamp(l.distance[0].max(1e-4), l.distance[1].max(1e-4));
    }

    /// Orbit from a pointer drag of `dx, dy` pixels in a viewport `height` pixels tall:
    /// dragging across the full height turns by π. Dragging right turns the model right;
    /// dragging down raises the eye (the model tilts towards the viewer), as in three.js.
    pub fn orbit_pixels(&mut self, dx: f32, dy: f32, height: f32) {
        let per_pixel = std::f32::consts::PI / height.max(1.0);
        self.orbit(-dx * per_pixel, dy * per_pixel);
    }

    /// Moves the target in the view plane so the point under the pointer follows a drag of
    /// `dx, dy` pixels in a viewport `height` pixels tall.
    pub fn pan_pixels(&mut self, dx: f32, dy: f32, height: f32) {
        if !dx.is_finite() || !dy.is_finite() || !self.limits.pan {
            return;
        }
        let per_pixel = 2.0 * self.distance * (0.5 * self.fov()).tan() / height.max(1.0);
        let view = self.view();
        let right = view.row(0).truncate();
        let up = view.row(1).truncate();
        self.target += (-dx * right + dy * up) * per_pixel;
    }

    /// Multiplies the distance by `factor` (< 1 zooms in), within 1 % to 100× the framed radius.
    pub fn zoom(&mut self, factor: f32) {
        if !factor.is_finite() || factor <= 0.0 || !self.limits.zoom {
            return;
        }
        self.distance = (self.distance * factor).clamp(self.radius * 0.01, self.radius * 100.0);
        self.constrain();
    }

    /// Zoom from a scroll of `delta` points (positive = away from the user = zoom in).
    pub fn zoom_scroll(&mut self, delta: f32) {
        self.zoom((-delta * 0.002).exp());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The eight corners of the box `min..max` and where `camera` puts them in normalized
    /// device coordinates for a view of `aspect`.
    fn corners_in_ndc(camera: &Camera, aspect: f32, min: Vec3, max: Vec3) -> impl Iterator<Item = (Vec3, Vec3)> {
        let vp = camera.view_proj(aspect);
        (0..8).map(move |corner| {
            let p = Vec3::new(
                if corner & 1 == 0 { min.x } else { max.x },
                if corner & 2 == 0 { min.y } else { max.y },
                if corner & 4 == 0 { min.z } else { max.z },
            );
            let clip = vp * p.extend(1.0);
            (p, clip.truncate() / clip.w)
        })
    }

    #[test]
    fn frame_to_fit_puts_the_box_in_view() {
        let mut camera = Camera::default();
        let (min, max) = (Vec3::new(-1.0, 0.0, -0.5), Vec3::new(1.0, 2.0, 0.5));
        camera.frame_to_fit(min, max);
        assert_eq!(camera.target, Vec3::new(0.0, 1.0, 0.0));
        for (p, ndc) in corners_in_ndc(&camera, 1.0, min, max) {
            assert!(ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0, "corner {p} at {ndc}");
            assert!(ndc.z > 0.0 && ndc.z < 1.0, "corner {p} depth {}", ndc.z);
        }
    }

    #[test]
    fn non_finite_input_is_ignored() {
        let mut camera = Camera::default();
        let before = camera;
        camera.orbit(f32::NAN, 0.0);
        camera.pan_pixels(f32::INFINITY, 0.0, 100.0);
        camera.zoom(f32::NAN);
        camera.zoom(-1.0);
        camera.frame_to_fit(Vec3::NAN, Vec3::ONE);
        assert_eq!(camera, before);
    }

    #[test]
    fn pitch_is_clamped_and_zoom_limited() {
        let mut camera = Camera::default();
        camera.orbit(0.0, 10.0);
        assert!(camera.pitch < std::f32::consts::FRAC_PI_2);
        assert!(camera.view().is_finite());
        camera.zoom(1e-9);
        assert!((camera.distance - camera.radius * 0.01).abs() < 1e-6);
    }

    #[test]
    fn pan_moves_target_in_view_plane() {
        let mut camera = Camera { yaw: 0.0, pitch: 0.0, ..Camera::default() };
        camera.pan_pixels(10.0, 0.0, 100.0);
        // Looking down −Z with +X to the right: dragging right moves the target left.
        assert!(camera.target.x < 0.0);
        assert!(camera.target.y.abs() < 1e-6 && camera.target.z.abs() < 1e-6);
    }

    #[test]
    fn limits_bound_orbit_zoom_and_pan() {
        let mut camera = Camera { yaw: 0.0, pitch: 0.0, distance: 4.0, ..Camera::default() };
        camera.limits =
            CameraLimits { yaw: [-0.5, 0.5], pitch: [0.1, 0.6], distance: [2.0, 5.0], zoom: true, pan: false }
                .sanitized();
        camera.constrain();
        assert_eq!(camera.pitch, 0.1, "pitch raised to its minimum");
        camera.orbit(2.0, 2.0);
        assert_eq!((camera.yaw, camera.pitch), (0.5, 0.6), "a bounded yaw clamps instead of wrapping");
        camera.orbit(-5.0, 0.0);
        assert_eq!(camera.yaw, -0.5);
        camera.zoom(10.0);
        assert_eq!(camera.distance, 5.0);
        camera.zoom(0.01);
        assert_eq!(camera.distance, 2.0);
        let target = camera.target;
        camera.pan_pixels(50.0, 20.0, 100.0);
        assert_eq!(camera.target, target, "panning is off");
        camera.limits.zoom = false;
        camera.zoom(1.2);
        assert_eq!(camera.distance, 2.0, "zooming is off");
        // Unbounded yaw wraps as before.
        camera.limits = CameraLimits::default();
        camera.orbit(std::f32::consts::TAU + 0.25, 0.0);
        assert!((camera.yaw - (-0.25f32).rem_euclid(std::f32::consts::TAU)).abs() < 1e-5, "{}", camera.yaw);
    }

    #[test]
    fn untrusted_limits_are_sorted_and_nan_means_unbounded() {
        let l = CameraLimits {
            yaw: [1.0, -1.0],
            pitch: [f32::NAN, 10.0],
            distance: [f32::NAN, -3.0],
            zoom: false,
            pan: true,
        }
        .sanitized();
        assert_eq!(l.yaw, [-1.0, 1.0]);
        assert_eq!(l.pitch, [-MAX_PITCH, MAX_PITCH]);
        assert_eq!(l.distance, [0.0, 0.0]);
        assert!(!l.zoom && l.pan);
    }

    #[test]
    fn a_tall_view_frames_the_whole_sphere_across_its_width() {
        let (min, max) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0));
        let mut wide = Camera::default();
        wide.frame_to_fit_aspect(min, max, 16.0 / 9.0);
        let mut square = Camera::default();
        square.frame_to_fit(min, max);
        assert_eq!(wide.distance, square.distance, "as wide as tall or wider: the vertical fit");
        let mut tall = Camera::default();
        tall.frame_to_fit_aspect(min, max, 9.0 / 16.0);
        assert!(tall.distance > square.distance * 1.5, "{} vs {}", tall.distance, square.distance);
        // Every corner of the box projects inside the tall view.
        for (p, ndc) in corners_in_ndc(&tall, 9.0 / 16.0, min, max) {
            assert!(ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0, "corner {p} at {ndc}");
        }
    }
}
