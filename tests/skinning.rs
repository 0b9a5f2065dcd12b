//! GPU skinning agrees with `kloub_core`'s CPU reference, vertex by vertex: every method
//! (rigid, LBS, DQS, SJB, SJBBE) in the vertex shader (read back through the capture pipeline) and in
//! the compute pass (its output buffer read back) — [`SceneRenderer::capture_skinned`] — on
//! whatever adapter wgpu picks (lavapipe in CI),
//! within 1e-4 of the model's bounding-box diagonal, normals within 0.5°. Morph targets are
//! applied on the GPU before skinning (RobotExpressive's face is morphed and skinned). SJB by
//! example, drawn as SJB over morph targets weighted by α, agrees with the core's CPU SJBBE within
//! 1e-6 of the diagonal (measured ≤ 3e-7) on the candy wrapper and CesiumMan.

use glam::Vec3;
use kloub_core::candy::CandyWrapper;
use kloub_core::job::dqs::SkinningMethod;
use kloub_core::{Asset, Instance};
use kloub_web::render::SkinningPath;
use kloub_web::render::offscreen::Offscreen;
use kloub_web::render::scene::SceneRenderer;

fn load(model: &str) -> Asset {
    let path = kloub_tests::shared_assets().join(model);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    kloub_core::import(&bytes, &kloub_core::NoResolver, &Default::default())
        .unwrap_or_else(|e| panic!("importing {}: {e}", path.display()))
        .asset
}

/// Compares every skinned draw of `renderer` with the CPU; returns failures.
fn compare(
    name: &str,
    offscreen: &Offscreen,
    renderer: &mut SceneRenderer,
    asset: &Asset,
    instance: &mut Instance,
) -> Vec<String> {
    let (min, max) = instance.scene_bounds(asset).expect("drawable");
    let diagonal = (max - min).length();
    let mut failures = Vec::new();
    for path in [SkinningPath::Gpu, SkinningPath::Compute] {
        if path == SkinningPath::Compute && !renderer.supports_compute() {
            eprintln!("{name}: this adapter has no compute shaders; the compute path is not compared");
            continue;
        }
        let captures =
            renderer.capture_skinned(offscreen.device(), offscreen.queue(), asset, instance, path).expect("capturing");
        failures.extend(compare_captures(name, path, &captures, asset, instance, diagonal));
    }
    failures
}

/// Compares captured draws with the CPU reference.
fn compare_captures(
    name: &str,
    path: SkinningPath,
    captures: &[kloub_web::render::scene::CapturedDraw],
    asset: &Asset,
    instance: &mut Instance,
    diagonal: f32,
) -> Vec<String> {
    assert!(!captures.is_empty(), "{name}: no skinned draw was captured on {}", path.name());
    let method = format!("{} on {}", instance.skinning().name(), path.name());
    let mut failures = Vec::new();
    let (mut positions, mut normals) = (Vec::new(), Vec::new());
    let (mut worst, mut worst_angle) = (0.0f32, 0.0f32);
    for draw in captures {
        instance
            .deform_primitive(asset, draw.node, draw.primitive, &mut positions, &mut normals)
            .expect("CPU reference");
        assert_eq!(positions.len(), draw.positions.len());
        for (v, (gpu, cpu)) in draw.positions.iter().zip(&positions).enumerate() {
            let d = Vec3::from(*gpu).distance(Vec3::from(*cpu)) / diagonal;
            if d > worst || d.is_nan() {
                worst = d;
            }
            if (d.is_nan() || d > 1e-4) && failures.len() < 5 {
                failures.push(format!(
                    "{name} {method}: mesh {} primitive {} vertex {v}: GPU {gpu:?} vs CPU {cpu:?} ({d:.2e} of the diagonal)",
                    draw.mesh, draw.primitive
                ));
            }
        }
        for (gpu, cpu) in draw.normals.iter().zip(&normals) {
            let (g, c) = (Vec3::from(*gpu), Vec3::from(*cpu));
            if c.length_squared() > 0.5 {
                worst_angle = worst_angle.max(g.dot(c).clamp(-1.0, 1.0).acos().to_degrees());
            }
        }
    }
    eprintln!("{name} {method}: largest GPU/CPU difference {worst:.2e} of the diagonal, normals {worst_angle:.3}°");
    if worst_angle.is_nan() || worst_angle > 0.5 {
        failures.push(format!("{name} {method}: normals differ by up to {worst_angle}°"));
    }
    failures
}

