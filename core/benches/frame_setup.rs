//! What the per-frame benchmarks time, platform-free: shared by `benches/frame.rs` and
//! `benches/frame_min.rs` (native, through `benches/common`) and `wasm-bench/tests/wasm_frame.rs`
//! (wasm32 in Node), so every side times the same frame: the clips and joints by name, the
//! `pose` and instance frames, and the `crossfade_layer` case's animator.

use kloub_core::animator::{Crossfade, Easing, Layer, Outgoing};
use kloub_core::asset::Asset;
use kloub_core::job::world::WorldJob;
use kloub_core::math::Mat4;
use kloub_core::pose::Pose;
use kloub_core::{Animator, Instance};
use std::hint::black_box;

/// One frame at 60 frames a second.
pub const DT: f32 = 1.0 / 60.0;

/// The clip named `name` (a panic otherwise: the benchmarks' characters have it).
pub fn clip(asset: &Asset, name: &str) -> usize {
    asset.find_clip(name).unwrap_or_else(|| panic!("no clip {name}"))
}

/// The node named `name`.
pub fn node(asset: &Asset, name: &str) -> u32 {
    let index = asset.nodes.iter().position(|n| n.name.as_deref() == Some(name));
    index.unwrap_or_else(|| panic!("no node {name}")) as u32
}

/// Buffers of the `pose` measure: a pose and world matrices outside any instance.
pub struct Posed {
    parents: Vec<Option<u32>>,
    pub pose: Pose,
    pub worlds: Vec<Mat4>,
}

impl Posed {
    pub fn new(asset: &Asset) -> Self {
        Self {
            parents: asset.nodes.iter().map(|n| n.parent).collect(),
            pose: Pose::rest(asset),
            worlds: vec![Mat4::IDENTITY; asset.nodes.len()],
        }
    }

    /// `pose`: advance + sample + blend + world transforms of all nodes (no palettes).
    pub fn frame(&mut self, asset: &Asset, animator: &mut Animator) {
        animator.advance(asset, DT);
        animator.evaluate_pose(asset, &mut self.pose).expect("valid");
        WorldJob { parents: &self.parents, order: &asset.order, locals: &self.pose.locals, worlds: &mut self.worlds }
            .run()
            .expect("valid");
        black_box(&self.worlds);
    }
}

/// `single` and `crossfade_layer`: advance + evaluate into an instance (worlds and palettes).
pub fn instance_frame(asset: &Asset, animator: &mut Animator, instance: &mut Instance) {
    animator.advance(asset, DT);
    animator.evaluate(asset, instance).expect("valid");
    black_box(instance.worlds());
}

/// An animator playing `base` with an override layer of `over` (weight 0.8) under the joint
/// `root`, crossfading to `target`: a very long linear crossfade advanced to its middle. At 1e7 s
/// a frame (1/60 s) is below half an f32 ulp of the elapsed time, so both sides weigh exactly 0.5
/// throughout: three clips sampled and blended per frame.
pub fn crossfade_layer(asset: &Asset, base: usize, target: usize, over: usize, root: u32) -> Animator {
    let mut animator = Animator::new(asset);
    animator.play(asset, Some(base)).expect("valid");
    let mut layer = Layer::new(over, root);
    layer.weight = 0.8;
    animator.add_layer(asset, layer).expect("valid");
    let fade = Crossfade { duration: 2.0e7, easing: Easing::Linear, outgoing: Outgoing::KeepPlaying };
    animator.crossfade_to(asset, Some(target), fade).expect("valid");
    animator.advance(asset, 1.0e7);
    animator
}
