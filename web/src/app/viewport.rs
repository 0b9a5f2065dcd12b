//! The 3D view: camera input (orbit, pan, zoom, touch), IK handles and their drags, picking
//! joints, the overlays drawn over the scene.

use super::*;

/// How far the wheel moves an IK target along the view direction, per scrolled point, as a
/// fraction of the camera's distance (scrolling up, positive, pulls it closer).
const IK_DEPTH_PER_POINT: f32 = 0.0002;

/// What an IK drag moves: goal `goal`'s target, or its pole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct IkHandle {
    goal: usize,
    pole: bool,
}

impl IkHandle {
    /// The handle's point in `ik` (model space).
    fn point(self, ik: &mut IkState) -> Option<&mut Vec3> {
        if !self.pole {
            Some(&mut ik.target)
        } else if ik.active_pole().is_some() {
            ik.pole.as_mut()
        } else {
            None
        }
    }
}

/// Draws the IK chain, the target (green when reached) with the error, and the pole (a
/// diamond tied to the middle joint) when the goal has one; returns where the target and the
/// pole were drawn.
fn paint_ik(
    painter: &egui::Painter,
    projection: &Projection,
    ik: &IkState,
    origin: Vec3,
    dragging: bool,
) -> (Option<Pos2>, Option<Pos2>) {
    let points: Vec<Pos2> = ik.joints.iter().filter_map(|&p| projection.to_screen(p + origin).map(|s| s.0)).collect();
    let gold = Color32::from_rgb(255, 214, 64);
    let chain = egui::Stroke::new(2.0, gold);
    for w in points.windows(2) {
        painter.line_segment([w[0], w[1]], chain);
    }
    for &p in &points {
        painter.circle_filled(p, 3.5, gold);
    }
    let pole = ik.active_pole().and_then(|p| projection.to_screen(p + origin)).map(|(at, _)| {
        let blue = Color32::from_rgb(110, 170, 255);
        if let Some(&middle) = points.get(points.len() / 2) {
            painter.line_segment([middle, at], egui::Stroke::new(1.0, blue));
        }
        let r = if dragging { 8.0 } else { 6.5 };
        let diamond =
            vec![at + egui::vec2(0.0, -r), at + egui::vec2(r, 0.0), at + egui::vec2(0.0, r), at + egui::vec2(-r, 0.0)];
        painter.add(egui::Shape::convex_polygon(diamond, Color32::TRANSPARENT, egui::Stroke::new(2.0, blue)));
        at
    });
    let Some((at, _)) = projection.to_screen(ik.target + origin) else { return (None, pole) };
    let reached = ik.report.error <= 1e-3;
    let color = if reached { Color32::from_rgb(80, 220, 120) } else { Color32::from_rgb(255, 90, 80) };
    painter.circle_stroke(at, if dragging { 11.0 } else { 9.0 }, egui::Stroke::new(2.5, color));
    painter.circle_filled(at, 2.5, color);
    painter.text(
        at + egui::vec2(14.0, -14.0),
        egui::Align2::LEFT_BOTTOM,
        format!("error {:.4}", ik.report.error),
        egui::FontId::monospace(12.0),
        color,
    );
    (Some(at), pole)
}

