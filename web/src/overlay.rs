//! What the viewport draws over the rendered model with egui's painter: the skeleton (joint
//! names on hover), the selected joint's axes, the framing bounds, and the deformed mesh's
//! wireframe and normals (deformed on the CPU by the core's reference job, for the main
//! character only), plus the world ↔ viewport projection the app's pointer handling uses.

use egui::{Color32, Pos2, Rect, Stroke};
use glam::{Mat4, Vec3};
use kloub_core::asset::NodeIndex;

use crate::model::Model;
use crate::render::Camera;

/// Pointer distance (points) within which a marker or joint is picked.
pub const GRAB_RADIUS: f32 = 14.0;

/// Most edges the wireframe and normals draw (beyond it they are skipped: the painter would
/// take longer than the frame).
pub const MAX_OVERLAY_LINES: usize = 120_000;

pub use crate::stage::Overlays;

/// Buffers the overlays reuse between frames.
#[derive(Debug, Default)]
pub struct OverlayScratch {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
}

/// World ↔ viewport points for one frame's camera.
pub struct Projection {
    view_proj: Mat4,
    inverse: Mat4,
    rect: Rect,
}

impl Projection {
    pub fn new(camera: &Camera, rect: Rect) -> Self {
        let aspect = (rect.width() / rect.height().max(1.0)).max(1e-3);
        let view_proj = camera.view_proj(aspect);
        Self { view_proj, inverse: view_proj.inverse(), rect }
    }

    /// The ray under `at`: a point on it (the near plane) and its unit direction.
    pub fn ray(&self, at: Pos2) -> Option<(Vec3, Vec3)> {
        let near = self.unproject(at, 0.0)?;
        let direction = (self.unproject(at, 0.9)? - near).try_normalize()?;
        Some((near, direction))
    }

    /// The view-projection's bits (tells one frame's view from another).
    pub fn key(&self) -> [u32; 16] {
        self.view_proj.to_cols_array().map(f32::to_bits)
    }

    /// Where `p` appears, and its depth (NDC z); `None` behind the camera.
    pub fn to_screen(&self, p: Vec3) -> Option<(Pos2, f32)> {
        let c = self.view_proj * p.extend(1.0);
        if c.w <= 1e-6 || !c.is_finite() {
            return None;
        }
        let n = c.truncate() / c.w;
        let r = self.rect;
        Some((Pos2::new(r.min.x + (n.x + 1.0) * 0.5 * r.width(), r.min.y + (1.0 - n.y) * 0.5 * r.height()), n.z))
    }

    /// The world point under `at` at NDC depth `depth`.
    pub fn unproject(&self, at: Pos2, depth: f32) -> Option<Vec3> {
        let r = self.rect;
        let ndc = Vec3::new((at.x - r.min.x) / r.width() * 2.0 - 1.0, 1.0 - (at.y - r.min.y) / r.height() * 2.0, depth);
        let w = self.inverse * ndc.extend(1.0);
        (w.w.abs() > 1e-12).then(|| w.truncate() / w.w).filter(|p| p.is_finite())
    }
}

/// The item drawn nearest to `pointer`, within [`GRAB_RADIUS`].
pub fn nearest_within<T>(pointer: Pos2, items: impl Iterator<Item = (Pos2, T)>) -> Option<T> {
    items
        .map(|(at, item)| (at.distance(pointer), item))
        .filter(|(d, _)| *d <= GRAB_RADIUS)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, item)| item)
}

/// Where each skeleton joint is drawn this frame (for hover and picking): joints of every
/// skin, or every node of a file without skins.
pub fn joint_points(model: &Model, projection: &Projection, origin: Vec3) -> Vec<(Pos2, NodeIndex)> {
    let worlds = model.instance.worlds();
    let nodes: Vec<NodeIndex> = if model.asset.skins.iter().any(|s| !s.joints.is_empty()) {
        let mut joints: Vec<NodeIndex> = model.asset.skins.iter().flat_map(|s| s.joints.iter().copied()).collect();
        joints.sort_unstable();
        joints.dedup();
        joints
    } else {
        (0..model.asset.nodes.len()).filter_map(|n| NodeIndex::try_from(n).ok()).collect()
    };
    nodes
        .into_iter()
        .filter_map(|n| {
            let p = worlds.get(n as usize)?.w_axis.truncate() + origin;
            projection.to_screen(p).map(|(at, _)| (at, n))
        })
        .collect()
}