/// The devices compared: WebGL2's limits (the vertex-shader path as the browser's WebGL2
/// backend runs it) and WebGPU's (the vertex shader and the compute pass).
fn devices() -> [Offscreen; 2] {
    let webgl2 = Offscreen::new().expect("a wgpu adapter (install Mesa lavapipe on machines without a GPU)");
    let webgpu = Offscreen::webgpu().expect("a device with WebGPU's default limits");
    [webgl2, webgpu]
}

#[test]
fn every_method_on_the_gpu_matches_the_cpu_reference() {
    for offscreen in devices() {
        every_method_matches_on(&offscreen);
    }
}

fn every_method_matches_on(offscreen: &Offscreen) {
    let mut failures = Vec::new();
    for (model, time) in [
        ("khronos/CesiumMan/glTF-Binary/CesiumMan.glb", 0.7),
        ("khronos/Fox/glTF-Binary/Fox.glb", 1.3),
        ("threejs/RobotExpressive/RobotExpressive.glb", 0.9),
    ] {
        let asset = load(model);
        let mut renderer = offscreen.scene_renderer(&asset).expect("uploading");
        let mut instance = Instance::new(&asset);
        for method in SkinningMethod::ALL {
            instance.set_skinning(&asset, method);
            instance.evaluate(&asset, Some(0), time).expect("sampling");
            // Every morph target half on, so morphing on the GPU is part of the comparison.
            for w in &mut instance.pose_mut().weights {
                *w = 0.5;
            }
            instance.update(&asset).expect("updating");
            failures.extend(compare(model, offscreen, &mut renderer, &asset, &mut instance));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn candy_wrapper_twisted_and_bent_matches_on_the_gpu() {
    for offscreen in devices() {
        candy_wrapper_matches_on(&offscreen);
    }
}

fn candy_wrapper_matches_on(offscreen: &Offscreen) {
    let rig = CandyWrapper::new();
    let mut renderer = offscreen.scene_renderer(&rig.asset).expect("uploading");
    let mut instance = Instance::new(&rig.asset);
    let mut failures = Vec::new();
    for method in SkinningMethod::ALL {
        instance.set_skinning(&rig.asset, method);
        for (twist, bend) in [(150.0, 0.0), (180.0, 0.0), (60.0, 120.0)] {
            rig.pose(&mut instance, twist, bend).expect("posing");
            failures.extend(compare(
                &format!("candy wrapper {twist}°/{bend}°"),
                offscreen,
                &mut renderer,
                &rig.asset,
                &mut instance,
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The page's viewers of one model on one device share its upload (meshes, textures, morph
/// targets, SJB centres) and the device's pipelines, and draw exactly what a viewer with its own
/// upload draws; the shared upload goes when the last of them does.
#[test]
fn viewers_sharing_a_device_share_one_upload_and_draw_the_same_pixels() {
    use kloub_web::render::scene;
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let (device, queue) = (offscreen.device(), offscreen.queue());
    let asset = std::sync::Arc::new(load("threejs/RobotExpressive/RobotExpressive.glb"));
    let format = kloub_web::render::texture::COLOR_FORMAT;
    // A key no other test uses: caches are per thread, tests may share one.
    let share = Some(0xC0FFEE);
    let (uploads, kits) = (scene::uploads_made(), kloub_web::render::pipelines::kits_built());
    let mut first = SceneRenderer::shared(device, queue, 1, format, share);
    first.set_shared_asset(device, queue, &asset).expect("uploading");
    let mut second = SceneRenderer::shared(device, queue, 1, format, share);
    second.set_shared_asset(device, queue, &asset).expect("sharing");
    assert_eq!(scene::uploads_made() - uploads, 1, "one upload for two viewers");
    assert_eq!(kloub_web::render::pipelines::kits_built() - kits, 1, "one pipeline kit for the device");
    let mut own = SceneRenderer::shared(device, queue, 1, format, None);
    own.set_shared_asset(device, queue, &asset).expect("uploading its own");
    assert_eq!(scene::uploads_made() - uploads, 2, "a renderer outside the page shares nothing");

    let mut instance = Instance::new(&asset);
    instance.evaluate(&asset, Some(0), 0.4).expect("sampling");
    instance.update(&asset).expect("updating");
    let (min, max) = instance.scene_bounds(&asset).expect("drawable");
    let mut camera = kloub_web::render::Camera::default();
    camera.frame_to_fit_aspect(min, max, 1.0);
    let shots: Vec<_> = [&mut first, &mut second, &mut own]
        .into_iter()
        .map(|r| offscreen.render(r, &asset, &mut instance, &camera, 96, 96).expect("rendering"))
        .collect();
    assert!(shots[0].pixels().any(|p| p.0 != shots[0].get_pixel(0, 0).0), "the model is drawn");
    assert!(shots[0] == shots[1] && shots[1] == shots[2], "shared and own uploads draw the same pixels");

    // The SJB centres are written when a viewer first chooses SJB (not at upload, while the page
    // waits for the first frame): the fallback counts read 0 before, the plan's after, in
    // every viewer of the shared upload.
    let plans: Vec<usize> = {
        let parents: Vec<Option<u32>> = asset.nodes.iter().map(|n| n.parent).collect();
        let mut counts = Vec::new();
        for node in asset.scene_nodes() {
            let n = &asset.nodes[node as usize];
            let (Some(mesh), Some(skin)) = (n.mesh, n.skin) else { continue };
            for p in asset.meshes[mesh as usize].primitives.iter().filter(|p| p.is_skinned()) {
                let skin = &asset.skins[skin as usize];
                counts.push(kloub_core::job::sjb::SjbPlan::build(skin, &parents, &p.joints, &p.weights).fallbacks);
            }
        }
        counts
    };
    let counts = |r: &SceneRenderer| r.sjb_fallbacks().iter().map(|f| f.2).collect::<Vec<_>>();
    assert!(plans.iter().any(|&f| f > 0), "RobotExpressive has vertices without a shared joint centre: {plans:?}");
    assert_eq!(counts(&first), vec![0; plans.len()], "nothing written before SJB is chosen");
    second.write_sjb_pivots(queue, &asset);
    assert_eq!((counts(&first), counts(&second)), (plans.clone(), plans), "written once for the shared upload");

    assert_eq!(scene::live_uploads(), 1);
    drop((first, second, own, asset));
    scene::release_unused_uploads(None);
    assert_eq!(scene::live_uploads(), 0, "the shared upload goes with the last viewer of the model");
}

/// SJB by example on the GPU (the viewer's way: SJB over morph targets weighted by α) against
/// the core's CPU SJBBE (`SjbbeJob`) on the asset without those targets, vertex by vertex: the
/// candy wrapper at its example and half way, CesiumMan's elbow at its example (the golden
/// case's sidecar) and at rest with a walk frame.
#[test]
fn sjbbe_on_the_gpu_matches_the_cpu_sjbbe() {
    use kloub_core::examples::{ExampleTargets, Examples};
    let rig = CandyWrapper::new();
    let rig = &rig;
    let cesium = load("khronos/CesiumMan/glTF-Binary/CesiumMan.glb");
    let sidecar = std::fs::read_to_string(
        kloub_tests::repo_root().join("tests/golden/cesiumman_sjbbe_elbow/examples.kloub.json"),
    )
    .expect("the golden case's sidecar");
    let elbow = Examples::from_json(&cesium, &sidecar).expect("reads");
    let elbow_node =
        cesium.nodes.iter().position(|n| n.name.as_deref() == Some("Skeleton_arm_joint_L__3_")).expect("elbow");
    let example = elbow.poses[0].rotation;
    // (name, asset, examples, poses: a function setting the pose on an instance of either asset)
    type Pose<'a> = Box<dyn Fn(&Asset, &mut Instance) + 'a>;
    let cases: Vec<(&str, &Asset, Examples, Vec<Pose<'_>>)> = vec![
        (
            "candy wrapper",
            &rig.asset,
            rig.examples().clone(),
            [90.0f32, 45.0, 130.0]
                .into_iter()
                .map(|bend| -> Pose<'_> {
                    Box::new(move |a: &Asset, i: &mut Instance| rig.pose_in(a, i, 20.0, bend).expect("posing"))
                })
                .collect(),
        ),
        (
            "CesiumMan",
            &cesium,
            elbow,
            vec![
                Box::new(move |a: &Asset, i: &mut Instance| {
                    i.evaluate(a, None, 0.0).expect("rest");
                    i.pose_mut().locals[elbow_node].rotation = example;
                    i.update(a).expect("update");
                }),
                Box::new(|a: &Asset, i: &mut Instance| i.evaluate(a, Some(0), 0.6).expect("walk")),
            ],
        ),
    ];
    for offscreen in devices() {
        let mut failures = Vec::new();
        for (name, asset, examples, poses) in &cases {
            let mut reference = Instance::new(asset);
            reference.set_skinning(asset, SkinningMethod::SphericalJointBlendByExample);
            reference.set_examples(asset, examples).expect("builds");
            let (derived, mut targets) = ExampleTargets::compile(asset, &reference);
            let mut renderer = offscreen.scene_renderer(&derived).expect("uploading");
            let mut drawn = Instance::new(&derived);
            drawn.set_skinning(&derived, SkinningMethod::SphericalJointBlendByExample);
            for (p, pose) in poses.iter().enumerate() {
                pose(asset, &mut reference);
                pose(&derived, &mut drawn);
                targets.write_weights(&mut drawn, true).expect("α");
                let (min, max) = reference.scene_bounds(asset).expect("drawable");
                let diagonal = (max - min).length();
                for path in [SkinningPath::Gpu, SkinningPath::Compute] {
                    if path == SkinningPath::Compute && !renderer.supports_compute() {
                        continue;
                    }
                    let captures = renderer
                        .capture_skinned(offscreen.device(), offscreen.queue(), &derived, &mut drawn, path)
                        .expect("capturing");
                    assert!(!captures.is_empty(), "{name}: nothing captured");
                    let (mut positions, mut normals) = (Vec::new(), Vec::new());
                    let mut worst = 0.0f32;
                    for draw in &captures {
                        reference
                            .deform_primitive(asset, draw.node, draw.primitive, &mut positions, &mut normals)
                            .expect("CPU SJBBE");
                        for (gpu, cpu) in draw.positions.iter().zip(&positions) {
                            let d = Vec3::from(*gpu).distance(Vec3::from(*cpu)) / diagonal;
                            worst = if d.is_nan() { f32::NAN } else { worst.max(d) };
                        }
                    }
                    eprintln!(
                        "{name} pose {p} sjbbe on {}: largest GPU/CPU difference {worst:.2e} of the diagonal",
                        path.name()
                    );
                    if worst.is_nan() || worst > 1e-6 {
                        failures.push(format!("{name} pose {p} on {}: {worst:.2e} of the diagonal", path.name()));
                    }
                }
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }
}