impl App {
    /// Draws the 3D viewport into `ui` and handles camera input.
    pub(super) fn viewport(&mut self, ui: &mut egui::Ui) {
        let (rect, response) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
        self.stage.set_view_rect(rect);
        let height = rect.height();
        let delta = response.drag_delta();
        let shift = ui.input(|i| i.modifiers.shift);
        let multi_touch = ui.input(|i| i.multi_touch()).is_some_and(|t| t.num_touches >= 2);
        let projection = Projection::new(&self.stage.camera, rect);
        let origin = self.stage.model.as_ref().map_or(Vec3::ZERO, |m| m.copy_offset(0));
        // Every IK handle on screen: targets, and the poles of two-bone goals that have one.
        let markers: Vec<(IkHandle, Pos2, f32)> = self
            .stage
            .model
            .as_ref()
            .map(|m| {
                m.ik.iter()
                    .enumerate()
                    .flat_map(|(goal, ik)| {
                        let target = projection
                            .to_screen(ik.target + origin)
                            .map(|(at, depth)| (IkHandle { goal, pole: false }, at, depth));
                        let pole = ik
                            .active_pole()
                            .and_then(|p| projection.to_screen(p + origin))
                            .map(|(at, depth)| (IkHandle { goal, pole: true }, at, depth));
                        [target, pole]
                    })
                    .flatten()
                    .collect()
            })
            .unwrap_or_default();
        let handle_at = |p: Pos2| nearest_within(p, markers.iter().map(|&(handle, at, _)| (at, handle)));
        // Pose mode first: its gizmo, joint picking and sculpt strokes.
        // IK handles win over obstacles: a press on one drags the handle.
        let on_ik = ui.input(|i| i.pointer.press_origin()).and_then(handle_at).is_some();
        let posing = self.pose_input(ui, &response, &projection, origin, shift)
            || (!on_ik && self.obstacle_input(ui, &response, &projection, origin, shift));
        let pose_mode = self.stage.model.as_ref().is_some_and(|m| m.pose_mode);
        if response.drag_started_by(egui::PointerButton::Primary) && !shift && !pose_mode {
            // Where the press was: a quick drag may have moved off the handle before egui calls it a drag.
            let pressed_at = ui.input(|i| i.pointer.press_origin());
            self.ik_drag = pressed_at.or_else(|| response.interact_pointer_pos()).and_then(handle_at);
            if let (Some(handle), Some(model)) = (self.ik_drag, self.stage.model.as_mut()) {
                model.ik_selected = handle.goal;
            }
        }
        let mut pending = None;
        // A click while the ragdoll runs throws a ball through it from the camera (not while posing).
        if response.clicked()
            && !pose_mode
            && let Some(pointer) = response.interact_pointer_pos()
        {
            self.throw_at(pointer, &projection, origin);
        }
        if posing {
            // Taken by pose mode.
        } else if let Some(handle) = self.ik_drag {
            if let (Some(&(_, _, depth)), Some(pointer), Some(ik)) = (
                markers.iter().find(|m| m.0 == handle),
                response.interact_pointer_pos(),
                self.stage.model.as_mut().and_then(|m| m.ik.get_mut(handle.goal)),
            ) && let Some(world) = projection.unproject(pointer, depth)
                && let Some(point) = handle.point(ik)
            {
                *point = world - origin;
            }
            if !response.dragged() || response.drag_stopped() {
                self.ik_drag = None;
            }
        } else if response.clicked()
            && let (Some(model), Some(pointer)) = (self.stage.model.as_ref(), response.interact_pointer_pos())
            && model.ik.is_empty()
            && (self.stage.overlays.skeleton || !model.has_meshes())
        {
            // A click on a joint selects it (its axes and channel plot); elsewhere clears.
            let points = overlay::joint_points(model, &projection, origin);
            pending = Some(Command::SelectJoint(nearest_within(pointer, points.into_iter())));
        } else if response.clicked()
            && let (Some(model), Some(pointer)) = (self.stage.model.as_ref(), response.interact_pointer_pos())
            && let Some(ik) = model.ik.get(model.ik_selected)
        {
            // A click on a joint makes it the effector (keeping the depth where possible).
            let joints = model.asset.skins.iter().flat_map(|s| s.joints.iter().copied()).filter_map(|j| {
                let p = model.instance.worlds().get(j as usize)?.w_axis.truncate();
                projection.to_screen(p + origin).map(|(at, _)| (at, j))
            });
            if let Some(joint) = nearest_within(pointer, joints) {
                let available = crate::ik::ancestors(&model.asset, joint);
                pending = Some(Command::ReplaceIk {
                    goal: model.ik_selected,
                    effector: joint,
                    depth: ik.depth().min(available).max(1),
                });
            }
        } else if response.dragged_by(egui::PointerButton::Primary) && !shift && !multi_touch {
            self.stage.camera.orbit_pixels(delta.x, delta.y, height);
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
            || (response.dragged_by(egui::PointerButton::Primary) && shift)
        {
            self.stage.camera.pan_pixels(delta.x, delta.y, height);
        }
        // The wheel over an IK ring (or while dragging one) moves its target along the view
        // direction instead of zooming.
        let ring = self.ik_drag.or_else(|| response.hover_pos().and_then(handle_at));
        if let Some(handle) = ring
            && let Some(ik) = self.stage.model.as_mut().and_then(|m| m.ik.get_mut(handle.goal))
            && let Some(point) = handle.point(ik)
        {
            let scroll = ui.input(|i| {
                i.raw
                    .events
                    .iter()
                    .filter_map(|e| match e {
                        egui::Event::MouseWheel { unit, delta, .. } => Some(match unit {
                            egui::MouseWheelUnit::Point => delta.y,
                            egui::MouseWheelUnit::Line => delta.y * 40.0,
                            egui::MouseWheelUnit::Page => delta.y * 400.0,
                        }),
                        _ => None,
                    })
                    .sum::<f32>()
            });
            if scroll != 0.0
                && let Some(direction) = (*point + origin - self.stage.camera.eye()).try_normalize()
            {
                *point -= direction * scroll * IK_DEPTH_PER_POINT * self.stage.camera.distance;
            }
        } else if response.hovered() {
            let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta.y, i.zoom_delta()));
            if scroll != 0.0 {
                self.stage.camera.zoom_scroll(scroll);
            }
            if zoom != 1.0 {
                self.stage.camera.zoom(1.0 / zoom);
            }
        }
        // Two fingers pan (their pinch zooms through zoom_delta above); one finger orbits as a drag.
        if response.hovered()
            && let Some(touch) = ui.input(|i| i.multi_touch())
            && touch.num_touches >= 2
        {
            self.stage.camera.pan_pixels(touch.translation_delta.x, touch.translation_delta.y, height);
        }
        if response.double_clicked() {
            self.stage.frame_model();
        }

