//! The whole app frame loop on a native wgpu device (lavapipe in CI): load by drop, play,
//! render into the viewport texture, reject a bad file while keeping the model, and mirror
//! the page contract's `dataset` values.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use kloub_core::job::ik::IkSolver;
use kloub_web::app::{App, AppConfig};
use kloub_web::control::Command;
use kloub_web::dom::Key;

/// A dropped file backed by bytes in memory.
#[derive(Debug)]
struct MemFile {
    path: PathBuf,
    bytes: Vec<u8>,
}

impl egui::DroppedFile for MemFile {
    fn path(&self) -> &Path {
        &self.path
    }

    fn bytes(&self) -> Result<Vec<u8>, String> {
        Ok(self.bytes.clone())
    }
}

fn dropped(name: &str, bytes: Vec<u8>) -> egui::DroppedFileHandle {
    Arc::new(MemFile { path: PathBuf::from(name), bytes })
}

fn render_state() -> egui_wgpu::RenderState {
    let config = egui_wgpu::WgpuConfiguration::default();
    let egui_wgpu::WgpuSetup::CreateNew(create) = &config.wgpu_setup else {
        panic!("the default wgpu setup creates a new device");
    };
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: create.instance_descriptor.backends,
        flags: create.instance_descriptor.flags,
        backend_options: create.instance_descriptor.backend_options.clone(),
        memory_budget_thresholds: create.instance_descriptor.memory_budget_thresholds,
        display: None,
    });
    pollster::block_on(egui_wgpu::RenderState::create(&config, &instance, None, egui_wgpu::RendererOptions::default()))
        .expect("a wgpu adapter (lavapipe: apt-get install mesa-vulkan-drivers)")
}

const SIZE: [u32; 2] = [640, 400];

struct Harness {
    ctx: egui::Context,
    frame: eframe::Frame,
    state: egui_wgpu::RenderState,
    app: App,
    time: f64,
}

impl Harness {
    fn new() -> Self {
        let ctx = egui::Context::default();
        let mut cc = eframe::CreationContext::_new_kittest(ctx.clone());
        let state = render_state();
        cc.wgpu_render_state = Some(state.clone());
        let app = App::new(&cc, AppConfig::default()).expect("app starts with a wgpu render state");
        let mut frame = eframe::Frame::_new_kittest();
        frame.wgpu_render_state = Some(state.clone());
        Self { ctx, frame, state, app, time: 0.0 }
    }

    /// Runs one frame of `dt` seconds with `files` dropped on it and paints it as eframe does
    /// (into an `Rgba8Unorm` target, like the web surface); returns the pixels.
    fn step(&mut self, dt: f64, files: Vec<egui::DroppedFileHandle>) -> image::RgbaImage {
        self.step_with(dt, files, Vec::new())
    }

    /// One frame with input `events` (pointer moves and presses).
    fn step_events(&mut self, dt: f64, events: Vec<egui::Event>) -> image::RgbaImage {
        self.step_with(dt, Vec::new(), events)
    }

    fn step_with(
        &mut self,
        dt: f64,
        files: Vec<egui::DroppedFileHandle>,
        events: Vec<egui::Event>,
    ) -> image::RgbaImage {
        use eframe::App as _;
        self.time += dt;
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(640.0, 400.0))),
            time: Some(self.time),
            predicted_dt: dt as f32,
            dropped_files: files,
            events,
            ..Default::default()
        };
        let (app, frame) = (&mut self.app, &mut self.frame);
        let output = self.ctx.run_ui(input, |ui| app.ui(ui, frame));
        self.paint(output)
    }

    fn paint(&self, mut output: egui::FullOutput) -> image::RgbaImage {
        let (device, queue) = (&self.state.device, &self.state.queue);
        let mut renderer = self.state.renderer.write();
        for (id, deltas) in &output.textures_delta.set {
            for delta in deltas {
                renderer.update_texture(device, queue, *id, delta);
            }
        }
        let jobs = self.ctx.tessellate(std::mem::take(&mut output.shapes), output.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor { size_in_pixels: SIZE, pixels_per_point: output.pixels_per_point };
        let format = self.state.target_format;
        let target = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("test frame"),
            size: wgpu::Extent3d { width: SIZE[0], height: SIZE[1], depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = target.create_view(&wgpu::TextureViewDescriptor::default());
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        let mut commands = renderer.update_buffers(device, queue, &mut encoder, &jobs, &screen);
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("egui"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
                .forget_lifetime();
            renderer.render(&mut pass, &jobs, &screen);
        }
        for id in &output.textures_delta.free {
            renderer.free_texture(id);
        }
        output.textures_delta.clear();
        drop(renderer);

        let row = (SIZE[0] * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("test readback"),
            size: u64::from(row * SIZE[1]),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        encoder.copy_texture_to_buffer(
            target.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(SIZE[1]),
                },
            },
            wgpu::Extent3d { width: SIZE[0], height: SIZE[1], depth_or_array_layers: 1 },
        );
        commands.push(encoder.finish());
        queue.submit(commands);
        buffer.slice(..).map_async(wgpu::MapMode::Read, |r| r.expect("readback maps"));
        device.poll(wgpu::PollType::wait_indefinitely()).expect("device finishes the frame");
        let data = buffer.slice(..).get_mapped_range().expect("mapped readback");
        let mut pixels = Vec::with_capacity((SIZE[0] * SIZE[1] * 4) as usize);
        for y in 0..SIZE[1] {
            let start = (y * row) as usize;
            pixels.extend_from_slice(&data[start..start + (SIZE[0] * 4) as usize]);
        }
        let mut image = image::RgbaImage::from_raw(SIZE[0], SIZE[1], pixels).expect("sized buffer");
        if format == wgpu::TextureFormat::Bgra8Unorm {
            for p in image.pixels_mut() {
                p.0.swap(0, 2);
            }
        }
        image
    }

    fn get(&self, key: Key) -> &str {
        self.app.dataset().get(key).unwrap_or("<unset>")
    }

    /// The first screen position in a `"x,y;…"` dataset key (`ikTarget`, `ikPole`).
    fn marker(&self, key: Key) -> egui::Pos2 {
        let first = self.get(key).split(';').next().unwrap_or("");
        let (x, y) = first.split_once(',').expect("x,y");
        egui::pos2(x.parse().expect("x"), y.parse().expect("y"))
    }

    /// Presses the primary button at `from`, drags by `by` in ten steps and lets go.
    fn drag(&mut self, from: egui::Pos2, by: egui::Vec2) {
        let press = |pos, pressed| egui::Event::PointerButton {
            pos,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: egui::Modifiers::NONE,
        };
        self.step_events(0.016, vec![egui::Event::PointerMoved(from)]);
        self.step_events(0.016, vec![press(from, true)]);
        for i in 1..=10 {
            self.step_events(0.016, vec![egui::Event::PointerMoved(from + (by / 10.0) * i as f32)]);
        }
        self.step_events(0.016, vec![press(from + by, false)]);
    }
}

