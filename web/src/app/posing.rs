//! Pose mode in the 3D view: clicking selects the nearest joint, the three-ring gizmo turns
//! it about its parent's X, Y and Z axes, and while an example pose is sculpted a drag paints
//! with the brush over the joint's support (highlighted).

use glam::{Quat, Vec2};

use super::*;

/// The gizmo's ring radius, as a fraction of the model's size.
const RING_RADIUS: f32 = 0.09;

/// Points per ring, for drawing and hit-testing.
const RING_POINTS: usize = 64;

/// How near the pointer must press to a ring to grab it, in points.
const RING_GRAB: f32 = 9.0;

/// How near a click must be to a joint to select it in pose mode, in points.
const JOINT_PICK: f32 = 60.0;

/// Ring colours: X red, Y green, Z blue.
const RING_COLORS: [Color32; 3] =
    [Color32::from_rgb(235, 80, 80), Color32::from_rgb(90, 210, 100), Color32::from_rgb(90, 150, 255)];

/// The gizmo of the selected joint this frame.
pub(super) struct Gizmo {
    joint: u32,
    /// Each ring's axis (the parent's X, Y, Z) in the world.
    axes: [Vec3; 3],
    /// Each ring's points in the world, then on screen.
    rings: [Vec<(Vec3, Option<Pos2>)>; 3],
    center: Pos2,
    /// The parent's frame is mirrored (negative determinant).
    mirrored: bool,
}

/// Where the sculpt brush met the surface under the pointer, and for which pointer, view
/// (the projection's bits) and shape (sculpt id, version) it was cast.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct SculptHover {
    key: Option<(Pos2, [u32; 16], u64, u64)>,
    hit: Option<Vec3>,
}

/// A ring being dragged.
#[derive(Clone, Copy, Debug)]
pub(super) struct GizmoDrag {
    joint: u32,
    axis: usize,
    /// The joint's local rotation when the drag began.
    start: Quat,
    /// Where the press was.
    press: Pos2,
    /// The ring's direction on screen where it was grabbed (unit), and points per radian.
    tangent: Vec2,
    per_radian: f32,
}

impl Gizmo {
    /// The rings around the selected joint, in pose mode (none while sculpting).
    fn of(model: &Model, projection: &Projection, origin: Vec3) -> Option<Gizmo> {
        if !model.pose_mode || model.sculpt.is_some() {
            return None;
        }
        let joint = model.selected_joint?;
        let worlds = model.instance.worlds();
        let at = worlds.get(joint as usize)?.w_axis.truncate() + origin;
        let parent = model.asset.nodes.get(joint as usize)?.parent;
        let frame = parent.and_then(|p| worlds.get(p as usize)).copied().unwrap_or(glam::Mat4::IDENTITY);
        // Under a mirrored parent a turn about a local axis turns the other way about its world axis.
        let mirrored = frame.determinant() < 0.0;
        let axes = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| frame.transform_vector3(a).normalize_or(a));
        let radius = RING_RADIUS * model.size();
        let rings = axes.map(|axis| {
            let u = axis.any_orthonormal_vector();
            let v = axis.cross(u);
            (0..=RING_POINTS)
                .map(|i| {
                    let t = i as f32 / RING_POINTS as f32 * std::f32::consts::TAU;
                    let p = at + (u * t.cos() + v * t.sin()) * radius;
                    (p, projection.to_screen(p).map(|s| s.0))
                })
                .collect()
        });
        let center = projection.to_screen(at)?.0;
        Some(Gizmo { joint, axes, rings, center, mirrored })
    }

    /// The ring nearest `pointer` within [`RING_GRAB`], and the world point grabbed.
    fn ring_at(&self, pointer: Pos2) -> Option<(usize, Vec3, Pos2)> {
        let mut best: Option<(f32, usize, Vec3, Pos2)> = None;
        for (axis, ring) in self.rings.iter().enumerate() {
            for w in ring.windows(2) {
                let (Some(a), Some(b)) = (w[0].1, w[1].1) else { continue };
                let ab = b - a;
                let t = ((pointer - a).dot(ab) / ab.length_sq().max(1e-6)).clamp(0.0, 1.0);
                let q = a + ab * t;
                let d = q.distance(pointer);
                if d <= RING_GRAB && best.is_none_or(|b| d < b.0) {
                    best = Some((d, axis, w[0].0.lerp(w[1].0, t), q));
                }
            }
        }
        best.map(|(_, axis, p, q)| (axis, p, q))
    }

    /// Points where a page script (or test) can grab each ring: the on-screen point of each
    /// ring farthest from the joint (least likely to overlap another ring), and the joint.
    fn handles(&self) -> [Pos2; 4] {
        let far = |ring: &Vec<(Vec3, Option<Pos2>)>| {
            ring.iter()
                .filter_map(|r| r.1)
                .max_by(|a, b| a.distance(self.center).total_cmp(&b.distance(self.center)))
                .unwrap_or(self.center)
        };
        [far(&self.rings[0]), far(&self.rings[1]), far(&self.rings[2]), self.center]
    }
}

