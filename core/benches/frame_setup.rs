//! The `crossfade_layer` case's animator, shared by `benches/frame.rs` (native) and
//! `wasm-bench/tests/wasm_frame.rs` (wasm32 in Node), so both time the same blend.

use kloub_core::Animator;
use kloub_core::animator::{Crossfade, Easing, Layer, Outgoing};
use kloub_core::asset::Asset;

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
