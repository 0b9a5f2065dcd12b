//! Golden images: the app's own renderer ([`kloub_web::render::SceneRenderer`]) drawing
//! models headless (lavapipe on a machine without a GPU), compared with committed PNGs.
//!
//! Each folder `tests/golden/<case>/` holds `manifest.json` and `expected.png`:
//! ```text
//! { "model": "khronos/CesiumMan/glTF-Binary/CesiumMan.glb",   // under the shared assets
//!   "clip": 0, "time": 0.5, "size": [256, 256],
//!   "max_channel_diff": 12,            // a pixel differs when a channel is off by more than this
//!   "max_differing_fraction": 0.005 }  // ... and at most this fraction of pixels may differ
//! ```
//! Optional: `"yaw"`, `"pitch"` (radians) for the camera direction; `"clip": null` for the rest
//! pose; `"skinning"`: `rigid|lbs|dqs|sjb`. A `.gltf` model reads its buffers and images from
//! its own folder. `"model": "procedural:candy-wrapper"` is kloub_core's two-bone cylinder,
//! posed by `"twist"` and `"bend"` (degrees).
//! The camera is [`Camera::frame_to_fit`] of the posed scene bounds with the default yaw and
//! pitch. `"examples"` gives example poses for `"skinning": "sjbbe"`: `"procedural"` (the candy
//! wrapper's own) or a sidecar file in the case's folder; they are drawn as the viewer draws
//! them (morph targets weighted by α). `"rotate": {"JOINT": [x, y, z, w]}` holds joints' local
//! rotations after the clip. `"ibl": false` draws as on a device that cannot prefilter an
//! environment (the hemisphere lights the meshes instead); `"environment"` names the one that
//! lights them (`environment-image`'s names; absent: the lighting preset's own). On failure `tests/out/<case>/actual.png` and `diff.png` are written. A missing
//! `expected.png` is written and the test fails; `KLOUB_BLESS=1` rewrites every
//! `expected.png` and passes.

use std::path::{Path, PathBuf};

use image::{Rgba, RgbaImage};
use kloub_core::candy::CandyWrapper;
use kloub_core::examples::{ExampleTargets, Examples};
use kloub_core::job::dqs::SkinningMethod;
use kloub_core::{Asset, ImportOptions, Instance, MapResolver};
use kloub_web::render::offscreen::Offscreen;
use kloub_web::render::{Camera, SkinningPath};

/// Cases that must exist (so deleting a folder cannot make the suite pass).
const REQUIRED_CASES: [&str; 12] = [
    "cesiumman_t0.5",
    "pbr_sphere_grid_studio_photo",
    "riggedsimple_t1.0",
    "texture_transform",
    "candy_rigid_twist150",
    "candy_lbs_twist150",
    "candy_dqs_twist150",
    "candy_sjb_twist150",
    "candy_sjbbe_bend90",
    "candy_sjbbe_bend45",
    "cesiumman_sjbbe_elbow",
    "pbr_sphere_grid_hemisphere",
];

/// `"model"` of the procedural candy-wrapper rig ([`CandyWrapper`]).
const CANDY_WRAPPER: &str = "procedural:candy-wrapper";
/// `"model"` of the metallic-roughness sphere grid ([`kloub_tests::materials::sphere_grid`]).
const SPHERE_GRID: &str = "procedural:sphere-grid";
/// `"model"` of the normal-mapped plane ([`kloub_tests::materials::normal_mapped_plane`]).
const NORMAL_PLANE: &str = "procedural:normal-plane";

/// Imports a model; a `.gltf` gets the files of its folder (buffers, images) by relative path.
fn load(model: &str) -> Asset {
    let path = kloub_tests::shared_assets().join(model);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    let mut folder = MapResolver::new();
    if path.extension().is_some_and(|e| e == "gltf") {
        let dir = path.parent().expect("a file has a folder");
        for entry in std::fs::read_dir(dir).expect("the model's folder is readable").flatten() {
            let file = entry.path();
            if file.is_file() {
                let name = entry.file_name().to_string_lossy().into_owned();
                folder.insert(name, std::fs::read(&file).expect("a readable file"));
            }
        }
    }
    kloub_core::import(&bytes, &folder, &ImportOptions::default())
        .unwrap_or_else(|e| panic!("importing {}: {e}", path.display()))
        .asset
}

/// The instance posed at `clip`/`time` and a camera framing it from `view` (yaw, pitch in
/// radians; default: the viewer's default view).
fn pose(asset: &Asset, clip: Option<usize>, time: f32, view: Option<(f32, f32)>) -> (Instance, Camera) {
    let mut instance = Instance::new(asset);
    instance.evaluate(asset, clip, time).expect("evaluating a valid clip");
    let (min, max) = instance.scene_bounds(asset).expect("the model has drawable meshes");
    let mut camera = Camera::default();
    if let Some((yaw, pitch)) = view {
        camera.yaw = yaw;
        camera.pitch = pitch;
    }
    camera.frame_to_fit(min, max);
    (instance, camera)
}

/// How two images differ.
struct Comparison {
    largest_channel_diff: u8,
    differing_fraction: f64,
    diff: RgbaImage,
}

/// Compares `actual` with `expected`; a pixel differs when a channel is off by more than
/// `threshold`. The diff image shows the actual frame dimmed, differing pixels in red.
fn compare(expected: &RgbaImage, actual: &RgbaImage, threshold: u8) -> Comparison {
    let mut diff = RgbaImage::new(actual.width(), actual.height());
    let mut largest = 0u8;
    let mut differing = 0usize;
    for ((e, a), d) in expected.pixels().zip(actual.pixels()).zip(diff.pixels_mut()) {
        let delta = e.0.iter().zip(a.0).map(|(&x, y)| x.abs_diff(y)).max().unwrap_or(0);
        largest = largest.max(delta);
        let grey = ((u16::from(a.0[0]) + u16::from(a.0[1]) + u16::from(a.0[2])) / 12) as u8;
        *d = if delta > threshold {
            differing += 1;
            Rgba([255, 0, 0, 255])
        } else {
            Rgba([grey, grey, grey, 255])
        };
    }
    let total = (actual.width() as usize * actual.height() as usize).max(1);
    Comparison { largest_channel_diff: largest, differing_fraction: differing as f64 / total as f64, diff }
}

fn write_png(image: &RgbaImage, path: &Path) {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("creating {}: {e}", dir.display()));
    }
    image.save(path).unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
}

fn case_dirs() -> Vec<PathBuf> {
    let root = kloub_tests::repo_root().join("tests/golden");
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap_or_else(|e| panic!("reading {}: {e}", root.display()))
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|path| path.join("manifest.json").is_file())
        .collect();
    dirs.sort();
    dirs
}

