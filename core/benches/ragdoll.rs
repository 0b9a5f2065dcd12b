//! Ragdoll cost per simulation step per character: one fixed 1/60 s rapier step of the
//! character's bodies and joints (falling from its first clip at 0.3 s; the measured steps
//! are the first second of the fall, while everything moves and collides), and the step plus
//! writing the pose back and updating the worlds and palettes, as the viewer does each frame.
//!
//! ```text
//! cargo bench -p kloub-core --bench ragdoll -- --warm-up-time 1 --measurement-time 3
//! ```

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use kloub_core::ragdoll::{Ragdoll, RagdollOptions};
use kloub_core::rig::JointSettings;
use kloub_core::{Asset, Instance, NoResolver};
use std::hint::black_box;
use std::path::PathBuf;

const MODELS: [(&str, &str); 5] = [
    ("CesiumMan", "khronos/CesiumMan/glTF-Binary/CesiumMan.glb"),
    ("Fox", "khronos/Fox/glTF-Binary/Fox.glb"),
    ("RiggedFigure", "khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb"),
    ("RobotExpressive", "threejs/RobotExpressive/RobotExpressive.glb"),
    ("Knight", "kaykit/Knight/Knight.glb"),
];

/// Steps already taken when a measured step runs (the body mid-fall).
const INTO_FALL: u32 = 20;

fn load(rel: &str) -> Asset {
    let root = std::env::var_os("KLOUB_SHARED_ASSETS")
        .map_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/assets"), PathBuf::from);
    let bytes = std::fs::read(root.join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"));
    kloub_core::import(&bytes, &NoResolver, &Default::default()).unwrap_or_else(|e| panic!("{rel}: {e}")).asset
}

fn falling(asset: &Asset) -> (Ragdoll, Instance) {
    let mut instance = Instance::new(asset);
    let clip = (!asset.clips.is_empty()).then_some(0);
    instance.evaluate(asset, clip, 0.3).expect("evaluate");
    let settings = JointSettings::humanoid(asset);
    let mut ragdoll =
        Ragdoll::new(asset, &mut instance, &settings, None, RagdollOptions::default()).expect("a ragdoll");
    for _ in 0..INTO_FALL {
        ragdoll.step_once();
    }
    (ragdoll, instance)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("ragdoll");
    for (name, path) in MODELS {
        let asset = load(path);
        let (ragdoll, instance) = falling(&asset);
        eprintln!("{name}: {} bodies", ragdoll.bodies().len());
        group.bench_function(format!("{name}/step"), |b| {
            b.iter_batched_ref(
                || falling(&asset).0,
                |ragdoll| {
                    ragdoll.step_once();
                    black_box(ragdoll.steps())
                },
                BatchSize::LargeInput,
            );
        });
        drop((ragdoll, instance));
        group.bench_function(format!("{name}/step+pose"), |b| {
            b.iter_batched_ref(
                || falling(&asset),
                |(ragdoll, instance)| {
                    ragdoll.step_once();
                    ragdoll.write_pose(instance.pose_mut(), 1.0);
                    instance.update(&asset).expect("update");
                    black_box(instance.worlds().len())
                },
                BatchSize::LargeInput,
            );
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
