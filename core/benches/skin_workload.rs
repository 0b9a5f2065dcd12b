//! The CPU skinning workload shared by `benches/skin.rs` (native, criterion) and
//! `wasm-bench/tests/wasm_skin.rs` (wasm32 in Node): CesiumMan's skinned mesh posed mid-walk, its vertex
//! streams repeated to [`VERTICES`] vertices so they do not fit any cache, skinned by every
//! method (`sjbbe` with one example pose on the left elbow, at its rotation in this pose so that
//! its offsets all apply); plus a `stream` kernel that reads and writes the same bytes with almost no
//! arithmetic — the memory-bandwidth bound of this data layout on this machine.

use kloub_core::Instance;
use kloub_core::asset::Asset;
use kloub_core::job::dqs::{DqPrepareJob, JointDq, SkinningMethod};
use kloub_core::job::sjb::SjbPlan;
use kloub_core::job::sjbbe::{ExamplePose, ExampleSpace, MAX_EXAMPLES, SjbbeAlphaJob, SjbbeInput, SjbbeRig};
use kloub_core::job::skin::SkinJob;
use kloub_core::math::Mat4;

/// Vertices skinned per run (CesiumMan's 3,273 repeated): ~100 MB of streams.
pub const VERTICES: usize = 1 << 20;

/// Bytes one vertex moves: position, normal, 8 joints (u16), 8 weights in; position, normal out.
pub const BYTES_PER_VERTEX: usize = 12 + 12 + 16 + 32 + 12 + 12;

/// Streams, palette and prepared tables of one posed mesh.
pub struct Workload {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub joints: Vec<[u16; 8]>,
    pub weights: Vec<[f32; 8]>,
    pub palette: Vec<Mat4>,
    pub dqs: Vec<JointDq>,
    pub plan: SjbPlan,
    pub rig: SjbbeRig,
    pub alphas: Vec<[f32; MAX_EXAMPLES]>,
    pub out_positions: Vec<[f32; 3]>,
    pub out_normals: Vec<[f32; 3]>,
}

fn repeat<T: Copy>(v: &[T]) -> Vec<T> {
    v.iter().copied().cycle().take(VERTICES).collect()
}

impl Workload {
    /// CesiumMan (`asset`) at 0.5 s of its clip, repeated to [`VERTICES`].
    pub fn new(asset: &Asset) -> Self {
        let mut instance = Instance::new(asset);
        instance.evaluate(asset, Some(0), 0.5).expect("samples");
        let node = asset.nodes.iter().position(|n| n.skin.is_some() && n.mesh.is_some()).expect("a skinned mesh");
        let (skin, mesh) =
            (asset.nodes[node].skin.expect("skin") as usize, asset.nodes[node].mesh.expect("mesh") as usize);
        let p = &asset.meshes[mesh].primitives[0];
        let palette = instance.palette(skin).to_vec();
        let mut dqs = vec![JointDq::default(); palette.len()];
        DqPrepareJob { palette: &palette, out: &mut dqs }.run().expect("sized");
        let parents: Vec<Option<u32>> = asset.nodes.iter().map(|n| n.parent).collect();
        let (joints, weights) = (repeat(&p.joints), repeat(&p.weights));
        let plan = SjbPlan::build(&asset.skins[skin], &parents, &joints, &weights);
        let (positions, normals) = (repeat(&p.positions), repeat(&p.normals));
        // One example pose on the left elbow, at the elbow's rotation in this pose (α = 1).
        let elbow = asset.nodes.iter().position(|n| n.name.as_deref() == Some("Skeleton_arm_joint_L__3_"));
        let elbow = elbow.expect("CesiumMan's left elbow");
        let joint = asset.skins[skin].joints.iter().position(|&j| j as usize == elbow).expect("a joint") as u16;
        let example = ExamplePose {
            joint,
            rotation: instance.pose().locals[elbow].rotation,
            positions: vec![[0.0, 0.0, 0.01]; VERTICES],
            normals: vec![[0.0, 0.01, 0.0]; VERTICES],
            space: ExampleSpace::Rest,
        };
        let input = SjbbeInput {
            skin: &asset.skins[skin],
            parents: &parents,
            positions: &positions,
            normals: &normals,
            joints: &joints,
            weights: &weights,
            plan: &plan,
        };
        let rig = SjbbeRig::build(input, &[example], &[]).expect("the example builds");
        let mut alphas = vec![[0.0; MAX_EXAMPLES]; rig.bones.len()];
        SjbbeAlphaJob { rig: &rig, palette: &palette, out: &mut alphas }.run().expect("α");
        Self {
            positions,
            normals,
            joints,
            weights,
            palette,
            dqs,
            plan,
            rig,
            alphas,
            out_positions: vec![[0.0; 3]; VERTICES],
            out_normals: vec![[0.0; 3]; VERTICES],
        }
    }

    /// Skins every vertex with `method`.
    pub fn skin(&mut self, method: SkinningMethod) {
        SkinJob {
            method,
            positions: &self.positions,
            normals: &self.normals,
            joints: &self.joints,
            weights: &self.weights,
            palette: &self.palette,
            joints_dq: &self.dqs,
            plan: Some(&self.plan),
            examples: Some((&self.rig, &self.alphas)),
            out_positions: &mut self.out_positions,
            out_normals: &mut self.out_normals,
        }
        .run()
        .expect("valid workload");
    }

    /// Touches the same bytes as skinning with next to no arithmetic: the bandwidth bound.
    pub fn stream(&mut self) {
        let inputs = self.positions.iter().zip(&self.normals).zip(&self.joints).zip(&self.weights);
        for ((((p, n), j), w), (op, on)) in inputs.zip(self.out_positions.iter_mut().zip(self.out_normals.iter_mut())) {
            let s = w[0] + w[7] + f32::from(j[0] ^ j[7]);
            *op = [p[0] + s, p[1], p[2]];
            *on = [n[0], n[1] + s, n[2]];
        }
    }
}