/// Renders one case; returns a failure message, or `None` when it passes.
fn run_case(offscreen: &Offscreen, dir: &Path, bless: bool) -> Option<String> {
    let name = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let manifest_path = dir.join("manifest.json");
    let manifest: serde_json::Value = std::fs::read_to_string(&manifest_path)
        .map_err(|e| e.to_string())
        .and_then(|text| serde_json::from_str(&text).map_err(|e| e.to_string()))
        .unwrap_or_else(|e| panic!("{}: {e}", manifest_path.display()));
    let field = |key: &str| manifest.get(key).unwrap_or_else(|| panic!("{name}: manifest lacks {key:?}"));
    let model = field("model").as_str().expect("model is a string");
    let clip = field("clip").as_u64().map(|c| c as usize);
    let time = field("time").as_f64().expect("time is a number") as f32;
    let size = field("size").as_array().expect("size is [width, height]");
    let dimension = |i: usize| size.get(i).and_then(|v| v.as_u64()).expect("size holds two integers") as u32;
    let (width, height) = (dimension(0), dimension(1));
    let threshold = field("max_channel_diff").as_u64().expect("max_channel_diff is an integer").min(255) as u8;
    let max_fraction = field("max_differing_fraction").as_f64().expect("max_differing_fraction is a number");

    let view = manifest.get("yaw").and_then(|y| y.as_f64()).map(|yaw| {
        let pitch = manifest.get("pitch").and_then(|p| p.as_f64()).unwrap_or(0.0);
        (yaw as f32, pitch as f32)
    });

    let candy = (model == CANDY_WRAPPER).then(CandyWrapper::new);
    let asset = match (&candy, model) {
        (Some(rig), _) => rig.asset.clone(),
        (None, SPHERE_GRID) => kloub_tests::materials::sphere_grid(),
        (None, NORMAL_PLANE) => kloub_tests::materials::normal_mapped_plane(),
        (None, _) => load(model),
    };
    // Example poses: compiled into morph targets as the viewer does.
    let mut targets = None;
    let asset = match manifest.get("examples").and_then(|e| e.as_str()) {
        None => asset,
        Some(source) => {
            let examples = match (source, &candy) {
                ("procedural", Some(rig)) => rig.examples().clone(),
                _ => {
                    let text =
                        std::fs::read_to_string(dir.join(source)).unwrap_or_else(|e| panic!("{name}: {source}: {e}"));
                    Examples::from_json(&asset, &text).unwrap_or_else(|e| panic!("{name}: {source}: {e}"))
                }
            };
            let mut rigs = Instance::new(&asset);
            rigs.set_examples(&asset, &examples).unwrap_or_else(|e| panic!("{name}: examples: {e}"));
            let (derived, t) = ExampleTargets::compile(&asset, &rigs);
            targets = Some(t);
            derived
        }
    };
    let (mut instance, mut camera) = pose(&asset, clip, time, view);
    let mut method = SkinningMethod::Linear;
    if let Some(name_of_method) = manifest.get("skinning").and_then(|m| m.as_str()) {
        method = SkinningMethod::from_name(name_of_method)
            .unwrap_or_else(|| panic!("{name}: unknown skinning method {name_of_method:?}"));
        instance.set_skinning(&asset, method);
        instance.update(&asset).expect("updating");
    }
    if let Some(rig) = &candy {
        let angle = |key: &str| manifest.get(key).and_then(|v| v.as_f64()).unwrap_or(0.0) as f32;
        rig.pose_in(&asset, &mut instance, angle("twist"), angle("bend")).expect("posing the candy wrapper");
        let (min, max) = instance.scene_bounds(&asset).expect("drawable");
        camera.frame_to_fit(min, max);
    }
    if let Some(rotate) = manifest.get("rotate").and_then(|r| r.as_object()) {
        for (joint, q) in rotate {
            let node = asset.nodes.iter().position(|n| n.name.as_deref() == Some(joint.as_str()));
            let node = node.unwrap_or_else(|| panic!("{name}: no joint {joint:?}"));
            let q: Vec<f32> =
                q.as_array().expect("[x, y, z, w]").iter().filter_map(|x| x.as_f64()).map(|x| x as f32).collect();
            instance.pose_mut().locals[node].rotation = kloub_core::math::Quat::from_slice(&q).normalize();
        }
        instance.update(&asset).expect("updating");
    }
    if let Some(t) = &mut targets {
        t.write_weights(&mut instance, method == SkinningMethod::SphericalJointBlendByExample).expect("α");
    }
    let mut renderer = offscreen.scene_renderer(&asset).unwrap_or_else(|e| panic!("{name}: uploading: {e}"));
    if manifest.get("ibl").and_then(|v| v.as_bool()) == Some(false) {
        renderer.set_ibl_supported(false);
    }
    if let Some(environment) = manifest.get("environment").and_then(|v| v.as_str()) {
        use kloub_web::render::environment::EnvironmentName;
        use kloub_web::render::uniforms::{EnvironmentChoice, Look};
        let name = EnvironmentName::from_name(environment).unwrap_or_else(|e| panic!("{name}: {e}"));
        renderer.set_look(Look { environment: EnvironmentChoice::Named(name), ..renderer.look() });
    }
    let actual = offscreen
        .render(&mut renderer, &asset, &mut instance, &camera, width, height)
        .unwrap_or_else(|e| panic!("{name}: rendering: {e}"));

    let expected_path = dir.join("expected.png");
    if bless || !expected_path.exists() {
        write_png(&actual, &expected_path);
        return (!bless)
            .then(|| format!("{name}: no expected.png; wrote {} (check it, then commit)", expected_path.display()));
    }
    let expected =
        image::open(&expected_path).unwrap_or_else(|e| panic!("reading {}: {e}", expected_path.display())).to_rgba8();
    if expected.dimensions() != actual.dimensions() {
        return Some(format!(
            "{name}: expected {:?} pixels, rendered {:?}",
            expected.dimensions(),
            actual.dimensions()
        ));
    }
    let comparison = compare(&expected, &actual, threshold);
    if comparison.differing_fraction <= max_fraction {
        return None;
    }
    let out = kloub_tests::repo_root().join("tests/out").join(&name);
    write_png(&actual, &out.join("actual.png"));
    write_png(&comparison.diff, &out.join("diff.png"));
    Some(format!(
        "{name}: {:.3}% of pixels differ by more than {threshold} (allowed {:.3}%), largest channel difference {}; \
         see {}",
        comparison.differing_fraction * 100.0,
        max_fraction * 100.0,
        comparison.largest_channel_diff,
        out.display()
    ))
}

