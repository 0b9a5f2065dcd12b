//! The ragdoll's world in the 3D view: the obstacles and thrown balls drawn over the scene,
//! a click throwing a ball from the camera at the character, and the test hook's readout.

use kloub_core::ragdoll::Piece;

use super::*;

/// How far from the character an obstacle may be dragged, in its sizes (the ground reaches 50).
const DRAG_REACH: f32 = 20.0;

/// A thrown ball's speed, in the model's sizes per second.
const BALL_SPEED: f32 = 4.0;

/// Obstacle fill and outline.
const OBSTACLE_FILL: Color32 = Color32::from_rgba_premultiplied(70, 90, 120, 150);
const OBSTACLE_EDGE: Color32 = Color32::from_rgb(150, 180, 220);
const BALL_FILL: Color32 = Color32::from_rgb(235, 150, 60);

impl App {
    /// A click while the ragdoll runs throws a ball from the camera through the clicked point.
    pub(super) fn throw_at(&mut self, pointer: Pos2, projection: &Projection, origin: Vec3) {
        let Some(model) = self.stage.model.as_ref() else { return };
        if model.ragdoll.is_none() {
            return;
        }
        let Some((_, direction)) = projection.ray(pointer) else { return };
        let size = model.size();
        let from = self.stage.camera.eye() - origin + direction * 0.05 * size;
        let velocity = direction * BALL_SPEED * size;
        if let Err(message) =
            self.stage.apply(Command::ThrowBall { from: from.to_array(), velocity: velocity.to_array() })
        {
            self.stage.fail(message);
        }
    }

    /// Dragging an obstacle moves it over the floor (in the horizontal plane through its
    /// centre) under the pointer; returns whether it took the pointer.
    pub(super) fn obstacle_input(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        projection: &Projection,
        origin: Vec3,
        shift: bool,
    ) -> bool {
        let Some(model) = self.stage.model.as_ref() else { return false };
        if response.drag_started_by(egui::PointerButton::Primary) && !shift && !model.pose_mode {
            let press = ui.input(|i| i.pointer.press_origin()).or_else(|| response.interact_pointer_pos());
            self.obstacle_drag = press.and_then(|p| {
                (model.obstacles.iter().enumerate())
                    .filter_map(|(i, o)| {
                        let center = o.center() + origin;
                        let (at, _) = projection.to_screen(center)?;
                        // Grabbed near its centre (a wide obstacle around the feet must not take
                        // every drag meant for the camera).
                        let reach = screen_radius(projection, center, 0.25 * obstacle_reach(o)).unwrap_or(0.0);
                        let d = at.distance(p);
                        (d <= reach.clamp(overlay::GRAB_RADIUS, 4.0 * overlay::GRAB_RADIUS)).then_some((d, i))
                    })
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .map(|(_, i)| i)
            });
        }
        let Some(index) = self.obstacle_drag else { return false };
        if let Some(pointer) = response.interact_pointer_pos()
            && let Some(obstacle) = model.obstacles.get(index)
            && let Some((near, direction)) = projection.ray(pointer)
        {
            // Where the pointer's ray meets the horizontal plane through the obstacle's centre.
            let center = obstacle.center();
            let from = near - origin;
            if direction.y.abs() > 1e-4 {
                let t = (center.y - from.y) / direction.y;
                let hit = from + direction * t;
                // Kept within the ground's reach around the character.
                let (lo, hi) = model.bounds.unwrap_or((Vec3::ZERO, Vec3::ZERO));
                let middle = 0.5 * (lo + hi);
                let reach = DRAG_REACH * model.size();
                let hit = Vec3::new(
                    hit.x.clamp(middle.x - reach, middle.x + reach),
                    center.y,
                    hit.z.clamp(middle.z - reach, middle.z + reach),
                );
                if t > 0.0 && hit.is_finite() && hit.distance(center) > 0.0 {
                    let mut list = model.obstacles.clone();
                    list[index] = obstacle.moved_to(hit);
                    if let Err(message) = self.stage.apply(Command::SetObstacles(list)) {
                        self.stage.fail(message);
                    }
                }
            }
        }
        if !response.dragged() || response.drag_stopped() {
            self.obstacle_drag = None;
        }
        true
    }

    /// Draws the obstacles (their faces towards the camera, shaded by facing) and the balls.
    pub(super) fn paint_world(&mut self, painter: &egui::Painter, projection: &Projection, origin: Vec3) {
        self.obstacle_marks.clear();
        let Some(model) = self.stage.model.as_ref() else { return };
        let eye = self.stage.camera.eye();
        for obstacle in &model.obstacles {
            self.obstacle_marks.push(projection.to_screen(obstacle.center() + origin).map(|s| s.0));
            for piece in obstacle.pieces() {
                paint_piece(painter, projection, origin, eye, piece);
            }
        }
        if let Some(state) = &model.ragdoll {
            for (center, radius) in state.ragdoll.balls() {
                paint_ball(painter, projection, center + origin, radius, BALL_FILL);
            }
        }
    }

    /// Where each obstacle's centre was drawn last frame, `[[x, y] | null, …]` in CSS pixels of
    /// the canvas (a test hook).
    #[cfg_attr(not(target_arch = "wasm32"), allow(dead_code, reason = "read by the wasm entry's test hook"))]
    pub(crate) fn obstacles_json(&self) -> String {
        let marks: Vec<serde_json::Value> = self
            .obstacle_marks
            .iter()
            .map(|m| m.map_or(serde_json::Value::Null, |p| serde_json::json!([p.x, p.y])))
            .collect();
        serde_json::Value::Array(marks).to_string()
    }

