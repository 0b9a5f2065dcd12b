//! The "candy wrapper" rig: a procedural two-bone cylinder for comparing skinning methods
//! (seed 001's test model), with the quality measures the viewer shows and the tests check.
//!
//! The cylinder lies along +X from x = −1 to x = 1 (radius [`RADIUS`]), closed by caps.
//! Joint 0 (`Root`) sits at its left end, joint 1 (`Joint`) at x = 0 and an unweighted `Tip`
//! at the right end (it gives `Joint`'s bone a direction); vertices within
//! [`BLEND_HALF_WIDTH`] of the joint blend linearly between the two. Twisting `Joint` about X
//! collapses linear blend skinning at the joint (the candy wrapper); bending it about Z loses
//! volume. Vertex colours stripe the surface so twist is visible.
//!
//! [`CandyWrapper::examples`] is an example pose for spherical joint blending by example:
//! `Joint` bent 90° with a bulge around the joint whose height keeps the volume at that bend.

use std::f32::consts::TAU;

use crate::asset::{Asset, Material, Mesh, Node, Primitive, Scene, Skin, Topology};
use crate::clip::{Channel, ChannelTarget, Clip, Interpolation};
use crate::error::JobError;
use crate::examples::{ExampleShape, Examples, JointExample};
use crate::instance::Instance;
use crate::job::dqs::SkinningMethod;
use crate::math::{Mat4, Quat, Transform, Vec3};

/// Cylinder radius.
pub const RADIUS: f32 = 0.25;
/// Vertices blend between the joints for |x| < this.
pub const BLEND_HALF_WIDTH: f32 = 0.3;
/// Rings along the cylinder (the middle one, [`JOINT_RING`], is at the joint).
pub const RINGS: usize = 41;
/// Vertices per ring.
pub const SEGMENTS: usize = 32;
/// Index of the ring at the joint.
pub const JOINT_RING: usize = RINGS / 2;
/// Node index of the twisting joint.
pub const JOINT_NODE: u32 = 1;
/// Bend of the example pose ([`CandyWrapper::examples`]), degrees.
pub const EXAMPLE_BEND: f32 = 90.0;

/// Quality of a deformed candy wrapper relative to its rest shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quality {
    /// Mean distance of the joint ring from its centroid over [`RADIUS`] (1: kept, 0: collapsed).
    pub radius_kept: f32,
    /// Enclosed volume over the rest volume.
    pub volume_ratio: f32,
}

/// The rig: an asset (one skinned mesh, two joints, `Twist` and `Bend` clips) and its rest
/// volume.
#[derive(Clone, Debug)]
pub struct CandyWrapper {
    /// The asset to load into the viewer or an [`Instance`].
    pub asset: Asset,
    rest_volume: f32,
    /// [`CandyWrapper::examples`], found on first use (a bisection over deformations).
    examples: std::cell::OnceCell<Examples>,
}

impl Default for CandyWrapper {
    fn default() -> Self {
        Self::new()
    }
}

impl CandyWrapper {
    /// Builds the rig.
    pub fn new() -> Self {
        let primitive = cylinder();
        let rest_volume = mesh_volume(&primitive.positions, &primitive.indices);
        let joint = |name: &str, parent, children, x| Node {
            name: Some(name.to_owned()),
            parent,
            children,
            rest: Transform { translation: Vec3::new(x, 0.0, 0.0), ..Transform::IDENTITY },
            ..Node::default()
        };
        let nodes = vec![
            joint("Root", None, vec![1], -1.0),
            joint("Joint", Some(0), vec![3], 1.0),
            Node { name: Some("Cylinder".into()), mesh: Some(0), skin: Some(0), ..Node::default() },
            joint("Tip", Some(1), vec![], 1.0),
        ];
        let skin = Skin {
            name: Some("CandyWrapper".into()),
            joints: vec![0, 1, 3],
            inverse_bind: vec![Mat4::from_translation(Vec3::X), Mat4::IDENTITY, Mat4::from_translation(-Vec3::X)],
            skeleton: Some(0),
        };
        let material = Material {
            name: Some("Stripes".into()),
            roughness: 0.6,
            metallic: 0.0,
            double_sided: false,
            ..Material::default()
        };
        let asset = Asset {
            nodes,
            order: vec![0, 1, 2, 3],
            scenes: vec![Scene { name: Some("Candy wrapper".into()), roots: vec![0, 2] }],
            default_scene: Some(0),
            meshes: vec![Mesh { name: Some("Cylinder".into()), primitives: vec![primitive], ..Mesh::default() }],
            skins: vec![skin],
            materials: vec![material],
            images: Vec::new(),
            clips: vec![swing("Twist", Vec3::X, 180.0), swing("Bend", Vec3::Z, 150.0)],
            weight_offsets: vec![0; 4],
            weight_total: 0,
            extensions: Default::default(),
        };
        CandyWrapper { asset, rest_volume, examples: std::cell::OnceCell::new() }
    }