#[test]
fn golden_images_match() {
    let dirs = case_dirs();
    for required in REQUIRED_CASES {
        assert!(
            dirs.iter().any(|d| d.file_name().is_some_and(|n| n == required)),
            "golden case {required} is missing from tests/golden"
        );
    }
    let bless = std::env::var_os("KLOUB_BLESS").is_some_and(|v| v == "1");
    let offscreen = Offscreen::new().expect("a wgpu adapter (install Mesa lavapipe on machines without a GPU)");
    eprintln!("golden images on {:?}", offscreen.adapter_info());
    let failures: Vec<String> = dirs.iter().filter_map(|dir| run_case(&offscreen, dir, bless)).collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The vertex-shader skinning (palette texture) and morphing (morph texture) draw the same
/// picture as kloub_core's CPU reference. RecursiveSkeletons has 84 skins, so it checks each
/// draw's palette offset; MorphStressTest has many targets per primitive.
#[test]
fn gpu_skinning_matches_cpu_reference() {
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let mut failures = Vec::new();
    for (model, time) in [
        ("khronos/CesiumMan/glTF-Binary/CesiumMan.glb", 0.5),
        ("khronos/Fox/glTF-Binary/Fox.glb", 1.0),
        ("khronos/RecursiveSkeletons/glTF-Binary/RecursiveSkeletons.glb", 1.0),
        // Morph targets on the GPU (vertex shader) against the CPU reference.
        ("khronos/AnimatedMorphSphere/glTF-Binary/AnimatedMorphSphere.glb", 1.2),
        ("khronos/MorphStressTest/glTF-Binary/MorphStressTest.glb", 0.8),
    ] {
        let asset = load(model);
        let (mut instance, camera) = pose(&asset, Some(0), time, None);
        let mut renderer = offscreen.scene_renderer(&asset).expect("uploading");
        let mut frame = |path| {
            renderer.set_skinning_path(path).expect("the GPU and CPU paths exist everywhere");
            offscreen.render(&mut renderer, &asset, &mut instance, &camera, 192, 192).expect("rendering")
        };
        let gpu = frame(SkinningPath::Gpu);
        let cpu = frame(SkinningPath::Cpu);
        // The same view without the model: the model must cover a fair part of the frame.
        let ground = renderer.ground();
        renderer.clear_asset();
        renderer.set_ground(ground);
        let empty = offscreen.render(&mut renderer, &asset, &mut instance, &camera, 192, 192).expect("rendering");
        let covered = compare(&empty, &gpu, 24).differing_fraction;
        let comparison = compare(&cpu, &gpu, 24);
        eprintln!(
            "{model}: GPU vs CPU skinning: {:.4}% of pixels differ, largest channel difference {}; model covers {:.1}%",
            comparison.differing_fraction * 100.0,
            comparison.largest_channel_diff,
            covered * 100.0
        );
        if comparison.differing_fraction > 0.002 || covered < 0.02 {
            let name = Path::new(model).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            let out = kloub_tests::repo_root().join("tests/out/skinning").join(&name);
            write_png(&gpu, &out.join("gpu.png"));
            write_png(&cpu, &out.join("cpu.png"));
            write_png(&comparison.diff, &out.join("diff.png"));
            failures.push(format!(
                "{model}: {:.3}% of pixels differ between GPU and CPU skinning (largest {}); the model covers \
                 {:.1}% of the frame (at least 2% expected); see {}",
                comparison.differing_fraction * 100.0,
                comparison.largest_channel_diff,
                covered * 100.0,
                out.display()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The WebGL2 canvas's target: plain `Rgba8Unorm` with the shaders encoding sRGB
/// (`SRGB_ENCODE`) draws the picture the sRGB target does; a transparent background leaves
/// alpha 0 around the model and 255 on it.
#[test]
fn plain_target_encodes_srgb_like_the_srgb_target_and_transparent_leaves_alpha() {
    use kloub_web::render::SceneRenderer;
    use kloub_web::render::uniforms::{Background, Look};
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let asset = load("khronos/CesiumMan/glTF-Binary/CesiumMan.glb");
    let (mut instance, camera) = pose(&asset, Some(0), 0.5, None);
    // Single-sampled: a multisampled edge resolves in gamma space on the plain target (up to
    // ~45 levels apart on 1 % of the pixels), which is not what this compares.
    let (device, queue) = (offscreen.device(), offscreen.queue());
    let mut srgb = SceneRenderer::new(device, queue, 1);
    srgb.set_asset(device, queue, &asset).expect("uploading");
    let mut plain = SceneRenderer::with_format(device, queue, 1, wgpu::TextureFormat::Rgba8Unorm);
    plain.set_asset(device, queue, &asset).expect("uploading");
    assert_eq!(plain.format(), wgpu::TextureFormat::Rgba8Unorm);
    // The grid and the ground shadow blend in gamma space on the plain target (as the browser
    // does): compared without them.
    srgb.set_grid(false);
    plain.set_grid(false);
    let unshadowed = Look { shadow_intensity: 0.0, ..Look::default() };
    srgb.set_look(unshadowed);
    plain.set_look(unshadowed);
    let a = offscreen.render(&mut srgb, &asset, &mut instance, &camera, 192, 192).expect("rendering");
    let b = offscreen.render(&mut plain, &asset, &mut instance, &camera, 192, 192).expect("rendering");
    let comparison = compare(&a, &b, 2);
    eprintln!(
        "plain vs sRGB target: {:.3}% of pixels differ by more than 2, largest {}",
        comparison.differing_fraction * 100.0,
        comparison.largest_channel_diff
    );
    // Rounding only: the shader's encoding is the hardware's.
    assert!(comparison.differing_fraction < 0.001, "{:.3}% differ", comparison.differing_fraction * 100.0);

    for renderer in [&mut srgb, &mut plain] {
        renderer.set_look(Look { background: Background::Transparent, ..unshadowed });
        let image = offscreen.render(renderer, &asset, &mut instance, &camera, 192, 192).expect("rendering");
        let opaque = image.pixels().filter(|p| p.0[3] == 255).count() as f64 / (192.0 * 192.0);
        assert_eq!(image.get_pixel(0, 0).0, [0, 0, 0, 0], "a corner is not transparent");
        assert!((0.02..0.9).contains(&opaque), "{:.1}% of the pixels are opaque", opaque * 100.0);
    }
}

/// The specular chain (`rgba8unorm`, texels encoded by `encode_radiance` in
/// shaders/equirect.wgsl) holds radiance over half floats' range: its finest level, a copy of
/// a source as wide as it, decodes to every source texel within the encoding's rounding (under
/// 0.27 % of the texel's largest channel: half an 8-bit step of a scale up to 2^(1/8) times that
/// channel, 0.21 %, and the source's half-float rounding, 0.05 %), and each texel takes
/// the smallest exponent that holds it (its largest channel in the top step of the mantissa).
#[test]
fn the_specular_chain_holds_radiance_over_half_floats_range() {
    use kloub_web::render::environment::{HdrImage, IblKit, SPECULAR_FORMAT, SPECULAR_WIDTH};
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let (device, queue) = (offscreen.device(), offscreen.queue());
    let kit = IblKit::new(device, true).expect("the adapter prefilters environments");
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("test environment"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
        ],
    });
    // Magnitudes from 2^-14 to 2^15.9 along u, the hue turning along v (each channel's share of
    // the largest from 1 down to 0.05).
    let (width, height) = (SPECULAR_WIDTH, SPECULAR_WIDTH / 2);
    let rgb: Vec<[f32; 3]> = (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as f32 / (width - 1) as f32, (i / width) as f32 / (height - 1) as f32);
            let m = (-14.0 + 29.9 * x).exp2();
            [m, m * (0.05 + 0.95 * y), m * (1.0 - 0.95 * y)]
        })
        .collect();
    let image = HdrImage { width, height, rgb };
    let environment = kit.environment(device, queue, &layout, &image).expect("prefiltering");
    let chain = environment.specular.as_ref().expect("a specular chain");
    assert_eq!(chain.format(), SPECULAR_FORMAT);
    let texels = offscreen.read_texture(chain).expect("reading the chain back");
    assert_eq!(texels.dimensions(), (width, height));
    let (mut worst, mut worst_at) = (0.0f32, (0, 0));
    for (x, y, texel) in texels.enumerate_pixels() {
        let [r, g, b, a] = texel.0;
        let scale = (f32::from(a) / 255.0 * 32.0 - 16.0).exp2();
        let decoded = [r, g, b].map(|c| f32::from(c) / 255.0 * scale);
        let expected = image.rgb[(y * width + x) as usize];
        let largest = expected.iter().fold(0.0f32, |m, &c| m.max(c));
        for (d, e) in decoded.iter().zip(expected) {
            let error = (d - e).abs() / largest;
            if error > worst {
                (worst, worst_at) = (error, (x, y));
            }
        }
        assert!(r.max(g).max(b) >= 233, "texel ({x}, {y}) {:?}: not the smallest exponent", texel.0);
    }
    eprintln!("specular chain: largest error {:.4} % of a texel's largest channel, at {worst_at:?}", worst * 100.0);
    assert!(worst < 0.0027, "texel {worst_at:?} is off by {:.3} % of its largest channel", worst * 100.0);
}

/// The GPU mip chain (images the browser decodes: `MipMaker`, `shaders/mip.wgsl`) gives the
/// CPU mip chain's levels (images the importer decodes) within a step per channel and level:
/// box filter in linear light for colour, plain average for alpha and for data textures
/// (normal, metallic-roughness, occlusion), down to 1×1.
#[test]
fn gpu_mips_match_the_cpu_mip_chain() {
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    for srgb in [true, false] {
        gpu_mips_match(&offscreen, srgb);
    }
}

fn gpu_mips_match(offscreen: &Offscreen, srgb: bool) {
    use kloub_web::render::texture::{MipMaker, gpu_mipped_texture, image_format, mip_chain, mip_count, write_level};
    let format = image_format(srgb);
    let (device, queue) = (offscreen.device(), offscreen.queue());
    let (width, height) = (64u32, 32u32);
    // Gradients, a hard edge and varying alpha: what averaging in linear light changes most.
    let mut rgba8 = Vec::new();
    for y in 0..height {
        for x in 0..width {
            let edge = if (x / 3 + y / 5) % 2 == 0 { 255 } else { 0 };
            rgba8.extend([(x * 4) as u8, edge, (y * 8) as u8, ((x * 7 + y * 13) % 256) as u8]);
        }
    }
    let image = kloub_core::asset::Image { name: None, width, height, rgba8, encoded: None };
    let expected = mip_chain(&image, u32::MAX, srgb).expect("a valid image");
    assert_eq!(expected.len() as u32, mip_count(width, height));
    let texture = gpu_mipped_texture(device, "mips under test", width, height, format);
    write_level(queue, &texture, 0, &expected[0]);
    MipMaker::new(device, format).generate(device, queue, &texture);
    for (mip, level) in expected.iter().enumerate().skip(1) {
        // Each level copied into a texture of its own to be read back.
        let size = wgpu::Extent3d { width: level.width, height: level.height, depth_or_array_layers: 1 };
        let copy = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("mip level"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        encoder.copy_texture_to_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: mip as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            copy.as_image_copy(),
            size,
        );
        queue.submit([encoder.finish()]);
        let actual = offscreen.read_texture(&copy).expect("readback");
        let largest = actual.as_raw().iter().zip(&level.rgba8).map(|(a, e)| a.abs_diff(*e)).max().unwrap_or(0);
        eprintln!("GPU mips ({format:?}): level {mip}: largest channel difference {largest}");
        // Each level is rounded to bytes before the next is made from it, on both paths: the
        // difference may grow by a step per level (lavapipe: 1, 1, 2, 2, 2, 3).
        assert!(
            u32::from(largest) <= mip as u32,
            "level {mip} ({}×{}): a channel is off by {largest}",
            level.width,
            level.height
        );
    }
}

/// Pixel of world point `p` in a `size`² frame of `camera`.
fn pixel_of(camera: &Camera, p: glam::Vec3, size: u32) -> (u32, u32) {
    let clip = camera.view_proj(1.0) * p.extend(1.0);
    let ndc = clip.truncate() / clip.w;
    let x = ((ndc.x * 0.5 + 0.5) * size as f32) as u32;
    let y = ((0.5 - ndc.y * 0.5) * size as f32) as u32;
    (x.min(size - 1), y.min(size - 1))
}

fn luminance(image: &RgbaImage, (x, y): (u32, u32)) -> f32 {
    let p = image.get_pixel(x, y).0;
    0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2])
}