    /// `{"ground": y, "bodies": [[x, y, z], …], "balls": n}` of the running ragdoll; `""` without one.
    #[cfg_attr(not(target_arch = "wasm32"), allow(dead_code, reason = "read by the wasm entry's test hook"))]
    pub(crate) fn ragdoll_json(&self) -> String {
        let Some(state) = self.stage.model.as_ref().and_then(|m| m.ragdoll.as_ref()) else { return String::new() };
        let r = &state.ragdoll;
        let bodies: Vec<[f32; 3]> =
            (0..r.bodies().len()).filter_map(|i| r.body_pose(i)).map(|(_, c)| c.to_array()).collect();
        serde_json::json!({ "ground": r.ground(), "bodies": bodies, "balls": r.balls().len() }).to_string()
    }
}

/// One convex piece: a box's or a ramp's faces, a sphere's disc, a capsule's outline.
fn paint_piece(painter: &egui::Painter, projection: &Projection, origin: Vec3, eye: Vec3, piece: Piece) {
    match piece {
        Piece::Cuboid(center, half, rotation) => {
            let corner = |i: usize| {
                let s = Vec3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                );
                center + rotation * (s * half) + origin
            };
            let corners: Vec<Vec3> = (0..8).map(corner).collect();
            // Faces wound outwards: -x, +x, -y, +y, -z, +z.
            let faces: [[usize; 4]; 6] =
                [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
            paint_faces(painter, projection, eye, &corners, &faces);
        }
        Piece::Hull(points) => {
            let corners: Vec<Vec3> = points.iter().map(|p| *p + origin).collect();
            // The ramp's wedge: bottom, back, slope, two sides.
            let faces: [&[usize]; 5] = [&[0, 1, 3, 2], &[2, 3, 5, 4], &[0, 4, 5, 1], &[0, 2, 4], &[1, 5, 3]];
            for face in faces {
                paint_polygon(painter, projection, eye, &corners, face);
            }
        }
        Piece::Ball(center, radius) => paint_ball(painter, projection, center + origin, radius, OBSTACLE_FILL),
        Piece::Capsule(center, half, radius, rotation) => {
            let axis = rotation * Vec3::Y * half;
            let (a, b) = (center - axis + origin, center + axis + origin);
            paint_ball(painter, projection, a, radius, OBSTACLE_FILL);
            paint_ball(painter, projection, b, radius, OBSTACLE_FILL);
            if let (Some((pa, _)), Some((pb, _))) = (projection.to_screen(a), projection.to_screen(b)) {
                let r = screen_radius(projection, a, radius).unwrap_or(2.0);
                painter.line_segment([pa, pb], egui::Stroke::new(2.0 * r, OBSTACLE_FILL));
            }
        }
    }
}

fn paint_faces(painter: &egui::Painter, projection: &Projection, eye: Vec3, corners: &[Vec3], faces: &[[usize; 4]]) {
    for face in faces {
        paint_polygon(painter, projection, eye, corners, face);
    }
}

/// A planar face (outward winding, counter-clockwise seen from outside), drawn when it faces
/// the camera, lighter the more it faces up.
fn paint_polygon(painter: &egui::Painter, projection: &Projection, eye: Vec3, corners: &[Vec3], face: &[usize]) {
    let Some(points) = face.iter().map(|&i| corners.get(i).copied()).collect::<Option<Vec<Vec3>>>() else { return };
    let [a, b, c, ..] = points[..] else { return };
    let normal = (b - a).cross(c - a).normalize_or_zero();
    if normal.dot(eye - a) <= 0.0 {
        return;
    }
    let Some(screen) = points.iter().map(|p| projection.to_screen(*p).map(|s| s.0)).collect::<Option<Vec<Pos2>>>()
    else {
        return;
    };
    let light = 0.65 + 0.35 * normal.y.max(0.0);
    let fill = Color32::from_rgba_premultiplied(
        (f32::from(OBSTACLE_FILL.r()) * light) as u8,
        (f32::from(OBSTACLE_FILL.g()) * light) as u8,
        (f32::from(OBSTACLE_FILL.b()) * light) as u8,
        OBSTACLE_FILL.a(),
    );
    painter.add(egui::Shape::convex_polygon(screen, fill, egui::Stroke::new(1.0, OBSTACLE_EDGE)));
}

fn paint_ball(painter: &egui::Painter, projection: &Projection, center: Vec3, radius: f32, fill: Color32) {
    let (Some((at, _)), Some(r)) = (projection.to_screen(center), screen_radius(projection, center, radius)) else {
        return;
    };
    painter.circle(at, r, fill, egui::Stroke::new(1.0, OBSTACLE_EDGE));
}

/// How far an obstacle reaches from its centre (model units), for grabbing it.
fn obstacle_reach(o: &kloub_core::ragdoll::Obstacle) -> f32 {
    use kloub_core::ragdoll::Obstacle;
    match *o {
        Obstacle::Box { size, .. } | Obstacle::Stairs { size, .. } | Obstacle::Ramp { size, .. } => {
            0.5 * size.max_element()
        }
        Obstacle::Sphere { radius, .. } => radius,
        Obstacle::Capsule { radius, height, .. } => radius + 0.5 * height,
    }
}

/// How many points a sphere of `radius` at `center` spans on screen.
fn screen_radius(projection: &Projection, center: Vec3, radius: f32) -> Option<f32> {
    let (at, _) = projection.to_screen(center)?;
    let up = projection.to_screen(center + Vec3::Y * radius)?.0;
    Some(at.distance(up).max(1.0))
}
