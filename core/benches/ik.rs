//! Inverse-kinematics solves per second: RiggedFigure's left arm (3 joints: shoulder, elbow,
//! wrist) and a 6-joint chain of unit bones, each solver, random reachable targets, from the
//! same start pose each time, at most 32 iterations, tolerance 1e-4 of the chain's length.
//!
//! ```text
//! cargo bench -p kloub-core --bench ik -- --warm-up-time 1 --measurement-time 3
//! ```

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use kloub_core::NoResolver;
use kloub_core::asset::NodeIndex;
use kloub_core::job::ik::{IkChain, IkGoal, IkJob, IkReport, IkSettings, IkSolver};
use kloub_core::math::{Quat, Transform, Vec3};
use std::hint::black_box;
use std::path::PathBuf;

/// Targets per batch (each criterion iteration solves them all).
const TARGETS: usize = 64;

fn world_of(parents: &[Option<NodeIndex>], locals: &[Transform], node: NodeIndex) -> Vec3 {
    let mut m = locals[node as usize].to_mat4();
    let mut p = parents[node as usize];
    while let Some(n) = p {
        m = locals[n as usize].to_mat4() * m;
        p = parents[n as usize];
    }
    m.w_axis.truncate()
}

fn targets(parents: &[Option<NodeIndex>], rest: &[Transform], chain: &IkChain) -> Vec<Vec3> {
    let mut seed = 0x2545_f491_u32;
    let mut random = move || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        seed as f32 / u32::MAX as f32
    };
    (0..TARGETS)
        .map(|_| {
            let mut posed = rest.to_vec();
            for &j in &chain.joints()[..chain.depth()] {
                let axis = Vec3::new(random() - 0.5, random() - 0.5, random() - 0.5).normalize();
                posed[j as usize].rotation = rest[j as usize].rotation * Quat::from_axis_angle(axis, random() * 1.5);
            }
            world_of(parents, &posed, chain.effector())
        })
        .collect()
}

fn ik(c: &mut Criterion) {
    let dir = std::env::var_os("KLOUB_SHARED_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/assets"));
    let bytes = std::fs::read(dir.join("khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb")).expect("RiggedFigure.glb");
    let asset = kloub_core::import(&bytes, &NoResolver, &Default::default()).expect("imports").asset;
    let figure_parents: Vec<Option<NodeIndex>> = asset.nodes.iter().map(|n| n.parent).collect();
    let figure_rest: Vec<Transform> = asset.nodes.iter().map(|n| n.rest).collect();
    let hand = asset.nodes.iter().position(|n| n.name.as_deref() == Some("arm_joint_L_3")).expect("hand") as u32;

    // Six joints in a line, unit bones (five rotate).
    let line_parents: Vec<Option<NodeIndex>> = (0..6).map(|i| if i == 0 { None } else { Some(i - 1) }).collect();
    let line_rest: Vec<Transform> = (0..6)
        .map(|i| Transform { translation: if i == 0 { Vec3::ZERO } else { Vec3::Y }, ..Transform::IDENTITY })
        .collect();

    let cases = [
        ("3 joints", figure_parents.clone(), figure_rest.clone(), hand, 2, &IkSolver::ALL[..]),
        ("6 joints", line_parents, line_rest, 5, 5, &[IkSolver::Ccd, IkSolver::Fabrik, IkSolver::Dls][..]),
    ];
    let mut group = c.benchmark_group("ik");
    group.throughput(Throughput::Elements(TARGETS as u64));
    for (name, parents, rest, effector, depth, solvers) in cases {
        let chain = IkChain::new(&parents, effector, depth).expect("chain");
        let goals = targets(&parents, &rest, &chain);
        // Plain CCD (seed 000's sweeps only) next to every solver with its defaults.
        let runs = solvers.iter().map(|&s| (s, true)).chain([(IkSolver::Ccd, false)]);
        for (solver, accelerate) in runs {
            let mut locals = rest.clone();
            let settings =
                IkSettings { solver, iterations: 32, tolerance: 1e-4, weight: 1.0, accelerate, softness: 0.0 };
            let label = if accelerate { solver.name() } else { "plain-ccd" };
            group.bench_function(format!("{label}/{name}"), |b| {
                b.iter(|| {
                    for &target in &goals {
                        locals.copy_from_slice(&rest);
                        let goal = IkGoal { chain: &chain, target, stiffness: &[], limits: &[], pole: None };
                        let mut reports = [IkReport::default()];
                        IkJob {
                            parents: &parents,
                            rest: &rest,
                            locals: &mut locals,
                            goals: &[goal],
                            settings,
                            reports: &mut reports,
                        }
                        .run()
                        .expect("valid");
                        black_box(reports[0]);
                    }
                });
            });
        }
    }
    group.finish();
}

criterion_group!(benches, ik);
criterion_main!(benches);