/// The normal map turns the right way on every axis: with the key light above and over the
/// viewer's left shoulder, each bump of the normal-mapped plane is brighter on its upper left
/// than its lower right, and brighter at its top than its bottom and at its left than its right
/// (an axis flipped by the texture's V convention or a backend's `dpdy` sign would swap one pair).
#[test]
fn normal_map_bumps_face_the_light() {
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let asset = kloub_tests::materials::normal_mapped_plane();
    let (mut instance, camera) = pose(&asset, None, 0.0, Some((0.0, 0.0)));
    let mut renderer = offscreen.scene_renderer(&asset).expect("uploading");
    let size = 256;
    let image = offscreen.render(&mut renderer, &asset, &mut instance, &camera, size, size).expect("rendering");
    let sides = bump_sides(&image, &camera, size);
    for (bump, s) in sides.iter().enumerate() {
        assert!(s.up > s.down + 8.0, "bump {bump}: top {} not brighter than bottom {}", s.up, s.down);
        assert!(s.left > s.right + 8.0, "bump {bump}: left {} not brighter than right {}", s.left, s.right);
        assert!(s.upper_left > s.lower_right + 16.0, "bump {bump}: upper left not brighter than lower right");
    }
    assert_eq!(sides.len(), 16);
}

/// Luminance at four sides of a bump of the normal-mapped plane, and at two corners.
struct BumpSides {
    up: f32,
    down: f32,
    left: f32,
    right: f32,
    upper_left: f32,
    lower_right: f32,
}

