//! Ragdoll cost per simulation step per character: one fixed 1/60 s rapier step of the
//! character's bodies and joints (falling from its first clip at 0.3 s; the measured steps
//! are the first second of the fall, while everything moves and collides), the step plus
//! writing the pose back and updating the worlds and palettes, as the viewer does each frame,
//! and the step in a world of obstacles (the five presets around the character and two
//! thrown balls).
//!
//! ```text
//! cargo bench -p kloub-core --bench ragdoll -- --warm-up-time 1 --measurement-time 3
//! ```

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use kloub_core::math::Vec3;
use kloub_core::ragdoll::{Obstacle, Ragdoll, RagdollOptions};
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
    falling_in(asset, false)
}

/// The ragdoll mid-fall; with `world`, among the five presets and two balls thrown at it.
fn falling_in(asset: &Asset, world: bool) -> (Ragdoll, Instance) {
    let mut instance = Instance::new(asset);
    let clip = (!asset.clips.is_empty()).then_some(0);
    instance.evaluate(asset, clip, 0.3).expect("evaluate");
    let settings = JointSettings::humanoid(asset);
    let mut ragdoll =
        Ragdoll::new(asset, &mut instance, &settings, None, RagdollOptions::default()).expect("a ragdoll");
    if world {
        let size = ragdoll.size();
        let (_, center) = ragdoll.body_pose(0).expect("a body");
        let feet = Vec3::new(center.x, ragdoll.ground(), center.z);
        let around = [Vec3::X, -Vec3::X, Vec3::Z, -Vec3::Z, Vec3::ZERO];
        let obstacles: Vec<Obstacle> = ["box", "sphere", "capsule", "stairs", "ramp"]
            .iter()
            .zip(around)
            .filter_map(|(shape, d)| Obstacle::preset(shape, feet + d * 0.4 * size, size))
            .collect();
        ragdoll.set_obstacles(&obstacles);
        for side in [-1.0, 1.0] {
            ragdoll.throw_ball(
                center + Vec3::new(side * size, 0.0, 0.0),
                Vec3::new(-side * 3.0 * size, 0.0, 0.0),
                0.06 * size,
            );
        }
    }
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
        group.bench_function(format!("{name}/step among obstacles"), |b| {
            b.iter_batched_ref(
                || falling_in(&asset, true).0,
                |ragdoll| {
                    ragdoll.step_once();
                    black_box(ragdoll.steps())
                },
                BatchSize::LargeInput,
            );
        });
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