/// Pixels that differ by more than a small tolerance inside `rect` (x0, y0, x1, y1).
fn changed_pixels(a: &image::RgbaImage, b: &image::RgbaImage, rect: (u32, u32, u32, u32)) -> usize {
    let mut n = 0;
    for y in rect.1..rect.3 {
        for x in rect.0..rect.2 {
            let (p, q) = (a.get_pixel(x, y).0, b.get_pixel(x, y).0);
            if p.iter().zip(q).any(|(u, v)| u.abs_diff(v) > 8) {
                n += 1;
            }
        }
    }
    n
}

fn save(image: &image::RgbaImage, name: &str) {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("app_headless");
    let _ = std::fs::create_dir_all(&dir);
    let _ = image.save(dir.join(name));
}

#[test]
fn drop_play_and_reject_a_bad_file() {
    let fox = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/Fox.glb")).expect("web/assets/Fox.glb");
    let mut h = Harness::new();
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Status), "ready", "nothing requested yet");
    assert_eq!(h.get(Key::Model), "");
    assert_eq!(h.get(Key::Clips), "[]");

    h.step(0.016, vec![dropped("Fox.glb", fox)]);
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Error), "");
    assert_eq!(h.get(Key::Status), "ready");
    assert_eq!(h.get(Key::Model), "Fox.glb");
    assert_eq!(h.get(Key::Clips), r#"["Survey","Walk","Run"]"#);
    assert_eq!(h.get(Key::Clip), "Survey");
    assert!(!h.get(Key::Backend).is_empty());

    let t0 = main_time(&h);
    let before = h.step(0.05, Vec::new());
    for _ in 0..4 {
        h.step(0.1, Vec::new());
    }
    let after = h.step(0.05, Vec::new());
    let t1 = main_time(&h);
    assert!(t1 > t0 + 0.3, "the clip plays: {t0} -> {t1}");
    save(&before, "fox-a.png");
    save(&after, "fox-b.png");
    // The viewport is right of the side panel; the animated fox changes it.
    let viewport = (320, 40, SIZE[0], SIZE[1] - 40);
    let changed = changed_pixels(&before, &after, viewport);
    assert!(changed > 200, "only {changed} viewport pixels changed while playing");
    let frames: u64 = h.get(Key::Frames).parse().expect("frames is an integer");
    assert_eq!(frames, 9);

    h.step(0.016, vec![dropped("broken.glb", b"glTF\x02\0\0\0not really".to_vec())]);
    for _ in 0..10 {
        h.step(0.05, Vec::new());
    }
    let shown = h.step(0.05, Vec::new());
    save(&shown, "bad-file.png");
    assert_eq!(h.get(Key::Status), "error");
    assert!(h.get(Key::Error).starts_with("broken.glb: "), "{}", h.get(Key::Error));
    assert!(h.app.error_message().is_some(), "an error window is open");
    assert_eq!(h.get(Key::Model), "Fox.glb", "the previous model stays");
    assert_eq!(h.app.model().map(|m| m.name.as_str()), Some("Fox.glb"));
}

fn main_time(h: &Harness) -> f32 {
    h.app.model().map_or(f32::NAN, |m| m.animator.main().time)
}

fn shared_asset(rel: &str) -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets").join(rel);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e} (the shared test assets)", path.display()))
}

/// Loads `name` by drop, pauses and shows its clip `clip` at `time`.
fn load_paused(h: &mut Harness, name: &str, bytes: Vec<u8>) {
    h.step(0.016, vec![dropped(name, bytes)]);
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Model), name, "{}", h.get(Key::Error));
    h.app.controls().send(Command::Pause);
}