        if self.stage.model.is_none() {
            ui.painter().rect_filled(rect, 0.0, ui.visuals().extreme_bg_color);
            let invitation = if self.stage.panels {
                "Drop a .glb or .gltf file here,\nor open one from Samples or Open (top of the panel)"
            } else {
                "Drop a .glb or .gltf file here"
            };
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                invitation,
                egui::FontId::proportional(18.0),
                ui.visuals().weak_text_color(),
            );
            return;
        }
        let ppp = ui.ctx().pixels_per_point();
        let gpu = &self.gpu;
        let Some(view) = self.stage.render_view(rect, ppp) else {
            // Drawn straight into the canvas (or dropped: it could not be drawn).
            self.paint_overlays(ui, rect, &response, &projection, origin);
            if let Some(command) = pending
                && let Err(message) = self.stage.apply(command)
            {
                self.stage.fail(message);
            }
            return;
        };
        {
            let version = self.stage.scene.target_version();
            let mut renderer = gpu.renderer.write();
            let id = match &mut self.viewport {
                Some(texture) if texture.version == version => texture.id,
                Some(texture) => {
                    renderer.update_egui_texture_from_wgpu_texture(
                        &gpu.device,
                        &view,
                        wgpu::FilterMode::Linear,
                        texture.id,
                    );
                    texture.version = version;
                    texture.id
                }
                None => {
                    let id = renderer.register_native_texture(&gpu.device, &view, wgpu::FilterMode::Linear);
                    self.viewport = Some(ViewportTexture { id, version });
                    id
                }
            };
            let uv = Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0));
            ui.painter().image(id, rect, uv, Color32::WHITE);
        }
        self.paint_overlays(ui, rect, &response, &projection, origin);
        if let Some(command) = pending
            && let Err(message) = self.stage.apply(command)
        {
            self.stage.fail(message);
        }
    }

    /// The overlays, the IK chains and their handles over the 3D view at `rect`.
    fn paint_overlays(
        &mut self,
        ui: &egui::Ui,
        rect: Rect,
        response: &egui::Response,
        projection: &Projection,
        origin: Vec3,
    ) {
        if let Some(model) = self.stage.model.as_mut() {
            let painter = ui.painter_at(rect);
            overlay::paint_mesh_lines(
                &painter,
                model,
                projection,
                origin,
                self.stage.overlays,
                &mut self.overlay_scratch,
            );
            if self.stage.overlays.bounds
                && let Some(bounds) = model.bounds
            {
                overlay::paint_box(&painter, projection, bounds, origin);
            }
            // A file without meshes (a bare skeleton) always shows its skeleton (pose mode draws its own).
            if (self.stage.overlays.skeleton || !model.has_meshes()) && !model.pose_mode {
                let points = overlay::joint_points(model, projection, origin);
                let hovered = response.hover_pos().and_then(|p| nearest_within(p, points.iter().copied()));
                overlay::paint_skeleton(&painter, model, &points, model.selected_joint, hovered);
            }
            if self.stage.overlays.bodies
                && let Some(state) = &model.ragdoll
            {
                overlay::paint_bodies(&painter, projection, origin, &state.ragdoll);
            }
            if let Some(joint) = model.selected_joint {
                let size = model.bounds.map_or(1.0, |(lo, hi)| (hi - lo).length());
                overlay::paint_axes(&painter, model, projection, origin, joint, size);
            }
        }
        self.paint_world(&ui.painter_at(rect), projection, origin);
        self.paint_pose(&ui.painter_at(rect), response, projection, origin);
        self.ik_markers.clear();
        self.ik_pole_markers.clear();
        if let Some(model) = self.stage.model.as_ref() {
            for ik in model.ik.iter().filter(|ik| ik.use_limits) {
                let frames = ik.limit_frames(model.instance.worlds());
                overlay::paint_limits(ui.painter(), projection, origin, &frames, &ik.limits);
            }
            for (i, ik) in model.ik.iter().enumerate() {
                let selected = i == model.ik_selected && model.ik.len() > 1;
                let dragging = self.ik_drag.is_some_and(|h| h.goal == i);
                let (target, pole) = paint_ik(ui.painter(), projection, ik, origin, dragging || selected);
                if let Some(at) = target {
                    self.ik_markers.push(at);
                }
                self.ik_pole_markers.push(pole);
            }
        }
    }
}