    /// Poses `instance` (made for [`CandyWrapper::asset`]): `Joint` twisted about the bone
    /// axis by `twist_degrees`, then bent about Z by `bend_degrees`.
    pub fn pose(&self, instance: &mut Instance, twist_degrees: f32, bend_degrees: f32) -> Result<(), JobError> {
        self.pose_in(&self.asset, instance, twist_degrees, bend_degrees)
    }

    /// [`CandyWrapper::pose`] for an instance of `asset`: the rig's asset or one made from it
    /// (with the example pose's morph targets, [`crate::examples::ExampleTargets`]).
    pub fn pose_in(
        &self,
        asset: &Asset,
        instance: &mut Instance,
        twist_degrees: f32,
        bend_degrees: f32,
    ) -> Result<(), JobError> {
        instance.pose_mut().reset_to_rest(asset);
        let local = instance
            .pose_mut()
            .locals
            .get_mut(JOINT_NODE as usize)
            .ok_or_else(|| JobError::InvalidInput("the instance is not of the candy wrapper".into()))?;
        local.rotation = joint_rotation(twist_degrees, bend_degrees);
        instance.update(asset)
    }

    /// The example pose of spherical joint blending by example: `Joint` bent [`EXAMPLE_BEND`]
    /// degrees about Z, its support (the vertices `Root` moves) bulged radially around the
    /// joint, `h · exp(−(x / 0.3)²)`, with `h` found so that the bent cylinder keeps its rest
    /// volume. Offsets in the rest pose, as the viewer saves them. Found once per rig.
    pub fn examples(&self) -> &Examples {
        self.examples.get_or_init(|| self.find_examples())
    }

    /// [`CandyWrapper::examples`], bisecting for the bulge's height.
    fn find_examples(&self) -> Examples {
        let side = |h: f32| -> Vec<[f32; 3]> {
            let p = &self.asset.meshes[0].primitives[0];
            (0..p.positions.len())
                .map(|v| {
                    if v >= RINGS * SEGMENTS {
                        return [0.0; 3];
                    }
                    let [x, y, z] = p.positions[v];
                    let bump = h * (-(x / 0.3).powi(2)).exp() / RADIUS;
                    [0.0, y * bump, z * bump]
                })
                .collect()
        };
        let with = |h: f32| Examples {
            poses: vec![JointExample {
                node: JOINT_NODE,
                mesh: 0,
                rotation: joint_rotation(0.0, EXAMPLE_BEND),
                shape: ExampleShape::Inline { positions: side(h), normals: Vec::new() },
                pointer: "/examples/Joint/0".into(),
            }],
            sigma: Vec::new(),
        };
        // The volume grows with the bulge: bisect for the rest volume.
        let volume = |h: f32| -> Option<f32> {
            let mut instance = Instance::new(&self.asset);
            instance.set_skinning(&self.asset, SkinningMethod::SphericalJointBlendByExample);
            instance.set_examples(&self.asset, &with(h)).ok()?;
            self.pose(&mut instance, 0.0, EXAMPLE_BEND).ok()?;
            let (mut p, mut n) = (Vec::new(), Vec::new());
            instance.deform_primitive(&self.asset, 2, 0, &mut p, &mut n).ok()?;
            Some(self.quality(&p).volume_ratio)
        };
        let (mut lo, mut hi) = (0.0f32, 0.2 * RADIUS);
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            match volume(mid) {
                Some(v) if v < 1.0 => lo = mid,
                _ => hi = mid,
            }
        }
        with(0.5 * (lo + hi))
    }

    /// [`CandyWrapper::examples`] as a `.kloub.json` sidecar.
    pub fn example_sidecar(&self) -> String {
        serde_json::Value::Object(self.examples().to_json(&self.asset)).to_string()
    }

    /// Quality of `positions` (the deformed vertices of the cylinder, in its vertex order).
    pub fn quality(&self, positions: &[[f32; 3]]) -> Quality {
        let indices = &self.asset.meshes[0].primitives[0].indices;
        let ring = positions.get(JOINT_RING * SEGMENTS..(JOINT_RING + 1) * SEGMENTS).unwrap_or(&[]);
        let centroid = ring.iter().map(|p| Vec3::from(*p)).sum::<Vec3>() / ring.len().max(1) as f32;
        let mean = ring.iter().map(|p| Vec3::from(*p).distance(centroid)).sum::<f32>() / ring.len().max(1) as f32;
        Quality { radius_kept: mean / RADIUS, volume_ratio: mesh_volume(positions, indices) / self.rest_volume }
    }
}