/// Each bump of the normal-mapped plane (as drawn unturned, facing the camera) sampled half its
/// radius (0.4 of a cell) from its centre.
fn bump_sides(image: &RgbaImage, camera: &Camera, size: u32) -> Vec<BumpSides> {
    let bumps = kloub_tests::materials::BUMPS;
    let cell = 1.0 / bumps as f32;
    let mut sides = Vec::new();
    for row in 0..bumps {
        for col in 0..bumps {
            // The bump's centre in world space (uv (0, 0) is the quad's top left).
            let centre = glam::Vec3::new(-0.5 + (col as f32 + 0.5) * cell, 0.5 - (row as f32 + 0.5) * cell, 0.0);
            let at = |dx: f32, dy: f32| {
                luminance(image, pixel_of(camera, centre + glam::Vec3::new(dx, dy, 0.0) * cell * 0.2, size))
            };
            sides.push(BumpSides {
                up: at(0.0, 1.0),
                down: at(0.0, -1.0),
                left: at(-1.0, 0.0),
                right: at(1.0, 0.0),
                upper_left: at(-0.7, 0.7),
                lower_right: at(0.7, -0.7),
            });
        }
    }
    sides
}

/// The file's tangents decide which way the normal map turns, and they move with the skin on
/// every path. A TANGENT along world +y (the image's −v) with w = 1 turns every bump's frame
/// by 90° (the bitangent, cross(normal, tangent), becomes −x): each bump is then brighter on
/// its right than its left, where the derived frame makes it brighter on its left. The same
/// plane skinned by a joint turned 90° about the view axis: tangents carried by the turn
/// (to −x, the bitangent to −y) light each bump brighter on its right and its top again, in
/// the vertex shader, the compute pass and the CPU path alike; and a morph target whose tangent
/// deltas turn +x into +y gives the first case's light, morphed on the GPU or the CPU.
/// Tangents ignored (the derived frame), left unturned by the skin or unmorphed would make the
/// left brighter.
#[test]
fn file_tangents_turn_the_normal_map_and_follow_the_skin() {
    use kloub_core::asset::{Node, Skin};
    use kloub_core::math::{Quat, Transform};
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let size = 256;
    let mut turned = kloub_tests::materials::normal_mapped_plane();
    turned.meshes[0].primitives[0].tangents = vec![[0.0, 1.0, 0.0, 1.0]; 4];
    let (mut instance, camera) = pose(&turned, None, 0.0, Some((0.0, 0.0)));
    let mut renderer = offscreen.scene_renderer(&turned).expect("uploading");
    let image = offscreen.render(&mut renderer, &turned, &mut instance, &camera, size, size).expect("rendering");
    assert_turned("turned tangents", &image, &camera, size);

    // Morphed: a target whose tangent deltas turn +x into +y, at weight 1, on the GPU (the morph
    // texture) and on the CPU.
    let mut morphed = kloub_tests::materials::normal_mapped_plane();
    {
        let p = &mut morphed.meshes[0].primitives[0];
        p.tangents = vec![[1.0, 0.0, 0.0, 1.0]; 4];
        p.targets = vec![kloub_core::asset::MorphTarget {
            positions: vec![[0.0; 3]; 4],
            normals: Vec::new(),
            tangents: vec![[-1.0, 1.0, 0.0]; 4],
        }];
    }
    morphed.meshes[0].weights = vec![1.0];
    morphed.nodes[0].weights = vec![1.0];
    morphed.weight_total = 1;
    let (mut instance, camera) = pose(&morphed, None, 0.0, Some((0.0, 0.0)));
    let mut renderer = offscreen.scene_renderer(&morphed).expect("uploading");
    for path in [SkinningPath::Gpu, SkinningPath::Cpu] {
        renderer.set_skinning_path(path).expect("lavapipe runs both paths");
        let image = offscreen.render(&mut renderer, &morphed, &mut instance, &camera, size, size).expect("rendering");
        assert_turned(&format!("morphed, {path:?}"), &image, &camera, size);
    }

    let mut skinned = kloub_tests::materials::normal_mapped_plane();
    {
        let p = &mut skinned.meshes[0].primitives[0];
        p.tangents = vec![[0.0, 1.0, 0.0, 1.0]; 4];
        p.joints = vec![[0; 8]; 4];
        p.weights = vec![[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]; 4];
    }
    let joint = Node {
        name: Some("turn".into()),
        rest: Transform { rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2), ..Transform::default() },
        ..Node::default()
    };
    skinned.nodes.push(joint);
    skinned.nodes[0].skin = Some(0);
    skinned.order.push(1);
    skinned.scenes[0].roots.push(1);
    skinned.weight_offsets.push(0);
    skinned.skins =
        vec![Skin { name: None, joints: vec![1], inverse_bind: vec![glam::Mat4::IDENTITY], skeleton: None }];
    let (mut instance, camera) = pose(&skinned, None, 0.0, Some((0.0, 0.0)));
    // WebGPU's limits: the compute pass too.
    let offscreen = Offscreen::webgpu().expect("a device with WebGPU's default limits");
    let mut renderer = offscreen.scene_renderer(&skinned).expect("uploading");
    for path in [SkinningPath::Gpu, SkinningPath::Compute, SkinningPath::Cpu] {
        renderer.set_skinning_path(path).expect("lavapipe runs every path");
        let image = offscreen.render(&mut renderer, &skinned, &mut instance, &camera, size, size).expect("rendering");
        assert_turned(&format!("skinned, {path:?}"), &image, &camera, size);
    }
}

/// Every bump lit as by a frame turned a quarter: brighter on its right than its left, and at
/// its top than its bottom.
fn assert_turned(case: &str, image: &RgbaImage, camera: &Camera, size: u32) {
    for (bump, s) in bump_sides(image, camera, size).iter().enumerate() {
        assert!(s.right > s.left + 8.0, "{case}, bump {bump}: right {} not brighter than left {}", s.right, s.left);
        assert!(s.up > s.down + 8.0, "{case}, bump {bump}: top {} not brighter than bottom {}", s.up, s.down);
    }
}

/// The sphere grid orders as the BRDF says: along the top row (smooth), the dielectric's
/// diffuse body is brighter than the metal's (metals have none; they only reflect); down the
/// dielectric column, roughness spreads the key light's highlight so its peak falls.
#[test]
fn metallic_and_roughness_change_the_spheres_as_the_brdf_says() {
    use kloub_tests::materials::GRID;
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let asset = kloub_tests::materials::sphere_grid();
    let (mut instance, camera) = pose(&asset, None, 0.0, Some((0.0, 0.0)));
    let mut renderer = offscreen.scene_renderer(&asset).expect("uploading");
    let size = 320;
    let image = offscreen.render(&mut renderer, &asset, &mut instance, &camera, size, size).expect("rendering");
    let centre = |row: usize, col: usize| glam::Vec3::new(col as f32 * 1.1 - 2.2, 2.2 - row as f32 * 1.1, 0.5);
    // The brightest pixel over a sphere's front (its highlight) and the mean over it.
    let stats = |row: usize, col: usize| {
        let (cx, cy) = pixel_of(&camera, centre(row, col), size);
        let (ex, _) = pixel_of(&camera, centre(row, col) + glam::Vec3::new(0.35, 0.0, 0.0), size);
        let r = (ex - cx) as i32;
        let (mut peak, mut sum, mut n) = (0.0f32, 0.0, 0.0);
        for dy in -r..=r {
            for dx in -r..=r {
                let l = luminance(&image, ((cx as i32 + dx) as u32, (cy as i32 + dy) as u32));
                peak = peak.max(l);
                sum += l;
                n += 1.0;
            }
        }
        (peak, sum / n)
    };
    let (_, dielectric) = stats(GRID - 1, 0);
    let (_, metal) = stats(GRID - 1, GRID - 1);
    assert!(dielectric > metal + 10.0, "rough dielectric {dielectric} not brighter than rough metal {metal}");
    let (smooth_peak, _) = stats(1, 0);
    let (rough_peak, _) = stats(GRID - 1, 0);
    assert!(smooth_peak > rough_peak + 10.0, "smooth highlight {smooth_peak} not above rough {rough_peak}");
}

