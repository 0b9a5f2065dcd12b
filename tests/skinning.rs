//! GPU skinning agrees with `kloub_core`'s CPU reference, vertex by vertex: every method
//! (rigid, LBS, DQS, SJB) in the vertex shader (read back through the capture pipeline) and in
//! the compute pass (its output buffer read back) — [`SceneRenderer::capture_skinned`] — on
//! whatever adapter wgpu picks (lavapipe in CI),
//! within 1e-4 of the model's bounding-box diagonal, normals within 0.5°. Morph targets are
//! applied on the GPU before skinning (RobotExpressive's face is morphed and skinned).

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

    assert_eq!(scene::live_uploads(), 1);
    drop((first, second, own, asset));
    scene::release_unused_uploads(None);
    assert_eq!(scene::live_uploads(), 0, "the shared upload goes with the last viewer of the model");
}
