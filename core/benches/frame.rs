//! Per-character, per-frame cost of the animation core: advance the clocks, sample, blend,
//! world transforms and skin palettes (the GPU skins the vertices).
//!
//! ```text
//! cargo bench -p kloub-core --bench frame -- --warm-up-time 1 --measurement-time 3
//! ```
//! Samples come from `tests/assets` in the repository, or `$KLOUB_SHARED_ASSETS`.
//!
//! - `jobs`: one clip, raw jobs (SampleJob into a pose, WorldJob), no palettes;
//! - `pose`: an [`Animator`] playing one clip: advance + sample + blend + world transforms of all
//!   nodes — the work the issue compares with three.js (its `mixer.update` and
//!   `updateMatrixWorld`); palettes are not part of it;
//! - `single`: an [`Animator`] playing one clip: advance + sample + blend + worlds + palettes;
//! - `single_nlerp`: the same with nlerp instead of slerp for LINEAR rotation keys;
//! - `crossfade_layer`: a crossfade half way between two playing clips plus an override layer
//!   on the upper body: three clips sampled and blended per frame.

mod common;

use common::{CHARACTERS, DT, Posed, clip, instance_frame, load, node};
use criterion::{Criterion, criterion_group, criterion_main};
use kloub_core::job::sample::{RotationLerp, SampleContext, SampleJob};
use kloub_core::job::world::WorldJob;
use kloub_core::math::Mat4;
use kloub_core::pose::Pose;
use kloub_core::{Animator, Instance};
use std::hint::black_box;

fn frame(c: &mut Criterion) {
    for (name, file, base, target, over, root) in CHARACTERS {
        let asset = load(file);
        let (base, target, over, root) =
            (clip(&asset, base), clip(&asset, target), clip(&asset, over), node(&asset, root));
        let duration = asset.clips[base].duration;

        let mut pose = Pose::rest(&asset);
        let mut context = SampleContext::new(&asset.clips[base]);
        let mut worlds = vec![Mat4::IDENTITY; asset.nodes.len()];
        let parents: Vec<Option<u32>> = asset.nodes.iter().map(|n| n.parent).collect();
        let mut time = 0.0;
        c.bench_function(&format!("jobs/{name}"), |b| {
            b.iter(|| {
                time = (time + DT) % duration.max(DT);
                SampleJob {
                    clip: &asset.clips[base],
                    time,
                    context: &mut context,
                    weight_offsets: &asset.weight_offsets,
                    locals: &mut pose.locals,
                    weights: &mut pose.weights,
                }
                .run()
                .expect("valid");
                WorldJob { parents: &parents, order: &asset.order, locals: &pose.locals, worlds: &mut worlds }
                    .run()
                    .expect("valid");
                black_box(&worlds);
            })
        });

        let mut animator = Animator::new(&asset);
        animator.play(&asset, Some(base)).expect("valid");
        let mut posed = Posed::new(&asset);
        c.bench_function(&format!("pose/{name}"), |b| b.iter(|| posed.frame(&asset, &mut animator)));

        let mut instance = Instance::new(&asset);
        for (label, lerp) in [("single", RotationLerp::Slerp), ("single_nlerp", RotationLerp::Nlerp)] {
            let mut animator = Animator::new(&asset);
            animator.set_rotation_lerp(lerp);
            animator.play(&asset, Some(base)).expect("valid");
            c.bench_function(&format!("{label}/{name}"), |b| {
                b.iter(|| instance_frame(&asset, &mut animator, &mut instance))
            });
        }

        let mut animator = common::crossfade_layer(&asset, base, target, over, root);
        c.bench_function(&format!("crossfade_layer/{name}"), |b| {
            b.iter(|| instance_frame(&asset, &mut animator, &mut instance))
        });
        let weight = animator.crossfade().map(|s| s.weight);
        assert!(weight.is_some_and(|w| (w - 0.5).abs() < 0.01), "{weight:?}");
    }
}

criterion_group!(benches, frame);
criterion_main!(benches);