/// The ground shadow (on by default) darkens the floor under the character and nothing far
/// from it; at intensity 0 it is gone, and a softer one spreads wider than a sharp one.
#[test]
fn ground_shadow_darkens_the_floor_under_the_character() {
    use kloub_web::render::SceneRenderer;
    use kloub_web::render::uniforms::{Background, Look};
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let asset = load("khronos/CesiumMan/glTF-Binary/CesiumMan.glb");
    let (mut instance, camera) = pose(&asset, Some(0), 0.5, Some((0.3, -0.5)));
    let (device, queue) = (offscreen.device(), offscreen.queue());
    let mut renderer = SceneRenderer::new(device, queue, 1);
    renderer.set_asset(device, queue, &asset).expect("uploading");
    renderer.set_grid(false);
    let size = 192;
    let mut shot_on = |background: Background, intensity: f32, softness: f32| {
        let look = Look { background, shadow_intensity: intensity, shadow_softness: softness, ..Look::default() };
        renderer.set_look(look);
        offscreen.render(&mut renderer, &asset, &mut instance, &camera, size, size).expect("rendering")
    };
    let grey = Background::Grey;
    let (with, sharp, without) = (shot_on(grey, 1.0, 1.0), shot_on(grey, 1.0, 0.0), shot_on(grey, 0.0, 1.0));
    // The character alone: opaque on a transparent background.
    let alone = shot_on(Background::Transparent, 0.0, 1.0);
    // Pixels where the shadow changed the floor, and how much darker it made them in all.
    let darkened = |a: &RgbaImage| {
        let (mut count, mut total) = (0usize, 0.0f32);
        for (p, q) in a.pixels().zip(without.pixels()) {
            let d = luminance_of(q) - luminance_of(p);
            if d > 2.0 {
                count += 1;
                total += d;
            }
            assert!(d > -2.0, "a shadow never brightens a pixel");
        }
        (count, total)
    };
    let (soft_count, soft_total) = darkened(&with);
    let (sharp_count, _) = darkened(&sharp);
    eprintln!("ground shadow: soft {soft_count} pixels ({soft_total:.0} levels), sharp {sharp_count}");
    assert!(soft_count > 200, "the shadow darkened only {soft_count} pixels");
    assert!(soft_count > sharp_count, "soft ({soft_count}) not wider than sharp ({sharp_count})");
    // Far from the character (the top corners: the background) nothing changes.
    for (x, y) in [(2, 2), (size - 3, 2)] {
        assert_eq!(with.get_pixel(x, y), without.get_pixel(x, y), "({x}, {y}) changed");
    }
    // The shadow starts at the feet (a shadow drawn under the wrong place would not): the
    // character is what is opaque on a transparent background, its feet its lowest rows, and
    // the shadow darkens the floor right beside them.
    let character: Vec<(u32, u32)> =
        alone.enumerate_pixels().filter(|(_, _, p)| p.0[3] > 0).map(|(x, y, _)| (x, y)).collect();
    let lowest = character.iter().map(|&(_, y)| y).max().expect("the character is in view");
    let feet: Vec<(u32, u32)> = character.iter().copied().filter(|&(_, y)| y + 3 >= lowest).collect();
    let beside_feet = with
        .enumerate_pixels()
        .filter(|&(x, y, p)| {
            luminance_of(without.get_pixel(x, y)) - luminance_of(p) > 2.0
                && feet.iter().any(|&(fx, fy)| fx.abs_diff(x) <= 4 && fy.abs_diff(y) <= 4)
        })
        .count();
    // And it falls away from the key light, which comes over the viewer's left shoulder: the
    // darkened floor's centre lies right of the feet's on screen.
    let centre_x = |points: &mut dyn Iterator<Item = u32>| {
        let (sum, n) = points.fold((0u64, 0u64), |(s, n), x| (s + u64::from(x), n + 1));
        sum as f32 / n.max(1) as f32
    };
    let feet_x = centre_x(&mut feet.iter().map(|&(x, _)| x));
    let shadow_x = centre_x(
        &mut with
            .enumerate_pixels()
            .filter(|&(x, y, p)| luminance_of(without.get_pixel(x, y)) - luminance_of(p) > 2.0)
            .map(|(x, _, _)| x),
    );
    eprintln!(
        "ground shadow: {beside_feet} darkened pixels beside the {} pixels of the feet; centre x {shadow_x:.1}, feet {feet_x:.1}",
        feet.len()
    );
    assert!(shadow_x > feet_x + 2.0, "the shadow (centre x {shadow_x}) does not fall right of the feet ({feet_x})");
    assert!(beside_feet >= 10, "the shadow is not at the feet ({beside_feet} darkened pixels beside them)");
}