#[test]
fn crossfade_from_the_page_controls_blends_into_the_target_clip() {
    let fox = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/Fox.glb")).expect("web/assets/Fox.glb");
    let mut h = Harness::new();
    load_paused(&mut h, "Fox.glb", fox);
    let controls = h.app.controls().clone();
    let (walk, run) = (controls.clip_index("Walk").expect("Walk"), controls.clip_index("Run").expect("Run"));
    assert!(controls.clip_index("Gallop").is_err());
    controls.send(Command::CrossfadeTo { clip: Some(walk), seconds: 0.0 });
    controls.send(Command::Pause);
    controls.send(Command::Seek(0.0));
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Clip), "Walk");
    assert_eq!(h.get(Key::Playing), "false");
    assert_eq!(h.get(Key::Crossfade), "", "a zero duration cuts");
    let walk_shot = h.step(0.016, Vec::new());

    controls.send(Command::CrossfadeTo { clip: Some(run), seconds: 0.5 });
    h.step(0.1, Vec::new());
    h.step(0.1, Vec::new());
    let w: f32 = h.get(Key::Crossfade).parse().expect("a crossfade weight while fading");
    assert!(w > 0.0 && w < 1.0, "mid-fade weight {w}");
    assert_eq!(h.get(Key::Clip), "Run");
    assert_eq!(h.get(Key::Playing), "true", "a crossfade plays its target");
    for _ in 0..5 {
        h.step(0.1, Vec::new());
    }
    assert_eq!(h.get(Key::Crossfade), "", "the crossfade finished");
    controls.send(Command::Pause);
    controls.send(Command::Seek(0.0));
    h.step(0.016, Vec::new());
    let faded = h.step(0.016, Vec::new());

    // The same frame reached by cutting straight to Run.
    controls.send(Command::CrossfadeTo { clip: Some(run), seconds: 0.0 });
    controls.send(Command::Pause);
    controls.send(Command::Seek(0.0));
    h.step(0.016, Vec::new());
    let cut = h.step(0.016, Vec::new());
    save(&walk_shot, "crossfade-walk.png");
    save(&faded, "crossfade-run.png");
    let viewport = (320, 40, SIZE[0], SIZE[1] - 40);
    let changed = changed_pixels(&walk_shot, &faded, viewport);
    assert!(changed > 200, "Walk -> Run changed only {changed} pixels");
    let residual = changed_pixels(&faded, &cut, viewport);
    assert!(residual < 20, "after the crossfade the pose is Run's: {residual} pixels differ");
}

#[test]
fn a_layer_moves_the_subtree_under_its_root_only() {
    let mut h = Harness::new();
    load_paused(&mut h, "RobotExpressive.glb", shared_asset("threejs/RobotExpressive/RobotExpressive.glb"));
    let controls = h.app.controls().clone();
    let walking = controls.clip_index("Walking").expect("Walking");
    let wave = controls.clip_index("Wave").expect("Wave");
    let abdomen = controls.node_index("Abdomen").expect("Abdomen");
    controls.send(Command::CrossfadeTo { clip: Some(walking), seconds: 0.0 });
    controls.send(Command::Pause);
    controls.send(Command::Seek(0.3));
    h.step(0.016, Vec::new());
    let plain = h.step(0.016, Vec::new());
    let model = h.app.model().expect("a model");
    let before: Vec<glam::Mat4> = model.instance.worlds().to_vec();

    controls.send(Command::SetLayer { clip: Some(wave), root: abdomen, weight: 1.0 });
    controls.send(Command::Play);
    for _ in 0..6 {
        h.step(0.1, Vec::new());
    }
    controls.send(Command::Pause);
    controls.send(Command::Seek(0.3));
    h.step(0.016, Vec::new());
    let layered = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Layer), "Wave@Abdomen:1.00");
    save(&plain, "layer-off.png");
    save(&layered, "layer-wave.png");

    let model = h.app.model().expect("a model");
    let after = model.instance.worlds();
    let name = |i: usize| model.asset.nodes[i].name.clone().unwrap_or_default();
    let moved = |i: usize| !before[i].abs_diff_eq(after[i], 1e-4);
    let hand = controls.node_index("LowerArm.R").expect("LowerArm.R") as usize;
    let leg = controls.node_index("LowerLeg.L").expect("LowerLeg.L") as usize;
    assert!(moved(hand), "{} under the layer root did not move", name(hand));
    assert!(!moved(leg), "{} outside the layer moved", name(leg));
    let changed = changed_pixels(&plain, &layered, (320, 40, SIZE[0], SIZE[1] - 40));
    assert!(changed > 100, "the Wave layer changed only {changed} pixels");

    controls.send(Command::SetLayer { clip: None, root: 0, weight: 0.0 });
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Layer), "");
}

/// The candy-wrapper sample from the page controls: LBS pinches it at 150° twist, DQS and SJB
/// keep its radius, the quality readout follows the method, the picture changes, and the
/// method and path survive loading another model.
#[test]
fn candy_wrapper_sample_compares_skinning_methods() {
    use kloub_core::job::dqs::SkinningMethod;
    use kloub_web::candy::Sample;
    use kloub_web::render::SkinningPath;

    let mut h = Harness::new();
    let controls = h.app.controls().clone();
    controls.send_global(Command::LoadSample(Sample::CandyWrapper));
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Model), "Candy wrapper");
    assert_eq!(h.get(Key::Clips), r#"["Twist","Bend"]"#);
    controls.send(Command::SetCandyPose { twist: 150.0, bend: 0.0 });
    h.step(0.016, Vec::new());
    let lbs = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Skinning), "lbs");
    let radius = |h: &Harness| -> f32 {
        let q = h.get(Key::Quality);
        q.split(',').next().and_then(|r| r.parse().ok()).unwrap_or_else(|| panic!("quality {q:?}"))
    };
    assert!((radius(&h) - 0.259).abs() < 0.01, "LBS radius at 150°: {}", h.get(Key::Quality));

    let mut pictures = vec![lbs];
    for method in [SkinningMethod::DualQuaternion, SkinningMethod::SphericalJointBlend] {
        controls.send_global(Command::SetSkinning(method));
        h.step(0.016, Vec::new());
        pictures.push(h.step(0.016, Vec::new()));
        assert_eq!(h.get(Key::Skinning), method.name());
        assert!(radius(&h) > 0.99, "{}: {}", method.name(), h.get(Key::Quality));
    }
    save(&pictures[0], "candy-lbs.png");
    save(&pictures[1], "candy-dqs.png");
    let changed = changed_pixels(&pictures[0], &pictures[1], (280, 40, SIZE[0], SIZE[1] - 40));
    assert!(changed > 200, "switching LBS → DQS changed only {changed} pixels");

    // The heatmap colours where SJB departs from LBS: the twisted joint.
    controls.send_global(Command::SetHeatmap(true));
    h.step(0.016, Vec::new());
    let heat = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Heatmap), "true");
    save(&heat, "candy-sjb-heatmap.png");
    let reddish = (280..SIZE[0])
        .flat_map(|x| (40..SIZE[1] - 40).map(move |y| (x, y)))
        .filter(|&(x, y)| {
            let p = heat.get_pixel(x, y).0;
            p[0] > 150 && p[1] < 90 && p[2] < 90
        })
        .count();
    assert!(reddish > 100, "the heatmap shows only {reddish} red pixels at a 150° twist");
    controls.send_global(Command::SetHeatmap(false));
    h.step(0.016, Vec::new());
    let off = h.step(0.016, Vec::new());
    let differ = changed_pixels(&pictures[2], &off, (280, 40, SIZE[0], SIZE[1] - 40));
    assert!(differ < 40, "turning the heatmap off left {differ} changed pixels");

    // The compute pass (native has compute shaders) draws the same picture as the vertex shader.
    controls.send_global(Command::SetSkinningPath(SkinningPath::Compute));
    h.step(0.016, Vec::new());
    let compute = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::SkinningPath), "compute");
    let differ = changed_pixels(&pictures[2], &compute, (280, 40, SIZE[0], SIZE[1] - 40));
    assert!(differ < 40, "vertex-shader and compute SJB differ in {differ} pixels");

    // The CPU path draws the same picture as the GPU one.
    controls.send_global(Command::SetSkinningPath(SkinningPath::Cpu));
    h.step(0.016, Vec::new());
    let cpu = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::SkinningPath), "cpu");
    let differ = changed_pixels(&pictures[2], &cpu, (280, 40, SIZE[0], SIZE[1] - 40));
    assert!(differ < 40, "GPU and CPU SJB differ in {differ} pixels");

    // A clip takes over from the sliders; the settings stay for the next model.
    let twist = controls.clip_index("Twist").expect("Twist");
    controls.send(Command::PlayClip(Some(twist)));
    h.step(0.016, Vec::new());
    assert!(!h.app.model().and_then(|m| m.candy.as_ref()).expect("sample").manual);
    load_paused(&mut h, "Fox.glb", shared_asset("khronos/Fox/glTF-Binary/Fox.glb"));
    assert_eq!(h.get(Key::Skinning), "sjb");
    assert_eq!(h.get(Key::SkinningPath), "cpu");
    assert_eq!(h.get(Key::Quality), "");
}