/// Draws the skeleton: a bone from each drawn joint to its drawn parent, a dot per joint
/// (the selected one larger), and the name of `hovered`.
pub fn paint_skeleton(
    painter: &egui::Painter,
    model: &Model,
    points: &[(Pos2, NodeIndex)],
    selected: Option<NodeIndex>,
    hovered: Option<NodeIndex>,
) {
    let at: std::collections::HashMap<NodeIndex, Pos2> = points.iter().map(|&(p, n)| (n, p)).collect();
    let bone = Stroke::new(2.0, Color32::from_rgba_unmultiplied(120, 200, 255, 220));
    for &(p, n) in points {
        let parent = model.asset.nodes.get(n as usize).and_then(|node| node.parent);
        if let Some(q) = parent.and_then(|parent| at.get(&parent)) {
            painter.line_segment([*q, p], bone);
        }
    }
    for &(p, n) in points {
        let big = selected == Some(n) || hovered == Some(n);
        painter.circle_filled(p, if big { 5.0 } else { 3.0 }, Color32::from_rgb(120, 200, 255));
    }
    if let Some(n) = hovered
        && let Some(p) = at.get(&n)
    {
        let name = model.node_name(n);
        let galley = painter.layout_no_wrap(name, egui::FontId::proportional(13.0), Color32::WHITE);
        let pos = *p + egui::vec2(10.0, -10.0 - galley.size().y);
        painter.rect_filled(Rect::from_min_size(pos, galley.size()).expand(3.0), 3.0, Color32::from_black_alpha(190));
        painter.galley(pos, galley, Color32::WHITE);
    }
}

/// Draws the local axes of `node` (X red, Y green, Z blue), each a tenth of `size` long.
pub fn paint_axes(
    painter: &egui::Painter,
    model: &Model,
    projection: &Projection,
    origin: Vec3,
    node: NodeIndex,
    size: f32,
) {
    let Some(world) = model.instance.worlds().get(node as usize) else { return };
    let o = world.w_axis.truncate() + origin;
    let Some((from, _)) = projection.to_screen(o) else { return };
    let colors = [Color32::from_rgb(240, 70, 70), Color32::from_rgb(80, 220, 90), Color32::from_rgb(80, 140, 255)];
    for (axis, color) in [world.x_axis, world.y_axis, world.z_axis].into_iter().zip(colors) {
        let Some(dir) = axis.truncate().try_normalize() else { continue };
        if let Some((to, _)) = projection.to_screen(o + dir * size * 0.1) {
            painter.line_segment([from, to], Stroke::new(2.5, color));
        }
    }
}

/// Draws each limited chain joint's allowed range: a hinge as an arc from its smallest to
/// its largest angle in the plane it turns in, a ball joint as its swing cone. `frames` are
/// [`crate::ik::IkState::limit_frames`] (joint, rest frame, bone), `limits` the same joints'.
pub fn paint_limits(
    painter: &egui::Painter,
    projection: &Projection,
    origin: Vec3,
    frames: &[(Vec3, glam::Quat, Vec3)],
    limits: &[kloub_core::job::ik::JointLimit],
) -> usize {
    use kloub_core::job::ik::JointLimit;
    const STEPS: usize = 24;
    let stroke = Stroke::new(1.5, Color32::from_rgba_unmultiplied(255, 214, 64, 170));
    let screen = |p: Vec3| projection.to_screen(p + origin).map(|s| s.0);
    let drawn = std::cell::Cell::new(0);
    let polyline = |points: &[Vec3]| {
        let pts: Vec<Pos2> = points.iter().filter_map(|&p| screen(p)).collect();
        if pts.len() == points.len() {
            painter.add(egui::Shape::line(pts, stroke));
            drawn.set(drawn.get() + 1);
        }
    };
    for (&(at, frame, bone), limit) in frames.iter().zip(limits) {
        let radius = bone.length() * 0.4;
        if radius <= 0.0 {
            continue;
        }
        match *limit {
            JointLimit::Free => {}
            JointLimit::Hinge { axis, min, max } => {
                let axis_w = (frame * axis).normalize_or_zero();
                let reference = frame * bone.reject_from_normalized(axis.normalize_or_zero());
                let Some(reference) = reference.try_normalize() else { continue };
                let arc: Vec<Vec3> = (0..=STEPS)
                    .map(|i| {
                        let a = min + (max - min) * i as f32 / STEPS as f32;
                        at + glam::Quat::from_axis_angle(axis_w, a) * reference * radius
                    })
                    .collect();
                polyline(&arc);
                for end in [arc.first(), arc.last()].into_iter().flatten() {
                    polyline(&[at, *end]);
                }
            }
            JointLimit::Ball { axis, swing, .. } => {
                let axis_w = (frame * axis).normalize_or_zero();
                let u = axis_w.any_orthonormal_vector();
                let v = axis_w.cross(u);
                let rim: Vec<Vec3> = (0..=STEPS)
                    .map(|i| {
                        let phi = std::f32::consts::TAU * i as f32 / STEPS as f32;
                        let dir = axis_w * swing.cos() + (u * phi.cos() + v * phi.sin()) * swing.sin();
                        at + dir * radius
                    })
                    .collect();
                polyline(&rim);
                for i in (0..STEPS).step_by(STEPS / 4) {
                    polyline(&[at, rim[i]]);
                }
            }
        }
    }
    drawn.get()
}