/// The joint's local rotation for a twist about X then a bend about Z, in degrees.
pub fn joint_rotation(twist_degrees: f32, bend_degrees: f32) -> Quat {
    Quat::from_rotation_z(bend_degrees.to_radians()) * Quat::from_rotation_x(twist_degrees.to_radians())
}

/// Volume enclosed by a closed triangle list (divergence theorem; outward winding positive).
/// Indices outside `positions` are skipped.
pub fn mesh_volume(positions: &[[f32; 3]], indices: &[u32]) -> f32 {
    let at = |i: u32| positions.get(i as usize).map(|p| Vec3::from(*p));
    let mut sum = 0.0f64;
    for t in indices.chunks_exact(3) {
        if let (Some(a), Some(b), Some(c)) = (at(t[0]), at(t[1]), at(t[2])) {
            sum += f64::from(a.dot(b.cross(c)));
        }
    }
    (sum / 6.0) as f32
}

/// A clip rotating `Joint` about `axis` from 0 to `degrees` and back over three seconds
/// (keys every 1/8 of the way, so slerp follows the long way round).
fn swing(name: &str, axis: Vec3, degrees: f32) -> Clip {
    let keys = 16;
    let mut times = Vec::with_capacity(keys + 1);
    let mut values = Vec::with_capacity(4 * (keys + 1));
    for k in 0..=keys {
        let t = k as f32 / keys as f32;
        times.push(3.0 * t);
        let amount = 1.0 - (2.0 * t - 1.0).abs();
        let q = Quat::from_axis_angle(axis, (degrees * amount).to_radians());
        values.extend_from_slice(&q.to_array());
    }
    let channel = Channel {
        node: JOINT_NODE,
        target: ChannelTarget::Rotation,
        interpolation: Interpolation::Linear,
        times,
        values,
        width: 4,
    };
    Clip::from_channels(Some(name.to_owned()), vec![channel])
}