/// Copies of the character fill a grid, each at its own time, and follow the main clip.
#[test]
fn copies_fill_a_grid_and_follow_the_main_clip() {
    let mut h = Harness::new();
    load_paused(&mut h, "Fox.glb", shared_asset("khronos/Fox/glTF-Binary/Fox.glb"));
    let controls = h.app.controls().clone();
    let one = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Copies), "1");
    controls.send(Command::SetCopies(9));
    h.step(0.016, Vec::new());
    let nine = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Copies), "9");
    save(&nine, "copies-9.png");
    let model = h.app.model().expect("a model");
    assert_eq!(model.copies.len(), 8);
    // Neighbouring copies stand apart and are at different times of the same clip.
    assert!(model.copy_offset(0).distance(model.copy_offset(1)) > 1.0);
    let main = model.animator.main();
    let (first, _) = &model.copies[0];
    assert_eq!(first.main().clip, main.clip);
    assert!((first.main().time - main.time).abs() > 0.1, "copy 1 plays at the main time");
    let changed = changed_pixels(&one, &nine, (280, 40, SIZE[0], SIZE[1] - 40));
    assert!(changed > 500, "nine copies changed only {changed} pixels");

    let run = controls.clip_index("Run").expect("Run");
    controls.send(Command::CrossfadeTo { clip: Some(run), seconds: 0.0 });
    h.step(0.016, Vec::new());
    let model = h.app.model().expect("a model");
    assert!(model.copies.iter().all(|(a, _)| a.main().clip == Some(run)), "copies did not follow the clip change");
    controls.send(Command::SetCopies(1));
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Copies), "1");
}

/// IK from the page controls and by dragging the target in the viewport: RiggedFigure's left
/// hand follows the target; the overlay's error readout says it reached it.
#[test]
fn dragging_the_ik_target_moves_the_hand_onto_it() {
    let mut h = Harness::new();
    load_paused(&mut h, "RiggedFigure.glb", shared_asset("khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb"));
    let controls = h.app.controls().clone();
    let hand = controls.node_index("arm_joint_L_3").expect("the left hand");
    let world = |h: &Harness| h.app.model().expect("a model").instance.worlds()[hand as usize].w_axis.truncate();
    let start = world(&h);
    let target = start + glam::Vec3::new(0.0, 0.06, 0.05);
    controls.send(Command::SetIk { effector: Some(hand), depth: 2, target: Some(target.to_array()) });
    h.step(0.016, Vec::new());
    let before = h.step(0.016, Vec::new());
    assert!(world(&h).distance(target) < 1e-3, "the hand is at {} instead of {target}", world(&h));
    let ik = h.get(Key::Ik).to_owned();
    assert!(ik.starts_with("arm_joint_L_3:"), "dataset.ik = {ik:?}");

    // Drag the target ring 40 points to the left and 30 up.
    let from = h.marker(Key::IkTarget);
    let to = from + egui::vec2(-40.0, -30.0);
    h.drag(from, to - from);
    let after = h.step(0.016, Vec::new());
    save(&before, "ik-before.png");
    save(&after, "ik-after.png");
    let moved = h.app.model().and_then(|m| m.ik.first()).expect("ik").target;
    assert!(moved.distance(target) > 0.02, "the drag did not move the target ({moved} vs {target})");
    assert!(world(&h).distance(moved) < 1e-3, "the hand {} did not follow the target {moved}", world(&h));
    let ring = h.marker(Key::IkTarget);
    assert!(
        (ring.x - to.x).abs() < 2.0 && (ring.y - to.y).abs() < 2.0,
        "the ring is at {ring:?}, the pointer let go at {to:?}"
    );
    assert!(changed_pixels(&before, &after, (280, 40, SIZE[0], SIZE[1] - 40)) > 30, "the arm did not move on screen");

    // The wheel over the ring moves the target along the view direction (towards the camera
    // for a positive scroll), not the camera.
    let eye = h.app.model().and_then(|m| m.ik.first()).map(|ik| ik.target).expect("ik");
    let distance_before = h.app.dataset().get(Key::Viewport).map(str::to_owned);
    h.step_events(0.016, vec![egui::Event::PointerMoved(to)]);
    h.step_events(
        0.016,
        vec![egui::Event::MouseWheel {
            unit: egui::MouseWheelUnit::Point,
            delta: egui::vec2(0.0, 60.0),
            phase: egui::TouchPhase::Move,
            source: egui::MouseWheelSource::Wheel,
            modifiers: egui::Modifiers::NONE,
        }],
    );
    h.step(0.016, Vec::new());
    let pushed = h.app.model().and_then(|m| m.ik.first()).map(|ik| ik.target).expect("ik");
    assert!(pushed.distance(eye) > 0.01, "the wheel did not move the target ({pushed} vs {eye})");
    assert_eq!(h.app.dataset().get(Key::Viewport).map(str::to_owned), distance_before);
    assert!(world(&h).distance(pushed) < 1e-3, "the hand did not follow the target in depth");

    controls.send(Command::SetIk { effector: None, depth: 0, target: None });
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Ik), "");
}