/// Draws the ragdoll's capsules: each as its axis with a circle of its radius at both ends
/// (radius measured on screen at the capsule's centre).
pub fn paint_bodies(
    painter: &egui::Painter,
    projection: &Projection,
    origin: Vec3,
    ragdoll: &kloub_core::ragdoll::Ragdoll,
) -> usize {
    let stroke = Stroke::new(1.5, Color32::from_rgb(120, 255, 170));
    let mut drawn = 0;
    for (i, body) in ragdoll.bodies().iter().enumerate() {
        let Some((rotation, center)) = ragdoll.body_pose(i) else { continue };
        let axis = rotation * Vec3::Y * body.half_height;
        let (a, b) = (center - axis + origin, center + axis + origin);
        let side = (rotation * Vec3::X) * body.radius;
        let (Some((pa, _)), Some((pb, _)), Some((pc, _)), Some((ps, _))) = (
            projection.to_screen(a),
            projection.to_screen(b),
            projection.to_screen(center + origin),
            projection.to_screen(center + origin + side),
        ) else {
            continue;
        };
        let r = pc.distance(ps).max(1.0);
        painter.line_segment([pa, pb], stroke);
        painter.circle_stroke(pa, r, stroke);
        painter.circle_stroke(pb, r, stroke);
        drawn += 1;
    }
    drawn
}

/// Draws the box `(min, max)` offset by `origin`.
pub fn paint_box(painter: &egui::Painter, projection: &Projection, (min, max): (Vec3, Vec3), origin: Vec3) {
    let corner = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        ) + origin
    };
    let stroke = Stroke::new(1.5, Color32::from_rgb(255, 180, 60));
    for i in 0..8 {
        for bit in [1, 2, 4] {
            let j = i | bit;
            if j != i
                && let (Some((a, _)), Some((b, _))) = (projection.to_screen(corner(i)), projection.to_screen(corner(j)))
            {
                painter.line_segment([a, b], stroke);
            }
        }
    }
}