/// The striped, capped cylinder: [`RINGS`] × [`SEGMENTS`] side vertices (ring-major), then
/// each cap as a centre plus its own ring (flat normals).
fn cylinder() -> Primitive {
    let mut p = Primitive { topology: Topology::Triangles, ..Primitive::default() };
    let weights_at = |x: f32| {
        let w1 = ((x + BLEND_HALF_WIDTH) / (2.0 * BLEND_HALF_WIDTH)).clamp(0.0, 1.0);
        [1.0 - w1, w1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    };
    let color = |x: f32, k: usize| {
        let stripe = if (k / 4).is_multiple_of(2) { 1.0 } else { 0.15 };
        let base = if x < 0.0 { [0.95, 0.55, 0.2] } else { [0.25, 0.6, 0.95] };
        [base[0] * stripe, base[1] * stripe, base[2] * stripe, 1.0]
    };
    let push = |p: &mut Primitive, x: f32, a: Option<f32>, k: usize, normal: Vec3| {
        let (s, c) = a.map_or((0.0, 0.0), f32::sin_cos);
        let r = if a.is_some() { RADIUS } else { 0.0 };
        p.positions.push([x, r * c, r * s]);
        p.normals.push(normal.to_array());
        p.colors.push(color(x, k));
        p.joints.push([0, 1, 0, 0, 0, 0, 0, 0]);
        p.weights.push(weights_at(x));
    };
    for ring in 0..RINGS {
        let x = -1.0 + 2.0 * ring as f32 / (RINGS - 1) as f32;
        for k in 0..SEGMENTS {
            let a = k as f32 / SEGMENTS as f32 * TAU;
            push(&mut p, x, Some(a), k, Vec3::new(0.0, a.cos(), a.sin()));
        }
    }
    let index = |ring: usize, k: usize| (ring * SEGMENTS + k % SEGMENTS) as u32;
    for ring in 0..RINGS - 1 {
        for k in 0..SEGMENTS {
            let (a, b, c, d) = (index(ring, k), index(ring, k + 1), index(ring + 1, k), index(ring + 1, k + 1));
            // Outward: the angle grows counter-clockwise seen from +X.
            p.indices.extend_from_slice(&[a, b, d, a, d, c]);
        }
    }
    for (x, normal) in [(-1.0f32, -Vec3::X), (1.0, Vec3::X)] {
        let centre = p.positions.len() as u32;
        push(&mut p, x, None, 0, normal);
        for k in 0..SEGMENTS {
            push(&mut p, x, Some(k as f32 / SEGMENTS as f32 * TAU), k, normal);
        }
        for k in 0..SEGMENTS as u32 {
            let (a, b) = (centre + 1 + k, centre + 1 + (k + 1) % SEGMENTS as u32);
            let tri = if x < 0.0 { [centre, b, a] } else { [centre, a, b] };
            p.indices.extend_from_slice(&tri);
        }
    }
    p.vertex_count = p.positions.len() as u32;
    p.bounds = ([-1.0, -RADIUS, -RADIUS], [1.0, RADIUS, RADIUS]);
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::dqs::SkinningMethod;

    fn measure(rig: &CandyWrapper, method: SkinningMethod, twist: f32, bend: f32) -> Quality {
        let mut instance = Instance::new(&rig.asset);
        instance.set_skinning(&rig.asset, method);
        instance.set_examples(&rig.asset, rig.examples()).expect("the example builds");
        rig.pose(&mut instance, twist, bend).expect("poses");
        let (mut p, mut n) = (Vec::new(), Vec::new());
        instance.deform_primitive(&rig.asset, 2, 0, &mut p, &mut n).expect("deforms");
        rig.quality(&p)
    }

    #[test]
    fn rest_pose_is_the_rest_shape() {
        let rig = CandyWrapper::new();
        let rest = cylinder();
        let polygon_area = 0.5 * SEGMENTS as f32 * RADIUS * RADIUS * (TAU / SEGMENTS as f32).sin();
        assert!((mesh_volume(&rest.positions, &rest.indices) - 2.0 * polygon_area).abs() < 1e-5, "outward and closed");
        for method in SkinningMethod::ALL {
            let q = measure(&rig, method, 0.0, 0.0);
            assert!((q.radius_kept - 1.0).abs() < 1e-5 && (q.volume_ratio - 1.0).abs() < 1e-5, "{method:?}: {q:?}");
        }
    }

    #[test]
    fn twist_collapses_linear_blend_only() {
        let rig = CandyWrapper::new();
        let q = |m| measure(&rig, m, 180.0, 0.0).radius_kept;
        assert!(q(SkinningMethod::Linear) < 0.10, "LBS keeps {}", q(SkinningMethod::Linear));
        assert!(q(SkinningMethod::DualQuaternion) >= 0.95, "DQS keeps {}", q(SkinningMethod::DualQuaternion));
        assert!(q(SkinningMethod::SphericalJointBlend) >= 0.95, "SJB keeps {}", q(SkinningMethod::SphericalJointBlend));
    }

    #[test]
    fn bend_loses_more_volume_under_linear_blend() {
        let rig = CandyWrapper::new();
        let v = |m| measure(&rig, m, 0.0, 120.0).volume_ratio;
        let (lbs, dqs, sjb) =
            (v(SkinningMethod::Linear), v(SkinningMethod::DualQuaternion), v(SkinningMethod::SphericalJointBlend));
        assert!(lbs < 0.97 && dqs > lbs + 0.01 && sjb > lbs + 0.01, "lbs {lbs} dqs {dqs} sjb {sjb}");
        for method in SkinningMethod::ALL {
            let q = measure(&rig, method, 0.0, 90.0);
            assert!(q.volume_ratio.is_finite() && q.volume_ratio > 0.5, "{method:?}: {q:?}");
        }
    }

    #[test]
    fn the_example_pose_keeps_the_volume_at_its_bend_and_sjb_elsewhere_at_rest() {
        let rig = CandyWrapper::new();
        let sjbbe = |bend| measure(&rig, SkinningMethod::SphericalJointBlendByExample, 0.0, bend);
        let sjb = |bend| measure(&rig, SkinningMethod::SphericalJointBlend, 0.0, bend);
        assert!((sjbbe(EXAMPLE_BEND).volume_ratio - 1.0).abs() < 1e-4, "{:?}", sjbbe(EXAMPLE_BEND));
        assert!(sjb(EXAMPLE_BEND).volume_ratio < 0.999, "SJB loses volume at 90°: {:?}", sjb(EXAMPLE_BEND));
        assert_eq!(sjbbe(0.0), sjb(0.0));
        // Half way the bulge is partly there.
        let (a, b) = (sjbbe(45.0).volume_ratio, sjb(45.0).volume_ratio);
        assert!(a > b, "at 45° SJBBE {a} SJB {b}");
        let json = rig.example_sidecar();
        assert_eq!(Examples::from_json(&rig.asset, &json).expect("reads back"), *rig.examples());
    }

    #[test]
    fn clips_reach_their_extremes_halfway() {
        let rig = CandyWrapper::new();
        let mut instance = Instance::new(&rig.asset);
        for (clip, q) in [(0, joint_rotation(180.0, 0.0)), (1, joint_rotation(0.0, 150.0))] {
            instance.evaluate(&rig.asset, Some(clip), 1.5).expect("samples");
            assert!(
                instance.pose().locals[1].rotation.abs_diff_eq(q, 1e-5)
                    || instance.pose().locals[1].rotation.abs_diff_eq(-q, 1e-5)
            );
        }
    }
}