/// A `.kloub.json` sidecar dropped with the model (or onto it) sets IK joint settings: with
/// the shoulder's stiffness at 0 only the elbow turns; a bad sidecar is refused with its JSON
/// pointer and the settings stay.
#[test]
fn a_dropped_sidecar_sets_ik_stiffness_and_limits() {
    let mut h = Harness::new();
    let sidecar = br#"{"ik": {"stiffness": {"arm_joint_L_1": 0}, "limits": {"arm_joint_L_2": "free"}}}"#.to_vec();
    let model = shared_asset("khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb");
    h.step(0.016, vec![dropped("RiggedFigure.glb", model), dropped("RiggedFigure.kloub.json", sidecar)]);
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Model), "RiggedFigure.glb");
    let controls = h.app.controls().clone();
    controls.send(Command::Pause);
    h.step(0.016, Vec::new());
    let shoulder = controls.node_index("arm_joint_L_1").expect("shoulder") as usize;
    let elbow = controls.node_index("arm_joint_L_2").expect("elbow") as usize;
    let hand = controls.node_index("arm_joint_L_3").expect("hand");
    let rotation = |h: &Harness, n: usize| h.app.model().expect("a model").instance.pose().locals[n].rotation;
    let (shoulder_before, elbow_before) = (rotation(&h, shoulder), rotation(&h, elbow));
    let model = h.app.model().expect("a model");
    assert_eq!(model.joint_settings.stiffness[shoulder], 0.0);
    assert!(model.sidecar_json().contains("arm_joint_L_1"), "{}", model.sidecar_json());
    let at = model.instance.worlds()[hand as usize].w_axis.truncate();
    controls.send(Command::SetIk {
        effector: Some(hand),
        depth: 2,
        target: Some((at + glam::Vec3::new(0.0, 0.05, 0.05)).to_array()),
    });
    h.step(0.016, Vec::new());
    h.step(0.016, Vec::new());
    assert!(rotation(&h, shoulder).abs_diff_eq(shoulder_before, 1e-6), "the frozen shoulder turned");
    assert!(!rotation(&h, elbow).abs_diff_eq(elbow_before, 1e-4), "the elbow did not turn");

    // A sidecar alone applies to the shown model; a bad one names its pointer and changes nothing.
    h.step(0.016, vec![dropped("RiggedFigure.kloub.json", br#"{"ik": {"stiffness": {"arm_joint_L_1": 1}}}"#.to_vec())]);
    h.step(0.016, Vec::new());
    assert_eq!(h.app.model().expect("a model").joint_settings.stiffness[shoulder], 1.0);
    h.step(0.016, vec![dropped("bad.kloub.json", br#"{"ik": {"limits": {"nope": "free"}}}"#.to_vec())]);
    h.step(0.016, Vec::new());
    assert!(h.get(Key::Error).contains("/ik/limits/nope"), "error: {}", h.get(Key::Error));
    assert_eq!(h.get(Key::Model), "RiggedFigure.glb");
    assert_eq!(h.app.model().expect("a model").joint_settings.stiffness[shoulder], 1.0);
}

/// Two goals at once (both hands): each reaches its own target; the dataset lists both; a
/// goal can be removed.
#[test]
fn two_ik_goals_are_solved_together() {
    let mut h = Harness::new();
    load_paused(&mut h, "RiggedFigure.glb", shared_asset("khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb"));
    let controls = h.app.controls().clone();
    let hands =
        [controls.node_index("arm_joint_L_3").expect("left"), controls.node_index("arm_joint_R_3").expect("right")];
    let world = |h: &Harness, n: u32| h.app.model().expect("a model").instance.worlds()[n as usize].w_axis.truncate();
    let targets = hands.map(|n| world(&h, n) + glam::Vec3::new(0.0, 0.06, 0.04));
    for (hand, target) in hands.iter().zip(&targets) {
        controls.send(Command::SetIk { effector: Some(*hand), depth: 2, target: Some(target.to_array()) });
    }
    h.step(0.016, Vec::new());
    h.step(0.016, Vec::new());
    for (hand, target) in hands.iter().zip(&targets) {
        assert!(world(&h, *hand).distance(*target) < 1e-3, "hand {hand} missed its target");
    }
    let summary = h.get(Key::Ik).to_owned();
    assert!(summary.starts_with("arm_joint_L_3:") && summary.contains(";arm_joint_R_3:"), "dataset.ik = {summary:?}");
    assert_eq!(h.get(Key::IkTarget).split(';').count(), 2);
    // Setting the same effector again replaces its goal instead of adding one.
    controls.send(Command::SetIk { effector: Some(hands[1]), depth: 2, target: None });
    h.step(0.016, Vec::new());
    assert_eq!(h.app.model().expect("a model").ik.len(), 2);
    controls.send(Command::RemoveIk(0));
    h.step(0.016, Vec::new());
    assert!(h.get(Key::Ik).starts_with("arm_joint_R_3:"), "dataset.ik = {}", h.get(Key::Ik));
}

/// Two-bone with a pole: the elbow bends towards the pole, and dragging the pole's diamond in
/// the viewport swings the elbow after it while the hand stays on its target.
#[test]
fn a_two_bone_pole_bends_the_elbow_and_is_dragged_in_the_viewport() {
    let mut h = Harness::new();
    load_paused(&mut h, "RiggedFigure.glb", shared_asset("khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb"));
    let controls = h.app.controls().clone();
    let [shoulder, elbow, hand] =
        ["arm_joint_L_1", "arm_joint_L_2", "arm_joint_L_3"].map(|n| controls.node_index(n).expect("a joint"));
    let world = |h: &Harness, n: u32| h.app.model().expect("a model").instance.worlds()[n as usize].w_axis.truncate();
    let set_solver = |solver, pole: Option<glam::Vec3>| Command::SetIkSolver {
        effector: hand,
        solver,
        pole: pole.map(|p| p.to_array()),
        softness: None,
        accelerate: None,
        iterations: None,
    };
    let target = world(&h, hand) + glam::Vec3::new(0.0, 0.04, 0.03);
    controls.send(Command::SetIk { effector: Some(hand), depth: 2, target: Some(target.to_array()) });
    h.step(0.016, Vec::new());
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::IkPole), "", "no pole until one is set");
    // A pole 40° around the shoulder–target line from where the elbow points now.
    let s = world(&h, shoulder);
    let line = (target - s).normalize();
    let off = |p: glam::Vec3| (p - s) - line * (p - s).dot(line);
    let side = glam::Quat::from_axis_angle(line, 40f32.to_radians()) * off(world(&h, elbow)).normalize();
    let pole = s + line * (world(&h, elbow) - s).dot(line) + side * 0.3;
    let facing = |h: &Harness, pole: glam::Vec3| off(world(h, elbow)).normalize().dot(off(pole).normalize());
    assert!(facing(&h, pole) < 0.8, "the elbow already faces the pole");
    controls.send(set_solver(IkSolver::TwoBone, Some(pole)));
    h.step(0.016, Vec::new());
    let before = h.step(0.016, Vec::new());
    assert!(facing(&h, pole) > 0.9, "the elbow does not bend towards the pole: {}", facing(&h, pole));
    assert!(world(&h, hand).distance(target) < 1e-3, "the hand left its target: {}", world(&h, hand).distance(target));
    // Drag the diamond 40 points to the right.
    let from = h.marker(Key::IkPole);
    h.drag(from, egui::vec2(40.0, 0.0));
    let after = h.step(0.016, Vec::new());
    let moved = h.app.model().and_then(|m| m.ik.first()).and_then(|ik| ik.pole).expect("the pole");
    assert!(moved.distance(pole) > 0.02, "the drag did not move the pole ({moved} vs {pole})");
    let target_now = h.app.model().and_then(|m| m.ik.first()).map(|ik| ik.target).expect("ik");
    assert!(target_now.distance(target) < 1e-6, "the drag moved the target instead of the pole");
    assert!(facing(&h, moved) > 0.9, "the elbow did not follow the pole: {}", facing(&h, moved));
    assert!(world(&h, hand).distance(target) < 1e-3, "the hand left its target: {}", world(&h, hand).distance(target));
    assert!(changed_pixels(&before, &after, (280, 40, SIZE[0], SIZE[1] - 40)) > 30, "the arm did not move on screen");
    // A new target for the same chain keeps its pole; the pole is shown for two-bone only.
    controls.send(Command::SetIk {
        effector: Some(hand),
        depth: 2,
        target: Some((target + glam::Vec3::Y * 0.01).to_array()),
    });
    h.step(0.016, Vec::new());
    assert_eq!(h.app.model().and_then(|m| m.ik.first()).and_then(|ik| ik.pole), Some(moved), "the pole was dropped");
    assert_ne!(h.get(Key::IkPole), "");
    controls.send(set_solver(IkSolver::Ccd, Some(moved)));
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::IkPole), "", "CCD has no pole to show");
    // Two-bone needs exactly two joints above the effector.
    controls.send(Command::SetIk { effector: Some(hand), depth: 1, target: None });
    controls.send(set_solver(IkSolver::TwoBone, None));
    h.step(0.016, Vec::new());
    assert!(h.get(Key::Error).contains("two-bone needs 2"), "error: {}", h.get(Key::Error));
}

fn key(key: egui::Key) -> Vec<egui::Event> {
    vec![egui::Event::Key { key, physical_key: None, pressed: true, repeat: false, modifiers: egui::Modifiers::NONE }]
}

#[test]
fn overlays_shortcuts_joint_selection_and_screenshot() {
    let fox = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/Fox.glb")).expect("web/assets/Fox.glb");
    let mut h = Harness::new();
    load_paused(&mut h, "Fox.glb", fox);
    let viewport = (320, 40, SIZE[0], SIZE[1] - 40);
    let plain = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Overlays), "");

    // B: the skeleton over the model.
    h.step_events(0.016, key(egui::Key::B));
    let bones = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Overlays), "skeleton");
    let changed = changed_pixels(&plain, &bones, viewport);
    assert!(changed > 100, "the skeleton changed only {changed} pixels");
    save(&bones, "overlay-skeleton.png");

    // W: the wireframe adds many more lines.
    h.step_events(0.016, key(egui::Key::W));
    let wire = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Overlays), "skeleton,wireframe");
    let more = changed_pixels(&bones, &wire, viewport);
    assert!(more > 500, "the wireframe changed only {more} pixels");
    save(&wire, "overlay-wireframe.png");

    // Space plays and pauses; → steps one frame (1/30 s) and pauses.
    h.step_events(0.016, key(egui::Key::Space));
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Playing), "true");
    h.step_events(0.016, key(egui::Key::Space));
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Playing), "false");
    let t0 = main_time(&h);
    h.step_events(0.016, key(egui::Key::ArrowRight));
    h.step(0.016, Vec::new());
    let t1 = main_time(&h);
    let expected = ((t0 * 30.0).round() + 1.0) / 30.0;
    assert!((t1 - expected).abs() < 1e-4, "→ from {t0} went to {t1}, expected {expected}");
    // ↓ plays the next clip.
    h.step_events(0.016, key(egui::Key::ArrowDown));
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Clip), "Walk");

    // A selected joint draws its axes and names itself.
    let controls = h.app.controls().clone();
    let neck = controls.node_index("b_Neck_04").expect("b_Neck_04");
    controls.send(Command::Pause);
    controls.send(Command::SetOverlays(kloub_web::overlay::Overlays::default()));
    h.step(0.016, Vec::new());
    let unselected = h.step(0.016, Vec::new());
    controls.send(Command::SelectJoint(Some(neck)));
    h.step(0.016, Vec::new());
    let selected = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Joint), "b_Neck_04");
    assert_eq!(h.get(Key::Overlays), "");
    let axes = changed_pixels(&unselected, &selected, viewport);
    assert!(axes > 20, "the joint's axes changed only {axes} pixels");

    // The screenshot is a PNG of the viewport alone, with the fox in it.
    controls.send_global(Command::Screenshot);
    for _ in 0..5 {
        h.step(0.016, Vec::new());
    }
    let png = h.app.last_screenshot().expect("a screenshot after a few frames");
    let shot = image::load_from_memory_with_format(png, image::ImageFormat::Png).expect("a PNG").to_rgba8();
    assert!(shot.width() > 200 && shot.height() > 200, "{}x{}", shot.width(), shot.height());
    let background = *shot.get_pixel(2, 2);
    let model_pixels = shot.pixels().filter(|p| p.0.iter().zip(background.0).any(|(a, b)| a.abs_diff(b) > 40)).count();
    assert!(model_pixels > 1000, "the screenshot shows {model_pixels} non-background pixels");
}