impl App {
    /// Pose-mode input on the 3D view: ring drags, joint picking, sculpt strokes. Returns
    /// whether it took the pointer (the camera then stays).
    pub(super) fn pose_input(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        projection: &Projection,
        origin: Vec3,
        shift: bool,
    ) -> bool {
        let Some(model) = self.stage.model.as_mut() else { return false };
        if !model.pose_mode {
            self.gizmo_drag = None;
            self.sculpt_stroke = None;
            return false;
        }
        let pressed_at = ui.input(|i| i.pointer.press_origin());
        // A sculpt: a primary drag paints, a click dabs once; no other click handler sees them.
        if model.sculpt.is_some() {
            if response.dragged_by(egui::PointerButton::Primary) && !shift {
                let Some(pointer) = response.interact_pointer_pos() else { return true };
                self.sculpt_at(pointer, projection, origin);
                return true;
            }
            self.sculpt_stroke = None;
            if response.clicked() {
                if let Some(pointer) = response.interact_pointer_pos() {
                    self.sculpt_at(pointer, projection, origin);
                }
                self.sculpt_stroke = None;
                return true;
            }
            return false;
        }
        let gizmo = Gizmo::of(model, projection, origin);
        if response.drag_started_by(egui::PointerButton::Primary)
            && !shift
            && let Some(g) = &gizmo
            && let Some(press) = pressed_at.or_else(|| response.interact_pointer_pos())
            && let Some((axis, grabbed, on_screen)) = g.ring_at(press)
            && let Some(start) = model.instance.pose().locals.get(g.joint as usize).map(|l| l.rotation)
        {
            // The ring's direction on screen at the grabbed point, and its length per radian.
            let centre = model.instance.worlds().get(g.joint as usize).map_or(Vec3::ZERO, |w| w.w_axis.truncate());
            let tangent = g.axes[axis].cross(grabbed - (centre + origin));
            let step = 0.05;
            if let Some((ahead, _)) = projection.to_screen(grabbed + tangent * step) {
                let screen = Vec2::new(ahead.x - on_screen.x, ahead.y - on_screen.y);
                let per_radian = screen.length() / step;
                if per_radian > 1e-3 {
                    self.gizmo_drag = Some(GizmoDrag {
                        joint: g.joint,
                        axis,
                        start,
                        press,
                        tangent: screen / screen.length(),
                        per_radian: if g.mirrored { -per_radian } else { per_radian },
                    });
                }
            }
        }
        if let Some(drag) = self.gizmo_drag {
            if let Some(pointer) = response.interact_pointer_pos() {
                let moved = pointer - drag.press;
                let angle = Vec2::new(moved.x, moved.y).dot(drag.tangent) / drag.per_radian;
                let axis = [Vec3::X, Vec3::Y, Vec3::Z][drag.axis];
                let q = (Quat::from_axis_angle(axis, angle) * drag.start).normalize();
                if let Err(message) =
                    self.stage.apply(Command::SetJointRotation { node: drag.joint, rotation: Some(q.to_array()) })
                {
                    self.stage.fail(message);
                }
            }
            if !response.dragged() || response.drag_stopped() {
                self.gizmo_drag = None;
            }
            return true;
        }
        // A click selects the joint nearest to it.
        if response.clicked()
            && let Some(pointer) = response.interact_pointer_pos()
        {
            let points = overlay::joint_points(model, projection, origin);
            let nearest = points
                .into_iter()
                .map(|(at, n)| (at.distance(pointer), n))
                .filter(|(d, _)| *d <= JOINT_PICK)
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, n)| n);
            if nearest.is_some() {
                model.selected_joint = nearest;
            }
            return true;
        }
        false
    }

    /// One step of a sculpt stroke at `pointer`: a dab where the ray meets the surface (the
    /// grab brush moves what it caught with the pointer).
    fn sculpt_at(&mut self, pointer: Pos2, projection: &Projection, origin: Vec3) {
        let Some(model) = self.stage.model.as_mut() else { return };
        let Some(state) = &model.sculpt else { return };
        let Some((near, direction)) = projection.ray(pointer) else { return };
        let radius = state.radius * model.size();
        let grab = state.brush == kloub_core::sculpt::Brush::Grab;
        match self.sculpt_stroke {
            // The grab brush keeps what it caught and moves it in the view plane.
            Some((last, at, depth)) if grab => {
                let (Some(from), Some(to)) = (projection.unproject(last, depth), projection.unproject(pointer, depth))
                else {
                    return;
                };
                let drag = to - from;
                if drag.length() > 0.0 {
                    model.sculpt_dab(at, drag);
                    self.sculpt_stroke = Some((pointer, at + drag, depth));
                }
            }
            Some((last, at, depth)) => {
                // Dabs a quarter of the radius apart along the stroke.
                let Some(hit) = state.sculpt.pick(near - origin, direction) else { return };
                if hit.distance(at) >= 0.25 * radius {
                    model.sculpt_dab(hit, Vec3::ZERO);
                    self.sculpt_stroke = Some((pointer, hit, depth));
                } else {
                    self.sculpt_stroke = Some((last, at, depth));
                }
            }
            None => {
                let Some(hit) = state.sculpt.pick(near - origin, direction) else { return };
                let depth = projection.to_screen(hit + origin).map_or(0.5, |s| s.1);
                if !grab {
                    model.sculpt_dab(hit, Vec3::ZERO);
                }
                self.sculpt_stroke = Some((pointer, hit, depth));
            }
        }
    }

    /// Pose mode's overlays: the skeleton's joints to click, the gizmo's rings, and while
    /// sculpting the support's vertices and the brush under the pointer.
    pub(super) fn paint_pose(
        &mut self,
        painter: &egui::Painter,
        response: &egui::Response,
        projection: &Projection,
        origin: Vec3,
    ) {
        self.gizmo_handles = None;
        let Some(model) = self.stage.model.as_ref() else { return };
        if !model.pose_mode {
            return;
        }
        if let Some(state) = &model.sculpt {
            let joint = model.instance.worlds().get(state.sculpt.joint as usize).map(|w| w.w_axis.truncate());
            self.gizmo_handles = joint.and_then(|j| projection.to_screen(j + origin)).map(|(at, _)| (None, at));
            let support = Color32::from_rgba_unmultiplied(255, 170, 60, 150);
            for p in &state.sculpt.primitives {
                for &v in &p.support {
                    if let Some((at, _)) =
                        p.positions.get(v as usize).and_then(|x| projection.to_screen(Vec3::from(*x) + origin))
                    {
                        painter.circle_filled(at, 1.5, support);
                    }
                }
            }
            // The brush where the pointer meets the surface (cast again only when the pointer,
            // the view or the shape changed: the cast tries every triangle).
            let key = response.hover_pos().map(|p| (p, projection.key(), state.id, state.version));
            if key != self.sculpt_hover.key {
                let hit = response.hover_pos().and_then(|pointer| {
                    let (near, direction) = projection.ray(pointer)?;
                    state.sculpt.pick(near - origin, direction)
                });
                self.sculpt_hover = SculptHover { key, hit };
            }
            if let Some(hit) = self.sculpt_hover.hit
                && let Some((at, _)) = projection.to_screen(hit + origin)
            {
                let radius = state.radius * model.size();
                let right = self.stage.camera.view().row(0).truncate().normalize_or(Vec3::X);
                let side = projection.to_screen(hit + origin + right * radius);
                let r = side.map_or(20.0, |(s, _)| s.distance(at));
                painter.circle_stroke(at, r, egui::Stroke::new(1.5, Color32::WHITE));
                painter.circle_filled(at, 2.0, Color32::WHITE);
            }
            return;
        }
        let points = overlay::joint_points(model, projection, origin);
        let hovered = response.hover_pos().and_then(|p| nearest_within(p, points.iter().copied()));
        overlay::paint_skeleton(painter, model, &points, model.selected_joint, hovered);
        let Some(gizmo) = Gizmo::of(model, projection, origin) else { return };
        let active = self.gizmo_drag.map(|d| d.axis);
        let hover = response.hover_pos().and_then(|p| gizmo.ring_at(p)).map(|r| r.0);
        for (axis, ring) in gizmo.rings.iter().enumerate() {
            let lit = active == Some(axis) || (active.is_none() && hover == Some(axis));
            let stroke = egui::Stroke::new(if lit { 3.5 } else { 2.0 }, RING_COLORS[axis]);
            let points: Vec<Pos2> = ring.iter().filter_map(|r| r.1).collect();
            painter.add(egui::Shape::line(points, stroke));
        }
        let [x, y, z, joint] = gizmo.handles();
        self.gizmo_handles = Some((Some([x, y, z]), joint));
    }

    /// `{"rings": [[x, y] per ring (X, Y, Z)] | null, "joint": [x, y]}` in CSS pixels of the
    /// canvas, where the gizmo (or, while sculpting, the joint) was drawn last frame; `""`
    /// outside pose mode (a test hook).
    #[cfg_attr(not(target_arch = "wasm32"), allow(dead_code, reason = "read by the wasm entry's test hook"))]
    pub(crate) fn gizmo_json(&self) -> String {
        let xy = |p: Pos2| serde_json::json!([p.x, p.y]);
        self.gizmo_handles.map_or_else(String::new, |(rings, joint)| {
            let rings = rings.map(|r| r.map(xy).to_vec());
            serde_json::json!({ "rings": rings, "joint": xy(joint) }).to_string()
        })
    }
}