/// A soft shadow's casters draw each primitive clustered on a grid
/// ([`kloub_core::simplify::cluster_triangles`]): the shadow is the full mesh's within a few
/// levels (the mask blurs detail finer than a cell), in every pose measured, while CesiumMan's
/// casters draw under a third of its triangles; many copies, each drawn small in the shadow map,
/// take the coarser cells (CesiumMan's: under 15 % of its triangles). The renderer's count of
/// the indices its casters drew says which lists it drew.
#[test]
fn a_soft_shadow_from_simplified_casters_matches_the_full_meshes() {
    use kloub_web::render::SceneRenderer;
    use kloub_web::render::uniforms::{Background, Look};
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let (device, queue) = (offscreen.device(), offscreen.queue());
    // Model, time, view, copies (in a square grid 1.25 boxes apart, as the element lays them out),
    // and whether its materials are made double-sided (their casters cull no face; gathered, each
    // triangle goes in with both windings).
    let cases = [
        ("khronos/CesiumMan/glTF-Binary/CesiumMan.glb", 0.5, (0.3, -0.5), 1, false),
        ("khronos/CesiumMan/glTF-Binary/CesiumMan.glb", 1.4, (-0.6, -0.15), 1, false),
        ("khronos/Fox/glTF-Binary/Fox.glb", 0.3, (0.3, -0.5), 1, false),
        ("threejs/RobotExpressive/RobotExpressive.glb", 0.8, (0.3, -0.4), 1, false),
        ("khronos/CesiumMan/glTF-Binary/CesiumMan.glb", 0.5, (0.3, -0.6), 4, false),
        ("khronos/CesiumMan/glTF-Binary/CesiumMan.glb", 0.5, (0.3, -0.6), 36, false),
        ("khronos/Fox/glTF-Binary/Fox.glb", 0.3, (0.3, -0.6), 16, false),
        // Several gathered draws of several copies (their order in the buffer), and double sides.
        ("threejs/RobotExpressive/RobotExpressive.glb", 0.8, (0.3, -0.5), 4, false),
        ("khronos/Fox/glTF-Binary/Fox.glb", 0.3, (0.3, -0.6), 4, true),
    ];
    for (model, time, view, copies, double_sided) in cases {
        let mut asset = load(model);
        if double_sided {
            asset.materials.iter_mut().for_each(|m| m.double_sided = true);
        }
        if model.contains("CesiumMan") {
            for (cells, most) in
                [(kloub_core::simplify::SHADOW_CELLS, 1.0 / 3.0), (kloub_core::simplify::COARSE_SHADOW_CELLS, 0.15)]
            {
                let (all, cast) = asset
                    .meshes
                    .iter()
                    .flat_map(|m| &m.primitives)
                    .map(|p| {
                        let simplified = kloub_core::simplify::cluster_triangles(p, cells);
                        (p.indices.len(), simplified.map_or(p.indices.len(), |s| s.len()))
                    })
                    .fold((0, 0), |(a, c), (x, y)| (a + x, c + y));
                assert!(
                    (cast as f64) < most * all as f64,
                    "CesiumMan's casters on {cells} cells draw {cast} of {all} indices"
                );
            }
        }
        let (mut instance, mut camera) = pose(&asset, Some(0), time, Some(view));
        let (min, max) = instance.scene_bounds(&asset).expect("the model has drawable meshes");
        let spacing = (max - min).x.max((max - min).z) * 1.25;
        let columns = (copies as f32).sqrt().ceil() as usize;
        let centre = |i: usize| (i as f32 - (columns - 1) as f32 / 2.0) * spacing;
        let offsets: Vec<glam::Vec3> =
            (0..copies).map(|c| glam::Vec3::new(centre(c % columns), 0.0, centre(c / columns))).collect();
        let reach = glam::Vec3::new(centre(columns - 1), 0.0, centre(columns - 1));
        camera.frame_to_fit(min - reach, max + reach);
        let mut others: Vec<Instance> = (1..copies).map(|_| instance.clone()).collect();
        let mut renderer = SceneRenderer::new(device, queue, 1);
        renderer.set_asset(device, queue, &asset).expect("uploading");
        renderer.set_grid(false);
        renderer.set_look(Look { background: Background::Grey, ..Look::default() });
        let size = 256;
        let mut shot = |full: bool, path: SkinningPath| {
            renderer.set_full_casters(full);
            renderer.set_skinning_path(path).expect("a skinning path");
            let mut all: Vec<&mut Instance> = std::iter::once(&mut instance).chain(others.iter_mut()).collect();
            renderer
                .render_copies(device, queue, &asset, &mut all, &offsets, &camera, [size, size])
                .expect("rendering");
            let image = offscreen.read_texture(renderer.target_texture().expect("rendered")).expect("reading back");
            let draws = renderer.caster_draws().expect("a shadow was drawn");
            (image, renderer.caster_indices_drawn().expect("a shadow was drawn"), draws)
        };
        let ((full, every, _), (simplified, drawn, each)) =
            (shot(true, SkinningPath::Gpu), shot(false, SkinningPath::Gpu));
        // On the CPU path (the browser's CPU adapters) every copy's casters are gathered into one
        // draw of the same triangles: the same shadow as the vertex shader's, within rounding.
        let (gathered, gathered_drawn, batched) = shot(false, SkinningPath::Cpu);
        let two_sided = (asset.meshes.iter().flat_map(|m| &m.primitives))
            .filter(|p| p.material.is_some_and(|m| asset.materials[m as usize].double_sided))
            .count();
        assert_eq!(each % copies as u64, 0, "{model} × {copies}: {each} caster draws on the GPU path");
        // One draw for every copy of the deformed primitives; RobotExpressive's static parts (not
        // deformed on the CPU) still draw one per copy.
        let expected = if model.contains("RobotExpressive") {
            batched < each && (each - batched + 1) % copies as u64 == 0
        } else {
            batched == 1
        };
        assert!(expected, "{model} × {copies}: {batched} caster draws gathered, {each} apart");
        match two_sided {
            0 => assert_eq!(gathered_drawn, drawn, "{model} × {copies}: the gathered casters draw the same triangles"),
            _ if double_sided => {
                assert_eq!(gathered_drawn, 2 * drawn, "{model} × {copies}: double-sided triangles gathered twice");
            }
            _ => {}
        }
        let g = compare(&simplified, &gathered, 2);
        eprintln!(
            "{model} × {copies}: gathered casters ({batched} draws against {each}) differ by up to {} levels, {:.3} % of pixels over 2",
            g.largest_channel_diff,
            g.differing_fraction * 100.0
        );
        // The model itself is skinned on the CPU here: its outline moves by rounding, as in
        // `gpu_skinning_matches_cpu_reference` (CesiumMan: up to 8 levels on under 0.1 %).
        assert!(g.largest_channel_diff <= 10, "{model} × {copies}: gathered casters {} levels", g.largest_channel_diff);
        assert!(
            g.differing_fraction < 0.002,
            "{model} × {copies}: gathered casters {} of pixels",
            g.differing_fraction
        );
        let all: usize = asset.meshes.iter().flat_map(|m| &m.primitives).map(|p| p.indices.len()).sum();
        assert_eq!(every, (all * copies) as u64, "{model} × {copies}: full casters draw every index");
        // What the simplified lists leave of the file's indices: CesiumMan's 32-cell lists under a
        // third, its 16-cell ones under 15 %; Fox's 16-cell ones 52 % (its 32-cell ones 78 %).
        let share = drawn as f64 / every as f64;
        let most = match (model.rsplit('/').next(), copies) {
            (Some("CesiumMan.glb"), 1..=4) => 1.0 / 3.0,
            (Some("CesiumMan.glb"), _) => 0.15,
            (Some("Fox.glb"), 9..) => 0.6,
            _ => 1.0,
        };
        assert!(share <= most, "{model} × {copies}: the casters drew {share:.3} of the indices");
        if model.contains("CesiumMan") {
            assert!(full != simplified, "{model} × {copies}: the simplified casters' shadow is the full one's");
        }
        let c = compare(&full, &simplified, 4);
        let out = kloub_tests::repo_root().join("tests/out/simplified-casters");
        let name = format!("{}-{time}-x{copies}", model.rsplit('/').next().unwrap_or(model));
        if std::fs::create_dir_all(&out).is_ok() {
            // Kept for a look: both shadows and where they differ.
            let _ = full.save(out.join(format!("{name}.full.png")));
            let _ = simplified.save(out.join(format!("{name}.simplified.png")));
            let _ = c.diff.save(out.join(format!("{name}.diff.png")));
        }
        eprintln!(
            "{model} × {copies} at {time} s: simplified casters' shadow differs by up to {} levels, {:.3} % of pixels over 4",
            c.largest_channel_diff,
            c.differing_fraction * 100.0
        );
        // Many copies: many more shadowed pixels in the view, so more along their outlines, and
        // coarser casters.
        let (levels, most) = if copies == 1 { (12, 0.005) } else { (14, 0.01) };
        assert!(c.largest_channel_diff <= levels, "{model} × {copies} at {time} s: {} levels", c.largest_channel_diff);
        assert!(c.differing_fraction < most, "{model} × {copies} at {time} s: {} of the pixels", c.differing_fraction);
    }
}