#[test]
fn a_bare_skeleton_is_framed_and_drawn() {
    let gltf = br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
        "nodes":[{"name":"hips","children":[1,2]},{"name":"spine","translation":[0,1,0],"children":[3]},
                 {"name":"leg","translation":[0.3,-1,0]},{"name":"head","translation":[0,0.8,0]}]}"#;
    let mut h = Harness::new();
    let empty = h.step(0.016, Vec::new());
    h.step(0.016, vec![dropped("bones.gltf", gltf.to_vec())]);
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Model), "bones.gltf", "{}", h.get(Key::Error));
    let shown = h.step(0.016, Vec::new());
    save(&shown, "bare-skeleton.png");
    let viewport = (320, 40, SIZE[0], SIZE[1] - 40);
    let drawn = changed_pixels(&empty, &shown, viewport);
    assert!(drawn > 200, "the skeleton changed only {drawn} viewport pixels");
    let model = h.app.model().expect("a model");
    let (lo, hi) = model.bounds.expect("framed on its joints");
    assert!((hi - lo).y > 1.7, "the bounds hold every joint: {lo:?} {hi:?}");
}

#[test]
fn a_held_morph_weight_changes_the_face_until_released() {
    let mut h = Harness::new();
    load_paused(&mut h, "RobotExpressive.glb", shared_asset("threejs/RobotExpressive/RobotExpressive.glb"));
    let controls = h.app.controls().clone();
    let model = h.app.model().expect("a model");
    let (node, _) = model
        .asset
        .nodes
        .iter()
        .enumerate()
        .find(|(_, n)| !n.weights.is_empty())
        .expect("RobotExpressive has a morphing head");
    let node = u32::try_from(node).expect("node index");
    let target = controls.morph_target_index(node, "Surprised").expect("a Surprised target");
    let slot = model.asset.weight_offsets[node as usize] as usize + target;
    let plain = h.step(0.016, Vec::new());
    controls.send(Command::SetMorph { node, target, weight: Some(1.0) });
    h.step(0.016, Vec::new());
    let surprised = h.step(0.016, Vec::new());
    let weight = h.app.model().map(|m| m.instance.pose().weights[slot]);
    assert_eq!(weight, Some(1.0), "the held weight is in the pose");
    save(&surprised, "morph-surprised.png");
    let viewport = (320, 40, SIZE[0], SIZE[1] - 40);
    let changed = changed_pixels(&plain, &surprised, viewport);
    assert!(changed > 50, "holding Surprised at 1 changed only {changed} pixels");
    controls.send(Command::SetMorph { node, target, weight: None });
    h.step(0.016, Vec::new());
    let released = h.step(0.016, Vec::new());
    assert!(changed_pixels(&plain, &released, viewport) < 10, "releasing the weight restores the clip's face");
    assert!(controls.morph_target_index(node, "Bored").is_err());
}