/// Draws the wireframe and/or the normals of the main character's meshes as deformed now
/// (morphs and the chosen skinning method, by the core's CPU reference). Returns the lines
/// drawn (0 when over [`MAX_OVERLAY_LINES`]).
pub fn paint_mesh_lines(
    painter: &egui::Painter,
    model: &mut Model,
    projection: &Projection,
    origin: Vec3,
    overlays: Overlays,
    scratch: &mut OverlayScratch,
) -> usize {
    if !overlays.wireframe && !overlays.normals {
        return 0;
    }
    let asset = &model.asset;
    let mut total = 0usize;
    for node in &asset.nodes {
        if let Some(mesh) = node.mesh.and_then(|m| asset.meshes.get(m as usize)) {
            for p in &mesh.primitives {
                total += if overlays.wireframe { p.indices.len() } else { 0 };
                total += if overlays.normals { p.normals.len() } else { 0 };
            }
        }
    }
    if total > MAX_OVERLAY_LINES {
        return 0;
    }
    let length = model.bounds.map_or(0.05, |(lo, hi)| (hi - lo).length() * 0.02);
    let wire = Stroke::new(1.0, Color32::from_rgba_unmultiplied(230, 230, 230, 110));
    let normal = Stroke::new(1.0, Color32::from_rgb(255, 80, 220));
    let mut drawn = 0;
    let Model { asset, instance, .. } = model;
    for (n, node) in asset.nodes.iter().enumerate() {
        let Some(mesh) = node.mesh.and_then(|m| asset.meshes.get(m as usize)) else { continue };
        let Ok(index) = u32::try_from(n) else { continue };
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if instance.deform_primitive(asset, index, p, &mut scratch.positions, &mut scratch.normals).is_err() {
                continue;
            }
            let screen: Vec<Option<Pos2>> =
                scratch.positions.iter().map(|&v| projection.to_screen(Vec3::from(v) + origin).map(|s| s.0)).collect();
            if overlays.wireframe && prim.topology == kloub_core::asset::Topology::Triangles {
                for tri in prim.indices.chunks_exact(3) {
                    let v = |i: u32| screen.get(i as usize).copied().flatten();
                    if let (Some(a), Some(b), Some(c)) = (v(tri[0]), v(tri[1]), v(tri[2])) {
                        painter.line_segment([a, b], wire);
                        painter.line_segment([b, c], wire);
                        painter.line_segment([c, a], wire);
                        drawn += 3;
                    }
                }
            }
            if overlays.normals {
                for (v, nrm) in scratch.positions.iter().zip(&scratch.normals) {
                    let from = Vec3::from(*v) + origin;
                    let to = from + Vec3::from(*nrm).normalize_or_zero() * length;
                    if let (Some((a, _)), Some((b, _))) = (projection.to_screen(from), projection.to_screen(to)) {
                        painter.line_segment([a, b], normal);
                        drawn += 1;
                    }
                }
            }
        }
    }
    drawn
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_round_trips_and_picks_the_nearest() {
        let camera = Camera::default();
        let rect = Rect::from_min_size(Pos2::new(10.0, 20.0), egui::vec2(400.0, 300.0));
        let projection = Projection::new(&camera, rect);
        let (at, depth) = projection.to_screen(camera.target).unwrap_or((Pos2::ZERO, 0.0));
        assert!((at - rect.center()).length() < 1e-3, "the target projects to the centre: {at:?}");
        let back = projection.unproject(at, depth).unwrap_or(Vec3::splat(f32::NAN));
        assert!((back - camera.target).length() < 1e-3 * camera.distance.max(1.0), "{back:?}");
        let items = [(Pos2::new(0.0, 0.0), 'a'), (Pos2::new(5.0, 0.0), 'b'), (Pos2::new(100.0, 0.0), 'c')];
        assert_eq!(nearest_within(Pos2::new(4.0, 0.0), items.into_iter()), Some('b'));
        assert_eq!(nearest_within(Pos2::new(60.0, 0.0), items.into_iter()), None);
    }

    #[test]
    fn limits_draw_an_arc_per_hinge_and_a_cone_per_ball() {
        use kloub_core::job::ik::JointLimit;
        let camera = Camera { target: Vec3::ZERO, distance: 5.0, ..Camera::default() };
        let rect = Rect::from_min_size(Pos2::ZERO, egui::vec2(400.0, 300.0));
        let projection = Projection::new(&camera, rect);
        let frames = [(Vec3::ZERO, glam::Quat::IDENTITY, Vec3::Y), (Vec3::Y, glam::Quat::IDENTITY, Vec3::Y)];
        let hinge = JointLimit::Hinge { axis: Vec3::X, min: 0.0, max: 2.0 };
        let ball = JointLimit::Ball { axis: Vec3::Y, swing: 0.8, twist_min: -0.5, twist_max: 0.5 };
        let ctx = egui::Context::default();
        let mut counts = Vec::new();
        let mut output = ctx.run_ui(egui::RawInput::default(), |ui| {
            let painter = ui.painter();
            counts.push(paint_limits(painter, &projection, Vec3::ZERO, &frames, &[hinge, ball]));
            counts.push(paint_limits(painter, &projection, Vec3::ZERO, &frames, &[JointLimit::Free, JointLimit::Free]));
        });
        output.textures_delta.clear();
        // Hinge: the arc and its two end spokes; ball: the rim and four spokes.
        assert_eq!(counts, [3 + 5, 0]);
    }
}