/// An alpha-masked material's casters draw every triangle even for a soft shadow: its cut is the
/// texture's alpha at interpolated UVs, which a clustered triangle would take from unrelated
/// parts of the texture. A dense sheet cut in rings (one a simplified list exists for) casts the
/// same shadow either way.
#[test]
fn an_alpha_masked_caster_draws_every_triangle() {
    use kloub_web::render::SceneRenderer;
    use kloub_web::render::uniforms::{Background, Look};
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let (device, queue) = (offscreen.device(), offscreen.queue());
    let mut asset = kloub_tests::materials::alpha_quads();
    // The masked quad (x −1.1..−0.1, y −0.5..0.5, facing +Z) made of 48 × 48 cells.
    let n = 48u32;
    let sheet = {
        let quad = &asset.meshes[0].primitives[0];
        assert_eq!(quad.material, Some(0), "the first quad is the masked one");
        let (lo, hi) = quad.bounds;
        let mut p = quad.clone();
        p.positions.clear();
        p.uv0.clear();
        p.indices.clear();
        for y in 0..=n {
            for x in 0..=n {
                let (u, v) = (x as f32 / n as f32, y as f32 / n as f32);
                p.positions.push([lo[0] + u * (hi[0] - lo[0]), hi[1] - v * (hi[1] - lo[1]), lo[2]]);
                p.uv0.push([u, v]);
            }
        }
        p.normals = vec![[0.0, 0.0, 1.0]; p.positions.len()];
        let at = |x: u32, y: u32| y * (n + 1) + x;
        for y in 0..n {
            for x in 0..n {
                p.indices.extend_from_slice(&[at(x, y), at(x, y + 1), at(x + 1, y + 1)]);
                p.indices.extend_from_slice(&[at(x, y), at(x + 1, y + 1), at(x + 1, y)]);
            }
        }
        p.vertex_count = p.positions.len() as u32;
        p
    };
    assert!(
        kloub_core::simplify::cluster_triangles(&sheet, kloub_core::simplify::SHADOW_CELLS).is_some(),
        "the sheet has a simplified list to not draw"
    );
    asset.meshes[0].primitives[0] = sheet;
    let (mut instance, camera) = pose(&asset, None, 0.0, Some((0.3, -0.5)));
    let mut renderer = SceneRenderer::new(device, queue, 1);
    renderer.set_asset(device, queue, &asset).expect("uploading");
    renderer.set_grid(false);
    renderer.set_look(Look { background: Background::Grey, ..Look::default() });
    let mut shot = |full: bool| {
        renderer.set_full_casters(full);
        let image = offscreen.render(&mut renderer, &asset, &mut instance, &camera, 256, 256).expect("rendering");
        (image, renderer.caster_indices_drawn().expect("a shadow was drawn"))
    };
    let ((full, every), (soft, drawn)) = (shot(true), shot(false));
    assert_eq!(drawn, every, "the masked sheet's casters drew a simplified list");
    assert!(full == soft, "the masked sheet's shadow changed");
}

fn luminance_of(p: &Rgba<u8>) -> f32 {
    0.2126 * f32::from(p.0[0]) + 0.7152 * f32::from(p.0[1]) + 0.0722 * f32::from(p.0[2])
}

/// A 1 × 1 quad in the XY plane facing +Z (counter-clockwise seen from there), single-sided,
/// with one morph target (all zeros: its vertices are deformed wherever morphs are), on a node
/// scaled by `scale`.
fn morphed_quad(scale: [f32; 3]) -> Asset {
    use base64::Engine as _;
    let mut bin: Vec<u8> = Vec::new();
    let positions = [[-0.5f32, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.0]];
    positions.iter().flatten().for_each(|f| bin.extend(f.to_le_bytes()));
    [[0.0f32, 0.0, 1.0]; 4].iter().flatten().for_each(|f| bin.extend(f.to_le_bytes()));
    [0.0f32; 12].iter().for_each(|f| bin.extend(f.to_le_bytes()));
    [0u16, 1, 2, 0, 2, 3].iter().for_each(|i| bin.extend(i.to_le_bytes()));
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bin));
    let view =
        |offset: usize, length: usize| serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": length});
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len(), "uri": uri}],
        "bufferViews": [view(0, 48), view(48, 48), view(96, 48), view(144, 12)],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-0.5, -0.5, 0.0], "max": [0.5, 0.5, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0]},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "meshes": [{"weights": [0.0], "primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 3, "targets": [{"POSITION": 2}],
        }]}],
        "nodes": [{"mesh": 0, "scale": scale}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    });
    let bytes = serde_json::to_vec(&json).expect("JSON");
    kloub_core::import(&bytes, &MapResolver::new(), &ImportOptions::default()).expect("a valid glTF").asset
}

/// A node that mirrors its mesh (a negative scale) turns its triangles' winding round; a
/// single-sided material must still show its front, whether the vertices are transformed by
/// the vertex shader or deformed (here: morphed) on the CPU with the node's matrix baked in.
#[test]
fn a_mirrored_single_sided_mesh_shows_its_front_on_every_path() {
    use kloub_web::render::SceneRenderer;
    use kloub_web::render::uniforms::{Background, Look};
    let offscreen = Offscreen::new().expect("a wgpu adapter");
    let (device, queue) = (offscreen.device(), offscreen.queue());
    let size = 64;
    for scale in [[1.0, 1.0, 1.0], [-1.0, 1.0, 1.0]] {
        let asset = morphed_quad(scale);
        let (mut instance, camera) = pose(&asset, None, 0.0, Some((0.0, 0.0)));
        for path in [SkinningPath::Cpu, SkinningPath::Gpu] {
            let mut renderer = SceneRenderer::new(device, queue, 1);
            renderer.set_asset(device, queue, &asset).expect("uploading");
            renderer.set_grid(false);
            renderer.set_skinning_path(path).expect("a path every device has");
            renderer.set_look(Look { background: Background::Transparent, shadow_intensity: 0.0, ..Look::default() });
            let image = offscreen.render(&mut renderer, &asset, &mut instance, &camera, size, size).expect("rendering");
            let shown = image.pixels().filter(|p| p.0[3] > 0).count();
            eprintln!("mirrored quad: scale {scale:?}, {path:?}: {shown} pixels");
            assert!(
                shown > (size * size / 8) as usize,
                "scale {scale:?}, {path:?}: the quad's front shows in {shown} pixels"
            );
        }
    }
}