#[test]
fn the_camera_moves_from_the_keyboard() {
    let fox = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/Fox.glb")).expect("web/assets/Fox.glb");
    let mut h = Harness::new();
    load_paused(&mut h, "Fox.glb", fox);
    h.step(0.016, Vec::new());
    let camera =
        |h: &Harness| -> Vec<f32> { h.get(Key::Camera).split(',').map(|v| v.parse().unwrap_or(f32::NAN)).collect() };
    let before = camera(&h);
    let shift = egui::Modifiers { shift: true, ..egui::Modifiers::NONE };
    let event = egui::Event::Key {
        key: egui::Key::ArrowLeft,
        physical_key: None,
        pressed: true,
        repeat: false,
        modifiers: shift,
    };
    h.step_events(0.016, vec![event]);
    h.step(0.016, Vec::new());
    let orbited = camera(&h);
    assert!((orbited[0] - before[0] - 15f32.to_radians()).abs() < 1e-3, "Shift+← turns 15°: {before:?} -> {orbited:?}");
    assert_eq!(h.get(Key::Time), "0.016", "Shift+← does not step the clock");
    h.step_events(0.016, key(egui::Key::Minus));
    h.step(0.016, Vec::new());
    let zoomed = camera(&h);
    assert!((zoomed[2] / orbited[2] - 1.25).abs() < 1e-3, "- backs off 1.25×: {orbited:?} -> {zoomed:?}");
}

#[test]
fn several_models_dropped_together_are_listed_to_switch_between() {
    let fox = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/Fox.glb")).expect("web/assets/Fox.glb");
    let simple = shared_asset("khronos/RiggedSimple/glTF-Binary/RiggedSimple.glb");
    let mut h = Harness::new();
    h.step(0.016, vec![dropped("Fox.glb", fox), dropped("RiggedSimple.glb", simple)]);
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Model), "Fox.glb", "the first model shows: {}", h.get(Key::Error));
    h.app.controls().send_global(Command::ShowModel(1));
    h.step(0.016, Vec::new());
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Model), "RiggedSimple.glb");
    assert_ne!(h.get(Key::Clips), r#"["Survey","Walk","Run"]"#, "the clip list follows the shown model");
    h.app.controls().send_global(Command::ShowModel(0));
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Model), "Fox.glb");
}

#[test]
fn lighting_and_background_presets_change_the_view() {
    use kloub_web::render::uniforms::{Background, Lighting};
    for l in Lighting::ALL {
        assert_eq!(Lighting::from_name(l.name()), Ok(l));
    }
    for b in Background::ALL {
        assert_eq!(Background::from_name(b.name()), Ok(b));
    }
    assert!(Lighting::from_name("disco").is_err() && Background::from_name("plaid").is_err());
    let fox = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/Fox.glb")).expect("web/assets/Fox.glb");
    let mut h = Harness::new();
    load_paused(&mut h, "Fox.glb", fox);
    h.step(0.016, Vec::new());
    let studio = h.step(0.016, Vec::new());
    assert_eq!((h.get(Key::Lighting), h.get(Key::Background)), ("studio", "dark"));
    let controls = h.app.controls().clone();
    controls.send_global(Command::SetLighting(Lighting::Flat));
    h.step(0.016, Vec::new());
    let flat = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Lighting), "flat");
    let viewport = (320, 40, SIZE[0], SIZE[1] - 40);
    assert!(changed_pixels(&studio, &flat, viewport) > 300, "flat lighting looks the same as studio");
    controls.send_global(Command::SetBackground(Background::Light));
    h.step(0.016, Vec::new());
    let light = h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Background), "light");
    // The corner of the view is background: near white now.
    let corner = light.get_pixel(SIZE[0] - 5, 45).0;
    assert!(corner[0] > 180 && corner[1] > 180, "the light background reads {corner:?}");
    save(&light, "look-flat-light.png");
}

#[test]
fn the_ragdoll_falls_settles_and_hands_back_to_the_animation() {
    let mut h = Harness::new();
    load_paused(&mut h, "CesiumMan.glb", shared_asset("khronos/CesiumMan/glTF-Binary/CesiumMan.glb"));
    let controls = h.app.controls().clone();
    controls.send_global(Command::SetOverlays(kloub_web::overlay::Overlays { bodies: true, ..Default::default() }));
    h.step(0.016, Vec::new());
    let standing = h.step(0.016, Vec::new());
    let head = |h: &Harness| -> f32 {
        let m = h.app.model().expect("a model");
        m.instance.worlds().iter().map(|w| w.w_axis.y).fold(f32::NEG_INFINITY, f32::max)
    };
    let top = head(&h);
    controls.send(Command::StartRagdoll);
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Ragdoll), "simulating", "{}", h.get(Key::Error));
    let mut frames = 0;
    while h.get(Key::Ragdoll) == "simulating" && frames < 600 {
        h.step(1.0 / 60.0, Vec::new());
        frames += 1;
    }
    let fallen = h.step(1.0 / 60.0, Vec::new());
    save(&fallen, "ragdoll-fallen.png");
    assert_eq!(h.get(Key::Ragdoll), "resting", "still moving after {frames} frames");
    eprintln!("CesiumMan came to rest after {:.2} s", frames as f32 / 60.0);
    assert!(head(&h) < top * 0.6, "the body fell: highest joint {top} -> {}", head(&h));
    let viewport = (320, 40, SIZE[0], SIZE[1] - 40);
    assert!(changed_pixels(&standing, &fallen, viewport) > 500, "the view did not change");
    controls.send(Command::RagdollToAnimation(0.5));
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Ragdoll), "blending");
    for _ in 0..40 {
        h.step(1.0 / 60.0, Vec::new());
    }
    assert_eq!(h.get(Key::Ragdoll), "", "handed back after 0.5 s");
    assert!((head(&h) - top).abs() < top * 0.05, "back on its feet: {top} vs {}", head(&h));
    // A model without a skin cannot be one.
    let before = h.get(Key::Error).to_owned();
    assert!(before.is_empty());
}

#[test]
fn a_large_drop_shows_parsing_for_a_frame_before_it_is_imported() {
    let fox = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/Fox.glb")).expect("web/assets/Fox.glb");
    let mut h = Harness::new();
    h.step(0.016, Vec::new());
    // 5 MB with the model: past the threshold for the "Parsing…" notice.
    h.step(0.016, vec![dropped("Fox.glb", fox), dropped("padding.bin", vec![0; 5 << 20])]);
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Status), "loading", "held for a frame");
    assert_eq!(h.get(Key::Model), "");
    h.step(0.016, Vec::new());
    assert_eq!(h.get(Key::Model), "Fox.glb", "{}", h.get(Key::Error));
    assert_eq!(h.get(Key::Status), "ready");
}
